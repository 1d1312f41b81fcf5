"""Bad input on the newer surfaces (python -m calibrate, python -m sim.render, custom CNC
paths, design sweeps, the C export), through their real entry points: each case ends in one
`error:` line (exit 2), a warning, or the correct result; never a traceback, a zero exit with
wrong output, or lost work."""

import re

import numpy as np
import pytest

from sim.footpad import trajectories as tr
from util import errors


def _path(tmp_path, text, suffix=".gcode"):
  p = tmp_path / f"p{suffix}"
  p.write_text(text)
  return tr.read_path(str(p))


# --- G-code words that change the motion are honoured or refused -------------------------

def test_a_quarter_arc_runs_on_its_circle_to_its_end(tmp_path):
  # from (2, 0) anticlockwise about the origin to (0, 2)
  w = _path(tmp_path, "G1 X2 Y0 F600\nG3 X0 Y2 I-2 J0\n")
  arc = w.points[2:] * 1e3
  np.testing.assert_allclose(np.hypot(arc[:, 0], arc[:, 1]), 2.0, atol=1e-9)
  np.testing.assert_allclose(arc[-1], [0, 2, 0], atol=1e-12)
  assert np.all(np.diff(np.arctan2(arc[:, 1], arc[:, 0])) > 0)  # anticlockwise
  assert len(arc) == 45  # 90 degrees in chords of at most 2


def test_a_clockwise_full_circle_comes_back_to_its_start(tmp_path):
  w = _path(tmp_path, "G1 X2 F600\nG2 X2 Y0 I-2 J0\n")
  arc = w.points[2:] * 1e3
  assert len(arc) == 180
  np.testing.assert_allclose(np.hypot(arc[:, 0], arc[:, 1]), 2.0, atol=1e-9)
  np.testing.assert_allclose(arc[-1], [2, 0, 0], atol=1e-12)
  assert arc[0][1] < 0  # clockwise from (2, 0) goes to negative y first


def test_relative_moves_add_up(tmp_path):
  w = _path(tmp_path, "G91\nG1 X2 F300\nG1 X2\nG1 Z-0.5\nG90\nG1 X0\n")
  np.testing.assert_allclose(w.points * 1e3, [[0, 0, 0], [2, 0, 0], [4, 0, 0], [4, 0, -0.5],
                                               [0, 0, -0.5]], atol=1e-12)


def test_compact_words_read_like_spaced_ones_and_motion_is_modal(tmp_path):
  a = _path(tmp_path, "G1X2Y1F300\nX-1\nG0Z1\n")
  b = _path(tmp_path, "G1 X2 Y1 F300\nG1 X-1\nG0 Z1\n")
  np.testing.assert_allclose(a.points, b.points)
  np.testing.assert_allclose(a.feeds, b.feeds)
  np.testing.assert_allclose(a.points[2] * 1e3, [-1, 1, 0])


def test_a_dwell_holds_the_point_for_its_time(tmp_path):
  plain = tr.waypoint_episode(_path(tmp_path, "G1 X1 F60\nG1 X0\n"), 0.001)
  held = tr.waypoint_episode(_path(tmp_path, "G1 X1 F60\nG4 P0.5\nG1 X0\n"), 0.001)
  assert len(held.target) - len(plain.target) == 500
  at_end = np.all(np.isclose(held.target, [0.001, 0, 0]), axis=1)
  assert at_end.sum() == 501  # reached, then held 0.5 s at 1 kHz


@pytest.mark.parametrize("text, message", [
    ("G1 X1 F60\nG2 X0 Y1 R1\n", "line 2: an arc needs its centre as I, J"),
    ("G1 X1 F60\nG3 X0 Y3 I-1 J0\n", "line 2: the arc's end is"),
    ("G28\n", "line 1: G28 is not supported"),
    ("G92 X0\n", "line 1: G92 is not supported"),
    ("G18\nG1 X1 F60\n", "line 1: G18 is not supported"),
    ("G93 G1 X1 F60\n", "line 1: G93 is not supported"),
    ("G1 X1 F60\nG4 X2\n", "line 2: G4 needs P"),
    ("G1 X1 F60\nX2 Q1\n", "line 2: 'Q1' is not one of"),
    ("X1 Y1\n", "line 1: coordinates before any motion word"),
    ("G1 X1 F60 #5\n", "line 1: '#5' is not a G-code word"),
    ("G1 X1 F6e-11\n", "'E-11' is not one of"),  # G-code numbers have no exponent
    ("G1 X1 F0.000000001\n", "waypoint 2 has feed 1.66667e-11 mm/s: allowed at least 0.1"),
    ("G1 X1 F3\n", "allowed at least 0.1 mm/s"),
    ("G1 X100 F6\nG1 X-100\nG1 X100\nG1 X-100\nG1 X100\nG1 X-100\nG1 X100\nG1 X-100\n"
     "G1 X100\nG1 X-100\nG1 X100\nG1 X-100\n", "allowed at most 3600 s"),
])
def test_motion_words_the_reader_cannot_run_are_refused_with_their_line(tmp_path, text, message):
  with pytest.raises(errors.DataError, match=re.escape(message)):
    _path(tmp_path, text)


def test_a_crawling_feed_in_a_csv_path_is_refused(tmp_path):
  with pytest.raises(errors.DataError, match="feed 1e-12 mm/s: allowed at least 0.1"):
    _path(tmp_path, "0,0,0,5\n1,0,0,1e-12\n", ".csv")


# --- the --out lock: one holder, however many start at once --------------------------------

def _contend(out, barrier, queue):
  import time
  from benchmarks import outputs
  barrier.wait()
  try:
    lock = outputs.claim(out)
  except errors.SettingError:
    queue.put(None)
    return
  start = time.monotonic()
  time.sleep(0.02)
  end = time.monotonic()
  lock.release()
  queue.put((start, end))


def test_eight_runs_started_at_once_never_share_an_out_folder(tmp_path):
  import multiprocessing
  ctx = multiprocessing.get_context("fork")
  holds = []
  for round_ in range(25):
    out = str(tmp_path / f"out{round_ % 3}")  # some rounds find an earlier round's folder
    barrier, queue = ctx.Barrier(8), ctx.Queue()
    procs = [ctx.Process(target=_contend, args=(out, barrier, queue)) for _ in range(8)]
    for p in procs:
      p.start()
    got = [queue.get(timeout=60) for _ in procs]
    for p in procs:
      p.join()
    spans = sorted(g for g in got if g is not None)
    assert spans, "nobody took a free folder"
    for (s0, e0), (s1, e1) in zip(spans, spans[1:]):
      assert s1 >= e0, f"round {round_}: two runs held {out} at once"
    holds.append(len(spans))
  assert min(holds) >= 1
