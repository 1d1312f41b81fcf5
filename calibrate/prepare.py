"""What real recordings need before a fit, one recording at a time, each step counted.

A real log is not a clean table: registers wrap around in hard presses, channels sit on an
ADC rail, the sensor's baseline and the reference's offset move between recordings. Each
step here finds what it acts on, says so in one line (file, line, channel, share), and acts
only when asked:

* wrap-around: a one-sample jump that looks like a register wrapping (`wrap_like`) is
  reported; with `unwrap_bits` every jump over half the register's range is one, undone
  exactly (plus or minus 2**bits times the channel's least significant bit, which is the
  smallest step between its values);
* rails: samples with a channel at its rail (`rails=(lo, hi)`, or found as the recording's
  minimum or maximum held for `RAIL_HOLD` samples in a row while another column moves) are
  reported per channel with their share, one line per recording; `drop_rails` removes
  those rows;
* tare (`Tare`): each input channel and each target offset by its median over the
  recording's unloaded rows (its first seconds, or rows where a contact flag is 0), as F/T
  users bias their sensor before each contact. An estimator keeps the rule, so `predict`,
  `evaluate` and the C export apply it to new recordings the same way.
"""

from __future__ import annotations

import dataclasses
from typing import Optional, Sequence

import numpy as np

from calibrate.info import integer_counts
from util import errors

RAIL_HOLD = 50  # samples in a row at a recording's extreme that make it a rail
SHOWN = 5  # lines named per finding; the rest counted


@dataclasses.dataclass(frozen=True)
class Tare:
  """How a recording's unloaded rows are found: its first `seconds` (by the time column),
  or the rows where the column `flag` is 0. Exactly one of the two."""
  seconds: Optional[float] = None
  flag: Optional[str] = None
  time_column: str = "time"

  def __post_init__(self):
    if (self.seconds is None) == (self.flag is None):
      raise errors.SettingError("a tare takes either --tare SECONDS or --tare-column FLAG")
    if self.seconds is not None and not 0 < self.seconds < 1e6:
      raise errors.SettingError(f"--tare {self.seconds!r} is out of range: allowed seconds "
                                f"in (0, 1e6)")

  def describe(self) -> str:
    return (f"the first {self.seconds:g} s of each recording" if self.seconds is not None
            else f"the rows of each recording where {self.flag} is 0")

  def rows(self, table, where: str) -> np.ndarray:
    """Indices of the unloaded rows of one recording (a `csvfile.Table`).

    Raises:
      errors.DataError when the recording has no such row, or lacks the column the rule
      reads.
    """
    if self.seconds is not None:
      t = table.seconds(self.time_column)
      if t is None:
        raise errors.DataError(f"{where}: --tare {self.seconds:g} needs a time column "
                               f"({self.time_column!r}); use --tare-column FLAG, or name it "
                               f"with --time-column")
      rows = np.flatnonzero(t - t[0] < self.seconds)
    else:
      flag = table.column(self.flag)
      if flag is None:
        raise errors.DataError(f"{where}: no column {self.flag!r} for --tare-column; its "
                               f"columns are {', '.join(table.names)}")
      bad = ~np.isin(flag, (0.0, 1.0))
      if bad.any():
        found = ", ".join(f"{v:g}" for v in np.unique(flag[bad])[:5])
        raise errors.DataError(f"{where}: --tare-column {self.flag} holds {found}: a contact "
                               f"flag is 0 (unloaded) or 1 (loaded)")
      rows = np.flatnonzero(flag == 0)
    if rows.size == 0:
      raise errors.DataError(f"{where}: no unloaded row to tare on ({self.describe()})")
    return rows

  def to_json(self) -> dict:
    return {"seconds": self.seconds, "flag": self.flag, "time_column": self.time_column}

  @staticmethod
  def from_json(d: Optional[dict]) -> Optional["Tare"]:
    return None if d is None else Tare(d.get("seconds"), d.get("flag"),
                                       d.get("time_column", "time"))


