"""shell_temporal: what remembering buys on the force-sensing shell, against its effects with
history.

The shell's two effects that carry the past are opt-in (`sim.shell.effects`): `stray_ir`, an
offset wandering over seconds on every photointerrupter, and `spring_hysteresis`, Coulomb
friction in the mount. This benchmark turns both on over the run's board and fits, on the
calibration run (100 Hz frames, each thread's session a segment), the paper's cubic (POLY)
and LS, static and behind the temporal front end of `calibrate.parts.memory` (history features:
each sensor's high-pass at time constants chosen on held-out sessions, and its first
difference), and GRU+memory (the cubic behind the same front end plus a recurrent network on
its residual). No drift
tracking: the hand never lets go for long (the loads are smooth random sweeps through every
axis), so there is no unloaded interval to tare in.

Printed: test NRMSE % per axis (mean over forces, over moments); on the turn scene (50 g on
the shell, the robot turned through the paper's sequence A-I, `gravity_vectors`) the mean
mass the shell reads and the mean angle to the accelerometer; the floor (the same fits with
neither effect); each effect alone, static POLY against the best temporal method. The drop
scene is left out: it has no reference wrench while the mass rings.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from benchmarks import outputs, shell
from benchmarks.registry import register

HISTORY = ("stray_ir", "spring_hysteresis")
FRAME_DT = 0.01  # s: the SkinProc's 100 Hz frames


def evaluate(cal, test, turn=None) -> dict:
  """{method: {"nrmse_pct": per axis, "seconds", "turn": gravity_vectors' figures}} for the
  calibration run `cal`, the test run `test` and the turn scene's (counts, gravity)."""
  from benchmarks.shell import gravity_vectors
  from calibrate import estimators
  K = estimators.Kind
  out, fits = {}, {}
  t0 = time.perf_counter()
  fits["POLY"] = estimators.fit(K.POLY, cal.counts, cal.wrench)
  fits["LS"] = estimators.fit(K.LS, cal.counts, cal.wrench)
  for kind in (K.POLY, K.LS):
    fits[f"{kind.value}+memory"] = estimators.fit_temporal(
        kind, cal.counts, cal.wrench, FRAME_DT, segments=cal.episode, seed=1)
  # the recurrent network on the cubic's residual: the shell's static map is the cubic
  cubic = fits["POLY+memory"]
  fits["GRU+memory"] = estimators.fit_temporal(
      K.GRU, cal.counts, cal.wrench, FRAME_DT, segments=cal.episode, seed=1,
      memory=cubic.memory, linear_fit=cubic.linear)
  fit_seconds = time.perf_counter() - t0
  for name, est in fits.items():  # a static estimator ignores the segments
    pred = est.predict(test.counts, segments=test.episode)
    scale = np.ptp(test.wrench, axis=0)
    nrmse = 100 * np.sqrt(np.mean((pred - test.wrench) ** 2, axis=0)) / scale
    out[name] = {"nrmse_pct": dict(zip(shell.AXES, nrmse.tolist())),
                 "taus": None if est.memory is None else list(est.memory.taus)}
    if turn is not None:
      counts, gravity = turn
      out[name]["turn"] = gravity_vectors.compare(est.predict(counts)[:, :3], gravity)
  out["_fit_seconds"] = fit_seconds
  return out


def _summary(res) -> tuple[float, float]:
  v = np.array(list(res["nrmse_pct"].values()))
  return float(v[:3].mean()), float(v[3:].mean())


@register("shell_temporal", "shell: the cubic and LS, static and behind history features, and "
          "a GRU, with the shell's effects that carry the past (stray IR, mount friction)",
          settings=shell.protocol_settings, presets=shell.presets, fixed=shell.FIXED,
          tags=("shell", "calibration"))
def run(ctx) -> dict:
  from sim.shell import protocol, turn
  base = dataclasses.replace(ctx.settings,
                             effects=tuple(dict.fromkeys(ctx.settings.effects + HISTORY)))
  floor_board = dataclasses.replace(base, effects=tuple(e for e in base.effects
                                                        if e not in HISTORY))

  def run_for(board, with_turn=True):
    _, runs, _ = shell.recordings(ctx, board)
    tr = None
    if with_turn:
      scene = protocol.scenes(board, ctx.quick, ctx.seed)["calibration"]
      tr = turn.simulate(scene, ctx.seed)
    return evaluate(runs["calibration"], runs["test"], tr)

  res = run_for(base)
  ctx.print("test NRMSE % (mean of Fx, Fy, Fz / of Mx, My, Mz); turn scene: mean mass g "
            "(50 g on the shell plus its own 9.7 g turned), mean angle deg to the "
            "accelerometer")
  for name, r in res.items():
    if name.startswith("_"):
      continue
    f, m = _summary(r)
    t = r["turn"]
    ctx.print(f"  {name:12s} F {f:6.2f}  M {m:6.2f}   turn {t['mean_mass_g']:6.1f} g "
              f"{t['mean_angle_deg']:5.1f} deg" + (f"   taus {r['taus']}" if r["taus"]
                                                  is not None else ""))
  floor = run_for(floor_board, with_turn=False)
  ctx.print("floor (neither effect): " + "  ".join(
      f"{n} F {_summary(r)[0]:.2f} M {_summary(r)[1]:.2f}" for n, r in floor.items()
      if not n.startswith("_")))
  ablation = {}
  ctx.print("each effect alone: NRMSE % F / M, static POLY against each temporal method")
  for effect in HISTORY:
    board = dataclasses.replace(floor_board, effects=floor_board.effects + (effect,))
    r = run_for(board, with_turn=False)
    ablation[effect] = {n: v["nrmse_pct"] for n, v in r.items() if not n.startswith("_")}
    ctx.print(f"  {effect:17s} " + "  ".join(
        f"{n} {_summary(v)[0]:.2f}/{_summary(v)[1]:.2f}" for n, v in r.items()
        if not n.startswith("_")))
  data = {"results": {n: r for n, r in res.items() if not n.startswith("_")},
          "floor": {n: r["nrmse_pct"] for n, r in floor.items() if not n.startswith("_")},
          "ablation": ablation, "fit_seconds": res["_fit_seconds"],
          "effects": list(base.effects)}

  def by_axis(per_method: dict) -> dict:  # {method: {axis: nrmse}} -> {method: {axis: {..}}}
    return {m: {ax: {"nrmse_pct": v} for ax, v in per.items()} for m, per in per_method.items()}
  rows = (outputs.scored("results", by_axis({n: r["nrmse_pct"]
                                             for n, r in data["results"].items()}))
          + outputs.scored("floor", by_axis(data["floor"]))
          + [r for e, got in ablation.items()
             for r in outputs.scored(f"ablation/{e}", by_axis(got))])
  return outputs.Result(data, tuple(rows + outputs.plain(
      data, skip=(("results", "*", "nrmse_pct"), ("floor",), ("ablation",)))))
