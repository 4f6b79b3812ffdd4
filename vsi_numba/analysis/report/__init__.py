"""``vsi report``: checks, figures and a Markdown report of a results file.

:func:`write_report` runs every check of :mod:`vsi_numba.analysis.checks` that the file
allows, draws the figures of :mod:`vsi_numba.analysis.plots` and writes ``report.md``
(plus ``summary.csv``) into one directory. The time-history figures show the governing
cases of the deck acceleration and wheel unloading checks; a case whose history the file
does not hold is re-run from the file's ``config_json`` (:mod:`.recompute`).
The command ``vsi report`` is :func:`vsi_numba.cli.report.report_command`.

Modules: :mod:`.text` (the Markdown sections), :mod:`.figures` (the figures and the
re-run governing cases); :func:`write_report` here puts them together.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis.dataset import prepare, require
from vsi_numba.analysis.recompute import CaseRunner
from vsi_numba.analysis.report.figures import _figures
from vsi_numba.analysis.report.load_effects import load_effects_section
from vsi_numba.analysis.report.text import (
    FIGURE_NAMES,
    MAX_ONE_STEP_ROWS,
    NOT_RELIABLE,
    REQUIRED_VARIABLES,
    WARN_STATUSES,
    _bridge,
    _cases,
    _deck_end_note,
    _flagged_trains,
    _one_step_losses,
    _provenance,
    _statistics,
    _summary,
    _trains,
    _warnings_block,
    mark_unreliable,
    stored_warnings,
)

__all__ = [
    "FIGURE_NAMES",
    "MAX_ONE_STEP_ROWS",
    "NOT_RELIABLE",
    "REQUIRED_VARIABLES",
    "WARN_STATUSES",
    "mark_unreliable",
    "stored_warnings",
    "write_report",
]


def write_report(
    ds: xr.Dataset, outdir: Path | str, *, q: float = chk.DEFAULT_Q,
    comfort_level: str = "very good", n_boot: int = 2000, seed: int = 0,
    source_path: Path | str | None = None, determinant_length: float | None = None,
    recompute: bool = True, config_dir: Path | str | None = None,
) -> Path:
    """Write ``report.md``, ``summary.csv`` and the PNG figures into ``outdir``.

    Parameters
    ----------
    ds : xarray.Dataset
        Results of ``vsi run`` / ``vsi sweep`` (or the same layout built in memory).
    outdir : path
        Directory, created if needed; existing report files are overwritten.
    q : float
        Characteristic fractile over irregularity realisations.
    comfort_level : str
        Required level of comfort (EN 1990 Table A2.9 [R]).
    n_boot, seed : int
        Bootstrap settings of the realisation statistics.
    source_path : path, optional
        The results file, named in the provenance.
    determinant_length : float, optional
        L_phi (m) for phi''; wins over the file's attribute and the EN 1991-2 Table 6.2
        [R] rule (:func:`vsi_numba.analysis.checks.determinant_length`).
    recompute : bool
        Re-run a governing case whose time history the file does not hold, from the
        file's ``config_json`` (:mod:`vsi_numba.analysis.recompute`), for the
        time-history figures.
    config_dir : path, optional
        Directory the stored configuration's relative paths (train file, profile)
        resolve against; default: tried from the results file's directory upwards, then
        the working directory.

    Returns
    -------
    pathlib.Path
        The Markdown report.

    Raises
    ------
    ResultsError
        If ``ds`` lacks :data:`REQUIRED_VARIABLES` or a ``speed`` coordinate.
    """
    ds = prepare(ds)
    require(ds, REQUIRED_VARIABLES, "the report")
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    for name in FIGURE_NAMES:  # no stale figure of an earlier report may stay behind
        (outdir / name).unlink(missing_ok=True)
    lphi = chk.determinant_length(ds, determinant_length)
    results = chk.run_checks(ds, q=q, comfort_level_required=comfort_level, n_boot=n_boot,
                             seed=seed, length=determinant_length)
    records = stored_warnings(ds)
    table = mark_unreliable(chk.summary_table(results), records)
    table.to_csv(outdir / "summary.csv", index=False)
    runner = (CaseRunner(ds, base_dir=config_dir, source_path=source_path) if recompute
              else None)
    figures, figure_notes = _figures(ds, results, outdir, runner)
    wu = results.get("wheel_unloading")
    applicable = None if wu is None or isinstance(wu, str) else wu["applicable"]

    title = ds.attrs.get("title") or "vsi_numba results"
    lines = [f"# {title}", "",
             "Railway vehicle–bridge interaction: dynamic checks of the results "
             + (f"`{Path(source_path).name}`." if source_path else "in memory."), ""]
    lines += _warnings_block(records)
    flagged = _flagged_trains(ds)
    if flagged:
        lines += [f"> ⚠ **WARNING: results for train(s) {', '.join(flagged)} rest on vehicle "
                  "data of doubtful status — see [Trains](#trains).**", ""]
    lines += _provenance(ds, Path(source_path) if source_path else None)
    lines += _bridge(ds, lphi)
    lines += _summary(results, table, np.asarray(ds["point"].values, float))
    lines += _deck_end_note(ds)
    lines += _one_step_losses(results)
    lines += _trains(ds, applicable)
    lines += _cases(ds)
    lines += _statistics(results, ds)
    lines += load_effects_section(ds, outdir, length=determinant_length).lines
    lines += ["## Figures", ""]
    for i, (name, caption) in enumerate(figures, 1):
        lines += [f"![Figure {i}]({name})", "", f"*Figure {i}: {caption}*", ""]
    if figure_notes:
        lines += [*figure_notes, ""]
    path = outdir / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def __getattr__(name):
    """The helpers of the sections and figures (``report._deck_end_note``, ...) as
    attributes of this package, as when the report was one module (tests use some)."""
    from vsi_numba.analysis.report import figures, text

    for module in (text, figures):
        if hasattr(module, name):
            return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
