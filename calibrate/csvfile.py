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
  """
  names: tuple[str, ...]
  units: tuple[str, ...]
  data: np.ndarray
  path: str = ""

  def columns(self, patterns: Sequence[str], what: str) -> list[int]:
    """Indices of the columns named by `patterns` (names or shell-style globs such as
    `p*`), in the order given.

    Raises:
      errors.SettingError naming `what` (e.g. "--inputs") and the columns the file has.
    """
    if not patterns:
      raise errors.SettingError(f"{what} names no column: give names or globs of "
                                f"{self.path}'s columns ({', '.join(self.names)})")
    out = []
    for pattern in patterns:
      hits = [i for i, n in enumerate(self.names) if fnmatch.fnmatchcase(n, pattern)]
      if not hits:
        raise errors.SettingError(
            f"{what}: {self.path} has no column {pattern!r}; its columns are "
            f"{', '.join(self.names)}")
      out += [i for i in hits if i not in out]
    return out

  def column(self, name: str) -> Optional[np.ndarray]:
    return self.data[:, self.names.index(name)] if name in self.names else None


def read_many(paths: Sequence, time_column: str = "time") -> tuple[Table, np.ndarray]:
  """Reads several recordings with the same columns as one table, and (N,) the index of the
  file each row came from (a path holding *, ? or [ is a glob, expanded in sorted order).

  Raises:
    errors.DataError naming the file that matches nothing or whose columns differ.
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
  expanded = list(dict.fromkeys(expanded))  # a file named twice is one recording
  tables = [read(p, time_column) for p in expanded]
  first = tables[0]
  for t in tables[1:]:
    if t.names != first.names:
      raise errors.DataError(f"{t.path}: its columns ({', '.join(t.names)}) differ from "
                             f"{first.path}'s ({', '.join(first.names)}): recordings fitted "
                             f"together need the same columns")
  labels = np.concatenate([np.full(len(t.data), k) for k, t in enumerate(tables)])
  path = first.path if len(tables) == 1 else f"{len(tables)} recordings ({first.path}, ...)"
  return Table(first.names, first.units, np.vstack([t.data for t in tables]), path), labels


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


def read(path, time_column: str = "time") -> Table:
  """Reads and checks a CSV file in the layout above.

  Raises:
    errors.DataError naming the file, line and column of the first problem.
  """
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
  if not rows:
    raise errors.DataError(f"{path}: no data rows after the header")
  try:  # all at once in C; the row-by-row pass below only finds what is wrong
    data = np.loadtxt([physical[k] for k in rows], delimiter=",", dtype=np.float64, ndmin=2)
    bad = data.shape != (len(rows), len(names)) or not np.isfinite(data).all()
  except ValueError:
    bad = True
  if bad:
    for k in rows:
      row = cells(k)
      if len(row) != len(names):
        raise errors.DataError(f"{path} line {k + 1}: {len(row)} cells for {len(names)} "
                               f"columns")
      for c, cell in enumerate(row):
        value = _number(cell)
        if value is None or not np.isfinite(value):
          why = ("is empty" if not cell else f"{cell!r} is not a finite number")
          raise errors.DataError(f"{path} line {k + 1}, column {names[c]!r}: {why}")
    # every cell is a number after all (quoted cells, say): read them one by one
    data = np.array([[float(c) for c in cells(k)] for k in rows], dtype=np.float64)
  table = Table(tuple(names), tuple(units), data, str(path))
  t = table.column(time_column)
  if t is not None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
      line = rows[bad[0] + 1] + 1
      raise errors.DataError(
          f"{path} line {line}, column {time_column!r}: time {t[bad[0] + 1]:g} does not "
          f"increase (previous row {t[bad[0]]:g})")
  return table


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
