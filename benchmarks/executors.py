"""Where a sweep's points run: one small interface over serial, local processes and Dask.

`sweep(fn, points, spec, store, progress)` evaluates fn(point) for every point (a JSON-able
dict that carries everything fn needs, its seed included, so a result never depends on the
executor or the number of workers). Points already in the `PointStore` are loaded, not run
again: an interrupted sweep, rerun with the same arguments, resumes. A point whose worker
fails (an exception, or a worker process that dies) is retried once, alone; if it fails
again it is reported, and the others are kept.

Executors:
* "serial": in this process, one point after another.
* "processes" (default): a pool of spawned processes on this machine (spawn, not fork: safe
  with MuJoCo's and JAX's threads), one per core unless `workers` says otherwise.
* "dask": Dask distributed, an optional extra imported only here. Without an address it
  starts a `LocalCluster` whose scheduler, workers and dashboard listen on 127.0.0.1 only;
  with `address` it joins a running scheduler using Dask's security settings (TLS
  certificates from the `distributed.comm.tls` configuration, or `tls_*` below), so a sweep
  never opens an unauthenticated port to the network by default.
"""

from __future__ import annotations

import concurrent.futures
import ctypes
import dataclasses
import functools
import hashlib
import multiprocessing
import os
import pathlib
import time
import traceback
import warnings
from typing import Any, Callable, Iterator, Literal, Optional

from util import errors, files, workers as util_workers

Point = dict[str, Any]
Progress = Callable[[int, int], None]


class ExecutorError(errors.UserError, RuntimeError):
  """An executor could not be started or reached; the message says what to change."""


@dataclasses.dataclass(frozen=True)
class ExecutorSpec:
  """How a sweep runs its points.

  Attributes:
    kind: "serial", "processes" or "dask".
    workers: processes or Dask workers; None: one per core.
    address: a running Dask scheduler to join (tcp://HOST:PORT or tls://HOST:PORT); None
      starts a LocalCluster on 127.0.0.1.
    tls_ca_file, tls_cert, tls_key: Dask TLS files for joining a scheduler (default: Dask's
      configuration).
    connect_timeout: seconds to wait for a scheduler before giving up.
  """
  kind: Literal["serial", "processes", "dask"] = "processes"
  workers: Optional[int] = None
  address: Optional[str] = None
  tls_ca_file: Optional[str] = None
  tls_cert: Optional[str] = None
  tls_key: Optional[str] = None
  connect_timeout: float = 5.0

  def count(self) -> int:
    return self.workers or os.cpu_count() or 1

  def check(self) -> None:
    """Refuses, before any work, TLS files that are not readable files, or TLS files without
    an address to use them on.

    Raises:
      ExecutorError naming the option.
    """
    given = {"--tls-ca-file": self.tls_ca_file, "--tls-cert": self.tls_cert,
             "--tls-key": self.tls_key}
    for option, path in given.items():
      if path is None:
        continue
      if self.address is None:
        raise ExecutorError(f"{option} is for joining a scheduler: add --address "
                            f"tls://HOST:PORT, or drop it")
      if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise ExecutorError(f"{option} {path}: not a readable file (give the PEM file Dask "
                            f"should use)")


@dataclasses.dataclass(frozen=True)
class Failure:
  """A point that failed twice: its index, the point and the last error."""
  index: int
  point: Point
  error: str


class _Died(Exception):
  """The worker running the point died (the process pool broke while it ran)."""


class PointStore:
  """Finished points on disk, one JSON file each under `folder`, named by a hash of the
  point (so a point with other settings or another seed is a different file)."""

  def __init__(self, folder: pathlib.Path):
    self.folder = pathlib.Path(folder)

  def _path(self, point: Point) -> pathlib.Path:
    from sim import cache
    return self.folder / f"{cache.content_key(point)}.json"

  def load(self, point: Point) -> Optional[Any]:
    path = self._path(point)
    if not path.exists():
      return None
    try:
      saved = files.from_json(path.read_text())
    except (OSError, ValueError):
      return None  # unreadable: run the point again
    if not isinstance(saved, dict) or saved.get("point") != files.from_json(
        files.json_text(point)):
      return None
    if saved.get("sha256") != _digest(saved.get("result")):
      warnings.warn(f"finished point {path} does not match its checksum (damaged or edited): "
                    f"running it again", stacklevel=2)
      return None
    return saved["result"]

  def save(self, point: Point, result: Any) -> None:
    self.folder.mkdir(parents=True, exist_ok=True)
    files.write_text(self._path(point), files.json_text(
        {"point": point, "result": result, "sha256": _digest(result)}, sort_keys=True))


