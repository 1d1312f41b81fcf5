"""Force estimators of the LSANN paper as plain data: fit, predict, save, load.

* LS: linear least squares from the six die counts (paper Sec. III-B).
* POLY: the cubic pseudoinverse (force-sensing-shell paper), same numerics.
* LSANN: LS, then the network fitted to the residual F - F_LS from the six counts (paper
  Sec. III-C: "the input is the array of voltage signals"; Eqn 8 sums the two).
* NN: the same network fitted to F from the six counts.
* GRU: LS, then a small recurrent network (`calibrate.recurrent`) fitted to the residual from
  the counts' past: a temporal estimator, fitted by `fit_temporal` on whole recordings.
"""

from __future__ import annotations

import dataclasses
import enum
import pathlib
import warnings
from typing import Optional, Sequence

import numpy as np

from calibrate import compose, splits, store
from calibrate.info import INTERVAL_GRID, Info, data_digest, group_means, held_out  # noqa: F401
from calibrate.parts import gru as recurrent
from calibrate.parts import linear, mlp
from calibrate.parts import memory as temporal
from calibrate.parts import poly as poly_lib
from calibrate.parts.base import Part, Stream
from util import errors


class Kind(enum.Enum):
  LS = "LS"
  POLY = "POLY"
  LSANN = "LSANN"
  NN = "NN"
  GRU = "GRU"  # LS plus a recurrent network on the residual (`fit_temporal` only)
  AUTO = "AUTO"  # per output, the candidate with the lowest held-out error (`fit_auto`)


class OutOfRangeWarning(UserWarning):
  """Inputs outside the range an estimator was fitted on: its output there is extrapolation."""


@dataclasses.dataclass(frozen=True)
class Estimator:
  """A fitted estimator: a tree of parts (`root`: `calibrate.parts` families composed by
  `calibrate.compose`), the method a user asked for (`kind`), what it was fitted on
  (`info`), and how its network's training went (`training`; `trainings`, an ensemble's
  members' in order)."""
  kind: Kind
  root: Part
  info: Optional[Info] = None
  training: Optional[object] = None
  trainings: tuple = ()

  @property
  def n_inputs(self) -> int:
    """C, the raw input channels."""
    return self.root.n_inputs

  @property
  def _stage(self) -> Part:
    """The stages behind the temporal front end (the root without one)."""
    return self.root.stage if isinstance(self.root, compose.Chain) else self.root

  # the stages by their old names, read-only
  @property
  def memory(self):
    return self.root.front if isinstance(self.root, compose.Chain) else None

  @property
  def linear(self):
    s = self._stage
    return s.base if isinstance(s, compose.Residual) else \
        s if isinstance(s, linear.LinearFit) else None

  @property
  def poly(self):
    return self._stage if isinstance(self._stage, poly_lib.PolyFit) else None

  @property
  def net(self):
    s = self._stage
    s = s.residual if isinstance(s, compose.Residual) else s
    return s if isinstance(s, mlp.MLP) else None

  @property
  def rnn(self):
    s = self._stage
    return s.residual if isinstance(s, compose.Residual) and \
        isinstance(s.residual, recurrent.GRU) else None

  @property
  def members(self) -> tuple["Estimator", ...]:
    s = self._stage
    if not isinstance(s, compose.Mean):
      return ()
    runs = self.trainings or (None,) * len(s.members)
    return tuple(Estimator(Kind(m.label), m, training=t) for m, t in zip(s.members, runs))

  @property
  def parts(self) -> tuple["Estimator", ...]:
    s = self._stage
    return tuple(Estimator(Kind(p.label), p) for p in s.parts) \
        if isinstance(s, compose.PerOutput) else ()

  @property
  def pick(self) -> tuple[int, ...]:
    return self._stage.pick if isinstance(self._stage, compose.PerOutput) else ()

  def guard(self) -> Optional[int]:
    """AUTO: the index of its LS part, whose plane carries the network parts beyond the
    training box (None: no LS part, or no network part, or no training range)."""
    return self._stage.guard if isinstance(self._stage, compose.PerOutput) else None

  def predict(self, counts: np.ndarray, return_std: bool = False,
              segments: Optional[np.ndarray] = None, contact: Optional[np.ndarray] = None,
              sessions: Optional[np.ndarray] = None):
    """(N, A) forces (output units) from (N, C) counts.

    Warns (`OutOfRangeWarning`, one warning naming the share of samples and the channels)
    when inputs leave the range the estimator was fitted on. With `return_std`, also (N, A)
    standard deviations: the members' spread per sample (an ensemble) combined with the
    validation residual spread of `info` (sqrt of the sum of squares).

    An estimator with a temporal front end (`memory`) reads the counts as recordings in time
    order: `segments` (N,) labels each sample's recording (None: one recording; its filters
    and tares start afresh at each change of label), `contact` (N,) an optional contact flag
    for its tare, `sessions` (N,) the runs of segments its tare carries through
    (`calibrate.parts.memory.Memory.features`). A static estimator ignores them.
    """
    counts = linear.check_array(counts, "counts", self.n_inputs)
    self._check_range(counts)
    stream = Stream(segments, contact, sessions) if self.memory is not None else None
    mean, spread = self.root.mean_spread(counts, stream)
    if not return_std:
      return mean
    sd = np.zeros_like(mean) if spread is None else spread
    if self.info is not None:
      sd = np.sqrt(sd ** 2 + self.info.residual_sd ** 2)
    return mean, sd

  def outside(self, counts: np.ndarray) -> np.ndarray:
    """(N, C) True where an input lies outside the range the estimator was fitted on (all
    False without `info`)."""
    counts = np.asarray(counts, float)
    if self.info is None:
      return np.zeros(counts.shape, bool)
    return (counts < self.info.input_lo) | (counts > self.info.input_hi)

  def _check_range(self, counts: np.ndarray) -> None:
    outside = self.outside(counts)
    rows = outside.any(axis=1)
    if rows.any():
      names = [n for n, o in zip(self.info.inputs, outside.any(axis=0)) if o]
      warnings.warn(f"{rows.mean():.1%} of the {len(counts)} samples have inputs outside the "
                    f"range this estimator was fitted on ({', '.join(names)}): its output "
                    f"there is extrapolation", OutOfRangeWarning, stacklevel=3)

  def save(self, path) -> None:
    """Writes the estimator to one .npz file, atomically (`calibrate.store`: format 4, with
    the format tag, version and a SHA-256 of the arrays that `load` checks)."""
    store.save(path, self.kind.value, self.root, self.info, self.training)

  @staticmethod
  def load(path) -> "Estimator":
    """Reads a file `save` wrote (or a version-3 file), checked: format tag and version (a
    version this testbench does not know is refused), checksum, finiteness of every array,
    the shape of every array against the others.

    Raises:
      errors.DataError naming the file and what is wrong with it.
    """
    kind, root, info = store.load(path)
    try:
      return Estimator(Kind(kind), root, info)
    except ValueError:
      raise errors.DataError(f"estimator {path}: method {kind!r} is not one this testbench "
                             f"knows") from None


