"""``vsi report``: checks, figures and a Markdown report of a results file.

:func:`write_report` runs every check of :mod:`vsi_numba.analysis.checks` that the file
allows, draws the figures of :mod:`vsi_numba.analysis.plots` and writes ``report.md``
(plus ``summary.csv``) into one directory. The time-history figures show the governing
cases of the deck acceleration and wheel unloading checks; a case whose history the file
does not hold is re-run from the file's ``config_json`` (:mod:`.recompute`).
The command ``vsi report`` is :func:`vsi_numba.cli.report.report_command`.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis import plots
from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    bridge_frequencies,
    nanargmax_case,
    prepare,
    require,
    status_meanings,
    track_type,
    track_type_assumed,
)
from vsi_numba.analysis.recompute import CaseRunner, RecomputeError
from vsi_numba.analysis.statistics import wilks_sample_size

#: Variables without which no report is written.
REQUIRED_VARIABLES = ("max_deck_acceleration", "max_deck_displacement")

#: Every figure the report may write.
FIGURE_NAMES = ("deck_acceleration.png", "dynamic_amplification.png", "wheel_unloading.png",
                "comfort.png", "time_history.png", "wheel_unloading_history.png")

#: Rows of the table of one-step contact losses.
MAX_ONE_STEP_ROWS = 15

#: Train data statuses that get a loud warning (see data/trains.toml status_values).
WARN_STATUSES = {
    "suspect": "transcribed values with a documented inconsistency",
    "reconstruction": "values derived here to remove a documented inconsistency, "
                      "not a published data set",
    "missing": "no vehicle data: a placeholder",
    "secondary": "only a third-party transcription of the source was available",
}


# --------------------------------------------------------------------------------------
# Formatting
# --------------------------------------------------------------------------------------


def _fmt(value, units: str = "", digits: int = 3) -> str:
    """Readable value with units for the Markdown tables (SI in, kN/mm for N/m)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not np.isfinite(v):
        return "–"
    if units == "N":
        return f"{v / 1e3:.1f} kN"
    if units == "m":
        return f"{v * 1e3:.2f} mm"
    if units == "m s-2":
        return f"{v:.{digits}g} m/s²"
    if units == "s":
        return f"{v:.3g} s"
    return f"{v:.{digits}g}"


def _result(text: str) -> str:
    return {"FAIL": "**FAIL**", "pass": "pass", NOT_RELIABLE: f"**{NOT_RELIABLE}**",
            f"FAIL ({NOT_RELIABLE})": f"**FAIL ({NOT_RELIABLE})**"}.get(text, text)


#: Result of a check computed under a time-step resolution warning (never "pass").
NOT_RELIABLE = "not reliable"


def stored_warnings(ds: xr.Dataset) -> list[dict]:
    """The configuration warnings a results file carries, as records {"message", "kind",
    "keys"}: from ``warnings_json``, else one record per line of ``config_warnings``
    (kind "resolution" when the line is a time-step resolution warning)."""
    raw = ds.attrs.get("warnings_json")
    if raw:
        try:
            recs = json.loads(str(raw))
            if isinstance(recs, list):
                return [r for r in recs if isinstance(r, dict) and "message" in r]
        except ValueError:
            pass
    text = str(ds.attrs.get("config_warnings", "") or "")
    return [{"message": line, "keys": [],
             "kind": "resolution" if ("under-resolve" in line and "solver.dt" in line)
             else "input"} for line in text.splitlines() if line.strip()]


def mark_unreliable(table: pd.DataFrame, records: list[dict]) -> pd.DataFrame:
    """Checks computed under a resolution warning: "pass" becomes "not reliable", "FAIL"
    becomes "FAIL (not reliable)"."""
    if not any(r.get("kind") == "resolution" for r in records):
        return table
    table = table.copy()
    table["result"] = table["result"].replace(
        {"pass": NOT_RELIABLE, "FAIL": f"FAIL ({NOT_RELIABLE})"})
    return table


def _warnings_block(records: list[dict]) -> list[str]:
    if not records:
        return []
    out = ["## Warnings of the configuration", ""]
    if any(r.get("kind") == "resolution" for r in records):
        out += [f"> ⚠ **The time step under-resolves the model (see below): the checks are "
                f"marked \"{NOT_RELIABLE}\", not pass.** Re-run with the time step the "
                "warning gives.", ""]
    out += [f"- {r['message']}" for r in records]
    return out + [""]


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return lines


def _version() -> str:
    try:
        return metadata.version("vsi_numba")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a checkout
        return "unknown"


