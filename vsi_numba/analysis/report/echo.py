"""The input echo of the report: what was analysed, read back from the results file.

The title block (project, client, document, revision, prepared / checked / approved by,
from the optional ``[report]`` section of the configuration), and the analysis input:
bridge and its modes (frequencies), damping zeta and the additional damping Delta-zeta
per train, time integration (dt, HHT-alpha), approach track, track model, contact model
with their parameters, irregularity, and the configuration's SHA-256. Every value comes
from the file (``config_json`` and attributes), none from the code's defaults, so the
echo shows what the run used.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.checks import applicable_trains, results_config
from vsi_numba.analysis.dataset import bridge_frequencies
from vsi_numba.analysis.report.document import Section, Table


def fmt_number(value, unit: str = "", digits: int = 4) -> str:
    """``1.508e10 N m²``-style numbers: plain below 1e5, else mantissa e exponent with
    trailing zeros dropped (``7.16e10``)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not np.isfinite(v):
        return "–"
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-4):
        mant, exp = f"{v:.{digits - 1}e}".split("e")
        mant = mant.rstrip("0").rstrip(".")
        text = f"{mant}e{int(exp)}"
    else:
        text = np.format_float_positional(v, precision=digits, unique=True, fractional=False,
                                          trim="-")
    text = text.replace("-", "−")
    return f"{text} {unit}".rstrip()


def fmt_list(values, unit: str = "", joiner: str = ", ") -> str:
    """A list of numbers with one unit at the end (``20 + 20 m`` with ``joiner=" + "``)."""
    vals = np.atleast_1d(np.asarray(values, dtype=float))
    return joiner.join(fmt_number(v) for v in vals) + (f" {unit}" if unit else "")


#: Title-block fields of ``[report]`` in the order shown.
TITLE_FIELDS = (("project", "Project"), ("client", "Client"), ("document", "Document"),
                ("revision", "Revision"), ("date", "Date"), ("prepared_by", "Prepared by"),
                ("checked_by", "Checked by"), ("approved_by", "Approved by"))


def title_block(ds: xr.Dataset, generated: str) -> Section:
    """The title block: the ``[report]`` fields given, the report's date and the hash."""
    rep = results_config(ds).get("report")
    rep = rep if isinstance(rep, dict) else {}
    rows = [[label, str(rep[key])] for key, label in TITLE_FIELDS if rep.get(key)]
    rows.append(["Report generated", generated])
    sha = ds.attrs.get("config_sha256")
    rows.append(["Configuration SHA-256", f"`{sha}`" if sha else "–"])
    lines = ["| | |", "|---|---|", *(f"| **{a}** | {b} |" for a, b in rows)]
    if not rep:
        lines += ["", "*No `[report]` section in the configuration (project, client, "
                  "revision, prepared_by, checked_by, ...): the title block is empty.*"]
    return Section("Document", ["\n".join(lines)], level=3, anchor="document")


def _damping_table(ds: xr.Dataset, cfg: dict) -> Table | None:
    bridge = cfg.get("bridge") if isinstance(cfg.get("bridge"), dict) else {}
    zeta = bridge.get("damping_ratio")
    if zeta is None and "damping_ratio" not in ds:
        return None
    z = np.atleast_1d(np.asarray(zeta if zeta is not None else ds["damping_ratio"].values,
                                 dtype=float))
    dz = float(bridge.get("additional_damping", 0.0) or 0.0)
    interaction = applicable_trains(ds) if "max_wheel_unloading" in ds else None
    rows = []
    for train in ds["train"].values:
        moving = interaction is None or not bool(interaction.sel(train=train))
        extra = dz if moving else 0.0
        zeta_text = (fmt_number(100 * z[0], "%") if z.size == 1 else
                     ", ".join(fmt_number(100 * v) for v in z) + " % (per mode)")
        total = (fmt_number(100 * (z[0] + extra), "%") if z.size == 1 else
                 ", ".join(fmt_number(100 * (v + extra)) for v in z) + " %")
        rows.append({"Train": str(train),
                     "Model": "moving forces" if moving else "interaction (multibody)",
                     "ζ (structure)": zeta_text,
                     "Δζ (EN 1991-2 6.4.6.3.1)": fmt_number(100 * extra, "%"),
                     "ζ + Δζ": total})
    frame = pd.DataFrame(rows)
    keys = [c for c in frame.columns if c != "Train"]
    groups = []
    for _, group in frame.groupby(keys, sort=False):
        names = list(group["Train"])
        label = (", ".join(names) if len(names) <= 4 else
                 f"{names[0]} … {names[-1]} ({len(names)} trains)")
        groups.append({"Train": label, **group.iloc[0][keys].to_dict()})
    frame = pd.DataFrame(groups, columns=frame.columns)
    return Table(frame, "Damping per train type (Δζ applies to moving-force trains only)")


