"""Photointerrupter (Sharp GP2S60) readout of the shell: reflector height to 12-bit counts.

The reflected intensity, after the SkinProc's current-to-voltage amplifier and 12-bit ADC,
follows s = a / r + b over the 2-4 mm window the paper fits (Sec. II-B, Eqns 1-2; Fig. 4:
~3900 counts at 2 mm, ~1975 at 4 mm). Nearer than that the detector's field of view and the
emitter's beam stop overlapping on the reflector, so the response peaks (at an assumed
~0.8 mm: it shapes the counts only below the 2 mm window) and falls to zero at contact; here that is the factor 1 - exp(-(r / r_c)^2), which peaks at
r = 1.121 r_c and departs from 1/r by under 0.05 % above 2 mm. `fit_inverse_r` is the paper's
Eqn 1 for users' own height sweeps, `range_from_counts` its Eqn 2.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from util import errors, fields
from util.fields import Sourced, setting
from sim.effects import Step, active, rng_for, run_steps, wander
from sim.shell import effects as fx
from sim.shell.effects import EFFECTS

# u = r / r_c at the maximum of (1 - exp(-u^2)) / u: 2 u^2 exp(-u^2) = 1 - exp(-u^2)
_PEAK_U = 1.1209


@fields.declared
@dataclasses.dataclass(frozen=True)
class Photointerrupter:
  """Response of one sensor channel.

  Attributes:
    a: 1/r coefficient, counts m. From the paper's Fig. 4 (3900 counts at 2 mm, 1975 at
      4 mm): a = 7.7 counts m, b = 50 counts.
    b: offset (the dark reading), counts; from Fig. 4 as for a.
    peak: height of the response peak, m (~0.8 mm).
    full_scale: largest ADC count (12-bit: 4095).
    window: (low, high) heights, m, where the 1/r law is fitted and trusted (2-4 mm).
    gain_spread, offset_spread: for the `unit_spread` effect: relative sd of a, sd of b
      (counts).
    stray_ir, stray_ir_time: for the `stray_ir` effect: rms offset (counts) of each of its
      two parts and their correlation time (s). 20 counts: near the top of the 3-22 counts
      per sensor that the paper's Table II resolutions amount to through the calibration
      (`shell_table2`; the sourced range); a 10 s rest sees less than the full rms of a 5 s
      process. The time is assumed.
  """
  a: float = setting(7.7, "(0, 1000]", "counts m")
  b: float = setting(50.0, "[-4095, 4095]", "counts")
  peak: float = setting(0.0008, "(0, 0.01)", "m")
  full_scale: int = setting(4095, "[1, 65535]", "counts")
  window: tuple[float, float] = setting((0.002, 0.004), "(0, 0.05)", "m")
  gain_spread: float = setting(0.15, "[0, 10]")
  offset_spread: float = setting(30.0, "[0, 1e4)", "counts")
  stray_ir: float = setting(20.0, "[0, 1e4)", "counts", sourced=Sourced(3.0, 22.0))
  stray_ir_time: float = setting(5.0, "(0, 1e4]", "s")

  def relations(self) -> fields.Relations:
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    yield (self.peak < self.window[0] < self.window[1], "window",
           f"(low, high) with peak={self.peak} m < low < high", self.window)

  def validate(self) -> None:
    fields.check(self)

  def counts(self, height: np.ndarray, near_field: bool = True) -> np.ndarray:
    """(...) counts before noise and quantisation, clipped to [0, full_scale]; NaN heights
    (no reflector in view) read the offset b.

    near_field=False keeps the 1/r law at every height (the ideal sensor of the fit).
    """
    r = np.asarray(height, dtype=np.float64)
    seen = np.isfinite(r)
    rr = np.where(seen, np.maximum(r, 1e-9), 1.0)
    s = self.a / rr
    if near_field:
      s = s * -np.expm1(-(rr * _PEAK_U / self.peak) ** 2)
    s = np.where(seen, s, 0.0) + self.b
    return np.clip(s, 0.0, float(self.full_scale))

  def in_window(self, height: np.ndarray) -> np.ndarray:
    """Boolean mask of heights inside the fitted window."""
    r = np.asarray(height)
    return (r >= self.window[0]) & (r <= self.window[1])


def fit_inverse_r(height: np.ndarray, counts: np.ndarray) -> tuple[float, float, float]:
  """Paper Eqn 1: least-squares (a, b) of s = a / r + b from a height sweep of one sensor.

  Args:
    height: (N,) reflector heights, m, inside the window to be trusted.
    counts: (N,) the sensor's readings there.
  Returns:
    (a, b, worst height error in m of Eqn 2 over the sweep).
  """
  r = np.asarray(height, dtype=np.float64)
  s = np.asarray(counts, dtype=np.float64)
  if r.shape != s.shape or r.ndim != 1:
    raise errors.DataError(f"height and counts must be 1-D of one length, got {r.shape}, {s.shape}")
  if len(r) < 3:
    raise errors.DataError(f"{len(r)} samples cannot fit a and b with an error estimate: need >= 3")
  if not (np.isfinite(r).all() and np.isfinite(s).all()) or np.any(r <= 0):
    raise errors.DataError("height must be finite and > 0 and counts finite")
  v = np.column_stack([1.0 / r, np.ones_like(r)])
  (a, b), *_ = np.linalg.lstsq(v, s, rcond=None)
  return float(a), float(b), float(np.max(np.abs(range_from_counts(s, a, b) - r)))


def range_from_counts(counts: np.ndarray, a: float, b: float) -> np.ndarray:
  """Paper Eqn 2: r = a / (s - b), m; NaN where s <= b (no reflector in range)."""
  s = np.asarray(counts, dtype=np.float64)
  with np.errstate(divide="ignore", invalid="ignore"):
    return np.where(s > b, a / (s - b), np.nan)


def apply(height: np.ndarray, effects, seed: int,
          sensor: Photointerrupter = Photointerrupter(),
          frame_rate: float = 100.0, unit_seed: int | None = None) -> np.ndarray:
  """Counts (N, 8) float64 from heights (N, 8), m, frames at frame_rate (Hz), with the listed
  signal effects of `sim.shell.effects.EFFECTS` (model effects are the scene's).

  unit_seed draws the `unit_spread` of the physical sensors (default: seed); runs of one
  board (calibration, test) share it while their noise differs.
  """
  on = active(effects, EFFECTS)
  sensor.validate()
  counts = sensor.counts(height, near_field=fx.OUT_OF_WINDOW in on)
  chain = _Chain(sensor, seed, seed if unit_seed is None else unit_seed, frame_rate)
  return run_steps(STEPS, counts, on, chain)


@dataclasses.dataclass(frozen=True)
class _Chain:
  """What the steps of one run read: the sensor, the run's seed, the board's seed (for
  `unit_spread`) and the frame rate (Hz)."""
  sensor: Photointerrupter
  seed: int
  unit_seed: int
  frame_rate: float


def _unit_spread(counts, c: _Chain):
  rng = rng_for(c.unit_seed, fx.UNIT_SPREAD.name)
  gain = rng.normal(1.0, c.sensor.gain_spread, counts.shape[1])
  offset = rng.normal(0.0, c.sensor.offset_spread, counts.shape[1])
  return (counts - c.sensor.b) * gain + c.sensor.b + offset


def _stray_ir(counts, c: _Chain):
  rng = rng_for(c.seed, fx.STRAY_IR.name)
  tau = c.sensor.stray_ir_time * c.frame_rate
  common = wander(rng, (counts.shape[0], 1), c.sensor.stray_ir, tau)
  return counts + common + wander(rng, counts.shape, c.sensor.stray_ir, tau)


def _adc_range(counts, c: _Chain):
  return np.clip(counts, 0.0, float(c.sensor.full_scale))


def _sensor_noise(counts, c: _Chain):
  noisy = counts + rng_for(c.seed, fx.SENSOR_NOISE.name).normal(0.0, 1.0, counts.shape)
  return _adc_range(noisy, c)


# The chain in the board's order: the sensors' own spread and the stray light on the
# detector (clipped once by the ADC's range), then the ADC's noise and its conversion.
STEPS = (Step((fx.UNIT_SPREAD,), _unit_spread),
         Step((fx.STRAY_IR,), _stray_ir),
         Step((fx.UNIT_SPREAD, fx.STRAY_IR), _adc_range),
         Step((fx.SENSOR_NOISE,), _sensor_noise),
         Step((fx.ADC_QUANTISATION,), lambda counts, c: np.floor(counts)))
