"""`python -m calibrate merge`: two raw streams (sensor, reference) into one recording."""

from __future__ import annotations

import argparse
import pathlib
from typing import Optional

import numpy as np

from calibrate import csvfile, streams
from calibrate.cli import common
from util import cli, errors, files


GAP_WARNING = 0.10  # a share of a pair's rows dropped in reference gaps that merge warns of


def add_parser(sub) -> None:
  p = sub.add_parser("merge", help="two raw streams (sensor, reference) into one recording",
                     formatter_class=argparse.RawDescriptionHelpFormatter,
                     description=streams.__doc__)
  p.add_argument("pairs", type=cli.path_arg, nargs="+", metavar="SENSOR.csv REFERENCE.csv",
                 help="a sensor file and its reference file; several pairs for several "
                      "recordings")
  p.add_argument("--lag", type=lag, default=None, metavar="SECONDS",
                 help="how much later the reference stamps the same event (its samples move "
                      "earlier by it); default: estimated from the data, and printed either "
                      "way")
  p.add_argument("--max-lag", type=float, default=1.0,
                 help="the largest lag the estimate considers, seconds (default 1)")
  p.add_argument("--max-gap", type=float, default=None, metavar="SECONDS",
                 help="the longest reference gap interpolated across (default "
                      f"{streams.GAP_PERIODS:g} mean reference periods, its longest 1 %% of steps "
                      "left out)")
  p.add_argument("--time-column", default="time", help="name of the time column (time)")
  common.cleaning_args(p)
  p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("merged"),
                 help="folder for the merged recordings, one per pair, named after the "
                      "sensor file (default merged/)")


def lag(text: str) -> Optional[float]:
  if text.strip().lower() == "auto":
    return None
  try:
    return float(text)
  except ValueError:
    raise argparse.ArgumentTypeError(f"{text!r} is not seconds or 'auto'") from None


def run(args) -> int:
  if len(args.pairs) % 2:
    raise errors.SettingError(f"merge takes files in pairs, SENSOR.csv REFERENCE.csv: got "
                              f"{len(args.pairs)} files")
  if not 0 < args.max_lag <= 60:
    raise errors.SettingError(f"--max-lag {args.max_lag:g} is out of range: allowed (0, 60] s")
  if args.lag is not None and not abs(args.lag) <= 60:  # nan and inf fail it too
    raise errors.SettingError(f"--lag {args.lag:g} is out of range: allowed seconds in "
                              f"[-60, 60], or auto")
  if args.max_gap is not None and not 0 < args.max_gap < 1e6:
    raise errors.SettingError(f"--max-gap {args.max_gap:g} is out of range: allowed seconds in "
                              f"(0, 1e6)")
  # two merges never fill one folder
  return files.holding(args.out, "--out", lambda out: _merge(args, out))


def _merge(args, out) -> int:
  pairs = list(zip(args.pairs[::2], args.pairs[1::2]))
  stems = [pathlib.Path(a).stem for a, _ in pairs]
  if len(set(stems)) != len(stems):
    raise errors.SettingError("two sensor files share a name; the merged recordings are named "
                              "after them: rename one")
  read = [[csvfile.read(f, args.time_column, drop_nan=args.drop_nan, dedupe=args.dedupe)
           for f in pair] for pair in pairs]
  for sensor, reference in read:
    for line in sensor.cleaned + reference.cleaned:
      print(line)
  done, far, median = streams.merge_all(read, args.lag, args.max_gap, args.time_column,
                                        args.max_lag)
  for k in far:
    print(f"warning: {pairs[k][0]}: its estimated lag {done[k].lag_estimated * 1e3:.1f} ms "
          f"lies far from the other pairs' (median {median * 1e3:.1f} ms): the estimate "
          f"locked onto another event; merged at the median instead (--lag SECONDS sets "
          f"every pair's)")
  for (a, _), stem, m in zip(pairs, stems, done):
    csvfile.write(out / f"{stem}.csv", m.names, m.data, m.units)
    print(m.describe(str(a)))
    share = m.in_gaps / max(1, len(m.data) + m.in_gaps)
    if share > GAP_WARNING:
      print(f"warning: {a}: {share:.0%} of its rows inside the reference's span fall in "
            f"gaps over {m.max_gap * 1e3:.1f} ms and were dropped: if the reference just "
            f"logs irregularly, give a longer --max-gap")
  lags = [m.lag * 1e3 for m in done]
  print(f"merged {len(done)} pair(s): {sum(len(m.data) for m in done):,} rows kept, "
        f"{sum(m.outside for m in done):,} outside the overlap and "
        f"{sum(m.in_gaps for m in done):,} in reference gaps dropped, lag "
        + (f"{lags[0]:.1f} ms" if len(set(np.round(lags, 1))) == 1 else
           f"{min(lags):.1f} to {max(lags):.1f} ms")
        + (f" ({len(far)} estimate(s) far from the others replaced by their median)"
           if far else "")
        + f"; wrote {out}/")
  return 0
