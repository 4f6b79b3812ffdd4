"""The report's "Deck deflection" section and its summary rows: the vertical deflection
under LM71 x Phi x alpha against L/600 (EN 1990 A2.4.4.2.3(1)) and the passenger-comfort
deflection against Fig. A2.3 (EN 1990 A2.4.4.3.2), from
:func:`vsi_numba.analysis.checks.deflection.deflection_checks`."""

from __future__ import annotations

import numpy as np

from vsi_numba.analysis.checks.deflection import (
    COMFORT_DEFLECTION_CLAUSE,
    DEFLECTION_CLAUSE,
    DeflectionResults,
)
from vsi_numba.analysis.report.document import Section, markdown_table
from vsi_numba.analysis.report.numbers import fmt_number
from vsi_numba.analysis.report.safe import md
from vsi_numba.code_profile import RECALLED

#: Title (and anchor "deck-deflection") of the section.
TITLE = "Deck deflection"
#: The summary's check names.
SAFETY_CHECK = "Vertical deflection δ under LM71 × Φ × α (track safety)"
COMFORT_CHECK = "Vertical deflection δ under LM71 × Φ (passenger comfort)"


def _mm(v) -> str:
    return fmt_number(1e3 * float(v), "mm", 4) if np.isfinite(v) else "–"


def _trunc(r) -> str:
    t = r.truncation
    if not np.isfinite(t):
        return ""
    return (f" (modal flexibility: an underestimate; the last retained mode adds "
            f"{100 * t:.2g} % of it)")


def _short(reason: str) -> str:
    """The reason without the text of an input's error message (which the section shows,
    as data): the summary's check names hold the package's own words only."""
    head = "the stored configuration cannot be rebuilt"
    return f"{head} (see {TITLE})" if reason.startswith(head) else reason


def summary_rows(res: DeflectionResults | str) -> list[dict]:
    """Rows of the summary table (:data:`vsi_numba.analysis.checks.SUMMARY_COLUMNS`):
    the governing span of each check, or one "n/a" row per check saying why not."""
    if isinstance(res, str):
        return [{"check": f"{name}: not computed ({_short(res)})", "value": np.nan, "units": "m",
                 "limit": np.nan, "margin": np.nan, "utilisation": np.nan, "result": "n/a",
                 "governing_train": "", "governing_speed_kmh": np.nan, "clause": clause}
                for name, clause in ((SAFETY_CHECK, DEFLECTION_CLAUSE),
                                     (COMFORT_CHECK, COMFORT_DEFLECTION_CLAUSE))]
    rows = []
    for which, name, clause, load, speed in (
            ("safety", SAFETY_CHECK, DEFLECTION_CLAUSE, "LM71 × Φ × α", np.nan),
            ("comfort", COMFORT_CHECK, COMFORT_DEFLECTION_CLAUSE, "LM71 × Φ",
             res.speed_kmh)):
        g = res.governing(which)
        if g is None:
            rows.append({"check": f"{name}: not computed ({res.comfort_note})",
                         "value": np.nan, "units": "m", "limit": np.nan, "margin": np.nan,
                         "utilisation": np.nan, "result": "n/a", "governing_train": "",
                         "governing_speed_kmh": np.nan, "clause": clause})
            continue
        where = f"track {g.track}, " if res.n_tracks > 1 else ""
        level = f", {res.level}" if which == "comfort" else ""
        approx = ", modal flexibility: an underestimate" if np.isfinite(g.truncation) else ""
        rows.append({"check": f"{name}{level}, {where}span {g.span} at x = {g.at:.4g} m"
                              f"{approx}",
                     "value": g.value, "units": "m", "limit": g.limit,
                     "margin": g.limit - g.value, "utilisation": g.utilisation,
                     "result": "pass" if g.passed else "FAIL", "governing_train": load,
                     "governing_speed_kmh": speed, "clause": clause})
    return rows


