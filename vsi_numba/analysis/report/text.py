"""The Markdown of the report: the warnings stored in a results file and one function
per section (provenance, bridge, summary, trains, cases, statistics); the numbers are
written by :mod:`.numbers`."""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    NOT_RELIABLE,
    bridge_frequencies,
    status_meanings,
    stored_warnings,  # noqa: F401 - the report modules import it from here
    track_type,
    track_type_assumed,
)
from vsi_numba.analysis.report.numbers import (
    _fmt,
    fmt_against,
    fmt_list,
    fmt_percent_against,
    sha256_text,
)
from vsi_numba.analysis.report.safe import clean, code, md
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


def _result(text: str) -> str:
    return {"FAIL": "**FAIL**", "pass": "pass", NOT_RELIABLE: f"**{NOT_RELIABLE}**",
            "not determined": "**not determined**",
            f"FAIL ({NOT_RELIABLE})": f"**FAIL ({NOT_RELIABLE})**"}.get(text, text)


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
    out += [f"- {md(r['message'])}" for r in records]
    return out + [""]


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(clean(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return lines


def _version() -> str:
    try:
        return metadata.version("vsi_numba")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a checkout
        return "unknown"


# --------------------------------------------------------------------------------------
# Sections
# --------------------------------------------------------------------------------------


def _shown(path) -> str:
    """A path as a report may show it: as given when relative, the name when absolute."""
    path = Path(path)
    return path.name if path.is_absolute() else str(path)


def _provenance(ds: xr.Dataset, source_path: Path | None) -> list[str]:
    """The provenance table.  Its content follows from the results alone (no clock, no
    machine): the results file as given (relative to the report directory), the command
    of the last history step without its time stamp (the results file's ``history``
    keeps the times) and with absolute paths cut to their file names, the config hash
    and the versions; a report of the same results is the same file."""
    a = ds.attrs
    history = str(a.get("history", "")).strip().splitlines()
    command = re.sub(r"^\d{4}-\d\d-\d\dT[\d:.]+Z?\s+", "", history[-1]) if history else "–"
    # absolute paths of the machine it ran on: the file name only
    command = " ".join(f"…/{Path(t).name}" if t.startswith("/") and len(t) > 1 else t
                       for t in command.split(" "))
    rows = [
        # relative to the report, or the name alone: a report must not carry the paths of
        # the machine it was made on
        ["results file", code(_shown(source_path)) if source_path else "(in memory)"],
        ["source", md(a.get("source", "–"))],
        ["config SHA-256", sha256_text(a.get("config_sha256"))],
        ["conventions", md(a.get("Conventions", "–"))],
        ["command (last step)", code(command) if command != "–" else command],
        ["report", f"vsi_numba {_version()}"],
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


def _bridge_description(ds: xr.Dataset) -> str:
    """``simply supported, spans 20 + 20 m, EI = 1.508e10 N m², m = 15000 kg/m`` from the
    stored config, else the file's ``bridge_description``."""

    bridge = _config_section(ds, "bridge") or {}
    if not bridge.get("kind"):
        return md(ds.attrs.get("bridge_description", "–"))
    parts = [md(str(bridge["kind"]).replace("_", " "))]
    if bridge.get("spans"):
        parts.append(("spans " if len(bridge["spans"]) > 1 else "span ")
                     + fmt_list(bridge["spans"], "m", " + "))
    if "EI" in bridge:
        parts.append("EI = " + fmt_list(bridge["EI"], "N m²"))
    if "mass_per_length" in bridge:
        parts.append("m = " + fmt_list(bridge["mass_per_length"], "kg/m"))
    return ", ".join(parts)


def _bridge(ds: xr.Dataset, lphi: chk.DeterminantLength | None = None) -> list[str]:
    a = ds.attrs
    f = bridge_frequencies(ds)
    out = ["## Bridge", ""]
    out.append(f"- Description: {_bridge_description(ds)}")
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
    rail = _track_model(ds)
    if rail is not None:
        out.append(f"- Track model at the wheels: {rail}")
    track = track_type(ds)
    profile = chk.profile_of(ds)  # the limits of the study's code profile
    limits = {t: profile[k] for t, k in chk.DECK_ACCELERATION_KEYS.items()}
    limit = limits.get(track)
    clause = profile.clause(chk.DECK_ACCELERATION_KEYS[track]) if limit else ""
    out.append(f"- Track: {md(track)}"
               + (f" (deck acceleration limit {limit:g} m/s², {md(clause)})"
                  if limit else " (unknown track type: no default acceleration limit)"))
    if track_type_assumed(ds):
        out.append(f"\n> **Note:** the results do not state the track type "
                   f"(track_type = '{md(a.get('track_type', ''))}'): the stricter ballasted-track "
                   f"limit {limits['ballasted']:g} m/s² is used. For direct-fastened track the "
                   f"limit is {limits['direct_fastening']:g} m/s².\n")
    if f.size:
        shown = f[:10]
        out.append("- Natural frequencies [Hz]: " + ", ".join(f"{x:.3f}" for x in shown)
                   + (f" … ({f.size} modes)" if f.size > shown.size else ""))
        cut = chk.frequency_cutoff(f)
        out.append(f"- Frequency cut-off of the acceleration check, max(30 Hz, 1.5 f₁, f₃) "
                   f"= max(30, {1.5 * f[0]:.2f}, "
                   f"{f[2]:.2f}) = **{cut:.2f} Hz** ({chk.DECK_ACCELERATION_CLAUSE})"
                   if f.size >= 3 else
                   f"- Frequency cut-off of the acceleration check: {cut:.2f} Hz "
                   f"(fewer than 3 modes known: f₃ not included)")
        out += _modes_left_out_note(ds, f, cut)
    else:
        out.append("- Natural frequencies: not in the file (no `frequency` variable); the "
                   "acceleration cut-off max(30 Hz, 1.5 f₁, f₃) cannot be stated.")
    return out + [""]


def _where_cell(row) -> str:
    """The summary's "Where" cell: the row's ``where``, "–" when it has none."""
    w = row.get("where", "") if hasattr(row, "get") else ""
    return md(w) if isinstance(w, str) and w else "–"


def _modes_left_out_note(ds: xr.Dataset, f: np.ndarray, cut: float) -> list[str]:
    """The note on modes up to the acceleration cut-off that the model left out: from the
    file's record of them (``modes_left_out_below_cutoff``); a file without that record
    and whose highest mode is below the cut-off gets a line saying it is not known."""
    a = ds.attrs
    try:  # a results file is input: an unreadable record is no record
        n = int(a["modes_left_out_below_cutoff"]) if "modes_left_out_below_cutoff" in a else None
        freqs = [float(x) for x in str(a.get("frequencies_left_out_below_cutoff", "")).split()]
    except (TypeError, ValueError):
        n, freqs = None, []
    if n is not None:
        if n <= 0:
            return []
        shown = ", ".join(f"{x:.2f}" for x in freqs[:10]) + (" …" if len(freqs) > 10 else "")
        return [f"\n> **Note:** {n} mode{'s' if n != 1 else ''} of the deck below the "
                f"cut-off {cut:.2f} Hz {'are' if n != 1 else 'is'} left out of the model"
                + (f" ({shown} Hz)" if shown else "") + ": the deck accelerations may be "
                "underestimated. Keep more modes (`bridge.n_modes` or "
                "`bridge.max_frequency`).\n"]
    if f[-1] < cut:
        return [f"\n> **Note:** the highest mode in the model is {f[-1]:.2f} Hz, below the "
                f"cut-off {cut:.2f} Hz, and the results file does not record whether the "
                "deck has modes between the two that were left out (written by an earlier "
                "version): not checked. Keep every mode up to the cut-off "
                "(`bridge.max_frequency`) if there are.\n"]
    return []


def _summary(results: dict, table: pd.DataFrame, pts: np.ndarray,
             not_made: list[str] | None = None) -> list[str]:
    out = ["## Summary of checks", ""]
    rows = []
    acc = results.get("deck_acceleration")
    acc_note = ("" if isinstance(acc, str) or acc is None
                else str(acc.attrs.get("accuracy_note", "")))
    for _, r in table.iterrows():
        units = r["units"]
        util = r["utilisation"]
        verdict = _result(r["result"])
        if acc_note and r["check"] == "Peak deck acceleration":
            verdict += f" ({acc_note})"
        rows.append([
            md(r["check"]), fmt_against(r["value"], r["limit"], units), _fmt(r["limit"], units),
            _fmt(r["margin"], units), fmt_percent_against(util),
            verdict, md(r["governing_train"]) if r["governing_train"] else "–",
            _fmt(r["governing_speed_kmh"]), _where_cell(r), md(r["clause"]),
        ])
    out += _table(["Check", "Value", "Limit", "Margin (limit − value)", "Utilisation",
                   "Result", "Governing train", "Speed [km/h]", "Where", "Clause"], rows)
    out.append("")
    if not isinstance(acc, str) and acc is not None:
        a = acc.attrs
        shown = ", ".join(f"{x:g}" for x in pts[:8]) + (" …" if pts.size > 8 else "")
        assumed = (f" Track type not stated in the file: ballasted ({a['limit']:g} m/s²) "
                   "assumed." if a.get("track_type_assumed") else "")
        if a.get("whole_deck"):
            line = (f" and along the line of the loaded track {a['loaded_track']}"
                    if a.get("loaded_track_whole_deck") else "")
            out.append(f"- Deck acceleration: max over the whole deck{line} (a grid along "
                       f"every span plus the {pts.size} output point"
                       f"{'s' if pts.size != 1 else ''}"
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
                   f"φ'' (EN 1991-2 Annex C) with L_Φ = {a['length']:g} m "
                   f"({a.get('length_rule', '')}"
                   f"{'' if a.get('length_assumed') else ', ' + chk.DETERMINANT_LENGTH_CLAUSE}"
                   f"), n₀ = {a['n0']:.3g} Hz: max {_fmt(a['phi2_max'])}. "
                   "The design factor 1 + φ'dyn + φ''/2 is information for the comparison "
                   "with Φ × LM71 (EN 1991-2 6.4.6.5(3)), not a pass/fail check.")
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
            where = f" The peak is in vehicle {md(a.get('governing_vehicle', ''))}, {side}."
        out.append(f"- Comfort: car-body acceleration at the centre of gravity and over each "
                   f"bogie pivot (the largest inside the coach between the pivots); required "
                   f"level **{md(a['required_level'])}**; level reached in the governing "
                   f"case: {md(a['level'])}.{where}")
        if "car_end_value" in a:
            d = float(a.get("car_end_position", np.nan))
            end = ("front" if d > 0 else "rear") if np.isfinite(d) else "an"
            out.append(f"- Comfort at the car-body ends (reported apart from the value above, "
                       f"the ends lying beyond the pivots): largest "
                       f"{_fmt(a['car_end_value'])} m/s² ({a['car_end_level']}), at the "
                       f"{end} end of vehicle {md(a.get('car_end_vehicle', ''))}"
                       f"{f', {abs(d):g} m from its centre of gravity' if np.isfinite(d) else ''}"
                       f" ({md(a.get('car_end_train', ''))}, "
                       f"{float(a.get('car_end_speed', np.nan)) * 3.6:.0f} km/h).")
    out.append("- Limits and clause values: the [code profile](#code-profile) of the study "
               "(one table, values recalled and not re-read marked there).")
    missing = [f"- {name.replace('_', ' ')}: {why}" for name, why in results.items()
               if isinstance(why, str)]
    missing += [f"- {md(why)}" for why in not_made or []]
    if missing:
        out += ["", "Checks not made:", *missing]
    return out + [""]


def _wheel_unloading_line(a: dict) -> str:
    """Summary bullet of the wheel unloading check, contact losses named for what they are."""
    txt = "- Wheel unloading"
    if a.get("not_applicable_trains"):
        txt += (f" (checked for {md(a['applicable_trains'])}; **not applicable** to "
                f"{md(a['not_applicable_trains'])}: prescribed contact forces, moving-force "
                "model — no ΔQ/Q₀ and no contact loss)")
    if a.get("zone"):
        txt += f" ({md(a['zone'])})"
    txt += f": governing axle {a['governing_wheel']}"
    if "min_contact_force" in a and np.isfinite(float(a["min_contact_force"])):
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
    if "bridge_upper" in a:
        txt += (f"; **{a.get('approach_records', 0)} axle records had their minimum contact "
                f"force off the bridge** (the approach / exit track): their ΔQ/Q₀ while on "
                f"the bridge is not in the file, only that it is at most "
                f"{a['bridge_upper']:.3f}, so the bridge's maximum lies between "
                f"{a['bridge_lower']:.3f} and {a['bridge_upper']:.3f}"
                + ("; the value shown is that upper bound" if a.get("value_is_upper_bound")
                   else "")
                + f" — result: {a['result']}")
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
        rows.append([md(train), f"{float(wu['speed_kmh'].sel(speed=speed)):.0f}",
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


def _config_section(ds: xr.Dataset, name: str) -> dict | None:
    """A section of the resolved config stored with the results (None if absent)."""
    sec = chk.results_config(ds).get(name)
    return sec if isinstance(sec, dict) else None


def _track_model(ds: xr.Dataset) -> str | None:
    """How the wheels see the track, from the stored config (None: not stated)."""
    if "config_json" not in ds.attrs:
        return None
    bridge = _config_section(ds, "bridge") or {}
    if "track" in bridge:
        return ("the FE track layer of the deck (rail, pads, sleepers, ballast); rigid "
                "approach track, the rail clamped at the deck ends")
    t = _config_section(ds, "track")
    if t is None or t.get("model") == "rigid":
        return ("**rigid-track idealisation** (the wheel runs on the deck line and on rigid "
                "approach track: a kink in the rail at each deck end)")
    k, ei = float(t["foundation_stiffness"]), float(t["rail_EI"])
    beta = (k / (4 * ei)) ** 0.25
    text = (f"elastic track — the rail (EI = {ei:.4g} N m², both rails) on a foundation of "
            f"{k / 1e6:.4g} MN/m per metre of track over the deck and the approaches, "
            f"{2 * k / beta / 1e6:.4g} kN/mm under one axle")
    if "foundation_damping" not in t or "rail_mass" not in t:
        # results written before the track had damping and mass: undamped, massless
        return text + ("; foundation damping and rail mass not recorded (undamped "
                       "foundation, massless rail) (vsi_numba.model.track)")
    c, m = float(t["foundation_damping"]), float(t["rail_mass"])
    # the wheel element's damping and mass: (3/4) (c / k) and (3/4) (m' / k) times the
    # axle stiffness 2 k / beta (ElasticTrack.wheel_element)
    return text + (f"; foundation damping {c / 1e3:.4g} kN s/m per metre of track "
                   f"({1.5 * c / beta / 1e3:.4g} kN s/m under one axle), rail mass "
                   f"{m:.4g} kg per metre of track ({1.5 * m / beta:.4g} kg under one axle)"
                   " (vsi_numba.model.track)")


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
    rail = _config_section(ds, "track")
    if rail is not None and rail.get("model") == "elastic":
        return [f"> **Note:** {int(at_end.sum())} of the {int(ok.sum())} wheel records with "
                f"ΔQ/Q₀ > 0.3 have their minimum contact force within {reach:g} m of a deck "
                "end. The rail carries the wheels over the joint on its foundation (elastic "
                "track), so this is the modelled transition, not a kink; its stiffness "
                "(`[track] foundation_stiffness`) governs it.", ""]
    model = (_config_section(ds, "contact") or {}).get("model", "rigid")
    if model == "rigid":
        advice = ("the minimum there depends on it and, with rigid contact (an impact at the "
                  "kink), on dt. Use the elastic track (`[track] model = \"elastic\"`, the "
                  "default), whose rail carries the wheel over the joint.")
    else:
        advice = ("the Hertz contact softens the impact at the kink, but the minimum there "
                  "still depends on this idealisation; the elastic track (`[track] model = "
                  "\"elastic\"`, the default) models the transition.")
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
        shown = f"**{md(status.upper())}**" if status in WARN_STATUSES else md(status)
        if applicable is None:
            contact = "–"
        elif bool(applicable.sel(train=train)):
            contact = "interaction"
        else:
            contact = "prescribed (moving forces): ΔQ/Q₀ n/a"
        rows.append([md(name), shown, "–" if not np.isfinite(D) or D <= 0 else f"{D:g}",
                     axles, weight, contact, vres])
        if status in WARN_STATUSES:
            warnings.append(f"> ⚠ **WARNING — train {md(name)} has data status "
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
    out.append(f"- Trains: {ds.sizes['train']} ({', '.join(map(md, ds['train'].values))})")
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
            example = (f"{md(ds['train'].values[first[1]])}, "
                       f"{ds['speed_kmh'].values[first[0]]:.0f} km/h, "
                       f"irregularity {ds['irregularity'].values[first[2]]}")
            rows.append([str(int(code)), md(meanings.get(int(code), "?")), str(len(where)),
                         example])
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
                     f"{md(c.attrs['governing_train'])}, "
                     f"{c.attrs['governing_speed_kmh']:.0f} km/h",
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
