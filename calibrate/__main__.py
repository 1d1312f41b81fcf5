"""Command line: calibrate recordings from your own rig, kept as CSV.

  python -m calibrate fit --csv runs/*.csv --inputs 'p*' --targets Fx,Fy,Fz --method auto
  python -m calibrate compare --csv runs/*.csv --inputs 'p*' --targets Fx,Fy,Fz
  python -m calibrate predict estimator.npz --csv new.csv [--std] [--out predictions.csv]
  python -m calibrate evaluate estimator.npz --csv test.csv [--out DIR]
  python -m calibrate export estimator.npz --c OUT_DIR
  python -m calibrate example DIR

The CSV layout is `calibrate.csvfile`'s: a header row of names, an optional units row, one
row per sample, an increasing `time` column if any. Mistakes in the files or the arguments
print one line starting `error:` and exit with code 2.

Like every module of `calibrate`, this command imports nothing from `sim` or `benchmarks`:
it serves recordings from any rig.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
from typing import Optional

import numpy as np

from calibrate import csvfile, prepare, splits as splits_lib, streams
from util import cli, errors, files

METHODS = ("ls", "poly", "lsann", "nn", "gru", "auto")
# median % error counts samples above these magnitudes (the shell paper's: 0.2 N, 10 mN m)
THRESHOLDS = {"N": 0.2, "N m": 0.01, "Nm": 0.01}


def _parser() -> argparse.ArgumentParser:
  parser = argparse.ArgumentParser(
      prog="python -m calibrate", formatter_class=argparse.RawDescriptionHelpFormatter,
      description="Fit, apply, score and export force estimators on CSV recordings.",
      epilog="CSV layout:\n" + "\n".join(
          line for line in csvfile.__doc__.splitlines() if line.startswith("*")))
  sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
  for command, text in (("fit", "fit an estimator on CSV recordings"),
                        ("compare", "every method on the same held-out groups: the table")):
    p = sub.add_parser(command, help=text)
    _training_args(p)
    p.add_argument("--ensemble", type=int, default=1,
                   help="LSANN and NN (also within auto): the mean of networks from this "
                        "many seeds, which predict --std spreads; at few load states 5 "
                        "interpolate better than one (default 1)")
    if command == "fit":
      p.add_argument("--method", required=True, type=_method,
                     metavar="{" + ",".join(METHODS) + "}",
                     help="ls: linear least squares; poly: polynomial with cross terms; "
                          "lsann: LS plus a network on its residual; nn: the network alone; "
                          "gru: LS plus a small recurrent network (GRU) on its residual, "
                          "reading the inputs' past (needs the time column); auto: ls, "
                          "poly, lsann and nn on the same held-out groups, the best kept per "
                          "output")
      p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("estimator.npz"),
                     help="where to write the estimator (default estimator.npz)")
      p.add_argument("--per-channel", action="store_true",
                     help="poly: powers of each channel alone, no cross terms and no ridge "
                          "(the force-sensing-shell paper's pseudoinverse); default: every "
                          "product of total degree <= --degree, continued linearly beyond "
                          "the training box")
    else:
      p.add_argument("--out", type=cli.path_arg, default=None,
                     help="also write the table to this CSV file")
  for name, text in (("predict", "apply an estimator to a CSV recording"),
                     ("evaluate", "the papers' metrics and figures on held-out data")):
    p = sub.add_parser(name, help=text)
    p.add_argument("estimator", type=cli.path_arg, help="an estimator file `fit` wrote")
    p.add_argument("--csv", required=True, type=cli.path_arg, help="the recording")
    p.add_argument("--time-column", default="time", help="name of the time column (time)")
    _cleaning_args(p)
    _rails_args(p)
    if name == "predict":
      p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("predictions.csv"),
                     help="where to write the predictions (default predictions.csv)")
      p.add_argument("--std", action="store_true",
                     help="add a standard deviation column per output (<name>_sd)")
      p.add_argument("--interval", type=float, default=None, metavar="LEVEL",
                     help="add the interval at LEVEL (e.g. 0.95) as "
                          "<name>_lo and <name>_hi columns (from fit's held-out groups)")
    else:
      p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("evaluation"),
                     help="folder for metrics.csv, metrics.json and figures (evaluation/)")
      p.add_argument("--level", type=float, default=0.95,
                     help="the interval level whose coverage to report (default 0.95)")
  p = sub.add_parser("merge", help="two raw streams (sensor, reference) into one recording",
                     formatter_class=argparse.RawDescriptionHelpFormatter,
                     description=streams.__doc__)
  p.add_argument("pairs", type=cli.path_arg, nargs="+", metavar="SENSOR.csv REFERENCE.csv",
                 help="a sensor file and its reference file; several pairs for several "
                      "recordings")
  p.add_argument("--lag", type=_lag, default=None, metavar="SECONDS",
                 help="how much later the reference stamps the same event (its samples move "
                      "earlier by it); default: estimated from the data, and printed either "
                      "way")
  p.add_argument("--max-lag", type=float, default=1.0,
                 help="the largest lag the estimate considers, seconds (default 1)")
  p.add_argument("--max-gap", type=float, default=None, metavar="SECONDS",
                 help="the longest reference gap interpolated across (default "
                      f"{streams.GAP_PERIODS:g} median reference periods)")
  p.add_argument("--time-column", default="time", help="name of the time column (time)")
  _cleaning_args(p)
  p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("merged"),
                 help="folder for the merged recordings, one per pair, named after the "
                      "sensor file (default merged/)")
  p = sub.add_parser("export", help="write the estimator as dependency-free C99")
  p.add_argument("estimator", type=cli.path_arg, help="an estimator file `fit` wrote")
  p.add_argument("--c", dest="c_dir", required=True, type=cli.path_arg,
                 help="folder for estimator.h and estimator.c")
  p.add_argument("--fixed-point", action="store_true",
                 help="gru: the recurrent network in Q16 integers (a tanh table), about a tenth "
                      "of its soft-float cost on a Cortex-M3; its outputs then differ from "
                      "predict by Q16's rounding, not float32's")
  p = sub.add_parser("example", help="write the example recordings (the simulated footpad)",
                     description="Copies the example recordings shipped with the package: the "
                                 "simulated footpad's quick protocol at seed 0, every 20th "
                                 "sample. 'python -m benchmarks.run footpad_dataset --quick' "
                                 "writes them afresh from the simulator, to its results "
                                 "folder's csv/.")
  p.add_argument("out", type=cli.path_arg, help="folder for train.csv and test.csv")
  p.add_argument("--streams", action="store_true",
                 help="write them instead as raw stream pairs, as a rig logs them (for "
                      "`merge` and `fit --tare`): the training recording cut in three, each "
                      "with 1 s at rest in front, the sensor's baseline and the reference's "
                      "offset moved per recording, the reference at an irregular 250 Hz "
                      "stamped 25 ms late: trainK_sensor.csv, trainK_reference.csv, "
                      "test_sensor.csv, test_reference.csv")
  return parser


def _cleaning_args(p: argparse.ArgumentParser) -> None:
  """What every command that reads recordings may drop, counted: empty cells, repeated
  times."""
  p.add_argument("--drop-nan", action="store_true",
                 help="drop rows with an empty cell or NaN (counted) instead of refusing the "
                      "file")
  p.add_argument("--dedupe", choices=csvfile.DEDUPE, default=None,
                 help="rows repeating the previous row's time: 'mean' averages them, 'first' "
                      "keeps the first (counted); default: refuse the file")


def _rails_args(p: argparse.ArgumentParser) -> None:
  p.add_argument("--rails", type=_rails, default=None, metavar="LO,HI",
                 help="the ADC's rails in the inputs' units (e.g. 0,4095); default: a "
                      f"recording's min or max held {prepare.RAIL_HOLD} samples in a row; "
                      "samples there are reported per channel")
  p.add_argument("--drop-rails", action="store_true",
                 help="drop rows with an input at a rail (counted)")


def _rails(text: str) -> tuple[float, float]:
  try:
    lo, hi = (float(v) for v in text.split(","))
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r}: give two numbers, LO,HI") from None
  return lo, hi


def _lag(text: str) -> Optional[float]:
  if text.strip().lower() == "auto":
    return None
  try:
    return float(text)
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r} is not seconds or 'auto'") from None


def _training_args(p: argparse.ArgumentParser) -> None:
  """The options `fit` and `compare` share: the recordings, the columns, the split."""
  p.add_argument("--csv", required=True, type=cli.path_arg, nargs="+",
                 help="training recordings: one or more files or globs ('runs/*.csv'); each "
                      "file is a recording, held out whole by the default split")
  p.add_argument("--inputs", required=True,
                 help="sensor columns, comma-separated names or globs (e.g. 'p*')")
  p.add_argument("--targets", required=True, help="F/T columns, e.g. Fx,Fy,Fz")
  p.add_argument("--group", default=None,
                 help="a column whose value tells recordings apart within a file (e.g. a "
                      "trial number); with several files, groups are per file and value")
  p.add_argument("--split", default="auto", choices=splits_lib.HOW,
                 help="what validation holds out: auto (whole recordings where there are "
                      "several, else contiguous blocks as long as the inputs' "
                      "autocorrelation), recordings, blocks, or samples (single samples at "
                      "random, the LSANN paper's: flatters every method)")
  p.add_argument("--folds", type=int, default=5,
                 help="grouped cross-validation folds for the held-out error and the "
                      "interval (default 5; 0: none, and no interval)")
  p.add_argument("--level", type=float, default=0.95,
                 help="interval level to report (default 0.95; predict --interval takes any)")
  p.add_argument("--seed", type=int, default=0, help="one seed for every random draw")
  p.add_argument("--hidden", type=_hidden, default=10,
                 help="hidden units (default 10, the paper's), or 'auto': the width of "
                      f"{', '.join(map(str, WIDTHS))} with the lowest held-out error")
  p.add_argument("--weight-decay", type=float, default=0.0,
                 help="networks: the penalty lambda |w|^2 on the (scaled) weights, for data "
                      "with few distinct load states (default 0, trainlm's)")
  p.add_argument("--epochs", type=int, default=None,
                 help="epoch cap (default 1000, trainlm's); gru: the cap on Adam steps "
                      "(default 3000)")
  p.add_argument("--degree", type=int, default=3,
                 help="poly: the highest degree (default 3); with cross-validation the degree "
                      "1..this and the ridge weight are chosen on held-out groups")
  p.add_argument("--val-fraction", type=float, default=0.15,
                 help="share held out for early stopping and the residual spread (0.15)")
  p.add_argument("--time-column", default="time", help="name of the time column (time)")
  p.add_argument("--no-progress", action="store_true", help="no progress bar")
  _cleaning_args(p)
  _rails_args(p)
  p.add_argument("--tare", type=float, default=None, metavar="SECONDS",
                 help="the first SECONDS of each recording are unloaded: each input and "
                      "target less its median there; the estimator keeps the rule for "
                      "predict, evaluate and the C export")
  p.add_argument("--tare-column", default=None, metavar="FLAG",
                 help="as --tare, the unloaded rows being those where the column FLAG is 0 "
                      "(a contact flag)")
  p.add_argument("--history", type=_history, default=None, metavar="auto|SECONDS,...",
                 help="give the estimator the recording's past (`calibrate.temporal`): each "
                      "input's high-pass at these time constants and its first difference "
                      "('auto': chosen on held-out recordings); needs the time column")
  p.add_argument("--track-drift", type=float, default=None, metavar="NEWTONS",
                 help="re-zero each input during unloaded intervals, those where the LS map's "
                      "third target (the normal force) reads under NEWTONS for 21 samples; "
                      "needs the time column")
  p.add_argument("--unwrap", type=int, default=None, metavar="BITS",
                 help="undo wrap-around of BITS-bit registers (one-sample jumps over half "
                      "the range, which are reported either way): +-2**BITS times the "
                      "channel's smallest step")


WIDTHS = (5, 10, 20, 40, 64)  # --hidden auto's candidates


def _history(text: str):
  """--history: 'auto' or time constants in seconds, comma-separated."""
  if text.strip().lower() == "auto":
    return "auto"
  try:
    taus = tuple(float(t) for t in text.split(",") if t.strip())
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r} is not 'auto' or seconds, e.g. 0.1,1") from None
  if not taus or not all(np.isfinite(t) and t > 0 for t in taus):
    raise argparse.ArgumentTypeError(f"{text!r}: time constants are seconds > 0")
  return taus


def _hidden(text: str):
  """--hidden: a positive integer or 'auto'."""
  if text.strip().lower() == "auto":
    return "auto"
  try:
    return int(text)
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r} is not a number of units or 'auto'") from None


def _config(args):
  """(network settings, widths to choose from) of the options."""
  from calibrate.parts import mlp
  auto = args.hidden == "auto"
  config = mlp.LMConfig(hidden=10 if auto else args.hidden,
                        epochs=1000 if args.epochs is None else args.epochs,
                        weight_decay=args.weight_decay)
  config.validate()
  return config, WIDTHS if auto else ()


def _gru_config(args):
  """The recurrent network's settings of the options (--hidden, --epochs as its steps)."""
  from calibrate.parts import gru
  if args.method != "gru":
    return gru.GRUConfig()
  if args.hidden == "auto":
    raise errors.SettingError("--hidden auto chooses the width of lsann and nn: give gru a "
                              "number of hidden units (--hidden 8)")
  config = gru.GRUConfig(hidden=args.hidden, **(
      {} if args.epochs is None else {"steps": args.epochs}))
  config.validate()
  return config


