"""Bad input on the newer surfaces (python -m calibrate, python -m sim.render, custom CNC
paths, design sweeps, the C export), through their real entry points: each case ends in one
`error:` line (exit 2), a warning, or the correct result; never a traceback, a zero exit with
wrong output, or lost work."""

import re

import numpy as np
import pytest

from sim.footpad import trajectories as tr
from util import errors


def _path(tmp_path, text, suffix=".gcode"):
  p = tmp_path / f"p{suffix}"
  p.write_text(text)
  return tr.read_path(str(p))


# --- G-code words that change the motion are honoured or refused -------------------------

def test_a_quarter_arc_runs_on_its_circle_to_its_end(tmp_path):
  # from (2, 0) anticlockwise about the origin to (0, 2)
  w = _path(tmp_path, "G1 X2 Y0 F600\nG3 X0 Y2 I-2 J0\n")
  arc = w.points[2:] * 1e3
  np.testing.assert_allclose(np.hypot(arc[:, 0], arc[:, 1]), 2.0, atol=1e-9)
  np.testing.assert_allclose(arc[-1], [0, 2, 0], atol=1e-12)
  assert np.all(np.diff(np.arctan2(arc[:, 1], arc[:, 0])) > 0)  # anticlockwise
  assert len(arc) == 45  # 90 degrees in chords of at most 2


def test_a_clockwise_full_circle_comes_back_to_its_start(tmp_path):
  w = _path(tmp_path, "G1 X2 F600\nG2 X2 Y0 I-2 J0\n")
  arc = w.points[2:] * 1e3
  assert len(arc) == 180
  np.testing.assert_allclose(np.hypot(arc[:, 0], arc[:, 1]), 2.0, atol=1e-9)
  np.testing.assert_allclose(arc[-1], [2, 0, 0], atol=1e-12)
  assert arc[0][1] < 0  # clockwise from (2, 0) goes to negative y first


def test_relative_moves_add_up(tmp_path):
  w = _path(tmp_path, "G91\nG1 X2 F300\nG1 X2\nG1 Z-0.5\nG90\nG1 X0\n")
  np.testing.assert_allclose(w.points * 1e3, [[0, 0, 0], [2, 0, 0], [4, 0, 0], [4, 0, -0.5],
                                               [0, 0, -0.5]], atol=1e-12)


def test_compact_words_read_like_spaced_ones_and_motion_is_modal(tmp_path):
  a = _path(tmp_path, "G1X2Y1F300\nX-1\nG0Z1\n")
  b = _path(tmp_path, "G1 X2 Y1 F300\nG1 X-1\nG0 Z1\n")
  np.testing.assert_allclose(a.points, b.points)
  np.testing.assert_allclose(a.feeds, b.feeds)
  np.testing.assert_allclose(a.points[2] * 1e3, [-1, 1, 0])


def test_a_dwell_holds_the_point_for_its_time(tmp_path):
  plain = tr.waypoint_episode(_path(tmp_path, "G1 X1 F60\nG1 X0\n"), 0.001)
  held = tr.waypoint_episode(_path(tmp_path, "G1 X1 F60\nG4 P0.5\nG1 X0\n"), 0.001)
  assert len(held.target) - len(plain.target) == 500
  at_end = np.all(np.isclose(held.target, [0.001, 0, 0]), axis=1)
  assert at_end.sum() == 501  # reached, then held 0.5 s at 1 kHz


