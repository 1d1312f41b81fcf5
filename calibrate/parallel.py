"""Independent fits on every core: the seeds, methods and splits of one benchmark.

`fit_all(data, jobs, workers)` runs `estimators.fit` once per job, `workers` at a time in
spawned processes, and returns the estimators in the jobs' order. A job is the keyword
arguments of one `fit` call; `counts` and `forces` (and `linear_fit`'s arrays, inside the
job) name entries of `data`, which each worker receives once, not once per job. Each fit
is the call a serial loop makes, with its own seed, so its estimator does not depend on
how many workers ran: `tests/test_calibrators.py` checks the weights are equal to the bit.

The training time of each network (`TrainResult.seconds`) is measured in its worker; with
several networks training at once on a machine's cores each may take longer than alone,
while the batch takes less wall time.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
import threading
import time
from typing import Callable, Optional, Sequence

import numpy as np

_DATA: dict = {}  # a worker's copy of `data`


def _start(data: dict, parent: int) -> None:
  """A worker's initializer: keep the shared arrays, and exit once the parent is gone (a
  killed command must not leave trainings holding the cores)."""
  _DATA.update(data)

  def watch():
    while os.getppid() == parent:
      time.sleep(1.0)
    os._exit(1)
  threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def _fit(job: dict):
  from calibrate import estimators
  args = dict(job)
  counts, forces = _DATA[args.pop("counts")], _DATA[args.pop("forces")]
  return estimators.fit(args.pop("kind"), counts, forces, **args)


def fit_all(data: dict[str, np.ndarray], jobs: Sequence[dict], workers: int = 1,
            progress: Optional[Callable[[int, int], None]] = None) -> list:
  """Estimators of `jobs` (each the keyword arguments of `estimators.fit`, with `kind`, and
  `counts` / `forces` naming arrays of `data`), in order.

  Args:
    workers: processes at once; 1 runs the jobs here, one after another.
    progress: called (jobs done, jobs) as each finishes.
  """
  jobs = list(jobs)
  out: list = [None] * len(jobs)
  if workers <= 1 or len(jobs) <= 1:
    _DATA.clear()
    _DATA.update(data)
    try:
      for i, job in enumerate(jobs):
        out[i] = _fit(job)
        if progress:
          progress(i + 1, len(jobs))
    finally:
      _DATA.clear()
    return out
  ctx = multiprocessing.get_context("spawn")
  with concurrent.futures.ProcessPoolExecutor(min(workers, len(jobs)), mp_context=ctx,
                                              initializer=_start,
                                              initargs=(data, os.getpid())) as pool:
    futures = {pool.submit(_fit, job): i for i, job in enumerate(jobs)}
    done = 0
    try:
      for fut in concurrent.futures.as_completed(futures):
        out[futures[fut]] = fut.result()
        done += 1
        if progress:
          progress(done, len(jobs))
    except BaseException:
      for fut in futures:
        fut.cancel()
      raise
  return out