def split_validation(n: int, fraction: float, seed: int, block: Optional[int] = None
                     ) -> tuple[np.ndarray, np.ndarray]:
  """Random (train, validation) indices from one integer seed.

  block=None draws single samples (MATLAB `dividerand`, the paper's): at 1 kHz every
  validation sample then sits beside training samples, and early stopping rarely fires.
  With `block` (samples), whole contiguous blocks of that length are held out instead.
  """
  if not 0 < fraction < 1:
    raise errors.SettingError(f"validation fraction {fraction!r} is out of range: allowed (0, 1)")
  rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
  if block is None:
    idx = rng.permutation(n)
    n_val = max(1, int(round(fraction * n)))
    return np.sort(idx[n_val:]), np.sort(idx[:n_val])
  if not 1 <= block <= n // 2:
    raise errors.SettingError(f"validation block {block!r} is out of range: allowed 1 to "
                              f"{n // 2} samples (two blocks at least)")
  starts = np.arange(0, n, block)
  n_val = max(1, int(round(fraction * len(starts))))
  held = np.zeros(n, bool)
  for b in rng.permutation(len(starts))[:n_val]:
    held[starts[b]:starts[b] + block] = True
  return np.flatnonzero(~held), np.flatnonzero(held)


def fit(kind: Kind, counts: np.ndarray, forces: np.ndarray, *,
        linear_fit: Optional[linear.LinearFit] = None, config: mlp.LMConfig = mlp.LMConfig(),
        val_fraction: float = 0.15, seed: int = 0, progress=None,
        degree: int = 3, snapshots: tuple[int, ...] = (),
        val_block: Optional[int] = None, ensemble: int = 1,
        inputs: Optional[Sequence[str]] = None, outputs: Optional[Sequence[str]] = None,
        input_units: Optional[Sequence[str]] = None,
        output_units: Optional[Sequence[str]] = None,
        groups: Optional[splits.Groups] = None, folds: int = 0,
        cross: bool = False, ridge: Optional[float] = None,
        widths: Sequence[int] = (), net_inputs: Optional[int] = None) -> Estimator:
  """Fits an estimator of the given kind.

  Args:
    kind: which estimator.
    counts, forces: (N, C) counts and (N, A) forces of the training data.
    linear_fit: for LSANN, the LS stage fitted beforehand (the paper fits it on the Z/X/Y
      strokes, the network on other paths); fitted on (counts, forces) when None.
    config: network training settings.  val_fraction: share held out for validation stops
      and for the residual spread of `Info` (LS and POLY are then fitted again on all).
    seed: integer for the validation split and the network's start point.
    degree: the polynomial degree of POLY (the shell paper's cubic: 3).
    snapshots: epoch caps to keep the best net at (`at_epoch_cap`).
    val_block: hold out contiguous blocks of this many samples for validation instead of
      single samples (`split_validation`); ignored when `groups` is given.
    ensemble: networks trained from this many seeds (spawned from `seed`); the estimator
      predicts their mean and `predict(return_std=True)` their spread.
    inputs, outputs, input_units, output_units: names and units kept in `Info` (default
      in0.., out0.., "counts", "N").
    groups: the samples' groups (`calibrate.splits`): validation then holds out whole groups
      (recordings or time blocks), never single samples between training ones.
    cross: POLY as a total-degree polynomial with cross terms, ridge-regularised and
      continued linearly beyond its training box (`calibrate.poly`); False: the shell
      paper's powers of each channel alone (`linear.fit_linear`).
    ridge: with `cross`, the ridge weight per training sample; None: chosen with the degree
      (1..`degree`) by grouped cross-validation over `folds` when given, else 0.
    widths: for LSANN and NN with `folds`: hidden widths to try (e.g. 5..64); the one with
      the lowest held-out error (summed over outputs, each relative to its spread) is kept,
      in place of `config.hidden`.
    net_inputs: for LSANN and NN, the network reads only the first this many input columns
      (None: all); the LS stage reads all.
    folds: with `groups`, grouped K-fold cross-validation of the whole fit (K more fits):
      its held-out residuals size the estimator's interval (`Info.half_width`) and its
      RMSE per output is kept; an LSANN output whose network does not beat its LS stage
      there keeps the LS stage alone (said in `Info.validation["ls_only"]`). 0: none.
  """
  kind = Kind(kind)
  if kind is Kind.AUTO:
    raise errors.SettingError("method AUTO chooses among the others on held-out groups: call "
                              "fit_auto(counts, forces, groups, folds)")
  if kind is Kind.GRU:
    raise errors.SettingError("method GRU reads recordings in time order: call fit_temporal("
                              "'GRU', counts, forces, dt, segments=...)")
  counts, forces = linear.check_pair(counts, forces)
  if not (isinstance(ensemble, (int, np.integer)) and 1 <= ensemble <= 100):
    raise errors.SettingError(f"ensemble={ensemble!r} is out of range: allowed integers 1..100")
  if ensemble > 1 and kind in (Kind.LS, Kind.POLY):
    raise errors.SettingError(f"ensemble={ensemble}: {kind.value} has no random start, so its "
                              f"seeds would agree; an ensemble is for LSANN and NN")
  if net_inputs is not None and not (isinstance(net_inputs, (int, np.integer))
                                     and 1 <= net_inputs <= counts.shape[1]):
    raise errors.SettingError(f"net_inputs={net_inputs!r} is out of range: allowed integers "
                              f"1..{counts.shape[1]} (the input columns)")
  if not (isinstance(seed, (int, np.integer)) and 0 <= seed < 2 ** 63):
    raise errors.SettingError(f"seed={seed!r} is out of range: allowed integers >= 0")
  if kind is Kind.POLY and not (isinstance(degree, (int, np.integer)) and 1 <= degree <= 5):
    raise errors.SettingError(f"degree={degree!r} is out of range: allowed integers 1..5")
  if folds and groups is None:
    raise errors.SettingError("folds need groups (calibrate.splits.groups): cross-validation "
                              "over single samples would flatter every method")
  if groups is not None and len(groups.labels) != len(counts):
    raise errors.SettingError(f"groups: {len(groups.labels)} labels for {len(counts)} samples")
  c, a = counts.shape[1], forces.shape[1]
  names = {"inputs": (inputs, [f"in{i}" for i in range(c)], c),
           "outputs": (outputs, [f"out{i}" for i in range(a)], a),
           "input_units": (input_units, ["counts"] * c, c),
           "output_units": (output_units, ["N"] * a, a)}
  given = {}
  for key, (value, default, n) in names.items():
    value = list(default if value is None else value)
    if len(value) != n:
      raise errors.SettingError(f"{key}: {len(value)} names for {n} columns")
    given[key] = tuple(str(v) for v in value)
  settings = {"method": kind.value, "val_fraction": val_fraction, "seed": seed,
              "val_block": None if groups is not None else val_block,
              # ADC counts or not: the C export takes uint16_t counts only if they were
              "integer_inputs": bool(np.all((counts >= 0) & (counts <= 65535)
                                            & (counts == np.round(counts))))}
  if groups is not None:
    settings.update(split=groups.how, groups=groups.count, block=groups.block)
  if kind is Kind.POLY and cross:
    if ridge is None and folds:
      degree, lam, table = poly_lib.choose(counts, forces, splits.folds(groups, folds, seed),
                                           tuple(range(1, degree + 1)))
      ridge = lam / len(counts)
      settings["poly_cv_mse"] = table
    ridge = 0.0 if ridge is None else float(ridge)
    settings.update(cross=True, ridge_per_sample=ridge)
  if kind is Kind.POLY:
    settings["degree"] = degree
  if kind in (Kind.LSANN, Kind.NN):
    settings.update(config=dataclasses.asdict(config), ensemble=ensemble)

  def split(n_or_groups, member_seed):
    if isinstance(n_or_groups, splits.Groups):
      return splits.holdout(n_or_groups, val_fraction, member_seed)
    return split_validation(n_or_groups, val_fraction, member_seed, val_block)

  def one_fit(x, y, where, lin_given, fold_progress, config=config):
    """(estimator without info, held-out residual sd) fitted on x, y."""
    if kind is Kind.POLY and cross:
      tr, va = split(where, seed)
      held = poly_lib.fit(x[tr], y[tr], degree, ridge * len(tr))
      sd = np.std(y[va] - held.predict(x[va]), axis=0)
      return [Estimator(kind, poly_lib.fit(x, y, degree, ridge * len(x)))], [sd]
    if kind in (Kind.LS, Kind.POLY):
      d = degree if kind is Kind.POLY else 1
      tr, va = split(where, seed)
      held = linear.fit_linear(x[tr], y[tr], degree=d)
      sd = np.std(y[va] - held.predict(x[va]), axis=0)
      return [Estimator(kind, linear.fit_linear(x, y, degree=d))], [sd]
    lin = None
    targets = y
    if kind is Kind.LSANN:
      lin = lin_given or linear.fit_linear(x, y)
      targets = y - lin.predict(x)
    seeds = [seed] if ensemble == 1 else [
        int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(ensemble)]
    members, sds = [], []
    xn = x if net_inputs is None else x[:, :net_inputs]
    for member_seed in seeds:
      tr, va = split(where, member_seed)
      res = mlp.train(xn[tr], targets[tr], xn[va], targets[va], config, member_seed,
                      fold_progress, snapshots=snapshots)
      sds.append(np.std(targets[va] - res.net.predict(xn[va]), axis=0))
      members.append(Estimator(kind, res.net if lin is None else compose.Residual(lin, res.net),
                               training=res))
    return members, sds

  if kind in (Kind.LSANN, Kind.NN):
    _warn_few_states(counts.shape[1], forces, config)
  cv = None
  if widths and folds and kind in (Kind.LSANN, Kind.NN):
    config, cv, table = _choose_width(kind, counts, forces, groups, folds, seed, one_fit,
                                      config, widths)
    settings.update(config=dataclasses.asdict(config), width_cv=table)
  where = groups if groups is not None else len(counts)
  members, sds = one_fit(counts, forces, where, linear_fit, progress, config)
  base = dict(input_lo=counts.min(axis=0), input_hi=counts.max(axis=0),
              output_lo=forces.min(axis=0), output_hi=forces.max(axis=0), samples=len(counts),
              data_sha256=data_digest(counts, forces), settings=settings, **given)
  extra = {}
  if folds:
    residual, ls_only, stats = cv or _cross_validate(kind, counts, forces, groups, folds,
                                                     seed, one_fit, config)
    if ls_only.any():
      members = [_ls_only(m, ls_only) for m in members]
    extra = held_out(residual, groups, {**stats, "ls_only": [
        given["outputs"][j] for j in np.flatnonzero(ls_only)]})
  out = [dataclasses.replace(m, info=Info(residual_sd=sd, **base, **extra))
         for m, sd in zip(members, sds)]
  return out[0] if len(out) == 1 else combine(out)


