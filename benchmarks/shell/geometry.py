"""shell_geometry: the shell's linearised height map from the simulation against Eqn 3.

The simulated map is d(ray heights)/d(mount joints) of the MuJoCo model, moved from the
mount's elastic centre to the centre of the reflector plane, the point about which the
paper's Eqn 3 writes its small-angle rotations. It prints both maps' difference, rank and
condition number (rotations scaled by 25 mm), the same over a sweep of reflector slopes
with the directions lost at rank < 6, and the frames/s of the closed-form height path.
`--set slope_x=0.1` (any `ShellParams` field) changes the design.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from benchmarks.registry import register

SWEEP = ((0.0, 0.0), (0.0, 0.3), (0.3, 0.0), (0.02, 0.02), (0.1, 0.1), (0.3, 0.3), (0.5, 0.5),
         (0.7, 0.7), (1.0, 1.0))


def params_settings(quick: bool, seed: int):
  """The shell's `ShellParams`, the root of this benchmark's --set keys."""
  from models.shell import ShellParams
  return ShellParams()


@register("shell_geometry", "shell height map (rays) vs the paper's Eqn 3: rank, condition, "
          "slope sweep, speed", settings=params_settings, tags=("shell", "design", "fast"))
def run(ctx):
  from models import shell
  from sim.shell import geometry as geo
  params = ctx.settings
  sim_map = geo.ray_jacobian(params)
  paper = shell.eqn3_matrix(params)
  diff = float(np.max(np.abs(sim_map - paper)) / np.max(np.abs(paper)))
  q_sim, q_paper = geo.map_quality(sim_map), geo.map_quality(paper)
  with np.printoptions(precision=4, suppress=True):
    ctx.print(f"slopes c_x = {params.slope_x}, c_y = {params.slope_y}; height map, rays "
              f"(columns x, y, z, theta_x, theta_y, theta_z; m/m and m/rad):\n{sim_map}")
  ctx.print(f"largest difference from Eqn 3: {diff:.2e} of its largest entry")
  ctx.print(f"rank {q_sim.rank} (Eqn 3: {q_paper.rank}), condition {q_sim.condition:.1f} "
            f"(Eqn 3: {q_paper.condition:.1f})")
  ctx.print(f"\n{'c_x':>5s} {'c_y':>5s} {'rank':>5s} {'condition':>10s}  lost directions")
  sweep = []
  for cx, cy in SWEEP:
    q = geo.map_quality(geo.ray_jacobian(dataclasses.replace(params, slope_x=cx, slope_y=cy)))
    ctx.print(f"{cx:5.2f} {cy:5.2f} {q.rank:5d} {q.condition:10.1f}  {'; '.join(q.lost)}")
    sweep.append({"slope_x": cx, "slope_y": cy, "rank": q.rank, "condition": q.condition,
                  "lost": list(q.lost)})

  frames = 200_000 if not ctx.quick else 20_000
  rng = np.random.default_rng(ctx.seed)
  poses = np.concatenate([rng.uniform(-5e-4, 5e-4, (frames, 3)),
                          rng.uniform(-0.02, 0.02, (frames, 3))], axis=1)
  geo.pose_heights(params, poses[:100])
  t = time.perf_counter()
  geo.pose_heights(params, poses)
  rate = frames / (time.perf_counter() - t)
  ctx.print(f"\nclosed-form heights: {rate:,.0f} frames/s ({frames} random poses; this project's "
            f"target for design sweeps: >= 2 M)")
  from benchmarks import outputs
  data = {"slopes": {"slope_x": params.slope_x, "slope_y": params.slope_y},
          "map": sim_map.tolist(), "eqn3": paper.tolist(), "max_rel_difference": diff,
          "rank": q_sim.rank, "condition": q_sim.condition, "sweep": sweep,
          "closed_form_frames_per_s": rate}
  # the maps' entries: a sensor's height per unit motion along one pose axis; the map's
  # source (MuJoCo's rays, the paper's closed form) as the method
  rows = outputs.scored("height map", {
      source: {ax: {f"sensor {i + 1}": m[i][j] for i in range(len(m))}
               for j, ax in enumerate(POSE_AXES)}
      for source, m in (("rays", sim_map), ("Eqn 3", paper))})
  return outputs.Result(data, tuple(rows + outputs.plain(data, skip=(("map",), ("eqn3",)))))


POSE_AXES = ("x", "y", "z", "theta_x", "theta_y", "theta_z")