def deflection_section(res: DeflectionResults | str) -> Section:
    """The "Deck deflection" section: how the deflection was computed, the two checks per
    track and span, the Fig. A2.3 reading and the limits of every level of comfort."""
    lines = [f"## {TITLE}", ""]
    if isinstance(res, str):
        lines += [f"Vertical deflection under LM71 ({DEFLECTION_CLAUSE}, L/600): not "
                  f"checked: {md(res)}.", "",
                  f"Passenger-comfort deflection ({COMFORT_DEFLECTION_CLAUSE}): not "
                  f"checked: {md(res)}."]
        return Section.from_markdown(lines)
    p = res.profile
    ratio = p["deflection_span_ratio"]
    tracks = (f"every one of the deck's {res.n_tracks} tracks loaded at once (× "
              f"{res.track_factor:g} on each, `lm71_factor_several_tracks`)"
              if res.n_tracks > 1 else "the track loaded")
    lines += [f"Static deflection of the deck along each track centre line under LM71 "
              f"placed most unfavourably (the axle group anywhere, the distributed load "
              f"where it adds to the deflection), times {res.phi_name} = "
              f"{fmt_number(res.phi)} (L_Φ = {fmt_number(res.lphi, 'm')}, "
              f"{md(res.lphi_rule)}; {md(res.maintenance)} maintenance). Method: {res.method}. "
              "The spreading of the loads by the track is neglected (it can only lower the "
              "peak deflection: the safe side). Positive down; the largest of each span.",
              ""]
    lines += [f"**Track safety** ({DEFLECTION_CLAUSE}): LM71 × Φ × α with α = "
              f"{fmt_number(res.alpha)}, {tracks}; limit L / {ratio:g}.", ""]
    rows = [[str(r.track), str(r.span), fmt_number(r.length, "m"), _mm(r.value) + _trunc(r),
             fmt_number(r.at, "m"), fmt_number(r.ratio, "", 4), _mm(r.limit),
             fmt_number(r.utilisation, "", 3), "pass" if r.passed else "**FAIL**"]
            for r in res.safety]
    lines += markdown_table(["track", "span", "L", "δ", "at x", "L/δ", f"limit L/{ratio:g}",
                             "utilisation", "verdict"], rows)
    lines.append("")
    one = ("one track loaded at a time (the deflection of the loaded track)"
           if res.n_tracks > 1 else "the track loaded")
    lines += [f"**Passenger comfort** ({COMFORT_DEFLECTION_CLAUSE}): LM71 × Φ with α = 1, "
              f"{one}, at V = {fmt_number(res.speed_kmh, 'km/h')} ({res.speed_rule}). "
              f"Least L/δ of Fig. A2.3 for b_v = 1.0 m/s² {RECALLED} "
              f"({res.figure_note or 'not read'}), times the factor for the deck "
              f"({res.deck_rule}), divided by b_v of the required level "
              f"**{res.level}** ({fmt_number(res.b_v, 'm/s²')}).", ""]
    if res.comfort:
        rows = [[str(r.track), str(r.span), fmt_number(r.length, "m"),
                 _mm(r.value) + _trunc(r), fmt_number(r.at, "m"), fmt_number(r.ratio, "", 4),
                 fmt_number(res.required_ratio[r.span - 1], "", 4), _mm(r.limit),
                 fmt_number(r.utilisation, "", 3), "pass" if r.passed else "**FAIL**"]
                for r in res.comfort]
        lines += markdown_table(["track", "span", "L", "δ", "at x", "L/δ", "required L/δ",
                                 "limit δ", "utilisation", "verdict"], rows)
        lines += ["", "Required L/δ of every level of comfort (the same figure and factor, "
                  "divided by its b_v), per span:", ""]
        worst = {}
        for r in res.comfort:
            worst[r.span] = max(worst.get(r.span, 0.0), r.value)
        spans = _spans(res)
        rows = []
        for name, b_v, req in res.levels:
            cells = [name, fmt_number(b_v, "m/s²")]
            for i, q in enumerate(req):
                w = worst.get(i + 1, 0.0)
                reached = "–" if not w > 0 else ("met" if spans[i] / w >= q else "not met")
                cells.append(f"{fmt_number(q, '', 4)} ({reached})")
            rows.append(cells)
        lines += markdown_table(["level", "b_v", *[f"span {i + 1}" for i in
                                                    range(len(res.required_ratio))]], rows)
    else:
        lines += [f"Passenger-comfort deflection: not checked: {md(res.comfort_note)}."]
    lines += ["", f"Fig. A2.3 {RECALLED} is read from the table "
              "`COMFORT_DEFLECTION_CURVES` of the code profile (linear in L between its "
              "points, linear in V between its curves)."]
    return Section.from_markdown(lines)


def _spans(res: DeflectionResults) -> dict:
    """Span lengths by index (0-based) from the checks' rows."""
    out = {}
    for r in (*res.safety, *res.comfort):
        out[r.span - 1] = r.length
    return out
