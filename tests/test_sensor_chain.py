"""MPXH6400A transfer law, ADC and the signal effects."""

import numpy as np
import pytest

from sim.footpad import sensor_chain
from sim.effects import Kind
from sim.footpad.effects import EFFECTS as FOOTPAD_EFFECTS

SIGNAL = [n for n, e in FOOTPAD_EFFECTS.items() if e.kind is Kind.SIGNAL]


def test_transfer_law_matches_datasheet_equation():
  adc = sensor_chain.AdcConfig(vs=5.0, vref=5.0)
  # datasheet: Vout = Vs (0.002421 P - 0.00842), P in kPa absolute
  volts = 5.0 * (0.002421 * 200.0 - 0.00842)
  counts = sensor_chain.pressure_to_counts(np.array([200e3 - 101.325e3]), adc)
  assert counts[0] == pytest.approx(volts / 5.0 * 4096, rel=1e-12)
  back = sensor_chain.counts_to_pressure(counts, adc)
  assert back[0] == pytest.approx(200e3 - 101.325e3, rel=1e-12)


@pytest.mark.parametrize("vref, gauge_kpa", [(5.0, 299), (3.3, 175)])
def test_saturation_pressure(vref, gauge_kpa):
  p = sensor_chain.saturation_pressure(sensor_chain.AdcConfig(vref=vref))
  assert p / 1e3 == pytest.approx(gauge_kpa, abs=2)


def _data(n=500, seed=1):
  rng = np.random.default_rng(seed)
  return rng.uniform(0, 400e3, (n, 6)), rng.normal(0, 50, (n, 6))


def test_no_effects_is_the_ideal_law():
  p, w = _data()
  adc = sensor_chain.AdcConfig()
  counts, wrench = sensor_chain.apply(p, w, (), seed=0, adc=adc)
  np.testing.assert_array_equal(counts, sensor_chain.pressure_to_counts(p, adc))
  np.testing.assert_array_equal(wrench, w)


@pytest.mark.parametrize("off", SIGNAL)
def test_effect_off_leaves_other_effects_bit_identical(off):
  """Each effect has its own stream: dropping one never changes another's draws."""
  p, w = _data()
  rest = [e for e in SIGNAL if e != off]
  a = sensor_chain.apply(p, w, rest, seed=3)
  b = sensor_chain.apply(p, w, rest + [off], seed=3)
  if off in ("sensor_noise", "gain_offset_spread", "adc_quantisation", "adc_saturation",
             "hysteresis", "thermal_drift"):
    assert not np.array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
  else:  # ft_noise
    np.testing.assert_array_equal(a[0], b[0])
    assert not np.array_equal(a[1], b[1])


def test_seed_reproduces_bytes_and_changes_noise_only():
  p, w = _data()
  a = sensor_chain.apply(p, w, SIGNAL, seed=7)
  b = sensor_chain.apply(p, w, SIGNAL, seed=7)
  c = sensor_chain.apply(p, w, SIGNAL, seed=8)
  assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()
  assert not np.array_equal(a[0], c[0])
  # the noise is small against the signal: same law, another draw
  ideal = sensor_chain.pressure_to_counts(p, sensor_chain.AdcConfig())
  assert np.median(np.abs(c[0] - ideal) / ideal) < 0.3


def test_saturation_and_quantisation_limits():
  adc = sensor_chain.AdcConfig(vref=3.3)
  p = np.array([[0.0, 1e5, 5e5, -2e5, 2e5, 3e5]])
  counts, _ = sensor_chain.apply(p, np.zeros((1, 6)), ["adc_saturation", "adc_quantisation"], 0,
                                 adc)
  assert counts.max() == 4095 and counts.min() >= 0
  assert np.all(counts == np.floor(counts))


def test_unknown_effect_is_refused():
  with pytest.raises(ValueError, match="unknown effect 'glitter'"):
    sensor_chain.apply(np.zeros((1, 6)), np.zeros((1, 6)), ["glitter"], 0)


