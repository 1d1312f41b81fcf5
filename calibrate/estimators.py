"""Force estimators of the LSANN paper as plain data: fit, predict, save, load.

* LS: linear least squares from the six die counts (paper Sec. III-B).
* POLY: the cubic pseudoinverse (force-sensing-shell paper), same numerics.
* LSANN: LS, then the network fitted to the residual F - F_LS from the six counts (paper
  Sec. III-C: "the input is the array of voltage signals"; Eqn 8 sums the two).
* NN: the same network fitted to F from the six counts.
* GRU: LS, then a small recurrent network (`calibrate.parts.gru`) fitted to the residual from
  the counts' past: a temporal estimator, fitted by `fit_temporal` on whole recordings.
* LSGP: LS, then a Gaussian process (`calibrate.parts.gp`) fitted to the residual.
* AUTO: per output, the candidate with the lowest held-out error (`fit_auto`).

This module is the callers' face: the fits are `calibrate.methods` (recipes, one selection
loop in `calibrate.select`) and `calibrate.temporal_fit`; the fitted type is
`calibrate.fitted.Estimator`, a tree of parts (`calibrate.parts`, `calibrate.compose`).
"""

from __future__ import annotations

import dataclasses
from typing import Optional, Sequence

import numpy as np

from calibrate import compose, methods, splits, temporal_fit
from calibrate.fitted import (CANDIDATES, Estimator, Kind,  # noqa: F401 (callers' names)
                              OutOfRangeWarning)
from calibrate.info import INTERVAL_GRID, Info, data_digest  # noqa: F401
from calibrate.methods import FewStatesWarning  # noqa: F401
from calibrate.parts import gru as recurrent
from calibrate.parts import linear, mlp
from calibrate.parts import memory as temporal
from calibrate.parts.base import Part
from calibrate.select import TIE  # noqa: F401
from calibrate.temporal_fit import TAU_CANDIDATES


