"""identify_footpad: the footpad's ranged parameters identified from a table of calibration
results (the LSANN paper's Table I by default, or your own `metrics.csv`).

As MuJoCo's `sysid` identifies a model from measurements (`benchmarks.identification`), with
a paper's table as the measurement: each parameter carries its nominal value, its sourced
range (`fields.Sourced`, the sources in the parameter's docstring) and the setting it
modifies (its --set key); a residual compares one run of the paper's protocol (LS on the Z presses and X/Y strokes,
LSANN and NN-only on the Asterisk path, all tested on Testing Paths 1 and 2) with every cell
of the target table; Optuna's TPE sampler (or CMA-ES, `--set sampler=cmaes`) moves the
parameters inside their ranges and nowhere else. The parameters: Thirion's friction law
(mu0, tau_s), static over kinetic friction, the two-term Prony relaxation, the dies'
hysteresis and thermal drift (offset and gain), the stroke length of the linear fit's data,
and which way the 2-by-3 die array faces the rig (as assumed, or turned a quarter).

The residual (`benchmarks.identification`): each target cell's deviation in its band (NRMSE and RMSE: relative, 25 %; R2:
8 points; the strokes' force range: 15 %; LSANN's training epochs over NN-only's, the
paper's time ratio (the two networks are one size, so an epoch costs both the same, and
epochs repeat exactly for a seed where seconds do not): 50 %),
squared, capped at 5 bands (a network that failed on one seed counts as far, not as
everything), and averaged over the cells. Networks are scored by their median over
`network_seeds` seeds; one evaluation is one noise and drift draw, so two trials a hair
apart can score a band apart: the study reports the seeds it used. Trial 0 is the nominal
design (every parameter at its sourced default), trial 1 the same pad turned a quarter. A
trial whose linear fit alone already scores worse than the median of the trials before it
is pruned before its networks train (Optuna's median pruner).

The study lives in DIR/study.db (SQLite): Ctrl-C keeps every finished trial, and the same
command goes on from there; each trial's sampler is seeded from the run's seed and the
number of trials finished before it, so an interrupted and resumed study asks for the same
designs as one that ran straight through. The result is printed as the preset it makes
(`sim.footpad.presets`): each parameter's value, its sourced range and where in the range it
sits, and the best trial's table beside the targets and beside the nominal design.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from benchmarks import footpad, identification
from benchmarks.identification import Target
from benchmarks.registry import register
from util import fields
from util.fields import setting

AXES = ("X", "Y", "Z")
ALLOWED = ("group results with method LS, LSANN or NN, axis X, Y or Z and metric nrmse_pct, "
           "rmse or r2_pct; group LS_train with method LS and metric nrmse_pct, rmse, r2_pct "
           "or range (N); group ratio with metric time_lsann_over_nn or epochs_lsann_over_nn")


def paper_targets() -> tuple[Target, ...]:
  """The LSANN paper's numbers as targets: every LSANN and NN-only cell of Table I (NRMSE and
  R2), the linear fit on its strokes (NRMSE, and the force range of each axis, Sec. III-B),
  and LSANN's training time over NN-only's."""
  from sim.footpad import paper
  out = [Target("results", m, ax, metric, paper.TABLE1[m][ax][i])
         for m in ("LSANN", "NN") for ax in ("Z", "Y", "X")
         for i, metric in ((1, "nrmse_pct"), (2, "r2_pct"))]
  out += [Target("LS_train", "LS", ax, "nrmse_pct", paper.LS_TRAIN_NRMSE[ax])
          for ax in ("Z", "Y", "X")]
  out += [Target("LS_train", "LS", ax, "range", paper.LS_TRAIN_RANGE[ax])
          for ax in ("Z", "Y", "X")]
  # the paper's time ratio as the ratio of epochs: both networks are the same size, so an
  # epoch costs both the same, and epochs, unlike seconds, repeat exactly for a seed
  out.append(Target("ratio", "", "", "epochs_lsann_over_nn", paper.TIME_RATIO))
  return tuple(out)


def scorable(group: str, method: str, axis: str, metric: str) -> bool:
  """Whether an evaluation produces the cell (group, method, axis, metric)."""
  if group == "ratio":
    return metric in ("time_lsann_over_nn", "epochs_lsann_over_nn") and not method and not axis
  if axis not in AXES:
    return False
  if group == "results":
    return method in ("LS", "LSANN", "NN") and metric in ("nrmse_pct", "rmse", "r2_pct")
  if group == "LS_train":
    return method == "LS" and metric in ("nrmse_pct", "rmse", "r2_pct", "range")
  return False


def needs_networks(targets) -> bool:
  return any(t.method in ("LSANN", "NN") or t.group == "ratio" for t in targets)


def evaluate(ctx, scene, seeds: list[int], workers: int, networks: bool = True,
             stop=None) -> dict:
  """The paper's protocol on `scene`: LS on the strokes (its scores on them and their force
  ranges), then, with `networks`, LSANN and NN-only from each of `seeds` (`workers` at once),
  all tested on the test paths. `stop(partial)` is called between the two and may raise
  to end the trial (pruned). Returns {"LS_train": {"LS": {axis: ...}}, "results": {method:
  {axis: ...}}, "ratio": {"time_lsann_over_nn", "epochs_lsann_over_nn"}}: the networks'
  scores are medians over the seeds."""
  from calibrate import estimators, metrics, parallel
  from sim.footpad import protocol
  recs = {name: rec for name, (rec, _) in footpad.recordings(ctx, scene).items()}
  strokes, net, test = protocol.splits(recs["train"], recs["test"]).values()
  truth, forces = test.wrench[:, :3], strokes.wrench[:, :3]
  ls = estimators.fit(estimators.Kind.LS, strokes.counts, forces)
  train = metrics.summary(ls.predict(strokes.counts), forces, AXES)
  for i, ax in enumerate(AXES):
    train[ax]["range"] = float(np.ptp(forces[:, i]))
  out = {"LS_train": {"LS": train},
         "results": {"LS": metrics.summary(ls.predict(test.counts), truth, AXES)}}
  if stop is not None:
    stop(out)
  if not networks:
    return out
  kinds = (estimators.Kind.LSANN, estimators.Kind.NN)
  jobs = [dict(kind=k, counts="x", forces="y", linear_fit=ls.linear, seed=s)
          for s in seeds for k in kinds]
  fitted = parallel.fit_all({"x": net.counts, "y": net.wrench[:, :3]}, jobs, workers)
  runs = {k.value: [] for k in kinds}
  for job, est in zip(jobs, fitted):
    runs[job["kind"].value].append((metrics.summary(est.predict(test.counts), truth, AXES),
                                    est.training.seconds, est.training.epochs))
  for m, rs in runs.items():
    out["results"][m] = {ax: {k: float(np.median([r[0][ax][k] for r in rs]))
                              for k in rs[0][0][ax]} for ax in AXES}
  pairs = list(zip(runs["LSANN"], runs["NN"]))
  out["ratio"] = {"time_lsann_over_nn": float(np.median([a[1] / b[1] for a, b in pairs])),
                  "epochs_lsann_over_nn": float(np.median([a[2] / max(b[2], 1)
                                                           for a, b in pairs]))}
  out["seconds"] = {m: [r[1] for r in rs] for m, rs in runs.items()}
  return out


@fields.declared
@dataclasses.dataclass(frozen=True)
class Identify(identification.Settings):
  """Settings of the footpad's identification.

  Attributes:
    trials: designs the study evaluates in all (a rerun with more goes on from the stored
      study).
    sampler: Optuna's TPE (tree-structured Parzen estimator; handles the layout's choice) or
      CMA-ES (the layout then stays at the best trial's so far).
    startup: trials drawn quasi-randomly (Sobol) before the sampler models the scores.
    targets: a metrics.csv whose rows are the targets (this project's columns: group,
      method, axis, metric, value); none: the LSANN paper's Table I.
    scene: the footpad protocol's scene the designs are applied to (its Z levels, effects,
      ADC).
    network_seeds: seeds per network and trial; the networks score by their median.
  """
  network_seeds: int = setting(1, "[1, 10]")


def settings(quick: bool, seed: int) -> Identify:
  from sim.footpad import protocol
  # paper scale: about 2 min a trial on 2 cores, 30 trials within the hour
  return Identify(trials=12 if quick else 30, network_seeds=1, startup=4 if quick else 8,
                  scene=protocol.base(quick, seed))


FIXED = {"scene.paths": "the protocol runs the paper's training and test paths",
         "scene.seed": "use --seed"}


@register("identify_footpad", "footpad: its ranged parameters (friction, stick-slip, "
          "relaxation, hysteresis, drift, stroke length, die layout) identified from the "
          "paper's Table I or your own metrics.csv, by Optuna within the sourced ranges; "
          "prints the preset",
          settings=settings, fixed=FIXED, tags=("footpad", "paper", "identification"),
          presets=footpad.presets, preset_prefix="scene.")
def run(ctx):
  from sim import settings as settings_lib
  from sim.footpad import presets
  s = ctx.settings
  targets = identification.targets_of(s, scorable, ALLOWED, paper_targets)
  networks = needs_networks(targets)
  seeds = [int(x.generate_state(1)[0])
           for x in np.random.SeedSequence(ctx.seed, spawn_key=(22,)).spawn(s.network_seeds)]
  workers = 1 if ctx.executor.kind == "serial" else ctx.executor.count()

  def one(design: dict, stop) -> dict:
    scene = settings_lib.apply(s.scene, presets.overrides(design))
    return evaluate(ctx, scene, seeds, workers, networks, stop)
  # a parameter whose effect the scene leaves off changes nothing: it is not searched
  searched = tuple(p for p in presets.parameters()
                   if not s.scene.unread("params.prony" if p.key.startswith("prony.") else p.key))
  left = [p.key for p in presets.parameters() if p not in searched]
  nominal = {k: v for k, v in presets.nominal_design().items()
             if k == "layout" or k in {p.key for p in searched}}
  spec = identification.Study(
      "identify_footpad", searched, {"layout": presets.LAYOUTS},
      (nominal, {**nominal, "layout": "turned"}), one,
      lambda design, command, note: presets.preset("identified", "the study's best design",
                                                   design, command, note),
      {"scene": type(s.scene).config(s.scene), "seeds": s.network_seeds})
  describe = (f"targets {'the paper' if not s.targets else s.targets}, networks the median "
              f"of {s.network_seeds} seed(s), {len(s.scene.z_levels)} Z levels" +
              (f"; not searched, their effects off: {', '.join(left)}" if left else ""))
  return identification.run(ctx, spec, targets, s.trials, s.sampler, s.startup, describe)
