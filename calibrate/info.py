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
from calibrate.parts.base import box_distance
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
    interval_growth: (A,) how the interval widens beyond the training box (`half_width_at`:
      the half-width times 1 + growth x the distance); None in older files (no growth).
    interval_local: (A, 2) per output (b, a): the within-recording part of the interval
      is `interval_abs`'s times max(1, b + a x the distance to the nearest training sample)
      (`nearest`, `local_slope`); None in older files (one width for all).
    interval_reference: (M, C') the training inputs (every k-th row, `REFERENCE_MAX` at
      most; the first C' inputs) that distance is measured to; None in older files.
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
  interval_growth: Optional[np.ndarray] = None
  interval_local: Optional[np.ndarray] = None
  interval_reference: Optional[np.ndarray] = None

  def distance(self, x: np.ndarray) -> np.ndarray:
    """(N,) how far each row of inputs (N, C) lies beyond the training box, in units of each
    input's training range (Euclidean over the inputs; 0 inside the box)."""
    return box_distance(x, self.input_lo, self.input_hi)

  def half_width_at(self, level: float, x: np.ndarray) -> np.ndarray:
    """(N, A) the interval's half-width at `level` for each row of inputs (N, C).

    Its within-recording part grows with how far the row lies from the nearest training
    sample (`local_scale`), never narrower than `half_width`'s one width for all. Beyond the
    training box it is then widened by 1 + `interval_growth` x the distance beyond the box
    (`distance`): held-out groups inside the box say nothing of the error outside it, where
    an estimator extrapolates; measured as the folds' held-out samples beyond their own
    training fold's box (`held_out`)."""
    self.check_level(level)
    growth = np.zeros(len(self.outputs)) if self.interval_growth is None else \
        self.interval_growth
    local = combine(self.within_width(level) * self.local_scale(x), self.interval_offsets,
                    level)
    return local * (1.0 + np.outer(self.distance(x), growth))

  def local_scale(self, x: np.ndarray) -> np.ndarray:
    """(N, A) the factor of the within-recording half-width at each row of inputs (N, C):
    max(1, b + a x `nearest`) (ones in older files).

    An estimator errs more between its training samples than on them (measured on the
    fingertip, one width for all: 98-100 % of the test samples nearest the training data
    covered, 81-86 % of the farthest quarter, all inside the box; on the footpad, 84 % of
    the test beyond the box where the interval grew with the box distance alone, 98 % with
    this scale as well). The scale is fitted on the held-out samples (`local_slope`), but
    held below 1 it would narrow the interval near the training
    data, and new recordings need not keep that promise: on the fingertip's deeper test
    presses it dropped the in-box coverage from 88.8 to 85.2 % (Fy, two draws)."""
    x = np.asarray(x, float)
    if self.interval_local is None or self.interval_reference is None:
      return np.ones((len(x), len(self.outputs)))
    c = self.interval_reference.shape[1]
    d = nearest(x[:, :c], self.interval_reference, self.input_lo[:c], self.input_hi[:c])
    return scale_at(self.interval_local, d)

  def within_width(self, level: float) -> np.ndarray:
    """(A,) the within-recording part of `half_width` (its split-conformal quantile)."""
    return within(self.interval_abs, self.interval_n, level)

  def half_width(self, level: float) -> np.ndarray:
    """(A,) half-width of the interval at `level` (0.5 to 0.999), per output.

    Two parts, joined by `combine`: within a recording, the split-conformal quantile (the
    ceil((n + 1) level)-th smallest of the n held-out absolute residuals less their group's
    mean); between recordings, the spread of a new recording's mean error from the G
    groups' held-out mean errors, which G - 1 degrees of freedom carry (`between` alone:
    Student's t at `level` times it). A conformal quantile over samples alone treats a
    recording's thousands of samples as thousands of draws when its offset is one draw:
    measured on the footpad's sessions, it covered 2-100 % of a new session's samples at
    95 %. The t factor states what G recordings can tell (11.0 at 95 % from 2, 2.7 from 5,
    2.3 from 8), as far as the between part weighs in the sum.

    Raises:
      errors.DataError when the estimator was fitted without cross-validation.
    """
    self.check_level(level)
    return combine(self.within_width(level), self.interval_offsets, level)

  def check_level(self, level: float) -> None:
    """Raises errors.DataError when the estimator holds no interval, errors.SettingError
    when `level` is out of range."""
    if self.interval_abs is None:
      raise errors.DataError("the estimator holds no interval: it was fitted without grouped "
                             "cross-validation (--folds 0, or before intervals existed); fit "
                             "it again with --folds 2 or more")
    if not 0.5 <= level <= 0.999:
      raise errors.SettingError(f"interval level {level!r} is out of range: allowed 0.5 to "
                                f"0.999")

  def between_width(self, level: float) -> np.ndarray:
    """(A,) the between-recordings part of `half_width` (zeros in older files)."""
    return between(self.interval_offsets, len(self.outputs), level)

  def to_json(self) -> dict:
    return {"inputs": list(self.inputs), "outputs": list(self.outputs),
            "input_units": list(self.input_units), "output_units": list(self.output_units),
            "samples": self.samples, "data_sha256": self.data_sha256, "settings": self.settings,
            "interval_n": self.interval_n, "validation": self.validation}

  ARRAYS = ("input_lo", "input_hi", "residual_sd", "interval_abs", "output_lo",
            "output_hi", "interval_offsets", "interval_growth", "interval_local",
            "interval_reference")

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
                got["output_lo"], got["output_hi"], got["interval_offsets"],
                got["interval_growth"], got["interval_local"], got["interval_reference"])
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
    if info.interval_growth is not None and info.interval_growth.shape != (a,):
      raise ValueError("its interval's growth does not fit its outputs")
    if (info.interval_local is None) != (info.interval_reference is None) or (
        info.interval_local is not None and (
            info.interval_local.shape != (a, 2) or info.interval_reference.ndim != 2
            or not 1 <= info.interval_reference.shape[1] <= c
            or len(info.interval_reference) < 1)):
      raise ValueError("its interval's local scale does not fit its inputs and outputs")
    if any(r is not None and r.shape != (a,) for r in (info.output_lo, info.output_hi)):
      raise ValueError("its outputs' training ranges do not fit its outputs")
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


