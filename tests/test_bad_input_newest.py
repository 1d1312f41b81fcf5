"""Bad input on the newest surfaces (merge, tare, multi-file fits, temporal fits, the native
arms), each class through the command a user types: the exit code, the one line, and that
nothing wrong was written."""

from __future__ import annotations

import numpy as np
import pytest

from calibrate import __main__ as cli, csvfile
from tests.test_raw_streams import LAG, _streams


def _run(capsys, argv, code=0):
  """(exit code checked, stdout, stderr) of `python -m calibrate ARGV`."""
  assert cli.main([str(a) for a in argv]) == code
  captured = capsys.readouterr()
  assert "Traceback" not in captured.err
  if code == 2:
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), captured.err
  return captured.out, captured.err


def _write(path, table, time_unit="s", scale=1.0):
  data = table.data.copy()
  data[:, 0] *= scale
  units = (time_unit,) + table.units[1:]
  csvfile.write(path, table.names, data, units)
  return path


# --- units rows are data ---------------------------------------------------------------------

def test_merge_reads_a_reference_stamped_in_milliseconds_as_milliseconds(tmp_path, capsys):
  sensor, reference = _streams()
  _write(tmp_path / "a.csv", sensor)
  _write(tmp_path / "b.csv", reference)
  _write(tmp_path / "b_ms.csv", reference, "ms", 1e3)
  _run(capsys, ["merge", tmp_path / "a.csv", tmp_path / "b.csv", "--lag", LAG,
                "--out", tmp_path / "s"])
  _run(capsys, ["merge", tmp_path / "a.csv", tmp_path / "b_ms.csv", "--lag", LAG,
                "--out", tmp_path / "ms"])
  want, got = csvfile.read(tmp_path / "s" / "a.csv"), csvfile.read(tmp_path / "ms" / "a.csv")
  assert got.names == want.names and got.data.shape == want.data.shape
  np.testing.assert_allclose(got.data, want.data, rtol=1e-12, atol=1e-12)


def test_a_time_unit_the_reader_does_not_know_is_refused_naming_it(tmp_path, capsys):
  sensor, reference = _streams()
  _write(tmp_path / "a.csv", sensor)
  _write(tmp_path / "b.csv", reference, "ticks")
  _, err = _run(capsys, ["merge", tmp_path / "a.csv", tmp_path / "b.csv", "--out",
                         tmp_path / "m"], 2)
  assert "b.csv: the time column 'time' is in 'ticks'" in err and "ms" in err
  assert not (tmp_path / "m" / "a.csv").exists()


def _example(capsys, tmp_path):
  _run(capsys, ["example", tmp_path / "ex"])
  return tmp_path / "ex"


def test_a_fit_over_files_whose_units_disagree_is_refused_naming_both(tmp_path, capsys):
  ex = _example(capsys, tmp_path)
  t = csvfile.read(ex / "train.csv")
  volts = tuple("V" if n == "p3" else u for n, u in zip(t.names, t.units))
  csvfile.write(tmp_path / "volts.csv", t.names, t.data / 1000, volts)
  _, err = _run(capsys, ["fit", "--csv", ex / "train.csv", tmp_path / "volts.csv", "--inputs",
                         "p*", "--targets", "Fx,Fy,Fz", "--method", "ls", "--out",
                         tmp_path / "e.npz"], 2)
  assert "volts.csv: its column 'p3' is in 'V'" in err and "train.csv's in 'counts'" in err
  assert not (tmp_path / "e.npz").exists()


def test_files_stamped_in_seconds_and_in_milliseconds_fit_as_one_clock(tmp_path, capsys):
  ex = _example(capsys, tmp_path)
  t = csvfile.read(ex / "train.csv")
  half = len(t.data) // 2
  csvfile.write(tmp_path / "a.csv", t.names, t.data[:half], t.units)
  ms = t.data[half:].copy()
  ms[:, 0] *= 1e3
  csvfile.write(tmp_path / "b.csv", t.names, ms, ("ms",) + t.units[1:])
  csvfile.write(tmp_path / "b_s.csv", t.names, t.data[half:], t.units)
  for other, out in (("b.csv", "ms.npz"), ("b_s.csv", "s.npz")):
    _run(capsys, ["fit", "--csv", tmp_path / "a.csv", tmp_path / other, "--inputs", "p*",
                  "--targets", "Fx,Fy,Fz", "--method", "ls", "--history", "0.05",
                  "--no-progress", "--out", tmp_path / out])
  from calibrate import estimators
  a, b = (estimators.Estimator.load(tmp_path / n) for n in ("ms.npz", "s.npz"))
  x = t.data[:300, 1:7]
  np.testing.assert_allclose(a.predict(x), b.predict(x), rtol=1e-9)