def _subset(g: splits.Groups, idx: np.ndarray) -> splits.Groups:
  """The groups of the samples `idx`, relabelled 0..G'-1."""
  _, labels = np.unique(g.labels[idx], return_inverse=True)
  return splits.Groups(labels.astype(int), g.how, g.block)


def _warn_few_states(inputs: int, forces: np.ndarray, config: mlp.LMConfig) -> None:
  """Warns when the targets take few distinct values (load states, told apart at 1 % of
  each output's range) for the network's weights: it will interpolate between them."""
  span = np.ptp(forces, axis=0)
  states = len(np.unique(np.round(forces / np.where(span > 0, span, 1.0) * 100), axis=0))
  weights = config.hidden * (inputs + 1) + forces.shape[1] * (config.hidden + 1)
  if states < 2 * weights:
    warnings.warn(f"the targets take only {states} distinct load states (told apart at 1 % of "
                  f"each output's range) for a network of at least {weights} weights: it "
                  f"will interpolate between them; average several networks (--ensemble "
                  f"5), and compare LS and POLY (--method auto)", FewStatesWarning,
                  stacklevel=3)


class FewStatesWarning(UserWarning):
  """Training targets with few distinct values for the network's size."""


def _choose_width(kind, counts, forces, groups, folds, seed, one_fit, config, widths):
  """(config with the width of lowest held-out error, that width's cross-validation, table
  {width: held-out error}); the error sums each output's held-out MSE over its variance."""
  spread = np.var(forces, axis=0)
  spread = np.where(spread > 0, spread, 1.0)
  best, table = None, {}
  for w in widths:
    cfg = dataclasses.replace(config, hidden=int(w))
    cfg.validate()
    cv = _cross_validate(kind, counts, forces, groups, folds, seed, one_fit, cfg)
    score = float(np.sum(np.square(cv[2]["cv_rmse"]) / spread))
    table[str(int(w))] = score
    if best is None or score < best[0]:
      best = (score, cfg, cv)
  return best[1], best[2], table


