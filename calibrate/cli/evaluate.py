"""`python -m calibrate evaluate`: the papers' metrics and figures of an estimator on held-out data."""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate.cli import common
from util import cli, errors, files

def add_parser(sub) -> None:
  p = sub.add_parser("evaluate", help="the papers' metrics and figures on held-out data")
  common.recording_args(p, "scored together")
  p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("evaluation"),
                 help="folder for metrics.csv, metrics.json and figures (evaluation/)")
  p.add_argument("--level", type=float, default=0.95,
                 help="the interval level whose coverage to report (default 0.95)")

def scores(pred: np.ndarray, truth: np.ndarray, names, units) -> dict:
  """The papers' metrics per output: RMSE (its unit), NRMSE %, R2 %, median % error (over
  samples above `THRESHOLDS` of the unit) and worst error as % of the range."""
  from calibrate import metrics
  out = {}
  for i, (name, unit) in enumerate(zip(names, units)):
    one = metrics.summary(pred[:, i:i + 1], truth[:, i:i + 1], (name,),
                          common.THRESHOLDS.get(unit, 0.0))
    out[name] = one[name]
  return out


def interval_scores(info, x, truth, pred, level: float, result: dict):
  """The interval's half-width and coverage per output into `result`, overall, with the
  inputs inside the training box and beyond it; returns ((N,) True beyond it, (N, A) True
  inside the interval, or None without one)."""
  far = info.distance(x) > 0  # inputs beyond the training box: the interval widens there
  inside = None
  if info.interval_abs is not None:  # the interval fit promised, against what it covers here
    inside = np.abs(truth - pred) <= info.half_width_at(level, x)
    half = info.half_width(level)
    for j, n in enumerate(info.outputs):
      result[n]["interval_half_width"] = float(half[j])
      result[n]["interval_coverage_pct"] = float(100 * inside[:, j].mean())
      result[n]["interval_coverage_in_box_pct"] = float(100 * inside[~far, j].mean()) \
          if (~far).any() else None
      result[n]["interval_coverage_out_of_box_pct"] = float(100 * inside[far, j].mean()) \
          if far.any() else None
      result[n]["inputs_out_of_box_pct"] = float(100 * far.mean())
  return far, inside


def over_recordings_line(result: dict, names, inside, far, recording, seed: int):
  """The in-box coverage's spread over the recordings it rests on (`metrics.share_range`,
  90 %; into `result`): a recording's samples share one draw of its offset, so the
  coverage is a share over recordings, not over samples. None with fewer than two."""
  from calibrate import metrics
  groups = [(~far) & (recording == g) for g in np.unique(recording)]
  hits = np.array([inside[g].sum(axis=0) for g in groups])
  n = np.array([g.sum() for g in groups])
  lo, hi = metrics.share_range(hits, n, seed)
  if not np.isfinite(lo).all():
    return None
  for j, name in enumerate(names):
    result[name]["interval_coverage_in_box_lo90_pct"] = float(lo[j])
    result[name]["interval_coverage_in_box_hi90_pct"] = float(hi[j])
  return (f"the coverage in the box rests on {(n > 0).sum()} recordings (a recording's "
          f"samples share one draw of its offset): resampling them, 90 % of its values lie in "
          + ", ".join(f"{name} {a:.1f}-{b:.1f} %" for name, a, b in zip(names, lo, hi)))


def bias_said(result: dict, names, info, error, far, recording):
  """The mean error common to the test recordings, in the box, and its z over what the
  held-out recordings' offsets allow (`calibrate.info.common_bias`; into `result`): far out,
  these recordings differ from the training ones, which no interval sized on those sees.
  None without held-out offsets or two recordings in the box."""
  from calibrate import info as info_lib
  bias = info_lib.common_bias(error[~far], recording[~far], info.interval_offsets)
  count = len(np.unique(recording[~far]))
  if "test_bias_z" not in bias or count < 2:
    return None
  for j, name in enumerate(names):
    result[name]["test_common_bias"] = bias["test_common_bias"][j]
    result[name]["test_bias_z"] = bias["test_bias_z"][j]
  return info_lib.bias_line(bias, names, count, "the estimator's")


def question_lines(info, names, units) -> None:
  """The fit's held-out RMSE with the question it answers, beside this file's."""
  v = info.validation or {}
  if v.get("cv_rmse") and v.get("split") in common.QUESTIONS:
    print(f"the fit's held-out RMSE, {v['split']} held out (how far off "
          f"{common.QUESTIONS[v['split']]}): "
          + ", ".join(f"{n} {r:.4g} {u}" for n, r, u in zip(names, v["cv_rmse"], units)))
    print("a file the fit never saw asks what --split recordings answers; a later stretch "
          "of a training recording, what --split blocks answers")


def coverage_line(result: dict, names, far: np.ndarray, level: float) -> str:
  """The interval's coverage inside the training box and beyond it, per output."""
  def share(key):
    return ", ".join(f"{n} {result[n][key]:.1f} %" for n in names)
  text = f"{level:.0%} interval's coverage, inputs inside the training box ({(~far).sum()} " \
         f"samples): " + (share("interval_coverage_in_box_pct") if (~far).any() else "none")
  if far.any():
    text += f"; beyond it ({far.sum()} samples, {far.mean():.0%}; the interval widens " \
            f"with the distance): " + share("interval_coverage_out_of_box_pct")
  return text


