"""Identification of a rig's ranged parameters from a table of results, as MuJoCo's `sysid`
identifies a model from measurements, with a paper's table as the measurement.

A rig brings its parameters (`sim.presets.Parameter`: nominal, sourced range, --set key),
its choices (the footpad's die layout), its targets (`Target`, cells named as metrics.csv
names them) and one evaluation (design -> {group: {method: {axis: {metric: value}}}}); this
module runs the study: Optuna's TPE sampler (or CMA-ES) moves the parameters inside their
ranges and nowhere else, the residual is each target's deviation in its band (`BANDS`),
squared, capped (`CAP`) and averaged, and a trial whose cheap first stage already scores
worse than the median of the trials before it is pruned (Optuna's median pruner).

The study lives in DIR/study.db (SQLite): Ctrl-C keeps every finished trial and the same
command goes on from there; each trial's sampler is seeded from the run's seed and the
number of trials finished before it, so an interrupted and resumed study asks for the same
designs as one that ran straight through. A study of other settings or targets in the same
folder is refused, not mixed in.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import pathlib
import time
from typing import Any, Callable, Literal, Optional, Sequence

import numpy as np

from benchmarks import outputs
from util import errors, fields, files
from util.fields import setting

# (kind, width) of a target's band, by its metric: the deviation counted as one band
BANDS = {"nrmse_pct": ("relative", 0.25), "rmse": ("relative", 0.25), "r2_pct": ("points", 8.0),
         "range": ("relative", 0.15), "time_lsann_over_nn": ("relative", 0.5),
         "epochs_lsann_over_nn": ("relative", 0.5),
         "median_pct": ("relative", 1.0), "worst_pct": ("relative", 1.0),
         "resolution": ("relative", 1.0), "mass_g": ("relative", 0.25),
         "legs_up_m_s2": ("relative", 0.5)}
CAP = 5.0  # bands: one failed network is far from the target, not infinitely far


@dataclasses.dataclass(frozen=True)
class Target:
  """One cell of a target table, named as metrics.csv names it.

  Attributes:
    group: where the number belongs ("results": the test; "LS_train": the linear fit on its
      own data; "ratio").
    method, axis, metric: as in metrics.csv ("LSANN", "X", "nrmse_pct").
    value: the target.
  """
  group: str
  method: str
  axis: str
  metric: str
  value: float

  @property
  def name(self) -> str:
    return "/".join(x for x in (self.group, self.method, self.axis, self.metric) if x)


def read_targets(path: pathlib.Path, scorable: Callable[[str, str, str, str], bool],
                 allowed: str) -> tuple[Target, ...]:
  """Targets from a metrics.csv (this project's, or your own in its columns: group, method,
  axis, metric, value; lines starting with "#" are comments): every row `scorable` accepts;
  other rows are left out. DataError naming the file and line for a table it cannot read,
  and saying which rows count (`allowed`) if none is left."""
  import csv
  lines = [line for line in pathlib.Path(path).read_text().splitlines()
           if not line.lstrip().startswith("#")]
  reader = csv.DictReader(lines)
  columns = ("group", "method", "axis", "metric", "value")
  if not set(columns) <= set(reader.fieldnames or ()):
    raise errors.DataError(f"targets={path}: its columns are {reader.fieldnames}; needed "
                           f"{', '.join(columns)} (as a run's metrics.csv has them)")
  out = []
  for n, r in enumerate(reader, start=2):
    try:
      value = float(r["value"])
    except (TypeError, ValueError):
      raise errors.DataError(f"targets={path}: row {n} has value {r['value']!r}: allowed a "
                             f"number") from None
    if scorable(r["group"], r["method"], r["axis"], r["metric"]) and math.isfinite(value):
      out.append(Target(r["group"], r["method"], r["axis"], r["metric"], value))
  out = tuple(out)
  if not out:
    raise errors.DataError(f"targets={path}: no row it can score; allowed rows: {allowed}")
  return out


def targets_of(s: "Settings", scorable: Callable[[str, str, str, str], bool], allowed: str,
               paper: Callable[[], tuple[Target, ...]]) -> tuple[Target, ...]:
  """The targets of the settings `s`: its `targets` file's rows (`read_targets`), or the
  paper's."""
  return read_targets(pathlib.Path(s.targets), scorable, allowed) if s.targets else paper()


