"""Effects declare the settings they read and replace; a --set that changes nothing is refused."""

import dataclasses
import pathlib
import re

import numpy as np
import pytest

from sim import settings
from sim.effects import Kind
from sim.footpad import effects as footpad_effects, protocol, scene as footpad, sensor_chain
from sim.shell import effects as shell_effects, photointerrupter, scene as shell
from util import errors

RIGS = {"footpad": (footpad_effects.EFFECTS, protocol.base(True, 0)),
        "shell": (shell_effects.EFFECTS, shell.ShellScene())}
DECLARED = [(rig, e.name, key, how) for rig, (table, _) in RIGS.items()
            for e in table.values()
            for how, keys in (("reads", e.reads), ("replaces", e.replaces)) for key in keys]


def _with(scene, *names):
  return dataclasses.replace(scene, effects=tuple(dict.fromkeys(scene.effects + names)))


def _without(scene, name):
  return dataclasses.replace(scene, effects=tuple(e for e in scene.effects if e != name))


def _value(scene, key):
  """The key's default as --set would type it."""
  from benchmarks.run import _format
  return next(_format(k.default) for k in settings.keys(scene) if k.name == key)


@pytest.mark.parametrize("rig, effect, key, how", DECLARED)
def test_every_declared_key_is_a_setting_of_the_rigs_scene(rig, effect, key, how):
  _, scene = RIGS[rig]
  assert key in {k.name for k in settings.keys(scene)}, (effect, key)


REPLACED = [d for d in DECLARED if d[3] == "replaces"]


def test_the_footpad_protocol_replaces_the_coulomb_coefficient():
  assert ("footpad", "pressure_friction", "params.friction", "replaces") in REPLACED


@pytest.mark.parametrize("rig, effect, key, how", REPLACED)
def test_a_replaced_setting_is_refused_naming_the_effect(rig, effect, key, how):
  _, scene = RIGS[rig]
  on = _with(scene, "friction", effect) if rig == "footpad" else _with(scene, effect)
  with pytest.raises(errors.SettingError, match=f"{key}=.* changes nothing: the effect {effect} "
                                                f"replaces it"):
    settings.apply(on, {key: _value(on, key)})
  off = _without(on, effect)
  assert settings.apply(off, {key: _value(off, key)}) == off  # read again once it is off


READ = [d for d in DECLARED if d[3] == "reads"]


@pytest.mark.parametrize("rig, effect, key, how", READ)
def test_a_setting_of_an_effect_that_is_off_is_refused_naming_it(rig, effect, key, how):
  _, scene = RIGS[rig]
  readers = [e.name for e in RIGS[rig][0].values() if key in e.reads]
  off = scene
  for name in readers:
    off = _without(off, name)
  if rig == "footpad":  # pressure_friction and stick_slip need friction
    off = _without(_without(off, "pressure_friction"), "stick_slip") if "friction" in readers \
        else off
  with pytest.raises(errors.SettingError, match=f"only the effect .*{effect}.* reads it"):
    settings.apply(off, {key: _value(off, key)})
  on = _with(off, "friction", effect) if rig == "footpad" else _with(off, effect)
  settings.apply(on, {key: _value(on, key)})


def test_the_cli_refuses_the_dead_coulomb_coefficient_in_one_line(capsys):
  from benchmarks import run as cli
  assert cli.main(["asterisk_path", "--quick", "--check", "--set", "params.friction=0.8"]) == 2
  err = capsys.readouterr().err.strip()
  assert "\n" not in err and "pressure_friction" in err and err.startswith("error:")


def test_the_thirion_coefficient_set_by_key_changes_the_recorded_counts():
  """At 0.3 mm (a shallow depth of the paper's, where elements reach their static limit) the
  coefficient of Thirion's law moves the counts; the identity check: the same value twice
  gives the same bytes."""
  base = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.0003,),
                              effects=("friction", "pressure_friction"), seed=3)
  recs = {mu0: footpad.simulate(settings.apply(base, {"params.friction_mu0": mu0}))[0]
          for mu0 in ("1.2", "2.5")}
  again = footpad.simulate(settings.apply(base, {"params.friction_mu0": "1.2"}))[0]
  assert again.counts.tobytes() == recs["1.2"].counts.tobytes()
  diff = np.abs(recs["1.2"].counts - recs["2.5"].counts).max()
  assert diff > 1.0, diff  # counts, not float noise


CHAINS = {"footpad": (footpad_effects.EFFECTS, sensor_chain.PRESSURE_STEPS
                      + sensor_chain.COUNT_STEPS + sensor_chain.WRENCH_STEPS),
          "shell": (shell_effects.EFFECTS, photointerrupter.STEPS)}


@pytest.mark.parametrize("rig", CHAINS)
def test_every_signal_step_stands_for_a_declared_signal_effect(rig):
  table, steps = CHAINS[rig]
  for step in steps:
    for e in step.effects:
      assert table.get(e.name) is e and e.kind is Kind.SIGNAL, (rig, e.name)


def test_no_code_branches_on_an_effect_by_its_name():
  """Effects are branched on as declared objects (a misspelt name fails at import, where
  `"frction" in effects` would be silently false)."""
  names = set(footpad_effects.EFFECTS) | set(shell_effects.EFFECTS)
  pattern = re.compile(r"""["'](%s)["']\s+(not\s+)?in\b""" % "|".join(names))
  root = pathlib.Path(__file__).resolve().parents[1]
  hits = [f"{p.relative_to(root)}:{i}" for top in ("sim", "models", "benchmarks")
          for p in (root / top).rglob("*.py")
          for i, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
  assert not hits, hits


def test_an_effect_that_needs_another_is_refused_without_it():
  scene = dataclasses.replace(protocol.base(True, 0), effects=("pressure_friction",))
  with pytest.raises(errors.SettingError, match="pressure_friction together with friction"):
    scene.validate()
