"""The report of a parametric study (``study.vary``): the table over the variants, the
governing variant with its full report, the design chart; HTML + Markdown + CSV/XLSX.

Reads the file one variant at a time (:func:`vsi_numba.analysis.variants.variant_view`
of a lazily opened Dataset); only the envelopes of one variant, and the time histories of
one case, are in memory at once.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import variants as var
from vsi_numba.analysis.report.atomic import atomic_directory, checkpoint
from vsi_numba.analysis.report.document import (
    Figure,
    Markdown,
    Section,
    Table,
    write_html,
    write_markdown,
)
from vsi_numba.analysis.report.echo import fmt_number, input_echo, title_block
from vsi_numba.analysis.report.safe import clean, code, md, sheet_frame, write_csv
from vsi_numba.analysis.report.tables import (
    CSV_FLOAT_FORMAT,
    fix_xlsx_dates,
    reproducible_zip,
    significant,
)
from vsi_numba.analysis.report.text import _version, _warnings_block, stored_warnings

#: Units of the columns of :func:`vsi_numba.analysis.variants.variant_table` (CSV/XLSX
#: headers carry them).
VARIANT_UNITS = {"f1_hz": "Hz", "zeta_pct": "%", "dzeta_mf_pct": "%",
                 "deck_acceleration": "m/s2", "limit": "m/s2", "governing_speed_kmh": "km/h",
                 "phi_dyn": "-", "mass_factor": "-", "label": "", "result": "",
                 "governing_train": ""}

_RENAME = {"f1_hz": "f1", "zeta_pct": "zeta", "dzeta_mf_pct": "dzeta (moving forces)",
           "governing_speed_kmh": "governing speed", "phi_dyn": "phi'dyn"}


def _with_units(ds: xr.Dataset, table: pd.DataFrame) -> pd.DataFrame:
    """Column names with units: ``f1 [Hz]``, ``bridge.EI [N m2]``, ..."""
    names = {}
    for col in table.columns:
        unit = VARIANT_UNITS.get(col)
        label = _RENAME.get(col, col)
        if unit is None and col in ds.coords:
            label = ds[col].attrs.get("key_path", col)
            unit = str(ds[col].attrs.get("units", "") or "")
            unit = "-" if unit in ("1", "") and ds[col].dtype.kind == "f" else unit
        names[col] = f"{label} [{unit}]" if unit else label
    return table.rename(columns=names)


def _show_table(table: pd.DataFrame) -> pd.DataFrame:
    """The variants table for print: strings with 4 significant digits, bold FAIL."""
    show = table.copy()
    for col in show.columns:
        if show[col].dtype.kind == "f":
            show[col] = show[col].map(fmt_number)
    if "result" in show:
        show["result"] = show["result"].map(lambda r: Markdown("**FAIL**") if r == "FAIL"
                                            else r)
    return show


def write_variants_report(ds: xr.Dataset, outdir, source_path=None, **kwargs) -> Path:
    """Write the report of a study of variants into ``outdir``.

    Files: ``report.html`` and ``report.md`` (+ ``design_chart.png``), ``variants.csv``
    and ``tables.xlsx`` (one row per variant, units in the headers), ``variants.json``
    (the governing variant) and the full report of the governing variant in
    ``governing_variant/`` (:func:`vsi_numba.analysis.report.write_report`, which gets
    ``kwargs``).

    Parameters
    ----------
    ds : xarray.Dataset
        Results with a ``variant`` dim, best opened lazily (nothing is loaded whole).
    outdir : path
        Report directory, replaced whole and atomically
        (:func:`~vsi_numba.analysis.report.atomic.atomic_directory`).
    source_path : path, optional
        The results file (its name is shown).

    Returns
    -------
    pathlib.Path
        ``report.md``.
    """
    with atomic_directory(outdir) as tmp:
        _write_variants(ds, tmp, Path(outdir), source_path, **kwargs)
    return Path(outdir) / "report.md"


def _fatigue(ds: xr.Dataset) -> list:
    """The fatigue section over the variants (a study with ``[fatigue]``), or none."""
    from vsi_numba.analysis.report.fatigue import variants_section

    sec = variants_section(ds)
    return [] if sec is None else [sec]


def _write_variants(ds: xr.Dataset, outdir: Path, report_dir: Path, source_path=None,
                    **kwargs) -> Path:
    """The files of :func:`write_variants_report`, written into ``outdir`` as they come
    (the temporary directory); ``report_dir`` is where they will be read."""
    from vsi_numba.analysis.dataset import prepare
    from vsi_numba.analysis.report import build_report

    table = var.variant_table(ds)
    units_table = _with_units(ds, table)
    write_csv(units_table, outdir / "variants.csv", float_format=CSV_FLOAT_FORMAT)
    checkpoint()
    with pd.ExcelWriter(outdir / "tables.xlsx", engine="openpyxl") as writer:
        sheet_frame(significant(units_table)).to_excel(writer, sheet_name="variants",
                                                       index=False)
        writer.sheets["variants"].freeze_panes = "B2"
        fix_xlsx_dates(writer)
    reproducible_zip(outdir / "tables.xlsx")
    checkpoint()
    gov = var.governing_variant(ds)
    view = var.variant_view(ds, gov)
    label = var.variant_label(ds, gov)
    (outdir / "governing_variant").mkdir()
    sub = build_report(prepare(view), outdir / "governing_variant",
                       report_dir=report_dir / "governing_variant", source_path=source_path,
                       variant_note=f"Variant {gov} of the study: {md(label)}.", **kwargs)
    buf = io.BytesIO()
    caption = var.design_charts(ds, buf)
    chart = Figure(buf.getvalue(), "design_chart.png", caption)

    title = clean(ds.attrs.get("title") or "vsi_numba study of variants")
    n_fail = int(table["result"].astype(str).str.startswith("FAIL").sum())
    generated = f"vsi_numba {_version()}"
    intro = (f"A study of {ds.sizes['variant']} variants ({md(ds.attrs.get('varied_keys', ''))}), "
             f"{ds.sizes['speed']} speeds × {ds.sizes['train']} trains × "
             f"{ds.sizes['irregularity']} track realisations"
             + (f": {code(Path(source_path).name)}." if source_path else "."))
    head = [Section("", [intro], level=0), title_block(view, generated)]
    warn = Section.from_markdown(_warnings_block(stored_warnings(ds)))  # marked per variant
    if warn is not None:
        head.append(warn)
    rules = [f"- {md(ds.attrs[key])}" for key in ("damping_rule", "additional_damping_rule")
             if ds.attrs.get(key)]
    if "damping_rule" in ds and any(str(r) for r in ds["damping_rule"].values):
        rules.append("- Damping per variant (columns zeta, dzeta): e.g. variant 0: "
                     f"{md(ds['damping_rule'].values[0])}")
    peak = var.peak_deck_acceleration(ds)
    g = peak.isel(variant=gov)
    v_gov = float(ds["speed_kmh"].values[int(np.nanargmax(g.values))])
    envelope = [
        f"- **Governing variant {gov}** ({md(label)}): peak deck acceleration "
        f"**{float(g.max()):.3g} m/s²** at {v_gov:g} km/h (limit "
        f"{var.variant_limit(ds, gov):g} m/s², {md(var.variant_track_type(ds, gov))} track; the "
        "governing variant uses the most of its own limit); its full report: "
        f"[governing_variant/report.html](governing_variant/report.html) "
        f"([Markdown](governing_variant/{sub.name})).",
        f"- Variants that FAIL the deck-acceleration check: **{n_fail}** of {len(table)}.",
        *rules,
    ]
    body = [
        Section("Envelope over the variants", ["\n".join(envelope)]),
        Section("Per variant", ["One row per variant (also `variants.csv`, `tables.xlsx`, "
                                "with units in the headers).",
                                Table(_show_table(_with_units(ds, table)),
                                      "Deck acceleration check per variant")]),
        *_fatigue(ds),
        Section("Design chart", [chart]),
        input_echo(view, f"The input of the governing variant {gov} ({md(label)}); the other "
                         "variants differ in the varied keys only."),
    ]
    path = write_markdown(head + body, outdir / "report.md", title=title)
    write_html(body, outdir / "report.html", title=title, header=head)
    (outdir / "variants.json").write_text(json.dumps(
        {"governing_variant": gov, "label": label}, indent=1))
    checkpoint()
    return path
