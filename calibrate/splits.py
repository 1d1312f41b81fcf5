"""Held-out data that shares no recording and no time block with the training data.

Recordings are autocorrelated: at ~100 Hz to 1 kHz a sample drawn at random for validation
sits between training samples that nearly equal it, so its error flatters every method
(most of all the flexible ones) and an interval sized from it is far too narrow. Here the
unit of a split is a *group*: a whole recording where there are several, otherwise a
contiguous block of samples as long as the signal takes to forget itself (`block_length`,
from its autocorrelation). `holdout` holds out whole groups; `folds` gives grouped K-fold
cross-validation (scikit-learn's `GroupKFold`, shuffled by the seed). The paper's split, single
samples at random (MATLAB `dividerand`), stays available as `how="samples"`.
"""

from __future__ import annotations

import dataclasses
from typing import Literal, Optional

import numpy as np

from util import errors

How = Literal["auto", "recordings", "blocks", "samples"]
HOW = ("auto", "recordings", "blocks", "samples")
MAX_BLOCKS = 200  # a single recording is cut into at least 2 and at most this many blocks


@dataclasses.dataclass(frozen=True)
class Groups:
  """Which group each sample belongs to, and what the groups are.

  Attributes:
    labels: (N,) int group of every sample, 0..G-1, in time order within a recording.
    how: "recordings", "blocks" or "samples" (every sample its own group).
    block: the block length in samples when how == "blocks" (else 0).
  """
  labels: np.ndarray
  how: str
  block: int = 0

  @property
  def count(self) -> int:
    return int(self.labels.max()) + 1 if len(self.labels) else 0

  def describe(self) -> str:
    """One line for the command's output."""
    if self.how == "recordings":
      return f"{self.count} recordings, each held out whole"
    if self.how == "blocks":
      return (f"{self.count} contiguous blocks of {self.block} samples, each within one "
              f"recording (the inputs' autocorrelation falls below 1/e by then)")
    return "single samples at random (the paper's split: flatters every method)"


