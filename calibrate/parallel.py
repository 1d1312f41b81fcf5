"""Independent fits on every core: the seeds, methods and splits of one benchmark.

`fit_all(data, jobs, workers)` runs `estimators.fit` once per job, `workers` at a time in
spawned processes, and returns the estimators in the jobs' order. A job is the keyword
arguments of one `fit` call; `counts` and `forces` (and `linear_fit`'s arrays, inside the
job) name entries of `data`, which each worker receives once, not once per job. Each fit
is the call a serial loop makes, with its own seed, so its estimator does not depend on
how many workers ran: `tests/test_calibrators.py` checks the weights are equal to the bit.

Every worker runs XLA and BLAS on one thread. XLA's own threading buys little for these
networks (measured, one NN at the quick protocol's N = 28,803: 11.3 s on 2 threads, 12.3 s
on one) while its second thread spins a whole core; one thread per worker and a worker per
core turns the cores into networks instead. It also fixes the summation order: XLA's
threaded sums differ in the last bits (3e-10 in a weight), so serial (`workers=1`, one
worker) and parallel runs give the same bytes. `workers=0` fits in this process, with its
threads, for callers that want no processes.

The training time of each network (`TrainResult.seconds`) is measured in its worker. Where
the cores share their memory bandwidth, trainings at once do not add up: on this project's
2-core machines two NN-only fits at N = 30,279 took 5.7 and 6.3 s beside one another against
3.5 and 3.6 s one at a time (the batch's wall time 0.79-0.95 of serial; 2.2x each, and no
gain, before the normal equations' blocks were sized to stay in cache).
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
from typing import Callable, Optional, Sequence

import numpy as np

from util import workers as workers_lib

_DATA: dict = {}  # a worker's copy of `data`
# set in the workers' environment before they start (XLA reads its flags once, at import)
ONE_THREAD = {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
              "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _start(data: dict, parent: int) -> None:
  """A worker's initializer: keep the shared arrays, and exit once the parent is gone."""
  _DATA.update(data)
  workers_lib.die_with_parent(parent)


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
    workers: processes at once, each on one thread (1: one after another, in one worker;
      0: in this process).
    progress: called (jobs done, jobs) as each finishes.
  """
  jobs = list(jobs)
  out: list = [None] * len(jobs)
  if workers <= 0:
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
  with workers_lib.environment(ONE_THREAD):  # inherited by the workers, spawned at submit
    return _pool(ctx, data, jobs, out, min(workers, len(jobs)), progress)


def _pool(ctx, data, jobs, out, workers, progress):
  with concurrent.futures.ProcessPoolExecutor(workers, mp_context=ctx, initializer=_start,
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
