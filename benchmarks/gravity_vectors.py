"""gravity_vectors: a 50 g mass on the shell, the robot turned through the paper's sequence.

Paper Sec. III-B, Figs. 8-9: legs down (A), nose up (B), legs up (C), nose down (D), legs down
(E), left side down (F), legs up (G), left side up (H), legs down (I): a full slow turn about
the robot's y axis, then one about x. Turning slowly is simulated by turning gravity in the
chassis frame (the F/T body stays put), 10 s per turn. The shell's reading, calibrated by the
cubic fit of `shell_table1`, divided by 50 g is compared with the accelerometer (gravity in
the chassis frame, as an accelerometer at rest reports it): mean mass |F| / |g|, mean angle
between the vectors, and the shell's |A_z| legs up. The shell's own 9.7 g is tared legs down,
so turning it adds up to twice its weight to the reading (measured: |A_z| 13.6 m/s^2 legs up,
(50 + 2 x 9.7) / 50 x g). The calibration is run twice: on loads in
every direction, and with the paper's bias (mostly downward pushes, `downward_bias` 0.8),
which the paper blames for reading about half when inverted.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from benchmarks import shell_data
from models import shell as model_lib
from sim import shell

DESCRIPTION = "shell vs accelerometer, 50 g on the shell, robot turned through sequence A-I"
PAYLOAD = 0.05
TURN_SECONDS = 10.0
BIASED = 0.8
PAPER = {"mean_mass_g": 50.4, "mean_angle_deg": 18.8, "inverted_az": 5.0}


def gravity_sequence(steps_per_turn: int, g: float = 9.81) -> np.ndarray:
  """(2 * steps_per_turn, 3) gravity in the chassis frame: a turn about y, then about x,
  starting legs down (gravity along -z)."""
  a = np.linspace(0, 2 * np.pi, steps_per_turn, endpoint=False)
  about_y = np.column_stack([g * np.sin(a), np.zeros_like(a), -g * np.cos(a)])
  about_x = np.column_stack([np.zeros_like(a), -g * np.sin(a), -g * np.cos(a)])
  return np.concatenate([about_y, about_x])


def turn(scene: shell.ShellScene, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """Frames at 100 Hz: (counts (F, 8), gravity in the chassis frame (F, 3)), on the board and
  with the effects of `scene` (the calibration's)."""
  loaded = dataclasses.replace(scene, params=dataclasses.replace(scene.params, payload=PAYLOAD))
  model = loaded.spec().compile()
  data = mujoco.MjData(model)
  dt = model.opt.timestep
  grav = gravity_sequence(int(round(TURN_SECONDS / dt)))
  adr = model_lib.mount_qpos_index(model)
  spf = shell.frame_steps(dt)
  for _ in range(1000):  # settle legs down with the mass on
    mujoco.mj_step(model, data)
  poses = []
  for i, g in enumerate(grav):
    model.opt.gravity[:] = g
    mujoco.mj_step(model, data)
    if i % spf == spf - 1:
      poses.append(data.qpos[adr].copy())
  _, counts = shell.sense(scene, np.array(poses), seed)
  return counts, grav[spf - 1::spf]


def compare(force: np.ndarray, gravity: np.ndarray) -> dict:
  """Shell acceleration against the accelerometer's reading (-gravity): the mass presses on
  the shell with its weight, so the shell reads -force / 50 g in the accelerometer's sense."""
  accel = -gravity
  shell_acc = -force / PAYLOAD
  cos = np.sum(shell_acc * accel, axis=1) / (np.linalg.norm(shell_acc, axis=1)
                                              * np.linalg.norm(accel, axis=1))
  # legs up: gravity along +z of the chassis
  up = gravity[:, 2] > 0.95 * np.linalg.norm(gravity, axis=1)
  return {"mean_mass_g": float(np.mean(np.linalg.norm(force, axis=1)
                                       / np.linalg.norm(gravity, axis=1)) * 1e3),
          "mean_angle_deg": float(np.degrees(np.mean(np.arccos(np.clip(cos, -1, 1))))),
          "inverted_az": float(abs(np.mean(shell_acc[up, 2]))),
          "accelerometer_inverted_az": float(abs(np.mean(accel[up, 2])))}


def run(ctx) -> dict:
  out = {}
  base = shell_data.scenes(ctx)["calibration"]
  counts, gravity = turn(base, ctx.seed)
  ctx.print(f"{'calibration loads':26s} {'mean mass g':>12s} {'mean angle deg':>15s} "
            f"{'|A_z| legs up m/s2':>19s}")
  for name, bias in (("every direction", 0.0), (f"mostly down (bias {BIASED})", BIASED)):
    sub = dataclasses.replace(ctx, overrides={**ctx.overrides, "downward_bias": str(bias)})
    est = shell_data.calibrated(sub).estimator
    res = compare(est.predict(counts)[:, :3], gravity)
    out[name] = res
    ctx.print(f"{name:26s} {res['mean_mass_g']:12.1f} {res['mean_angle_deg']:15.1f} "
              f"{res['inverted_az']:19.2f}")
  ctx.print(f"{'paper':26s} {PAPER['mean_mass_g']:12.1f} {PAPER['mean_angle_deg']:15.1f} "
            f"{PAPER['inverted_az']:19.2f}   (accelerometer legs up: 9.81)")
  return {"results": out, "paper": PAPER}
