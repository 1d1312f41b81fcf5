"""The results folder of a run, checked before any work: writable, and this run's alone.

`claim(out)` fails in the first second, with one line, when `--out` is a file, cannot be
created or written, or another live run holds it; otherwise it takes a lock file in it that
`release` removes. A lock left by a run that was killed (its process is gone) is taken over.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib

from models import errors, files

LOCK = ".run.lock"


@dataclasses.dataclass
class Lock:
  """This run's hold on a results folder."""
  path: pathlib.Path

  def release(self) -> None:
    try:
      if self.path.read_text().strip() == str(os.getpid()):
        self.path.unlink()
    except OSError:
      pass


def claim(out: pathlib.Path) -> Lock:
  """Checks that `out` can take this run's results and locks it for this run.

  Raises:
    errors.SettingError naming --out and what to change.
  """
  out = pathlib.Path(out)
  if out.exists() and not out.is_dir():
    raise errors.SettingError(f"--out {out} is a file: give a folder for the results")
  try:
    out.mkdir(parents=True, exist_ok=True)
    probe = out / f".write-test-{os.getpid()}"
    probe.write_bytes(b"")
    probe.unlink()
  except OSError as err:
    raise errors.SettingError(f"--out {out} cannot be written ({err.strerror}): give a folder "
                              f"you can write to") from None
  path = out / LOCK
  for _ in range(2):  # a second try after removing a dead run's lock
    try:
      fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
      try:
        pid = int(path.read_text().strip() or 0)
      except (OSError, ValueError):
        pid = 0
      if pid and pid != os.getpid() and files.process_alive(pid):
        raise errors.SettingError(
            f"--out {out} is in use by another run (process {pid}): give this run another "
            f"--out, or wait for that one to finish") from None
      path.unlink(missing_ok=True)  # its run is gone
      continue
    with os.fdopen(fd, "w") as f:
      f.write(str(os.getpid()))
    return Lock(path)
  raise errors.SettingError(f"--out {out}: could not take its lock file {path}; remove it if "
                            f"no run is using the folder")
