"""`python -m calibrate predict`: an estimator applied to a CSV recording."""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate.cli import common
from calibrate import csvfile
from util import cli, files

def add_parser(sub) -> None:
  p = sub.add_parser("predict", help="apply an estimator to a CSV recording")
  common.recording_args(p)
  p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("predictions.csv"),
                 help="where to write the predictions (default predictions.csv)")
  p.add_argument("--std", action="store_true",
                 help="add a standard deviation column per output (<name>_sd)")
  p.add_argument("--interval", type=float, default=None, metavar="LEVEL",
                 help="add the interval at LEVEL (e.g. 0.95) as "
                      "<name>_lo and <name>_hi columns (from fit's held-out groups; wider "
                      "with the inputs' distance beyond the training box)")

def run(args) -> int:
  from calibrate import estimators
  files.output_file(args.out, "--out", (".csv",))
  est = estimators.Estimator.load(args.estimator)
  if args.interval is not None:
    est.info.half_width(args.interval)  # a level out of range, or no interval: say so first
  table, ready = common.new_recording(est, args)
  x = ready.x
  pred, sd = est.predict(x, return_std=True, **common.stream_of(est, table, ready))
  names, units, cols = list(est.info.outputs), list(est.info.output_units), [pred]
  a = len(est.info.outputs)
  if args.std:
    names += [f"{n}_sd" for n in est.info.outputs]
    units += units[:a]
    cols.append(sd)
  if args.interval is not None:
    half = est.info.half_width_at(args.interval, x)  # wider beyond the training box
    names += [f"{n}_{end}" for end in ("lo", "hi") for n in est.info.outputs]
    units += units[:a] * 2
    cols += [pred - half, pred + half]
  t = table.seconds(args.time_column)
  if t is not None:
    names, units, cols = ([args.time_column] + names, ["s"] + units,
                          [t[ready.rows, None]] + cols)
  csvfile.write(args.out, names, np.hstack(cols), units)
  print(f"{len(x)} predictions of {', '.join(est.info.outputs)} to {args.out}")
  return 0
