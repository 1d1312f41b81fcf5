"""MJCF builder for the MIT Cheetah footpad test rig (Chuah & Kim, LSANN paper, Sec. III-A).

The rig: a force/torque plate welded to the world, a 3-axis CNC positioner (three slide joints
with stiff position servos, not mocap: friction needs real velocities), and the footpad carried
by the CNC. The polyurethane layer is a grid of "bristle" elements: each element is a small body
on three slide joints whose springs carry the rubber's local stiffness, ending in a sphere that
makes stiff frictional contact with the plate. MuJoCo then resolves stick, partial slip and full
slip element by element. Stresses inside the rubber are computed after the physics from the
element forces (see `sim.footpad.layer`).

Frames (SI units throughout): the plate's top face is the plane z = 0 and carries the F/T site.
The carriage origin is the centre of the pad's contact face; CNC joint positions are the
carriage displacement, with z = 0 the first touch of a flat pad, negative z pressing down.
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
import threading
from typing import Literal

import mujoco
import numpy as np

from models import lighting

from util import errors, fields, native
from util.fields import Sourced, setting

# Element joints are ordered x, y, z per element, elements row-major in (ix, iy).
AXES = ("x", "y", "z")


@fields.declared
@dataclasses.dataclass(frozen=True)
class FootpadParams:
  """Physical parameters of the footpad and its rig.

  Attributes:
    grid: number of bristle elements along (X, Y). 6x8 keeps elements near square on the
      32x39 mm board and runs at ~5-7k steps/s (measured here).
    footprint: pad size along (X, Y), m. The paper's PCB is 32 mm x 39 mm (Sec. II-A).
    thickness: rubber thickness between PCB and contact face, m. Not given in the paper; 13 mm
      is where the finite-element block (bonded to the PCB, face stuck to the plate, the same
      model that gives the die kernel) presses with the paper's ~221 N at the deepest 1.5 mm
      training indentation (Sec. III-B; measured here): 144 kN/m, 2.06 x E*A/h because a bonded
      near-incompressible layer cannot bulge freely. A 6 mm block, the earlier assumption
      from E*A/h alone, is 4.5 x E*A/h in that model (~1020 N at 1.5 mm).
    youngs_modulus: Vytaflex 20 (Shore 20A), Pa; 0.73 MPa from Gent's relation.
    poisson_ratio: polyurethane rubber is nearly incompressible; 0.49.
    friction: Coulomb coefficient pad/plate of the `friction` effect, one for every element
      (assumed 0.9, soft polyurethane on metal); `pressure_friction` replaces it with
      Thirion's law per element (friction_mu0, friction_shear_strength).
    crown_radius: radius of a spherical crown of the contact face, m; inf for a flat pad.
    density: rubber density, kg/m^3 (Vytaflex 20: specific gravity ~1.0, Smooth-On data);
      sets the lumped mass of each element's rubber column.
    damping_ratio: damping ratio of each element's springs about its own lumped mass.
      Assumed 0.3, of the order of the loss factor of soft polyurethane at low frequency.
    die_x: X positions of the two die columns, m (assumed +-6.5 mm).
    die_y: Y positions of the three die rows, m (assumed -11/0/+11 mm).
    die_depth: depth of the dies below the contact face, m: 1 mm above the PCB, the exposed
      silicon of the machined-down MPXH6400A (assumed).
    tip_radius: radius of the contact sphere ending each element, m.
    timestep: simulation step, s; one step per 1 kHz sample (paper Sec. III-A).
    cnc_kp: CNC servo stiffness, N/m. 2e7 deflects the axis ~11 um at a ~220 N peak.
    cnc_mass: moving mass of each CNC axis (as joint armature), kg.
    prony: for the `viscoelastic` effect, the rubber's two-term Prony series (g1, tau1, g2,
      tau2): after a step strain its stress is E0 (1 - g1 - g2 + g1 exp(-t/tau1) + g2
      exp(-t/tau2)), E0 the instantaneous modulus the finite-element rates stand for (Shore A
      is read within 1 s, ASTM D2240). No Prony data is published for Vytaflex 20; soft cast
      polyurethanes: a fast term g1 0.05-0.2 at tau1 0.1-2 s, a slow one g2 0.03-0.15 at
      tau2 10-100 s, relaxed/instantaneous 0.65-0.92 (low confidence; Vytaflex 40 needed
      9-16 s to recover, Hou, Zhou & Spiers, T-RO 2024). Defaults: the ranges' middles
      (tau2 geometric), relaxed/instantaneous 0.79.
    friction_mu0, friction_shear_strength: for the `pressure_friction` effect, Thirion's law
      of rubber on a hard surface, tau = mu0 p / (1 + mu0 p / tau_s): the coefficient tau/p
      is mu0 at low contact pressure and falls as the pressure nears tau_s / mu0
      (Schallamach 1952; pressure-dependent kinetic friction, Braun & Persson 2016). mu0
      1.2-2.5 for soft polyurethane on metal (medium confidence on the form, low on the
      numbers; default the middle, 1.85); tau_s has no direct source: 0.15-0.5 MPa (default
      0.3 MPa) gives mu 1.0-1.7 at 0.1 MPa.
    static_friction_ratio: for the `stick_slip` effect, static over kinetic friction of the
      pad's rubber on the plate: a stuck element holds up to this times its (kinetic)
      coefficient before it breaks away. Elastomers on hard surfaces hold more than they
      slide with (static friction from the contact's bond population growing while stuck,
      Kaiser, Savio & Bactavatchalou, Lubricants 12:250, 2024); for soft polyurethane on
      metal 1.0-1.3 (low confidence, no measurement for Vytaflex 20); default the middle,
      1.15.
    stiffness_profile: "bonded_plate" takes each element's spring rates from the finite-element
      block under a rigid plate stuck to its face, moved along x, y and z in turn (its nodal
      reactions split by tributary area, `sim.footpad.layer.plate_stiffness`): stiffer in the middle
      than at the free edges (normal x 0.87 at the corners to x 1.26 in the centre of the
      mean at 13 mm), with totals of 2.06 x E*A/h normal and 0.92 x G*A/h tangential.
      "uniform" gives every element a free rubber column's rates, E*A/h and G*A/h
      (`element_stiffness`).
  """

  grid: tuple[int, int] = setting((6, 8), "[2, 20]", "elements")
  footprint: tuple[float, float] = setting((0.032, 0.039), "[0.005, 0.2]", "m")
  thickness: float = setting(0.013, "[0.001, 0.05]", "m")
  youngs_modulus: float = setting(0.73e6, "[1e4, 1e8]", "Pa")
  poisson_ratio: float = setting(0.49, "[0, 0.495]")
  friction: float = setting(0.9, "(0, 5]")
  crown_radius: float = setting(math.inf, "(0, inf]", "m")
  density: float = setting(1000.0, "[100, 5000]", "kg/m^3")
  damping_ratio: float = setting(0.3, "[0, 2]")
  die_x: tuple[float, ...] = setting((-0.0065, 0.0065), "[-0.1, 0.1]", "m", length=(1, 10))
  die_y: tuple[float, ...] = setting((-0.011, 0.0, 0.011), "[-0.1, 0.1]", "m", length=(1, 10))
  die_depth: float = setting(0.012, "(0, 0.05)", "m")
  tip_radius: float = setting(0.0005, "[0.0001, 0.005]", "m")
  timestep: float = setting(0.001, "[1e-4, 2e-3]", "s")
  cnc_kp: float = setting(2e7, "[1e4, 1e9]", "N/m")
  cnc_mass: float = setting(1.0, "[0.01, 100]", "kg")
  prony: tuple[float, float, float, float] = setting(
      (0.12, 1.0, 0.09, 30.0), "[0.01, 1000]", length=(4, 4),
      sourced=(Sourced(0.05, 0.2, part="g1"), Sourced(0.1, 2.0, log=True, part="tau1"),
               Sourced(0.03, 0.15, part="g2"), Sourced(10.0, 100.0, log=True, part="tau2")))
  friction_mu0: float = setting(1.85, "[1.2, 2.5]", sourced=Sourced(1.2, 2.5))
  friction_shear_strength: float = setting(0.3e6, "[0.15e6, 0.5e6]", "Pa",
                                           sourced=Sourced(0.15e6, 0.5e6))
  static_friction_ratio: float = setting(1.15, "[1.0, 2.0]", sourced=Sourced(1.0, 1.3))
  stiffness_profile: Literal["bonded_plate", "uniform"] = "bonded_plate"

  @property
  def shear_modulus(self) -> float:
    return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

  @property
  def num_elements(self) -> int:
    return self.grid[0] * self.grid[1]

  @property
  def element_size(self) -> tuple[float, float]:
    return (self.footprint[0] / self.grid[0], self.footprint[1] / self.grid[1])

  def element_centres(self) -> np.ndarray:
    """(num_elements, 2) element centres in the pad plane, m, row-major in (ix, iy)."""
    dx, dy = self.element_size
    xs = (np.arange(self.grid[0]) + 0.5) * dx - self.footprint[0] / 2
    ys = (np.arange(self.grid[1]) + 0.5) * dy - self.footprint[1] / 2
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)

  def quarter_turned(self) -> "FootpadParams":
    """The same pad turned a quarter about Z on the rig: X and Y of the die layout, the
    footprint and the element grid swapped. The paper gives a 2-by-3 array on a 32 mm by
    39 mm board, not which way it faces the CNC's axes; the default has the three rows
    along Y."""
    return dataclasses.replace(self, die_x=self.die_y, die_y=self.die_x,
                               footprint=self.footprint[::-1], grid=self.grid[::-1])

  def die_positions(self) -> np.ndarray:
    """(num_dies, 3) die centres in the carriage frame, m; dies ordered column-major (x, y)."""
    return np.array([(x, y, self.die_depth) for x in self.die_x for y in self.die_y])

  def crown_sag(self) -> np.ndarray:
    """(num_elements,) height of each element's contact face above the flat plane, m."""
    if math.isinf(self.crown_radius):
      return np.zeros(self.num_elements)
    r2 = np.sum(self.element_centres() ** 2, axis=1)
    return self.crown_radius - np.sqrt(self.crown_radius**2 - r2)

  def element_stiffness(self) -> np.ndarray:
    """(num_elements, 3) spring rates (kx, ky, kz) of free rubber columns, N/m.

    A column of area A and local thickness h: normal k = E*A/h, shear k = G*A/h. The crown
    thins the rubber towards the edges.
    """
    dx, dy = self.element_size
    h_local = self.thickness - self.crown_sag()
    kn = self.youngs_modulus * dx * dy / h_local
    kt = self.shear_modulus * dx * dy / h_local
    return np.stack([kt, kt, kn], axis=1)

  def relations(self) -> fields.Relations:
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    half_diag = 0.5 * math.hypot(*self.footprint)
    yield (self.crown_radius > 4 * half_diag, "crown_radius",
           f"> {4 * half_diag:.3f} m (or inf for a flat pad)", self.crown_radius)
    yield self.die_depth < self.thickness, "die_depth", f"(0, {self.thickness}) m", self.die_depth
    g1, _, g2, _ = self.prony
    yield (g1 + g2 < 1, "prony", "(g1, tau1, g2, tau2) with g1 + g2 < 1 (a relaxed modulus "
           "left)", self.prony)
    yield (all(abs(x) < self.footprint[0] / 2 for x in self.die_x), "die_x",
           f"|x| < {self.footprint[0] / 2} m", self.die_x)
    yield (all(abs(y) < self.footprint[1] / 2 for y in self.die_y), "die_y",
           f"|y| < {self.footprint[1] / 2} m", self.die_y)

  def validate(self) -> None:
    """Raise ValueError naming the first parameter outside its allowed range."""
    fields.check(self)