def _cross_validate(kind, counts, forces, groups, k, seed, one_fit, config):
  """Grouped K-fold cross-validation of `one_fit` with `config`: (held-out residuals (N, A)
  of the estimator as kept, per-output mask of LSANN outputs whose network lost to its LS
  stage, statistics). The LS stage given to LSANN is refitted per fold (it saw every
  sample)."""
  residual = np.zeros_like(forces)
  ls_residual = np.zeros_like(forces)
  folds = splits.folds(groups, k, seed)
  for tr, va in folds:
    fitted, _ = one_fit(counts[tr], forces[tr], _subset(groups, tr), None, None, config)
    est = fitted[0] if len(fitted) == 1 else Estimator(
        kind, compose.Mean(tuple(f.root for f in fitted)))
    residual[va] = forces[va] - est.predict(counts[va])
    if kind is Kind.LSANN:
      ls_residual[va] = forces[va] - fitted[0].linear.predict(counts[va])
  rmse = np.sqrt(np.mean(residual ** 2, axis=0))
  ls_only = np.zeros(forces.shape[1], bool)
  stats = {"split": groups.how, "groups": groups.count, "block": groups.block,
           "folds": len(folds), "cv_rmse": rmse.tolist(),
           "cv_fold_rmse": [np.sqrt(np.mean(residual[va] ** 2, axis=0)).tolist()
                            for _, va in folds]}
  if kind is Kind.LSANN:
    ls_rmse = np.sqrt(np.mean(ls_residual ** 2, axis=0))
    ls_only = ls_rmse <= rmse
    residual[:, ls_only] = ls_residual[:, ls_only]
    stats["cv_fold_rmse"] = [np.sqrt(np.mean(residual[va] ** 2, axis=0)).tolist()
                             for _, va in folds]
    stats.update(cv_rmse_ls_stage=ls_rmse.tolist(),
                 cv_rmse=np.where(ls_only, ls_rmse, rmse).tolist())
  return residual, ls_only, stats


