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
import re
from typing import Literal, Optional

import numpy as np

from util import errors

STROKE = 0.003  # m, the paper's 3 mm paths (Asterisk, Testing Paths; Sec. III-C)
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


def _route(name: str, repeats: int, stroke: float = STROKE) -> list[np.ndarray]:
  pts: list[np.ndarray] = [np.zeros(2)]
  if name == "x_stroke":
    for _ in range(repeats):
      pts += [np.array([stroke, 0]), np.array([-stroke, 0]), np.zeros(2)]
  elif name == "y_stroke":
    for _ in range(repeats):
      pts += [np.array([0, stroke]), np.array([0, -stroke]), np.zeros(2)]
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
    # diagonals, once, for generalisation at untrained depths
    pts += [np.array(c, float) for c in ((0.002, 0.002), (-0.002, 0.002), (-0.002, -0.002),
                                         (0.002, -0.002), (0.002, 0.002), (-0.002, -0.002),
                                         (0, 0))]
  elif name == "lissajous":  # none of the paper's: a 3:2 Lissajous figure, +-2.5 mm, once
    t = np.linspace(0, 2 * np.pi, 361)[1:]
    pts += list(np.column_stack([0.0025 * np.sin(3 * t), 0.0025 * np.sin(2 * t)]))
  elif name == "spiral":  # none of the paper's: three turns out to 3 mm, straight back, once
    t = np.linspace(0, 6 * np.pi, 541)[1:]
    r = STROKE * t / t[-1]
    pts += list(np.column_stack([r * np.cos(t), r * np.sin(t)])) + [np.zeros(2)]
  else:
    raise errors.SettingError(f"unknown path {name!r}: allowed {', '.join(PATHS)}")
  return pts


PATHS = ("z_press", "x_stroke", "y_stroke", "asterisk", "circular", "test_path_1",
         "test_path_2", "square", "lissajous", "spiral")
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


def episode(path: str, z_level: float, feed: float, dt: float, repeats: int = 10,
            stroke: float = STROKE) -> Episode:
  """The CNC commands of one path at one indentation.

  Args:
    path: one of PATHS.
    z_level: indentation, m (for z_press: the press depth).
    feed: feed rate, m/s.
    dt: sample period, s.
    repeats: presses for z_press; back-and-forth strokes for x_stroke / y_stroke.
    stroke: amplitude of x_stroke / y_stroke, m (the other paths' sizes are the paper's).
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
  xy = _resample(np.array(_route(path, repeats, stroke)), step)
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
  feed `feeds` (K,), m/s (the first row is the start: its feed is unused), the machine then
  holding still at the point for `holds` (K,) s (a G4 dwell; None: no holds)."""
  points: np.ndarray
  feeds: np.ndarray
  name: str
  holds: Optional[np.ndarray] = None


MIN_FEED = 0.1  # mm/s: slower asks for hours of 1 kHz samples per millimetre
MAX_SECONDS = 3600.0  # s: the longest path a run simulates (3.6 M samples at 1 kHz)
MAX_WAYPOINTS = 100_000  # a path's waypoints (each move takes one time step at least)


def read_path(path: str) -> Waypoints:
  """Reads a path file: CSV rows `x, y, z, feed` in mm and mm/s (a header row of names, and
  `#` comments, are skipped), or G-code (`.gcode`, `.nc`, `.ngc`; see `_gcode_rows` for the
  words it honours and refuses). Every feed is at least `MIN_FEED` and the whole path takes
  at most `MAX_SECONDS`.

  Raises:
    errors.DataError naming the file, the line and the column or word that cannot be run.
  """
  file = pathlib.Path(path)
  try:
    lines = file.read_text().splitlines()
  except (OSError, UnicodeDecodeError) as err:
    raise errors.DataError(f"path file {file}: cannot be read ({err})") from None
  if file.suffix.lower() in (".gcode", ".nc", ".ngc"):
    rows = _gcode_rows(file, lines)
  else:
    rows = [r + [0.0] for r in _csv_rows(file, lines)]
  if len(rows) < 2:
    raise errors.DataError(f"path file {file}: needs at least two waypoints, found {len(rows)}")
  if len(rows) > MAX_WAYPOINTS:
    raise errors.DataError(f"path file {file}: {len(rows)} waypoints; allowed at most "
                           f"{MAX_WAYPOINTS:,} (each move takes one time step at least: join "
                           f"short moves into longer ones)")
  a = np.array(rows, dtype=float)
  points, feeds, holds = a[:, :3] * 1e-3, a[:, 3] * 1e-3, a[:, 4]
  slow = np.flatnonzero(a[1:, 3] < MIN_FEED)
  if len(slow):
    k = int(slow[0]) + 1
    raise errors.DataError(f"path file {file}: waypoint {k + 1} has feed {a[k, 3]:g} mm/s: "
                           f"allowed at least {MIN_FEED:g} mm/s ({MIN_FEED * 60:g} mm/min)")
  seconds = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1) / feeds[1:])
                  + holds.sum())
  if seconds > MAX_SECONDS:
    raise errors.DataError(f"path file {file}: the path takes {seconds:.4g} s at its feeds; "
                           f"allowed at most {MAX_SECONDS:g} s")
  return Waypoints(points, feeds, f"custom:{file.name}", holds if holds.any() else None)


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


