"""The one command-line error path of the project's commands (`python -m benchmarks.run`,
`python -m calibrate`, `python -m sim.render`).

A mistake that is the user's to fix (`util.errors.UserError`: a setting, a file, an output
place) prints one line starting `error:` and exits with code 2; Ctrl-C prints one line and
exits with 130; anything else is a bug in the testbench: two lines, exit code 3, and the
traceback saved to a file of its own (never overwritten by another error in the same second).
Warnings print as one line each, not with the source line that raised them: a command's
output is read by people, not debuggers.
"""

from __future__ import annotations

import pathlib
import sys
import os
import tempfile
import time
import traceback
import warnings
from typing import Callable

from util import errors, files, interrupt

INTERRUPTED = 130
TERMINATED = 143  # 128 + SIGTERM, as a shell reports a process it ended


def path_arg(text: str) -> pathlib.Path:
  """argparse type of a path option: an empty one is refused (pathlib would read it as the
  current folder)."""
  if not text.strip():
    import argparse
    raise argparse.ArgumentTypeError("an empty path: give a file or folder name")
  return pathlib.Path(text)


def _warning_line(message, category, filename, lineno, line=None) -> str:
  return f"warning: {message}\n"


def run(body: Callable[[], int], command: str,
        interrupted: str = "interrupted: nothing was written") -> int:
  """Runs a command's `body` (which returns its exit code) on the error path above; a bug's
  traceback goes to the cache's `tracebacks/` folder, named after `command`, the time and a
  unique suffix."""
  before, warnings.formatwarning = warnings.formatwarning, _warning_line
  out, sys.stdout = sys.stdout, _Reader(sys.stdout)
  try:
    with interrupt.handled():
      return body()
  except errors.UserError as err:
    print(f"error: {err}", file=sys.stderr)
    return 2
  except interrupt.Terminated:
    print(interrupted.replace("interrupted", "terminated (SIGTERM)", 1), file=sys.stderr)
    return TERMINATED
  except KeyboardInterrupt:
    print(interrupted, file=sys.stderr)
    return INTERRUPTED
  except Exception:
    return internal_error(traceback_path(command))
  finally:
    warnings.formatwarning = before
    if isinstance(sys.stdout, _Reader) and sys.stdout.gone:
      # the reader left (`| head`): keep Python's own last flush from complaining
      os.dup2(os.open(os.devnull, os.O_WRONLY), out.fileno())
    sys.stdout = out


class _Reader:
  """The command's stdout, which may be a pipe whose reader leaves early (`... | head`): the
  rest of the report goes nowhere, and the work (its files) still completes."""

  def __init__(self, stream):
    self._stream, self.gone = stream, False

  def write(self, text: str) -> int:
    if not self.gone:
      try:
        self._stream.write(text)
      except BrokenPipeError:
        self.gone = True
    return len(text)

  def flush(self) -> None:
    if not self.gone:
      try:
        self._stream.flush()
      except BrokenPipeError:
        self.gone = True

  def __getattr__(self, name):
    return getattr(self._stream, name)


def traceback_path(command: str) -> pathlib.Path:
  """A new file for one bug's traceback: `cache_dir()/tracebacks/COMMAND-TIME-XXXX.txt`."""
  folder = files.cache_dir() / "tracebacks"
  folder.mkdir(parents=True, exist_ok=True)
  fd, name = tempfile.mkstemp(prefix=f"{command}-{time.strftime('%Y%m%d-%H%M%S')}-",
                              suffix=".txt", dir=folder)
  os.close(fd)
  return pathlib.Path(name)


def internal_error(path: pathlib.Path) -> int:
  """Saves the traceback being handled to `path` and says so in two lines; exit code 3."""
  path = pathlib.Path(path)
  path.parent.mkdir(parents=True, exist_ok=True)
  files.write_text(path, traceback.format_exc())
  kind, value = sys.exc_info()[:2]
  print(f"internal error (a bug in the testbench, not in your settings): {kind.__name__}: "
        f"{value}\n  the traceback is in {path}; please report it with that file",
        file=sys.stderr)
  return 3
