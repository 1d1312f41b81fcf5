"""The fitted estimator: a tree of parts, the method it was asked for, what it was fitted on.

`Estimator` is what every fit returns and what `calibrate.store` saves and loads; the fits
themselves are in `calibrate.methods` and `calibrate.temporal_fit`, called through
`calibrate.estimators`.
"""

from __future__ import annotations

import dataclasses
import enum
import warnings
from typing import Optional

import numpy as np

from calibrate import compose, store
from calibrate.info import Info
from calibrate.parts import linear
from calibrate.parts.base import Part, Stream
from util import errors


class Kind(enum.Enum):
  LS = "LS"
  POLY = "POLY"
  LSANN = "LSANN"
  NN = "NN"
  GRU = "GRU"  # LS plus a recurrent network on the residual (`fit_temporal` only)
  AUTO = "AUTO"  # per output, the candidate with the lowest held-out error (`fit_auto`)
  LSGP = "LSGP"  # LS plus a Gaussian process on its residual (`calibrate.parts.gp`)
  MLP = "MLP"  # LS plus a perceptron of one or two layers on its residual (`parts.deep`)


# the methods as their plain fits (`fit_auto` chooses among `methods.AUTO_CANDIDATES`)
CANDIDATES = (Kind.LS, Kind.POLY, Kind.LSANN, Kind.NN)


class OutOfRangeWarning(UserWarning):
  """Inputs outside the range an estimator was fitted on: its output there is extrapolation."""


@dataclasses.dataclass(frozen=True)
class Estimator:
  """A fitted estimator: a tree of parts (`root`: `calibrate.parts` families composed by
  `calibrate.compose`), the method a user asked for (`kind`), what it was fitted on
  (`info`), and how its network's training went (`training`; `trainings`, an ensemble's
  members' in order). `plane_info`: for `fit_auto`, the `info` its held-out predictions
  gave continued along an LS plane beyond the training box (`compose.PerOutput`); None
  for a tame estimator and in files (it is not saved)."""
  kind: Kind
  root: Part
  info: Optional[Info] = None
  training: Optional[object] = None
  trainings: tuple = ()
  plane_info: Optional[Info] = None

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
        s if s.NAME == "linear" else None

  @property
  def poly(self):
    return self._stage if self._stage.NAME == "poly" else None

  @property
  def net(self):
    s = self._stage
    s = s.residual if isinstance(s, compose.Residual) else s
    return s if s.NAME == "mlp" else None

  @property
  def rnn(self):
    s = self._stage
    return s.residual if isinstance(s, compose.Residual) and \
        s.residual.NAME == "gru" else None

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

  def continued(self) -> tuple[list[str], Optional[float]]:
    """AUTO: (the outputs whose part is continued along the LS plane past the training box,
    how far past it the held-out samples checked that, in training ranges, past which the
    part's correction fades out: `compose.PerOutput`; None for files written before)."""
    s = self._stage
    if not isinstance(s, compose.PerOutput) or self.info is None:
      return [], None
    return [n for n, on in zip(self.info.outputs, s.guarded()) if on], s.reach

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
