"""From raw streams to a calibration: merge, lag, gaps, wrap-around, rails, tare, repeated
times and empty cells, each checked against a planted answer."""

from __future__ import annotations

import numpy as np
import pytest

from calibrate import __main__ as cli, csvfile, prepare, streams
from util import errors

LAG = 0.025  # s: the reference stamps an event this much later
SENSOR_HZ = 88.0
W = np.array([0.9, 1.7, 0.4])  # rad/s of the true force's three axes


def _force(t: np.ndarray) -> np.ndarray:
  return np.column_stack([5 * np.sin(W[0] * 2 * np.pi * t), 3 * np.cos(W[1] * 2 * np.pi * t),
                          20 + 15 * np.sin(W[2] * 2 * np.pi * t) ** 2])


def _streams(seed=0, seconds=40.0, start=0.3, quiet=0.0, mix_seed=None):
  """A sensor at 88 Hz (6 channels linear in the force, mixed by `mix_seed`'s matrix) and a
  reference at an irregular 250 Hz (periods 2-6 ms) stamping every event LAG later; the
  force rests for the first `quiet` seconds."""
  rng = np.random.default_rng(seed)
  mix = np.random.default_rng(seed if mix_seed is None else mix_seed).normal(size=(3, 6))

  def force(t):
    return _force(np.maximum(t, quiet))
  ts = np.arange(0, seconds, 1 / SENSOR_HZ) + start
  tr = np.cumsum(rng.uniform(0.5, 1.5, int(seconds * 250) + 200) / 250)
  counts = force(ts) @ mix * 20 + 2000 + rng.normal(0, 1, (len(ts), 6))  # 1 count of noise
  sensor = csvfile.Table(("time",) + tuple(f"p{i}" for i in range(6)), ("s",) + ("counts",) * 6,
                         np.column_stack([ts, counts]), "sensor.csv")
  reference = csvfile.Table(("time", "Fx", "Fy", "Fz"), ("s", "N", "N", "N"),
                            np.column_stack([tr, force(tr - LAG)]), "reference.csv")
  return sensor, reference


def test_merged_targets_are_the_true_force_at_the_sensor_samples():
  sensor, reference = _streams()
  m = streams.merge(sensor, reference, lag=LAG)
  truth = _force(m.data[:, 0])
  # linear interpolation over a reference period h <= 6 ms: error <= h^2/8 max|f''|
  h = np.diff(reference.data[:, 0]).max()
  bound = h ** 2 / 8 * np.array([5, 3, 15 * 2]) * (2 * np.pi * W * np.array([1, 1, 2])) ** 2
  assert (np.abs(m.data[:, 7:] - truth).max(axis=0) <= bound * 1.001).all()
  assert m.names[7:] == ("Fx", "Fy", "Fz") and m.units[7:] == ("N", "N", "N")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_lag_estimate_is_within_one_sensor_period(seed):
  sensor, reference = _streams(seed)
  m = streams.merge(sensor, reference)  # lag from the data
  assert abs(m.lag - LAG) < 1 / SENSOR_HZ, m.lag
  assert m.lag_estimated == m.lag


def test_outside_the_overlap_and_inside_gaps_rows_are_dropped_and_counted():
  sensor, reference = _streams(start=-0.5)  # the sensor starts first
  tr = reference.data[:, 0]
  cut = (tr > 10.0) & (tr < 10.4)  # the reference logged nothing for 0.4 s
  reference = csvfile.Table(reference.names, reference.units, reference.data[~cut], "r.csv")
  m = streams.merge(sensor, reference, lag=LAG)
  ts = sensor.data[:, 0]
  t_ref = reference.data[:, 0] - LAG
  outside = (ts < t_ref[0]) | (ts > t_ref[-1])
  lo, hi = t_ref[t_ref <= 10.0 - LAG].max(), t_ref[t_ref >= 10.4 - LAG].min()
  in_gap = (ts > lo) & (ts < hi)
  assert m.outside == outside.sum() > 0
  assert m.in_gaps == in_gap.sum() > 0
  assert len(m.data) == len(ts) - outside.sum() - in_gap.sum()
  assert not ((m.data[:, 0] > lo) & (m.data[:, 0] < hi)).any()  # nothing invented there


