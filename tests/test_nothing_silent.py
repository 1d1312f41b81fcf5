"""Nothing silent: diverged physics, bad settings, damaged files and unwritable outputs each
end in one clear line (or a warning and a repaired cache), never in a traceback or in a zero
exit with wrong numbers."""

import dataclasses
import json
import os
import pathlib
import signal
import subprocess
import sys
import warnings

import mujoco
import numpy as np
import pytest

from benchmarks import executors, outputs, registry, run as cli
from calibrate import estimators
from calibrate.parts import linear
from util import errors, files
from models import footpad as footpad_model
from sim import cache, physics, recording
from sim.footpad import scene as footpad, trajectories
from sim.shell import scene as shell

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _one_line_error(capsys, argv, tmp_path, code=2) -> str:
  """Runs the command; checks its exit code and that stderr is one line, no traceback."""
  argv = argv + ["--no-progress", "--out", str(tmp_path / "out")] if "--out" not in argv else argv
  assert cli.main(argv) == code
  err = capsys.readouterr().err.strip()
  assert "Traceback" not in err
  assert len(err.splitlines()) == (1 if code == 2 else 2), err
  return err


# 1. diverged physics never reports numbers ------------------------------------------------

@pytest.mark.parametrize("argv, named", [
    (["shell_table1", "--quick", "--set", "params.spring_rate=1e4"], "params.spring_rate"),
    (["step_response", "--quick", "--set", "params.spring_rate=3e4"], "params.spring_rate"),
    (["gravity_vectors", "--quick", "--set", "params.spring_rate=1e5"], "params.spring_rate"),
])
def test_springs_too_stiff_for_the_step_are_refused_before_simulating(capsys, tmp_path, argv,
                                                                      named):
  err = _one_line_error(capsys, argv, tmp_path)
  assert named in err and "omega dt" in err and "timestep" in err
  assert not (tmp_path / "out" / "metrics.json").exists()


def test_the_stability_limit_is_the_spring_mass_frequency():
  # one shell on its z spring, the chassis fixed: omega = sqrt(k_z / m)
  board = shell.ShellScene()
  model = board.spec().compile()
  dof = model.jnt_dofadr[model.joint("mount_z").id]
  m = model.body("shell").subtreemass[0]
  k = model.jnt_stiffness[model.joint("mount_z").id]
  dofs = np.array([dof])
  got = physics.check_explicit_springs(model, dofs, "test", "k")
  assert got == pytest.approx(np.sqrt(k / m) * model.opt.timestep, rel=1e-9)


def test_a_run_that_diverges_midway_names_the_scene_and_time(tmp_path, monkeypatch):
  monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT beside the process
  board = shell.ShellScene()
  model = board.spec(base="free", contacts=True).compile()
  data = mujoco.MjData(model)

  def kick(i):
    if i == 150:  # a NaN force on the shell at 0.15 s: MuJoCo warns and resets the state
      data.xfrc_applied[model.body("shell").id, 2] = np.nan

  with pytest.raises(errors.SimulationError,
                     match=r"shell drop: .*diverged.*between t=0\.15 and 0\.16 s"):
    shell.run_frames("shell drop", model, data, 400, 10, kick)


def test_a_cnc_that_does_not_reach_its_command_is_an_error():
  # the stiffest legal rubber: the servo yields by more than the pad is pressed
  scene = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.0015,), effects=("friction",),
                               params=footpad_model.FootpadParams(youngs_modulus=1e8))
  with pytest.raises(errors.SimulationError, match="CNC missed its command.*params.cnc_kp"):
    footpad.simulate(scene)


def test_the_default_cnc_holds_its_commands():
  scene = footpad.FootpadScene(paths=("x_stroke",), z_levels=(0.0015,), effects=("friction",))
  rec, _ = footpad.simulate(scene)
  target = trajectories.episode("x_stroke", 0.0015, scene.feed, scene.params.timestep,
                                3).target
  held = rec.phase == 1
  assert np.abs(rec.cnc[held] - target[held]).max() < footpad.REACH_FLOOR


# 2. every setting checked ------------------------------------------------------------------

@pytest.mark.parametrize("argv, named", [
    (["asterisk_path", "--quick", "--set", "adc.noise_counts=nan"], "adc.noise_counts"),
    (["asterisk_path", "--quick", "--set", "params.cnc_kp=0"], "params.cnc_kp"),
    (["asterisk_path", "--quick", "--set", "params.density=nan"], "params.density"),
    (["shell_table1", "--quick", "--set", "sensor.a=inf"], "sensor.a"),
    (["shell_table1", "--quick", "--set", "params.spring_rate=-150"], "params.spring_rate"),
    (["reflector_slope_sweep", "--quick", "--set", "sweep.spring_rate=100,-3"],
     "spring_rate"),
])
def test_bad_settings_are_one_line_naming_the_key(capsys, tmp_path, argv, named):
  err = _one_line_error(capsys, argv, tmp_path)
  assert err.startswith("error: ") and named in err


