"""lm_solvers: one network, one dataset, four Levenberg-Marquardt implementations.

The NN-only network (6 counts -> 10 tanh -> 3 forces, inputs and outputs scaled to [-1, 1])
on the footpad's Asterisk training samples, from one Nguyen-Widrow start point. The project's
LM with MATLAB trainlm's damping runs to its validation stop; its best validation MSE becomes
the target, and each solver reports the time and iterations it needs to reach it (capped):
the project's LM again with Nielsen's gain-ratio damping, jaxopt's LM, scipy's MINPACK LM,
`mujoco.minimize` and, when the optional extra is installed, optimistix's LevenbergMarquardt. Per-iteration time of the project's LM is compared with the dense J^T J
product (J of shape (N*3, 103)) timed in the same run. Times exclude JIT compilation, which is
reported separately. The whole race runs with JAX's 64-bit types on.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from benchmarks import footpad
from benchmarks.registry import register

SAMPLES = 100_000
QUICK_SAMPLES = 20_000


class _Reached(Exception):
  pass


def _dense_jtj_seconds(rows: int, p: int, repeats: int = 5) -> float:
  import jax
  import jax.numpy as jnp
  j = jax.random.normal(jax.random.key(0), (rows, p), jnp.float64)
  f = jax.jit(lambda a: a.T @ a)
  f(j).block_until_ready()
  times = []
  for _ in range(repeats):
    t = time.perf_counter()
    f(j).block_until_ready()
    times.append(time.perf_counter() - t)
  return float(np.median(times))


def _optimistix_racer(theta0, res_fn):
  """(run(check, state), compile seconds) stepping optimistix's LevenbergMarquardt one
  iteration at a time on the same residuals and start; None without optimistix (an optional
  extra: it is the maintained JAX least-squares library, raced here as a reference)."""
  try:
    import equinox as eqx  # optimistix's own dependency: its states hold non-array leaves
    import optimistix as optx
  except ImportError:
    return None
  import jax

  solver = optx.LevenbergMarquardt(rtol=1e-15, atol=1e-15)

  def fn(y, args):
    return res_fn(y), None
  f_struct = jax.eval_shape(lambda: fn(theta0, None)[0])
  init = eqx.filter_jit(lambda y: solver.init(fn, y, None, {}, f_struct, None, frozenset()))
  step = eqx.filter_jit(lambda y, st: solver.step(fn, y, None, {}, st, frozenset())[:2])
  t = time.perf_counter()
  jax.block_until_ready(step(theta0, init(theta0)))
  compile_s = time.perf_counter() - t

  def run(check, state):
    y, st = theta0, init(theta0)
    while True:
      y, st = step(y, st)
      state["jac"] += 1
      check(np.asarray(y))
  return run, compile_s


def _race(name, run, val_mse, target, cap_s):
  """Runs `run(check, state)`: the solver calls check(theta) on every evaluated point, which
  ends the race at the target or the time cap, and counts its Jacobians in state["jac"]."""
  state = {"t0": None, "jac": 0, "best": np.inf}

  def check(theta):
    v = val_mse(theta)
    state["best"] = min(state["best"], v)
    if v <= target:
      raise _Reached
    if time.perf_counter() - state["t0"] > cap_s:
      raise TimeoutError

  state["t0"] = time.perf_counter()
  try:
    run(check, state)
    outcome = "stopped before the target"
  except _Reached:
    outcome = "reached"
  except TimeoutError:
    outcome = f"cap {cap_s:.0f} s"
  seconds = time.perf_counter() - state["t0"]
  return {"solver": name, "outcome": outcome, "seconds": seconds, "iterations": state["jac"],
          "best_val_mse": state["best"]}


@register("lm_solvers", "LM for the footpad network: own vs jaxopt, scipy, mujoco.minimize, optimistix",
          settings=footpad.protocol_settings, presets=footpad.presets, fixed=footpad.FIXED,
          tags=("footpad", "speed"))
def run(ctx):
  import jax
  from benchmarks import outputs
  from calibrate import metrics
  with jax.enable_x64(True):  # the race runs the network's building blocks in float64
    scene, p = _problem(ctx)
    results, own, target = _own_solvers(ctx, p)
    results += _reference_solvers(ctx, p, target)
    jtj_s = _dense_jtj_seconds(len(p.x) * p.outputs, p.theta0.size)
  ratio, speedup, exact = _report(ctx, results, own, target, jtj_s, p)
  data = {"samples": {"train": len(p.x), "validation": len(p.xv)}, "parameters": p.theta0.size,
          "target_val_mse_scaled": target, "solvers": results,
          "dense_jtj_seconds": jtj_s, "own_per_iteration_over_jtj": ratio,
          "speedup_over_fastest_other": speedup, "speedup_is_lower_bound": not exact,
          "effects": list(scene.effects)}
  # one row per solver and number, the solver as the method (no axis: one network, 3 outputs)
  rows = metrics.scored("race", {r["solver"]: {"": {k: v for k, v in r.items()
                                                    if k not in ("solver", "outcome")}}
                                 for r in results})
  return outputs.Result(data, tuple(rows + outputs.plain(data, skip=(("solvers",),))))


@dataclasses.dataclass(frozen=True)
class _Problem:
  """The race's data, scaled to [-1, 1] (jax arrays), and its start point.

  Attributes:
    x, y: training counts and forces, unscaled (N, 6), (N, 3).
    xj, yj, xv, yv: scaled training and validation inputs and targets.
    theta0: the Nguyen-Widrow start, (P,).
    hidden, inputs, outputs: the network's sizes.
    forward: the network, jitted: (theta, scaled inputs) -> scaled outputs.
  """
  x: np.ndarray
  y: np.ndarray
  xj: object
  yj: object
  xv: object
  yv: object
  theta0: np.ndarray
  hidden: int
  inputs: int
  outputs: int
  forward: object

  def val_mse(self, theta) -> float:
    """Validation MSE in scaled output units, the same for every solver."""
    import jax.numpy as jnp
    return float(jnp.mean((self.forward(jnp.asarray(theta).ravel(), self.xv) - self.yv) ** 2))


def _problem(ctx) -> tuple:
  """(the training scene, the race's `_Problem`): Asterisk samples of the train recording,
  a random subset (`SAMPLES`, `QUICK_SAMPLES`) with a 15 % validation split."""
  import jax
  import jax.numpy as jnp
  from calibrate import splits
  from calibrate.parts import mlp
  from sim.footpad import protocol, scene as scene_lib
  scene = protocol.scenes(ctx.settings)["train"]
  rec, _ = scene_lib.generate(scene, ctx.progress("train episodes"), ctx.use_cache)
  ctx.used(rec)
  data = rec.on_path("asterisk")
  n_want = QUICK_SAMPLES if ctx.quick else SAMPLES
  pick = np.random.default_rng(np.random.SeedSequence([ctx.seed, 2])).permutation(len(data))
  tr_all, va_all = splits.validation(min(len(data), int(n_want / 0.85)), 0.15,
                                               ctx.seed)
  tr, va = pick[tr_all][:n_want], pick[va_all]
  x, y = data.counts[tr], data.wrench[tr, :3]
  xs, ys = mlp.MinMax.fit(x), mlp.MinMax.fit(y)
  h, d, o = 10, x.shape[1], 3
  p = _Problem(x, y, jnp.asarray(xs.forward(x)), jnp.asarray(ys.forward(y)),
               jnp.asarray(xs.forward(data.counts[va])),
               jnp.asarray(ys.forward(data.wrench[va, :3])),
               np.asarray(mlp.nguyen_widrow(jax.random.key(ctx.seed), d, h, o)), h, d, o,
               jax.jit(lambda t, a: mlp._forward(t, a, h, d, o)))
  ctx.print(f"N = {len(x)} training samples ({len(va)} validation), {p.theta0.size} parameters")
  return scene, p


def _own_solvers(ctx, p: _Problem) -> tuple[list, object, float]:
  """The project's LM (trainlm's damping, then Nielsen's) and jaxopt's, from their per-epoch
  validation history (`mlp.train`); the trainlm run sets the target. (rows, that run, the
  target validation MSE)."""
  from calibrate.parts import mlp
  results, own, target = [], None, None
  for name, backend, damping in (("own LM (trainlm)", "own", "trainlm"),
                                 ("own LM (nielsen)", "own", "nielsen"),
                                 ("jaxopt LM", "jaxopt", "trainlm")):
    first = own is None
    cfg = mlp.LMConfig(hidden=p.hidden, backend=backend, damping=damping,
                       max_fail=6 if first else 10**9, epochs=1000 if backend == "own" else 200)
    res = mlp.train(np.asarray(p.xj), np.asarray(p.yj), np.asarray(p.xv), np.asarray(p.yv),
                    cfg, start=p.theta0, progress=ctx.progress(f"{name} epochs"))
    per_iter = res.seconds / max(res.epochs, 1)
    if first:
      own, target = res, res.best_val_mse
    hit = res.epochs_to(target)
    results.append({"solver": name,
                    "outcome": "stopped before the target" if hit is None else "reached",
                    "seconds": res.seconds if hit is None else hit * per_iter,
                    "iterations": res.epochs if hit is None else hit,
                    "best_val_mse": float(res.val_mse.min()),
                    "seconds_per_iteration": per_iter, "compile_seconds": res.compile_seconds})
  return results, own, target


def _reference_solvers(ctx, p: _Problem, target: float) -> list[dict]:
  """scipy's MINPACK LM, mujoco.minimize and (if installed) optimistix, each raced to the
  target on the same residuals, Jacobians and start."""
  import jax
  import jax.numpy as jnp
  import mujoco.minimize
  import scipy.optimize
  from calibrate.parts import mlp
  cap = 60.0 if ctx.quick else 300.0
  res_fn = jax.jit(lambda t: mlp.residuals(t, p.xj, p.yj, p.hidden))
  # one analytic Jacobian for every library (`mlp.jacobian`): with jax.jacfwd, assembling J
  # took 88 % of a mujoco.minimize iteration, and the race timed that, not the solvers
  jac_fn = jax.jit(lambda t: mlp.jacobian(t, p.xj, p.yj, p.hidden))
  t = time.perf_counter()
  jax.block_until_ready((res_fn(jnp.asarray(p.theta0)), jac_fn(jnp.asarray(p.theta0))))
  compile_ref = time.perf_counter() - t

  def scipy_run(check, state):
    def fun(theta):
      check(theta)
      return np.asarray(res_fn(jnp.asarray(theta)))

    def jac(theta):
      state["jac"] += 1
      return np.asarray(jac_fn(jnp.asarray(theta)))
    scipy.optimize.least_squares(fun, p.theta0, jac=jac, method="lm", max_nfev=10**6,
                                 xtol=1e-15, ftol=1e-15, gtol=1e-15)

  def mujoco_run(check, state):
    def fun(theta):
      cols = []
      for k in range(theta.shape[1]):
        check(theta[:, k])
        cols.append(np.asarray(res_fn(jnp.asarray(theta[:, k]))))
      return np.stack(cols, axis=1)

    def jac(theta, r):
      state["jac"] += 1
      return np.asarray(jac_fn(jnp.asarray(theta.ravel())))
    mujoco.minimize.least_squares(p.theta0, fun, jacobian=jac, max_iter=10**6, verbose=0,
                                  xtol=1e-15, gtol=1e-15)

  racers = [("scipy least_squares lm", scipy_run, compile_ref),
            ("mujoco.minimize", mujoco_run, compile_ref)]
  optimistix = _optimistix_racer(jnp.asarray(p.theta0), res_fn)
  if optimistix is None:
    ctx.print("optimistix is not installed (pip install -e '.[optimistix]'): its "
              "LevenbergMarquardt is left out of the race")
  else:
    racers.append(("optimistix LM", *optimistix))
  results = []
  for name, fn, compile_s in racers:
    ctx.print(f"running {name} (capped at {cap:.0f} s)...")
    row = _race(name, fn, p.val_mse, target, cap)
    row["compile_seconds"] = compile_s
    row["seconds_per_iteration"] = row["seconds"] / max(row["iterations"], 1)
    results.append(row)
  return results


def _report(ctx, results: list, own, target: float, jtj_s: float, p: _Problem) -> tuple:
  """Prints the race; (own LM's seconds per iteration over the dense J^T J product, each own
  solver's speed-up over the fastest other one to reach the target, whether that is exact)."""
  own_rows = [r for r in results if r["solver"].startswith("own")]
  others = [r for r in results if not r["solver"].startswith("own")]
  # A solver that missed the target would have needed at least the time it ran.
  bound = min((r["seconds"] for r in others), default=None)
  ctx.print(f"\ntarget validation MSE (scaled units) {target:.4g}: own LM's best, epoch "
            f"{own.best_epoch} of {own.epochs} ({own.stop.name})")
  ctx.print(f"{'solver':24s} {'outcome':>24s} {'seconds':>9s} {'iterations':>11s} "
            f"{'s/iteration':>12s} {'compile s':>10s}")
  for r in results:
    ctx.print(f"{r['solver']:24s} {r['outcome']:>24s} {r['seconds']:9.2f} {r['iterations']:11d} "
              f"{r['seconds_per_iteration']:12.4f} {r['compile_seconds']:10.2f}")
  ratio = own_rows[0]["seconds_per_iteration"] / jtj_s
  ctx.print(f"dense J^T J matmul ({len(p.x) * p.outputs} x {p.theta0.size}): "
            f"{jtj_s * 1e3:.1f} ms; own LM per iteration / that = {ratio:.2f} (this project's "
            f"target: at most 3, the Gram product being the floor of an LM iteration)")
  speedup = {}
  reached = [r for r in others if r["outcome"] == "reached"]
  rival = min(reached, key=lambda r: r["seconds"]) if reached else None
  for r in own_rows:
    if r["outcome"] != "reached" or r["seconds"] <= 0:
      speedup[r["solver"]] = None
      ctx.print(f"{r['solver']}: did not reach the target")
    elif rival is not None:
      speedup[r["solver"]] = rival["seconds"] / r["seconds"]
      ctx.print(f"{r['solver']} reaches the target {speedup[r['solver']]:.1f}x as fast as "
                f"{rival['solver']}, the fastest other solver to reach it")
    else:
      speedup[r["solver"]] = bound / r["seconds"] if bound else None
      ctx.print(f"{r['solver']} speed-up to the target: at least {speedup[r['solver']]:.1f}x "
                f"(no other solver reached it in the time it ran)" if bound else
                f"{r['solver']}: no other solver ran")
  return ratio, speedup, rival is not None
