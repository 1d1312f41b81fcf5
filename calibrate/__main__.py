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

import sys
from typing import Optional

from calibrate.cli import module, parser
from util import cli


def main(argv: Optional[list[str]] = None) -> int:
  args = parser().parse_args(argv)
  run = module(args.command).run
  return cli.run(lambda: run(args), "calibrate", "interrupted: nothing was written")


if __name__ == "__main__":
  sys.exit(main())
