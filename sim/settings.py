"""`key=value` settings (the command's --set) applied to the declared dataclasses of any scene.

Keys name fields, with dots into nested dataclasses (params.friction_mu0=1.5). Each value is read
as the field's annotation says (`util.fields`): numbers, integers, booleans (true/false,
1/0, yes/no, on/off), comma-separated tuples (pairs separated by ";", e.g.
spring_xy=0.03,0.02;-0.03,0.02;0.03,-0.02), `Literal` choices, enums by value, "none" for
an optional field. Every value is then checked against the field's declared range, and the
whole object against its relations; any problem raises one ValueError that names the key and
what it allows.
"""

from __future__ import annotations

import dataclasses
import enum
import typing
from typing import Any, Mapping

from util import errors, fields

_TRUE = ("true", "1", "yes", "on")
_FALSE = ("false", "0", "no", "off")


@dataclasses.dataclass(frozen=True)
class Key:
  """One settable key, as `NAME --help` lists it.

  Attributes:
    name: dotted key (params.friction_mu0).
    type: the annotation, as text.
    default: the value before any --set.
    allowed: the declared range, choices or form.
    doc: first sentence of the field's docstring entry.
  """
  name: str
  type: str
  default: Any
  allowed: str
  doc: str


def apply(obj: Any, overrides: Mapping[str, str],
          fixed: Mapping[str, str] | None = None) -> Any:
  """A copy of the dataclass `obj` with the settings applied and checked.

  Args:
    obj: a declared dataclass (`util.fields.declared`).
    overrides: {key: text}.
    fixed: keys the caller sets itself, with the reason; setting one is refused.
  Raises:
    ValueError naming the key and what it allows: unknown or fixed keys, unreadable values,
    values out of range, relations between fields that fail, and keys that change nothing
    (a scene's `unread(key)`: the effect that replaces them, or the effect they size is off).
  """
  fixed = fixed or {}
  for key, text in overrides.items():
    for name, why in fixed.items():
      if key == name or key.startswith(name + "."):
        raise errors.SettingError(f"{key} is set by this benchmark ({why}); it cannot be changed "
                                  f"with --set")
    obj = _override(obj, key, key, text)
  fields.check(obj)
  unread = getattr(obj, "unread", None)  # a scene: which settings its effects leave unread
  for key, text in overrides.items():
    why = unread(key) if unread else None
    if why:
      raise errors.SettingError(f"{key}={text} changes nothing: {why}")
  return obj


def keys(obj: Any, fixed: Mapping[str, str] | None = None, prefix: str = "") -> list[Key]:
  """Every key of `obj` that --set takes (nested fields included, fixed keys left out)."""
  fixed = fixed or {}
  out = []
  hints = fields.types_of(type(obj))
  docs = fields.docs_of(type(obj))
  for f in dataclasses.fields(obj):
    name = prefix + f.name
    if name in fixed:
      continue
    value = getattr(obj, f.name)
    if dataclasses.is_dataclass(value):
      out += keys(value, fixed, name + ".")
    else:
      out.append(Key(name, _type_text(hints[f.name]), value,
                     fields.allowed(hints[f.name], f.metadata), docs.get(f.name, "")))
  return out


def _override(obj: Any, key: str, path: str, text: str) -> Any:
  head, _, rest = path.partition(".")
  by_name = {f.name: f for f in dataclasses.fields(obj)}
  if head not in by_name:
    prefix = key[:len(key) - len(path)]
    raise errors.unknown("setting", key, [prefix + k.name for k in keys(obj)],
                         "python -m benchmarks.run NAME --help")
  current = getattr(obj, head)
  if rest:
    if not dataclasses.is_dataclass(current):
      raise errors.SettingError(f"unknown setting {key!r}: {head} has no sub-settings")
    return dataclasses.replace(obj, **{head: _override(current, key, rest, text)})
  if dataclasses.is_dataclass(current):
    raise errors.SettingError(f"setting {key!r} needs a field, e.g. {key}.<name> (see NAME --help)")
  f = by_name[head]
  tp = fields.types_of(type(obj))[head]
  allowed = fields.allowed(tp, f.metadata)
  try:
    value = parse(text, tp)
  except ValueError as err:
    raise errors.SettingError(
        f"{key}={text!r} could not be read ({err}): allowed {allowed}") from None
  fields.check_value(key, value, tp, f.metadata)
  return dataclasses.replace(obj, **{head: value})


def parse(text: str, tp) -> Any:
  """The value of `text` as annotation `tp` says; ValueError saying what was expected."""
  text = text.strip()
  inner, optional = fields.optional(tp)
  if optional:
    return None if text.lower() in ("none", "") else parse(text, inner)
  origin = typing.get_origin(tp)
  if origin is typing.Literal:
    choices = typing.get_args(tp)
    for c in choices:
      if text == str(c):
        return c
    raise ValueError(f"{text!r} is not one of the choices{_close(text, choices)}")
  if isinstance(tp, type) and issubclass(tp, enum.Enum):
    try:
      return tp(text)
    except ValueError:
      raise ValueError(f"{text!r} is not one of the choices"
                       f"{_close(text, [m.value for m in tp])}") from None
  if tp is bool:
    if text.lower() in _TRUE:
      return True
    if text.lower() in _FALSE:
      return False
    raise ValueError("needs true/false, 1/0, yes/no or on/off")
  if origin is tuple:
    args = typing.get_args(tp)
    item = args[0]
    sep = ";" if typing.get_origin(item) is tuple else ","
    parts = [p for p in text.split(sep) if p.strip()]
    if len(args) == 2 and args[1] is Ellipsis:
      return tuple(parse(p, item) for p in parts)
    if len(parts) != len(args):
      raise ValueError(f"needs {len(args)} items separated by {sep!r}, got {len(parts)}")
    return tuple(parse(p, a) for p, a in zip(parts, args))
  if tp is int:
    try:
      return int(text)
    except ValueError:
      raise ValueError("not an integer") from None
  if tp is float:
    try:
      return float(text)
    except ValueError:
      raise ValueError("not a number") from None
  return text


def _close(text: str, choices) -> str:
  """"; did you mean X?" for a typo of one of `choices`, else ""."""
  close = errors.closest(text, choices)
  return f"; did you mean {close}?" if close else ""


def _type_text(tp) -> str:
  inner, optional = fields.optional(tp)
  if optional:
    return f"optional {_type_text(inner)}"
  origin = typing.get_origin(tp)
  if origin is typing.Literal:
    return "choice"
  if isinstance(tp, type) and issubclass(tp, enum.Enum):
    return "choice"
  if origin is tuple:
    args = typing.get_args(tp)
    if len(args) == 2 and args[1] is Ellipsis:
      return f"{_type_text(args[0])}s"
    return "(" + ", ".join(_type_text(a) for a in args) + ")"
  return getattr(tp, "__name__", str(tp))
