"""The footpad's named effects: every non-ideality its scenes can ask for (`sim.effects`)."""

from __future__ import annotations

from typing import Literal

from sim.effects import Effect, Kind

FRICTION = Effect("friction", Kind.MODEL,
    "Coulomb friction between pad and plate (condim 3, elliptic cone), one coefficient "
    "FootpadParams.friction for every element (`pressure_friction` replaces it with "
    "Thirion's law per element). Off: frictionless contact, no shear.",
    reads=("params.friction",))
PRESSURE_FRICTION = Effect("pressure_friction", Kind.MODEL,
    "Rubber's friction falls with contact pressure (Thirion's law, tau = mu0 p / (1 + "
    "mu0 p / tau_s); Schallamach 1952, Braun & Persson 2016): each element's "
    "coefficient follows its pressure under the press to the episode's depth, in "
    "place of the one Coulomb coefficient (FootpadParams.friction_mu0 and "
    "friction_shear_strength, whose sourced ranges are declared with them). Needs "
    "`friction`.",
    reads=("params.friction_mu0", "params.friction_shear_strength"),
    replaces=("params.friction",), needs=("friction",))
STICK_SLIP = Effect("stick_slip", Kind.MODEL,
    "Static friction above kinetic: a stuck element holds up to "
    "FootpadParams.static_friction_ratio times its coefficient (its sourced range is "
    "declared with it), breaks away there and slides at the kinetic coefficient "
    "until it stops or turns over the plate, then sticks again (a Karnopp-style state "
    "per element, updated every step). A history effect: after a reversal every "
    "element must build its shear past the static limit again. Needs `friction`. The "
    "steps run in chunks through MuJoCo's rollout, the state read from one contact "
    "sensor over the tips; a chunk is rolled again from the step where a coefficient "
    "changes (identical to stepping singly: `StickSlip.roll`).",
    reads=("params.static_friction_ratio",), needs=("friction",))
VISCOELASTIC = Effect("viscoelastic", Kind.MODEL,
    "Stress relaxation of the polyurethane as a two-term Prony series per element and "
    "axis (FootpadParams.prony, a fast and a slow term; their sourced ranges, low "
    "confidence, are declared with it). Rubber relaxes in shear (its bulk "
    "response is nearly elastic), so the shear springs relax alike, and the bonded "
    "layer's normal stiffness, which its shear modulus sets, too. With one material, "
    "imposed displacement and stuck contact every die and the plate relax with one "
    "kernel and the map stays linear: relaxation costs a calibration only with slip. "
    "Each Maxwell arm is an activation state of MuJoCo's, not a body: a compiled "
    "activation callback where a C compiler exists, else a passive DC motor with "
    "inductance, which obeys the arm's equation (`models.footpad.maxwell_arm`).",
    reads=("params.prony",))
P_DELTA = Effect("p_delta", Kind.STRESS,
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
    "solution of the layer would pin the split down.")
HYSTERESIS = Effect("hysteresis", Kind.SIGNAL,
    "Rate-independent hysteresis of each die (silicone gel, cast rubber and the "
    "transducer's own): a play operator on its pressure, loop width "
    "AdcConfig.hysteresis of the 380 kPa span (its range, bounded by the LSANN paper's "
    "linear Z fit, is declared with it). A history effect: one reading "
    "depends on the path the load took to it, which no static calibration can learn.",
    reads=("adc.hysteresis",))
THERMAL_DRIFT = Effect("thermal_drift", Kind.SIGNAL,
    "Slow drift of each die's offset and gain over a session (warm-up, the pad "
    "warming under load): Ornstein-Uhlenbeck processes with rms AdcConfig.drift_offset "
    "of span and drift_gain, correlation time drift_time (sizes and sources declared "
    "with them: the MPXH6400A's +-1.5 % band over 0-85 C).",
    reads=("adc.drift_offset", "adc.drift_gain", "adc.drift_time"))
SENSOR_NOISE = Effect("sensor_noise", Kind.SIGNAL,
    "White noise of the pressure sensor and ADC, in counts rms (default 1.5). Assumed: "
    "MPXH6400A output noise plus MCP3208 transition noise (datasheet: +-1 LSB INL) on an "
    "unshielded board; replace with a value measured at rest on your rig.",
    reads=("adc.noise_counts",))
GAIN_OFFSET_SPREAD = Effect("gain_offset_spread", Kind.SIGNAL,
    "Unit-to-unit spread of each die's sensitivity and offset after the casing is "
    "machined off and the die is cast in rubber: gain x N(1, 0.10), offset N(0, 3 kPa). "
    "Assumed; the datasheet's +-1.5 % VFSS holds only for unaltered sensors.",
    reads=("adc.gain_spread", "adc.offset_spread"))
ADC_QUANTISATION = Effect("adc_quantisation", Kind.SIGNAL,
    "12-bit conversion (MCP3208): counts are floored to integers.")
ADC_SATURATION = Effect("adc_saturation", Kind.SIGNAL,
    "Output limits: the MPXH6400A output saturates at its full-scale 400 kPa absolute "
    "(datasheet range 20-400 kPa) and the ADC clips at its reference (AdcConfig.vref): "
    "~299 kPa gauge with a 5 V reference, ~175 kPa with 3.3 V.")
FT_NOISE = Effect("ft_noise", Kind.SIGNAL,
    "Noise of the ATI Delta SI-660-60 plate: 1/8 N rms on Fx, Fy, 1/4 N on Fz (ATI's "
    "stated resolution for that calibration) and 0.0075 N m on torques (assumed).")

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    FRICTION, PRESSURE_FRICTION, STICK_SLIP, VISCOELASTIC, P_DELTA, HYSTERESIS, THERMAL_DRIFT,
    SENSOR_NOISE, GAIN_OFFSET_SPREAD, ADC_QUANTISATION, ADC_SATURATION, FT_NOISE)}

# The names a scene's `effects` field takes.
EffectName = Literal[tuple(EFFECTS)]
