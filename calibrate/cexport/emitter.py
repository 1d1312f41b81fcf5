"""The bookkeeping of a C export: constant arrays, static state, resets and cost counts.

Every part of an estimator writes its own C block through one `Emitter` (its `emit_c`), which
collects the arrays (flash), the code, the state a temporal estimator carries between calls,
and what one estimate costs: float multiply-adds and tanhf calls, Q16 multiply-adds and table
tanh, the largest working arrays (stack).
"""

from __future__ import annotations

import numpy as np


def literal(v: float) -> str:
  """A float32 C literal that reads back to the same float (9 significant digits)."""
  text = f"{float(np.float32(v)):.9g}"
  return text + ("f" if any(ch in text for ch in ".eEn") else ".0f")


def floats(a: np.ndarray) -> str:
  return ", ".join(literal(v) for v in np.asarray(a, np.float32).ravel())


class Emitter:
  """Collects the constant arrays and the code of one estimator, part by part.

  Attributes:
    fixed: recurrent parts in Q16 fixed point (`calibrate.parts.gru`).
    arrays, code, state: C lines: `static const` arrays, the body of `estimate`, and the
      static variables a temporal estimator carries between calls.
    resets: lines of estimate_restart() (an episode's start); session_resets: lines that
      estimate_reset() adds (a session's start).
    flash, stack: bytes of weights and of the largest working arrays.
    macs, tanh, fixed_macs, fixed_tanh: operations per estimate.
  """

  def __init__(self, fixed_point: bool = False):
    self.fixed = fixed_point
    self.arrays: list[str] = []
    self.code: list[str] = []
    self.state: list[str] = []
    self.resets: list[str] = []
    self.session_resets: list[str] = []
    self.flash = self.stack = 0
    self.macs = self.tanh = 0
    self.fixed_macs = self.fixed_tanh = 0

  def array(self, name: str, a: np.ndarray) -> str:
    """A float32 `static const` array; returns its name."""
    a = np.asarray(a, np.float64)
    self.arrays.append(f"static const float {name}[{a.size}] = {{{floats(a)}}};")
    self.flash += 4 * a.size
    return name

  def ints(self, name: str, a: np.ndarray) -> str:
    """A Q16 (value x 65,536, rounded) int32_t array; returns its name."""
    q = np.clip(np.round(np.asarray(a, np.float64).ravel() * 65536.0), -2 ** 31, 2 ** 31 - 1)
    self.arrays.append(f"static const int32_t {name}[{q.size}] = "
                       f"{{{', '.join(str(int(v)) for v in q)}}};")
    self.flash += 4 * q.size
    return name

  def bytes_(self, name: str, a: np.ndarray) -> str:
    """An `unsigned char` array of small integers; returns its name."""
    self.arrays.append(f"static const unsigned char {name}[{a.size}] = "
                       f"{{{', '.join(str(int(v)) for v in a.ravel())}}};")
    self.flash += a.size
    return name

  def costs(self, macs: int = 0, tanh: int = 0, stack: int = 0, fixed_macs: int = 0,
            fixed_tanh: int = 0) -> None:
    """Adds one part's operations and its working arrays (bytes of stack)."""
    self.macs += macs
    self.tanh += tanh
    self.fixed_macs += fixed_macs
    self.fixed_tanh += fixed_tanh
    self.stack = max(self.stack, stack)

  def take(self, before: int) -> list[str]:
    """The code lines written since `len(self.code)` was `before`, removed from the body."""
    lines, self.code = self.code[before:], self.code[:before]
    return lines
