"""The results folder of a run: checked before any work, filled when the run ends.

`util.files.claim(out)` (which `benchmarks.run` calls) fails in the first second, with one line, when `--out` is a file, cannot be
created or written, or another live run holds it; otherwise it takes a lock file in it that
`release` removes. The hold is the system's (`flock`): a run that was killed, however, holds
nothing, and two runs started at once can never both hold one folder.

A finished run leaves (`write_run`): `manifest.json` (the command, every resolved setting,
seed, effects, package versions, git commit, the cached recordings it used, timings),
`metrics.json` (all the benchmark returned), `metrics.csv` (one row per number: group,
method, axis, metric, value, spread; method and axis as the benchmark's `Result` gives
them), `table.md` (the printed report), and where the benchmark has them
`predictions.npz` (`write_predictions`) and `figures/*.png`.
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import numpy as np

from calibrate import metrics
from util import errors, files

TABLE = "table.md"  # the printed report of a run


def quiet_out_of_range() -> None:
  """Silences `calibrate.estimators.OutOfRangeWarning` in this process (inside a
  `warnings.catch_warnings` block): benchmarks report the share of samples outside an
  estimator's training range once (Table I) rather than a warning per prediction. Matched by
  its text, so `--help` needs no JAX."""
  import warnings
  warnings.filterwarnings("ignore", message=".* outside the range this estimator")


# ---- what a finished run leaves in its folder -------------------------------------------

PACKAGES = ("mujoco", "numpy", "scipy", "jax", "jaxlib", "jaxopt", "matplotlib", "trimesh")
Row, scored = metrics.Row, metrics.scored


@dataclasses.dataclass(frozen=True)
class Result:
  """What a benchmark's `run(ctx)` returns (a plain dict is taken as `Result(data,
  plain(data))`).

  Attributes:
    data: everything for metrics.json (nested, JSON-able).
    rows: metrics.csv: every number once, a per-method and per-axis number with its method
      and axis (`scored`), the rest with neither (`plain`).
  """
  data: dict
  rows: tuple = ()


def per_axis(group: str, by_axis: dict, method: str = "") -> list[Row]:
  """The rows of {axis: {metric: value}} of one method (or of none, as a paper's or a
  recording's ranges), each naming its axis."""
  return [Row(group, method, ax, k, float(v)) for ax, per in by_axis.items()
          for k, v in per.items()]


def plain(data: Any, path: tuple[str, ...] = (), skip: tuple[tuple[str, ...], ...] = ()
          ) -> list[Row]:
  """Every number of nested dicts and lists as a row of no method and no axis: the group is
  its path but for the last key, the metric that key. Paths that start with one of `skip`
  (where "*" stands for any key) are left out: the benchmark gave their rows (`scored`)."""
  if any(len(path) >= len(s) and all(a in ("*", b) for a, b in zip(s, path)) for s in skip):
    return []
  if isinstance(data, dict):
    return [r for k, v in data.items() for r in plain(v, path + (str(k),), skip)]
  if isinstance(data, (list, tuple)):
    return [r for i, v in enumerate(data) for r in plain(v, path + (str(i),), skip)]
  if isinstance(data, bool) or not isinstance(data, (int, float, np.integer, np.floating)):
    return []
  return [Row("/".join(path[:-1]), "", "", path[-1] if path else "", float(data))]


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


def read_rows(path: pathlib.Path) -> list[Row]:
  """The rows of a run's metrics.csv.

  Raises:
    errors.SettingError naming the file when it is missing or not such a table.
  """
  try:
    return metrics.read_csv(path)
  except (OSError, ValueError, KeyError) as err:
    raise errors.SettingError(f"--compare: {path} cannot be read as a run's metrics.csv "
                              f"({err}); give the results folder of an earlier run") from None


def write_run(out: pathlib.Path, result: Result, head: dict, lines: list[str], title: str,
              manifest: dict) -> None:
  """Fills the results folder of a finished run: metrics.json (`head`, then the result's
  data), metrics.csv (its rows, then `head`'s numbers), table.md (the printed `lines` under
  `title`) and manifest.json (`manifest`, with the folder's files)."""
  out = pathlib.Path(out)
  files.write_text(out / "metrics.json", files.json_text({**head, **result.data}, indent=1,
                                                          sort_keys=True, default=str))
  files.write_text(out / "metrics.csv", metrics.csv_text(list(result.rows) + plain(head)))
  files.write_text(out / TABLE, title + "```\n" + "\n".join(lines) + "\n```\n")
  written = {str(p.relative_to(out)) for p in out.rglob("*")
             if p.is_file() and not p.name.startswith(".")}
  manifest = {**manifest, "files": sorted(written | {"manifest.json"})}
  files.write_text(out / "manifest.json", files.json_text(manifest, indent=1, default=str))


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


def compare_lines(old: list[Row], new: list[Row], limit: int = 80) -> list[str]:
  """The metrics two runs share, side by side with their difference; a change within the
  seeds' spread (either run's, where the number is a median over seeds) is marked "~", as
  asv's compare does, so scatter is not read as a change. Per-seed and per-design rows (a
  number in their group) are left out to keep the headline."""
  def key(r):
    return (r.group, r.method, r.axis, r.metric)
  before = {key(r): r for r in old}
  for r in new:  # an earlier run's row that named no method (written before rows had them)
    unnamed = (r.group, "", r.axis, r.metric)
    if key(r) not in before and unnamed in before and not before[unnamed].method:
      before[key(r)] = before[unnamed]
  shared = [r for r in new if key(r) in before and
            not any(part.isdigit() for part in r.group.split("/"))]
  # the headline first: a benchmark's "results" (Table I's cells, say), then the rest
  shared.sort(key=lambda r: r.group.split("/")[0] != "results")
  if not shared:
    return ["no metric in common with the earlier run (another benchmark?)"]
  width = max(len(" ".join(p for p in key(r) if p)) for r in shared[:limit])
  lines = [f"{'metric':{width}s} {'earlier':>12s} {'this run':>12s} {'change':>12s}"]
  for r in shared[:limit]:
    a, b = before[key(r)].value, r.value
    spread = np.nanmax([before[key(r)].spread, r.spread, 0.0])
    mark = " ~" if b != a and abs(b - a) <= spread else ""
    lines.append(f"{' '.join(p for p in key(r) if p):{width}s} {a:12.4g} {b:12.4g} "
                 f"{b - a:+12.4g}{mark}")
  if len(shared) > limit:
    lines.append(f"... and {len(shared) - limit} more in metrics.csv")
  if any(line.endswith(" ~") for line in lines):
    lines.append("~: within the seeds' spread (standard deviation over the networks' seeds)")
  return lines
