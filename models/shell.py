"""The VelociRoACH force-sensing shell (Goldberg & Fearing) as a MuJoCo model.

Chassis welded to an F/T body (the paper's ATI Nano43) on the world; the SkinProc PCB with
eight photointerrupters on the chassis; the reflector plate and shell, one rigid body, on four
coil springs. The springs are lumped at their elastic centre (half their height, the centre
of the spring pattern) as six joint springs, 3 slides then 3 hinges, whose rates follow from
coil-spring theory (`mount_stiffness`). Frames: x forward, z up; the chassis frame's origin
is on the PCB's top face between the sensor arrays.

Sensor layout (paper Eqn 3): P1, P5 sit under reflectors sloped along y (slope c_y, signs
+/-), P3, P7 under reflectors sloped along x (c_x, +/-), P2, P4, P6, P8 under flat ones. A
reflector's height above its sensor therefore grows by c_y * dy (P1), -c_y * dy (P5),
c_x * dx (P3), -c_x * dx (P7) when the shell moves by (dx, dy).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from models import lighting

from util import fields
from util.fields import setting


@fields.declared
@dataclasses.dataclass(frozen=True)
class ShellParams:
  """Physical parameters of the shell, its mount and the sensor layout (SI units).

  Attributes:
    slope_x, slope_y: reflector slopes c_x, c_y (rise over run) of P3/P7 and P1/P5. Not
      given in the paper; 0.3 assumed (the map's condition number falls from 143
      at 0.02 to ~6 at 0.5; `shell_geometry` prints it).
    spring_rate: axial rate of each coil spring, N/m (paper Sec. II-A: ~150 N/m).
    spring_height: working height of the springs, m (paper: 1.5 cm).
    spring_diameter: mean coil diameter, m (paper: 1.0 cm, taken as the mean diameter).
    spring_poisson: Poisson's ratio of the spring steel (0.3), which sets E/G = 2(1 + nu).
    spring_xy: (x, y) of the four springs about the elastic centre, m (assumed (+-30, +-20)
      mm: the paper gives no spacing).
    gap: design height of every reflector above its sensor at rest under gravity, m; 3 mm,
      the middle of the photointerrupter's 2-4 mm fitted window (paper Fig. 4).
    damping_ratio: damping ratio of each mount joint about its own inertia (assumed 0.05:
      the paper's step response rings at ~15 Hz for several cycles, Fig. 10).
    shell_mass: polycarbonate shell, kg (paper: 6.7 g).
    reflector_mass: reflector plate, kg (assumed 3 g).
    chassis_mass: robot and electronics under the springs, kg (paper: 30 g robot + 18.7 g
      sensing hardware, less the shell and reflector).
    sensor_x, sensor_y: (8,) sensor positions P1..P8 on the PCB, m. The defaults follow
      Eqn 3's layout with assumed spacings: l15 = 40, l37 = 24, l28 = l46 = 32 mm along x and
      l24 = l68 = 16 mm along y.
    reflector_size: side of each reflector facet, m (assumed 5 mm).
    payload: mass fixed on top of the shell's centre, kg (the paper's experiments: 50 g);
      the preload is for the shell alone, so a payload sags the shell.
    mount_friction: for the `spring_hysteresis` effect, Coulomb friction of the mount's
      slides (N) and hinges (N m); assumed 1 % of the hand loads' range.
    timestep: simulation step, s (the joint springs are explicit: keep it <= 2 ms,
      measured here).
  """
  slope_x: float = setting(0.3, "[-2, 2]")
  slope_y: float = setting(0.3, "[-2, 2]")
  spring_rate: float = setting(150.0, "(0, 1e5]", "N/m")
  spring_height: float = setting(0.015, "[0.002, 0.1]", "m")
  spring_diameter: float = setting(0.010, "[0.001, 0.05]", "m")
  spring_poisson: float = setting(0.3, "[0, 0.5)")
  spring_xy: tuple[tuple[float, float], ...] = setting(
      ((0.03, 0.02), (-0.03, 0.02), (0.03, -0.02), (-0.03, -0.02)), "[-0.1, 0.1]", "m",
      length=(3, 16))
  gap: float = setting(0.003, "[0.002, 0.004]", "m")
  damping_ratio: float = setting(0.05, "[0, 2]")
  shell_mass: float = setting(0.0067, "(0, 1]", "kg")
  reflector_mass: float = setting(0.003, "(0, 1]", "kg")
  chassis_mass: float = setting(0.039, "(0, 1]", "kg")
  sensor_x: tuple[float, ...] = setting(
      (0.020, 0.016, 0.012, 0.016, -0.020, -0.016, -0.012, -0.016), "[-0.1, 0.1]", "m",
      length=(8, 8))
  sensor_y: tuple[float, ...] = setting(
      (0.0, -0.008, 0.0, 0.008, 0.0, 0.008, 0.0, -0.008), "[-0.1, 0.1]", "m", length=(8, 8))
  reflector_size: float = setting(0.005, "(0, 0.05]", "m")
  payload: float = setting(0.0, "[0, 0.2]", "kg")
  mount_friction: tuple[float, float] = setting((0.01, 0.0006), "[0, 1]", "N, N m")
  timestep: float = setting(0.001, "(0, 0.002]", "s")

  def validate(self) -> None:
    """Raise ValueError naming the first parameter outside its allowed range."""
    fields.check(self)

  def sensor_positions(self) -> np.ndarray:
    """(8, 3) sensor apertures in the chassis frame, m (z = 0: the PCB's top face)."""
    return np.column_stack([self.sensor_x, self.sensor_y, np.zeros(8)])

  def slopes(self) -> np.ndarray:
    """(8, 2) surface slopes (d height / dx, d height / dy) of the reflector over each sensor,
    in the shell frame. A facet whose underside descends along +x reads higher as the shell
    moves +x."""
    s = np.zeros((8, 2))
    s[0, 1], s[4, 1] = -self.slope_y, self.slope_y  # P1, P5
    s[2, 0], s[6, 0] = -self.slope_x, self.slope_x  # P3, P7
    return s


def eqn3_matrix(params: ShellParams) -> np.ndarray:
  """(8, 6) the paper's Eqn 3: heights R1..R8 per (x, y, z, theta_x, theta_y, theta_z).

  Written from the layout as the paper writes it, from the spacings l_mn, for comparison
  with the simulated map (`sim.shell.geometry.height_jacobian`).
  """
  x, y = np.asarray(params.sensor_x), np.asarray(params.sensor_y)
  l15, l37 = x[0] - x[4], x[2] - x[6]
  l24, l68 = y[3] - y[1], y[5] - y[7]
  l28, l46 = x[1] - x[7], x[3] - x[5]
  cx, cy = params.slope_x, params.slope_y
  return np.array([
      [0, cy, 1, 0, -l15 / 2, cy * l15 / 2],
      [0, 0, 1, -l24 / 2, -l28 / 2, 0],
      [cx, 0, 1, 0, -l37 / 2, 0],
      [0, 0, 1, l24 / 2, -l46 / 2, 0],
      [0, -cy, 1, 0, l15 / 2, cy * l15 / 2],
      [0, 0, 1, l68 / 2, l46 / 2, 0],
      [-cx, 0, 1, 0, l37 / 2, 0],
      [0, 0, 1, -l68 / 2, l28 / 2, 0],
  ])


def mount_stiffness(params: ShellParams) -> np.ndarray:
  """(6,) stiffness of the four-spring mount at its elastic centre: x, y, z in N/m, then
  rotations about x, y, z in N m/rad.

  Each close-coiled spring is an equivalent column (Haringx): with axial rate k, mean radius
  R, height L and wire E/G = 2(1 + nu), its bending rigidity is B = 2 (1 + nu) R^2 k L /
  (2 + nu), its shear rigidity 2 (1 + nu) k L, and its twist rate (1 + nu) R^2 k. With both
  ends held parallel (shell and chassis), a lateral force deflects it by F L^3 / (12 B) +
  F L / (2 (1 + nu) k L); a tilt about the mid-height (the elastic centre) costs B / L per
  radian and no lateral force. Rotations of the plate add each spring's axial (and lateral,
  for twist) rate times its squared distance.
  """
  k, nu = params.spring_rate, params.spring_poisson
  r, h = params.spring_diameter / 2, params.spring_height
  bending = 2 * (1 + nu) * r**2 * k * h / (2 + nu)
  lateral = 1.0 / (h**3 / (12 * bending) + 1.0 / (2 * (1 + nu) * k))
  twist = (1 + nu) * r**2 * k
  xy = np.asarray(params.spring_xy, dtype=float)
  n = len(xy)
  return np.array([n * lateral, n * lateral, n * k,
                   k * np.sum(xy[:, 1] ** 2) + n * bending / h,
                   k * np.sum(xy[:, 0] ** 2) + n * bending / h,
                   lateral * np.sum(xy**2) + n * twist])


MOUNT_JOINTS = ("x", "y", "z", "rx", "ry", "rz")  # `mount_<name>`: 3 slides, then 3 hinges
FT_SITE = (0.0, 0.0, -0.015)  # the F/T reference point in the chassis frame, m
CHASSIS_HALF = (0.05, 0.025, 0.006)  # chassis box half-sizes, m
CHASSIS_Z = -0.008  # chassis box centre below the PCB's top face, m
# shell half-sizes, m: it overhangs the chassis so that obstacles meet it first
SHELL_HALF = (0.056, 0.031, 0.0005)
SHELL_LIFT = 0.01  # shell centre above the springs' upper ends, m
REFLECTOR_GROUP = 3  # geom group of the facets, the only geoms the sensors' rays see
_PLATE_THICKNESS = 0.001  # reflector plate above the facets, m (assumed)
_FACET_THICKNESS = 0.0015  # facet material above its underside at the sensor, m (assumed)
_SHEET = 2e-5  # thickness of the facet meshes the rays see, m


def spring_top(params: ShellParams) -> float:
  """Height of the springs' upper ends (the reflector plate's top) above the PCB, m."""
  return params.gap + _FACET_THICKNESS + _PLATE_THICKNESS


def shell_top(params: ShellParams) -> float:
  """Height of the shell's outer face above the PCB, m."""
  return spring_top(params) + SHELL_LIFT + SHELL_HALF[2]


def elastic_centre(params: ShellParams) -> np.ndarray:
  """The mount's elastic centre in the chassis frame, m: mid-height of the springs."""
  return np.array([0.0, 0.0, spring_top(params) - params.spring_height / 2])


def facet_mesh(params: ShellParams, i: int):
  """The reflector facet over sensor i as a trimesh sheet, in the chassis frame at rest: a
  square of side reflector_size whose underside is the sloped plane the sensor reads (its
  mass and bulk belong to the reflector plate's geom)."""
  import trimesh
  half = params.reflector_size / 2
  x0, y0 = params.sensor_x[i], params.sensor_y[i]
  sx, sy = params.slopes()[i]
  pts = []
  for dx in (-half, half):
    for dy in (-half, half):
      under = params.gap + sx * dx + sy * dy
      pts.append((x0 + dx, y0 + dy, under))
      # a thin sloped sheet: a sensor looking past the facet's edge sees no side wall
      pts.append((x0 + dx, y0 + dy, under + _SHEET))
  return trimesh.convex.convex_hull(np.array(pts))


def build_spec(params: ShellParams, base: str = "ft", contacts: bool = False,
               hysteresis: bool = False) -> mujoco.MjSpec:
  """The rig: F/T body welded to the world, chassis welded to it, shell on its mount.

  Args:
    params: the shell's parameters.
    base: "ft" welds the chassis to the world through the F/T body (calibration, gravity
      tests); "free" gives the chassis a free joint `chassis_free` and no F/T body (the
      robot on its own: dropped masses, walking).
    contacts: the chassis and shell collide with other bodies (the floor, a dropped mass),
      never with each other; off, nothing collides.
    hysteresis: Coulomb friction `mount_friction` on the mount joints (`spring_hysteresis`).

  Sensors: `ft_force`, `ft_torque` (on site `ft`, the chassis's interaction with the F/T
  body, reported child-to-parent as MuJoCo does); sites `P1`..`P8` on the PCB, z up.
  Mount joints `mount_x`, ..., `mount_rz` at the elastic centre with `mount_stiffness`,
  damping from `damping_ratio` and the joint's own inertia, and a z preload that holds the
  shell at the design gap under gravity.
  """
  params.validate()
  if base not in ("ft", "free"):
    raise ValueError(f"base={base!r} is unknown: allowed 'ft', 'free'")
  collide = dict(contype=1, conaffinity=1) if contacts else dict(contype=0, conaffinity=0)
  spec = mujoco.MjSpec()
  spec.modelname = "shell"
  spec.option.timestep = params.timestep
  spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
  world = spec.worldbody
  if base == "ft":
    ft = world.add_body(name="ft_body")
    ft.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.022, 0.0075, 0],
                pos=[0, 0, -0.0225], mass=0.06, contype=0, conaffinity=0,
                rgba=[0.5, 0.5, 0.5, 1])
    chassis = ft.add_body(name="chassis", pos=[0, 0, 0])
  else:
    chassis = world.add_body(name="chassis", pos=[0, 0, 0])
    chassis.add_freejoint(name="chassis_free")
  chassis.add_site(name="ft", pos=list(FT_SITE))
  chassis.add_geom(name="chassis", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(CHASSIS_HALF),
                   pos=[0, 0, CHASSIS_Z], mass=params.chassis_mass, rgba=[0.2, 0.2, 0.25, 1],
                   **collide)
  for i in range(8):
    chassis.add_site(name=f"P{i + 1}", pos=[params.sensor_x[i], params.sensor_y[i], 0.0],
                     size=[0.0008, 0, 0], rgba=[0.9, 0.2, 0.2, 1])

  centre = elastic_centre(params)
  shell = chassis.add_body(name="shell", pos=centre.tolist())
  stiff = mount_stiffness(params)
  for j, name in enumerate(MOUNT_JOINTS):
    hinge = j >= 3
    joint = shell.add_joint(name=f"mount_{name}", axis=np.eye(3)[j % 3], stiffness=stiff[j],
                            type=mujoco.mjtJoint.mjJNT_HINGE if hinge else
                            mujoco.mjtJoint.mjJNT_SLIDE,
                            frictionloss=params.mount_friction[hinge] if hysteresis else 0.0)
    if hysteresis:
      # MuJoCo's friction rows are soft and creep; stiff rows hold like Coulomb friction
      joint.solref_friction = [2 * params.timestep, 1.0]
      joint.solimp_friction = [0.99, 0.999, 0.001, 0.5, 2.0]
  top = spring_top(params)
  plate_z = top - _PLATE_THICKNESS / 2 - centre[2]
  shell.add_geom(name="reflector_plate", type=mujoco.mjtGeom.mjGEOM_BOX,
                 size=[0.03, 0.015, _PLATE_THICKNESS / 2], pos=[0, 0, plate_z],
                 mass=params.reflector_mass, contype=0, conaffinity=0, group=2,
                 rgba=[0.8, 0.8, 0.8, 1])
  shell.add_geom(name="shell", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(SHELL_HALF),
                 pos=[0, 0, top + SHELL_LIFT - centre[2]], mass=params.shell_mass, group=1,
                 rgba=[0.3, 0.5, 0.9, 0.4], **collide)
  if params.payload > 0:
    shell.add_geom(name="payload", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.01, 0.005, 0],
                   pos=[0, 0, top + 0.016 - centre[2]], mass=params.payload, contype=0,
                   conaffinity=0, group=1, rgba=[0.7, 0.6, 0.2, 1])
  for i in range(8):
    mesh = facet_mesh(params, i)
    spec.add_mesh(name=f"facet{i + 1}",
                  uservert=(np.asarray(mesh.vertices) - centre).ravel().tolist(),
                  userface=np.asarray(mesh.faces).ravel().tolist())
    shell.add_geom(name=f"facet{i + 1}", type=mujoco.mjtGeom.mjGEOM_MESH,
                   meshname=f"facet{i + 1}", contype=0, conaffinity=0,
                   group=REFLECTOR_GROUP, mass=1e-5, rgba=[0.95, 0.95, 0.9, 1])
  if contacts:  # the shell rides on its springs, never on the chassis, which would bypass them
    spec.add_exclude(bodyname1="chassis", bodyname2="shell")
  spec.add_sensor(name="ft_force", type=mujoco.mjtSensor.mjSENS_FORCE,
                  objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft")
  spec.add_sensor(name="ft_torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
                  objtype=mujoco.mjtObj.mjOBJ_SITE, objname="ft")

  # Damping and preload need the compiled inertia: the joint's own diagonal of M, and the
  # weight the z spring carries.
  model = spec.compile()
  data = mujoco.MjData(model)
  mujoco.mj_forward(model, data)
  full = np.zeros((model.nv, model.nv))
  mujoco.mj_fullM(model, data, full)
  weight = -model.opt.gravity[2] * (model.body("shell").subtreemass[0] - params.payload)
  for j, name in enumerate(MOUNT_JOINTS):
    joint = spec.joint(f"mount_{name}")
    dof = model.joint(joint.name).dofadr[0]
    joint.damping = [2 * params.damping_ratio * math.sqrt(stiff[j] * full[dof, dof]), 0, 0]
    if joint.name == "mount_z":
      joint.springref = weight / stiff[2]  # unloaded rest above the design gap
  lighting.light(spec, 0.2)
  return spec


def mount_qpos_index(model: mujoco.MjModel) -> np.ndarray:
  """(6,) qpos addresses of the mount joints: x, y, z slides, then hinges about x, y, z."""
  return np.array([model.joint(f"mount_{n}").qposadr[0] for n in MOUNT_JOINTS])
