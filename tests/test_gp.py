"""A family added by one file and one registry line: LSGP, LS plus a Gaussian process on its
residual (`calibrate.parts.gp`), through fit, the file, `fit_auto`, the command line and C."""

import shutil
import warnings

import numpy as np
import pytest

from calibrate import cexport, estimators, splits
from calibrate import __main__ as cli
from calibrate.parts import gp

SMALL = gp.GPConfig(points=60)
CC = shutil.which("cc") or shutil.which("gcc")


def _data(n=400, seed=0):
  """Counts (n, 4) and forces (n, 3): one output linear, two with smooth bends LS misses."""
  rng = np.random.default_rng(seed)
  x = np.round(rng.uniform(500, 3500, (n, 4)))
  z = (x - 2000) / 800
  y = np.column_stack([40 + 10 * z.sum(axis=1), z[:, 0] - z[:, 1] + 0.3 * z[:, 0] ** 2,
                       np.tanh(2 * z[:, 2]) * 5])
  return x, y + 0.01 * rng.normal(size=y.shape)


def test_its_mean_is_scikit_learns_prediction():
  """The arrays it keeps reproduce `GaussianProcessRegressor.predict` (the reference:
  scikit-learn fitted on the same standardised data, with the same kernel and bounds)."""
  from sklearn.gaussian_process import GaussianProcessRegressor
  from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
  x, y = _data(120)
  part = gp.fit(x, y, gp.GPConfig(points=120))
  xm, xs, ym, ys = x.mean(axis=0), x.std(axis=0), y.mean(axis=0), y.std(axis=0)
  kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(4), (1e-2, 1e3)) \
      + WhiteKernel(1e-2, (1e-8, 1e1))
  with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    ref = GaussianProcessRegressor(kernel).fit((x - xm) / xs, (y - ym) / ys)
  probe = np.random.default_rng(1).uniform(400, 3600, (50, 4))
  want = ref.predict((probe - xm) / xs) * ys + ym
  np.testing.assert_allclose(part.predict(probe), want, rtol=1e-9, atol=1e-9 * ys.max())


def test_lsgp_beats_ls_where_the_residual_bends_and_keeps_ls_where_it_does_not():
  x, y = _data()
  g = splits.groups(len(x), "blocks", block=40)
  ls = estimators.fit("LS", x, y, groups=g, folds=3)
  est = estimators.fit("LSGP", x, y, groups=g, folds=3, gp=SMALL)
  assert est.kind is estimators.Kind.LSGP and est.root.label == "LSGP"
  held, base = np.array(est.info.validation["cv_rmse"]), np.array(ls.info.validation["cv_rmse"])
  assert np.all(held[1:] < 0.5 * base[1:]), (held, base)  # the bends, from 60 points
  assert held[0] <= 1.01 * base[0]  # the linear output: the GP adds nothing, or is dropped


def test_a_saved_lsgp_predicts_the_same_bytes(tmp_path):
  x, y = _data()
  est = estimators.fit("LSGP", x, y, gp=SMALL)
  est.save(tmp_path / "gp.npz")
  back = estimators.Estimator.load(tmp_path / "gp.npz")
  assert back.kind is estimators.Kind.LSGP
  np.testing.assert_array_equal(back.predict(x), est.predict(x))


def test_auto_takes_it_as_a_candidate():
  x, y = _data()
  g = splits.groups(len(x), "blocks", block=40)
  with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    est, table = estimators.fit_auto(x, y, g, 3, candidates=("LS", "LSGP"), gp=SMALL)
  assert list(table) == ["LS", "LSGP"]
  assert est.info.validation["chosen"][1:] == ["LSGP", "LSGP"]


def test_the_command_fits_it_and_refuses_options_it_does_not_read(tmp_path, capsys):
  from calibrate import csvfile
  x, y = _data()
  path = csvfile.write(tmp_path / "r.csv", ["p1", "p2", "p3", "p4", "Fx", "Fy", "Fz"],
                       np.column_stack([x, y]))
  base = ["fit", "--csv", str(path), "--inputs", "p*", "--targets", "Fx,Fy,Fz",
          "--method", "lsgp", "--folds", "0", "--no-progress", "--out", str(tmp_path / "e.npz")]
  assert cli.main(base + ["--hidden", "5"]) == 2
  assert "--hidden is not an option of --method lsgp" in capsys.readouterr().err
  assert cli.main(base) == 0
  assert estimators.Estimator.load(tmp_path / "e.npz").kind is estimators.Kind.LSGP


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
def test_its_c_export_computes_what_predict_does(tmp_path):
  x, y = _data()
  est = estimators.fit("LSGP", x, y, gp=SMALL)
  report = cexport.write(est, tmp_path)
  assert report.tanh == SMALL.points  # one expf per kept point
  got = cexport.run_on_host(est, x[:100], cc=CC)
  want = est.predict(x[:100])
  assert np.max(np.abs(got - want) / np.ptp(y, axis=0)) < 1e-5
