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
  if off in ("sensor_noise", "gain_offset_spread", "adc_quantisation", "adc_saturation"):
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
