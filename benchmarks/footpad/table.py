"""The LSANN paper's Table I, registered three times: asterisk_path (the main job: networks
trained on the Asterisk path), circular_path (on the Circular path) and footpad_table1 (the
paper's full protocol, Asterisk + Circular).

LS is fitted on the Z presses and X/Y strokes (paper Sec. III-B); LSANN and NN-only train on
the given paths at every Z level (Sec. III-C); all three are tested on Testing Paths 1 and 2.
Networks train from several seeds (spawned from the run's one seed) and the table reports
medians; per-seed numbers go to metrics.json, fitted estimators to DIR/estimators/.

Where the simulation and the paper differ, and the measured mechanism, is in the README's
"Known gaps against the papers" (each figure with the command that measured it).
"""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np

from benchmarks import footpad
from benchmarks.registry import register
from sim.footpad import paper

AXES = ("X", "Y", "Z")
METHODS = ("LS", "LSANN", "NN")
PAPER_TABLE1, PAPER_LS_TRAIN_NRMSE, PAPER_MINUTES = paper.TABLE1, paper.LS_TRAIN_NRMSE, \
    paper.MINUTES
SEEDS = 5  # every run, --quick included: medians over five seeds
BLOCK_SEEDS = 2  # seeds trained again with the blocks validation split
BLOCK = 1000  # samples: 1 s at the footpad's 1 kHz
_STOPS = {"MAX_EPOCHS": "at the epoch cap", "VALIDATION": "by the validation stop",
          "MIN_GRADIENT": "at the gradient floor", "MU_MAX": "at the damping cap",
          "GOAL": "at the MSE goal"}


def run_table(ctx, nn_paths: tuple[str, ...], seeds: int | None = None,
              unseen: bool = True, blocks: bool = True) -> dict:
  """Fits LS, LSANN and NN-only as the paper does, the networks on `nn_paths`, and prints
  Table I against the paper's (and, once, the share of test samples outside each
  estimator's training range, in place of a warning per prediction); with `unseen`, also
  the generalisation block on shapes none of the paper's paths has; with `blocks`, the
  networks of the first `BLOCK_SEEDS` seeds again under a blocks validation split."""
  import warnings
  from benchmarks import outputs
  with warnings.catch_warnings():
    outputs.quiet_out_of_range()
    return _run_table(ctx, nn_paths, seeds, unseen, blocks)


def _run_table(ctx, nn_paths: tuple[str, ...], seeds: int | None, unseen: bool = True,
               blocks: bool = True):
  from benchmarks import outputs
  from calibrate import estimators
  from sim.footpad import protocol
  recs = {name: rec for name, (rec, _) in footpad.recordings(ctx).items()}
  strokes, nn_train, test = protocol.splits(recs["train"], recs["test"], nn_paths).values()
  # the names `calibrate` CSVs of footpad recordings carry (benchmarks.footpad.dataset)
  names = dict(inputs=[f"p{i + 1}" for i in range(strokes.counts.shape[1])],
               outputs=["Fx", "Fy", "Fz"])
  est_dir = ctx.out / "estimators"
  est_dir.mkdir(parents=True, exist_ok=True)
  ls, ls_seconds, ls_train = _fit_ls(ctx, strokes, names, est_dir)
  ctx.print(f"networks on {len(nn_train)} samples of {', '.join(nn_paths)}; test on "
            f"{len(test)} samples")
  n_seeds = seeds or SEEDS
  child = [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(ctx.seed).spawn(n_seeds)]
  per_seed, fitted, on_test = _fit_networks(ctx, ls, nn_train, test, child, names, est_dir)
  for m in ("LSANN", "NN"):  # the seeds as one estimator: their mean and spread
    estimators.combine(fitted[m]).save(est_dir / f"{m}_ensemble.npz")
  results = _medians(per_seed, on_test["LS"][0], test.wrench[:, :3], ls_seconds)
  comparison = _comparison(per_seed, results)
  _print_table(ctx, results, comparison, n_seeds, per_seed)
  outside = {m: float(fitted[m][0].outside(test.counts).any(axis=1).mean()) for m in METHODS}
  comparison["test_outside_training_range"] = outside
  ctx.print("test samples with counts outside the training range: " + ", ".join(
      f"{m} {v:.1%}" for m, v in outside.items()) + f" (LS is fitted on the Z presses and "
      f"strokes, the networks on {', '.join(nn_paths)}: outside, they extrapolate)")
  _predictions_and_figures(ctx, recs["train"], test, on_test)
  draws = _test_draws(ctx, recs["test"], fitted)
  general = _generalisation(ctx, fitted) if unseen else {}
  data = {"results": results, "LS_train": ls_train, "per_seed": per_seed, "test_draws": draws,
          "validation_blocks": _blocks_split(ctx, ls, nn_train, test, child[:BLOCK_SEEDS],
                                             per_seed) if blocks else {},
          "generalisation": general,
          "comparison": comparison, "seeds": child,
          "paper": {"table1": PAPER_TABLE1, "LS_train_nrmse_pct": PAPER_LS_TRAIN_NRMSE,
                    "training_minutes": PAPER_MINUTES, "iteration_ratio": paper.TIME_RATIO},
          "samples": {"ls_train": len(strokes), "nn_train": len(nn_train), "test": len(test)},
          "nn_paths": list(nn_paths), "effects": list(recs["train"].meta["effects"])}
  return outputs.Result(data, tuple(_rows(data)))