@pytest.mark.parametrize("text, message", [
    ("G1 X1 F60\nG2 X0 Y1 R1\n", "line 2: an arc needs its centre as I, J"),
    ("G1 X1 F60\nG3 X0 Y3 I-1 J0\n", "line 2: the arc's end is"),
    ("G28\n", "line 1: G28 is not supported"),
    ("G92 X0\n", "line 1: G92 is not supported"),
    ("G18\nG1 X1 F60\n", "line 1: G18 is not supported"),
    ("G93 G1 X1 F60\n", "line 1: G93 is not supported"),
    ("G1 X1 F60\nG4 X2\n", "line 2: G4 needs P"),
    ("G1 X1 F60\nX2 Q1\n", "line 2: 'Q1' is not one of"),
    ("X1 Y1\n", "line 1: coordinates before any motion word"),
    ("G1 X1 F60 #5\n", "line 1: '#5' is not a G-code word"),
    ("G1 X1 F6e-11\n", "'E-11' is not one of"),  # G-code numbers have no exponent
    ("G1 X1 F0.000000001\n", "waypoint 2 has feed 1.66667e-11 mm/s: allowed at least 0.1"),
    ("G1 X1 F3\n", "allowed at least 0.1 mm/s"),
    ("G1 X100 F6\nG1 X-100\nG1 X100\nG1 X-100\nG1 X100\nG1 X-100\nG1 X100\nG1 X-100\n"
     "G1 X100\nG1 X-100\nG1 X100\nG1 X-100\n", "allowed at most 3600 s"),
])
def test_motion_words_the_reader_cannot_run_are_refused_with_their_line(tmp_path, text, message):
  with pytest.raises(errors.DataError, match=re.escape(message)):
    _path(tmp_path, text)


def test_a_crawling_feed_in_a_csv_path_is_refused(tmp_path):
  with pytest.raises(errors.DataError, match="feed 1e-12 mm/s: allowed at least 0.1"):
    _path(tmp_path, "0,0,0,5\n1,0,0,1e-12\n", ".csv")


# --- the --out lock: one holder, however many start at once --------------------------------

def _contend(out, barrier, queue):
  import time
  from util import files
  barrier.wait()
  try:
    lock = files.claim(out)
  except errors.SettingError:
    queue.put(None)
    return
  start = time.monotonic()
  time.sleep(0.02)
  end = time.monotonic()
  lock.release()
  queue.put((start, end))


def test_eight_runs_started_at_once_never_share_an_out_folder(tmp_path):
  import multiprocessing
  ctx = multiprocessing.get_context("fork")
  holds = []
  for round_ in range(25):
    out = str(tmp_path / f"out{round_ % 3}")  # some rounds find an earlier round's folder
    barrier, queue = ctx.Barrier(8), ctx.Queue()
    procs = [ctx.Process(target=_contend, args=(out, barrier, queue)) for _ in range(8)]
    for p in procs:
      p.start()
    got = [queue.get(timeout=60) for _ in procs]
    for p in procs:
      p.join()
    spans = sorted(g for g in got if g is not None)
    assert spans, "nobody took a free folder"
    for (s0, e0), (s1, e1) in zip(spans, spans[1:]):
      assert s1 >= e0, f"round {round_}: two runs held {out} at once"
    holds.append(len(spans))
  assert min(holds) >= 1


# --- generated C takes names only as escaped comments and sanitised identifiers -------------

NASTY_INPUTS = ["p1 */ int injected = 1; /*", 'p2 "quoted"', "p 3 with spaces", "p4 ünï",
                "p5 /* nested", "5p"]
NASTY_OUTPUTS = ["F x", "F-x", "Fz */ int also_injected; /*"]


def _export_nasty(tmp_path):
  from calibrate import cexport, estimators
  rng = np.random.default_rng(0)
  counts = rng.uniform(500, 3500, (400, 6))
  forces = counts @ rng.normal(0, 0.01, (6, 3))
  est = estimators.fit("LS", counts, forces, inputs=NASTY_INPUTS, outputs=NASTY_OUTPUTS,
                       output_units=["N", "N */ x", "N"])
  cexport.write(est, tmp_path)
  return tmp_path / "estimator.h", tmp_path / "estimator.c"