def _digest(result: Any) -> str:
  return hashlib.sha256(files.json_text(result, sort_keys=True).encode()).hexdigest()


@functools.cache  # once per process
def _keep_freed_memory() -> None:
  """Lets this process keep the memory of freed arrays (glibc only; elsewhere a no-op).

  A sweep point allocates and frees arrays of a few MB again and again. By default glibc
  gives such memory back to the kernel and faults it in again, page by page, on the next
  allocation: measured, that took 15 % of a design's time in `reflector_slope_sweep` (its
  145 designs 12.0 s -> 10.5 s on 2 workers once kept). An mmap threshold of 32 MB
  (glibc's largest) and a trim threshold of 512 MB keep it; numbers do not change.
  """
  try:
    libc = ctypes.CDLL("libc.so.6")
  except OSError:
    return
  m_trim_threshold, m_mmap_threshold = -1, -3  # from glibc's malloc.h
  libc.mallopt(m_mmap_threshold, 32 << 20)
  libc.mallopt(m_trim_threshold, 512 << 20)


def _call(fn, point):
  from benchmarks import outputs
  _keep_freed_memory()
  try:
    with warnings.catch_warnings():  # a worker process: the command's filters are not here
      outputs.quiet_out_of_range()
      return fn(point), None
  except Exception:  # reported with the point, the sweep goes on
    return None, traceback.format_exc(limit=3)


def _serial(fn, items) -> Iterator[tuple[int, Any, Optional[BaseException]]]:
  # one BLAS thread, as in the workers of the other executors: a threaded BLAS sums in
  # another order, and results would differ in the last digits between executors
  from threadpoolctl import threadpool_limits
  for i, point in items:
    with threadpool_limits(1):
      result, err = _call(fn, point)
    yield i, result, (RuntimeError(err) if err else None)


# One BLAS thread per worker process: the workers already fill the cores, and numpy's
# threads on top of them oversubscribe (measured: a 145-design sweep took 68 s on 2 workers
# instead of ~25 s). Dask's nanny sets the same variables for its workers.
_ONE_THREAD = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                       "MKL_NUM_THREADS")}


def _processes(fn, items, workers: int, one_at_a_time: bool):
  """Points on a pool of spawned processes. A worker's death breaks the whole pool and fails
  every point still on it, so all of those are charged an attempt; the retry round then runs
  points one at a time (`one_at_a_time`), so that a point which kills its worker fails alone."""
  ctx = multiprocessing.get_context("spawn")
  with util_workers.environment(_ONE_THREAD):  # the workers, spawned as needed, inherit it
    yield from _pool(fn, items, ctx, workers, one_at_a_time)


def _pool(fn, items, ctx, workers: int, one_at_a_time: bool):
  pool = concurrent.futures.ProcessPoolExecutor(workers, mp_context=ctx,
                                                initializer=util_workers.die_with_parent,
                                                initargs=(os.getpid(),))
  finished = False
  try:
    yield from _on_pool(pool, fn, items, one_at_a_time)
    finished = True
  finally:
    if finished:
      pool.shutdown(wait=True)
    else:  # Ctrl-C, SIGTERM or an error: stop now, not after every queued point has run
      pool.shutdown(wait=False, cancel_futures=True)
      for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()  # the running points (no public way to end a worker)


def _on_pool(pool, fn, items, one_at_a_time: bool):
  if one_at_a_time:
    for i, point in items:
      try:
        result, err = pool.submit(_call, fn, point).result()
      except concurrent.futures.process.BrokenProcessPool:
        yield i, None, _Died("the worker process died")
        return  # the pool is gone: the caller runs what is left in a new one
      yield i, result, (RuntimeError(err) if err else None)
    return
  futures = {pool.submit(_call, fn, point): i for i, point in items}
  for fut in concurrent.futures.as_completed(futures):
    try:
      result, err = fut.result()
    except concurrent.futures.process.BrokenProcessPool:
      yield futures[fut], None, _Died("the worker process died")
      continue
    yield futures[fut], result, (RuntimeError(err) if err else None)