TEST_DRAWS = 5  # independent noise and drift draws of the test session


def _test_draws(ctx, test_rec, fitted: dict) -> dict:
  """Table I's test over `TEST_DRAWS` other draws of the test session's noise and drift: the
  same die pressures and measured wrench, the sensor chain run again with other recording
  streams (the dies' unit spread is the pad's and stays). One draw (the paper's single test)
  can sit anywhere in this spread. Returns {method: {axis: {metric: [per draw]}}} of the
  first seed's estimators, and prints each metric's median and range."""
  import dataclasses as dc
  from calibrate import metrics
  from sim.footpad import sensor_chain
  cfg = test_rec.meta["config"]
  effects = [e for e in test_rec.meta["effects"] if e != "ft_noise"]  # the truth stays
  adc = sensor_chain.AdcConfig(**{k: tuple(v) if isinstance(v, list) else v
                                   for k, v in cfg["adc"].items()})
  out = {m: {ax: {} for ax in AXES} for m in METHODS}
  for k in range(TEST_DRAWS):
    counts, _ = sensor_chain.apply(test_rec.pressure, test_rec.wrench, effects, cfg["seed"],
                                   adc, cfg["params"]["timestep"], stream=k + 1)
    test = dc.replace(test_rec, counts=counts).on_path()  # the protocol's test split
    for m in METHODS:
      got = metrics.summary(fitted[m][0].predict(test.counts), test.wrench[:, :3], AXES)
      for ax in AXES:
        for key, v in got[ax].items():
          out[m][ax].setdefault(key, []).append(v)
  ctx.print(f"\ntest R2 % over {TEST_DRAWS} other noise and drift draws of the test session "
            f"(first seed): median [min-max]")
  for m in METHODS:
    ctx.print(f"  {m:6s} " + "   ".join(
        f"{ax} {np.median(out[m][ax]['r2_pct']):6.2f} [{min(out[m][ax]['r2_pct']):6.2f}-"
        f"{max(out[m][ax]['r2_pct']):6.2f}]" for ax in ("Z", "Y", "X")))
  return out


def _fit_ls(ctx, strokes, names: dict, est_dir) -> tuple:
  """The paper's LS fit on the Z presses and X/Y strokes, saved as LS.npz: (estimator, fit
  seconds, its training summary), the training NRMSE printed beside the paper's."""
  from calibrate import estimators, metrics
  t0 = time.perf_counter()
  ls = estimators.fit(estimators.Kind.LS, strokes.counts, strokes.wrench[:, :3], **names)
  seconds = time.perf_counter() - t0
  ls.save(est_dir / "LS.npz")
  train = metrics.summary(ls.predict(strokes.counts), strokes.wrench[:, :3], AXES)
  ctx.print(f"LS on {len(strokes)} stroke samples (rank {ls.linear.rank})")
  ctx.print(f"{'LS train NRMSE %':18s} " + "  ".join(
      f"{ax} {train[ax]['nrmse_pct']:6.2f} (paper {PAPER_LS_TRAIN_NRMSE[ax]:5.2f})"
      for ax in ("Z", "Y", "X")))
  return ls, seconds, train