def test_column_names_cannot_close_the_generated_comment(tmp_path):
  header, _ = _export_nasty(tmp_path)
  text = header.read_text()
  comment = text[:text.index("*/") + 2]  # the first comment ends where it should
  assert comment.rstrip().endswith(". */") and "#ifndef" in text[len(comment):]
  assert text.isascii()
  defines = re.findall(r"#define ESTIMATOR_(IN|OUT)_(\w+) (\d+)", text)
  assert [d[1] for d in defines if d[0] == "IN"] == [
      "P1____INT_INJECTED___1____", "P2__QUOTED_", "P_3_WITH_SPACES", "P4__N_", "P5____NESTED",
      "C5P"]
  assert [d[1] for d in defines if d[0] == "OUT"] == ["F_X", "F_X_1",
                                                      "FZ____INT_ALSO_INJECTED____"]


CC = __import__("shutil").which("cc") or __import__("shutil").which("gcc")


@pytest.mark.skipif(CC is None, reason="no C compiler on this machine")
def test_an_export_of_hostile_names_compiles_to_nothing_but_the_estimator(tmp_path):
  import subprocess
  header, source = _export_nasty(tmp_path)
  (tmp_path / "use.c").write_text(
      '#include "estimator.h"\nint first(void) { return ESTIMATOR_IN_C5P + ESTIMATOR_OUT_F_X_1; }\n')
  for c in (source, tmp_path / "use.c"):
    subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", str(c),
                    "-o", str(c.with_suffix(".o"))], check=True, capture_output=True, text=True)
  symbols = subprocess.run(["nm", str(source.with_suffix(".o"))], capture_output=True,
                           text=True, check=True).stdout
  assert "injected" not in symbols and " T estimate" in symbols


# --- every command checks its outputs before the work ---------------------------------------

def _calibrate(capsys, argv, code=2) -> str:
  from calibrate.__main__ import main
  assert main(argv) == code
  captured = capsys.readouterr()
  err = captured.err.strip()
  assert "Traceback" not in err
  if code == 2:
    assert len(err.splitlines()) == 1 and err.startswith("error:"), err
  return err if code else captured.out


@pytest.fixture
def csvs(tmp_path, capsys):
  """The shipped example recordings and an LS estimator of them."""
  _calibrate(capsys, ["example", str(tmp_path / "ex")], 0)
  _calibrate(capsys, ["fit", "--csv", str(tmp_path / "ex" / "train.csv"), "--inputs", "p*",
                      "--targets", "Fx,Fy,Fz", "--method", "ls", "--out",
                      str(tmp_path / "e.npz")], 0)
  return tmp_path / "ex", tmp_path / "e.npz"


def _fit(csvs, out, method="ls"):
  return ["fit", "--csv", str(csvs[0] / "train.csv"), "--inputs", "p*", "--targets",
          "Fx,Fy,Fz", "--method", method, "--no-progress", "--out", str(out)]


def test_fit_makes_a_missing_folder_for_its_estimator(csvs, capsys, tmp_path):
  out = _calibrate(capsys, _fit(csvs, tmp_path / "new" / "deeper" / "e.npz"), 0)
  assert (tmp_path / "new" / "deeper" / "e.npz").is_file() and "wrote" in out


@pytest.mark.parametrize("where, message", [
    (lambda t: t / "ex" / "train.csv" / "e.npz", "is a file: give a folder"),  # under a file
    (lambda t: t / "ex", "is a folder: give a file name ending in .npz"),
    (lambda t: t / "e.bin", "unknown suffix '.bin': allowed .npz"),
])
def test_fit_refuses_an_output_it_cannot_write_before_training(csvs, capsys, tmp_path, where,
                                                               message, monkeypatch):
  from calibrate import estimators

  def never(*a, **k):
    raise AssertionError("trained before checking --out")
  monkeypatch.setattr(estimators, "fit", never)
  assert message in _calibrate(capsys, _fit(csvs, where(tmp_path), "lsann"))