# --------------------------------------------------------------------------------------
# Sections
# --------------------------------------------------------------------------------------


def _provenance(ds: xr.Dataset, source_path: Path | None) -> list[str]:
    a = ds.attrs
    history = str(a.get("history", "")).strip().splitlines()
    rows = [
        ["results file", f"`{source_path}`" if source_path else "(in memory)"],
        ["source", a.get("source", "–")],
        ["config SHA-256", f"`{a['config_sha256']}`" if a.get("config_sha256") else "–"],
        ["conventions", a.get("Conventions", "–")],
        ["history (last step)", history[-1] if history else "–"],
        ["report", f"vsi_numba {_version()}, "
                   f"{datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}"],
    ]
    out = ["## Provenance", ""] + _table(["", ""], rows)
    if not a.get("config_json"):
        out += ["", "> The file carries no `config_json`: the run cannot be reproduced from it."]
    return out + [""]


def _flagged_trains(ds: xr.Dataset) -> list[str]:
    """Trains whose data status is in :data:`WARN_STATUSES`."""
    if "train_status" not in ds:
        return []
    return [str(t) for t, s in zip(ds["train"].values, ds["train_status"].values, strict=True)
            if str(s) in WARN_STATUSES]


def _bridge(ds: xr.Dataset, lphi: chk.DeterminantLength | None = None) -> list[str]:
    a = ds.attrs
    f = bridge_frequencies(ds)
    out = ["## Bridge", ""]
    out.append(f"- Description: {a.get('bridge_description', '–')}")
    if "bridge_length" in a:
        out.append(f"- Length: {float(a['bridge_length']):g} m")
    if lphi is not None:
        value = (f"**{lphi.value:g} m**" if np.isfinite(lphi.value) else "not applicable")
        out.append(f"- Determinant length L_Φ ({chk.DETERMINANT_LENGTH_CLAUSE}, for φ''): "
                   f"{value}; {lphi.rule}.")
        if lphi.assumed:
            out.append("\n> **Note:** L_Φ rests on an assumption (above): φ'' and the design "
                       "factor depend on it. Give the determinant length explicitly "
                       "(`determinant_length`) if the deck is not as assumed.\n")
    track = track_type(ds)
    limit = chk.DECK_ACCELERATION_LIMITS.get(track)
    out.append(f"- Track: {track}"
               + (f" (deck acceleration limit {limit:g} m/s², {chk.DECK_ACCELERATION_CLAUSE})"
                  if limit else " (unknown track type: no default acceleration limit)"))
    if track_type_assumed(ds):
        out.append(f"\n> **Note:** the results do not state the track type "
                   f"(track_type = '{a.get('track_type', '')}'): the stricter ballasted-track "
                   "limit 3.5 m/s² is used. For direct-fastened track the limit is 5 m/s².\n")
    if f.size:
        shown = f[:10]
        out.append("- Natural frequencies [Hz]: " + ", ".join(f"{x:.3f}" for x in shown)
                   + (f" … ({f.size} modes)" if f.size > shown.size else ""))
        cut = chk.frequency_cutoff(f)
        out.append(f"- Frequency cut-off of the acceleration check, max(30 Hz, 1.5 f₁, f₃) "
                   f"= max(30, {1.5 * f[0]:.2f}, "
                   f"{f[2]:.2f}) = **{cut:.2f} Hz** ({chk.DECK_ACCELERATION_CLAUSE} [R])"
                   if f.size >= 3 else
                   f"- Frequency cut-off of the acceleration check: {cut:.2f} Hz "
                   f"(fewer than 3 modes known: f₃ not included)")
        if f[-1] < cut:
            out.append(f"\n> **Note:** the highest mode in the model is {f[-1]:.2f} Hz, below "
                       f"the cut-off {cut:.2f} Hz: modes between the two are missing and the "
                       "deck accelerations may be underestimated. Keep more modes.")
    else:
        out.append("- Natural frequencies: not in the file (no `frequency` variable); the "
                   "acceleration cut-off max(30 Hz, 1.5 f₁, f₃) cannot be stated.")
    return out + [""]