def test_the_play_operator_equals_its_recursion():
  from sim.effects import play
  rng = np.random.default_rng(0)
  x = np.cumsum(rng.normal(size=(3001, 3)), axis=0)
  w = np.array([0.5, 3.0, 0.0])
  ref = np.empty_like(x)
  ref[0] = x[0]
  for t in range(1, len(x)):
    ref[t] = np.clip(ref[t - 1], x[t] - w, x[t] + w)
  np.testing.assert_array_equal(play(x, w), ref)
  np.testing.assert_array_equal(play(x, 0.0), x)  # no width: the identity


@pytest.mark.parametrize("width", [0.0, 0.004, 0.012])
def test_hysteresis_loop_is_as_wide_as_stated(width):
  adc = sensor_chain.AdcConfig(hysteresis=width)
  up = np.linspace(0, 200e3, 2001)
  p = np.concatenate([up, up[::-1]])[:, None] * np.ones(6)
  counts, _ = sensor_chain.apply(p, np.zeros((len(p), 6)), ["hysteresis"], 0, adc)
  loaded, unloaded = counts[:2001, 0], counts[2001:, 0][::-1]
  # at mid-range both branches have left their start: their gap is the loop width
  mid = slice(800, 1200)
  gap = sensor_chain.counts_to_pressure(unloaded[mid], adc) - sensor_chain.counts_to_pressure(
      loaded[mid], adc)
  np.testing.assert_allclose(gap, width * sensor_chain.MPX_SPAN, rtol=1e-9, atol=1e-6)


def test_thermal_drift_has_its_stated_size_and_time():
  adc = sensor_chain.AdcConfig(drift_offset=0.01, drift_gain=0.0, drift_time=2.0)
  n, dt = 200_000, 0.001
  p = np.zeros((n, 6))
  counts, _ = sensor_chain.apply(p, np.zeros((n, 6)), ["thermal_drift"], 4, adc, dt)
  drift = sensor_chain.counts_to_pressure(counts, adc)
  # 100 correlation times x 6 channels: the rms within 10 %, the lag-tau correlation 1/e
  assert np.std(drift) == pytest.approx(0.01 * sensor_chain.MPX_SPAN, rel=0.1)
  lag = int(2.0 / dt)
  r = np.mean([np.corrcoef(drift[:-lag, c], drift[lag:, c])[0, 1] for c in range(6)])
  assert r == pytest.approx(np.exp(-1), abs=0.08)
  gain_only = sensor_chain.AdcConfig(drift_offset=0.0, drift_gain=0.015, drift_time=2.0)
  p = np.full((n, 6), 100e3)
  counts, _ = sensor_chain.apply(p, np.zeros((n, 6)), ["thermal_drift"], 4, gain_only, dt)
  rel = sensor_chain.counts_to_pressure(counts, gain_only) / 100e3 - 1
  assert np.std(rel) == pytest.approx(0.015, rel=0.1)



def test_two_recordings_of_one_run_share_no_noise_or_drift_draw():
  """Each recording keys its streams by its identity: the training and test recordings of
  one protocol run differ in noise and drift (|correlation| of their noise rows and drift
  increments < 0.05), the dies' unit spread stays the pad's, and each stream is reproducible."""
  from sim.footpad import layer, protocol, scene
  streams = []
  for s in protocol.scenes(protocol.base(True, 0)).values():
    streams.append(scene.stream_of(scene.episodes(s, layer.die_kernel(s.params, s.kernel))))
  assert streams[0] != streams[1]
  n = 200_000
  zero = np.zeros((n, 6))
  adc = sensor_chain.AdcConfig(drift_time=30.0)

  def draw(effect, stream):
    counts, _ = sensor_chain.apply(zero, np.zeros((n, 6)), [effect], 7, adc, 0.001, stream)
    return counts - sensor_chain.pressure_to_counts(zero, adc)
  for effect, change in (("sensor_noise", lambda c: c),
                         ("thermal_drift", lambda c: np.diff(c, axis=0))):
    a, b = (change(draw(effect, st)) for st in streams)
    corr = [np.corrcoef(a[:, d], b[:, d])[0, 1] for d in range(6)]
    assert np.max(np.abs(corr)) < 0.05, (effect, corr)
    np.testing.assert_array_equal(a, change(draw(effect, streams[0])))
  spread = [draw("gain_offset_spread", st) for st in streams]
  np.testing.assert_array_equal(spread[0], spread[1])