def _ls_only(est: Estimator, outputs: np.ndarray) -> Estimator:
  """LSANN with its network's contribution removed on `outputs` (bool (A,)): their output
  scaling maps to exactly 0, so every consumer (predict, the C export) sees the LS stage."""
  return dataclasses.replace(est, root=compose.Residual(
      est.root.base, est.root.residual.without_outputs(outputs)))


CANDIDATES = (Kind.LS, Kind.POLY, Kind.LSANN, Kind.NN)
TIE = 0.01  # relative held-out RMSE within which `fit_auto` prefers the simpler candidate


def fit_auto(counts: np.ndarray, forces: np.ndarray, groups: splits.Groups, folds: int = 5,
             candidates: Sequence[Kind] = CANDIDATES, progress=None, **kwargs
             ) -> tuple[Estimator, dict]:
  """Every candidate fitted and cross-validated on the same grouped folds (POLY with cross
  terms); for each output, the simplest (in the order of `candidates`) whose held-out RMSE
  is within one standard error over the folds (or `TIE`) of the lowest.

  Returns (the AUTO estimator, {method: {"cv_rmse": [per output], "seconds": fit time,
  "estimator": the candidate fitted}}). `kwargs` go to every `fit` (config, seed, names...;
  `ensemble` to the networks only)."""
  import time
  if groups is None or folds < 2:
    raise errors.SettingError("method auto chooses on held-out groups: it needs groups and "
                              "folds >= 2")
  fitted, table = [], {}
  for kind in candidates:
    kind = Kind(kind)
    t0 = time.perf_counter()
    net = {} if kind in (Kind.LSANN, Kind.NN) else {"ensemble": 1}  # LS, POLY: no seeds
    est = fit(kind, counts, forces, groups=groups, folds=folds, cross=kind is Kind.POLY,
              progress=progress, **{**kwargs, **net})
    table[kind.value] = {"cv_rmse": est.info.validation["cv_rmse"],
                         "seconds": time.perf_counter() - t0, "estimator": est}
    fitted.append(est)
  rmse = np.array([table[e.kind.value]["cv_rmse"] for e in fitted])  # (K, A)
  # the one-standard-error rule (Hastie, Tibshirani & Friedman, Elements of Statistical
  # Learning, Sec. 7.10): the simplest candidate whose held-out RMSE is within one standard
  # error (over the folds) of the lowest, and within `TIE` in any case: a smaller difference
  # is not one the held-out groups can tell, and a simpler model extrapolates tamer
  folds_rmse = np.array([e.info.validation["cv_fold_rmse"] for e in fitted])  # (K, F, A)
  lowest = np.argmin(rmse, axis=0)
  cols = np.arange(forces.shape[1])
  se = folds_rmse[lowest, :, cols].std(axis=1, ddof=1) / np.sqrt(folds_rmse.shape[1])
  near = rmse <= rmse[lowest, cols] + np.maximum(se, TIE * rmse[lowest, cols]) \
      + 1e-12 * np.abs(forces).max(axis=0)
  best = np.argmax(near, axis=0)
  # LS stays a part even where no output keeps it: its plane continues the networks beyond
  # the training box (`Estimator._guarded`)
  ls = [k for k, e in enumerate(fitted) if e.kind is Kind.LS]
  used = sorted(set(best.tolist()) | set(ls))
  parts = tuple(fitted[k] for k in used)
  pick = tuple(used.index(k) for k in best)
  infos = [fitted[k].info for k in best]
  first = parts[0].info
  info = dataclasses.replace(
      first, residual_sd=np.array([i.residual_sd[j] for j, i in zip(cols, infos)]),
      interval_abs=np.column_stack([i.interval_abs[:, j] for j, i in zip(cols, infos)]),
      interval_offsets=None if infos[0].interval_offsets is None else np.column_stack(
          [i.interval_offsets[:, j] for j, i in zip(cols, infos)]),
      settings={"method": Kind.AUTO.value, "candidates": [e.kind.value for e in fitted],
                "seed": first.settings.get("seed"),
                "integer_inputs": first.settings.get("integer_inputs")},
      validation={**{k: v for k, v in first.validation.items()
                     if k in ("split", "groups", "block", "folds")},
                  "cv_rmse": rmse[best, cols].tolist(),
                  "chosen": [fitted[k].kind.value for k in best],
                  "candidates": {k: v["cv_rmse"] for k, v in table.items()},
                  "ls_only": [n for j, n in enumerate(first.outputs)
                              if n in infos[j].validation.get("ls_only", [])]})
  root = compose.PerOutput(tuple(p.root for p in parts), pick, info.input_lo, info.input_hi)
  return Estimator(Kind.AUTO, root, info), table


