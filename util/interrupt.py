"""Ctrl-C (and SIGTERM) that always stops a command.

Python delivers SIGINT as a KeyboardInterrupt in whatever the main thread runs next. When that
is a finaliser (JAX frees device buffers in `__del__` and weakref callbacks, often), Python
prints "Exception ignored" and carries on: measured, a `calibrate fit` interrupted that way
ran to the end and exited 0. So the handler also remembers the request, and `check()` (called
by every progress callback, `util.progress`) raises it again at the next progress step; the
swallowed copy is not printed.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

_requested = threading.Event()
_by = [signal.SIGINT]  # the signal that asked


class Terminated(KeyboardInterrupt):
  """SIGTERM (a `kill`, a scheduler's stop): handled as Ctrl-C is, exit code 143."""


def _stop() -> KeyboardInterrupt:
  return Terminated() if _by[0] == signal.SIGTERM else KeyboardInterrupt()


def check() -> None:
  """Raises KeyboardInterrupt (`Terminated` for SIGTERM) when Ctrl-C was pressed, or SIGTERM
  came, in a command run under `handled()`."""
  if _requested.is_set():
    raise _stop()


def _on_signal(signum, frame):
  _by[0] = signum
  _requested.set()
  raise _stop()


def _unraisable(before):
  def hook(unraisable):
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
      return  # swallowed in a finaliser: `check()` raises it again at the next step
    before(unraisable)
  return hook


@contextlib.contextmanager
def handled():
  """Installs the handler for the duration of a command (main thread only; elsewhere, e.g.
  a command run from a worker thread, Python's own handling stays)."""
  if threading.current_thread() is not threading.main_thread():
    yield
    return
  _requested.clear()
  before = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
  before_hook = sys.unraisablehook
  sys.unraisablehook = _unraisable(before_hook)
  try:
    yield
  finally:
    for s, handler in before.items():
      signal.signal(s, handler)
    sys.unraisablehook = before_hook
    _requested.clear()
    _by[0] = signal.SIGINT
