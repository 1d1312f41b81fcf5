"""Two raw streams, one table: the reference's forces put on the sensor's clock.

A sensor and its reference F/T log on their own clocks and rates, in separate files, and
the reference stamps an event `lag` seconds after the sensor does. `merge` moves the
reference's stamps earlier by the lag and interpolates its columns linearly onto the
sensor's samples, only where the reference brackets them: outside the overlap, or inside a
gap of the reference longer than `max_gap`, a sensor sample gets no target and is dropped
(counted), since interpolating there would invent forces. `estimate_lag` finds the lag from
the data: the peak of the cross-correlation between the rates of change of two magnitudes,
the sensor channels' deviation from their medians and the reference force's.
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from util import errors

GAP_PERIODS = 3.0  # default max_gap: this many mean reference periods (`sample_period`)


@dataclasses.dataclass(frozen=True)
class Merged:
  """One merged recording.

  Attributes:
    data: (N, K) the kept sensor rows with the reference's columns appended.
    names, units: (K,) the sensor's columns, then the reference's (its time left out).
    lines: (N,) the sensor file's line of every kept row.
    lag: seconds the reference was moved earlier by.  lag_estimated: the data's estimate.
    outside: sensor rows dropped outside the reference's span.
    in_gaps: sensor rows dropped inside a reference gap longer than max_gap.
    max_gap: seconds.
  """
  data: np.ndarray
  names: tuple[str, ...]
  units: tuple[str, ...]
  lines: np.ndarray
  lag: float
  lag_estimated: Optional[float]
  outside: int
  in_gaps: int
  max_gap: float

  def describe(self, path: str) -> str:
    est = (f" (estimated from the data: {self.lag_estimated * 1e3:.1f} ms)"
           if self.lag_estimated is not None else "")
    return (f"{path}: {len(self.data)} rows kept, {self.outside} outside the reference's "
            f"span and {self.in_gaps} in its gaps over {self.max_gap * 1e3:.1f} ms dropped, "
            f"lag {self.lag * 1e3:.1f} ms{est}")


def _magnitude(values: np.ndarray) -> np.ndarray:
  """(N,) the norm of each row's deviation from the columns' medians, each column scaled by
  its spread (so no channel's units dominate)."""
  d = values - np.median(values, axis=0)
  scale = d.std(axis=0)
  return np.linalg.norm(d / np.where(scale > 0, scale, 1.0), axis=1)


def estimate_lag(t_sensor: np.ndarray, sensor: np.ndarray, t_ref: np.ndarray,
                 reference: np.ndarray, max_lag: float = 1.0) -> float:
  """Seconds the reference stamps an event after the sensor does, from the data.

  Both magnitudes are resampled on one uniform grid (a quarter of the sensor's median
  period) over the span both cover; the lag is the peak of their cross-correlation within
  +-max_lag, refined by a parabola through the peak and its neighbours.

  Raises:
    errors.DataError when the streams share too short a span to tell.
  """
  dt = float(np.median(np.diff(t_sensor))) / 4
  lo, hi = max(t_sensor[0], t_ref[0]), min(t_sensor[-1], t_ref[-1])
  if hi - lo < 4 * max_lag or hi - lo < 100 * dt:
    raise errors.DataError(f"the streams overlap for {max(hi - lo, 0):.3g} s: too short to "
                           f"estimate a lag of up to {max_lag:g} s; give --lag")
  grid = np.arange(lo, hi, dt)
  # their rates of change: the presses' edges time the streams, slow shape differences
  # (drift, relaxation tails) do not (measured on the footpad's streams: 22 ms for a 25 ms
  # lag, against 18-21 ms from the magnitudes themselves)
  a = np.gradient(np.interp(grid, t_sensor, _magnitude(sensor)))
  b = np.gradient(np.interp(grid, t_ref, _magnitude(reference)))
  a, b = a - a.mean(), b - b.mean()
  n = len(grid)
  size = 1 << int(np.ceil(np.log2(2 * n)))
  # corr[k] = sum_i a[i] b[i + k]: b (the reference) later by k grid steps
  corr = np.fft.irfft(np.conj(np.fft.rfft(a, size)) * np.fft.rfft(b, size), size)
  k_max = min(int(max_lag / dt), n - 1)
  lags = np.arange(-k_max, k_max + 1)
  values = corr[lags % size]
  i = int(np.argmax(values))
  shift = 0.0
  if 0 < i < len(values) - 1:  # parabolic refinement between grid steps
    y0, y1, y2 = values[i - 1], values[i], values[i + 1]
    denom = y0 - 2 * y1 + y2
    shift = 0.5 * (y0 - y2) / denom if denom != 0 else 0.0
  return float((lags[i] + shift) * dt)


def sample_period(t: np.ndarray) -> float:
  """A log's sampling period, s: the mean step with its longest 1 % left out (dropouts).
  The mean, not the median: a logger that writes its samples in packets (three stamps 0.2
  ms apart, then 11 ms) has a median step of 0.2 ms, and a gap rule of a few medians calls
  every packet's pause a gap (a 210-330 Hz irregular F/T log lost 49 % of its sensor's rows
  to the median rule, as a user reported)."""
  steps = np.diff(np.asarray(t, float))
  if not len(steps):
    return float("nan")
  return float(np.mean(steps[steps <= np.quantile(steps, 0.99)]))


def merge(sensor, reference, lag: Optional[float] = None, max_gap: Optional[float] = None,
          time_column: str = "time", max_lag: float = 1.0) -> Merged:
  """The reference's columns on the sensor's samples (two `csvfile.Table`s).

  Args:
    lag: seconds the reference stamps an event after the sensor (None: `estimate_lag`).
    max_gap: the longest reference gap interpolated across, seconds (None: `GAP_PERIODS`
      reference periods, `sample_period`).
    max_lag: the largest lag `estimate_lag` considers, seconds.
  Raises:
    errors.DataError when a file has no time column, the two share a column name, or
      nothing overlaps.
  """
  # each file's stamps in seconds by its own units row (a logger's "ms" is not seconds)
  ts, tr = sensor.seconds(time_column), reference.seconds(time_column)
  for table, t in ((sensor, ts), (reference, tr)):
    if t is None:
      raise errors.DataError(f"{table.path}: no time column {time_column!r} to merge on "
                             f"(name it with --time-column)")
  for table, t in ((sensor, ts), (reference, tr)):
    if len(t) < 2:
      raise errors.DataError(f"{table.path}: {len(t)} data row(s): a stream needs two or more "
                             f"to be merged (the reference is interpolated between its rows)")
  ref_cols = [i for i, n in enumerate(reference.names) if n != time_column]
  sen_cols = [i for i, n in enumerate(sensor.names) if n != time_column]
  shared = {reference.names[i] for i in ref_cols} & {sensor.names[i] for i in sen_cols}
  if shared:
    raise errors.DataError(f"{sensor.path} and {reference.path} both have column(s) "
                           f"{', '.join(sorted(shared))}: rename one side's")
  if max_gap is None:
    max_gap = GAP_PERIODS * sample_period(tr)
  if not max_gap > 0:
    raise errors.SettingError(f"--max-gap {max_gap!r} is out of range: allowed seconds > 0")
  estimated = None  # estimated either way: printed beside a lag the user gives
  try:
    estimated = estimate_lag(ts, sensor.data[:, sen_cols], tr, reference.data[:, ref_cols],
                             max_lag)
  except errors.DataError:
    if lag is None:
      raise
  used = estimated if lag is None else float(lag)
  t_ref = tr - used  # the reference's stamps on the sensor's clock
  inside = (ts >= t_ref[0]) & (ts <= t_ref[-1])
  k = np.clip(np.searchsorted(t_ref, ts), 1, len(t_ref) - 1)  # t_ref[k-1] <= ts <= t_ref[k]
  gap = (t_ref[k] - t_ref[k - 1]) > max_gap
  keep = inside & ~gap
  if not keep.any():
    raise errors.DataError(f"{sensor.path} and {reference.path}: no sensor sample lies inside "
                           f"the reference's span (lag {used:g} s): check the files pair up "
                           f"and the lag")
  values = np.column_stack([np.interp(ts[keep], t_ref, reference.data[:, i])
                            for i in ref_cols])
  lines = sensor.lines if sensor.lines is not None else np.arange(len(ts)) + 1
  return Merged(np.hstack([sensor.data[keep], values]),
                sensor.names + tuple(reference.names[i] for i in ref_cols),
                sensor.units + tuple(reference.units[i] for i in ref_cols), lines[keep],
                used, estimated, int((~inside).sum()), int((inside & gap).sum()),
                float(max_gap))


def merge_all(pairs, lag: Optional[float] = None, max_gap: Optional[float] = None,
              time_column: str = "time", max_lag: float = 1.0
              ) -> tuple[list[Merged], list[int], Optional[float]]:
  """Several (sensor, reference) pairs of one logger merged: (each pair's `Merged`, the
  pairs whose estimated lag lay far from the others', the others' median lag (s) they were
  merged at instead; None when none was). One logger's lag does not change between
  recordings: an estimate far from the others' locked onto another event."""
  done = [merge(a, b, lag, max_gap, time_column, max_lag) for a, b in pairs]
  estimated = [k for k, m in enumerate(done) if m.lag_estimated is not None]
  far = [estimated[k] for k in outlying_lags([done[k].lag for k in estimated])]
  if not far:
    return done, [], None
  median = float(np.median([done[j].lag for j in estimated if j not in far]))
  for k in far:
    done[k] = dataclasses.replace(merge(*pairs[k], median, max_gap, time_column, max_lag),
                                  lag_estimated=done[k].lag_estimated)
  return done, far, median


def two_streams(t: np.ndarray, x: np.ndarray, y: np.ndarray, x_names, y_names, *,
                lag: float, rng: np.random.Generator, step: int = 1,
                reference_rate: float = 250.0, x_offset: float = 0.0, y_offset: float = 0.0,
                x_units=None, y_units=None, name: str = "recording"):
  """One synchronised recording as a rig would log it in two files (for examples and
  benchmarks): (sensor `csvfile.Table`, reference `csvfile.Table`).

  The sensor keeps every `step`-th sample, each channel moved by an offset drawn with rms
  `x_offset` (a baseline of the day) and rounded when `x` is integer; the reference samples
  `y` at irregular times (each period 0.5-1.5 / reference_rate), linearly interpolated,
  moved by an offset of rms `y_offset` per column, stamped `lag` s late.
  """
  from calibrate import csvfile
  integer = bool(np.all(x == np.round(x)))
  xs = x[::step] + rng.normal(0, x_offset, x.shape[1])
  xs = np.round(xs) if integer else xs
  tr = np.cumsum(rng.uniform(0.5, 1.5, int((t[-1] - t[0]) * reference_rate) + 1)
                 / reference_rate) + t[0]
  tr = tr[tr <= t[-1]]
  ref = np.column_stack([np.interp(tr, t, col) for col in y.T])
  ref += rng.normal(0, y_offset, y.shape[1])
  x_units = tuple(x_units or ("",) * x.shape[1])
  y_units = tuple(y_units or ("",) * y.shape[1])
  return (csvfile.Table(("time",) + tuple(x_names), ("s",) + x_units,
                        np.column_stack([t[::step], xs]), f"{name}_sensor.csv"),
          csvfile.Table(("time",) + tuple(y_names), ("s",) + y_units,
                        np.column_stack([tr + lag, ref]), f"{name}_reference.csv"))


# a pair's estimated lag this far from the others' median (at least; else 5 robust standard
# deviations of theirs) is reported: one logger's lag does not change between recordings,
# so such an estimate has locked onto another event. 10 ms: a few samples of a 250-1000 Hz
# reference, within which estimates scatter (`raw_streams`: within one sensor period)
LAG_SPREAD_FLOOR = 0.010


def outlying_lags(lags) -> list[int]:
  """Indices of the estimated lags (s) far from the others' median: beyond 5 robust
  standard deviations (1.4826 x the median absolute deviation) and `LAG_SPREAD_FLOOR`.
  Three lags at least; fewer cannot tell which one is wrong."""
  lags = np.asarray(lags, float)
  if len(lags) < 3:
    return []
  mid = np.median(lags)
  spread = max(5 * 1.4826 * np.median(np.abs(lags - mid)), LAG_SPREAD_FLOOR)
  return [int(k) for k in np.flatnonzero(np.abs(lags - mid) > spread)]
