"""Recording: the one thing that passes from `sim/` to `calibrate/`.

A recording is arrays plus metadata, saved as `<name>.npz` + `<name>.json`. Simulated
recordings are cached under a hash of everything that determines their bytes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pathlib
import tempfile
from typing import Any

import numpy as np

_ARRAYS = ("time", "counts", "pressure", "wrench", "element_force", "cnc", "path", "z_level",
           "phase", "episode")


@dataclasses.dataclass(frozen=True)
class Recording:
  """Synchronised samples of sensor output and ground truth.

  Attributes:
    time: (N,) s since the start of each episode.
    counts: (N, D) ADC counts of the D sensors, float64.
    pressure: (N, D) die pressures before the sensor chain, Pa gauge (compressive positive).
    wrench: (N, 6) plate F/T reading: force (N) and torque about the plate site (N m) that the
      plate exerts on the pad (+z compresses the pad), with `ft_noise` if listed.
    element_force: (N, 3) sum of the element spring forces, N: truth free of rig transients.
    cnc: (N, 3) carriage position, m.
    path: (N,) index into meta["paths"].
    z_level: (N,) nominal indentation, m.
    phase: (N,) 1 on the path at its indentation, 0 approaching or retreating.
    episode: (N,) index of the continuous run the sample belongs to.
    meta: scene parameters, effects, seed, versions.
  """
  time: np.ndarray
  counts: np.ndarray
  pressure: np.ndarray
  wrench: np.ndarray
  element_force: np.ndarray
  cnc: np.ndarray
  path: np.ndarray
  z_level: np.ndarray
  phase: np.ndarray
  episode: np.ndarray
  meta: dict[str, Any]

  def __len__(self) -> int:
    return len(self.time)

  def select(self, mask: np.ndarray) -> "Recording":
    """The samples where mask is True (same metadata)."""
    return dataclasses.replace(self, **{k: getattr(self, k)[mask] for k in _ARRAYS})

  def paths(self, *names: str) -> "Recording":
    """The samples of the named paths."""
    known = self.meta["paths"]
    for n in names:
      if n not in known:
        raise ValueError(f"path {n!r} is not in this recording: it has {', '.join(known)}")
    idx = [known.index(n) for n in names]
    return self.select(np.isin(self.path, idx))

  def on_path(self, *names: str) -> "Recording":
    """The samples on the named paths (all paths if none) at their indentation (phase 1)."""
    rec = self.paths(*names) if names else self
    return rec.select(rec.phase == 1)

  def save(self, stem: str | os.PathLike) -> pathlib.Path:
    """Writes stem.npz and stem.json atomically; returns the .npz path."""
    stem = pathlib.Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(stem.with_suffix(".json"),
            lambda f: f.write(json.dumps(self.meta, indent=1, sort_keys=True).encode()))
    atomic_write(stem.with_suffix(".npz"),
            lambda f: np.savez(f, **{k: getattr(self, k) for k in _ARRAYS}))
    return stem.with_suffix(".npz")

  @classmethod
  def load(cls, stem: str | os.PathLike) -> "Recording":
    stem = pathlib.Path(stem)
    with np.load(stem.with_suffix(".npz")) as z:
      arrays = {k: z[k] for k in _ARRAYS}
    meta = json.loads(stem.with_suffix(".json").read_text())
    return cls(meta=meta, **arrays)

  @classmethod
  def concatenate(cls, parts: list["Recording"], meta: dict[str, Any]) -> "Recording":
    arrays = {k: np.concatenate([getattr(p, k) for p in parts]) for k in _ARRAYS}
    return cls(meta=meta, **arrays)


def atomic_write(path: pathlib.Path, write) -> None:
  with tempfile.NamedTemporaryFile(dir=path.parent, prefix=path.name, suffix=".tmp",
                                   delete=False) as f:
    write(f)
  os.replace(f.name, path)


def cache_dir() -> pathlib.Path:
  """Root of the on-disk cache: $TESTBENCH_CACHE or ~/.cache/footpad-testbench."""
  root = os.environ.get("TESTBENCH_CACHE")
  return pathlib.Path(root) if root else pathlib.Path.home() / ".cache" / "footpad-testbench"


def content_key(config: dict[str, Any]) -> str:
  """Stable hash of a JSON-able configuration."""
  return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:24]
