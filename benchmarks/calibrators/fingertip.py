"""A synthetic magnetic fingertip logged as real rigs log it: the pathologies of a real
recording set, planted with known answers, for `real_recordings`.

A magnet in a soft elastomer dome moves under the contact force; four three-axis
magnetometers below it read its dipole field (12 coupled, nonlinear channels). What a real
log adds, each planted here:
  - the dome's creep: a fast Prony term (g = 0.15 of the compliance at tau = 0.8 s, inside
    the range given for soft cast polyurethane, g1 0.05-0.2 at 0.1-2 s) delays part of the
    displacement, so loading and unloading differ (rate-dependent hysteresis);
  - a baseline per recording and channel (the earth's field and the sensor's offset move
    between sessions: 20 uT sd), each recording starting with 1 s at rest for a tare;
  - 16-bit registers at 0.3 uT per bit (a magnetometer's, e.g. MLX90393's 0.3 uT/LSB
    range): a hard press drives the nearest chip's x and y past +-9,830 uT and its registers
    wrap; the logger writes each value times one calibration gain (1.0137), so the values
    lie off the 0.3-uT grid, on a grid of 0.3 x the gain, and a few rows it repaired (the
    mean of their neighbours, 0.05 %) lie off any grid;
  - the sensor at 100 Hz, the force/torque reference on its own irregular clock (210-330
    Hz, as a USB logger's) with dropouts (a 50-150 ms gap every ~4 s), stamping each event
    25 ms late; unit-laden headers (`X0 [uT]`, `F_x [N]`);
  - test recordings pressed deeper than the training ones (peak normal force 9 N against
    6 N).
"""

from __future__ import annotations

import dataclasses

import numpy as np

RATE = 100.0  # Hz, the magnetometers'
LSB = 0.3  # uT per bit
BITS = 16
LAG = 0.025  # s: the reference stamps each event this much later
REST = 1.0  # s at rest at the start of every recording (for the tare)
MU0_4PI = 1e-7  # T m / A
MOMENT = np.array([0.0, 0.0, 8.8e-3])  # A m^2: the magnet's dipole, along z
MAGNET = np.array([0.0, 0.0, 4.0e-3])  # m: its rest position above the chips' plane
CHIPS = np.array([[3e-3, 3e-3, 0.0], [-3e-3, 3e-3, 0.0], [-3e-3, -3e-3, 0.0],
                  [2.2e-3, -2.2e-3, 0.0]])  # m: the last one nearest the magnet: it wraps
COMPLIANCE = np.array([0.25e-3, 0.25e-3, 0.4e-3])  # m/N at zero load (x, y, z): a soft dome
STIFFEN = 6.0  # N: the dome stiffens, its compliance halved at this force
CREEP, TAU = 0.15, 0.8  # the fast Prony term: share of the compliance, s


@dataclasses.dataclass(frozen=True)
class Recording:
  """One recording as the two loggers wrote it: the sensor's (time, 12 channels in uT) and
  the reference's (time, Fx, Fy, Fz in N), with the force at the sensor's instants."""
  sensor_t: np.ndarray
  sensor: np.ndarray
  reference_t: np.ndarray
  reference: np.ndarray
  truth: np.ndarray


def loads(rng: np.random.Generator, seconds: float, peak: float, rate: float) -> np.ndarray:
  """(N, 3) contact force at `rate` Hz: presses of 0.5-2 s (raised cosine), 0.3-1 s apart,
  peak normal force up to `peak` N, tangential up to half of it; at rest for `REST` s."""
  t = np.arange(0, seconds, 1 / rate)
  f = np.zeros((len(t), 3))
  start = REST + rng.uniform(0.2, 0.5)
  while start < seconds - 0.5:
    length = rng.uniform(0.5, 2.0)
    fz = rng.uniform(0.5, peak)
    shear = rng.uniform(-0.5, 0.5, 2) * fz
    on = (t >= start) & (t < start + length)
    shape = 0.5 - 0.5 * np.cos(2 * np.pi * (t[on] - start) / length)
    f[on] = np.outer(shape, [shear[0], shear[1], fz])
    start += length + rng.uniform(0.3, 1.0)
  return f


