"""The on-disk cache shared by both rigs: recordings and finite-element results, stored under
a hash of everything that determines their bytes, and written atomically."""

from __future__ import annotations

import hashlib
import json
import os
import pathlib
import warnings
import zipfile
from typing import Any, Callable

import numpy as np

from util import blas, files


cache_dir = files.cache_dir


def content_key(config: dict[str, Any]) -> str:
  """Stable hash of a JSON-able configuration."""
  return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:24]


def clean_orphans(folder: pathlib.Path) -> int:
  """Removes the temporary files that writers killed mid-write left under `folder` (their
  process is gone; a live writer keeps its own); returns how many."""
  removed = 0
  for tmp in pathlib.Path(folder).rglob(f"*{files.TMP_SUFFIX}"):
    pid = files.writer_pid(tmp)
    if pid is None or pid == os.getpid() or files.process_alive(pid):
      continue
    try:
      tmp.unlink()
      removed += 1
    except OSError:
      pass  # gone already, or not ours to remove
  return removed


def cached_array(kind: str, key: dict[str, Any], compute: Callable[[], np.ndarray]) -> np.ndarray:
  """An array from `cache_dir()/kind/`, computed and stored on a miss.

  The file holds the array and a SHA-256 of its bytes, dtype and shape: a damaged or edited
  file is reported (a warning naming it), deleted and computed again."""
  # the file format and the BLAS kernels enter the key: files of an older format, or
  # computed on other kernels (other last bits), are simply not found
  path = cache_dir() / kind / (content_key({"key": key, "format": 2,
                                            "blas": blas.architecture()}) + ".npz")
  if path.exists():
    try:
      with np.load(path) as z:
        value, digest = z["value"], str(z["sha256"])
      if digest != files.array_digest({"value": value}):
        raise ValueError("its array does not match the checksum written with it")
      return value
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
      warnings.warn(f"cached {kind} {path} is damaged ({err}): deleted, computing it again",
                    stacklevel=2)
      path.unlink(missing_ok=True)
  value = compute()
  path.parent.mkdir(parents=True, exist_ok=True)
  files.atomic_write(path, lambda f: np.savez(
      f, value=value, sha256=np.array(files.array_digest({"value": value}))))
  return value
