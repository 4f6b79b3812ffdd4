"""``vsi report``: checks, figures and the report of a results file, as one
self-contained HTML file and as Markdown, with CSV/XLSX tables.

:func:`write_report` runs every check of :mod:`vsi_numba.analysis.checks` that the file
allows, draws the figures of :mod:`vsi_numba.analysis.plots` and writes ``report.html``,
``report.md`` (plus the PNGs), ``summary.csv``, ``tables/*.csv`` and ``tables.xlsx`` into
one directory, replaced whole (:mod:`.atomic`). It loads the envelopes only and reads
time histories one case at a time.
The time-history figures show the governing cases of the deck acceleration and wheel
unloading checks; a case whose history the file does not hold is re-run from the file's
``config_json`` (:mod:`.recompute`).
The command ``vsi report`` is :func:`vsi_numba.cli.report.report_command`.

Modules: :mod:`.document` (sections of text, tables and figures; the Markdown and HTML
writers), :mod:`.text` (the Markdown sections), :mod:`.echo` (input echo, title block),
:mod:`.tables` (maxima, deck / approach wheel unloading, CSV/XLSX), :mod:`.figures` (the
figures and the re-run governing cases), :mod:`.variants` (parametric studies),
:mod:`.safe` (text from configurations and results files shown literally), :mod:`.atomic`
(the directory written whole or not at all), :mod:`.background` (the re-runs of the
governing cases and the deflection checks in a second process, on two cores, while the
figures, tables and text are written here);
:func:`write_report` here puts them together.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis.checks.deflection import deflection_checks
from vsi_numba.analysis.checks.load_effects import load_effect_checks
from vsi_numba.analysis.dataset import envelopes, prepare, require
from vsi_numba.analysis.recompute import CaseRunner
from vsi_numba.analysis.report import profile as code_profile
from vsi_numba.analysis.report import tables as tbl
from vsi_numba.analysis.report.atomic import atomic_directory, checkpoint
from vsi_numba.analysis.report.background import Background
from vsi_numba.analysis.report.compatibility import compatibility_section
from vsi_numba.analysis.report.convergence import convergence_section
from vsi_numba.analysis.report.deflection import deflection_section
from vsi_numba.analysis.report.deflection import summary_rows as deflection_rows
from vsi_numba.analysis.report.document import (
    Figure,
    Section,
    Table,
    write_html,
    write_markdown,
)
from vsi_numba.analysis.report.echo import input_echo, title_block
from vsi_numba.analysis.report.fatigue import fatigue_section, has_fatigue
from vsi_numba.analysis.report.fatigue import summary_rows as fatigue_rows
from vsi_numba.analysis.report.figures import (
    envelope_figures,
    history_figures,
    history_reruns,
    rerun_cases,
)
from vsi_numba.analysis.report.load_effects import (
    consistent_deflection,
    load_effects_section,
    summary_with_load_effects,
    summary_with_torque,
)
from vsi_numba.analysis.report.safe import clean, code, md, natural_order, write_csv
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
    _version,
    _warnings_block,
    mark_unreliable,
    stored_warnings,
)
from vsi_numba.analysis.report.twist import twist_section
from vsi_numba.io.schema import ALL_TRACKS_SUFFIX

__all__ = [
    "FIGURE_NAMES",
    "REPORT_FILES",
    "Figure",
    "Section",
    "Table",
    "MAX_ONE_STEP_ROWS",
    "build_report",
    "NOT_RELIABLE",
    "REQUIRED_VARIABLES",
    "WARN_STATUSES",
    "mark_unreliable",
    "stored_warnings",
    "write_report",
]


#: Files of the report besides the figures (an earlier report's are replaced).
REPORT_FILES = ("report.md", "report.html", "summary.csv", "tables.xlsx")


def write_report(
    ds: xr.Dataset, outdir: Path | str, *, q: float = chk.DEFAULT_Q,
    comfort_level: str = "very good", n_boot: int = 2000, seed: int = 0,
    source_path: Path | str | None = None, determinant_length: float | None = None,
    recompute: bool = True, config_dir: Path | str | None = None,
    sections: list | None = None, variant_note: str = "",
) -> Path:
    """Write the report of a results file into ``outdir``.

    Files: ``report.html`` (one self-contained file: figures embedded, prints to PDF from
    a browser), ``report.md`` with the figures as PNG beside it (for diffs),
    ``summary.csv`` (one row per check), ``tables/<quantity>.csv`` (speed x train, units
    in every header) and ``tables.xlsx`` (the same plus the tables of maxima).

    Only the envelopes are loaded (:func:`vsi_numba.analysis.dataset.envelopes`); the
    time histories are read from ``ds`` one case at a time, so a file opened lazily
    (``xarray.open_dataset``) is reported in memory that does not grow with the study.

    Parameters
    ----------
    ds : xarray.Dataset
        Results of ``vsi run`` / ``vsi sweep`` (or the same layout built in memory);
        best opened lazily.
    outdir : path
        The report's directory, replaced whole and atomically
        (:mod:`~vsi_numba.analysis.report.atomic`): the report is written into a new
        directory beside it that takes its place when complete, so a kill leaves the
        complete earlier report or the complete new one. It must not exist, be empty or
        hold only an earlier report.
    q : float
        Characteristic fractile over irregularity realisations.
    comfort_level : str
        Required level of comfort (EN 1990 Table A2.9 [R]).
    n_boot, seed : int
        Bootstrap settings of the realisation statistics.
    source_path : path, optional
        The results file, named in the provenance (by its name only).
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
    sections : list, optional
        More sections, placed before the figures: each a
        :class:`~vsi_numba.analysis.report.document.Section`, or a callable
        ``f(envelopes, results) -> Section | None`` (``results`` as returned by
        :func:`vsi_numba.analysis.checks.run_checks`).
    variant_note : str, optional
        Markdown shown at the top of the input echo (e.g. which variant of a parametric
        study this is).

    Returns
    -------
    pathlib.Path
        The Markdown report.

    Raises
    ------
    ResultsError
        If ``ds`` lacks :data:`REQUIRED_VARIABLES` or a ``speed`` coordinate.
    ReportDirectoryError
        If ``outdir`` holds files that are not a report's, or is the working directory.
    """
    full = prepare(ds)
    require(full, REQUIRED_VARIABLES, "the report")
    with atomic_directory(outdir) as tmp:
        build_report(full, tmp, report_dir=outdir, q=q, comfort_level=comfort_level,
                     n_boot=n_boot, seed=seed, source_path=source_path,
                     determinant_length=determinant_length, recompute=recompute,
                     config_dir=config_dir, sections=sections, variant_note=variant_note)
    return Path(outdir) / "report.md"


def build_report(full: xr.Dataset, outdir: Path, *, report_dir: Path | str | None = None,
                 q: float = chk.DEFAULT_Q, comfort_level: str = "very good",
                 n_boot: int = 2000, seed: int = 0, source_path: Path | str | None = None,
                 determinant_length: float | None = None, recompute: bool = True,
                 config_dir: Path | str | None = None, sections: list | None = None,
                 variant_note: str = "") -> Path:
    """The files of :func:`write_report` written into the existing directory ``outdir``
    as they come (no atomic replacement: the caller's temporary directory);
    ``report_dir`` is where the report will be read from (default ``outdir``): the
    results file is named relative to it."""
    report_dir = Path(outdir if report_dir is None else report_dir)
    outdir = Path(outdir)
    # the results to 12 digits: the last digits differ between machines (tables.denoised)
    env = tbl.denoised(envelopes(full))
    # trains in natural order (HSLM-A2 before HSLM-A10) in every table and figure
    order = natural_order(env["train"].values)
    if order != list(range(env.sizes["train"])):
        env = env.isel(train=order)
    lphi = chk.determinant_length(env, determinant_length)
    results = chk.run_checks(env, q=q, comfort_level_required=comfort_level, n_boot=n_boot,
                             seed=seed, length=determinant_length)
    records = stored_warnings(env)
    le_checks = _LoadEffects(env, determinant_length, results.get("dynamic_amplification"))
    runner = (CaseRunner(env, base_dir=config_dir, source_path=source_path) if recompute
              else None)
    # EN 1990 A2.4.4.2.3(1) / A2.4.4.3.2: the static deflection under LM71
    deflection = functools.partial(deflection_checks, env, length=determinant_length,
                                   comfort_level=comfort_level, base_dir=config_dir,
                                   source_path=source_path)
    with _reruns(env, full, results, runner, q, le_checks, determinant_length,
                 deflection) as reruns:
        le_all = (load_effect_checks(env, length=determinant_length, all_tracks=True)
                  if any(str(v).endswith(ALL_TRACKS_SUFFIX) for v in env.variables)
                  else None)
        return _build(full, env, outdir, report_dir, results, records, le_checks, le_all,
                      lphi, runner, reruns, q=q, comfort_level=comfort_level,
                      source_path=source_path, determinant_length=determinant_length,
                      config_dir=config_dir, sections=sections, variant_note=variant_note)


class _LoadEffects:
    """The load-effect checks of the summary (:func:`load_effect_checks` with the
    deflection's phi'_dyn, :func:`consistent_deflection`), computed once in the process
    that calls it first (the background process's first job, whose convergence section
    uses them too), or given to it (:meth:`set`: the result the other process sent)."""

    def __init__(self, env, length, dyn):
        self.env, self.length, self.dyn = env, length, dyn
        self.value, self.done = None, False

    def __call__(self):
        if not self.done:
            self.set(consistent_deflection(load_effect_checks(self.env, length=self.length),
                                           self.env, self.dyn))
        return self.value

    def set(self, value):
        self.value, self.done = value, True
        return value


def _reruns(env, full, results, runner, q, le_checks: _LoadEffects, length,
            deflection) -> Background:
    """The re-runs of the governing cases (numba kernels): the time-history figures'
    (job ``figures``: :func:`~.figures.rerun_cases`) and the convergence section (job
    ``convergence``: the section and the checks it could not make), in a second process
    while this one writes the figures, tables and text (:mod:`.background`); before them
    the load-effect checks (job ``load_effects``) and the static deflection checks (job
    ``deflection``), which the summary needs first: the envelope figures are drawn here
    meanwhile."""
    keys = history_reruns(full, results) if runner is not None else []

    def convergence():
        missing: list[str] = []
        section = convergence_section(env, results, runner, q=q, le_checks=le_checks(),
                                      not_made=missing, length=length)
        return section, missing

    return Background({"load_effects": le_checks,
                       "deflection": deflection,
                       "figures": lambda: rerun_cases(runner, keys) if keys else {},
                       "convergence": convergence},
                      fork=None if runner is not None else False)


def _build(full, env, outdir, report_dir, results, records, le_checks, le_all, lphi,
           runner, reruns: Background, *, q, comfort_level, source_path,
           determinant_length, config_dir, sections, variant_note) -> Path:
    """The rest of :func:`build_report`, the re-runs in ``reruns``."""
    figures = envelope_figures(env, results)  # while the load effects are checked
    for fig in figures:
        fig.png()
    le_checks = le_checks.set(reruns.get("load_effects"))
    table = mark_unreliable(summary_with_torque(summary_with_load_effects(
        chk.summary_table(results), le_checks, le_all), env), records)
    deflection = reruns.get("deflection")
    table = pd.concat([table, pd.DataFrame(deflection_rows(deflection))], ignore_index=True)
    if has_fatigue(full):  # Miner's damage per section (a [fatigue] study)
        table = pd.concat([table, pd.DataFrame(fatigue_rows(full))], ignore_index=True)
    # 7 significant digits (tables.SIGNIFICANT): the same results give the same file (the
    # last digits of a float may differ between machines and thread schedules)
    write_csv(table, outdir / "summary.csv", float_format=tbl.CSV_FLOAT_FORMAT)
    checkpoint()
    wu = results.get("wheel_unloading")
    applicable = None if wu is None or isinstance(wu, str) else wu["applicable"]
    zones = tbl.wheel_unloading_by_zone(env)
    per_train = tbl.maxima_per_train(env, results, zones)
    per_point = tbl.maxima_per_point(env)
    zone_table = tbl.wheel_unloading_zones_table(zones) if zones is not None else None
    speed_tables = tbl.speed_train_tables(env, results, zones)
    extra = {"summary": table, "maxima_per_train": tbl.ascii_units(per_train),
             "maxima_per_point": tbl.ascii_units(per_point)}
    if zone_table is not None:
        extra["wheel_unloading_zones"] = tbl.ascii_units(zone_table)
    load_effects = load_effects_section(env, None, checks=le_checks, save_figure=False,
                                        checks_all=le_all)
    extra.update(load_effects.tables)
    tbl.write_tables(speed_tables, extra, outdir)
    more, figure_notes = history_figures(results, runner, full, reruns.get("figures"))
    figures += more
    for fig in figures:  # the PNGs drawn while the convergence re-runs go on
        fig.png()

    title = clean(env.attrs.get("title") or "vsi_numba results")
    generated = f"vsi_numba {_version()}"
    intro = ("Railway vehicle–bridge interaction: dynamic checks of the results "
             + (f"{code(Path(source_path).name)}." if source_path else "in memory."))
    head = [Section("", [intro], level=0), title_block(env, generated)]
    warn = Section.from_markdown(_warnings_block(records))
    if warn is not None:
        head.append(warn)
    flagged = _flagged_trains(env)
    if flagged:
        head.append(Section("", [f"> ⚠ **WARNING: results for train(s) "
                                 f"{', '.join(md(t) for t in flagged)} rest on vehicle data "
                                 "of doubtful status — see [Trains](#trains).**"], level=0))
    body: list[Section] = []

    def add(lines):
        sec = Section.from_markdown(lines)
        if sec is not None:
            body.append(sec)

    compat = compatibility_section(env, table)  # [compatibility]: the answer comes first
    if compat is not None:
        body.append(compat)
    # the sections whose checks may not be made, first: the summary lists what was not
    not_made: list[str] = []
    twist = twist_section(env, config_dir, source_path, not_made=not_made)
    # the sections after the summary that do not need the convergence re-runs, made
    # while they go on (the summary lists the checks they could not make)
    middle = [input_echo(env, variant_note), code_profile.profile_section(env)]
    middle += [Section.from_markdown(_bridge(env, lphi))]
    middle += [_maxima_section(env, per_train, per_point, zone_table, zones, speed_tables)]
    middle += [Section.from_markdown(lines) for lines in (
        _trains(env, applicable), _cases(env), _statistics(results, env))]
    middle += [load_effects.section, deflection_section(deflection), twist]
    if has_fatigue(full):
        middle.append(fatigue_section(full))
    _render([*body, *middle])  # the PNGs of these sections too, before the wait
    convergence, missing = reruns.get("convergence")
    not_made += missing
    checkpoint()
    summary = _summary(results, table, np.asarray(env["point"].values, float), not_made)
    at = len(summary) - 1 if summary and not summary[-1] else len(summary)
    add(summary[:at] + _zone_lines(zone_table) + summary[at:] + _deck_end_note(env)
        + _one_step_losses(results))
    body += [sec for sec in middle if sec is not None]
    body.append(convergence)
    for extra_section in sections or []:
        sec = extra_section(env, results) if callable(extra_section) else extra_section
        if sec is not None:
            body.append(sec)
    fig_blocks: list = list(figures)
    if figure_notes:
        fig_blocks.append("\n".join(figure_notes))
    if fig_blocks:
        body.append(Section("Figures", fig_blocks))
    # the results file relative to the report (never the absolute path of this machine)
    add(_provenance(env, Path(os.path.relpath(Path(source_path).resolve(),
                                              report_dir.resolve()))
                    if source_path else None))

    path = write_markdown(head + body, outdir / "report.md", title=title)
    write_html(body, outdir / "report.html", title=title, header=head)
    return path


def _render(sections) -> None:
    """The PNG of every figure of ``sections`` rendered now (:meth:`Figure.png`: once)."""
    for sec in sections:
        for block in getattr(sec, "blocks", ()):
            for item in block if isinstance(block, list) else [block]:
                if isinstance(item, Figure):
                    item.png()


def _zone_lines(zone_table) -> list[str]:
    """Summary bullet: the governing wheel unloading on the deck and on the approach."""
    if zone_table is None:
        return []
    parts = []
    zone = f"{tbl.TRANSITION_ZONE:g} m"
    for _, r in zone_table.iterrows():
        bridge = r["Minimum contact force"].startswith("on the bridge")
        where = (f"on the bridge (the deck and {zone} beyond its ends: the check)" if bridge
                 else f"on the approach / exit track beyond {zone} of the deck ends "
                      "(information, not the bridge's check)")
        if not np.isfinite(r["ΔQ/Q₀ max"]):
            parts.append(f"{where}: none")
            continue
        value = f"{r['ΔQ/Q₀ max']:.3f}"
        parts.append(f"{where} {f'**{value}**' if bridge else value} ({md(r['Train'])}, "
                     f"{r['Speed [km/h]']:.0f} km/h, axle {r['Axle']} at "
                     f"x = {r['x of the axle [m]']:.1f} m)")
    return ["- Wheel unloading by where the axle was at its minimum contact force (largest "
            "over the realisations): " + "; ".join(parts) + ". See [Maxima](#maxima)."]


def _maxima_section(env, per_train, per_point, zone_table, zones, speed_tables) -> Section:
    """Tables of maxima per train, per output point, wheel unloading by zone."""
    blocks: list = []
    n_real = env.sizes.get("irregularity", 1)
    basis = ("largest over the speeds" + (" and the track realisations" if n_real > 1 else "")
             + "; the checks above use the characteristic value over realisations"
             if n_real > 1 else "largest over the speeds")
    blocks.append(f"Maxima per train ({basis}). Deck acceleration a at the deck abscissa x "
                  "of its peak (whole deck where the file has it); δ the total deck "
                  "displacement (positive down) at the output point x; φ'dyn the dynamic "
                  "increment; ΔQ/Q₀ split by where the axle was at its minimum contact "
                  "force (deck 0 ≤ x ≤ L, approach x < 0 or x > L); b_v the car-body "
                  "acceleration.")
    deck, vehicles = tbl.split_per_train(per_train)
    blocks.append(Table(deck, "Maxima per train: deck"))
    if vehicles is not None:
        blocks.append(Table(vehicles, "Maxima per train: wheels and car bodies (trains "
                                      "with an interaction model)"))
    if zone_table is not None:
        length = zones.attrs["bridge_length"]
        blocks.append(
            "Wheel unloading on the bridge and on the approach track, separately "
            f"(bridge: the deck 0 ≤ x ≤ {length:g} m and {tbl.TRANSITION_ZONE:g} m beyond "
            "each end, the zone of the check; x from `position_of_min_contact_force`). The "
            "file keeps one minimum contact force per run and axle: a record whose minimum "
            "lay on the approach bounds that axle's unloading on the bridge from above but "
            "does not give it.")
        blocks.append(Table(zone_table, "Governing wheel unloading by zone"))
    blocks.append(Table(per_point, "Maxima per output point (over speeds, trains and "
                                   "realisations)"))
    if speed_tables:
        files = ", ".join(f"`tables/{n}.csv`" for n in speed_tables)
        blocks.append(f"Speed × train tables (units in every header): {files}; all of them "
                      "and the tables above in `tables.xlsx`.")
    return Section("Maxima", blocks)


def __getattr__(name):
    """The helpers of the sections and figures (``report._deck_end_note``, ...) as
    attributes of this package, as when the report was one module (tests use some)."""
    from vsi_numba.analysis.report import figures, text

    for module in (text, figures):
        if hasattr(module, name):
            return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