@dataclasses.dataclass(frozen=True)
class Steps:
  """The steps asked for (the command's options).

  Attributes:
    unwrap_bits: the register width whose wrap-around is undone (None: only reported); the
      period is 2**bits times each channel's smallest step (`lsb`).
    unwrap_period: the wrap-around's period itself, in the inputs' units, for channels
      whose values are not on one grid of their least significant bit (scaled, filtered).
    rails: (lo, hi) the ADC's rails, in the inputs' units (None: found per recording).
    drop_rails: remove rows with an input at a rail.
    tare: the tare rule (None: no tare).
  """
  unwrap_bits: Optional[int] = None
  rails: Optional[tuple[float, float]] = None
  drop_rails: bool = False
  tare: Optional[Tare] = None
  unwrap_period: Optional[float] = None

  def __post_init__(self):
    if self.unwrap_bits is not None and self.unwrap_period is not None:
      raise errors.SettingError("--unwrap and --unwrap-period: give one of them")
    if self.unwrap_period is not None and not (np.isfinite(self.unwrap_period)
                                               and self.unwrap_period > 0):
      raise errors.SettingError(f"--unwrap-period {self.unwrap_period!r} is out of range: "
                                f"allowed > 0, in the inputs' units")
    if self.unwrap_bits is not None and not 2 <= self.unwrap_bits <= 64:
      raise errors.SettingError(f"--unwrap {self.unwrap_bits!r} is out of range: allowed "
                                f"register widths 2 to 64 bits")
    if self.rails is not None and not self.rails[0] < self.rails[1]:
      raise errors.SettingError(f"--rails {self.rails[0]:g},{self.rails[1]:g}: the low rail "
                                f"must be below the high one")


@dataclasses.dataclass(frozen=True)
class Prepared:
  """Recordings made ready: inputs (N, C), targets (N, A) or None, (N,) the recording of
  every row, (N,) each row's index in the recordings' rows stacked, the lines said, and what
  the estimator keeps (`record`: the unwrap periods and the tare rule, JSON-able)."""
  x: np.ndarray
  y: Optional[np.ndarray]
  recording: np.ndarray
  rows: np.ndarray
  said: tuple[str, ...]
  record: dict


def lsb(values: np.ndarray) -> float:
  """A channel's least significant bit as far as its values show it: the smallest step
  between neighbouring distinct values that recurs (in at least `LSB_SHARE` of those steps,
  and twice). A few values off the grid (a glitch, a logger's rounding) make steps of their
  own that occur once and do not set it; 1.0 for a channel with a single value."""
  u = np.unique(values)
  if len(u) < 2:
    return 1.0
  d = np.diff(u)
  d = d[d > 1e-9 * max(np.abs(u).max(), 1.0)]
  steps, counts = np.unique(np.round(d / d.max(), 9), return_counts=True)
  common = steps[counts >= max(2, LSB_SHARE * len(d))]
  return float((common.min() if common.size else steps.min()) * d.max())


LSB_SHARE = 0.01


def jumps(x: np.ndarray, threshold: np.ndarray) -> list[tuple[int, int]]:
  """(row, channel) of every one-sample jump larger than `threshold` (C,)."""
  rows, cols = np.nonzero(np.abs(np.diff(x, axis=0)) > threshold)
  return sorted(zip((rows + 1).tolist(), cols.tolist()))


def wrap_like(x: np.ndarray, others: Optional[np.ndarray] = None) -> list[tuple[int, int]]:
  """(row, channel) of the jumps that look like a register wrapping, with no register width
  given: over three quarters of the channel's range in one sample, from its outer quarter on
  one side to the outer quarter on the other, and staying there (the next `WRAP_STAY`
  samples on the far half, or those before a jump back as large). Half the range (the plain rule) also flags the press edges of a
  50 Hz log (measured on the example recordings: 3-6 per recording). Noise is no wrap: a
  channel whose median step is over `WRAP_NOISE` of its range, or whose range is under
  `WRAP_MIN_BITS` of its bits, is not searched (a channel at rest spans a few counts, and
  each of them jumps across it). Nor is a step of the load: a jump where another column (an
  input, or a target in `others` (N, A)) jumps over `WRAP_ALONE` of its range in the same
  sample (static loads changing state) is the load's, as a register wraps alone."""
  candidates = jumps(x, 0.75 * np.ptp(x, axis=0))
  if not candidates:  # most recordings: nothing to look into further
    return []
  every = x if others is None else np.column_stack([x, others])
  width = np.ptp(every, axis=0)
  step = np.abs(np.diff(every, axis=0)) / np.where(width > 0, width, 1.0)
  lo, span = x.min(axis=0), width[:x.shape[1]]
  pos = (x - lo) / np.where(span > 0, span, 1.0)  # 0..1 within the channel's range
  steady = {c: np.median(np.abs(np.diff(x[:, c]))) <= WRAP_NOISE * span[c]
            and span[c] >= WRAP_MIN_BITS * lsb(x[:, c]) for c in {c for _, c in candidates}}
  found = []
  for row, c in candidates:
    a, b = pos[row - 1, c], pos[row, c]
    # on the far side until the next jump of the channel back over 3/4 of its range: a peak
    # just over the register's top wraps there and back within a sample or two
    back = [r for r, k in candidates if k == c and row < r <= row + WRAP_STAY]
    after = pos[row:(back[0] if back else row + 1 + WRAP_STAY), c]
    stays = np.all(after > 0.5) if b > a else np.all(after < 0.5)
    alone = np.delete(step[row - 1], c).max(initial=0.0) < WRAP_ALONE
    if steady[c] and min(a, b) < 0.25 and max(a, b) > 0.75 and stays and alone:
      found.append((row, c))
  return found


