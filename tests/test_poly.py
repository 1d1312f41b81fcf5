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
  deg, ridge, table = methods.choose_poly(x, y, parts, (2,))
  largest = max(poly.RIDGES)
  assert ridge / len(x) > largest
  assert any(f"ridge {largest * 10:g} x samples" in k for k in table)
  # a signal the polynomial holds: the weight stays inside the grid
  y2 = np.column_stack([x[:, 0] ** 2 - x[:, 1], x[:, 2]]) + 0.01 * rng.normal(size=(400, 2))
  _, ridge2, table2 = methods.choose_poly(x, y2, parts, (2,))
  assert ridge2 / len(x) < largest and len(table2) == len(poly.RIDGES)
