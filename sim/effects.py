"""Named effects: every non-ideality a scene can ask for, off unless the scene lists it.

Model effects change the MuJoCo model; signal effects are pure, seeded functions applied after
the physics (`sim.sensor_chain`). Each effect draws its random numbers from its own stream,
derived from the run's seed and the effect's name, so switching one effect on or off never
changes the draws of another, and an effect that is off draws nothing.
"""

from __future__ import annotations

import dataclasses
import enum
import zlib

import numpy as np


class Kind(enum.Enum):
  MODEL = "model"  # changes the MuJoCo model
  STRESS = "stress"  # changes how element forces become die stresses, after the physics
  SIGNAL = "signal"  # acts on die stresses and plate readings (`sim.sensor_chain`)


@dataclasses.dataclass(frozen=True)
class Effect:
  """An effect's name, kind and the physical thing it stands for (with its magnitude's source)."""
  name: str
  kind: Kind
  doc: str


FOOTPAD_EFFECTS: dict[str, Effect] = {e.name: e for e in [
    Effect("friction", Kind.MODEL,
           "Coulomb friction between pad and plate (condim 3, elliptic cone), coefficient "
           "FootpadParams.friction = 0.9: 0.8-1 reproduces the paper's ~220 N shear ranges "
           "(DESIGN.md, measured). Off: frictionless contact, no shear."),
    Effect("viscoelastic", Kind.MODEL,
           "Stress relaxation of the polyurethane: a standard linear solid per element and "
           "axis (the element spring in parallel with a Maxwell arm of stiffness "
           "relaxation_fraction * k and time constant relaxation_time). Rubber relaxes in "
           "shear (its bulk response is nearly elastic), so the shear springs relax alike, "
           "and the bonded layer's normal stiffness, which its shear modulus sets, too. "
           "Magnitudes are assumed (20 % over 1 s, of the order reported for soft cast "
           "polyurethanes); no datasheet gives them for Vytaflex 20."),
    Effect("p_delta", Kind.STRESS,
           "Second-order (P-delta) statics of the deformed pad: the plate's forces act where the "
           "contact face has moved, sideways by each element's shear deflection u and towards "
           "the PCB by its compression q_z, so each element adds a couple f_z u - f_t q_z "
           "(N m) about its patch, carried to the dies by the same layer model "
           "(`sim.layer.couple_kernel`); the small-strain kernel alone balances the PCB's "
           "moment in the undeformed geometry. No free parameter: the size follows from the "
           "simulated deflections. On the default pad f_z u is 0.77 of the shear's own moment "
           "f_t h at 210 N (u = f_t / k_t, k_t = 21 kN/m, h = 13 mm) and the X column "
           "difference per newton of shear grows x1.46, x1.91, x2.36 at 70, 140, 210 N "
           "(measured): the dies, 1 mm above the PCB, feel a couple on the face more than the "
           "same moment delivered by shear. First order in u; a geometrically nonlinear "
           "solution of the layer would pin the split down."),
    Effect("sensor_noise", Kind.SIGNAL,
           "White noise of the pressure sensor and ADC, in counts rms (default 1.5). Assumed: "
           "MPXH6400A output noise plus MCP3208 transition noise (datasheet: +-1 LSB INL) on an "
           "unshielded board; replace with a value measured at rest on your rig."),
    Effect("gain_offset_spread", Kind.SIGNAL,
           "Unit-to-unit spread of each die's sensitivity and offset after the casing is "
           "machined off and the die is cast in rubber: gain x N(1, 0.10), offset N(0, 3 kPa). "
           "Assumed; the datasheet's +-1.5 % VFSS holds only for unaltered sensors."),
    Effect("adc_quantisation", Kind.SIGNAL,
           "12-bit conversion (MCP3208): counts are floored to integers."),
    Effect("adc_saturation", Kind.SIGNAL,
           "Output limits: the MPXH6400A output saturates at its full-scale 400 kPa absolute "
           "(datasheet range 20-400 kPa) and the ADC clips at its reference (AdcConfig.vref): "
           "~299 kPa gauge with a 5 V reference, ~175 kPa with 3.3 V."),
    Effect("ft_noise", Kind.SIGNAL,
           "Noise of the ATI Delta SI-660-60 plate: 1/8 N rms on Fx, Fy, 1/4 N on Fz (ATI's "
           "stated resolution for that calibration) and 0.0075 N m on torques (assumed)."),
]}


