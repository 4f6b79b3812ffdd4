"""The "Load effects" section of the report: envelopes of M, V, R and theta (dynamic,
static crawl, LM71 x Phi x alpha), phi'_dyn per effect and train, the EN 1991-2
6.4.6.5(3) verdict with its margin, the deck-end rotation check and a figure of the M and
V envelopes along the deck.

:func:`load_effects_section` is self-contained: it returns a document section (text,
tables, figure) for the Markdown and HTML writers, the same as Markdown lines, the figure
file and the tables as :class:`pandas.DataFrame` (SI units) for CSV/XLSX.  Files without
load-effect variables (older files, bridges that cannot give them) get a short section
that says why.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from vsi_numba.analysis.checks.load_effects import (
    EFFECTS,
    LoadEffectChecks,
    load_effect_checks,
)
from vsi_numba.analysis.report.document import (
    Figure,
    Markdown,
    Section,
    Table,
    section_markdown,
)
from vsi_numba.analysis.report.numbers import fixed_against
from vsi_numba.analysis.report.safe import natural_key
from vsi_numba.en1990 import END_ROTATION_CLAUSE
from vsi_numba.en1991 import ALPHA_CLAUSE, LM71_CLAUSE, PHI_CLAUSE
from vsi_numba.io.schema import ALL_TRACKS_SUFFIX

#: Title of the section.
TITLE = "Load effects"
#: File name of the figure of the M and V envelopes.
FIGURE_NAME = "load_effects.png"
#: Display units per SI unit: (factor, label).
_UNITS = {"N m": (1e-3, "kN m"), "N": (1e-3, "kN"), "m": (1e3, "mm"), "rad": (1e3, "mrad")}


class LoadEffectsSection(NamedTuple):
    """``section`` (a :class:`~vsi_numba.analysis.report.document.Section` of text,
    tables and the figure, for the Markdown and HTML writers), ``lines`` (the same as
    Markdown), ``figures`` ((file name, caption) pairs; the PNG is written into
    ``outdir`` when one is given) and ``tables`` (name -> DataFrame, SI units; empty when
    the checks could not be made)."""

    section: Section
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


def _where(effect: str, x: float) -> str:
    return f"support x = {x:g} m" if EFFECTS[effect][2] == "support" else f"x = {x:g} m"


def load_effects_section(ds, outdir: Path | str | None = None, *, checks=None,
                         alpha: float | None = None, maintenance: str | None = None,
                         length: float | None = None, save_figure: bool = True,
                         checks_all=None) -> LoadEffectsSection:
    """Build the "Load effects" section of a results file.

    Parameters
    ----------
    ds : xarray.Dataset
        Results (see :func:`~vsi_numba.analysis.checks.load_effects.load_effect_checks`;
        the envelopes are enough).
    outdir : path, optional
        Report directory: a stale figure of an earlier report is removed, and with
        ``save_figure`` the figure is written there.
    checks : LoadEffectChecks or str, optional
        Precomputed checks (default: computed here with ``alpha``, ``maintenance``,
        ``length``).
    save_figure : bool
        Write the PNG into ``outdir`` (the report's Markdown writer writes it itself).
    checks_all : LoadEffectChecks or str, optional
        The checks with every train loaded (``all_tracks=True``), for a study with
        trains on other tracks (default: computed here when the file has them).

    Returns
    -------
    LoadEffectsSection
    """
    if checks is None:
        checks = load_effect_checks(ds, alpha=alpha, maintenance=maintenance, length=length)
    if outdir is not None:
        Path(outdir).mkdir(parents=True, exist_ok=True)
        (Path(outdir) / FIGURE_NAME).unlink(missing_ok=True)  # no stale figure stays
    blocks: list = []
    tables: dict = {}
    figure = None
    if isinstance(checks, str):
        blocks.append(f"Not available: {checks}.")
    else:
        blocks, tables, figure = _blocks(checks)
        torque, torque_table = _torque_blocks(ds)
        blocks += torque
        if torque_table is not None:
            tables["torsional_moment_envelopes"] = torque_table
        if any(str(v).endswith(ALL_TRACKS_SUFFIX) for v in ds.variables):
            several = checks_all if checks_all is not None else load_effect_checks(
                ds, alpha=alpha, maintenance=maintenance, length=length, all_tracks=True)
            blocks += _several_blocks(ds, several)
            if not isinstance(several, str):
                tables["load_effect_verdict_all_tracks"] = several.verdict
                tables["load_effect_envelopes_all_tracks"] = several.envelopes
    section = Section(TITLE, blocks)
    figs: list = []
    lines = section_markdown(section, figs, {"figure": 0, "table": 0})
    written = []
    if figure is not None:
        if outdir is not None and save_figure:
            (Path(outdir) / FIGURE_NAME).write_bytes(figure.png())
        written.append((FIGURE_NAME, figure.caption))
    return LoadEffectsSection(section, lines, written, tables)


def _limit(c: LoadEffectChecks, key: str) -> float:
    """Entry ``key`` of the code profile the checks used (the recommended value when the
    checks do not say)."""
    from vsi_numba.code_profile import default_profile

    return (c.factors.get("profile") or default_profile())[key]


def _blocks(c: LoadEffectChecks):
    fa = c.factors
    ph = fa["phi_name"]
    blocks: list = [
        f"EN 1991-2 6.4.6.5(3): per effect, the design value is the more unfavourable "
        f"of (1 + φ'dyn + φ''/2) × (static effect of the HSLM / real train) and "
        f"{ph} × α × LM71. LM71 ({LM71_CLAUSE}): 4 × {_limit(c, 'lm71_axle_load') / 1e3:g} "
        f"kN at {_limit(c, 'lm71_axle_spacing'):g} m and {_limit(c, 'lm71_udl') / 1e3:g} kN/m "
        f"outside the {4 * _limit(c, 'lm71_axle_spacing'):g} m axle zone where unfavourable, "
        "placed most "
        f"unfavourably; α = {fa['alpha']:g} ({ALPHA_CLAUSE}, `study.classification_factor`); "
        f"{ph} = {fa['phi']:.4g} ({PHI_CLAUSE}, track maintenance "
        f"'{fa['maintenance']}', `study.track_maintenance`) with L_Φ = {fa['length']:g} m "
        f"({fa['length_rule']}); {fa['phi2_note']}, max φ'' = {fa['phi2_max']:.3g}. "
        "Static effects of the trains: their axle loads crawling over the deck (exact "
        "influence lines, every placement). Magnitudes |E| (both signs) are compared."]
    blocks += [f"> ⚠ {n}." for n in fa.get("notes", [])]
    tables = {"load_effect_envelopes": c.envelopes, "phi_dyn": c.phi_dyn,
              "phi_dyn_speeds": c.phi_dyn_speeds, "load_effect_verdict": c.verdict,
              "end_rotation": c.rotation}

    rows = [{"Effect": EFFECTS[r.effect][4], "Governing location": _where(r.effect, r.location),
             "(1 + φ'dyn + φ''/2) × train": _v(r.real_design, r.units),
             "Train, speed": f"{r.train} at {r.speed_kmh:g} km/h",
             f"{ph} × α × LM71": _v(r.lm71_design, r.units),
             "Ratio": fixed_against(r.ratio, 1.0), "Governs": Markdown(f"**{r.governs}**"),
             "Margin": fixed_against(r.margin, 1.0)}
            for r in c.verdict.itertuples(index=False)]
    blocks += ["### Verdict (EN 1991-2 6.4.6.5(3))",
               Table(pd.DataFrame(rows), "Load effects: EN 1991-2 6.4.6.5(3) verdict"),
               "Ratio = (1 + φ'dyn + φ''/2) × train / (Φ × α × LM71), its largest value over "
               "the locations; margin = how many times the governing model exceeds the "
               "other (≥ 1)."
               + (f" The trains' effects are every train of the run (interaction trains on "
                  f"the other tracks in the same run), against LM71 on track "
                  f"{fa['loaded_tracks']} alone: on the safe side; the verdict with every "
                  "track loaded is under *Several tracks loaded*."
                  if fa.get("together") else "")]

    rows = [{"Effect": EFFECTS[r.effect][4], "Location": _where(r.effect, r.location),
             "Dynamic max |E|": _v(r.dynamic, r.units),
             "Train, speed": f"{r.train} at {r.speed_kmh:g} km/h",
             "Static crawl max |E|": _v(r.static, r.units), "LM71 (static)": _v(r.lm71, r.units),
             f"{ph} × α × LM71": _v(r.lm71_design, r.units),
             "Ratio": fixed_against(r.ratio, 1.0)}
            for r in c.envelopes.itertuples(index=False)]
    blocks += ["### Envelopes",
               Table(pd.DataFrame(rows), "Load-effect envelopes: dynamic, static crawl, LM71"),
               "Dynamic: max over speeds and trains (deterministic track); static crawl: max "
               "over the trains; deflection: downward only."]

    if not c.phi_dyn.empty:
        trains = sorted(c.phi_dyn["train"].unique(), key=natural_key)
        piv = c.phi_dyn.pivot(index="train", columns="effect", values="phi_dyn").reindex(trains)
        spd = c.phi_dyn.pivot(index="train", columns="effect", values="speed_kmh").reindex(
            trains)
        eff = [e for e in EFFECTS if e in piv.columns]
        rows = [{"Train": t, **{EFFECTS[e][4]: f"{piv.loc[t, e]:.3f} ({spd.loc[t, e]:g} km/h)"
                                for e in eff}} for t in piv.index]
        blocks += ["### Dynamic increment φ'dyn per effect",
                   Table(pd.DataFrame(rows), "φ'dyn per effect and train (max over speeds, "
                                             "at the speed given)"),
                   "φ'dyn = max over locations of max|E_dyn| / max over locations of "
                   "max|E_static crawl| − 1 for the bending moment, shear force, reactions "
                   "and rotations (mode-accelerated: the static part of the dynamic effect "
                   "is the exact one, compared with the exact static crawl)."]
    if c.factors.get("deflection_phi"):
        blocks.append(c.factors["deflection_phi"])

    blocks.append(f"### Deck-end rotation ({END_ROTATION_CLAUSE})")
    if c.rotation.empty:
        blocks.append("Not available: the results hold no end rotations.")
    else:
        rows = [{"Deck end": f"x = {r.support:g} m",
                 f"θ under {ph} × α × LM71": _v(r.theta_lm71_design, "rad"),
                 "θ (1 + φ'dyn + φ''/2) × train": _v(r.theta_real_design, "rad"),
                 "Design θ (the larger)": _v(r.theta_design, "rad"),
                 "Limit (ballasted, deck to abutment)": _v(r.limit, "rad"),
                 "Utilisation": fixed_against(r.utilisation, 1.0),
                 "Result": Markdown("**FAIL**") if r.result == "FAIL" else r.result}
                for r in c.rotation.itertuples(index=False)]
        blocks += [Table(pd.DataFrame(rows), "Deck-end rotation"),
                   f"Limits ([code profile](#code-profile)): "
                   f"{_v(_limit(c, 'end_rotation_limit_abutment'), 'rad')} between a "
                   f"deck end and the abutment, "
                   f"{_v(_limit(c, 'end_rotation_limit_decks'), 'rad')} for "
                   "θ₁ + θ₂ between two consecutive decks (not checked: one deck)."]
    figure = None
    if c.deck:
        fig = _figure(c)
        if fig is not None:
            figure = Figure(fig, FIGURE_NAME,
                            f"Bending moment and shear force envelopes along the deck: "
                            f"dynamic max/min of the governing train against {ph} × α × "
                            f"LM71 (α = {fa['alpha']:g}, {ph} = {fa['phi']:.3g}).")
            blocks.append(figure)
    return blocks, tables, figure


def _several_blocks(ds, c) -> list:
    """The sub-section of the load effects with every train of a run loaded
    (``train.other_trains``)."""
    import json

    blocks: list = ["### Several tracks loaded"]
    if isinstance(c, str):
        return blocks + [f"Not available: {c}."]
    fa = c.factors
    ph = fa["phi_name"]
    others = json.loads(ds.attrs.get("other_trains", "[]"))
    ways = {"opposite": "entering at the far end (trains meeting)",
            "same": "same direction"}
    def own(o):
        tr = o.get("train")
        name = ("the run's train" if tr is None else str(tr) if isinstance(tr, str)
                else str(tr.get("name") or Path(str(tr.get("file", "axles"))).stem))
        speed = (f"at {o['speed_kmh']:g} km/h" if "speed_kmh" in o else
                 f"at {o['speed_factor']:g} × the run's speed" if "speed_factor" in o
                 else "at the run's speed")
        return f"{name} {speed}"

    where = "; ".join(f"track {o['track']}: {own(o)}, {ways[o['direction']]}"
                      + (f", {o['offset']:g} m behind" if o["offset"] else "")
                      for o in others)
    blocks.append(
        f"Every run also had trains on the other tracks ({where}); tracks loaded: "
        f"{fa['loaded_tracks']}. The envelopes of the trains together come from one "
        + ("run (interaction trains: every wheel of every train and the deck solved "
           "together, each axle load at its own track's eccentricity)"
           if ds.attrs.get("other_trains_loading") == "together" else
           "time history (their runs superposed: exact for moving forces on the linear "
           "deck)")
        + f". They are compared with {ph} × α × LM71 on each loaded track (× "
        f"{_limit(c, 'lm71_factor_several_tracks'):g}, "
        f"{fa['profile'].clause('lm71_factor_several_tracks')}); the φ''/2 term takes the "
        "trains' static envelopes added (an upper bound). A beam deck's bending does not "
        "depend on where across the deck a load stands, so LM71 on n tracks is n times "
        "LM71 on one.")
    rows = [{"Effect": EFFECTS[r.effect][4], "Governing location": _where(r.effect, r.location),
             "(1 + φ'dyn + φ''/2) × trains": _v(r.real_design, r.units),
             "Train, speed": f"{r.train} at {r.speed_kmh:g} km/h",
             f"{ph} × α × LM71 (tracks {fa['loaded_tracks']})": _v(r.lm71_design, r.units),
             "Ratio": fixed_against(r.ratio, 1.0), "Governs": Markdown(f"**{r.governs}**"),
             "Margin": fixed_against(r.margin, 1.0)}
            for r in c.verdict.itertuples(index=False)]
    blocks.append(Table(pd.DataFrame(rows), "Load effects with every train loaded: EN "
                                            "1991-2 6.4.6.5(3) verdict"))
    if not c.rotation.empty:
        rows = [{"Deck end": f"x = {r.support:g} m",
                 "Design θ (the larger)": _v(r.theta_design, "rad"),
                 "Limit": _v(r.limit, "rad"),
                 "Utilisation": fixed_against(r.utilisation, 1.0),
                 "Result": Markdown("**FAIL**") if r.result == "FAIL" else r.result}
                for r in c.rotation.itertuples(index=False)]
        blocks.append(Table(pd.DataFrame(rows), "Deck-end rotation with every train "
                                                "loaded"))
    return blocks


#: The torsional moment envelopes of a deck in space: (suffix, what is loaded, sections).
_TORQUE_ROWS = (("", "the run's train", "output points"),
                ("_whole_deck", "the run's train", "whole-deck grid"),
                (ALL_TRACKS_SUFFIX, "every train", "output points"),
                ("_whole_deck" + ALL_TRACKS_SUFFIX, "every train", "whole-deck grid"))


def torque_envelopes(ds) -> pd.DataFrame:
    """The largest and smallest St-Venant torsional moment of the file (N m), per loading
    and set of sections, with where, the train and the speed of each; empty without
    them."""
    rows = []
    together = ds.attrs.get("other_trains_loading") == "together"
    for sfx, loaded, sections in _TORQUE_ROWS:
        if together:  # every variable holds every train; the twins repeat the values
            if sfx.endswith(ALL_TRACKS_SUFFIX):
                continue
            loaded = "every train of the run"
        hi, lo = ds.get(f"max_torsional_moment{sfx}"), ds.get(f"min_torsional_moment{sfx}")
        if hi is None or lo is None or not np.isfinite(hi.values).any():
            continue
        dim = "deck_x" if "whole_deck" in sfx else "point"
        row = {"loaded": loaded, "sections": sections}
        for ext, da, pick in (("max", hi, np.nanargmax), ("min", lo, np.nanargmin)):
            i = np.unravel_index(pick(da.values), da.shape)
            at = dict(zip(da.dims, i, strict=True))
            row[f"{ext}_torsional_moment"] = float(da.values[i])
            row[f"{ext}_x"] = float(ds[dim].values[at[dim]])
            row[f"{ext}_train"] = str(ds["train"].values[at["train"]]) if "train" in at \
                else ""
            row[f"{ext}_speed_kmh"] = (float(ds["speed_kmh"].values[at["speed"]])
                                       if "speed" in at else np.nan)
        rows.append(row)
    return pd.DataFrame(rows)


def _torque_blocks(ds) -> tuple[list, pd.DataFrame | None]:
    """The torsional moment sub-section (a deck in space with torsion), or nothing."""
    env = torque_envelopes(ds)
    if env.empty:
        return [], None
    attrs = ds["max_torsional_moment"].attrs if "max_torsional_moment" in ds else {}
    sign = attrs.get("sign_convention", "T = GJ dθ/dx")
    blocks: list = ["### Torsional moment", (
        f"St-Venant torsional moment T = GJ dθ/dx of the deck (N m; {sign}). "
        "Dynamic envelopes of the "
        "mode-acceleration method (static torque of the eccentric loads plus the "
        "torsional modes' correction); no EN limit applies: the values are for the "
        "design of the section and its bearings.")]
    rows = [{"Loading": r.loaded, "Sections": r.sections,
             "Largest T": _v(r.max_torsional_moment, "N m"),
             "Where (largest)": f"x = {r.max_x:g} m", "Train, speed (largest)":
             f"{r.max_train} at {r.max_speed_kmh:g} km/h",
             "Smallest T": _v(r.min_torsional_moment, "N m"),
             "Where (smallest)": f"x = {r.min_x:g} m", "Train, speed (smallest)":
             f"{r.min_train} at {r.min_speed_kmh:g} km/h"}
            for r in env.itertuples(index=False)]
    blocks.append(Table(pd.DataFrame(rows), "Torsional moment envelopes"))
    return blocks, env


def _figure(c: LoadEffectChecks):
    from matplotlib.figure import Figure as MplFigure

    effects = [e for e in ("moment", "shear") if e in c.deck]
    if not effects:
        return None
    fig = MplFigure(figsize=(7.5, 3.0 * len(effects)), layout="constrained")
    x = c.deck["x"]
    for i, e in enumerate(effects, 1):
        ax = fig.add_subplot(len(effects), 1, i)
        d = c.deck[e]
        f, label = _UNITS["N m" if e == "moment" else "N"]
        ax.plot(x, d["dyn_max"] * f, color="C0",
                label=f"dynamic, {d['train']} (max/min)")
        ax.plot(x, d["dyn_min"] * f, color="C0")
        ax.plot(x, d["lm71_max"] * f, "--", color="C3",
                label=f"{c.factors['phi_name']} × α × LM71")
        ax.plot(x, d["lm71_min"] * f, "--", color="C3")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"{'M' if e == 'moment' else 'V'} ({label})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    ax.set_xlabel("x along the deck (m)")
    return fig


#: How the report takes phi'_dyn of the deflection (said once in the section).
DEFLECTION_PHI_NOTE = (
    "Deflection: the deck displacement of the results is modal (the modes kept, not "
    "mode-accelerated), so its φ'dyn is the one of the summary - the dynamic and the "
    "static displacement of the same modes (`max_deck_displacement` / "
    "`max_static_deck_displacement`), like with like - and (1 + φ'dyn + φ''/2) multiplies "
    "the exact static crawl of the train at each output point. The report uses this one "
    "φ'dyn for the deflection everywhere (summary, figures, this section).")


def consistent_deflection(c, ds, dyn, step: float = 0.05):
    """The load-effect checks ``c`` with the deflection's phi'_dyn taken from the deck
    check ``dyn`` (:func:`vsi_numba.analysis.checks.dynamic_amplification`: modal dynamic
    over modal static displacement, per speed, train and point), so that the report
    shows one phi'_dyn of the deflection.

    The design deflection of the real trains becomes, per output point, the max over
    speeds and trains of (1 + phi'_dyn + phi''/2) x the exact static crawl (influence
    line); the verdict and the phi'_dyn tables follow. ``c`` is returned unchanged when
    it is a reason (str), has no deflection or ``dyn`` is not a check result.
    """
    import xarray as xr

    from vsi_numba.analysis.checks.load_effects import (
        LM71_GOVERNS,
        REAL_GOVERNS,
        crawl_envelope,
        static_deck_of,
    )
    from vsi_numba.analysis.dataset import DETERMINISTIC
    from vsi_numba.model.influence import influence

    if isinstance(c, str) or not isinstance(dyn, xr.Dataset) or "phi_dyn" not in dyn:
        return c
    env = c.envelopes.copy()
    rows = np.flatnonzero(env["effect"].to_numpy() == "deflection")
    static = static_deck_of(ds)
    if rows.size == 0 or isinstance(static, str):
        return c
    at = env["location"].to_numpy()[rows].astype(float)
    trains = [str(t) for t in dyn["train"].values]
    kmh = np.asarray(ds["speed_kmh"].sel(speed=dyn["speed"]).values, float)
    wp = ds["wheel_position"].sel(train=dyn["train"]).values
    wl = ds["static_wheel_load"].sel(train=dyn["train"]).values
    bp = np.concatenate([static.supports, at])
    stat = np.full((len(trains), at.size), np.nan)   # exact static crawl (train, point)
    for t in range(len(trains)):
        ok = np.isfinite(wp[t]) & np.isfinite(wl[t]) & (wl[t] > 0)
        if ok.any():
            stat[t] = crawl_envelope(lambda x: influence(static, "deflection", at, x),
                                     wp[t][ok] - wp[t][ok].min(), wl[t][ok], bp,
                                     (0.0, static.length), step=step, n_at=at.size).max
    phi = dyn["phi_dyn"].sel(point=at, method="nearest").transpose("speed", "train", "point")
    det = bool((np.asarray(ds["irregularity"].values) == DETERMINISTIC).any())
    phi2 = (np.nan_to_num(np.asarray(dyn["phi2"].values, float)) if det
            else np.zeros(dyn.sizes["speed"]))   # as the load-effect checks take phi''
    real = (1.0 + np.asarray(phi.values, float) + 0.5 * phi2[:, None, None]) * stat[None]
    for j, r in enumerate(rows):
        rj = real[:, :, j]
        if np.all(np.isnan(rj)):
            continue
        k_s, k_t = np.unravel_index(np.nanargmax(rj), rj.shape)
        lm = float(env.at[env.index[r], "lm71_design"])
        env.at[env.index[r], "real_design"] = float(rj[k_s, k_t])
        env.at[env.index[r], "real_train"] = trains[k_t]
        env.at[env.index[r], "real_speed_kmh"] = float(kmh[k_s])
        env.at[env.index[r], "ratio"] = float(rj[k_s, k_t]) / lm if lm > 0 else np.nan
    verdict = c.verdict.copy()
    grp = env.iloc[rows]
    if grp["ratio"].notna().any() and not verdict.empty:
        g = grp.loc[grp["ratio"].idxmax()]
        real_gov = g["ratio"] > 1
        new = {"effect": "deflection", "location": g["location"],
               "real_design": g["real_design"], "train": g["real_train"],
               "speed_kmh": g["real_speed_kmh"], "lm71_design": g["lm71_design"],
               "ratio": g["ratio"], "governs": REAL_GOVERNS if real_gov else LM71_GOVERNS,
               "margin": g["ratio"] if real_gov else 1.0 / g["ratio"], "units": g["units"]}
        hit = np.flatnonzero(verdict["effect"].to_numpy() == "deflection")
        for key, value in new.items():
            verdict.at[verdict.index[hit[0]] if hit.size else len(verdict), key] = value
    value = dyn["value"].transpose("speed", "train").values   # (speed, train)
    phi_rows, speed_rows = [], []
    for t, tr in enumerate(trains):
        col = np.asarray(value[:, t], float)
        if np.all(np.isnan(col)):
            continue
        i = int(np.nanargmax(col))
        phi_rows.append({"effect": "deflection", "train": tr, "phi_dyn": float(col[i]),
                         "speed_kmh": float(kmh[i])})
        speed_rows += [{"effect": "deflection", "train": tr, "speed_kmh": float(v),
                        "phi_dyn": float(p)} for v, p in zip(kmh, col, strict=True)]

    def replaced(frame, new_rows):
        if frame.empty:
            return pd.DataFrame(new_rows)
        keep = frame[frame["effect"] != "deflection"]
        return pd.concat([pd.DataFrame(new_rows), keep], ignore_index=True)

    factors = {**c.factors, "deflection_phi": DEFLECTION_PHI_NOTE}
    return c._replace(envelopes=env, verdict=verdict,
                      phi_dyn=replaced(c.phi_dyn, phi_rows),
                      phi_dyn_speeds=replaced(c.phi_dyn_speeds, speed_rows),
                      factors=factors)


def summary_with_torque(table: pd.DataFrame, ds) -> pd.DataFrame:
    """The summary table with one row per loading of the largest |torsional moment| of
    the deck (:func:`torque_envelopes`): reported, no EN limit; ``table`` itself without
    it."""
    env = torque_envelopes(ds)
    rows = []
    for r in env.itertuples(index=False):
        up = abs(r.max_torsional_moment) >= abs(r.min_torsional_moment)
        ext = "max" if up else "min"
        rows.append({
            "check": f"Torsional moment |T| ({r.loaded}, {r.sections})",
            "value": abs(float(getattr(r, f"{ext}_torsional_moment"))), "units": "N m",
            "limit": np.nan, "margin": np.nan, "utilisation": np.nan,
            "result": "reported (no EN limit)",
            "governing_train": str(getattr(r, f"{ext}_train")),
            "governing_speed_kmh": float(getattr(r, f"{ext}_speed_kmh")),
            "where": f"x = {getattr(r, f'{ext}_x'):g} m", "clause": "–"})
    if not rows:
        return table
    return pd.concat([table, pd.DataFrame(rows, columns=table.columns)], ignore_index=True)


def summary_with_load_effects(table: pd.DataFrame, c, c_all=None) -> pd.DataFrame:
    """The summary table (:func:`vsi_numba.analysis.checks.summary_table`) with the
    EN 1991-2 6.4.6.5(3) verdict (one row per effect: the ratio of the real trains'
    design effect to Φ × α × LM71, and which governs) and the deck-end rotation check
    (the worse deck end) appended; ``table`` itself when ``c`` is a reason (str).
    ``c_all``: the checks with every train loaded (``train.other_trains``), whose
    verdicts follow, marked with the tracks loaded."""
    if isinstance(c, str):
        return table
    rows = []
    ph = c.factors["phi_name"]
    alone = (f", every train of the run against LM71 on track {c.factors['loaded_tracks']} "
             "alone (on the safe side)" if c.factors.get("together") else "")
    verdicts = [(r, alone) for r in c.verdict.itertuples(index=False)]
    if c_all is not None and not isinstance(c_all, str):
        tracks = c_all.factors["loaded_tracks"]
        verdicts += [(r, f", tracks {tracks} loaded") for r in
                     c_all.verdict.itertuples(index=False)]
    for r, loaded in verdicts:
        rows.append({
            "check": f"6.4.6.5(3) {EFFECTS[r.effect][4]}{loaded}: (1 + φ'dyn + φ''/2) × "
                     f"train / ({ph} × α × LM71)",
            # the verdict hinges on the ratio 1 (which model governs)
            "value": float(r.ratio), "units": "1", "limit": 1.0, "margin": np.nan,
            "utilisation": np.nan, "result": f"{r.governs} govern"
                                             + ("" if r.governs.endswith("s") else "s"),
            "governing_train": str(r.train), "governing_speed_kmh": float(r.speed_kmh),
            "where": _where(r.effect, r.location), "clause": "EN 1991-2 6.4.6.5(3)"})
    if not c.rotation.empty:
        w = c.rotation.loc[c.rotation["utilisation"].idxmax()]
        e = c.envelopes[(c.envelopes["effect"] == "rotation")
                        & np.isclose(c.envelopes["location"], w["support"])]
        real = bool(w["theta_real_design"] >= w["theta_lm71_design"])
        rows.append({
            "check": f"Deck-end rotation θ at x = {w['support']:g} m (design value)",
            "value": float(w["theta_design"]), "units": "rad", "limit": float(w["limit"]),
            "margin": float(w["limit"] - w["theta_design"]),
            "utilisation": float(w["utilisation"]), "result": str(w["result"]),
            "governing_train": (str(e["real_train"].iloc[0]) if real and not e.empty
                                else f"{ph} × α × LM71"),
            "governing_speed_kmh": (float(e["real_speed_kmh"].iloc[0])
                                    if real and not e.empty else np.nan),
            "where": f"deck end x = {w['support']:g} m",
            "clause": c.factors.get("rotation_clause", END_ROTATION_CLAUSE)})
    if not rows:
        return table
    return pd.concat([table, pd.DataFrame(rows, columns=table.columns)], ignore_index=True)