# --- the tare checks what it tares ----------------------------------------------------------

def test_a_tare_window_that_carries_load_is_a_warning_with_its_size(tmp_path, capsys):
  ex = _example(capsys, tmp_path)  # train.csv presses 0-243 N in its first 0.8 s
  out, _ = _run(capsys, ["fit", "--csv", ex / "train.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--tare", "0.8", "--out",
                         tmp_path / "e.npz"])
  line = next(s for s in out.splitlines() if "not at rest" in s)
  assert line.startswith("warning: ") and "the first 0.8 s of each recording" in line
  assert "Fz spans" in line and "of its range" in line


def test_the_readme_streams_tare_is_at_rest_and_says_nothing(tmp_path, capsys):
  _run(capsys, ["example", tmp_path / "s", "--streams"])
  pairs = [tmp_path / "s" / f"train{k}_{side}.csv" for k in (1, 2, 3)
           for side in ("sensor", "reference")]
  _run(capsys, ["merge", *pairs, "--out", tmp_path / "m"])
  out, _ = _run(capsys, ["fit", "--csv", tmp_path / "m" / "*.csv", "--inputs", "p*",
                         "--targets", "F_x [N],F_y [N],F_z [N]", "--method", "ls", "--tare",
                         "0.8", "--out", tmp_path / "e.npz"])
  assert "not at rest" not in out and "tare: each input" in out


def test_a_contact_flag_with_other_values_is_refused_for_the_tare(tmp_path, capsys):
  ex = _example(capsys, tmp_path)
  t = csvfile.read(ex / "train.csv")
  flag = np.clip(np.floor(t.data[:, -1] / 40), 0, 5)  # 0..5 by load, as in the audit
  csvfile.write(tmp_path / "f.csv", t.names + ("contact",), np.column_stack([t.data, flag]),
                t.units + ("",))
  _, err = _run(capsys, ["fit", "--csv", tmp_path / "f.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--tare-column", "contact", "--out",
                         tmp_path / "e.npz"], 2)
  assert "--tare-column contact holds 2, 3, 4, 5" in err and "0 (unloaded) or 1" in err
  assert not (tmp_path / "e.npz").exists()


@pytest.mark.parametrize("value, message", [
    ("1e9", "allowed seconds in (0, 1e6)"), ("nan", "allowed seconds in (0, 1e6)"),
    ("inf", "allowed seconds in (0, 1e6)")])
def test_a_tare_window_out_of_range_names_the_real_limit(tmp_path, capsys, value, message):
  ex = _example(capsys, tmp_path)
  _, err = _run(capsys, ["fit", "--csv", ex / "train.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--tare", value, "--out",
                         tmp_path / "e.npz"], 2)
  assert message in err


# --- wraps are reported whether or not --unwrap is given ------------------------------------

def test_two_register_wraps_without_unwrap_are_reported(tmp_path, capsys):
  """A 12-bit register whose deepest press peaks just over its top: it wraps there and back
  within a few samples, twice in all; the fit without --unwrap names both."""
  ex = _example(capsys, tmp_path)
  t = csvfile.read(ex / "train.csv")
  d = t.data.copy()
  k = t.names.index("p6")  # the channel that never reaches the ADC rail
  # the highest level that one run of samples alone exceeds: the register's top sits there
  def one_run(v):
    above = d[:, k] > v
    return not above[0] and not above[-1] and np.count_nonzero(np.diff(above.astype(int))
                                                                == 1) == 1
  top = next(v for v in np.unique(d[:, k])[::-1] if one_run(v))
  d[:, k] = np.mod(d[:, k] + (4095 - top), 4096)
  steps = np.flatnonzero(np.abs(np.diff(d[:, k])) > 2048)
  assert len(steps) == 2
  csvfile.write(tmp_path / "w.csv", t.names, d, t.units)
  out, _ = _run(capsys, ["fit", "--csv", tmp_path / "w.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--out", tmp_path / "e.npz"])
  line = next(s for s in out.splitlines() if "one-sample jumps" in s)
  assert f"p6 2 (line {t.lines[steps[0] + 1]}, {t.lines[steps[1] + 1]})" in line
  assert "--unwrap" in line


