"""accuracy_vs_time: what each calibrator's accuracy costs in training time, on both sensors.

Every calibrator over its settings gives a point: linear least squares; the polynomial
pseudoinverse of degrees 1-4 (the shell paper's is 3); LSANN and NN-only (LM-trained tanh
networks) with each hidden size, each epoch cap and both damping rules (MATLAB trainlm's and
Nielsen's). A point is (training seconds after JIT compilation, test error, prediction cost
per sample). One training run per network keeps its best validation net at every cap
(`calibrate.parts.mlp.train(snapshots=...)`), which is what a run capped there would return; its
time is the run's time at that epoch.

On the footpad also the calibrators that remember (`temporal_calibrators`): LS, LSANN (each
hidden size and cap) and a GRU (8 and 16 units) behind drift tracking and history features.

Data: the footpad's protocol (LS and polynomials fitted on the Z presses and X/Y strokes, the
networks on the Asterisk path, LSANN's linear stage the LS fit, all tested on Testing Paths 1
and 2; error: mean NRMSE over X, Y, Z) and the shell's (everything fitted on the calibration
run, tested on the test run; error: mean median % error over the six axes, the paper's Table
I metric). Networks train on at most `samples` samples drawn at random. Fits run one after
another in this process, so that their times are not shared with other work.

The Pareto front (no faster point is as accurate) is printed per sensor, with where more
training time stops paying: the first front point from which no slower front point lowers
the error by 10 % or more per doubling of the training time.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Literal

import numpy as np

from benchmarks.registry import register
from util import fields
from util.fields import setting

PAYING = 0.10  # a doubling of training time must lower the error by this share to pay


@fields.declared
@dataclasses.dataclass(frozen=True)
class AccuracyVsTime:
  """Settings of the accuracy-against-time benchmark.

  Attributes:
    rigs: the sensors whose data the calibrators fit.
    degrees: polynomial degrees of the pseudoinverse.
    hidden: hidden tanh units of LSANN and NN-only.
    epochs: epoch caps of the networks (up to 300 by default: an LM epoch of the 40-unit
      network on the shell's six outputs costs about 0.24 s per 20000 samples here, and
      1000-epoch caps on 50000 samples kept one run over 40 minutes, measured; no front
      point past 100 epochs paid for its time in the runs that finished).
    dampings: LM damping rules.
    samples: at most this many training samples for the networks, drawn at random.
    gru_hidden: hidden units of the footpad's GRU+memory (8-16: what a Cortex-M3 steps at
      1 kHz in fixed point).
    gru_steps: the GRU's cap on Adam steps.
  """
  rigs: tuple[Literal["footpad", "shell"], ...] = ("footpad", "shell")

  def relations(self):
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    yield bool(self.rigs), "rigs", "footpad, shell or both (not none)", self.rigs
  degrees: tuple[int, ...] = setting((1, 2, 3, 4), "[1, 5]", length=(0, 5))
  hidden: tuple[int, ...] = setting((5, 10, 20, 40), "[1, 200]", length=(0, 8))
  epochs: tuple[int, ...] = setting((10, 30, 100, 300), "[1, 5000]", length=(1, 8))
  dampings: tuple[Literal["trainlm", "nielsen"], ...] = ("trainlm", "nielsen")
  samples: int = setting(20000, "[1000, 1e7]")
  gru_hidden: tuple[int, ...] = setting((8, 16), "[1, 64]", length=(0, 4))
  gru_steps: int = setting(3000, "[1, 1e6]")


def settings(quick: bool, seed: int) -> AccuracyVsTime:
  if quick:
    return AccuracyVsTime(hidden=(5, 10, 20), epochs=(10, 30, 100), samples=10000)
  return AccuracyVsTime()


def _data(ctx, rig: str) -> dict:
  """Training and test arrays of one sensor, and its error function."""
  from benchmarks import footpad, shell
  from calibrate import metrics
  if rig == "footpad":
    from sim.footpad import protocol
    recs = {n: rec for n, (rec, _) in footpad.recordings(
        ctx, protocol.base(ctx.quick, ctx.seed)).items()}
    lin, net, test = protocol.splits(recs["train"], recs["test"]).values()

    def error(pred, truth):
      return float(np.mean(metrics.nrmse_pct(pred, truth)))
    return {"linear": (lin.counts, lin.wrench[:, :3]), "net": (net.counts, net.wrench[:, :3]),
            "test": (test.counts, test.wrench[:, :3]), "error": error,
            "metric": "mean NRMSE % over X, Y, Z (test paths)", "recordings": recs}
  from sim.shell import protocol
  _, recs, _ = shell.recordings(ctx, protocol.base(ctx.quick, ctx.seed))
  cal, test = recs["calibration"], recs["test"]

  def error(pred, truth):
    return float(np.mean(metrics.wrench_median_pct(pred, truth)))
  return {"linear": (cal.counts, cal.wrench), "net": (cal.counts, cal.wrench),
          "test": (test.counts, test.wrench), "error": error,
          "metric": "mean median % error over the six axes (test run)"}


def _predict_cost(est, counts) -> float:
  """Seconds per sample of est.predict over the test counts (best of three)."""
  est.predict(counts[:10])
  best = np.inf
  for _ in range(3):
    t = time.perf_counter()
    est.predict(counts)
    best = min(best, time.perf_counter() - t)
  return best / len(counts)


def front(points: list[dict]) -> list[dict]:
  """The Pareto front: points no faster point beats in error, by training time."""
  from benchmarks import figures
  idx = figures.pareto(np.array([p["seconds"] for p in points], float),
                       np.array([p["error"] for p in points], float))
  return [points[i] for i in idx]


def stops_paying(front_points: list[dict]) -> dict | None:
  """The first front point from which no slower front point lowers the error by PAYING
  (relative) or more per doubling of training time."""
  for k, a in enumerate(front_points):
    pays = False
    for b in front_points[k + 1:]:
      doublings = np.log2(max(b["seconds"], 1e-9) / max(a["seconds"], 1e-9))
      kept = b["error"] / a["error"]  # the share of the error left
      pays |= doublings <= 0 or 1 - kept ** (1 / doublings) >= PAYING
    if not pays:
      return a
  return None


def _rig(ctx, rig: str) -> dict:
  from calibrate import estimators
  from calibrate.parts import mlp
  s = ctx.settings
  d = _data(ctx, rig)
  error = d["error"]
  test_x, test_y = d["test"]
  points = []

  def add(name, est, seconds, compile_seconds=0.0, **extra):
    points.append({"calibrator": name, "seconds": seconds, "compile_seconds": compile_seconds,
                   "error": error(est.predict(test_x), test_y),
                   "predict_us": _predict_cost(est, test_x) * 1e6, **extra})

  x, y = d["linear"]
  t = time.perf_counter()
  ls = estimators.fit(estimators.Kind.LS, x, y)
  add("LS", ls, time.perf_counter() - t)
  for degree in s.degrees:
    t = time.perf_counter()
    est = estimators.fit(estimators.Kind.POLY, x, y, degree=degree)
    add(f"POLY{degree}", est, time.perf_counter() - t, degree=degree)
  nx, ny = d["net"]
  pick = np.random.default_rng(np.random.SeedSequence(ctx.seed, spawn_key=(3,))).permutation(
      len(nx))[:s.samples]
  nx, ny = nx[pick], ny[pick]
  caps = tuple(sorted(s.epochs))
  runs = [(k, h, dmp) for k in ("LSANN", "NN") for h in s.hidden for dmp in s.dampings]
  for n, (kind, hidden, damping) in enumerate(runs):
    cfg = mlp.LMConfig(hidden=hidden, damping=damping, epochs=max(caps))
    est = estimators.fit(estimators.Kind(kind), nx, ny, linear_fit=ls.linear, config=cfg,
                         seed=ctx.seed, snapshots=caps,
                         progress=ctx.progress(f"{rig} {kind} h={hidden} {damping} "
                                               f"({n + 1}/{len(runs)})"))
    tr = est.training
    for cap in caps:
      _, best_epoch = tr.snapshots[cap]
      ran = min(cap, tr.epochs)
      add(f"{kind} h={hidden} {damping} <={cap}", estimators.at_epoch_cap(est, cap),
          float(tr.times[ran]), tr.compile_seconds, kind=kind, hidden=hidden,
          damping=damping, cap=cap, epochs_run=ran, best_epoch=best_epoch)
  if "recordings" in d:
    points += _temporal_points(ctx, d["recordings"], error, caps)
  f = front(points)
  return {"metric": d["metric"], "points": points, "front": f, "stops_paying": stops_paying(f),
          "samples": {"linear": len(x), "networks": len(nx), "test": len(test_x)}}


def _temporal_points(ctx, recs: dict, error, caps) -> list[dict]:
  """The footpad's calibrators that remember (`temporal_calibrators`' protocol: the front end
  fitted with LS on the strokes, the networks on the whole Asterisk episodes, every test
  episode predicted in time order and scored on its paths): LS+memory, LSANN+memory at each
  hidden size and epoch cap, GRU+memory at each of `gru_hidden`. A point's seconds are the front
  end's fit plus the network's training to its cap (JIT compilation apart)."""
  from benchmarks.footpad import temporal
  from calibrate import estimators
  from calibrate.parts import mlp
  from calibrate.parts import gru
  from sim.footpad import protocol
  s = ctx.settings
  train, test = recs["train"], recs["test"]
  dt = float(train.meta["config"]["params"]["timestep"])
  y = train.wrench[:, :3]
  on = test.on_path_mask()
  kw = dict(segments=train.episode, seed=ctx.seed)
  points = []

  def add(name, est, seconds, compile_seconds=0.0, **extra):
    pred = est.predict(test.counts, segments=test.episode)
    t = time.perf_counter()
    est.predict(test.counts, segments=test.episode)
    points.append({"calibrator": name, "seconds": seconds, "compile_seconds": compile_seconds,
                   "error": error(pred[on], test.wrench[on, :3]),
                   "predict_us": (time.perf_counter() - t) / len(test.counts) * 1e6,
                   "kind": name.split()[0], **extra})

  t = time.perf_counter()
  ls = estimators.fit_temporal(estimators.Kind.LS, train.counts, y, dt,
                               select=train.on_path_mask(*protocol.LS_PATHS),
                               tare=temporal.tare_rule(), **kw)
  front_end = time.perf_counter() - t
  add("LS+memory", ls, front_end)
  net_sel = train.on_path_mask("asterisk")
  for hidden in s.hidden:
    cfg = mlp.LMConfig(hidden=hidden, epochs=max(caps))
    est = estimators.fit_temporal(estimators.Kind.LSANN, train.counts, y, dt, select=net_sel,
                                  memory=ls.memory, linear_fit=ls.linear, config=cfg,
                                  snapshots=caps, **kw)
    tr = est.training
    for cap in caps:
      ran = min(cap, tr.epochs)
      add(f"LSANN+memory h={hidden} <={cap}", estimators.at_epoch_cap(est, cap),
          front_end + float(tr.times[ran]), tr.compile_seconds, hidden=hidden, cap=cap,
          epochs_run=ran)
  for hidden in s.gru_hidden:
    est = estimators.fit_temporal(estimators.Kind.GRU, train.counts, y, dt, select=net_sel,
                                  memory=ls.memory, linear_fit=ls.linear,
                                  gru=gru.GRUConfig(hidden=hidden, steps=s.gru_steps),
                                  **kw)
    tr = est.training
    add(f"GRU+memory h={hidden}", est, front_end + tr.seconds, tr.compile_seconds,
        hidden=hidden, steps_run=tr.epochs)
  return points


@register("accuracy_vs_time", "every calibrator over its settings on both sensors: training "
          "seconds against test error, Pareto front, where more time stops paying",
          settings=settings, tags=("footpad", "shell", "calibration", "speed"))
def run(ctx):
  out = {}
  for rig in ctx.settings.rigs:
    r = out[rig] = _rig(ctx, rig)
    ctx.print(f"\n{rig}: {r['metric']}; {len(r['points'])} points "
              f"({r['samples']['linear']} linear / {r['samples']['networks']} network training "
              f"samples, {r['samples']['test']} test)")
    ctx.print(f"  {'Pareto front':34s} {'train s':>9s} {'error':>8s} {'predict us':>11s}")
    for p in r["front"]:
      mark = "  <- more time stops paying" if p is r["stops_paying"] else ""
      ctx.print(f"  {p['calibrator']:34s} {p['seconds']:9.3f} {p['error']:8.3f} "
                f"{p['predict_us']:11.3f}{mark}")
    slowest = max(r["points"], key=lambda p: p["seconds"])
    ctx.print(f"  slowest point: {slowest['calibrator']} {slowest['seconds']:.2f} s, error "
              f"{slowest['error']:.3f}; JIT compilation is not counted (up to "
              f"{max(p['compile_seconds'] for p in r['points']):.2f} s per network)")
  from benchmarks import figures
  for rig, r in out.items():
    kinds = {}
    for p in r["points"]:
      kinds.setdefault(p.get("kind") or p["calibrator"].rstrip("0123456789"), []).append(p)
    figures.save(figures.front({k: (np.array([p["seconds"] for p in v]),
                                    np.array([p["error"] for p in v])) for k, v in kinds.items()},
                               error_label=r["metric"], benchmark=ctx.name, seed=ctx.seed,
                               what=f"{rig}: test error against training time"),
                 ctx.out, f"accuracy_vs_time_{rig}")
  return _result(out)


def _result(out: dict):
  """One row per calibrator setting and number, the setting as the method (the error is a
  mean over the axes: no axis), with whether it is on the front and where time stops
  paying."""
  from benchmarks import outputs
  data = {"rigs": out, "paying_rule": f"a doubling of time lowers the error by >= {PAYING:.0%}"}
  rows = []
  for rig, r in out.items():
    on_front = {id(p) for p in r["front"]}
    rows += outputs.scored(rig, {p["calibrator"]: {"": {
        **{k: v for k, v in p.items() if isinstance(v, (int, float)) and not isinstance(v, bool)
           and k not in ("degree", "hidden", "cap")},
        "on_front": float(id(p) in on_front),
        "stops_paying": float(p is r["stops_paying"])}} for p in r["points"]})
  return outputs.Result(data, tuple(rows + outputs.plain(
      data, skip=(("rigs", "*", "points"), ("rigs", "*", "front"),
                  ("rigs", "*", "stops_paying")))))
