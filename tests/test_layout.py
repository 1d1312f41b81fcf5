"""The project's shape: the import graph, the benchmark registry, scoped float64."""

import ast
import contextlib
import io
import pathlib
import subprocess
import sys

import pytest

from benchmarks import registry
from benchmarks import run as cli

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = ("util", "models", "sim", "calibrate", "benchmarks")


def _modules() -> dict[str, pathlib.Path]:
  out = {}
  for pkg in PACKAGES:
    for path in (ROOT / pkg).rglob("*.py"):
      parts = path.relative_to(ROOT).with_suffix("").parts
      name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
      out[name] = path
  return out


def _imports(path: pathlib.Path, modules) -> set[str]:
  """Project modules `path` imports anywhere in it (function-level imports included)."""
  found = set()
  for node in ast.walk(ast.parse(path.read_text())):
    names = []
    if isinstance(node, ast.Import):
      names = [a.name for a in node.names]
    elif isinstance(node, ast.ImportFrom) and node.module:
      names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
    for n in names:
      while n and n not in modules:
        n = n.rpartition(".")[0]
      if n:
        found.add(n)
  return found


GRAPH = {name: _imports(path, _modules()) - {name} for name, path in _modules().items()}


@pytest.mark.parametrize("low, high", [("util", "models"), ("util", "sim"),
                                       ("util", "calibrate"), ("util", "benchmarks"),
                                       ("models", "sim"), ("models", "calibrate"),
                                       ("models", "benchmarks"), ("sim", "benchmarks"),
                                       ("sim", "calibrate"), ("calibrate", "sim"),
                                       ("calibrate", "benchmarks"), ("calibrate", "models")])
def test_data_flows_one_way(low, high):
  # every module counts, commands (calibrate/__main__.py) included: the users' own tool
  # needs neither the simulator nor the benchmarks
  wrong = {m: sorted(d for d in deps if d.split(".")[0] == high)
           for m, deps in GRAPH.items() if m.split(".")[0] == low}
  assert not {m: d for m, d in wrong.items() if d}, f"{low} must not import {high}"


def test_models_holds_only_model_builders():
  """Every module of models/ builds or describes MuJoCo models (the plumbing is in util/)."""
  for name, path in _modules().items():
    if name.startswith("models.") and name != "models":
      assert "MjSpec" in path.read_text() or "mjspec" in path.read_text().lower(), name


COMMANDS = ("benchmarks.run", "calibrate.__main__", "sim.render")


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_takes_the_one_error_path(command):
  """The three commands end in `util.cli.run`: one place says how an error is printed and
  which exit code it gets; no command prints its own "error:" line."""
  source = _modules()[command].read_text()
  assert "util.cli" in GRAPH[command] and "cli.run(" in source, command
  assert "\"error: " not in source and "internal error" not in source, command


def test_no_import_cycles():
  state: dict[str, int] = {}

  def visit(m, path):
    if state.get(m) == 1:
      raise AssertionError(" -> ".join(path + [m]))
    if state.get(m) == 2:
      return
    state[m] = 1
    for d in sorted(GRAPH.get(m, ())):
      # a package's submodule importing its own package __init__ is not a cycle unless the
      # __init__ imports it back, which the graph shows
      visit(d, path + [m])
    state[m] = 2

  for m in sorted(GRAPH):
    visit(m, [])


def test_help_and_list_import_neither_jax_nor_mujoco():
  code = ("import sys, io, contextlib\n"
          "from benchmarks import run\n"
          "with contextlib.redirect_stdout(io.StringIO()):\n"
          "  assert run.main(['--list']) == 0 and run.main(['--help']) == 0\n"
          "print(sorted(m for m in ('jax', 'mujoco') if m in sys.modules))\n")
  out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       check=True).stdout
  assert out.strip() == "[]", out


BENCHMARKS = registry.all_benchmarks()


def test_the_registry_holds_every_benchmark_once_with_the_main_job():
  assert "asterisk_path" in BENCHMARKS and len(BENCHMARKS) >= 13
  # the three Table I benchmarks are one function registered three times
  runs = {BENCHMARKS[n].run.func for n in ("asterisk_path", "circular_path", "footpad_table1")}
  assert len(runs) == 1


