"""Fits behind a temporal front end: `Chain(Memory, stage)`.

The front end (`calibrate.parts.memory.Memory`) is built first: its drift tare's detector
and no-load reference from the counts, then its time constants chosen greedily by grouped
cross-validation of LS over whole segments (`calibrate.select`). The stages (`methods.fit`,
or LS plus a recurrent network for GRU) are fitted on its features of the selected samples,
and `Info` describes the raw counts the chain reads.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from calibrate import compose, methods, select, splits
from calibrate.fitted import Estimator, Kind
from calibrate.info import data_digest, held_out, integer_counts, reference

from calibrate.parts import gru as recurrent
from calibrate.parts import linear
from calibrate.parts import memory as temporal
from calibrate.parts.base import Stream
from util import errors

# time constants the history features choose from, s: from the footpad's fast relaxation
# (Prony tau1 0.1-2 s) to its slow one and the dies' drift (tens of seconds to minutes)
TAU_CANDIDATES = (0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)


def fit_temporal(kind, counts, forces, dt, *, segments=None, select=None, contact=None,
                 sessions=None, taus=None, candidates=TAU_CANDIDATES, max_taus=3,
                 differences=True, tare=None, folds=5, seed=0, inputs=None, memory=None,
                 network_history=False, gru=recurrent.GRUConfig(), **kwargs):
  """`calibrate.estimators.fit_temporal` (its docstring says what each option does)."""
  counts, forces = linear.check_pair(counts, forces)
  n, c = counts.shape
  segments = np.zeros(n, int) if segments is None else np.asarray(segments)
  select = np.ones(n, bool) if select is None else np.asarray(select, bool)
  if segments.shape != (n,) or select.shape != (n,):
    raise errors.DataError(f"segments and select need one value per sample ({n})")
  names = tuple(inputs) if inputs is not None else tuple(f"in{k}" for k in range(c))
  stream = (contact, sessions)
  gain = None  # LS's held-out error without and with the history chosen here
  if memory is not None:
    if memory.channels != c:
      raise errors.DataError(f"the front end reads {memory.channels} channels, the counts "
                             f"have {c}")
  else:
    memory, gain = build_memory(counts, forces, dt, segments, select, stream, tare,
                                differences, taus, candidates, max_taus, folds, seed)
  est = fit_behind(memory, kind, counts, forces, segments, select, stream, names, seed,
                   network_history, folds, kwargs, gru)
  if gain is not None:
    est = dataclasses.replace(est, info=dataclasses.replace(
        est.info, settings={**est.info.settings, "history_gain": gain}))
  return est


def fit_auto_temporal(counts, forces, dt, groups, folds=5, *, segments=None, contact=None,
                      taus=None, candidates=TAU_CANDIDATES, max_taus=3, differences=True,
                      tare=None, seed=0, inputs=None, input_units=None, static=None,
                      **kwargs):
  """`fit_auto` with memory among its candidates: a front end (its time constants chosen on
  held-out recordings as `fit_temporal` chooses them), then every static candidate on its
  counts and `methods.MEMORY_CANDIDATES` on its features, each output kept from the
  simplest within a standard error of the best. The features run per recording (no filter
  crosses a boundary, a held-out recording's first samples read unwarmed filters as at use),
  and the memory candidates come last: kept only where their held-out gain over every
  static candidate exceeds a standard error (`static`: their names, default
  `methods.AUTO_CANDIDATES`). Returns (estimator, table) as `fit_auto`; the estimator holds
  the front end only where an output kept a memory candidate."""
  counts, forces = linear.check_pair(counts, forces)
  n, c = counts.shape
  segments = np.zeros(n, int) if segments is None else np.asarray(segments)
  names = tuple(inputs) if inputs is not None else tuple(f"in{k}" for k in range(c))
  memory, _ = build_memory(counts, forces, dt, segments, np.ones(n, bool), (contact, None),
                           tare, differences, taus, candidates, max_taus, folds, seed)
  feats = memory.features(counts, segments, contact)
  est, table = methods.fit_auto(
      feats, forces, groups, folds,
      tuple(static or methods.AUTO_CANDIDATES) + methods.MEMORY_CANDIDATES,
      static_columns=c, seed=seed, inputs=memory.names(names), **kwargs)
  kept = set(est.info.validation["chosen"]) & set(methods.MEMORY_CANDIDATES)
  info = raw_info(est.info, names, input_units, counts, forces,
                  memory.settings() if kept else None)
  if not kept and memory.tare is None:  # the static parts read the counts themselves
    return dataclasses.replace(est, info=info), table
  return dataclasses.replace(est, root=compose.Chain(memory, est.root), info=info), table


def build_memory(counts, forces, dt, segments, select, stream, tare, differences, taus,
                 candidates, max_taus, folds, seed):
  """(the front end, LS's held-out error without and with its history or None): its tare
  (`front_end`), then the time constants given or chosen on held-out recordings
  (`choose_taus`)."""
  base = front_end(counts, forces, dt, segments, select, stream, tare, differences)
  gain = None
  if taus is None:
    taus, differences, gain = choose_taus(base, counts, forces, segments, select, stream,
                                          tuple(candidates), max_taus, folds, seed)
  memory = dataclasses.replace(base, taus=tuple(float(t) for t in taus),
                               differences=differences)
  memory.validate()
  return memory, gain


def raw_info(info, names, input_units, raw, forces, memory_settings):
  """`info` of a fit on a front end's features, made to describe the raw counts (N, C) it
  reads: their names, units, ranges and digest, and the front end's settings."""
  c = raw.shape[1]
  return dataclasses.replace(
      info, inputs=tuple(names), input_units=tuple(input_units or ("counts",) * c),
      input_lo=raw.min(axis=0), input_hi=raw.max(axis=0),
      # the rows the local scale measured to, as the raw counts predict reads them
      interval_reference=None if info.interval_reference is None else reference(raw),
      data_sha256=data_digest(raw, forces),
      settings={**info.settings, "memory": memory_settings,
                "integer_inputs": integer_counts(raw)})


def front_end(counts, forces, dt, segments, select, stream, tare, differences):
  """The front end without time constants: the tare's detector (LS on the selected samples,
  unless a contact flag says where the sensor is unloaded) and no-load reference."""
  c = counts.shape[1]
  contact, sessions = stream
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
  return base


def choose_taus(base, counts, forces, segments, chosen, stream, candidates, max_taus, folds,
                seed) -> tuple[tuple[float, ...], bool, dict]:
  """The time constants, greedily, that lower LS's error on held-out segments, whether the
  first differences do (when `base.differences` allows them), and LS's held-out RMSE (over
  each output's spread, root mean square over the outputs) without the history and with
  what was kept."""
  labels = segments[chosen]
  if folds < 2:
    raise errors.SettingError(f"choosing the time constants holds out recordings: folds="
                              f"{folds} is out of range, give 2 or more (or the time "
                              f"constants themselves)")
  if len(np.unique(labels)) < 2:
    raise errors.SettingError("choosing the time constants holds out whole recordings: give "
                              "two segments or more, or the time constants themselves")
  groups = splits.groups(int(chosen.sum()), "recordings", labels)
  parts = splits.folds(groups, min(folds, groups.count), seed)
  every = dataclasses.replace(base, taus=candidates)  # differences last, if allowed
  feats = every.features(counts, segments, *stream)[chosen]
  y = forces[chosen]
  spread = np.maximum(y.std(axis=0), 1e-12)
  ch = base.channels
  column = {None: list(range(ch))}
  for i, tau in enumerate(candidates):
    column[tau] = list(range(ch * (1 + i), ch * (2 + i)))
  column["d"] = list(range(ch * (1 + len(candidates)), ch * (2 + len(candidates))))

  @functools.lru_cache(maxsize=None)
  def scored(keys: tuple) -> float:
    cols = sum((column[k] for k in (None,) + keys), [])

    def fold(tr, va):
      return [linear.fit_linear(feats[tr][:, cols], y[tr]).predict(feats[va][:, cols])]
    err = select.fold_sums(select.held_out(fold, y, parts), parts, spread)[0]
    return float(np.sqrt(err / len(y)))

  def score(keys) -> float:  # greedy's trials, remembered: the gain below reads two again
    return scored(tuple(keys))

  def room(kept, t) -> bool:
    return t == "d" or sum(k != "d" for k in kept) < max_taus

  kept = select.greedy(score, list(candidates) + (["d"] if base.differences else []), room)
  gain = {"without": score([]), "with": score(kept)}
  return tuple(sorted(k for k in kept if k != "d")), "d" in kept, gain


def fit_behind(memory, kind, counts, forces, segments, chosen, stream, names, seed,
               network_history, folds, kwargs, gru=recurrent.GRUConfig()):
  """The stages of `kind` fitted on `memory`'s features of the selected samples
  (cross-validated over `folds` of the `groups` in kwargs, when there are any), behind it."""
  kind = Kind(kind)
  c = counts.shape[1]
  units = kwargs.pop("input_units", None)
  feats = memory.features(counts, segments, *stream)
  if kind is Kind.GRU:
    est = fit_gru(feats, forces, segments, chosen, memory.names(names), seed, folds, gru,
                  c, kwargs)
  else:
    est = methods.fit(kind, feats[chosen], forces[chosen], seed=seed,
                      inputs=memory.names(names), net_inputs=None if network_history else c,
                      folds=folds if kwargs.get("groups") is not None else 0, **kwargs)
  info = raw_info(est.info, names, units, counts[chosen], forces[chosen], memory.settings())
  return dataclasses.replace(est, root=compose.Chain(memory, est.root), info=info)


@dataclasses.dataclass(frozen=True)
class GRURecipe:
  """LS on the features x (N, width) of the chosen samples (or `given`), the recurrent
  network (reading the first `c` features, the tared counts) on its residual over the
  recordings that hold chosen samples."""
  config: recurrent.GRUConfig
  c: int
  seed: int

  def fit(self, x, forces, segments, rows, progress=None, given=None):
    lin = given or linear.fit_linear(x[rows], forces[rows])
    have = [(lo, hi) for lo, hi in temporal._runs(segments, len(x)) if rows[lo:hi].any()]
    net, res = recurrent.train(x[:, :self.c], forces - lin.predict(x), have, rows,
                               self.config, self.seed, progress)
    return compose.Residual(lin, net), res


def fit_gru(x, forces, segments, chosen, names, seed, folds, config, c, kwargs):
  """GRU on the features x of whole recordings; with `groups` in kwargs and `folds`, the
  whole fit cross-validated over them (the held-out samples' targets never reach the loss;
  their inputs pass through the state, as at use). `Info` (in feature space) as `fit` gives
  it, the residual spread from the network's held-out recordings."""
  if kwargs.pop("ensemble", 1) != 1:
    raise errors.SettingError("an ensemble of recurrent networks is not built: ensemble=1 "
                              "with method GRU")
  progress, groups = kwargs.pop("progress", None), kwargs.pop("groups", None)
  given = kwargs.pop("linear_fit", None)
  # what the LS stage's fit reads; the other methods' options (a network's config, the
  # poly's degree) are not GRU's
  kwargs = {k: v for k, v in kwargs.items()
            if k in ("val_fraction", "outputs", "output_units", "input_units")}
  config.validate()
  how = GRURecipe(config, c, seed)
  root, res = how.fit(x, forces, segments, chosen, progress, given)
  ls = methods.fit(Kind.LS, x[chosen], forces[chosen], seed=seed, inputs=names, **kwargs)
  held = np.zeros(len(x), bool)
  for lo, hi in res.held_out:
    held[lo:hi] = True
  held &= chosen
  pred = root.mean_spread(x, Stream(segments))[0]
  settings = {**ls.info.settings, "method": Kind.GRU.value, "seed": seed,
              "gru": dataclasses.asdict(config)}
  info = dataclasses.replace(ls.info, residual_sd=np.std(forces[held] - pred[held], axis=0),
                             settings=settings)
  if folds and groups is not None and groups.count >= 2:
    rows_of = np.flatnonzero(chosen)
    parts = splits.folds(groups, folds, seed)

    def fold(tr, va):
      rows = np.zeros(len(x), bool)
      rows[rows_of[tr]] = True
      return [how.fit(x, forces, segments, rows)[0].mean_spread(x, Stream(segments))[0]
              [rows_of[va]]]
    residual = select.held_out(fold, forces[rows_of], parts)[0]
    stats = {**select.stats(residual, parts, groups), "ls_only": []}
    info = dataclasses.replace(info, **held_out(residual, groups, stats))
    info = dataclasses.replace(info, settings={**info.settings, "split": groups.how,
                                               "groups": groups.count})
  return Estimator(Kind.GRU, root, info, training=res)