def combine(members: Sequence[Estimator]) -> Estimator:
  """Fitted estimators of one kind (networks from several seeds) as one ensemble: it predicts
  their mean, and its residual spread is the root mean square of theirs. Each member needs
  its `info` (every `fit` gives one); the ensemble's is the first member's otherwise."""
  members = tuple(members)
  first = members[0].info
  spread = np.sqrt(np.mean([m.info.residual_sd ** 2 for m in members], axis=0))
  info = dataclasses.replace(first, residual_sd=spread,
                             settings={**first.settings, "ensemble": len(members)})
  return Estimator(members[0].kind, compose.Mean(tuple(m.root for m in members)), info,
                   trainings=tuple(m.training for m in members))


def at_epoch_cap(est: Estimator, cap: int) -> Estimator:
  """The estimator that training `est` with `epochs=cap` would have returned (its fit must
  have been asked for that cap in `snapshots`)."""
  net, _ = est.training.snapshots[cap]
  return dataclasses.replace(est, root=_with_net(est.root, net))


def _with_net(part: Part, net: mlp.MLP) -> Part:
  """`part` with its network replaced by `net`."""
  if isinstance(part, compose.Chain):
    return compose.Chain(part.front, _with_net(part.stage, net))
  if isinstance(part, compose.Residual):
    return compose.Residual(part.base, net)
  return net


# time constants the history features choose from, s: from the footpad's fast relaxation
# (Prony tau1 0.1-2 s) to its slow one and the dies' drift (tens of seconds to minutes)
TAU_CANDIDATES = (0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)