@pytest.mark.parametrize("name", sorted(BENCHMARKS))
def test_every_benchmark_describes_itself_and_its_settings(name):
  bench = BENCHMARKS[name]
  assert len(bench.description) > 20 and len(bench.doc) > 40
  assert set(bench.tags) & set(registry.RIGS)
  out = io.StringIO()
  with contextlib.redirect_stdout(out):
    assert cli.main([name, "--help"]) == 0
  text = out.getvalue()
  from sim import settings
  keys = settings.keys(bench.settings(False, 0), bench.fixed)
  assert keys
  for k in keys:
    assert f"  {k.name}  (" in text and k.doc, k.name
  for key in bench.fixed:
    assert f"  {key}  (" not in text


def test_calibrate_does_not_switch_jax_to_float64_on_import():
  code = ("import jax, numpy as np\n"
          "from calibrate import estimators\n"
          "from calibrate.parts import mlp\n"
          "assert not jax.config.jax_enable_x64\n"
          "rng = np.random.default_rng(0)\n"
          "x = rng.uniform(size=(300, 3)); y = np.tanh(x @ rng.normal(size=(3, 2)))\n"
          "est = estimators.fit(estimators.Kind.NN, x, y, config=mlp.LMConfig(hidden=3, "
          "epochs=3))\n"
          "assert est.net.w1.dtype == np.float64 and est.predict(x).dtype == np.float64\n"
          "assert not jax.config.jax_enable_x64\n"
          "print('ok')\n")
  out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
  assert out.stdout.strip() == "ok", out.stderr


def test_no_module_sets_numpy_print_options_globally():
  for path in _modules().values():
    assert "np.set_printoptions" not in path.read_text(), path


def test_every_physical_parameter_has_its_source_in_the_physics_page():
  import dataclasses as dc

  from models.footpad import FootpadParams
  from models.shell import ShellParams
  from sim.footpad.sensor_chain import AdcConfig
  from sim.shell.photointerrupter import Photointerrupter
  page = (ROOT / "docs" / "physics.md").read_text()
  for cls in (FootpadParams, AdcConfig, ShellParams, Photointerrupter):
    for f in dc.fields(cls):
      assert f"`{f.name}`" in page, f"{cls.__name__}.{f.name} is missing from docs/physics.md"


def test_every_document_a_source_names_is_in_the_repository():
  """A user who installs the project can open every document its code and docs cite."""
  import re
  cited = set()
  for path in list(_modules().values()) + [ROOT / "README.md", ROOT / "docs" / "physics.md"]:
    cited |= {(path, name) for name in re.findall(r"[\w./-]+\.md\b", path.read_text())}
  from benchmarks import outputs
  missing = [(str(p.relative_to(ROOT)), n) for p, n in cited
             if not (ROOT / n).exists() and not (p.parent / n).exists()
             and n.rsplit("/", 1)[-1] != outputs.TABLE]  # what a run writes
  assert not missing, missing


def test_families_stand_alone():
  """A model family (calibrate/parts/*.py) imports the parts' base, other families and the C
  emitter only: nothing of the composites, the fits, the file format or the command line, so
  a new family is one file and one registry line (calibrate.parts.FAMILIES)."""
  from calibrate import parts
  allowed = {"calibrate.parts", "calibrate.parts.base", "calibrate.cexport.emitter"} | {
      module for module, _ in parts.FAMILIES.values()}
  families = [m for m in GRAPH if m.startswith("calibrate.parts.") and m != "calibrate.parts.base"]
  assert {module for module, _ in parts.FAMILIES.values()} <= set(families)
  for m in families:
    wrong = sorted(d for d in GRAPH[m] if d.startswith("calibrate") and d not in allowed)
    assert not wrong, f"{m} imports {wrong}"


def test_no_function_of_calibrate_runs_past_sixty_lines():
  """calibrate/ is what users run on their own rigs: every function reads on one screen."""
  long = []
  for name, path in _modules().items():
    if name.split(".")[0] == "calibrate":
      for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.FunctionDef) and node.end_lineno - node.lineno >= 60:
          long.append(f"{name}.{node.name}: {node.end_lineno - node.lineno + 1} lines")
  assert not long, long
