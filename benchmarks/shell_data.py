"""The shell's calibration and test runs and their cubic calibration, shared by the shell
benchmarks."""

from __future__ import annotations

import dataclasses

import numpy as np

from calibrate import estimators
from sim import settings, shell


def scenes(ctx) -> dict[str, shell.ShellScene]:
  """{"calibration", "test"} scenes at the paper's frame counts (a tenth with --quick), from
  seeds drawn from the run's seed; `--set` takes `ShellScene` fields."""
  base = settings.apply(shell.ShellScene(), ctx.overrides)
  seeds = np.random.SeedSequence(ctx.seed).generate_state(2)
  out = {}
  for (name, frames), seed in zip(shell.PAPER_FRAMES.items(), seeds):
    n = frames // 10 if ctx.quick else frames
    out[name] = dataclasses.replace(base, frames=n, seed=int(seed))
    out[name].validate()
  return out


def calibrated(ctx) -> tuple[dict[str, shell.ShellRun], estimators.Estimator]:
  """The runs of `scenes` and the polynomial pseudoinverse (s, s^2, s^3 of each sensor, paper
  Eqns 4-9) fitted on the calibration run: counts -> (Fx, Fy, Fz, Mx, My, Mz)."""
  runs = {name: shell.simulate(scene, ctx.progress(f"{name} frames"))
          for name, scene in scenes(ctx).items()}
  cal = runs["calibration"]
  return runs, estimators.fit(estimators.Kind.POLY, cal.counts, cal.wrench)