class _Dask:
  def __init__(self, spec: ExecutorSpec):
    try:
      import distributed
    except ImportError:
      raise ExecutorError("--executor dask needs Dask: pip install -e '.[cluster]'") from None
    self._cluster = None
    try:
      if spec.address:
        security = distributed.Security(
            tls_ca_file=spec.tls_ca_file, tls_client_cert=spec.tls_cert,
            tls_client_key=spec.tls_key) if spec.tls_ca_file else distributed.Security()
        self.client = distributed.Client(spec.address, security=security,
                                         timeout=f"{spec.connect_timeout}s")
      else:
        self._cluster = distributed.LocalCluster(
            n_workers=spec.count(), threads_per_worker=1, processes=True, host="127.0.0.1",
            scheduler_port=0, dashboard_address="127.0.0.1:0", silence_logs=40)
        self.client = distributed.Client(self._cluster, timeout=f"{spec.connect_timeout}s")
    except (OSError, TimeoutError) as err:
      self.close()
      raise ExecutorError(f"could not reach the Dask scheduler at {spec.address}: {err} "
                          f"(check --address, and the scheduler's TLS settings)") from None

  def map(self, fn, items):
    import distributed
    futures = {self.client.submit(_call, fn, point, pure=False, retries=1): i
               for i, point in items}
    for fut in distributed.as_completed(futures):
      i = futures[fut]
      try:
        result, err = fut.result()
      except Exception as exc:  # the worker died more often than Dask retries
        yield i, None, _Died(f"{type(exc).__name__}: {exc}")
        continue
      yield i, result, (RuntimeError(err) if err else None)

  def close(self):
    if getattr(self, "client", None) is not None:
      self.client.close()
    if self._cluster is not None:
      self._cluster.close()


def sweep(fn: Callable[[Point], Any], points: list[Point], spec: ExecutorSpec = ExecutorSpec(),
          store: Optional[PointStore] = None, progress: Optional[Progress] = None
          ) -> tuple[list[Optional[Any]], list[Failure]]:
  """Evaluates fn on every point.

  Args:
    fn: a module-level function (workers import it by name) of one JSON-able point.
    points: the points, each carrying its own seed.
    spec: where to run them.
    store: finished points; those in it are loaded, new ones saved as they finish.
    progress: progress(done, total) as points finish (loaded ones count as done).
  Returns:
    The results in the order of `points` (None for a failed point) and the failures.
  """
  results: list[Optional[Any]] = [None] * len(points)
  todo = []
  for i, p in enumerate(points):
    saved = store.load(p) if store else None
    if saved is not None:
      results[i] = saved
    else:
      todo.append(i)
  done = len(points) - len(todo)
  if progress:
    progress(done, len(points))
  attempts = {i: 0 for i in todo}
  last_error: dict[int, str] = {}
  dask = _Dask(spec) if spec.kind == "dask" and todo else None
  try:
    retry = False
    while todo:
      items = [(i, points[i]) for i in todo]
      if spec.kind == "serial":
        outcomes = _serial(fn, items)
      elif spec.kind == "processes":
        outcomes = _processes(fn, items, 1 if retry else min(spec.count(), len(items)), retry)
      elif spec.kind == "dask":
        outcomes = dask.map(fn, items)
      else:
        raise ExecutorError(f"executor {spec.kind!r} is unknown: allowed serial, processes, "
                            f"dask")
      try:
        for i, result, err in outcomes:
          if err is None:
            results[i] = result
            if store:
              store.save(points[i], result)
            done += 1
            if progress:
              progress(done, len(points))
          else:
            attempts[i] += 1
            last_error[i] = str(err)
      finally:  # an interrupted consumer (Ctrl-C in a progress step) stops the pool at once
        outcomes.close()
      # a failed point is retried once; what a broken pool never ran runs again
      todo = sorted(i for i in attempts if results[i] is None and attempts[i] < 2)
      retry = any(attempts[i] for i in todo)
  finally:
    if dask is not None:
      dask.close()
  failures = [Failure(i, points[i], last_error.get(i, "not run"))
              for i in range(len(points)) if results[i] is None]
  return results, failures


def run_designs(ctx, fn: Callable[[Point], Any], points: list[Point],
                describe: Callable[[Point], Any]) -> tuple[list, list[Failure], float]:
  """A benchmark's sweep: `sweep` on the run's executor, its finished points kept in
  DIR/points/, progress as designs complete, each design that failed twice printed (as
  `describe(point)`). Returns the results (None where failed), the failures and the seconds."""
  t0 = time.perf_counter()
  results, failures = sweep(fn, points, ctx.executor, PointStore(ctx.out / "points"),
                            ctx.progress("designs"))
  seconds = time.perf_counter() - t0
  for f in failures:
    ctx.print(f"design {describe(f.point)} failed twice: {f.error.strip().splitlines()[-1]}")
  return results, failures, seconds

