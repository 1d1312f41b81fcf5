"""Estimators as plain data, and the LSANN paper's Table I trends on the --quick footpad data."""

import numpy as np
import pytest

from benchmarks.footpad import table as footpad_table
from benchmarks.registry import Context
from calibrate import estimators, splits
from calibrate.parts import mlp

FAST = mlp.LMConfig(hidden=5, epochs=30)


def _data(n=600, seed=0):
  rng = np.random.default_rng(seed)
  v = rng.uniform(500, 3500, (n, 6))
  f = np.column_stack([v @ rng.normal(size=6) * 1e-2, np.tanh((v[:, 0] - 2000) / 800) * 30,
                       (v[:, 1] / 1000) ** 2])
  return v, f


@pytest.mark.parametrize("kind", estimators.CANDIDATES)  # AUTO: test_honest_validation
def test_save_load_round_trip(kind, tmp_path):
  v, f = _data()
  est = estimators.fit(kind, v, f, config=FAST, seed=1)
  est.save(tmp_path / "e.npz")
  back = estimators.Estimator.load(tmp_path / "e.npz")
  assert back.kind is kind
  np.testing.assert_array_equal(back.predict(v), est.predict(v))


def test_lsann_is_ls_plus_a_network_on_the_residual():
  v, f = _data()
  ls = estimators.fit(estimators.Kind.LS, v, f)
  # the paper's 10 hidden units: with 5, early stopping ends 6 of 10 seeds near the LS start
  # (measured), and the check below would hang on one lucky seed
  est = estimators.fit(estimators.Kind.LSANN, v, f, linear_fit=ls.linear,
                       config=mlp.LMConfig(hidden=10, epochs=30), seed=2)
  f_ls = ls.predict(v)
  np.testing.assert_allclose(est.predict(v), f_ls + est.net.predict(v), rtol=1e-13)
  assert est.net.w1.shape[1] == 6 + 1  # its inputs are the six counts (paper Sec. III-C)
  # the residual network improves on LS where the map is nonlinear
  err = lambda p: np.sqrt(np.mean((p - f) ** 2, axis=0))
  assert err(est.predict(v))[1] < 0.5 * err(f_ls)[1]


def test_same_seed_same_network():
  v, f = _data()
  a = estimators.fit(estimators.Kind.NN, v, f, config=FAST, seed=5)
  b = estimators.fit(estimators.Kind.NN, v, f, config=FAST, seed=5)
  np.testing.assert_array_equal(a.net.w1, b.net.w1)


TREND_SEEDS = footpad_table.SEEDS  # at quick scale the seeds decide a shear cell: their median
# three of the paper's depths, one of them shallow enough to slide (at the --quick depths,
# 0.5-1.5 mm, nothing slides and 29 % of the test lies outside the networks' training
# range at the preset: measured, NN-only's X R2 -49 %)
TREND_Z_LEVELS = "0.0003,0.0009,0.0015"


@pytest.fixture(scope="module")
def table(tmp_path_factory):
  """Table I at quick scale at the paper preset (`sim.footpad.presets`): the trends the
  LSANN paper reports."""
  from sim import settings
  from sim.footpad import presets, protocol
  scene = settings.apply(protocol.base(quick=True, seed=0), {
      **presets.get("paper").overrides(), "z_levels": TREND_Z_LEVELS})
  ctx = Context(quick=True, seed=0, out=tmp_path_factory.mktemp("table"), settings=scene,
                show_progress=False)
  # not the blocks split's networks again: no test here reads them (the heavy tests run
  # asterisk_path whole, blocks included: tests/test_registry.py)
  data = footpad_table.run_table(ctx, ("asterisk",), seeds=TREND_SEEDS, unseen=False,
                                 blocks=False).data
  return {**data["results"], "out": ctx.out, "test_draws": data["test_draws"],
          "comparison": data["comparison"], "first_seed": data["per_seed"][0]}


@pytest.mark.slow  # Table I at quick scale: about 60 s, shared by the tests that read it
def test_predictions_file_reproduces_the_tables_errors(table):
  from calibrate import metrics
  with np.load(table["out"] / "predictions.npz") as z:
    truth, axes = z["truth"].astype(float), tuple(z["axes"])
    assert str(z["unit"]) == "N" and z["time"].shape == (len(truth),)
    for m in footpad_table.METHODS:  # the networks' predictions are their first seed's
      got = metrics.summary(z[f"pred_{m}"].astype(float), truth, axes)
      want = table[m] if m == "LS" else table["first_seed"][m]["test"]
      for ax in axes:  # float32 in the file: agreement to its precision
        assert got[ax]["rmse"] == pytest.approx(want[ax]["rmse"], rel=1e-4), (m, ax)
  ensemble = estimators.Estimator.load(table["out"] / "estimators" / "NN_ensemble.npz")
  assert ensemble.info.inputs == ("p1", "p2", "p3", "p4", "p5", "p6")
  assert ensemble.info.outputs == ("Fx", "Fy", "Fz") and len(ensemble.members) == TREND_SEEDS
  for name in ("force_over_time", "strokes"):
    assert (table["out"] / "figures" / f"{name}.png").stat().st_size > 10_000


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_z_is_estimated_far_better_than_shear(table):
  for m in footpad_table.METHODS:
    z = table[m]["Z"]["nrmse_pct"]
    assert z < 3.0 and z < table[m]["X"]["nrmse_pct"] and z < table[m]["Y"]["nrmse_pct"], m


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_shear_r2_in_the_papers_neighbourhood(table):
  # the paper: 72-84 %; at the nominal values the networks reach 94-97 % (quick, measured)
  for m in ("LSANN", "NN"):
    for ax in ("X", "Y"):
      assert 50.0 < table[m][ax]["r2_pct"] < 95.0, (m, ax)


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_x_is_estimated_better_than_y_by_lsann(table):
  # the paper credits its 2-by-3 array with it (Sec. IV)
  assert table["LSANN"]["X"]["nrmse_pct"] < table["LSANN"]["Y"]["nrmse_pct"]