def test_wraps_planted_every_n_samples_are_all_found_and_undone_exactly():
  rng = np.random.default_rng(3)
  lsb, bits, every = 0.15, 16, 137  # a magnetometer: 0.15 uT per bit, 16-bit registers
  true = np.round(np.cumsum(rng.normal(0, 30, (2000, 3)), axis=0) / lsb) * lsb
  period = 2 ** bits * lsb
  k = np.zeros(2000)
  k[every::every] = rng.choice([-1.0, 1.0], len(k[every::every]))  # a wrap up or down
  wrapped = true.copy()
  wrapped[:, 1] += np.cumsum(k) * period  # planted on channel 1 every 137 samples
  found = prepare.jumps(wrapped, np.full(3, period / 2))
  assert found == [(r, 1) for r in range(every, 2000, every)]
  back, undone = prepare.unwrap(wrapped, np.full(3, period))
  assert undone.tolist() == [0, len(found), 0]
  np.testing.assert_allclose(back, true, atol=1e-9 * period)
  assert prepare.lsb(true[:, 0]) == pytest.approx(lsb)


def test_a_wrap_with_a_repaired_row_in_its_middle_is_undone():
  """A logger's repaired row interpolated across a wrap splits it into two steps, each under
  half the period: both are one wrap, and the repaired row takes its neighbours' mean."""
  rng = np.random.default_rng(8)
  lsb, bits = 0.3, 16
  period = 2 ** bits * lsb
  t = np.arange(3000)
  true = np.column_stack([1.2 * period * np.sin(t / 150), 0.3 * period * np.sin(t / 40)])
  true += rng.normal(0, 3, true.shape)  # channel 0 crosses the register's ends, 1 never
  raw = (true + period / 2) % period - period / 2
  wraps = np.flatnonzero(np.abs(np.diff(raw[:, 0])) > period / 2) + 1
  assert len(wraps) >= 3
  repaired = wraps[::2]  # every other wrap gets a repaired row in its middle
  raw[repaired, 0] = (raw[repaired - 1, 0] + raw[repaired + 1, 0]) / 2
  back, undone = prepare.unwrap(raw, np.full(2, period))
  assert undone.tolist() == [len(wraps), 0]
  clean = np.setdiff1d(np.arange(3000), repaired)
  np.testing.assert_allclose(back[clean] - back[0] + true[0], true[clean], atol=1e-6)
  # the repaired rows: their unwrapped neighbours' mean
  np.testing.assert_allclose(back[repaired, 0],
                             (back[repaired - 1, 0] + back[repaired + 1, 0]) / 2)
  # the swinging channel's steps stay under a quarter period: nothing undone there
  np.testing.assert_array_equal(back[:, 1], raw[:, 1])


def test_a_planted_rail_is_reported_with_its_exact_share():
  rng = np.random.default_rng(4)
  x = rng.uniform(100, 900, (1000, 3))
  x[300:420, 2] = 1023.0  # channel 2 on its rail for 120 samples
  x[700:760, 0] = 0.0  # channel 0 on the other for 60
  given = prepare.at_rails(x, (0.0, 1023.0))
  found = prepare.at_rails(x, None)
  for mask in (given, found):
    assert mask.sum(axis=0).tolist() == [60, 0, 120]
  table = csvfile.Table(("a", "b", "c"), ("",) * 3, x, "rails.csv")
  ready = prepare.apply([table], [0, 1, 2], None, prepare.Steps(drop_rails=True))
  assert any("at a rail: a 60 of 1000 samples (6.0%), c 120 of 1000 samples (12.0%)" in s
             for s in ready.said)
  assert len(ready.x) == 1000 - 180