# 3. caches verified and repaired ---------------------------------------------------------

def _truncate(path):
  data = path.read_bytes()
  path.write_bytes(data[:len(data) // 2])


def _flip(path):
  data = bytearray(path.read_bytes())
  for k in range(len(data) // 3, len(data) // 3 + 8):
    data[k] ^= 0xFF
  path.write_bytes(bytes(data))


SMALL_SHELL = shell.ShellScene(frames=300, sessions=1, seed=3)


@pytest.mark.parametrize("damage", ["truncate npz", "flip npz", "edit json field",
                                    "truncate json"])
def test_a_damaged_cached_recording_is_reported_and_regenerated(tmp_path, monkeypatch, damage):
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  first, timing = shell.generate(SMALL_SHELL)
  assert timing is not None
  stem = next((tmp_path / "recordings").glob("*.npz")).with_suffix("")
  if damage == "truncate npz":
    _truncate(stem.with_suffix(".npz"))
  elif damage == "flip npz":
    _flip(stem.with_suffix(".npz"))
  elif damage == "edit json field":
    head = json.loads(stem.with_suffix(".json").read_text())
    head["meta"]["seed"] = 4  # a valid value, not the one the arrays were made with
    stem.with_suffix(".json").write_text(json.dumps(head))
  else:
    _truncate(stem.with_suffix(".json"))
  with pytest.warns(UserWarning, match=f"recording {stem}.*simulating it again"):
    again, timing = shell.generate(SMALL_SHELL)
  assert timing is not None  # simulated, not loaded
  assert again.counts.tobytes() == first.counts.tobytes()
  with warnings.catch_warnings():
    warnings.simplefilter("error")
    _, timing = shell.generate(SMALL_SHELL)  # repaired: a clean hit
  assert timing is None


@pytest.mark.parametrize("damage", ["truncate", "flip", "edit value"])
def test_a_damaged_cached_array_is_reported_and_computed_again(tmp_path, monkeypatch, damage):
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  calls = []

  def compute():
    calls.append(1)
    return np.arange(2000.0).reshape(40, 50)

  first = cache.cached_array("kernels", {"k": 1}, compute)
  path = next((tmp_path / "kernels").glob("*.npz"))
  if damage == "truncate":
    _truncate(path)
  elif damage == "flip":
    _flip(path)
  else:  # a valid file with another array under the old checksum
    with np.load(path) as z:
      digest = z["sha256"]
    np.savez(path, value=first + 1e-9, sha256=digest)
  with pytest.warns(UserWarning, match=f"cached kernels {path} is damaged"):
    again = cache.cached_array("kernels", {"k": 1}, compute)
  assert len(calls) == 2 and np.array_equal(again, first)


def test_an_array_cached_on_other_blas_kernels_is_computed_again(tmp_path, monkeypatch):
  """Other BLAS kernels give other last bits (`util.blas.architecture`): an array cached on
  them is not read on these, nor is a footpad recording; on the same kernels it is."""
  from sim.footpad import scene as footpad
  from util import blas
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  calls = []

  def compute():
    calls.append(1)
    return np.full(3, float(len(calls)))

  here = blas.architecture()
  assert here  # this machine's kernels are known
  key = footpad.cache_key(footpad.FootpadScene())
  cache.cached_array("kernels", {"k": 1}, compute)
  monkeypatch.setattr(blas, "architecture", lambda: "openblas:SkylakeX")
  assert cache.cached_array("kernels", {"k": 1}, compute)[0] == 2.0
  assert footpad.cache_key(footpad.FootpadScene()) != key
  monkeypatch.setattr(blas, "architecture", lambda: here)
  assert cache.cached_array("kernels", {"k": 1}, compute)[0] == 1.0 and len(calls) == 2


@pytest.mark.parametrize("damage", ["truncate", "flip", "edit result"])
def test_a_damaged_finished_point_is_run_again(tmp_path, damage):
  store = executors.PointStore(tmp_path)
  point = {"x": 2.0, "seed": 1}
  store.save(point, {"y": 4.0, "worst": float("inf")})
  assert store.load(point) == {"y": 4.0, "worst": float("inf")}
  path = next(tmp_path.glob("*.json"))
  if damage == "truncate":
    _truncate(path)
  elif damage == "flip":
    _flip(path)
  else:
    path.write_text(path.read_text().replace("4.0", "5.0"))
  with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the edited file warns; the others do not parse
    assert store.load(point) is None


_WRITER = """
import sys, time, pathlib
sys.path.insert(0, {root!r})
from util import files
def slow(f):
  f.write(b"new" * 1000)
  f.flush()
  print("writing", flush=True)
  time.sleep(60)
files.atomic_write(pathlib.Path({path!r}), slow)
"""


def test_a_writer_killed_mid_write_leaves_the_old_file_and_the_next_run_clean(tmp_path):
  target = tmp_path / "metrics.json"
  target.write_text('{"old": true}')
  proc = subprocess.Popen([sys.executable, "-c", _WRITER.format(root=str(ROOT),
                                                                 path=str(target))],
                          stdout=subprocess.PIPE, text=True)
  assert proc.stdout.readline().strip() == "writing"
  os.kill(proc.pid, signal.SIGKILL)
  proc.wait()
  assert json.loads(target.read_text()) == {"old": True}
  orphans = list(tmp_path.glob(f"*{files.TMP_SUFFIX}"))
  assert len(orphans) == 1 and files.writer_pid(orphans[0]) == proc.pid
  assert cache.clean_orphans(tmp_path) == 1
  assert not list(tmp_path.glob(f"*{files.TMP_SUFFIX}"))


def test_a_failed_write_leaves_no_temporary_file(tmp_path):
  def broken(f):
    f.write(b"half")
    raise OSError("disk full")
  with pytest.raises(OSError, match="disk full"):
    files.atomic_write(tmp_path / "x.npz", broken)
  assert list(tmp_path.iterdir()) == []


# 4. outputs checked first ------------------------------------------------------------------

def test_out_that_is_a_file_fails_at_once(capsys, tmp_path):
  (tmp_path / "taken").write_text("x")
  err = _one_line_error(capsys, ["shell_table1", "--quick", "--out", str(tmp_path / "taken")],
                        tmp_path)
  assert "is a file" in err


def test_out_that_cannot_be_created_fails_at_once(capsys, tmp_path):
  (tmp_path / "file").write_text("x")
  err = _one_line_error(capsys, ["shell_table1", "--quick", "--out",
                                 str(tmp_path / "file" / "sub")], tmp_path)
  assert "cannot be written" in err


def test_two_runs_never_share_an_out_folder(capsys, tmp_path):
  holder = subprocess.Popen(
      [sys.executable, "-c", "import sys, time; from util import files; "
       f"files.claim({str(tmp_path / 'out')!r}); print('held', flush=True); time.sleep(30)"],
      stdout=subprocess.PIPE, text=True)
  try:
    assert holder.stdout.readline().strip() == "held"
    err = _one_line_error(capsys, ["shell_table1", "--quick"], tmp_path)
    assert f"in use by another run (process {holder.pid})" in err
  finally:
    holder.kill()  # killed: it never releases, its lock file stays
    holder.wait()
  assert (tmp_path / "out" / files.LOCK).exists()
  lock = files.claim(tmp_path / "out")  # its run is gone: the lock is taken over
  assert (tmp_path / "out" / files.LOCK).read_text() == str(os.getpid())
  lock.release()
  assert not (tmp_path / "out" / files.LOCK).exists()


# 5. one error path ---------------------------------------------------------------------------

def _bench(monkeypatch, fn):
  name = "shell_table2"
  bench = registry.all_benchmarks()[name]
  monkeypatch.setitem(registry._REGISTRY, name, dataclasses.replace(bench, run=fn))
  return name


def test_an_internal_error_says_so_and_saves_its_traceback(capsys, tmp_path, monkeypatch):
  def broken(ctx):
    import math
    return math.log(-1.0)
  name = _bench(monkeypatch, broken)
  err = _one_line_error(capsys, [name, "--quick"], tmp_path, code=3)
  assert "internal error" in err and "math domain error" in err
  saved = tmp_path / "out" / "traceback.txt"
  assert str(saved) in err and "math.log(-1.0)" in saved.read_text()
  assert not (tmp_path / "out" / files.LOCK).exists()


def test_an_internal_error_before_the_run_saves_its_traceback_in_the_cache(capsys, tmp_path,
                                                                           monkeypatch):
  from sim import settings
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path / "cache"))

  def broken(*args):
    raise KeyError("oops")
  monkeypatch.setattr(settings, "apply", broken)
  err = _one_line_error(capsys, ["shell_table2", "--quick"], tmp_path, code=3)
  saved = list((tmp_path / "cache" / "tracebacks").glob("*.txt"))
  assert len(saved) == 1 and str(saved[0]) in err and "KeyError" in saved[0].read_text()


def test_a_user_error_from_deep_inside_is_one_line(capsys, tmp_path, monkeypatch):
  def deep(ctx):
    raise errors.DataError("recording x.npz: counts hold NaN or inf")
  name = _bench(monkeypatch, deep)
  err = _one_line_error(capsys, [name, "--quick"], tmp_path)
  assert err == "error: recording x.npz: counts hold NaN or inf"


# 6. files other tools can read ---------------------------------------------------------------

def _strict_load(text):
  def refuse(token):
    raise AssertionError(f"non-standard JSON token {token}")
  return json.loads(text, parse_constant=refuse)


def test_json_written_is_strict_and_reads_back():
  value = {"a": float("inf"), "b": [float("-inf"), float("nan"), 1.5], "c": np.float64(2.0)}
  text = files.json_text(value)
  assert _strict_load(text)["a"] == "Infinity"
  back = files.from_json(text)
  assert back["a"] == np.inf and back["b"][0] == -np.inf and np.isnan(back["b"][1])


def test_metrics_json_is_strict(capsys, tmp_path):
  argv = ["reflector_slope_sweep", "--quick", "--executor", "serial", "--set",
          "sweep.slope_x=0,0.6", "--set", "sweep.slope_y=0.5", "--set", "confirm=0",
          "--set", "search=false", "--no-progress", "--out", str(tmp_path)]
  assert cli.main(argv) == 0
  metrics = _strict_load((tmp_path / "metrics.json").read_text())
  assert "Infinity" in [r["fom"] for r in metrics["unranked"]]  # rank 5 at slope_x = 0


def test_loaders_refuse_files_that_are_not_theirs(tmp_path):
  rec, _ = shell.generate(SMALL_SHELL, use_cache=False)
  rec.save(tmp_path / "r")
  head = json.loads((tmp_path / "r.json").read_text())
  for change, message in [({"format": "other"}, "not a testbench recording"),
                          ({"version": 99}, "format version 99")]:
    (tmp_path / "r.json").write_text(json.dumps({**head, **change}))
    with pytest.raises(errors.DataError, match=f"{tmp_path / 'r'}.*{message}"):
      recording.Recording.load(tmp_path / "r")
  rng = np.random.default_rng(0)
  v, f = rng.uniform(0, 4000, (300, 6)), rng.normal(size=(300, 3))
  est = estimators.fit(estimators.Kind.LS, v, f)
  est.save(tmp_path / "e.npz")
  with np.load(tmp_path / "e.npz") as z:
    arrays = dict(z)
  meta = json.loads(str(arrays.pop("meta")))
  for change, message in [({"version": 1}, "format version 1"),
                          ({"format": "x"}, "not a testbench estimator")]:
    np.savez(tmp_path / "bad.npz", meta=json.dumps({**meta, **change}), **arrays)
    with pytest.raises(errors.DataError, match=f"bad.npz.*{message}"):
      estimators.Estimator.load(tmp_path / "bad.npz")
  arrays["root/coef"] = arrays["root/coef"] * np.nan
  np.savez(tmp_path / "bad.npz", meta=json.dumps(meta), **arrays)
  with pytest.raises(errors.DataError, match="bad.npz.*(checksum|NaN)"):
    estimators.Estimator.load(tmp_path / "bad.npz")
  _truncate(tmp_path / "e.npz")
  with pytest.raises(errors.DataError, match="e.npz.*cannot be read"):
    estimators.Estimator.load(tmp_path / "e.npz")


# 7. scale-aware numerics ---------------------------------------------------------------------

@pytest.mark.parametrize("unit", [1e-13, 1e-9, 1.0, 1e6])
def test_a_live_channel_in_any_units_is_kept(unit):
  rng = np.random.default_rng(1)
  v = rng.uniform(-1, 1, (500, 3)) * unit
  f = np.column_stack([v[:, 0] / unit + 2 * v[:, 1] / unit, v[:, 2] / unit])
  with warnings.catch_warnings():
    warnings.simplefilter("error")  # no channel may be reported dropped
    fit = linear.fit_linear(v, f)
  assert fit.rank == 4
  np.testing.assert_allclose(fit.predict(v), f, atol=1e-9)


def test_a_constant_channel_in_small_units_is_still_dropped():
  rng = np.random.default_rng(2)
  v = np.column_stack([rng.uniform(-1, 1, 200) * 1e-9, np.full(200, 3e-9)])
  with pytest.warns(UserWarning, match=r"channels \[1\] are constant"):
    fit = linear.fit_linear(v, v[:, :1] * 1e9)
  assert fit.scale[1] == 0
