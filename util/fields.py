"""Declared settings: each field of a configuration dataclass states its range and unit once.

A numeric field is declared with `setting(default, interval, unit)`, the interval written as it
is printed: "[0.001, 0.05]", "(0, inf)" (inf refused), "(0, inf]" (inf allowed). NaN is never
allowed. Tuples apply the interval to every number in them. Strings take `Literal[...]`
annotations, enums their members, booleans only True or False. `declared` refuses, when the
class is defined, a numeric field without an interval or any field without a line in the
class's "Attributes:" docstring, so a field cannot be added unchecked or unexplained. `check`
runs every declared check of a dataclass and of the dataclasses nested in it, then each
class's `relations()` (checks between fields), and raises `ValueError` naming the key as
`--set` spells it ("params.friction=0.0 is out of range: allowed (0, inf)").

This module imports only `util.errors`: `models`, `sim` and `benchmarks` build on it.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import inspect
import math
import re
import types
import typing
from typing import Any, Iterator, Mapping, Optional

import numpy as np

from util import errors

_INTERVAL = re.compile(r"\s*([\[(])\s*([^,\s]+)\s*,\s*([^,\s]+)\s*([\])])\s*")
_ENTRY = re.compile(r"^ {2}(\w+(?:, \w+)*): ?(.*)$")


@dataclasses.dataclass(frozen=True)
class Interval:
  """An interval of the real line as written, e.g. "(0, 5]"; inf is inside only behind a
  closed bracket."""
  text: str
  lo: float
  hi: float
  lo_closed: bool
  hi_closed: bool

  @classmethod
  def parse(cls, text: str) -> "Interval":
    m = _INTERVAL.fullmatch(text)
    if not m:
      raise ValueError(f"interval {text!r} is not of the form '[lo, hi]' or '(lo, hi)'")
    return cls(text, float(m[2]), float(m[3]), m[1] == "[", m[4] == "]")

  def __contains__(self, v: float) -> bool:
    # comparisons with NaN are False: NaN is never inside
    above = v >= self.lo if self.lo_closed else v > self.lo
    below = v <= self.hi if self.hi_closed else v < self.hi
    return bool(above and below)

  def __str__(self) -> str:
    return self.text


@dataclasses.dataclass(frozen=True)
class Sourced:
  """The range a parameter's sources leave it in (narrower than what it allows): where a
  magnitude is known only that far, a sweep simulates the whole range. The sources are in
  the field's docstring entry.

  Attributes:
    lo, hi: the range's ends.
    log: drawn uniformly in log (a time constant spanning decades).
    part: for one item of a tuple field, the item's name ("g1" of a Prony series).
  """
  lo: float
  hi: float
  log: bool = False
  part: str = ""


def setting(default: Any, interval: str, unit: str = "", *,
            length: Optional[tuple[int, int]] = None,
            sourced: Optional[Sourced | tuple[Sourced, ...]] = None) -> Any:
  """A dataclass field with its allowed interval and unit (and, for a variable-length tuple,
  its allowed number of items, inclusive; for a magnitude known only within a range, that
  range: one `Sourced`, or one per item of a tuple)."""
  return dataclasses.field(default=default, metadata={
      "interval": Interval.parse(interval), "unit": unit, "length": length,
      "sourced": sourced})


def sourced(cls: type, name: str) -> dict[str, Sourced]:
  """{key: range} of the field `name` of the dataclass `cls`: `name` for a number, and
  "name.part" for each item of a tuple ("prony.g1")."""
  meta = next(f.metadata for f in dataclasses.fields(cls) if f.name == name)
  ranges = meta.get("sourced")
  if ranges is None:
    raise KeyError(f"{cls.__name__}.{name} declares no sourced range")
  if isinstance(ranges, Sourced):
    return {name: ranges}
  return {f"{name}.{r.part}": r for r in ranges}


@functools.cache
def types_of(cls: type) -> dict[str, Any]:
  """{field name: resolved annotation} of a dataclass."""
  return typing.get_type_hints(cls)


def optional(tp) -> tuple[Any, bool]:
  """(inner type, True) for Optional[inner], else (tp, False)."""
  if typing.get_origin(tp) in (typing.Union, types.UnionType):
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    if len(args) == 1 and len(typing.get_args(tp)) == 2:
      return args[0], True
  return tp, False


def _numbers(tp) -> bool:
  """Whether values of the annotation hold numbers (directly or inside tuples)."""
  tp, _ = optional(tp)
  if typing.get_origin(tp) is tuple:
    return any(_numbers(a) for a in typing.get_args(tp) if a is not Ellipsis)
  return tp in (int, float)


@functools.cache
def docs_of(cls: type) -> dict[str, str]:
  """{field name: its first sentence} from the class docstring's "Attributes:" section
  (entries "    name: text" or "    a, b: text", continued on deeper-indented lines)."""
  out: dict[str, str] = {}
  # dedented, so a class defined at any depth reads the same
  text = inspect.cleandoc(cls.__doc__ or "").split("Attributes:", 1)
  if len(text) < 2:
    return out
  names: list[str] = []
  for line in text[1].splitlines():
    m = _ENTRY.match(line)
    if m:
      names = m[1].split(", ")
      for n in names:
        out[n] = m[2].strip()
    elif line.startswith("    ") and names:
      for n in names:
        out[n] += " " + line.strip()
    elif line.strip() and not line.startswith("    "):
      names = []
  return {k: _first_sentence(v) for k, v in out.items()}


def _first_sentence(text: str) -> str:
  """Up to the first full stop that ends a sentence: not an abbreviation's ("e.g.") and
  not inside parentheses, whose sentence ends after them."""
  for m in re.finditer(r"\.(\s|$)", text):
    head = text[:m.start() + 1]
    if re.search(r"\b(e\.g|i\.e|cf|vs|etc)\.$", head) and m.end() < len(text):
      continue
    if head.count("(") > head.count(")"):
      continue
    return head
  return text


def declared(cls: type) -> type:
  """Class decorator for configuration dataclasses: every numeric field has an interval and
  every field a docstring line, or the class cannot be defined."""
  docs = docs_of(cls)
  hints = types_of(cls)
  for f in dataclasses.fields(cls):
    if _numbers(hints[f.name]) and "interval" not in f.metadata:
      raise TypeError(f"{cls.__name__}.{f.name} holds numbers but declares no interval: "
                      f"use fields.setting(default, interval, unit)")
    if f.name not in docs:
      raise TypeError(f"{cls.__name__}.{f.name} has no entry in the class docstring's "
                      f"Attributes section")
  return cls


def allowed(tp, meta) -> str:
  """What a field takes, as the error messages and --help print it."""
  tp, is_optional = optional(tp)
  tail = " or none" if is_optional else ""
  item = _innermost(tp)
  many = typing.get_origin(tp) is tuple
  if typing.get_origin(item) is typing.Literal:
    choices = ", ".join(repr(a) for a in typing.get_args(item))
    return (f"any of {choices}" if many else choices) + tail
  if isinstance(item, type) and issubclass(item, enum.Enum):
    return ", ".join(repr(m.value) for m in item) + tail
  if item is bool:
    return "true or false" + tail
  if "interval" in meta:
    unit = f" {meta['unit']}" if meta.get("unit") else ""
    kind = "integers in " if item is int else ""
    return f"{kind}{meta['interval']}{unit}{_length_text(tp, meta)}{tail}"
  return "text" + tail


def _innermost(tp):
  while typing.get_origin(tp) is tuple:
    tp = typing.get_args(tp)[0]
  return tp


def _length_text(tp, meta) -> str:
  if typing.get_origin(tp) is not tuple:
    return ""
  args = typing.get_args(tp)
  if len(args) == 2 and args[1] is Ellipsis:
    lo, hi = meta.get("length") or (0, math.inf)
    n = f"{lo}" if lo == hi else f"{lo} to {hi}" if hi < math.inf else f"at least {lo}"
    return f", {n} items"
  return f", {len(args)} items"


def check_value(key: str, value: Any, tp, meta) -> None:
  """Raise ValueError naming `key` when `value` is not of the field's type, length or range."""
  inner, is_optional = optional(tp)
  if value is None and is_optional:
    return
  if not _fits(value, inner, meta):
    raise errors.SettingError(f"{key}={value!r} is out of range: allowed {allowed(tp, meta)}")