def _static_10bit(seed=5, states=20, hold=200):
  """A sensor on a 10-bit ADC under static loads held `hold` samples each: its readings in
  50-950, quiet within a state (one count of noise, often none), the reference's loads too."""
  rng = np.random.default_rng(seed)
  loads = np.repeat(rng.uniform(-10, 10, (states, 3)), hold, axis=0)
  mix = rng.normal(size=(3, 4))
  counts = np.clip(np.round(500 + loads @ mix * 40 / np.abs(mix).sum(axis=0)
                            + rng.normal(0, 0.3, (len(loads), 4))), 50, 950)
  return counts, loads


def test_static_loads_and_a_tared_logger_are_no_rail_and_no_wrap():
  """The detectors' false positives: held states inside the ADC's range, and a logger that
  reads exactly 0 V at rest, each holding its extreme for many samples with nothing else
  moving, are at no rail; a channel at rest, a few counts of noise, does not wrap."""
  counts, loads = _static_10bit()
  assert not prepare.at_rails(counts, None, loads).any()
  volts = np.concatenate([np.zeros(300), np.linspace(0, 2.5, 200), np.full(300, 2.5),
                          np.linspace(2.5, 0, 200), np.zeros(300)])  # rest, press, rest
  force = volts * 40
  assert not prepare.at_rails(volts[:, None], None, force[:, None]).any()
  noise = np.round(np.random.default_rng(6).normal(2000, 1.5, (5000, 2)))  # at rest
  assert prepare.wrap_like(noise) == [] and prepare.wrap_like(counts, loads) == []
  table = csvfile.Table(tuple("abcdFGH"), ("",) * 7, np.column_stack([counts, loads]),
                        "static.csv")
  ready = prepare.apply([table], [0, 1, 2, 3], [4, 5, 6], prepare.Steps())
  assert ready.said == ()


def test_recordings_of_one_static_load_each_are_at_no_rail():
  """A printed F/T sensor's layout: each recording one load held 200 samples, a count of
  noise on the sensor and a little on the reference. Within a recording every column spans
  its noise alone; against that a count "moves", so the recording's own ranges called most
  channels railed. Against every recording's ranges nothing moves: no rail line. A
  recording where the load sweeps and a channel clips is still found beside them."""
  rng = np.random.default_rng(8)
  states = rng.uniform(-10, 10, (20, 3))
  mix = rng.normal(size=(3, 4))
  loads = np.repeat(states, 200, axis=0) + rng.normal(0, 0.002, (4000, 3))  # the logger's noise
  # quieter than a count: most channels hold one value through their recording
  counts = np.round(500 + np.repeat(states @ mix * 40 / np.abs(mix).sum(axis=0), 200, axis=0)
                    + rng.normal(0, 0.15, (4000, 4)))
  tables = [csvfile.Table(tuple("abcdFGH"), ("",) * 7,
                          np.column_stack([counts, loads])[k:k + 200], f"state{k // 200}.csv")
            for k in range(0, len(counts), 200)]
  assert sum(prepare.at_rails(t.data[:, :4], None, t.data[:, 4:]).any() for t in tables) > 10
  ready = prepare.apply(tables, [0, 1, 2, 3], [4, 5, 6], prepare.Steps())
  assert not any("rail" in line for line in ready.said), ready.said
  sweep = np.column_stack([np.linspace(-10, 10, 400)] * 3)
  clipped = np.column_stack([500 + 80 * sweep[:, 0], 500 + 20 * sweep])
  clipped[:, 0] = np.minimum(clipped[:, 0], 950.0)  # at the top from 5.6 N on
  moving = csvfile.Table(tuple("abcdFGH"), ("",) * 7, np.column_stack([clipped, sweep]),
                         "sweep.csv")
  ready = prepare.apply(tables + [moving], [0, 1, 2, 3], [4, 5, 6], prepare.Steps())
  rails = [line for line in ready.said if "rail" in line]
  held = int(np.sum(clipped[:, 0] == 950.0))
  assert rails == [f"sweep.csv: at a rail: a {held} of 400 samples ({held / 400:.1%}): "
                   f"--drop-rails removes them"]


