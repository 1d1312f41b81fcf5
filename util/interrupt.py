"""Ctrl-C that always stops a command.

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


def check() -> None:
  """Raises KeyboardInterrupt when Ctrl-C was pressed in a command run under `handled()`."""
  if _requested.is_set():
    raise KeyboardInterrupt


def _on_sigint(signum, frame):
  _requested.set()
  raise KeyboardInterrupt


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
  before_handler = signal.signal(signal.SIGINT, _on_sigint)
  before_hook = sys.unraisablehook
  sys.unraisablehook = _unraisable(before_hook)
  try:
    yield
  finally:
    signal.signal(signal.SIGINT, before_handler)
    sys.unraisablehook = before_hook
    _requested.clear()