_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
# G words that change no motion here: XY plane, mm, no cutter or length offsets, the first
# work system, path modes, canned cycles off, feed per minute
_INERT_G = {17, 21, 40, 49, 54, 61, 64, 80, 94}
_INERT_TEXT = ", ".join(f"G{g}" for g in sorted(_INERT_G))
_ARC_STEP = np.radians(2.0)  # arcs run as chords of at most 2 degrees


def _gcode_rows(file: pathlib.Path, lines: list[str]) -> list[list[float]]:
  """Rows (x, y, z mm, feed mm/s, hold s) of a G-code file. Honoured: G0 (at `RAPID`), G1,
  G2/G3 arcs in the XY plane with I, J centre offsets (as chords of at most 2 degrees, Z
  moving linearly: helices too), G90/G91 absolute and relative coordinates, G4 dwell (P in
  seconds, as LinuxCNC and grbl read it), words written without spaces (`G1X2F300`), motion
  modes kept from line to line, N line numbers, M, S and T words (no motion). Refused with
  the line: inches (G20), arcs by radius (R), other planes, and every other G word (homing,
  offsets, inverse-time feed...). The machine starts at the origin."""
  pos = np.zeros(3)
  feed, mode, relative = None, None, False
  rows = [[0.0, 0.0, 0.0, 0.0, 0.0]]
  for n, line in enumerate(lines, 1):
    text = re.sub(r"\(.*?\)", " ", line.split(";")[0]).strip().upper()
    if not text:
      continue
    words = _words(file, n, text)
    values, motion, dwell = {}, None, False
    for letter, number in words:
      if letter == "G":
        code = float(number)
        if code in (0, 1, 2, 3):
          motion = int(code)
        elif code in (90, 91):
          relative = code == 91
        elif code == 4:
          dwell = True
        elif code == 20:
          raise errors.DataError(f"path file {file}, line {n}: G20 (inches) is not supported: "
                                 f"write the path in millimetres (G21)")
        elif code not in _INERT_G:
          raise errors.DataError(f"path file {file}, line {n}: G{number} is not supported "
                                 f"(honoured: G0-G4, G90/G91, and {_INERT_TEXT}, which move "
                                 f"nothing)")
      elif letter in "NMST":
        continue
      elif letter in "XYZFIJP":
        values[letter] = float(number)
      elif letter == "R":
        raise errors.DataError(f"path file {file}, line {n}: an arc needs its centre as I, J "
                               f"(offsets from its start, mm); arcs by radius (R) are not "
                               f"supported")
      else:
        raise errors.DataError(f"path file {file}, line {n}: '{letter}{number}' is not one "
                               f"of X, Y, Z, F, I, J, P (or G, M, N, S, T)")
    if "F" in values:
      feed = values.pop("F")
    if dwell:
      rows[-1][4] += _dwell(file, n, values)
      continue
    mode = motion if motion is not None else mode
    if not set(values) & set("XYZ"):
      if set(values) & set("IJ"):
        raise errors.DataError(f"path file {file}, line {n}: I/J without an arc's end point")
      continue
    if mode is None:
      raise errors.DataError(f"path file {file}, line {n}: coordinates before any motion word "
                             f"(G0, G1, G2 or G3)")
    end = np.array([values.get(k, 0.0 if relative else pos[i]) for i, k in enumerate("XYZ")])
    end = pos + end if relative else end
    if mode == 0:
      rows.append([*end, RAPID * 1e3, 0.0])
    elif feed is None:
      raise errors.DataError(f"path file {file}, line {n}: a G{mode} move before any feed "
                             f"(F, mm/min)")
    elif mode == 1:
      rows.append([*end, feed / 60.0, 0.0])
    else:
      rows += [[*p, feed / 60.0, 0.0] for p in _arc(file, n, pos, end, values, mode == 2)]
    pos = end
  return rows