def _method(text: str) -> str:
  """--method's value; a typo is answered with the closest method."""
  if text.lower() in METHODS:
    return text.lower()
  raise argparse.ArgumentTypeError(str(errors.unknown("method", text, METHODS)))


def _list(text: str) -> list[str]:
  return [t.strip() for t in text.split(",") if t.strip()]


def _steps(args):
  """The preparation steps `fit` and `compare` were asked for."""
  tare = None
  if args.tare is not None or args.tare_column is not None:
    if args.tare is not None and args.tare_column is not None:
      raise errors.SettingError("--tare and --tare-column: give one of them")
    tare = prepare.Tare(args.tare, args.tare_column, args.time_column)
  return prepare.Steps(args.unwrap, args.rails, args.drop_rails, tare)


def _training(args):
  """(table, x, y, groups, names) of `fit` and `compare`, every option checked first."""
  if not 0 <= args.folds <= 20:
    raise errors.SettingError(f"--folds {args.folds} is out of range: allowed 0 to 20")
  if not 0.5 <= args.level <= 0.999:
    raise errors.SettingError(f"--level {args.level} is out of range: allowed 0.5 to 0.999")
  steps = _steps(args)
  tables, table, recording = csvfile.read_many(args.csv, args.time_column,
                                               drop_nan=args.drop_nan, dedupe=args.dedupe)
  ins = table.columns(_list(args.inputs), "--inputs")
  outs = table.columns(_list(args.targets), "--targets")
  if set(ins) & set(outs):
    raise errors.SettingError("--inputs and --targets share columns: "
                              + ", ".join(table.names[i] for i in set(ins) & set(outs)))
  ready = prepare.apply(tables, ins, outs, steps)
  for line in table.cleaned + ready.said:
    print(line)
  recording = recording[ready.rows]
  if args.group is not None:
    (g,) = table.columns([args.group], "--group")
    if g in ins or g in outs:
      raise errors.SettingError(f"--group {args.group} is also an input or a target")
    column = table.data[ready.rows, g]
    recording = recording * (1 + int(np.abs(column).max())) + column
  x, y = ready.x, ready.y
  args.prepared = ready.record
  args.recording = recording  # each row's recording: the temporal front end's segments
  args.dt = _sample_time(table, args, ready.rows, recording) \
      if getattr(args, "history", None) is not None or getattr(args, "track_drift", None) \
      is not None or getattr(args, "method", None) == "gru" else None
  try:
    groups = splits_lib.groups(len(x), args.split, recording, x)
  except errors.SettingError as err:  # too few rows or recordings: say which file
    raise errors.DataError(f"{table.path}: {len(table.data)} data row(s) in {recording.max() + 1} "
                           f"recording(s), --split {args.split}: {err}") from None
  names = dict(inputs=[table.names[i] for i in ins], outputs=[table.names[i] for i in outs],
               input_units=[table.units[i] or "counts" for i in ins],
               output_units=[table.units[i] or "N" for i in outs])
  return table, x, y, groups, names