# --- groups of one sample each --------------------------------------------------------------

def test_groups_of_one_row_each_are_a_warning_that_says_what_the_split_means(tmp_path, capsys):
  ex = _example(capsys, tmp_path)
  t = csvfile.read(ex / "train.csv")
  trial = np.arange(len(t.data), dtype=float)  # a value unique to every row
  csvfile.write(tmp_path / "g.csv", t.names + ("trial",), np.column_stack([t.data, trial]),
                t.units + ("",))
  out, _ = _run(capsys, ["fit", "--csv", tmp_path / "g.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--group", "trial", "--out",
                         tmp_path / "e.npz"])
  line = next(s for s in out.splitlines() if s.startswith("warning: --group trial"))
  assert f"{len(t.data)} groups of a median 1 row(s)" in line and "single samples" in line
  # a label per press (whole presses, longer than the autocorrelation) says nothing
  press = np.cumsum(np.r_[0, np.abs(np.diff(t.data[:, 0])) > 0.5] + (np.arange(len(t.data))
                                                                    % 400 == 0))
  csvfile.write(tmp_path / "p.csv", t.names + ("trial",), np.column_stack([t.data, press]),
                t.units + ("",))
  out, _ = _run(capsys, ["fit", "--csv", tmp_path / "p.csv", "--inputs", "p*", "--targets",
                         "Fx,Fy,Fz", "--method", "ls", "--group", "trial", "--out",
                         tmp_path / "e2.npz"])
  assert "warning: --group" not in out


# --- every command with an --out folder takes the benchmark's lock --------------------------

@pytest.mark.parametrize("command", ["evaluate", "merge", "export", "example"])
def test_a_folder_another_run_holds_is_refused_and_left_alone(tmp_path, capsys, command):
  import os
  import subprocess
  import sys
  out = tmp_path / "out"
  holder = subprocess.Popen(
      [sys.executable, "-c", "import sys, time; from util import files; "
       f"files.claim({str(out)!r}); print('held', flush=True); time.sleep(60)"],
      stdout=subprocess.PIPE, text=True, cwd=os.getcwd())
  try:
    assert holder.stdout.readline().strip() == "held"
    ex = _example(capsys, tmp_path)
    _run(capsys, ["fit", "--csv", ex / "train.csv", "--inputs", "p*", "--targets",
                  "Fx,Fy,Fz", "--method", "ls", "--out", tmp_path / "e.npz"])
    sensor, reference = _streams()
    argv = {"evaluate": ["evaluate", tmp_path / "e.npz", "--csv", ex / "test.csv", "--out", out],
            "merge": ["merge", _write(tmp_path / "a.csv", sensor),
                      _write(tmp_path / "b.csv", reference), "--out", out],
            "export": ["export", tmp_path / "e.npz", "--c", out],
            "example": ["example", out]}[command]
    _, err = _run(capsys, argv, 2)
    assert f"{out} is in use by another run (process {holder.pid})" in err
    assert sorted(p.name for p in out.iterdir()) == [".run.lock"]  # nothing of this run's
  finally:
    holder.kill()
    holder.wait()


# --- a cache that is not a writable folder --------------------------------------------------

@pytest.mark.parametrize("where, message", [
    ("file", "is a file: point TESTBENCH_CACHE at a folder"),
    ("under a file", "cannot be written (Not a directory)"),
])
def test_a_cache_that_is_not_a_writable_folder_is_named_before_any_work(
    tmp_path, capsys, monkeypatch, where, message):
  from benchmarks import run as bench
  if where == "file":
    cache = tmp_path / "cache.txt"
    cache.write_text("not a folder")
  else:  # a path no one can make (root writes into read-only folders)
    (tmp_path / "cache.txt").write_text("not a folder")
    cache = tmp_path / "cache.txt" / "cache"
  monkeypatch.setenv("TESTBENCH_CACHE", str(cache))
  assert bench.main(["collisions", "--quick", "--no-progress", "--out",
                     str(tmp_path / "out")]) == 2
  err = capsys.readouterr().err.strip()
  assert "Traceback" not in err and len(err.splitlines()) == 1
  assert err.startswith(f"error: TESTBENCH_CACHE {cache}") and message in err
  assert not (tmp_path / "out").exists()