def test_fit_and_evaluate_on_static_recordings_say_no_rail_and_no_infinite_metric(tmp_path,
                                                                                 capsys):
  """One static load per file, as a user's F/T logger writes them: `fit` and `evaluate`
  print no rail line (evaluate judges a load's movement against the training ranges, its
  one file spanning its noise alone); on a file whose truth holds one value the metrics
  that scale by its spread are NaN, said in one line, not infinite, and a file with every
  input inside the training box has no coverage beyond it (NaN in metrics.csv)."""
  import json
  import warnings
  rng = np.random.default_rng(8)
  mix = rng.normal(size=(3, 4))
  names = ["s1", "s2", "s3", "s4", "Fx", "Fy", "Fz"]
  for k in range(12):
    load = rng.uniform(-10, 10, 3) if k < 11 else np.zeros(3)  # the last at rest, inside
    counts = np.round(500 + load @ mix * 40 / np.abs(mix).sum(axis=0)
                      + rng.normal(0, 0.15, (200, 4)))
    if k == 11:  # at rest: one channel holds, another flickers a count
      counts[:, 0], counts[:, 1] = 500, 500 + np.arange(200) % 2
    csvfile.write(tmp_path / f"state{k:02d}.csv", names, np.column_stack(
        [counts, np.tile(load, (200, 1))]))
  with warnings.catch_warnings():
    warnings.simplefilter("error", RuntimeWarning)  # no division by a zero range
    assert cli.main(["fit", "--csv", str(tmp_path / "state0*.csv"), str(tmp_path / "state10.csv"),
                     "--inputs", "s*", "--targets", "Fx,Fy,Fz", "--method", "ls",
                     "--out", str(tmp_path / "e.npz")]) == 0
    fitted = capsys.readouterr().out
    assert cli.main(["evaluate", str(tmp_path / "e.npz"), "--csv", str(tmp_path / "state11.csv"),
                     "--out", str(tmp_path / "ev")]) == 0
  said = capsys.readouterr().out
  assert "rail" not in fitted and "rail" not in said, (fitted, said)
  assert "Fx, Fy, Fz: the truth holds one value here (a static load)" in said
  got = json.loads((tmp_path / "ev" / "metrics.json").read_text())["results"]
  assert np.isfinite(got["Fx"]["rmse"]) and got["Fx"]["interval_coverage_out_of_box_pct"] is None
  rows = (tmp_path / "ev" / "metrics.csv").read_text().splitlines()
  assert any(",Fx,nrmse_pct,nan" in r for r in rows) and \
      any(",Fx,interval_coverage_out_of_box_pct,nan" in r for r in rows), rows[:12]


def test_a_rail_while_the_load_moves_is_found_beside_a_held_state():
  """The true case beside the false one: one channel clips at 1023 while the others (and
  the load) keep moving; another holds a state while everything holds."""
  t = np.linspace(0, 20, 2000)
  load = np.column_stack([np.sin(t), np.cos(0.7 * t)])
  x = np.column_stack([600 + 600 * load[:, 0], 500 + 300 * load[:, 1]])
  x[:, 0] = np.minimum(x[:, 0], 1023.0)  # clips over the sine's crests
  x[1800:, :] = x[1800]  # the last 200 samples: everything at rest
  load[1800:] = load[1800]
  found = prepare.at_rails(x, None, load)
  np.testing.assert_array_equal(found[:, 0], x[:, 0] == 1023.0)
  assert found[:, 0].sum() > 100 and not found[:, 1].any()


