"""The Dask backend of a study: a ``dask.distributed`` cluster (:class:`DaskBackend`), the
chunks of neighbouring batches it runs as tasks (:func:`dask_chunks`), and a cluster of
separate processes on 127.0.0.1 as a user starts one by hand (:class:`LoopbackCluster`).

The other backends and what every backend promises: :mod:`vsi_numba.study.backends`.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from vsi_numba._process import term_with_parent as _term_with_parent
from vsi_numba.study.backends import LOOPBACK, QUIET_DASK, worker_env


class DaskBackend:
    """A Dask cluster: a loopback ``LocalCluster`` of ``n_workers``, or ``scheduler``."""

    name = "dask"

    def __init__(self, n_workers: int | None = None, scheduler: str | None = None,
                 key_prefix: str = "vsi-batch", local_directory=None):
        if scheduler is None and (n_workers is None or n_workers < 1):
            raise ValueError(f"workers = {n_workers!r}: expected >= 1")
        self.scheduler = scheduler
        self._n = n_workers
        self.key_prefix = key_prefix
        self.local_directory = local_directory
        self._cluster = None
        self._client = None
        self._futures: list = []
        self._config = None
        self._log = None  # the "distributed" logger while in use (see __enter__)
        self._log_level = logging.NOTSET

    @property
    def n_workers(self) -> int:
        """Workers of the cluster (as seen when it was connected)."""
        if self._client is None:
            return self._n or 0
        return len(self._client.scheduler_info(n_workers=-1).get("workers", {}))

    @property
    def client(self):
        """The connected ``dask.distributed.Client`` (None outside the ``with`` block)."""
        return self._client

    @property
    def n_threads(self) -> int:
        """Threads of the cluster's workers (as the scheduler reports them)."""
        if self._client is None:
            return self._n or 0
        workers = self._client.scheduler_info(n_workers=-1).get("workers", {})
        return int(sum(w.get("nthreads", 0) for w in workers.values()))

    def __enter__(self):
        import dask
        from dask.distributed import Client, LocalCluster

        # Dask's scratch space (spilling, locks) in the store, not the system temp dir;
        # no profiler and slow admin ticks in this process (QUIET_DASK)
        config = dict(QUIET_DASK)
        if self.local_directory is not None:
            config["temporary-directory"] = str(self.local_directory)
        self._config = dask.config.set(config)
        self._config.__enter__()
        # distributed logs at INFO to stderr once its LocalCluster has closed (and
        # restored the level it silenced), e.g. "Batched Comm Closed" with the traceback
        # of a comm an interrupted sweep shut: WARNING while the backend is in use
        # (LocalCluster restores to that), and after an interrupted or failed study
        self._log = logging.getLogger("distributed")
        self._log_level = self._log.level
        if self._log.getEffectiveLevel() < logging.WARNING:
            self._log.setLevel(logging.WARNING)
        if self.scheduler is not None:
            self._client = Client(self.scheduler, timeout="30s")
            # the workers load this process's compiled kernels instead of compiling them
            from vsi_numba.study.worker_kernels import share_kernels

            share_kernels(self._client)
        else:
            # worker threads in this process (the kernels release the GIL): no process
            # start-up, the model and the numba cache are loaded once; in-process
            # transport, the dashboard (if any) on loopback, scratch space in the store
            kw = {}
            if self.local_directory is not None:
                kw["local_directory"] = str(self.local_directory)
            self._cluster = LocalCluster(
                n_workers=self._n, threads_per_worker=1, processes=False,
                dashboard_address=f"{LOOPBACK}:0",
                worker_dashboard_address=f"{LOOPBACK}:0", **kw,
            )
            self._client = Client(self._cluster)
        return self

    def __exit__(self, exc_type, exc, tb):
        client, cluster = self._client, self._cluster
        self._client = self._cluster = None
        try:
            if client is not None:
                if self._futures and exc_type is not None:
                    client.cancel(self._futures)
                self._futures = []
                client.close()
        finally:
            if cluster is not None:
                cluster.close()
            if self._config is not None:
                self._config.__exit__(None, None, None)
                self._config = None
            if exc_type is None and self._log is not None:
                self._log.setLevel(self._log_level)
            if self.local_directory is not None:
                import shutil

                shutil.rmtree(self.local_directory, ignore_errors=True)
        return None

    def run(self, fn: Callable, spec, batches: Iterable) -> Iterator[tuple[Any, Any]]:
        """Run the batches as chunked tasks; yield ``(batch, result or exception)`` as
        the chunks finish.

        The spec (one per variant: 91 configurations for the catalogue) is scattered to
        every worker once instead of being pickled into each task, and the batches go in
        :func:`dask_chunks` of about :func:`chunk_seconds` each, neighbours in the plan
        together (same variant and train: the worker's model cache hits).
        """
        from dask.distributed import as_completed

        batches = list(batches)
        if not batches:
            return
        client = self._client
        if not self.n_workers:  # scatter needs a worker: wait for one (no time limit), as
            client.wait_for_workers(1)  # the tasks would; later workers fetch the spec
        # the spec (a tuple: one piece of data) and, on a cluster of other processes, the
        # models this process built from it (the catalogue: 91, 2 MB pickled), so that
        # no worker builds them again
        models = _built_models(spec) if self.scheduler is not None else {}
        spec_ref, models_ref = client.scatter([spec, models], broadcast=True, hash=False)
        n_threads = max(self.n_threads, 1)
        chunks = dask_chunks(batches, chunk_seconds(batches, n_threads), n_threads)
        futures = [
            client.submit(run_chunk, fn, spec_ref, chunk, models_ref,
                          key=f"{self.key_prefix}-{chunk[0].key}-n{len(chunk)}",
                          pure=False, retries=0, priority=-i)
            for i, chunk in enumerate(chunks)
        ]
        self._futures = futures
        by_key = {f.key: c for f, c in zip(futures, chunks, strict=True)}
        for fut in as_completed(futures):
            chunk = by_key[fut.key]
            try:
                results = fut.result()
            except Exception as exc:  # the whole task failed (e.g. a worker died)
                results = [exc] * len(chunk)
            fut.release()
            yield from zip(chunk, results, strict=True)
        spec_ref.release()
        models_ref.release()
        self._futures = []


