"""Small C sources compiled once per machine into the cache and loaded with ctypes: for
MuJoCo callbacks, where a Python function would cost a GIL round trip per call.

Compiling needs a C compiler ($CC, else `cc` or `gcc`); where none works, `shared_library`
returns None with the reason and the caller falls back to a pure-MuJoCo formulation (the
commands say so in a warning and in the run's manifest). A cached library that no longer
loads is built again."""

from __future__ import annotations

import ctypes
import hashlib
import os
import pathlib
import shutil
import subprocess
import tempfile
import threading

from util import files

_lock = threading.Lock()
_loaded: dict[str, tuple[ctypes.CDLL | None, str]] = {}


def compiler() -> str | None:
  """The C compiler used: $CC if set (an empty $CC disables compiling), else cc or gcc."""
  cc = os.environ.get("CC")
  if cc is not None:
    return shutil.which(cc) if cc else None
  return shutil.which("cc") or shutil.which("gcc")


def shared_library(source: pathlib.Path, include_dirs: tuple[str, ...] = (),
                   tag: str = "") -> tuple[ctypes.CDLL | None, str]:
  """(library, "") with `source` compiled and loaded, or (None, why not).

  The library lives in `cache_dir()/native/`, named by a hash of the source, `tag` (e.g. the
  headers' version) and the compiler, so an edit or an upgrade builds it again; it is
  written atomically, so processes compiling at once each see a whole file. Loaded once per
  process."""
  source = pathlib.Path(source)
  cc = compiler()
  if cc is None:
    return None, "no C compiler found (set CC, or install gcc)"
  text = source.read_bytes()
  digest = hashlib.sha256(text + tag.encode() + cc.encode()).hexdigest()[:16]
  out = files.cache_dir() / "native" / f"{source.stem}-{digest}.so"
  with _lock:
    if str(out) in _loaded:
      return _loaded[str(out)]
    result = _build_and_load(source, out, cc, include_dirs)
    _loaded[str(out)] = result
    return result


def _build_and_load(source, out, cc, include_dirs, rebuilt=False
                    ) -> tuple[ctypes.CDLL | None, str]:
  if not out.exists():
    try:
      out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
      return None, f"cannot write the library into {out.parent}: {err}"
    with tempfile.TemporaryDirectory() as tmp:
      built = pathlib.Path(tmp) / out.name
      # -ffp-contract=off: no fused multiply-adds, so every machine rounds as the source reads
      cmd = [cc, "-O2", "-ffp-contract=off", "-shared", "-fPIC", "-o", str(built), str(source)]
      cmd += [f"-I{d}" for d in include_dirs]
      try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
      except (OSError, subprocess.SubprocessError) as err:
        return None, f"{cc} failed to run: {err}"
      if proc.returncode != 0:
        return None, f"{cc} could not compile {source.name}: {proc.stderr.strip()[:400]}"
      try:
        files.atomic_write(out, lambda f: f.write(built.read_bytes()))
      except OSError as err:
        return None, f"cannot write the library {out}: {err}"
  try:
    return ctypes.CDLL(str(out)), ""
  except OSError as err:
    if not rebuilt:  # a damaged cached library (a cut copy, a flipped byte): built again
      try:
        out.unlink()
      except OSError:
        return None, f"cannot load {out} ({err}) nor remove it"
      return _build_and_load(source, out, cc, include_dirs, rebuilt=True)
    return None, f"cannot load {out}: {err}"