def _fit_networks(ctx, ls, nn_train, test, child: list[int], names: dict, est_dir) -> tuple:
  """LSANN and NN-only, one of each per seed of `child`, each saved: (per-seed rows of test
  scores and training figures, {method: estimators}, {method: test predictions (N, 3) N})."""
  from calibrate import estimators, metrics
  truth = test.wrench[:, :3]
  per_seed = []
  fitted = {"LS": [ls], "LSANN": [], "NN": []}
  on_test = {"LS": [ls.predict(test.counts)], "LSANN": [], "NN": []}
  kinds = (estimators.Kind.LSANN, estimators.Kind.NN)
  jobs = [dict(kind=kind, counts="x", forces="y", linear_fit=ls.linear, seed=seed, **names)
          for seed in child for kind in kinds]
  nets = iter(_fit_all(ctx, nn_train, jobs, f"networks ({len(child)} seeds x 2)"))
  for k, seed in enumerate(child):
    row, trained = {"seed": seed}, {}
    for kind in kinds:
      est = next(nets)
      est.save(est_dir / f"{kind.value}_seed{k}.npz")
      fitted[kind.value].append(est)
      on_test[kind.value].append(est.predict(test.counts))
      tr = trained[kind.value] = est.training
      row[kind.value] = {"test": metrics.summary(on_test[kind.value][-1], truth, AXES),
                         "train": {"seconds": tr.seconds, "compile_seconds": tr.compile_seconds,
                                   "iterations": tr.epochs, "best_epoch": tr.best_epoch,
                                   "stop": tr.stop.name, "final_val_mse": tr.best_val_mse}}
    lsann, nn = trained["LSANN"], trained["NN"]
    row["LSANN"]["train"]["iterations_to_nn_val_mse"] = lsann.epochs_to(nn.best_val_mse)
    row["NN"]["train"]["iterations_to_nn_val_mse"] = nn.best_epoch
    # the accuracy both arms reach: the worse of the two best validation MSEs
    common = max(nn.best_val_mse, lsann.best_val_mse)
    row["common_val_mse"] = common
    row["iterations_to_common"] = {"LSANN": lsann.epochs_to(common), "NN": nn.epochs_to(common)}
    per_seed.append(row)
  return per_seed, fitted, on_test


def _fit_all(ctx, nn_train, jobs: list, label: str) -> list:
  """The network fits of `jobs`, one per core at once (`--workers N` sets how many;
  `--executor serial` one at a time), in spawned workers (`calibrate.parallel`: each
  identical to the serial fit, bit for bit). Side by side each training takes longer than
  alone (measured on 2 cores: NN-only at N = 30,279, 5.7 and 6.3 s beside each other against
  3.5 and 3.6 s one at a time, wall 0.79-0.95 of serial); the table says how many ran at
  once, and `--workers 1` gives solo times."""
  from calibrate import parallel
  workers = _training_workers(ctx)
  return parallel.fit_all({"x": nn_train.counts, "y": nn_train.wrench[:, :3]}, jobs, workers,
                          ctx.progress(label))


def _training_workers(ctx) -> int:
  spec = ctx.executor
  return 1 if spec.kind == "serial" else spec.count()


def _medians(per_seed: list, ls_pred, truth, ls_seconds: float) -> dict:
  """{method: {axis: scores}, "train": ...}: LS's scores, the networks' medians over seeds."""
  from calibrate import metrics
  results = {"LS": {**metrics.summary(ls_pred, truth, AXES),
                    "train": {"seconds": ls_seconds, "compile_seconds": 0.0, "iterations": 1}}}
  for m in ("LSANN", "NN"):
    results[m] = {ax: {key: float(np.median([r[m]["test"][ax][key] for r in per_seed]))
                       for key in per_seed[0][m]["test"][ax]} for ax in AXES}
    results[m]["train"] = {key: float(np.median([r[m]["train"][key] for r in per_seed]))
                           for key in ("seconds", "compile_seconds", "iterations")}
  return results


