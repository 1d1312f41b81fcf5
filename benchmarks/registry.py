"""The benchmark registry, in the style of dm_control's suite: each benchmark module registers
its run functions with `register`, and `all_benchmarks` imports the modules of the packages
(`benchmarks.footpad`, `benchmarks.shell`, `benchmarks.calibrators`) to collect them, so the
list of names is never written twice.

Benchmark modules import nothing heavy at module level (no JAX, no MuJoCo): the command's
`--help` and `--list` import them all.
"""

from __future__ import annotations

import dataclasses
import importlib
import pathlib
import pkgutil
import sys
from typing import Any, Callable, Mapping, Optional

from util import errors
from util.progress import Progress, progress_bar, quiet

RIGS = ("footpad", "shell")
PACKAGES = RIGS + ("calibrators",)  # the calibrators' benchmarks take both rigs' data


@dataclasses.dataclass(frozen=True)
class Context:
  """What a benchmark gets from the command line.

  Attributes:
    quick: small data, for a run in seconds to minutes.
    seed: one integer for every random draw.
    out: the results folder.
    settings: the benchmark's settings (`Benchmark.settings`) with the user's --set applied.
    overrides: the --set text as typed, for the report.
    use_cache: load recordings simulated before.
    show_progress: draw progress bars.
    executor: where sweeps run their points (`benchmarks.executors.ExecutorSpec`).
    lines: what `print` printed, in order (the report's text for DIR/table.md).
    preset: the name of the preset the settings start from ("" for none).
    benchmark: the registered name the run was started by.
    recordings: cache stems of the recordings the run used (`used`), for the manifest.
  """
  quick: bool
  seed: int
  out: pathlib.Path
  settings: Any
  overrides: Mapping[str, str] = dataclasses.field(default_factory=dict)
  use_cache: bool = True
  show_progress: bool = True
  executor: Any = None
  lines: list = dataclasses.field(default_factory=list)
  benchmark: str = ""
  preset: str = ""
  recordings: list = dataclasses.field(default_factory=list)

  @property
  def name(self) -> str:
    """The benchmark's name for titles and figures (its folder's when not given)."""
    return self.benchmark or self.out.name

  def __post_init__(self):
    if self.executor is None:
      from benchmarks import executors
      object.__setattr__(self, "executor", executors.ExecutorSpec())

  def print(self, *args) -> None:
    """Prints a line of the report and keeps it for DIR/table.md."""
    text = " ".join(str(a) for a in args)
    self.lines.append(text)
    print(text, flush=True)

  def used(self, *recs) -> None:
    """Notes recordings (or their cache stems, from sweep workers) for the manifest."""
    for r in recs:
      stem = r if isinstance(r, str) else getattr(r, "stem", None)
      if stem and stem not in self.recordings:
        self.recordings.append(stem)

  def progress(self, label: str) -> Optional[Progress]:
    """A progress callback for library code: a bar (`progress_bar`), or with --no-progress
    one that draws nothing and still stops at a Ctrl-C."""
    return progress_bar(label) if self.show_progress else quiet


@dataclasses.dataclass(frozen=True)
class Benchmark:
  """A registered benchmark.

  Attributes:
    name: what the command takes.
    description: one line for --list.
    run: run(ctx) -> dict of results for metrics.json.
    settings: settings(quick, seed) -> the dataclass that --set keys name (imports the
      simulation only when called).
    fixed: keys the benchmark sets itself, with the reason a --set of them is refused.
    tags: the rig and what kind of benchmark it is; "fast": its --quick run takes seconds
      (the registry-wide conformance test runs every such benchmark twice).
    doc: the module's docstring, for NAME --help.
    presets: () -> {name: preset} of the designs --preset takes (each with `overrides()`,
      the --set text of its settings, and `lines()`, its account for the report); None
      where the benchmark takes none.
    preset_prefix: where the presets' keys sit among the benchmark's settings ("scene.").
    default_preset: the preset a run without --preset uses (None: the settings as
      declared).
  """
  name: str
  description: str
  run: Callable[[Context], dict]
  settings: Callable[[bool, int], Any]
  fixed: Mapping[str, str]
  tags: tuple[str, ...]
  doc: str
  presets: Optional[Callable[[], Mapping[str, Any]]] = None
  preset_prefix: str = ""
  default_preset: Optional[str] = None

  def preset(self, name: Optional[str]):
    """(the preset called `name`, or the default one; its --set overrides under the
    benchmark's keys), or (None, {}) where there is none."""
    name = name or self.default_preset
    if name is None:
      return None, {}
    known = self.presets() if self.presets else {}
    if not known:
      raise errors.SettingError(f"--preset {name}: {self.name} takes no preset")
    if name not in known:
      raise errors.unknown("preset", name, known, f"python -m benchmarks.run {self.name} --help")
    preset = known[name]
    return preset, {self.preset_prefix + k: v for k, v in preset.overrides().items()}


_REGISTRY: dict[str, Benchmark] = {}


def register(name: str, description: str, *, settings: Callable[[bool, int], Any],
             fixed: Optional[Mapping[str, str]] = None, tags: tuple[str, ...] = (),
             presets: Optional[Callable[[], Mapping[str, Any]]] = None, preset_prefix: str = "",
             default_preset: Optional[str] = None):
  """Decorator: registers run(ctx) under `name`."""
  def add(run: Callable[[Context], dict]) -> Callable[[Context], dict]:
    if name in _REGISTRY:
      raise ValueError(f"benchmark {name!r} is registered twice")
    # a functools.partial carries its function's module
    module = sys.modules.get(getattr(getattr(run, "func", run), "__module__", ""), None)
    _REGISTRY[name] = Benchmark(name, description, run, settings, dict(fixed or {}),
                                tuple(tags), (getattr(module, "__doc__", None) or "").strip(),
                                presets, preset_prefix, default_preset)
    return run
  return add


def all_benchmarks() -> dict[str, Benchmark]:
  """Every registered benchmark, by name, in the order the rig packages register them."""
  for name in PACKAGES:
    package = importlib.import_module(f"benchmarks.{name}")
    for info in pkgutil.iter_modules(package.__path__):
      importlib.import_module(f"benchmarks.{name}.{info.name}")
  return dict(_REGISTRY)


def get(name: str) -> Benchmark:
  """The benchmark `name`; ValueError listing the known names otherwise."""
  known = all_benchmarks()
  if name not in known:
    raise errors.unknown("benchmark", name, known, "python -m benchmarks.run --list")
  return known[name]