def _static_only(what: str, args) -> None:
  """Refuses the temporal front end's options where they would not be read."""
  if args.history is not None or args.track_drift is not None:
    raise errors.SettingError(f"{what} compares static estimators: --history and "
                              f"--track-drift go with fit --method ls, poly, lsann, nn or gru")


def _sample_time(table, args, rows, recording) -> float:
  """s between samples: the median step of the time column within recordings."""
  t = table.column(args.time_column)
  if t is None:
    raise errors.SettingError(f"--history, --track-drift and --method gru read the recording "
                              f"in time: "
                              f"the files need a {args.time_column!r} column (or name it "
                              f"with --time-column)")
  t = t[rows]
  step = np.diff(t)[np.diff(recording) == 0]
  if not len(step):
    raise errors.DataError(f"{table.path}: too few rows to tell the time between samples")
  return float(np.median(step))


def _held_out_groups(what: str, groups, args) -> None:
  """Refuses a choice made on held-out groups when there are none to hold out."""
  if groups.count < 2 or args.folds < 2:
    raise errors.SettingError(f"{what} chooses on held-out groups: give --folds 2 or more, "
                              f"and data that make two groups or more")


def _auto(args, x, y, groups, names):
  from calibrate import estimators
  from util.progress import progress_bar, quiet
  _held_out_groups("--method auto", groups, args)
  config, widths = _config(args)
  return estimators.fit_auto(
      x, y, groups, args.folds, config=config, widths=widths, seed=args.seed,
      val_fraction=args.val_fraction, degree=args.degree, ensemble=args.ensemble,
      progress=quiet if args.no_progress else progress_bar("training"), **names)