@pytest.mark.parametrize("argv, message", [
    (lambda ex, est, t: ["predict", str(est), "--csv", str(ex / "test.csv"), "--out", str(t)],
     "is a folder: give a file name ending in .csv"),
    (lambda ex, est, t: ["predict", str(est), "--csv", str(ex / "test.csv"), "--out",
                         str(t / "p.txt")], "unknown suffix '.txt': allowed .csv"),
    (lambda ex, est, t: ["evaluate", str(est), "--csv", str(ex / "test.csv"), "--out",
                         str(ex / "test.csv")], "is a file: give a folder"),
    (lambda ex, est, t: ["export", str(est), "--c", str(ex / "test.csv")], "is a file"),
    (lambda ex, est, t: ["example", str(ex / "train.csv")], "is a file: give a folder"),
])
def test_the_other_calibrate_commands_check_their_outputs_first(csvs, capsys, tmp_path, argv,
                                                                message):
  ex, est = csvs
  assert message in _calibrate(capsys, argv(ex, est, tmp_path))


def test_an_empty_out_is_refused_not_read_as_the_current_folder(csvs, capsys, tmp_path):
  from calibrate.__main__ import main
  with pytest.raises(SystemExit) as stop:
    main(["evaluate", str(csvs[1]), "--csv", str(csvs[0] / "test.csv"), "--out", ""])
  assert stop.value.code == 2 and "an empty path" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["shell", "--path", "asterisk", "--z", "3"], "--path and --z choose the footpad's"),
    (["footpad", "--out", "{t}"], "is a folder: give a file name ending in .png"),
    (["footpad", "--out", "{t}/r.txt"], "unknown suffix '.txt': allowed .png"),
    (["footpad", "--out", "{t}/f.png", "--video", "{t}/f.png/v.mp4"], "is a file: give a folder"),
    (["footpad", "--out", "{t}/g.png", "--video", "{t}/v.gif"], "unknown suffix '.gif'"),
    (["footpad", "--z", "nan"], "--z nan is out of range"),
])
def test_render_checks_its_options_and_outputs_before_drawing(capsys, tmp_path, argv, message):
  from sim import render
  (tmp_path / "f.png").write_text("not a folder")
  assert render.main([a.replace("{t}", str(tmp_path)) for a in argv]) == 2
  err = capsys.readouterr().err.strip()
  assert len(err.splitlines()) == 1 and message in err, err


def test_render_refuses_an_unknown_gl_backend_in_one_line(tmp_path):
  import os
  import subprocess
  import sys
  env = dict(os.environ, MUJOCO_GL="bogus")
  run = subprocess.run([sys.executable, "-m", "sim.render", "shell", "--out",
                        str(tmp_path / "s.png")], env=env, capture_output=True, text=True)
  assert run.returncode == 2 and run.stderr.strip().splitlines() == [
      "error: MUJOCO_GL='bogus' is not a GL backend MuJoCo renders offscreen with: allowed "
      "egl, osmesa, glfw, glx (or unset it to let the command choose)"]


@pytest.mark.parametrize("sig, code, line", [
    ("SIGINT", 130, "interrupted: nothing was written"),  # Ctrl-C
    ("SIGTERM", 143, "terminated (SIGTERM): nothing was written")])  # kill, a scheduler
def test_ctrl_c_or_sigterm_in_calibrate_fit_is_one_line_and_its_exit_code(csvs, tmp_path, sig,
                                                                          code, line):
  import os
  import signal
  import subprocess
  import sys
  ex, _ = csvs
  proc = subprocess.Popen([sys.executable, "-m", "calibrate", "fit", "--csv",
                           str(ex / "train.csv"), "--inputs", "p*", "--targets", "Fx,Fy,Fz",
                           "--method", "nn", "--epochs", "100000", "--ensemble", "50",
                           "--out", str(tmp_path / "nn.npz")],
                          stderr=subprocess.PIPE, text=True, env=dict(os.environ, COLUMNS="80"))
  seen = proc.stderr.readline()  # the first network's progress line: training has begun
  assert seen.startswith("training"), seen
  proc.send_signal(getattr(signal, sig))
  err = seen + proc.stderr.read()
  assert proc.wait(timeout=60) == code
  assert "Traceback" not in err and err.strip().splitlines()[-1] == line
  assert not (tmp_path / "nn.npz").exists()


