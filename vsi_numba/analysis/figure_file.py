"""A figure a command writes to a path the user gave (``vsi modes -o``, ``vsi profile
--plot``, ``vsi trains --signature --plot``): the path is checked before anything is
drawn, and the file is written whole or not at all.

Every figure the package writes, here or in a report, goes through :func:`savefig`: the
same figure gives the same bytes on every machine (no metadata, no path simplification,
:data:`METADATA`, :data:`RC`), and text from inputs in it is drawn literally
(:func:`vsi_numba.analysis.sanitize.plot_labels`).

The format is the file name's suffix (``.png``, ``.pdf``, ``.svg``, ... as matplotlib
writes them); a name without one, or with one matplotlib cannot write, is refused rather
than given another name.  Missing directories are created.  The file goes through
:func:`vsi_numba.io.atomic.write_atomic` (temporary name, fsync, rename).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

#: Metadata of every written figure: none.  matplotlib writes its version as the PNG's
#: ``Software`` and a date into SVG and PDF; another version or day would change the file.
METADATA = {"png": {"Software": None},
            "svg": {"Date": None, "Creator": None},
            "pdf": {"CreationDate": None, "ModDate": None, "Creator": None,
                    "Producer": None}}
#: matplotlib settings while a figure is written: SVG ids from a fixed salt, and no path
#: simplification (matplotlib drops the vertices of a line that move it by less than 1/9
#: pixel; the decision is discontinuous, so a last-digit difference of the data between
#: two machines could keep a vertex on one and drop it on the other).  The pixels then
#: depend on the versions of matplotlib (and its FreeType) only, the PNG compression on
#: Pillow's.
RC = {"svg.hashsalt": "vsi_numba", "path.simplify": False}


def savefig(fig, target, *, format: str = "png", **options):
    """``fig.savefig(target, format=format, **options)`` with :data:`METADATA` and
    :data:`RC`: the same figure gives the same bytes; every text of the figure drawn
    literally (:func:`~vsi_numba.analysis.sanitize.plot_labels`).  ``target`` is a path
    or a binary file object."""
    import matplotlib
    from matplotlib.lines import Line2D

    from vsi_numba.analysis.sanitize import plot_labels

    plot_labels(fig)  # text from inputs: no math text, no control character

    for line in fig.findobj(Line2D):  # paths made before the rc context: not simplified
        line.get_path().should_simplify = False
    with matplotlib.rc_context(RC), _layout_only_first(fig, options):
        fig.savefig(target, format=format, metadata=METADATA.get(format, {}), **options)
    return target


@contextlib.contextmanager
def _layout_only_first(fig, options):
    """While ``fig`` is saved: the first draw of the figure, the one matplotlib makes
    with drawing disabled before the file's draw when the figure has a layout engine
    (``print_figure``: it places the axes), only executes the layout engine, as that
    draw does first; the file's draw then draws every artist once, not twice (the
    artists' dry draw is ~10 % of a report figure's time).  The file is the same.  Not
    for a tight bounding box (``bbox_inches="tight"``), which measures the artists
    after that draw."""
    import matplotlib

    bbox = options.get("bbox_inches", matplotlib.rcParams["savefig.bbox"])
    if fig.get_layout_engine() is None or bbox is not None or "draw" in vars(fig):
        yield
        return

    def layout_only(renderer):
        del fig.draw  # the next draw, the file's, is the figure's own
        if fig.axes and fig.get_layout_engine() is not None:
            try:
                fig.get_layout_engine().execute(fig)
            except ValueError:  # as Figure.draw: a layout that cannot be made is left
                pass

    fig.draw = layout_only
    try:
        yield
    finally:
        vars(fig).pop("draw", None)


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

    Raises
    ------
    ValueError
        If :func:`figure_problem` finds the path unusable.
    OSError
        If the file cannot be written (a full disk, permissions); nothing is left.
    """
    from vsi_numba.io.atomic import write_atomic

    problem = figure_problem(path)
    if problem is not None:
        raise ValueError(problem)
    fmt = Path(path).suffix.lower().lstrip(".")
    return write_atomic(os.fspath(path), lambda tmp: savefig(fig, tmp, format=fmt, **options),
                        parents=True)
