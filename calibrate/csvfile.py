"""Recordings from real rigs as CSV: read, checked, written.

The layout (`python -m calibrate --help` prints it):

* line 1: column names, comma-separated (e.g. `time,p1,p2,p3,p4,p5,p6,Fx,Fy,Fz`);
* optionally line 2: units, one per column (`s,counts,...,N`): a row with no number in it;
* then one row per sample, every cell a number; lines starting with `#` are comments;
* a time column (by default the one named `time`), when present, must increase.
* several files (recordings) may be given together: the same columns in each; the time may
  start again in every file.

Every problem is one `errors.DataError` naming the file, the line and the column: a missing
column, an empty cell, NaN or inf, text where a number belongs, time going backwards.
"""

from __future__ import annotations

import csv
import dataclasses
import fnmatch
import io
import pathlib
from typing import Optional, Sequence

import numpy as np

from util import errors, files


@dataclasses.dataclass(frozen=True)
class Table:
  """The numbers of a CSV file.

  Attributes:
    names: (K,) column names.  units: (K,) units ("" where the file gives none).
    data: (N, K) float64.
    path: where it was read from.
    lines: (N,) the file line of every row (1-based), for messages; None when not from a file.
    cleaned: what reading removed, one line each ("3 rows with an empty cell dropped").
  """
  names: tuple[str, ...]
  units: tuple[str, ...]
  data: np.ndarray
  path: str = ""
  lines: Optional[np.ndarray] = None
  cleaned: tuple[str, ...] = ()

  def columns(self, patterns: Sequence[str], what: str) -> list[int]:
    """Indices of the columns named by `patterns` (names or shell-style globs such as
    `p*`), in the order given. A pattern that is a column's whole name is that column, so
    names holding glob characters (`F_x [N]`, with its unit) are read as they are.

    Raises:
      errors.SettingError naming `what` (e.g. "--inputs") and the columns the file has.
    """
    if not patterns:
      raise errors.SettingError(f"{what} names no column: give names or globs of "
                                f"{self.path}'s columns ({', '.join(self.names)})")
    out = []
    for pattern in patterns:
      hits = [self.names.index(pattern)] if pattern in self.names else \
          [i for i, n in enumerate(self.names) if fnmatch.fnmatchcase(n, pattern)]
      if not hits:
        raise errors.SettingError(
            f"{what}: {self.path} has no column {pattern!r}; its columns are "
            f"{', '.join(self.names)}")
      out += [i for i in hits if i not in out]
    return out

  def column(self, name: str) -> Optional[np.ndarray]:
    return self.data[:, self.names.index(name)] if name in self.names else None

  def seconds(self, name: str) -> Optional[np.ndarray]:
    """The time column `name` in seconds, read by the unit its units row gives it (none:
    seconds); None without the column.

    Raises:
      errors.DataError naming the file, the column and its unit when the unit is not one of
      `TIME_UNITS`.
    """
    t = self.column(name)
    if t is None:
      return None
    unit = self.units[self.names.index(name)].strip()
    if unit not in TIME_UNITS:
      raise errors.DataError(
          f"{self.path}: the time column {name!r} is in {unit!r}, a unit this reader does "
          f"not know: allowed {', '.join(u for u in TIME_UNITS if u)} (or no unit: seconds)")
    return t * TIME_UNITS[unit]


# a time column's units row, to seconds
TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "seconds": 1.0, "ms": 1e-3, "us": 1e-6,
              "\u00b5s": 1e-6, "\u03bcs": 1e-6, "ns": 1e-9, "min": 60.0}


def expand(paths: Sequence) -> list[str]:
  """The files named by `paths`, a path holding *, ? or [ read as a glob (sorted); a file
  named twice is one recording.

  Raises:
    errors.DataError naming the glob that matches nothing.
  """
  import glob
  expanded = []
  for p in paths:
    text = str(p)
    if any(ch in text for ch in "*?[") and not pathlib.Path(text).exists():
      hits = sorted(glob.glob(text))
      if not hits:
        raise errors.DataError(f"--csv {text}: no file matches")
      expanded += hits
    else:
      expanded.append(text)
  return list(dict.fromkeys(expanded))


