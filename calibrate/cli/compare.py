"""`python -m calibrate compare`: every method on the same held-out groups, as a table."""

from __future__ import annotations

from calibrate.cli import common
from util import cli, files


def add_parser(sub) -> None:
  p = sub.add_parser("compare", help="every method on the same held-out groups: the table")
  common.training_args(p)
  p.add_argument("--out", type=cli.path_arg, default=None,
                 help="also write the table to this CSV file")


def run(args) -> int:
  common.static_only("compare", args)
  common.check_options(args, "auto")
  if args.out is not None:
    files.output_file(args.out, "--out", (".csv",))
  table, x, y, groups, names = common.training_data(args)
  print(f"{len(x)} samples of {table.path}; validation: {groups.describe()}")
  est, candidates = common.fit_auto(args, x, y, groups, names)
  common.print_candidates(est, candidates)
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
