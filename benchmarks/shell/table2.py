"""shell_table2: the shell paper's Table II, range and resolution of each axis.

The cubic calibration of `shell_table1` is applied to a run at rest (10 s, no load): the
resolution is the standard deviation of each calibrated axis there, as the paper reads it
("the standard deviation of F_x is 5.4 mN"); the range is that of the test loads. Printed
beside the paper's SkinProc row and its ATI Nano43 reference row.

The paper's resolutions are also turned into a count-noise budget: through this calibration,
linearised at rest, the white noise per sensor (counts rms, independent between sensors)
and the common offset shared by all eight that would each alone give the paper's standard
deviation on each axis. The paper's own bench figure is 1 count (Sec. II-B: "a standard
deviation of only 1 bit" for a static reflector); what the robot adds above it shows there.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from benchmarks import shell
from benchmarks.registry import register

from sim.shell import paper  # noqa: E402

AXES, PAPER_TABLE2 = shell.AXES, paper.TABLE2
NANO43 = {"force": (18.0, 0.0039), "torque": (0.25, 0.00005)}
REST_FRAMES = 1000
FULL_SCALE = 4095  # counts: the SkinProc's 12-bit ADC


def count_noise_equivalent(est, counts: np.ndarray, resolution: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
  """(6,) independent and (6,) common count noise (counts rms) that gives `resolution` (6,)
  through the estimator linearised at `counts` (8,), by central differences of 1 count."""
  step = np.eye(8)
  jac = np.stack([(est.predict((counts + step[k])[None]) - est.predict((counts - step[k])[None]))
                  [0] / 2 for k in range(8)], axis=1)  # (6, 8) per count
  return (resolution / np.linalg.norm(jac, axis=1), resolution / np.abs(jac.sum(axis=1)))


def at_rest(ctx, fit) -> tuple:
  """(the run at rest of the calibration `fit`'s test scene, 10 s with no load; the standard
  deviation of each calibrated axis there, Table II's resolution (6,))."""
  from sim.shell import scene as scene_lib
  rest_seed = int(np.random.SeedSequence(ctx.seed).generate_state(3)[2])
  rest, _ = scene_lib.generate(dataclasses.replace(fit.scenes["test"], loading="rest",
                                                   frames=REST_FRAMES, seed=rest_seed),
                               use_cache=ctx.use_cache)
  ctx.used(rest)
  return rest, np.std(fit.estimator.predict(rest.counts), axis=0)


@register("shell_table2", "shell paper Table II: range and resolution (std at rest) per axis",
          settings=shell.protocol_settings, presets=shell.presets, fixed=shell.FIXED,
          tags=("shell", "paper", "calibration", "fast"))
def run(ctx) -> dict:
  fit = shell.calibrated(ctx)
  runs, est = fit.runs, fit.estimator
  scene = fit.scenes["test"]
  rest, resolution = at_rest(ctx, fit)
  span = np.ptp(runs["test"].wrench, axis=0)
  unit = shell.PRINT_UNITS
  ctx.print(f"{'axis':5s} {'range':>16s} {'resolution':>18s}   (N or mN m; [paper], Nano43)")
  for i, a in enumerate(AXES):
    nano = NANO43["force" if i < 3 else "torque"]
    ctx.print(f"{a:5s} {span[i] * unit[i]:7.3g} [{PAPER_TABLE2[a][0] * unit[i]:5.3g}] "
              f"{resolution[i] * unit[i]:9.3g} [{PAPER_TABLE2[a][1] * unit[i]:6.3g}]   "
              f"Nano43 {nano[0] * unit[i]:g}/{nano[1] * unit[i]:g}")
  paper_res = np.array([PAPER_TABLE2[a][1] for a in AXES])
  white, common = count_noise_equivalent(est, rest.counts.mean(axis=0), paper_res)
  ctx.print("the paper's resolution as count noise through this calibration, counts rms "
            "(bench: 1):")
  def cell(v: float) -> str:  # beyond the 12-bit range no such noise exists
    return f"{v:5.1f}" if v <= FULL_SCALE else f">{FULL_SCALE}"
  ctx.print("  white, per sensor  " + "  ".join(f"{a} {cell(v)}" for a, v in zip(AXES, white)))
  ctx.print("  common to all 8    " + "  ".join(f"{a} {cell(v)}" for a, v in zip(AXES, common)))
  if (np.concatenate([white, common]) > FULL_SCALE).any():
    ctx.print(f"  (>{FULL_SCALE}: more than the 12-bit range, so no such noise explains the "
              f"paper's figure: the calibration cancels noise common to the sensors there)")
  data = {"results": {a: {"range": float(span[i]), "resolution": float(resolution[i]),
                          "paper_white_counts": float(white[i]),
                          "paper_common_counts": float(common[i])}
                      for i, a in enumerate(AXES)},
          "paper": {a: {"range": v[0], "resolution": v[1]} for a, v in PAPER_TABLE2.items()},
          "nano43": NANO43, "rest_frames": REST_FRAMES, "effects": list(scene.effects)}
  from benchmarks import outputs
  # resolution through the cubic calibration (paper Eqns 4-9), here and in the paper; the
  # test loads' range per axis belongs to no method
  rows = outputs.scored("results", {"POLY": {a: {k: v for k, v in r.items() if k != "range"}
                                             for a, r in data["results"].items()}})
  rows += outputs.scored("paper", {"POLY": {a: {"resolution": r["resolution"]}
                                            for a, r in data["paper"].items()}})
  rows += [outputs.Row(g, "", a, "range", r["range"]) for g in ("results", "paper")
           for a, r in data[g].items()]
  return outputs.Result(data, tuple(rows + outputs.plain(data, skip=(("results",),
                                                                     ("paper",)))))