def compare(args) -> int:
  _static_only("compare", args)
  if args.out is not None:
    files.output_file(args.out, "--out", (".csv",))
  table, x, y, groups, names = _training(args)
  print(f"{len(x)} samples of {table.path}; validation: {groups.describe()}")
  est, candidates = _auto(args, x, y, groups, names)
  _print_candidates(est, candidates)
  if args.out is not None:
    import csv
    import io
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["method"] + [f"{n}_cv_rmse" for n in names["outputs"]] + ["fit_seconds"])
    writer.writerows([m] + [repr(v) for v in row["cv_rmse"]] + [repr(row["seconds"])]
                     for m, row in candidates.items())
    writer.writerow(["kept"] + est.info.validation["chosen"] + [""])
    files.write_text(args.out, buf.getvalue())
    print(f"wrote {args.out}")
  return 0


def fit(args) -> int:
  from calibrate import estimators
  files.output_file(args.out, "--out", (".npz",))
  if args.method == "auto":
    _static_only("fit --method auto", args)
  table, x, y, groups, names = _training(args)
  if args.method == "auto":
    est, candidates = _auto(args, x, y, groups, names)
    est = _with_preparation(est, args.prepared)
    est.save(args.out)
    _print_candidates(est, candidates)
    _report_fit(est, table, args, y, groups)
    print(f"wrote {args.out}")
    return 0
  from util.progress import progress_bar, quiet
  progress = quiet if args.no_progress else progress_bar("training")
  config, widths = _config(args)
  if widths:
    _held_out_groups("--hidden auto", groups, args)
  common = dict(config=config, widths=widths, val_fraction=args.val_fraction,
                degree=args.degree, ensemble=args.ensemble, progress=progress,
                groups=groups, folds=args.folds if groups.count >= 2 else 0,
                cross=args.method == "poly" and not args.per_channel)
  kind = estimators.Kind(args.method.upper())
  try:
    if args.dt is None:
      est = estimators.fit(kind, x, y, seed=args.seed, **names, **common)
    else:
      from calibrate.parts import memory
      est = estimators.fit_temporal(
          kind, x, y, args.dt, segments=args.recording, seed=args.seed,
          taus=None if args.history == "auto" else (args.history or ()),
          differences=args.history is not None,
          tare=None if args.track_drift is None else memory.Tare(args.track_drift),
          gru=_gru_config(args), **names, **common)
    est = _with_preparation(est, args.prepared)
  except errors.DataError as err:  # say which file, and how many rows it gave
    raise errors.DataError(f"{table.path}: {len(table.data)} data row(s), "
                           f"{args.val_fraction:.0%} of them held out for validation: "
                           f"{err}") from None
  est.save(args.out)
  _report_fit(est, table, args, y, groups)
  print(f"wrote {args.out}")
  return 0


