"""Every file and directory a command writes: whole, and owned.

Files (:func:`write_atomic`)
    A file is written to a temporary name beside its target (``.NAME.XXXXXXXX.tmp``, in
    the same directory, so on the same file system), flushed to disk (``fsync``), then
    renamed over the target (``os.replace``, atomic on POSIX) and the directory is flushed
    too.  A kill, a full disk or any error at any moment leaves the old file or the new
    one, never part of one; the temporary file is removed on an error (a SIGKILL leaves
    it, hidden, beside the target).  The files of a directory built for
    :func:`replace_directory` need none of this (the swap makes the directory whole, and
    flushes its files before it).  ``exclusive=True`` puts the finished file in place
    with a hard link instead, which fails when the name exists: a file that must never
    replace another one (``vsi init``) is still never seen half-written.

Directories (:func:`replace_directory`)
    A command that writes a directory of its own (``vsi report``, ``vsi verify``) builds
    it in a new directory beside the target (``.NAME.vsi-tmp-PID``) and, when it is
    complete, swaps the two in one step (``renameat2(RENAME_EXCHANGE)`` on Linux; two
    renames elsewhere).  It owns only the entries it writes (``owns``): whatever else is
    in the old directory - a file another process dropped there while the new one was
    being built - is moved back into the new directory, and only the owned entries of
    the old one are deleted, entry by entry (never ``rmtree``).  Leftovers of a killed
    writer are tidied the same way by the next one.

Directory locks
    A writer of a file holds a shared ``flock`` on the file's directory and on every
    directory above it for the time of the write (the output lock of a study holds them
    for the whole study); a command that replaces a directory holds an exclusive
    ``flock`` on it from before it checks the directory until the swap is done.  The two
    exclude each other whichever starts first, with :class:`DirectoryBusyError` naming
    the directory and, where it can be found, the process holding it: ``vsi sweep -o
    DIR/x.nc`` during ``vsi report -o DIR`` is refused, and so is the report while the
    sweep runs.  The kernel drops a ``flock`` when its process dies (SIGKILL too).

Errors are ``OSError`` with the path; :func:`describe` turns one into the end of a
one-line message ("No space left on device: the disk is full").
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import signal
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from vsi_numba.io.paths import fitting_name, name_max

#: Environment variable of the testing hook of the directory writers: ``k`` (``k:TERM``,
#: ``k:INT``) makes the process send itself SIGKILL (SIGTERM, SIGINT) at its k-th
#: :func:`checkpoint`, after each file of a directory is written and between the steps of
#: the swap, so that a test can stop a writer at every point deterministically.
KILL_ENV = "VSI_REPORT_KILL_AT"
TMP_MARK = ".vsi-tmp-"
OLD_MARK = ".vsi-old-"
_checkpoints = [0]
#: The directories beside their targets that writers of this process are using.
_active: set[str] = set()


class DirectoryBusyError(OSError):
    """Another process holds a directory this write needs (``errno`` EBUSY)."""

    def __init__(self, message: str):
        super().__init__(errno.EBUSY, message)

    def __str__(self) -> str:  # the message alone, without "[Errno 16]"
        return str(self.strerror)


def checkpoint() -> None:
    """Count a step of a directory writer (the testing hook :data:`KILL_ENV`)."""
    spec = os.environ.get(KILL_ENV)
    if not spec:
        return
    _checkpoints[0] += 1
    at, _, name = spec.partition(":")
    if _checkpoints[0] == int(at):
        os.kill(os.getpid(), getattr(signal, f"SIG{name or 'KILL'}"))


def describe(exc: BaseException) -> str:
    """The reason of a failed write, for the end of a message (a full disk said so)."""
    if isinstance(exc, OSError):
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return f"{exc.strerror or 'No space left on device'}: the disk is full"
        if exc.strerror:
            return str(exc.strerror)
    return str(exc) or type(exc).__name__


# ------------------------------------------------------------------------ locks


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid > 0
    return True


def _command_of(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return ""
    parts = [p.decode("utf-8", "replace") for p in raw.split(b"\0") if p]
    if len(parts) >= 3 and parts[1] == "-m" and parts[2].startswith("vsi_numba.cli"):
        parts = ["vsi", *parts[3:]]
    elif parts and Path(parts[0]).name.startswith("python") and len(parts) > 1:
        parts = parts[1:]
    return " ".join(parts)[:200]


def _replacer(directory: Path) -> str:
    """``" (pid N: COMMAND)"`` of a live process replacing ``directory``, or ""."""
    for _path, _kind, pid in leftovers(directory):
        if _pid_alive(pid):
            cmd = _command_of(pid)
            return f" (pid {pid}{': ' + cmd if cmd else ''})"
    return ""


def _writers(directory: Path) -> str:
    """What the output locks (``.*.lock``) in ``directory`` say of their holders."""
    found = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(directory):
            if entry.name.startswith(".") and entry.name.endswith(".lock"):
                with contextlib.suppress(OSError):
                    text = Path(entry.path).read_text(encoding="utf-8",
                                                      errors="replace").strip()
                    if text:
                        found.append(text.splitlines()[0])
    return f" ({'; '.join(found[:2])})" if found else ""


def _lock_dir(path: Path, exclusive: bool) -> int | None:
    """A ``flock`` on the directory ``path`` (its fd), None where there is nothing to
    lock (no such directory, no ``flock`` on this system or file system)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no advisory locks
        return None
    for _ in range(100):  # each retry follows a swap of the directory by its holder
        try:
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        except OSError:
            return None
        try:
            fcntl.flock(fd, (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            if exclusive:
                raise DirectoryBusyError(
                    f"the directory {path} is in use: another process is writing into it"
                    f"{_writers(path) or _replacer(path)}; wait for it to finish or choose "
                    "another directory") from None
            raise DirectoryBusyError(
                f"the directory {path} is being replaced by another process"
                f"{_replacer(path)}; wait for it to finish or write elsewhere") from None
        except OSError:
            os.close(fd)
            return None
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except OSError:
            same = False
        if same:
            return fd
        os.close(fd)  # swapped between our open and our flock: the new one counts
    raise DirectoryBusyError(f"the directory {path} keeps being replaced; try again")


class DirectoryLocks:
    """Shared ``flock`` s on a directory and every directory above it (a writer into
    it), and optionally an exclusive one on a directory (its replacer); see the module
    notes.  Use as a context manager or call :meth:`acquire` / :meth:`release`.

    Parameters
    ----------
    shared : path, optional
        The directory written into; it and its parents are locked shared.
    exclusive : path, optional
        A directory to be replaced; locked exclusive.
    """

    def __init__(self, shared=None, exclusive=None):
        self.shared = None if shared is None else Path(os.path.realpath(shared))
        self.exclusive = None if exclusive is None else Path(os.path.realpath(exclusive))
        self._fds: list[int] = []

    def acquire(self) -> DirectoryLocks:
        """Take the locks or raise :class:`DirectoryBusyError` (never waits)."""
        try:
            if self.shared is not None:
                for d in (self.shared, *self.shared.parents):
                    fd = _lock_dir(d, exclusive=False)
                    if fd is not None:
                        self._fds.append(fd)
            if self.exclusive is not None:
                fd = _lock_dir(self.exclusive, exclusive=True)
                if fd is not None:
                    self._fds.append(fd)
        except BaseException:
            self.release()
            raise
        return self

    def release(self) -> None:
        """Drop the locks."""
        while self._fds:
            os.close(self._fds.pop())

    def __enter__(self) -> DirectoryLocks:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


# ------------------------------------------------------------------------ files


def fsync_dir(directory) -> None:
    """Flush a directory's entries (a rename in it) to disk, where the system can."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _default_mode(path) -> None:
    """Give a temporary file the mode of a normally created one (0666 & ~umask):
    mkstemp makes it private (0600), and the rename would keep that."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


def temp_path(path) -> Path:
    """A new, empty temporary file beside ``path`` (``.NAME.XXXXXXXX.tmp``, shortened
    with a hash of the name when it would not fit), with the default file mode."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    # mkstemp adds 8 random characters and the suffix: the prefix leaves room for them
    prefix = fitting_name(path.name, prefix=".", suffix=".", limit=name_max(parent) - 12)
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=parent)
    os.close(fd)
    try:
        _default_mode(tmp)
    except OSError:
        os.unlink(tmp)
        raise
    return Path(tmp)


def write_atomic(path, write: Callable[[Path], object], *, exclusive: bool = False,
                 parents: bool = False) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, flush it to disk and put
    it in place (see the module notes); return ``path``.

    Parameters
    ----------
    path : path
        The file to write.
    write : callable
        Writes the whole content to the path it is given (it may replace that file).
    exclusive : bool
        Never replace an existing ``path``: ``FileExistsError`` instead.
    parents : bool
        Create the missing directories above ``path`` first.

    Raises
    ------
    OSError
        Any failure (``ENOSPC``, permissions, :class:`DirectoryBusyError`); the temporary
        file is removed and an existing ``path`` is left as it was.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    with DirectoryLocks(shared=parent), DirectoryLocks(shared=make_parents(parent)
                                                       if parents else parent):
        tmp = temp_path(path)
        try:
            write(tmp)
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
            if exclusive:
                os.link(tmp, path)  # fails with EEXIST: never replaces a file
                os.unlink(tmp)
            else:
                os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
            raise
        fsync_dir(parent)
    return path


def make_parents(directory) -> Path:
    """Create ``directory`` and the missing ones above it, and return it; call it with the
    existing ones locked (:class:`DirectoryLocks`), so that nothing is created inside a
    directory another process is replacing."""
    Path(directory).mkdir(parents=True, exist_ok=True)
    return Path(directory)


def write_bytes_atomic(path, data: bytes, **options) -> Path:
    """Write ``data`` to ``path`` with :func:`write_atomic` (same options)."""
    return write_atomic(path, lambda tmp: Path(tmp).write_bytes(data), **options)


def write_text_atomic(path, text: str, encoding: str = "utf-8", **options) -> Path:
    """Write ``text`` to ``path`` with :func:`write_atomic` (same options)."""
    return write_bytes_atomic(path, text.encode(encoding), **options)


# ------------------------------------------------------------------ directories

#: ``owns(relative_path, is_dir)``: whether an entry of a directory is the writer's.
Owns = Callable[[str, bool], bool]


def foreign_entries(path, owns: Owns) -> list[str]:
    """Relative paths (``a``, ``sub/b``) of the entries of the directory ``path`` that
    ``owns`` does not claim; owned directories are looked into."""
    out: list[str] = []

    def walk(folder: str, prefix: str) -> None:
        for entry in sorted(os.scandir(folder), key=lambda e: e.name):
            rel = prefix + entry.name
            is_dir = entry.is_dir(follow_symlinks=False)
            if not owns(rel, is_dir):
                out.append(rel)
            elif is_dir:
                walk(entry.path, rel + "/")

    walk(os.fspath(path), "")
    return out


def _move_foreign(old: Path, into: Path | None, owns: Owns, prefix: str = "") -> None:
    """Move the entries of ``old`` that ``owns`` does not claim to the same place in
    ``into`` (when that name is free there); owned directories are looked into."""
    try:
        entries = list(os.scandir(old))
    except OSError:
        return
    for entry in entries:
        rel = prefix + entry.name
        is_dir = entry.is_dir(follow_symlinks=False)
        if owns(rel, is_dir):
            if is_dir:
                _move_foreign(Path(entry.path), into, owns, rel + "/")
            continue
        if into is None:
            continue
        dest = into / rel
        with contextlib.suppress(OSError):
            dest.parent.mkdir(parents=True, exist_ok=True)
            if not os.path.lexists(dest):
                os.rename(entry.path, dest)


def _remove_owned(folder: Path, owns: Owns, prefix: str = "") -> None:
    """Delete the entries of ``folder`` that ``owns`` claims, one by one (directories
    once emptied); nothing else is touched."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        rel = prefix + entry.name
        is_dir = entry.is_dir(follow_symlinks=False)
        if not owns(rel, is_dir):
            continue
        with contextlib.suppress(OSError):
            if is_dir:
                _remove_owned(Path(entry.path), owns, rel + "/")
                os.rmdir(entry.path)
            else:
                os.unlink(entry.path)


_TEMP_FILE = re.compile(r"^\.(.+)\.[a-z0-9_]{8}\.tmp$")


def with_temps(owns: Owns) -> Owns:
    """``owns``, and also the temporary files of :func:`write_atomic` of the files it
    owns (``.NAME.XXXXXXXX.tmp``, left by a writer killed as it wrote ``NAME``)."""

    def claims(rel: str, is_dir: bool) -> bool:
        if owns(rel, is_dir):
            return True
        head, _, name = rel.rpartition("/")
        m = None if is_dir else _TEMP_FILE.match(name)
        return bool(m) and owns(f"{head}/{m.group(1)}" if head else m.group(1), False)

    return claims


def dispose(old, into, owns: Owns) -> bool:
    """Empty the directory ``old`` of a writer: what ``owns`` does not claim goes to
    ``into`` (None: stays), the rest is deleted (the temporary files of what it owns
    too, :func:`with_temps`); ``old`` itself goes when empty.  Returns True when ``old``
    is gone."""
    old = Path(old)
    owns = with_temps(owns)
    _move_foreign(old, None if into is None else Path(into), owns)
    _remove_owned(old, owns)
    try:
        os.rmdir(old)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return True


def leftovers(target) -> list[tuple[Path, str, int]]:
    """``(path, kind, pid)`` of the directories writers into ``target`` made beside it:
    kind :data:`TMP_MARK`, a new directory being built (everything in it is its
    writer's); kind :data:`OLD_MARK`, the old directory (after the swap, or renamed
    aside) or the complete new one just before the swap (see :func:`_swap`)."""
    target = Path(target)
    out = []
    prefix = f".{target.name}"
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return out
    for entry in entries:
        for kind in (TMP_MARK, OLD_MARK):
            head = prefix + kind
            if entry.name.startswith(head) and entry.name[len(head):].isdigit():
                out.append((Path(entry.path), kind, int(entry.name[len(head):])))
    return out


def _everything(rel: str, is_dir: bool) -> bool:
    return True


def tidy(target, owns: Owns) -> None:
    """Finish what killed writers into ``target`` left beside it: a new directory never
    swapped in is removed; an old directory renamed aside whose replacement never
    arrived goes back to ``target``; any other old one is emptied with :func:`dispose`
    (what ``owns`` does not claim into ``target``)."""
    target = Path(target)
    for path, kind, pid in sorted(leftovers(target), key=lambda t: t[1] != OLD_MARK):
        if (pid != os.getpid() and _pid_alive(pid)) or str(path) in _active:
            continue  # another writer into the same place is running
        if kind == OLD_MARK and not os.path.lexists(target):
            os.rename(path, target)
        elif kind == OLD_MARK:
            dispose(path, target if target.is_dir() and not target.is_symlink() else None,
                    owns)
        else:
            dispose(path, None, _everything)


def _exchange(a: Path, b: Path) -> bool:
    """Swap the directories ``a`` and ``b`` atomically; False where the system cannot."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):  # pragma: no cover - not Linux / old C library
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                   ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False  # the file system cannot exchange: rename in two steps
    raise OSError(err, os.strerror(err), str(b))


def fsync_tree(folder) -> None:
    """Flush every file and directory under ``folder`` to disk (the files of a directory
    built for :func:`replace_directory` are written plainly: the swap makes them whole,
    this makes them durable before it)."""
    for root, _dirs, files in os.walk(folder):
        for name in files:
            try:
                fd = os.open(os.path.join(root, name), os.O_RDONLY | os.O_NOFOLLOW)
            except OSError:  # a symbolic link, a file that cannot be opened: not ours to flush
                continue
            try:
                os.fsync(fd)  # a full disk with delayed allocation says so here: raised
            finally:
                os.close(fd)
        fsync_dir(root)


def _swap(tmp: Path, target: Path, owns: Owns, step: Callable[[], None]) -> None:
    """Put the complete directory ``tmp`` at ``target`` and empty the old one into it
    (its foreign entries kept), SIGINT and SIGTERM held meanwhile."""
    fsync_tree(tmp)
    held = {signal.SIGINT, signal.SIGTERM}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        old = target.with_name(f".{target.name}{OLD_MARK}{os.getpid()}")
        if not os.path.lexists(target):
            os.rename(tmp, target)
            step()
            return
        # the complete new directory takes the old one's name first, so that whatever
        # a kill leaves under that name is emptied into the target by the next writer
        os.rename(tmp, old)
        step()
        if _exchange(old, target):
            step()
            dispose(old, target, owns)  # the old directory, now under that name
            step()
        else:
            os.rename(old, tmp)
            os.rename(target, old)
            step()
            os.rename(tmp, target)
            step()
            dispose(old, target, owns)
            step()
    finally:
        fsync_dir(target.parent)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


@contextmanager
def replace_directory(outdir, owns: Owns, check: Callable[[Path], None] | None = None,
                      step: Callable[[], None] = checkpoint) -> Iterator[Path]:
    """Build a directory that replaces ``outdir`` on success (see the module notes).

    Yields the new, empty directory beside ``outdir``; on a normal exit it takes
    ``outdir``'s place and the owned entries of the old one are deleted (the others
    moved into the new one); on an exception (KeyboardInterrupt too) the new one is
    emptied and removed and ``outdir`` is left as it was.  ``outdir`` is locked
    exclusive (created empty if missing, removed again if the build fails) before
    ``check(outdir)`` runs and until the swap is done.

    Raises
    ------
    DirectoryBusyError
        If another process writes into ``outdir`` (or replaces its parent).
    OSError
        If the directory cannot be made or swapped; whatever ``check`` raises.
    """
    target = Path(os.path.abspath(outdir))
    if target.is_symlink():
        target = target.resolve()
    created = False
    with DirectoryLocks(shared=target.parent), \
            DirectoryLocks(shared=make_parents(target.parent)):
        tidy(target, owns)
        if not os.path.lexists(target):
            with contextlib.suppress(FileExistsError):
                target.mkdir()
                created = True
        try:
            with DirectoryLocks(exclusive=target) if target.is_dir() else \
                    contextlib.nullcontext():
                if check is not None:
                    check(target)
                tmp = target.with_name(f".{target.name}{TMP_MARK}{os.getpid()}")
                if os.path.lexists(tmp):  # left so by tidy: foreign files it cannot place
                    raise FileExistsError(
                        errno.EEXIST, f"{tmp} (left by an earlier writer into {target}) "
                        f"holds files that could not be put back into {target}: move them "
                        "away, then run the command again", str(tmp))
                tmp.mkdir()
                busy = {str(tmp), str(target.with_name(f".{target.name}{OLD_MARK}"
                                                       f"{os.getpid()}"))}
                _active.update(busy)
                try:
                    yield tmp
                    _swap(tmp, target, owns, step)
                except BaseException:
                    dispose(tmp, None, _everything)  # the new directory, never swapped in
                    raise
                finally:
                    _active.difference_update(busy)
        except BaseException:
            if created:
                with contextlib.suppress(OSError):
                    os.rmdir(target)  # only while empty: nothing of anyone else goes
            raise
