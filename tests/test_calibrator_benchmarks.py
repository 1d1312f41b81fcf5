"""The calibrators' benchmarks: accuracy against training time (the snapshots stand for capped
runs, the front and the point where time stops paying follow their definitions, the command
runs on both rigs) and the effect ablation."""

import json

import numpy as np
import pytest

from benchmarks import run as cli
from benchmarks.calibrators import accuracy_vs_time as avt
from calibrate import estimators
from calibrate.parts import mlp


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_a_snapshot_at_a_cap_is_the_run_capped_there():
  rng = np.random.default_rng(0)
  x = rng.uniform(-1, 1, (2000, 4))
  y = np.column_stack([np.tanh(x @ rng.normal(size=4)), np.sin(x[:, 0] * 2)])
  long = estimators.fit(estimators.Kind.NN, x, y, config=mlp.LMConfig(hidden=6, epochs=40,
                                                                        max_fail=1000),
                        seed=2, snapshots=(5, 20))
  for cap in (5, 20):
    short = estimators.fit(estimators.Kind.NN, x, y, config=mlp.LMConfig(
        hidden=6, epochs=cap, max_fail=1000), seed=2)
    np.testing.assert_array_equal(estimators.at_epoch_cap(long, cap).net.w1, short.net.w1)
  assert long.training.times.shape == (long.training.epochs + 1,)
  assert np.all(np.diff(long.training.times) > 0)


def _p(name, seconds, error):
  return {"calibrator": name, "seconds": seconds, "error": error}


def test_the_front_keeps_only_points_no_faster_point_beats():
  pts = [_p("a", 1, 10), _p("b", 2, 12), _p("c", 3, 5), _p("d", 0.5, 20), _p("e", 8, 5)]
  assert [p["calibrator"] for p in avt.front(pts)] == ["d", "a", "c"]


def test_time_stops_paying_where_no_later_point_gains_ten_percent_a_doubling():
  # a -> b: one doubling, error x0.5 (pays); b -> c: four doublings, x0.9 (2.6 % a doubling)
  f = [_p("a", 1, 10), _p("b", 2, 5), _p("c", 32, 4.5)]
  assert avt.stops_paying(f)["calibrator"] == "b"
  assert avt.stops_paying([_p("a", 1, 10), _p("b", 2, 5)])["calibrator"] == "b"


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_the_command_gives_points_and_a_front_for_both_sensors(tmp_path):
  args = ["accuracy_vs_time", "--quick", "--no-progress", "--out", str(tmp_path),
          "--set", "hidden=3", "--set", "epochs=2,6", "--set", "dampings=trainlm",
          "--set", "degrees=1,3", "--set", "samples=2000", "--set", "gru_hidden=4",
          "--set", "gru_steps=20"]
  assert cli.main(args) == 0
  m = json.loads((tmp_path / "metrics.json").read_text())
  for rig in ("footpad", "shell"):
    r = m["rigs"][rig]
    # LS, two degrees, two networks at two caps; on the footpad also LS+memory, LSANN+memory
    # at two caps and one GRU+memory
    assert len(r["points"]) == 1 + 2 + 2 * 2 + (1 + 2 + 1) * (rig == "footpad")
    assert all(np.isfinite(p["error"]) and p["predict_us"] > 0 for p in r["points"])
    errors = [p["error"] for p in r["front"]]
    assert errors == sorted(errors, reverse=True)
  shell = {p["calibrator"]: p["error"] for p in m["rigs"]["shell"]["points"]}
  assert shell["POLY3"] < 0.5 * shell["POLY1"]  # the paper's cubic against a linear map


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_effect_ablation_switches_each_shell_effect_on_alone_then_all(tmp_path):
  from sim.shell import effects
  args = ["effect_ablation", "--quick", "--no-progress", "--out", str(tmp_path),
          "--set", "rigs=shell"]
  assert cli.main(args) == 0
  rows = json.loads((tmp_path / "metrics.json").read_text())["rigs"]["shell"]["rows"]
  assert [r["config"] for r in rows] == (["baseline"] + [f"+{e}" for e in effects.EFFECTS]
                                         + ["all"])
  assert rows[-1]["effects"] == list(effects.EFFECTS) and rows[0]["effects"] == []
  by = {r["config"]: r for r in rows}
  # stray light wanders far above the 1-count noise: it costs the calibration most
  assert by["+stray_ir"]["error"] > 2 * by["baseline"]["error"]
  assert by["+sensor_noise"]["error"] < 1.2 * by["baseline"]["error"]