def _fits(value, tp, meta) -> bool:
  origin = typing.get_origin(tp)
  if origin is typing.Literal:
    return value in typing.get_args(tp)
  if isinstance(tp, type) and issubclass(tp, enum.Enum):
    return isinstance(value, tp)
  if tp is bool:
    return isinstance(value, (bool, np.bool_))
  if tp is str:
    return isinstance(value, str)
  if origin is tuple:
    args = typing.get_args(tp)
    if not isinstance(value, (tuple, list)):
      return False
    if len(args) == 2 and args[1] is Ellipsis:
      lo, hi = meta.get("length") or (0, math.inf)
      return lo <= len(value) <= hi and all(_fits(v, args[0], meta) for v in value)
    return len(value) == len(args) and all(_fits(v, a, meta) for v, a in zip(value, args))
  if tp in (int, float):
    if isinstance(value, (bool, np.bool_)):
      return False
    ok_type = (int, np.integer) if tp is int else (int, float, np.integer, np.floating)
    return isinstance(value, ok_type) and value in meta["interval"]
  return True


def check(obj: Any, prefix: str = "") -> None:
  """Every declared check of the dataclass `obj` and of the dataclasses nested in it, then the
  `relations()` of each; keys are prefixed as --set names them (params.friction)."""
  hints = types_of(type(obj))
  for f in dataclasses.fields(obj):
    value = getattr(obj, f.name)
    if dataclasses.is_dataclass(value):
      check(value, f"{prefix}{f.name}.")
    else:
      check_value(prefix + f.name, value, hints[f.name], f.metadata)
  for ok, name, allowed_text, value in getattr(obj, "relations", lambda: ())():
    if not ok:
      raise errors.SettingError(f"{prefix}{name}={value!r} is out of range: allowed {allowed_text}")


Relation = tuple[bool, str, str, Any]
Relations = Iterator[Relation]


def build(cls: type, data: Mapping[str, Any]) -> Any:
  """The dataclass `cls` from `dataclasses.asdict` output that went through JSON (lists back
  to tuples, enums from their values, nested dataclasses rebuilt); missing fields keep their
  defaults. The result is not checked: call `check` on it."""
  hints = types_of(cls)
  kwargs = {}
  for f in dataclasses.fields(cls):
    if f.name in data:
      kwargs[f.name] = _rebuild(hints[f.name], data[f.name], f)
  return cls(**kwargs)


def _rebuild(tp, value, f=None):
  inner, _ = optional(tp)
  if value is None:
    return None
  if dataclasses.is_dataclass(inner):
    return build(inner, value)
  if isinstance(inner, type) and issubclass(inner, enum.Enum):
    return inner(value)
  if typing.get_origin(inner) is tuple:
    args = typing.get_args(inner)
    if len(args) == 2 and args[1] is Ellipsis:
      return tuple(_rebuild(args[0], v) for v in value)
    return tuple(_rebuild(a, v) for a, v in zip(args, value))
  return value
