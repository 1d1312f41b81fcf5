"""The robot walking into obstacles with its force-sensing shell (paper Sec. III-D, Fig. 11).

A free chassis on six legs, crank-driven in an alternating tripod (left front, right middle,
left rear against the other three), walks on a floor with the paper's friction; the shell
rides on its springs and meets walls with its overhanging edge. Nothing is scripted beyond
the legs' crank angles: the thrust is what the feet's friction gives (at most mu_s x weight,
the paper's ~0.5 N), the bob and the touchdown jolts that shake the shell come from the legs
rolling over and handing over the body, and the turn after a corner hit from the contacts.

Legs are straight spokes of length `leg_length` on a Buehler clock, as in RHex: each tripod
sweeps its stance arc (-sweep .. +sweep about straight down) in half a stride, then
recirculates over the top in the other half, so one tripod always stands. Spokes stand in
for the VelociRoACH's crank-and-linkage legs, whose geometry the shell paper does not give.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import mujoco
import numpy as np

from models import shell as model_lib

from util import fields
from util.fields import setting
from sim.shell import scene as shell

# hips along x, m (assumed: front and rear legs near the 10 cm body's ends, the wheelbase
# that keeps the front feet down while the shell's edge is pushed, 40 mm up)
_HIP_X = (0.04, 0.0, -0.04)
_LEG_RADIUS = 0.001  # m, foot and spoke radius (assumed)
_GROUND, _FEET = 1 << 1, 1 << 2  # contact bits: feet touch only the floor


@fields.declared
@dataclasses.dataclass(frozen=True)
class Walk:
  """One walking episode: at rest, then walking straight ahead into the walls.

  Attributes:
    board: the shell, its sensors and their effects (a calibration's `ShellScene`).
    wall: "none"; "head_on", a wall square across the path; or "course", the paper's
      Fig. 11: a wall on the left closing in at `approach` that the shell's front-left
      corner meets first, then, `follow` along it, a wall perpendicular to it.
    stride_hz: stride frequency, Hz (paper: 2 Hz).
    weight: the robot's weight, N (paper Sec. III-D: "the 0.7 N robot", from which it
      derives the 0.5 N thrust; its Sec. II gives 30 g of robot and 18.7 g of sensing
      hardware, 0.48 N); the chassis takes what the shell, reflector and legs leave of it.
    friction: foot-floor friction coefficient (paper: mu_s = 0.7 on corkboard).
    leg_length: hip to foot centre, m (assumed 15 mm: the PCB stands 22 mm and the chassis
      8 mm above the floor. At 20 mm the wall's push on the shell's edge, 40 mm up, lifts the
      front legs and the robot rears onto its chassis nose, measured here).
    sweep: half the stance arc, rad (assumed 30 degrees: the body bobs by
      leg_length (1 - cos sweep) = 2 mm and walks 2 leg_length sin sweep per step).
    leg_mass: each leg, kg (assumed 0.5 g).
    crank_inertia: rotor inertia reflected to each hip through its gearbox, kg m^2 (assumed:
      a 1e-8 kg m^2 rotor through a ~30:1 train); it also keeps the stiff crank servo stable
      at the model's 1 ms step.
    rest: time standing still before the legs start, s (the paper's section [I]).
    distance: free path before the first wall, m.
    approach: angle between the path and the course's left wall, rad (assumed 20 degrees:
      a glancing hit, after which the paper's robot turns right and follows the wall on its
      left, Sec. III-D).
    follow: length of the course's left wall from the first hit to the end wall, m.
    duration: s.
    seed: for the sensor chain's noise.
  """
  board: shell.ShellScene = shell.ShellScene()
  wall: Literal["none", "head_on", "course"] = "head_on"
  stride_hz: float = setting(2.0, "[0.1, 10]", "Hz")
  weight: float = setting(0.7, "[0.1, 5]", "N")
  friction: float = setting(0.7, "[0, 2]")
  leg_length: float = setting(0.015, "[0.01, 0.05]", "m")
  sweep: float = setting(math.radians(30), "[0.05, 1.2]", "rad")
  leg_mass: float = setting(0.0005, "[1e-5, 0.01]", "kg")
  crank_inertia: float = setting(1e-5, "[1e-7, 1e-3]", "kg m^2")
  rest: float = setting(0.5, "[0, 10]", "s")
  distance: float = setting(0.1, "[0, 5]", "m")
  approach: float = setting(math.radians(20), "[0.1, 1.2]", "rad")
  follow: float = setting(0.12, "[0.02, 5]", "m")
  duration: float = setting(5.0, "[0.1, 60]", "s")
  seed: int = setting(0, "[0, inf)")

  def relations(self) -> fields.Relations:
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    legs = 6 * self.leg_mass + self.board.params.shell_mass + self.board.params.reflector_mass
    yield (self.weight / 9.81 > legs, "weight",
           f"> {legs * 9.81:.3f} N (legs, shell and reflector: the chassis needs some mass)",
           self.weight)

  def validate(self) -> None:
    """Raise ValueError naming the first setting outside its allowed range."""
    fields.check(self)


@dataclasses.dataclass(frozen=True)
class WalkRun:
  """Frames at 100 Hz.

  Attributes:
    time: (F,) s.
    counts: (F, 8) photointerrupter counts.
    contact: (F, 6) force (N) and torque about the elastic centre (N m) that obstacles apply
      to the shell, in the chassis frame: the truth the shell should read.
    feet: (F, 3) the floor's friction and normal force on all six feet, world frame, N.
    mount: (F, 6) the mount joints (m, rad), from which the shell's counts are read.
    touching: (F,) bit k set while wall k touches the shell (course: 0 the side wall, 1 the
      end wall).
    pose: (F, 4) chassis x, y, z (m) and yaw (rad).
    crank: (F, 2) crank angle of each tripod, rad (the paper's "leg position").
  """
  time: np.ndarray
  counts: np.ndarray
  contact: np.ndarray
  feet: np.ndarray
  mount: np.ndarray
  touching: np.ndarray
  pose: np.ndarray
  crank: np.ndarray


def crank_angle(walk: Walk, t: np.ndarray | float) -> np.ndarray:
  """(..., 2) Buehler-clock crank angle of tripods 0 and 1 at time t (s), rad from straight
  down, growing as the foot moves back: a slow stance sweep over half a stride, a fast
  recirculation over the other. Tripod 1 runs half a stride behind; both stand at rest."""
  phase = np.maximum(np.asarray(t, dtype=float) - walk.rest, 0.0) * walk.stride_hz
  out = []
  for offset in (0.0, 0.5):
    p = phase + offset
    turns, frac = np.floor(p), p - np.floor(p)
    stance = -walk.sweep + 4 * walk.sweep * frac
    swing = walk.sweep + (2 * math.pi - 2 * walk.sweep) * (2 * frac - 1)
    out.append(2 * math.pi * turns + np.where(frac < 0.5, stance, swing))
  return np.stack(out, axis=-1)


def _model(walk: Walk) -> tuple[mujoco.MjModel, np.ndarray]:
  """The robot on its legs and the walls; and (6,) the tripod of each crank actuator."""
  params = walk.board.params
  spec = walk.board.spec(base="free", contacts=True)
  world = spec.worldbody
  world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.01],
                 friction=[walk.friction, 0.005, 1e-4], contype=1 | _GROUND,
                 conaffinity=1 | _GROUND)
  front = np.array(model_lib.SHELL_HALF[:2])  # the shell's front-left corner at rest
  walls = []  # (a point of the face, its unit normal away from the robot)
  if walk.wall == "head_on":
    walls.append((np.array([front[0] + walk.distance, 0.25]), np.array([1.0, 0.0])))
  elif walk.wall == "course":
    a = walk.approach
    hit = front + [walk.distance, 0.0]
    along = np.array([math.cos(a), -math.sin(a)])
    normal = np.array([math.sin(a), math.cos(a)])
    walls.append((hit - 0.05 * along, normal))  # starts just behind the first hit
    walls.append((hit + walk.follow * along, along))
  half = (0.01, 0.3, 0.05)  # m: thickness, length (from the face point on), height
  for k, (point, normal) in enumerate(walls):
    run = np.array([normal[1], -normal[0]])  # along the face, to the robot's right
    centre = point + half[0] * normal + (half[1] - half[0]) * run
    world.add_geom(name=f"wall{k}", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half),
                   pos=[*centre, half[2]], friction=[0.3, 0.005, 1e-4],
                   euler=[0, 0, math.degrees(math.atan2(normal[1], normal[0]))])  # degrees
  chassis = spec.body("chassis")
  tripods = []
  hip_z = model_lib.CHASSIS_Z
  hip_y = model_lib.CHASSIS_HALF[1] + 2 * _LEG_RADIUS
  for side, y in (("left", hip_y), ("right", -hip_y)):
    for i, x in enumerate(_HIP_X):
      tripod = (i + (side == "right")) % 2
      leg = chassis.add_body(name=f"leg_{side}{i}", pos=[x, y, hip_z])
      leg.add_joint(name=f"hip_{side}{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                    armature=walk.crank_inertia)
      leg.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -walk.leg_length],
                   size=[_LEG_RADIUS, 0, 0], mass=walk.leg_mass, contype=_FEET,
                   conaffinity=_GROUND, friction=[walk.friction, 0.005, 1e-4],
                   rgba=[0.2, 0.2, 0.2, 1])
      crank = spec.add_actuator(name=f"crank_{side}{i}", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                target=f"hip_{side}{i}")
      # stiff enough to hold the body's share within ~1 degree, the crank is kinematic
      kp = 50 * walk.weight * walk.leg_length
      crank.set_to_position(kp=kp, kv=2 * math.sqrt(kp * walk.crank_inertia))
      tripods.append(tripod)
  g = -spec.option.gravity[2]
  spec.geom("chassis").mass = (walk.weight / g - 6 * walk.leg_mass - params.shell_mass
                               - params.reflector_mass)
  return shell.compile_checked(spec, "shell walk", params), np.array(tripods)


def simulate(walk: Walk) -> WalkRun:
  """Runs the episode; frames every 10 ms."""
  walk.validate()
  model, tripod = _model(walk)
  data = mujoco.MjData(model)
  dt = model.opt.timestep
  spf = shell.frame_steps(dt)
  shell_geom = model.geom("shell").id
  floor = model.geom("floor").id
  free = model.joint("chassis_free").qposadr[0]
  start = crank_angle(walk, 0.0)
  # stand on tripod 0 at -sweep and tripod 1 at +sweep, feet on the floor
  data.qpos[free + 2] = (walk.leg_length * math.cos(walk.sweep) + _LEG_RADIUS
                         - model_lib.CHASSIS_Z)
  for a in range(model.nu):
    data.qpos[model.jnt_qposadr[model.actuator_trnid[a, 0]]] = start[tripod[a]]
  centre = model_lib.elastic_centre(walk.board.params)
  wall_bit = {g: 1 << int(model.geom(g).name[4:]) for g in range(model.ngeom)
              if model.geom(g).name.startswith("wall")}
  force6 = np.zeros(6)
  angles = [start]

  def drive(i: int) -> None:
    angles[0] = crank_angle(walk, (i + 1) * dt)
    data.ctrl[:] = angles[0][tripod]

  def read() -> tuple:
    total, foot, touch = np.zeros(6), np.zeros(3), 0
    rot = data.body("chassis").xmat.reshape(3, 3)
    ec = data.body("chassis").xpos + rot @ centre
    for c in range(data.ncon):
      con = data.contact[c]
      mujoco.mj_contactForce(model, data, c, force6)
      # the contact force acts on geom2 along +normal; on geom1 the opposite
      f_world = con.frame.reshape(3, 3).T @ force6[:3]
      if shell_geom in (con.geom1, con.geom2):
        f_on_shell = f_world if con.geom2 == shell_geom else -f_world
        total[:3] += rot.T @ f_on_shell
        total[3:] += rot.T @ np.cross(con.pos - ec, f_on_shell)
        touch |= wall_bit.get(con.geom1, 0) | wall_bit.get(con.geom2, 0)
      elif floor in (con.geom1, con.geom2) and model.geom_contype[
          con.geom2 if con.geom1 == floor else con.geom1] == _FEET:
        foot += f_world if con.geom1 == floor else -f_world
    q = data.qpos[free + 3:free + 7]
    yaw = math.atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] ** 2 + q[3] ** 2))
    return total, foot, touch, [*data.qpos[free:free + 3], yaw], angles[0]

  pose, frames = shell.run_frames("shell walk", model, data, int(round(walk.duration / dt)), spf,
                                  drive, read)
  contact, feet, touching, base, cranks = (np.array(x) for x in zip(*frames))
  _, counts = shell.sense(walk.board, pose, walk.seed)
  return WalkRun(time=(np.arange(len(pose)) + 1) * spf * dt, counts=counts, contact=contact,
                 feet=feet, mount=pose, touching=touching, pose=base, crank=cranks)
