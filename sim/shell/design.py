"""What a shell design is worth before any calibration: the linear map from wrench to counts,
the wrench resolution the sensors' noise leaves, and how much of a load box keeps every
sensor in its window. All on the static path (poses from the mount's stiffness, no
dynamics), in closed form; `objective` is the same in JAX, differentiable in the reflector
slopes and the gap, for the gradient search of `reflector_slope_sweep`.
"""

from __future__ import annotations

import dataclasses
import numpy as np

from models import shell as model_lib

from util import fields
from util.fields import setting
from sim.shell import geometry, paper, photointerrupter, scene as scene_lib

AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
# The paper's load box (Table II ranges, N and N m), centred on zero.
PAPER_RANGE = np.array([paper.TABLE2[a][0] for a in AXES])
# The paper's Table II resolutions (N and N m): each axis's scale in `objective`.
PAPER_RESOLUTION = np.array([paper.TABLE2[a][1] for a in AXES])
# The ShellParams fields that hold one number: the axes a sweep can take.
AXIS_FIELDS = tuple(f.name for f in dataclasses.fields(model_lib.ShellParams)
                    if fields.types_of(model_lib.ShellParams)[f.name] is float)
# The continuous axes `objective` differentiates.
SEARCH_FIELDS = ("slope_x", "slope_y", "gap")
# `objective`: weight of the in-window range's shortfall against the paper's half ranges
# (in decades) against the mean resolution (in decades). Above 1, a design that buys
# resolution by narrowing its range below the paper's loads loses more than it gains.
WINDOW_WEIGHT = 2.0
# `objective`: sharpness of the smooth hinge and of the smooth maximum over sensors.
HINGE_SHARPNESS = 20.0
MAX_NORM = 16


def _sweep_axes_class():
  """SweepAxes: one tuple field per ShellParams number, with that field's range and unit."""
  spec, lines = [], []
  grid = tuple(float(v) for v in np.round(np.linspace(0.0, 1.5, 12), 6))
  for f in dataclasses.fields(model_lib.ShellParams):
    if f.name in AXIS_FIELDS:
      default = grid if f.name in ("slope_x", "slope_y") else ()
      spec.append((f.name, tuple[float, ...], setting(
          default, str(f.metadata["interval"]), f.metadata["unit"], length=(0, 64))))
      lines.append(f"    {f.name}: values of params.{f.name} to sweep (none: the board's).")
  cls = dataclasses.make_dataclass("SweepAxes", spec, frozen=True)
  cls.__module__ = __name__
  cls.__qualname__ = "SweepAxes"
  cls.__doc__ = ("The axes of a design grid: every combination of the listed values.\n\n"
                 "  Attributes:\n" + "\n".join(lines) + "\n  ")
  return fields.declared(cls)


SweepAxes = _sweep_axes_class()


@fields.declared
@dataclasses.dataclass(frozen=True)
class SlopeSweep:
  """Settings of a design sweep.

  Attributes:
    board: the design every grid point starts from, with its loading, sensors and effects.
    sweep: the axes of the grid (default: slope_x and slope_y, 0 to 1.5 in 12 steps).
    confirm: how many designs also run the full MuJoCo scene: the best three on the static
      path and the rest spread evenly over the ranked table.
    search: run the gradient search over the swept continuous axes (slopes, gap).
    box_samples: loads drawn uniformly in the paper's box (Table II ranges) for the window
      shares.
  """
  board: scene_lib.ShellScene = scene_lib.ShellScene()
  sweep: SweepAxes = SweepAxes()
  confirm: int = setting(8, "[0, 50]")
  search: bool = True
  box_samples: int = setting(20000, "[100, 1e6]")

  def axes(self) -> dict[str, tuple[float, ...]]:
    """{field: values} of the swept axes."""
    return {f.name: getattr(self.sweep, f.name) for f in dataclasses.fields(self.sweep)
            if getattr(self.sweep, f.name)}

  def designs(self) -> list[dict[str, float]]:
    """Every combination of the swept values, as {field: value}, the last axis fastest."""
    axes = self.axes()
    if not axes:
      return []
    grid = np.meshgrid(*axes.values(), indexing="ij")
    return [{name: float(g.flat[k]) for name, g in zip(axes, grid)}
            for k in range(grid[0].size)]

  def relations(self) -> fields.Relations:
    yield bool(self.axes()), "sweep", "at least one axis with values (e.g. sweep.slope_x=0,0.5)", ()


