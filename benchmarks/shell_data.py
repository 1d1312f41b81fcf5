"""The shell's calibration and test runs and their cubic calibration, shared by the shell
benchmarks."""

from __future__ import annotations

import dataclasses

import numpy as np

from calibrate import estimators
from sim import settings, shell


AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
PRINT_UNITS = np.array([1, 1, 1, 1e3, 1e3, 1e3])  # SI to the paper's N and mN m
# the paper's Table II, SkinProc row: range, resolution (N and N m)
PAPER_TABLE2 = {"Fx": (2.3, 0.0054), "Fy": (2.1, 0.0167), "Fz": (1.9, 0.0051),
                "Mx": (0.096, 0.00072), "My": (0.127, 0.00025), "Mz": (0.138, 0.00044)}


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


@dataclasses.dataclass(frozen=True)
class Calibration:
  """The shell runs of one benchmark and the fit made from them.

  Attributes:
    scenes: {"calibration", "test"} scenes (`scenes`); the calibration's is the board every
      other shell scene of the run is read with.
    runs: their simulated runs.
    estimator: the polynomial pseudoinverse (s, s^2, s^3 of each sensor, paper Eqns 4-9)
      fitted on the calibration run: counts -> (Fx, Fy, Fz, Mx, My, Mz).
  """
  scenes: dict[str, shell.ShellScene]
  runs: dict[str, shell.ShellRun]
  estimator: estimators.Estimator

  @property
  def board(self) -> shell.ShellScene:
    return self.scenes["calibration"]


def calibrated(ctx) -> Calibration:
  """Runs `scenes` and fits the cubic calibration on the calibration run."""
  sc = scenes(ctx)
  runs = {name: shell.simulate(scene, ctx.progress(f"{name} frames"))
          for name, scene in sc.items()}
  cal = runs["calibration"]
  return Calibration(sc, runs, estimators.fit(estimators.Kind.POLY, cal.counts, cal.wrench))