def _with_preparation(est, record: dict):
  """The estimator with the preparation its inputs had (unwrap periods, tare rule) in its
  settings, which `predict`, `evaluate` and the C export apply to new recordings."""
  import dataclasses
  return dataclasses.replace(est, info=dataclasses.replace(
      est.info, settings={**est.info.settings, "prepare": record}))


def _new_recording(est, args, targets: bool = False):
  """(table, `prepare.Prepared`) of `predict` and `evaluate`: the recording read and
  prepared as the estimator's training recordings were (its unwrap and tare), with the
  estimator's outputs as targets when `targets` (tared by the same rule)."""
  table = csvfile.read(args.csv, args.time_column, drop_nan=args.drop_nan,
                       dedupe=args.dedupe)
  names = est.info.inputs if est.info is not None else None
  if names is None:
    raise errors.DataError(f"{args.command}: the estimator holds no input names (fitted "
                           f"before they were saved): fit it again")
  ins = table.columns(list(names), "--csv (the estimator's inputs)")
  outs = table.columns(list(est.info.outputs), "--csv (the estimator's outputs)") \
      if targets else None
  record = est.info.settings.get("prepare") or {}
  periods = record.get("unwrap_periods")
  tare = prepare.Tare.from_json(record.get("tare"))
  ready = prepare.apply([table], ins, outs, prepare.Steps(None, args.rails, args.drop_rails,
                                                          tare),
                        None if periods is None else np.asarray(periods))
  for line in table.cleaned + ready.said:
    print(line)
  return table, ready


def _print_candidates(est, candidates: dict) -> None:
  """The held-out RMSE of every candidate per output, the kept one marked."""
  info = est.info
  print(f"{'method':8s} " + " ".join(f"{n:>12s}" for n in info.outputs) + f" {'fit s':>8s}")
  chosen = info.validation["chosen"]
  for method, row in candidates.items():
    print(f"{method:8s} " + " ".join(
        f"{v:11.4g}{'*' if chosen[j] == method else ' '}" for j, v in enumerate(row["cv_rmse"]))
        + f" {row['seconds']:8.1f}")
  print("held-out RMSE per output (grouped cross-validation); * the method kept for it")