def input_echo(ds: xr.Dataset, variant_note: str = "") -> Section:
    """The analysis input, from the results file."""
    cfg = results_config(ds)
    a = ds.attrs
    rows: list[tuple[str, str]] = []
    bridge = cfg.get("bridge") if isinstance(cfg.get("bridge"), dict) else {}
    if bridge:
        kind = str(bridge.get("kind", "–")).replace("_", " ")
        rows.append(("Bridge", kind))
        if bridge.get("spans"):
            rows.append(("Spans", fmt_list(bridge["spans"], "m", " + ")))
        if "EI" in bridge:
            rows.append(("Bending stiffness EI", fmt_list(bridge["EI"], "N m²")))
        if "mass_per_length" in bridge:
            rows.append(("Mass per length m", fmt_list(bridge["mass_per_length"], "kg/m")))
        for key, label in (("n_modes", "Modes kept (n_modes)"),
                           ("max_frequency", "Modes up to (max_frequency)"),
                           ("elements_per_span", "FE elements per span")):
            if key in bridge:
                rows.append((label, fmt_number(bridge[key], "Hz" if key == "max_frequency"
                                               else "")))
        if "output_points" in bridge:
            pts = np.atleast_1d(np.asarray(bridge["output_points"], float))
            rows.append(("Output points x", ", ".join(fmt_number(x, digits=7) for x in pts)
                         + " m"))
        if bridge.get("file"):
            rows.append(("Modes file", f"`{bridge['file']}`"))
    elif "bridge_description" in a:
        rows.append(("Bridge", str(a["bridge_description"])))
    if "bridge_length" in a:
        rows.append(("Bridge length L", fmt_number(a["bridge_length"], "m")))
    f = bridge_frequencies(ds)
    if f.size:
        shown = ", ".join(f"{x:.3f}" for x in f[:12]) + (" …" if f.size > 12 else "")
        rows.append(("Natural frequencies", f"{shown} Hz ({f.size} modes)"))
    if "acceleration_cutoff_hz" in a:
        rows.append(("Deck-acceleration cut-off", fmt_number(a["acceleration_cutoff_hz"],
                                                             "Hz")))
    for key in ("damping_rule", "additional_damping_rule"):
        text = a.get(key) or bridge.get(key)
        if text:
            rows.append(("Damping rule" if key == "damping_rule" else "Additional damping rule",
                         str(text)))
    track_type = a.get("track_type") or bridge.get("track_type")
    if track_type:
        rows.append(("Track type (acceleration limit)", str(track_type).replace("_", " ")))
    solver = cfg.get("solver") if isinstance(cfg.get("solver"), dict) else {}
    dt = solver.get("dt", a.get("dt"))
    if dt is not None:
        rows.append(("Time step dt", fmt_number(dt, "s")))
    alpha = solver.get("hht_alpha", a.get("hht_alpha"))
    if alpha is not None:
        rows.append(("HHT-α", fmt_number(alpha)))
    if "approach" in solver:
        rows.append(("Approach track (first axle starts at x = −approach)",
                     fmt_number(solver["approach"], "m")))
    if "free_vibration" in solver:
        rows.append(("Free vibration after the last axle", fmt_number(solver["free_vibration"],
                                                                      "s")))
    track = cfg.get("track") if isinstance(cfg.get("track"), dict) else None
    if "track" in bridge:
        layer = bridge["track"]
        rows.append(("Track model", "FE track layer of the deck: " + ", ".join(
            f"{k} = {fmt_number(v)}" for k, v in layer.items())))
    elif track is not None:
        if track.get("model") == "elastic":
            k, ei = float(track["foundation_stiffness"]), float(track["rail_EI"])
            beta = (k / (4 * ei)) ** 0.25
            rows.append(("Track model", "elastic: rail on a Winkler foundation over the "
                         f"deck and the approaches; rail EI = {fmt_number(ei, 'N m²')} (both "
                         f"rails), foundation k = {fmt_number(k, 'N/m²')}, "
                         f"{fmt_number(2 * k / beta / 1e6, 'kN/mm')} under one axle"))
        else:
            rows.append(("Track model", "rigid-track idealisation (kink at the deck ends)"))
    contact = cfg.get("contact") if isinstance(cfg.get("contact"), dict) else None
    if contact is not None:
        text = str(contact.get("model", "rigid"))
        if "hertz_coefficient" in contact:
            text += f", G = {fmt_number(contact['hertz_coefficient'], 'm N^−2/3')}"
        rows.append(("Contact model", text))
    irr = cfg.get("irregularity") if isinstance(cfg.get("irregularity"), dict) else None
    if irr is not None:
        rows.append(("Irregularity", ", ".join(
            f"{k} = {v}" if not isinstance(v, float) else f"{k} = {fmt_number(v)}"
            for k, v in irr.items() if k != "defects") or "none"))
    train = cfg.get("train") if isinstance(cfg.get("train"), dict) else {}
    if train:
        names = ", ".join(str(t) for t in ds["train"].values)
        rows.append(("Trains", names + (f" (train.model = {train['model']})"
                                        if train.get("model") else "")))
    study = cfg.get("study") if isinstance(cfg.get("study"), dict) else {}
    v = np.asarray(ds["speed_kmh"].values, float)
    rows.append(("Speeds", f"{v.size}, {v.min():.0f}–{v.max():.0f} km/h"))
    if study.get("history_speeds_kmh"):
        rows.append(("Time histories kept at", fmt_list(study["history_speeds_kmh"], "km/h")))
    sha = a.get("config_sha256")
    rows.append(("Configuration SHA-256", f"`{sha}`" if sha else "– (not in the file)"))
    if "source" in a:
        rows.append(("Computed with", str(a["source"])))
    blocks: list = []
    if variant_note:
        blocks.append(variant_note)
    blocks.append(Table(pd.DataFrame(rows, columns=["Input", "Value"]),
                        "Analysis input, read back from the results file"))
    damping = _damping_table(ds, cfg)
    if damping is not None:
        blocks.append(damping)
    if not cfg:
        blocks.append("> The file carries no `config_json`: only its attributes are echoed.")
    return Section("Input", blocks)