def _comparison(per_seed: list, results: dict) -> dict:
  """The paper's claims as measured: LSANN's time and iterations against NN-only's, X
  against Y, the networks against LS."""
  hits = [r["LSANN"]["train"]["iterations_to_nn_val_mse"] for r in per_seed]
  ratios = [h / r["NN"]["train"]["best_epoch"] for h, r in zip(hits, per_seed)
            if h is not None and r["NN"]["train"]["best_epoch"] > 0]
  common = [r["iterations_to_common"]["LSANN"] / max(r["iterations_to_common"]["NN"], 1)
            for r in per_seed]
  return {
      "time_ratio_lsann_over_nn": float(np.median(
          [r["LSANN"]["train"]["seconds"] / r["NN"]["train"]["seconds"] for r in per_seed])),
      "iteration_ratio_to_nn_val_mse": float(np.median(ratios)) if ratios else None,
      "seeds_where_lsann_reached_nn_val_mse": len(ratios),
      "iteration_ratio_to_common_val_mse": float(np.median(common)),
      "x_better_than_y": {m: results[m]["X"]["nrmse_pct"] < results[m]["Y"]["nrmse_pct"]
                          for m in METHODS},
      "networks_better_than_ls": {m: {ax: results[m][ax]["nrmse_pct"] < results["LS"][ax]["nrmse_pct"]
                                      for ax in AXES} for m in ("LSANN", "NN")},
  }


def _rows(data: dict) -> list:
  """metrics.csv: every score with its method and axis (the networks' medians with their
  spread over the seeds), the rest as plain numbers."""
  from benchmarks import outputs
  results, per_seed = data["results"], data["per_seed"]
  nets = ("LSANN", "NN")
  spread = {m: {ax: {k: float(np.std([r[m]["test"][ax][k] for r in per_seed]))
                     for k in per_seed[0][m]["test"][ax]} for ax in AXES} for m in nets}
  out = outputs.scored("results", {m: {ax: results[m][ax] for ax in AXES} for m in METHODS},
                       spread)
  out += [outputs.Row("results/train", m, "", k, v) for m in METHODS
          for k, v in results[m]["train"].items()]
  out += outputs.scored("LS_train", {"LS": data["LS_train"]})
  for i, r in enumerate(per_seed):
    out += outputs.scored(f"per_seed/{i}/test", {m: r[m]["test"] for m in nets})
  for m in nets:
    for i, r in enumerate(data["validation_blocks"].get(m, [])):
      out += outputs.scored(f"validation_blocks/{i}/test", {m: r["test"]})
  draws = data["test_draws"]  # median over the draws, their spread as the spread
  out += outputs.scored("test_draws", {
      m: {ax: {k: float(np.median(v)) for k, v in draws[m][ax].items()} for ax in AXES}
      for m in METHODS}, {m: {ax: {k: float(np.std(v)) for k, v in draws[m][ax].items()}
                              for ax in AXES} for m in METHODS})
  for key, by_method in data["generalisation"].items():
    out += outputs.scored(f"generalisation/{key}", by_method)
  out += outputs.scored("paper/table1", {m: {ax: dict(zip(("rmse", "nrmse_pct", "r2_pct"), v))
                                             for ax, v in t.items()}
                                         for m, t in PAPER_TABLE1.items()})
  out += outputs.scored("paper/LS_train", {"LS": {ax: {"nrmse_pct": v} for ax, v in
                                                  PAPER_LS_TRAIN_NRMSE.items()}})
  return out + outputs.plain(data, skip=(
      ("results",), ("LS_train",), ("test_draws",), ("per_seed", "*", "LSANN", "test"),
      ("per_seed", "*", "NN", "test"), ("validation_blocks", "*", "*", "test"),
      ("generalisation",), ("paper", "table1"),
      ("paper", "LS_train_nrmse_pct")))


def _predictions_and_figures(ctx, train, test, on_test: dict) -> None:
  """DIR/predictions.npz (the test truth, each method's prediction from the first seed, and
  the spread of the networks' seeds per sample, float32) and the paper's Figs. 5 and 7;
  `on_test` holds each method's test predictions per seed."""
  from benchmarks import figures, outputs
  truth = test.wrench[:, :3]
  preds = {m: on_test[m][0] for m in METHODS}
  spread = {f"spread_{m}": np.std(on_test[m], axis=0).astype(np.float32)
            for m in ("LSANN", "NN")}
  clock = footpad.clock(test)
  outputs.write_predictions(ctx.out, truth.astype(np.float32),
                            {m: p.astype(np.float32) for m, p in preds.items()}, AXES, "N",
                            time=clock, episode=test.episode, **spread)
  name = ctx.name
  figures.save(figures.over_time(clock, truth, preds, AXES, "N", benchmark=name, seed=ctx.seed,
                                 what="predicted and measured force on Testing Paths 1 and 2 "
                                      "(LSANN paper Fig. 7; networks: first seed)"),
               ctx.out, "force_over_time")
  segments = {}
  for path, label in (("z_press", "Z presses"), ("x_stroke", "X strokes"),
                      ("y_stroke", "Y strokes")):
    part = train.paths(path)
    if not len(part):
      continue
    levels = np.unique(part.z_level)
    level = levels[np.argmin(abs(levels - np.median(levels)))]
    ep = part.episode[np.flatnonzero(part.z_level == level)[0]]
    one = part.select(part.episode == ep)
    segments[f"{label} at {level * 1e3:.1f} mm"] = (one.time, one.counts, one.wrench[:, :3])
  if segments:
    figures.save(figures.strokes(segments, [f"die {i + 1}" for i in range(train.counts.shape[1])],
                                 AXES, benchmark=name, seed=ctx.seed), ctx.out, "strokes")