def _report_fit(est, table, args, y: np.ndarray, groups) -> None:
  """What `fit` prints: the data, the split, the held-out error and the interval."""
  info = est.info
  units = info.output_units
  print(f"fitted {est.kind.value} on {info.samples} samples of {table.path} "
        f"({len(info.inputs)} inputs -> {', '.join(info.outputs)})")
  v = info.validation
  print(f"validation: {groups.describe()}")
  if "width_cv" in info.settings:
    table = info.settings["width_cv"]
    print(f"network width {info.settings['config']['hidden']} (held-out error, each output's "
          f"MSE over its variance: " + ", ".join(f"{w}: {v:.3g}" for w, v in table.items())
          + ")")
  if info.settings.get("cross"):
    print(f"polynomial: every product of total degree <= {info.settings['degree']}, ridge "
          f"{info.settings['ridge_per_sample']:g} per sample"
          + (" (both chosen by grouped cross-validation)" if "poly_cv_mse" in info.settings
             else "") + "; linear beyond the training box")
  if v:
    print(f"held-out error ({v['folds']}-fold grouped cross-validation), RMSE: " + ", ".join(
        f"{n} {r:.4g} {u}" for n, r, u in zip(info.outputs, v["cv_rmse"], units)))
    half = info.half_width(args.level)
    scale = np.abs(y).max(axis=0)
    print(f"{args.level:.0%} interval (held-out groups): " + ", ".join(
        f"{n} +-{h:.4g} {u} ({h / s:.1%} of full scale {s:.4g})" if s > 0 else
        f"{n} +-{h:.4g} {u}" for n, h, u, s in zip(info.outputs, half, units, scale)))
    between = info.between_width(args.level)
    if between.any():
      g = len(info.interval_offsets)
      print(f"  of which how far a new group's mean error may lie (Student's t over {g} "
            f"groups' means): " + ", ".join(f"{n} +-{b:.4g} {u}" for n, b, u in
                                            zip(info.outputs, between, units))
            + ("; more recordings narrow it" if g < 8 else ""))
    if v.get("ls_only"):
      print(f"LSANN keeps only its LS stage on {', '.join(v['ls_only'])}: its network did not "
            f"beat the LS stage on held-out groups there")
  else:
    print("no cross-validation (--folds 0, or a single group): no interval; the validation "
          "residual sd " + ", ".join(f"{n} {s:.4g} {u}" for n, s, u in
                                     zip(info.outputs, info.residual_sd, units)))
  stops = [m.training for m in (est.members or (est,)) if m.training is not None]
  if len(stops) > 3:  # an ensemble: the spread, not a line per network
    why = sorted({t.stop.value for t in stops})
    epochs = np.array([t.epochs for t in stops])
    print(f"training stopped: {len(stops)} networks ({'; '.join(why)}), after "
          f"{epochs.min()}-{epochs.max()} epochs (median {np.median(epochs):.0f}), "
          f"{sum(t.seconds for t in stops):.1f} s in all")
  elif stops and est.rnn is not None:  # a recurrent network: Adam steps, held-out checks
    t = stops[0]
    why = "the step cap" if t.stop.name == "MAX_EPOCHS" else \
        f"{est.info.settings['gru']['patience']} held-out checks without a better error"
    print(f"training stopped: {why} after {t.epochs} Adam steps ({t.seconds:.1f} s); kept "
          f"the weights of step {t.best_epoch}")
  elif stops:
    print("training stopped: " + "; ".join(
        f"{t.stop.value} after {t.epochs} epochs ({t.seconds:.1f} s)" for t in stops))


def predict(args) -> int:
  from calibrate import estimators
  files.output_file(args.out, "--out", (".csv",))
  est = estimators.Estimator.load(args.estimator)
  if args.interval is not None:
    est.info.half_width(args.interval)  # a level out of range, or no interval: say so first
  table, ready = _new_recording(est, args)
  x = ready.x
  pred, sd = est.predict(x, return_std=True)
  names, units, cols = list(est.info.outputs), list(est.info.output_units), [pred]
  a = len(est.info.outputs)
  if args.std:
    names += [f"{n}_sd" for n in est.info.outputs]
    units += units[:a]
    cols.append(sd)
  if args.interval is not None:
    half = est.info.half_width(args.interval)
    names += [f"{n}_{end}" for end in ("lo", "hi") for n in est.info.outputs]
    units += units[:a] * 2
    cols += [pred - half, pred + half]
  t = table.column(args.time_column)
  if t is not None:
    names, units, cols = ([args.time_column] + names, ["s"] + units,
                          [t[ready.rows, None]] + cols)
  csvfile.write(args.out, names, np.hstack(cols), units)
  print(f"{len(x)} predictions of {', '.join(est.info.outputs)} to {args.out}")
  return 0


