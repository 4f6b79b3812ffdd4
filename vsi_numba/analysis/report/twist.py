"""The report's section on a deck in space: the deck twist check of EN 1990 A2.4.4.2.2
(static under LM71 x Phi x alpha, and the dynamic runs) and the peak deck acceleration
along each track (:func:`vsi_numba.analysis.checks.twist.twist_checks`)."""

from __future__ import annotations

import numpy as np

from vsi_numba.analysis.checks.twist import TWIST_CLAUSE, twist_checks
from vsi_numba.analysis.report.document import Section, markdown_table
from vsi_numba.analysis.report.numbers import fmt_number
from vsi_numba.analysis.report.safe import md


def _mm(v) -> str:
    return fmt_number(1e3 * float(v), "mm", 3) if np.isfinite(v) else "–"


def _verdict(value, limit) -> str:
    if not np.isfinite(value):
        return "–"
    return "pass" if value <= limit else "**FAIL**"


def dynamic_twist_note(env) -> str:
    """The sign and size of the dynamic twist's error, for beside its verdict: files whose
    twist is a plain modal sum (no ``deck_twist_method`` attribute) state it."""
    method = str(env.attrs.get("deck_twist_method", "modal sum"))
    if method == "modal sum" and "track_line" in env:  # an imported deck
        return ("modal sum without static correction: its error is not measured for an "
                "imported deck; on beam decks up to 8 % LOW, unsafe side")
    if method == "modal sum":  # measured on the whole-deck grid, the table's value
        return ("modal sum without static correction: up to 8 % LOW, unsafe side, "
                "against a converged reference")
    # mode acceleration: exact static part; at a torsional resonance every torsional
    # mode resonates (f_j = j f_t1), the truncated ones are left out (vsi verify V16,
    # V19: +5.3 .. +6.7 %; -1.6 % measured on the whole-deck grid of a 20 m span)
    return ("mode acceleration: within 0.1 % at crawl speed and off a torsional "
            "resonance within about 2 %; at a torsional resonance -2 .. +7 % against a "
            "converged reference")


