"""What the commands share: the training options and data, the preparation record, the
method's options checked against the families it is built from."""

from __future__ import annotations

import argparse

import numpy as np

from calibrate import csvfile, parts, prepare, splits as splits_lib
from util import cli, errors

METHODS = tuple(parts.METHODS)
# median % error counts samples above these magnitudes (the shell paper's: 0.2 N, 10 mN m)
THRESHOLDS = {"N": 0.2, "N m": 0.01, "Nm": 0.01}
# the model options' defaults, filled in after `check_options` has seen what was given
DEFAULTS = {"hidden": 10, "degree": 3, "ensemble": 1}


def check_options(args, method: str) -> None:
  """Refuses a model option that `method` does not read (its families declare the ones
  they do: `calibrate.parts.OPTIONS`), then fills the defaults of the ones not given."""
  allowed = parts.options(method)
  for flag in sorted({f for o in parts.OPTIONS.values() for f in o}):
    value = getattr(args, flag[2:].replace("-", "_"), None)
    if value not in (None, False) and flag not in allowed:
      reads = ", ".join(sorted(allowed)) or "none of the model options"
      raise errors.SettingError(f"{flag} is not an option of --method {method}: it reads "
                                f"{reads}")
  for key, value in DEFAULTS.items():
    if getattr(args, key, None) is None:
      setattr(args, key, value)


def cleaning_args(p: argparse.ArgumentParser) -> None:
  """What every command that reads recordings may drop, counted: empty cells, repeated
  times."""
  p.add_argument("--drop-nan", action="store_true",
                 help="drop rows with an empty cell or NaN (counted) instead of refusing the "
                      "file")
  p.add_argument("--dedupe", choices=csvfile.DEDUPE, default=None,
                 help="rows repeating the previous row's time: 'mean' averages them, 'first' "
                      "keeps the first (counted); default: refuse the file")


def recording_args(p: argparse.ArgumentParser, together: str) -> None:
  """The options of the commands that apply an estimator to one or more recordings, each
  its own; `together`: what the command does with several."""
  p.add_argument("estimator", type=cli.path_arg, help="an estimator file `fit` wrote")
  p.add_argument("--csv", required=True, nargs="+", type=cli.path_arg,
                 help="the recordings: one or more files or globs ('test/*.csv'), each its "
                      f"own recording (tared and filtered afresh), {together}")
  p.add_argument("--time-column", default="time", help="name of the time column (time)")
  cleaning_args(p)
  rails_args(p)


def rails_args(p: argparse.ArgumentParser) -> None:
  p.add_argument("--rails", type=rails, default=None, metavar="LO,HI",
                 help="the ADC's rails in the inputs' units (e.g. 0,4095); default: a "
                      f"recording's min or max held {prepare.RAIL_HOLD} samples in a row; "
                      "samples there are reported per channel")
  p.add_argument("--drop-rails", action="store_true",
                 help="drop rows with an input at a rail (counted)")


def rails(text: str) -> tuple[float, float]:
  try:
    lo, hi = (float(v) for v in text.split(","))
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r}: give two numbers, LO,HI") from None
  return lo, hi


def preparation_args(p: argparse.ArgumentParser) -> None:
  """What `fit` and `compare` do to the recordings before fitting: tare, front end, unwrap."""
  p.add_argument("--tare", type=float, default=None, metavar="SECONDS",
                 help="the first SECONDS of each recording are unloaded: each input and "
                      "target less its median there; the estimator keeps the rule for "
                      "predict, evaluate and the C export")
  p.add_argument("--tare-column", default=None, metavar="FLAG",
                 help="as --tare, the unloaded rows being those where the column FLAG is 0 "
                      "(a contact flag)")
  p.add_argument("--history", type=history, default=None, metavar="auto|SECONDS,...",
                 help="give the estimator the recording's past (`calibrate.parts.memory`): each "
                      "input's high-pass at these time constants and its first difference "
                      "('auto': chosen on held-out recordings); needs the time column")
  p.add_argument("--track-drift", type=float, default=None, metavar="NEWTONS",
                 help="re-zero each input during unloaded intervals, those where the LS map's "
                      "normal force (--drift-axis) reads under NEWTONS for 21 samples; "
                      "needs the time column")
  p.add_argument("--contact-column", default=None, metavar="FLAG",
                 help="re-zero each input during unloaded intervals as --track-drift does, "
                      "those being where the column FLAG is 0 (a contact flag of 0s and 1s) "
                      "rather than where a force reads low; predict and evaluate "
                      "read the same column; needs the time column")
  p.add_argument("--drift-axis", default=None, metavar="TARGET",
                 help="--track-drift: the target that is the normal force (default: the "
                      "third target, or the only one of a one-axis sensor)")
  p.add_argument("--unwrap", type=int, default=None, metavar="BITS",
                 help="undo wrap-around of BITS-bit registers (one-sample jumps over half "
                      "the range, which are reported either way, or two in a row around a "
                      "repaired row): +-2**BITS times the channel's smallest step")
  p.add_argument("--unwrap-period", type=float, default=None, metavar="VALUE",
                 help="as --unwrap, the period given in the inputs' units (for values not "
                      "on one grid of their bit: scaled or filtered registers)")


