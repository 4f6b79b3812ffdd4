"""Where the batches of a study run: in this process, on threads, in local worker
processes, on Dask.

Every backend calls the same picklable function ``fn(spec, batch)`` and yields
``(batch, result)`` pairs as batches finish (in completion order), ``result`` being the
function's return value (numpy arrays) or the exception it raised.  The parent process
alone writes the results, so workers never write to a shared file system.

* ``SerialBackend`` - in this process, in the given order.
* ``ThreadBackend`` - the default: ``n`` threads of this process, each running whole
  batches.  The numba kernels release the GIL (``nogil=True``), so the threads run in
  parallel with no process start-up, no second import of the stack, no second load of
  the numba cache and nothing to pickle: the model is built once.  Measured against the
  process pool on the same batches (reports/benchmarks.md), it is the faster of the two
  on every study here.  The threads are daemons: on Ctrl-C the study stops at once, the
  batches in flight are dropped.
* ``ProcessBackend`` - ``concurrent.futures.ProcessPoolExecutor`` with the **spawn**
  start method (numba's GNU OpenMP layer is not fork-safe, docs/manual/developer.md,
  "Processes and threads"), fed with whole batches; each worker rebuilds the model
  once.  Workers die with their parent, also when it dies while they start
  (``PR_SET_PDEATHSIG`` on Linux, a parent-pid check and a watchdog thread); the multiprocessing
  resource tracker then ends too and
  removes the pool's semaphores from ``/dev/shm``.
* ``DaskBackend`` (:mod:`vsi_numba.study.cluster`) - a ``dask.distributed`` cluster
  with chunks of neighbouring batches as tasks (``dask_chunks``) and the spec scattered
  to every worker once: a ``LocalCluster`` of ``n`` worker threads in this process
  (``--workers N``; in-process transport; the only network listeners, the scheduler's
  dashboard and the workers' HTTP servers, are bound to 127.0.0.1), or an existing
  scheduler (``--scheduler ADDR``).  Remote workers rebuild the model once per process
  from the configuration, so the files a config names (imported bridge, profile CSV,
  user train file) must exist at the same absolute paths on every worker, and the
  workers should set their own ``NUMBA_CACHE_DIR``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from vsi_numba._process import available_cores  # noqa: F401 (the backends' API)

#: The only interface a local Dask cluster listens on (scheduler, workers, dashboards).
LOOPBACK = "127.0.0.1"

#: Environment of worker processes: serial kernels, one thread each.
WORKER_ENV = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


#: Dask settings of the clusters this package starts (and of its client): the batches are
#: long compute-bound tasks, so the worker's statistical profiler (a stack sample every
#: 10 ms), the event-loop tick monitor (every 20 ms, in every process) and the system
#: monitor (every 0.5 s) only take CPU from them - 14 % of a core for an idle
#: scheduler + 2 nanny/worker pairs, 4 % with these (measured, reports/benchmarks.md).
QUIET_DASK = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
}


def dask_env(config: dict[str, object] = QUIET_DASK) -> dict[str, str]:
    """``config`` as Dask's environment variables (``DASK_DISTRIBUTED__WORKER__...``)."""
    return {"DASK_" + k.upper().replace(".", "__").replace("-", "_"): str(v)
            for k, v in config.items()}


def worker_env() -> dict[str, str]:
    """Environment for local workers: :data:`WORKER_ENV`, :data:`QUIET_DASK` (for Dask
    processes) plus ``NUMBA_CACHE_DIR`` if set."""
    env = dict(WORKER_ENV)
    env.update(dask_env())
    for name in ("NUMBA_CACHE_DIR", "NUMBA_OPT", "NUMBA_DISABLE_JIT"):
        if name in os.environ:
            env[name] = os.environ[name]
    return env


#: Seconds between two looks of a worker's watchdog at its parent.
WATCHDOG_PERIOD = 0.5


def _die_with_parent(parent_pid: int | None) -> None:
    """Make this worker process end when its parent ``parent_pid`` dies.

    Linux kills it (``PR_SET_PDEATHSIG``) when the parent dies from now on; a parent that
    died earlier, while this process was still starting (interpreter start-up and
    imports take about a second), is seen here by the parent pid having changed (the
    orphan was adopted by another process): exit at once.  A daemon thread also checks
    the parent every :data:`WATCHDOG_PERIOD` seconds (other systems, and the signal is
    tied to the parent's thread that started the worker, not to the whole process).
    """
    import signal
    import threading

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    if parent_pid is None:
        return
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch():
        import time

        while True:
            time.sleep(WATCHDOG_PERIOD)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="vsi-parent-watchdog").start()


