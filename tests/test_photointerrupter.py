"""The photointerrupter curve and the paper's 1/r fit (Eqns 1-2)."""

import numpy as np
import pytest

from sim.shell.photointerrupter import Photointerrupter, fit_inverse_r, range_from_counts

S = Photointerrupter()


def test_matches_the_papers_figure_4_points():
  assert S.counts(0.002) == pytest.approx(3900, abs=3)
  assert S.counts(0.004) == pytest.approx(1975, abs=1)


def test_response_peaks_near_0_8_mm_and_falls_to_contact():
  r = np.linspace(1e-7, 0.003, 30001)
  unclipped = Photointerrupter(full_scale=10**9)
  s = unclipped.counts(r)
  assert r[np.argmax(s)] == pytest.approx(S.peak, rel=0.01)
  assert s[0] < 0.01 * s.max() + S.b
  # the ADC clips what the amplifier passes below the window
  assert S.counts(0.0008) == S.full_scale


def test_fit_recovers_a_b_exactly_on_noiseless_in_window_data():
  r = np.linspace(*S.window, 200)
  a, b, worst = fit_inverse_r(r, S.counts(r, near_field=False))
  assert a == pytest.approx(S.a, rel=1e-12) and b == pytest.approx(S.b, rel=1e-10)
  assert worst < 1e-12
  # with the near-field fall-off the window still fits within the paper's 20 um (Fig. 4b)
  a, b, worst = fit_inverse_r(r, S.counts(r))
  assert worst < 20e-6


def test_range_inverts_counts_and_flags_no_reflector():
  r = np.array([0.002, 0.003, 0.004])
  np.testing.assert_allclose(range_from_counts(S.counts(r, near_field=False), S.a, S.b), r,
                             rtol=1e-12)
  assert np.isnan(range_from_counts(np.array([S.b]), S.a, S.b)[0])
  assert S.counts(np.array([np.nan]))[0] == S.b


def test_bad_sweep_is_named():
  with pytest.raises(ValueError, match="1-D"):
    fit_inverse_r(np.ones(5), np.ones(4))
  with pytest.raises(ValueError, match="> 0"):
    fit_inverse_r(np.array([0.002, 0.0, 0.003]), np.ones(3))


def test_chain_effects_are_independent_and_seeded():
  from sim.shell import photointerrupter
  rng = np.random.default_rng(0)
  h = rng.uniform(0.0005, 0.005, (2000, 8))
  ideal = photointerrupter.apply(h, (), seed=1)
  np.testing.assert_array_equal(ideal, S.counts(h, near_field=False))
  noisy = photointerrupter.apply(h, ("sensor_noise",), seed=1)
  inside = (h > 0.0025) & (h < 0.0045)  # away from the clip at 4095
  assert np.std((noisy - ideal)[inside]) == pytest.approx(1.0, rel=0.05)
  both = photointerrupter.apply(h, ("sensor_noise", "out_of_window"), seed=1)
  # switching out_of_window on changes no noise draw
  np.testing.assert_allclose((both - S.counts(h))[inside], (noisy - ideal)[inside], atol=1e-9)
  assert photointerrupter.apply(h, ("sensor_noise",), seed=1).tobytes() == noisy.tobytes()
  with pytest.raises(ValueError, match="unknown effect"):
    photointerrupter.apply(h, ("glare",), seed=1)


def test_unit_spread_is_an_affine_map_per_sensor():
  from sim.shell import photointerrupter
  h = np.random.default_rng(2).uniform(0.0022, 0.0038, (3000, 8))
  ideal = photointerrupter.apply(h, (), seed=4)
  spread = photointerrupter.apply(h, ("unit_spread",), seed=4)
  slopes = []
  for i in range(8):
    fit = np.polyfit(ideal[:, i], spread[:, i], 1, full=True)
    slopes.append(fit[0][0])
    assert fit[1][0] < 1e-12 * np.sum(spread[:, i] ** 2)  # exactly affine
  assert 0.05 < np.std(slopes) < 0.3  # gain_spread 0.15 over 8 units


def test_stray_ir_wanders_with_its_rms_and_correlation_time():
  from sim.shell import photointerrupter
  h = np.full((200_000, 8), 0.003)
  base = photointerrupter.apply(h, (), seed=1)
  ir = photointerrupter.apply(h, ("stray_ir",), seed=1) - base
  # shared + own parts, each 20 counts rms
  assert np.std(ir) == pytest.approx(np.sqrt(2) * S.stray_ir, rel=0.1)
  # Ornstein-Uhlenbeck: autocorrelation exp(-lag / tau) at lag tau (5 s at 100 Hz)
  x = ir[:, 0] - ir[:, 0].mean()
  lag = int(S.stray_ir_time * 100)
  rho = np.mean(x[:-lag] * x[lag:]) / np.var(x)
  assert rho == pytest.approx(np.exp(-1), abs=0.1)
  # the shared part moves all sensors together
  assert np.corrcoef(ir[:, 0], ir[:, 1])[0, 1] == pytest.approx(0.5, abs=0.15)
