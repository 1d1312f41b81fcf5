"""Calibrators that remember (`calibrate.temporal`), against systems with known answers: a
Prony relaxation whose inverse is exactly linear in a filter, a drift that taring removes."""

import numpy as np
import pytest
from scipy import signal

from calibrate import estimators, mlp, temporal
from util import errors

DT = 0.001


def _lowpass(x, tau):
  a = np.exp(-DT / tau)
  return signal.lfilter([1 - a], [1, -a], x, axis=0, zi=a * x[:1])[0]


def _loads(rng, n, segments, outputs=2):
  """Smooth random forces (n, outputs) in `segments` recordings, each from rest."""
  f = np.cumsum(rng.normal(size=(n, outputs)), axis=0)
  f = signal.filtfilt(*signal.butter(2, 0.01), f, axis=0) * 5.0
  labels = np.repeat(np.arange(segments), n // segments)
  return f, labels


def _relaxed(f, labels, g_inf, g1, tau):
  """c = g_inf f + g1 (f - LP_tau f): a one-term Prony solid stepped at DT, each recording
  starting relaxed."""
  out = np.empty_like(f)
  for s in np.unique(labels):
    m = labels == s
    out[m] = g_inf * f[m] + g1 * (f[m] - _lowpass(f[m], tau))
  return out


@pytest.mark.filterwarnings("ignore:features are rank-deficient")  # 4 channels of 2 forces
def test_history_features_invert_a_prony_relaxation_exactly():
  """Counts of a known linear system behind a one-term Prony relaxation: the inverse is
  f = (a/b c + (b - a)/(b (1 - b)) LP_b(c)) / (g_inf + g1 a) in discrete time, with
  a = exp(-dt/tau) and b = (g_inf + g1) a / (g_inf + g1 a). The time constant chosen on held
  out recordings is that of b, and LS with it recovers the forces to rounding, where the
  static LS is off by percents."""
  rng = np.random.default_rng(0)
  f, labels = _loads(rng, 24_000, 6)
  mix = rng.normal(size=(4, 2))
  g_inf, g1, tau = 0.7, 0.3, 0.5
  counts = _relaxed(f @ mix.T, labels, g_inf, g1, tau) + 2000.0
  a = np.exp(-DT / tau)
  b = (g_inf + g1) * a / (g_inf + g1 * a)
  tau_star = -DT / np.log(b)
  candidates = (0.05, tau_star, 3.0, 30.0)
  est = estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, segments=labels,
                                candidates=candidates, differences=False)
  assert est.memory.taus == (tau_star,)
  err = np.abs(est.predict(counts, segments=labels) - f).max() / np.abs(f).max()
  assert err < 1e-9
  static = estimators.fit(estimators.Kind.LS, counts, f)
  assert np.abs(static.predict(counts) - f).max() / np.abs(f).max() > 0.01


def _drifting(rng, n=60_000, segments=4, channels=5):
  """Counts of a linear map of forces that press and lift (0.4 s on, 0.1 s off), plus each
  channel's offset wandering by ~30 counts over the run, plus 1 count of noise."""
  t = np.arange(n) * DT
  on = (t % 0.5) < 0.4
  f = np.column_stack([40 * np.sin(2 * np.pi * t / 3.1), 30 * np.cos(2 * np.pi * t / 2.3),
                       80 + 40 * np.sin(2 * np.pi * t / 1.7)]) * on[:, None]
  gain = rng.normal(size=(channels, 3)) * 4.0
  gain[:, 2] = np.abs(gain[:, 2]) + 6.0  # every channel sees the normal force
  drift = np.cumsum(rng.normal(size=(n, channels)), axis=0)
  drift = signal.filtfilt(*signal.butter(1, 1e-4), drift, axis=0)
  drift *= 30.0 / drift.std(axis=0)
  counts = 2000.0 + f @ gain.T + drift + rng.normal(size=(n, channels))
  labels = np.repeat(np.arange(segments), n // segments)
  return counts, f, labels, ~on


def test_tare_removes_a_drift_the_static_map_cannot():
  """A slow offset drift on every channel, the load lifted every 0.5 s: re-zeroing in each
  lift brings LS within a fifth of the static map's error, which stays off by the drift.
  The threshold (15 N) lies above what the drift makes the normal force read (~5-10 N) and
  below the lightest press (40 N): the rule then tares only where the load is off (no false
  tare), and catches the lifts it would miss at 5 N."""
  rng = np.random.default_rng(1)
  counts, f, labels, free = _drifting(rng)
  train = labels < 2
  static = estimators.fit(estimators.Kind.LS, counts[train], f[train])
  tared = estimators.fit_temporal(estimators.Kind.LS, counts[train], f[train], DT,
                                  segments=labels[train], taus=(), differences=False,
                                  tare=temporal.Tare(threshold=15.0, hold=10))
  test = ~train
  rms = lambda p: np.sqrt(np.mean((p - f[test]) ** 2))  # noqa: E731
  e_static = rms(static.predict(counts[test]))
  e_tared = rms(tared.predict(counts[test], segments=labels[test]))
  assert e_tared < 0.2 * e_static
  read = tared.memory.offsets(counts[test], labels[test])[1]
  assert read.sum() > 1000 and not (read & ~free[test]).any()
  # given as a contact flag, the same intervals: the same offsets
  flagged = estimators.fit_temporal(estimators.Kind.LS, counts[train], f[train], DT,
                                    segments=labels[train], taus=(), differences=False,
                                    tare=temporal.Tare(hold=10), contact=~free[train])
  e_flag = rms(flagged.predict(counts[test], segments=labels[test], contact=~free[test]))
  assert e_flag < 0.2 * e_static


def test_filters_and_tares_never_cross_recordings():
  """Two recordings run together give each one's features as if it were alone."""
  rng = np.random.default_rng(2)
  counts, f, labels, _ = _drifting(rng, n=8000, segments=2)
  est = estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, segments=labels,
                                taus=(0.1, 1.0), tare=temporal.Tare(threshold=5.0))
  both = est.memory.features(counts, labels)
  for s in (0, 1):
    m = labels == s
    np.testing.assert_array_equal(both[m], est.memory.features(counts[m]))


