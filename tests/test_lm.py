"""The Levenberg-Marquardt trainer against independent references."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.optimize

from calibrate.parts import mlp


@pytest.fixture(autouse=True)
def float64():
  """The building blocks are called directly here: float64 as the trainer runs them."""
  with jax.enable_x64(True):
    yield


def _teacher(n=400, d=3, h=4, o=2, seed=0):
  """Inputs in [-1, 1] and the outputs of a known network (already in scaled units)."""
  rng = np.random.default_rng(seed)
  x = rng.uniform(-1, 1, (n, d))
  theta = mlp.nguyen_widrow(jax.random.key(seed + 1), d, h, o) * 1.3
  return x, np.asarray(mlp._forward(theta, jnp.asarray(x), h, d, o)), theta


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_normal_equations_match_jacfwd():
  x, y, theta = _teacher()
  y = y + 0.05 * np.random.default_rng(1).standard_normal(y.shape)
  jtj, jte, sse = mlp.normal_equations(theta, jnp.asarray(x), jnp.asarray(y), 4)
  # J of the predictions = -d(residuals)/d(theta)
  jac = -jax.jacfwd(mlp.residuals)(theta, jnp.asarray(x), jnp.asarray(y), 4)
  e = mlp.residuals(theta, jnp.asarray(x), jnp.asarray(y), 4)
  scale = float(jnp.max(jnp.abs(jac.T @ jac)))
  np.testing.assert_allclose(jtj, jac.T @ jac, rtol=0, atol=1e-10 * scale)
  np.testing.assert_allclose(jte, jac.T @ e, rtol=0, atol=1e-10 * scale)
  assert float(sse) == pytest.approx(float(e @ e), rel=1e-12)
  assert jtj.dtype == jnp.float64


def test_the_closed_form_jacobian_is_jacfwds():
  """`mlp.jacobian`, which lm_solvers hands every library, against automatic
  differentiation, on a network with three outputs."""
  x, y, theta = _teacher(o=3)
  args = (jnp.asarray(x), jnp.asarray(y), 4)
  want = jax.jacfwd(mlp.residuals)(theta, *args)
  got = mlp.jacobian(theta, *args)
  assert got.shape == want.shape
  np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * float(jnp.max(jnp.abs(want))))


@pytest.mark.parametrize("damping", ["trainlm", "nielsen"])
def test_recovers_noiseless_teacher_data(damping):
  x, y, _ = _teacher(n=600)
  cfg = mlp.LMConfig(hidden=4, epochs=400, min_grad=1e-14, max_fail=1000, damping=damping)
  res = mlp.train(x, y, x[:100], y[:100], cfg, seed=3)
  pred = res.net.predict(x)
  rel = np.sqrt(np.mean((pred - y) ** 2) / np.mean(y**2))
  assert rel < 1e-8, (rel, res.stop, res.epochs)
  assert pred.dtype == np.float64


@pytest.mark.parametrize("damping", ["trainlm", "nielsen"])
def test_first_step_matches_scipy_lm(damping):
  """Our damped step equals the damped least-squares step [J; sqrt(mu) I] d = [e; 0] solved by
  numpy's lstsq on the jacfwd Jacobian; from the same start both our LM and scipy's MINPACK LM
  (analytic Jacobian) reach the same error."""
  x, y, teacher = _teacher()
  rng = np.random.default_rng(2)
  y = y + 0.05 * rng.standard_normal(y.shape)
  # near the teacher, so that both solvers descend into the same minimum
  theta0 = np.asarray(teacher) + 0.2 * rng.standard_normal(teacher.shape)
  xj, yj = jnp.asarray(x), jnp.asarray(y)
  mu = 1e-3
  step = mlp._lm_epoch_fn(4, mlp.LMConfig(hidden=4, damping=damping))
  start = (jnp.asarray(mu), jnp.asarray(2.0))
  theta1, _, sse1, _ = step(jnp.asarray(theta0), start, xj, yj)
  # reference: solve the damped least-squares problem [J; sqrt(mu) I] d = [e; 0] with lstsq
  jac = -np.asarray(jax.jacfwd(mlp.residuals)(jnp.asarray(theta0), xj, yj, 4))
  e = np.asarray(mlp.residuals(jnp.asarray(theta0), xj, yj, 4))
  a = np.vstack([jac, np.sqrt(mu) * np.eye(len(theta0))])
  d = np.linalg.lstsq(a, np.concatenate([e, np.zeros(len(theta0))]), rcond=None)[0]
  np.testing.assert_allclose(np.asarray(theta1), theta0 + d, rtol=1e-8, atol=1e-10)
  # and over a few iterations the error falls like scipy's LM from the same start
  fun = lambda t: np.asarray(mlp.residuals(jnp.asarray(t), xj, yj, 4))
  jac_res = lambda t: np.asarray(jax.jacfwd(mlp.residuals)(jnp.asarray(t), xj, yj, 4))
  ref = scipy.optimize.least_squares(fun, theta0, jac=jac_res, method="lm", max_nfev=300)
  theta, state = jnp.asarray(theta0), start
  for _ in range(300):
    theta, state, sse_per_output, _ = step(theta, state, xj, yj)
  sse = jnp.sum(sse_per_output)
  assert float(sse) == pytest.approx(2 * ref.cost, rel=0.02)


def test_float64_stays_float64_and_bad_input_is_named():
  x, y, _ = _teacher(n=200)
  res = mlp.train(x, y, x[:50], y[:50], mlp.LMConfig(hidden=3, epochs=3), seed=0)
  assert res.net.w1.dtype == np.float64 and res.train_mse.dtype == np.float64
  with pytest.raises(ValueError, match="hidden"):
    mlp.train(x, y, x, y, mlp.LMConfig(hidden=0))
  with pytest.raises(ValueError, match="samples"):
    mlp.train(x[:10], y, x, y)
  bad = x.copy()
  bad[5, 1] = np.nan
  with pytest.raises(ValueError, match="NaN"):
    mlp.train(bad, y, x, y)
  with pytest.raises(ValueError, match="cannot fit"):
    mlp.train(x[:5], y[:5], x, y, mlp.LMConfig(hidden=10))


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_fits_of_nearby_sizes_share_one_compiled_epoch():
  """A cross-validation's folds differ in size by a few samples: their fits run one compiled
  epoch, on data padded with masked rows, and the mask leaves the padding out: the normal
  equations of the padded set are those of its samples alone."""
  x, y, theta = _teacher(n=900)
  cfg = mlp.LMConfig(hidden=3, epochs=4, max_fail=10)
  mlp._compiled.cache_clear()  # this module's other fits compiled other sizes already
  for n in (500, 470, 430):  # one size class (512 rows)
    mlp.train(x[:n], y[:n], x[n:n + 100], y[n:n + 100], cfg, seed=0)
  _, step, _ = mlp._kernel(dataclasses.replace(cfg, epochs=40))  # stopping rules aside
  assert step._cache_size() == 1
  a = mlp.train(x[:500], y[:500], x[500:600], y[500:600], cfg, seed=2)
  mlp.train(x[:500], y[:500], x[500:700], y[500:700], cfg, seed=2)  # another size class
  assert step._cache_size() == 2
  again = mlp.train(x[:500], y[:500], x[500:600], y[500:600], cfg, seed=2)
  np.testing.assert_array_equal(a.net.w1, again.net.w1)
  (xp, mask), (yp, _) = mlp._padded(x[:430]), mlp._padded(y[:430])
  assert xp.shape[0] == 512 and float(mask.sum()) == 430
  padded = mlp.normal_equations(theta, xp, yp, 4, mask)
  alone = mlp.normal_equations(theta, jnp.asarray(x[:430]), jnp.asarray(y[:430]), 4)
  for p, q in zip(padded, alone):
    np.testing.assert_allclose(p, q, rtol=1e-12, atol=1e-12 * float(jnp.max(jnp.abs(q))))
