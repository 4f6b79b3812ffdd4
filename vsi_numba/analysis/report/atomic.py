"""A report directory written whole or not at all, owning only its own files.

:func:`atomic_directory` gives a new, empty directory beside the target
(``.<name>.vsi-tmp-<pid>``); the report is written there and, when it is complete, takes
the target's place in one step (:func:`vsi_numba.io.atomic.replace_directory`):
``renameat2(RENAME_EXCHANGE)`` swaps the two directories atomically (Linux); where the
exchange is not available, the old directory is renamed aside
(``.<name>.vsi-old-<pid>``) and the new one renamed in. SIGINT and SIGTERM are held
during the swap. A kill at any moment therefore leaves the complete old report or
the complete new one at the target, never a mixture; the next report into the same place
tidies what a killed one left beside it (and puts an old report renamed aside back if
the new one never took its place).

The target must hold a report and nothing else when the report starts
(:func:`foreign_entries`); from then until the swap the report holds an exclusive lock on
it, so a ``vsi sweep`` or ``vsi run`` writing into it is refused (and the report is
refused while one of them writes there). Of the old directory only the report's own
files are deleted, one by one: anything else found in it at the swap (a file dropped
there by another program meanwhile) is moved into the new report directory.

Testing hook: with the environment variable ``VSI_REPORT_KILL_AT=k`` (``k:TERM``,
``k:INT``) the process sends itself SIGKILL (SIGTERM, SIGINT) at its k-th
:func:`checkpoint` - after each file of the report is written and between the steps of
the swap - so that a test can stop the writer at every point deterministically.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from vsi_numba.io import atomic as _io
from vsi_numba.io.atomic import KILL_ENV, _checkpoints, checkpoint  # noqa: F401

#: Files and folders a report directory may hold (any report of this package: the study
#: report, the variants report and its governing variant's report).
REPORT_ENTRIES = frozenset({
    "report.md", "report.html", "summary.csv", "tables.xlsx", "tables", "variants.csv",
    "variants.json", "design_chart.png", "governing_variant", "load_effects.png",
    "deck_acceleration.png", "dynamic_amplification.png", "wheel_unloading.png",
    "comfort.png", "time_history.png", "wheel_unloading_history.png",
    "fatigue_spectra.png", "signature.png"})


class ReportDirectoryError(OSError):
    """The target cannot take a report (it holds other files, is the working directory,
    or another process writes into it)."""


def _owns(rel: str, is_dir: bool) -> bool:
    """Whether ``rel`` (a path inside a report directory) is a report's file."""
    head, _, rest = rel.partition("/")
    if not rest:
        return head in REPORT_ENTRIES and is_dir == (head in ("tables", "governing_variant"))
    if head == "tables":
        return "/" not in rest and not is_dir and rest.endswith(".csv")
    if head == "governing_variant":
        return _owns(rest, is_dir)
    return False


def foreign_entries(path: Path) -> list[str]:
    """Entries of the directory ``path`` that no report writes (a report directory may be
    replaced whole only when this is empty)."""
    return _io.foreign_entries(path, _owns)


def _tidy(target: Path) -> None:
    """Finish what killed reports into ``target`` left beside it: an old report renamed
    aside whose replacement never arrived goes back to ``target``; of the others, the
    report files are removed and anything else is put back into ``target``."""
    _io.tidy(target, _owns)


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
        If ``outdir`` cannot be replaced (:func:`check_target`) or another process
        writes into it.
    """
    target = Path(os.path.abspath(outdir))
    if target.is_symlink():
        target = target.resolve()
    if os.path.lexists(target) and not target.is_dir():
        check_target(target)  # raises: not a directory
    try:
        with _io.replace_directory(target, _owns, check=check_target,
                                   step=checkpoint) as tmp:
            yield tmp
    except _io.DirectoryBusyError as exc:
        raise ReportDirectoryError(str(exc)) from None