def read_many(paths: Sequence, time_column: str = "time", **cleaning
              ) -> tuple[list[Table], Table, np.ndarray]:
  """Reads several recordings with the same columns: (each file's table, all of them as one
  table, (N,) the index of the file each row came from). `paths` as `expand` takes them;
  `cleaning` goes to `read`.

  Raises:
    errors.DataError naming the file that matches nothing or whose columns differ.
  """
  expanded = expand(paths)
  tables = [read(p, time_column, **cleaning) for p in expanded]
  first = tables[0]
  for t in tables[1:]:
    if t.names != first.names:
      raise errors.DataError(f"{t.path}: its columns ({', '.join(t.names)}) differ from "
                             f"{first.path}'s ({', '.join(first.names)}): recordings fitted "
                             f"together need the same columns")
  tables = _same_units(tables, time_column)
  first = tables[0]
  labels = np.concatenate([np.full(len(t.data), k) for k, t in enumerate(tables)])
  path = first.path if len(tables) == 1 else f"{len(tables)} recordings ({first.path}, ...)"
  return tables, Table(first.names, first.units, np.vstack([t.data for t in tables]), path,
                       np.concatenate([t.lines for t in tables]),
                       tuple(f"{t.path}: {c}" for t in tables for c in t.cleaned)), labels


def _same_units(tables: list[Table], time_column: str) -> list[Table]:
  """`tables` whose units rows agree: a time column in other units is read in seconds (each
  by its own); any other column whose units two files give differently is refused, since
  counts beside volts or N beside kN would be fitted as one quantity."""
  first = tables[0]
  for t in tables[1:]:
    for name, a, b in zip(t.names, first.units, t.units):
      if name != time_column and a and b and a != b:
        raise errors.DataError(
            f"{t.path}: its column {name!r} is in {b!r}, {first.path}'s in {a!r}: recordings "
            f"fitted together need one unit per column (convert one file, or fit them apart)")
  if time_column in first.names and len({t.units[t.names.index(time_column)]
                                          for t in tables}) > 1:
    k = first.names.index(time_column)
    out = []
    for t in tables:
      data = t.data.copy()
      data[:, k] = t.seconds(time_column)
      out.append(dataclasses.replace(t, data=data, units=t.units[:k] + ("s",)
                                     + t.units[k + 1:]))
    return out
  return tables


def _number(cell: str) -> Optional[float]:
  try:
    return float(cell)
  except ValueError:
    return None


def _check_units_row(path, line: int, names, row: list[str]) -> None:
  """A second row mostly of words is a units row: a number in it is named as such, not read
  as data (which would blame the next word)."""
  words = [c for c in row if c and _number(c) is None]
  numbers = [k for k, c in enumerate(row) if _number(c) is not None]
  if numbers and len(words) > len(row) / 2:
    k = numbers[0]
    column = names[k] if k < len(names) else f"#{k + 1}"
    raise errors.DataError(f"{path} line {line}, column {column!r}: {row[k]!r} in what reads "
                           f"as the units row (its other cells are words): a unit is a word "
                           f"such as N or counts; leave it empty if there is none")


DEDUPE = ("mean", "first")


def read(path, time_column: str = "time", drop_nan: bool = False,
         dedupe: Optional[str] = None) -> Table:
  """Reads and checks a CSV file in the layout above.

  Args:
    drop_nan: drop rows with an empty cell or NaN (counted in `Table.cleaned`) instead of
      refusing the file; text where a number belongs is refused either way.
    dedupe: rows with a repeated time: "mean" averages them into one, "first" keeps the
      first (counted); None refuses the file.
  Raises:
    errors.DataError naming the file, line and column of the first problem.
  """
  if dedupe is not None and dedupe not in DEDUPE:
    raise errors.unknown("--dedupe", dedupe, DEDUPE)
  path = pathlib.Path(path)
  try:
    text = path.read_text(encoding="utf-8-sig")  # a byte-order mark is not a name
  except (OSError, UnicodeDecodeError) as err:
    raise errors.DataError(f"{path}: cannot be read ({err})") from None
  physical = text.splitlines()
  kept = [k for k, line in enumerate(physical)
          if line.strip() and not line.lstrip().startswith("#")]
  if not kept:
    raise errors.DataError(f"{path}: empty (expected a header row of column names)")

  def cells(k: int) -> list[str]:
    return [c.strip() for c in next(csv.reader([physical[k]]))]
  names, units, rows = _header(path, kept, cells)
  if not rows:
    raise errors.DataError(f"{path}: no data rows after the header")
  try:  # all at once in C; the row-by-row pass below only finds what is wrong
    data = np.loadtxt([physical[k] for k in rows], delimiter=",", dtype=np.float64, ndmin=2)
    bad = data.shape != (len(rows), len(names)) or not np.isfinite(data).all()
  except ValueError:
    bad = True
  cleaned = []
  if bad:
    rows, data, cleaned = _checked_rows(path, rows, names, cells, drop_nan)
  lines = np.asarray(rows) + 1
  t = data[:, names.index(time_column)] if time_column in names else None
  if t is not None:
    data, lines, note = _repeated_times(path, data, lines, names.index(time_column), dedupe)
    cleaned += note
    t = data[:, names.index(time_column)]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
      raise errors.DataError(
          f"{path} line {lines[bad[0] + 1]}, column {time_column!r}: time "
          f"{t[bad[0] + 1]:g} does not increase (previous row {t[bad[0]]:g})")
  return Table(tuple(names), tuple(units), data, str(path), lines, tuple(cleaned))