#: Bounds of the estimated kernel seconds of one Dask task (see :func:`chunk_seconds`).
CHUNK_SECONDS = (0.25, 2.0)
#: Tasks per worker thread a chunked study aims at (load balance of the last tasks).
CHUNKS_PER_THREAD = 8
#: At the end of the plan a task holds at most the cost still to be chunked over this
#: many tasks per worker thread (see :func:`dask_chunks`).
TAIL_CHUNKS_PER_THREAD = 4


def chunk_seconds(batches, n_threads: int) -> float:
    """Estimated kernel seconds of one Dask task: the study's estimated cost over
    :data:`CHUNKS_PER_THREAD` tasks per worker thread, within :data:`CHUNK_SECONDS`.

    A task costs the scheduler, the transport and the worker a few milliseconds whatever
    its size: the catalogue's 910 batches of ~0.05 s each lost ~10 % to that as one
    task each.  Eight or more tasks per thread, largest first, keep the last ones short.
    """
    lo, hi = CHUNK_SECONDS
    total = float(sum(b.cost for b in batches))
    return min(hi, max(lo, total / (CHUNKS_PER_THREAD * max(int(n_threads), 1))))


def dask_chunks(batches, seconds: float, n_threads: int | None = None) -> list[list]:
    """Group batches into tasks of about ``seconds`` estimated kernel time.

    Batches are taken in plan order (``index``: one variant's trains and speeds are
    neighbours, so a worker builds each model once), cut when the next batch would pass
    the chunk's target; a batch that keeps raw histories is a task of its own (its
    buffers are up to :data:`~vsi_numba.study.batches.BATCH_HISTORY_BYTES`).  The
    chunks are returned largest first (longest-processing-time order).  The chunks
    depend on the worker count; the batches, which name the stored results, do not.

    With ``n_threads`` the target shrinks at the end of the plan (guided
    self-scheduling): it is ``seconds``, or the cost still to be chunked over
    ``TAIL_CHUNKS_PER_THREAD x n_threads`` when that is less, but no less than the
    floor of :data:`CHUNK_SECONDS`.  Submitted largest first, the last tasks are then
    short and the threads finish together.
    """
    lo = min(CHUNK_SECONDS[0], seconds)
    order = sorted(batches, key=lambda b: b.index)
    remaining = float(sum(b.cost for b in order))
    tail = None if n_threads is None else TAIL_CHUNKS_PER_THREAD * max(int(n_threads), 1)
    chunks: list[list] = []
    chunk: list = []
    cost = 0.0

    def target():
        return seconds if tail is None else min(seconds, max(lo, (remaining + cost) / tail))

    for b in order:
        alone = any(b.histories)
        if chunk and (alone or cost + b.cost > target()):
            chunks.append(chunk)
            chunk, cost = [], 0.0
        chunk.append(b)
        cost += b.cost
        remaining -= b.cost
        if alone:
            chunks.append(chunk)
            chunk, cost = [], 0.0
    if chunk:
        chunks.append(chunk)
    return sorted(chunks, key=lambda c: (-sum(b.cost for b in c), c[0].index))