# --- CSV files: what reads silently wrong -----------------------------------------------------

def test_a_byte_order_mark_is_not_part_of_the_first_name(tmp_path):
  from calibrate import csvfile
  path = tmp_path / "bom.csv"
  path.write_bytes("\ufefftime,p1,p2,Fx\n0,1,2,3\n1,2,3,4\n".encode())
  table = csvfile.read(path)
  assert table.names == ("time", "p1", "p2", "Fx")
  assert table.columns(["p*"], "--inputs") == [1, 2] and table.column("time") is not None


@pytest.mark.parametrize("inputs", ["", ",", " , "])
def test_inputs_naming_no_column_are_refused(csvs, capsys, inputs):
  argv = _fit(csvs, "unused.npz")
  argv[argv.index("p*")] = inputs
  assert "--inputs names no column" in _calibrate(capsys, argv)


def test_a_number_in_the_units_row_is_named_as_such(tmp_path, capsys):
  path = tmp_path / "u.csv"
  path.write_text("time,p1,p2,Fx\ns,counts,1,N\n0,1,2,3\n1,2,3,4\n")
  err = _calibrate(capsys, ["fit", "--csv", str(path), "--inputs", "p*", "--targets", "Fx",
                            "--method", "ls", "--out", str(tmp_path / "e.npz")])
  assert "line 2, column 'p2': '1' in what reads as the units row" in err


def test_too_few_rows_name_the_file_and_its_row_count(tmp_path, capsys):
  path = tmp_path / "one.csv"
  path.write_text("time,p1,p2,Fx\n0,1,2,3\n")
  err = _calibrate(capsys, ["fit", "--csv", str(path), "--inputs", "p*", "--targets", "Fx",
                            "--method", "ls", "--out", str(tmp_path / "e.npz")])
  assert f"{path}: 1 data row(s) in 1 recording(s), --split auto: 1 samples cannot make two " \
      f"blocks" in err


# --- a sweep never crowns a NaN ---------------------------------------------------------------

def _sweep_argv(out, *sets):
  argv = ["reflector_slope_sweep", "--quick", "--executor", "serial", "--no-progress",
          "--out", str(out), "--set", "confirm=0", "--set", "search=false"]
  for s in sets:
    argv += ["--set", s]
  return argv


def test_a_design_whose_error_is_nan_is_listed_not_ranked(tmp_path, capsys, monkeypatch):
  import json
  from benchmarks import run as bench_cli
  from benchmarks.shell import slope_sweep
  real = slope_sweep.evaluate

  def nan_at_06(point):
    r = real(point)
    if point["design"]["slope_x"] == 0.6:
      r["median_pct"] = [float("nan")] * 6
      r["fom"] = float("nan")
    return r
  monkeypatch.setattr(slope_sweep, "evaluate", nan_at_06)
  assert bench_cli.main(_sweep_argv(tmp_path, "sweep.slope_x=0.3,0.6",
                                    "sweep.slope_y=0.3,0.6")) == 0
  out = capsys.readouterr().out
  data = json.loads((tmp_path / "metrics.json").read_text())
  assert all(r["design"]["slope_x"] == 0.3 for r in data["table"])
  assert data["best"]["design"]["slope_x"] == 0.3
  assert sorted(r["design"]["slope_y"] for r in data["unranked"]) == [0.3, 0.6]
  assert "not a finite number" in data["unranked"][0]["reason"]
  assert "nan %" not in out and "not ranked: its calibrated error" in out
  assert f"why it wins: rank {data['best']['rank']}," in out