def test_real_recordings_pools_its_draws_by_their_test_samples():
  """Over draws, NRMSE is the draws' mean and coverage the share of every draw's test samples
  inside: a draw of 300 samples, 1/3 beyond the box, and one of 100, none beyond."""
  from benchmarks.calibrators import real_recordings as rr
  one = {"auto": {"nrmse_pct": [2.0, 4.0], "r2_pct": [99.0, 98.0], "seconds": 1.0,
                  "test_samples": 300, "inputs_out_of_box_pct": [100 / 3] * 2,
                  "coverage_pct": [80.0, 90.0], "coverage_in_box_pct": [90.0, 95.0],
                  "coverage_out_of_box_pct": [60.0, 80.0]},
         "sklearn MLP": {"nrmse_pct": [3.0, 3.0], "r2_pct": [98.0, 98.0], "seconds": 2.0}}
  two = {"auto": {"nrmse_pct": [4.0, 2.0], "r2_pct": [97.0, 99.0], "seconds": 3.0,
                  "test_samples": 100, "inputs_out_of_box_pct": [0.0] * 2,
                  "coverage_pct": [100.0, 50.0], "coverage_in_box_pct": [100.0, 50.0],
                  "coverage_out_of_box_pct": [float("nan")] * 2},
         "sklearn MLP": {"nrmse_pct": [1.0, 5.0], "r2_pct": [99.0, 97.0], "seconds": 4.0}}
  got = rr.pool([one, two])
  a = got["auto"]
  np.testing.assert_allclose(a["nrmse_pct"], [3.0, 3.0])
  np.testing.assert_allclose(a["seconds"], 2.0)
  # in the box: 200 x 90 % + 100 x 100 % of 300; beyond: the first draw's 100 alone
  np.testing.assert_allclose(a["coverage_in_box_pct"], [(180 + 100) / 3, (190 + 50) / 3])
  np.testing.assert_allclose(a["coverage_out_of_box_pct"], [60.0, 80.0])
  np.testing.assert_allclose(a["coverage_pct"], [(240 + 100) / 4, (270 + 50) / 4])
  np.testing.assert_allclose(a["inputs_out_of_box_pct"], [25.0, 25.0])
  assert a["test_samples"] == 400 and "coverage_pct" not in got["sklearn MLP"]
  # the ratio of the means, not the mean of the ratios (0.67 and 4.0; 1.33 and 0.4)
  assert rr.ratios(got, ("Fx", "Fy"))[0] == "auto / best baseline, per axis: Fx: 1.50 Fy: 0.75"


@pytest.mark.parametrize("recordings, asked, want", [(24, 0, 10), (12, 0, 5), (24, 3, 3)])
def test_real_recordings_holds_out_the_folds_calibrate_fit_would(recordings, asked, want):
  """folds=0 (the default) counts the folds as `python -m calibrate fit --folds auto` does;
  a number is taken as given; the printed report says how many."""
  import types
  from benchmarks.calibrators import real_recordings as rr
  from calibrate import splits
  rec = np.repeat(np.arange(recordings), 4)
  d = rr.Data(np.zeros((len(rec), 2)), np.zeros((len(rec), 1)), rec, np.zeros((1, 2)),
              np.zeros((1, 1)), ("Fx",), "data", np.zeros(1, int))
  ctx = types.SimpleNamespace(settings=rr.RealRecordings(folds=asked))
  assert rr._folds(ctx, d) == want
  if not asked:
    assert want == splits.fold_count(splits.groups(len(rec), "recordings", rec), "auto")
  assert rr._folds_line(ctx, d).startswith(
      f"held out: {want}-fold grouped cross-validation over the {recordings} training ")


def test_a_coverage_over_few_recordings_is_given_its_spread_over_them():
  """A coverage resting on R recordings, each nearly all inside or all outside its interval,
  is a share of R draws: resampled over the recordings its 90 % range is the binomial's
  (scipy), not a sample count's; pooled draws resample the draws, each with its recordings
  (they share its paths and loads), so a spread between draws shows whole."""
  import scipy.stats
  from benchmarks.calibrators import real_recordings as rr
  from calibrate import metrics
  r, p = 40, 0.9  # 36 of 40 equal recordings inside, 4 outside
  hits = np.column_stack([np.r_[np.full(36, 100.0), np.zeros(4)], np.full(r, 50.0)])
  lo, hi = metrics.share_range(hits, np.full(r, 100.0), seed=3, resamples=20_000)
  want = 100 * scipy.stats.binom.ppf([0.05, 0.95], r, p) / r
  np.testing.assert_allclose([lo[0], hi[0]], want, atol=2.5)  # one recording is 2.5 %
  assert lo[1] == hi[1] == 50.0  # every recording half inside: no spread
  again = metrics.share_range(hits, np.full(r, 100.0), seed=3, resamples=20_000)
  np.testing.assert_array_equal(again[0], lo)  # the same seed, the same range
  # a recording without in-box samples is no draw; one recording alone tells no spread
  none = metrics.share_range(np.array([[5.0], [0.0]]), np.array([10.0, 0.0]), seed=0)
  assert np.isnan(none).all()
  # pooled draws resample the draws, each one's recordings together (they share its paths)
  draw = {"auto": {"nrmse_pct": [1.0], "r2_pct": [99.0], "seconds": 1.0, "test_samples": 300,
                   "inputs_out_of_box_pct": [0.0], "coverage_pct": [100.0],
                   "coverage_in_box_pct": [100.0], "coverage_out_of_box_pct": [float("nan")],
                   "in_box_by_recording": [100.0, 100.0, 100.0],
                   "in_box_inside_by_recording": [[100.0, 100.0, 100.0]]}}
  worse = {"auto": {**draw["auto"], "coverage_pct": [0.0], "coverage_in_box_pct": [0.0],
                    "in_box_inside_by_recording": [[0.0, 0.0, 0.0]]}}
  got = rr.pool([draw, worse], seed=1)["auto"]
  assert got["in_box_by_draw"] == [300.0] * 2
  assert got["in_box_inside_by_draw"] == [[300.0, 0.0]]
  lo, hi = got["coverage_in_box_range_pct"]
  # two draws resampled: 0, 50 or 100 %, each of the extremes a quarter of the time
  assert (lo[0], hi[0]) == (0.0, 100.0) and got["coverage_in_box_pct"] == [50.0]
  line = rr.coverage_spread({"auto": got}, ("Fx",))[0]
  assert "rests on 2 draws" in line and "Fx: 0.0-100.0" in line
  # recordings that agree within each draw but not between draws: as draws the range is
  # wider than the nine recordings' would be (Binomial(9, 2/3)'s 5 % point, 4 of 9)
  three = rr.pool([draw, worse, draw], seed=1)["auto"]["coverage_in_box_range_pct"]
  alone = metrics.share_range(np.array([[100.0]] * 6 + [[0.0]] * 3), np.full(9, 100.0), seed=1)
  assert three[0][0] == pytest.approx(100 / 3) and alone[0][0] == pytest.approx(400 / 9)