def test_a_few_values_off_the_grid_do_not_set_the_least_significant_bit():
  rng = np.random.default_rng(7)
  grid = np.round(rng.normal(0, 300, 5000) / 0.3) * 0.3  # a magnetometer's 0.3 uT bit
  grid[rng.choice(5000, 6, replace=False)] += 0.002 * rng.integers(1, 10, 6)
  assert prepare.lsb(grid) == pytest.approx(0.3)


def test_blocks_stay_within_their_recording():
  from calibrate import splits
  rec = np.repeat([0, 1, 2], [130, 70, 100])
  g = splits.groups(300, "blocks", rec, block=40)
  for label in range(g.count):
    assert len(np.unique(rec[g.labels == label])) == 1
  assert g.count == 4 + 2 + 3  # ceil(130/40), ceil(70/40), ceil(100/40)


def test_a_tare_makes_per_recording_offsets_vanish():
  """Two recordings of one sensor, each with its own input and target offset over an
  unloaded first second: after the tare they are the same recording."""
  t = np.arange(0, 10, 0.01)
  load = np.where(t[:, None] < 1.0, 0.0, np.sin(t)[:, None] * [1.0, 2.0])
  tables = []
  for k, (dx, dy) in enumerate([(37.0, 0.8), (-120.0, -2.5)]):
    x = load @ [[3.0, 1.0, 0.5], [0.2, 2.0, 1.0]] * 100 + 1000 + dx
    y = load + dy
    tables.append(csvfile.Table(("time", "a", "b", "c", "F1", "F2"), ("",) * 6,
                                np.column_stack([t, x, y]), f"rec{k}.csv"))
  steps = prepare.Steps(tare=prepare.Tare(seconds=1.0))
  ready = prepare.apply(tables, [1, 2, 3], [4, 5], steps)
  n = len(t)
  np.testing.assert_allclose(ready.x[:n], ready.x[n:], atol=1e-9)
  np.testing.assert_allclose(ready.y[:n], ready.y[n:], atol=1e-12)
  np.testing.assert_allclose(ready.y[:n], load, atol=1e-12)
  assert ready.record["tare"]["seconds"] == 1.0


def test_empty_cells_and_repeated_times_are_refused_or_dropped_and_counted(tmp_path):
  path = tmp_path / "log.csv"
  path.write_text("time,a,F\n0,1,2\n0.1,,3\n0.2,2,4\n0.2,4,6\n0.3,5,nan\n0.4,6,7\n")
  with pytest.raises(errors.DataError, match="line 3, column 'a': is empty .*--drop-nan"):
    csvfile.read(path)
  with pytest.raises(errors.DataError, match="line 5: time 0.2 repeats .*--dedupe"):
    csvfile.read(path, drop_nan=True)
  table = csvfile.read(path, drop_nan=True, dedupe="mean")
  assert table.data.tolist() == [[0, 1, 2], [0.2, 3, 5], [0.4, 6, 7]]
  assert table.lines.tolist() == [2, 4, 7]
  assert table.cleaned == ("2 row(s) with an empty cell or NaN dropped",
                           "1 row(s) repeating a time averaged")
  first = csvfile.read(path, drop_nan=True, dedupe="first")
  assert first.data[1].tolist() == [0.2, 2, 4]


def _write(path, table):
  csvfile.write(path, table.names, table.data, table.units)


