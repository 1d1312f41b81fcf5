"""The paper's CNC paths: shapes, feed and bookkeeping."""

import re

import numpy as np
import pytest

from util import errors
from sim.footpad import trajectories as tr

DT, FEED = 0.001, 0.005


@pytest.mark.parametrize("path", tr.PATHS)
def test_paths_start_and_end_at_rest_and_keep_the_feed(path):
  ep = tr.episode(path, 0.001, FEED, DT, repeats=2)
  np.testing.assert_allclose(ep.target[0], [0, 0, tr.APPROACH_HEIGHT], atol=1e-12)
  np.testing.assert_allclose(ep.target[-1], [0, 0, tr.APPROACH_HEIGHT], atol=1e-12)
  steps = np.linalg.norm(np.diff(ep.target, axis=0), axis=1)
  assert steps.max() <= FEED * DT * 1.01
  on = ep.target[ep.phase == 1]
  if path != "z_press":
    np.testing.assert_allclose(on[:, 2], -0.001)


def test_asterisk_has_eight_spokes_of_3mm():
  ep = tr.episode("asterisk", 0.001, FEED, DT)
  xy = ep.target[ep.phase == 1, :2]
  r = np.hypot(xy[:, 0], xy[:, 1])
  assert r.max() == pytest.approx(0.003, rel=1e-9)
  tips = xy[np.isclose(r, 0.003)]
  angles = np.unique(np.round(np.degrees(np.arctan2(tips[:, 1], tips[:, 0])) % 360))
  np.testing.assert_array_equal(angles, np.arange(0, 360, 45))
  # 8 x 6 mm at 5 mm/s: the 9.6 s the design notes give per Z level
  assert len(xy) * DT == pytest.approx(9.6, rel=0.01)


def test_circular_diameters_and_directions():
  ep = tr.episode("circular", 0.001, FEED, DT)
  xy = ep.target[ep.phase == 1, :2]
  r = np.round(np.hypot(xy[:, 0], xy[:, 1]), 6)
  for radius in (0.001, 0.002, 0.003):
    assert np.sum(np.isclose(r, radius, atol=2e-6)) > 0.9 * 2 * 2 * np.pi * radius / (FEED * DT)
  # signed area swept: clockwise and counter-clockwise cancel
  cross = xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]
  assert abs(cross.sum()) < 1e-3 * np.abs(cross).sum()


def test_unknown_path():
  with pytest.raises(ValueError, match="unknown path 'helix'"):
    tr.episode("helix", 0.001, FEED, DT)


SQUARE_CSV = """# a 4 mm square at 0.8 mm, then a press at 1.2 mm
x_mm, y_mm, z_mm, feed_mm_s
0, 0, 0.1, 0
0, 0, -0.8, 2
2, 2, -0.8, 5
-2, 2, -0.8, 5
-2, -2, -0.8, 5
2, -2, -0.8, 5
0, 0, -1.2, 3
0, 0, 0.1, 3
"""
SQUARE_GCODE = """G21 ; mm
G0 X0 Y0 Z0.1
G1 Z-0.8 F120
G1 X2 Y2 F300
G1 X-2
G1 Y-2
G1 X2
G1 X0 Y0 Z-1.2 F180
G1 Z0.1
"""


def test_a_csv_path_and_its_gcode_are_the_same_moves(tmp_path):
  (tmp_path / "p.csv").write_text(SQUARE_CSV)
  (tmp_path / "p.gcode").write_text(SQUARE_GCODE)
  a = tr.read_path(str(tmp_path / "p.csv"))
  b = tr.read_path(str(tmp_path / "p.gcode"))
  np.testing.assert_allclose(a.points, b.points[1:])  # G-code starts at the origin
  np.testing.assert_allclose(a.feeds[1:], b.feeds[2:])
  ep = tr.waypoint_episode(a, 0.001)
  # every move at its feed: the commanded speed between samples is the waypoint's feed
  speed = np.linalg.norm(np.diff(ep.target, axis=0), axis=1) / 0.001
  assert speed.max() == pytest.approx(0.005, rel=1e-6)
  assert ep.z_level == pytest.approx(0.0012) and set(np.unique(ep.phase)) == {0, 1}
  np.testing.assert_allclose(ep.target[0], a.points[0])
  np.testing.assert_allclose(ep.target[-1], a.points[-1])


@pytest.mark.parametrize("text, suffix, message", [
    ("x,y,z,feed\n0,0,0,0\n1,abc,-0.5,2\n", ".csv", "line 3, column y: 'abc' is not a number"),
    ("0,0,0,0\n1,1,-0.5\n", ".csv", "line 2: 3 columns"),
    ("0,0,0,0\n1,1,-0.5,0\n", ".csv", "waypoint 2 has feed 0"),
    ("0,0,0,0\n", ".csv", "at least two waypoints"),
    ("G20\nG1 X1 F60\n", ".gcode", "line 1: G20"),
    ("G1 X1 Y2\n", ".gcode", "line 1: a G1 move before any feed"),
    ("G1 X1 Q2 F60\n", ".gcode", "line 1: 'Q2'"),
])
def test_bad_path_files_name_the_line_and_column(tmp_path, text, suffix, message):
  path = tmp_path / f"bad{suffix}"
  path.write_text(text)
  with pytest.raises(errors.DataError, match=re.escape(message)):
    tr.read_path(str(path))


def test_a_custom_path_runs_through_the_scene_and_keys_the_cache_by_content(tmp_path):
  from sim.footpad import scene as footpad
  path = tmp_path / "p.csv"
  path.write_text(SQUARE_CSV)
  scene = footpad.FootpadScene(paths=(), custom_path=str(path), effects=("friction",))
  rec, _ = footpad.simulate(scene)
  assert rec.meta["paths"] == ["custom:p.csv"]
  held = rec.phase == 1
  assert rec.wrench[held, 2].max() > 100  # pressed 1.2 mm: over 100 N
  key = scene.config()["custom_path_sha256"]
  path.write_text(SQUARE_CSV.replace("-1.2", "-1.1"))
  assert scene.config()["custom_path_sha256"] != key
  path.write_text(SQUARE_CSV.replace("-1.2", "-9"))
  with pytest.raises(errors.DataError, match="presses 9.00 mm deep"):
    scene.validate()


def test_a_custom_path_is_on_path_only_at_its_depth(tmp_path):
  """As on the paper's paths, phase 1 is the path at its depth: the press down, the lift and
  a move from one depth to another are not (the press down is where NN-only was off by
  hundreds of newtons)."""
  (tmp_path / "p.csv").write_text("0,0,0.1,5\n0,0,-1,1\n2,0,-1,5\n2,0,-1.5,1\n0,0,-1.5,5\n"
                                  "0,0,0.1,1\n")
  ep = tr.waypoint_episode(tr.read_path(str(tmp_path / "p.csv")), 0.001)
  z, on = ep.target[:, 2] * 1e3, ep.phase == 1
  moving_z = np.r_[False, np.abs(np.diff(z)) > 1e-9]
  assert on.any() and not (on & moving_z).any()  # no sample of a press, lift or step down
  np.testing.assert_allclose(sorted(set(np.round(z[on], 9))), [-1.5, -1.0])
  # every sample at depth moving sideways is on the path
  sideways = np.r_[False, np.abs(np.diff(ep.target[:, 0])) > 0] & (z < 0) & ~moving_z
  assert (on[sideways]).all()
