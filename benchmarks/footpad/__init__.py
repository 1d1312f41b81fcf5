"""Benchmarks of the MIT Cheetah footpad (LSANN paper): its data protocol, Table I, the
kernels, speed, and the Levenberg-Marquardt solvers."""

from __future__ import annotations

# Settings the paper's protocol sets itself, with the reason a --set of them is refused.
FIXED = {"paths": "the protocol runs the paper's training and test paths",
         "seed": "use --seed"}


def protocol_settings(quick: bool, seed: int):
  """The footpad protocol's scene (`sim.footpad.protocol.base`), the root of --set keys."""
  from sim.footpad import protocol
  return protocol.base(quick, seed)


def presets() -> dict:
  """The footpad's named designs (`sim.footpad.presets`): what --preset takes."""
  from sim.footpad import presets as presets_lib
  return presets_lib.presets()


def recordings(ctx, base=None) -> dict:
  """{"train", "test"}: (recording, timing) of the protocol for `base` (default the run's
  settings), from the cache when simulated before."""
  from sim.footpad import protocol, scene
  out = {name: scene.generate(s, ctx.progress(f"footpad {name} episodes"), ctx.use_cache)
         for name, s in protocol.scenes(ctx.settings if base is None else base).items()}
  ctx.used(*(rec for rec, _ in out.values()))
  return out


def clock(rec):
  """(N,) s: a footpad recording's samples laid end to end at the scene's time step, so time
  increases across episodes (each episode's own `time` starts again at 0)."""
  import numpy as np
  return np.arange(len(rec)) * float(rec.meta["config"]["params"]["timestep"])