def within(interval_abs: np.ndarray, n: int, level: float) -> np.ndarray:
  """(A,) the split-conformal quantile at `level` of n held-out scores whose quantiles at
  `INTERVAL_GRID` are `interval_abs` (P, A)."""
  p = min(1.0, np.ceil((n + 1) * level) / n)
  return np.array([np.interp(p, INTERVAL_GRID, q) for q in interval_abs.T])


def scale_at(local: np.ndarray, d: np.ndarray) -> np.ndarray:
  """(N, A) the local scale max(1, b + a x d) of (A, 2) per-output (b, a) `local` at (N,)
  distances `d` to the nearest training sample (`Info.local_scale`, held out in `held_out`)."""
  return np.maximum(1.0, local[:, 0] + np.outer(d, local[:, 1]))


def combine(within_part: np.ndarray, offsets: Optional[np.ndarray], level: float
            ) -> np.ndarray:
  """(A,) or (N, A) half-widths at `level` of a new recording's error: its within part
  (the conformal quantile, A or N x A) plus its mean error, whose spread `offset_spread`
  the G groups' held-out mean errors `offsets` (G, A) give with G - 1 degrees of freedom
  (None or one group: the within part alone).

  Welch-Satterthwaite: Student's t at `level` with the sum's effective degrees of freedom
  (G - 1)(w^2 + s^2)^2 / s^4 times sqrt(w^2 + s^2), w the within part over the normal
  quantile (its many samples: known), s the spread. Where s is nothing it gives the
  conformal quantile itself; where w is, `between`. Adding the two parts in quadrature, as
  before, charged the t factor to the between part whatever its weight: simulated (G = 5,
  normal parts, 200,000 draws) that covered 95.1-96.6 % as s / w went from 0 to 5, most
  (96.6 %) where the two are alike, as on the shell's Fy; this covers 94.1-95.1 %."""
  if offsets is None or len(offsets) < 2:
    return np.asarray(within_part, float)
  import scipy.stats
  g = len(offsets)
  w2 = (np.asarray(within_part, float) / scipy.stats.norm.ppf(0.5 + level / 2)) ** 2
  s2 = np.broadcast_to(offset_spread(offsets, 1) ** 2, np.shape(w2))
  dof = np.where(s2 > 0, (g - 1) * (w2 + s2) ** 2 / np.where(s2 > 0, s2, 1.0) ** 2, np.inf)
  return scipy.stats.t.ppf(0.5 + level / 2, dof) * np.sqrt(w2 + s2)