def training_args(p: argparse.ArgumentParser) -> None:
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
  p.add_argument("--folds", type=folds, default="auto",
                 help="grouped cross-validation folds for the held-out error and the "
                      "interval: a number 2 to 20, 0 (none, and no interval), or auto (the "
                      "default): 10 where the split holds out 20 whole recordings or more "
                      "(a few dozen load states: each fold then trains on 90 %% of them), "
                      "else 5")
  p.add_argument("--level", type=float, default=0.95,
                 help="interval level to report (default 0.95; predict --interval takes any)")
  p.add_argument("--seed", type=int, default=0, help="one seed for every random draw")
  p.add_argument("--hidden", type=hidden, default=None,
                 help="hidden units (default 10, the paper's), or 'auto': the width of "
                      f"{', '.join(map(str, WIDTHS))} with the lowest held-out error")
  p.add_argument("--layers", type=layers, default=None, metavar="auto|W[,W]",
                 help="mlp (also within auto): the perceptron's hidden layers, e.g. 64,64; "
                      "default auto: one or two layers of 16 to 128 units, chosen on held-out "
                      "groups")
  p.add_argument("--activation", choices=("auto", "relu", "tanh"), default=None,
                 help="mlp (also within auto): the perceptron's units; default auto: relu "
                      "(scikit-learn's) or tanh, chosen on held-out groups at the layers kept")
  p.add_argument("--weight-decay", type=float, default=None,
                 help="networks: the penalty lambda |w|^2 on the (scaled) weights, for data "
                      "with few distinct load states (default 0, trainlm's); mlp: AdamW's "
                      "decoupled decay (default 1e-4, scikit-learn's alpha)")
  p.add_argument("--epochs", type=int, default=None,
                 help="epoch cap (default 1000, trainlm's); gru: the cap on Adam steps "
                      "(default 3000); mlp: the cap on held-out checks, 50 AdamW steps "
                      "apart (default 300)")
  p.add_argument("--degree", type=int, default=None,
                 help="poly: the highest degree (default 3); with cross-validation the degree "
                      "1..this and the ridge weight are chosen on held-out groups")
  p.add_argument("--val-fraction", type=float, default=0.15,
                 help="share held out for early stopping and the residual spread (0.15)")
  p.add_argument("--time-column", default="time", help="name of the time column (time)")
  p.add_argument("--no-progress", action="store_true", help="no progress bar")
  cleaning_args(p)
  rails_args(p)
  preparation_args(p)
  p.add_argument("--ensemble", type=int, default=None,
                 help="LSANN, NN and MLP: the mean of networks from this many seeds, which "
                      "predict --std spreads; at few load states 5 interpolate better than "
                      "one (default 1). With --method auto, each network's mean (NNx5) is "
                      "weighed beside the single network, kept where it beats it by more "
                      "than a standard error")


WIDTHS = (5, 10, 20, 40, 64)  # --hidden auto's candidates


def history(text: str):
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


def _auto_or_count(what: str):
  """An argparse type: 'auto', or a whole number (of `what`)."""
  def parse(text: str):
    if text.strip().lower() == "auto":
      return "auto"
    try:
      return int(text)
    except ValueError:
      raise argparse.ArgumentTypeError(f"{text!r} is not a number of {what} or 'auto'") \
          from None
  return parse


folds = _auto_or_count("folds")  # --folds: `splits.fold_count` of the groups where 'auto'
hidden = _auto_or_count("units")  # --hidden: 'auto' chooses among `WIDTHS`


def net_config(args):
  """(network settings, widths to choose from) of the options."""
  from calibrate.parts import mlp
  auto = args.hidden == "auto"
  config = mlp.LMConfig(hidden=10 if auto else args.hidden,
                        epochs=1000 if args.epochs is None else args.epochs,
                        weight_decay=args.weight_decay or 0.0)
  config.validate()
  return config, WIDTHS if auto else ()