def pose_per_wrench(xp, params: model_lib.ShellParams, gap=None):
  """(6, 6) mount joints per unit wrench about the F/T site (`scene.static_pose`: the wrench
  moved to the elastic centre, over the mount's stiffness); `gap` may be a variable of xp."""
  gap = params.gap if gap is None else gap
  centre_z = model_lib.elastic_centre(params)[2] - params.gap + gap
  d = [model_lib.FT_SITE[0], model_lib.FT_SITE[1], model_lib.FT_SITE[2] - centre_z]
  zero = 0.0 * centre_z
  cross = xp.stack([xp.stack([zero, -d[2], d[1] + zero]),  # [d]x, so that d x F = [d]x F
                    xp.stack([d[2], zero, -d[0] + zero]),
                    xp.stack([-d[1] + zero, d[0] + zero, zero])])
  eye = xp.eye(3)
  t = xp.concatenate([xp.concatenate([eye, 0.0 * eye], axis=1),
                      xp.concatenate([cross, eye], axis=1)], axis=0)
  return t / xp.asarray(model_lib.mount_stiffness(params))[:, None]


def height_map(params: model_lib.ShellParams) -> np.ndarray:
  """(8, 6) reflector heights per unit wrench (m per N, N m) at rest, static path."""
  jac = geometry.height_jacobian(params, centre=model_lib.elastic_centre(params))
  return jac @ pose_per_wrench(np, params)


def count_map(params: model_lib.ShellParams, sensor: photointerrupter.Photointerrupter
              ) -> np.ndarray:
  """(8, 6) counts per unit wrench (N, N m) at rest: the 1/r law's slope at the gap (its
  near-field factor differs from 1 by < 1e-7 above 2 mm) times `height_map`."""
  return -sensor.a / params.gap**2 * height_map(params)


def in_window_range(xp, heights_per_wrench, gap, window, p=None):
  """(6,) load along each axis alone (N, N m) at which the first sensor leaves the window,
  linearised at rest from (8, 6) heights per wrench; with p, the maximum over sensors is a
  p-norm (smooth). On the default design it is up to 34 % above `window_range` (Fy; the
  exact one: the tilt a lateral load brings turns the sloped facets, measured), but smooth
  in the design: the objective's term."""
  margin = xp.minimum(window[1] - gap, gap - window[0])
  col = xp.abs(heights_per_wrench)
  worst = xp.max(col, axis=0) if p is None else xp.sum(col**p, axis=0) ** (1.0 / p)
  with np.errstate(divide="ignore"):  # an axis no sensor sees has an unbounded range
    return margin / worst


def resolution(params: model_lib.ShellParams, sensor: photointerrupter.Photointerrupter,
               noise: float = 1.0) -> np.ndarray:
  """(6,) standard deviation of each wrench axis (N, N m) estimated by least squares from
  counts with white noise of `noise` counts rms per sensor; inf on axes the sensors cannot
  see."""
  a = count_map(params, sensor)
  u, s, vt = np.linalg.svd(a, full_matrices=False)
  keep = s > 1e-9 * s[0]
  sd = noise * np.sqrt(np.sum((vt[keep].T / s[keep]) ** 2, axis=1))
  lost = np.any(np.abs(vt[~keep]) > 1e-6, axis=0)
  return np.where(lost, np.inf, sd)


def window_range(params: model_lib.ShellParams, sensor: photointerrupter.Photointerrupter
                 ) -> np.ndarray:
  """(6,) the exact static load along each axis alone (N, N m), in either direction, at which
  the first sensor leaves its window (bisection on the closed form, `scene.window_scale`)."""
  linear = in_window_range(np, height_map(params), params.gap, sensor.window)
  reach = np.where(np.isfinite(linear), 4 * linear, 1e3)
  loads = np.concatenate([np.diag(reach), -np.diag(reach)])
  scale = scene_lib.window_scale(params, loads, sensor)
  return np.minimum(scale[:6], scale[6:]) * reach