def measured(result: dict, t: Target) -> float:
  """The evaluation's value of the target cell `t` (NaN where it holds none)."""
  try:
    if t.group == "ratio":
      return float(result["ratio"][t.metric])
    return float(result[t.group][t.method][t.axis][t.metric])
  except KeyError:
    return math.nan


def deviation(value: float, t: Target) -> float:
  """How far `value` lies from the target, in bands (signed: + above); +-CAP beyond, and
  CAP for no number."""
  kind, width = BANDS[t.metric]
  if not math.isfinite(value):
    return CAP
  if kind == "points":
    d = (value - t.value) / width
  elif value <= 0 or t.value <= 0:
    d = CAP if value != t.value else 0.0
  else:
    d = math.log(value / t.value) / math.log1p(width)
  return float(np.clip(d, -CAP, CAP))


def score(result: dict, targets: Sequence[Target], partial: bool = False) -> float:
  """The residual: the mean over the targets of their squared deviations in bands (with
  `partial`, over those the result holds so far)."""
  ds = [deviation(measured(result, t), t) for t in targets
        if not partial or math.isfinite(measured(result, t))]
  return float(np.mean(np.square(ds))) if ds else math.nan


@fields.declared
@dataclasses.dataclass(frozen=True)
class Settings:
  """Settings of an identification.

  Attributes:
    trials: designs the study evaluates in all (a rerun with more goes on from the stored
      study).
    sampler: Optuna's TPE (tree-structured Parzen estimator; handles categorical choices)
      or CMA-ES (the choices then stay at the best trial's so far).
    startup: trials drawn quasi-randomly (Sobol) before the sampler models the scores.
    targets: a metrics.csv whose rows are the targets (this project's columns: group,
      method, axis, metric, value); none: the rig's paper.
    scene: the rig protocol's scene the designs are applied to.
  """
  trials: int = setting(30, "[1, 10000]")
  sampler: Literal["tpe", "cmaes"] = "tpe"
  startup: int = setting(8, "[0, 1000]")
  targets: Optional[str] = None
  scene: object = None

  def validate(self) -> None:
    """What a field's range cannot say: the targets' file exists, and the scene passes its
    own checks, each error named under "scene."."""
    if self.targets is not None and not pathlib.Path(self.targets).is_file():
      raise errors.SettingError(f"targets={self.targets!r} is not a file: allowed a "
                                f"metrics.csv (columns group, method, axis, metric, value) or "
                                f"none")
    if hasattr(self.scene, "validate"):
      try:
        self.scene.validate()
      except errors.UserError as err:
        raise type(err)(f"scene.{err}") from None


@dataclasses.dataclass(frozen=True)
class Study:
  """One rig's identification.

  Attributes:
    name: the benchmark's name (the study's in study.db).
    parameters: the ranged parameters searched.
    choices: {name: options} of the categorical choices searched.
    start: designs evaluated first, in order (the nominal one, ...).
    evaluate: (design, stop) -> result; `stop(partial)` is to be called after the cheap
      first stage and raises to prune the trial.
    preset: design -> a `sim.presets.Preset` of it (for the report).
    fingerprint: everything the evaluations depend on besides the design (settings,
      targets): a stored study of another is refused.
  """
  name: str
  parameters: tuple
  choices: dict
  start: tuple
  evaluate: Callable[[dict, Callable[[dict], None]], dict]
  preset: Callable[..., Any]
  fingerprint: Any


class Pruned(Exception):
  """Raised by the evaluation's stop callback: the trial's first stage scores worse than
  the median of the trials before it."""


