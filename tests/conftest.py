"""Shared fixtures: the quick protocols' recordings, built once per session whichever test asks
first (from the test cache, or simulated there), and the `slow` marker's meaning."""

import os
import pathlib

import pytest

# Keep test recordings out of the user's cache; finite-element kernels are shared.
os.environ.setdefault("TESTBENCH_CACHE", str(pathlib.Path.home() / ".cache" / "footpad-testbench-tests"))
# Offscreen rendering: MuJoCo picks its GL backend on first import, so choose it first.
from sim import render  # noqa: E402

render.choose_backend()


@pytest.fixture(scope="session")
def quick_footpad():
  """{"train", "test"}: the footpad's quick protocol at seed 0 (what `asterisk_path --quick`
  and the shipped CSV examples use)."""
  from sim.footpad import protocol, scene
  return {k: scene.generate(s)[0] for k, s in protocol.scenes(protocol.base(True, 0)).items()}


@pytest.fixture(scope="session")
def quick_shell():
  """{"calibration", "test"}: the shell's quick protocol at seed 0."""
  from sim.shell import protocol, scene
  return {k: scene.generate(s)[0]
          for k, s in protocol.scenes(protocol.base(True, 0), True, 0).items()}