WRAP_STAY = 3  # samples after a wrap that stay on its far side
WRAP_NOISE = 0.05  # a median one-sample step over this share of the range: noise
WRAP_MIN_BITS = 64  # a channel spanning fewer bits than this is at rest, not wrapping
WRAP_ALONE = 0.25  # another column's one-sample step over this share of its range: a load step


def unwrap(x: np.ndarray, period: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
  """(x with every wrap of its registers undone, (C,) wraps undone per channel): a jump
  larger than half the period is a wrap, and the rest of the recording moves by whole
  periods. So are two steps in a row of the same sign, each over a quarter of the period and
  together over half of it: a wrap with a logger's repaired row in its middle, interpolated
  between the two sides (measured on the fingertip benchmark's full-scale logs: two steps of
  -9,816 uT against a period of 19,661 uT, each under half of it; the wrap left in, LS's
  held-out error on that recording's fold was 8.9 N against 0.03 N on the others). The
  row between takes the mean of its unwrapped neighbours."""
  d = np.diff(x, axis=0)
  half = np.abs(d) > period / 2
  k = np.where(half, np.round(d / period), 0.0)
  pair = (np.abs(d[:-1]) > period / 4) & (np.abs(d[1:]) > period / 4) & \
      (np.sign(d[:-1]) == np.sign(d[1:])) & (np.abs(d[:-1] + d[1:]) > period / 2) & \
      ~half[:-1] & ~half[1:]
  rows, cols = np.nonzero(pair)
  k[rows + 1, cols] = np.round((d[rows, cols] + d[rows + 1, cols]) / period[cols])
  out = x.copy()
  out[1:] -= np.cumsum(k, axis=0) * period
  out[rows + 1, cols] = (out[rows, cols] + out[rows + 2, cols]) / 2
  return out, (k != 0).sum(axis=0)


def at_rails(x: np.ndarray, rails: Optional[tuple[float, float]],
             others: Optional[np.ndarray] = None,
             spans: Optional[np.ndarray] = None) -> np.ndarray:
  """(N, C) bool: the samples at a rail. Given rails: at or beyond them. Otherwise a
  channel's minimum or maximum over the recording, where it is held `RAIL_HOLD` samples in
  a row while the load moves: some other column (another input, or a target in `others`
  (N, A)) sweeps over `RAIL_MOVE` of its range during that run, the range `spans` (C + A,)
  over every recording of the fit (None: this recording's). A held extreme with everything
  else held too is a static load or a sensor at rest (a logger tared to exactly zero), not
  a clipped one; a single column with nothing beside it is never called railed unless the
  rails are given. The range is every recording's because a recording of one static load
  spans its noise alone: a count of it would "move" past a tenth of that (measured on a
  printed F/T sensor's 60 recordings of one load each, 200 samples in 38-496 of a 10-bit
  ADC: 55 of them had channels called railed, 151 of their 480; against every recording's
  ranges, none)."""
  if rails is not None:
    return (x <= rails[0]) | (x >= rails[1])
  every = x if others is None else np.column_stack([x, others])
  span = np.ptp(every, axis=0) if spans is None else np.asarray(spans, float)
  mask = np.zeros(x.shape, bool)
  for c in range(x.shape[1]):
    rest = np.delete(np.arange(every.shape[1]), c)
    for extreme in (x[:, c].min(), x[:, c].max()):
      at = x[:, c] == extreme
      for a, b in _runs(at):
        moved = np.ptp(every[a:b][:, rest], axis=0) > RAIL_MOVE * span[rest]
        if b - a >= RAIL_HOLD and moved.any():
          mask[:, c] |= at
          break
  return mask


RAIL_MOVE = 0.1


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
  """(start, stop) of each run of True in `flags`."""
  edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
  return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _where(table, rows: Sequence[int]) -> str:
  lines = table.lines if table.lines is not None else np.arange(len(table.data)) + 1
  shown = ", ".join(str(int(lines[r])) for r in list(rows)[:SHOWN])
  more = f" and {len(rows) - SHOWN} more" if len(rows) > SHOWN else ""
  return f"line {shown}{more}"


def _periods(tables, inputs, steps: Steps) -> np.ndarray:
  """(C,) the wrap-around periods: given, or 2**bits times each channel's smallest step.
  A period no longer than the channel's observed range cannot be its register's (a wrapped
  register's values stay within one period): its smallest step is then no bit (values off a
  grid: scaled, filtered, noisy), and unwrapping would undo noise; refused, naming it."""
  every = np.vstack([t.data[:, inputs] for t in tables])
  names = tables[0].names
  out = []
  for c in range(len(inputs)):
    period = steps.unwrap_period if steps.unwrap_period is not None else \
        2.0 ** steps.unwrap_bits * lsb(every[:, c])
    span = float(np.ptp(every[:, c]))
    if period <= span:
      how = (f"--unwrap-period {period:g}" if steps.unwrap_period is not None else
             f"--unwrap {steps.unwrap_bits} makes its period {period:g} (2**"
             f"{steps.unwrap_bits} x its smallest step {lsb(every[:, c]):g}), which")
      raise errors.SettingError(
          f"{names[inputs[c]]}: {how} is no longer than the range its values span "
          f"({span:g}), so it is not the register's period"
          + ("" if steps.unwrap_period is not None else
             ": its values are not on one grid of a bit; give the period itself "
             "(--unwrap-period, in the inputs' units)"))
    out.append(period)
  return np.array(out)


TARE_SPREAD = 0.05  # of a column's range: more spread over the "unloaded" rows is a load


def _tare_said(table, tare: Tare, rows, x, y, names) -> list[str]:
  """A warning when the rows the tare takes as unloaded are not at rest: a column (input or
  target) spanning over `TARE_SPREAD` of its range there (its 5-95 % spread, against its
  1-99 % one over the recording) was loaded, and its median there, taken as zero, carries
  that load into every row."""
  values = x if y is None else np.hstack([x, y])
  lo, hi = np.percentile(values[rows], [5, 95], axis=0)
  full = np.ptp(np.percentile(values, [1, 99], axis=0), axis=0)
  share = np.where(full > 0, (hi - lo) / np.where(full > 0, full, 1.0), 0.0)
  j = int(np.argmax(share))
  if share[j] <= TARE_SPREAD:
    return []
  at = values[rows, j]
  return [f"warning: {table.path}: {tare.describe()} are not at rest: {names[j]} spans "
          f"{at.min():.4g} to {at.max():.4g} there ({share[j]:.0%} of its range), and the "
          f"tare takes its median, {np.median(at):.4g}, as zero in every row; give a window "
          f"where nothing touches the sensor (--tare SECONDS) or a contact flag "
          f"(--tare-column FLAG)"]


def _record(tables, inputs, steps: Steps, periods, said: list[str]) -> dict:
  """What the estimator keeps of the preparation, for `predict`, `evaluate` and the C."""
  raw = np.vstack([t.data[:, inputs] for t in tables])
  times = [t.seconds(steps.tare.time_column if steps.tare else "time") for t in tables]
  steps_s = [np.diff(t) for t in times if t is not None and len(t) > 1]
  record = {"unwrap_periods": None if periods is None else [float(p) for p in periods],
            "tare": None if steps.tare is None else steps.tare.to_json(),
            # what the C export takes when it tares the raw inputs itself
            "raw_integer_inputs": integer_counts(raw),
            "sample_rate": float(1 / np.median(np.concatenate(steps_s))) if steps_s else None,
            "steps": list(said)}
  return record


def _jumps_said(table, x: np.ndarray, y, names: list[str], periods) -> list[str]:
  """One line for the recording: the channels with one-sample jumps over half their
  register (with periods, which are undone) or over 3/4 of their range (a wrap-around,
  perhaps), each with its count and first lines."""
  per = {}
  for row, c in (jumps(x, periods / 2) if periods is not None else wrap_like(x, y)):
    per.setdefault(c, []).append(row)
  if not per:
    return []
  size = "half its register" if periods is not None else "3/4 of its range"
  found = "; ".join(f"{names[c]} {len(rows)} ({_where(table, rows)})"
                    for c, rows in per.items())
  return [f"{table.path}: one-sample jumps over {size}: {found}"
          + (" (undone)" if periods is not None else
             ": register wrap-around? --unwrap BITS or --unwrap-period undoes them")]


def _rails_said(table, rail: np.ndarray, names: list[str], dropped: bool) -> list[str]:
  """One line for the recording: the channels at a rail, each with its share of samples."""
  hit = np.flatnonzero(rail.any(axis=0))
  if not hit.size:
    return []
  shares = ", ".join(f"{names[c]} {rail[:, c].sum()} of {len(rail)} samples "
                     f"({rail[:, c].mean():.1%})" for c in hit)
  return [f"{table.path}: at a rail: {shares}"
          + (" (dropped)" if dropped else ": --drop-rails removes them")]


def _read(tables, inputs, targets, periods) -> tuple[list[str], list, np.ndarray]:
  """(the jump lines, each recording's (inputs unwrapped, targets or None), (C + A,) the
  columns' ranges over every recording)."""
  names = tables[0].names
  said, read = [], []
  for table in tables:
    x = table.data[:, inputs]
    y = None if targets is None else table.data[:, targets]
    said += _jumps_said(table, x, y, [names[i] for i in inputs], periods)
    read.append((unwrap(x, periods)[0] if periods is not None else x, y))
  every = [x if y is None else np.column_stack([x, y]) for x, y in read]
  return said, read, (np.max([e.max(axis=0) for e in every], axis=0)
                      - np.min([e.min(axis=0) for e in every], axis=0))


def apply(tables, inputs: Sequence[int], targets: Optional[Sequence[int]], steps: Steps,
          periods: Optional[np.ndarray] = None, spans: Optional[np.ndarray] = None
          ) -> Prepared:
  """Runs the steps on each recording (a `csvfile.Table` each) and stacks them.

  Args:
    inputs, targets: column indices (targets None: inputs only, as for `predict`).
    periods: (C,) the unwrap periods an estimator kept (None: 2**unwrap_bits times each
      channel's least significant bit in these recordings).
    spans: (C + A,) ranges the columns are known to span (an estimator's training ranges),
      against which the rail detector measures a load moving, when wider than these
      recordings' own (`at_rails`).
  """
  names = tables[0].names
  xs, ys, recs, kept = [], [], [], []
  start = 0
  if (steps.unwrap_bits is not None or steps.unwrap_period is not None) and periods is None:
    periods = _periods(tables, inputs, steps)
  said, read, seen = _read(tables, inputs, targets, periods)
  # a load moves against the columns' ranges over every recording (`at_rails`)
  spans = seen if spans is None else np.maximum(seen, spans)
  for k, (table, (x, y)) in enumerate(zip(tables, read)):
    keep = np.ones(len(x), bool)
    rail = at_rails(x, steps.rails, y, spans)
    said += _rails_said(table, rail, [names[i] for i in inputs], steps.drop_rails)
    if steps.drop_rails:
      keep &= ~rail.any(axis=1)
    if steps.tare is not None:
      rows = steps.tare.rows(table, table.path)
      said += _tare_said(table, steps.tare, rows, x, y,
                         [names[i] for i in inputs] + [names[i] for i in targets or ()])
      x = x - np.median(x[rows], axis=0)
      if y is not None:
        y = y - np.median(y[rows], axis=0)
    if not keep.any():
      raise errors.DataError(f"{table.path}: every row has an input at a rail: nothing left "
                             f"to fit (check --rails)")
    xs.append(x[keep])
    ys.append(None if y is None else y[keep])
    recs.append(np.full(int(keep.sum()), k))
    kept.append(start + np.flatnonzero(keep))
    start += len(keep)
  dropped = sum(len(t.data) for t in tables) - sum(len(x) for x in xs)
  if steps.drop_rails:
    said.append(f"rails: {dropped} row(s) with an input at a rail dropped")
  if periods is not None:
    said.append("unwrap: period " + ", ".join(f"{names[i]} {p:g}" for i, p in
                                               zip(inputs, periods)))
  if steps.tare is not None:
    said.append(f"tare: each input and target less its median over {steps.tare.describe()}")
  record = _record(tables, inputs, steps, periods, said)
  return Prepared(np.vstack(xs), None if targets is None else np.vstack(ys),
                  np.concatenate(recs), np.concatenate(kept), tuple(said), record)
