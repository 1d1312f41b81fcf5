"""Shared fixtures: the quick protocols' recordings, built once per session whichever test asks
first (from the test cache, or simulated there), and the `slow` marker's meaning."""

import os
import pathlib
import shutil
import tempfile

import pytest

from util import blas

blas.pin()  # set here too, before the workers start: they inherit it before NumPy loads

# Keep test recordings out of the user's cache; finite-element kernels are shared.
os.environ.setdefault("TESTBENCH_CACHE", str(pathlib.Path.home() / ".cache" / "footpad-testbench-tests"))
# Compiled JAX programs shared by the test workers and the commands the tests run, which
# compile the same training steps: a persistent cache in a folder of this run's own (set
# before JAX is imported, read by every process started below).
_JAX_CACHE = None if "JAX_COMPILATION_CACHE_DIR" in os.environ else \
    tempfile.mkdtemp(prefix="jax-cache-")
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", _JAX_CACHE or "")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES", "0")
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


def pytest_sessionfinish(session):
  """The run's compilation cache removed once, by the process that made it (not a worker)."""
  if _JAX_CACHE and not hasattr(session.config, "workerinput"):
    shutil.rmtree(_JAX_CACHE, ignore_errors=True)
