"""`key=value` settings (the command's --set) applied to frozen dataclasses of any scene.

Keys name fields, with dots into nested dataclasses (params.friction=0.8); values are parsed
like the field's current value (numbers, booleans, comma-separated tuples, enums by value).
"""

from __future__ import annotations

import dataclasses
import enum


def require(ok: bool, name: str, allowed: str, value) -> None:
  """Raise ValueError naming a setting whose value lies outside what is allowed."""
  if not ok:
    raise ValueError(f"{name}={value!r} is out of range: allowed {allowed}")


def in_bounds(obj, bounds) -> None:
  """`require` each (field name, low, high) of `bounds` on the dataclass `obj`, inclusive."""
  for name, lo, hi in bounds:
    v = getattr(obj, name)
    require(lo <= v <= hi, name, f"[{lo}, {hi}]", v)


def apply(obj, overrides: dict[str, str]):
  """A copy of the dataclass `obj` with the settings applied; unknown keys and unreadable
  values raise ValueError naming the key and what is allowed."""
  for key, text in overrides.items():
    obj = _override(obj, key, text)
  return obj


def _parse(text: str, like):
  if isinstance(like, bool):
    return text.lower() in ("1", "true", "yes", "on")
  if isinstance(like, tuple):
    items = [t for t in text.split(",") if t]
    return tuple(_parse(t, like[0]) if like else float(t) for t in items)
  if isinstance(like, int):
    return int(text)
  if isinstance(like, float) or like is None:
    return float(text)
  if isinstance(like, enum.Enum):
    return type(like)(text)
  return text


def _override(obj, key: str, text: str):
  head, _, rest = key.partition(".")
  fields = {f.name: f for f in dataclasses.fields(obj)}
  if head not in fields:
    raise ValueError(f"unknown setting {key!r}: allowed "
                     f"{', '.join(sorted(_setting_names(obj)))}")
  current = getattr(obj, head)
  if rest:
    if not dataclasses.is_dataclass(current):
      raise ValueError(f"unknown setting {key!r}: {head} has no sub-settings")
    return dataclasses.replace(obj, **{head: _override(current, rest, text)})
  if dataclasses.is_dataclass(current):
    raise ValueError(f"setting {key!r} needs a field, e.g. {head}.<name>")
  try:
    value = _parse(text, current)
  except ValueError as err:
    raise ValueError(f"setting {key}={text!r} could not be read: {err}") from None
  return dataclasses.replace(obj, **{head: value})


def _setting_names(obj, prefix: str = "") -> list[str]:
  out = []
  for f in dataclasses.fields(obj):
    v = getattr(obj, f.name)
    if dataclasses.is_dataclass(v):
      out += _setting_names(v, prefix + f.name + ".")
    else:
      out.append(prefix + f.name)
  return out
