"""The footpad scene: CNC paths over the F/T plate, die stresses, ADC counts, ground truth.

A scene is declarative (`FootpadScene`): model parameters, paths, Z indentations, feed,
effects and seed. `simulate` runs every episode (threads, one MjData each, `mujoco.rollout`),
turns joint positions into element forces, die pressures (through `sim.footpad.layer`) and
counts (through `sim.footpad.sensor_chain`), and returns one `Recording`. `generate` adds the
on-disk cache.
"""

from __future__ import annotations

import concurrent.futures
import copy
import dataclasses
import hashlib
import json
import math
import os
import pathlib
import time
from typing import Callable, Optional

import mujoco
import mujoco.rollout
import numpy as np

from models import footpad as model_lib

from util import blas, errors, fields
from util.errors import SimulationError
from util.fields import setting
from sim import physics, recording
from sim import effects as effects_lib
from sim.effects import active, check_effects
from sim.footpad import effects as fx
from sim.footpad import layer, sensor_chain, trajectories
from sim.footpad.effects import EFFECTS, EffectName
from sim.footpad.trajectories import PathName

PAPER_Z_LEVELS = tuple(round(0.0001 * i, 4) for i in range(16))  # 0-1.5 mm in 0.1 mm steps
# Strain up to which the linear element springs stand for the rubber; the CNC is refused
# deeper presses (at 100 % the tips would reach the PCB).
MAX_STRAIN = 0.4
CNC_REACH = 0.03  # m from the origin: the 32 x 39 mm pad stays on the 120 mm plate

Progress = Callable[[int, int], None]