# --- the loader checks every array's shape against the others --------------------------------

def _family(name):
  from calibrate import estimators, splits
  from calibrate.fitted import Kind
  from calibrate.parts import deep, gru, mlp
  rng = np.random.default_rng(0)
  x = rng.uniform(500, 3500, (400, 4))
  y = np.column_stack([x @ [1e-3, 2e-3, 0, 1e-3], np.tanh((x[:, 0] - 2000) / 500),
                       x[:, 1] * 1e-3])
  net = mlp.LMConfig(hidden=4, epochs=3)
  fit = {
      "LS": lambda: estimators.fit(Kind.LS, x, y),
      "POLY": lambda: estimators.fit(Kind.POLY, x, y, cross=True, ridge=1e-3),
      "POLY-CH": lambda: estimators.fit(Kind.POLY, x, y),
      "NN": lambda: estimators.fit(Kind.NN, x, y, config=net),
      "LSANN": lambda: estimators.fit(Kind.LSANN, x, y, config=net),
      "LSGP": lambda: estimators.fit(Kind.LSGP, x, y),
      "MLP": lambda: estimators.fit(Kind.MLP, x, y, deep=deep.DeepConfig(epochs=3),
                                    layers=(8,)),
      "LS+MEM": lambda: estimators.fit_temporal(Kind.LS, x, y, 0.01, taus=(0.05,)),
      # the file's arrays are what is checked, not how well the network learned
      "GRU": lambda: estimators.fit_temporal(Kind.GRU, x, y, 0.01, taus=(0.05,), folds=2,
                                             segments=np.repeat(np.arange(4), 100),
                                             gru=gru.GRUConfig(hidden=4, steps=20, check=10,
                                                               window=64, burn_in=16)),
      "AUTO": lambda: estimators.fit_auto(x, y, splits.groups(400, "blocks", block=40), 2,
                                          candidates=("LS", "POLY-CH", "NN"), config=net)[0],
  }[name]
  return fit(), x


@pytest.mark.parametrize("family", [
    "LS", "POLY", "POLY-CH", "NN", "LSANN", "LSGP", "LS+MEM",
    pytest.param("MLP", marks=pytest.mark.slow), pytest.param("GRU", marks=pytest.mark.slow),
    pytest.param("AUTO", marks=pytest.mark.slow)])
def test_an_array_of_the_wrong_shape_is_refused_by_the_loader(tmp_path, capsys, family):
  """Every numeric array of the file a row short, or a scalar, re-signed: `predict` refuses
  the file in one line naming it, and writes nothing (the arrays that may legitimately be
  shorter excepted: the offsets of one group fewer, the interval's reference rows one
  fewer)."""
  from util import files
  est, x = _family(family)
  est.save(tmp_path / "e.npz")
  csvfile.write(tmp_path / "x.csv", [f"in{k}" for k in range(4)], x[:20])
  with np.load(tmp_path / "e.npz") as z:
    arrays = {k: z[k] for k in z.files}
  meta = files.from_json(str(arrays.pop("meta")))
  tried = 0
  for key, a in arrays.items():
    if a.dtype.kind not in "fi" or a.ndim == 0:
      continue
    shorter = key.endswith(("interval_offsets", "interval_reference"))
    for bad in ([a[:-1]] if len(a) > 1 and not shorter else []) \
        + [np.float64(1.0)]:
      changed = {**arrays, key: bad}
      signed = {**meta, "sha256": files.array_digest(changed)}
      np.savez(tmp_path / "bad.npz", meta=files.json_text(signed), **changed)
      _, err = _run(capsys, ["predict", tmp_path / "bad.npz", "--csv", tmp_path / "x.csv",
                             "--out", tmp_path / "p.csv"], 2)
      assert "bad.npz" in err, (key, err)
      assert not (tmp_path / "p.csv").exists()
      tried += 1
  assert tried >= 4


# --- errors name the real cause, with the limit that applies ---------------------------------

