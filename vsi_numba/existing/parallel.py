"""Where the evaluations of ``vsi calibrate`` and ``vsi reliability`` run, and the store
that makes both resumable.

An *evaluation* maps rows ``u`` (standard normal coordinates of the parameters or random
inputs) to rows of outputs: the log-likelihood and the records' shifts of a calibration
(:meth:`vsi_numba.existing.calibrate._Prepared.evaluate_u`), the check's values per
speed of a reliability estimate (:meth:`vsi_numba.existing.reliability.Response.values`).
The sampler (emcee, OpenTURNS) asks for a block of rows at a time; the block is cut into
chunks of :data:`~vsi_numba.existing.forward.CHUNK_ROWS` rows in order, the chunks run on
the backend and come back in order.  The chunks are the same on every backend, and a
chunk's arithmetic does not depend on where it runs, so a seed gives the same numbers,
bit for bit, in this process, on threads, in worker processes or on a Dask cluster.

Backends (the names of ``--backend``):

* ``serial`` - this process, one chunk after the other;
* ``threads`` - the default: threads of this process (the kernels release the GIL);
* ``processes`` - local worker processes (spawn), each building the model once from the
  configuration;
* ``dask`` - a Dask cluster: a ``LocalCluster`` of ``--workers N`` worker threads in this
  process, listening on 127.0.0.1 only, or the scheduler at ``--scheduler ADDRESS``,
  whose workers build the model once per process (the records and the files the
  configuration names must be at the same absolute paths there).

The store
    Every block computed is appended to ``OUTPUT.evaluations`` next to the output (its
    rows and outputs as float64, after a header naming the configuration's hash and the
    package version).  A run that is interrupted (Ctrl-C, a kill) leaves it behind; the
    same command on the same configuration replays the sampler from the start, answers
    each block it finds in the store from there (the same rows ask for the same block:
    the sampler is deterministic given its seed and the outputs) and computes the rest,
    so the resumed result is the uninterrupted one, bit for bit.  A store of another
    configuration or version is discarded; ``--fresh`` discards it in any case; a
    finished run removes it.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.existing.forward import CHUNK_ROWS, threads

BACKENDS = ("serial", "threads", "processes", "dask")
#: Format of the store's header.
STORE_FORMAT = "vsi-existing-evaluations-1"
#: Test hook: interrupt (KeyboardInterrupt) after this many blocks were computed.
INTERRUPT_ENV = "VSI_EXISTING_INTERRUPT_AFTER"


class BackendError(ValueError):
    """A backend that cannot be used (the message says why)."""


@dataclass(frozen=True)
class Spec:
    """What a worker needs to build an evaluation: its kind and the configuration."""

    kind: str  # a key of FACTORIES
    config_json: str
    base_dir: str

    @property
    def key(self) -> str:
        return hashlib.sha256(f"{self.kind}\0{self.base_dir}\0{self.config_json}".encode()
                              ).hexdigest()


#: The function that builds a kind's evaluation from a configuration (in a worker).
FACTORIES = {"calibration": "vsi_numba.existing.calibrate:evaluation_of",
             "calibration_predictive": "vsi_numba.existing.calibrate:predictive_of",
             "calibration_check": "vsi_numba.existing.calibrate:check_of",
             "reliability": "vsi_numba.existing.reliability:evaluation_of"}
#: The evaluations this process holds (spec key -> callable rows -> outputs).
_EVALUATIONS: dict = {}


def register(spec: Spec, evaluation) -> None:
    """Use ``evaluation`` for ``spec`` in this process (threads, in-process Dask)."""
    _EVALUATIONS[spec.key] = evaluation


def unregister(spec: Spec) -> None:
    _EVALUATIONS.pop(spec.key, None)


def _evaluation(spec: Spec):
    ev = _EVALUATIONS.get(spec.key)
    if ev is None:  # a worker process: build it from the configuration, once
        import importlib

        from vsi_numba.config import load_config

        cfg = load_config(json.loads(spec.config_json), base_dir=spec.base_dir)
        module, name = FACTORIES[spec.kind].split(":")
        ev = getattr(importlib.import_module(module), name)(cfg)
        _EVALUATIONS[spec.key] = ev
    return ev


_CONTROLLER = []  # this process's threadpoolctl controller, found once


def _blas_one_thread():
    """A context with the BLAS pool at one thread (threadpoolctl's controller of this
    process, its libraries found once: finding them costs ~1 ms, as much as a run)."""
    if not _CONTROLLER:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=1, user_api="blas")


def evaluate_chunk(spec: Spec, u: np.ndarray) -> np.ndarray:
    """The outputs of one chunk of rows (the function every backend runs)."""
    with _blas_one_thread():
        return np.asarray(_evaluation(spec)(np.asarray(u, float)), float)


def chunks(u: np.ndarray) -> list[np.ndarray]:
    """The rows of a block in chunks of :data:`CHUNK_ROWS`, in order."""
    return [u[i: i + CHUNK_ROWS] for i in range(0, len(u), CHUNK_ROWS)]


class Store:
    """The blocks computed so far (see the module notes)."""

    def __init__(self, path: Path | None, identity: dict, fresh: bool = False):
        self.path = None if path is None else Path(path)
        self.identity = dict(identity, format=STORE_FORMAT)
        self.blocks: dict[bytes, np.ndarray] = {}
        self._stored: set[bytes] = set()  # the blocks read from the file
        self.discarded = ""
        self.replayed = 0
        self.computed = 0
        self._file = None
        if self.path is None:
            return
        if fresh and self.path.exists():
            self.path.unlink()
        if self.path.exists():
            self._load()

    @staticmethod
    def _key(u: np.ndarray) -> bytes:
        u = np.ascontiguousarray(u, np.float64)
        return hashlib.sha256(np.asarray(u.shape, np.int64).tobytes() + u.tobytes()).digest()

    def _load(self) -> None:
        raw = self.path.read_bytes()
        head, sep, body = raw.partition(b"\n")
        try:
            ident = json.loads(head.decode()) if sep else None
        except (UnicodeDecodeError, json.JSONDecodeError):
            ident = None
        if ident != self.identity:
            self.discarded = ("it belongs to another configuration or version"
                              if ident is not None else "it is not readable")
            self.path.unlink()
            return
        n_in, n_out = int(self.identity["n_in"]), int(self.identity["n_out"])
        pos = 0
        good = 0
        while pos + 8 <= len(body):
            n = int(np.frombuffer(body, np.int64, 1, pos)[0])
            size = 8 + 8 * n * (n_in + n_out)
            if n < 0 or pos + size > len(body):
                break
            u = np.frombuffer(body, np.float64, n * n_in, pos + 8).reshape(n, n_in)
            y = np.frombuffer(body, np.float64, n * n_out, pos + 8 + 8 * n * n_in
                              ).reshape(n, n_out)
            self.blocks[self._key(u)] = y.copy()
            self._stored.add(self._key(u))
            pos += size
            good = pos
        if good < len(body):  # a block cut short by a kill: drop it
            with open(self.path, "r+b") as f:
                f.truncate(len(head) + 1 + good)

    def get(self, u):
        """The stored outputs of a block (None: not computed yet); a block asked for
        twice in one run (a search that comes back to a point) is computed once."""
        key = self._key(u)
        y = self.blocks.get(key)
        if y is not None and key in self._stored:
            self._stored.discard(key)
            self.replayed += 1
        return y

    def put(self, u, y) -> None:
        u = np.ascontiguousarray(u, np.float64)
        y = np.ascontiguousarray(y, np.float64)
        self.blocks[self._key(u)] = y
        self.computed += 1
        if self.path is None:
            return
        if self._file is None:
            new = not self.path.exists()
            self._file = open(self.path, "ab")  # noqa: SIM115 - kept open while running
            if new:
                self._file.write(json.dumps(self.identity, sort_keys=True).encode() + b"\n")
        self._file.write(np.int64(len(u)).tobytes() + u.tobytes() + y.tobytes())
        self._file.flush()

    def close(self, remove: bool = False) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        if remove and self.path is not None and self.path.exists():
            self.path.unlink()


class Evaluator:
    """Blocks of rows -> outputs, on a backend, through the store (a context manager)."""

    def __init__(self, spec: Spec, evaluation, n_out: int, backend: str | None = None,
                 workers: int | None = None, scheduler: str | None = None,
                 store: Store | None = None):
        if backend is None:
            backend = "dask" if (workers is not None or scheduler is not None) else "threads"
        if backend not in BACKENDS:
            raise BackendError(f"--backend {backend}: expected one of {', '.join(BACKENDS)}")
        if workers is not None and workers < 1:
            raise BackendError(f"--workers {workers}: expected a number of workers >= 1")
        if scheduler is not None and backend != "dask":
            raise BackendError(f"--scheduler with --backend {backend}: a scheduler is a "
                               "Dask cluster's (--backend dask)")
        self.spec = spec
        self.evaluation = evaluation
        self.n_out = int(n_out)
        self.backend = backend
        self.workers = workers
        self.scheduler = scheduler
        self.store = store if store is not None else Store(None, {})
        self.blocks = 0
        self._pool = None
        self._dask = None  # the Dask backend while in use
        self._client = None
        self._spec_ref = None
        self._others: list[Spec] = []  # the specs of :meth:`other`
        self._refs: dict = {}  # their references on a Dask cluster
        limit = os.environ.get(INTERRUPT_ENV, "").strip()
        self._interrupt = int(limit) if limit.isdigit() else None

    @property
    def n_workers(self) -> int:
        if self.backend == "serial":
            return 1
        return int(self.workers or threads())

    def describe(self) -> str:
        if self.backend == "dask":
            return (f"Dask scheduler {self.scheduler}" if self.scheduler else
                    f"Dask LocalCluster of {self.n_workers} workers on 127.0.0.1")
        if self.backend == "serial":
            return "this process"
        return f"{self.n_workers} {self.backend}"

    def __enter__(self):
        register(self.spec, self.evaluation)
        if self.backend == "threads" and self.n_workers > 1:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=self.n_workers)
        elif self.backend == "processes":
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            from vsi_numba.study.backends import _init_worker, worker_env

            self._pool = ProcessPoolExecutor(
                max_workers=self.n_workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_init_worker, initargs=(worker_env(), os.getpid()))
        elif self.backend == "dask":
            self._start_dask()
        return self

    def _start_dask(self) -> None:
        """The cluster of a study's Dask backend (:class:`~vsi_numba.study.cluster.DaskBackend`:
        a loopback LocalCluster of worker threads, or the scheduler, whose workers get
        this process's compiled kernels), the spec scattered to every worker."""
        from vsi_numba.study.cluster import DaskBackend

        self._dask = DaskBackend(n_workers=self.n_workers if self.scheduler is None else None,
                                 scheduler=self.scheduler)
        try:
            self._dask.__enter__()
        except OSError as exc:
            self._stop_dask()
            raise BackendError(f"cannot reach the Dask scheduler {self.scheduler}: {exc}"
                               ) from None
        self._client = self._dask.client
        self._client.wait_for_workers(1)
        self._spec_ref = self._client.scatter(self.spec, broadcast=True, hash=False)

    def _stop_dask(self) -> None:
        dask_backend, self._dask, self._client = self._dask, None, None
        if dask_backend is not None:
            dask_backend.__exit__(None, None, None)

    def __exit__(self, exc_type, exc, tb):
        pool, self._pool = self._pool, None
        try:
            if pool is not None:
                pool.shutdown(wait=exc_type is None, cancel_futures=exc_type is not None)
            if self._dask is not None:
                self._stop_dask()
        finally:
            unregister(self.spec)
            for spec in self._others:
                unregister(spec)
        return None

    def _run(self, parts: list[np.ndarray], spec=None) -> list[np.ndarray]:
        spec = spec or self.spec
        if self.backend == "dask":
            ref = self._spec_ref if spec is self.spec else self._refs[spec.key]
            futures = [self._client.submit(evaluate_chunk, ref, p, pure=False)
                       for p in parts]
            return self._client.gather(futures)
        if self._pool is not None:
            return list(self._pool.map(evaluate_chunk, [spec] * len(parts), parts))
        return [evaluate_chunk(spec, p) for p in parts]

    def other(self, spec: Spec, evaluation, n_out: int):
        """Another evaluation run on this evaluator's backend (its threads, worker
        processes or cluster), in the same chunks, without the store: a callable rows
        (n, n_in) -> outputs (n, n_out).  ``evaluation`` serves this process; a worker
        process builds its own from ``spec`` (:data:`FACTORIES`)."""
        register(spec, evaluation)
        self._others.append(spec)
        if self.backend == "dask":
            self._refs[spec.key] = self._client.scatter(spec, broadcast=True, hash=False)

        def run(u) -> np.ndarray:
            u = np.ascontiguousarray(np.atleast_2d(np.asarray(u, float)))
            if not len(u):
                return np.zeros((0, int(n_out)))
            return np.concatenate(self._run(chunks(u), spec), axis=0).reshape(
                len(u), int(n_out))

        return run

    def __call__(self, u) -> np.ndarray:
        """Outputs (n, n_out) of rows ``u`` (n, n_in): from the store, or computed."""
        u = np.ascontiguousarray(np.atleast_2d(np.asarray(u, float)))
        y = self.store.get(u)
        if y is None:
            y = np.concatenate(self._run(chunks(u)), axis=0).reshape(len(u), self.n_out)
            self.store.put(u, y)
            if self._interrupt is not None and self.store.computed >= self._interrupt:
                raise KeyboardInterrupt
        self.blocks += 1
        return y