def fit(kind: Kind, counts: np.ndarray, forces: np.ndarray, *,
        linear_fit: Optional[linear.LinearFit] = None, config: mlp.LMConfig = mlp.LMConfig(),
        val_fraction: float = 0.15, seed: int = 0, progress=None,
        degree: int = 3, snapshots: tuple[int, ...] = (), val_block: Optional[int] = None,
        ensemble: int = 1, inputs: Optional[Sequence[str]] = None,
        outputs: Optional[Sequence[str]] = None, input_units: Optional[Sequence[str]] = None,
        output_units: Optional[Sequence[str]] = None,
        groups: Optional[splits.Groups] = None, folds: int = 0,
        cross: bool = False, ridge: Optional[float] = None,
        widths: Sequence[int] = (), net_inputs: Optional[int] = None,
        gp=None, deep=None, layers: Optional[Sequence[int]] = None, activation=None
        ) -> Estimator:
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
      continued linearly beyond its training box (`calibrate.parts.poly`); False: the shell
      paper's powers of each channel alone (`linear.fit_linear`).
    ridge: with `cross`, the ridge weight per training sample; None: chosen with the degree
      (1..`degree`) by grouped cross-validation over `folds` when given, else 0.
    widths: for LSANN and NN with `folds`: hidden widths to try (e.g. 5..64); the one with
      the lowest held-out error (summed over outputs, each relative to its spread) is kept,
      in place of `config.hidden`.
    net_inputs: for LSANN and NN, the network reads only the first this many input columns
      (None: all); the LS stage reads all.
    gp: for LSGP, the Gaussian process's settings (`calibrate.parts.gp.GPConfig`; None: its
      defaults).
    deep: for MLP, the perceptron's settings (`calibrate.parts.deep.DeepConfig`; None: its
      defaults). layers: its hidden layers, e.g. (64, 64), and activation: its units,
      "relu" or "tanh"; each None: chosen on the held-out groups when there are folds
      (the layers among `deep.GRID`, then the units at them), else `deep`'s.
    folds: with `groups`, grouped K-fold cross-validation of the whole fit (K more fits):
      its held-out residuals size the estimator's interval (`Info.half_width`) and its
      RMSE per output is kept; an LSANN output whose network does not beat its LS stage
      there keeps the LS stage alone (said in `Info.validation["ls_only"]`). 0: none.
  """
  return methods.fit(
      Kind(kind), counts, forces, linear_fit=linear_fit, config=config,
      val_fraction=val_fraction, seed=seed, progress=progress, degree=degree,
      snapshots=snapshots, val_block=val_block, ensemble=ensemble, inputs=inputs,
      outputs=outputs, input_units=input_units, output_units=output_units, groups=groups,
      folds=folds, cross=cross, ridge=ridge, widths=widths, net_inputs=net_inputs, gp=gp,
      deep=deep, layers=layers, activation=activation)


def fit_auto(counts: np.ndarray, forces: np.ndarray, groups: splits.Groups,
             folds: "Optional[int | str]" = None,
             candidates: Optional[Sequence] = None, progress=None, **kwargs
             ) -> tuple[Estimator, dict]:
  """Every candidate fitted and cross-validated on the same grouped folds; for each output,
  the simplest (in the order of `candidates`) whose held-out RMSE is within one standard
  error over the folds (or `TIE`) of the lowest, the held-out groups' mean errors weighed
  by the share of the loads' variance between the groups (`select.model_error`). A
  candidate that is not tame (a network, a cubic) is scored as `auto` predicts with it:
  continued along LS's plane past the training box (its correction to LS fading out past
  the held-out samples' reach, `compose.PerOutput`), and again, named "<name> unguarded",
  as it extrapolates itself, which is kept only where the held-out samples beyond their
  fold's box say it is the better (`methods._continuations`). `candidates`: names of
  `methods.AUTO` (or methods, each its plain fit); None: `methods.AUTO_CANDIDATES`, LS,
  each channel's powers (POLY-CH), POLY with cross terms, LSANN and NN.

  Returns (the AUTO estimator, {method: {"cv_rmse": [per output], "seconds": fit time,
  "estimator": the candidate fitted}}). `kwargs` go to every `fit` (config, seed, names...);
  `ensemble` N > 1 adds each network's mean of N networks (named e.g. "NNx5") right after
  the single network, which reuses the width or layers the single one chose. `folds` None
  or "auto": `splits.fold_count` of the groups (10 at 20 whole recordings or more, else
  5)."""
  return methods.fit_auto(counts, forces, groups, _folds(groups, folds), candidates,
                          progress, **kwargs)


def _folds(groups: Optional[splits.Groups], folds) -> Optional[int]:
  """`splits.fold_count` (`methods.fit_auto` refuses a fit without groups itself)."""
  return folds if groups is None else splits.fold_count(groups, folds)


def fit_auto_temporal(counts: np.ndarray, forces: np.ndarray, dt: float,
                      groups: splits.Groups, folds: "Optional[int | str]" = None,
                      **kwargs
                      ) -> tuple[Estimator, dict]:
  """`fit_auto` with memory among the candidates: LS and POLY behind a memory front end
  (`calibrate.temporal_fit.fit_auto_temporal`; `segments`, `taus`, `tare`, `differences`
  as `fit_temporal` takes them), kept per output only where their held-out gain beats every
  static candidate's by more than a standard error; `folds` as `fit_auto` takes them."""
  return temporal_fit.fit_auto_temporal(counts, forces, dt, groups, _folds(groups, folds),
                                        **kwargs)


def fit_temporal(kind: Kind, counts: np.ndarray, forces: np.ndarray, dt: float, *,
                 segments: Optional[np.ndarray] = None, select: Optional[np.ndarray] = None,
                 contact: Optional[np.ndarray] = None, sessions: Optional[np.ndarray] = None,
                 taus: Optional[Sequence[float]] = None,
                 candidates: Sequence[float] = TAU_CANDIDATES, max_taus: int = 3,
                 differences: bool = True, tare: Optional[temporal.Tare] = None,
                 folds: int = 5, seed: int = 0, inputs: Optional[Sequence[str]] = None,
                 memory: Optional[temporal.Memory] = None, network_history: bool = False,
                 gru: recurrent.GRUConfig = recurrent.GRUConfig(), **kwargs) -> Estimator:
  """Fits an estimator of `kind` behind a temporal front end (`calibrate.parts.memory.Memory`).

  Args:
    kind: the stages (LS, POLY, LSANN, NN, GRU) fitted on the front end's features. GRU is
      LS on the features plus a recurrent network (`calibrate.parts.gru`) that reads the
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
  return temporal_fit.fit_temporal(
      Kind(kind), counts, forces, dt, segments=segments, select=select, contact=contact,
      sessions=sessions, taus=taus, candidates=candidates, max_taus=max_taus,
      differences=differences, tare=tare, folds=folds, seed=seed, inputs=inputs,
      memory=memory, network_history=network_history, gru=gru, **kwargs)


def combine(members: Sequence[Estimator]) -> Estimator:
  """Fitted estimators of one kind (networks from several seeds) as one ensemble: it predicts
  their mean, and its residual spread is the root mean square of theirs. Each member needs
  its `info` (every `fit` gives one); the ensemble's is the first member's otherwise."""
  return methods.combine(members)


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
