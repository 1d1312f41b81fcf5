"""The footpad scene: CNC paths over the F/T plate, die stresses, ADC counts, ground truth.

A scene is declarative (`FootpadScene`): model parameters, paths, Z indentations, feed,
effects and seed. `simulate` runs every episode (threads, one MjData each, `mujoco.rollout`),
turns joint positions into element forces, die pressures (through `sim.layer`) and counts
(through `sim.sensor_chain`), and returns one `Recording`. `generate` adds the on-disk cache.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import json
import math
import os
import time
from typing import Callable, Optional

import mujoco
import mujoco.rollout
import numpy as np

from models import footpad as model_lib
from sim import layer, recording, sensor_chain, settings, trajectories
from sim.effects import FOOTPAD_EFFECTS, check_effects

PAPER_Z_LEVELS = tuple(round(0.0001 * i, 4) for i in range(16))  # 0-1.5 mm in 0.1 mm steps
# Strain up to which the linear element springs stand for the rubber; the CNC is refused
# deeper presses (at 100 % the tips would reach the PCB).
MAX_STRAIN = 0.4

Progress = Callable[[int, int], None]


@dataclasses.dataclass(frozen=True)
class FootpadScene:
  """Everything that determines a footpad recording.

  Attributes:
    params: pad and rig parameters.
    paths: path names (see `sim.trajectories.PATHS`).
    z_levels: indentations, m, at which every path except z_press runs.
    feed: CNC feed rate, m/s (assumed 5 mm/s: ~9.6 s per asterisk, DESIGN.md).
    press_repeats: presses in z_press (paper: 10); strokes use 3 back-and-forth passes.
    press_depth: depth of z_press, m; None presses until the first die saturates (paper
      Sec. III-B), computed from the kernel, capped at the strain limit.
    kernel: die-stress kernel.
    adc: sensor supply and ADC.
    effects: names from `sim.effects.FOOTPAD_EFFECTS`.
    seed: one integer for every random draw of the run.
  """
  params: model_lib.FootpadParams = model_lib.FootpadParams()
  paths: tuple[str, ...] = ("asterisk",)
  z_levels: tuple[float, ...] = PAPER_Z_LEVELS
  feed: float = 0.005
  press_repeats: int = 10
  press_depth: Optional[float] = None
  kernel: layer.Kernel = layer.Kernel.BONDED_LAYER
  adc: sensor_chain.AdcConfig = sensor_chain.AdcConfig(vref=3.3)
  effects: tuple[str, ...] = ("friction",)
  seed: int = 0

  @property
  def max_indentation(self) -> float:
    return MAX_STRAIN * self.params.thickness

  def validate(self) -> None:
    self.params.validate()
    self.adc.validate()
    check_effects(self.effects, FOOTPAD_EFFECTS)
    for p in self.paths:
      if p not in trajectories.PATHS:
        raise ValueError(f"unknown path {p!r}: allowed {', '.join(trajectories.PATHS)}")
    lim = self.max_indentation
    for z in self.z_levels:
      if not (0.0 <= z <= lim):
        raise ValueError(f"z_level {z!r} m is out of range: allowed [0, {lim:.4g}] m "
                         f"({MAX_STRAIN:.0%} strain of the {self.params.thickness} m rubber)")
    if self.press_depth is not None and not 0.0 < self.press_depth <= lim:
      raise ValueError(f"press_depth {self.press_depth!r} m is out of range: allowed "
                       f"(0, {lim:.4g}] m")
    if not 1e-4 <= self.feed <= 0.05:
      raise ValueError(f"feed {self.feed!r} m/s is out of range: allowed [1e-4, 0.05] m/s")
    if not 1 <= self.press_repeats <= 100:
      raise ValueError(f"press_repeats {self.press_repeats!r} is out of range: allowed [1, 100]")
    if int(self.seed) != self.seed or self.seed < 0:
      raise ValueError(f"seed {self.seed!r} is out of range: allowed integers >= 0")

  def config(self) -> dict:
    """JSON-able description (the cache key and the recording's metadata)."""
    d = dataclasses.asdict(self)
    d["kernel"] = self.kernel.value
    d["effects"] = list(check_effects(self.effects, FOOTPAD_EFFECTS))
    return d

  def with_overrides(self, overrides: dict[str, str]) -> "FootpadScene":
    """A copy with `key=value` settings applied; keys name scene fields or `params.*`,
    `adc.*` fields (e.g. params.friction=0.8, adc.vref=5, z_levels=0.0005,0.001)."""
    return settings.apply(self, overrides)


# ---------------------------------------------------------------------------------------------

class SimulationError(RuntimeError):
  """MuJoCo reported a warning (instability, contact overflow) or produced non-finite data."""


def compile_model(scene: FootpadScene) -> mujoco.MjModel:
  """The scene's MuJoCo model, with the model effects it lists."""
  effects = check_effects(scene.effects, FOOTPAD_EFFECTS)
  return model_lib.build_spec(scene.params, friction="friction" in effects,
                              viscoelastic="viscoelastic" in effects,
                              stiffness=layer.element_stiffness(scene.params)).compile()


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
      out.append(trajectories.episode(path, z, scene.feed, dt, repeats=3))
  return out


_WARNINGS = (mujoco.mjtWarning.mjWARN_CONTACTFULL, mujoco.mjtWarning.mjWARN_CNSTRFULL,
             mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
             mujoco.mjtWarning.mjWARN_BADQACC)


def _run_episode(model: mujoco.MjModel, data: mujoco.MjData, ep: trajectories.Episode):
  """Rolls one episode out from rest; returns (qpos (T, nq), sensordata (T, ns), seconds)."""
  t0 = time.perf_counter()
  mujoco.mj_resetData(model, data)
  data.qpos[model_lib.cnc_qpos_index(model)] = ep.target[0]
  data.ctrl[:] = ep.target[0]
  mujoco.mj_forward(model, data)
  spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
  state0 = np.empty(mujoco.mj_stateSize(model, spec))
  mujoco.mj_getState(model, data, state0, spec)
  state, sens = mujoco.rollout.rollout(model, data, state0, ep.target[None])
  for w in _WARNINGS:
    if data.warning[w].number:
      raise SimulationError(f"MuJoCo warning {w.name} in {ep.path} at z={ep.z_level * 1e3:.2f} "
                            f"mm: the step diverged or overflowed; lower the indentation or "
                            f"feed, or raise params.timestep resolution")
  qpos = state[0, :, 1:1 + model.nq]
  if not (np.isfinite(qpos).all() and np.isfinite(sens).all()):
    raise SimulationError(f"non-finite state in {ep.path} at z={ep.z_level * 1e3:.2f} mm")
  return qpos, sens[0], time.perf_counter() - t0


@dataclasses.dataclass(frozen=True)
class Timing:
  """Where the time went.

  Attributes:
    build: model compilation and die kernel (from cache or solved), s.
    simulate: wall time of the episodes over all threads, s.
    physics_cpu: summed per-thread time inside MuJoCo, s.
    sensor_chain_cpu: summed time from joint positions to counts (element forces, die
      kernel, transfer law, effects), s; compare with physics_cpu.
    steps: simulation steps.
    threads: worker threads.
  """
  build: float
  simulate: float
  physics_cpu: float
  sensor_chain_cpu: float
  steps: int
  threads: int


def element_couples(forces: np.ndarray, deflection: np.ndarray) -> np.ndarray:
  """(..., num_elements, 2) couples (N m, along x and y) of the `p_delta` effect: the normal
  force moved sideways by the shear deflection, the shear moved towards the PCB by the
  compression (the layer kernel measures a shear's lever from the undeformed face)."""
  return forces[..., 2:3] * deflection[..., :2] - forces[..., :2] * deflection[..., 2:3]


def simulate(scene: FootpadScene, progress: Optional[Progress] = None,
             threads: Optional[int] = None) -> tuple[recording.Recording, Timing]:
  """Runs the scene (no cache). `progress(done, total)` is called as episodes finish."""
  scene.validate()
  t0 = time.perf_counter()
  effects = check_effects(scene.effects, FOOTPAD_EFFECTS)
  model = compile_model(scene)
  kernel = layer.die_kernel(scene.params, scene.kernel)
  eps = episodes(scene, kernel)
  threads = threads or min(os.cpu_count() or 1, len(eps))
  datas = [mujoco.MjData(model) for _ in range(threads)]
  t1 = time.perf_counter()

  results: list = [None] * len(eps)
  free = list(range(threads))
  cnc_idx = model_lib.cnc_qpos_index(model)
  g = kernel.reshape(len(kernel), -1).T
  gc = None
  if "p_delta" in effects:
    couples = layer.couple_kernel(scene.params, scene.kernel)
    gc = couples.reshape(len(couples), -1).T

  def work(i: int):
    slot = free.pop()
    try:
      qpos, sens, physics = _run_episode(model, datas[slot], eps[i])
    finally:
      free.append(slot)
    t = time.perf_counter()
    forces, deflection = model_lib.element_state(model, scene.params, qpos)
    pressure = forces.reshape(len(forces), -1) @ g
    if gc is not None:
      pressure += element_couples(forces, deflection).reshape(len(forces), -1) @ gc
    chain = time.perf_counter() - t
    return i, (pressure, sens[:, :6], forces.sum(axis=1), qpos[:, cnc_idx], physics, chain)

  done = 0
  with concurrent.futures.ThreadPoolExecutor(threads) as pool:
    for fut in concurrent.futures.as_completed([pool.submit(work, i) for i in range(len(eps))]):
      i, res = fut.result()
      results[i] = res
      done += 1
      if progress:
        progress(done, len(eps))
  t2 = time.perf_counter()
  pressure, sens, force_sum, cnc = (np.concatenate([r[k] for r in results]) for k in range(4))
  counts, wrench = sensor_chain.apply(pressure, sens, effects, scene.seed, scene.adc)
  chain_cpu = sum(r[5] for r in results) + time.perf_counter() - t2
  physics_cpu = sum(r[4] for r in results)

  path_names = list(dict.fromkeys(ep.path for ep in eps))
  rec = recording.Recording(
      time=np.concatenate([np.arange(len(ep.target)) * scene.params.timestep for ep in eps]),
      counts=counts, pressure=pressure, wrench=wrench, element_force=force_sum, cnc=cnc,
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
  return rec, Timing(t1 - t0, t2 - t1, physics_cpu, chain_cpu, len(pressure), threads)


def versions() -> dict[str, str]:
  # "physics" changes whenever the model or sensor chain does, so stale cached recordings
  # are not reused: 2 = element rates from the bonded finite-element block; 3 = viscoelastic
  # in shear too.
  return {"mujoco": mujoco.__version__, "numpy": np.__version__, "recording_format": "1",
          "physics": "3"}


def cache_key(scene: FootpadScene) -> str:
  return recording.content_key({"scene": scene.config(), "versions": versions()})


def generate(scene: FootpadScene, progress: Optional[Progress] = None,
             use_cache: bool = True) -> tuple[recording.Recording, Optional[Timing]]:
  """The scene's recording, from the cache when an identical request was made before.

  Returns the recording and the timing of the simulation (None when loaded from the cache).
  """
  scene.validate()
  stem = recording.cache_dir() / "recordings" / f"footpad-{cache_key(scene)}"
  if use_cache and stem.with_suffix(".npz").exists() and stem.with_suffix(".json").exists():
    return recording.Recording.load(stem), None
  rec, timing = simulate(scene, progress)
  if use_cache:
    rec.save(stem)
  return rec, timing


def bare_step_rate(scene: FootpadScene, steps: int = 3000) -> float:
  """Steps/s of plain `mj_step` on the scene's model with sensors disabled, one thread,
  pressing at the deepest z level (the reference for `footpad_throughput`)."""
  model = compile_model(scene)
  model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SENSOR
  data = mujoco.MjData(model)
  z = max(scene.z_levels) if scene.z_levels else 0.001
  data.ctrl[:] = [0.0, 0.0, -z]
  for _ in range(200):
    mujoco.mj_step(model, data)
  t = time.perf_counter()
  for i in range(steps):
    data.ctrl[0] = 0.003 * math.sin(2 * math.pi * i / steps)
    mujoco.mj_step(model, data)
  return steps / (time.perf_counter() - t)