def _summary(results: dict, table: pd.DataFrame, pts: np.ndarray) -> list[str]:
    out = ["## Summary of checks", ""]
    rows = []
    for _, r in table.iterrows():
        units = r["units"]
        util = r["utilisation"]
        rows.append([
            r["check"], _fmt(r["value"], units), _fmt(r["limit"], units),
            _fmt(r["margin"], units), "–" if not np.isfinite(util) else f"{100 * util:.0f} %",
            _result(r["result"]), r["governing_train"] or "–",
            _fmt(r["governing_speed_kmh"]), r["clause"],
        ])
    out += _table(["Check", "Value", "Limit", "Margin (limit − value)", "Utilisation",
                   "Result", "Governing train", "Speed [km/h]", "Clause"], rows)
    out.append("")
    acc = results.get("deck_acceleration")
    if not isinstance(acc, str) and acc is not None:
        a = acc.attrs
        shown = ", ".join(f"{x:g}" for x in pts[:8]) + (" …" if pts.size > 8 else "")
        assumed = (" Track type not stated in the file: ballasted (3.5 m/s²) assumed."
                   if a.get("track_type_assumed") else "")
        if a.get("whole_deck"):
            out.append(f"- Deck acceleration: max over the whole deck (a grid along every "
                       f"span plus the {pts.size} output point{'s' if pts.size != 1 else ''}"
                       f", x = {shown} m); governing x = {a['governing_point']:g} m "
                       f"(max at the output points in that case: "
                       f"{_fmt(a.get('value_at_output_points', np.nan))} m/s², at x = "
                       f"{_fmt(a.get('governing_output_point', np.nan))} m). Over "
                       f"realisations: {a['basis']}.{assumed}")
        else:
            out.append(f"- Deck acceleration: max over the {pts.size} output point"
                       f"{'s' if pts.size != 1 else ''} (x = {shown} m); governing point "
                       f"x = {a['governing_point']:g} m. Over realisations: {a['basis']}."
                       + assumed)
        if pts.size < 3 and not a.get("whole_deck"):
            out.append("  **Few output points:** peaks of the higher modes (within the "
                       "cut-off) may lie between them; add output points along the deck "
                       "(e.g. every L/8) for the acceleration check.")
    dyn = results.get("dynamic_amplification")
    if not isinstance(dyn, str) and dyn is not None:
        a = dyn.attrs
        out.append(f"- φ'dyn = max|y_dyn| / max|y_stat| − 1 of the deck maximum displacement, "
                   f"static response of the same model; basis: {a['basis']}. "
                   f"φ'' (EN 1991-2 Annex C [R]) with L_Φ = {a['length']:g} m "
                   f"({a.get('length_rule', '')}"
                   f"{'' if a.get('length_assumed') else ', ' + chk.DETERMINANT_LENGTH_CLAUSE}"
                   f"), n₀ = {a['n0']:.3g} Hz: max {_fmt(a['phi2_max'])}. "
                   "The design factor 1 + φ'dyn + φ''/2 is information for the comparison "
                   "with Φ × LM71 (EN 1991-2 6.4.6.5(3) [R]), not a pass/fail check.")
    wu = results.get("wheel_unloading")
    if not isinstance(wu, str) and wu is not None and "note" in wu.attrs:
        out.append(f"- Wheel unloading: not applicable, {wu.attrs['note']}.")
    elif not isinstance(wu, str) and wu is not None:
        out.append(_wheel_unloading_line(wu.attrs))
    cf = results.get("comfort")
    if not isinstance(cf, str) and cf is not None and "note" in cf.attrs:
        out.append(f"- Comfort: not applicable, {cf.attrs['note']}.")
    elif not isinstance(cf, str) and cf is not None:
        a = cf.attrs
        where = ""
        if "governing_position" in a:
            d = float(a["governing_position"])
            side = ("at the centre of gravity" if abs(d) < 1e-9 else
                    f"{abs(d):g} m {'ahead of' if d > 0 else 'behind'} the centre of gravity"
                    " (over a suspension pivot)")
            where = f" The peak is in vehicle {a.get('governing_vehicle', '')}, {side}."
        out.append(f"- Comfort: car-body acceleration at the centre of gravity and over each "
                   f"bogie pivot (the largest inside the coach between the pivots); required "
                   f"level **{a['required_level']}**; level reached in the governing case: "
                   f"{a['level']}.{where}")
    out.append("- Limits and clauses tagged [R] are recalled from the standard, not re-read: "
               "check them against the primary text before relying on them.")
    missing = [f"- {name.replace('_', ' ')}: {why}" for name, why in results.items()
               if isinstance(why, str)]
    if missing:
        out += ["", "Checks not made:", *missing]
    return out + [""]


