"""Parts of a report computed in a second process while this one writes the rest.

A new report spends most of its time in two kinds of work that do not depend on each
other: the re-runs of the governing cases (the time-history figures, the convergence
section: numba kernels) and the figures, tables and text (matplotlib, pandas, openpyxl).
:class:`Background` runs named jobs (functions without arguments) in a child made by
``fork`` (it shares this process's modules and data: nothing is imported or sent to it)
and hands back their results, pickled, as each one is done; on two cores the two kinds
of work then run at once.

The result of a job is the same in either process, so the report is the same file: a
job the child could not deliver (it raised, or the child died) is run again here, where
it raises as it would have; where there is no ``fork``, a single core, or a thread
besides this one (a fork would copy locks held by it), every job runs here when it is
asked for.  The child dies with this process (``PR_SET_PDEATHSIG``), is killed when the
report ends or stops, and leaves the testing hook of :func:`~vsi_numba.io.atomic.checkpoint`
to this process.
"""

from __future__ import annotations

import gc
import os
import pickle
import threading
import warnings
from collections.abc import Callable

from vsi_numba.io.atomic import KILL_ENV


def can_fork() -> bool:
    """A child by ``fork`` would run beside this process: POSIX ``fork``, two cores or
    more, and no thread but this one."""
    import multiprocessing as mp

    from vsi_numba._process import available_cores

    return (hasattr(os, "fork") and "fork" in mp.get_all_start_methods()
            and available_cores() >= 2 and threading.active_count() == 1)


def _die_with_parent(parent: int) -> None:
    """SIGTERM to this process when its parent ends (Linux), and an exit now if it has
    ended already."""
    import signal

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    if os.getppid() != parent:
        os._exit(1)


def _close_directory_fds(keep: int) -> None:
    """Close this process's descriptors of directories (but ``keep``): the ``flock`` s
    of the report directory (:class:`~vsi_numba.io.atomic.DirectoryLocks`) are the
    parent's; a copy held here would keep them after the parent ended."""
    import stat

    try:
        fds = [int(f) for f in os.listdir("/proc/self/fd")]
    except OSError:  # pragma: no cover - not Linux
        fds = list(range(3, 1024))
    for fd in fds:
        if fd <= 2 or fd == keep:
            continue
        try:
            if stat.S_ISDIR(os.fstat(fd).st_mode):
                os.close(fd)
        except OSError:
            pass


def _child(jobs: dict, conn, parent: int) -> None:
    """The child's work: each job in order, its result sent as ``(name, True, value)``
    or ``(name, False, None)`` when it raised (this process then runs it itself).  A
    thread sends them: a result larger than the pipe's buffer waits there until the
    parent asks for it, and the next job must not wait with it."""
    import queue

    _die_with_parent(parent)
    _close_directory_fds(conn.fileno())
    os.environ.pop(KILL_ENV, None)  # the testing hook counts the report's own steps
    outbox: queue.Queue = queue.Queue()

    def send() -> None:
        while (message := outbox.get()) is not None:
            try:
                conn.send_bytes(message)
            except OSError:  # the parent stopped reading
                return

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    try:
        for name, job in jobs.items():
            try:
                message = pickle.dumps((name, True, job()),
                                       protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:  # noqa: BLE001 - run again in the parent, where it raises
                message = pickle.dumps((name, False, None))
            outbox.put(message)
    finally:  # an interrupt too: what is done is sent, nothing more is made
        outbox.put(None)
        sender.join()
        conn.close()


class Background:
    """Run ``jobs`` (name -> function without arguments) in a child process by ``fork``
    (when ``fork`` is True, or None and :func:`can_fork`); :meth:`get` returns a job's
    result, from the child, or computed here.  Use it as a context manager (the child
    is ended on leaving)."""

    def __init__(self, jobs: dict[str, Callable[[], object]], fork: bool | None = None):
        self.jobs = dict(jobs)
        self.results: dict = {}
        self.failed: set = set()
        self.proc = None
        self.conn = None
        if self.jobs and (can_fork() if fork is None else fork):
            self._start()

    def _start(self) -> None:
        import multiprocessing as mp

        ctx = mp.get_context("fork")
        reader, writer = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_child, args=(self.jobs, writer, os.getpid()),
                           daemon=True, name="vsi-report-background")
        # the objects made so far out of the collector's reach in the child: a collection
        # there would write to every page holding one (copied from the parent, a page
        # fault each)
        gc.freeze()
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of fork with threads
                warnings.simplefilter("ignore", DeprecationWarning)
                proc.start()
        except OSError:  # no process to spare: the jobs run here
            reader.close()
            writer.close()
            return
        finally:
            gc.unfreeze()
        writer.close()
        self.proc, self.conn = proc, reader

    @property
    def forked(self) -> bool:
        """The jobs run in a child process."""
        return self.proc is not None

    def get(self, name: str):
        """The result of job ``name``: the child's when it delivered it, else the job
        run here (once)."""
        while (name not in self.results and name not in self.failed
               and self.conn is not None):
            try:
                got, ok, value = pickle.loads(self.conn.recv_bytes())
            except (EOFError, OSError, pickle.UnpicklingError):  # the child ended
                self.close()
                break
            if ok:
                self.results[got] = value
            else:
                self.failed.add(got)
        if name in self.results:
            return self.results.pop(name)
        return self.jobs[name]()

    def close(self) -> None:
        """End the child (if any) and wait for it."""
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        if self.proc is not None:
            if self.proc.is_alive():
                self.proc.kill()
            self.proc.join()
            self.proc.close()
            self.proc = None

    def __enter__(self) -> Background:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
