"""Die stress to ADC counts for the footpad: MPXH6400A transfer law, named effects, MCP3208.

Runs after the physics and never feeds back into it, so it can be re-applied to stored die
pressures with other effects or another seed without re-simulating.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from util import fields
from util.fields import setting
from sim.effects import check_effects, play, rng_for, wander
from sim.footpad.effects import EFFECTS

ATMOSPHERE = 101.325e3  # Pa
# MPXH6400A transfer function (datasheet): Vout = Vs * (0.002421 * P[kPa] - 0.00842).
MPX_GAIN = 0.002421  # 1/kPa
MPX_OFFSET = 0.00842
MPX_P_MAX = 400e3  # Pa absolute, end of the rated range
MPX_P_MIN = 20e3
MPX_SPAN = MPX_P_MAX - MPX_P_MIN  # Pa, the rated range


@fields.declared
@dataclasses.dataclass(frozen=True)
class AdcConfig:
  """Sensor supply and ADC.

  Attributes:
    vs: sensor supply, V (datasheet nominal 5.1 V; the footpad board runs at 5 V).
    vref: ADC reference, V; sets where the counts clip.
    bits: ADC resolution.
    noise_counts: rms noise for the `sensor_noise` effect, counts.
    gain_spread: relative sd of per-die sensitivity for `gain_offset_spread`.
    offset_spread: sd of per-die offset for `gain_offset_spread`, Pa.
    hysteresis: for the `hysteresis` effect, the width of each die's loading/unloading loop
      as a share of the MPXH6400A's 380 kPa span. Range 0-1.2 %: the ceiling is the LSANN
      paper's own linear Z fit (0.42 % NRMSE, Sec. III-B), which a wider loop could not
      leave; the default is the range's middle (no measurement of a cast die is published).
    drift_offset, drift_gain: for the `thermal_drift` effect, the rms of each die's slow
      offset drift (share of the span) and gain drift (relative). The MPXH6400A datasheet
      holds an intact sensor within +-1.5 % of span over 0-85 C; taking that band as 3 sd
      gives 0.5 % each by default (range 0-1.5 %: a die cast in rubber with its lid removed
      is compensated worse, and a session sees only part of 0-85 C).
    drift_time: correlation time of the drifts, s (assumed 300 s: the datasheet's warm-up
      and a pad warming under load drift over minutes).
  """
  vs: float = setting(5.0, "[4.5, 5.5]", "V")
  vref: float = setting(5.0, "[1, 5.5]", "V")
  bits: Literal[8, 10, 12, 14, 16] = 12
  noise_counts: float = setting(1.5, "[0, 1000]", "counts")
  gain_spread: float = setting(0.10, "[0, 1]")
  offset_spread: float = setting(3e3, "[0, 1e5]", "Pa")
  hysteresis: float = setting(0.006, "[0, 0.012]")
  drift_offset: float = setting(0.005, "[0, 0.015]")
  drift_gain: float = setting(0.005, "[0, 0.015]")
  drift_time: float = setting(300.0, "[1, 1e5]", "s")

  @property
  def full_scale(self) -> int:
    return 2**self.bits - 1

  def validate(self) -> None:
    fields.check(self)


def pressure_to_counts(pressure: np.ndarray, adc: AdcConfig) -> np.ndarray:
  """Ideal transfer law: gauge die pressure (Pa) to counts (float, unclipped)."""
  volts = adc.vs * (MPX_GAIN * (pressure + ATMOSPHERE) / 1e3 - MPX_OFFSET)
  return volts / adc.vref * (adc.full_scale + 1)


def counts_to_pressure(counts: np.ndarray, adc: AdcConfig) -> np.ndarray:
  """Inverse of `pressure_to_counts`, Pa gauge."""
  volts = np.asarray(counts) * adc.vref / (adc.full_scale + 1)
  return (volts / adc.vs + MPX_OFFSET) / MPX_GAIN * 1e3 - ATMOSPHERE


def saturation_pressure(adc: AdcConfig) -> float:
  """Lowest gauge pressure (Pa) at which a die's counts stop following the load."""
  return min(MPX_P_MAX - ATMOSPHERE, float(counts_to_pressure(adc.full_scale, adc)))


def apply(pressure: np.ndarray, wrench: np.ndarray, effects, seed: int,
          adc: AdcConfig = AdcConfig(), dt: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
  """Runs the chain.

  Args:
    pressure: (N, D) die pressures, Pa gauge (compressive positive), one session in time
      order (the history effects, `hysteresis` and `thermal_drift`, run along it).
    wrench: (N, 6) plate wrench, N and N m.
    effects: names of the signal effects to apply (model effects are ignored here).
    seed: the run's seed.
    adc: sensor supply and ADC settings.
    dt: time between samples, s.
  Returns:
    counts (N, D) float64 and the plate wrench as measured (N, 6).
  """
  effects = check_effects(effects, EFFECTS)
  adc.validate()
  p = np.asarray(pressure, dtype=np.float64)
  if "hysteresis" in effects:
    p = play(p, adc.hysteresis * MPX_SPAN / 2)
  if "thermal_drift" in effects:
    rng = rng_for(seed, "thermal_drift")
    steps = adc.drift_time / dt
    offset = wander(rng, p.shape, adc.drift_offset * MPX_SPAN, steps)
    gain = 1.0 + wander(rng, p.shape, adc.drift_gain, steps)
    p = p * gain + offset
  if "gain_offset_spread" in effects:
    rng = rng_for(seed, "gain_offset_spread")
    gain = rng.normal(1.0, adc.gain_spread, p.shape[1])
    offset = rng.normal(0.0, adc.offset_spread, p.shape[1])
    p = p * gain + offset
  if "adc_saturation" in effects:
    p = np.clip(p, MPX_P_MIN - ATMOSPHERE, MPX_P_MAX - ATMOSPHERE)
  counts = pressure_to_counts(p, adc)
  if "sensor_noise" in effects:
    counts = counts + rng_for(seed, "sensor_noise").normal(0.0, adc.noise_counts, counts.shape)
  if "adc_saturation" in effects:
    counts = np.clip(counts, 0.0, float(adc.full_scale))
  if "adc_quantisation" in effects:
    counts = np.floor(counts)
  measured = np.array(wrench, dtype=np.float64)
  if "ft_noise" in effects:
    sd = np.array([0.125, 0.125, 0.25, 0.0075, 0.0075, 0.0075])
    measured = measured + rng_for(seed, "ft_noise").normal(0.0, 1.0, measured.shape) * sd
  return counts, measured
