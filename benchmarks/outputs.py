"""The results folder of a run: checked before any work, filled when the run ends.

`claim(out)` fails in the first second, with one line, when `--out` is a file, cannot be
created or written, or another live run holds it; otherwise it takes a lock file in it that
`release` removes. A lock left by a run that was killed (its process is gone) is taken over.

A finished run leaves (`benchmarks.run`): `manifest.json` (the command, every resolved
setting, seed, effects, package versions, git commit, the cached recordings it used,
timings), `metrics.json` (all the benchmark returned), `metrics.csv` (one row per number:
group, method, axis, metric, value), `table.md` (the printed report), and where the
benchmark has them `predictions.npz` (`write_predictions`) and `figures/*.png`.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
from typing import Any

import numpy as np

from util import errors, files

LOCK = ".run.lock"
TABLE = "table.md"  # the printed report of a run


def quiet_out_of_range() -> None:
  """Silences `calibrate.estimators.OutOfRangeWarning` in this process (inside a
  `warnings.catch_warnings` block): benchmarks report the share of samples outside an
  estimator's training range once (Table I) rather than a warning per prediction. Matched by
  its text, so `--help` needs no JAX."""
  import warnings
  warnings.filterwarnings("ignore", message=".* outside the range this estimator")


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


# ---- what a finished run leaves in its folder -------------------------------------------

METHODS = ("LS", "POLY", "LSANN", "NN", "cubic")
AXES = ("X", "Y", "Z", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
CSV_COLUMNS = ("group", "method", "axis", "metric", "value")
PACKAGES = ("mujoco", "numpy", "scipy", "jax", "jaxlib", "jaxopt", "matplotlib", "trimesh")


def versions() -> dict[str, str]:
  """Python's and the numerical packages' versions (absent ones left out)."""
  import importlib.metadata
  import platform
  out = {"python": platform.python_version()}
  for name in PACKAGES:
    try:
      out[name] = importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
      pass
  return out


def git_commit() -> str | None:
  """The project's git commit (with "-dirty" when its tracked files differ), or None outside
  a git checkout."""
  import subprocess
  root = pathlib.Path(__file__).resolve().parents[1]
  try:
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                          text=True, timeout=10)
    if head.returncode != 0:
      return None
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                           capture_output=True, text=True, timeout=10).stdout.strip()
  except (OSError, subprocess.SubprocessError):
    return None
  return head.stdout.strip() + ("-dirty" if dirty else "")


def metric_rows(result: Any, path: tuple[str, ...] = ()) -> list[dict]:
  """Every number of a result (nested dicts and lists) as a row (group, method, axis, metric,
  value): the method and axis are the first path elements that name one (`METHODS`,
  `AXES`), the metric the last, the group the rest joined by "/"."""
  if isinstance(result, dict):
    return [r for k, v in result.items() for r in metric_rows(v, path + (str(k),))]
  if isinstance(result, (list, tuple)):
    return [r for i, v in enumerate(result) for r in metric_rows(v, path + (str(i),))]
  if isinstance(result, bool) or not isinstance(result, (int, float, np.integer, np.floating)):
    return []
  method = next((p for p in path[:-1] if p in METHODS), "")
  axis = next((p for p in path[:-1] if p in AXES), "")
  group = "/".join(p for p in path[:-1] if p not in (method, axis))
  return [{"group": group, "method": method, "axis": axis, "metric": path[-1] if path else "",
           "value": float(result)}]


def csv_text(rows: list[dict]) -> str:
  import csv
  import io
  buf = io.StringIO()
  writer = csv.DictWriter(buf, CSV_COLUMNS, lineterminator="\n")
  writer.writeheader()
  writer.writerows({**r, "value": repr(r["value"])} for r in rows)
  return buf.getvalue()


def read_metric_rows(path: pathlib.Path) -> list[dict]:
  """The rows of a metrics.csv `write_results` wrote.

  Raises:
    errors.SettingError naming the file when it is missing or not such a table.
  """
  import csv
  try:
    with open(path, newline="") as f:
      reader = csv.DictReader(f)
      if tuple(reader.fieldnames or ()) != CSV_COLUMNS:
        raise ValueError(f"its columns are {reader.fieldnames}, not {', '.join(CSV_COLUMNS)}")
      return [{**r, "value": float(r["value"])} for r in reader]
  except (OSError, ValueError) as err:
    raise errors.SettingError(f"--compare: {path} cannot be read as a run's metrics.csv "
                              f"({err}); give the results folder of an earlier run") from None


def write_predictions(out: pathlib.Path, truth: np.ndarray, predictions: dict[str, np.ndarray],
                      axes: tuple[str, ...], unit: str, **extra: np.ndarray) -> pathlib.Path:
  """DIR/predictions.npz: the test truth (N, A), each method's prediction (N, A), the axes'
  names and unit, and any further per-sample arrays (time, episode...)."""
  arrays = {"truth": np.asarray(truth, float), "axes": np.array(axes), "unit": np.array(unit)}
  arrays.update({f"pred_{m}": np.asarray(p, float) for m, p in predictions.items()})
  arrays.update({k: np.asarray(v) for k, v in extra.items()})
  path = pathlib.Path(out) / "predictions.npz"
  files.atomic_write(path, lambda f: np.savez_compressed(f, **arrays))
  return path


def compare_lines(old: list[dict], new: list[dict], limit: int = 80) -> list[str]:
  """The metrics two runs share, side by side with their difference; per-seed and
  per-design rows (a number in their group) are left out to keep the headline."""
  def key(r):
    return (r["group"], r["method"], r["axis"], r["metric"])
  before = {key(r): r["value"] for r in old}
  shared = [r for r in new if key(r) in before and
            not any(part.isdigit() for part in r["group"].split("/"))]
  # the headline first: a benchmark's "results" (Table I's cells, say), then the rest
  shared.sort(key=lambda r: r["group"].split("/")[0] != "results")
  if not shared:
    return ["no metric in common with the earlier run (another benchmark?)"]
  width = max(len(" ".join(p for p in key(r) if p)) for r in shared[:limit])
  lines = [f"{'metric':{width}s} {'earlier':>12s} {'this run':>12s} {'change':>12s}"]
  for r in shared[:limit]:
    a, b = before[key(r)], r["value"]
    lines.append(f"{' '.join(p for p in key(r) if p):{width}s} {a:12.4g} {b:12.4g} {b - a:+12.4g}")
  if len(shared) > limit:
    lines.append(f"... and {len(shared) - limit} more in metrics.csv")
  return lines