@fields.declared
@dataclasses.dataclass(frozen=True)
class FootpadScene:
  """Everything that determines a footpad recording.

  Attributes:
    params: pad and rig parameters.
    paths: path names (see `sim.footpad.trajectories.PATHS`).
    z_levels: indentations, m, at which every path except z_press runs.
    feed: CNC feed rate, m/s (assumed 5 mm/s: ~9.6 s per asterisk path).
    stroke: amplitude of the X and Y strokes the linear fit takes (x_stroke, y_stroke), m.
      The paper does not give it (Sec. III-B); its own numbers bound it. Its test paths,
      which reach 3 mm from the origin, span 126 N of shear (Table I: RMSE over NRMSE,
      12.84 N / 10.14 % on Y, 10.48 N / 8.30 % on X, both networks alike), while its strokes
      span 233 N on Y and 219 N on X (Sec. III-B): with the same rubber, strokes of about
      +-5.2-5.5 mm if the pad stays stuck, shorter where it slides. Sourced range 3-6 mm
      (3 mm, the reach of every other path of the paper, is the default).
    press_repeats: presses in z_press (paper: 10); strokes use 3 back-and-forth passes.
    press_depth: depth of z_press, m; None presses until the first die saturates (paper
      Sec. III-B), computed from the kernel, capped at the strain limit.
    kernel: die-stress kernel.
    adc: sensor supply and ADC.
    effects: names from `sim.footpad.effects.EFFECTS`.
    custom_path: a file with your own CNC path (`sim.footpad.trajectories.read_path`: CSV
      rows x, y, z in mm and feed in mm/s, or G0/G1 G-code), run once after `paths` as
      written (z = 0 at first touch, negative pressing); none by default.
    seed: one integer for every random draw of the run.
    session: which recording session of the pad this is: its noise and drift draws are the
      session's own, while the pad (its dies' unit spread, drawn from `seed`) stays the
      same, as when one pad is recorded on several days.
  """
  params: model_lib.FootpadParams = model_lib.FootpadParams()
  paths: tuple[PathName, ...] = ("asterisk",)
  z_levels: tuple[float, ...] = setting(PAPER_Z_LEVELS, "[0, 0.02]", "m", length=(1, 100))
  feed: float = setting(0.005, "[1e-4, 0.05]", "m/s")
  stroke: float = setting(trajectories.STROKE, "[0.0005, 0.01]", "m",
                          sourced=fields.Sourced(0.003, 0.006))
  press_repeats: int = setting(10, "[1, 100]")
  press_depth: Optional[float] = setting(None, "(0, 0.02]", "m")
  kernel: layer.Kernel = layer.Kernel.BONDED_LAYER
  adc: sensor_chain.AdcConfig = sensor_chain.AdcConfig(vref=3.3)
  effects: tuple[EffectName, ...] = ("friction",)
  custom_path: Optional[str] = None
  seed: int = setting(0, "[0, inf)")
  session: int = setting(0, "[0, 1000000]")

  @property
  def max_indentation(self) -> float:
    return MAX_STRAIN * self.params.thickness

  def unread(self, key: str) -> Optional[str]:
    """Why the setting `key` changes nothing under this scene's effects (None if it may)."""
    return effects_lib.unread(key, self.effects, EFFECTS)

  def relations(self) -> fields.Relations:
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    lim = self.max_indentation
    strain = f"[0, {lim:.4g}] m ({MAX_STRAIN:.0%} strain of the {self.params.thickness} m rubber)"
    yield all(0.0 <= z <= lim for z in self.z_levels), "z_levels", strain, self.z_levels
    yield (self.press_depth is None or self.press_depth <= lim, "press_depth",
           f"(0, {lim:.4g}] m or none", self.press_depth)
    for name, need in effects_lib.missing_needs(self.effects, EFFECTS):
      yield False, "effects", f"{name} together with {need} (it works on {need}'s model)", \
          self.effects

  def validate(self) -> None:
    """Raise ValueError naming the first setting outside its allowed range (and DataError
    naming the line of a custom path file that cannot be used)."""
    fields.check(self)
    if not self.paths and self.custom_path is None:
      raise errors.SettingError("paths=() and no custom_path: the scene has nothing to run")
    if self.custom_path is not None:
      if not pathlib.Path(self.custom_path).is_file():
        raise errors.SettingError(f"custom_path={self.custom_path!r} is not a file: allowed a "
                                  f"CSV or G-code path file (see README: your own CNC path)")
      try:
        way = trajectories.read_path(self.custom_path)
      except errors.DataError as err:
        raise errors.DataError(f"custom_path: {err}") from None
      deepest = -way.points[:, 2].min()
      if deepest > self.max_indentation:
        raise errors.DataError(
            f"custom_path: path file {self.custom_path} presses {deepest * 1e3:.2f} mm deep; "
            f"the pad takes at most {self.max_indentation * 1e3:.2f} mm ({MAX_STRAIN:.0%} "
            f"strain)")
      reach = np.abs(way.points[:, :2]).max()
      if reach > CNC_REACH:
        raise errors.DataError(
            f"custom_path: path file {self.custom_path} moves {reach * 1e3:.1f} mm from the "
            f"origin; the rig's plate allows {CNC_REACH * 1e3:g} mm")

  def config(self) -> dict:
    """JSON-able description (the cache key and the recording's metadata): a custom path
    enters with its file's SHA-256, so an edited file is simulated anew."""
    d = dataclasses.asdict(self)
    d["kernel"] = self.kernel.value
    d["effects"] = list(check_effects(self.effects, EFFECTS))
    if self.custom_path is not None:
      d["custom_path_sha256"] = hashlib.sha256(
          pathlib.Path(self.custom_path).read_bytes()).hexdigest()
    return d


# ---------------------------------------------------------------------------------------------

def compile_model(scene: FootpadScene) -> mujoco.MjModel:
  """The scene's MuJoCo model, with the model effects it lists."""
  on = active(scene.effects, EFFECTS)
  return model_lib.build_spec(scene.params, friction=fx.FRICTION in on,
                              viscoelastic=fx.VISCOELASTIC in on,
                              stiffness=layer.element_stiffness(scene.params),
                              contact_sensors=fx.STICK_SLIP in on).compile()


def stream_of(eps, session: int = 0) -> int:
  """A recording's identity for its random streams: a CRC of the CNC commands of its
  episodes (paths, depths, feeds, custom paths alike) and the session, so two recordings of
  one run, or one path in two sessions, draw their noise and drift apart, while the same
  commands with other physics settings (an ablation, a sweep) draw the same."""
  import zlib
  crc = 0
  for ep in eps:
    crc = zlib.crc32(np.ascontiguousarray(ep.target, dtype=np.float64).tobytes(), crc)
  return crc if session == 0 else zlib.crc32(f"session {session}".encode(), crc)


