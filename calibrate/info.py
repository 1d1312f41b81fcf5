"""What an estimator was fitted on and how far to trust it: `Info`, saved with it.

`Info` holds the inputs' and outputs' names, units and training ranges, the held-out residual
spread, and the quantiles that size `predict`'s interval (`Info.half_width`); `held_out`
builds those from the residuals of grouped cross-validation.
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from calibrate import splits
from util import errors, files


@dataclasses.dataclass(frozen=True)
class Info:
  """What an estimator was fitted on, saved with it.

  Attributes:
    inputs, outputs: names of the input channels (C) and the outputs (A).
    input_units, output_units: their units ("counts", "N", "N m"...).
    input_lo, input_hi: (C,) the training range of every input channel.
    residual_sd: (A,) spread (standard deviation) of the residual on held-out validation
      samples, output units: the estimator's own error, as measured when it was fitted.
    samples: training samples.
    data_sha256: SHA-256 of the training inputs and targets (float64 bytes).
    settings: the method and its settings (JSON-able).
    interval_abs: (P, A) quantiles, at the probabilities `INTERVAL_GRID`, of the absolute
      residual on held-out groups (grouped cross-validation) less its group's mean, output
      units; None when the fit ran no cross-validation. `half_width` turns it into the
      interval.
    interval_n: the held-out samples behind `interval_abs`.
    interval_offsets: (G, A) the mean held-out residual of every group (a recording's
      offset, drift, pose), output units; None in older files (their `interval_abs` holds
      the whole residual).
    validation: how the held-out data were chosen and what they gave (JSON-able): the split,
      its groups, the folds, the cross-validated RMSE per output, outputs where LSANN kept
      only its LS stage.
    output_lo, output_hi: (A,) the training range of every output (None in older files):
      truth beyond it is target extrapolation, where every method under-reaches.
  """
  inputs: tuple[str, ...]
  outputs: tuple[str, ...]
  input_units: tuple[str, ...]
  output_units: tuple[str, ...]
  input_lo: np.ndarray
  input_hi: np.ndarray
  residual_sd: np.ndarray
  samples: int
  data_sha256: str
  settings: dict
  interval_abs: Optional[np.ndarray] = None
  interval_n: int = 0
  validation: dict = dataclasses.field(default_factory=dict)
  output_lo: Optional[np.ndarray] = None
  output_hi: Optional[np.ndarray] = None
  interval_offsets: Optional[np.ndarray] = None

  def half_width(self, level: float) -> np.ndarray:
    """(A,) half-width of the interval at `level` (0.5 to 0.999), per output.

    Two parts, added in quadrature: within a recording, the split-conformal quantile (the
    ceil((n + 1) level)-th smallest of the n held-out absolute residuals less their group's
    mean); between recordings, how far a new recording's mean error may lie, Student's t
    at `level` with G degrees of freedom times the RMS of the G groups' mean errors. A
    conformal quantile over samples alone treats a recording's thousands of samples as
    thousands of draws when its offset is one draw: measured on the footpad's sessions, it
    covered 2-100 % of a new session's samples at 95 %. The t factor states what G
    recordings can tell (4.3 at 95 % from 2, 2.3 from 8).

    Raises:
      errors.DataError when the estimator was fitted without cross-validation.
    """
    if self.interval_abs is None:
      raise errors.DataError("the estimator holds no interval (fitted without grouped "
                             "cross-validation): fit it again with this version's `fit`")
    if not 0.5 <= level <= 0.999:
      raise errors.SettingError(f"interval level {level!r} is out of range: allowed 0.5 to "
                                f"0.999")
    p = min(1.0, np.ceil((self.interval_n + 1) * level) / self.interval_n)
    within = np.array([np.interp(p, INTERVAL_GRID, q) for q in self.interval_abs.T])
    return np.hypot(within, self.between_width(level))

  def between_width(self, level: float) -> np.ndarray:
    """(A,) the between-recordings part of `half_width` (zeros in older files)."""
    offsets = self.interval_offsets
    if offsets is None or len(offsets) < 2:
      return np.zeros(len(self.outputs))
    import scipy.stats
    t = scipy.stats.t.ppf(0.5 + level / 2, df=len(offsets))
    return t * np.sqrt(np.mean(offsets ** 2, axis=0))

  def to_json(self) -> dict:
    return {"inputs": list(self.inputs), "outputs": list(self.outputs),
            "input_units": list(self.input_units), "output_units": list(self.output_units),
            "samples": self.samples, "data_sha256": self.data_sha256, "settings": self.settings,
            "interval_n": self.interval_n, "validation": self.validation}

  ARRAYS = ("input_lo", "input_hi", "residual_sd", "interval_abs", "output_lo",
            "output_hi", "interval_offsets")

  def arrays(self, prefix: str = "info_") -> dict[str, np.ndarray]:
    """Its arrays by name (those it holds), each name after `prefix`."""
    return {prefix + k: getattr(self, k) for k in self.ARRAYS if getattr(self, k) is not None}

  @staticmethod
  def from_saved(head: dict, arrays: dict[str, np.ndarray], prefix: str = "info_") -> "Info":
    """The `Info` that `to_json` and `arrays(prefix)` gave; ValueError when its parts do not
    fit together."""
    got = {k: arrays.get(prefix + k) for k in Info.ARRAYS}
    for k in ("input_lo", "input_hi", "residual_sd"):
      if got[k] is None:
        raise KeyError(prefix + k)
    info = Info(tuple(head["inputs"]), tuple(head["outputs"]), tuple(head["input_units"]),
                tuple(head["output_units"]), got["input_lo"], got["input_hi"],
                got["residual_sd"], int(head["samples"]), str(head["data_sha256"]),
                dict(head["settings"]), got["interval_abs"],
                int(head.get("interval_n", 0)), dict(head.get("validation", {})),
                got["output_lo"], got["output_hi"], got["interval_offsets"])
    c, a = len(info.inputs), len(info.outputs)
    if (len(info.input_units), info.input_lo.shape, info.input_hi.shape) != (c, (c,), (c,)) or \
       (len(info.output_units), info.residual_sd.shape) != (a, (a,)):
      raise ValueError("its names, units and ranges do not fit together")
    if info.interval_abs is not None and (info.interval_abs.shape != (len(INTERVAL_GRID), a)
                                          or info.interval_n < 1):
      raise ValueError("its interval does not fit its outputs")
    if info.interval_offsets is not None and (info.interval_offsets.ndim != 2
                                              or info.interval_offsets.shape[1] != a):
      raise ValueError("its interval's offsets do not fit its outputs")
    return info


# probabilities at which an estimator keeps its held-out absolute residuals' quantiles
INTERVAL_GRID = np.linspace(0.0, 1.0, 1001)


def integer_counts(values: np.ndarray) -> bool:
  """Whether every value is an integer in 0..65535: ADC counts, which the C export takes as
  uint16_t."""
  values = np.asarray(values, float)
  return bool(np.all((values >= 0) & (values <= 65535) & (values == np.round(values))))


def data_digest(counts: np.ndarray, forces: np.ndarray) -> str:
  """SHA-256 of training data: the float64 bytes of inputs and targets, with their shapes."""
  return files.array_digest({"inputs": np.asarray(counts, float),
                             "targets": np.asarray(forces, float)})


def held_out(residual: np.ndarray, groups: splits.Groups, stats: dict) -> dict:
  """`Info`'s interval fields from held-out residuals (N, A) of grouped cross-validation."""
  # every sample its own group (the paper's split): no recording offsets to tell apart
  offsets = group_means(residual, groups.labels) if groups.how != "samples" else None
  within = residual if offsets is None else \
      residual - offsets[np.unique(groups.labels, return_inverse=True)[1]]
  return dict(interval_abs=np.quantile(np.abs(within), INTERVAL_GRID, axis=0),
              interval_n=len(residual), interval_offsets=offsets, validation=stats)


def group_means(values: np.ndarray, labels: np.ndarray) -> np.ndarray:
  """(G, A) the mean of `values` (N, A) over each group, in the order of np.unique(labels)."""
  _, inverse = np.unique(labels, return_inverse=True)
  sums = np.zeros((inverse.max() + 1, values.shape[1]))
  np.add.at(sums, inverse, values)
  return sums / np.bincount(inverse)[:, None]