def build_spec(params: FootpadParams, friction: bool = True, viscoelastic: bool = False,
               stiffness: np.ndarray | None = None,
               contact_sensors: bool = False, arms: str | None = None) -> mujoco.MjSpec:
  """Builds the rig as an MjSpec.

  Args:
    params: physical parameters.
    friction: frictional contact (condim 3) when True; frictionless (condim 1) otherwise.
    viscoelastic: each element's springs become two-term Prony solids (`FootpadParams.prony`),
      per axis: the joint keeps the relaxed spring, in parallel with two Maxwell arms
      (`maxwell_arm`), which add activation states but no bodies or joints.
    stiffness: (num_elements, 3) element spring rates, N/m; None for free rubber columns
      (`FootpadParams.element_stiffness`); see `sim.footpad.layer.element_stiffness`.
    contact_sensors: a contact sensor "tip_contacts" after the plate's force and torque,
      reporting every contact of the plate (found, force in the contact frame, position: 7
      values per slot, one slot per tip): what the `stick_slip` effect's state machine
      reads from a rollout.
    arms: how the Maxwell arms are integrated (`maxwell_arm`): "native" or "dcmotor"; None
      takes `arm_dynamics()`, the native callback wherever it could be compiled.
  Returns:
    The spec; compile with `spec.compile()`.
  """
  params.validate()
  spec = mujoco.MjSpec()
  spec.modelname = "footpad"
  opt = spec.option
  opt.timestep = params.timestep
  # Measured here: a looser tolerance gave false shear spikes; implicitfast diverged.
  opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
  opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
  opt.tolerance = 1e-8
  opt.iterations = 200
  opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
  # A soft friction row creeps at a rate set by its impedance: at impratio 1 a held 3 mm
  # stroke relaxed from 113 N to 40 N in 1 s (measured); at 100 the creep is below 1 %.
  opt.impratio = 100.0
  # The CNC holds the pad, the plate is tared: gravity only adds the pad's weight offset.
  opt.gravity = [0.0, 0.0, 0.0]

  # Stiff contact; rubber compliance lives in the element springs. Contact rows: timeconst =
  # timestep/2 with refsafe off and dmin = 0.9. Measured here: stiffer rows (timeconst <=
  # 0.2 ms, or dmin >= 0.95 at the refsafe limit) made every element lose contact at the onset
  # of sliding (shear collapsing to ~0 each cycle); this setting slides smoothly at exactly
  # mu*N and costs ~2 % of the normal stiffness in contact penetration.
  opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE
  # The carriage couples every element into one constraint island, so finding islands is
  # pure overhead: without it a step costs 11-12 % less and gives the same state to the bit
  # (measured, pressed and dragged, with and without the viscoelastic arms).
  opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
  contact_solref = [params.timestep / 2, 1.0]
  contact_solimp = [0.9, 0.95, 1e-3, 0.5, 2.0]
  condim = 3 if friction else 1

  world = spec.worldbody
  plate = world.add_body(name="plate")
  plate.add_geom(name="plate", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.06, 0.06, 0.005],
                 pos=[0, 0, -0.005], condim=condim, contype=0, conaffinity=1, friction=[params.friction, 0.005, 1e-4],
                 solref=contact_solref, solimp=contact_solimp, rgba=[0.6, 0.6, 0.65, 1])
  plate.add_site(name="ft", pos=[0, 0, 0])

  carriage = world.add_body(name="carriage", pos=[0, 0, 0])
  for i, axis in enumerate(AXES):
    ax = [0.0, 0.0, 0.0]
    ax[i] = 1.0
    carriage.add_joint(name=f"cnc_{axis}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=ax,
                       armature=params.cnc_mass)
  pcb_z = params.thickness
  carriage.add_geom(name="pcb", type=mujoco.mjtGeom.mjGEOM_BOX, contype=0, conaffinity=0,
                    size=[params.footprint[0] / 2, params.footprint[1] / 2, 0.0008],
                    pos=[0, 0, pcb_z + 0.0008], mass=0.02, rgba=[0.1, 0.5, 0.2, 1])
  carriage.add_geom(name="rubber", type=mujoco.mjtGeom.mjGEOM_BOX, contype=0, conaffinity=0,
                    size=[params.footprint[0] / 2, params.footprint[1] / 2, pcb_z / 2],
                    pos=[0, 0, pcb_z / 2], mass=0.024, group=2, rgba=[0.9, 0.9, 0.8, 0.3])
  for ax_i, axis in enumerate(AXES):
    act = spec.add_actuator(name=f"cnc_{axis}", target=f"cnc_{axis}",
                            trntype=mujoco.mjtTrn.mjTRN_JOINT)
    m_eff = params.cnc_mass + 0.044 + params.num_elements * 1e-4
    act.set_to_position(kp=params.cnc_kp, kv=2.0 * math.sqrt(params.cnc_kp * m_eff))

  k = params.element_stiffness() if stiffness is None else np.asarray(stiffness, float)
  if k.shape != (params.num_elements, 3):
    raise ValueError(f"stiffness has shape {k.shape}: expected ({params.num_elements}, 3)")
  dx, dy = params.element_size
  centres = params.element_centres()
  sag = params.crown_sag()
  g1, tau1, g2, tau2 = params.prony
  kind = None
  if viscoelastic:
    available, why = arm_dynamics()
    kind = arms or available
    if kind == "native" and available != "native":
      raise errors.SettingError(f"arms='native': the callback is unavailable ({why})")
  if kind not in (None, "native", "dcmotor"):
    raise errors.SettingError(f"arms is {arms!r}: expected 'native', 'dcmotor' or None")
  arms = ((g1, tau1), (g2, tau2)) if viscoelastic else ()
  relaxed = 1.0 - sum(g for g, _ in arms)
  for e in range(params.num_elements):
    h_local = params.thickness - sag[e]
    mass = params.density * dx * dy * h_local
    r = params.tip_radius
    el = carriage.add_body(name=f"el{e}", pos=[centres[e, 0], centres[e, 1], sag[e] + r])
    for i, axis in enumerate(AXES):
      el.add_joint(name=f"el{e}_{axis}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=np.eye(3)[i],
                   stiffness=k[e, i] * relaxed,
                   damping=2 * params.damping_ratio * math.sqrt(k[e, i] * mass))
      for arm, (g, tau) in enumerate(arms):
        maxwell_arm(spec, f"el{e}_{axis}", g * k[e, i], tau, f"el{e}_{axis}_arm{arm}", kind)
    el.add_geom(name=f"tip{e}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], mass=mass,
                # Tips collide with the plate only, never with each other.
                contype=1, conaffinity=0, condim=condim, friction=[params.friction, 0.005, 1e-4], solref=contact_solref,
                solimp=contact_solimp, rgba=[0.9, 0.6, 0.2, 1])

  # The plate's F/T sensor: the tips' contacts are all that load the plate, so their net
  # wrench is what a force and torque sensor at the site reads (equal to 1e-17 of the force,
  # measured), without the post-constraint dynamics of MuJoCo's force sensors (4 % of a step).
  # reduce="netforce" (3; no enum in the bindings): one synthetic contact
  _plate_contacts(spec, "ft", ("FORCE", "TORQUE", "POS"), reduce=3, slots=1)
  if contact_sensors:  # one sensor for every tip: 48 of their own cost 8 % of a step
    _plate_contacts(spec, "tip_contacts", ("FOUND", "FORCE", "POS"), reduce=0,
                    slots=params.num_elements)
  lighting.light(spec, 0.2)
  return spec