SHELL_EFFECTS: dict[str, Effect] = {e.name: e for e in [
    Effect("out_of_window", Kind.SIGNAL,
           "The photointerrupter's response outside the 2-4 mm window the 1/r law is fitted "
           "on: below ~2 mm the 12-bit ADC clips at 4095, below the ~0.8 mm peak the response "
           "falls towards zero (paper Fig. 4, DESIGN.md). Off: the ideal a/r + b at every "
           "height (still clipped to the ADC's range)."),
    Effect("ray_miss", Kind.SIGNAL,
           "A sensor whose line of sight passes beside its reflector facet (a square of "
           "ShellParams.reflector_size, 5 mm assumed, in the shell frame) sees no reflector "
           "and reads its dark offset b, as MuJoCo's rays do (`sim.shell_geometry.heights` "
           "with finite_facets). No free parameter beyond the facet's size."),
    Effect("sensor_noise", Kind.SIGNAL,
           "White noise of the photointerrupter, amplifier and ADC: 1 count rms, the paper's "
           "'standard deviation of only 1 bit' at a static height (Sec. II-B)."),
    Effect("adc_quantisation", Kind.SIGNAL,
           "12-bit conversion of the microcontroller's ADC: counts are floored to integers."),
    Effect("unit_spread", Kind.SIGNAL,
           "Unit-to-unit spread of the photointerrupters: each sensor's 1/r coefficient a x "
           "N(1, Photointerrupter.gain_spread = 0.15) and offset b + N(0, offset_spread = 30 "
           "counts). Assumed within wide limits: the paper fits a and b per sensor (Eqns "
           "1-2) without giving their spread, and Sharp specifies its photointerrupters' "
           "output only within a 10:1 window (GP1S24 datasheet: collector current 40-400 uA). "
           "The calibration absorbs it: Table I medians move by 0.3 points at most."),
    Effect("stray_ir", Kind.SIGNAL,
           "Stray infrared light reaching the detectors through the open shell: an offset "
           "wandering as an Ornstein-Uhlenbeck process, shared by all sensors (room light) plus "
           "a per-sensor part, each Photointerrupter.stray_ir = 20 counts rms with a "
           "stray_ir_time = 5 s correlation time. Size from the paper: its Table II standard "
           "deviations at rest are, through this model's calibration, 3-22 counts of white "
           "noise per sensor or 7 counts common to all (`shell_table2` prints it), far above "
           "the 1 count of a static sensor on the bench (Sec. II-B); it zeroes 'a small "
           "constant offset' by averaging (Sec. III-A) and names stray IR for new shells to "
           "shield against (Sec. IV). The correlation time is assumed."),
    Effect("spring_hysteresis", Kind.MODEL,
           "Coulomb friction in the mount (spring seats, shell fixings): frictionloss on the "
           "mount joints of ShellParams.mount_friction = 10 mN and 0.6 mN m, 1 % of the hand "
           "loads' range. Assumed; steel springs themselves are nearly lossless."),
]}


def check_effects(names, known: dict[str, Effect]) -> tuple[str, ...]:
  """Validates effect names; returns them sorted and de-duplicated."""
  unknown = [n for n in names if n not in known]
  if unknown:
    raise ValueError(f"unknown effect {unknown[0]!r}: allowed {', '.join(sorted(known))}")
  return tuple(sorted(set(names)))


def rng_for(seed: int, effect: str) -> np.random.Generator:
  """The random stream of one effect in one run: SeedSequence(seed) spawned by the name."""
  return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(zlib.crc32(effect.encode()),)))
