"""footpad_throughput: scene steps/s, the sensor chain's share, and the scene against bare
mj_step on the same model and commands (its deepest episode, in contact, one thread); then,
each as a ratio measured in this one run (the machine's load printed with it): the
viscoelastic model's step cost against the friction-only model's, one LM epoch against the
structured Gram floor it needs (u blocks, N x 81, `u.T @ u` in OpenBLAS), and network
trainings two at a time (`calibrate.parallel`) against one at a time.

The targets of the speed work (issue: the main job in minutes) read off these: scene/bare
in contact >= 0.9, viscoelastic/friction-only <= 1.3, epoch/Gram floor <= 1.5.
"""

from __future__ import annotations

import dataclasses

from benchmarks import footpad
from benchmarks.registry import register


@register("footpad_throughput", "footpad simulation speed: scene vs bare mj_step, "
          "sensor-chain share of time", settings=footpad.protocol_settings,
          presets=footpad.presets,
          fixed=footpad.FIXED, tags=("footpad", "speed"))
def run(ctx) -> dict:
  from sim.footpad import layer, protocol, scene as scene_lib
  scene = protocol.scenes(ctx.settings)["train"]
  scene = dataclasses.replace(scene, paths=("asterisk",))
  layer.die_kernel(scene.params, scene.kernel)  # solve (or load) the kernel outside the timing
  rec, t = scene_lib.simulate(scene, ctx.progress("episodes"))
  scene_rate = t.steps / t.simulate
  res = {"steps": t.steps, "threads": t.threads, "scene_steps_per_s": scene_rate,
         "scene_steps_per_s_per_thread": scene_rate / t.threads,
         "physics_thread_s": t.physics_cpu, "sensor_chain_thread_s": t.sensor_chain_cpu,
         "simulate_wall_s": t.simulate, "sensor_chain_share": t.sensor_chain_cpu / t.physics_cpu}
  ctx.print(f"scene: {t.steps} steps in {t.simulate:.2f} s on {t.threads} threads = "
            f"{scene_rate:,.0f} steps/s ({scene_rate / t.threads:,.0f} per thread)")
  ctx.print(f"sensor chain: {t.sensor_chain_cpu:.3f} thread-s = "
            f"{res['sensor_chain_share']:.1%} of the physics' {t.physics_cpu:.2f} thread-s")
  in_scene, bare = scene_lib.step_rates(scene)
  res.update(scene_in_contact_per_s=in_scene, bare_mj_step_per_s=bare,
             scene_vs_bare=in_scene / bare)
  ctx.print(f"deepest episode, 1 thread: scene {in_scene:,.0f} steps/s, bare mj_step on the "
            f"same model and commands (sensors off) {bare:,.0f}: scene/bare {in_scene / bare:.2f}")
  res.update(_viscoelastic_cost(ctx, scene, bare))
  res.update(_epoch_against_gram(ctx, rec))
  res.update(_parallel_training(ctx, rec))
  import os
  res["load_average"] = os.getloadavg()
  ctx.print("load average (1, 5, 15 min) at the end: " + ", ".join(
      f"{v:.2f}" for v in res["load_average"]))
  return {"samples": len(rec), "effects": list(scene.effects), "timing": res}


def _viscoelastic_cost(ctx, scene, bare: float) -> dict:
  """Bare mj_step of the model with and without its viscoelastic arms, in contact."""
  from sim.footpad import effects as fx, scene as scene_lib
  if fx.VISCOELASTIC.name not in scene.effects:
    return {}
  plain = dataclasses.replace(scene, effects=tuple(e for e in scene.effects
                                                   if e != fx.VISCOELASTIC.name))
  rate = scene_lib.step_rates(plain, bare_only=True)[1]
  ctx.print(f"bare mj_step in contact: viscoelastic model {bare:,.0f} steps/s, without its "
            f"arms {rate:,.0f}: step cost ratio {rate / bare:.2f}")
  return {"bare_mj_step_per_s_no_viscoelastic": rate, "viscoelastic_step_cost_ratio":
          rate / bare}


EPOCH_SAMPLES = 100_000  # the size at which the epoch target is set


def _epoch_against_gram(ctx, rec, epochs: int = 20) -> dict:
  """One LM epoch of a 10-unit network on `EPOCH_SAMPLES` of the recording's samples (tiled
  when it has fewer) against the Gram product it needs, (N, 81) u blocks in float64 through
  OpenBLAS; both on one thread, in a worker started with XLA and BLAS on one thread."""
  import concurrent.futures
  import multiprocessing
  import numpy as np
  from calibrate import parallel
  from util import workers
  idx = np.resize(np.arange(len(rec)), EPOCH_SAMPLES)
  x, y = rec.counts[idx], rec.wrench[idx, :3]
  with workers.environment(parallel.ONE_THREAD):
    with concurrent.futures.ProcessPoolExecutor(
        1, mp_context=multiprocessing.get_context("spawn")) as pool:
      epoch, best, compile_s, done = pool.submit(_epoch_timing, x, y, epochs).result()
  ctx.print(f"LM epoch at N = {len(x):,}, 1 thread (median of {done}, JIT {compile_s:.1f} s "
            f"apart): {epoch * 1e3:.1f} ms; Gram floor (N x 81, OpenBLAS) {best * 1e3:.1f} ms: "
            f"ratio {epoch / best:.2f}")
  return {"lm_epoch_s": epoch, "gram_floor_s": best, "epoch_over_gram": epoch / best,
          "lm_samples": len(x)}


def _epoch_timing(x, y, epochs: int):
  """(median epoch s, best of 5 u.T @ u s, compile s, epochs run), in a one-thread worker."""
  import time
  import numpy as np
  from calibrate.parts import mlp
  u = np.random.default_rng(0).normal(size=(len(x), 81))
  best = np.inf
  for _ in range(5):
    t0 = time.perf_counter()
    u.T @ u
    best = min(best, time.perf_counter() - t0)
  res = mlp.train(x, y, x[:1000], y[:1000], mlp.LMConfig(epochs=epochs, max_fail=epochs + 1),
                  seed=0)
  return float(np.median(np.diff(res.times))), best, res.compile_seconds, res.epochs


def _parallel_training(ctx, rec) -> dict:
  """Two NN-only fits one at a time (one worker) and at once (two workers)."""
  import time
  from calibrate import parallel
  data = {"x": rec.counts, "y": rec.wrench[:, :3]}
  jobs = [dict(kind="NN", counts="x", forces="y", seed=s) for s in (1, 2)]
  out = {}
  for workers in (1, 2):
    t0 = time.perf_counter()
    fits = parallel.fit_all(data, jobs, workers)
    out[workers] = (time.perf_counter() - t0, [f.training.seconds for f in fits])
  (w1, s1), (w2, s2) = out[1], out[2]
  ctx.print(f"two NN-only fits on {len(data['x']):,} samples: one at a time {w1:.1f} s wall "
            f"(training {' + '.join(f'{v:.1f}' for v in s1)} s), two at once {w2:.1f} s "
            f"(training {' + '.join(f'{v:.1f}' for v in s2)} s): parallel/serial wall "
            f"{w2 / w1:.2f}")
  return {"training_serial_wall_s": w1, "training_parallel_wall_s": w2,
          "parallel_over_serial": w2 / w1}
