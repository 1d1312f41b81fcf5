"""footpad_kernels: how well die counts carry shear, bonded-layer kernel vs half-space kernel.

The same physics (X and Y strokes at the scene's Z levels) goes through each kernel; a linear
least-squares fit from the six die counts to each force axis reports R² and NRMSE on its own
data, so the difference is the kernel's alone."""

from __future__ import annotations

import dataclasses

from benchmarks import footpad
from benchmarks.registry import register


@register("footpad_kernels", "shear sensing through the bonded-layer vs half-space die kernel "
          "(linear fit R²)", settings=footpad.protocol_settings, presets=footpad.presets,
          fixed={**footpad.FIXED, "kernel": "the benchmark runs both kernels"},
          tags=("footpad", "physics", "fast"))
def run(ctx) -> dict:
  from benchmarks import outputs
  from calibrate import metrics
  from calibrate.parts import linear
  from sim.footpad import paper
  from sim.footpad import layer, protocol, scene as scene_lib
  base = protocol.scenes(ctx.settings)["train"]
  base = dataclasses.replace(base, paths=("x_stroke", "y_stroke"))
  results = {}
  ctx.print(f"{'kernel':14s} {'R2 X %':>8s} {'R2 Y %':>8s} {'R2 Z %':>8s} {'NRMSE X %':>10s} "
            f"{'NRMSE Y %':>10s}")
  for kernel in layer.Kernel:
    rec, _ = scene_lib.generate(dataclasses.replace(base, kernel=kernel),
                              ctx.progress(kernel.value), ctx.use_cache)
    ctx.used(rec)
    on = rec.on_path()
    fit = linear.fit_linear(on.counts, on.wrench[:, :3])
    pred = fit.predict(on.counts)
    r2 = metrics.r2_pct(pred, on.wrench[:, :3])
    nrmse = metrics.nrmse_pct(pred, on.wrench[:, :3])
    results[kernel.value] = {ax: {"r2_pct": float(r2[i]), "nrmse_pct": float(nrmse[i])}
                             for i, ax in enumerate("XYZ")}
    ctx.print(f"{kernel.value:14s} {r2[0]:8.2f} {r2[1]:8.2f} {r2[2]:8.2f} {nrmse[0]:10.2f} "
              f"{nrmse[1]:10.2f}")
  ctx.print(f"paper (LSANN, test paths): R2 X {paper.TABLE1['LSANN']['X'][2]} %, "
            f"Y {paper.TABLE1['LSANN']['Y'][2]} %")
  data = {"results": results, "samples": len(on), "effects": list(base.effects)}
  # one linear fit per kernel: the group names the kernel, the method the fit
  rows = [r for k, v in results.items() for r in outputs.scored(f"results/{k}", {"LS": v})]
  return outputs.Result(data, tuple(rows + outputs.plain(data, skip=(("results",),))))
