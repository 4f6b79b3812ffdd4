"""The "Load effects" section of the report: envelopes of M, V, R and theta (dynamic,
static crawl, LM71 x Phi x alpha), phi'_dyn per effect and train, the EN 1991-2
6.4.6.5(3) verdict with its margin, the deck-end rotation check and a figure of the M and
V envelopes along the deck.

:func:`load_effects_section` is self-contained: it returns the Markdown lines, the figure
files it wrote and the tables as :class:`pandas.DataFrame` (SI units), so any output
format can use it.  Files without load-effect variables (older files, bridges that cannot
give them) get a short section that says why.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from vsi_numba.analysis.checks.load_effects import (
    EFFECTS,
    LoadEffectChecks,
    load_effect_checks,
)
from vsi_numba.en1990 import (
    END_ROTATION_CLAUSE,
    END_ROTATION_LIMIT_ABUTMENT,
    END_ROTATION_LIMIT_DECKS,
)
from vsi_numba.en1991 import ALPHA_CLAUSE, LM71_CLAUSE, PHI_CLAUSE

#: File name of the figure of the M and V envelopes.
FIGURE_NAME = "load_effects.png"
#: Display units per SI unit: (factor, label).
_UNITS = {"N m": (1e-3, "kN m"), "N": (1e-3, "kN"), "m": (1e3, "mm"), "rad": (1e3, "mrad")}


class LoadEffectsSection(NamedTuple):
    """``lines`` (Markdown), ``figures`` ((file name, caption) pairs written into the
    report directory) and ``tables`` (name -> DataFrame, SI units; empty when the checks
    could not be made)."""

    lines: list
    figures: list
    tables: dict


def _v(value, units) -> str:
    f, label = _UNITS.get(units, (1.0, units))
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    return "–" if not np.isfinite(x) else f"{x * f:.4g} {label}"


def _md(header, rows) -> list[str]:
    header = [str(h).replace("|", "\\|") for h in header]
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return out + ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |"
                  for r in rows]


def _where(effect: str, x: float) -> str:
    return f"support x = {x:g} m" if EFFECTS[effect][2] == "support" else f"x = {x:g} m"


def load_effects_section(ds, outdir: Path | str | None = None, *, checks=None,
                         alpha: float | None = None, maintenance: str | None = None,
                         length: float | None = None, heading: str = "##"
                         ) -> LoadEffectsSection:
    """Build the "Load effects" section of a results file.

    Parameters
    ----------
    ds : xarray.Dataset
        Results (see :func:`~vsi_numba.analysis.checks.load_effects.load_effect_checks`).
    outdir : path, optional
        Directory of the figure; None: no figure.
    checks : LoadEffectChecks or str, optional
        Precomputed checks (default: computed here with ``alpha``, ``maintenance``,
        ``length``).
    heading : str
        Markdown heading level of the section.

    Returns
    -------
    LoadEffectsSection
    """
    if checks is None:
        checks = load_effect_checks(ds, alpha=alpha, maintenance=maintenance, length=length)
    lines = [f"{heading} Load effects", ""]
    if outdir is not None:
        Path(outdir).mkdir(parents=True, exist_ok=True)
        (Path(outdir) / FIGURE_NAME).unlink(missing_ok=True)  # no stale figure stays
    if isinstance(checks, str):
        lines += [f"Not available: {checks}.", ""]
        return LoadEffectsSection(lines, [], {})
    c: LoadEffectChecks = checks
    fa = c.factors
    lines += [
        f"EN 1991-2 6.4.6.5(3) [R]: per effect, the design value is the more unfavourable "
        f"of (1 + φ'dyn + φ''/2) × (static effect of the HSLM / real train) and "
        f"{fa['phi_name']} × α × LM71. LM71 ({LM71_CLAUSE}): 4 × 250 kN at 1.6 m and "
        f"80 kN/m outside the 6.4 m axle zone where unfavourable, placed most "
        f"unfavourably; α = {fa['alpha']:g} ({ALPHA_CLAUSE}, `study.classification_factor`); "
        f"{fa['phi_name']} = {fa['phi']:.4g} ({PHI_CLAUSE}, track maintenance "
        f"'{fa['maintenance']}', `study.track_maintenance`) with L_Φ = {fa['length']:g} m "
        f"({fa['length_rule']}); {fa['phi2_note']}, max φ'' = {fa['phi2_max']:.3g}. "
        "Static effects of the trains: their axle loads crawling over the deck (exact "
        "influence lines, every placement). Magnitudes |E| (both signs) are compared.", ""]
    tables = {"load_effect_envelopes": c.envelopes, "phi_dyn": c.phi_dyn,
              "phi_dyn_speeds": c.phi_dyn_speeds,
              "load_effect_verdict": c.verdict, "end_rotation": c.rotation}

    lines += [f"{heading}# Verdict (EN 1991-2 6.4.6.5(3) [R])", ""]
    rows = []
    for r in c.verdict.itertuples(index=False):
        rows.append([EFFECTS[r.effect][4], _where(r.effect, r.location),
                     _v(r.real_design, r.units), f"{r.train} at {r.speed_kmh:g} km/h",
                     _v(r.lm71_design, r.units), f"{r.ratio:.3f}", f"**{r.governs}**",
                     f"{r.margin:.3f}"])
    lines += _md(["effect", "governing location", "(1 + φ'dyn + φ''/2) × train",
                  "train, speed", f"{fa['phi_name']} × α × LM71", "ratio", "governs",
                  "margin"], rows)
    lines += ["", "ratio = (1 + φ'dyn + φ''/2) × train / (Φ × α × LM71), its largest value "
              "over the locations; margin = how many times the governing model exceeds the "
              "other (≥ 1).", ""]

    lines += [f"{heading}# Envelopes", ""]
    rows = []
    for r in c.envelopes.itertuples(index=False):
        rows.append([EFFECTS[r.effect][4], _where(r.effect, r.location),
                     _v(r.dynamic, r.units), f"{r.train} at {r.speed_kmh:g} km/h",
                     _v(r.static, r.units), _v(r.lm71, r.units), _v(r.lm71_design, r.units),
                     f"{r.ratio:.3f}"])
    lines += _md(["effect", "location", "dynamic max|E|", "train, speed",
                  "static crawl max|E|", "LM71 (static)", f"{fa['phi_name']} × α × LM71",
                  "ratio"], rows)
    lines += ["", "Dynamic: max over speeds and trains (deterministic track); static crawl: "
              "max over the trains; deflection: downward only.", ""]

    lines += [f"{heading}# Dynamic increment φ'dyn per effect", ""]
    if not c.phi_dyn.empty:
        piv = c.phi_dyn.pivot(index="train", columns="effect", values="phi_dyn")
        spd = c.phi_dyn.pivot(index="train", columns="effect", values="speed_kmh")
        eff = [e for e in EFFECTS if e in piv.columns]
        rows = [[t] + [f"{piv.loc[t, e]:.3f} ({spd.loc[t, e]:g} km/h)" for e in eff]
                for t in piv.index]
        lines += _md(["train"] + [EFFECTS[e][4] for e in eff], rows)
        lines += ["", "φ'dyn = max over locations of max|E_dyn| / max over locations of "
                  "max|E_static crawl| − 1, its maximum over speeds (at the speed given).", ""]

    lines += [f"{heading}# Deck-end rotation ({END_ROTATION_CLAUSE})", ""]
    if c.rotation.empty:
        lines += ["Not available: the results hold no end rotations.", ""]
    else:
        rows = [[f"x = {r.support:g} m", _v(r.theta_lm71_design, "rad"),
                 _v(r.theta_real_design, "rad"), _v(r.theta_design, "rad"),
                 _v(r.limit, "rad"), f"{r.utilisation:.3f}",
                 "**FAIL**" if r.result == "FAIL" else r.result]
                for r in c.rotation.itertuples(index=False)]
        lines += _md(["deck end", f"θ under {fa['phi_name']} × α × LM71",
                      "θ (1 + φ'dyn + φ''/2) × train", "design θ (the larger)",
                      "limit (ballasted, deck to abutment)", "utilisation", "result"], rows)
        lines += ["", f"Limits recalled [R]: {_v(END_ROTATION_LIMIT_ABUTMENT, 'rad')} "
                  f"between a deck end and the abutment, {_v(END_ROTATION_LIMIT_DECKS, 'rad')}"
                  " for θ₁ + θ₂ between two consecutive decks (not checked: one deck).", ""]

    figures = []
    if outdir is not None and c.deck:
        fig = _figure(c)
        if fig is not None:
            from vsi_numba.analysis import plots

            plots.save(fig, Path(outdir) / FIGURE_NAME)
            caption = (f"Bending moment and shear force envelopes along the deck: dynamic "
                       f"max/min of the governing train against {fa['phi_name']} × α × LM71 "
                       f"(α = {fa['alpha']:g}, {fa['phi_name']} = {fa['phi']:.3g}).")
            figures.append((FIGURE_NAME, caption))
            lines += [f"![Load effects]({FIGURE_NAME})", "", f"*{caption}*", ""]
    return LoadEffectsSection(lines, figures, tables)


def _figure(c: LoadEffectChecks):
    from matplotlib.figure import Figure

    effects = [e for e in ("moment", "shear") if e in c.deck]
    if not effects:
        return None
    fig = Figure(figsize=(7.5, 3.0 * len(effects)))
    x = c.deck["x"]
    for i, e in enumerate(effects, 1):
        ax = fig.add_subplot(len(effects), 1, i)
        d = c.deck[e]
        f, label = _UNITS["N m" if e == "moment" else "N"]
        ax.plot(x, d["dyn_max"] * f, color="C0", label=f"dynamic, {d['train']} (max/min)")
        ax.plot(x, d["dyn_min"] * f, color="C0")
        ax.plot(x, d["lm71_max"] * f, "--", color="C3",
                label=f"{c.factors['phi_name']} × α × LM71")
        ax.plot(x, d["lm71_min"] * f, "--", color="C3")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"{'M' if e == 'moment' else 'V'} ({label})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax.set_xlabel("x along the deck (m)")
    fig.tight_layout()
    return fig