def between(offsets: Optional[np.ndarray], a: int, level: float) -> np.ndarray:
  """(A,) how far a new recording's mean error may lie: Student's t at `level` with G - 1
  degrees of freedom times `offset_spread` of one new recording: sqrt(1 - 1/G^2) times the
  RMS of the G groups' held-out mean errors (zeros below 2 groups).

  Student's t with G degrees of freedom times the RMS, as it was, covers 87.4 % of new
  groups from 2 held out, 92.3 % from 3, 94.1 % from 5 (simulated, 100,000 draws each; this
  factor 95.0-95.1 %, and 95.0-95.2 % where folds hold out several groups, 12 in 5 folds,
  25 in 10)."""
  if offsets is None or len(offsets) < 2:
    return np.zeros(a)
  import scipy.stats
  t = scipy.stats.t.ppf(0.5 + level / 2, df=len(offsets) - 1)
  return t * offset_spread(offsets, 1)


def offset_spread(offsets: np.ndarray, r: int) -> np.ndarray:
  """(A,) the spread of the mean offset of `r` new groups less the estimator's own, from the
  G groups' held-out mean errors `offsets` (G, A): RMS x sqrt((1/r + 1/G)(G - 1)/G).

  Exact where each group's offset is a normal draw and the estimator's own offset the mean
  of its training groups': a held-out group's mean error is then its offset less its fold's
  other groups' mean, so the G of them hold G - 1 degrees of freedom (two groups' are one
  number, of opposite signs), and over this spread the new groups' mean is Student's t with
  G - 1 degrees of freedom."""
  g = len(offsets)
  return np.sqrt(np.mean(np.asarray(offsets) ** 2, axis=0) * (1.0 / r + 1.0 / g)
                 * (g - 1) / g)


def held_out(residual: np.ndarray, groups: splits.Groups, stats: dict,
             distance: Optional[np.ndarray] = None,
             near: Optional[tuple[np.ndarray, np.ndarray]] = None) -> dict:
  """`Info`'s interval fields from held-out residuals (N, A) of grouped cross-validation;
  `distance` (N,): how far each held-out sample lay beyond its training fold's box
  (`box_distance`), for the interval's growth there (None: no growth); `near`: (each
  held-out sample's distance (N,) to the nearest of its training fold's reference rows,
  `fold_nearest`; the reference rows of all the training data (M, C')), for the local scale
  (`local_slope`; None: none)."""
  # every sample its own group (the paper's split): no recording offsets to tell apart
  offsets = group_means(residual, groups.labels) if groups.how != "samples" else None
  within_r = residual if offsets is None else \
      residual - offsets[np.unique(groups.labels, return_inverse=True)[1]]
  out = dict(interval_abs=np.quantile(np.abs(within_r), INTERVAL_GRID, axis=0),
             interval_n=len(residual), interval_offsets=offsets, validation=stats)
  scale = np.ones_like(residual)
  if near is not None:
    slope, q = local_slope(np.abs(within_r), near[0])
    # relative to the one width: at GROWTH_LEVEL, b + a d times it is the local interval
    flat = within(out["interval_abs"], len(residual), GROWTH_LEVEL)
    b = np.where(flat > 0, q / np.where(flat > 0, flat, 1.0), 1.0)
    local = np.column_stack([b, b * slope])
    scale = scale_at(local, near[0])
    out.update(interval_local=local, interval_reference=near[1])
  if distance is not None:
    half = combine(within(out["interval_abs"], len(residual), GROWTH_LEVEL) * scale, offsets,
                   GROWTH_LEVEL)
    growth, beyond = interval_growth(np.abs(residual), distance, half)
    out["interval_growth"] = growth
    out["validation"] = {**stats, "held_out_beyond_box": int(beyond),
                         # as far past its fold's box as a held-out sample checked the
                         # estimator: `compose.PerOutput` fades its continuation past it
                         "held_out_reach": float(distance.max(initial=0.0))}
  return out


GROWTH_LEVEL = 0.95  # the level at which the growth is measured (and used at every level)
GROWTH_MIN = 20  # held-out samples beyond their fold's box that measure the growth
GROWTH_DEFAULT = 1.0  # with fewer: the half-width doubles one training range out (unmeasured)