def run_chunk(fn: Callable, spec, chunk, models: dict | None = None) -> list:
    """Run ``fn(spec, batch)`` for every batch of a chunk; a batch's exception is its
    result (the others still run).  ``models`` (spec -> built model) seed this process's
    model cache with the chunk's models first (the cache keeps its bound: the oldest
    model goes, as when it builds one)."""
    if models:
        from vsi_numba.study.batches import _spec_of
        from vsi_numba.study.spec import _MODELS, MODEL_CACHE_SIZE

        for s in dict.fromkeys(_spec_of(spec, b) for b in chunk):
            if s in models and s not in _MODELS:
                while len(_MODELS) >= MODEL_CACHE_SIZE:
                    _MODELS.pop(next(iter(_MODELS)))
                _MODELS[s] = models[s]
    out = []
    for batch in chunk:
        try:
            out.append(fn(spec, batch))
        except Exception as exc:  # reported per batch by the runner
            out.append(exc)
    return out


def _built_models(spec) -> dict:
    """The models this process holds for ``spec`` (one spec or a tuple of them)."""
    from vsi_numba.study.spec import _MODELS

    specs = (spec,) if hasattr(spec, "config_json") else tuple(spec)
    return {s: _MODELS[s] for s in specs if s in _MODELS}


class LoopbackCluster:
    """A Dask cluster of separate processes on 127.0.0.1: ``dask scheduler`` and
    ``n_workers`` x ``dask worker --nthreads 1`` (each a nanny and its worker), as a
    user starts them by hand; ``address`` is the scheduler's ``tcp://127.0.0.1:PORT``.

    Every listener (scheduler, its dashboard, workers, nannies, their dashboards) is
    bound to 127.0.0.1 on a free port.  The processes get ``env`` on top of this
    process's environment (default :func:`worker_env`: one thread each, this process's
    ``NUMBA_CACHE_DIR``).

    Start-up waits on events, never for a fixed time: the scheduler file (complete JSON),
    then the scheduler's count of running workers, each polled until ``timeout`` seconds
    have passed or a process has exited (then the error names the logs).  On exit, also
    when the start or the body failed, every process of the cluster - the ones started
    here and all their descendants (a nanny's worker) - is sent SIGTERM, then SIGKILL
    after ``grace`` seconds, and waited for until it is gone.  The processes started here
    also get SIGTERM from Linux if this thread dies (``PR_SET_PDEATHSIG``); a worker ends
    with its nanny.

    Parameters
    ----------
    n_workers : int
        Worker processes (one thread each).
    directory : path
        Scratch space of the cluster (scheduler file, worker directories, logs).
    env : dict, optional
        Environment added to this process's (default :func:`worker_env`).
    timeout : float
        Seconds to wait for the scheduler, for the workers, and for the processes to go
        after SIGKILL.
    grace : float
        Seconds between SIGTERM and SIGKILL on exit.
    """

    def __init__(self, n_workers: int, directory, env: dict | None = None,
                 timeout: float = 300.0, grace: float = 10.0):
        from pathlib import Path

        if n_workers < 1:
            raise ValueError(f"workers = {n_workers!r}: expected >= 1")
        self.n_workers = int(n_workers)
        self.directory = Path(directory)
        self.env = dict(os.environ)
        self.env.update(worker_env() if env is None else env)
        self.timeout, self.grace = float(timeout), float(grace)
        self.address: str | None = None
        self._procs: list = []

    @property
    def pids(self) -> list[int]:
        """Process ids of the cluster now: the processes started here (scheduler,
        nannies) and all their descendants (workers)."""
        return [p.pid for p in self._tree()]

    def _tree(self) -> list:
        import psutil

        out: dict = {}
        for p in self._procs:
            try:
                root = psutil.Process(p.pid)
                for q in (root, *root.children(recursive=True)):
                    out.setdefault(q.pid, q)
            except psutil.Error:
                continue
        return list(out.values())

    def _start(self, args: list[str], name: str):
        import subprocess

        log = open(self.directory / f"{name}.log", "wb")  # noqa: SIM115 - kept open
        try:
            proc = subprocess.Popen([sys.executable, "-m", "dask", *args], env=self.env,
                                    cwd=self.directory, stdout=log, stderr=subprocess.STDOUT,
                                    start_new_session=True, preexec_fn=_term_with_parent())
        finally:
            log.close()
        self._procs.append(proc)
        return proc

    def __enter__(self):
        import json
        import time

        self.directory.mkdir(parents=True, exist_ok=True)
        sched_file = self.directory / "scheduler.json"
        sched_file.unlink(missing_ok=True)
        try:
            self._start(["scheduler", "--host", LOOPBACK, "--port", "0",
                         "--dashboard-address", f"{LOOPBACK}:0",
                         "--scheduler-file", str(sched_file)], "scheduler")
            t_end = time.monotonic() + self.timeout
            while self.address is None:
                try:  # written when the scheduler listens; a partly written file waits
                    self.address = json.loads(sched_file.read_text())["address"]
                except (OSError, ValueError, KeyError):
                    self._check(t_end, "the scheduler")
                    time.sleep(0.05)
            for i in range(self.n_workers):
                self._start(["worker", self.address, "--nthreads", "1",
                             "--host", LOOPBACK, "--dashboard-address", f"{LOOPBACK}:0",
                             "--nanny-port", "0", "--worker-port", "0",
                             "--local-directory", str(self.directory / f"worker{i}"),
                             "--name", f"vsi-worker-{i}"], f"worker{i}")
            from dask.distributed import Client

            t_end = time.monotonic() + self.timeout
            with Client(self.address, timeout=f"{self.timeout:.0f}s") as client:
                while True:  # the scheduler's count of running workers, polled
                    try:
                        client.wait_for_workers(self.n_workers, timeout=1.0)
                        break
                    except TimeoutError:
                        self._check(t_end, f"{self.n_workers} workers")
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _check(self, t_end: float, what: str) -> None:
        import time

        dead = [p for p in self._procs if p.poll() is not None]
        if dead or time.monotonic() > t_end:
            why = (f"a process exited with {dead[0].returncode}" if dead
                   else f"not up after {self.timeout:.0f} s")
            raise RuntimeError(f"{what} of the loopback Dask cluster: {why}; "
                               f"logs in {self.directory}")

    def __exit__(self, *exc):
        import signal
        import time

        import psutil

        tree = self._tree()  # before any signal: a nanny's worker is found through it
        procs = self._procs

        def alive():
            for p in procs:
                p.poll()  # reap the direct children
            out = []
            for q in tree:
                try:
                    if q.status() != psutil.STATUS_ZOMBIE:
                        out.append(q)
                except psutil.NoSuchProcess:
                    pass
            return out

        def wait(seconds):
            t_end = time.monotonic() + seconds
            while alive() and time.monotonic() < t_end:
                time.sleep(0.05)

        # SIGTERM to the nannies, then to the scheduler, never to a worker: a nanny
        # closes its worker (one killed under a running nanny would be restarted), while
        # the scheduler is still there to see it go
        t_end = time.monotonic() + self.grace
        for group in (procs[1:], procs[:1]):
            for p in group:
                if p.poll() is None:
                    try:
                        p.send_signal(signal.SIGTERM)
                    except OSError:
                        pass
            while any(p.poll() is None for p in group) and time.monotonic() < t_end:
                time.sleep(0.05)
        wait(t_end - time.monotonic())
        tree = list({q.pid: q for q in [*tree, *self._tree()]}.values())  # restarted ones
        self._procs = []
        for q in alive():
            try:
                q.send_signal(signal.SIGKILL)
            except psutil.Error:
                pass
        wait(self.timeout)
        for p in procs:
            try:
                p.wait(timeout=self.timeout)
            except Exception:  # noqa: BLE001 - nothing more to do about it
                pass
        return None
