"""A report directory written whole or not at all.

:func:`atomic_directory` gives a new, empty directory beside the target
(``.<name>.vsi-tmp-<pid>``); the report is written there and, when it is complete, takes
the target's place in one step: ``renameat2(RENAME_EXCHANGE)`` swaps the two directories
atomically (Linux), and the old report, now under the temporary name, is removed after.
Where the exchange is not available, the old directory is renamed aside
(``.<name>.vsi-old-<pid>``) and the new one renamed in. SIGINT and SIGTERM are held
during the swap. A kill at any moment therefore leaves the complete old report or
the complete new one at the target, never a mixture; the next report into the same place
removes what a killed one left beside it (and puts an old report renamed aside back if
the new one never took its place).

The target must hold a report and nothing else (:func:`foreign_entries`): it is replaced
whole, so a directory with other files in it (the results file, notes) is refused.

Testing hook: with the environment variable ``VSI_REPORT_KILL_AT=k`` (``k:TERM``,
``k:INT``) the process sends itself SIGKILL (SIGTERM, SIGINT) at its k-th
:func:`checkpoint` - after each file of the report is written and between the steps of
the swap - so that a test can stop the writer at every point deterministically.
"""

from __future__ import annotations

import os
import shutil
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: Environment variable of the testing hook (see the module notes).
KILL_ENV = "VSI_REPORT_KILL_AT"
_TMP = ".vsi-tmp-"
_OLD = ".vsi-old-"
_checkpoints = [0]

#: Files and folders a report directory may hold (any report of this package: the study
#: report, the variants report and its governing variant's report).
REPORT_ENTRIES = frozenset({
    "report.md", "report.html", "summary.csv", "tables.xlsx", "tables", "variants.csv",
    "variants.json", "design_chart.png", "governing_variant", "load_effects.png",
    "deck_acceleration.png", "dynamic_amplification.png", "wheel_unloading.png",
    "comfort.png", "time_history.png", "wheel_unloading_history.png",
    "fatigue_spectra.png", "signature.png"})


class ReportDirectoryError(OSError):
    """The target cannot take a report (it holds other files, or it is the working
    directory)."""


def checkpoint() -> None:
    """Count a step of the report writer (the testing hook of the module notes)."""
    spec = os.environ.get(KILL_ENV)
    if not spec:
        return
    _checkpoints[0] += 1
    at, _, name = spec.partition(":")
    if _checkpoints[0] == int(at):
        os.kill(os.getpid(), getattr(signal, f"SIG{name or 'KILL'}"))


def foreign_entries(path: Path) -> list[str]:
    """Entries of the directory ``path`` that no report writes (a report directory may be
    replaced whole only when this is empty)."""
    out = []
    for entry in sorted(os.scandir(path), key=lambda e: e.name):
        if entry.name not in REPORT_ENTRIES:
            out.append(entry.name)
        elif entry.name == "tables" and entry.is_dir(follow_symlinks=False):
            out += [f"tables/{n}" for n in sorted(os.listdir(entry.path))
                    if not n.endswith(".csv")]
        elif entry.name == "governing_variant" and entry.is_dir(follow_symlinks=False):
            out += [f"governing_variant/{n}" for n in foreign_entries(Path(entry.path))]
        elif entry.is_dir(follow_symlinks=False) != (entry.name in ("tables",
                                                                   "governing_variant")):
            out.append(entry.name)
    return out


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _leftovers(target: Path) -> list[tuple[Path, str, int]]:
    """(path, kind, pid) of the temporary directories of earlier reports into ``target``."""
    out = []
    prefix = f".{target.name}"
    try:
        entries = list(os.scandir(target.parent))
    except FileNotFoundError:
        return out
    for entry in entries:
        for kind in (_TMP, _OLD):
            head = prefix + kind
            if entry.name.startswith(head) and entry.name[len(head):].isdigit():
                out.append((Path(entry.path), kind, int(entry.name[len(head):])))
    return out


def _tidy(target: Path) -> None:
    """Remove what killed reports into ``target`` left beside it; an old report renamed
    aside whose replacement never arrived goes back to ``target``."""
    for path, kind, pid in _leftovers(target):
        if pid != os.getpid() and _pid_alive(pid):
            continue  # another report into the same place is running
        if kind == _OLD and not os.path.lexists(target):
            os.rename(path, target)
            continue
        shutil.rmtree(path, ignore_errors=True)


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
    import errno

    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False  # the file system cannot exchange: rename in two steps
    raise OSError(err, os.strerror(err), str(b))


def _swap(tmp: Path, target: Path) -> None:
    """Put the complete report ``tmp`` at ``target`` (see the module notes), SIGINT and
    SIGTERM held meanwhile (they act when it is done)."""
    held = {signal.SIGINT, signal.SIGTERM}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        if not os.path.lexists(target):
            os.rename(tmp, target)
            checkpoint()
        elif _exchange(tmp, target):
            checkpoint()
            shutil.rmtree(tmp)  # the old report, now under the temporary name
            checkpoint()
        else:
            old = target.with_name(f".{target.name}{_OLD}{os.getpid()}")
            os.rename(target, old)
            checkpoint()
            os.rename(tmp, target)
            checkpoint()
            shutil.rmtree(old)
            checkpoint()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def check_target(target: Path) -> None:
    """Raise :class:`ReportDirectoryError` when ``target`` cannot be replaced by a report:
    not a directory, the working directory (or one holding it), or a directory with
    files that are not a report's."""
    if not os.path.lexists(target):
        return
    if not target.is_dir():
        raise ReportDirectoryError(f"'{target}' exists and is not a directory")
    cwd = Path.cwd().resolve()
    if cwd == target or target in cwd.parents:
        raise ReportDirectoryError(
            f"'{target}' is the working directory or holds it: a report replaces its "
            "directory whole; give a directory of its own (-o DIR)")
    foreign = foreign_entries(target)
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more"
                                          if len(foreign) > 3 else "")
        raise ReportDirectoryError(
            f"'{target}' holds files that are not part of a report ({shown}): a report "
            "replaces its directory whole; give an empty or new directory, or one that "
            "holds only an earlier report")


@contextmanager
def atomic_directory(outdir) -> Iterator[Path]:
    """Write a report into a new directory that replaces ``outdir`` whole on success.

    Yields the temporary directory (beside ``outdir``, on the same file system). On a
    normal exit it takes ``outdir``'s place; on an exception (KeyboardInterrupt too) it
    is removed and ``outdir`` is left as it was.

    Raises
    ------
    ReportDirectoryError
        If ``outdir`` cannot be replaced (:func:`check_target`).
    """
    target = Path(os.path.abspath(outdir))
    if target.is_symlink():
        target = target.resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    _tidy(target)
    check_target(target)
    tmp = target.with_name(f".{target.name}{_TMP}{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        yield tmp
        _swap(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