def _init_worker(env: dict[str, str], parent_pid: int | None = None) -> None:
    """Set up a local worker process: one thread for numba/BLAS/OpenMP, dies with its
    parent ``parent_pid`` (even if that died while the worker was starting)."""
    _die_with_parent(parent_pid)
    os.environ.update(env)
    if "numba" in sys.modules:  # imported while unpickling; env var came too late
        import numba

        if numba.get_num_threads() > 1:
            numba.set_num_threads(1)


class SerialBackend:
    """Run cases one after the other in this process."""

    name = "serial"
    n_workers = 1

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return None

    def run(self, fn: Callable, config_json: str, cases: Iterable) -> Iterator[tuple[Any, Any]]:
        """Yield ``(case, result or exception)`` in the given order."""
        for case in cases:
            try:
                result = fn(config_json, case)
            except Exception as exc:  # reported per case by the runner
                result = exc
            yield case, result


class ThreadBackend:
    """Daemon threads of this process running whole batches (the kernels release the GIL)."""

    name = "threads"

    def __init__(self, n_workers: int):
        if n_workers < 1:
            raise ValueError(f"workers = {n_workers!r}: expected >= 1")
        self.n_workers = int(n_workers)
        self._stop = None

    def __enter__(self):
        import threading

        self._stop = threading.Event()
        return self

    def __exit__(self, *exc):
        if self._stop is not None:
            self._stop.set()  # threads take no new batch; the one in flight is dropped
        return None

    def run(self, fn: Callable, spec, tasks: Iterable) -> Iterator[tuple[Any, Any]]:
        """Run the tasks on the threads; yield ``(task, result or exception)`` as they
        finish."""
        import queue
        import threading

        todo: queue.Queue = queue.Queue()
        tasks = list(tasks)
        for t in tasks:
            todo.put(t)
        # at most one finished result per thread waits for the parent: memory stays at
        # n_workers batches in flight + n_workers waiting, whatever the study size
        done: queue.Queue = queue.Queue(maxsize=self.n_workers)
        stop = self._stop

        def work():
            while not stop.is_set():
                try:
                    task = todo.get_nowait()
                except queue.Empty:
                    return
                try:
                    result = fn(spec, task)
                except BaseException as exc:  # noqa: BLE001 - reported per task
                    result = exc
                while not stop.is_set():
                    try:
                        done.put((task, result), timeout=0.2)
                        break
                    except queue.Full:
                        continue

        threads = [threading.Thread(target=work, daemon=True, name=f"vsi-batch-{i}")
                   for i in range(min(self.n_workers, len(tasks)))]
        for th in threads:
            th.start()
        for _ in range(len(tasks)):
            while True:  # short waits: Ctrl-C reaches this (main) thread at once
                try:
                    item = done.get(timeout=0.2)
                    break
                except queue.Empty:
                    if not any(th.is_alive() for th in threads) and done.empty():
                        raise RuntimeError("the worker threads stopped unexpectedly") from None
            yield item


class ProcessBackend:
    """Local worker processes (``ProcessPoolExecutor``, spawn start method)."""

    name = "processes"

    def __init__(self, n_workers: int):
        if n_workers < 1:
            raise ValueError(f"workers = {n_workers!r}: expected >= 1")
        self.n_workers = int(n_workers)
        self._pool = None

    def __enter__(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self._pool = ProcessPoolExecutor(
            max_workers=self.n_workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker,
            initargs=(worker_env(), os.getpid()),
        )
        return self

    def __exit__(self, exc_type, exc, tb):
        pool, self._pool = self._pool, None
        if pool is None:
            return None
        if exc_type is None:
            pool.shutdown(wait=True)
        else:  # interrupted or failed: drop queued cases and stop running ones now
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                if proc.is_alive():
                    proc.terminate()
            for proc in procs:
                proc.join(timeout=10)
        return None

    def run(self, fn: Callable, config_json: str, cases: Iterable) -> Iterator[tuple[Any, Any]]:
        """Submit every case; yield ``(case, result or exception)`` as they finish."""
        from concurrent.futures import as_completed
        from concurrent.futures.process import BrokenProcessPool

        futures = {self._pool.submit(fn, config_json, case): case for case in cases}
        for fut in as_completed(futures):
            case = futures[fut]
            try:
                result = fut.result()
            except BrokenProcessPool:
                raise
            except Exception as exc:
                result = exc
            yield case, result