def box_loads(samples: int, seed: int, box: np.ndarray = PAPER_RANGE) -> np.ndarray:
  """(samples, 6) wrenches drawn uniformly in the box of full ranges `box`, centred on 0."""
  rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7,)))
  return rng.uniform(-0.5, 0.5, (samples, 6)) * box


def window_shares(params: model_lib.ShellParams, sensor: photointerrupter.Photointerrupter,
                  loads: np.ndarray) -> tuple[float, float]:
  """(share of `loads` whose static pose keeps every sensor in its window, share that drives
  a reflector to or into the PCB)."""
  return scene_lib.frame_shares(
      sensor, scene_lib.heights_from_pose(params, scene_lib.static_pose(params, loads)))


def objective_terms(xp, sd, window_range):
  """The design objective from the per-axis resolution sd (6,) and in-window range (6,), in
  the array module xp (see `objective`)."""
  short = xp.log10(xp.asarray(PAPER_RANGE / 2) / window_range)
  hinge = xp.logaddexp(0.0, HINGE_SHARPNESS * short) / HINGE_SHARPNESS
  return (xp.mean(xp.log10(sd / xp.asarray(PAPER_RESOLUTION)))
          + WINDOW_WEIGHT * xp.mean(hinge))


def objective(params: model_lib.ShellParams, sensor: photointerrupter.Photointerrupter,
              noise: float = 1.0) -> float:
  """The design objective, lower is better:

    mean_i log10(resolution_i / paper's_i)
      + WINDOW_WEIGHT x mean_i softplus(log10(paper's half range_i / in-window range_i)),

  the resolution from `noise` counts rms per sensor through the count map, the second term a
  smooth hinge that counts only where the window holds less than the paper's loads (Table
  II ranges); inf where the sensors cannot see an axis. `objective_fn` is the same in JAX."""
  sd = resolution(params, sensor, noise)
  if not np.all(np.isfinite(sd)):
    return float("inf")
  rng = in_window_range(np, height_map(params), params.gap, sensor.window, MAX_NORM)
  return float(objective_terms(np, sd, rng))


def objective_fn(board: scene_lib.ShellScene, names: tuple[str, ...], noise: float = 1.0):
  """`objective` as a JAX function of the values of `names` (a subset of SEARCH_FIELDS), the
  board's other parameters held; differentiable. Call it inside `jax.enable_x64(True)`."""
  import jax
  import jax.numpy as jnp
  params, sensor = board.params, board.sensor
  sensors = jnp.asarray(params.sensor_positions())

  def fn(values):
    v = dict(zip(names, values))
    cx, cy = v.get("slope_x", params.slope_x), v.get("slope_y", params.slope_y)
    gap = v.get("gap", params.gap)
    # the layout of ShellParams.slopes: P1, P5 sloped along y, P3, P7 along x
    slopes = jnp.zeros((8, 2)).at[0, 1].set(-cy).at[4, 1].set(cy)
    slopes = slopes.at[2, 0].set(-cx).at[6, 0].set(cx)
    centre = jnp.stack([0.0, 0.0, model_lib.elastic_centre(params)[2] - params.gap + gap])

    def heights(pose):
      return geometry.plane_heights(jnp, slopes, sensors, gap,
                                    geometry.rotation_xp(jnp, pose[..., 3:]), pose[..., :3],
                                    centre)
    hw = jax.jacfwd(heights)(jnp.zeros(6)) @ pose_per_wrench(jnp, params, gap)
    _, r = jnp.linalg.qr((-sensor.a / gap**2) * hw)
    sd = noise * jnp.linalg.norm(jnp.linalg.inv(r), axis=1)  # rows of R^-1: diag (A^T A)^-1
    return objective_terms(jnp, sd, in_window_range(jnp, hw, gap, sensor.window, MAX_NORM))
  return fn
