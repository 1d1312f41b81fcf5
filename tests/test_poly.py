"""The polynomial with cross terms: scikit-learn's PolynomialFeatures + Ridge as the
reference inside the box, a tangent plane outside it, the cubic of coupled channels
recovered exactly, and the per-channel cubic beaten where channels couple."""

import numpy as np
import pytest

from calibrate import estimators, splits
from calibrate.parts import poly


def _data(n=600, seed=0):
  rng = np.random.default_rng(seed)
  x = rng.normal(size=(n, 4)) * [100, 5, 1, 30] + [2000, 0, 3, -50]
  y = np.column_stack([x[:, 0] * x[:, 1] / 100 + x[:, 2] ** 3,
                       np.sin(x[:, 2]) + x[:, 3] ** 2 / 100 - x[:, 1] * x[:, 3] / 10])
  return x, y


@pytest.mark.parametrize("degree", [1, 2, 3])
@pytest.mark.parametrize("ridge", [0.0, 1e-3, 10.0, 1e3])
def test_inside_the_box_it_is_polynomialfeatures_plus_ridge(degree, ridge):
  from sklearn.linear_model import Ridge
  from sklearn.preprocessing import PolynomialFeatures
  x, y = _data()
  fit = poly.fit(x, y, degree, ridge)
  z = fit.standardise(x)
  features = PolynomialFeatures(degree, include_bias=False).fit_transform(z)
  want = Ridge(alpha=ridge, solver="svd").fit(features, y).predict(features)
  np.testing.assert_allclose(fit.predict(x), want, rtol=0, atol=1e-8 * np.abs(want).max())


def test_the_monomials_are_every_product_of_total_degree_up_to_d():
  p = poly.powers(4, 3)
  assert len(p) == 34  # C(4 + 3, 3) - 1
  assert len({tuple(r) for r in p}) == len(p) and set(p.sum(axis=1)) == {1, 2, 3}
  assert len(poly.powers(4, 3, cross=False)) == 12


def test_a_polynomial_of_coupled_channels_is_recovered_exactly():
  rng = np.random.default_rng(1)
  x = rng.uniform(-1, 1, (400, 3))
  y = (2 * x[:, 0] * x[:, 1] - x[:, 2] ** 3 + 0.5 * x[:, 0] * x[:, 1] * x[:, 2] + 1)[:, None]
  np.testing.assert_allclose(poly.fit(x, y, 3).predict(x), y, atol=1e-10)


def test_beyond_the_box_it_grows_linearly_along_its_tangent_plane():
  x, y = _data()
  fit = poly.fit(x, y, 3)
  edge = x[np.argmax(x[:, 3])]
  # out along the line from the box's centre through a point on its face
  ray = (edge - (x.min(axis=0) + x.max(axis=0)) / 2) / 100
  steps = edge + np.outer([0, 10, 20, 40, 80], ray)
  f = fit.predict(steps)
  # equal steps, equal increments: a straight line, however curved the cubic was
  np.testing.assert_allclose(np.diff(f, axis=0) / [[1], [1], [2], [4]],
                             np.repeat(np.diff(f, axis=0)[:1], 4, axis=0), rtol=1e-9)
  # continuous at the box, and its slope is the polynomial's there
  h = 1e-4
  inside = fit.predict(edge[None] - h * ray)
  slope = (f[1] - f[0]) / 10
  np.testing.assert_allclose(slope, (f[0] - inside[0]) / h, rtol=1e-3,
                             atol=1e-6 * np.abs(slope).max())
  # off that line too it stays continuous at the face: no jump where the box ends
  side = edge + np.array([[0, 0, 0, -1e-9], [0, 0, 0, 1e-9]]) * np.ptp(x[:, 3])
  np.testing.assert_allclose(*fit.predict(side), rtol=1e-6)


def test_cross_terms_beat_the_per_channel_cubic_on_coupled_channels_held_out():
  x, y = _data(3000, seed=2)
  g = splits.groups(len(x), "blocks", block=100)
  tr, va = splits.holdout(g, 0.3, seed=0)
  cross = estimators.fit("POLY", x[tr], y[tr], cross=True, groups=splits.Groups(
      np.unique(g.labels[tr], return_inverse=True)[1], "blocks", 100), folds=4)
  channel = estimators.fit("POLY", x[tr], y[tr], degree=3)
  err = [np.sqrt(np.mean((e.predict(x[va]) - y[va]) ** 2, axis=0)) for e in (cross, channel)]
  assert (err[0] <= err[1]).all() and (err[0] < 0.1 * err[1]).any(), err


def test_the_ridge_search_goes_past_its_grid_while_the_held_out_error_still_falls():
  """Targets that are noise alone: the held-out error falls with every larger ridge weight
  (the polynomial shrinks to the mean), so the search goes past the grid's largest weight
  (1 x the samples) instead of stopping at its edge unsaid."""
  from calibrate import methods
  rng = np.random.default_rng(2)
  x, y = rng.uniform(-1, 1, (400, 3)), rng.normal(size=(400, 2))
  parts = splits.folds(splits.groups(400, "blocks", block=40), 4, 0)
  deg, ridges, table = methods.choose_poly(x, y, parts, (2,))
  largest = max(poly.RIDGES)
  assert all(r / len(x) > largest for r in ridges)
  assert any(f"ridge {largest * 10:g} x samples" in k for k in table)
  # a signal the polynomial holds: the weight stays inside the grid
  y2 = np.column_stack([x[:, 0] ** 2 - x[:, 1], x[:, 2]]) + 0.01 * rng.normal(size=(400, 2))
  _, ridges2, table2 = methods.choose_poly(x, y2, parts, (2,))
  assert all(r / len(x) < largest for r in ridges2) and len(table2) == len(poly.RIDGES)


