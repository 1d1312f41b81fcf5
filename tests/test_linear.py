"""Linear least squares against exact answers and degenerate inputs."""

import numpy as np
import pytest

from calibrate import linear, metrics


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
  with pytest.raises(ValueError, match="same N"):
    linear.fit_linear(v[:10], f[:9])
  with pytest.raises(ValueError, match="cannot fit"):
    linear.fit_linear(v[5:10], f[5:10])


def test_metrics_definitions():
  truth = np.array([[0.0], [10.0], [20.0]])
  pred = truth + np.array([[1.0], [-1.0], [1.0]])
  assert metrics.rmse(pred, truth)[0] == pytest.approx(1.0)
  assert metrics.nrmse_pct(pred, truth)[0] == pytest.approx(5.0)
  assert metrics.r2_pct(pred, truth)[0] == pytest.approx(100 * (1 - 3 / 200))
