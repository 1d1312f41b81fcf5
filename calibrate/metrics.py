"""The papers' accuracy metrics (LSANN paper Eqns 5, 6, 9)."""

from __future__ import annotations

import dataclasses

import numpy as np


def rmse(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """Root mean squared error per column (Eqn 5)."""
  return np.sqrt(np.mean((np.asarray(pred) - truth) ** 2, axis=0))


def nrmse_pct(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """RMSE as % of the range of the truth (Eqn 6); NaN where the truth does not vary (one
  static load), which has no range to scale by."""
  return 100.0 * _over(rmse(pred, truth), np.ptp(truth, axis=0))


def r2_pct(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """Coefficient of determination, % (Eqn 9); NaN where the truth does not vary."""
  ss_res = np.sum((truth - pred) ** 2, axis=0)
  ss_tot = np.sum((truth - np.mean(truth, axis=0)) ** 2, axis=0)
  # a constant column's sum around its mean is rounding (1e-35), not a spread
  return 100.0 * (1.0 - _over(ss_res, np.where(np.ptp(truth, axis=0) > 0, ss_tot, 0.0)))


def _over(num: np.ndarray, den: np.ndarray) -> np.ndarray:
  """num / den, NaN where den is 0 (a metric undefined there, not infinite)."""
  num, den = np.asarray(num, float), np.asarray(den, float)
  return np.divide(num, den, out=np.full(np.broadcast(num, den).shape, np.nan), where=den > 0)


def median_pct_error(pred: np.ndarray, truth: np.ndarray, threshold: float) -> np.ndarray:
  """Median of |pred - truth| / |truth| x 100 over samples with |truth| > threshold, per column
  (shell paper Table I: forces above 0.2 N, torques above 10 mN m). NaN where none qualify."""
  pred, truth = _columns(pred), _columns(truth)
  out = np.full(len(truth), np.nan)
  for c, (p, t) in enumerate(zip(pred, truth)):
    keep = np.abs(t) > threshold
    if keep.any():
      out[c] = np.median(np.abs(p[keep] - t[keep]) / np.abs(t[keep])) * 100
  return out


def wrench_median_pct(pred: np.ndarray, truth: np.ndarray, force: float = 0.2,
                      torque: float = 0.01) -> np.ndarray:
  """(6,) `median_pct_error` of (N, 6) wrenches, forces over `force` N and torques over
  `torque` N m, as the shell paper's Table I counts them."""
  pred, truth = np.asarray(pred), np.asarray(truth)
  return np.concatenate([median_pct_error(pred[:, :3], truth[:, :3], force),
                         median_pct_error(pred[:, 3:], truth[:, 3:], torque)])


def worst_pct_of_range(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """Largest |pred - truth| as % of the range of the truth, per column (shell paper Table I);
  NaN where the truth does not vary."""
  pred, truth = _columns(pred), _columns(truth)
  return 100.0 * _over(np.max(np.abs(pred - truth), axis=1), np.ptp(truth, axis=1))


def share_range(hits: np.ndarray, n: np.ndarray, seed: int, level: float = 0.9,
                resamples: int = 2000) -> tuple[np.ndarray, np.ndarray]:
  """(lo (A,), hi (A,)): the central `level` of a share, e.g. an interval's coverage, over
  `resamples` resamplings with replacement of the R groups its samples come in (percentile
  bootstrap over groups). A recording's samples share one draw of its offset, so they fall
  inside an interval nearly all or nearly none, and a coverage rests on R draws, not on its
  thousands of samples. hits (R, A): samples inside per group and output; n (R,): samples
  per group (groups of none are left out). NaN with fewer than 2 groups: one draw tells no
  spread."""
  hits, n = np.asarray(hits, float).reshape(len(n), -1), np.asarray(n, float)
  keep = n > 0
  hits, n = hits[keep], n[keep]
  if len(n) < 2:
    return np.full(hits.shape[1], np.nan), np.full(hits.shape[1], np.nan)
  pick = np.random.default_rng(seed).integers(0, len(n), (resamples, len(n)))
  share = 100.0 * hits[pick].sum(axis=1) / n[pick].sum(axis=1)[:, None]
  tail = 50.0 * (1.0 - level)
  return np.percentile(share, tail, axis=0), np.percentile(share, 100.0 - tail, axis=0)


def _columns(a) -> np.ndarray:
  """(C, N) the columns of a (N, C) as contiguous rows: numpy takes the maximum, range or a
  masked selection of those several times faster than of the short rows of `a`."""
  return np.ascontiguousarray(np.asarray(a, float).T)


def summary(pred: np.ndarray, truth: np.ndarray, axes, threshold: float = 0.2) -> dict:
  """{axis: {rmse, nrmse_pct, r2_pct, median_pct, worst_pct}} for (N, len(axes)) forces, N."""
  cols = {"rmse": rmse(pred, truth), "nrmse_pct": nrmse_pct(pred, truth),
          "r2_pct": r2_pct(pred, truth), "median_pct": median_pct_error(pred, truth, threshold),
          "worst_pct": worst_pct_of_range(pred, truth)}
  return {ax: {k: float(v[i]) for k, v in cols.items()} for i, ax in enumerate(axes)}


# ---- the results table: one row per number (metrics.csv) -----------------------------------

COLUMNS = ("group", "method", "axis", "metric", "value", "spread")


@dataclasses.dataclass(frozen=True)
class Row:
  """One number of a results table (a line of metrics.csv).

  Attributes:
    group: where in the run the number belongs ("results", "generalisation", "design/3"...).
    method: the calibrator it scores (LS, LSANN...), "" for a number of no method.
    axis: the output it scores (X, Fz...), "" for a number of no axis.
    metric: what it is (rmse, r2_pct, seconds...).
    value: the number (NaN where it is undefined).
    spread: its standard deviation over the seeds it is a median or mean of (NaN where it
      is one fit's), so a comparison can tell a change from seed-to-seed scatter.
  """
  group: str
  method: str
  axis: str
  metric: str
  value: float
  spread: float = float("nan")


def scored(group: str, by_method: dict, spread: dict | None = None) -> list[Row]:
  """The rows of {method: {axis: {metric: value}}} (each method's `summary`); `spread`, of
  the same shape, gives each value's seed-to-seed standard deviation."""
  out = []
  for m, axes in by_method.items():
    for ax, per in axes.items():
      for k, v in per.items():
        sd = spread[m][ax][k] if spread and m in spread else float("nan")
        # None: a share of no samples (e.g. coverage beyond the box where none lie)
        out.append(Row(group, m, ax, k, float("nan") if v is None else float(v), float(sd)))
  return out


def csv_text(table: list[Row]) -> str:
  """metrics.csv's text: a header of `COLUMNS`, then a line per row (values as repr, so
  they read back to the same float; an empty spread where there is none)."""
  import csv
  import io
  buf = io.StringIO()
  writer = csv.writer(buf, lineterminator="\n")
  writer.writerow(COLUMNS)
  writer.writerows((r.group, r.method, r.axis, r.metric, repr(float(r.value)),
                    "" if r.spread != r.spread else repr(float(r.spread))) for r in table)
  return buf.getvalue()


def read_csv(path) -> list[Row]:
  """The rows of a metrics.csv (one written before the spread column too); ValueError
  saying why when it is not such a table."""
  import csv
  with open(path, newline="") as f:
    reader = csv.DictReader(f)
    if tuple(reader.fieldnames or ()) not in (COLUMNS, COLUMNS[:-1]):
      raise ValueError(f"its columns are {reader.fieldnames}, not {', '.join(COLUMNS)}")
    return [Row(r["group"], r["method"], r["axis"], r["metric"], float(r["value"]),
                float(r.get("spread") or "nan")) for r in reader]
