"""Named effects: every non-ideality a scene can ask for, off unless the scene lists it.

Model effects change the MuJoCo model; signal effects are pure, seeded functions applied after
the physics (`sim.footpad.sensor_chain`, `sim.shell.photointerrupter`). Each rig lists its
effects in its own table (`sim.footpad.effects`, `sim.shell.effects`). Each effect draws its
random numbers from its own stream, derived from the run's seed and the effect's name, so
switching one effect on or off never changes the draws of another, and an effect that is off
draws nothing.
"""

from __future__ import annotations

import dataclasses
import enum
import zlib
from typing import Any, Callable

import numpy as np

from util import errors


class Kind(enum.Enum):
  MODEL = "model"  # changes the MuJoCo model
  STRESS = "stress"  # changes how element forces become die stresses, after the physics
  SIGNAL = "signal"  # acts on the physical signals and truth after the physics


@dataclasses.dataclass(frozen=True)
class Effect:
  """An effect: what it is and which of the scene's settings it uses.

  Attributes:
    name: what a scene's `effects` lists.
    kind: where it acts (the model, the die stresses, the signals).
    doc: the physical thing it stands for, with its magnitude's source.
    reads: the settings (keys as --set spells them) that size it; they matter only while
      the effect is on.
    replaces: settings it takes the place of while it is on (they then change nothing).
    needs: effects that must be on with it (it sizes or modifies theirs).
  """
  name: str
  kind: Kind
  doc: str
  reads: tuple[str, ...] = ()
  replaces: tuple[str, ...] = ()
  needs: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Step:
  """One small function of a signal chain, run when any of `effects` is on.

  Attributes:
    effects: the declared effects it stands for (usually one; a shared clip may serve two).
    fn: (values, chain) -> values; `chain` carries the rig's settings and the run's seed.
  """
  effects: tuple[Effect, ...]
  fn: Callable[[Any, Any], Any]


def run_steps(steps, values, on: frozenset, chain):
  """Applies, in order, each step of `steps` whose effects meet the active set `on`."""
  for step in steps:
    if on.intersection(step.effects):
      values = step.fn(values, chain)
  return values


def active(names, known: dict[str, Effect]) -> frozenset[Effect]:
  """The declared effects a scene's `effects` names switch on (names checked first)."""
  return frozenset(known[n] for n in check_effects(names, known))


def missing_needs(names, known: dict[str, Effect]):
  """(effect, needed effect) pairs where an effect in `names` needs one that is off."""
  return [(n, need) for n in names for need in known[n].needs if need not in names]


def unread(key: str, active, known: dict[str, Effect]) -> str | None:
  """Why the setting `key` changes nothing with the effects `active` on (None if it may
  matter): an active effect replaces it, or only effects that are off read it."""
  for e in known.values():
    if e.name in active and key in e.replaces:
      instead = " and ".join(e.reads) or "nothing"
      return (f"the effect {e.name} replaces it (it reads {instead}): set those, or drop "
              f"{e.name} from effects")
  readers = [e.name for e in known.values() if key in e.reads]
  if readers and not set(readers) & set(active):
    return (f"only the effect {' or '.join(readers)} reads it, and the scene's effects leave "
            f"{'it' if len(readers) == 1 else 'them'} off: add {readers[0]} to effects")
  return None


def check_effects(names, known: dict[str, Effect]) -> tuple[str, ...]:
  """Validates effect names; returns them sorted and de-duplicated."""
  unknown = [n for n in names if n not in known]
  if unknown:
    raise errors.unknown("effect", unknown[0], sorted(known))
  return tuple(sorted(set(names)))


def rng_for(seed: int, effect: str, stream: int | None = None) -> np.random.Generator:
  """The random stream of one effect in one run: SeedSequence(seed) spawned by the name, and
  by `stream` (the recording's identity) when given, so two recordings of one run share no
  noise or drift draw while the pad's own unit spread (drawn without it) stays one pad."""
  key = (zlib.crc32(effect.encode()),) + (() if stream is None else (int(stream),))
  return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def wander(rng: np.random.Generator, shape: tuple[int, int], rms: float,
           steps_per_tau: float) -> np.ndarray:
  """(T, C) Ornstein-Uhlenbeck processes along axis 0 with stationary rms `rms` and
  correlation time `steps_per_tau` samples, stationary from the first sample (slow drifts:
  stray light, temperature)."""
  phi = np.exp(-1.0 / steps_per_tau)
  kick = rng.normal(0.0, rms * np.sqrt(1 - phi**2), shape)
  kick[0] = rng.normal(0.0, rms, shape[1])
  # out[i] = phi out[i-1] + kick[i], out[0] = kick[0]
  import scipy.signal  # here: its import takes 0.4 s, which every sweep worker would pay
  return scipy.signal.lfilter([1.0], [1.0, -phi], kick, axis=0)


def play(x: np.ndarray, half_width: float | np.ndarray) -> np.ndarray:
  """(T, C) the play (backlash) operator along axis 0: the output follows the input only
  when it is more than `half_width` away, so a loop of the input traces a rate-independent
  hysteresis loop 2 half_width wide; it starts at x[0].

  y[t] = clip(y[t-1], x[t] - w, x[t] + w) is a composition of clips, and clips compose into
  clips: clip(clip(y, a1, b1), a2, b2) = clip(y, clip(a1, a2, b2), clip(b1, a2, b2)). So the
  recursion is a prefix scan of (low, high) pairs, done in log2(T) vectorised passes
  (Hillis-Steele) instead of T Python steps.
  """
  x = np.asarray(x, dtype=np.float64)
  lo, hi = x - half_width, x + half_width
  step = 1
  while step < len(x):
    # the maps up to t become (maps up to t - step) followed by (maps t - step + 1 .. t)
    new_lo = np.clip(lo[:-step], lo[step:], hi[step:])
    new_hi = np.clip(hi[:-step], lo[step:], hi[step:])
    lo[step:], hi[step:] = new_lo, new_hi
    step *= 2
  return np.clip(x[:1], lo, hi)