def _wheel_unloading_line(a: dict) -> str:
    """Summary bullet of the wheel unloading check, contact losses named for what they are."""
    txt = "- Wheel unloading"
    if a.get("not_applicable_trains"):
        txt += (f" (checked for {a['applicable_trains']}; **not applicable** to "
                f"{a['not_applicable_trains']}: prescribed contact forces, moving-force "
                "model — no ΔQ/Q₀ and no contact loss)")
    txt += f": governing axle {a['governing_wheel']}"
    if "min_contact_force" in a:
        txt += f"; smallest contact force {_fmt(a['min_contact_force'], 'N')}"
    total = a.get("max_time_separated")
    if total is not None and np.isfinite(total) and total == 0:
        txt += "; no loss of contact"
    elif total is not None:
        source = a.get("longest_contact_loss_source", "")
        if source == "longest_contact_loss":
            txt += (f"; longest single loss of contact {_fmt(a['max_longest_contact_loss'], 's')}"
                    f", total time separated (one wheel, one case) up to {_fmt(total, 's')}")
        else:
            txt += (f"; total time separated (one wheel, one case) up to {_fmt(total, 's')} — "
                    "the longest single loss of contact is not in the file (at most this)")
        if "max_contact_loss_count" in a:
            txt += f" ({a['max_contact_loss_count']:.0f} events in the worst case)"
    if "max_single_step_contact_losses" in a:
        n = a["max_single_step_contact_losses"]
        txt += ("; no one-step losses of contact" if np.isfinite(n) and n == 0 else
                f"; up to {n:.0f} one-step losses of contact in a case (see "
                "[One-step contact losses](#one-step-contact-losses))")
    return txt + "."


def _one_step_losses(results: dict) -> list[str]:
    """Table of the cases with losses of contact lasting a single time step.

    A separation that lasts exactly one step is often numerical ringing of the contact
    (too large a dt, an undamped high mode) rather than a real loss of contact.
    """
    wu = results.get("wheel_unloading")
    if wu is None or isinstance(wu, str) or "single_step_contact_losses" not in wu:
        return []
    n = wu["single_step_contact_losses"]  # (speed, train)
    out = ["## One-step contact losses", ""]
    flagged = n.where(n > 0).to_series().dropna().sort_values(ascending=False)
    if flagged.empty:
        return out + ["No loss of contact lasted a single time step in any case.", ""]
    total = wu.get("contact_loss_count")
    rows = []
    for (speed, train), count in flagged.iloc[:MAX_ONE_STEP_ROWS].items():
        events = "–"
        if total is not None:
            events = _fmt(float(total.sel(speed=speed, train=train)))
        rows.append([str(train), f"{float(wu['speed_kmh'].sel(speed=speed)):.0f}",
                     f"{count:.0f}", events])
    out.append(f"{flagged.size} case{'s' if flagged.size != 1 else ''} (train, speed) had "
               "losses of contact lasting exactly one time step. **Possible spurious "
               "ringing of the contact**: check such cases with a smaller dt (and HHT-α "
               "damping of the high modes) before trusting their contact-loss figures.")
    out.append("")
    out += _table(["Train", "Speed [km/h]", "One-step losses (all wheels, worst realisation)",
                   "All contact-loss events"], rows)
    if flagged.size > MAX_ONE_STEP_ROWS:
        out.append(f"\n… and {flagged.size - MAX_ONE_STEP_ROWS} more cases.")
    return out + [""]


def _deck_end_note(ds: xr.Dataset, reach: float = 1.0) -> list[str]:
    """Warn when the smallest contact forces occur at the deck ends.

    The modal deck meets rigid, level approach track at each end, so a deflected deck
    puts a kink in the rail there; with rigid wheel-rail contact the wheel takes an
    impact at the kink, and the minimum contact force (and dQ/Q0) there is an artefact of
    that idealisation and depends on dt.
    """
    needed = ("position_of_min_contact_force", "min_contact_force", "static_wheel_load")
    length = ds.attrs.get("bridge_length")
    if length is None or any(n not in ds for n in needed):
        return []
    pos = ds["position_of_min_contact_force"]
    x = np.asarray(pos.values, float)
    ratio = (ds["min_contact_force"] / ds["static_wheel_load"]).transpose(*pos.dims)
    unload = 1.0 - np.asarray(ratio.values, float)
    ok = np.isfinite(x) & np.isfinite(unload) & (unload > 0.3)
    at_end = ok & ((np.abs(x) <= reach) | (np.abs(x - float(length)) <= reach))
    if not at_end.any():
        return []
    import json

    try:
        contact = json.loads(ds.attrs.get("config_json", "{}")).get("contact", {})
        model = contact.get("model", "rigid")
    except (TypeError, ValueError, AttributeError):
        model = "rigid"
    if model == "rigid":
        advice = ("the minimum there depends on it and, with rigid contact (an impact at the "
                  "kink), on dt. Check it with Hertz contact (`[contact] model = \"hertz\"`) "
                  "or a track layer.")
    else:
        advice = ("the Hertz contact softens the impact at the kink, but the minimum there "
                  "still depends on this idealisation; a track layer models the transition.")
    return [f"> **Note:** {int(at_end.sum())} of the {int(ok.sum())} wheel records with "
            f"ΔQ/Q₀ > 0.3 have their minimum contact force within {reach:g} m of a deck end. "
            "There the deflected deck meets rigid approach track with a kink in the rail, an "
            f"idealisation of the transition: {advice}", ""]


