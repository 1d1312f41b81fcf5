"""The on-disk cache shared by both rigs: recordings and finite-element results, stored under
a hash of everything that determines their bytes, and written atomically."""

from __future__ import annotations

import hashlib
import json
import os
import pathlib
import tempfile
from typing import Any, Callable

import numpy as np


def cache_dir() -> pathlib.Path:
  """Root of the on-disk cache: $TESTBENCH_CACHE or ~/.cache/footpad-testbench."""
  root = os.environ.get("TESTBENCH_CACHE")
  return pathlib.Path(root) if root else pathlib.Path.home() / ".cache" / "footpad-testbench"


def content_key(config: dict[str, Any]) -> str:
  """Stable hash of a JSON-able configuration."""
  return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:24]


def atomic_write(path: pathlib.Path, write: Callable) -> None:
  """Calls write(file) on a temporary file beside `path`, then renames it into place, so a
  reader never sees a half-written file."""
  with tempfile.NamedTemporaryFile(dir=path.parent, prefix=path.name, suffix=".tmp",
                                   delete=False) as f:
    write(f)
  os.replace(f.name, path)


def cached_array(kind: str, key: dict[str, Any], compute: Callable[[], np.ndarray]) -> np.ndarray:
  """An array from `cache_dir()/kind/`, computed and stored on a miss."""
  path = cache_dir() / kind / (content_key(key) + ".npy")
  if path.exists():
    return np.load(path)
  value = compute()
  path.parent.mkdir(parents=True, exist_ok=True)
  atomic_write(path, lambda f: np.save(f, value))
  return value
