"""Files every layer writes: atomically, and JSON that other tools can read.

`atomic_write` writes beside the target and renames into place, so a reader (or a run that
was killed mid-write) never leaves a half-written file under the real name; `json_text`
writes strict JSON (no NaN or Infinity tokens) and `from_json` reads it back. This module
imports only `util.errors`, so every package shares it. `cache_dir` is the root of the
project's on-disk cache (recordings, kernels, saved tracebacks).
"""

from __future__ import annotations

import dataclasses
import fcntl
import hashlib
import json
import os
import pathlib
import tempfile
from typing import Any, Callable

import numpy as np

from util import errors

TMP_SUFFIX = ".tmp"


def atomic_write(path: pathlib.Path, write: Callable) -> None:
  """Calls write(file) on a temporary file beside `path`, then renames it into place, so a
  reader never sees a half-written file; on any error the temporary file is removed (a
  killed process leaves one behind: `sim.cache.clean_orphans` removes it)."""
  path = pathlib.Path(path)
  # the writer's pid in the name: a cleaner can tell a dead writer's file from a live one's
  with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f"{path.name}.{os.getpid()}.",
                                   suffix=TMP_SUFFIX, delete=False) as f:
    try:
      write(f)
    except BaseException:
      f.close()
      os.unlink(f.name)
      raise
  # a temporary file is made 0600; what a user writes gets the mode their umask asks for,
  # as open() would give it (results shared with a group stay readable to it)
  os.chmod(f.name, 0o666 & ~_umask())
  os.replace(f.name, path)


def _umask() -> int:
  """The process's umask (read once: setting it to read it is not thread-safe)."""
  global _UMASK
  if _UMASK is None:
    _UMASK = os.umask(0o022)
    os.umask(_UMASK)
  return _UMASK


_UMASK = None


def output_folder(path, what: str, instead: str = "give a folder",
                  writable: str = "give a folder you can write to") -> pathlib.Path:
  """Checks, before any work, a folder a command will write into: not a file, made if it is
  missing, and writable (a file is created in it and removed). Returns it.

  Raises:
    errors.SettingError naming `what` (the option, e.g. "--out") and what to change:
    `instead` of a file, `writable` of a folder it cannot write.
  """
  folder = pathlib.Path(path)
  if str(path).strip() == "":
    raise errors.SettingError(f"{what} is empty: give a folder")
  if folder.exists() and not folder.is_dir():
    raise errors.SettingError(f"{what} {folder} is a file: {instead}")
  try:
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryFile(dir=folder):
      pass
  except OSError as err:
    raise errors.SettingError(f"{what} {folder} cannot be written ({err.strerror}): "
                              f"{writable}") from None
  return folder



LOCK = ".run.lock"  # the lock file `claim` holds in a folder it fills


def holding(folder, what: str, work: Callable):
  """work(folder) while this process holds `folder` (`claim`); returns what it returns."""
  lock = claim(folder, what)
  try:
    return work(lock.path.parent)
  finally:
    lock.release()


@dataclasses.dataclass
class Lock:
  """A process's hold on a results folder: an open lock file under an exclusive `flock`,
  which the system drops when the process ends, however it ends."""
  path: pathlib.Path
  fd: int

  def release(self) -> None:
    # unlink while still holding it: whoever opened this file meanwhile finds it replaced
    try:
      self.path.unlink()
    except OSError:
      pass
    os.close(self.fd)


def claim(out, what: str = "--out") -> Lock:
  """Checks that the folder `out` can take a command's results (as `output_folder`) and
  locks it for this process, so that two runs never fill one folder: a second is refused in
  one line naming the holder. The hold is the system's (`flock`), dropped however the
  process ends; `Lock.release` also removes the lock file.

  Raises:
    errors.SettingError naming `what` (the option) and what to change.
  """
  out = output_folder(out, what)
  path = out / LOCK
  for _ in range(100):  # again only if the holder released the file between open and lock
    fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o644)
    try:
      fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
      holder = os.read(fd, 32).decode(errors="replace").strip()
      os.close(fd)
      raise errors.SettingError(
          f"{what} {out} is in use by another run"
          + (f" (process {holder})" if holder.isdigit() else "")
          + ": give this run another --out, or wait for that one to finish") from None
    try:
      current = os.stat(path).st_ino == os.fstat(fd).st_ino
    except FileNotFoundError:
      current = False
    if current:
      os.ftruncate(fd, 0)
      os.write(fd, str(os.getpid()).encode())
      return Lock(path, fd)
    os.close(fd)
  raise errors.SettingError(f"{what} {out}: could not take its lock file {path}; remove it if "
                            f"no run is using the folder")

