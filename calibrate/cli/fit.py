"""`python -m calibrate fit`: an estimator fitted on CSV recordings, and what it is worth."""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate import splits
from calibrate.cli import common
from calibrate.info import GROWTH_MIN
from util import cli, errors, files

def add_parser(sub) -> None:
  p = sub.add_parser("fit", help="fit an estimator on CSV recordings")
  common.training_args(p)
  p.add_argument("--method", required=True, type=common.method_arg,
                 metavar="{" + ",".join(common.METHODS) + "}",
                 help="ls: linear least squares; poly: polynomial with cross terms; "
                      "lsann: LS plus a network on its residual; nn: the network alone; "
                      "mlp: LS plus a perceptron of one or two layers (chosen on held-out "
                      "groups) trained by AdamW on its residual; "
                      "gru: LS plus a small recurrent network (GRU) on its residual, "
                      "reading the inputs' past (needs the time column); lsgp: LS plus a "
                      "Gaussian process on its residual; auto: ls, each channel's powers "
                      "(POLY-CH), poly, lsann, nn and mlp on the same held-out groups, the best "
                      "kept per output (with --history also ls and poly behind the memory "
                      "front end, kept only where they beat every static one)")
  p.add_argument("--out", type=cli.path_arg, default=pathlib.Path("estimator.npz"),
                 help="where to write the estimator (default estimator.npz)")
  p.add_argument("--per-channel", action="store_true",
                 help="poly: powers of each channel alone, no cross terms and no ridge "
                      "(the force-sensing-shell paper's pseudoinverse); default: every "
                      "product of total degree <= --degree, continued linearly beyond "
                      "the training box")


def run(args) -> int:
  from calibrate import estimators
  files.output_file(args.out, "--out", (".npz",))
  common.check_options(args, args.method)
  table, x, y, groups, names = common.training_data(args)
  if args.method == "auto":
    est, candidates = common.fit_auto(args, x, y, groups, names)
    est = common.with_preparation(est, args)
    est.save(args.out)
    common.print_candidates(est, candidates)
    common.ensemble_hint(candidates)
    if args.dt is not None and est.memory is None:
      print("memory front end not kept: no output's held-out error fell by more than a "
            "standard error with it")
    report(est, table, args, y, groups)
    print(f"wrote {args.out}")
    return 0
  from util.progress import progress_bar, quiet
  progress = quiet if args.no_progress else progress_bar("training")
  config, widths = common.net_config(args)
  if widths:
    common.held_out_groups("--hidden auto", groups, args)
  shared = dict(config=config, widths=widths, val_fraction=args.val_fraction,
                degree=args.degree, ensemble=args.ensemble, progress=progress,
                groups=groups,
                folds=splits.fold_count(groups, args.folds) if groups.count >= 2 else 0,
                cross=args.method == "poly" and not args.per_channel,
                **(common.deep_options(args) if args.method == "mlp" else {}))
  kind = estimators.Kind(args.method.upper())
  try:
    if args.dt is None:
      est = estimators.fit(kind, x, y, seed=args.seed, **names, **shared)
    else:
      est = estimators.fit_temporal(
          kind, x, y, args.dt, segments=args.recording, contact=args.contact, seed=args.seed,
          taus=None if args.history == "auto" else (args.history or ()),
          differences=args.history is not None,
          tare=common.drift_tare(args, names["outputs"]),
          gru=common.gru_config(args), **names, **shared)
    est = common.with_preparation(est, args)
  except errors.DataError as err:  # say which file, and how many rows it gave
    raise errors.DataError(f"{table.path}: {len(table.data)} data row(s), "
                           f"{args.val_fraction:.0%} of them held out for validation: "
                           f"{err}") from None
  est.save(args.out)
  report(est, table, args, y, groups)
  print(f"wrote {args.out}")
  return 0


