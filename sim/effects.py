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

import numpy as np

from models import errors


class Kind(enum.Enum):
  MODEL = "model"  # changes the MuJoCo model
  STRESS = "stress"  # changes how element forces become die stresses, after the physics
  SIGNAL = "signal"  # acts on the physical signals and truth after the physics


@dataclasses.dataclass(frozen=True)
class Effect:
  """An effect's name, kind and the physical thing it stands for (with its magnitude's source)."""
  name: str
  kind: Kind
  doc: str


def check_effects(names, known: dict[str, Effect]) -> tuple[str, ...]:
  """Validates effect names; returns them sorted and de-duplicated."""
  unknown = [n for n in names if n not in known]
  if unknown:
    raise errors.SettingError(f"effects={tuple(names)!r} is out of range: unknown effect "
                              f"{unknown[0]!r}; allowed any of {', '.join(sorted(known))}")
  return tuple(sorted(set(names)))


def rng_for(seed: int, effect: str) -> np.random.Generator:
  """The random stream of one effect in one run: SeedSequence(seed) spawned by the name."""
  return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(zlib.crc32(effect.encode()),)))