def deep_options(args) -> dict:
  """The perceptron's `fit` options: its settings (--epochs as its cap on held-out checks,
  --weight-decay) and its layers (None: chosen on held-out groups)."""
  from calibrate.parts import deep
  given = {k: v for k, v in (("epochs", args.epochs), ("weight_decay", args.weight_decay))
           if v is not None}
  config = deep.DeepConfig(**given)
  config.validate()
  return {"deep": config, "layers": None if args.layers in (None, "auto") else args.layers,
          "activation": None if args.activation in (None, "auto") else args.activation}


def layers(text: str):
  """--layers: 'auto' or one or two widths, e.g. 64,64."""
  if text.strip().lower() == "auto":
    return "auto"
  try:
    out = tuple(int(w) for w in text.split(","))
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r} is not 'auto' or widths, e.g. 64,64") from None
  if not 1 <= len(out) <= 2 or not all(1 <= w <= 512 for w in out):
    raise argparse.ArgumentTypeError(f"{text!r}: one or two hidden layers of 1 to 512 units")
  return out


def gru_config(args):
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


def method_arg(text: str) -> str:
  """--method's value; a typo is answered with the closest method."""
  if text.lower() in METHODS:
    return text.lower()
  raise argparse.ArgumentTypeError(str(errors.unknown("method", text, METHODS)))


def names_list(text: str) -> list[str]:
  return [t.strip() for t in text.split(",") if t.strip()]


def preparation(args):
  """The preparation steps `fit` and `compare` were asked for."""
  tare = None
  if args.tare is not None or args.tare_column is not None:
    if args.tare is not None and args.tare_column is not None:
      raise errors.SettingError("--tare and --tare-column: give one of them")
    tare = prepare.Tare(args.tare, args.tare_column, args.time_column)
  return prepare.Steps(args.unwrap, args.rails, args.drop_rails, tare, args.unwrap_period)


def training_data(args):
  """(table, x, y, groups, names) of `fit` and `compare`, every option checked first."""
  if args.folds != "auto" and not 0 <= args.folds <= 20:
    raise errors.SettingError(f"--folds {args.folds} is out of range: allowed 0 to 20, or "
                              f"auto")
  if not 0.5 <= args.level <= 0.999:
    raise errors.SettingError(f"--level {args.level} is out of range: allowed 0.5 to 0.999")
  drift = getattr(args, "track_drift", None)
  if drift is not None and not 0 < drift < float("inf"):  # by value, before any file is read
    raise errors.SettingError(f"--track-drift {drift:g} is out of range: allowed a finite "
                              f"force > 0 (the targets' unit)")
  steps = preparation(args)
  tables, table, recording = csvfile.read_many(args.csv, args.time_column,
                                               drop_nan=args.drop_nan, dedupe=args.dedupe)
  ins = table.columns(names_list(args.inputs), "--inputs")
  outs = table.columns(names_list(args.targets), "--targets")
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
    _say_short_groups(args, recording, ready.x)
  x, y = ready.x, ready.y
  args.prepared = ready.record
  args.recording = recording  # each row's recording: the temporal front end's segments
  args.contact = contact_flag(table, getattr(args, "contact_column", None), ready.rows)
  args.dt = sample_time(table, args, ready.rows, recording) \
      if getattr(args, "history", None) is not None or getattr(args, "track_drift", None) \
      is not None or args.contact is not None or getattr(args, "method", None) == "gru" \
      else None
  try:
    groups = splits_lib.groups(len(x), args.split, recording, x)
  except errors.SettingError as err:  # too few rows or recordings: say which file
    raise errors.DataError(f"{table.path}: {len(table.data)} data row(s) in {recording.max() + 1} "
                           f"recording(s), --split {args.split}: {err}") from None
  names = dict(inputs=[table.names[i] for i in ins], outputs=[table.names[i] for i in outs],
               input_units=[table.units[i] or "counts" for i in ins],
               output_units=[table.units[i] or "N" for i in outs])
  return table, x, y, groups, names