def report(est, table, args, y: np.ndarray, groups) -> None:
  """What `fit` prints: the data, the split, the held-out error and the interval."""
  info = est.info
  units = info.output_units
  print(f"fitted {est.kind.value} on {info.samples} samples of {table.path} "
        f"({len(info.inputs)} inputs -> {', '.join(info.outputs)})")
  v = info.validation
  print(f"validation: {groups.describe()}")
  print(common.question(groups, len(np.unique(args.recording))))
  if est.memory is not None:
    print(memory_line(est.memory, args.history == "auto"))
    gain = info.settings.get("history_gain")
    if gain:
      print(f"  LS's held-out error (squared errors over each output's spread, root mean) "
            f"without the history {gain['without']:.4g}, with it {gain['with']:.4g} "
            f"({1 - gain['with'] / gain['without']:.0%} less) on the recordings held out in "
            f"turn: a gain a new recording may not repeat when few recordings show it; "
            f"--method auto --history auto keeps it only where it beats every static "
            f"candidate by a standard error")
  for key, what, chosen in (
      ("width_cv", "network width", str(info.settings.get("config", {}).get("hidden"))),
      ("layers_cv", "perceptron layers",
       "x".join(map(str, info.settings.get("deep", {}).get("layers", ()))))):
    if key in info.settings:
      print(grid_line(what, chosen, info.settings[key]))
  if "activation_cv" in info.settings:
    print(grid_line("perceptron units", f"{info.settings['deep']['activation']} at those "
                    f"layers", info.settings["activation_cv"], sizes=False))
  if info.settings.get("cross"):
    print(poly_lines(info.settings))
  if v:
    print(f"held-out error ({v['folds']}-fold grouped cross-validation), RMSE: " + ", ".join(
        f"{n} {r:.4g} {u}" for n, r, u in zip(info.outputs, v["cv_rmse"], units)))
    interval_lines(info, args.level, np.abs(y).max(axis=0), units)
    continued, reach = est.continued()
    if continued:
      print(f"past the training box {', '.join(continued)} carry their part's correction to "
            f"LS along LS's plane" + ("" if reach is None else
            f" as far as held-out samples lay past their fold's box ({reach:.3g} training "
            f"ranges), fading to LS alone beyond: held-out data never checked it there"))
    if v.get("ls_only"):
      print(f"{est.kind.value} keeps only its LS stage on {', '.join(v['ls_only'])}: its "
            f"network did not beat the LS stage on held-out groups there")
  else:
    print("no cross-validation (--folds 0, or a single group): no interval; the validation "
          "residual sd " + ", ".join(f"{n} {s:.4g} {u}" for n, s, u in
                                     zip(info.outputs, info.residual_sd, units)))
  training_lines(est, args, groups)


def interval_lines(info, level: float, scale: np.ndarray, units) -> None:
  """Prints the interval `fit` kept: its one width (and as % of full scale `scale`), how it
  grows from the training data and beyond the box, its between-recordings part."""
  half = info.half_width(level)
  print(f"{level:.0%} interval (held-out groups): " + ", ".join(
      f"{n} +-{h:.4g} {u} ({h / s:.1%} of full scale {s:.4g})" if s > 0 else
      f"{n} +-{h:.4g} {u}" for n, h, u, s in zip(info.outputs, half, units, scale)))
  if info.interval_local is not None and info.interval_local[:, 1].any():
    print("  within a recording it grows by max(1, b + a x d), d the distance to the nearest "
          "training sample (in training ranges): " +
          ", ".join(f"{o} {b:.3g} + {a:.3g} d" if a else f"{o} one width"
                    for o, (b, a) in zip(info.outputs, info.interval_local)))
  if info.interval_growth is not None:
    n = info.validation.get("held_out_beyond_box", 0)
    print("  beyond the training box it widens by 1 + g x the distance (in training ranges), "
          "g " + ", ".join(f"{o} {g:.3g}" for o, g in zip(info.outputs, info.interval_growth))
          + (f": measured on {n} held-out samples beyond their fold's box"
             if n >= GROWTH_MIN else
             f": too few held-out samples beyond their fold's box to measure it ({n}), so "
             f"it doubles one training range out"))
  between = info.between_width(level)
  if between.any():
    g = len(info.interval_offsets)
    print(f"  of which how far a new group's mean error alone may lie (Student's t over {g} "
          f"groups' means): " + ", ".join(f"{n} +-{b:.4g} {u}" for n, b, u in
                                          zip(info.outputs, between, units))
          + ("; more recordings narrow it" if g < 8 else ""))