def _trains(ds: xr.Dataset, applicable=None) -> list[str]:
    out = ["## Trains", ""]
    f = bridge_frequencies(ds)
    lo, hi = float(ds["speed_kmh"].min()), float(ds["speed_kmh"].max())
    rows, warnings = [], []
    for train in ds["train"].values:
        name = str(train)
        status = (str(ds["train_status"].sel(train=train).values)
                  if "train_status" in ds else "unknown")
        D = (float(ds["train_regular_length"].sel(train=train))
             if "train_regular_length" in ds else np.nan)
        if "static_wheel_load" in ds:
            q0 = ds["static_wheel_load"].sel(train=train).values
            axles = str(int(np.isfinite(q0).sum()))
            weight = _fmt(np.nansum(q0), "N") if np.isfinite(q0).any() else "–"
        else:
            axles, weight = "–", "–"
        res = chk.resonance_speeds(f[0], D) if f.size else chk.resonance_speeds(np.nan, D)
        vres = ", ".join(
            (f"**{v:.0f}**" if lo <= v <= hi else f"{v:.0f}") for v in res["speed_kmh"]
        ) or "–"
        shown = f"**{status.upper()}**" if status in WARN_STATUSES else status
        if applicable is None:
            contact = "–"
        elif bool(applicable.sel(train=train)):
            contact = "interaction"
        else:
            contact = "prescribed (moving forces): ΔQ/Q₀ n/a"
        rows.append([name, shown, "–" if not np.isfinite(D) or D <= 0 else f"{D:g}",
                     axles, weight, contact, vres])
        if status in WARN_STATUSES:
            warnings.append(f"> ⚠ **WARNING — train {name} has data status "
                            f"'{status.upper()}'** ({WARN_STATUSES[status]}). Its results "
                            "are not fit for design decisions until the vehicle data are "
                            "confirmed against the primary source.")
    out += _table(["Train", "Data status", "D [m]", "Axles", "Σ static axle loads",
                   "Contact forces",
                   "Resonance speeds f₁D/i, i = 1..4 [km/h] (bold: in the analysed range)"], rows)
    if warnings:
        out += [""] + [w + "\n" for w in warnings]
    return out + [""]


def _cases(ds: xr.Dataset) -> list[str]:
    v = ds["speed_kmh"].values
    irr = ds["irregularity"].values
    out = ["## Analysed cases", ""]
    steps = np.unique(np.round(np.diff(v), 6)) if v.size > 1 else np.zeros(0)
    step = (f", step {steps[0]:g} km/h" if steps.size == 1 else
            (", variable step" if steps.size else ""))
    out.append(f"- Speeds: {v.size}, {v.min():.0f}–{v.max():.0f} km/h{step}")
    out.append(f"- Trains: {ds.sizes['train']} ({', '.join(map(str, ds['train'].values))})")
    seeds = irr[irr != DETERMINISTIC]
    text = f"- Irregularity: {irr.size} realisation{'s' if irr.size != 1 else ''}"
    if (irr == DETERMINISTIC).any():
        text += " (deterministic track" + (f" and {seeds.size} random" if seeds.size else "") + ")"
    else:
        more = " …" if seeds.size > 10 else ""
        text += f" (random, seeds {', '.join(map(str, seeds[:10]))}{more})"
    out.append(text)
    status = ds["status"].values
    n_fail = int((status != 0).sum())
    out.append(f"- Cases: {status.size}, failed: {n_fail}")
    if n_fail:
        meanings = status_meanings(ds)
        rows = []
        for code in np.unique(status[status != 0]):
            where = np.argwhere(status == code)
            first = where[0]
            example = (f"{ds['train'].values[first[1]]}, "
                       f"{ds['speed_kmh'].values[first[0]]:.0f} km/h, "
                       f"irregularity {ds['irregularity'].values[first[2]]}")
            rows.append([str(int(code)), meanings.get(int(code), "?"), str(len(where)), example])
        out += ["", "> **Failed cases are left out of every check (NaN outputs).**", ""]
        out += _table(["Status", "Meaning", "Cases", "First case"], rows)
    return out + [""]