def _words(file: pathlib.Path, n: int, text: str) -> list[tuple[str, str]]:
  """(letter, number) pairs of a G-code line, spaced or not; anything else is refused."""
  words, at = [], 0
  for m in _WORD.finditer(text):
    if text[at:m.start()].strip():
      break
    words.append((m[1], m[2]))
    at = m.end()
  rest = text[at:].strip()
  if rest:
    raise errors.DataError(f"path file {file}, line {n}: {rest.split()[0]!r} is not a G-code "
                           f"word (a letter followed by a number)")
  return words


def _dwell(file: pathlib.Path, n: int, values: dict) -> float:
  seconds = values.get("P")
  if seconds is None or not 0 <= seconds <= MAX_SECONDS or set(values) - {"P"}:
    raise errors.DataError(f"path file {file}, line {n}: G4 needs P, the dwell in seconds "
                           f"(0 to {MAX_SECONDS:g}), and nothing else")
  return seconds


def _arc(file: pathlib.Path, n: int, start: np.ndarray, end: np.ndarray, values: dict,
         clockwise: bool) -> list[np.ndarray]:
  """Chord end points of a G2 (clockwise) or G3 arc in XY from `start` to `end` about
  start + (I, J); a full circle where they meet. The end must lie on the circle."""
  if not set(values) & set("IJ"):
    raise errors.DataError(f"path file {file}, line {n}: an arc needs its centre as I, J "
                           f"(offsets from its start, mm); arcs by radius (R) are not "
                           f"supported")
  centre = start[:2] + np.array([values.get("I", 0.0), values.get("J", 0.0)])
  r0, r1 = np.linalg.norm(start[:2] - centre), np.linalg.norm(end[:2] - centre)
  if r0 == 0 or abs(r0 - r1) > max(1e-3, 1e-3 * r0):
    raise errors.DataError(f"path file {file}, line {n}: the arc's end is {r1:.4g} mm from "
                           f"its centre and its start {r0:.4g} mm: they must be equal")
  a0 = np.arctan2(*(start[:2] - centre)[::-1])
  a1 = np.arctan2(*(end[:2] - centre)[::-1])
  sweep = (a0 - a1) % (2 * np.pi) if clockwise else (a1 - a0) % (2 * np.pi)
  sweep = sweep or 2 * np.pi  # the end on the start: a full circle
  k = max(1, int(np.ceil(sweep / _ARC_STEP)))
  angles = a0 + (-1 if clockwise else 1) * sweep * np.arange(1, k + 1) / k
  out = [np.array([centre[0] + r0 * np.cos(t), centre[1] + r0 * np.sin(t), 0.0])
         for t in angles]
  for j, p in enumerate(out, 1):
    p[2] = start[2] + (end[2] - start[2]) * j / k
  out[-1] = end.copy()
  return out


def _is_number(text: str) -> bool:
  try:
    return np.isfinite(float(text))
  except ValueError:
    return False


def waypoint_episode(waypoints: Waypoints, dt: float) -> Episode:
  """The CNC commands of a user's path: each move resampled at its feed, each hold as the
  point repeated for its time. Phase 1 marks the path at its depth, as on the paper's paths:
  moves and holds in the plate (z < 0) that keep their depth; a press down, a lift and a
  move from one depth to another are phase 0. The episode's z_level is its deepest press."""
  holds = np.zeros(len(waypoints.points)) if waypoints.holds is None else waypoints.holds
  p = waypoints.points
  # each move takes one step at least: a path of many tiny moves simulates far longer than
  # it travels, so its samples are counted before any is made
  steps = np.maximum(np.ceil(np.linalg.norm(np.diff(p, axis=0), axis=1)
                             / (waypoints.feeds[1:] * dt)), 1).sum() + np.round(holds / dt).sum()
  if steps * dt > MAX_SECONDS:
    raise errors.DataError(f"path {waypoints.name}: {int(steps):,} time steps of {dt:g} s "
                           f"({steps * dt:.4g} s simulated, one step per move at least); "
                           f"allowed at most {MAX_SECONDS:g} s: join short moves into longer "
                           f"ones")
  parts, flags = [p[:1]], [np.zeros(1, np.int8)]
  for k in range(len(p)):
    if k:
      seg = _resample(p[k - 1:k + 1], waypoints.feeds[k] * dt)[1:]
      at_depth = p[k - 1, 2] == p[k, 2] < 0
      parts.append(seg)
      flags.append(np.full(len(seg), at_depth, np.int8))
    if holds[k] > 0:
      n = int(round(holds[k] / dt))
      parts.append(np.repeat(p[k:k + 1], n, axis=0))
      flags.append(np.full(n, p[k, 2] < 0, np.int8))
  target = np.concatenate(parts)
  phase = np.concatenate(flags)
  return Episode(waypoints.name, float(max(-target[:, 2].min(), 0.0)), target, phase)