def fit_temporal(kind: Kind, counts: np.ndarray, forces: np.ndarray, dt: float, *,
                 segments: Optional[np.ndarray] = None, select: Optional[np.ndarray] = None,
                 contact: Optional[np.ndarray] = None, sessions: Optional[np.ndarray] = None,
                 taus: Optional[Sequence[float]] = None,
                 candidates: Sequence[float] = TAU_CANDIDATES, max_taus: int = 3,
                 differences: bool = True, tare: Optional[temporal.Tare] = None,
                 folds: int = 5, seed: int = 0, inputs: Optional[Sequence[str]] = None,
                 memory: Optional[temporal.Memory] = None, network_history: bool = False,
                 gru: recurrent.GRUConfig = recurrent.GRUConfig(), **kwargs) -> Estimator:
  """Fits an estimator of `kind` behind a temporal front end (`calibrate.temporal.Memory`).

  Args:
    kind: the stages (LS, POLY, LSANN, NN, GRU) fitted on the front end's features. GRU is
      LS on the features plus a recurrent network (`calibrate.recurrent`) that reads the
      tared counts in time and is fitted to LS's residual on the selected samples.
    counts, forces: (N, C) counts and (N, A) forces of whole recordings in time order: the
      filters and tares run over every sample, the fit takes `select`.
    dt: s between samples.
    segments: (N,) label of each sample's recording; filters and tares start afresh where it
      changes, and the time constants are chosen holding out whole segments.
    select: (N,) bool, the samples to fit on (None: all), e.g. the paper's on-path samples.
    contact: (N,) bool contact flag for the tare (None: a linear map of the counts decides).
    sessions: (N,) labels of the runs of segments read without a reset, through which the
      tare's offset carries (None: each segment its own session).
    taus: the high-pass features' time constants, s; None: chosen from `candidates` by
      grouped cross-validation of LS over `folds` folds of the segments (greedy, up to
      `max_taus`, each kept only if it lowers the held-out error by 1 % or more), and the
      first differences with them, kept by the same rule.
    differences: with `taus` given, add each channel's first difference; with taus None,
      whether the differences may be chosen.
    tare: drift tracking's rule (None: no tracking).
    folds: grouped cross-validation folds, for the time constants (over the segments) and,
      with `groups` in kwargs, for the static stages' held-out error and interval (`fit`).
    seed: for the folds and the static stages.
    inputs: the channels' names (and `input_units` in kwargs their units, default counts).
    memory: a front end fitted before (e.g. the LS stage's, for LSANN's network on other
      paths): used as it is, and `taus`, `differences` and `tare` are not read.
    network_history: LSANN's and NN's network reads the history features too; by default it
      reads the tared counts only, and the history features reach the LS stage alone. A
      network given the history of its training paths fits it, and other paths' histories
      differ (measured, footpad with drift alone, a 10 s high-pass chosen: LSANN X NRMSE 4.5
      % static, 9.9 % with the network reading it).
    gru: the recurrent network's settings (GRU only).
    kwargs: passed to `fit` for the static stages (e.g. `linear_fit` fitted on the same
      front end's features, `config`, `groups` of the selected samples).
  Returns:
    The estimator: `predict(counts, segments=..., contact=...)` runs the front end.
  """
  kind = Kind(kind)
  counts, forces = linear.check_pair(counts, forces)
  n, c = counts.shape
  segments = np.zeros(n, int) if segments is None else np.asarray(segments)
  select = np.ones(n, bool) if select is None else np.asarray(select, bool)
  if segments.shape != (n,) or select.shape != (n,):
    raise errors.DataError(f"segments and select need one value per sample ({n})")
  names = tuple(inputs) if inputs is not None else tuple(f"in{k}" for k in range(c))
  if memory is not None:
    if memory.channels != c:
      raise errors.DataError(f"the front end reads {memory.channels} channels, the counts "
                             f"have {c}")
    return _fit_behind(memory, kind, counts, forces, segments, select, (contact, sessions),
                       names, seed, network_history, folds, kwargs, gru)
  detector = reference = None
  if tare is not None:
    tare.validate()
    if contact is None and not 0 <= tare.axis < forces.shape[1]:
      raise errors.SettingError(f"the tare reads the normal force as target {tare.axis + 1} "
                                f"of the LS map, and there are {forces.shape[1]} targets: "
                                f"give the normal force as the third, or a contact flag")
    if contact is None:
      detector = linear.fit_linear(counts[select], forces[select])
      probe = temporal.Memory(c, dt, tare=tare, detector=detector, reference=np.zeros(c))
      # with no offset yet, the first unloaded interval of each recording marks samples free
      free = probe.offsets(counts, segments, sessions=sessions)[1]
    else:
      free = ~np.asarray(contact, bool)
    reference = temporal.reference_counts(counts, free)
  base = temporal.Memory(c, dt, (), differences, tare, detector, reference)
  base.validate()
  if taus is None:
    taus, differences = _choose_taus(base, counts, forces, segments, select,
                                     (contact, sessions), tuple(candidates), max_taus, folds,
                                     seed)
  memory = dataclasses.replace(base, taus=tuple(float(t) for t in taus),
                               differences=differences)
  memory.validate()
  return _fit_behind(memory, kind, counts, forces, segments, select, (contact, sessions),
                     names, seed, network_history, folds, kwargs, gru)


def _fit_behind(memory, kind, counts, forces, segments, select, stream, names, seed,
                network_history, folds, kwargs, gru=recurrent.GRUConfig()) -> Estimator:
  """The static stages of `kind` fitted on `memory`'s features of the selected samples
  (cross-validated over `folds` of the `groups` in kwargs, when there are any)."""
  c = counts.shape[1]
  units = tuple(kwargs.pop("input_units", None) or ("counts",) * c)
  if kind is Kind.GRU:
    est = _fit_gru(memory, memory.features(counts, segments, *stream), forces, segments,
                   select, memory.names(names), seed, folds, gru, kwargs)
  else:
    x = memory.features(counts, segments, *stream)[select]
    est = fit(kind, x, forces[select], seed=seed, inputs=memory.names(names),
              net_inputs=None if network_history else c,
              folds=folds if kwargs.get("groups") is not None else 0, **kwargs)
  raw = counts[select]
  info = dataclasses.replace(
      est.info, inputs=names, input_units=units, input_lo=raw.min(axis=0),
      input_hi=raw.max(axis=0), data_sha256=data_digest(raw, forces[select]),
      settings={**est.info.settings, "memory": memory.settings(),
                "integer_inputs": bool(np.all((raw >= 0) & (raw <= 65535)
                                              & (raw == np.round(raw))))})
  return dataclasses.replace(est, root=compose.Chain(memory, est.root), info=info)