def test_temporal_estimators_round_trip_through_a_file(tmp_path):
  rng = np.random.default_rng(3)
  counts, f, labels, _ = _drifting(rng, n=8000, segments=2)
  for kind, extra in ((estimators.Kind.LS, {}),
                      (estimators.Kind.LSANN, {"config": mlp.LMConfig(hidden=4, epochs=5)})):
    est = estimators.fit_temporal(kind, counts, f, DT, segments=labels, taus=(0.3,),
                                  tare=temporal.Tare(threshold=5.0), **extra)
    path = tmp_path / f"{kind.value}.npz"
    est.save(path)
    back = estimators.Estimator.load(path)
    assert back.memory.taus == (0.3,) and back.memory.tare == est.memory.tare
    assert back.info.inputs == ("in0", "in1", "in2", "in3", "in4")
    if kind is estimators.Kind.LSANN:  # the history reaches the LS stage; the net, the counts
      assert back.linear.coef.shape[0] == 15 and back.net.w1.shape[1] == 5 + 1
    np.testing.assert_array_equal(back.predict(counts, segments=labels),
                                  est.predict(counts, segments=labels))


def test_same_seed_same_bytes():
  rng = np.random.default_rng(4)
  counts, f, labels, _ = _drifting(rng, n=8000, segments=2)
  runs = [estimators.fit_temporal(estimators.Kind.LSANN, counts, f, DT, segments=labels,
                                  taus=(0.3,), seed=5, config=mlp.LMConfig(hidden=4, epochs=8))
          .predict(counts, segments=labels).tobytes() for _ in range(2)]
  assert runs[0] == runs[1]


def test_bad_temporal_input_names_the_field():
  rng = np.random.default_rng(5)
  counts, f, labels, _ = _drifting(rng, n=4000, segments=2)
  with pytest.raises(errors.SettingError, match="tare threshold"):
    estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, taus=(),
                            tare=temporal.Tare(threshold=-1.0))
  with pytest.raises(errors.SettingError, match="time constant"):
    estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, taus=(0.0,))
  with pytest.raises(errors.SettingError, match="two segments or more"):
    estimators.fit_temporal(estimators.Kind.LS, counts, f, DT)
  est = estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, taus=(0.3,))
  with pytest.raises(errors.DataError, match="segments has 3 labels"):
    est.predict(counts, segments=labels[:3])


def test_the_c_export_refuses_a_front_end_it_cannot_write(tmp_path):
  from calibrate import cexport
  rng = np.random.default_rng(6)
  counts, f, labels, _ = _drifting(rng, n=4000, segments=2)
  est = estimators.fit_temporal(estimators.Kind.LS, counts, f, DT, taus=(0.3,))
  with pytest.raises(errors.SettingError, match="temporal front end"):
    cexport.write(est, tmp_path)
  assert not list(tmp_path.iterdir())


def test_the_command_line_fits_and_uses_a_front_end(tmp_path, capsys):
  """`python -m calibrate fit --history` on the shipped example (one recording with a time
  column): the estimator keeps its front end through evaluate and predict, lowers the shear
  error of the static LS (measured: Fx NRMSE 10.0 -> 4.8 %), and the commands that cannot
  use it say so."""
  import json
  import pathlib
  import calibrate
  from calibrate import __main__ as cli
  examples = pathlib.Path(calibrate.__file__).parent / "examples"
  common = ["--csv", str(examples / "train.csv"), "--inputs", "p*", "--targets", "Fx,Fy,Fz",
            "--method", "ls", "--no-progress"]
  nrmse = {}
  for name, extra in (("static", []), ("memory", ["--history", "0.1,1"])):
    est = tmp_path / f"{name}.npz"
    assert cli.main(["fit", *common, *extra, "--out", str(est)]) == 0
    assert cli.main(["evaluate", str(est), "--csv", str(examples / "test.csv"), "--out",
                     str(tmp_path / name)]) == 0
    metrics = json.loads((tmp_path / name / "metrics.json").read_text())
    nrmse[name] = metrics["results"]["Fx"]["nrmse_pct"]
  assert estimators.Estimator.load(tmp_path / "memory.npz").memory.taus == (0.1, 1.0)
  assert nrmse["memory"] < 0.7 * nrmse["static"]
  assert cli.main(["predict", str(tmp_path / "memory.npz"), "--csv",
                   str(examples / "test.csv"), "--out", str(tmp_path / "p.csv")]) == 0
  capsys.readouterr()
  assert cli.main(["export", str(tmp_path / "memory.npz"), "--c", str(tmp_path / "c")]) == 2
  assert "temporal front end" in capsys.readouterr().err
  assert cli.main(["compare", *common[:6], "--history", "auto"]) == 2
  assert "compares static estimators" in capsys.readouterr().err