def thirion_friction(mu0: float, shear_strength: float, pressure: np.ndarray) -> np.ndarray:
  """Friction coefficient tau / p of rubber at contact pressure p (Pa) by Thirion's law,
  tau = mu0 p / (1 + mu0 p / tau_s): mu0 as p -> 0, tau -> tau_s as p -> inf."""
  return mu0 / (1.0 + mu0 * np.maximum(pressure, 0.0) / shear_strength)


def episode_friction(scene: FootpadScene, z: float) -> np.ndarray:
  """(num_elements,) each element's friction coefficient for an episode at indentation z (m),
  for the `pressure_friction` effect: Thirion's law at the element's pressure under the flat
  press to z (its normal rate times its indentation, the crown's sag taken off, over its
  patch). The coefficient is held over the episode: the stroke's shear moves the pressure
  under each element by less than the press (measured: `footpad_dataset`'s slip table)."""
  params = scene.params
  kz = layer.element_stiffness(params)[:, 2]
  dx, dy = params.element_size
  pressure = kz * np.maximum(z - params.crown_sag(), 0.0) / (dx * dy)
  return thirion_friction(params.friction_mu0, params.friction_shear_strength, pressure)


def press_depth(scene: FootpadScene, kernel: np.ndarray) -> float:
  """Depth at which the first die saturates under a uniform press, capped at the strain limit."""
  if scene.press_depth is not None:
    return scene.press_depth
  kz = layer.element_stiffness(scene.params)[:, 2]
  pa_per_m = np.max(kernel[:, :, 2] @ kz)
  # 5 % past the linear estimate: contact penetration makes the pad ~2 % softer than its
  # springs.
  depth = 1.05 * sensor_chain.saturation_pressure(scene.adc) / pa_per_m
  return float(min(depth, scene.max_indentation))


def episodes(scene: FootpadScene, kernel: np.ndarray) -> list[trajectories.Episode]:
  """Every episode of the scene, in order."""
  dt = scene.params.timestep
  out = []
  for path in scene.paths:
    if path == "z_press":
      out.append(trajectories.episode(path, press_depth(scene, kernel), scene.feed, dt,
                                      scene.press_repeats))
      continue
    for z in scene.z_levels:
      out.append(trajectories.episode(path, z, scene.feed, dt, repeats=3,
                                      stroke=scene.stroke))
  if scene.custom_path is not None:
    out.append(trajectories.waypoint_episode(trajectories.read_path(scene.custom_path), dt))
  return out


# the CNC must hold each commanded indentation to this share of it (or REACH_FLOOR, m): a
# servo that yields under a stiff pad would record the command, not where the pad was
REACH_SHARE = 0.05
REACH_FLOOR = 25e-6


