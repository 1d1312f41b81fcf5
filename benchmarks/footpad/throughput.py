"""footpad_throughput: scene steps/s against bare mj_step, and the sensor chain's share."""

from __future__ import annotations

import dataclasses

from benchmarks import footpad
from benchmarks.registry import register


@register("footpad_throughput", "footpad simulation speed: scene vs bare mj_step, "
          "sensor-chain share of time", settings=footpad.protocol_settings,
          fixed=footpad.FIXED, tags=("footpad", "speed"))
def run(ctx) -> dict:
  from sim.footpad import layer, protocol, scene as scene_lib
  scene = protocol.scenes(ctx.settings)["train"]
  scene = dataclasses.replace(scene, paths=("asterisk",))
  layer.die_kernel(scene.params, scene.kernel)  # solve (or load) the kernel outside the timing
  rec, t = scene_lib.simulate(scene, ctx.progress("episodes"))
  bare = scene_lib.bare_step_rate(scene)
  scene_rate = t.steps / t.simulate
  res = {"steps": t.steps, "threads": t.threads, "scene_steps_per_s": scene_rate,
         "scene_steps_per_s_per_thread": scene_rate / t.threads,
         "bare_mj_step_per_s": bare,
         "scene_vs_bare_per_thread": scene_rate / t.threads / bare,
         "physics_thread_s": t.physics_cpu, "sensor_chain_thread_s": t.sensor_chain_cpu,
         "simulate_wall_s": t.simulate, "sensor_chain_share": t.sensor_chain_cpu / t.physics_cpu}
  ctx.print(f"scene: {t.steps} steps in {t.simulate:.2f} s on {t.threads} threads = "
            f"{scene_rate:,.0f} steps/s ({scene_rate / t.threads:,.0f} per thread)")
  ctx.print(f"bare mj_step, sensors off, 1 thread: {bare:,.0f} steps/s; scene per thread / bare "
            f"= {res['scene_vs_bare_per_thread']:.2f}")
  ctx.print(f"sensor chain: {t.sensor_chain_cpu:.3f} thread-s = "
            f"{res['sensor_chain_share']:.1%} of the physics' {t.physics_cpu:.2f} thread-s")
  return {"samples": len(rec), "effects": list(scene.effects), "timing": res}