def test_a_bias_common_to_the_test_recordings_is_scored_against_the_held_out_offsets():
  """`calibrate.info.common_bias`: recordings offset by +-a about a common b give the mean
  b, and z = b over RMS(held-out offsets) x sqrt((1/R + 1/G) (G - 1)/G); recordings drawn
  about zero give z = 0; the line names the axes beyond Student's t's 97.5 % point at G - 1
  degrees of freedom (scipy: 12.71 at 1)."""
  from benchmarks.calibrators import real_recordings as rr
  from calibrate import info
  rng = np.random.default_rng(0)
  rec = np.repeat(np.arange(4), 50)
  noise = rng.standard_normal((200, 2))
  noise -= np.array([noise[rec == g].mean(axis=0) for g in range(4)])[rec]  # zero per recording
  shift = np.array([[1.0, 3.0], [-1.0, -3.0], [1.0, 3.0], [-1.0, -3.0]])
  offsets = np.array([[2.0, 0.5], [-2.0, -0.5]])  # RMS 2 and 0.5
  got = info.common_bias(noise + shift[rec] + [1.5, 0.0], rec, offsets)
  np.testing.assert_allclose(got["test_common_bias"], [1.5, 0.0], atol=1e-12)
  np.testing.assert_allclose(got["test_bias_z"], [1.5 / (2.0 * np.sqrt(0.75 / 2)), 0.0],
                             atol=1e-12)
  assert "test_bias_z" not in info.common_bias(noise, rec, None)  # no held-out offsets, no z
  assert got["test_bias_dof"] == 1
  line = rr.bias_lines({"auto": {**got, "test_bias_z": [13.0, 4.0],
                                 "in_box_by_recording": [50, 50, 50, 50]}}, ("Fx", "Fy"))[0]
  assert "4 test recordings" in line and "beyond 12.71 (one time in twenty by chance) on Fx:" \
      in line
  pooled = rr.bias_lines({}, ("Fx", "Fy"), [
      {"auto": {"test_bias_z": [3.0, 1.0], "test_bias_dof": 4}},
      {"auto": {"test_bias_z": [-1.0, 1.0], "test_bias_dof": 4}}])[0]
  assert f"Fx: {np.sqrt(5):.1f} Fy: 1.0" in pooled and "(1.41 where" in pooled \
      and "the 5 held-out ones" in pooled


def test_the_test_bias_z_of_recordings_drawn_alike_is_students_t():
  """Every recording's offset a normal draw, the estimator's own the mean of its G training
  recordings', each held out in turn: z of R test recordings lies beyond Student's t's
  97.5 % point at G - 1 degrees of freedom 5 % of the time, to three standard errors over
  4,000 draws (over RMS(offsets)/sqrt(R) and beyond t at G, as it was, 11.1 % at G = R = 5;
  simulated, 200,000 draws)."""
  import scipy.stats
  from calibrate import info
  rng = np.random.default_rng(7)
  g, r, n = 5, 5, 4000
  edge = scipy.stats.t.ppf(0.975, g - 1)
  rec = np.repeat(np.arange(r), 2)
  far = 0
  for _ in range(n):
    train, test = rng.normal(size=g), rng.normal(size=r)
    held = train - (train.sum() - train) / (g - 1)  # each less the other recordings' mean
    got = info.common_bias((test - train.mean())[rec][:, None], rec, held[:, None])
    far += abs(got["test_bias_z"][0]) > edge
  assert abs(far / n - 0.05) < 3 * np.sqrt(0.05 * 0.95 / n), far / n