def _force_and_moment(n=1200, seed=3):
  """A force (sd ~30 N) linear in the channels under 3 N of noise beside a moment (sd ~0.1 N
  m) that is a cubic of them under 1e-3 N m: the units of a six-axis sensor."""
  rng = np.random.default_rng(seed)
  x = rng.uniform(-1, 1, (n, 3))
  force = 30 * (x[:, 0] - x[:, 1]) + 3 * rng.normal(size=n)
  moment = 0.1 * (x[:, 0] * x[:, 1] * x[:, 2] + x[:, 2] ** 3) + 1e-3 * rng.normal(size=n)
  return x, np.column_stack([force, moment])


def test_each_output_chooses_its_own_degree_on_its_own_held_out_error():
  """The sum of squared errors over outputs is the force's alone (the moment's is 1e-5 of
  it), so a joint choice gives the moment whatever the force wants. Each output chooses on
  its own error: the moment gets the cubic its truth is, and its held-out error is each
  output's lowest over the whole grid, which a joint choice cannot beat on any output."""
  from calibrate import methods
  x, y = _force_and_moment()
  parts = splits.folds(splits.groups(len(x), "blocks", block=60), 5, 0)
  degrees, ridges, table = methods.choose_poly(x, y, parts, (1, 2, 3))
  assert degrees[1] == 3
  mse = np.array(list(table.values()))  # (candidates, outputs)
  chosen = [table[f"degree {d}, ridge {r / len(x):g} x samples"][a]
            for a, (d, r) in enumerate(zip(degrees, ridges))]
  np.testing.assert_allclose(chosen, mse.min(axis=0))
  joint = mse[np.argmin(mse.sum(axis=1))]
  assert np.all(np.asarray(chosen) <= joint)
  assert joint[1] > 10 * chosen[1], (joint, chosen)  # the force's choice fails the moment


def test_each_output_at_its_own_degree_equals_that_output_fitted_alone():
  """One polynomial at the largest degree with zeros past each output's own: inside and
  beyond the box each output is `fit` of that output alone at its degree and ridge."""
  x, y = _force_and_moment(400)
  both = poly.fit_each(x, y, (1, 3), (4.0, 1e-3))
  far = np.vstack([x, 3 * x[:20]])  # past the box: the tangent plane
  for a, (d, r) in enumerate([(1, 4.0), (3, 1e-3)]):
    alone = poly.fit(x, y[:, a:a + 1], d, r)
    np.testing.assert_allclose(both.predict(far)[:, a], alone.predict(far)[:, 0],
                               rtol=1e-9, atol=1e-12)
  assert both.ridge == (4.0, 1e-3) and both.degree == 3
  assert np.all(both.coef[len(poly.powers(3, 1)):, 0] == 0)


def test_fit_keeps_each_outputs_choice_and_says_it():
  """`estimators.fit` with cross-validation records each output's degree and ridge, its
  predictions are `fit_each`'s at them, and `fit` prints each output's pair."""
  from calibrate.cli.fit import poly_lines
  x, y = _force_and_moment()
  g = splits.groups(len(x), "blocks", block=60)
  est = estimators.fit("POLY", x, y, cross=True, groups=g, folds=5, outputs=["F", "M"])
  s = est.info.settings
  assert s["degrees"][1] == 3 and s["degree"] == max(s["degrees"])
  ridges = np.broadcast_to(s["ridge_per_sample"], (2,)) * len(x)
  want = poly.fit_each(x, y, s["degrees"], ridges).predict(x)
  np.testing.assert_allclose(est.predict(x), want, rtol=1e-9, atol=1e-9)
  assert s["degrees"][0] == 1  # a line under noise
  line = poly_lines(s, ["F", "M"])
  assert "F degree 1 ridge" in line and "M degree 3 ridge" in line, line


CC = __import__("shutil").which("cc") or __import__("shutil").which("gcc")


@pytest.mark.skipif(CC is None, reason="no C compiler (cc or gcc) on this machine")
def test_each_outputs_polynomial_is_saved_loaded_and_exported_as_it_predicts(tmp_path):
  """The per-output ridges go through the file, and the C export's one loop over the
  largest degree's monomials gives each output's own polynomial, past the box too."""
  from calibrate import cexport
  x, y = _force_and_moment(600)
  est = estimators.fit("POLY", x, y, cross=True, groups=splits.groups(600, "blocks", block=60),
                       folds=4)
  assert len(set(est.info.settings["degrees"])) == 2
  est.save(tmp_path / "e.npz")
  back = estimators.Estimator.load(tmp_path / "e.npz")
  test = np.random.default_rng(4).uniform(-1.5, 1.5, (200, 3))
  np.testing.assert_array_equal(back.predict(test), est.predict(test))
  c_out = cexport.run_on_host(back, test, cc=CC)
  want = est.predict(test)
  assert np.max(np.abs(c_out - want) / np.abs(want).max(axis=0)) < 1e-5