def interval_growth(abs_residual: np.ndarray, distance: np.ndarray, half: np.ndarray
                    ) -> tuple[np.ndarray, int]:
  """((A,) the growth, the held-out samples beyond the box it was measured on): the split-
  conformal `GROWTH_LEVEL` quantile of (|r| / half - 1) / distance over the held-out
  samples beyond their training fold's box, so that half x (1 + growth x distance) covers
  that share of them; `GROWTH_DEFAULT` with fewer than `GROWTH_MIN` such samples. `half`:
  (A,), or (N, A) each sample's own."""
  out = distance > 1e-9
  n = int(out.sum())
  if n < GROWTH_MIN:
    return np.full(abs_residual.shape[1], GROWTH_DEFAULT), n
  half = np.broadcast_to(half, abs_residual.shape)[out]
  score = (abs_residual[out] / np.where(half > 0, half, 1.0) - 1.0) / distance[out, None]
  return np.maximum(conformal(score), 0.0), n


# how steeply the local scale may grow with the distance to the nearest training sample, per
# unit of an input's training range: 0 (none), then 0.1 to 1000 in steps of 10^0.25;
# measured, the fingertip's held-out samples lie 0.003-0.5 ranges from the nearest training
# sample, the shell's 0.08-0.5
LOCAL_SLOPES = (0.0,) + tuple(np.geomspace(0.1, 1000.0, 17))
LOCAL_BINS = 4  # the slope evens the coverage over this many quantile bins of the distance


