import os
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
# Keep test recordings out of the user's cache; finite-element kernels are shared.
os.environ.setdefault("TESTBENCH_CACHE", str(pathlib.Path.home() / ".cache" / "footpad-testbench-tests"))
# Offscreen rendering: MuJoCo picks its GL backend on first import, so choose it first.
from sim import render  # noqa: E402,F401  (sets MUJOCO_GL)