def training_lines(est, args, groups) -> None:
  """How the networks' training stopped, and what their early-stopping hold-out was for."""
  stops = [m.training for m in (est.members or (est,)) if m.training is not None]
  deep = est.info.settings.get("deep") if est.kind.value == "MLP" else None
  if deep and deep.get("checks"):  # a length from the held-out groups' curve, no hold-out
    n = len(stops)
    print(f"training: {'each of ' + str(n) + ' networks ' if n > 1 else ''}{deep['checks']} "
          f"checks ({deep['checks'] * deep['steps']} AdamW steps, "
          f"{sum(t.seconds for t in stops):.1f} s{' in all' if n > 1 else ''}) on every "
          f"sample, the length where the held-out groups' mean error was lowest"
          + (": the cap (--epochs), where it still fell" if deep["checks"] == deep["epochs"]
             else ""))
    return
  if len(stops) > 3:  # an ensemble: the spread, not a line per network
    why = sorted({t.stop.value for t in stops})
    epochs = np.array([t.epochs for t in stops])
    print(f"training stopped: {len(stops)} networks ({'; '.join(why)}), after "
          f"{epochs.min()}-{epochs.max()} epochs (median {np.median(epochs):.0f}), "
          f"{sum(t.seconds for t in stops):.1f} s in all")
  elif stops and deep:  # AdamW: held-out checks `steps` apart
    why = {"VALIDATION": f"no better held-out error in {deep['patience']} checks",
           "MAX_EPOCHS": "the cap on checks"}
    print("training stopped: " + "; ".join(
        f"{why[t.stop.name]} after {t.epochs * deep['steps']} AdamW steps ({t.seconds:.1f} "
        f"s), the weights of step {t.best_epoch * deep['steps']} kept" for t in stops))
  elif stops and est.rnn is not None:  # a recurrent network: Adam steps, held-out checks
    t = stops[0]
    why = "the step cap" if t.stop.name == "MAX_EPOCHS" else \
        f"{est.info.settings['gru']['patience']} held-out checks without a better error"
    print(f"training stopped: {why} after {t.epochs} Adam steps ({t.seconds:.1f} s); kept "
          f"the weights of step {t.best_epoch}")
    if t.best_epoch == 0:
      print("the recurrent network never beat its start (LS alone) on its held-out "
            "recordings, so it adds nothing: the estimator is its LS stage; --method ls "
            "with the same --history gives it in a fraction of the time")
  elif stops:
    print("training stopped: " + "; ".join(
        f"{t.stop.value} after {t.epochs} epochs ({t.seconds:.1f} s)" for t in stops))
  if stops:
    what = "networks never trained on their" if len(stops) > 1 else "network never trained on its"
    print(f"the {what} early-stopping hold-out ({args.val_fraction:.0%} of the samples, "
          f"{'whole recordings' if groups.how == 'recordings' else groups.how}), which only "
          f"chose when to stop")


def grid_line(what: str, chosen: str, table: dict, sizes: bool = True) -> str:
  """The choice made on held-out groups, every option's error, and for `sizes` whether it is
  the grid's largest (a larger one might do better: said, not tried)."""
  text = (f"{what} {chosen} (held-out error, each output's MSE over its variance: "
          + ", ".join(f"{w}: {v:.3g}" for w, v in table.items()) + ")")
  if sizes and chosen == list(table)[-1] and len(table) > 1:
    text += "\n  the largest size tried: a larger one might do better still"
  return text


def memory_line(mem, chosen: bool) -> str:
  """What the temporal front end reads: its time constants (said when they were chosen on
  held-out recordings), the first differences, the drift tare."""
  taus = ", ".join(f"{t:g}" for t in mem.taus) or "none"
  return (f"memory front end: high-pass time constants {taus} s"
          + (" (chosen on held-out recordings)" if chosen else "")
          + f", first differences {'kept' if mem.differences else 'not kept'}"
          + ("" if mem.tare is None else ", drift tare where the contact flag is 0"
             if mem.detector is None else f", drift tare below {mem.tare.threshold:g} N"))


def poly_lines(settings: dict) -> str:
  """What the polynomial with cross terms is: its degree and ridge, and whether the ridge
  search ended at its largest weight with the held-out error still falling."""
  from calibrate import methods
  from calibrate.parts import poly
  text = (f"polynomial: every product of total degree <= {settings['degree']}, ridge "
          f"{settings['ridge_per_sample']:g} per sample"
          + (" (both chosen by grouped cross-validation)" if "poly_cv_mse" in settings
             else "") + "; linear beyond the training box")
  last = max(poly.RIDGES) * 10.0 ** methods.RIDGE_STEPS  # the search's largest weight
  if "poly_cv_mse" in settings and settings["ridge_per_sample"] >= 0.999 * last:
    text += (f"\n  the held-out error still fell at the largest ridge weight tried ({last:g} "
             f"per sample): the polynomial adds little beyond the mean here; compare LS "
             f"(--method auto)")
  return text
