"""Die stress to ADC counts for the footpad: MPXH6400A transfer law, named effects, MCP3208.

Runs after the physics and never feeds back into it, so it can be re-applied to stored die
pressures with other effects or another seed without re-simulating.
"""

from __future__ import annotations

import dataclasses
from typing import Literal, Optional

import numpy as np

from util import fields
from util.fields import Sourced, setting
from sim.effects import Step, active, play, rng_for, run_steps, wander
from sim.footpad import effects as fx
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
  hysteresis: float = setting(0.006, "[0, 0.012]", sourced=Sourced(0.0, 0.012))
  drift_offset: float = setting(0.005, "[0, 0.015]", sourced=Sourced(0.0, 0.015))
  drift_gain: float = setting(0.005, "[0, 0.015]", sourced=Sourced(0.0, 0.015))
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
          adc: AdcConfig = AdcConfig(), dt: float = 0.001,
          stream: Optional[int] = None) -> tuple[np.ndarray, np.ndarray]:
  """Runs the chain.

  Args:
    pressure: (N, D) die pressures, Pa gauge (compressive positive), one session in time
      order (the history effects, `hysteresis` and `thermal_drift`, run along it).
    wrench: (N, 6) plate wrench, N and N m.
    effects: names of the signal effects to apply (model effects are ignored here).
    seed: the run's seed.
    adc: sensor supply and ADC settings.
    dt: time between samples, s.
    stream: the recording's identity (`scene.stream_of`): its noise and drift are its own,
      while the dies' unit spread stays the pad's (None: keyed by the seed alone).
  Returns:
    counts (N, D) float64 and the plate wrench as measured (N, 6).
  """
  on = active(effects, EFFECTS)
  adc.validate()
  chain = _Chain(adc, seed, dt, stream)
  p = run_steps(PRESSURE_STEPS, np.asarray(pressure, dtype=np.float64), on, chain)
  counts = run_steps(COUNT_STEPS, pressure_to_counts(p, adc), on, chain)
  measured = run_steps(WRENCH_STEPS, np.array(wrench, dtype=np.float64), on, chain)
  return counts, measured


@dataclasses.dataclass(frozen=True)
class _Chain:
  """What the steps of one run read: the ADC settings, the run's seed, the sample time (s),
  the recording's stream."""
  adc: AdcConfig
  seed: int
  dt: float
  stream: Optional[int] = None


def _hysteresis(p, c: _Chain):
  return play(p, c.adc.hysteresis * MPX_SPAN / 2)


def _thermal_drift(p, c: _Chain):
  rng = rng_for(c.seed, fx.THERMAL_DRIFT.name, c.stream)
  steps = c.adc.drift_time / c.dt
  offset = wander(rng, p.shape, c.adc.drift_offset * MPX_SPAN, steps)
  gain = 1.0 + wander(rng, p.shape, c.adc.drift_gain, steps)
  return p * gain + offset


def _gain_offset_spread(p, c: _Chain):
  rng = rng_for(c.seed, fx.GAIN_OFFSET_SPREAD.name)
  gain = rng.normal(1.0, c.adc.gain_spread, p.shape[1])
  offset = rng.normal(0.0, c.adc.offset_spread, p.shape[1])
  return p * gain + offset


def _sensor_range(p, c: _Chain):
  return np.clip(p, MPX_P_MIN - ATMOSPHERE, MPX_P_MAX - ATMOSPHERE)


def _sensor_noise(counts, c: _Chain):
  rng = rng_for(c.seed, fx.SENSOR_NOISE.name, c.stream)
  return counts + rng.normal(0.0, c.adc.noise_counts, counts.shape)


def _adc_range(counts, c: _Chain):
  return np.clip(counts, 0.0, float(c.adc.full_scale))


def _ft_noise(wrench, c: _Chain):
  sd = np.array([0.125, 0.125, 0.25, 0.0075, 0.0075, 0.0075])
  return wrench + rng_for(c.seed, fx.FT_NOISE.name, c.stream).normal(0.0, 1.0,
                                                                     wrench.shape) * sd


# The chain in the order the hardware applies it: on the die's pressure (the gel's history,
# the die's drift and spread, the transducer's range), then on the counts (noise, the ADC's
# range, its conversion), and the plate's own noise on the wrench.
PRESSURE_STEPS = (Step((fx.HYSTERESIS,), _hysteresis),
                  Step((fx.THERMAL_DRIFT,), _thermal_drift),
                  Step((fx.GAIN_OFFSET_SPREAD,), _gain_offset_spread),
                  Step((fx.ADC_SATURATION,), _sensor_range))
COUNT_STEPS = (Step((fx.SENSOR_NOISE,), _sensor_noise),
               Step((fx.ADC_SATURATION,), _adc_range),
               Step((fx.ADC_QUANTISATION,), lambda counts, c: np.floor(counts)))
WRENCH_STEPS = (Step((fx.FT_NOISE,), _ft_noise),)
