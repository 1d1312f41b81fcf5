"""`python -m calibrate compare`: every method on the same held-out groups, as a table."""

from __future__ import annotations

import warnings

from calibrate.cli import common
from calibrate.methods import FewStatesWarning
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
  print(common.question(groups, 1))
  est, candidates = common.fit_auto(args, x, y, groups, names)
  common.print_candidates(est, candidates)
  other = _other_split(groups, x, args.recording)
  if other is not None:  # the other question the same data can answer
    print(f"\nvalidation: {other.describe()}")
    print(common.question(other, 1))
    with warnings.catch_warnings():  # the first table said it of the same targets
      warnings.simplefilter("ignore", FewStatesWarning)
      est_other, more = common.fit_auto(args, x, y, other, names)
    common.print_candidates(est_other, more)
    if est_other.info.validation["chosen"] != est.info.validation["chosen"]:
      print("the two questions keep different methods: fit with the --split whose question "
            "is yours")
  if args.out is not None:
    import csv
    import io
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["method"] + [f"{n}_cv_rmse" for n in names["outputs"]] + ["fit_seconds"])
    writer.writerows([m] + [repr(v) for v in row["cv_rmse"]] + [repr(row["seconds"])]
                     for m, row in candidates.items())
    writer.writerow(["kept"] + est.info.validation["chosen"] + [""])
    if other is not None:  # the other split's rows, named by it
      writer.writerows([f"{m} [{other.how}]"] + [repr(v) for v in row["cv_rmse"]]
                       + [repr(row["seconds"])] for m, row in more.items())
      writer.writerow([f"kept [{other.how}]"] + est_other.info.validation["chosen"] + [""])
    files.write_text(args.out, buf.getvalue())
    print(f"wrote {args.out}")
  return 0


def _other_split(groups, x, recording):
  """The split that answers the other question (blocks within recordings for a split by
  recordings, and back), where there are several recordings; None otherwise."""
  import numpy as np
  from calibrate import splits
  if groups.how not in ("recordings", "blocks") or len(np.unique(recording)) < 2:
    return None
  return splits.groups(len(x), "blocks" if groups.how == "recordings" else "recordings",
                       recording, x)