@pytest.mark.parametrize("case, message", [
    ("lag nan", "--lag nan is out of range: allowed seconds in [-60, 60]"),
    ("lag inf", "--lag inf is out of range: allowed seconds in [-60, 60]"),
    ("max-gap nan", "--max-gap nan is out of range"),
    ("one-row reference", "one_ref.csv: 1 data row(s): a stream needs two or more"),
    ("track-drift inf", "--track-drift inf is out of range: allowed a finite force > 0"),
    ("nn on one row", "0 training samples (1 held out for validation)"),
    ("interval without folds", "fit it again with --folds 2 or more"),
])
def test_a_mistake_is_blamed_on_what_was_wrong(tmp_path, capsys, case, message):
  ex = _example(capsys, tmp_path)
  _run(capsys, ["example", tmp_path / "st", "--streams"])
  sensor, reference = tmp_path / "st" / "train1_sensor.csv", tmp_path / "st" / "train1_reference.csv"
  for src, dst in ((reference, "one_ref.csv"), (ex / "train.csv", "one.csv")):
    t = csvfile.read(src)
    csvfile.write(tmp_path / dst, t.names, t.data[:1], t.units)
  data = ["--inputs", "p*", "--targets", "Fx,Fy,Fz"]
  if case == "interval without folds":
    _run(capsys, ["fit", "--csv", ex / "train.csv", *data, "--method", "ls", "--folds", "0",
                  "--out", tmp_path / "e0.npz"])
  argv = {
      # refused by value, before the (missing) files are read
      "lag nan": ["merge", sensor, tmp_path / "no.csv", "--lag", "nan", "--out", tmp_path / "m"],
      "lag inf": ["merge", sensor, tmp_path / "no.csv", "--lag", "inf", "--out", tmp_path / "m"],
      "max-gap nan": ["merge", sensor, tmp_path / "no.csv", "--max-gap", "nan", "--out",
                      tmp_path / "m"],
      "one-row reference": ["merge", sensor, tmp_path / "one_ref.csv", "--out", tmp_path / "m"],
      "track-drift inf": ["fit", "--csv", tmp_path / "missing.csv", *data, "--method", "ls",
                          "--track-drift", "inf", "--out", tmp_path / "e.npz"],  # unread
      "nn on one row": ["fit", "--csv", tmp_path / "one.csv", *data, "--method", "nn",
                        "--split", "samples", "--out", tmp_path / "e.npz"],
      "interval without folds": ["predict", tmp_path / "e0.npz", "--csv", ex / "test.csv",
                                 "--interval", "0.95", "--out", tmp_path / "p.csv"],
  }[case]
  _, err = _run(capsys, argv, 2)
  assert message in err
  assert not (tmp_path / "m").exists() or not any((tmp_path / "m").glob("*.csv"))
  assert not (tmp_path / "e.npz").exists() and not (tmp_path / "p.csv").exists()


# --- files are written with the process's umask ----------------------------------------------

def test_written_files_take_the_umask_not_0600(tmp_path):
  import os
  import subprocess
  import sys
  script = ("import os; os.umask(0o022); from util import files; "
            f"files.write_text({str(tmp_path / 'a.txt')!r}, 'x'); os.umask(0o077); "
            "files._UMASK = None; "
            f"files.write_text({str(tmp_path / 'b.txt')!r}, 'y')")
  subprocess.run([sys.executable, "-c", script], check=True, cwd=os.getcwd())
  assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o644
  assert (tmp_path / "b.txt").stat().st_mode & 0o777 == 0o600



# --- a sweep stops within seconds -------------------------------------------------------------

def _slow_point(point):
  import time
  time.sleep(point["seconds"])
  return point["seconds"]


@pytest.mark.slow  # spawns two worker processes
def test_an_interrupted_sweep_stops_without_running_its_queued_points():
  """Ctrl-C at the first finished point of a sweep of 10 points of 4 s on 2 workers: the
  sweep stops at once (its queued points cancelled, the running ones ended), not after the
  ~16 s the queue would take."""
  import time
  from benchmarks import executors
  points = [{"seconds": 0.5 if k == 0 else 4.0, "seed": k} for k in range(10)]

  def progress(done, total):
    if done:
      raise KeyboardInterrupt
  t0 = time.perf_counter()
  with pytest.raises(KeyboardInterrupt):
    executors.sweep(_slow_point, points, executors.ExecutorSpec(workers=2), progress=progress)
  assert time.perf_counter() - t0 < 5.0  # spawning and the first point; the queue: ~18 s


# --- the native arms: a fallback is said, a damaged library is built again -------------------