def scores(pred: np.ndarray, truth: np.ndarray, names, units) -> dict:
  """The papers' metrics per output: RMSE (its unit), NRMSE %, R2 %, median % error (over
  samples above `THRESHOLDS` of the unit) and worst error as % of the range."""
  from calibrate import metrics
  out = {}
  for i, (name, unit) in enumerate(zip(names, units)):
    one = metrics.summary(pred[:, i:i + 1], truth[:, i:i + 1], (name,),
                          THRESHOLDS.get(unit, 0.0))
    out[name] = one[name]
  return out


def evaluate(args) -> int:
  from calibrate import estimators, figures, metrics as metrics_lib
  out = files.output_folder(args.out, "--out")
  if not 0.5 <= args.level <= 0.999:
    raise errors.SettingError(f"--level {args.level} is out of range: allowed 0.5 to 0.999")
  est = estimators.Estimator.load(args.estimator)
  table, ready = _new_recording(est, args, targets=True)
  x, truth = ready.x, ready.y  # the truth tared by the same rule, as in training
  pred = est.predict(x)
  names, units = est.info.outputs, est.info.output_units
  result = scores(pred, truth, names, units)
  info = est.info
  if info.interval_abs is not None:  # the interval fit promised, against what it covers here
    half = info.half_width(args.level)
    inside = np.abs(truth - pred) <= half
    for j, n in enumerate(names):
      result[n]["interval_half_width"] = float(half[j])
      result[n]["interval_coverage_pct"] = float(100 * inside[:, j].mean())
  if info.output_lo is not None:  # truth beyond what the fit saw: every method under-reaches
    beyond = (truth < info.output_lo) | (truth > info.output_hi)
    for j, n in enumerate(names):
      result[n]["truth_outside_training_pct"] = float(100 * beyond[:, j].mean())
  print(f"{est.kind.value} on {len(x)} samples of {args.csv}")
  cover = info.interval_abs is not None
  print(f"{'output':8s} {'RMSE':>10s} {'NRMSE %':>8s} {'R2 %':>8s} {'median %':>9s} "
        f"{'worst %':>8s}" + (f" {f'in {args.level:.0%} int.':>12s}" if cover else "")
        + f" {'truth beyond fit %':>18s}")
  for n, u in zip(names, units):
    r = result[n]
    print(f"{n:8s} {r['rmse']:10.4g} {r['nrmse_pct']:8.2f} {r['r2_pct']:8.2f} "
          f"{r['median_pct']:9.2f} {r['worst_pct']:8.2f}"
          + (f" {r['interval_coverage_pct']:11.1f}%" if cover else "")
          + f" {r.get('truth_outside_training_pct', float('nan')):18.1f}   RMSE in {u}")
  if not cover:
    print("no interval: the estimator was fitted without grouped cross-validation")
  metrics = {"estimator": str(args.estimator), "csv": str(args.csv), "samples": len(x),
             "method": est.kind.value, "results": result}
  text = files.json_text(metrics, indent=1)
  files.write_text(out / "metrics.json", text)
  files.write_text(out / "metrics.csv", metrics_lib.csv_text(
      metrics_lib.scored("results", {est.kind.value: result})))
  t = table.column(args.time_column)
  t = np.arange(len(x), dtype=float) if t is None else t[ready.rows]
  label = f"calibrate evaluate {args.estimator.name} on {args.csv.name}"
  figures.save(figures.over_time(t, truth, {est.kind.value: pred}, names, "/".join(
      dict.fromkeys(units)), benchmark=label, seed=est.info.settings.get("seed", 0)),
      out, "over_time")
  figures.save(figures.scatter(truth, {est.kind.value: pred}, names, units, benchmark=label,
                               seed=est.info.settings.get("seed", 0)), out, "predicted_vs_true")
  print(f"wrote {out}/metrics.csv, metrics.json, figures/")
  return 0


def export(args) -> int:
  from calibrate import cexport, estimators
  files.output_folder(args.c_dir, "--c")
  est = estimators.Estimator.load(args.estimator)
  if args.fixed_point and est.rnn is None:
    raise errors.SettingError(f"--fixed-point writes a recurrent network in integers: "
                              f"{args.estimator} is {est.kind.value}, which has none (fit "
                              f"--method gru)")
  report = cexport.write(est, args.c_dir, fixed_point=args.fixed_point)
  print(report.text())
  return 0