def test_a_grid_that_all_loses_rank_ends_in_one_line(tmp_path, capsys):
  from benchmarks import run as bench_cli
  assert bench_cli.main(_sweep_argv(tmp_path, "sweep.slope_x=0", "sweep.slope_y=0,0.3")) == 2
  err = capsys.readouterr().err.strip()
  assert len(err.splitlines()) == 1 and "no design of the grid can be ranked" in err


def test_a_grid_that_all_fails_ends_in_one_line(tmp_path, capsys, monkeypatch):
  from benchmarks import run as bench_cli
  from benchmarks.shell import slope_sweep

  def broken(point):
    raise ValueError("the static path diverged")
  monkeypatch.setattr(slope_sweep, "evaluate", broken)
  assert bench_cli.main(_sweep_argv(tmp_path, "sweep.slope_x=0.3,0.6",
                                    "sweep.slope_y=0.3")) == 2
  err = capsys.readouterr().err.strip().splitlines()
  assert err[-1].startswith("error: every design of the sweep failed (3)")
  assert "the static path diverged" in err[-1]


# --- loaders check what the arrays hold and how far they expand, before the checksum ------

def _resign_estimator(src, dst, change):
  """A copy of the estimator file `src` with `change(arrays)` applied and the checksum
  signed again, as a careless tool would."""
  from util import files
  with np.load(src) as z:
    arrays = {k: z[k] for k in z.files}
  meta = files.from_json(str(arrays.pop("meta")))
  change(arrays)
  meta["sha256"] = files.array_digest(arrays)
  np.savez(dst, meta=files.json_text(meta), **arrays)


@pytest.mark.parametrize("change, message", [
    (lambda a: a.__setitem__("root/coef", a["root/coef"].astype(str)), "holds <U"),
    (lambda a: a.__setitem__("root/bias", np.array(["0.1"] * len(a["root/bias"]))),
     "root/bias holds"),
])
def test_an_estimator_whose_arrays_hold_text_is_refused(csvs, tmp_path, capsys, change,
                                                        message):
  bad = tmp_path / "bad.npz"
  _resign_estimator(csvs[1], bad, change)
  err = _calibrate(capsys, ["predict", str(bad), "--csv", str(csvs[0] / "test.csv"), "--out",
                            str(tmp_path / "p.csv")])
  assert message in err and "expected numbers" in err


def test_a_recording_that_expands_far_beyond_its_file_is_refused_unread(tmp_path):
  import json
  from sim import recording
  from sim.shell import scene as shell
  rec, _ = shell.generate(shell.ShellScene(frames=300, seed=1), use_cache=False)
  rec.save(tmp_path / "r")
  with np.load(tmp_path / "r.npz") as z:
    arrays = {k: z[k] for k in z.files}
  arrays["counts"] = np.zeros((2_000_000, 8))  # 128 MB of zeros, a few hundred kB zipped
  np.savez_compressed(tmp_path / "r.npz", **arrays)
  head = json.loads((tmp_path / "r.json").read_text())
  head["sha256"] = recording._digest((tmp_path / "r.npz").read_bytes(), head["meta"])
  (tmp_path / "r.json").write_text(json.dumps(head))
  with pytest.raises(errors.DataError, match="expand to 1[0-9]{2} MiB from a 0.[0-9] MiB file"):
    recording.Recording.load(tmp_path / "r")


# --- one error path: the benchmark command's checks before any work ---------------------------

def _bench_error(capsys, argv) -> str:
  from benchmarks import run as bench_cli
  assert bench_cli.main(argv) == 2
  err = capsys.readouterr().err.strip()
  assert len(err.splitlines()) == 1 and "Traceback" not in err, err
  return err


def test_tracebacks_of_one_second_never_overwrite_each_other(tmp_path, monkeypatch):
  from util import cli
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  paths = {cli.traceback_path("calibrate") for _ in range(50)}
  assert len(paths) == 50 and all(p.exists() for p in paths)