def _statistics(results: dict, ds: xr.Dataset) -> list[str]:
    out = ["## Statistics over irregularity realisations", ""]
    n_real = int((ds["irregularity"].values != DETERMINISTIC).sum())
    if n_real == 0:
        return out + ["Deterministic track only (one realisation per case): no statistics.", ""]
    rows = []
    q = None
    for name in ("deck_acceleration", "wheel_unloading", "comfort"):
        c = results.get(name)
        if c is None or isinstance(c, str) or not c.attrs.get("governing_train"):
            continue
        q = c.attrs["q"]
        case = c.sel(train=c.attrs["governing_train"], speed=c.attrs["governing_speed"])
        units = c.attrs["units"]
        ci = (f"[{_fmt(case['ci_low'], units)}, {_fmt(case['ci_high'], units)}]"
              if np.isfinite(float(case["ci_low"])) else "– (n < 2)")
        p = float(case["exceedance_probability"]) if "exceedance_probability" in case else np.nan
        pn = (float(case["exceedance_probability_normal"])
              if "exceedance_probability_normal" in case else np.nan)
        rows.append([c.attrs["check"],
                     f"{c.attrs['governing_train']}, {c.attrs['governing_speed_kmh']:.0f} km/h",
                     str(int(case["n"])), _fmt(case["mean"], units), _fmt(case["std"], units),
                     _fmt(case["characteristic"], units), ci,
                     "–" if not np.isfinite(p) else f"{p:.2f}",
                     "–" if not np.isfinite(pn) else f"{pn:.2g}"])
    if q is None:
        return out + ["No check had realisations to summarise.", ""]
    pct = f"{100 * q:g} %"
    out += _table(["Quantity", "Governing case", "n", "Mean", "Std", f"{pct} fractile",
                   f"95 % bootstrap CI of the {pct} fractile", "P(> limit), sample",
                   "P(> limit), normal fit"], rows)
    wilks = wilks_sample_size(q)
    out += [
        "",
        f"The characteristic value is the empirical {pct} fractile over the realisations "
        "(linear interpolation between order statistics); its confidence interval is a "
        "percentile bootstrap (resampling the realisations with replacement). "
        "P(> limit), sample is the fraction of realisations above the limit; the normal "
        "fit extrapolates beyond 1/n and is indicative only.",
    ]
    if n_real < wilks:
        out.append(
            f"\n> **More realisations needed:** n = {n_real}. With n realisations the sample "
            f"maximum bounds the {pct} fractile with 95 % confidence only for n ≥ {wilks} "
            f"(Wilks: 1 − {q:g}ⁿ ≥ 0.95; here 1 − {q:g}^{n_real} = {1 - q ** n_real:.2f}). "
            "For small n the bootstrap interval is too narrow."
        )
    return out + [""]


# --------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------


def _irr_text(irr) -> str:
    return "deterministic track" if int(irr) == DETERMINISTIC else f"irregularity seed {irr}"


class _Histories:
    """Time histories of single cases: from the file when stored, else re-run.

    ``get`` returns ``(case, how)`` with ``case`` a Dataset on ``time`` (and ``point``,
    ``wheel``) and ``how`` = "stored" or "recomputed", or ``(None, reason)``.
    """

    def __init__(self, ds: xr.Dataset, runner: CaseRunner | None):
        self.ds = ds
        self.runner = runner
        self.runs: dict = {}

    def stored(self, train, speed, irr, name: str, **where) -> bool:
        ds = self.ds
        if "time" not in ds.dims or name not in ds:
            return False
        return bool(ds[name].sel(train=train, speed=speed, irregularity=irr, **where)
                    .notnull().any())

    def get(self, train, speed, irr, needs: dict):
        if all(self.stored(train, speed, irr, name, **where) for name, where in needs.items()):
            return self.ds.sel(train=train, speed=speed, irregularity=irr), "stored"
        if self.runner is None:
            return None, "re-running cases is switched off"
        key = (str(train), float(speed), int(irr))
        if key not in self.runs:
            try:
                self.runs[key] = (self.runner.run(train, speed, irr), "recomputed")
            except RecomputeError as exc:
                self.runs[key] = (None, str(exc))
            except Exception as exc:  # noqa: BLE001 - a figure must not stop the report
                first = str(exc).splitlines()[0] if str(exc) else ""
                self.runs[key] = (None, f"the re-run raised {type(exc).__name__}: {first}")
        return self.runs[key]