def _say_short_groups(args, recording, x) -> None:
  """A warning when --group's groups are shorter than the inputs' autocorrelation (a label
  unique to each row, say): a held-out group's neighbours stay in training, so the held-out
  error is the single-sample split's under another name, and flatters every method."""
  if args.split not in ("auto", "recordings"):
    return
  _, sizes = np.unique(recording, return_counts=True)
  size, memory = float(np.median(sizes)), splits_lib.block_length(x)
  if size < memory:
    print(f"warning: --group {args.group} gives {len(sizes)} groups of a median {size:g} "
          f"row(s), shorter than the inputs' autocorrelation ({memory} rows): each held-out "
          f"group's neighbours stay in training, so the held-out error is that of single "
          f"samples held out, and flatters every method; name a column that labels whole "
          f"recordings or trials, or use --split blocks")


def static_only(what: str, args) -> None:
  """Refuses the temporal front end's options where they would not be read."""
  if args.history is not None or args.track_drift is not None or \
     args.contact_column is not None:
    raise errors.SettingError(f"{what} compares static estimators: --history, --track-drift "
                              f"and --contact-column go with fit (--method auto among them)")


def contact_flag(table, name, rows) -> "np.ndarray | None":
  """(len(rows),) bool: the contact flag column `name` at `rows` (None without a name); a
  value other than 0/1 is refused, naming the column and the values found."""
  if name is None:
    return None
  (k,) = table.columns([name], "--contact-column")
  values = table.data[rows, k]
  bad = ~np.isin(values, (0.0, 1.0))
  if bad.any():
    found = ", ".join(f"{v:g}" for v in np.unique(values[bad])[:5])
    raise errors.DataError(f"{table.path}: --contact-column {name} holds {found}: a contact "
                           f"flag is 0 (unloaded) or 1 (loaded)")
  return values == 1.0


def drift_tare(args, outputs):
  """The drift tracker's rule of --track-drift and --drift-axis (None without them): the
  normal force is the named target, else the third, else a one-axis sensor's only one."""
  from calibrate.parts import memory
  flag = getattr(args, "contact_column", None)
  if flag is not None:
    if args.track_drift is not None or args.drift_axis is not None:
      raise errors.SettingError(f"--contact-column {flag} says where the sensor is unloaded: "
                                f"--track-drift's force threshold and --drift-axis are then "
                                f"not read; give one of the two ways")
    return memory.Tare()
  if args.track_drift is None:
    if args.drift_axis is not None:
      raise errors.SettingError("--drift-axis names the normal force of --track-drift: give "
                                "--track-drift NEWTONS too")
    return None
  outputs = list(outputs)
  if args.drift_axis is not None:
    if args.drift_axis not in outputs:
      raise errors.SettingError(f"--drift-axis {args.drift_axis!r} is not a target: allowed "
                                f"{', '.join(outputs)}")
    axis = outputs.index(args.drift_axis)
  elif len(outputs) >= 3 or len(outputs) == 1:
    axis = 2 if len(outputs) >= 3 else 0
  else:
    raise errors.SettingError(f"--track-drift reads the normal force, and of {len(outputs)} "
                              f"targets none is the third: name it with --drift-axis (one "
                              f"of {', '.join(outputs)})")
  tare = memory.Tare(args.track_drift, axis=axis)
  tare.validate()
  return tare


def sample_time(table, args, rows, recording) -> float:
  """s between samples: the median step of the time column within recordings."""
  t = table.seconds(args.time_column)
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


def held_out_groups(what: str, groups, args) -> None:
  """Refuses a choice made on held-out groups when there are none to hold out."""
  if groups.count < 2 or splits_lib.fold_count(groups, args.folds) < 2:
    raise errors.SettingError(f"{what} chooses on held-out groups: give --folds 2 or more, "
                              f"and data that make two groups or more")


def fit_auto(args, x, y, groups, names):
  from calibrate import estimators
  from util.progress import progress_bar, quiet
  held_out_groups("--method auto", groups, args)
  config, widths = net_config(args)
  options = dict(config=config, widths=widths, seed=args.seed, **deep_options(args),
                 val_fraction=args.val_fraction, degree=args.degree, ensemble=args.ensemble,
                 progress=quiet if args.no_progress else progress_bar("training"), **names)
  if getattr(args, "dt", None) is not None:  # --history: memory among the candidates
    return estimators.fit_auto_temporal(
        x, y, args.dt, groups, args.folds, segments=args.recording, contact=args.contact,
        taus=None if args.history == "auto" else (args.history or ()),
        tare=drift_tare(args, names["outputs"]), **options)
  return estimators.fit_auto(x, y, groups, args.folds, **options)