@pytest.mark.parametrize("argv, message", [
    (["reflector_slope_sweep", "--quick", "--executor", "dask", "--address",
      "tls://127.0.0.1:1", "--tls-ca-file", "/no/such/ca.pem", "--check"],
     "--tls-ca-file /no/such/ca.pem: not a readable file"),
    (["reflector_slope_sweep", "--quick", "--executor", "dask", "--tls-cert", __file__,
      "--check"], "--tls-cert is for joining a scheduler: add --address"),
    (["asterisk_path", "--quick", "--check", "--set", "custom_path=/no/such/path.csv"],
     "custom_path='/no/such/path.csv' is not a file"),
    (["effect_ablation", "--quick", "--check", "--set", "rigs="],
     "rigs=() is out of range: allowed footpad, shell or both (not none)"),
    (["accuracy_vs_time", "--quick", "--check", "--set", "rigs="], "rigs=() is out of range"),
])
def test_the_benchmark_command_refuses_these_before_any_work(capsys, argv, message):
  assert message in _bench_error(capsys, argv)


@pytest.mark.parametrize("text, message", [
    ("G1 Z-0.5 F60\nG1 X1 F0.00000000006\n", "allowed at least 0.1 mm/s"),
    ("G1 Z-0.5 F60\nG2 X1 Y1 R1\n", "line 2: an arc needs its centre as I, J"),
    ("G28\nG1 X1 F60\n", "line 1: G28 is not supported"),
    ("G20\nG1 X1 F60\n", "line 1: G20 (inches) is not supported"),
])
def test_a_custom_path_the_rig_cannot_run_is_one_line_before_any_work(capsys, tmp_path, text,
                                                                      message):
  path = tmp_path / "p.gcode"
  path.write_text(text)
  err = _bench_error(capsys, ["asterisk_path", "--quick", "--check", "--set",
                              f"custom_path={path}"])
  assert message in err and str(path) in err


def test_predict_keeps_the_time_column_of_a_file_with_a_byte_order_mark(csvs, capsys, tmp_path):
  from calibrate import csvfile
  ex, est = csvs
  bom = tmp_path / "bom.csv"
  bom.write_bytes(b"\xef\xbb\xbf" + (ex / "test.csv").read_bytes())
  _calibrate(capsys, ["predict", str(est), "--csv", str(bom), "--out", str(tmp_path / "p.csv")],
             0)
  out = csvfile.read(tmp_path / "p.csv")
  assert out.names[0] == "time" and len(out.data) == len(csvfile.read(ex / "test.csv").data)


def test_a_reader_that_leaves_early_loses_no_work(csvs, tmp_path):
  """`python -m calibrate evaluate ... | head -1`: the pipe closes after the first line; the
  command still writes its results and exits 0, with no traceback."""
  import subprocess
  import sys
  ex, est = csvs
  cmd = (f"{sys.executable} -m calibrate evaluate {est} --csv {ex / 'test.csv'} --out "
         f"{tmp_path / 'ev'} | head -1")
  run = subprocess.run(["bash", "-c", f"set -o pipefail; {cmd}"], capture_output=True,
                       text=True)
  assert run.returncode == 0 and "Traceback" not in run.stderr and "internal" not in run.stderr
  assert (tmp_path / "ev" / "metrics.json").exists()


def test_a_swallowed_ctrl_c_stops_at_the_next_progress_step():
  """A KeyboardInterrupt raised inside a finaliser is swallowed by Python; the request stays,
  and the next progress step (a bar or --no-progress's silent one) raises it again."""
  from util import interrupt, progress
  with interrupt.handled():
    progress.quiet(1, 3)  # nothing asked: nothing raised
    interrupt._requested.set()
    with pytest.raises(KeyboardInterrupt):
      progress.quiet(2, 3)
    with pytest.raises(KeyboardInterrupt):
      progress.progress_bar("x")(1, 3)
  progress.quiet(3, 3)  # the command is over: the request is gone