def run(ctx, study_spec: Study, targets: Sequence[Target], trials: int, sampler: str,
        startup: int, describe: str) -> outputs.Result:
  """Runs (or goes on with) the study to `trials` trials and reports the best design as a
  preset beside the targets and the first design (the nominal)."""
  import warnings
  import optuna
  with warnings.catch_warnings():
    outputs.quiet_out_of_range()
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = _stored(ctx, study_spec, targets, sampler, startup)
    if not study.trials:
      for design in study_spec.start:
        study.enqueue_trial(design)
    done = _count(study, "COMPLETE", "PRUNED")
    ctx.print(f"{study_spec.name}: {len(study_spec.parameters)} parameters" +
              (f" and {', '.join(study_spec.choices)}" if study_spec.choices else "") +
              f" within their sourced ranges, {len(targets)} target cells, {sampler.upper()} "
              f"after {startup} quasi-random trials; {describe}; {done} of {trials} trials "
              f"stored in {ctx.out}/study.db")
    bar = ctx.progress(f"{study_spec.name} trials")
    t_start = time.perf_counter()
    while done < trials:
      study.sampler = _sampler(sampler, startup, ctx.seed, done, study)
      fixed = {}
      if sampler == "cmaes" and study_spec.choices:  # CMA-ES takes numbers only
        best = min(_complete(study), key=lambda t: t.value, default=None)
        fixed = {k: best.params[k] for k in study_spec.choices} if best else {}
      trial = study.ask(_distributions(study_spec, fixed))
      _one_trial(ctx, study, study_spec, trial, targets)
      done += 1
      if bar:
        bar(done, trials)
    return _report(ctx, study, study_spec, targets, time.perf_counter() - t_start)


def _one_trial(ctx, study, spec: Study, trial, targets) -> None:
  import optuna
  design = dict(trial.params)
  t0 = time.perf_counter()

  def stop(partial: dict) -> None:
    value = score(partial, targets, partial=True)
    if math.isfinite(value):
      trial.report(value, 0)
      if trial.should_prune():
        raise Pruned(value)
  try:
    result = spec.evaluate(design, stop)
  except Pruned as p:
    study.tell(trial, state=optuna.trial.TrialState.PRUNED)
    line = f"pruned after its first stage (partial score {p.args[0]:.2f})"
  except errors.SimulationError as err:  # a design the physics cannot run: reported, skipped
    study.set_user_attr(f"error{trial.number}", str(err))
    study.tell(trial, state=optuna.trial.TrialState.FAIL)
    line = f"failed: {err}"
  except BaseException:
    study.tell(trial, state=optuna.trial.TrialState.FAIL)
    raise
  else:
    value = score(result, targets)
    study.set_user_attr(f"trial{trial.number}", result)
    study.tell(trial, value)
    line = f"score {value:.3f}"
  ctx.print(f"  trial {trial.number:3d} ({time.perf_counter() - t0:5.0f} s): {line}; " +
            ", ".join(f"{k} {v if isinstance(v, str) else f'{v:.4g}'}" for k, v in design.items()))


def _stored(ctx, spec: Study, targets, sampler: str, startup: int):
  """The stored study (created, or loaded to go on), with interrupted trials marked failed
  (they are asked again)."""
  import optuna
  storage = f"sqlite:///{(ctx.out / 'study.db').resolve()}"
  study = optuna.create_study(study_name=f"{spec.name}-seed{ctx.seed}", storage=storage,
                              load_if_exists=True, direction="minimize",
                              pruner=optuna.pruners.MedianPruner(n_startup_trials=4))
  key = hashlib.sha256(files.json_text({
      "fingerprint": spec.fingerprint, "sampler": sampler, "startup": startup,
      "targets": [dataclasses.astuple(t) for t in targets],
      "parameters": [dataclasses.astuple(p) for p in spec.parameters],
      "choices": spec.choices}, default=str).encode()).hexdigest()
  stored = study.user_attrs.get("fingerprint")
  if stored is None:
    study.set_user_attr("fingerprint", key)
  elif stored != key:
    raise errors.SettingError(
        f"--out {ctx.out} holds a study of other settings or targets ({ctx.out}/study.db); "
        f"give another --out, or delete that folder to start again")
  for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
    study.tell(t.number, state=optuna.trial.TrialState.FAIL)
  return study


def _count(study, *states: str) -> int:
  return sum(t.state.name in states for t in study.get_trials(deepcopy=False))


def _complete(study) -> list:
  import optuna
  return study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))


def _sampler(kind: str, startup: int, seed: int, finished: int, study):
  """The sampler of the next trial, seeded from the run's seed and how many trials finished
  before it (so a resumed study asks what an uninterrupted one would)."""
  import optuna
  trial_seed = int(np.random.SeedSequence(seed, spawn_key=(21, finished)).generate_state(1)[0])
  if finished < startup or not _complete(study):
    return optuna.samplers.QMCSampler(seed=seed, scramble=True)
  if kind == "cmaes":  # it rebuilds its search distribution from the stored trials
    return optuna.samplers.CmaEsSampler(
        seed=trial_seed, independent_sampler=optuna.samplers.RandomSampler(seed=trial_seed))
  return optuna.samplers.TPESampler(seed=trial_seed, multivariate=True, group=True,
                                    n_startup_trials=0)


