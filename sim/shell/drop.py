"""The drop scene: a 50 g mass dropped from 0.5 cm onto the inverted robot (shell paper
Sec. III-C, Fig. 10).

The robot lies on its back: its shell on the floor, the chassis (free, no F/T body) on the
four springs above it. The mass floats `DROP` over the chassis's underside (gravity
compensated) and is let go at `DROP_AT`. Contacts and damping are the model effects this
scene needs; the board (sensors, effects) is the calibration's.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from models import shell as model_lib
from sim.shell import scene as shell

PAYLOAD = 0.05  # kg, the paper's mass
DROP = 0.005  # m above the chassis's underside (paper: 0.5 cm)
DROP_AT, END = 1.0, 4.0  # s


@dataclasses.dataclass(frozen=True)
class DropRun:
  """The drop's traces.

  Attributes:
    z: (steps,) the mount's z joint at every physics step, m.
    counts: (F, 8) photointerrupter counts at 100 Hz frames.
    moving_mass: the mass ringing on the springs (chassis, its payload), kg.
    dt: physics step, s.  frame_dt: frame period, s.
  """
  z: np.ndarray
  counts: np.ndarray
  moving_mass: float
  dt: float
  frame_dt: float


def simulate(board: shell.ShellScene, seed: int) -> DropRun:
  """Drops the mass on the robot whose board (sensors, effects, params) is `board`."""
  spec = board.spec(base="free", contacts=True)
  spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.3, 0.3, 0.01],
                          friction=[0.7, 0.005, 1e-4])
  # inverted: chassis frame z points down; the shell's outer face on the floor
  chassis_z = model_lib.shell_top(board.params)
  # the chassis box's bottom face, now on top
  underside = chassis_z - (model_lib.CHASSIS_Z - model_lib.CHASSIS_HALF[2])
  mass = spec.worldbody.add_body(name="mass", pos=[0, 0, underside + DROP + 0.003],
                                 gravcomp=1.0)
  mass.add_freejoint()
  mass.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.012, 0.003, 0], mass=PAYLOAD,
                rgba=[0.7, 0.6, 0.2, 1])
  model = shell.compile_checked(spec, "shell drop", board.params)
  data = mujoco.MjData(model)
  free = model.joint("chassis_free").qposadr[0]
  data.qpos[free:free + 3] = [0, 0, chassis_z]
  data.qpos[free + 3:free + 7] = [0, 1, 0, 0]  # 180 degrees about x
  dt = model.opt.timestep
  spf = shell.frame_steps(dt)
  release = int(round(DROP_AT / dt))

  def let_go(i: int) -> None:
    if i == release:
      model.body_gravcomp[model.body("mass").id] = 0.0

  pose, _ = shell.run_frames("shell drop", model, data, int(round(END / dt)), 1, let_go)
  _, counts = shell.sense(board, pose[spf - 1::spf], seed)
  moving = model.body("chassis").subtreemass[0] - model.body("shell").subtreemass[0] + PAYLOAD
  return DropRun(pose[:, 2], counts, float(moving), dt, spf * dt)
