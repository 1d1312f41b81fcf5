"""Command line: python -m benchmarks.run NAME [--quick] [--seed N] [--out DIR] [--set k=v ...]

Each benchmark is a module of this package with DESCRIPTION and run(ctx) -> dict; the command
writes what it returns to DIR/metrics.json next to `benchmark`, `seed` and `wall_seconds`.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import pathlib
import sys
import time
from typing import Callable, Optional

BENCHMARKS = ("asterisk_path", "circular_path", "footpad_table1", "lm_solvers", "footpad_dataset",
              "footpad_kernels", "footpad_throughput", "shell_geometry", "shell_table1",
              "shell_table2", "step_response", "gravity_vectors", "collisions")


@dataclasses.dataclass(frozen=True)
class Context:
  """What a benchmark gets from the command line."""
  quick: bool
  seed: int
  out: pathlib.Path
  overrides: dict[str, str]
  use_cache: bool
  show_progress: bool = True

  def print(self, *args) -> None:
    print(*args, flush=True)

  def progress(self, label: str) -> Optional[Callable[[int, int], None]]:
    """A progress callback for library code: a tqdm bar if installed, else a status line."""
    if not self.show_progress:
      return None
    try:
      from tqdm import tqdm
    except ImportError:
      def line(done: int, total: int) -> None:
        end = "\n" if done == total else ""
        print(f"\r{label}: {done}/{total}", end=end, file=sys.stderr, flush=True)
      return line
    bar = {}

    def update(done: int, total: int) -> None:
      if "b" not in bar:
        bar["b"] = tqdm(total=total, desc=label, file=sys.stderr, leave=False)
      bar["b"].update(done - bar["b"].n)
      if done == total:
        bar["b"].close()
    return update


def _module(name: str):
  return importlib.import_module(f"benchmarks.{name}")


def _parse_sets(items: list[str]) -> dict[str, str]:
  out = {}
  for item in items:
    key, eq, value = item.partition("=")
    if not eq or not key:
      raise ValueError(f"--set {item!r} is not key=value (e.g. --set params.friction=0.8)")
    out[key.strip()] = value.strip()
  return out


def main(argv: Optional[list[str]] = None) -> int:
  names = list(BENCHMARKS)
  parser = argparse.ArgumentParser(
      prog="python -m benchmarks.run",
      description="Run a named benchmark of the tactile-sensor testbench and write "
                  "DIR/metrics.json.",
      epilog="benchmarks: " + "; ".join(f"{n}: {_module(n).DESCRIPTION}" for n in names))
  parser.add_argument("name", nargs="?", help="benchmark name (see --list)")
  parser.add_argument("--list", action="store_true", help="list benchmarks and exit")
  parser.add_argument("--quick", action="store_true",
                      help="small data (3 Z levels instead of 16): finishes in seconds")
  parser.add_argument("--seed", type=int, default=0, help="one seed for every random draw")
  parser.add_argument("--out", type=pathlib.Path, default=None,
                      help="results folder (default results/NAME)")
  parser.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                      help="override a scene setting, e.g. params.friction=0.8, adc.vref=5, "
                           "z_levels=0.0005,0.001, effects=friction,sensor_noise")
  parser.add_argument("--no-cache", action="store_true", help="simulate even if cached")
  parser.add_argument("--no-progress", action="store_true", help="no progress bars")
  args = parser.parse_args(argv)

  if args.list:
    for n in names:
      print(f"{n:22s} {_module(n).DESCRIPTION}")
    return 0
  if not args.name:
    parser.error("a benchmark name is required (see --list)")
  if args.name not in names:
    parser.error(f"unknown benchmark {args.name!r}: allowed {', '.join(names)}")
  if args.seed < 0:
    parser.error(f"--seed {args.seed} is out of range: allowed integers >= 0")
  try:
    overrides = _parse_sets(args.sets)
  except ValueError as err:
    parser.error(str(err))
  out = args.out or pathlib.Path("results") / args.name
  ctx = Context(args.quick, args.seed, out, overrides, not args.no_cache, not args.no_progress)
  t0 = time.perf_counter()
  try:
    result = _module(args.name).run(ctx)
  except ValueError as err:  # a setting out of range: one line, no traceback
    print(f"error: {err}", file=sys.stderr)
    return 2
  metrics = {"benchmark": args.name, "seed": args.seed, "quick": args.quick,
             "settings": overrides, "wall_seconds": time.perf_counter() - t0, **result}
  out.mkdir(parents=True, exist_ok=True)
  (out / "metrics.json").write_text(json.dumps(metrics, indent=1, sort_keys=True, default=str))
  print(f"wrote {out / 'metrics.json'}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
