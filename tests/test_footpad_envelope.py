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
  lo = envelope.design_values(np.zeros(len(envelope.ranges())))
  hi = envelope.design_values(np.full(len(envelope.ranges()), 1 - 1e-12))
  mid = envelope.design_values(np.full(len(envelope.ranges()), 0.5))
  for name, (a, b, log) in envelope.ranges().items():
    assert lo[name] == pytest.approx(a) and hi[name] == pytest.approx(b)
    assert mid[name] == pytest.approx(np.sqrt(a * b) if log else (a + b) / 2)


def test_a_design_scene_carries_its_values_and_every_envelope_effect():
  base = protocol.base(True, 0)
  values = envelope.design_values(np.full(len(envelope.ranges()), 0.25))
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
  d = len(envelope.ranges())
  units = envelope.latin_hypercube(400, d, rng)
  weights = np.zeros(d)
  weights[0], weights[6] = 2.0, 1.0  # variance shares 4:1 (equal input spreads)
  shares, r2 = envelope.sensitivity(units, units @ weights)
  names = list(envelope.ranges())
  assert shares[names[0]] == pytest.approx(0.8, abs=0.01)
  assert shares[names[6]] == pytest.approx(0.2, abs=0.01)
  assert r2 == pytest.approx(1.0)


def synthetic(point: dict) -> dict:
  """A design's metrics as known functions of its drawn values: shear R2 set by the
  hysteresis, the linear stroke fit's NRMSE by the static friction ratio."""
  v = point["values"]
  hyst = v["adc.hysteresis"] / 0.012
  ratio = (v["params.static_friction_ratio"] - 1.0) / 0.3
  axis = {"nrmse_pct": 1.0, "r2_pct": 99.0, "rmse": 1.0, "median_pct": 1.0, "worst_pct": 1.0}
  net = {"X": {**axis, "r2_pct": 95.0 - 30.0 * hyst}, "Y": {**axis, "r2_pct": 95.0 - 30.0 * hyst},
         "Z": axis}
  strokes = {"X": {**axis, "nrmse_pct": 3.0 + 6.0 * ratio}, "Y": {**axis, "nrmse_pct": 2.0},
             "Z": axis}
  return {"LS": net, "LSANN": net, "NN": net, "LS_train": strokes,
          "POLY3_train": {ax: {**m, "nrmse_pct": 0.5 * m["nrmse_pct"]} for ax, m in strokes.items()},
          "time_ratio": 0.5, "iteration_ratio": 0.5, "slip": 0.0}


def test_the_report_finds_the_envelope_and_the_parameter_each_metric_follows(tmp_path,
                                                                              monkeypatch):
  from benchmarks import executors
  from benchmarks.registry import Context
  monkeypatch.setattr(envelope, "evaluate", synthetic)
  ctx = Context(quick=True, seed=3, out=tmp_path, settings=envelope.Envelope(designs=16),
                show_progress=False, executor=executors.ExecutorSpec("serial"))
  result = envelope.run(ctx)
  out = result.data
  shear = [95.0 - 30.0 * d["values"]["adc.hysteresis"] / 0.012 for d in out["designs"]]
  # metrics.csv's rows carry the method and axis the cell scores, not a key's spelling
  low = [r for r in result.rows if (r.group, r.method, r.axis, r.metric) ==
         ("envelope/test/min", "LSANN", "X", "r2_pct")]
  assert len(low) == 1 and low[0].value == pytest.approx(min(shear))
  row = out["envelope"]["LSANN X r2_pct"]
  assert (row["min"], row["median"], row["max"]) == pytest.approx(
      (min(shear), np.median(shear), max(shear)))
  assert row["paper_inside"] == (min(shear) <= row["paper"] <= max(shear))
  (shear_name, shear_fit), (strokes_name, strokes_fit) = out["sensitivity"].items()
  assert max(shear_fit["shares"], key=shear_fit["shares"].get) == "adc.hysteresis"
  assert max(strokes_fit["shares"], key=strokes_fit["shares"].get) == \
      "params.static_friction_ratio"
  assert shear_fit["linear_fit_r2"] == pytest.approx(1.0)
  x = out["stroke_fit_split"]["X"]
  assert x["cubic"] == pytest.approx(0.5 * x["LS"])