def _run_episode(model: mujoco.MjModel, data: mujoco.MjData, ep: trajectories.Episode,
                 stick: Optional["StickSlip"] = None):
  """Rolls one episode out from rest; returns (qpos (T, nq), act (T, na), sensordata (T, ns),
  slip (T,) or None, seconds). With `stick` the tips' friction follows each element's
  stick-slip state (`StickSlip.roll`), and slip is the share of loaded elements sliding.

  Raises SimulationError if the physics diverged or the CNC did not reach its commands."""
  model_lib.require_arm_dynamics(model)
  t0 = time.perf_counter()
  mujoco.mj_resetData(model, data)
  data.qpos[model_lib.cnc_qpos_index(model)] = ep.target[0]
  data.ctrl[:] = ep.target[0]
  mujoco.mj_forward(model, data)
  slip = None
  if stick is None:
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)
    state, sens = mujoco.rollout.rollout(model, data, state0, ep.target[None])
    a = 1 + model.nq + model.nv
    times, qpos, act, sens = state[0, :, 0], state[0, :, 1:1 + model.nq], \
        state[0, :, a:a + model.na], sens[0]
  else:
    times, qpos, act, sens, slip = stick.roll(model, data, ep.target)
  where = f"footpad {ep.path} at z={ep.z_level * 1e3:.2f} mm"
  physics.check(data, where, "lower the indentation (z_levels) or feed, or params.timestep",
                times=times, values=(qpos, sens))
  cnc = qpos[:, model_lib.cnc_qpos_index(model)]
  held = ep.phase == 1
  if held.any():
    miss = np.abs(cnc[held] - ep.target[held]).max(axis=1)
    k = int(np.argmax(miss))
    if miss[k] > max(REACH_SHARE * abs(ep.z_level), REACH_FLOOR):
      t = np.flatnonzero(held)[k] * model.opt.timestep
      raise SimulationError(
          f"{where}: the CNC missed its command by {miss[k] * 1e3:.3f} mm at t={t:.3f} s "
          f"(its servo yields to the pad): raise params.cnc_kp (now "
          f"{model.actuator_gainprm[0, 0]:g} N/m), or lower the indentation or the rubber's "
          f"modulus")
  return qpos, act, sens, slip, time.perf_counter() - t0


# a sliding element sticks again when its speed over the plate falls below this (m/s) or
# turns: far above a stuck contact's creep (< 0.03 mm/s at impratio 100, measured), far
# below the CNC's 5 mm/s feed
STICK_SPEED = 2e-4


