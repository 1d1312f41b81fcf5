"""Command line: python -m benchmarks.run NAME [--quick] [--seed N] [--out DIR] [--set k=v ...]

Runs a registered benchmark (`benchmarks.registry`) and fills its results folder (default
results/NAME, results/NAME-quick with --quick; see `benchmarks.outputs`): manifest.json,
metrics.json, metrics.csv, table.md, and the benchmark's predictions and figures.
`--compare DIR` prints the new run's metrics beside those of the run in DIR.
`python -m benchmarks.run NAME --help` lists the keys --set takes for that benchmark.
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib
import shlex
import sys
import time
from typing import Optional

from benchmarks import executors, outputs, registry
from util import cli, errors, files


def _parse_sets(items: list[str]) -> dict[str, str]:
  out = {}
  for item in items:
    key, eq, value = item.partition("=")
    if not eq or not key.strip():
      raise errors.SettingError(
          f"--set {item!r} is not key=value (e.g. --set params.friction_mu0=1.5)")
    out[key.strip()] = value.strip()
  return out


def _parser(benchmarks: dict[str, registry.Benchmark]) -> argparse.ArgumentParser:
  parser = argparse.ArgumentParser(
      prog="python -m benchmarks.run", add_help=False,
      formatter_class=argparse.RawDescriptionHelpFormatter,
      description="Run a named benchmark of the tactile-sensor testbench and fill its "
                  "results folder (table.md, metrics.csv/json, manifest.json, figures, "
                  "predictions). 'NAME --help' lists the settings NAME takes.",
      epilog="benchmarks:\n" + "\n".join(f"  {n:20s} {b.description}"
                                         for n, b in benchmarks.items()))
  parser.add_argument("name", nargs="?", help="benchmark name (see --list)")
  parser.add_argument("-h", "--help", action="store_true",
                      help="show this help, or with NAME the settings NAME takes, and exit")
  parser.add_argument("--list", action="store_true", help="list benchmarks and exit")
  parser.add_argument("--quick", action="store_true",
                      help="small data (3 Z levels instead of 16, a tenth of the shell's "
                           "frames): seconds for the geometry benchmarks, a few minutes for "
                           "those that train networks or sweep designs")
  parser.add_argument("--check", action="store_true",
                      help="check the command (name, settings, --out) and print the resolved "
                           "settings without running")
  parser.add_argument("--seed", type=int, default=0, help="one seed for every random draw")
  parser.add_argument("--out", type=cli.path_arg, default=None,
                      help="results folder (default results/NAME, or results/NAME-quick "
                           "with --quick, so a quick run never overwrites a full one)")
  parser.add_argument("--compare", type=pathlib.Path, default=None, metavar="DIR",
                      help="print this run's metrics beside those of an earlier run's "
                           "results folder")
  parser.add_argument("--preset", default=None, metavar="NAME",
                      help="start from a named design of the rig's ranged parameters, your "
                           "--set on top: on the footpad's benchmarks 'paper' (identified "
                           "from the paper's tables by identify_footpad) or 'nominal' (every "
                           "parameter at its sourced default); NAME --help says which a "
                           "benchmark takes and which it runs by default")
  parser.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                      help="change a setting, e.g. params.friction_mu0=1.5, adc.vref=5, "
                           "z_levels=0.0005,0.001, effects=friction,sensor_noise (see NAME "
                           "--help)")
  parser.add_argument("--data", type=cli.path_arg, default=None, metavar="DIR",
                      help="run on your own recordings, one CSV per recording (benchmarks "
                           "with a data setting: real_recordings, with --set inputs=... "
                           "--set targets=...)")
  parser.add_argument("--executor", choices=("processes", "serial", "dask"), default="processes",
                      help="where a sweep's points run: local processes on every core "
                           "(default), this process, or Dask (an optional extra: pip install "
                           "-e '.[cluster]'); without --address Dask starts a LocalCluster "
                           "listening on 127.0.0.1 only")
  parser.add_argument("--workers", type=int, default=None,
                      help="processes or Dask workers for a sweep (default: one per core); "
                           "for Table I's network trainings, how many train at once "
                           "(default: one per core; 1 gives each training's solo time)")
  parser.add_argument("--address", default=None,
                      help="join a running Dask scheduler (tls://HOST:PORT, or tcp:// on a "
                           "trusted network); TLS certificates come from Dask's configuration "
                           "(distributed.comm.tls) or --tls-ca-file/--tls-cert/--tls-key")
  parser.add_argument("--tls-ca-file", default=None, help="Dask TLS: CA certificate")
  parser.add_argument("--tls-cert", default=None, help="Dask TLS: client certificate")
  parser.add_argument("--tls-key", default=None, help="Dask TLS: client key")
  parser.add_argument("--no-cache", action="store_true", help="simulate even if cached")
  parser.add_argument("--no-progress", action="store_true", help="no progress bars")
  return parser


def _format(value) -> str:
  if isinstance(value, tuple):
    return ",".join(_format(v) for v in value) if not any(
        isinstance(v, tuple) for v in value) else ";".join(_format(v) for v in value)
  return str(getattr(value, "value", value))


def _resolved(applied, fixed=None) -> dict[str, str]:
  """{key: value as --set would take it} for every setting of `applied` (`fixed` keys left
  out)."""
  from sim import settings
  return {k.name: _format(k.default) for k in settings.keys(applied, fixed)}


def benchmark_help(bench: registry.Benchmark, quick: bool, seed: int) -> str:
  """NAME --help: what the benchmark does and every key --set takes."""
  from sim import settings
  rows = settings.keys(bench.settings(quick, seed), bench.fixed)
  lines = [f"python -m benchmarks.run {bench.name} [--quick] [--seed N] [--out DIR] "
           f"[--set KEY=VALUE ...]", "", bench.description, "", bench.doc, "",
           f"settings (--set KEY=VALUE){' with --quick' if quick else ''}:"]
  for k in rows:
    lines.append(f"  {k.name}  ({k.type}, default {_format(k.default)}; allowed {k.allowed})")
    if k.doc:
      lines.append(f"      {k.doc}")
  if bench.presets:
    lines += ["", "presets (--preset NAME; your --set applies on top):"]
    for name, preset in bench.presets().items():
      default = " (the default)" if name == bench.default_preset else ""
      lines.append(f"  {name}{default}: {preset.what}")
  if bench.fixed:
    lines += ["", "set by the benchmark itself (not settable):"]
    lines += [f"  {key}: {why}" for key, why in bench.fixed.items()]
  return "\n".join(lines)


def main(argv: Optional[list[str]] = None) -> int:
  import warnings

  def body() -> int:
    with warnings.catch_warnings():
      outputs.quiet_out_of_range()
      return _main(argv)
  return cli.run(body, "benchmarks.run", INTERRUPTED)


INTERRUPTED = ("interrupted: finished points and cached recordings are kept; rerun the same "
               "command to go on")


def _main(argv: Optional[list[str]]) -> int:
  benchmarks = registry.all_benchmarks()
  parser = _parser(benchmarks)
  args = parser.parse_args(argv)
  if args.help and not args.name:
    parser.print_help()
    return 0
  if args.list:
    for n, b in benchmarks.items():
      print(f"{n:22s} {b.description}")
    return 0
  if not args.name:
    parser.error("a benchmark name is required (see --list)")
  bench = registry.get(args.name)
  if args.seed < 0:
    parser.error(f"--seed {args.seed} is out of range: allowed integers >= 0")
  if args.help:
    print(benchmark_help(bench, args.quick, args.seed))
    return 0
  from sim import settings
  overrides = _parse_sets(args.sets)
  if args.data is not None:
    if "data" not in {f.name for f in dataclasses.fields(bench.settings(args.quick, args.seed))}:
      parser.error(f"--data: {args.name} reads no recordings of yours (real_recordings does)")
    overrides["data"] = str(args.data)
  preset, preset_sets = bench.preset(args.preset)
  applied = settings.apply(settings.apply(bench.settings(args.quick, args.seed), preset_sets,
                                          bench.fixed), overrides, bench.fixed)
  if hasattr(applied, "validate"):  # what a field's range cannot say (a custom path's file)
    applied.validate()
  if args.workers is not None and not 1 <= args.workers <= 1024:
    parser.error(f"--workers {args.workers} is out of range: allowed 1 to 1024")
  if args.address and args.executor != "dask":
    parser.error("--address joins a Dask scheduler: add --executor dask")
  executors.ExecutorSpec(args.executor, args.workers, args.address, args.tls_ca_file,
                         args.tls_cert, args.tls_key).check()
  out = args.out or pathlib.Path("results") / (args.name + ("-quick" if args.quick else ""))
  if args.check:
    for name, value in _resolved(applied, bench.fixed).items():
      print(f"{name} = {value}")
    print(f"ok: {args.name} would write to {out}/")
    return 0
  earlier = None
  if args.compare is not None:  # read before the run: a mistake costs no simulation
    earlier = outputs.read_rows(args.compare / "metrics.csv")
  files.usable_cache_dir()  # the recordings' cache too, before any simulation
  lock = files.claim(out, "--out")  # before any simulation: a run that cannot write does not start
  try:
    return _run(bench, args, applied, overrides, out, earlier,
                sys.argv[1:] if argv is None else list(argv), preset)
  finally:
    lock.release()


def arm_integration(tags) -> Optional[dict]:
  """How the footpad's Maxwell arms are integrated in this run ({"integration": "native" or
  "dcmotor", "why": the fallback's reason}), for a benchmark tagged "footpad"; None
  otherwise."""
  if "footpad" not in tags:
    return None
  from models import footpad
  kind, why = footpad.arm_dynamics()
  return {"integration": kind, "why": why}


def _run(bench: registry.Benchmark, args, applied, overrides: dict, out: pathlib.Path,
         earlier: Optional[list[outputs.Row]], argv: list[str], preset=None) -> int:
  from sim import cache
  spec = executors.ExecutorSpec(args.executor, args.workers, args.address, args.tls_ca_file,
                                args.tls_cert, args.tls_key)
  ctx = registry.Context(args.quick, args.seed, out, applied, overrides, not args.no_cache,
                         not args.no_progress, spec, benchmark=args.name,
                         preset=preset.name if preset else "")
  if preset is not None:  # which design the numbers below are of, first in the report
    for line in preset.lines():
      ctx.print(line)
  for folder in (cache.cache_dir(), out):  # what killed runs left half-written
    cache.clean_orphans(folder)
  arms = arm_integration(bench.tags)
  if arms and arms["integration"] != "native":
    ctx.print(f"warning: the footpad's Maxwell arms run as MuJoCo's DC motors, not the compiled "
              f"callback ({arms['why']}): slower, and its recordings are other bytes")
  started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
  t0 = time.perf_counter()
  try:
    result = bench.run(ctx)
  except (errors.UserError, KeyboardInterrupt):
    raise  # one line, from main (util.cli.run)
  except Exception:  # not the user's mistake: a short message, the traceback in the results
    return cli.internal_error(out / "traceback.txt")
  wall = time.perf_counter() - t0
  if not isinstance(result, outputs.Result):
    result = outputs.Result(result, tuple(outputs.plain(files.from_json(files.json_text(
        result, default=str)))))  # arrays as lists, as metrics.json has them
  head = {"benchmark": args.name, "seed": args.seed, "quick": args.quick,
          "settings": overrides, "wall_seconds": wall}
  command = "python -m benchmarks.run " + shlex.join(argv)
  manifest = {
      "benchmark": args.name, "command": command, "seed": args.seed, "quick": args.quick,
      "preset": ctx.preset, "overrides": overrides, "settings": _resolved(applied),
      "effects": list(getattr(applied, "effects", ()) or ()),
      "versions": outputs.versions(), "git_commit": outputs.git_commit(),
      "cache_dir": str(cache.cache_dir()), "started": started, "wall_seconds": wall,
      "rerun": "the command above at git_commit; with the same versions it gives the same "
               "bytes (every draw follows the seed)"}
  manifest["recordings"] = ctx.recordings
  if arms:
    manifest["maxwell_arms"] = arms
  outputs.write_run(out, result, head, ctx.lines, f"# {args.name}\n\n{bench.description}\n\n"
                    f"`{command}` (seed {args.seed})\n\n", manifest)
  if earlier is not None:
    print(f"\ncompared with {args.compare}:")
    print("\n".join(outputs.compare_lines(earlier, list(result.rows))))
  print(f"results in {out}/: table.md, metrics.csv, metrics.json, manifest.json"
        + (", predictions.npz" if (out / "predictions.npz").exists() else "")
        + (", figures/" if (out / "figures").is_dir() else ""))
  return 0


if __name__ == "__main__":
  sys.exit(main())
