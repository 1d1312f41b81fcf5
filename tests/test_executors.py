"""Sweeps give the same results whatever runs them, resume, and survive failing workers."""

import os
import pathlib
import time

import numpy as np
import pytest

from benchmarks import executors


def noisy_sum(point):
  """A point's result from its own seed alone."""
  rng = np.random.default_rng(point["seed"])
  return {"value": float(np.sum(rng.normal(size=1000)) + point["x"]), "pid": os.getpid()}


def dies_on_seven(point):
  if point["x"] == 7:
    os._exit(3)  # the worker process dies mid-sweep
  if point["x"] == 5:
    raise ValueError("bad point")
  return {"value": point["x"]}


POINTS = [{"x": x, "seed": 100 + x} for x in range(12)]


def _values(results):
  return [r["value"] for r in results]


@pytest.fixture(scope="module")
def serial():
  results, failures = executors.sweep(noisy_sum, POINTS, executors.ExecutorSpec("serial"))
  assert not failures
  return _values(results)


def test_processes_give_the_serial_results(serial):
  results, failures = executors.sweep(noisy_sum, POINTS, executors.ExecutorSpec("processes",
                                                                                  workers=2))
  assert not failures and _values(results) == serial
  assert len({r["pid"] for r in results}) >= 1 and results[0]["pid"] != os.getpid()


def test_dask_local_cluster_on_loopback_gives_the_serial_results(serial):
  pytest.importorskip("distributed")
  results, failures = executors.sweep(noisy_sum, POINTS, executors.ExecutorSpec("dask",
                                                                                  workers=2))
  assert not failures and _values(results) == serial


def test_an_interrupted_sweep_resumes_from_its_store(tmp_path, serial):
  store = executors.PointStore(tmp_path)
  executors.sweep(noisy_sum, POINTS[:5], executors.ExecutorSpec("serial"), store)
  seen = []
  results, _ = executors.sweep(noisy_sum, POINTS, executors.ExecutorSpec("serial"), store,
                               progress=lambda d, t: seen.append(d))
  assert _values(results) == serial
  assert seen[0] == 5 and seen[-1] == 12  # five loaded, seven run
  # another seed is another point
  other = [dict(p, seed=p["seed"] + 1) for p in POINTS[:1]]
  assert store.load(other[0]) is None


@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_failing_points_are_retried_once_then_reported_and_the_rest_kept(kind):
  if kind == "serial":
    points = [p for p in POINTS if p["x"] != 7]  # a dying point would end this process
  else:
    points = POINTS
  results, failures = executors.sweep(dies_on_seven, points,
                                      executors.ExecutorSpec(kind, workers=2))
  bad = {f.point["x"] for f in failures}
  assert bad == ({5, 7} if kind == "processes" else {5})
  assert all("bad point" in f.error or "died" in f.error for f in failures)
  kept = [r["value"] for r, p in zip(results, points) if p["x"] not in bad]
  assert kept == [p["x"] for p in points if p["x"] not in bad]


def test_an_unreachable_scheduler_is_a_clear_error():
  pytest.importorskip("distributed")
  with pytest.raises(executors.ExecutorError, match="could not reach the Dask scheduler"):
    executors.sweep(noisy_sum, POINTS[:1], executors.ExecutorSpec(
        "dask", address="tcp://127.0.0.1:9", connect_timeout=3))


def test_a_killed_sweep_leaves_no_worker_running(tmp_path):
  """SIGKILL of the command (no chance to shut its pool down): its workers exit on their own
  within a few seconds instead of finishing their points."""
  import os
  import signal
  import subprocess
  import sys
  import time
  script = ("import concurrent.futures, multiprocessing, os, time\n"
            "from util import workers\n"
            "if __name__ == '__main__':\n"
            "  ctx = multiprocessing.get_context('spawn')\n"
            "  pool = concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx,\n"
            "      initializer=workers.die_with_parent, initargs=(os.getpid(),))\n"
            "  print(pool.submit(os.getpid).result(), flush=True)\n"
            "  pool.submit(time.sleep, 120)\n"
            "  time.sleep(120)\n")
  (tmp_path / "parent.py").write_text(script)
  parent = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")],
                            stdout=subprocess.PIPE, text=True)
  worker = int(parent.stdout.readline())
  parent.send_signal(signal.SIGKILL)
  parent.wait()
  deadline = time.monotonic() + 10
  while time.monotonic() < deadline:
    try:  # gone, or a zombie nobody reaps (pid 1 of a container may not)
      with open(f"/proc/{worker}/stat") as stat:
        if stat.read().rsplit(")", 1)[1].split()[0] in ("Z", "X"):
          return
    except FileNotFoundError:
      return
    time.sleep(0.2)
  os.kill(worker, signal.SIGKILL)
  raise AssertionError("the worker outlived its killed parent by 10 s")


def test_ctrl_c_ends_idle_and_busy_workers_without_a_traceback(tmp_path):
  """A terminal's Ctrl-C reaches the command and its workers (one process group): each
  worker ends at once and silently, so the command's one line is all that is printed."""
  import os
  import signal
  import subprocess
  import sys
  # a command started in the background by a shell ignores SIGINT: this one takes Ctrl-C as
  # a terminal's foreground command does
  script = ("import concurrent.futures, multiprocessing, os, signal, sys, time\n"
            "from util import workers\n"
            "if __name__ == '__main__':\n"
            "  signal.signal(signal.SIGINT, signal.default_int_handler)\n"
            "  ctx = multiprocessing.get_context('spawn')\n"
            "  try:\n"
            "    with concurrent.futures.ProcessPoolExecutor(2, mp_context=ctx,\n"
            "        initializer=workers.die_with_parent, initargs=(os.getpid(),)) as pool:\n"
            "      for f in [pool.submit(time.sleep, 0.5) for _ in range(2)]:\n"
            "        f.result()  # two workers started, both idle now\n"
            "      busy = pool.submit(time.sleep, 60)\n"
            "      print('ready', flush=True)\n"
            "      time.sleep(60)\n"
            "  except KeyboardInterrupt:\n"
            "    print('interrupted', file=sys.stderr)\n")
  (tmp_path / "parent.py").write_text(script)
  env = {**os.environ, "PYTHONPATH": str(pathlib.Path(__file__).resolve().parents[1])}
  proc = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, start_new_session=True, env=env)
  proc.stdout.readline()
  time.sleep(1.0)  # one worker sleeps in its job, the other waits idle for one
  os.killpg(proc.pid, signal.SIGINT)
  _, err = proc.communicate(timeout=20)
  assert "Traceback" not in err, err
  assert err.strip() == "interrupted"