@dataclasses.dataclass(frozen=True)
class StickSlip:
  """The `stick_slip` effect's per-element state machine for one model.

  Attributes:
    tips: (E,) the tips' geom ids; their friction changes as elements stick and slide.
    contacts: sensordata address of the plate's contacts (`model_lib.build_spec`'s
      contact_sensors: E slots of found, force in the contact frame, position).
    cells: (2, 2) the element grid on the carriage: its corner and cell size (x, y), m; a
      contact belongs to the tip whose cell it lies in (a tip moves well under half a cell).
    dofs: (E + 1, 2) qvel addresses of each element's x and y joints, then the CNC's: a
      tip's velocity over the plate is its carriage's plus its own (slide joints, no
      rotation), read from the state rather than from the contact sensor, whose velocity
      field cost 20 % of a step (measured).
    grid: elements along x and y (tips numbered row-major in x, y).
    kinetic: (E,) each element's kinetic coefficient.
    ratio: static over kinetic coefficient.
  """
  tips: np.ndarray
  contacts: int
  cells: np.ndarray
  dofs: np.ndarray
  grid: tuple[int, int]
  kinetic: np.ndarray
  ratio: float

  @classmethod
  def of(cls, model: mujoco.MjModel, params: model_lib.FootpadParams, kinetic: np.ndarray
         ) -> "StickSlip":
    """The machine for a model built with contact sensors, its tips at `kinetic` (E,)."""
    joints = [[f"el{e}_x", f"el{e}_y"] for e in range(params.num_elements)] + [["cnc_x",
                                                                                 "cnc_y"]]
    return cls(np.array([model.geom(f"tip{e}").id for e in range(params.num_elements)]),
               int(model.sensor_adr[model.sensor("tip_contacts").id]),
               np.array([-np.array(params.footprint) / 2, params.element_size]),
               model.jnt_dofadr[[[model.joint(j).id for j in row] for row in joints]],
               params.grid, kinetic, params.static_friction_ratio)

  def per_element(self, sensordata: np.ndarray, cnc: np.ndarray, qvel: np.ndarray
                  ) -> np.ndarray:
    """(c, E, 6) found, force (normal, two tangents) and velocity (x, y) of each tip's
    contact from (c, ns) sensordata, with the carriage at (c, 2) cnc positions and (c, nv)
    qvel before each step (what the step's sensors saw); zero where none."""
    c, nt = len(sensordata), len(self.tips)
    slots = sensordata[:, self.contacts:self.contacts + 7 * nt].reshape(c, nt, 7)
    row, slot = np.nonzero(slots[..., 0] > 0)
    found = slots[row, slot]
    cell = np.floor((found[:, 4:6] - cnc[row] - self.cells[0]) / self.cells[1]).astype(int)
    cell = np.clip(cell, 0, np.array(self.grid) - 1)
    tip = cell[:, 0] * self.grid[1] + cell[:, 1]
    out = np.zeros((c, nt, 6))
    out[row, tip, :4] = found[:, :4]
    velocity = qvel[:, self.dofs[:-1]] + qvel[:, None, self.dofs[-1]]  # (c, E, 2)
    out[row, tip, 4:] = velocity[row, tip]
    return out

  def roll(self, model: mujoco.MjModel, data: mujoco.MjData, target: np.ndarray):
    """Steps `target` (T, 3) CNC commands from data's state; returns times (T,), qpos (T, nq),
    act (T, na), the plate sensor's sensordata (T, model_lib.PLATE_SENSOR) after each step
    (as `mujoco.rollout` records them) and the share of loaded elements sliding (T,).

    The steps run in chunks through `mujoco.rollout` with the friction coefficients fixed.
    The state machine then reads the chunk's contact sensors: up to the first step at which
    an element's coefficient must change, the chunk is exactly what stepping one at a time
    gives (the change takes effect from the next step), so the rest is rolled again from
    there. Most steps see no change (no sliding sample at 12 of 16 depths), so few are."""
    n, nt = len(target), len(self.tips)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    warm = data.qacc_warmstart.copy()
    times, slip = np.empty(n), np.zeros(n)
    qpos, sens = np.empty((n, model.nq)), np.empty((n, model_lib.PLATE_SENSOR))
    act = np.empty((n, model.na))
    a = 1 + model.nq + model.nv
    stuck = np.ones(nt, bool)
    velocity = np.zeros((nt, 2))
    static = self.ratio * self.kinetic
    t, chunk = 0, CHUNK[0]
    cnc = model_lib.cnc_qpos_index(model)[:2] + 1  # in the state, after its time
    while t < n:
      c = min(chunk, n - t)
      model.geom_friction[self.tips, 0] = np.where(stuck, static, self.kinetic)
      st, sd = mujoco.rollout.rollout(model, data, state, target[None, t:t + c],
                                      initial_warmstart=warm[None])
      st, sd = st[0], sd[0]
      before = np.concatenate([state[None, :a], st[:-1, :a]])  # time, qpos, qvel
      con = self.per_element(sd, before[:, cnc], before[:, 1 + model.nq:])
      fn = con[..., 1]  # found, force (n, t1, t2), velocity (x, y)
      ft = np.hypot(con[..., 2], con[..., 3])
      v = con[..., 4:6]
      speed = np.hypot(v[..., 0], v[..., 1])
      loaded = (con[..., 0] > 0) & (fn > LOADED)
      limit = SLIDING * static * fn
      j, keep = 0, c
      while j < c:  # one pass per change of state, each over the chunk's remaining steps
        prev = np.concatenate([velocity[None], v[j:-1]])  # a sliding element's last step
        breaks = stuck & loaded[j:] & (ft[j:] >= limit[j:])
        halts = ~stuck & loaded[j:] & ((speed[j:] < STICK_SPEED)
                                       | ((v[j:] * prev).sum(axis=-1) < 0))
        lifts = ~stuck & ~loaded[j:]
        change = (breaks | halts | lifts).any(axis=1)
        end = j + int(np.argmax(change)) if change.any() else c
        rows = slice(j, end)
        n_loaded = loaded[rows].sum(axis=1)
        slip[t + j:t + end] = np.where(
            n_loaded > 0, (loaded[rows] & ~stuck).sum(axis=1) / np.maximum(n_loaded, 1), 0.0)
        seen = loaded[j:end + 1]  # the rows this pass settles, a changing one included
        has = seen.any(axis=0)
        last = j + len(seen) - 1 - np.argmax(seen[::-1], axis=0)
        velocity[has] = v[last[has], has]  # each element's speed when last loaded
        if end == c:
          break
        k = end - j
        was = stuck.copy()
        stuck[breaks[k]] = False
        stuck[halts[k]] = True
        slip[t + end] = (np.count_nonzero(loaded[end] & ~stuck) / loaded[end].sum()
                         if loaded[end].any() else 0.0)
        stuck |= ~loaded[end]
        j = end + 1
        if np.any((stuck != was) & (static != self.kinetic)):
          keep = j  # its coefficient changes from the next step: roll again from there
          break
      times[t:t + keep] = st[:keep, 0]
      qpos[t:t + keep] = st[:keep, 1:1 + model.nq]
      act[t:t + keep] = st[:keep, a:a + model.na]
      sens[t:t + keep] = sd[:keep, :model_lib.PLATE_SENSOR]
      if keep == c:  # the solver's warm start: the rollout's own where it ran to its end;
        warm = data.qacc_warmstart.copy()  # else the last step's velocity change over dt,
        chunk = min(2 * chunk, CHUNK[1])  # which is that step's qacc under `discrete`
      else:
        before = st[keep - 2] if keep > 1 else state
        warm = (st[keep - 1, 1 + model.nq:a] - before[1 + model.nq:a]) / model.opt.timestep
        chunk = CHUNK[0]
      state = st[keep - 1]
      t += keep
      if any(data.warning[w].number for w in physics.DIVERGED):
        times[t:], qpos[t:], act[t:], sens[t:] = times[t - 1], qpos[t - 1], act[t - 1], \
            sens[t - 1]  # as a diverged rollout fills its rest; `physics.check` reports it
        break
    return times, qpos, act, sens, slip


