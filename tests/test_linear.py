"""Linear least squares against exact answers and degenerate inputs."""

import numpy as np
import pytest

from calibrate import metrics
from calibrate.parts import linear


def _problem(n=400, seed=0):
  rng = np.random.default_rng(seed)
  v = rng.uniform(1000, 4000, (n, 6))
  a = rng.normal(0, 0.1, (6, 3))
  return v, v @ a + np.array([1.0, -2.0, 3.0])


def test_recovers_exact_linear_map():
  v, f = _problem()
  fit = linear.fit_linear(v, f)
  assert fit.rank == 7
  np.testing.assert_allclose(fit.predict(v), f, rtol=1e-10, atol=1e-8)
  assert np.all(metrics.r2_pct(fit.predict(v), f) > 99.9999)


def test_dead_and_duplicated_channels_reduce_rank_with_a_warning():
  v, f = _problem()
  v[:, 2] = 2048.0
  with pytest.warns(UserWarning, match="constant"):
    fit = linear.fit_linear(v, f - 0.0)
  v2, f2 = _problem()
  v2[:, 5] = v2[:, 4]
  with pytest.warns(UserWarning, match="rank-deficient"):
    fit2 = linear.fit_linear(v2, f2)
  assert fit2.rank == 6 and np.all(np.isfinite(fit2.coef))
  assert np.all(np.isfinite(fit.predict(v)))


def test_bad_input_is_refused():
  v, f = _problem()
  v[3, 1] = np.nan
  with pytest.raises(ValueError, match="1 of 400 rows hold NaN"):
    linear.fit_linear(v, f)
  v, f = _problem()
  with pytest.raises(ValueError, match="must match"):
    linear.fit_linear(v[:10], f[:9])
  with pytest.raises(ValueError, match="cannot fit"):
    linear.fit_linear(v[5:10], f[5:10])


def test_qr_and_svd_agree():
  rng = np.random.default_rng(3)
  v = rng.integers(0, 4096, (500, 6)).astype(float)
  f = rng.normal(size=(500, 3)) + v @ rng.normal(size=(6, 3))
  for degree in (1, 3):
    qr = linear.fit_linear(v, f, degree=degree, method="qr")
    svd = linear.fit_linear(v, f, degree=degree, method="svd")
    scale = np.max(np.abs(qr.coef))
    np.testing.assert_allclose(qr.coef, svd.coef, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(qr.predict(v), svd.predict(v), rtol=1e-10, atol=1e-10)


def test_cubic_features_of_raw_counts_are_solved_to_full_accuracy():
  """Forces an exact cubic of raw 12-bit counts (s^3 up to 7e10): recovered to ~1e-12."""
  rng = np.random.default_rng(4)
  s = rng.integers(0, 4096, (2000, 6)).astype(float)
  c1, c2, c3 = rng.normal(size=(3, 6, 3))
  f = s @ c1 * 1e-3 + s**2 @ c2 * 1e-6 + s**3 @ c3 * 1e-9 + 5.0
  fit = linear.fit_linear(s, f, degree=3)
  assert fit.rank == 19
  err = np.max(np.abs(fit.predict(s) - f)) / np.max(np.abs(f))
  assert err < 1e-11


def test_float32_is_promoted_with_a_note():
  v, f = _problem()
  with pytest.warns(UserWarning, match="float32: promoted"):
    fit = linear.fit_linear(v.astype(np.float32), f)
  assert fit.coef.dtype == np.float64 and fit.predict(v.astype(np.float32)).dtype == np.float64


def test_metrics_definitions():
  truth = np.array([[0.0], [10.0], [20.0]])
  pred = truth + np.array([[1.0], [-1.0], [1.0]])
  assert metrics.rmse(pred, truth)[0] == pytest.approx(1.0)
  assert metrics.nrmse_pct(pred, truth)[0] == pytest.approx(5.0)
  assert metrics.r2_pct(pred, truth)[0] == pytest.approx(100 * (1 - 3 / 200))


def test_median_and_worst_case_metrics():
  truth = np.array([[0.1], [1.0], [2.0], [4.0]])
  pred = np.array([[5.0], [1.1], [2.4], [4.0]])
  # |truth| > 0.2 keeps 1, 2, 4 N: errors 10 %, 20 %, 0 % -> median 10 %
  assert metrics.median_pct_error(pred, truth, 0.2)[0] == pytest.approx(10.0)
  assert metrics.worst_pct_of_range(pred, truth)[0] == pytest.approx(100 * 4.9 / 3.9)