UNSEEN = ("square", "lissajous", "spiral")  # shapes none of the paper's paths has


def _generalisation(ctx, fitted: dict) -> dict:
  """The fitted estimators ({method: [estimator per seed]}) on shapes that are none of the
  paper's (`UNSEEN`, one pass each), at training depths and halfway between them (at most
  three of each):
  how they do where they were not trained. {"<path> <at|between>": {method: {axis: ...}}}."""
  from calibrate import metrics
  from sim.footpad import scene as scene_lib
  levels = sorted(ctx.settings.z_levels)
  # every gap between distinct levels (the paper's are 0.1 mm apart: 1e-4 itself is no
  # threshold, float spacing puts some gaps a hair under it)
  between = [round((a + b) / 2, 6) for a, b in zip(levels, levels[1:]) if b - a > 1e-6]
  def pick(zs):  # the first, the middle and the last
    return tuple(zs[i] for i in sorted({0, len(zs) // 2, len(zs) - 1})) if zs else ()
  depths = {"at": pick(levels), "between": pick(between)}
  scene = dataclasses.replace(ctx.settings, paths=UNSEEN,
                              z_levels=tuple(sorted(set(depths["at"] + depths["between"]))))
  rec, _ = scene_lib.generate(scene, ctx.progress("footpad unseen shapes"), ctx.use_cache)
  ctx.used(rec)
  ctx.print(f"\ngeneralisation: shapes none of the paper's paths has, at training depths "
            f"({', '.join(f'{z * 1e3:g}' for z in depths['at'])} mm) and between them "
            f"({', '.join(f'{z * 1e3:g}' for z in depths['between'])} mm); test NRMSE % / R2 % "
            f"Z, Y, X (networks: median of {len(fitted['NN'])} seeds)")
  out = {}
  for path in UNSEEN:
    for where, zs in depths.items():
      if not zs:
        continue
      held = rec.paths(path).on_path()
      held = held.select(np.isin(np.round(held.z_level, 6), np.round(zs, 6)))
      truth = held.wrench[:, :3]
      key = f"{path} {where}"
      out[key] = {}
      for m in METHODS:
        summaries = [metrics.summary(est.predict(held.counts), truth, AXES) for est in fitted[m]]
        out[key][m] = {ax: {k: float(np.median([s[ax][k] for s in summaries]))
                            for k in summaries[0][ax]} for ax in AXES}
        ctx.print(f"  {key:18s} {m:6s} " + "   ".join(
            f"{ax} {out[key][m][ax]['nrmse_pct']:6.2f} / {out[key][m][ax]['r2_pct']:7.2f}"
            for ax in ("Z", "Y", "X")))
  if ctx.quick:
    ctx.print("  (--quick trains at 3 depths only: between them the networks meet contact "
              "states, such as a die partly clipped, that their training never held; the "
              "paper's 16 depths do not leave such gaps)")
  return out


def _blocks_split(ctx, ls, nn_train, test, seeds, per_seed) -> dict:
  """The networks again on the first seeds with the validation set held out as contiguous
  1 s blocks instead of single samples (the paper's `dividerand`), side by side."""
  from calibrate import estimators, metrics
  truth = test.wrench[:, :3]
  out = {"block_samples": BLOCK, "seeds": list(seeds)}
  ctx.print(f"\nvalidation split (first {len(seeds)} seeds): single samples (the paper's) "
            f"against contiguous {BLOCK / 1000:g} s blocks; test NRMSE % Z/Y/X, epochs, stop")
  kinds = (estimators.Kind.LSANN, estimators.Kind.NN)
  jobs = [dict(kind=kind, counts="x", forces="y", linear_fit=ls.linear, seed=seed,
               val_block=BLOCK) for kind in kinds for seed in seeds]
  nets = iter(_fit_all(ctx, nn_train, jobs, "networks, blocks split"))
  for kind in kinds:
    rows = []
    for _ in seeds:
      est = next(nets)
      rows.append({"test": metrics.summary(est.predict(test.counts), truth, AXES),
                   "train": {"iterations": est.training.epochs,
                             "stop": est.training.stop.name}})
    out[kind.value] = rows
    for name, recs in (("samples", [r[kind.value] for r in per_seed[:len(seeds)]]),
                       ("blocks", rows)):
      nrmse = [np.median([r["test"][ax]["nrmse_pct"] for r in recs]) for ax in ("Z", "Y", "X")]
      epochs = np.median([r["train"]["iterations"] for r in recs])
      stops = ", ".join(sorted({r["train"]["stop"] for r in recs}))
      ctx.print(f"  {kind.value:6s} {name:8s} " + " / ".join(f"{v:5.2f}" for v in nrmse) +
                f"   {epochs:5.0f} epochs   {stops}")
  return out


def _print_table(ctx, results, comparison, n_seeds, per_seed) -> None:
  ctx.print(f"\nTable I (test paths; networks: median of {n_seeds} seeds)   [paper in brackets]")
  ctx.print(f"{'':6s} {'axis':4s} {'RMSE N':>16s} {'NRMSE %':>16s} {'R2 %':>16s}")
  for m in METHODS:
    for ax in ("Z", "Y", "X"):
      r, p = results[m][ax], PAPER_TABLE1.get(m, {}).get(ax)
      cells = [f"{r[k]:7.2f}" + (f" [{p[i]:6.2f}]" if p else " " * 9)
               for i, k in enumerate(("rmse", "nrmse_pct", "r2_pct"))]
      ctx.print(f"{m if ax == 'Z' else '':6s} {ax:4s} " + " ".join(cells))
  ctx.print(f"\n{'training':9s} {'seconds':>9s} {'compile s':>10s} {'iterations':>11s}   paper"
            f"   (networks {_training_workers(ctx)} at a time; --workers 1 for solo times)")
  for m in METHODS:
    t = results[m]["train"]
    cited = f"{PAPER_MINUTES[m]} min" if m in PAPER_MINUTES else ""
    ctx.print(f"{m:9s} {t['seconds']:9.2f} {t['compile_seconds']:10.2f} {t['iterations']:11.0f}"
              f"   {cited}")
  for m in ("LSANN", "NN"):
    stops = [r[m]["train"]["stop"] for r in per_seed]
    ctx.print(f"{m} training stopped: " + ", ".join(
        f"{_STOPS.get(s, s)} {stops.count(s)}/{len(stops)}" for s in sorted(set(stops))))
  ir = comparison["iteration_ratio_to_nn_val_mse"]
  ctx.print(f"LSANN/NN-only training time {comparison['time_ratio_lsann_over_nn']:.2f} "
            f"(paper {paper.TIME_RATIO:.2f})")
  ctx.print("LSANN iterations to NN-only's final validation MSE / NN-only's: " +
            (f"{ir:.2f}" if ir is not None else "never reached") +
            f" ({comparison['seeds_where_lsann_reached_nn_val_mse']}/{n_seeds} seeds; paper 0.41)")
  ctx.print(f"LSANN/NN-only iterations to the validation MSE both reach: "
            f"{comparison['iteration_ratio_to_common_val_mse']:.2f}")
  xb = comparison["x_better_than_y"]
  ctx.print("X estimated better than Y (paper: yes): " +
            ", ".join(f"{m} {'yes' if v else 'no'}" for m, v in xb.items()))


for _name, _paths, _what in (
    ("asterisk_path", ("asterisk",), "LS, LSANN and NN-only trained on the Asterisk path "
                                     "(paper Table I)"),
    ("circular_path", ("circular",), "LS, LSANN and NN-only trained on the Circular path"),
    ("footpad_table1", ("asterisk", "circular"), "the paper's full protocol (Asterisk + "
                                                 "Circular training), Table I")):
  # Table I runs at the paper preset unless told otherwise: its printed table sits beside
  # the paper's, and the preset is the design identified from that table (--preset nominal
  # for the sourced defaults)
  register(_name, "footpad: " + _what, settings=footpad.protocol_settings,
           presets=footpad.presets, fixed=footpad.FIXED, default_preset="paper",
           tags=("footpad", "paper", "calibration"))(
      functools.partial(run_table, nn_paths=_paths))