def _fit_gru(memory, x, forces, segments, select, names, seed, folds, config, kwargs
             ) -> Estimator:
  """GRU on the features x (N, width) of whole recordings: the LS stage on the selected
  samples (or `linear_fit` in kwargs, fitted before), the recurrent network on its residual
  over the recordings that hold selected samples; with `groups` in kwargs and `folds`, the whole fit cross-validated over them (the
  held-out samples' targets never reach the loss; their inputs pass through the state, as at
  use). `Info` (in feature space) as `fit` gives it, the residual spread from the network's
  held-out recordings."""
  if kwargs.pop("ensemble", 1) != 1:
    raise errors.SettingError("an ensemble of recurrent networks is not built: ensemble=1 "
                              "with method GRU")
  progress = kwargs.pop("progress", None)
  groups = kwargs.pop("groups", None)
  given = kwargs.pop("linear_fit", None)
  for unread in ("config", "widths", "degree", "cross", "ridge", "snapshots", "val_block",
                 "net_inputs"):
    kwargs.pop(unread, None)
  config.validate()
  c, n = memory.channels, len(x)
  runs = temporal._runs(segments, n)
  first = recurrent.starts(segments, n)

  def one(rows, bar, lin=None):
    lin = lin or linear.fit_linear(x[rows], forces[rows])
    have = [(lo, hi) for lo, hi in runs if rows[lo:hi].any()]
    net, res = recurrent.train(x[:, :c], forces - lin.predict(x), have, rows, config, seed,
                               bar)
    return lin, net, res

  lin, net, res = one(select, progress, given)
  ls = fit(Kind.LS, x[select], forces[select], seed=seed, inputs=names, **kwargs)
  pred = lin.predict(x) + net.predict(x[:, :c], first)
  held = np.zeros(n, bool)
  for lo, hi in res.held_out:
    held[lo:hi] = True
  held &= select
  sd = np.std(forces[held] - pred[held], axis=0)
  settings = {**ls.info.settings, "method": Kind.GRU.value, "seed": seed,
              "gru": dataclasses.asdict(config)}
  info = dataclasses.replace(ls.info, residual_sd=sd, settings=settings)
  if folds and groups is not None and groups.count >= 2:
    rows_of = np.flatnonzero(select)
    residual = np.zeros((len(rows_of), forces.shape[1]))
    parts = splits.folds(groups, folds, seed)
    for tr, va in parts:
      rows = np.zeros(n, bool)
      rows[rows_of[tr]] = True
      f_lin, f_net, _ = one(rows, None)
      out = f_lin.predict(x) + f_net.predict(x[:, :c], first)
      residual[va] = forces[rows_of[va]] - out[rows_of[va]]
    stats = {"split": groups.how, "groups": groups.count, "block": groups.block,
             "folds": len(parts), "cv_rmse": np.sqrt(np.mean(residual ** 2, axis=0)).tolist(),
             "cv_fold_rmse": [np.sqrt(np.mean(residual[va] ** 2, axis=0)).tolist()
                              for _, va in parts], "ls_only": []}
    info = dataclasses.replace(info, **held_out(residual, groups, stats))
    info = dataclasses.replace(info, settings={**info.settings, "split": groups.how,
                                               "groups": groups.count})
  return Estimator(Kind.GRU, compose.Residual(lin, net), info, training=res)


def _choose_taus(base, counts, forces, segments, select, stream, candidates, max_taus,
                 folds, seed) -> tuple[tuple[float, ...], bool]:
  """The time constants, greedily, that lower LS's error on held-out segments, and whether
  the first differences do (when `base.differences` allows them)."""
  labels = segments[select]
  if folds < 2:
    raise errors.SettingError(f"choosing the time constants holds out recordings: folds="
                              f"{folds} is out of range, give 2 or more (or the time "
                              f"constants themselves)")
  if len(np.unique(labels)) < 2:
    raise errors.SettingError("choosing the time constants holds out whole recordings: give "
                              "two segments or more, or the time constants themselves")
  groups = splits.groups(int(select.sum()), "recordings", labels)
  parts = splits.folds(groups, min(folds, groups.count), seed)
  every = dataclasses.replace(base, taus=candidates)  # differences last, if allowed
  feats = every.features(counts, segments, *stream)[select]
  y = forces[select]
  spread = np.maximum(y.std(axis=0), 1e-12)
  ch = base.channels
  column = {None: list(range(ch))}
  for i, tau in enumerate(candidates):
    column[tau] = list(range(ch * (1 + i), ch * (2 + i)))
  if base.differences:
    column["d"] = list(range(ch * (1 + len(candidates)), ch * (2 + len(candidates))))

  def held_out(keys) -> float:
    cols = sum((column[k] for k in keys), [])
    err = 0.0
    for train, test in parts:
      lin = linear.fit_linear(feats[train][:, cols], y[train])
      err += np.sum(((lin.predict(feats[test][:, cols]) - y[test]) / spread) ** 2)
    return float(np.sqrt(err / len(y)))

  best = held_out([None])
  kept: list = []
  options = list(candidates) + (["d"] if base.differences else [])
  while True:
    room = sum(k != "d" for k in kept) < max_taus
    trials = {t: held_out([None] + kept + [t]) for t in options
              if t not in kept and (t == "d" or room)}
    if not trials:
      break
    t, score = min(trials.items(), key=lambda kv: kv[1])
    if score > 0.99 * best or best < 1e-9:  # below 1e-9 of the spread nothing is left
      break
    kept.append(t)
    best = score
  return tuple(sorted(k for k in kept if k != "d")), "d" in kept
