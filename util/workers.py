"""What every pool of spawned worker processes here needs: to exit with the command that
started it, and to start with the environment it should run in."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from typing import Optional


def die_with_parent(parent: int) -> None:
  """A worker's initializer: the worker exits once the process that started it is gone.
  Without it, a command killed (not Ctrl-C'd) leaves its workers computing to the end, each
  holding a core (seen on a shared machine). Ctrl-C, which a terminal sends to the workers
  with their command, ends a worker at once and silently: the command says the one line
  (an idle worker printed a KeyboardInterrupt traceback from its job queue, measured)."""
  if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:  # a command that ignores it keeps
    signal.signal(signal.SIGINT, lambda *_: os._exit(130))  # workers that ignore it too

  def watch():
    while os.getppid() == parent:
      time.sleep(1.0)
    os._exit(1)
  threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def _apply(values: dict[str, Optional[str]]) -> None:
  for k, v in values.items():
    if v is None:
      os.environ.pop(k, None)
    else:
      os.environ[k] = v


@contextlib.contextmanager
def environment(values: dict[str, Optional[str]]):
  """Sets environment variables (None: unset) for the block: workers spawned inside it
  inherit them; the process's own are put back after."""
  old = {k: os.environ.get(k) for k in values}
  try:
    _apply(values)
    yield
  finally:
    _apply(old)
