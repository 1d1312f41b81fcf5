"""step_response: a 50 g mass dropped from 0.5 cm onto the inverted robot (paper Sec. III-C).

The scene is `sim.shell.drop`: the robot on its back, a 50 g mass let go 5 mm over the
chassis's underside at 1 s. The shell's photointerrupters are read at 100 Hz and
calibrated by the cubic fit of `shell_table1` (the robot upright on the F/T body); the
benchmark prints the ringing frequency of the chassis on its springs (from the mount's z
joint at 1 kHz), the spring-mass value sqrt(k / m) / 2 pi for the moving mass, and the step
of the calibrated Fz, beside the paper's ~15 Hz and ~-0.5 N (Fig. 10). Contacts and damping
are the effects this scene needs; `--set` takes `ShellScene` fields as the other shell
benchmarks do (params.damping_ratio=0.1), for the calibration and the drop alike.
"""

from __future__ import annotations

import math

import numpy as np

from benchmarks import shell
from benchmarks.registry import register


def ringing_hz(z: np.ndarray, dt: float) -> float:
  """Dominant frequency of a trace (mean removed), by the peak of its Hann-windowed spectrum,
  refined by parabolic interpolation."""
  x = (z - z.mean()) * np.hanning(len(z))
  spec = np.abs(np.fft.rfft(x, n=8 * len(x)))
  freq = np.fft.rfftfreq(8 * len(x), dt)
  k = int(np.argmax(spec[1:])) + 1
  a, b, c = spec[k - 1], spec[k], spec[k + 1]
  return float(freq[k] + 0.5 * (a - c) / (a - 2 * b + c) * (freq[1] - freq[0]))


@register("step_response", "shell step response: 50 g dropped on the inverted robot, ringing Hz "
          "and Fz step", settings=shell.protocol_settings,
          presets=shell.presets, fixed=shell.FIXED,
          tags=("shell", "paper", "dynamics", "fast"))
def run(ctx) -> dict:
  from models import shell as model_lib
  from sim.shell import drop
  fit = shell.calibrated(ctx)
  scene, est = fit.board, fit.estimator
  params = scene.params
  sim = drop.simulate(scene, ctx.seed)
  dt = sim.dt
  after = sim.z[int(round(drop.DROP_AT / dt)) + 20:int(round((drop.DROP_AT + 1.5) / dt))]
  hz = ringing_hz(after, dt)
  k = model_lib.mount_stiffness(params)[2]
  expected = math.sqrt(k / sim.moving_mass) / (2 * math.pi)
  fz = est.predict(sim.counts)[:, 2]
  t = (np.arange(len(fz)) + 1) * sim.frame_dt
  before = fz[(t > drop.DROP_AT - 0.5) & (t < drop.DROP_AT)].mean()
  settled = fz[t > drop.END - 1.0].mean()
  ctx.print(f"ringing {hz:.1f} Hz (paper ~15 Hz); spring-mass sqrt(k/m)/2pi = {expected:.1f} Hz "
            f"for k = {k:.0f} N/m, m = {sim.moving_mass * 1e3:.0f} g")
  ctx.print(f"calibrated Fz step {settled - before:+.3f} N (paper ~-0.5 N; the mass weighs "
            f"{drop.PAYLOAD * 9.81:.3f} N)")
  return {"ringing_hz": hz, "spring_mass_hz": expected, "fz_step": float(settled - before),
          "moving_mass": sim.moving_mass, "paper": {"ringing_hz": 15.0, "fz_step": -0.5}}
