"""The shell paper's data protocol (Sec. III-A): a calibration run and a test run of hand
loads at the paper's frame counts, from seeds drawn from the run's one seed."""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.shell import scene as scene_lib



def base(quick: bool, seed: int) -> scene_lib.ShellScene:
  """The protocol's scene before the user's settings (its frames and seed are set per run)."""
  return scene_lib.ShellScene()


def scenes(scene: scene_lib.ShellScene, quick: bool, seed: int
           ) -> dict[str, scene_lib.ShellScene]:
  """{"calibration", "test"}: `scene` (the user's board and loading) at the paper's frame
  counts (a tenth with --quick), seeds drawn from `seed`."""
  seeds = np.random.SeedSequence(seed).generate_state(2)
  out = {}
  for (name, frames), s in zip(scene_lib.PAPER_FRAMES.items(), seeds):
    out[name] = dataclasses.replace(scene, frames=frames // 10 if quick else frames, seed=int(s))
    out[name].validate()
  return out