def field(force: np.ndarray, dt: float) -> np.ndarray:
  """(N, 12) the chips' field in uT: the magnet displaced by the dome's compliance, part of
  it creeping in with `TAU` (the displacement's fast Prony term)."""
  norm = np.linalg.norm(force, axis=1, keepdims=True)
  instant = force * COMPLIANCE / (1 + norm / STIFFEN)
  creep = np.zeros_like(instant)
  a = dt / (TAU + dt)
  for k in range(1, len(instant)):  # first order lag toward the creep's share
    creep[k] = creep[k - 1] + a * (CREEP * instant[k] - creep[k - 1])
  pos = MAGNET + ((1 - CREEP) * instant + creep) * [1.0, 1.0, -1.0]  # a press: down
  out = []
  for chip in CHIPS:
    r = chip - pos
    d = np.linalg.norm(r, axis=1, keepdims=True)
    rhat = r / d
    b = MU0_4PI * (3 * rhat * (rhat @ MOMENT)[:, None] - MOMENT) / d ** 3
    out.append(b * 1e6)  # T -> uT
  return np.hstack(out)


GAIN = 1.0137  # the logger's calibration gain: its values leave the 0.3-uT grid


def register(b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
  """What the logger writes: the field quantised to `LSB`, held in a signed `BITS`-bit
  register (wrapping past its ends), times `GAIN`; 0.05 % of the rows repaired as the mean
  of their neighbours."""
  counts = np.round(b / LSB)
  half = 2 ** (BITS - 1)
  out = ((counts + half) % (2 * half) - half) * LSB * GAIN
  repaired = rng.choice(np.arange(1, len(out) - 1), max(1, len(out) // 2000), replace=False)
  out[repaired] = (out[repaired - 1] + out[repaired + 1]) / 2
  return out


PERIOD = 2 ** BITS * LSB * GAIN  # the wrap-around's period in the logged units


def recording(rng: np.random.Generator, seconds: float, peak: float) -> Recording:
  """One recording: the force at 1 kHz, the sensor read at `RATE` with its baseline and
  1 uT of noise, the reference on its irregular clock with dropouts, `LAG` late."""
  fine = 1000.0
  f = loads(rng, seconds, peak, fine)
  t = np.arange(len(f)) / fine
  b = field(f, 1 / fine)
  ts = np.arange(0, seconds - 0.05, 1 / RATE)
  idx = np.round(ts * fine).astype(int)
  baseline = rng.normal(0, 20.0, 12)
  sensor = register(b[idx] + baseline + rng.normal(0, 1.0, (len(idx), 12)), rng)
  steps = rng.uniform(1 / 330, 1 / 210, int(seconds * 330))
  tr = np.cumsum(steps)
  tr = tr[tr < seconds - 0.05]
  keep = np.ones(len(tr), bool)
  for start in np.arange(rng.uniform(1.5, 4), seconds, rng.uniform(3, 5)):
    keep &= ~((tr > start) & (tr < start + rng.uniform(0.05, 0.15)))
  tr = tr[keep]
  ref = np.column_stack([np.interp(tr, t, c) for c in f.T]) + rng.normal(0, 0.01, (len(tr), 3))
  return Recording(ts, sensor, tr + LAG, ref, f[idx])


SENSOR_NAMES = tuple(f"X{i} [uT]" for i in range(12))
REFERENCE_NAMES = ("F_x [N]", "F_y [N]", "F_z [N]")


def write(folder, name: str, rec: Recording) -> tuple:
  """The recording's two logger files, `<name>_sensor.csv` and `<name>_reference.csv`, with
  unit-laden headers; returns their paths."""
  from calibrate import csvfile
  a, b = folder / f"{name}_sensor.csv", folder / f"{name}_reference.csv"
  csvfile.write(a, ("time",) + SENSOR_NAMES, np.column_stack([rec.sensor_t, rec.sensor]))
  csvfile.write(b, ("time",) + REFERENCE_NAMES,
                np.column_stack([rec.reference_t, rec.reference]))
  return a, b
