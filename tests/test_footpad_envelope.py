"""The envelope study's design space: Latin hypercube, sourced ranges, sensitivity shares."""

import dataclasses

import numpy as np
import pytest

from benchmarks.footpad import envelope
from sim.footpad import protocol


def test_latin_hypercube_puts_one_point_in_each_stratum():
  u = envelope.latin_hypercube(12, 9, np.random.default_rng(0))
  assert u.shape == (12, 9) and u.min() >= 0 and u.max() < 1
  for col in u.T:
    assert sorted(np.floor(col * 12).astype(int)) == list(range(12))


def test_designs_stay_inside_the_sourced_ranges_and_log_axes_are_geometric():
  lo = envelope.design_values(np.zeros(len(envelope.RANGES)))
  hi = envelope.design_values(np.full(len(envelope.RANGES), 1 - 1e-12))
  mid = envelope.design_values(np.full(len(envelope.RANGES), 0.5))
  for name, (a, b, log) in envelope.RANGES.items():
    assert lo[name] == pytest.approx(a) and hi[name] == pytest.approx(b)
    assert mid[name] == pytest.approx(np.sqrt(a * b) if log else (a + b) / 2)


def test_a_design_scene_carries_its_values_and_every_envelope_effect():
  base = protocol.base(True, 0)
  values = envelope.design_values(np.full(len(envelope.RANGES), 0.25))
  scene = envelope.design_scene(base, values)
  scene.validate()
  assert scene.params.friction_mu0 == values["params.friction_mu0"]
  assert scene.params.prony == (values["prony.g1"], values["prony.tau1"], values["prony.g2"],
                                values["prony.tau2"])
  assert scene.adc.hysteresis == values["adc.hysteresis"]
  assert set(envelope.ENVELOPE_EFFECTS) <= set(scene.effects)
  assert set(base.effects) <= set(scene.effects)
  assert dataclasses.replace(scene, effects=base.effects).paths == base.paths


def test_sensitivity_recovers_the_shares_of_a_known_linear_response():
  rng = np.random.default_rng(1)
  d = len(envelope.RANGES)
  units = envelope.latin_hypercube(400, d, rng)
  weights = np.zeros(d)
  weights[0], weights[6] = 2.0, 1.0  # variance shares 4:1 (equal input spreads)
  shares, r2 = envelope.sensitivity(units, units @ weights)
  names = list(envelope.RANGES)
  assert shares[names[0]] == pytest.approx(0.8, abs=0.01)
  assert shares[names[6]] == pytest.approx(0.2, abs=0.01)
  assert r2 == pytest.approx(1.0)
