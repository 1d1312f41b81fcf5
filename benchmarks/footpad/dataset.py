"""footpad_dataset: generate and cache the paper's training and test recordings."""

from __future__ import annotations

import dataclasses

import numpy as np

from benchmarks import footpad
from benchmarks.registry import register


@register("footpad_dataset", "generate and cache the footpad's training and test recordings "
          "(paper Sec. III)", settings=footpad.protocol_settings, fixed=footpad.FIXED,
          tags=("footpad", "data"))
def run(ctx) -> dict:
  from sim import cache
  from sim.footpad import protocol, scene as scene_lib
  out = {"recordings": {}, "timing": {}}
  scenes = protocol.scenes(ctx.settings)
  for name, (rec, timing) in footpad.recordings(ctx).items():
    ranges = {ax: [float(rec.wrench[:, i].min()), float(rec.wrench[:, i].max())]
              for i, ax in enumerate("XYZ")}
    per_path = {p: int(np.sum(rec.path == i)) for i, p in enumerate(rec.meta["paths"])}
    key = cache.content_key(scene_lib.cache_key(scenes[name]))
    out["recordings"][name] = {"samples": len(rec), "per_path": per_path,
                               "force_range_N": ranges, "cache_key": key}
    ctx.print(f"{name}: {len(rec)} samples; " + ", ".join(
        f"F{ax} {lo:+.1f}..{hi:+.1f} N (range {hi - lo:.1f})" for ax, (lo, hi) in ranges.items()))
    for p, n in per_path.items():
      ctx.print(f"  {p:12s} {n:8d} samples")
    if timing is None:
      ctx.print("  loaded from cache")
      out["timing"][name] = {"cached": True}
    else:
      out["timing"][name] = {"cached": False, **dataclasses.asdict(timing),
                             "steps_per_s": timing.steps / timing.simulate,
                             "sensor_chain_share": timing.sensor_chain_cpu / timing.physics_cpu}
      ctx.print(f"  {timing.steps} steps in {timing.simulate:.1f} s on {timing.threads} threads "
                f"({timing.steps / timing.simulate:,.0f} steps/s); sensor chain "
                f"{timing.sensor_chain_cpu:.2f} s = "
                f"{timing.sensor_chain_cpu / timing.physics_cpu:.1%} of the physics' "
                f"{timing.physics_cpu:.1f} thread-s; model + kernel {timing.build:.1f} s")
  out["samples"] = sum(r["samples"] for r in out["recordings"].values())
  out["effects"] = list(scenes["train"].effects)
  return out
