"""The shell scene: hand-applied wrench sweeps on the spring-mounted shell, at 100 Hz frames.

A scene is declarative (`ShellScene`). `hand_loads` draws smooth random wrenches like the
paper's slow manual loading (about +-1 N and +-60 mN m in every axis, Sec. III-A); `simulate`
applies them to the shell through `xfrc_applied` with `mujoco.rollout` (one continuous
session per thread, each starting and ending at rest), and returns a `Recording` holding per
frame the shell's pose, each reflector's height above its sensor (closed form from the mount
joints), and the F/T body's reading (sign flipped to the wrench on the shell, tared at no
load) as truth. `generate` adds the on-disk cache. The other shell scenes (`drop`, `turn`,
`walk`) step their own rigs through `run_frames` and read the same board through `sense`.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import json
import os
import time
import warnings
from typing import Any, Callable, Literal, Optional

import mujoco
import mujoco.rollout
import numpy as np

from models import shell as model_lib

from util import fields
from util.fields import setting
from sim import physics, recording
from sim.shell import geometry, photointerrupter
from sim import effects as effects_lib
from sim.effects import active
from sim.shell import effects as fx
from sim.shell.effects import EFFECTS, EffectName

PAPER_FRAMES = {"calibration": 97526, "test": 42316}  # Sec. III-A
FRAME_RATE = 100.0  # Hz: the SkinProc's frame rate

Progress = Callable[[int, int], None]


@fields.declared
@dataclasses.dataclass(frozen=True)
class ShellScene:
  """Everything that determines a shell run.

  Attributes:
    params: shell, mount and layout.
    frames: 100 Hz frames to record (paper: 97526 calibration, 42316 test).
    steps_per_frame: physics steps per frame (1 ms steps at the default).
    force_range: largest hand force per axis, N (paper: about 1 N, Sec. III-A; its Table II
      ranges, 1.9-2.3 N peak to peak, put it at 0.95-1.15 N: the sourced range).
    torque_range: largest hand torque per axis, N m (paper: about 60 mN m, Sec. III-A; its
      Table II ranges, 96-138 mN m peak to peak, put it at 48-69 mN m: the sourced range).
    knot_interval: time between the hand's random targets, s (slow manual loading; assumed
      0.5 s).
    downward_bias: in [0, 1]; 0 draws Fz evenly in +-force_range, 1 only downward (the
      paper's calibration lacked upward forces, Sec. III-B).
    in_window: the hand backs off where the sensors would leave their 2-4 mm window: each
      random target is scaled down until its static pose keeps every height inside (the
      paper chose its load range "to prevent the sensor from saturating", Sec. III-A).
      False draws the targets from the full box.
    window_kept: with `in_window`, the share of the hand's targets it scales back into the
      window; the rest it pushes to where they were drawn. The paper says both that its hand
      kept the sensors from saturating (Sec. III-A: 1) and that its test loads spanned
      1.9-2.3 N and 96-138 mN m (Table II), which at this model's mount leave the window on
      94 % of frames: the sourced range is all of [0, 1], the default 1.
    loading: "hand" (the random sweeps) or "rest" (no load: noise and offsets alone).
    sessions: continuous loading sessions, run in parallel, each from rest to rest.
    sensor: the photointerrupters' response and the sizes of their effects.
    unit_seed: which physical board: draws the sensors' `unit_spread`, shared by the runs of
      one board (calibration and test) while `seed` draws their loads and noise.
    effects: names from `sim.shell.effects.EFFECTS`; by default the ones whose magnitude
      has a source (`ray_miss` waits on the real facet size: opt in with effects=...).
    seed: one integer for every random draw.
  """
  params: model_lib.ShellParams = model_lib.ShellParams()
  frames: int = setting(PAPER_FRAMES["calibration"], "[1, 1e7]")
  steps_per_frame: int = setting(10, "[1, 100]")
  force_range: float = setting(1.0, "(0, 5]", "N", sourced=fields.Sourced(0.95, 1.15))
  torque_range: float = setting(0.06, "(0, 0.3]", "N m", sourced=fields.Sourced(0.048, 0.069))
  knot_interval: float = setting(0.5, "[0.05, 10]", "s")
  downward_bias: float = setting(0.0, "[0, 1]")
  in_window: bool = True
  window_kept: float = setting(1.0, "[0, 1]", sourced=fields.Sourced(0.0, 1.0))
  loading: Literal["hand", "rest"] = "hand"
  sessions: int = setting(2, "[1, 64]")
  effects: tuple[EffectName, ...] = ("adc_quantisation", "out_of_window", "sensor_noise")
  sensor: photointerrupter.Photointerrupter = photointerrupter.Photointerrupter()
  unit_seed: int = setting(0, "[0, inf)")
  seed: int = setting(0, "[0, inf)")

  def unread(self, key: str) -> Optional[str]:
    """Why the setting `key` changes nothing under this scene's effects (None if it may)."""
    return effects_lib.unread(key, self.effects, EFFECTS)

  def relations(self) -> fields.Relations:
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    frame = self.params.timestep * self.steps_per_frame
    yield (abs(frame * FRAME_RATE - 1) <= 1e-9, "steps_per_frame",
           f"{1 / (FRAME_RATE * self.params.timestep):g} at params.timestep="
           f"{self.params.timestep} s: one 100 Hz frame", self.steps_per_frame)

  def validate(self) -> None:
    """Raise ValueError naming the first setting outside its allowed range."""
    fields.check(self)

  def spec(self, base: str = "ft", contacts: bool = False) -> mujoco.MjSpec:
    """The scene's rig (`models.shell.build_spec`) with the model effects it lists."""
    return model_lib.build_spec(self.params, base, contacts,
                                hysteresis=fx.SPRING_HYSTERESIS in active(self.effects, EFFECTS))


def frame_steps(timestep: float) -> int:
  """Physics steps per 100 Hz SkinProc frame."""
  return int(round(1 / (FRAME_RATE * timestep)))


def sense(scene: ShellScene, pose: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """What the board of `scene` reads at 100 Hz frames of mount joints `pose` (F, 6):
  (heights (F, 8), m, NaN for a missed facet under `ray_miss`; counts (F, 8) through the
  sensor chain with the scene's effects, noise drawn from `seed`)."""
  height = heights_from_pose(scene.params, pose, finite_facets=fx.RAY_MISS in active(scene.effects, EFFECTS))
  return height, photointerrupter.apply(height, scene.effects, seed, scene.sensor, FRAME_RATE,
                                        scene.unit_seed)


def hand_loads(scene: ShellScene, steps: int, rng: np.random.Generator,
               dt: Optional[float] = None) -> np.ndarray:
  """(steps, 6) smooth random wrench (N, N m) about the F/T site, one per physics step (or
  per `dt`, s, if given: the static path samples it at frames).

  Random targets every knot_interval, uniform in each axis's range, the first and last at
  rest. The hand moves from one target to the next along a quintic smoothstep (zero rate
  and acceleration at each target), the same blend for all six axes: every load on the way
  is a convex combination of two targets, so with `in_window` no static pose between them
  leaves the window either (heights are linear in small loads). A spline through the
  targets would overshoot them: measured, 7 % of frames then clip the ADC below 1.9 mm.
  """
  if scene.loading == "rest":
    return np.zeros((steps, 6))
  dt = scene.params.timestep if dt is None else dt
  n_knots = max(2, int(np.ceil(steps * dt / scene.knot_interval)) + 1)
  lim = np.array([scene.force_range] * 3 + [scene.torque_range] * 3)
  lo = -lim.copy()
  hi = lim.copy()
  # the bias moves the upper bound of Fz down towards 0 (only pushing down on the shell)
  hi[2] = scene.force_range * (1 - scene.downward_bias)
  knots = rng.uniform(lo, hi, (n_knots, 6))
  knots[0] = knots[-1] = 0.0
  if scene.in_window:
    scale = window_scale(scene.params, knots, scene.sensor)
    if scene.window_kept < 1:  # drawn only then: the default's loads stay as they were
      scale = np.where(rng.random(n_knots) < scene.window_kept, scale, 1.0)
    knots *= scale[:, None]
  u = np.arange(steps) * dt / (steps * dt) * (n_knots - 1)  # in knot intervals
  i = np.minimum(u.astype(int), n_knots - 2)
  tau = u - i
  blend = tau**3 * (10 - 15 * tau + 6 * tau**2)
  return knots[i] + (knots[i + 1] - knots[i]) * blend[:, None]


def static_pose(params: model_lib.ShellParams, wrench: np.ndarray) -> np.ndarray:
  """(..., 6) mount joints under a steady wrench (..., 6) about the F/T site, small angles."""
  w = np.asarray(wrench, float)
  site = np.array(model_lib.FT_SITE)
  # the same wrench about the elastic centre: M_c = M_site + (site - centre) x F
  m = w[..., 3:] + np.cross(site - model_lib.elastic_centre(params), w[..., :3])
  return np.concatenate([w[..., :3], m], axis=-1) / model_lib.mount_stiffness(params)


def window_scale(params: model_lib.ShellParams, wrench: np.ndarray,
                 sensor: photointerrupter.Photointerrupter, tol: float = 2.0**-30
                 ) -> np.ndarray:
  """(K,) largest factor in [0, 1] keeping every static height inside the sensor's window,
  to within `tol`; the returned factor itself keeps them inside.

  Along a ray of small loads the heights are monotonic, so the worst excess over the window,
  g(s) = max_j max(low - h_j, h_j - high), crosses 0 once between the rest (g < 0) and the
  full load. The heights are nearly linear in s: regula falsi with the Illinois rule finds
  the crossing in about 6 evaluations where bisection needs 30 (measured on the paper's
  load box), and keeps the bracket, so the inside end is returned.
  """
  low, high = sensor.window

  def excess(w, s):
    h = heights_from_pose(params, static_pose(params, w * s[:, None]))
    return np.max(np.maximum(low - h, h - high), axis=1)

  g1 = excess(wrench, np.ones(len(wrench)))
  out = np.ones(len(wrench))
  todo = np.flatnonzero(g1 > 0)  # only the loads that leave the window need the search
  w = wrench[todo]
  lo, hi = np.zeros(len(w)), np.ones(len(w))
  g_lo, g_hi = excess(w, lo), g1[todo]
  side = np.zeros(len(w), int)  # which end moved last: -1 low, +1 high
  for _ in range(100):
    open_ = hi - lo > tol
    if not open_.any():
      break
    k = np.flatnonzero(open_)
    # the secant's root, kept off the ends so that the bracket always shrinks
    s = (lo[k] * g_hi[k] - hi[k] * g_lo[k]) / (g_hi[k] - g_lo[k])
    margin = 0.01 * (hi[k] - lo[k])
    s = np.clip(s, lo[k] + margin, hi[k] - margin)
    g = excess(w[k], s)
    ok = g <= 0
    # Illinois: an end that stays put twice running has its value halved
    g_hi[k] = np.where(ok & (side[k] == -1), g_hi[k] / 2, g_hi[k])
    g_lo[k] = np.where(~ok & (side[k] == 1), g_lo[k] / 2, g_lo[k])
    lo[k], g_lo[k] = np.where(ok, s, lo[k]), np.where(ok, g, g_lo[k])
    hi[k], g_hi[k] = np.where(ok, hi[k], s), np.where(ok, g_hi[k], g)
    side[k] = np.where(ok, -1, 1)
  out[todo] = lo
  return out


def heights_from_pose(params: model_lib.ShellParams, pose: np.ndarray,
                      finite_facets: bool = False) -> np.ndarray:
  """(..., 8) heights from mount joint positions (..., 6): the closed form of the joint chain
  (slides, then hinges about x, turned y, turned z through the elastic centre); with
  finite_facets, NaN where a sensor looks past its facet (`geometry.heights`)."""
  return geometry.pose_heights(params, pose, model_lib.elastic_centre(params), finite_facets)


def _xfrc(model: mujoco.MjModel, data: mujoco.MjData, wrench: np.ndarray) -> np.ndarray:
  """(T, nbody * 6) xfrc_applied putting `wrench` (about the F/T site) on the shell."""
  mujoco.mj_forward(model, data)
  com = data.body("shell").xipos
  site = data.site("ft").xpos
  out = np.zeros((len(wrench), model.nbody, 6))
  b = model.body("shell").id
  out[:, b, :3] = wrench[:, :3]
  # the same wrench about the shell's centre of mass: M_com = M_site + (site - com) x F
  out[:, b, 3:] = wrench[:, 3:] + np.cross(site - com, wrench[:, :3])
  return out.reshape(len(wrench), -1)


def simulate(scene: ShellScene, progress: Optional[Progress] = None,
             threads: Optional[int] = None) -> tuple[recording.Recording, recording.Timing]:
  """Runs the scene's sessions in parallel (no cache); `progress(done, total)` per finished
  chunk. Returns the frames as a `Recording` and where the time went."""
  scene.validate()
  _warn_rank(scene)
  t_build = time.perf_counter()
  model = compile_checked(scene.spec(), "shell calibration", scene.params)
  per_session = np.diff(np.linspace(0, scene.frames, scene.sessions + 1).astype(int))
  seqs = np.random.SeedSequence(scene.seed).spawn(scene.sessions)
  threads = threads or min(os.cpu_count() or 1, scene.sessions)
  spf = scene.steps_per_frame
  q_adr = model_lib.mount_qpos_index(model)
  sens = [model.sensor("ft_force").adr[0], model.sensor("ft_torque").adr[0]]
  state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
  chunk_frames = 5000
  total_chunks = int(sum(np.ceil(per_session / chunk_frames)))
  done = [0]

  def run_session(i: int):
    t_session = time.perf_counter()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    tare = np.concatenate([data.sensordata[sens[0]:sens[0] + 3],
                           data.sensordata[sens[1]:sens[1] + 3]])
    state = np.empty(mujoco.mj_stateSize(model, state_spec))
    mujoco.mj_getState(model, data, state, state_spec)
    loads = hand_loads(scene, int(per_session[i]) * spf, np.random.default_rng(seqs[i]))
    xfrc = _xfrc(model, data, loads)
    poses, ft = [], []
    for start in range(0, len(loads), chunk_frames * spf):
      ctrl = xfrc[start:start + chunk_frames * spf]
      st, sd = mujoco.rollout.rollout(model, data, state, ctrl[None],
                                      control_spec=mujoco.mjtState.mjSTATE_XFRC_APPLIED)
      physics.check(data, f"shell calibration, session {i}", HINT, times=st[0, :, 0],
                    values=(st, sd))
      state = st[0, -1]
      # the frame is the state after each frame's last step
      poses.append(st[0, spf - 1::spf, 1:1 + model.nq][:, q_adr])
      raw = np.concatenate([sd[0, spf - 1::spf, sens[0]:sens[0] + 3],
                            sd[0, spf - 1::spf, sens[1]:sens[1] + 3]], axis=1)
      ft.append(-(raw - tare))  # child-to-parent reading, flipped to the shell side
      done[0] += 1
      if progress:
        progress(done[0], total_chunks)
    return (np.concatenate(poses), np.concatenate(ft), loads[spf - 1::spf],
            time.perf_counter() - t_session)

  t0 = time.perf_counter()
  with concurrent.futures.ThreadPoolExecutor(threads) as pool:
    parts = list(pool.map(run_session, range(scene.sessions)))
  t1 = time.perf_counter()
  pose = np.concatenate([p[0] for p in parts])
  height, counts = sense(scene, pose, scene.seed)
  out, bottomed = _shares(scene, pose, height)
  _warn_bottomed(scene, bottomed)
  time_in_session = np.concatenate([np.arange(1, len(p[0]) + 1) / FRAME_RATE for p in parts])
  rec = recording.Recording(
      time=time_in_session, counts=counts, wrench=np.concatenate([p[1] for p in parts]),
      episode=np.concatenate([np.full(len(p[0]), i, np.int32) for i, p in enumerate(parts)]),
      height=height, pose=pose, applied=np.concatenate([p[2] for p in parts]),
      meta=json.loads(json.dumps({
          "scene": "shell", "config": config(scene), "effects": list(scene.effects),
          "seed": scene.seed, "sensors": "GP2S60 x8", "out_of_window": out,
          "bottomed": bottomed,
          "units": {"counts": "ADC counts", "wrench": "N, N m", "height": "m",
                    "pose": "m, rad", "applied": "N, N m", "time": "s"},
          "versions": versions()})))
  timing = recording.Timing(build=t0 - t_build, simulate=t1 - t0,
                            physics_cpu=sum(p[3] for p in parts),
                            sensor_chain_cpu=time.perf_counter() - t1,
                            steps=int(per_session.sum()) * spf, threads=threads)
  return rec, timing


def simulate_static(scene: ShellScene) -> recording.Recording:
  """The static path: the scene's hand loads at 100 Hz frames, each held long enough for the
  shell to settle at `static_pose` (the mount's stiffness, no dynamics), read through the
  board's sensors with the scene's signal effects. Model effects (`spring_hysteresis`) have
  no static counterpart and are ignored. Loads and noise are drawn from `scene.seed`; the
  wrench is the applied one, which a tared F/T body reads at rest.
  """
  scene.validate()
  loads = hand_loads(scene, scene.frames, np.random.default_rng(scene.seed), 1 / FRAME_RATE)
  pose = static_pose(scene.params, loads)
  height, counts = sense(scene, pose, scene.seed)
  out, bottomed = _shares(scene, pose, height)
  return recording.Recording(
      time=np.arange(1, scene.frames + 1) / FRAME_RATE, counts=counts, wrench=loads,
      episode=np.zeros(scene.frames, np.int32), height=height, pose=pose, applied=loads,
      meta={"scene": "shell", "path": "static", "config": config(scene),
            "effects": list(scene.effects), "seed": scene.seed,
            "out_of_window": out, "bottomed": bottomed})


def frame_shares(sensor: photointerrupter.Photointerrupter, height: np.ndarray
                 ) -> tuple[float, float]:
  """(share of frames (rows of `height` (F, 8), m) with every sensor inside its window,
  share with a reflector at or into the PCB)."""
  # over the sensors of each frame, on the transposed heights: numpy reduces eight
  # contiguous rows about 8x faster than the eight short columns of each frame
  h = np.ascontiguousarray(np.asarray(height, float).T)
  inside = np.logical_and.reduce(sensor.in_window(h), axis=0)
  return float(np.mean(inside)), float(np.mean(np.logical_or.reduce(h <= 0.0, axis=0)))


def _shares(scene: ShellScene, pose: np.ndarray, height: np.ndarray) -> tuple[float, float]:
  """(share of frames out of the window, share bottomed) of a run; a missed facet is no
  contact, so bottoming is judged on the unbounded facet planes."""
  inside, bottomed = frame_shares(scene.sensor, height)
  if fx.RAY_MISS in active(scene.effects, EFFECTS):
    bottomed = frame_shares(scene.sensor, heights_from_pose(scene.params, pose))[1]
  return 1.0 - inside, bottomed


def _warn_rank(scene: ShellScene) -> None:
  quality = geometry.map_quality(geometry.height_jacobian(scene.params))
  if quality.rank < 6:
    warnings.warn(f"slopes c_x={scene.params.slope_x}, c_y={scene.params.slope_y} give a height "
                  f"map of rank {quality.rank}: the sensors cannot see "
                  f"{'; '.join(quality.lost)}", stacklevel=3)


def _warn_bottomed(scene: ShellScene, bottomed: float) -> None:
  if bottomed > 0:
    warnings.warn(f"{bottomed:.1%} of frames drive a reflector into the PCB (the shell would "
                  f"hit the chassis, which is not simulated): lower force_range "
                  f"({scene.force_range} N) or torque_range ({scene.torque_range} N m)",
                  stacklevel=3)


def config(scene: ShellScene) -> dict:
  """JSON-able description (the cache key and the recording's metadata)."""
  return json.loads(json.dumps(dataclasses.asdict(scene)))


def versions() -> dict[str, str]:
  # "physics" changes whenever the model or the sensor chain does, so stale cached
  # recordings are not reused.
  # 2 = heights through the matrix form of the closed form (equal to 1e-18 m)
  # 3 = window_scale by regula falsi (hand loads within 1e-9 of the bisection's)
  return {"mujoco": mujoco.__version__, "numpy": np.__version__, "recording_format": "2",
          "physics": "3"}


def generate(scene: ShellScene, progress: Optional[Progress] = None, use_cache: bool = True
             ) -> tuple[recording.Recording, Optional[recording.Timing]]:
  """The scene's recording, from the cache when an identical request was made before.

  Returns the recording and the timing of the simulation (None when loaded from the cache).
  """
  scene.validate()
  rec, timing = recording.generate("shell", {"scene": config(scene), "versions": versions()},
                                   lambda: simulate(scene, progress), use_cache)
  if timing is None:  # from the cache: the warnings its simulation gave
    _warn_rank(scene)
    _warn_bottomed(scene, rec.meta["bottomed"])
  return rec, timing


def run_frames(scene: str, model: mujoco.MjModel, data: mujoco.MjData, steps: int, every: int,
               before_step: Optional[Callable[[int], None]] = None,
               read: Optional[Callable[[], Any]] = None) -> tuple[np.ndarray, list]:
  """The step-and-read loop of the shell's free-running scenes (drop, turn, walk).

  Steps the model `steps` times from its current state; before step i, `before_step(i)` sets
  whatever the scene drives (controls, gravity, a released mass). After every `every`-th step
  it records the mount joints and, if given, `read()` (contacts, the base's pose), and checks
  that the physics held (`sim.physics.check`; `scene` names the run in the error).

  Returns:
    (steps // every, 6) mount joints (m, rad) and the list of `read()` values.
  """
  adr = model_lib.mount_qpos_index(model)
  poses, extra = [], []
  t0, dt = float(data.time), model.opt.timestep
  for i in range(steps):
    if before_step is not None:
      before_step(i)
    mujoco.mj_step(model, data)
    if i % every == every - 1:
      poses.append(data.qpos[adr].copy())
      physics.check(data, scene, HINT, (t0 + (i + 1 - every) * dt, t0 + (i + 1) * dt),
                    poses[-1:])
      if read is not None:
        extra.append(read())
  return np.array(poses).reshape(-1, 6), extra


HINT = "lower params.spring_rate or the loads, or params.timestep"


def compile_checked(spec: mujoco.MjSpec, scene: str, params: model_lib.ShellParams
                    ) -> mujoco.MjModel:
  """The compiled rig, refused if its spring mount is too stiff for its step
  (`sim.physics.check_explicit_springs`)."""
  model = spec.compile()
  dofs = model.jnt_dofadr[[model.joint(f"mount_{n}").id for n in model_lib.MOUNT_JOINTS]]
  physics.check_explicit_springs(model, dofs, scene,
                                 f"params.spring_rate={params.spring_rate:g} N/m")
  return model