@pytest.mark.xfail(strict=True, reason="NN-only estimates Y better than X at the preset, here "
                   "(quick: 16.2 against 10.7 %) and at paper scale (8.62 against 7.45 %): "
                   "the die rows along Y give Y the longer lever arm; README, known gaps")
@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_x_is_estimated_better_than_y_by_nn_only(table):
  assert table["NN"]["X"]["nrmse_pct"] < table["NN"]["Y"]["nrmse_pct"]


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_lsann_trains_faster_than_nn_only(table):
  # the paper: 0.41 (59.0 against 144.5 min); the median over the seeds of each one's ratio
  assert table["comparison"]["time_ratio_lsann_over_nn"] < 1.0


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_the_test_is_reported_over_independent_draws_of_its_noise_and_drift(table):
  draws = table["test_draws"]
  for m in footpad_table.METHODS:
    for ax in ("X", "Y", "Z"):
      r2 = draws[m][ax]["r2_pct"]
      assert len(r2) == footpad_table.TEST_DRAWS and len(set(r2)) == len(r2), (m, ax)
    # drift moves shear, not the normal force: the draws spread Z less than either shear
    # axis (not a bound on Z itself: at quick scale a network of a poor seed extrapolates on
    # 16 % of the test, and one draw took LSANN's first seed to Z 97.5 %, Y -779 %)
    spread = {ax: np.ptp(draws[m][ax]["r2_pct"]) for ax in ("X", "Y", "Z")}
    assert spread["Z"] < min(spread["X"], spread["Y"]), (m, spread)
  assert min(draws["LS"]["Z"]["r2_pct"]) > 99.0


@pytest.mark.slow  # Table I at quick scale: about 20 s
def test_lsann_and_nn_agree_within_one_and_a_half_times_in_shear(table):
  # the paper: within 1.05x on every axis; on Z both lie far below shear here (0.6 and 1.3 %,
  # measured), where a ratio of two small numbers says little
  for ax in ("X", "Y"):
    a, b = table["LSANN"][ax]["nrmse_pct"], table["NN"][ax]["nrmse_pct"]
    assert max(a, b) / min(a, b) < 1.5, (ax, a, b)


def test_blocks_split_holds_out_whole_contiguous_blocks():
  tr, va = splits.validation(10_000, 0.15, seed=3, block=1000)
  assert len(np.intersect1d(tr, va)) == 0 and len(tr) + len(va) == 10_000
  assert len(va) == 2000  # round(0.15 x 10 blocks) = 2 blocks
  starts = va[np.flatnonzero(np.diff(np.concatenate([[-2], va])) > 1)]
  assert all(s % 1000 == 0 for s in starts) and len(starts) <= 2
  again = splits.validation(10_000, 0.15, seed=3, block=1000)
  np.testing.assert_array_equal(again[1], va)
  # the paper's split: single samples, almost every one beside a training sample
  _, single = splits.validation(10_000, 0.15, seed=3)
  assert np.mean(np.diff(single) == 1) < 0.3
  with pytest.raises(ValueError, match="validation block"):
    splits.validation(100, 0.15, seed=0, block=80)


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_fits_on_several_processes_equal_serial_ones_to_the_bit():
  """`calibrate.parallel.fit_all`: the same jobs on two workers and one after another in
  one worker give the same weights, bit for bit (each fit its own seed, one thread each)."""
  from calibrate import estimators, parallel
  from calibrate.parts import linear, mlp
  rng = np.random.default_rng(0)
  x = rng.uniform(0, 4000, (600, 6))
  y = np.column_stack([np.tanh(x[:, 0] / 2000 - 1), x[:, 1] / 1000, x[:, 2:].sum(axis=1) / 4000])
  lin = linear.fit_linear(x, y)
  config = mlp.LMConfig(hidden=4, epochs=5)
  jobs = [dict(kind=kind, counts="x", forces="y", seed=seed, config=config, linear_fit=lin)
          for seed in (3, 4) for kind in (estimators.Kind.LSANN, estimators.Kind.NN)]
  serial = parallel.fit_all({"x": x, "y": y}, jobs, workers=1)
  spread = parallel.fit_all({"x": x, "y": y}, jobs, workers=2)
  for a, b in zip(serial, spread):
    assert a.kind == b.kind
    for f in ("w1", "w2"):
      np.testing.assert_array_equal(getattr(a.net, f), getattr(b.net, f))
    np.testing.assert_array_equal(a.predict(x), b.predict(x))
