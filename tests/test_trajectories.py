"""The paper's CNC paths: shapes, feed and bookkeeping."""

import numpy as np
import pytest

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
  with pytest.raises(ValueError, match="unknown path 'spiral'"):
    tr.episode("spiral", 0.001, FEED, DT)