def _header(path, kept: list[int], cells):
  """(names, units, the data rows' line indices) from the first kept lines: a row of
  names, then optionally a row of units (one with no number in it)."""
  names = cells(kept[0])
  if any(_number(n) is not None for n in names) or len(set(names)) != len(names) or \
     not all(names):
    raise errors.DataError(
        f"{path} line {kept[0] + 1}: the first row must name every column, once each "
        f"(got {', '.join(names) or 'nothing'})")
  units, rows = [""] * len(names), kept[1:]
  if rows:
    _check_units_row(path, rows[0] + 1, names, cells(rows[0]))
  if rows and all(_number(c) is None for c in cells(rows[0])):
    units = cells(rows[0])
    if len(units) != len(names):
      raise errors.DataError(f"{path} line {rows[0] + 1}: {len(units)} units for "
                             f"{len(names)} columns")
    rows = rows[1:]
  return names, units, rows


def _checked_rows(path, rows: list[int], names: list[str], cells, drop_nan: bool):
  """(rows kept, their data, what was dropped) read cell by cell: the first cell that is
  not a finite number is refused by line and column, or with `drop_nan` an empty or NaN
  cell drops its row."""
  cleaned, kept_rows, dropped = [], [], 0
  for k in rows:
    row = cells(k)
    if len(row) != len(names):
      raise errors.DataError(f"{path} line {k + 1}: {len(row)} cells for {len(names)} "
                             f"columns")
    missing = False
    for c, cell in enumerate(row):
      value = _number(cell)
      if drop_nan and (not cell or (value is not None and np.isnan(value))):
        missing = True
        continue
      if value is None or not np.isfinite(value):
        why = ("is empty" if not cell else f"{cell!r} is not a finite number")
        hint = " (--drop-nan drops such rows, counted)" if not cell or cell.lower() == \
            "nan" else ""
        raise errors.DataError(f"{path} line {k + 1}, column {names[c]!r}: {why}{hint}")
    if missing:
      dropped += 1
    else:
      kept_rows.append(k)
  if not kept_rows:
    raise errors.DataError(f"{path}: every data row has an empty cell or NaN")
  if dropped:
    cleaned.append(f"{dropped} row(s) with an empty cell or NaN dropped")
  # every cell is a number after all (quoted cells, say): read them one by one
  data = np.array([[float(c) for c in cells(k)] for k in kept_rows], dtype=np.float64)
  return kept_rows, data, cleaned


def _repeated_times(path, data: np.ndarray, lines: np.ndarray, col: int,
                    dedupe: Optional[str]) -> tuple[np.ndarray, np.ndarray, list[str]]:
  """Rows whose time repeats the previous row's: merged by `dedupe`, or refused."""
  same = np.flatnonzero(np.diff(data[:, col]) == 0) + 1  # rows repeating the one before
  if not same.size:
    return data, lines, []
  if dedupe is None:
    k = same[0]
    raise errors.DataError(f"{path} line {lines[k]}: time {data[k, col]:g} repeats the "
                           f"previous row's ({same.size} repeated in all; --dedupe mean or "
                           f"--dedupe first merges them, counted)")
  start = np.ones(len(data), bool)
  start[same] = False
  run = np.cumsum(start) - 1  # the run of equal times each row belongs to
  if dedupe == "first":
    merged = data[start]
  else:
    merged = np.zeros((run[-1] + 1, data.shape[1]))
    np.add.at(merged, run, data)
    merged /= np.bincount(run)[:, None]
  word = "averaged" if dedupe == "mean" else "dropped (the first kept)"
  return merged, lines[start], [f"{same.size} row(s) repeating a time {word}"]


def write(path, names: Sequence[str], data: np.ndarray,
          units: Optional[Sequence[str]] = None) -> pathlib.Path:
  """Writes (N, K) numbers under `names` (and a units row), atomically; floats in full
  precision (repr), so a round trip gives the same bytes of float64."""
  data = np.asarray(data, float)
  if data.ndim != 2 or data.shape[1] != len(names):
    raise ValueError(f"{data.shape} data for {len(names)} names")
  buf = io.StringIO()
  writer = csv.writer(buf, lineterminator="\n")
  writer.writerow(names)
  if units is not None:
    writer.writerow(units)
  for row in data:
    writer.writerow([repr(float(v)) for v in row])
  path = pathlib.Path(path)
  files.write_text(path, buf.getvalue())
  return path