def _recompute_note(case, ds, name, envelope, where: dict, train, speed, irr, units,
                    lowest=False) -> str:
    """Say that a case was re-run and compare its extreme with the stored envelope."""
    y = np.asarray(case[name].sel(**where).values, float)
    got = np.nanmin(y) if lowest else np.nanmax(np.abs(y))
    ref = float(ds[envelope].sel(train=train, speed=speed, irregularity=irr, **where))
    text = (" No history was stored for this case: it was re-run from the file's "
            f"configuration (config_json); re-run {'minimum' if lowest else 'peak'} "
            f"{_fmt(got, units)}, stored envelope {_fmt(ref, units)}")
    if np.isfinite(ref) and not np.isclose(got, ref, rtol=1e-6, atol=0.0):
        text += (" — **they differ: the model or the code changed since the study was run; "
                 "the figure may not show the stored case**")
    return text + "."


def _deck_history(ds, results, hist: _Histories, applicable):
    """(figure, caption) of the governing deck acceleration case, or (None, reason)."""
    acc = results.get("deck_acceleration")
    if acc is None or isinstance(acc, str) or not acc.attrs.get("governing_train"):
        return None, ""
    a = acc.attrs
    train, speed = a["governing_train"], a["governing_speed"]
    # histories are stored at the output points only: show the one with the largest peak
    point = a.get("governing_output_point", a["governing_point"])
    irr = a.get("governing_irregularity", DETERMINISTIC)
    wheel = None
    if (applicable is not None and bool(applicable.sel(train=train))
            and "max_wheel_unloading" in ds):
        w = nanargmax_case(ds["max_wheel_unloading"].sel(train=train, speed=speed,
                                                         irregularity=irr))
        wheel = None if w is None else int(w["wheel"])
    needs = {"deck_acceleration": {"point": point}}
    if wheel is not None:
        needs["contact_force"] = {"wheel": wheel}
    case, how = hist.get(train, speed, irr, needs)
    note, fallback = "", case is None
    if case is None:
        reason = how
        if "time" not in ds.dims or "deck_acceleration" not in ds:
            return None, (f"the file holds no time histories and the governing case could "
                          f"not be re-run ({reason})")
        stored = ds["deck_acceleration"].sel(train=train, point=point).notnull().any("time")
        peak = ds["max_deck_acceleration"].sel(train=train, point=point).where(stored)
        alt = nanargmax_case(peak)
        if alt is None:
            return None, (f"no history of train {train} is stored and the governing case "
                          f"could not be re-run ({reason})")
        speed, irr = alt["speed"], alt["irregularity"]
        case = ds.sel(train=train, speed=speed, irregularity=irr)
        if wheel is not None and not hist.stored(train, speed, irr, "contact_force",
                                                 wheel=wheel):
            wheel = None
        note = (" No history was stored for the governing case and it could not be re-run "
                f"({reason}); shown: the stored case of the governing train with the "
                "largest peak.")
    elif how == "recomputed":
        note = _recompute_note(case, ds, "deck_acceleration", "max_deck_acceleration",
                               {"point": point}, train, speed, irr, "m s-2")
    kmh = float(ds["speed_kmh"].sel(speed=speed))
    q0 = (float(ds["static_wheel_load"].sel(train=train, wheel=wheel))
          if wheel is not None and "static_wheel_load" in ds else None)
    fig = plots.plot_case_history(case, plots.case_title(train, kmh, irr, point), point=point,
                                  wheel=wheel, limit=a["limit"], q0=q0)
    role = "governing train" if fallback else "governing case"
    caption = (f"Time histories of {train} at {kmh:.0f} km/h ({_irr_text(irr)}), "
               f"the {role} of the deck acceleration check, at x = {point:g} m"
               + (f", contact force of axle {wheel} (largest unloading)" if wheel is not None
                  else "") + "." + note)
    return fig, caption