def test_the_command_merges_pairs_fits_with_a_tare_and_applies_it_again(tmp_path, capsys):
  """Two recordings as raw stream pairs, each with its own sensor and reference offset:
  `merge` then `fit --tare`; `predict` on a third recording tares it by the same rule, and
  `evaluate` scores it against its tared truth."""
  pairs = []
  for k in range(3):
    # one sensor, three recordings: at rest for their first 1.5 s
    sensor, reference = _streams(seed=10 + k, start=0.0, quiet=1.5, mix_seed=99)
    rng = np.random.default_rng(k)
    sensor.data[:, 1:] += rng.normal(0, 50, 6)  # this recording's baseline
    reference.data[:, 1:] += rng.normal(0, 2, 3)  # and its reference's offset
    pairs += [tmp_path / f"s{k}.csv", tmp_path / f"r{k}.csv"]
    _write(pairs[-2], sensor)
    _write(pairs[-1], reference)
  assert cli.main(["merge", *map(str, pairs[:4]), "--lag", str(LAG), "--out",
                   str(tmp_path / "merged")]) == 0
  out = capsys.readouterr().out
  assert "merged 2 pair(s)" in out and "lag 25.0 ms" in out
  assert cli.main(["fit", "--csv", str(tmp_path / "merged" / "*.csv"), "--inputs", "p*",
                   "--targets", "Fx,Fy,Fz", "--method", "ls", "--tare", "1", "--folds", "2",
                   "--no-progress", "--out", str(tmp_path / "e.npz")]) == 0
  out = capsys.readouterr().out
  assert "tare: each input and target less its median over the first 1 s" in out
  assert "rail" not in out and "jump" not in out  # nothing to report in these
  assert cli.main(["merge", *map(str, pairs[4:]), "--lag", str(LAG), "--out",
                   str(tmp_path / "new")]) == 0
  assert cli.main(["evaluate", str(tmp_path / "e.npz"), "--csv", str(tmp_path / "new" /
                   "s2.csv"), "--out", str(tmp_path / "ev")]) == 0
  import json
  result = json.loads((tmp_path / "ev" / "metrics.json").read_text())["results"]
  assert all(result[a]["nrmse_pct"] < 1.0 for a in ("Fx", "Fy", "Fz")), result


CC = __import__("shutil").which("cc") or __import__("shutil").which("gcc")
TARE_HARNESS = r"""
#include <stdio.h>
#include "estimator.h"
int main(void) {
  int n_tare;
  unsigned v;
  uint16_t c[ESTIMATOR_INPUTS]; float out[ESTIMATOR_OUTPUTS];
  if (scanf("%d", &n_tare) != 1) return 1;
  estimate_tare_reset();
  for (int k = 0; k < n_tare; ++k) {
    for (int i = 0; i < ESTIMATOR_INPUTS; ++i) { if (scanf("%u", &v) != 1) return 1; c[i] = v; }
    estimate_tare_add(c);
  }
  estimate_tare_end();
  for (;;) {
    for (int i = 0; i < ESTIMATOR_INPUTS; ++i) { if (scanf("%u", &v) != 1) return 0; c[i] = v; }
    estimate(c, out);
    for (int j = 0; j < ESTIMATOR_OUTPUTS; ++j) printf("%.9g ", out[j]);
    printf("\n");
  }
}
"""


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
def test_the_c_export_tares_as_predict_does(tmp_path, capsys):
  """Fitted with --tare on raw counts: the C function takes the raw counts, tares them on the
  recording's first second as `predict` does, and agrees with it within 1e-5 of each
  output's scale."""
  import subprocess
  paths = []
  for k in range(2):
    sensor, reference = _streams(seed=20 + k, start=0.0, quiet=1.5, mix_seed=98)
    sensor.data[:, 1:] = np.round(sensor.data[:, 1:] + 40 * k)  # counts, a baseline each
    reference.data[:, 1:] += k
    m = streams.merge(sensor, reference, lag=LAG)
    paths.append(tmp_path / f"rec{k}.csv")
    csvfile.write(paths[-1], m.names, m.data, m.units)
  est_path = tmp_path / "e.npz"
  assert cli.main(["fit", "--csv", *map(str, paths), "--inputs", "p*", "--targets",
                   "Fx,Fy,Fz", "--method", "lsann", "--epochs", "5", "--tare", "1",
                   "--folds", "2", "--no-progress", "--out", str(est_path)]) == 0
  assert cli.main(["predict", str(est_path), "--csv", str(paths[1]), "--out",
                   str(tmp_path / "p.csv")]) == 0
  assert cli.main(["export", str(est_path), "--c", str(tmp_path / "c")]) == 0
  capsys.readouterr()
  want = csvfile.read(tmp_path / "p.csv").data[:, 1:]
  (tmp_path / "c" / "main.c").write_text(TARE_HARNESS)
  exe = tmp_path / "est"
  subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic",
                  str(tmp_path / "c" / "estimator.c"), str(tmp_path / "c" / "main.c"), "-lm",
                  "-o", str(exe)], check=True, capture_output=True, text=True)
  rec = csvfile.read(paths[1])
  counts = rec.data[:, 1:7].astype(int)
  quiet = rec.data[:, 0] - rec.data[0, 0] < 1.0
  text = "\n".join([str(quiet.sum())] + [" ".join(map(str, r)) for r in counts[quiet]]
                   + [" ".join(map(str, r)) for r in counts])
  run = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
  got = np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])
  scale = np.abs(want).max(axis=0)
  assert np.max(np.abs(got - want) / scale) < 1e-5