def twist_section(env, config_dir=None, source_path=None,
                  not_made: list | None = None) -> Section | None:
    """The "Deck twist and tracks" section, or None for a planar deck (no per-track
    outputs in the file); ``config_dir``, ``source_path``: where the files of an
    imported deck are looked for; ``not_made``: a list the checks not made are appended
    to (for the summary)."""
    if "max_track_displacement" not in env:
        return None
    missing = not_made if not_made is not None else []
    res = twist_checks(env, base_dir=config_dir, source_path=source_path)
    if isinstance(res, str):
        missing.append(f"deck twist ({TWIST_CLAUSE}): {res}")
        return Section.from_markdown(["## Deck twist and tracks", "", f"Not checked: {md(res)}."])
    if not res.static:
        missing.append(f"static deck twist under LM71 × Φ × α ({TWIST_CLAUSE}): "
                       f"{res.static_note or 'not computed'}")
    ecc = (np.asarray(env["track_eccentricity"].values, float)
           if "track_eccentricity" in env else np.full(len(res.acceleration), np.nan))
    names = [str(v) for v in env["track_line"].values] if "track_line" in env else None
    rails = ("the rails of a track are 1.435 m apart unless the configuration says "
             "otherwise" if names is None else "the rails of a track are the lines "
             "`<track>/left` and `<track>/right` of the imported deck")
    lines = ["## Deck twist and tracks", "",
             f"Deck twist over 3 m ({TWIST_CLAUSE}): limit {_mm(res.limit)} for the line "
             f"speed {fmt_number(res.line_speed_kmh, 'km/h')} (from the code profile "
             f"above). The train runs on track {res.loaded_track}; {rails}, and the "
             "deck model is vertical only (no roll of the vehicles, no lateral dynamics).",
             ""]
    if res.static:
        a, p = res.static[0].alpha, res.static[0].phi
        lines += [f"**Static: LM71 × Φ × α** on each track in turn (α = {fmt_number(a)}, "
                  f"Φ = {fmt_number(p)} with L_Φ = {fmt_number(res.lphi, 'm')}, "
                  f"{md(res.maintenance)} maintenance), placed most unfavourably:", ""]
        rows = [[str(c.loaded), str(c.track), _mm(c.value), fmt_number(c.at, "m"),
                 fmt_number(c.load_at, "m"), fmt_number(c.utilisation, "", 3),
                 _verdict(c.value, c.limit)] for c in res.static]
        lines += markdown_table(["loaded track", "twisted track", "twist", "window from",
                                 "LM71 axle group at", "utilisation", "verdict"], rows)
        lines.append("")
    else:
        lines += [f"Static twist under LM71: not computed ({md(res.static_note)}).", ""]
    together = env.attrs.get("other_trains_loading") == "together"
    alone = (f"every train of the run (the study's trains on track {res.loaded_track} and "
             "train.other_trains, interaction trains in one run)" if together
             else f"the study's trains on track {res.loaded_track}")
    for dyn, what in ((res.dynamic, alone),
                      (res.dynamic_all, "every train of a run loaded (train.other_trains)")):
        if not dyn or (together and dyn is res.dynamic_all):  # the same values again
            continue
        lines += [f"**Dynamic: {what}**, largest |twist| over the speeds "
                  "(whole-deck grid of window starts and the output points):", ""]
        note = dynamic_twist_note(env)
        rows = [[str(k), _mm(v), md(t), fmt_number(s, "km/h"), fmt_number(x, "m"),
                 fmt_number(v / res.limit, "", 3),
                 _verdict(v, res.limit) + (f" ({note})" if note and np.isfinite(v) else "")]
                for k, v, t, s, x in dyn]
        lines += markdown_table(["track", "twist", "train", "speed", "window from",
                                 "utilisation", "verdict"], rows)
        lines.append("")
    where = ("the whole-deck grid along the track line and the output points"
             if "max_track_acceleration_whole_deck" in env else "the output points")
    lines += [f"**Peak deck acceleration along each track** (on {where}, modes "
              f"up to the EN 1990 A2 cut-off; limit {fmt_number(res.acceleration_limit)} "
              "m/s²; the deck-acceleration check above takes the loaded track):", ""]
    rows = [[str(k) if names is None else f"{k} ({md(names[i])})",
             fmt_number(ecc[i] if i < ecc.size else np.nan, "m"),
             fmt_number(a, "m/s²"), md(t), fmt_number(s, "km/h"), fmt_number(x, "m"),
             _verdict(a, res.acceleration_limit)]
            for i, (k, a, t, s, x) in enumerate(res.acceleration)]
    lines += markdown_table(["track", "y", "peak acceleration", "train", "speed", "at x",
                             "verdict"], rows)
    if res.acceleration_all:
        lines += ["", "With every train of a run loaded (`train.other_trains`), for "
                  "information: the deck-acceleration check of the summary loads the "
                  "train's own track; whether the trains meeting on the deck must meet the "
                  "limit too is the design basis' to say:", ""]
        rows = [[str(k) if names is None else f"{k} ({md(names[i])})",
                 fmt_number(ecc[i] if i < ecc.size else np.nan, "m"),
                 fmt_number(a, "m/s²"), md(t), fmt_number(s, "km/h"), fmt_number(x, "m"),
                 fmt_number(a / res.acceleration_limit, "", 3)]
                for i, (k, a, t, s, x) in enumerate(res.acceleration_all)]
        lines += markdown_table(["track", "y", "peak acceleration", "train", "speed",
                                 "at x", "ratio to the limit"], rows)
    if names is None:
        lines += ["", "Load effects (bending moment, shear, reactions) of the beam deck do "
                  "not depend on where across the deck a load stands: the section *Load "
                  "effects* gives them with the train on its track and, for a study with "
                  "trains on other tracks (`train.other_trains`), with every train loaded."]
    else:
        lines += ["", "Load effects (bending moment, shear force) are those of the loaded "
                  "track's train."]
    return Section.from_markdown(lines)
