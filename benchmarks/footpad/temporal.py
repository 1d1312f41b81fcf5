"""temporal_calibrators: what remembering buys on the footpad, against the effects with history.

The paper's protocol (LS on the Z presses and X/Y strokes; LSANN's network and NN-only on the
Asterisk path; tested on Testing Paths 1 and 2) with every calibrator twice: static, as in
the paper, and behind a temporal front end (`calibrate.parts.memory`): drift tracking (each die
re-zeroed in the unloaded intervals that start and end every stroke, read from the LS map's
normal force: `tare_rule`) and history features (each die's high-pass at time constants
chosen on held-out episodes of the strokes, and its first difference, each kept only where
it lowers LS's held-out error). The history features reach the LS stage; the networks read
the tared counts (`estimators.fit_temporal`'s network_history says why). GRU+memory is the
same LS stage plus a recurrent network (`calibrate.parts.gru`) fitted on the Asterisk
episodes to its residual, stopped on held-out blocks of them. The filters and the GRU run
over each whole episode, approach included, and are scored on the samples on the path, as
the static fits.

Printed: test NRMSE and R2 per axis for each method (networks: median over `SEEDS` seeds),
training seconds, the C export's cost on the LPC1768 model (`calibrate.cexport`); LSANN's
front end again with the tare carried through each recording instead of restarted with each
episode (`/session`); the tare's false-tare rate (the share of the samples the tares read as unloaded while the plate read
more than 1 N); the floor, static LS and LSANN with every history effect off (what a static
map reaches without history); the ablation: each history effect alone over that floor, each
static method against its temporal counterpart, and the share of the error the effect adds
that the front end recovers; and the envelope's two corners (`envelope.corner`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from benchmarks import footpad, outputs
from benchmarks.registry import register

# the effects whose reading depends on the path the load took
HISTORY_EFFECTS = ("thermal_drift", "viscoelastic", "hysteresis", "stick_slip")
SEEDS = 3  # network seeds per method; the table's figure is their median
LOADED = 1.0  # N: a tare while the plate reads more than this is a false tare
AXES = ("X", "Y", "Z")


def tare_rule():
  """Unloaded: the LS stroke map reads under 10 N of normal force for 21 ms (2 hold + 1
  samples; the tare reads them from 10 ms in to 10 ms back). The dies'
  offset drift at its nominal 0.5 % of span makes that map's normal force err by about 4 %
  of its range, ~6 N (measured: LS test NRMSE Z 4.1 % with `thermal_drift` alone, 2.3 %
  without), and the lightest press on a path is 58 N (0.5 mm deep; measured), so 10 N
  catches the unloaded start and end of every episode and no sample on a path. At 3 N the
  drift hid every unloaded interval of the test recording."""
  from calibrate.parts import memory
  return memory.Tare(threshold=10.0, hold=10)


def evaluate(train, test, seeds, methods=("static", "temporal"),
             kinds=("LS", "LSANN", "NN", "GRU"), costs: bool = False) -> dict:
  """{method name: {"test": per-axis summary (networks: median over seeds), "seconds",
  "taus", with `costs` "c": the C export's cost}} and the tare's figures, for the
  protocol's recordings `train` and `test`."""
  from calibrate import estimators, metrics
  from sim.footpad import protocol
  from util import errors
  dt = float(train.meta["config"]["params"]["timestep"])
  y = train.wrench[:, :3]
  ls_sel, net_sel = train.on_path_mask(*protocol.LS_PATHS), train.on_path_mask("asterisk")
  test_sel = test.on_path_mask()
  truth = test.wrench[test_sel, :3]
  out = {}

  def score(pred):  # every test sample predicted in time order, scored on the paths
    return metrics.summary(pred[test_sel], truth, AXES)

  def median(runs):
    return {ax: {k: float(np.median([r[ax][k] for r in runs])) for k in runs[0][ax]}
            for ax in AXES}

  K = estimators.Kind

  def c_cost(est, fixed_point=False) -> dict:
    """The C export's cost per estimate on the LPC1768 model; a recurrent network's also in
    fixed point, with how far that C (compiled here, when a compiler is) strays from
    `predict` over the test recording, per axis, relative to its largest output."""
    import tempfile
    from calibrate import cexport
    with tempfile.TemporaryDirectory() as d:
      r = cexport.write(est, d, fixed_point=fixed_point)
    loop = r.budget.clock_hz / r.budget.rate_hz
    out = {"cycles": list(r.cycles), "budget_pct": [100 * c / loop for c in r.cycles],
           "multiply_adds": r.multiply_adds, "tanh": r.tanh}
    if est.rnn is not None and not fixed_point:
      out["fixed_point"] = c_cost(est, True)
      try:
        got = cexport.run_on_host(est, test.counts, test.episode, fixed_point=True)
      except errors.SettingError:  # no compiler here: the cost stands, the error unmeasured
        return out
      want = est.predict(test.counts, segments=test.episode)
      out["fixed_point"]["max_error_of_scale"] = (
          np.abs(got - want)[test_sel].max(axis=0) / np.abs(want[test_sel]).max(axis=0)).tolist()
    return out

  for method in methods:
    t0 = time.perf_counter()
    if method == "static":
      ls = estimators.fit(K.LS, train.counts[ls_sel], y[ls_sel])
      predict = lambda est: est.predict(test.counts)  # noqa: E731
      fit_net = lambda kind, seed: estimators.fit(  # noqa: E731
          kind, train.counts[net_sel], y[net_sel], linear_fit=ls.linear, seed=seed)
    else:
      # "temporal": the tare restarts with each episode, where the CNC has lifted the pad
      # clear (as an F/T user biases before each contact); "session": it carries through the
      # recording, as the dies' drift does, and a bad tare stays until the next good one
      one = np.zeros(len(y), int) if method == "session" else None
      one_test = np.zeros(len(test.counts), int) if method == "session" else None
      ls = estimators.fit_temporal(K.LS, train.counts, y, dt, segments=train.episode,
                                   sessions=one, select=ls_sel, tare=tare_rule(), seed=0)
      predict = lambda est: est.predict(test.counts, segments=test.episode,  # noqa: E731
                                        sessions=one_test)
      fit_net = lambda kind, seed: estimators.fit_temporal(  # noqa: E731
          kind, train.counts, y, dt, segments=train.episode, sessions=one, select=net_sel,
          memory=ls.memory, linear_fit=ls.linear, seed=seed)
    name = {"static": "", "temporal": "+memory", "session": "+memory/session"}[method]
    if "LS" in kinds and method != "session":
      out["LS" + name] = {"test": score(predict(ls)), "seconds": time.perf_counter() - t0}
      if costs:
        out["LS" + name]["c"] = c_cost(ls)
    for kind in ("LSANN", "NN", "GRU"):
      if kind not in kinds or (kind == "GRU" and method == "static") or (
          kind != "LSANN" and method == "session"):
        continue
      runs, secs = [], []
      for seed in seeds:
        t1 = time.perf_counter()
        est = fit_net(K(kind), seed)
        secs.append(time.perf_counter() - t1)
        runs.append(score(predict(est)))
      out[kind + name] = {"test": median(runs), "seconds": float(np.median(secs))}
      if costs:
        out[kind + name]["c"] = c_cost(est)
    if method != "static":
      for m in [k for k in out if k.endswith(name)]:
        out[m]["taus"] = list(ls.memory.taus)
      read = ls.memory.offsets(test.counts, test.episode, sessions=one_test)[1]
      loaded = np.abs(test.wrench[:, 2]) > LOADED
      out["tare" + name[len("+memory"):]] = {
          "read_share": float(read.mean()),
          "false_tare_share": float((read & loaded).sum() / max(read.sum(), 1)),
          "taus": list(ls.memory.taus)}
  return out


# (static method, its temporal counterpart): GRU's is LSANN, LS plus a static network on
# the residual where the GRU puts a recurrent one
PAIRS = (("LS", "LS+memory"), ("LSANN", "LSANN+memory"), ("LSANN", "GRU+memory"))
ADDS_NOTHING = 0.1  # NRMSE points: an effect adding less over the floor has nothing to recover


def _shear(res) -> float:
  """Mean of the X and Y test NRMSE %."""
  return float(np.mean([res["test"][ax]["nrmse_pct"] for ax in ("X", "Y")]))


def _row(ctx, name, res):
  t = res["test"]
  cells = "  ".join(f"{ax} {t[ax]['nrmse_pct']:6.2f} {t[ax]['r2_pct']:7.2f}" for ax in AXES)
  c = res.get("c")
  cost = f"   C {c['budget_pct'][0]:4.0f}-{c['budget_pct'][1]:3.0f} %" if c else ""
  if c and "fixed_point" in c:
    fx = c["fixed_point"]
    err = fx.get("max_error_of_scale")
    cost += (f" (fixed point {fx['budget_pct'][0]:.0f}-{fx['budget_pct'][1]:.0f} %"
             + (f", off predict by <= {max(err):.1e} of scale)" if err else ")"))
  ctx.print(f"  {name:14s} {cells}   {res['seconds']:7.1f} s{cost}")


@register("temporal_calibrators", "footpad: static calibrators against the same behind "
          "drift tracking and history features, and what each history effect costs them",
          settings=footpad.protocol_settings, presets=footpad.presets, fixed=footpad.FIXED,
          tags=("footpad",))
def run(ctx) -> dict:
  from sim.footpad import scene as scene_lib
  seeds = list(range(1, SEEDS + 1))
  base = ctx.settings
  recs = footpad.recordings(ctx)
  train, test = recs["train"][0], recs["test"][0]
  res = evaluate(train, test, seeds, ("static", "temporal", "session"), costs=True)
  ctx.print(f"test NRMSE % and R2 % per axis (networks: median of {len(seeds)} seeds); "
            f"training s; C export's cycles per estimate, % of a 1 kHz loop on the LPC1768 "
            f"(96 MHz Cortex-M3, soft float)")
  for name, r in res.items():
    if not name.startswith("tare"):
      _row(ctx, name, r)
  tare = res["tare"]
  for key, how in (("tare", "restarted each episode"), ("tare/session", "carried per session")):
    t = res[key]
    ctx.print(f"memory, tare {how}: time constants {t['taus']} s chosen on held-out stroke "
              f"episodes; the tares read {t['read_share']:.2%} of the test samples, "
              f"{t['false_tare_share']:.2%} of them while the plate read over {LOADED:g} N")
  # the floor: no history effect at all
  plain = dataclasses.replace(base, effects=tuple(e for e in base.effects
                                                  if e not in HISTORY_EFFECTS))
  floor_recs = footpad.recordings(ctx, plain)
  floors = evaluate(floor_recs["train"][0], floor_recs["test"][0], seeds, ("static",),
                    ("LS", "LSANN"))
  floor = floors["LSANN"]
  _row(ctx, "LSANN, no hist", floor)
  shear = {m: _shear(res[m]) for m in res if not m.startswith("tare")}
  floor_shear = _shear(floor)
  best = min((m for m in shear if m.endswith("+memory")), key=shear.get)
  ctx.print(f"shear NRMSE (mean of X, Y): static LSANN {shear['LSANN']:.2f} %, best with memory "
            f"{best} {shear[best]:.2f} % ({1 - shear[best] / shear['LSANN']:.0%} lower); "
            f"floor without history {floor_shear:.2f} % (the best at "
            f"{shear[best] / floor_shear:.2f}x it)")
  # the ablation: each history effect alone over the floor
  ablation = {}
  ctx.print("each history effect alone: shear NRMSE % (mean of X, Y) static -> with memory, "
            "and the share of the error the effect adds over the static floor that memory "
            "recovers (of how many points)")
  variants = []
  for effect in (e for e in HISTORY_EFFECTS if e in base.effects):
    one = dataclasses.replace(plain, effects=plain.effects + (effect,))
    variants.append((effect, one))
    if effect == "thermal_drift":  # a tare can undo the offsets' drift, not the gains'
      variants += [(f"drift {part} only", dataclasses.replace(one, adc=dataclasses.replace(
          one.adc, **{other: 0.0}))) for part, other in (("offset", "drift_gain"),
                                                         ("gain", "drift_offset"))]
  for effect, one in variants:
    r = footpad.recordings(ctx, one)
    both = evaluate(r["train"][0], r["test"][0], seeds[:1], kinds=("LS", "LSANN", "GRU"))
    ablation[effect] = {}
    cells = []
    for static, memory in PAIRS:
      s0, s1 = _shear(both[static]), _shear(both[memory])
      added = s0 - _shear(floors[static])
      recovered = (s0 - s1) / added if added > ADDS_NOTHING else float("nan")
      ablation[effect][memory] = {"static": s0, "memory": s1, "added": added,
                                  "recovered_share": recovered}
      share = "adds nothing" if np.isnan(recovered) else f"{recovered:4.0%} of {added:4.2f}"
      cells.append(f"{static} {s0:5.2f} -> {memory} {s1:5.2f} ({share})")
    ablation[effect]["taus"] = both["tare"]["taus"]
    ctx.print(f"  {effect:17s} " + "   ".join(cells))
  # the envelope's corners: every history parameter at the low, then the high end of its
  # sourced range
  from benchmarks.footpad import envelope
  corners = {}
  ctx.print("the envelope's corners (every history parameter at its sourced low / high end): "
            "shear NRMSE % static LSANN, LSANN+memory (tare per episode, per session), "
            "GRU+memory; Z NRMSE %")
  for name, level in (("least history", 0.0), ("most history", 1.0)):
    scene = envelope.design_scene(base, envelope.corner(level))
    r = footpad.recordings(ctx, scene)
    got = evaluate(r["train"][0], r["test"][0], seeds[:1], ("static", "temporal", "session"),
                   kinds=("LSANN", "GRU"))
    corners[name] = {m: got[m]["test"] for m in got if not m.startswith("tare")}
    ctx.print(f"  {name:13s} " + "  ".join(
        f"{m} {_shear(got[m]):5.2f} (Z {got[m]['test']['Z']['nrmse_pct']:4.2f})"
        for m in ("LSANN", "LSANN+memory", "LSANN+memory/session", "GRU+memory")))
  data = {"results": {m: r["test"] for m, r in res.items() if not m.startswith("tare")},
          "seconds": {m: r["seconds"] for m, r in res.items() if not m.startswith("tare")},
          "c_cost": {m: r["c"] for m, r in res.items() if not m.startswith("tare")},
          "floors": {m: r["test"] for m, r in floors.items() if not m.startswith("tare")},
          "corners": corners, "best_memory": best,
          "tare": tare, "tare_session": res["tare/session"], "floor": floor["test"],
          "shear_nrmse_pct": shear,
          "floor_shear_nrmse_pct": float(floor_shear), "ablation": ablation,
          "seeds": seeds, "effects": list(base.effects),
          "scene": scene_lib.FootpadScene.config(base)}
  # each per-axis score with its method and axis named (the floor: LSANN without history)
  rows = (outputs.scored("results", data["results"]) + outputs.scored("floors", data["floors"])
          + outputs.scored("floor", {"LSANN": data["floor"]})
          + [r for name, got in corners.items() for r in outputs.scored(f"corners/{name}", got)]
          + [outputs.Row("fit", m, "", "seconds", v) for m, v in data["seconds"].items()])
  return outputs.Result(data, tuple(rows + outputs.plain(
      data, skip=(("results",), ("floors",), ("floor",), ("corners",), ("seconds",)))))