def test_a_lag_estimate_far_from_the_others_is_replaced_by_their_median(tmp_path, capsys,
                                                                       monkeypatch):
  """One logger's lag does not change between recordings: of four pairs (all stamped LAG
  late), the one whose estimate locks onto another event (+918 ms, as measured on a real
  fingertip's log) is named in a warning and merged at the others' median, so its targets
  are the true force; the three that agree are not named."""
  pairs = []
  for k in range(4):
    sensor, reference = _streams(seed=20 + k, seconds=20.0, mix_seed=5)
    pairs += [tmp_path / f"s{k}.csv", tmp_path / f"r{k}.csv"]
    _write(pairs[-2], sensor)
    _write(pairs[-1], reference)
  estimate, calls = streams.estimate_lag, []

  def locked_on_another_event(*a, **kw):
    calls.append(1)
    return 0.918 if len(calls) == 4 else estimate(*a, **kw)
  monkeypatch.setattr(streams, "estimate_lag", locked_on_another_event)
  assert cli.main(["merge", *map(str, pairs), "--out", str(tmp_path / "m")]) == 0
  out = capsys.readouterr().out
  warned = [line for line in out.splitlines() if line.startswith("warning:")]
  assert len(warned) == 1 and "s3.csv" in warned[0] and "918.0 ms" in warned[0], out
  assert "(1 estimate(s) far from the others replaced by their median)" in out
  merged = csvfile.read(tmp_path / "m" / "s3.csv")
  np.testing.assert_allclose(merged.data[:, 7:], _force(merged.data[:, 0]), atol=0.3)
  assert streams.outlying_lags([0.025, 0.026, 0.024]) == []
  assert streams.outlying_lags([-0.014, -0.036, -0.025, 0.918, -0.216, -0.02]) == [3, 4]


def test_a_reference_logged_in_packets_loses_no_rows_to_the_default_gap_rule(tmp_path):
  """A reference that writes its samples three at a time (0.2 ms apart, then an 11 ms
  pause; 263 Hz on average): its median step is 0.2 ms, its mean 3.8 ms. The default gap
  rule (3 sampling periods, `streams.sample_period`) keeps every row between packets, and
  still drops the rows of a real 0.3 s dropout."""
  sensor, reference = _streams(seed=3, seconds=20.0)
  steps = np.tile([0.0002, 0.0002, 0.011], 3000)
  tr = 0.1 + np.concatenate([[0.0], np.cumsum(steps)])
  tr[tr > 10.0] += 0.3  # a dropout of the reference at 10 s
  ref = csvfile.Table(reference.names, reference.units,
                      np.column_stack([tr, _force(tr - LAG)]), "reference.csv")
  assert np.median(np.diff(tr)) == pytest.approx(0.0002)
  m = streams.merge(sensor, ref, lag=LAG)
  dropout = int(np.sum((sensor.data[:, 0] > 10.0 - LAG) & (sensor.data[:, 0] < 10.3 - LAG)))
  assert 0 < m.in_gaps <= dropout + 1, (m.in_gaps, dropout)
  assert m.max_gap == pytest.approx(3 * 0.0038, rel=0.05)