def _wheel_history(ds, results, hist: _Histories):
    """(figure, caption) of the governing wheel unloading case, or (None, reason)."""
    wu = results.get("wheel_unloading")
    if wu is None or isinstance(wu, str) or not wu.attrs.get("governing_train"):
        return None, ""
    a = wu.attrs
    train, speed, wheel = a["governing_train"], a["governing_speed"], a["governing_wheel"]
    irr = a.get("governing_irregularity", DETERMINISTIC)
    if wheel < 0:
        return None, ""
    case, how = hist.get(train, speed, irr, {"contact_force": {"wheel": wheel}})
    kmh = float(ds["speed_kmh"].sel(speed=speed))
    if case is None:
        return None, (f"the governing case of the wheel unloading check ({train}, "
                      f"{kmh:.0f} km/h) has no stored history and could not be re-run "
                      f"({how})")
    sel = {"train": train, "speed": speed, "irregularity": irr, "wheel": wheel}
    pos = (float(ds["position_of_min_contact_force"].sel(sel))
           if "position_of_min_contact_force" in ds else np.nan)
    q0 = (float(ds["static_wheel_load"].sel(train=train, wheel=wheel))
          if "static_wheel_load" in ds else None)
    length = float(ds.attrs["bridge_length"]) if "bridge_length" in ds.attrs else None
    dq = float(ds["max_wheel_unloading"].sel(sel))
    fig = plots.plot_case_history(
        case, plots.case_title(train, kmh, irr) + f", axle {wheel}", wheel=wheel, q0=q0,
        min_position=pos if np.isfinite(pos) else None, bridge_length=length,
        speed=float(speed))
    caption = (f"Contact force of axle {wheel} of {train} at {kmh:.0f} km/h "
               f"({_irr_text(irr)}), the governing case of the wheel unloading check "
               f"(ΔQ/Q₀ = {dq:.3f} in this realisation)")
    if np.isfinite(pos):
        caption += (f"; ★ minimum contact force, with the axle at x = {pos:.2f} m along the "
                    "track (position_of_min_contact_force"
                    + (f"; the deck spans 0–{length:g} m, shaded while the axle is on it"
                       if length is not None else "") + ")")
    caption += "."
    if how == "recomputed":
        caption += _recompute_note(case, ds, "contact_force", "min_contact_force",
                                   {"wheel": wheel}, train, speed, irr, "N", lowest=True)
    return fig, caption


def _figures(ds: xr.Dataset, results: dict, outdir: Path,
             runner: CaseRunner | None = None) -> tuple[list[tuple[str, str]], list[str]]:
    """Write the PNGs; return (file name, caption) pairs and notes on figures not drawn."""
    made, notes = [], []

    def put(fig, name, caption):
        plots.save(fig, outdir / name)
        made.append((name, caption))

    acc = results.get("deck_acceleration")
    if not isinstance(acc, str):
        put(plots.plot_deck_acceleration(ds, acc), "deck_acceleration.png",
            "Peak vertical deck acceleration (max over the deck points) against speed, "
            "with the EN 1990 A2.4.4.2.1 limit; ▼ resonance speeds f₁D/i; shaded: 95 % "
            "bootstrap interval of the characteristic value where there are realisations.")
    dyn = results.get("dynamic_amplification")
    if not isinstance(dyn, str):
        put(plots.plot_dynamic_amplification(ds, dyn), "dynamic_amplification.png",
            "Dynamic increment φ'dyn of the deck maximum displacement against speed; "
            "dotted: φ''/2 (EN 1991-2 Annex C [R]).")
    wu = results.get("wheel_unloading")
    applicable = None
    if not isinstance(wu, str) and wu is not None:
        applicable = wu["applicable"]
    if not isinstance(wu, str) and "note" not in wu.attrs:
        skipped = wu.attrs.get("not_applicable_trains", "")
        put(plots.plot_wheel_unloading(ds, wu), "wheel_unloading.png",
            "Minimum wheel–rail contact force and wheel unloading ΔQ/Q₀ (max over axles) "
            "against speed, with the 0.6 limit (EN 14363 practice [R])"
            + (f"; not drawn: {skipped} (prescribed moving forces, not applicable)"
               if skipped else "") + ".")
    cf = results.get("comfort")
    if not isinstance(cf, str) and bool(cf["value"].notnull().any()):
        put(plots.plot_comfort(ds, cf), "comfort.png",
            "Vertical car-body acceleration (max over vehicles) against speed with the "
            "levels of comfort of EN 1990 Table A2.9 [R].")
    hist = _Histories(ds, runner)
    for name, make in (("time_history.png", lambda: _deck_history(ds, results, hist,
                                                                  applicable)),
                       ("wheel_unloading_history.png", lambda: _wheel_history(ds, results,
                                                                              hist))):
        fig, caption = make()
        if fig is not None:
            put(fig, name, caption)
        elif caption:
            notes.append(f"- Not drawn: {caption}.")
    return made, notes


# --------------------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------------------


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
    lines += ["## Figures", ""]
    for i, (name, caption) in enumerate(figures, 1):
        lines += [f"![Figure {i}]({name})", "", f"*Figure {i}: {caption}*", ""]
    if figure_notes:
        lines += [*figure_notes, ""]
    path = outdir / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path
