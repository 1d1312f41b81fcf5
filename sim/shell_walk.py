"""The robot walking into obstacles with its force-sensing shell (paper Sec. III-D, Fig. 11).

The chassis moves in the plane (slides x, y, a yaw hinge) pushed by a force-limited thrust
along its heading against the legs' ground drag, and bobs vertically at the stride frequency
on a stiff servo; the shell rides on its springs and meets walls with its overhanging edge.
The paper's numbers set the scene: a 2 Hz stride, and a thrust of at most mu_s x weight =
0.7 x 0.7 N ~ 0.49 N on corkboard. Walking speed and bob amplitude are assumed.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from models import shell as model_lib
from sim import shell

WALLS = ("none", "head_on", "corner")


@dataclasses.dataclass(frozen=True)
class Walk:
  """One walking episode.

  Attributes:
    board: the shell, its sensors and their effects (a calibration's `ShellScene`).
    wall: "none", "head_on" (a wall square across the path) or "corner" (a wall turned
      45 degrees so the shell's front-left corner meets it first).
    stride_hz: stride frequency, Hz (paper: 2 Hz).
    bob: vertical amplitude of the chassis at the stride frequency, m (assumed 1 mm).
    thrust: largest propulsive force, N (paper: mu_s 0.7 x 0.7 N ~ 0.49 N).
    speed: free walking speed, m/s (assumed 0.15); sets the legs' ground drag thrust/speed.
    distance: free path before the wall, m.
    duration: s.
    seed: for the sensor chain's noise.
  """
  board: shell.ShellScene = shell.ShellScene()
  wall: str = "head_on"
  stride_hz: float = 2.0
  bob: float = 0.001
  thrust: float = 0.49
  speed: float = 0.15
  distance: float = 0.3
  duration: float = 5.0
  seed: int = 0

  def validate(self) -> None:
    self.board.params.validate()
    if self.wall not in WALLS:
      raise ValueError(f"wall={self.wall!r} is unknown: allowed {', '.join(WALLS)}")
    for name, lo, hi in (("stride_hz", 0.1, 20), ("bob", 0, 0.005), ("thrust", 0, 5),
                         ("speed", 0.01, 2), ("distance", 0, 5), ("duration", 0.1, 60)):
      v = getattr(self, name)
      if not lo <= v <= hi:
        raise ValueError(f"{name}={v!r} is out of range: allowed [{lo}, {hi}]")


@dataclasses.dataclass(frozen=True)
class WalkRun:
  """Frames at 100 Hz.

  Attributes:
    time: (F,) s.
    counts: (F, 8) photointerrupter counts.
    contact: (F, 6) force (N) and torque about the elastic centre (N m) that obstacles apply
      to the shell, in the chassis frame: the truth the shell should read.
    pose: (F, 4) chassis x, y (m), z (m) and yaw (rad).
  """
  time: np.ndarray
  counts: np.ndarray
  contact: np.ndarray
  pose: np.ndarray


def _model(walk: Walk) -> mujoco.MjModel:
  params = walk.board.params
  spec = walk.board.spec(base="planar", contacts=True)
  world = spec.worldbody
  if walk.wall != "none":
    # the wall's face sits `distance` ahead of the shell's front edge
    front = model_lib.SHELL_HALF[0]
    yaw = 0.0 if walk.wall == "head_on" else math.radians(45)  # its left end comes first
    face = front + walk.distance
    centre = np.array([face + 0.01 * math.cos(yaw), 0.01 * math.sin(yaw), 0.02])
    world.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.01, 0.3, 0.05],
                   pos=centre.tolist(), euler=[0, 0, math.degrees(yaw)],  # MjSpec: degrees
                   friction=[0.3, 0.005, 1e-4])
  drag = walk.thrust / walk.speed
  for j in spec.joints:
    if j.name in ("chassis_x", "chassis_y"):
      j.damping = [drag, 0, 0]
    elif j.name == "chassis_yaw":
      j.damping = [drag * 0.03**2, 0, 0]  # legs resist turning about a 3 cm footprint
  chassis = spec.body("chassis")
  chassis.add_site(name="thrust", pos=[0, 0, -0.008])
  act = spec.add_actuator(name="thrust", trntype=mujoco.mjtTrn.mjTRN_SITE, target="thrust",
                          gear=[1, 0, 0, 0, 0, 0])
  act.ctrlrange = [0, walk.thrust]
  act.ctrllimited = 1
  mass = params.chassis_mass + params.shell_mass + params.reflector_mass
  kp = mass * (2 * math.pi * 10 * walk.stride_hz) ** 2  # a servo 10x faster than the stride
  bob = spec.add_actuator(name="bob", trntype=mujoco.mjtTrn.mjTRN_JOINT, target="chassis_z")
  bob.set_to_position(kp=kp, kv=2 * math.sqrt(kp * mass))
  return spec.compile()


def simulate(walk: Walk) -> WalkRun:
  """Runs the episode; frames every 10 ms."""
  walk.validate()
  model = _model(walk)
  data = mujoco.MjData(model)
  dt = model.opt.timestep
  spf = shell.frame_steps(dt)
  adr = model_lib.mount_qpos_index(model)
  shell_geom = model.geom("shell").id
  chassis_q = [model.joint(f"chassis_{n}").qposadr[0] for n in ("x", "y", "z", "yaw")]
  centre = model_lib.elastic_centre(walk.board.params)
  weight = -model.opt.gravity[2] * float(np.sum(model.body_mass))
  steps = int(round(walk.duration / dt))
  poses, contact, base = [], [], []
  force6 = np.zeros(6)
  for i in range(steps):
    t = i * dt
    data.ctrl[0] = walk.thrust
    # the servo holds the weight and bobs at the stride frequency
    data.ctrl[1] = (walk.bob * math.sin(2 * math.pi * walk.stride_hz * t)
                    + weight / model.actuator_gainprm[1, 0])
    mujoco.mj_step(model, data)
    if i % spf != spf - 1:
      continue
    total = np.zeros(6)
    rot = data.body("chassis").xmat.reshape(3, 3)
    ec = data.body("chassis").xpos + rot @ centre
    for c in range(data.ncon):
      con = data.contact[c]
      if shell_geom not in (con.geom1, con.geom2):
        continue
      mujoco.mj_contactForce(model, data, c, force6)
      frame = con.frame.reshape(3, 3)
      f_world = frame.T @ force6[:3]
      # the contact force acts on geom2 along +normal; on geom1 the opposite
      f_on_shell = f_world if con.geom2 == shell_geom else -f_world
      total[:3] += rot.T @ f_on_shell
      total[3:] += rot.T @ np.cross(con.pos - ec, f_on_shell)
    poses.append(data.qpos[adr].copy())
    contact.append(total)
    base.append(data.qpos[chassis_q].copy())
  pose = np.array(poses)
  _, counts = shell.sense(walk.board, pose, walk.seed)
  return WalkRun(time=(np.arange(len(pose)) + 1) * spf * dt, counts=counts,
                 contact=np.array(contact), pose=np.array(base))
