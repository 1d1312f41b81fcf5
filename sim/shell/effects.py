"""The shell's named effects: every non-ideality its scenes can ask for (`sim.effects`)."""

from __future__ import annotations

from typing import Literal

from sim.effects import Effect, Kind

OUT_OF_WINDOW = Effect("out_of_window", Kind.SIGNAL,
    "The photointerrupter's response outside the 2-4 mm window the 1/r law is fitted "
    "on: below ~2 mm the 12-bit ADC clips at 4095, below the ~0.8 mm peak the response "
    "falls towards zero (the peak position, Photointerrupter.peak, is assumed). Off: the "
    "ideal a/r + b at every height (still clipped to the ADC's range).",
    reads=("sensor.peak",))
RAY_MISS = Effect("ray_miss", Kind.SIGNAL,
    "A sensor whose line of sight passes beside its reflector facet (a square of "
    "ShellParams.reflector_size, 5 mm assumed, in the shell frame) sees no reflector "
    "and reads its dark offset b, as MuJoCo's rays do (`sim.shell.geometry.heights` "
    "with finite_facets). No free parameter beyond the facet's size.")
SENSOR_NOISE = Effect("sensor_noise", Kind.SIGNAL,
    "White noise of the photointerrupter, amplifier and ADC: 1 count rms, the paper's "
    "'standard deviation of only 1 bit' at a static height (Sec. II-B).")
ADC_QUANTISATION = Effect("adc_quantisation", Kind.SIGNAL,
    "12-bit conversion of the microcontroller's ADC: counts are floored to integers.")
UNIT_SPREAD = Effect("unit_spread", Kind.SIGNAL,
    "Unit-to-unit spread of the photointerrupters: each sensor's 1/r coefficient a x "
    "N(1, Photointerrupter.gain_spread = 0.15) and offset b + N(0, offset_spread = 30 "
    "counts). Assumed within wide limits: the paper fits a and b per sensor (Eqns "
    "1-2) without giving their spread, and Sharp specifies its photointerrupters' "
    "output only within a 10:1 window (GP1S24 datasheet: collector current 40-400 uA). "
    "The calibration absorbs it: Table I medians move by 0.3 points at most.",
    reads=("sensor.gain_spread", "sensor.offset_spread"))
STRAY_IR = Effect("stray_ir", Kind.SIGNAL,
    "Stray infrared light reaching the detectors through the open shell: an offset "
    "wandering as an Ornstein-Uhlenbeck process, shared by all sensors (room light) plus "
    "a per-sensor part, each Photointerrupter.stray_ir = 20 counts rms with a "
    "stray_ir_time = 5 s correlation time. Size from the paper: its Table II standard "
    "deviations at rest are, through this model's calibration, 3-22 counts of white "
    "noise per sensor or 7 counts common to all (`shell_table2` prints it), far above "
    "the 1 count of a static sensor on the bench (Sec. II-B); it zeroes 'a small "
    "constant offset' by averaging (Sec. III-A) and names stray IR for new shells to "
    "shield against (Sec. IV). The correlation time is assumed.",
    reads=("sensor.stray_ir", "sensor.stray_ir_time"))
SPRING_HYSTERESIS = Effect("spring_hysteresis", Kind.MODEL,
    "Coulomb friction in the mount (spring seats, shell fixings): frictionloss on the "
    "mount joints of ShellParams.mount_friction = 10 mN and 0.6 mN m, 1 % of the hand "
    "loads' range. Assumed; steel springs themselves are nearly lossless.",
    reads=("params.mount_friction",))

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    OUT_OF_WINDOW, RAY_MISS, SENSOR_NOISE, ADC_QUANTISATION, UNIT_SPREAD, STRAY_IR,
    SPRING_HYSTERESIS)}

# The names a scene's `effects` field takes.
EffectName = Literal[tuple(EFFECTS)]
