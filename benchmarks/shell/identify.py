"""identify_shell: the shell's ranged parameters identified from its paper's tables (or your
own `metrics.csv`).

The same identification as `identify_footpad` (`benchmarks.identification`: Optuna within
the sourced ranges, a residual over the target cells in bands, a resumable study in
DIR/study.db). The parameters: the stray infrared light's size (`stray_ir`, turned on; 3-22
counts per sensor, what the paper's Table II resolutions amount to through the
calibration), the hand's largest force and torque (the paper's "about 1 N" and "about 60
mN m", bounded by its Table II ranges), and the share of its targets the hand scales back
into the sensors' window (the paper chose its range "to prevent the sensor from
saturating", yet its Table II ranges leave the window at this model's mount). One evaluation
is the paper's protocol: the cubic calibration on the calibration run, the Table I medians
on the test run, the test loads' ranges, and each axis's standard deviation over 10 s at
rest (Table II's resolution). Targets and bands: each median and resolution within a factor
of 2 is one band, each range within 15 %.

Trial 0 is the protocol's own design with stray infrared light at its nominal size.
"""

from __future__ import annotations

import numpy as np

from benchmarks import identification, shell
from benchmarks.identification import Target
from benchmarks.registry import register

AXES = shell.AXES
ALLOWED = ("group results with method POLY, an axis of Fx, Fy, Fz, Mx, My, Mz and metric "
           "median_pct, worst_pct or resolution (N, N m); group results with no method and "
           "metric range (N, N m)")


def paper_targets() -> tuple[Target, ...]:
  """The shell paper's Table I medians and Table II ranges and resolutions."""
  from sim.shell import paper
  out = [Target("results", "POLY", a, "median_pct", float(paper.TABLE1[a][0])) for a in AXES]
  out += [Target("results", "POLY", a, "resolution", paper.TABLE2[a][1]) for a in AXES]
  out += [Target("results", "", a, "range", paper.TABLE2[a][0]) for a in AXES]
  return tuple(out)


def scorable(group: str, method: str, axis: str, metric: str) -> bool:
  if group != "results" or axis not in AXES:
    return False
  if metric == "range":
    return not method
  return method == "POLY" and metric in ("median_pct", "worst_pct", "resolution")


def evaluate(ctx, board) -> dict:
  """The paper's protocol on the scene `board` as `shell_table1` and `shell_table2` run it:
  the cubic calibration's Table I scores on the test run, the test loads' ranges and the
  standard deviation at rest per axis."""
  from benchmarks.shell import table2
  from calibrate import metrics
  fit = shell.calibrated(ctx, board)
  test = fit.runs["test"]
  pred = fit.estimator.predict(test.counts)
  median = metrics.wrench_median_pct(pred, test.wrench)
  worst = metrics.worst_pct_of_range(pred, test.wrench)
  _, resolution = table2.at_rest(ctx, fit)
  span = np.ptp(test.wrench, axis=0)
  return {"results": {
      "POLY": {a: {"median_pct": float(median[i]), "worst_pct": float(worst[i]),
                   "resolution": float(resolution[i])} for i, a in enumerate(AXES)},
      "": {a: {"range": float(span[i])} for i, a in enumerate(AXES)}},
      "out_of_window": float(test.meta["out_of_window"])}


def settings(quick: bool, seed: int) -> identification.Settings:
  from sim.shell import protocol
  # a trial takes about 1 s with --quick, about 10 s at the paper's frames (2 cores)
  return identification.Settings(trials=60, scene=protocol.base(quick, seed))


FIXED = {"scene.frames": "the protocol runs the paper's frame counts (a tenth with --quick)",
         "scene.seed": "use --seed"}


@register("identify_shell", "shell: stray IR, the hand's force and torque ranges and its "
          "window identified from the paper's Tables I and II or your own metrics.csv, by "
          "Optuna within the sourced ranges; prints the preset",
          settings=settings, fixed=FIXED, tags=("shell", "paper", "identification"),
          presets=shell.presets, preset_prefix="scene.")
def run(ctx):
  from sim import settings as settings_lib
  from sim.shell import presets as presets_lib
  from sim.shell.scene import config as scene_config
  s = ctx.settings
  targets = identification.targets_of(s, scorable, ALLOWED, paper_targets)

  def one(design: dict, stop) -> dict:
    return evaluate(ctx, settings_lib.apply(s.scene, presets_lib.overrides(design)))
  nominal = {p.key: p.nominal for p in presets_lib.parameters()}
  spec = identification.Study(
      "identify_shell", presets_lib.parameters(), {}, (nominal,), one,
      lambda design, command, note: presets_lib.preset("identified", "the study's best design",
                                                       design, command, note),
      {"scene": scene_config(s.scene), "quick": ctx.quick})
  describe = (f"targets {'the paper' if not s.targets else s.targets}, "
              f"{'a tenth of ' if ctx.quick else ''}the paper's frames")
  return identification.run(ctx, spec, targets, s.trials, s.sampler, s.startup, describe)
