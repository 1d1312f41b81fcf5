"""The shell scene: hand-applied wrench sweeps on the spring-mounted shell, at 100 Hz frames.

A scene is declarative (`ShellScene`). `hand_loads` draws smooth random wrenches like the
paper's slow manual loading (about +-1 N and +-60 mN m in every axis, Sec. III-A); `simulate`
applies them to the shell through `xfrc_applied` with `mujoco.rollout` (one continuous
session per thread, each starting and ending at rest), and returns per frame the shell's
pose, each reflector's height above its sensor (closed form from the mount joints), and the
F/T body's reading (sign flipped to the wrench on the shell, tared at no load) as truth.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import os
import time
import warnings
from typing import Callable, Optional

import mujoco
import mujoco.rollout
import numpy as np

from models import shell as model_lib
from sim import photointerrupter, recording, shell_geometry
from sim.effects import SHELL_EFFECTS, check_effects
from sim.settings import require

PAPER_FRAMES = {"calibration": 97526, "test": 42316}  # Sec. III-A
FRAME_RATE = 100.0  # Hz: the SkinProc's frame rate

Progress = Callable[[int, int], None]


@dataclasses.dataclass(frozen=True)
class ShellScene:
  """Everything that determines a shell run.

  Attributes:
    params: shell, mount and layout.
    frames: 100 Hz frames to record (paper: 97526 calibration, 42316 test).
    steps_per_frame: physics steps per frame (1 ms steps at the default).
    force_range: largest hand force per axis, N (paper: about 1 N).
    torque_range: largest hand torque per axis, N m (paper: about 60 mN m).
    knot_interval: time between the hand's random targets, s (slow manual loading; assumed
      0.5 s).
    downward_bias: in [0, 1]; 0 draws Fz evenly in +-force_range, 1 only downward (the
      paper's calibration lacked upward forces, Sec. III-B).
    in_window: the hand backs off where the sensors would leave their 2-4 mm window: each
      random target is scaled down until its static pose keeps every height inside (the
      paper chose its load range "to prevent the sensor from saturating", Sec. III-A).
      False draws the targets from the full box.
    loading: "hand" (the random sweeps) or "rest" (no load: noise and offsets alone).
    sessions: continuous loading sessions, run in parallel, each from rest to rest.
    sensor: the photointerrupters' response and the sizes of their effects.
    unit_seed: which physical board: draws the sensors' `unit_spread`, shared by the runs of
      one board (calibration and test) while `seed` draws their loads and noise.
    effects: names from `sim.effects.SHELL_EFFECTS`; by default the ones whose magnitude
      has a source (`ray_miss` waits on the real facet size: opt in with effects=...).
    seed: one integer for every random draw.
  """
  params: model_lib.ShellParams = model_lib.ShellParams()
  frames: int = PAPER_FRAMES["calibration"]
  steps_per_frame: int = 10
  force_range: float = 1.0
  torque_range: float = 0.06
  knot_interval: float = 0.5
  downward_bias: float = 0.0
  in_window: bool = True
  loading: str = "hand"
  sessions: int = 2
  effects: tuple[str, ...] = ("adc_quantisation", "out_of_window", "sensor_noise")
  sensor: photointerrupter.Photointerrupter = photointerrupter.Photointerrupter()
  unit_seed: int = 0
  seed: int = 0

  def validate(self) -> None:
    self.params.validate()
    self.sensor.validate()
    check_effects(self.effects, SHELL_EFFECTS)
    require(1 <= self.frames <= 10**7, "frames", "[1, 1e7]", self.frames)
    require(1 <= self.steps_per_frame <= 100, "steps_per_frame", "[1, 100]",
            self.steps_per_frame)
    require(0 < self.force_range <= 5, "force_range", "(0, 5] N", self.force_range)
    require(0 < self.torque_range <= 0.3, "torque_range", "(0, 0.3] N m", self.torque_range)
    require(0.05 <= self.knot_interval <= 10, "knot_interval", "[0.05, 10] s",
            self.knot_interval)
    require(0 <= self.downward_bias <= 1, "downward_bias", "[0, 1]", self.downward_bias)
    require(1 <= self.sessions <= 64, "sessions", "[1, 64]", self.sessions)
    require(self.loading in ("hand", "rest"), "loading", "'hand' or 'rest'", self.loading)
    require(int(self.seed) == self.seed and self.seed >= 0, "seed", "integers >= 0", self.seed)
    dt = self.params.timestep * self.steps_per_frame
    if abs(dt * FRAME_RATE - 1) > 1e-9:
      raise ValueError(f"timestep x steps_per_frame = {dt} s: must be one 100 Hz frame")

  def spec(self, base: str = "ft", contacts: bool = False) -> mujoco.MjSpec:
    """The scene's rig (`models.shell.build_spec`) with the model effects it lists."""
    return model_lib.build_spec(self.params, base, contacts,
                                hysteresis="spring_hysteresis" in self.effects)


def frame_steps(timestep: float) -> int:
  """Physics steps per 100 Hz SkinProc frame."""
  return int(round(1 / (FRAME_RATE * timestep)))


def sense(scene: ShellScene, pose: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """What the board of `scene` reads at 100 Hz frames of mount joints `pose` (F, 6):
  (heights (F, 8), m, NaN for a missed facet under `ray_miss`; counts (F, 8) through the
  sensor chain with the scene's effects, noise drawn from `seed`)."""
  height = heights_from_pose(scene.params, pose, finite_facets="ray_miss" in scene.effects)
  return height, photointerrupter.apply(height, scene.effects, seed, scene.sensor, FRAME_RATE,
                                        scene.unit_seed)


def hand_loads(scene: ShellScene, steps: int, rng: np.random.Generator) -> np.ndarray:
  """(steps, 6) smooth random wrench (N, N m) about the F/T site, one per physics step.

  Random targets every knot_interval, uniform in each axis's range, the first and last at
  rest. The hand moves from one target to the next along a quintic smoothstep (zero rate
  and acceleration at each target), the same blend for all six axes: every load on the way
  is a convex combination of two targets, so with `in_window` no static pose between them
  leaves the window either (heights are linear in small loads). A spline through the
  targets would overshoot them: measured, 7 % of frames then clip the ADC below 1.9 mm.
  """
  if scene.loading == "rest":
    return np.zeros((steps, 6))
  dt = scene.params.timestep
  n_knots = max(2, int(np.ceil(steps * dt / scene.knot_interval)) + 1)
  lim = np.array([scene.force_range] * 3 + [scene.torque_range] * 3)
  lo = -lim.copy()
  hi = lim.copy()
  # the bias moves the upper bound of Fz down towards 0 (only pushing down on the shell)
  hi[2] = scene.force_range * (1 - scene.downward_bias)
  knots = rng.uniform(lo, hi, (n_knots, 6))
  knots[0] = knots[-1] = 0.0
  if scene.in_window:
    knots *= _window_scale(scene.params, knots, scene.sensor)[:, None]
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


def _window_scale(params: model_lib.ShellParams, wrench: np.ndarray,
                  sensor: photointerrupter.Photointerrupter) -> np.ndarray:
  """(K,) largest factor in [0, 1] keeping every static height inside the sensor's window,
  by bisection (the heights are monotonic along a ray of small loads)."""
  def inside(s):
    h = heights_from_pose(params, static_pose(params, wrench * s[:, None]))
    return np.all(sensor.in_window(h), axis=1)
  lo, hi = np.zeros(len(wrench)), np.ones(len(wrench))
  full = inside(hi)
  for _ in range(30):
    mid = (lo + hi) / 2
    ok = inside(mid)
    lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
  return np.where(full, 1.0, lo)


@dataclasses.dataclass(frozen=True)
class ShellRun:
  """Frames of a shell run.

  Attributes:
    pose: (F, 6) mount joints: shell displacement (m) and hinge angles (rad).
    height: (F, 8) reflector heights above P1..P8, m; NaN where a sensor looks past its
      facet (`ray_miss`).
    counts: (F, 8) photointerrupter counts with the scene's effects.
    wrench: (F, 6) F/T truth: force (N) and torque about the F/T site (N m) on the shell side,
      tared at no load.
    applied: (F, 6) the hand's wrench about the F/T site, N and N m.
    session: (F,) index of the continuous session.
    seconds: wall time of the physics, s.  steps: physics steps.
    out_of_window: share of frames with any height outside the sensor's 2-4 mm window (or
      missed).
    bottomed: share of frames with any reflector at or below the PCB (the shell would hit the
      chassis; that contact is not simulated).
  """
  pose: np.ndarray
  height: np.ndarray
  counts: np.ndarray
  wrench: np.ndarray
  applied: np.ndarray
  session: np.ndarray
  seconds: float
  steps: int
  out_of_window: float
  bottomed: float


def heights_from_pose(params: model_lib.ShellParams, pose: np.ndarray,
                      finite_facets: bool = False) -> np.ndarray:
  """(..., 8) heights from mount joint positions (..., 6): the closed form of the joint chain
  (slides, then hinges about x, turned y, turned z through the elastic centre); with
  finite_facets, NaN where a sensor looks past its facet (`shell_geometry.heights`)."""
  return shell_geometry.pose_heights(params, pose, model_lib.elastic_centre(params),
                                    finite_facets)


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
             threads: Optional[int] = None) -> ShellRun:
  """Runs the scene's sessions in parallel; `progress(done, total)` per finished chunk."""
  scene.validate()
  quality = shell_geometry.map_quality(shell_geometry.height_jacobian(scene.params))
  if quality.rank < 6:
    warnings.warn(f"slopes c_x={scene.params.slope_x}, c_y={scene.params.slope_y} give a height "
                  f"map of rank {quality.rank}: the sensors cannot see "
                  f"{'; '.join(quality.lost)}", stacklevel=2)
  model = scene.spec().compile()
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
      state = st[0, -1]
      # the frame is the state after each frame's last step
      poses.append(st[0, spf - 1::spf, 1:1 + model.nq][:, q_adr])
      raw = np.concatenate([sd[0, spf - 1::spf, sens[0]:sens[0] + 3],
                            sd[0, spf - 1::spf, sens[1]:sens[1] + 3]], axis=1)
      ft.append(-(raw - tare))  # child-to-parent reading, flipped to the shell side
      done[0] += 1
      if progress:
        progress(done[0], total_chunks)
    if not np.isfinite(state).all():
      raise RuntimeError(f"session {i}: the shell's state became non-finite")
    return np.concatenate(poses), np.concatenate(ft), loads[spf - 1::spf]

  t0 = time.perf_counter()
  with concurrent.futures.ThreadPoolExecutor(threads) as pool:
    parts = list(pool.map(run_session, range(scene.sessions)))
  seconds = time.perf_counter() - t0
  pose = np.concatenate([p[0] for p in parts])
  height, counts = sense(scene, pose, scene.seed)
  out = float(np.mean(~np.all(scene.sensor.in_window(height), axis=1)))
  # a missed facet is no contact: bottoming is judged on the unbounded facet planes
  unbounded = height if "ray_miss" not in scene.effects else heights_from_pose(scene.params,
                                                                               pose)
  bottomed = float(np.mean(np.any(unbounded <= 0.0, axis=1)))
  if bottomed > 0:
    warnings.warn(f"{bottomed:.1%} of frames drive a reflector into the PCB (the shell would "
                  f"hit the chassis, which is not simulated): lower force_range "
                  f"({scene.force_range} N) or torque_range ({scene.torque_range} N m)",
                  stacklevel=2)
  return ShellRun(pose=pose, height=height, counts=counts,
                  wrench=np.concatenate([p[1] for p in parts]),
                  applied=np.concatenate([p[2] for p in parts]),
                  session=np.concatenate([np.full(len(p[0]), i, np.int32)
                                          for i, p in enumerate(parts)]),
                  seconds=seconds, steps=int(per_session.sum()) * spf, out_of_window=out,
                  bottomed=bottomed)


def to_recording(run: ShellRun, scene: ShellScene) -> recording.Recording:
  """The run as a `Recording` (the type every calibrator and file takes), 100 Hz frames."""
  per = np.bincount(run.session)
  t = np.concatenate([np.arange(1, n + 1) / FRAME_RATE for n in per])
  config = dataclasses.asdict(scene)
  return recording.Recording(
      time=t, counts=run.counts, wrench=run.wrench, episode=run.session, height=run.height,
      pose=run.pose,
      meta={"scene": "shell", "config": config, "effects": list(scene.effects),
            "seed": scene.seed, "sensors": "GP2S60 x8",
            "out_of_window": run.out_of_window, "bottomed": run.bottomed,
            "units": {"counts": "ADC counts", "wrench": "N, N m", "height": "m",
                      "pose": "m, rad", "time": "s"},
            "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__,
                         "recording_format": "1"}})