# the ranged parameters that size a history effect (a reading that depends on the path the
# load took): stick-slip, relaxation strengths, hysteresis, drift
@pytest.fixture(scope="module")
def corners():
  """The quick protocol at the two corners of the sourced ranges: every history parameter at
  its low end, then at its high end (the other parameters at their middles); the networks'
  metrics are medians over three seeds (at quick scale one seed is a lottery: at the corner
  with the most history seed 1 alone gave NN-only Y 79.7 %, the median 53.4 %). The corners
  run side by side, one per core."""
  from benchmarks import executors
  from sim.footpad import scene as scene_lib
  base = scene_lib.FootpadScene.config(protocol.base(True, 0))
  points = [{"base": base, "seeds": [1, 2, 3], "values": envelope.corner(level)}
            for level in (0.0, 1.0)]
  out, failures = executors.sweep(envelope.evaluate, points, executors.ExecutorSpec(workers=2))
  assert not failures, failures[0].error
  return out


@pytest.mark.slow
def test_the_papers_shear_r2_lies_between_the_corners_of_the_sourced_ranges(corners):
  """The CI trend check of the envelope: the paper's shear and normal R2 of the networks
  (Table I) lie inside the span of the sourced ranges, above the corner with the most
  history, below the one with none (measured: shear 99.87-99.98 % and -60-53 %; Z 99.99 %
  and 97.7-98.2 %, each recording drawing its own noise and drift)."""
  from benchmarks.footpad import table
  least, most = corners
  for m in ("LSANN", "NN"):
    for ax in ("X", "Y"):
      paper = table.PAPER_TABLE1[m][ax][2]
      assert most[m][ax]["r2_pct"] < paper < least[m][ax]["r2_pct"], (m, ax)
  for m in ("LSANN", "NN"):  # the normal force too, now that the test recording drifts
    paper = table.PAPER_TABLE1[m]["Z"][2]  # on its own: the networks fit the training drift
    assert most[m]["Z"]["r2_pct"] < paper < least[m]["Z"]["r2_pct"], (m, "Z")
  # the linear fit of the normal force stays good at either corner (a sum over the dies)
  assert most["LS"]["Z"]["r2_pct"] > 99.0 and least["LS"]["Z"]["r2_pct"] > 99.0


def test_a_quarter_turn_swaps_the_layouts_axes_and_twice_is_none():
  from models.footpad import FootpadParams
  p = FootpadParams()
  t = p.quarter_turned()
  assert t.footprint == p.footprint[::-1] and t.grid == p.grid[::-1]
  # the same dies, their X and Y exchanged
  assert sorted(map(tuple, t.die_positions()[:, [1, 0, 2]].tolist())) == \
      sorted(map(tuple, p.die_positions().tolist()))
  assert t.quarter_turned() == p
  t.validate()


def test_every_sourced_range_lies_in_its_allowed_interval_around_its_default():
  """The ranges the envelope sweeps are the parameters' own (`fields.Sourced`)."""
  from models.footpad import FootpadParams
  from sim.footpad.sensor_chain import AdcConfig
  from util import fields
  defaults = {"params": FootpadParams(), "adc": AdcConfig()}
  for prefix, name in envelope.SWEPT:
    cls = type(defaults[prefix])
    meta = next(f.metadata for f in dataclasses.fields(cls) if f.name == name)
    value = getattr(defaults[prefix], name)
    ranges = list(fields.sourced(cls, name).values())
    values = value if isinstance(value, tuple) else (value,)
    assert len(ranges) == len(values), name
    for r, v in zip(ranges, values):
      assert r.lo in meta["interval"] and r.hi in meta["interval"], (name, r)
      assert r.lo <= v <= r.hi, (name, r, v)
