"""Model selection on held-out groups: one cross-validation loop, the choices as rules.

As scikit-learn's `GridSearchCV` evaluates every candidate on every split and lets a callable
pick the best, `held_out` runs a fold function over grouped folds (`calibrate.splits.folds`:
no recording and no time block shared between training and held-out data) and gathers each
candidate's held-out residuals; the rules below read them:

- `lowest` (the poly's degree x ridge, the network's width, the memory's time constants: the
  candidate with the lowest held-out error),
- `greedy` (time constants added one at a time while each lowers the error by `GAIN`),
- `ls_only` (LSANN's outputs whose network does not beat its LS stage held out),
- `one_standard_error` (`fit_auto`: per output, the simplest candidate within one standard
  error of the best, on the error `model_error` weighs).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from calibrate import splits
from calibrate.info import group_means

TIE = 0.01  # relative held-out RMSE within which `one_standard_error` prefers the simpler
GAIN = 0.99  # `greedy` keeps a candidate that leaves at most this share of the error


def held_out(fold_fn: Callable, y: np.ndarray, parts: Sequence[tuple[np.ndarray, np.ndarray]],
             candidates: int = 1) -> np.ndarray:
  """(K, N, A) held-out residuals y - prediction of K candidates: `fold_fn(train, test)`
  fits on the samples `train` and returns (K, len(test), A) predictions for `test` (one
  factorisation may serve several candidates, as the poly's ridge weights)."""
  out = np.zeros((candidates,) + y.shape)
  for tr, va in parts:
    out[:, va] = y[va] - np.asarray(fold_fn(tr, va)).reshape((candidates, len(va), -1))
  return out


def fold_sums(residual: np.ndarray, parts, scale=1.0) -> np.ndarray:
  """(K,) the sum of squared (residual / scale) over every fold's held-out samples, fold by
  fold (K, N, A residuals)."""
  total = np.zeros(residual.shape[0])
  for _, va in parts:
    for k in range(residual.shape[0]):
      total[k] += np.sum((residual[k, va] / scale) ** 2)
  return total


def stats(residual: np.ndarray, parts, groups: splits.Groups) -> dict:
  """What a grouped cross-validation gave, for `Info.validation`: the split, its groups and
  folds, the held-out RMSE per output, overall and per fold, and the part of the mean square
  that is the held-out groups' mean errors, overall and per fold (`cv_between_ms`,
  `cv_fold_between_ms`: the sum over the groups of n_g x mean_g^2, over n; (N, A) residual)."""
  def between(rows):
    return (between_squares(residual[rows], groups.labels[rows]) / len(rows)).tolist()
  return {"split": groups.how, "groups": groups.count, "block": groups.block,
          "folds": len(parts), "cv_rmse": np.sqrt(np.mean(residual ** 2, axis=0)).tolist(),
          "cv_fold_rmse": [np.sqrt(np.mean(residual[va] ** 2, axis=0)).tolist()
                           for _, va in parts],
          "cv_between_ms": between(np.arange(len(residual))),
          "cv_fold_between_ms": [between(va) for _, va in parts]}


def lowest(scores: dict):
  """The key of the lowest score (the first of equal ones)."""
  return min(scores.items(), key=lambda kv: kv[1])[0]


def greedy(score: Callable, options: Sequence, room: Callable) -> list:
  """Options added one at a time, each the one that lowers `score(kept)` most, while it
  lowers it to `GAIN` of the best so far or less; `room(kept)` says which may still come."""
  best, kept = score([]), []
  while True:
    trials = {t: score(kept + [t]) for t in options if t not in kept and room(kept, t)}
    if not trials:
      return kept
    t = lowest(trials)
    if trials[t] > GAIN * best or best < 1e-9:  # below 1e-9 of the spread nothing is left
      return kept
    kept.append(t)
    best = trials[t]


def ls_only(full_rmse: np.ndarray, base_rmse: np.ndarray) -> np.ndarray:
  """(A,) outputs where the base stage alone held out no worse than base plus residual part
  ((A,) held-out RMSE of each)."""
  return base_rmse <= full_rmse


def between_squares(values: np.ndarray, labels: np.ndarray) -> np.ndarray:
  """(A,) the sum over the groups of n_g x mean_g^2 of `values` (N, A), (N,) group labels."""
  n = np.unique(labels, return_counts=True)[1]
  return np.sum(n[:, None] * group_means(values, labels) ** 2, axis=0)


def between_share(y: np.ndarray, labels: np.ndarray) -> np.ndarray:
  """(A,) the share of each output's variance that lies between the groups' means ((N, A)
  targets, (N,) group labels): 0 where every group spans the same loads, 1 where each holds
  one load state."""
  centred = np.asarray(y, float) - np.mean(y, axis=0)
  total = np.sum(centred ** 2, axis=0)
  between = between_squares(centred, labels)
  # rounding leaves one state per group at 1 +- 5e-14 (the shell's 48 static loads)
  return np.clip(np.where(total > 0, between / np.where(total > 0, total, 1.0), 1.0), 0, 1)


def model_error(validation: dict, share: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
  """((A,), (F, A)) a candidate's held-out RMSE, overall and per fold, with the held-out
  groups' mean errors weighed by `share` (`between_share`). A group's mean error measures
  the model only as far as the groups' loads differ: where every recording spans the same
  loads it is mostly the recording's own offset (on the footpad, thermal drift through each
  candidate's gains: 0.00 N with it off), and from five recordings noise: by the whole error
  `fit_auto`'s Z pick between LS and POLY kept the one that covered new sessions less in
  eight of nine draws. Measured (`real_recordings`, footpad seeds 0-9, every candidate),
  whole error then weighed: in-box Z coverage 86.9 to 94.0 %, auto / best baseline Z 0.98
  to 0.96, and the shear's X 0.74 to 0.82, Y 0.76 to 0.81 (their sessions' offsets, 5 N
  RMS on X, did tell some candidates apart); the shell's ratios and coverage within 0.01
  and 0.3 points, the fingertip's the same (seeds 1-4), and where each recording holds
  one load state (the share 1) nothing changes."""
  keep = 1.0 - np.asarray(share)
  fold_ms = np.square(validation["cv_fold_rmse"]) \
      - keep * np.asarray(validation["cv_fold_between_ms"])
  ms = np.square(validation["cv_rmse"]) - keep * np.asarray(validation["cv_between_ms"])
  return np.sqrt(np.maximum(ms, 0.0)), np.sqrt(np.maximum(fold_ms, 0.0))


def one_standard_error(rmse: np.ndarray, fold_rmse: np.ndarray, scale: np.ndarray
                       ) -> np.ndarray:
  """(A,) for each output, the first candidate (the simplest, in order) whose held-out RMSE
  is within one standard error over the folds of the lowest, and within `TIE` in any case
  (Hastie, Tibshirani & Friedman, Elements of Statistical Learning, Sec. 7.10): a smaller
  difference is not one the held-out groups can tell, and a simpler model extrapolates
  tamer. rmse (K, A), fold_rmse (K, F, A); scale (A,) the outputs' size, for ties at
  rounding."""
  lowest_k = np.argmin(rmse, axis=0)
  cols = np.arange(rmse.shape[1])
  se = fold_rmse[lowest_k, :, cols].std(axis=1, ddof=1) / np.sqrt(fold_rmse.shape[1])
  near = rmse <= rmse[lowest_k, cols] + np.maximum(se, TIE * rmse[lowest_k, cols]) \
      + 1e-12 * scale
  return np.argmax(near, axis=0)
