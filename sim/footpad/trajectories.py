"""CNC trajectories of the LSANN paper (Sec. III-B, III-C, Fig. 6), sampled at the step rate,
and users' own paths.

Every paper path is an XY route that starts and ends at the origin, run at one Z indentation
at a constant feed; an episode adds the approach from just above first touch and the retreat.
`z_press` is the exception: presses straight down to a depth and back, repeated. A user's
path (`read_path`: a CSV of waypoints or a G0/G1 G-code file) runs as written
(`waypoint_episode`).
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Literal

import numpy as np

from util import errors

STROKE = 0.003  # m, the paper's 3 mm strokes
APPROACH_HEIGHT = 1e-4  # m above first touch where an episode starts and ends


def _line(a, b) -> list[np.ndarray]:
  return [np.asarray(a, float), np.asarray(b, float)]


def _circle(centre, start, sign: int, n: int = 180) -> list[np.ndarray]:
  """Full circle from `start` around `centre`; sign +1 counter-clockwise, -1 clockwise."""
  c = np.asarray(centre, float)
  r0 = np.asarray(start, float) - c
  a0 = np.arctan2(r0[1], r0[0])
  rad = np.hypot(*r0)
  ang = a0 + sign * np.linspace(0, 2 * np.pi, n + 1)
  return list(c + rad * np.stack([np.cos(ang), np.sin(ang)], axis=1))


def _out_and_back(angle_deg: float, length: float = STROKE) -> list[np.ndarray]:
  a = np.deg2rad(angle_deg)
  return _line((0, 0), (length * np.cos(a), length * np.sin(a))) + [np.zeros(2)]


def _route(name: str, repeats: int) -> list[np.ndarray]:
  pts: list[np.ndarray] = [np.zeros(2)]
  if name == "x_stroke":
    for _ in range(repeats):
      pts += [np.array([STROKE, 0]), np.array([-STROKE, 0]), np.zeros(2)]
  elif name == "y_stroke":
    for _ in range(repeats):
      pts += [np.array([0, STROKE]), np.array([0, -STROKE]), np.zeros(2)]
  elif name == "asterisk":
    for ang in range(0, 360, 45):
      pts += _out_and_back(ang)[1:]
  elif name == "circular":
    for d in (0.002, 0.004, 0.006):
      r = d / 2
      pts += [np.array([r, 0.0])]
      pts += _circle((0, 0), (r, 0), -1)[1:]
      pts += _circle((0, 0), (r, 0), +1)[1:]
      pts += [np.zeros(2)]
  elif name == "test_path_1":
    for ang in (0, 180, 90, 270):
      pts += _out_and_back(ang)[1:]
    r = 0.003
    pts += [np.array([r, 0.0])] + _circle((0, 0), (r, 0), -1)[1:] + _circle((0, 0), (r, 0), 1)[1:]
    pts += [np.zeros(2)]
  elif name == "test_path_2":
    for ang in (45, 135, 225, 315):
      pts += _out_and_back(ang)[1:]
    for c in ((0.0015, 0), (-0.0015, 0), (0, 0.0015), (0, -0.0015)):
      pts += _circle(c, (0, 0), 1)[1:]
  elif name == "square":  # none of the paper's: a 4 mm square corner to corner, then its
    for _ in range(repeats):  # diagonals, for generalisation at untrained depths
      pts += [np.array(c, float) for c in ((0.002, 0.002), (-0.002, 0.002), (-0.002, -0.002),
                                           (0.002, -0.002), (0.002, 0.002), (-0.002, -0.002),
                                           (0, 0))]
  else:
    raise errors.SettingError(f"unknown path {name!r}: allowed {', '.join(PATHS)}")
  return pts


PATHS = ("z_press", "x_stroke", "y_stroke", "asterisk", "circular", "test_path_1",
         "test_path_2", "square")
PathName = Literal[PATHS]  # what a scene's `paths` field takes


def _resample(points: np.ndarray, step: float) -> np.ndarray:
  """Points spaced `step` apart in arc length along a polyline (ends included)."""
  seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
  s = np.concatenate([[0.0], np.cumsum(seg)])
  n = max(int(np.ceil(s[-1] / step)), 1)
  t = np.linspace(0.0, s[-1], n + 1)
  return np.stack([np.interp(t, s, points[:, i]) for i in range(points.shape[1])], axis=1)


@dataclasses.dataclass(frozen=True)
class Episode:
  """One continuous CNC run.

  Attributes:
    path: path name.
    z_level: nominal indentation, m (positive into the plate).
    target: (T, 3) CNC position commands per step, m (z negative = pressing).
    phase: (T,) 0 approach/retreat, 1 on the path at z_level.
  """
  path: str
  z_level: float
  target: np.ndarray
  phase: np.ndarray


def episode(path: str, z_level: float, feed: float, dt: float, repeats: int = 10) -> Episode:
  """The CNC commands of one path at one indentation.

  Args:
    path: one of PATHS.
    z_level: indentation, m (for z_press: the press depth).
    feed: feed rate, m/s.
    dt: sample period, s.
    repeats: presses for z_press; back-and-forth strokes for x_stroke / y_stroke.
  """
  step = feed * dt
  z_path = np.array([[APPROACH_HEIGHT], [-z_level]])
  down = _resample(z_path, step)[:, 0]
  up = down[::-1]
  if path == "z_press":
    one = np.concatenate([down, up[1:]])
    z = np.concatenate([one] + [one[1:]] * (repeats - 1))
    target = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    phase = (z < 0).astype(np.int8)
    return Episode(path, z_level, target, phase)
  xy = _resample(np.array(_route(path, repeats)), step)
  hold = int(round(0.05 / dt))  # 50 ms to settle at each end of the press
  parts = [np.column_stack([np.zeros((len(down), 2)), down]),
           np.column_stack([np.zeros((hold, 2)), np.full(hold, -z_level)]),
           np.column_stack([xy, np.full(len(xy), -z_level)]),
           np.column_stack([np.zeros((len(up), 2)), up])]
  phase = np.concatenate([np.zeros(len(down) + hold), np.ones(len(xy)), np.zeros(len(up))])
  return Episode(path, z_level, np.concatenate(parts), phase.astype(np.int8))


@dataclasses.dataclass(frozen=True)
class Waypoints:
  """A user's CNC path: straight moves through `points` (K, 3), m, in the rig's frame (x, y
  on the plate; z = 0 at first touch, negative pressing into the plate), each move at its
  feed `feeds` (K,), m/s (the first row is the start: its feed is unused)."""
  points: np.ndarray
  feeds: np.ndarray
  name: str


def read_path(path: str) -> Waypoints:
  """Reads a path file: CSV rows `x, y, z, feed` in mm and mm/s (a header row of names, and
  `#` comments, are skipped), or G-code (`.gcode`, `.nc`, `.ngc`: G0/G1 moves with X Y Z in
  mm and F in mm/min, modal as G-code is; G0 at `RAPID`; G21 millimetres only; the
  machine starts at the origin).

  Raises:
    errors.DataError naming the file, the line and the column that cannot be read.
  """
  file = pathlib.Path(path)
  try:
    lines = file.read_text().splitlines()
  except (OSError, UnicodeDecodeError) as err:
    raise errors.DataError(f"path file {file}: cannot be read ({err})") from None
  if file.suffix.lower() in (".gcode", ".nc", ".ngc"):
    rows = _gcode_rows(file, lines)
  else:
    rows = _csv_rows(file, lines)
  if len(rows) < 2:
    raise errors.DataError(f"path file {file}: needs at least two waypoints, found {len(rows)}")
  a = np.array(rows, dtype=float)
  points, feeds = a[:, :3] * 1e-3, a[:, 3] * 1e-3
  if np.any(feeds[1:] <= 0):
    k = int(np.flatnonzero(feeds[1:] <= 0)[0]) + 1
    raise errors.DataError(f"path file {file}: waypoint {k + 1} has feed {a[k, 3]:g}: "
                           f"a move needs a feed > 0")
  return Waypoints(points, feeds, f"custom:{file.name}")


_COLUMNS = ("x", "y", "z", "feed")
RAPID = 0.01  # m/s: G0 moves run at this feed (a CNC's rapids would shake the soft pad)


def _csv_rows(file: pathlib.Path, lines: list[str]) -> list[list[float]]:
  rows = []
  for n, line in enumerate(lines, 1):
    text = line.split("#")[0].strip()
    if not text:
      continue
    cells = [c.strip() for c in text.split(",")]
    if not rows and cells and not _is_number(cells[0]):
      continue  # the header
    if len(cells) != 4:
      raise errors.DataError(f"path file {file}, line {n}: {len(cells)} columns; expected x, "
                             f"y, z (mm), feed (mm/s)")
    for name, cell in zip(_COLUMNS, cells):
      if not _is_number(cell):
        raise errors.DataError(f"path file {file}, line {n}, column {name}: {cell!r} is not "
                               f"a number")
    rows.append([float(c) for c in cells])
  return rows


def _gcode_rows(file: pathlib.Path, lines: list[str]) -> list[list[float]]:
  x = y = z = 0.0
  feed = None
  rows = [[x, y, z, 0.0]]
  for n, line in enumerate(lines, 1):
    text = line.split(";")[0].split("(")[0].strip().upper()
    if not text:
      continue
    words = text.split()
    code = words[0]
    if code in ("G20",):
      raise errors.DataError(f"path file {file}, line {n}: G20 (inches) is not supported: "
                             f"write the path in millimetres (G21)")
    if code not in ("G0", "G00", "G1", "G01"):
      continue  # units, plane and spindle words carry no motion
    values = {}
    for w in words[1:]:
      if w[0] not in "XYZF" or not _is_number(w[1:]):
        raise errors.DataError(f"path file {file}, line {n}: {w!r} is not one of X, Y, Z, F "
                               f"followed by a number")
      values[w[0]] = float(w[1:])
    x, y, z = values.get("X", x), values.get("Y", y), values.get("Z", z)
    feed = values.get("F", feed)
    if code in ("G0", "G00"):
      rows.append([x, y, z, RAPID * 1e3])
      continue
    if feed is None:
      raise errors.DataError(f"path file {file}, line {n}: a G1 move before any feed "
                             f"(F, mm/min)")
    rows.append([x, y, z, feed / 60.0])
  return rows


def _is_number(text: str) -> bool:
  try:
    return np.isfinite(float(text))
  except ValueError:
    return False


def waypoint_episode(waypoints: Waypoints, dt: float) -> Episode:
  """The CNC commands of a user's path: each move resampled at its feed; phase 1 where the
  command presses into the plate (z < 0); the episode's z_level is its deepest press."""
  parts = [waypoints.points[:1]]
  for k in range(1, len(waypoints.points)):
    seg = _resample(waypoints.points[k - 1:k + 1], waypoints.feeds[k] * dt)
    parts.append(seg[1:])
  target = np.concatenate(parts)
  phase = (target[:, 2] < 0).astype(np.int8)
  return Episode(waypoints.name, float(max(-target[:, 2].min(), 0.0)), target, phase)

