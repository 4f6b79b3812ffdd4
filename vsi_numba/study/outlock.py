"""One writer per results file: the output lock.

``vsi run`` and ``vsi sweep`` keep their finished batches in different stores
(``out.nc.run-cases/``, ``out.nc.cases/``), each with its own lock; the output file is
what they share.  Whoever writes ``out.nc`` first holds ``.out.nc.lock`` beside it
(``flock``, released by the kernel when the process dies, even on SIGKILL) from before
its store is opened until the file is written and the store removed.  A second ``vsi
run`` or ``vsi sweep`` (or ``run_study``) on the same output is refused at once with
:class:`OutputBusyError`, naming the output and the process that holds it (its pid and
command line, written into the lock file).

The holder also holds a shared lock on the output's directory and on every directory
above it (:class:`vsi_numba.io.atomic.DirectoryLocks`), so a command that replaces a
directory whole (``vsi report -o DIR``, ``vsi verify -o DIR``) and a study writing into it
exclude each other, whichever starts first; the output's directory is created for that.

The lock file is removed by its holder (unlinked while still locked); a process that
locked a file that has since been unlinked (the race with that removal) sees that the
name no longer points to its file and tries again, so two processes can never both hold
"the" lock of one output.
"""

from __future__ import annotations

import contextlib
import os
from datetime import UTC, datetime
from pathlib import Path

from vsi_numba.io.atomic import DirectoryBusyError, DirectoryLocks, make_parents
from vsi_numba.io.paths import fitting_name, name_max
from vsi_numba.study.store import StoreBusyError

LOCK_PREFIX = "."
LOCK_SUFFIX = ".lock"


class OutputBusyError(StoreBusyError):
    """Another process is writing the same results file (exit code 2)."""


def lock_path(output: str | os.PathLike) -> Path:
    """The lock file of a results file: ``.<name>.lock`` beside it (shortened with a hash
    of the name when that would be too long a file name)."""
    output = Path(output)
    limit = name_max(output.parent if str(output.parent) else ".")
    return output.with_name(fitting_name(output.name, prefix=LOCK_PREFIX,
                                         suffix=LOCK_SUFFIX, limit=limit))


def _holder(path: Path) -> str:
    try:
        text = path.read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        text = ""
    return text or "another process (it has not written its name yet)"


class OutputLock:
    """Exclusive lock of a results file for the duration of a ``with`` block.

    Parameters
    ----------
    output : path
        The results file.
    command : str
        What holds it (a command line), written into the lock file for the message
        another process prints.
    """

    def __init__(self, output, command: str = ""):
        self.output = Path(output)
        self.path = lock_path(self.output)
        self.command = command
        self._fd: int | None = None
        self._dirs: DirectoryLocks | None = None

    def acquire(self) -> OutputLock:
        """Take the lock or raise :class:`OutputBusyError` (never waits)."""
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows: no advisory lock
            return self
        parent = self.output.parent if str(self.output.parent) else Path(".")
        # the existing directories first, then the ones made for the output
        first, dirs = DirectoryLocks(shared=parent), DirectoryLocks(shared=parent)
        try:
            first.acquire()
            with contextlib.suppress(OSError):  # else the writability check says why
                make_parents(parent)
            dirs.acquire()
        except DirectoryBusyError as exc:
            raise OutputBusyError(f"cannot write the output {self.output}: {exc}") from None
        finally:
            first.release()
        try:
            self._take(fcntl)
        except BaseException:
            dirs.release()
            raise
        self._dirs = dirs
        return self

    def _take(self, fcntl) -> None:
        """The lock file itself (see :meth:`acquire`)."""
        for _ in range(100):  # each retry follows a removal by the previous holder
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError:  # the directory cannot take it: the writability check says why
                return
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                raise OutputBusyError(
                    f"the output {self.output} is being written by another process: "
                    f"{_holder(self.path)}; wait for it to finish or write to another "
                    "output (-o PATH)") from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except OSError:
                same = False
            if same:
                break
            os.close(fd)  # the holder removed the name between our open and our flock
        else:  # pragma: no cover - a hundred removals in a row
            raise OutputBusyError(f"the output {self.output} keeps changing hands; try again")
        started = datetime.now(UTC).isoformat(timespec="seconds")
        text = f"pid {os.getpid()}: {self.command or 'a study'} (started {started})\n"
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)
            os.pwrite(fd, text.encode("utf-8", "replace"), 0)
        self._fd = fd

    def release(self) -> None:
        """Remove the lock file, then unlock it (the name goes first: see the module),
        then the directories."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                self.path.unlink()
            os.close(self._fd)
            self._fd = None
        if self._dirs is not None:
            self._dirs.release()
            self._dirs = None

    def __enter__(self) -> OutputLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