# steps per rollout chunk of `StickSlip.roll`, from just after a change of coefficient to its
# longest: short chunks waste little where elements change often, long ones save calls
CHUNK = (8, 256)


# an element whose shear is within this share of its friction limit is taken as sliding:
# MuJoCo's soft contact reaches the cone's edge only asymptotically
SLIDING = 0.98
LOADED = 0.05  # N: elements pressed less than this are out of contact


def slip_share(forces: np.ndarray, mu: float) -> np.ndarray:
  """(T,) share of the pad's loaded elements at their friction limit (|f_t| >= SLIDING mu
  f_n), from element forces (T, E, 3), N, +z pressing."""
  fn = forces[..., 2]
  ft = np.hypot(forces[..., 0], forces[..., 1])
  loaded = fn > LOADED
  sliding = loaded & (ft >= SLIDING * mu * fn)
  return sliding.sum(axis=-1) / np.maximum(loaded.sum(axis=-1), 1)


def element_couples(forces: np.ndarray, deflection: np.ndarray) -> np.ndarray:
  """(..., num_elements, 2) couples (N m, along x and y) of the `p_delta` effect: the normal
  force moved sideways by the shear deflection, the shear moved towards the PCB by the
  compression (the layer kernel measures a shear's lever from the undeformed face)."""
  return forces[..., 2:3] * deflection[..., :2] - forces[..., :2] * deflection[..., 2:3]


def _set_friction(scene: FootpadScene, model: mujoco.MjModel,
                  kinetic: Optional[np.ndarray]) -> Optional[StickSlip]:
  """Gives an episode's own model (the plate's coefficient zeroed: MuJoCo takes the larger)
  its tips' kinetic coefficients, `kinetic` (E,) under `pressure_friction` or the pad's
  friction otherwise; returns the `stick_slip` state machine when the scene has it."""
  on = active(scene.effects, EFFECTS)
  if fx.PRESSURE_FRICTION not in on and fx.STICK_SLIP not in on:
    return None
  if kinetic is None:
    kinetic = np.full(scene.params.num_elements, scene.params.friction)
  tips = [model.geom(f"tip{e}").id for e in range(scene.params.num_elements)]
  model.geom_friction[tips, 0] = kinetic
  return StickSlip.of(model, scene.params, kinetic) if fx.STICK_SLIP in on else None


