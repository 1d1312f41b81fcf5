"""step_response: a 50 g mass dropped from 0.5 cm onto the inverted robot (paper Sec. III-C).

The robot lies on its back: its shell on the floor, the chassis (free, no F/T body) on the
four springs above it. A 50 g mass floats 5 mm over the chassis's underside (gravity
compensated) and is let go at 1 s. The shell's photointerrupters are read at 100 Hz and
calibrated by the cubic fit of `shell_table1` (the robot upright on the F/T body); the
benchmark prints the ringing frequency of the chassis on its springs (from the mount's z
joint at 1 kHz), the spring-mass value sqrt(k / m) / 2 pi for the moving mass, and the step
of the calibrated Fz, beside the paper's ~15 Hz and ~-0.5 N (Fig. 10). Contacts and damping
are the effects this scene needs; `--set` takes `ShellScene` fields as the other shell
benchmarks do (params.damping_ratio=0.1), for the calibration and the drop alike.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from benchmarks import shell_data
from models import shell as model_lib
from sim import shell

DESCRIPTION = "shell step response: 50 g dropped on the inverted robot, ringing Hz and Fz step"
PAYLOAD = 0.05  # kg
DROP = 0.005  # m above the chassis's underside
DROP_AT, END = 1.0, 4.0  # s


def drop(scene: shell.ShellScene, seed: int) -> dict:
  """Simulates the drop on the board and with the effects of `scene` (the calibration's);
  returns 1 kHz mount z, 100 Hz counts and the moving mass."""
  spec = scene.spec(base="free", contacts=True)
  spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.3, 0.3, 0.01],
                          friction=[0.7, 0.005, 1e-4])
  # inverted: chassis frame z points down; the shell's outer face on the floor
  chassis_z = model_lib.shell_top(scene.params)
  # the chassis box's bottom face, now on top
  underside = chassis_z - (model_lib.CHASSIS_Z - model_lib.CHASSIS_HALF[2])
  mass = spec.worldbody.add_body(name="mass", pos=[0, 0, underside + DROP + 0.003],
                                 gravcomp=1.0)
  mass.add_freejoint()
  mass.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.012, 0.003, 0], mass=PAYLOAD,
                rgba=[0.7, 0.6, 0.2, 1])
  model = spec.compile()
  data = mujoco.MjData(model)
  free = model.joint("chassis_free").qposadr[0]
  data.qpos[free:free + 3] = [0, 0, chassis_z]
  data.qpos[free + 3:free + 7] = [0, 1, 0, 0]  # 180 degrees about x
  adr = model_lib.mount_qpos_index(model)
  dt = model.opt.timestep
  steps = int(round(END / dt))
  spf = shell.frame_steps(dt)
  pose = np.empty((steps, 6))
  for i in range(steps):
    if i == int(round(DROP_AT / dt)):
      model.body_gravcomp[model.body("mass").id] = 0.0
    mujoco.mj_step(model, data)
    pose[i] = data.qpos[adr]
  _, counts = shell.sense(scene, pose[spf - 1::spf], seed)
  moving = model.body("chassis").subtreemass[0] - model.body("shell").subtreemass[0] + PAYLOAD
  return {"z": pose[:, 2], "counts": counts, "moving_mass": moving, "dt": dt,
          "frame_dt": spf * dt}


def ringing_hz(z: np.ndarray, dt: float) -> float:
  """Dominant frequency of a trace (mean removed), by the peak of its Hann-windowed spectrum,
  refined by parabolic interpolation."""
  x = (z - z.mean()) * np.hanning(len(z))
  spec = np.abs(np.fft.rfft(x, n=8 * len(x)))
  freq = np.fft.rfftfreq(8 * len(x), dt)
  k = int(np.argmax(spec[1:])) + 1
  a, b, c = spec[k - 1], spec[k], spec[k + 1]
  return float(freq[k] + 0.5 * (a - c) / (a - 2 * b + c) * (freq[1] - freq[0]))


def run(ctx) -> dict:
  fit = shell_data.calibrated(ctx)
  scene, est = fit.board, fit.estimator
  params = scene.params
  sim = drop(scene, ctx.seed)
  dt = sim["dt"]
  after = sim["z"][int(round(DROP_AT / dt)) + 20:int(round((DROP_AT + 1.5) / dt))]
  hz = ringing_hz(after, dt)
  k = model_lib.mount_stiffness(params)[2]
  expected = math.sqrt(k / sim["moving_mass"]) / (2 * math.pi)
  fz = est.predict(sim["counts"])[:, 2]
  t = (np.arange(len(fz)) + 1) * sim["frame_dt"]
  before = fz[(t > DROP_AT - 0.5) & (t < DROP_AT)].mean()
  settled = fz[t > END - 1.0].mean()
  ctx.print(f"ringing {hz:.1f} Hz (paper ~15 Hz); spring-mass sqrt(k/m)/2pi = {expected:.1f} Hz "
            f"for k = {k:.0f} N/m, m = {sim['moving_mass'] * 1e3:.0f} g")
  ctx.print(f"calibrated Fz step {settled - before:+.3f} N (paper ~-0.5 N; the mass weighs "
            f"{PAYLOAD * 9.81:.3f} N)")
  return {"ringing_hz": hz, "spring_mass_hz": expected, "fz_step": float(settled - before),
          "moving_mass": sim["moving_mass"], "paper": {"ringing_hz": 15.0, "fz_step": -0.5}}