def output_file(path, what: str, suffixes: tuple[str, ...]) -> pathlib.Path:
  """Checks, before any work, a file a command will write: a name ending in one of
  `suffixes`, not an existing folder, in a folder that exists or can be made and can be
  written. Returns it (an existing file is replaced when the work is done).

  Raises:
    errors.SettingError naming `what` and the allowed suffixes.
  """
  file = pathlib.Path(path)
  if str(path).strip() == "" or file.name in ("", ".", ".."):
    raise errors.SettingError(f"{what} is empty: give a file name ending in "
                              f"{' or '.join(suffixes)}")
  if file.is_dir():
    raise errors.SettingError(f"{what} {file} is a folder: give a file name ending in "
                              f"{' or '.join(suffixes)}")
  if file.suffix.lower() not in suffixes:
    raise errors.SettingError(f"{what} {file}: unknown suffix {file.suffix or '(none)'!r}: "
                              f"allowed {', '.join(suffixes)}")
  output_folder(file.parent, f"{what} {file}: its folder")
  return file


EXPANSION = 4.0  # the testbench writes .npz uncompressed: a file of its own never expands more


def read_npz(source, what: str, keys=None, text: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
  """The arrays of an .npz file (a path or its bytes), checked from their headers before any
  is read: each a numeric array (bool, integer, float; the members named in `text` may be
  strings), and all of them, expanded, at most `EXPANSION` times the file's size plus 1 MiB.
  A checksum says a file is unchanged, not that it is sane to read.

  Raises:
    errors.DataError naming `what` and the member at fault.
  """
  import io
  import zipfile
  raw = source if isinstance(source, bytes) else None
  try:
    size = len(raw) if raw is not None else os.path.getsize(source)
    with zipfile.ZipFile(io.BytesIO(raw) if raw is not None else source) as zf:
      members = [i for i in zf.infolist()
                 if keys is None or i.filename.removesuffix(".npy") in keys]
      total = 0
      for info in members:
        name = info.filename.removesuffix(".npy")
        with zf.open(info) as f:
          version = np.lib.format.read_magic(f)
          read_header = {(1, 0): np.lib.format.read_array_header_1_0,
                         (2, 0): np.lib.format.read_array_header_2_0}.get(version)
          if read_header is None:
            raise errors.DataError(f"{what}: array {name} has .npy format {version}, which "
                                   f"the testbench does not write")
          shape, _, dtype = read_header(f)
        if not (dtype.kind in "biuf" or (name in text and dtype.kind == "U")):
          raise errors.DataError(f"{what}: array {name} holds {dtype} values; expected "
                                 f"numbers")
        total += int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
      if total > EXPANSION * size + 2**20:
        raise errors.DataError(f"{what}: its arrays expand to {total / 2**20:.0f} MiB from a "
                               f"{size / 2**20:.1f} MiB file; the testbench writes them "
                               f"uncompressed, so this file is not one of its own")
      with np.load(io.BytesIO(raw) if raw is not None else source, allow_pickle=False) as z:
        return {i.filename.removesuffix(".npy"): z[i.filename.removesuffix(".npy")]
                for i in members}
  except errors.DataError:
    raise
  except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
    raise errors.DataError(f"{what}: cannot be read ({err})") from None


def cache_dir() -> pathlib.Path:
  """Root of the on-disk cache: $TESTBENCH_CACHE or ~/.cache/footpad-testbench."""
  root = os.environ.get("TESTBENCH_CACHE")
  return pathlib.Path(root) if root else pathlib.Path.home() / ".cache" / "footpad-testbench"


def usable_cache_dir() -> pathlib.Path:
  """`cache_dir`, checked before any work: a folder, made if missing, that this process can
  write.

  Raises:
    errors.SettingError naming TESTBENCH_CACHE (or the default) and what to change.
  """
  what = "TESTBENCH_CACHE" if os.environ.get("TESTBENCH_CACHE") else "the cache folder"
  return output_folder(cache_dir(), what, "point TESTBENCH_CACHE at a folder (or unset it for "
                       "~/.cache/footpad-testbench)",
                       "point TESTBENCH_CACHE at a folder you can write to")


def writer_pid(tmp: pathlib.Path) -> int | None:
  """The process id in the name of a temporary file `atomic_write` made (None if not one)."""
  parts = pathlib.Path(tmp).name.removesuffix(TMP_SUFFIX).split(".")
  try:
    return int(parts[-2])
  except (IndexError, ValueError):
    return None


def process_alive(pid: int) -> bool:
  """Whether process `pid` is running (on this machine)."""
  try:
    os.kill(pid, 0)
  except ProcessLookupError:
    return False
  except PermissionError:
    return True  # someone else's live process
  return True


def write_text(path: pathlib.Path, text: str) -> None:
  """`atomic_write` of a text file (UTF-8)."""
  atomic_write(path, lambda f: f.write(text.encode()))


_NON_FINITE = {"Infinity": float("inf"), "-Infinity": float("-inf"), "NaN": float("nan")}


def _strict(value):
  if isinstance(value, float) and not np.isfinite(value):
    return "NaN" if np.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
  if isinstance(value, dict):
    return {k: _strict(v) for k, v in value.items()}
  if isinstance(value, (list, tuple)):
    return [_strict(v) for v in value]
  if isinstance(value, np.generic):
    return _strict(value.item())
  if isinstance(value, np.ndarray):
    return _strict(value.tolist())
  return value


def json_text(value: Any, **kwargs) -> str:
  """Strict JSON (RFC 8259, which other tools read): non-finite floats become the strings
  "Infinity", "-Infinity" and "NaN" (`from_json` turns them back), numpy values plain."""
  return json.dumps(_strict(value), allow_nan=False, **kwargs)


def from_json(text: str) -> Any:
  """`json.loads` that turns the strings `json_text` wrote for non-finite floats back."""
  def back(v):
    if isinstance(v, str):
      return _NON_FINITE.get(v, v)
    if isinstance(v, dict):
      return {k: back(x) for k, x in v.items()}
    if isinstance(v, list):
      return [back(x) for x in v]
    return v
  return back(json.loads(text))


def array_digest(arrays: dict[str, np.ndarray]) -> str:
  """SHA-256 of named arrays: their names, dtypes, shapes and bytes, in name order."""
  h = hashlib.sha256()
  for k in sorted(arrays):
    a = np.ascontiguousarray(arrays[k])
    h.update(f"{k}{a.dtype.str}{a.shape}".encode())
    h.update(a.tobytes())
  return h.hexdigest()


def check_header(head: Any, path: pathlib.Path, kind: str, tag: str, version,
                 digest: str) -> None:
  """Raise DataError naming `path` unless the header `head` a loader read carries the format
  `tag`, one of the versions `version` (an int, or a collection of them) and the checksum
  `digest` of what it describes."""
  known = sorted(version) if isinstance(version, (set, frozenset, tuple, list)) else [version]
  if not isinstance(head, dict) or head.get("format") != tag:
    raise errors.DataError(f"{kind} {path}: not a testbench {kind} (no format tag {tag!r})")
  if head.get("version") not in known:
    raise errors.DataError(f"{kind} {path}: format version {head.get('version')!r}; this "
                           f"testbench reads version {' or '.join(map(str, known))}")
  if head.get("sha256") != digest:
    raise errors.DataError(f"{kind} {path}: its contents do not match the checksum written "
                           f"with them (damaged or edited)")