def merge(args) -> int:
  from calibrate import streams
  if len(args.pairs) % 2:
    raise errors.SettingError(f"merge takes files in pairs, SENSOR.csv REFERENCE.csv: got "
                              f"{len(args.pairs)} files")
  if not 0 < args.max_lag <= 60:
    raise errors.SettingError(f"--max-lag {args.max_lag:g} is out of range: allowed (0, 60] s")
  out = files.output_folder(args.out, "--out")
  pairs = list(zip(args.pairs[::2], args.pairs[1::2]))
  stems = [pathlib.Path(a).stem for a, _ in pairs]
  if len(set(stems)) != len(stems):
    raise errors.SettingError("two sensor files share a name; the merged recordings are named "
                              "after them: rename one")
  done = []
  for (a, b), stem in zip(pairs, stems):
    sensor = csvfile.read(a, args.time_column, drop_nan=args.drop_nan, dedupe=args.dedupe)
    reference = csvfile.read(b, args.time_column, drop_nan=args.drop_nan, dedupe=args.dedupe)
    for line in sensor.cleaned + reference.cleaned:
      print(line)
    m = streams.merge(sensor, reference, args.lag, args.max_gap, args.time_column,
                      args.max_lag)
    csvfile.write(out / f"{stem}.csv", m.names, m.data, m.units)
    print(m.describe(str(a)))
    done.append(m)
  lags = [m.lag * 1e3 for m in done]
  print(f"merged {len(done)} pair(s): {sum(len(m.data) for m in done):,} rows kept, "
        f"{sum(m.outside for m in done):,} outside the overlap and "
        f"{sum(m.in_gaps for m in done):,} in reference gaps dropped, lag "
        + (f"{lags[0]:.1f} ms" if len(set(np.round(lags, 1))) == 1 else
           f"{min(lags):.1f}-{max(lags):.1f} ms") + f"; wrote {out}/")
  return 0


EXAMPLES = pathlib.Path(__file__).parent / "examples"


def example(args) -> int:
  files.output_folder(args.out, "the example folder")
  written = []
  if args.streams:
    written = _example_streams(args.out)
  else:
    for name in ("train.csv", "test.csv"):
      files.write_text(args.out / name, (EXAMPLES / name).read_text())
      written.append(args.out / name)
  for path in written:
    print(f"wrote {path}")
  return 0


EXAMPLE_LAG = 0.025  # s: how late the example reference stamps an event
EXAMPLE_REST = 1.0  # s at rest in front of every example stream recording


def _example_streams(out: pathlib.Path) -> list[pathlib.Path]:
  """The example recordings as raw stream pairs (`example --streams`): a demonstration of
  the commands, made from the 50 Hz example (the reference is interpolated from it);
  `python -m benchmarks.run raw_streams` measures the same steps on 1 kHz simulator data."""
  from calibrate import streams
  rng = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(24,)))
  written = []
  # the pad at rest: the training recording's least loaded row (|F| 0.1 N; the test paths
  # never unload)
  train = csvfile.read(EXAMPLES / "train.csv")
  rest = train.data[np.argmin(np.linalg.norm(train.data[:, -3:], axis=1)), 1:-3]
  for part, pieces in (("train", 3), ("test", 1)):
    table = csvfile.read(EXAMPLES / f"{part}.csv")
    ins, outs = table.columns(["p*"], "p*"), table.columns(["Fx", "Fy", "Fz"], "F")
    t = table.column("time")
    dt = float(np.median(np.diff(t)))
    # cut where the pad is least loaded near each third: a recording starts off the plate
    load = np.linalg.norm(table.data[:, outs], axis=1)
    w = len(t) // 10
    cuts = [int(c - w + np.argmin(load[c - w:c + w])) for c in
            (len(t) * np.arange(1, pieces) // pieces)]
    for k, rows in enumerate(np.split(np.arange(len(t)), cuts)):
      n = int(round(EXAMPLE_REST / dt))
      x = np.vstack([np.round(rest + rng.normal(0, 1.5, (n, len(ins)))),
                     table.data[rows][:, ins]])
      y = np.vstack([rng.normal(0, 0.1, (n, len(outs))), table.data[rows][:, outs]])
      name = f"{part}{k + 1}" if pieces > 1 else part
      pair = streams.two_streams(np.arange(len(x)) * dt, x, y,
                                 [table.names[i] for i in ins], [table.names[i] for i in outs],
                                 lag=EXAMPLE_LAG, rng=rng, x_offset=40.0, y_offset=3.0,
                                 x_units=[table.units[i] for i in ins],
                                 y_units=[table.units[i] for i in outs], name=name)
      for one in pair:
        written.append(csvfile.write(out / one.path, one.names, one.data, one.units))
  return written


def main(argv: Optional[list[str]] = None) -> int:
  args = _parser().parse_args(argv)
  command = {"fit": fit, "compare": compare, "predict": predict, "evaluate": evaluate,
             "export": export, "example": example, "merge": merge}[args.command]
  return cli.run(lambda: command(args), "calibrate", "interrupted: nothing was written")


if __name__ == "__main__":
  sys.exit(main())
