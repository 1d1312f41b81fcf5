"""Benchmarks of the VelociRoACH force-sensing shell: the paper's Tables I and II, its step,
gravity and collision experiments, and the reflector geometry; with the calibration they
share."""

from __future__ import annotations

import dataclasses
from typing import Any, Optional

import numpy as np

from sim.shell import paper

AXES = paper.AXES
PRINT_UNITS = np.array([1, 1, 1, 1e3, 1e3, 1e3])  # SI to the paper's N and mN m
# Settings the protocol sets itself, with the reason a --set of them is refused.
FIXED = {"frames": "the protocol runs the paper's frame counts (a tenth with --quick)",
         "seed": "use --seed"}


def presets() -> dict:
  """The shell's named designs (`sim.shell.presets`): what --preset takes."""
  from sim.shell import presets as presets_lib
  return presets_lib.presets()


def protocol_settings(quick: bool, seed: int):
  """The shell protocol's scene (`sim.shell.protocol.base`), the root of --set keys."""
  from sim.shell import protocol
  return protocol.base(quick, seed)


@dataclasses.dataclass(frozen=True)
class Calibration:
  """The shell runs of one benchmark and the fit made from them.

  Attributes:
    scenes: {"calibration", "test"} scenes (`sim.shell.protocol.scenes`); the calibration's
      is the board every other shell scene of the run is read with.
    runs: their recordings.
    timings: their simulation timings (None where loaded from the cache).
    estimator: the polynomial pseudoinverse (s, s^2, s^3 of each sensor, paper Eqns 4-9)
      fitted on the calibration run: counts -> (Fx, Fy, Fz, Mx, My, Mz).
  """
  scenes: dict[str, Any]
  runs: dict[str, Any]
  timings: dict[str, Any]
  estimator: Any

  @property
  def board(self):
    return self.scenes["calibration"]


def recordings(ctx, board: Optional[Any] = None) -> tuple[dict, dict, dict]:
  """The protocol's scenes for `board` (default the run's settings), and their recordings
  and timings ({"calibration", "test"} each), from the cache when simulated before."""
  from sim.shell import protocol, scene as scene_lib
  scenes = protocol.scenes(ctx.settings if board is None else board, ctx.quick, ctx.seed)
  runs, timings = {}, {}
  for name, scene in scenes.items():
    runs[name], timings[name] = scene_lib.generate(scene, ctx.progress(f"{name} frames"),
                                                   ctx.use_cache)
  ctx.used(*runs.values())
  return scenes, runs, timings


def calibrated(ctx, board: Optional[Any] = None) -> Calibration:
  """`recordings` for `board` and the cubic calibration fitted on the calibration run."""
  from calibrate import estimators
  scenes, runs, timings = recordings(ctx, board)
  cal = runs["calibration"]
  return Calibration(scenes, runs, timings,
                     estimators.fit(estimators.Kind.POLY, cal.counts, cal.wrench))