def block_length(x: np.ndarray, limit: Optional[int] = None) -> int:
  """Samples after which the signal `x` (N, C) forgets itself: the first lag at which the
  mean autocorrelation of its channels (each centred, a constant channel skipped) falls
  below 1/e, at least 1; `limit` (default N // 2) caps it."""
  x = np.asarray(x, float)
  n = len(x)
  limit = max(1, n // 2 if limit is None else min(limit, n // 2))
  x = x - x.mean(axis=0)
  var = (x ** 2).sum(axis=0)
  live = var > 1e-12 * max(float(var.max()), 1e-300)
  if n < 4 or not live.any():
    return 1
  x = x[:, live] / np.sqrt(var[live])
  size = 1 << int(np.ceil(np.log2(2 * n)))  # zero-padded FFT: the linear, not circular, sum
  spec = np.fft.rfft(x, size, axis=0)
  acf = np.fft.irfft(spec * spec.conj(), size, axis=0)[:n].mean(axis=1)
  below = np.flatnonzero(acf[1:limit + 1] < np.exp(-1.0))
  return int(below[0]) + 1 if below.size else limit


def groups(n: int, how: How = "auto", recording: Optional[np.ndarray] = None,
           x: Optional[np.ndarray] = None, block: Optional[int] = None) -> Groups:
  """The groups of a split of N samples.

  Args:
    how: "recordings" (each distinct `recording` label one group), "blocks" (contiguous
      blocks of `block` samples, or of `block_length(x)`), "samples" (the paper's), or "auto":
      recordings where there are several, blocks otherwise.
    recording: (N,) label of the recording each sample came from (None: one recording).
    x: (N, C) the inputs, for the block length.
    block: the block length, samples (None: from `x`).
  Raises:
    errors.SettingError naming the split that cannot be made.
  """
  if how not in HOW:
    raise errors.unknown("split", how, HOW)
  several = recording is not None and len(np.unique(recording)) > 1
  if how == "auto":
    how = "recordings" if several else "blocks"
  if how == "samples":
    return Groups(np.arange(n), "samples")
  if how == "recordings":
    if not several:
      raise errors.SettingError("split=recordings needs two recordings or more (several "
                                "--csv files, or --group naming a column that tells them apart)")
    _, labels = np.unique(np.asarray(recording), return_inverse=True)
    return Groups(labels.astype(int), "recordings")
  if block is None:
    block = block_length(x) if x is not None else 1
  block = int(min(max(block, -(-n // MAX_BLOCKS)), max(n // 2, 1)))
  if n < 2 * block:
    raise errors.SettingError(f"{n} samples cannot make two blocks of {block}: give more "
                              f"samples or several recordings")
  if recording is None:
    return Groups(np.arange(n) // block, "blocks", block)
  # blocks within each recording: a block across a file boundary would join two recordings
  _, rec = np.unique(np.asarray(recording), return_inverse=True)
  within = np.empty(n, int)  # each sample's place in its own recording
  for r in range(rec.max() + 1):
    mine = rec == r
    within[mine] = np.arange(mine.sum())
  _, labels = np.unique(np.column_stack([rec, within // block]), axis=0,
                        return_inverse=True)
  return Groups(labels.astype(int), "blocks", block)


def holdout(g: Groups, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """(train, held-out) sample indices: whole groups at random until about `fraction` of the
  samples are held out (at least one group, never all; of a single group, its last
  `fraction` of samples)."""
  if not 0 < fraction < 1:
    raise errors.SettingError(f"validation fraction {fraction!r} is out of range: allowed (0, 1)")
  rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
  if g.how == "samples":
    idx = rng.permutation(len(g.labels))
    n_val = max(1, int(round(fraction * len(idx))))
    return np.sort(idx[n_val:]), np.sort(idx[:n_val])
  sizes = np.bincount(g.labels)
  if len(sizes) < 2:  # one group (a fold of two recordings): hold out its contiguous tail
    n_val = max(1, int(round(fraction * len(g.labels))))
    idx = np.arange(len(g.labels))
    return idx[:-n_val], idx[-n_val:]
  order = rng.permutation(len(sizes))
  held, total = [], 0
  for k in order[:-1]:  # never every group
    if held and total + sizes[k] / 2 > fraction * len(g.labels):
      break
    held.append(k)
    total += sizes[k]
  mask = np.isin(g.labels, held)
  return np.flatnonzero(~mask), np.flatnonzero(mask)


FOLDS = 5  # grouped folds by default (`fold_count`)
MANY_FOLDS, MANY_RECORDINGS = 10, 20  # where there are this many whole recordings or more


def fold_count(g: Groups, asked=None) -> int:
  """The folds to hold out of `g`: `asked` where it is a number; where it is None or "auto"
  (`--folds auto`, the default), `MANY_FOLDS` where the groups are `MANY_RECORDINGS` whole
  recordings or more, else `FOLDS`.

  K folds train each candidate on (K - 1) / K of the groups. Where each recording holds one
  load state (a weight in a pose) and the states are a few dozen, the error of a flexible
  candidate still falls steeply with every state added, so at 80 % of them its held-out error
  ranks it against the others as it would not rank at 100 % (Hastie, Tibshirani & Friedman,
  Elements of Statistical Learning, Sec. 7.10.1: K-fold estimates the error of a fit on
  (K - 1) / K of the data, biased where the learning curve is steep there). Ten folds train
  on 90 %, at twice the fits; with fewer recordings each fold would hold one or two, whose
  error is one draw. Blocks of the same recordings keep `FOLDS`: there each group holds
  many states. Measured (`python -m benchmarks.run real_recordings --quick`, auto against
  LS and scikit-learn's baselines, 5 folds then 10): on a printed six-axis F/T sensor's
  public recordings (60 static weights in a pose, every 5th held out to test), auto / best
  baseline Fx..Mz 1.00 1.00 2.14 1.72 1.35 1.02, then 1.00 0.88 0.82 0.99 0.97 1.02 (the
  5-fold choice kept LSANNx5 for Fz, 1.8x LS's error on the test weights); on the shell at
  48 static load states, seeds 1-4 pooled, the same picks within 10 % and auto's in-box
  95 % coverage 92.8 97.4 92.3 99.1 97.0 98.0 %, then 90.5 94.3 93.8 96.4 94.8 96.2 %: each
  fold's residuals are nearer the final fit's."""
  if asked is not None and asked != "auto":
    return int(asked)
  return MANY_FOLDS if g.how == "recordings" and g.count >= MANY_RECORDINGS else FOLDS


def folds(g: Groups, k: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
  """Grouped K-fold cross-validation: (train, held-out) index pairs, each group held out
  exactly once, no group split between the two (at most one fold per group)."""
  from sklearn.model_selection import GroupKFold
  k = min(int(k), g.count)
  if k < 2:
    raise errors.SettingError(f"cross-validation needs two groups or more; this split has "
                              f"{g.count}")
  # GroupKFold balances sizes deterministically; relabelling the groups at random first
  # makes the folds depend on the seed, not on the groups' order in time
  perm = np.random.default_rng(np.random.SeedSequence([seed, 2])).permutation(g.count)
  splitter = GroupKFold(n_splits=k)
  idx = np.arange(len(g.labels))
  return [(tr, va) for tr, va in splitter.split(idx, groups=perm[g.labels])]


def validation(n: int, fraction: float, seed: int, block: Optional[int] = None
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
