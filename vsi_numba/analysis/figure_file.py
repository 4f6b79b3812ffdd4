"""A figure a command writes to a path the user gave (``vsi modes -o``, ``vsi profile
--plot``, ``vsi trains --signature --plot``): the path is checked before anything is
drawn, and the file is written whole or not at all.

The format is the file name's suffix (``.png``, ``.pdf``, ``.svg``, ... as matplotlib
writes them); a name without one, or with one matplotlib cannot write, is refused rather
than given another name.  Missing directories are created.  The file goes through
:func:`vsi_numba.io.atomic.write_atomic` (temporary name, fsync, rename).
"""

from __future__ import annotations

import os
from pathlib import Path

#: Suffixes matplotlib writes (lower case, without the dot): its Agg canvas's list.
FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")


def figure_problem(path, what: str = "figure") -> str | None:
    """Why a figure cannot be written to ``path`` (its suffix, its length, a directory
    there), or None."""
    from vsi_numba.io.paths import path_length_problem

    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        got = f"'{path.suffix}'" if path.suffix else "no suffix"
        return (f"{path}: the {what} file's name must end in the format to write, .png "
                f"(or {', '.join('.' + f for f in FORMATS[1:6])}, ...); it has {got}")
    problem = path_length_problem(path, what, "choose a shorter name")
    if problem is not None:
        return problem
    if path.is_dir():
        return f"{path} is a directory; give the {what} file's name"
    return None


def save_figure(fig, path, **options) -> Path:
    """Write the matplotlib figure ``fig`` to ``path`` in the format of its suffix
    (``options`` go to ``savefig``), whole or not at all; create missing directories.
    Its texts are drawn literally (:func:`vsi_numba.analysis.sanitize.plot_labels`).

    Raises
    ------
    ValueError
        If :func:`figure_problem` finds the path unusable.
    OSError
        If the file cannot be written (a full disk, permissions); nothing is left.
    """
    from vsi_numba.analysis.sanitize import plot_labels
    from vsi_numba.io.atomic import write_atomic

    plot_labels(fig)  # text from inputs drawn literally
    problem = figure_problem(path)
    if problem is not None:
        raise ValueError(problem)
    fmt = Path(path).suffix.lower().lstrip(".")
    return write_atomic(os.fspath(path), lambda tmp: fig.savefig(tmp, format=fmt, **options),
                        parents=True)
