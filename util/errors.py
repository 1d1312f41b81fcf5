"""The project's error types: what a user can fix, told in one line.

Every layer raises these for mistakes that are the user's to fix (a setting out of range, a
file that is not what it should be, physics driven past what the integrator can follow); the
command line prints them as one line and exits with code 2. Anything else is an internal
error: the command saves its traceback and says where. This module imports nothing, so every
layer (`models`, `sim`, `calibrate`, `benchmarks`) can use it.
"""

from __future__ import annotations


class UserError(Exception):
  """A mistake the user can fix; the message names what was wrong and what is allowed."""


class SettingError(UserError, ValueError):
  """A setting (field, option, key) outside what it allows."""


class DataError(UserError, ValueError):
  """Arrays or a file given to the project that it cannot use: the message names the file or
  the array, and the row, column or field."""


class SimulationError(UserError, RuntimeError):
  """The physics of a scene diverged, or the rig did not reach a command: the message names
  the scene, the simulated time and the setting to change. No numbers are reported from such
  a run."""


def closest(name: str, allowed) -> str | None:
  """The allowed name `name` is a typo of, if one is close enough (difflib's 0.6 ratio)."""
  import difflib
  close = difflib.get_close_matches(str(name), [str(a) for a in allowed], n=1, cutoff=0.6)
  return close[0] if close else None


def unknown(what: str, name: str, allowed, where: str = "") -> SettingError:
  """The error for a name that is not one of `allowed`, in one line: the closest allowed
  name as "did you mean ...?" where one is close (a typo), else the allowed names (or, when
  there are many, `where` to find them)."""
  allowed = [str(a) for a in allowed]
  close = closest(name, allowed)
  if close:
    hint = f"did you mean {close}?"
  elif len(allowed) <= 12 or not where:
    hint = f"allowed {', '.join(allowed)}"
  else:
    hint = f"see {where}"
  return SettingError(f"unknown {what} {name!r}: {hint}")