def test_a_damaged_cached_library_is_built_again(tmp_path):
  import os
  import subprocess
  import sys
  from util import native
  if native.compiler() is None:
    pytest.skip("no C compiler on this machine")
  source = tmp_path / "seven.c"
  source.write_text("int seven(void) { return 7; }\n")
  load = ("import sys, pathlib; from util import native; "
          f"lib, why = native.shared_library(pathlib.Path({str(source)!r})); "
          "print(lib.seven() if lib else why)")
  env = dict(os.environ, TESTBENCH_CACHE=str(tmp_path / "cache"))

  def run():  # each load its own process, as each run is (a loaded library stays mapped)
    return subprocess.run([sys.executable, "-c", load], env=env, capture_output=True,
                          text=True, cwd=os.getcwd()).stdout.strip()
  assert run() == "7"
  (built,) = (tmp_path / "cache" / "native").glob("seven-*.so")
  built.write_bytes(built.read_bytes()[:100])  # a cut copy
  assert run() == "7"  # built again, not a fallback for every later run
  assert built.stat().st_size > 100


@pytest.mark.parametrize("cc, said", [("/bin/false", "could not compile"),
                                      ("", "no C compiler found")])
def test_an_unusable_compiler_is_a_fallback_with_its_reason(tmp_path, monkeypatch, cc, said):
  from util import native
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path / "cache"))
  monkeypatch.setenv("CC", cc)
  source = tmp_path / "seven.c"
  source.write_text("int seven(void) { return 7; }\n")
  lib, why = native.shared_library(source)
  assert lib is None and said in why


def test_a_footpad_run_says_how_its_arms_are_integrated(monkeypatch):
  from benchmarks import run as bench
  from models import footpad
  monkeypatch.setattr(footpad, "_arm_state", ("dcmotor", "/bin/false could not compile it"))
  assert bench.arm_integration(("footpad", "data")) == {
      "integration": "dcmotor", "why": "/bin/false could not compile it"}
  assert bench.arm_integration(("shell",)) is None


def test_a_footpad_run_records_its_arms_in_the_manifest(tmp_path, capsys, quick_footpad):
  """Through the command: the manifest says how the arms were integrated, and a fallback is
  one warning line in the report (which of the two this machine gives)."""
  import json
  from benchmarks import run as bench
  from models import footpad
  assert bench.main(["footpad_dataset", "--quick", "--no-progress", "--out",
                     str(tmp_path / "out")]) == 0
  out = capsys.readouterr().out
  kind, why = footpad.arm_dynamics()
  manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
  assert manifest["maxwell_arms"] == {"integration": kind, "why": why}
  warned = [s for s in out.splitlines() if s.startswith("warning: the footpad's Maxwell arms")]
  assert len(warned) == (kind != "native")


# --- a path's samples are bounded before simulation -------------------------------------------

def test_a_path_of_too_many_tiny_moves_is_refused_before_any_work(tmp_path, capsys):
  from benchmarks import run as bench
  from sim.footpad import trajectories
  lines = ["G21", "G1 Z-0.5 F60"] + [f"G1 X{(k + 1) * 0.001:.3f} F6"
                                     for k in range(trajectories.MAX_WAYPOINTS)]
  (tmp_path / "p.gcode").write_text("\n".join(lines) + "\n")
  assert bench.main(["asterisk_path", "--quick", "--no-progress", "--set",
                     f"custom_path={tmp_path / 'p.gcode'}", "--out", str(tmp_path / "out")]) == 2
  err = capsys.readouterr().err.strip()
  assert len(err.splitlines()) == 1 and "allowed at most 100,000" in err
  assert not (tmp_path / "out" / "metrics.csv").exists()


def test_a_path_is_refused_when_its_steps_would_outlast_the_limit():
  """One step per move at least: 50,000 moves of 1 um at a 0.1 s time step simulate 5000 s
  though the path travels 0.5 s."""
  from sim.footpad import trajectories
  from util import errors
  n = 50_000
  points = np.column_stack([np.arange(n) * 1e-6, np.zeros(n), np.full(n, -5e-4)])
  path = trajectories.Waypoints(points, np.full(n, 1e-4), "custom:tiny")
  with pytest.raises(errors.DataError, match=r"49,999 time steps of 0.1 s .*allowed at most "
                                             r"3600 s"):
    trajectories.waypoint_episode(path, 0.1)
  assert len(trajectories.waypoint_episode(path, 1e-3).target) >= n  # 50 s: allowed
