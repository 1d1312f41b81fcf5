"""Every figure drawn headless and read back: its panels, labels (with units), title
(benchmark and seed) and the data its lines carry, against the arrays it was given."""

import numpy as np
import pytest

from benchmarks import figures

RNG = np.random.default_rng(0)


def _title(fig) -> str:
  return fig._suptitle.get_text()


def test_over_time_draws_truth_and_each_prediction_per_axis(tmp_path):
  t = np.arange(500) * 1e-3
  truth = RNG.normal(size=(500, 3)) * [1, 2, 30]
  preds = {"LS": truth + 0.1, "NN": truth - 0.2}
  fig = figures.over_time(t, truth, preds, ("X", "Y", "Z"), "N", benchmark="asterisk_path",
                          seed=7)
  axes = fig.axes
  assert [a.get_ylabel() for a in axes] == ["X (N)", "Y (N)", "Z (N)"]
  assert axes[-1].get_xlabel() == "time (s)"
  assert "asterisk_path" in _title(fig) and "seed 7" in _title(fig)
  for i, ax in enumerate(axes):
    lines = ax.get_lines()
    assert len(lines) == 3
    np.testing.assert_array_equal(lines[0].get_ydata(), truth[:, i])
    np.testing.assert_array_equal(lines[2].get_ydata(), preds["NN"][:, i])
    np.testing.assert_array_equal(lines[0].get_xdata(), t)
  path = figures.save(fig, tmp_path, "f")
  assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_long_series_are_thinned_keeping_their_ends():
  n = 3 * figures.MAX_POINTS + 17
  t = np.arange(n) * 1e-3
  truth = np.sin(t)[:, None]
  fig = figures.over_time(t, truth, {}, ("Z",), "N", benchmark="b", seed=0)
  x = fig.axes[0].get_lines()[0].get_xdata()
  assert len(x) <= figures.MAX_POINTS and x[0] == t[0] and x[-1] == t[-1]


def test_strokes_put_counts_above_forces_per_stroke():
  seg = {}
  for name in ("Z", "X"):
    t = np.arange(200) * 1e-3
    seg[name] = (t, RNG.integers(0, 4096, (200, 6)).astype(float), RNG.normal(size=(200, 3)))
  fig = figures.strokes(seg, [f"die {i}" for i in range(6)], ("X", "Y", "Z"), benchmark="b",
                        seed=1)
  top, bottom = fig.axes[0], fig.axes[2]  # row-major 2 x 2
  assert top.get_title() == "Z" and fig.axes[1].get_title() == "X"
  assert "counts" in top.get_ylabel() and "(N)" in bottom.get_ylabel()
  assert len(top.get_lines()) == 6 and len(bottom.get_lines()) == 3
  np.testing.assert_array_equal(top.get_lines()[5].get_ydata(), seg["Z"][1][:, 5])


def test_scatter_has_the_one_to_one_line_over_the_truths_range():
  truth = RNG.normal(size=(300, 4)) * [1, 2, 3, 4]
  fig = figures.scatter(truth, {"POLY": truth * 1.1}, ("Fx", "Fy", "Fz", "Mx"),
                        ("N", "N", "N", "N m"), benchmark="shell_table1", seed=0)
  visible = [a for a in fig.axes if a.get_visible()]
  assert len(visible) == 4
  assert visible[3].get_xlabel() == "true Mx (N m)"
  for i, ax in enumerate(visible):
    pts, one = ax.get_lines()
    np.testing.assert_array_equal(pts.get_xdata(), truth[:, i])
    np.testing.assert_allclose(pts.get_ydata(), 1.1 * truth[:, i])
    assert one.get_xdata() == pytest.approx([truth[:, i].min(), truth[:, i].max()])
    np.testing.assert_array_equal(one.get_xdata(), one.get_ydata())


def test_traces_shade_their_spans_on_every_panel():
  t = np.linspace(0, 10, 400)
  groups = {"force": {"Fx": np.sin(t), "Fz": np.cos(t)}, "angle": {"tilt": t}}
  fig = figures.traces(t, groups, {"force": "N", "angle": "deg"}, benchmark="collisions",
                       seed=2, what="course", spans=[(0, 2, "A"), (2, 5, "B")])
  assert [a.get_ylabel() for a in fig.axes] == ["force (N)", "angle (deg)"]
  for ax in fig.axes:
    assert len(ax.patches) == 2
  np.testing.assert_array_equal(fig.axes[1].get_lines()[0].get_ydata(), t)
  assert [x.get_text() for x in fig.axes[0].texts] == ["A", "B"]


def test_heatmap_holds_the_grid_and_the_mark():
  x, y = np.linspace(0, 1.5, 4), np.linspace(0, 1.5, 3)
  v = RNG.random((3, 4))
  fig = figures.heatmap(x, y, v, xlabel="slope x", ylabel="slope y", label="median error %",
                        benchmark="reflector_slope_sweep", seed=0, what="sweep",
                        mark=(0.3, 0.3, "board"))
  ax = fig.axes[0]
  np.testing.assert_array_equal(np.asarray(ax.collections[0].get_array()).reshape(3, 4), v)
  assert ax.get_xlabel() == "slope x" and fig.axes[1].get_ylabel() == "median error %"
  assert ax.get_lines()[0].get_xdata()[0] == 0.3


def test_the_pareto_front_is_the_set_no_point_beats():
  s = np.array([1.0, 2.0, 3.0, 4.0, 0.5])
  e = np.array([5.0, 3.0, 4.0, 1.0, 9.0])
  np.testing.assert_array_equal(figures.pareto(s, e), [4, 0, 1, 3])
  fig = figures.front({"LS": (s[:2], e[:2]), "NN": (s[2:], e[2:])}, error_label="NRMSE %",
                      benchmark="accuracy_vs_time", seed=0, what="front")
  line = fig.axes[0].get_lines()[-1]
  np.testing.assert_array_equal(line.get_xdata(), [0.5, 1.0, 2.0, 4.0])
  assert fig.axes[0].get_xscale() == "log"
