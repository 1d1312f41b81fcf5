"""Recording: the one thing that passes from `sim/` to `calibrate/`.

A recording is arrays plus metadata, saved as `<name>.npz` + `<name>.json`. Simulated
recordings are cached under a hash of everything that determines their bytes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pathlib
import warnings
from typing import Any, Callable, Optional

import numpy as np

from util import errors, files
from sim import cache

_REQUIRED = ("time", "counts", "wrench", "episode")
_OPTIONAL = ("pressure", "element_force", "cnc", "path", "z_level", "phase", "slip", "height",
             "pose", "applied")


@dataclasses.dataclass(frozen=True)
class Recording:
  """Synchronised samples of sensor output and ground truth, from any scene.

  Every scene fills the first four arrays; the others belong to the scenes that have them
  (None otherwise).

  Attributes:
    time: (N,) s since the start of each episode.
    counts: (N, D) ADC counts of the D sensors, float64.
    wrench: (N, 6) F/T truth: force (N) and torque about the F/T site (N m). Footpad: what
      the plate exerts on the pad (+z compresses the pad), with `ft_noise` if listed. Shell:
      the wrench on the shell, tared at no load.
    episode: (N,) index of the continuous run (footpad episode, shell session).
    meta: scene parameters, effects, seed, versions, "scene".
    pressure: footpad, (N, D) die pressures before the sensor chain, Pa gauge.
    element_force: footpad, (N, 3) sum of the element spring forces, N: truth free of rig
      transients.
    cnc: footpad, (N, 3) carriage position, m.
    path: footpad, (N,) index into meta["paths"].
    z_level: footpad, (N,) nominal indentation, m.
    phase: footpad, (N,) 1 on the path at its indentation, 0 approaching or retreating.
    slip: footpad, (N,) share of the pad's loaded elements sliding on the plate (at their
      friction limit); 0 without the `friction` effect.
    height: shell, (N, 8) reflector heights above the sensors, m (NaN: a missed facet).
    pose: shell, (N, 6) mount joints: displacement (m) and hinge angles (rad).
    applied: shell, (N, 6) the hand's wrench about the F/T site, N and N m.
    stem: the cache stem (`<rig>-<key>`) `generate` filed it under, for a run's manifest
      (None for a recording made otherwise); not saved.
  """
  time: np.ndarray
  counts: np.ndarray
  wrench: np.ndarray
  episode: np.ndarray
  meta: dict[str, Any]
  pressure: Optional[np.ndarray] = None
  element_force: Optional[np.ndarray] = None
  cnc: Optional[np.ndarray] = None
  path: Optional[np.ndarray] = None
  z_level: Optional[np.ndarray] = None
  phase: Optional[np.ndarray] = None
  slip: Optional[np.ndarray] = None
  height: Optional[np.ndarray] = None
  pose: Optional[np.ndarray] = None
  applied: Optional[np.ndarray] = None
  stem: Optional[str] = dataclasses.field(default=None, compare=False)

  def _arrays(self) -> dict[str, np.ndarray]:
    return {k: getattr(self, k) for k in _REQUIRED + _OPTIONAL if getattr(self, k) is not None}

  def __len__(self) -> int:
    return len(self.time)

  def select(self, mask: np.ndarray) -> "Recording":
    """The samples where mask is True (same metadata)."""
    return dataclasses.replace(self, **{k: v[mask] for k, v in self._arrays().items()})

  def paths(self, *names: str) -> "Recording":
    """The samples of the named paths."""
    return self.select(self._path_mask(names))

  def on_path(self, *names: str) -> "Recording":
    """The samples on the named paths (all paths if none) at their indentation (phase 1)."""
    return self.select(self.on_path_mask(*names))

  def on_path_mask(self, *names: str) -> np.ndarray:
    """(N,) True for the samples `on_path` keeps: for a calibrator that reads the whole
    recording in time order (`calibrate.temporal`) and is scored on the paths."""
    return (self._path_mask(names) if names else np.ones(len(self), bool)) & (self.phase == 1)

  def _path_mask(self, names) -> np.ndarray:
    if self.path is None:
      raise errors.DataError("this recording has no paths (it is not a footpad recording)")
    known = self.meta["paths"]
    for n in names:
      if n not in known:
        raise errors.DataError(f"path {n!r} is not in this recording: it has {', '.join(known)}")
    return np.isin(self.path, [known.index(n) for n in names])

  def save(self, stem: str | os.PathLike) -> pathlib.Path:
    """Writes stem.npz (the arrays) and stem.json (the metadata with the format tag and a
    SHA-256 of both), each atomically, the JSON last; returns the .npz path."""
    stem = pathlib.Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    npz = stem.with_suffix(".npz")
    files.atomic_write(npz, lambda f: np.savez(f, **self._arrays()))
    meta = files.from_json(files.json_text(self.meta))
    head = {"format": FORMAT, "version": VERSION, "meta": meta,
            "sha256": _digest(npz.read_bytes(), meta)}
    files.write_text(stem.with_suffix(".json"), files.json_text(head, indent=1, sort_keys=True))
    return npz

  @classmethod
  def load(cls, stem: str | os.PathLike) -> "Recording":
    """Reads a recording `save` wrote, checked: format tag and version, the checksum of the
    arrays and metadata, the arrays' shapes and finiteness.

    Raises:
      errors.DataError naming the file and what is wrong with it.
    """
    stem = pathlib.Path(stem)
    npz, head_path = stem.with_suffix(".npz"), stem.with_suffix(".json")
    try:
      head = files.from_json(head_path.read_text())
      data = npz.read_bytes()
    except (OSError, ValueError) as err:
      raise errors.DataError(f"recording {stem}: cannot be read ({err})") from None
    meta = head.get("meta") if isinstance(head, dict) else None
    files.check_header(head, stem, "recording", FORMAT, VERSION, _digest(data, meta))
    arrays = files.read_npz(data, f"recording {npz}", keys=_REQUIRED + _OPTIONAL)
    _check_arrays(npz, arrays)
    return cls(meta=meta, **arrays)

  @classmethod
  def concatenate(cls, parts: list["Recording"], meta: dict[str, Any]) -> "Recording":
    arrays = {k: np.concatenate([getattr(p, k) for p in parts]) for k in parts[0]._arrays()}
    return cls(meta=meta, **arrays)


FORMAT = "testbench-recording"
VERSION = 2  # 1: bare metadata JSON, no checksum


def _digest(npz: bytes, meta: Any) -> str:
  h = hashlib.sha256(npz)
  h.update(files.json_text(meta, sort_keys=True).encode())
  return h.hexdigest()


# arrays that may hold NaN: a missed facet's height under `ray_miss`
_MAY_BE_NAN = ("height",)


def _check_arrays(path: pathlib.Path, arrays: dict[str, np.ndarray]) -> None:
  missing = [k for k in _REQUIRED if k not in arrays]
  if missing:
    raise errors.DataError(f"recording {path}: missing arrays {', '.join(missing)}")
  n = len(arrays["time"])
  for k, a in arrays.items():
    if a.ndim == 0 or len(a) != n:
      raise errors.DataError(f"recording {path}: {k} has shape {a.shape}; the recording has "
                             f"{n} samples")
    if k not in _MAY_BE_NAN and np.issubdtype(a.dtype, np.floating) and not np.isfinite(a).all():
      raise errors.DataError(f"recording {path}: {k} holds NaN or inf")
  if arrays["counts"].ndim != 2 or arrays["wrench"].shape != (n, 6):
    raise errors.DataError(f"recording {path}: counts {arrays['counts'].shape} and wrench "
                           f"{arrays['wrench'].shape} must be (N, D) and (N, 6)")


@dataclasses.dataclass(frozen=True)
class Timing:
  """Where the time of a simulated recording went.

  Attributes:
    build: model compilation and precomputed kernels (from the cache or solved), s.
    simulate: wall time of the physics over all threads, s.
    physics_cpu: summed per-thread time inside MuJoCo, s.
    sensor_chain_cpu: summed time from joint positions to counts, s; compare with physics_cpu.
    steps: simulation steps.
    threads: worker threads.
  """
  build: float
  simulate: float
  physics_cpu: float
  sensor_chain_cpu: float
  steps: int
  threads: int


def generate(rig: str, key: dict[str, Any], simulate: Callable[[], tuple[Recording, Timing]],
             use_cache: bool = True) -> tuple[Recording, Optional[Timing]]:
  """The recording of a scene, from the cache when an identical request was made before.

  Args:
    rig: name prefix of the cached files ("footpad", "shell").
    key: everything that determines the recording's bytes (scene and versions).
    simulate: runs the scene when the cache misses.
  Returns:
    The recording (its `stem` the cache stem, which a run's manifest names) and the timing
    of its simulation (None when loaded from the cache).
  """
  stem = cache.cache_dir() / "recordings" / f"{rig}-{cache.content_key(key)}"
  if use_cache and stem.with_suffix(".npz").exists() and stem.with_suffix(".json").exists():
    try:
      return dataclasses.replace(Recording.load(stem), stem=stem.name), None
    except errors.DataError as err:  # damaged: say so, drop it, simulate it again
      warnings.warn(f"{err}: deleted from the cache, simulating it again", stacklevel=2)
      for suffix in (".npz", ".json"):
        stem.with_suffix(suffix).unlink(missing_ok=True)
  rec, timing = simulate()
  if not use_cache:
    return rec, timing
  rec.save(stem)
  return dataclasses.replace(rec, stem=stem.name), timing