def maxwell_arm(spec: mujoco.MjSpec, joint: str, stiffness: float, tau: float,
                name: str, kind: str = "dcmotor") -> None:
  """Adds a Maxwell arm (a spring of `stiffness` N/m in series with a dashpot of time constant
  `tau` s, between the carriage and `joint`) as an actuator whose activation is the arm's
  force on the joint, N (`element_state` reads it): one state, and no body, joint or
  constraint (three bodies' worth of degrees of freedom per element before).

  The arm's spring stretch y obeys y' = -y/tau - v (v the joint's speed) and pushes the joint
  with k y, so its force f = k y obeys f' = -f/tau - k v. Two integrations of that equation:

  - "native": the same motor with user activation dynamics (`maxwell_arm.c`, compiled once
    per machine, see `arm_dynamics`) that step its equation explicitly like any activation:
    stable while dt < 2 tau (tau >= 0.01 s by its setting's range, dt <= 2 ms), within the
    Prony test's 3 %, and 1.2x the friction-only step cost against 1.65x for the motor
    (measured, `footpad_throughput`).
  - "dcmotor": MuJoCo's passive DC motor with inductance, L i' = -R i - K v pushing with K i:
    the same equation for i = f / K when L = K^2 / k and R = L / tau. It needs no compiler,
    but the `discrete` integrator couples each motor implicitly, which costs the rest.
  """
  inductance = 1.0 / stiffness  # K^2 / k with K = 1 V s/m
  act = spec.add_actuator(name=name, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
  act.set_to_dcmotor(motorconst=[1.0, 1.0], resistance=inductance / tau,
                     inductance=[inductance, 0.0], ctrlspec=mujoco.mjtCtrlInput.mjINPUT_NONE)
  if kind == "native":  # the motor's parameters and gain (K i) stay; its dynamics go
    act.dyntype = mujoco.mjtDyn.mjDYN_USER
    act.dynprm[_ARM_MARK_INDEX] = _ARM_MARK
    act.actearly = False  # early activations would bring back the implicit coupling's cost


# dynprm[9] of a native arm, MAXWELL_ARM_MARK in maxwell_arm.c: free, where a value in slot 2,
# 5 or 7 fails the motor's checks (as found in MuJoCo 4.0)
_ARM_MARK, _ARM_MARK_INDEX = 6174.0, 9
_arm_lock = threading.Lock()
_arm_state: tuple[str, str] | None = None


def arm_dynamics() -> tuple[str, str]:
  """("native", "") once the arms' activation callback is compiled and installed as MuJoCo's
  `mjcb_act_dyn` in this process; else ("dcmotor", why not): no C compiler (an empty $CC
  says so on purpose), no MuJoCo headers, or another `mjcb_act_dyn` already installed."""
  global _arm_state
  with _arm_lock:
    if _arm_state is None:
      include = pathlib.Path(mujoco.__file__).parent / "include"
      lib, why = native.shared_library(pathlib.Path(__file__).with_name("maxwell_arm.c"),
                                       (str(include),), tag=mujoco.__version__)
      current = mujoco.get_mjcb_act_dyn()
      if lib is not None and current is not None and current is not lib.maxwell_arm_act_dyn:
        lib, why = None, "another mjcb_act_dyn callback is installed"
      if lib is None:
        _arm_state = ("dcmotor", why)
      else:
        mujoco.set_mjcb_act_dyn(lib.maxwell_arm_act_dyn)
        _arm_state = ("native", "")
    return _arm_state


def require_arm_dynamics(model: mujoco.MjModel) -> None:
  """Raises unless every native arm of `model` will be integrated: a model compiled in
  another process (pickled to a worker) or before someone replaced `mjcb_act_dyn` would
  otherwise step with arms that never relax."""
  native_arms = ((model.actuator_dyntype == mujoco.mjtDyn.mjDYN_USER)
                 & (model.actuator_dynprm[:, _ARM_MARK_INDEX] == _ARM_MARK))
  if not native_arms.any():
    return
  kind, why = arm_dynamics()
  if kind != "native":
    raise errors.SimulationError(f"this footpad model has native Maxwell arms but their "
                                 f"callback is unavailable here ({why}): build the model "
                                 f"again with arms='dcmotor'")
  installed = mujoco.get_mjcb_act_dyn()
  if installed is None or getattr(installed, "__name__", "") != "maxwell_arm_act_dyn":
    raise errors.SimulationError("mjcb_act_dyn was replaced after the footpad's native "
                                 "Maxwell arms were installed: their activations would not "
                                 "be integrated")


def _plate_contacts(spec: mujoco.MjSpec, name: str, data: tuple[str, ...], reduce: int,
                    slots: int) -> None:
  """A contact sensor over the plate's contacts reporting the `mjtConDataField` fields
  `data` (names without their mjCONDATA_ prefix) in `slots` slots, reduced by `reduce`."""
  bits = sum(1 << int(getattr(mujoco.mjtConDataField, f"mjCONDATA_{f}")) for f in data)
  sensor = spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT,
                           objtype=mujoco.mjtObj.mjOBJ_GEOM, objname="plate")
  sensor.intprm[:3] = [bits, reduce, slots]