def one_draw_line(info, level: float) -> str | None:
  """Said where the interval has a between-recordings part: one file is one draw of its
  offset, so its coverage is one draw of what the level promises over recordings."""
  if not info.between_width(level).any():
    return None
  return ("this file is one recording: its samples share one draw of its offset, so they "
          "fall inside nearly all or nearly none, and the level is a share over recordings: "
          "judge it over several test recordings' evaluations")


def print_table(result: dict, names, units, truth: np.ndarray, level: float,
                cover: bool) -> None:
  """The metrics per output, and which outputs' truth holds one value (a static load)."""
  print(f"{'output':8s} {'RMSE':>10s} {'NRMSE %':>8s} {'R2 %':>8s} {'median %':>9s} "
        f"{'worst %':>8s}" + (f" {f'in {level:.0%} int.':>12s}" if cover else "")
        + f" {'truth beyond fit %':>18s}")
  for n, u in zip(names, units):
    r = result[n]
    print(f"{n:8s} {r['rmse']:10.4g} {r['nrmse_pct']:8.2f} {r['r2_pct']:8.2f} "
          f"{r['median_pct']:9.2f} {r['worst_pct']:8.2f}"
          + (f" {r['interval_coverage_pct']:11.1f}%" if cover else "")
          + f" {r.get('truth_outside_training_pct', float('nan')):18.1f}   RMSE in {u}")
  if (held := [n for j, n in enumerate(names) if np.ptp(truth[:, j]) == 0]):
    print(f"{', '.join(held)}: the truth holds one value here (a static load): NRMSE, R2 "
          f"and worst % scale by its spread and are undefined (nan); RMSE holds")


def run(args) -> int:
  # two evaluations never fill one folder
  return files.holding(args.out, "--out", lambda out: _evaluate(args, out))


def _evaluate(args, out) -> int:
  from calibrate import estimators, figures, metrics as metrics_lib
  if not 0.5 <= args.level <= 0.999:
    raise errors.SettingError(f"--level {args.level} is out of range: allowed 0.5 to 0.999")
  est = estimators.Estimator.load(args.estimator)
  table, ready = common.new_recording(est, args, targets=True)
  x, truth = ready.x, ready.y  # the truth tared by the same rule, as in training
  # each file its own recording: a memory's filters and tares start afresh in each
  pred = est.predict(x, segments=ready.recording, **common.stream_of(est, table, ready))
  recordings = len(np.unique(ready.recording))
  several = recordings > 1
  names, units = est.info.outputs, est.info.output_units
  result = scores(pred, truth, names, units)
  info = est.info
  far, inside = interval_scores(info, x, truth, pred, args.level, result)
  if info.output_lo is not None:  # truth beyond what the fit saw: every method under-reaches
    beyond = (truth < info.output_lo) | (truth > info.output_hi)
    for j, n in enumerate(names):
      result[n]["truth_outside_training_pct"] = float(100 * beyond[:, j].mean())
  print(f"{est.kind.value} on {len(x)} samples of {table.path}")
  cover = info.interval_abs is not None
  print_table(result, names, units, truth, args.level, cover)
  if not cover:
    print("no interval: the estimator was fitted without grouped cross-validation")
  else:
    print(coverage_line(result, names, far, args.level))
    line = over_recordings_line(result, names, inside, far, ready.recording,
                                info.settings.get("seed", 0)) if several \
        else one_draw_line(info, args.level)
    if line is not None:
      print(line)
    if several and (line := bias_said(result, names, info, pred - truth, far,
                                      ready.recording)) is not None:
      print(line)
  question_lines(info, names, units)
  metrics = {"estimator": str(args.estimator), "csv": list(map(str, args.csv)),
             "recordings": recordings, "samples": len(x),
             "method": est.kind.value, "results": result}
  text = files.json_text(metrics, indent=1)
  files.write_text(out / "metrics.json", text)
  files.write_text(out / "metrics.csv", metrics_lib.csv_text(
      metrics_lib.scored("results", {est.kind.value: result})))
  t = None if several else table.seconds(args.time_column)  # each file's clock restarts
  t = np.arange(len(x), dtype=float) if t is None else t[ready.rows]
  label = f"calibrate evaluate {args.estimator.name} on " + (
      f"{recordings} recordings" if several else pathlib.Path(table.path).name)
  figures.save(figures.over_time(t, truth, {est.kind.value: pred}, names, "/".join(
      dict.fromkeys(units)), benchmark=label, seed=est.info.settings.get("seed", 0)),
      out, "over_time")
  figures.save(figures.scatter(truth, {est.kind.value: pred}, names, units, benchmark=label,
                               seed=est.info.settings.get("seed", 0)), out, "predicted_vs_true")
  print(f"wrote {out}/metrics.csv, metrics.json, figures/")
  return 0
