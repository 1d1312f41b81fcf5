"""`python -m calibrate predict`: an estimator applied to a CSV recording."""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate.cli import common
from calibrate import csvfile
from util import cli, errors, files

DEFAULT_OUT = pathlib.Path("predictions.csv")


def add_parser(sub) -> None:
  p = sub.add_parser("predict", help="apply an estimator to a CSV recording")
  common.recording_args(p, "each predicted to its own file")
  p.add_argument("--out", type=cli.path_arg, default=DEFAULT_OUT,
                 help="where to write the predictions (default predictions.csv); for several "
                      "recordings a folder, one CSV each under its file's name (default "
                      "predictions/)")
  p.add_argument("--std", action="store_true",
                 help="add a standard deviation column per output (<name>_sd)")
  p.add_argument("--interval", type=float, default=None, metavar="LEVEL",
                 help="add the interval at LEVEL (e.g. 0.95) as "
                      "<name>_lo and <name>_hi columns (from fit's held-out groups; wider "
                      "with the inputs' distance beyond the training box)")

def run(args) -> int:
  from calibrate import estimators
  paths = csvfile.expand(args.csv)
  if len(paths) == 1:
    files.output_file(args.out, "--out", (".csv",))
    return _predict(args, estimators.Estimator.load(args.estimator), paths, args.out, None)
  names = [pathlib.Path(p).name for p in paths]
  if len(set(names)) < len(names):
    twice = next(n for n in names if names.count(n) > 1)
    raise errors.SettingError(f"--csv: two recordings are named {twice}: predictions of "
                              f"several go to one folder under their files' names; rename one")
  out = pathlib.Path("predictions") if args.out == DEFAULT_OUT else args.out
  if out.suffix.lower() == ".csv":
    raise errors.SettingError(f"--out {out}: {len(paths)} recordings write one CSV each: "
                              f"give a folder (e.g. --out predictions/)")
  est = estimators.Estimator.load(args.estimator)  # before the folder: a broken file leaves none
  return files.holding(out, "--out", lambda folder: _predict(args, est, paths, folder, names))


def _predict(args, est, paths, out, files_named) -> int:
  """`est`'s predictions of the recordings `paths` to the file `out`, or with `files_named`
  (one per recording) to the folder `out`, one file each."""
  if args.interval is not None:
    est.info.half_width(args.interval)  # a level out of range, or no interval: say so first
  table, ready = common.new_recording(est, args, paths=paths)
  x = ready.x
  # each file its own recording: a memory's filters and tares start afresh in each
  pred, sd = est.predict(x, return_std=True, segments=ready.recording,
                         **common.stream_of(est, table, ready))
  columns, units, cols = list(est.info.outputs), list(est.info.output_units), [pred]
  a = len(est.info.outputs)
  if args.std:
    columns += [f"{n}_sd" for n in est.info.outputs]
    units += units[:a]
    cols.append(sd)
  if args.interval is not None:
    half = est.info.half_width_at(args.interval, x)  # wider beyond the training box
    columns += [f"{n}_{end}" for end in ("lo", "hi") for n in est.info.outputs]
    units += units[:a] * 2
    cols += [pred - half, pred + half]
  t = table.seconds(args.time_column)
  if t is not None:
    columns, units, cols = ([args.time_column] + columns, ["s"] + units,
                            [t[ready.rows, None]] + cols)
  rows = np.hstack(cols)
  if files_named is None:
    csvfile.write(out, columns, rows, units)
    print(f"{len(x)} predictions of {', '.join(est.info.outputs)} to {out}")
    return 0
  for k, name in enumerate(files_named):
    csvfile.write(out / name, columns, rows[ready.recording == k], units)
  print(f"{len(x)} predictions of {', '.join(est.info.outputs)} for {len(files_named)} "
        f"recordings to {out}/ (one CSV each, under its file's name)")
  return 0