def simulate(scene: FootpadScene, progress: Optional[Progress] = None,
             threads: Optional[int] = None) -> tuple[recording.Recording, recording.Timing]:
  """Runs the scene (no cache). `progress(done, total)` is called as episodes finish."""
  scene.validate()
  t0 = time.perf_counter()
  effects = check_effects(scene.effects, EFFECTS)
  on = active(effects, EFFECTS)
  model = compile_model(scene)
  kernel = layer.die_kernel(scene.params, scene.kernel)
  eps = episodes(scene, kernel)
  threads = threads or min(os.cpu_count() or 1, len(eps))
  per_element = fx.PRESSURE_FRICTION in on
  stick_slip = fx.STICK_SLIP in on
  # each thread its own model when episodes set their own friction coefficients
  own = per_element or stick_slip
  models = [copy.copy(model) if own else model for _ in range(threads)]
  if own:
    for m in models:  # the tip's coefficient decides (MuJoCo takes the larger of the two)
      m.geom_friction[m.geom("plate").id, 0] = 0.0
  # one set of coefficients per depth, before the threads start (not one per episode)
  friction = {z: episode_friction(scene, z) for z in {ep.z_level for ep in eps}} \
      if per_element else {}
  datas = [mujoco.MjData(m) for m in models]
  t1 = time.perf_counter()

  results: list = [None] * len(eps)
  free = list(range(threads))
  cnc_idx = model_lib.cnc_qpos_index(model)
  g = kernel.reshape(len(kernel), -1).T
  gc = None
  if fx.P_DELTA in on:
    couples = layer.couple_kernel(scene.params, scene.kernel)
    gc = couples.reshape(len(couples), -1).T


  def work(i: int):
    slot = free.pop()
    m = models[slot]
    try:
      stick = _set_friction(scene, m, friction.get(eps[i].z_level))
      qpos, act, sens, state_slip, physics_s = _run_episode(m, datas[slot], eps[i], stick)
      mu = model_lib.contact_friction(m)
    finally:
      free.append(slot)
    t = time.perf_counter()
    forces, deflection = model_lib.element_state(model, scene.params, qpos, act)
    pressure = forces.reshape(len(forces), -1) @ g
    if gc is not None:
      pressure += element_couples(forces, deflection).reshape(len(forces), -1) @ gc
    slip = state_slip if state_slip is not None else \
        slip_share(forces, mu) if fx.FRICTION in on else np.zeros(len(forces))
    chain = time.perf_counter() - t
    return i, (pressure, model_lib.plate_wrench(sens), forces.sum(axis=1), qpos[:, cnc_idx],
               slip, physics_s, chain)

  done = 0
  with concurrent.futures.ThreadPoolExecutor(threads) as pool:
    for fut in concurrent.futures.as_completed([pool.submit(work, i) for i in range(len(eps))]):
      i, res = fut.result()
      results[i] = res
      done += 1
      if progress:
        progress(done, len(eps))
  t2 = time.perf_counter()
  pressure, sens, force_sum, cnc, slip = (np.concatenate([r[k] for r in results])
                                          for k in range(5))
  counts, wrench = sensor_chain.apply(pressure, sens, effects, scene.seed, scene.adc,
                                      scene.params.timestep, stream_of(eps, scene.session))
  chain_cpu = sum(r[6] for r in results) + time.perf_counter() - t2
  physics_cpu = sum(r[5] for r in results)

  path_names = list(dict.fromkeys(ep.path for ep in eps))
  rec = recording.Recording(
      time=np.concatenate([np.arange(len(ep.target)) * scene.params.timestep for ep in eps]),
      counts=counts, pressure=pressure, wrench=wrench, element_force=force_sum, cnc=cnc,
      slip=slip,
      path=np.concatenate([np.full(len(ep.target), path_names.index(ep.path), np.int16)
                           for ep in eps]),
      z_level=np.concatenate([np.full(len(ep.target), ep.z_level) for ep in eps]),
      phase=np.concatenate([ep.phase for ep in eps]),
      episode=np.concatenate([np.full(len(ep.target), i, np.int32) for i, ep in enumerate(eps)]),
      meta=json.loads(json.dumps({"scene": "footpad", "config": scene.config(), "paths": path_names,
            "effects": list(effects), "seed": scene.seed, "sensors": "MPXH6400A x6",
            "units": {"counts": "ADC counts", "pressure": "Pa", "wrench": "N, N m",
                      "cnc": "m", "time": "s"},
            "versions": versions()})))
  return rec, recording.Timing(t1 - t0, t2 - t1, physics_cpu, chain_cpu, len(pressure), threads)