def test_a_bit_inferred_from_values_off_its_grid_is_refused_and_the_period_can_be_given():
  """A magnetometer read out scaled (values off the 0.3 uT grid: a smallest step of about
  0.002 uT, so 2**16 of them is 131 uT against a 19,660 uT register): `--unwrap 16` would
  'undo' noise steps. The period that is no longer than the channel's range is refused,
  naming the channel; `--unwrap-period` gives the register's period itself, and undoes a
  planted wrap exactly."""
  rng = np.random.default_rng(8)
  period = 2 ** 16 * 0.3
  true = np.cumsum(rng.normal(0, 20, (3000, 2)), axis=0) * 1.0037  # scaled: off-grid
  true += period / 2 - true[1500]  # channel 1 crosses the register's top there
  true[:, 1] += np.linspace(0, period, 3000)
  wrapped = np.mod(true, period)  # as the register holds them
  table = csvfile.Table(("X0 [uT]", "X1 [uT]"), ("uT", "uT"), wrapped, "mag.csv")
  with pytest.raises(errors.SettingError, match=r"X0 \[uT\]: --unwrap 16 makes its period .* "
                                                r"no longer than the range .*--unwrap-period"):
    prepare.apply([table], [0, 1], None, prepare.Steps(unwrap_bits=16))
  ready = prepare.apply([table], [0, 1], None, prepare.Steps(unwrap_period=period))
  assert np.sum(np.abs(np.diff(wrapped[:, 1])) > period / 2) >= 1  # a wrap is planted
  np.testing.assert_allclose(ready.x - ready.x[0], true - true[0], atol=1e-9 * period)
  assert ready.record["unwrap_periods"] == [period, period]
  with pytest.raises(errors.SettingError, match="give one of them"):
    prepare.Steps(unwrap_bits=16, unwrap_period=period)


def test_the_example_streams_raw_path_needs_no_manual_fix(tmp_path, capsys):
  """`example --streams` plants a real log's pathologies: unit-laden names, an irregular
  reference with dropouts, and in train2 a lean on the plate the lag estimate locks onto.
  merge names that pair and merges it at the others' median (no merged row holds the lean);
  fit reads the unit-laden names literally and reports no rail or wrap that is not there."""
  assert cli.main(["example", str(tmp_path / "s"), "--streams"]) == 0
  pairs = [str(tmp_path / "s" / f"train{k}_{side}.csv") for k in (1, 2, 3)
           for side in ("sensor", "reference")]
  capsys.readouterr()
  assert cli.main(["merge", *pairs, "--out", str(tmp_path / "m")]) == 0
  out = capsys.readouterr().out
  warned = [line for line in out.splitlines() if line.startswith("warning:")]
  assert len(warned) == 1 and "train2_sensor.csv" in warned[0], out
  merged = [csvfile.read(tmp_path / "m" / f"train{k}_sensor.csv") for k in (1, 2, 3)]
  fz = merged[1].column("F_z [N]")
  others = np.concatenate([m.column("F_z [N]") for m in (merged[0], merged[2])])
  assert fz.max() < others.max() + 50  # the 600 N lean is in no merged row
  assert cli.main(["fit", "--csv", str(tmp_path / "m" / "*.csv"), "--inputs", "p*",
                   "--targets", "F_x [N],F_y [N],F_z [N]", "--method", "ls", "--tare", "0.8",
                   "--folds", "3", "--no-progress", "--out", str(tmp_path / "e.npz")]) == 0
  out = capsys.readouterr().out
  assert "rail" not in out and "jump" not in out, out
