"""The progress callback library code takes (`progress(done, total)`); commands draw it."""

from __future__ import annotations

import sys
import time
from typing import Callable

from util import interrupt

Progress = Callable[[int, int], None]


def progress_bar(label: str) -> Progress:
  """A progress callback: a bar on a terminal; piped or in CI, one line when the stage ends
  (its count and seconds), so logs stay readable. A count that starts again (the next
  network of an ensemble) is a new stage."""
  stream = sys.stderr
  tty = hasattr(stream, "isatty") and stream.isatty()
  state = {"last": None, "t0": 0.0, "bar": None, "stages": 0}

  def update(done: int, total: int) -> None:
    interrupt.check()  # a Ctrl-C swallowed in a finaliser stops the command here
    if state["last"] is None or done < state["last"]:  # a new stage
      state["stages"] += 1
      state["t0"] = time.perf_counter()
      name = label if state["stages"] == 1 else f"{label} ({state['stages']})"
      if tty:
        from tqdm import tqdm
        if state["bar"] is not None:
          state["bar"].close()
        state["bar"] = tqdm(total=total, desc=name, file=stream, leave=False)
      state["name"] = name
    state["last"] = done
    if tty:
      bar = state["bar"]
      bar.total = total
      bar.update(done - bar.n)
      if done == total:
        bar.close()
    elif done == total:
      # one write: a Ctrl-C between the text and its newline would glue the next line on
      stream.write(f"{state['name']}: {total} done in {time.perf_counter() - state['t0']:.1f} "
                   f"s\n")
      stream.flush()
  return update


def quiet(done: int, total: int) -> None:
  """The progress callback of a command run with --no-progress: draws nothing, still stops
  at a Ctrl-C (`util.interrupt.check`)."""
  interrupt.check()