PLATE_SENSOR = 9  # sensordata values of the plate's sensor, first in every footpad model


def plate_wrench(sensordata: np.ndarray) -> np.ndarray:
  """(..., 6) force (N) and torque (N m) the pad applies to the plate, about the plate's F/T
  site at the origin, from (..., nsensordata) sensordata: the net contact force and torque
  about the contacts' force-weighted centroid, moved to the site."""
  force, torque, centroid = sensordata[..., 0:3], sensordata[..., 3:6], sensordata[..., 6:9]
  return np.concatenate([force, torque + np.cross(centroid, force)], axis=-1)


def element_state(model: mujoco.MjModel, params: FootpadParams, qpos: np.ndarray,
                  act: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
  """Forces the plate applies to the rubber at each element, and the elements' deflections.

  The spring rates are read from the model, so they always match what was simulated.

  Args:
    model: a model built by `build_spec` with these params (viscoelastic or not).
    params: the same parameters.
    qpos: (..., nq) joint positions.
    act: (..., na) activations; the viscoelastic model's Maxwell arms hold their forces
      there (`maxwell_arm`), so it needs them.
  Returns:
    forces (..., num_elements, 3), N, +z compressing the rubber; and deflections
    (..., num_elements, 3), m: how far each element's contact point has moved from its rest
    position relative to the PCB, +z compressing the rubber.
  """
  joints = [[model.joint(f"el{e}_{a}").id for a in AXES] for e in range(params.num_elements)]
  idx = model.jnt_qposadr[joints]
  k = model.jnt_stiffness[joints]
  flat = idx.ravel()
  if np.all(np.diff(flat) == 1):  # the usual layout: a contiguous slice, no gather
    q = qpos[..., flat[0]:flat[-1] + 1].reshape(qpos.shape[:-1] + idx.shape)
  else:
    q = qpos[..., idx]
  f = k * q
  if model.na:  # the arms push the joint with their activations: the plate takes the rest
    if act is None:
      raise ValueError("element_state: the viscoelastic model needs act, the Maxwell arms' "
                       "activations")
    arms = model.na // (params.num_elements * len(AXES))
    f = f - act.reshape(act.shape[:-1] + idx.shape + (arms,)).sum(axis=-1)
  return f, q


def element_forces(model: mujoco.MjModel, params: FootpadParams, qpos: np.ndarray,
                   act: np.ndarray | None = None) -> np.ndarray:
  """(..., num_elements, 3) forces of `element_state`, N."""
  return element_state(model, params, qpos, act)[0]


def contact_friction(model: mujoco.MjModel) -> np.ndarray:
  """(num_elements,) sliding friction coefficient of each element's tip on the plate: MuJoCo
  takes the larger of the two geoms' coefficients."""
  tips = [g for g in range(model.ngeom) if (model.geom(g).name or "").startswith("tip")]
  return np.maximum(model.geom_friction[tips, 0], model.geom("plate").friction[0])


def cnc_qpos_index(model: mujoco.MjModel) -> np.ndarray:
  """(3,) qpos addresses of the CNC joints (x, y, z)."""
  return np.array([model.jnt_qposadr[model.joint(f"cnc_{a}").id] for a in AXES])