def _distributions(spec: Study, fixed: dict) -> dict:
  import optuna
  out = {p.key: optuna.distributions.FloatDistribution(p.lo, p.hi, log=p.log)
         for p in spec.parameters}
  for name, options in spec.choices.items():
    out[name] = optuna.distributions.CategoricalDistribution(
        (fixed[name],) if name in fixed else tuple(options))
  return out


def _report(ctx, study, spec: Study, targets, wall: float) -> outputs.Result:
  complete = _complete(study)
  if not complete:
    raise errors.SimulationError(f"{spec.name}: no trial finished: see the trials above")
  best = min(complete, key=lambda t: t.value)
  first = next((t for t in complete if spec.start and t.params == spec.start[0]), None)
  results = {t.number: study.user_attrs.get(f"trial{t.number}") for t in complete}
  states = [t.state.name for t in study.trials]
  ctx.print(f"\n{len(study.trials)} trials ({states.count('COMPLETE')} complete, "
            f"{states.count('PRUNED')} pruned, {states.count('FAIL')} failed); this run "
            f"{wall:.0f} s; best: trial {best.number}, score {best.value:.3f}" +
            (f" (nominal design, trial {first.number}: {first.value:.3f})" if first else ""))
  ctx.print(f"\n{'target':34s} {'target':>9s} {'best':>9s} {'bands':>6s}" +
            (f" {'nominal':>9s}" if first else ""))
  cells = []
  for t in targets:
    got = measured(results[best.number], t)
    nom = measured(results[first.number], t) if first else math.nan
    d = deviation(got, t)
    cells.append({"target": dataclasses.asdict(t), "best": got, "nominal": nom, "bands": d})
    ctx.print(f"{t.name:34s} {t.value:9.4g} {got:9.4g} {d:+6.2f}" +
              (f" {nom:9.4g}" if first else ""))
  inside = sum(abs(c["bands"]) <= 1 for c in cells)
  inside_nominal = sum(abs(deviation(c["nominal"], t)) <= 1 for c, t in zip(cells, targets))
  ctx.print(f"within one band: best {inside} of {len(cells)} cells" +
            (f", nominal {inside_nominal}" if first else ""))
  design = dict(best.params)
  command = f"python -m benchmarks.run {spec.name}{' --quick' if ctx.quick else ''} --seed {ctx.seed}"
  found = spec.preset(design, command,
                      f"{len(study.trials)} trials; score {best.value:.3f}" +
                      (f" against the nominal design's {first.value:.3f}" if first else ""))
  ctx.print("")
  for line in found.lines():
    ctx.print(line)
  overrides = found.overrides()
  files.write_text(ctx.out / "preset.json", files.json_text(
      {"design": design, "overrides": overrides, "score": best.value, "trial": best.number,
       "trials": len(study.trials), "seed": ctx.seed}))
  preset = [{"key": p.key, "value": design[p.key], "range": [p.lo, p.hi], "log": p.log,
             "position": p.position(design[p.key]), "nominal": p.nominal}
            for p in spec.parameters]
  data = {"best": {"trial": best.number, "score": best.value, "design": design,
                   "overrides": overrides, "result": results[best.number]},
          "nominal": ({"trial": first.number, "score": first.value,
                       "result": results[first.number]} if first else None),
          "cells": cells, "preset": preset,
          "trials": [{"number": t.number, "state": t.state.name, "value": t.value,
                      "params": t.params} for t in study.trials],
          "speed": {"seconds_this_run": wall}}
  rows = [outputs.Row(f"{kind}/{c['target']['group']}", c["target"]["method"],
                      c["target"]["axis"], c["target"]["metric"], c[value])
          for c in cells for kind, value in (("best", "best"), ("nominal", "nominal"))
          if not (kind == "nominal" and not first)]
  rows += [outputs.Row(f"target/{c['target']['group']}", c["target"]["method"],
                       c["target"]["axis"], c["target"]["metric"], c["target"]["value"])
           for c in cells]
  rows += [outputs.Row("preset", "", "", p["key"], p["value"]) for p in preset]
  rows += [outputs.Row("study", "", "", "best_score", best.value),
           outputs.Row("study", "", "", "trials", float(len(study.trials)))]
  return outputs.Result(data, tuple(rows))
