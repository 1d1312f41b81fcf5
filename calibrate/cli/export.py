"""`python -m calibrate export`: an estimator as dependency-free C99."""

from __future__ import annotations

from util import cli, errors


def add_parser(sub) -> None:
  p = sub.add_parser("export", help="write the estimator as dependency-free C99")
  p.add_argument("estimator", type=cli.path_arg, help="an estimator file `fit` wrote")
  p.add_argument("--c", dest="c_dir", required=True, type=cli.path_arg,
                 help="folder for estimator.h and estimator.c")
  p.add_argument("--fixed-point", action="store_true",
                 help="gru: the recurrent network in Q16 integers (a tanh table), about a tenth "
                      "of its soft-float cost on a Cortex-M3; its outputs then differ from "
                      "predict by Q16's rounding, not float32's")


def run(args) -> int:
  from util import files
  # two exports never fill one folder
  return files.holding(args.c_dir, "--c", lambda _: _export(args))


def _export(args) -> int:
  from calibrate import cexport, estimators
  est = estimators.Estimator.load(args.estimator)
  if args.fixed_point and est.rnn is None:
    raise errors.SettingError(f"--fixed-point writes a recurrent network in integers: "
                              f"{args.estimator} is {est.kind.value}, which has none (fit "
                              f"--method gru)")
  report = cexport.write(est, args.c_dir, fixed_point=args.fixed_point)
  print(report.text())
  return 0
