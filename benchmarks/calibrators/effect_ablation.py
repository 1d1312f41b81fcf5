"""effect_ablation: what each named effect costs in simulation time and what it does to the
calibrated error, on both sensors.

Each effect is switched on alone over a baseline, then all together. Footpad: the baseline
is frictional contact alone (without `friction` there is no shear to calibrate); the data are
the protocol's Z presses and X/Y strokes (the linear fit, paper Sec. III-B) and Testing Path
1 (the test), at the protocol's Z levels (3 with --quick). Shell: the baseline has no effect;
the protocol's calibration and test runs with the cubic calibration. Every configuration is
simulated anew (no cache), so its time is its own: physics (thread-seconds inside MuJoCo) and
sensor chain (counts from the physical signals). The same seed drives every configuration,
and each effect draws from its own stream, so an effect that is off draws nothing and costs
nothing: the differences from the baseline are the effect's.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from benchmarks.registry import register
from util import fields


@fields.declared
@dataclasses.dataclass(frozen=True)
class EffectAblation:
  """Settings of the effect ablation.

  Attributes:
    rigs: the sensors whose effects are switched on one at a time.
  """
  rigs: tuple[Literal["footpad", "shell"], ...] = ("footpad", "shell")

  def relations(self):
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    yield bool(self.rigs), "rigs", "footpad, shell or both (not none)", self.rigs


def settings(quick: bool, seed: int) -> EffectAblation:
  return EffectAblation()


def _configs(baseline: tuple[str, ...], effects) -> list[tuple[str, tuple[str, ...]]]:
  others = [e for e in effects if e not in baseline]
  return ([("baseline", baseline)] + [(f"+{e}", baseline + (e,)) for e in others]
          + [("all", baseline + tuple(others))])


def _footpad(ctx) -> tuple[list[dict], str]:
  from calibrate import estimators, metrics
  from sim.footpad import effects, protocol, scene
  base = dataclasses.replace(protocol.base(ctx.quick, ctx.seed), paths=(
      "z_press", "x_stroke", "y_stroke", "test_path_1"))
  rows = []
  for name, chosen in _configs(("friction",), effects.EFFECTS):
    rec, t = scene.generate(dataclasses.replace(base, effects=chosen),
                            ctx.progress(f"footpad {name}"), use_cache=False)
    train = rec.on_path(*protocol.LS_PATHS)
    test = rec.on_path("test_path_1")
    ls = estimators.fit(estimators.Kind.LS, train.counts, train.wrench[:, :3])
    err = metrics.nrmse_pct(ls.predict(test.counts), test.wrench[:, :3])
    rows.append({"config": name, "effects": list(chosen), "physics_s": t.physics_cpu,
                 "chain_s": t.sensor_chain_cpu, "wall_s": t.simulate, "steps": t.steps,
                 "error": float(np.mean(err)), "per_axis": err.tolist()})
  return rows, "LS test NRMSE %, mean over X, Y, Z (Testing Path 1)"


def _shell(ctx) -> tuple[list[dict], str]:
  from calibrate import estimators, metrics
  from sim.shell import effects, protocol, scene
  runs = protocol.scenes(protocol.base(ctx.quick, ctx.seed), ctx.quick, ctx.seed)
  rows = []
  for name, chosen in _configs((), effects.EFFECTS):
    recs, timing = {}, []
    for part, s in runs.items():
      recs[part], t = scene.generate(dataclasses.replace(s, effects=chosen),
                                     ctx.progress(f"shell {name} {part}"), use_cache=False)
      timing.append(t)
    est = estimators.fit(estimators.Kind.POLY, recs["calibration"].counts,
                         recs["calibration"].wrench)
    test = recs["test"]
    pred = est.predict(test.counts)
    err = metrics.wrench_median_pct(pred, test.wrench)
    rows.append({"config": name, "effects": list(chosen),
                 "physics_s": sum(t.physics_cpu for t in timing),
                 "chain_s": sum(t.sensor_chain_cpu for t in timing),
                 "wall_s": sum(t.simulate for t in timing),
                 "steps": sum(t.steps for t in timing),
                 "error": float(np.mean(err)), "per_axis": err.tolist()})
  return rows, "cubic calibration, median % error, mean over the six axes (test run)"


@register("effect_ablation", "each effect on alone and all together, both sensors: its cost in "
          "simulation time and its change of the calibrated error", settings=settings,
          tags=("footpad", "shell", "effects", "speed"))
def run(ctx):
  from benchmarks import outputs
  out = {}
  for rig in ctx.settings.rigs:
    rows, metric = (_footpad if rig == "footpad" else _shell)(ctx)
    base = rows[0]
    out[rig] = {"metric": metric, "rows": rows}
    ctx.print(f"\n{rig}: {metric}")
    ctx.print(f"  {'configuration':22s} {'physics s':>10s} {'chain s':>8s} {'error':>8s} "
              f"{'vs baseline':>12s}")
    for r in rows:
      ctx.print(f"  {r['config']:22s} {r['physics_s']:10.2f} {r['chain_s']:8.3f} "
                f"{r['error']:8.3f} {r['error'] - base['error']:+12.3f}")
  data = {"rigs": out}
  table = [row for rig, d in out.items() for r in d["rows"] for row in outputs.scored(
      f"{rig}/{r['config']}", {SCORED[rig][0]: {
          ax: {SCORED[rig][1]: v} for ax, v in zip(SCORED[rig][2], r["per_axis"])}})]
  return outputs.Result(data, tuple(table + outputs.plain(
      data, skip=(("rigs", "*", "rows", "*", "per_axis"),))))


# each rig's per-axis error: (method, metric, axes)
SCORED = {"footpad": ("LS", "nrmse_pct", ("X", "Y", "Z")),
          "shell": ("cubic", "median_pct", ("Fx", "Fy", "Fz", "Mx", "My", "Mz"))}
