"""Presets: named designs of a rig, every ranged parameter at one value inside its sourced
range (`util.fields.Sourced`).

A design names each parameter by its --set key in the rig's protocol scene
("params.friction_mu0", "adc.hysteresis"; a tuple field's item as "prony.g1") and holds any
choice the rig adds (the footpad's die layout). Each rig's presets live in its wing
(`sim.footpad.presets`, `sim.shell.presets`): the nominal design (every parameter at its
sourced default) and the design identified from its paper's tables (`identify_footpad`,
`identify_shell`). `--preset NAME` applies one under the user's --set.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

from util import fields


@dataclasses.dataclass(frozen=True)
class Parameter:
  """One ranged parameter of a design.

  Attributes:
    key: its name in a design: the --set key of the rig's protocol scene, or
      "field.part" for one item of a tuple field ("prony.g1").
    lo, hi: its sourced range (the sources in the field's docstring).
    log: spread on a log scale (a time constant spanning decades).
    nominal: its value in the protocol's scene (the sourced default).
  """
  key: str
  lo: float
  hi: float
  log: bool
  nominal: float

  def position(self, value: float) -> float:
    """Where `value` sits in the range: 0 at lo, 1 at hi (on a log scale if spread so)."""
    if self.log:
      return math.log(value / self.lo) / math.log(self.hi / self.lo)
    return (value - self.lo) / (self.hi - self.lo)


def ranged(base: Any, fields_: tuple[tuple[str, str], ...]) -> tuple[Parameter, ...]:
  """The parameters of the fields (prefix, name) of the scene `base` ("params",
  "friction_mu0"; prefix "" for a field of the scene itself), read from their declared
  sourced ranges, nominal at the scene's values."""
  out = []
  for prefix, name in fields_:
    holder = getattr(base, prefix) if prefix else base
    value = getattr(holder, name)
    for k, (key, r) in enumerate(fields.sourced(type(holder), name).items()):
      nominal = value[k] if isinstance(value, tuple) else value
      full = key if r.part else (f"{prefix}.{key}" if prefix else key)
      out.append(Parameter(full, r.lo, r.hi, r.log, float(nominal)))
  return tuple(out)


def text(value) -> str:
  """A value as --set reads it."""
  if isinstance(value, tuple):
    return ",".join(text(v) for v in value)
  return repr(float(value)) if isinstance(value, float) else str(value)


@dataclasses.dataclass(frozen=True)
class Preset:
  """A named design and where it came from.

  Attributes:
    name: what --preset takes.
    what: one line for --help and the report.
    design: {parameter key: value, and the rig's choices}; a parameter left out stays
      nominal.
    parameters: () -> the rig's ranged parameters.
    to_overrides: design -> the --set overrides (key: text) that make it.
    identified_by: the command that found it ("" for the nominal design).
    note: how it was found (trials, seeds, its score and the nominal's).
  """
  name: str
  what: str
  design: dict
  parameters: Callable[[], tuple[Parameter, ...]]
  to_overrides: Callable[[dict], dict]
  identified_by: str = ""
  note: str = ""

  def overrides(self) -> dict[str, str]:
    return self.to_overrides(self.design)

  def lines(self) -> list[str]:
    """The report's account of the preset: each parameter, its range and where in it the
    value sits; a value outside its range is named as such."""
    out = [f"preset {self.name}: {self.what}" + (f"; identified by `{self.identified_by}`"
                                                 if self.identified_by else "")]
    if self.note:
      out.append(f"  {self.note}")
    keys = set()
    for p in self.parameters():
      keys.add(p.key)
      v = self.design.get(p.key, p.nominal)
      where = p.position(v)
      inside = "" if -1e-9 <= where <= 1 + 1e-9 else "   OUTSIDE its sourced range"
      out.append(f"  {p.key:32s} {v:11.4g}  range [{p.lo:g}, {p.hi:g}]"
                 f"{' log' if p.log else ''}, at {where:4.0%}{inside}")
    for key, value in self.design.items():
      if key not in keys and not isinstance(value, float):
        out.append(f"  {key:32s} {value!s:>11s}")
    return out