def versions() -> dict[str, str]:
  # "physics" changes whenever the model or sensor chain does, so stale cached recordings
  # are not reused: 2 = element rates from the bonded finite-element block; 3 = viscoelastic
  # in shear too; 4 = the slip share of each sample, FootpadParams' friction law; 5 = every
  # recording its own noise and drift streams (`stream_of`); 6 = a custom path's phase 1 is
  # the path at its depth (not its press down); 7 = the square path once (not three times);
  # 8 = the Maxwell arms as activation states (`model_lib.maxwell_arm`), not bodies; 9 = the
  # plate's F/T as the net contact wrench (`model_lib.plate_wrench`), equal to 1e-9; 10 = the
  # arms integrated by the compiled callback where there is one ("maxwell_arms"). The BLAS
  # kernels set the die kernel's last bits, z_press's depth and so every noise stream.
  return {"mujoco": mujoco.__version__, "numpy": np.__version__, "recording_format": "2",
          "physics": "10", "maxwell_arms": model_lib.arm_dynamics()[0],
          "blas": blas.architecture()}


def cache_key(scene: FootpadScene) -> dict:
  """Everything that determines the scene's recording: its settings, the versions, and the
  CNC commands themselves (`stream_of` of its episodes; a custom path's file by its
  content), so a path whose definition or file changed is simulated again rather than read
  stale from the cache."""
  return {"scene": scene.config(), "versions": versions(), "commands": _commands(scene)}


def _commands(scene: FootpadScene) -> int:
  """`stream_of` the scene's path episodes; z_press's depth comes from the pad's kernel,
  which the settings in the key already determine."""
  eps = [trajectories.episode(p, z, scene.feed, scene.params.timestep, repeats=3,
                              stroke=scene.stroke)
         for p in scene.paths if p != "z_press" for z in scene.z_levels]
  if scene.custom_path is not None:
    eps.append(trajectories.waypoint_episode(trajectories.read_path(scene.custom_path),
                                             scene.params.timestep))
  return stream_of(eps)


def generate(scene: FootpadScene, progress: Optional[Progress] = None, use_cache: bool = True
             ) -> tuple[recording.Recording, Optional[recording.Timing]]:
  """The scene's recording, from the cache when an identical request was made before.

  Returns the recording and the timing of the simulation (None when loaded from the cache).
  """
  scene.validate()
  return recording.generate("footpad", cache_key(scene), lambda: simulate(scene, progress),
                            use_cache)


def step_rates(scene: FootpadScene, bare_only: bool = False
               ) -> tuple[Optional[float], float]:
  """Steps/s, one thread, of the scene's deepest episode of its first path: as `simulate`
  runs it (rollout, sensors, the stick-slip machine, the checks; None with `bare_only`) and
  as bare `mj_step` on the same model and commands with sensors disabled; the reference of
  `footpad_throughput`."""
  model = compile_model(scene)
  model.geom_friction[model.geom("plate").id, 0] = 0.0
  eps = episodes(dataclasses.replace(scene, paths=scene.paths[:1], custom_path=None),
                 layer.die_kernel(scene.params, scene.kernel))
  ep = max(eps, key=lambda e: e.z_level)
  per_element = fx.PRESSURE_FRICTION in active(scene.effects, EFFECTS)
  stick = _set_friction(scene, model, episode_friction(scene, ep.z_level) if per_element
                        else None)
  data = mujoco.MjData(model)
  in_scene = None if bare_only else len(ep.target) / _run_episode(model, data, ep, stick)[-1]
  model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SENSOR
  mujoco.mj_resetData(model, data)
  data.qpos[model_lib.cnc_qpos_index(model)] = ep.target[0]
  mujoco.mj_forward(model, data)
  t = time.perf_counter()
  for u in ep.target:
    data.ctrl[:] = u
    mujoco.mj_step(model, data)
  return in_scene, len(ep.target) / (time.perf_counter() - t)