def with_preparation(est, args):
  """The estimator with the preparation its inputs had (unwrap periods, tare rule) in its
  settings, which `predict`, `evaluate` and the C export apply to new recordings, and the
  contact flag column its drift tare reads (--contact-column), which they read too."""
  import dataclasses
  more = {"contact_column": args.contact_column} \
      if getattr(args, "contact", None) is not None and est.memory is not None else {}
  return dataclasses.replace(est, info=dataclasses.replace(
      est.info, settings={**est.info.settings, "prepare": args.prepared, **more}))


def new_recording(est, args, targets: bool = False, paths=None):
  """(table, `prepare.Prepared`) of `predict` and `evaluate`: the recordings of `args.csv`
  (or `paths`, their files already expanded; several as one table) read and prepared as
  the estimator's training recordings were (its unwrap and tare, per recording), with the
  estimator's outputs as targets when `targets` (tared by the same rule)."""
  cleaning = dict(drop_nan=args.drop_nan, dedupe=args.dedupe)
  paths = csvfile.expand(args.csv) if paths is None else paths
  if len(paths) > 1:
    tables, table, _ = csvfile.read_many(paths, args.time_column, **cleaning)
  else:
    table = csvfile.read(paths[0], args.time_column, **cleaning)
    tables = [table]
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
  info = est.info
  # one recording of one static load spans its noise alone: a load moves against the
  # training ranges (`prepare.at_rails`)
  spans = np.asarray(info.input_hi, float)[:len(ins)] - np.asarray(info.input_lo, float)[:len(ins)]
  if outs is not None:
    spans = None if info.output_lo is None else np.concatenate(
        [spans, np.asarray(info.output_hi, float) - np.asarray(info.output_lo, float)])
  ready = prepare.apply(tables, ins, outs, prepare.Steps(None, args.rails, args.drop_rails,
                                                        tare),
                        None if periods is None else np.asarray(periods), spans)
  for line in table.cleaned + ready.said:
    print(line)
  return table, ready


def stream_of(est, table, ready) -> dict:
  """`predict`'s keywords for a recording `table` (its rows `ready.rows`): the contact flag
  an estimator fitted with --contact-column reads, from the same column."""
  flag = (est.info.settings.get("contact_column") if est.info is not None else None)
  if flag is None:
    return {}
  return {"contact": contact_flag(table, flag, ready.rows)}


# what the held-out error answers with each split: how far off ...
QUESTIONS = {
    "recordings": "on a recording the fit never saw (another session, another day)",
    "blocks": "later in these same recordings (blocks of them held out, no block shared "
              "with training)",
    "samples": "at instants between training samples (single samples held out: flatters "
               "every method)",
}


def question(groups, recordings: int) -> str:
  """What the held-out error answers with this split, and the option for the other
  question where the data allow it."""
  other = {"recordings": "--split blocks: later time in these same recordings",
           "blocks": "--split recordings: a recording the fit never saw"}.get(groups.how)
  text = f"the held-out error answers: how far off {QUESTIONS[groups.how]}"
  if other and recordings >= 2:
    text += f"; the other question: {other} (compare prints both)"
  return text


def print_candidates(est, candidates: dict) -> None:
  """The held-out RMSE of every candidate per output, the kept one marked."""
  info = est.info
  print(f"{'method':8s} " + " ".join(f"{n:>12s}" for n in info.outputs) + f" {'fit s':>8s}")
  chosen = info.validation["chosen"]
  for method, row in candidates.items():
    print(f"{method:8s} " + " ".join(
        f"{v:11.4g}{'*' if chosen[j] == method else ' '}" for j, v in enumerate(row["cv_rmse"]))
        + f" {row['seconds']:8.1f}")
  print("held-out RMSE per output (grouped cross-validation); * the method kept for it")
  share = info.validation.get("between_share")
  if share is not None and min(share) < 0.99:
    print("* chosen with each held-out recording's mean error weighed by the loads' share "
          "between recordings (" + ", ".join(f"{n} {v:.2f}" for n, v in zip(info.outputs, share))
          + "):\n  where each recording spans the same loads, its offset is its own (a drift), "
          "not the model's")


def ensemble_hint(candidates: dict) -> None:
  """Says how to weigh ensembles when `auto` weighed single networks only."""
  from calibrate import methods
  if not any(methods.split_ensemble(m)[1] > 1 for m in candidates) and any(
      methods.seeded(methods.AUTO[m][0].value) for m in candidates if m in methods.AUTO):
    print("each network from one seed: --ensemble 5 weighs each one's mean of five beside it "
          "(about five times its fit time)")