def local_slope(abs_within: np.ndarray, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
  """((A,) per output the slope g of the local scale 1 + g x `near`, (A,) the split-
  conformal `GROWTH_LEVEL` quantile of |r| over that scale). The slope is the one of
  `LOCAL_SLOPES` under which that interval covers the held-out samples most evenly over
  `LOCAL_BINS` quantile bins of their distance (least squared departure from the level);
  0, the first, is one width for all. The narrowest interval on average is not the one: on
  errors that spread as 1 + 10 d it takes the slope 5, and covers 92.5 % of the nearest
  half. abs_within: (N, A) held-out absolute residuals less their group's mean; near: (N,)
  each one's distance to its training fold's nearest reference row."""
  edges = np.quantile(near, np.linspace(0, 1, LOCAL_BINS + 1)[1:-1])
  bins = np.searchsorted(edges, near, side="right")
  present = np.unique(bins)
  slope, quantile = np.zeros(abs_within.shape[1]), np.zeros(abs_within.shape[1])
  best = np.full(abs_within.shape[1], np.inf)
  for g in LOCAL_SLOPES:
    s = (1.0 + g * near)[:, None]
    q = conformal(abs_within / s)
    inside = abs_within <= q * s
    loss = sum((inside[bins == j].mean(axis=0) - GROWTH_LEVEL) ** 2 for j in present)
    better = loss < best - 1e-12  # a tie keeps the gentler slope
    best = np.where(better, loss, best)
    slope[better], quantile[better] = g, q[better]
  return slope, quantile


def conformal(scores: np.ndarray) -> np.ndarray:
  """(A,) the split-conformal `GROWTH_LEVEL` quantile of n held-out scores (n, A): the
  ceil((n + 1) level)-th smallest (the largest when n is too small)."""
  n = len(scores)
  k = min(n, int(np.ceil((n + 1) * GROWTH_LEVEL)))
  return np.partition(scores, k - 1, axis=0)[k - 1]


REFERENCE_MAX = 2000  # the training rows kept to measure the distance to the nearest


def reference(x: np.ndarray, n: Optional[int] = None) -> np.ndarray:
  """(M, C) every k-th row of `x` (N, C), k the least that keeps `REFERENCE_MAX` or fewer of
  `n` rows (None: N): the rows `nearest` measures to. A fold's training rows take the k of
  all the training data (`fold_nearest`), so that its reference is as dense along its
  recordings as the final fit's, and the held-out distances are those `predict` will see."""
  k = max(1, -(-(len(x) if n is None else n) // REFERENCE_MAX))
  return np.asarray(x, np.float32)[::k]  # float32 halves the file; a distance needs no more


def nearest(x: np.ndarray, ref: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
  """(N,) each row of `x` (N, C)'s Euclidean distance to the nearest row of `ref` (M, C),
  each input in units of its range [lo, hi] (a constant input in its own units)."""
  from scipy.spatial import cKDTree
  span = np.where(hi > lo, hi - lo, 1.0)
  return cKDTree(np.asarray(ref, float) / span).query(np.asarray(x, float) / span)[0]


def fold_nearest(x: np.ndarray, parts) -> np.ndarray:
  """(N,) for each sample, its distance to the nearest `reference` row of the fold that
  held it out (every k-th of its training rows, k as for all of `x`), in units of that
  fold's ranges."""
  out = np.zeros(len(x))
  for tr, va in parts:
    out[va] = nearest(x[va], reference(x[tr], len(x)), x[tr].min(axis=0), x[tr].max(axis=0))
  return out


def fold_distance(x: np.ndarray, parts) -> np.ndarray:
  """(N,) for each sample, how far it lies beyond the box of the fold that held it out."""
  out = np.zeros(len(x))
  for tr, va in parts:
    out[va] = box_distance(x[va], x[tr].min(axis=0), x[tr].max(axis=0))
  return out


def common_bias(error: np.ndarray, recording: np.ndarray, offsets) -> dict:
  """The mean error (A,) common to the test recordings, from in-box errors (N, A) and their
  test recording (N,), and it over the spread that the held-out recordings' offsets (G, A)
  allow it where the test recordings are drawn as the training ones were (a z-score, A).

  The R test recordings share one estimator, whose own offset is an estimate from the G
  training recordings: their common error is the mean of their R offsets less that
  estimate, which spreads as RMS(offsets) x sqrt((1/R + 1/G) (G - 1)/G)
  (`offset_spread`, the interval's between part at R = 1). Over it, z is
  Student's t with G - 1 degrees of freedom: beyond its 97.5 % point one time in twenty,
  its RMS over draws sqrt((G - 1)/(G - 3)), 1.41 from 5. Over RMS(offsets)/sqrt(R) alone,
  as it was, recordings drawn alike gave z far out: measured on the footpad (LS, seed 3, 150
  random splits of 15 sessions of the training paths into 5 to train and 5 to test), its
  RMS X 1.71, Y 2.32, Z 2.06 against the 1.29 then expected; on this scale 1.35, 1.83, 1.63
  against 1.41.
  Nor do the footpad's test paths differ much from its training paths: over seeds 0-9
  (LS), the RMS of new sessions' Z offsets was 1.30 N on the training paths, 1.43 N on the
  test paths, the held-out sessions' 1.16 N (0.78 N in the median draw, 2.69 N in one:
  five recordings' spread is mostly small and now and then large); with `thermal_drift`
  off every session's offset was 0.00 N (seed 3)."""
  if not len(error):
    return {}
  means = group_means(error, recording)
  common = means.mean(axis=0)
  out = {"test_common_bias": common.tolist()}
  if offsets is not None and len(offsets) >= 2:
    spread = offset_spread(offsets, len(means))
    out["test_bias_z"] = np.where(spread > 0, common / np.where(spread > 0, spread, 1.0),
                                  np.nan).tolist()
    out["test_bias_dof"] = len(offsets) - 1
  return out


def bias_line(bias: dict, names, recordings: int, who: str) -> str:
  """The line of `common_bias`: the mean error common to `recordings` test recordings (in
  the box) per output, its z, and the outputs beyond Student's t's 97.5 % point at its
  degrees of freedom, where the test recordings differ from ones drawn as the training
  ones were. `who`: whose error ("auto's")."""
  import scipy.stats
  z = np.array(bias["test_bias_z"], float)
  edge = float(scipy.stats.t.ppf(0.975, bias["test_bias_dof"]))
  line = (f"{who} mean error common to the {recordings} test recordings (in the box), per "
          f"axis: " + " ".join(f"{a}: {v:.3g}" for a, v in zip(names, bias["test_common_bias"]))
          + "; over what the held-out recordings' offsets allow such a mean (z): "
          + " ".join(f"{a}: {v:.1f}" for a, v in zip(names, z)))
  far = [a for a, v in zip(names, z) if abs(v) > edge]
  if far:
    line += (f"; beyond {edge:.2f} (one time in twenty by chance) on {', '.join(far)}: the "
             f"test recordings differ from recordings like the training ones (their loads, "
             f"paths or conditions), and the interval, sized on held-out training "
             f"recordings, cannot see that bias")
  return line


def group_means(values: np.ndarray, labels: np.ndarray) -> np.ndarray:
  """(G, A) the mean of `values` (N, A) over each group, in the order of np.unique(labels)."""
  _, inverse = np.unique(labels, return_inverse=True)
  sums = np.zeros((inverse.max() + 1, values.shape[1]))
  np.add.at(sums, inverse, values)
  return sums / np.bincount(inverse)[:, None]
