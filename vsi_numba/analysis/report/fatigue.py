"""The report's fatigue section (results of a study with ``[fatigue]``,
:mod:`vsi_numba.study.fatigue`): Miner's damage per section and per train over the design
life, the damage-equivalent stress range against the lambda-method, the verdict per
section, the same for the headed stud shear connectors (``[[fatigue.studs]]``), the
summary rows, and the table over the variants of a parametric study."""

from __future__ import annotations

import numpy as np
import pandas as pd

from vsi_numba.analysis.report.document import Figure, Markdown, Section, Table
from vsi_numba.analysis.report.safe import md

#: Clauses cited by the section.
CLAUSES = ("EN 1991-2 6.4.6.6 (fatigue with dynamic analysis); EN 1993-1-9 7.1 and 8 "
           "(S-N curves, Miner); EN 1993-2 9.5.3 (lambda-method); EN 1991-2 Annex D "
           "(traffic) [R]")
#: Clauses of the stud check.
STUD_CLAUSES = ("EN 1994-1-1 6.8.3 (stud S-N curve); EN 1994-2 6.8.7.2(1) (damage "
                "equivalent check) [R]")


def has_fatigue(ds) -> bool:
    """True when the results hold the fatigue variables."""
    return "fatigue_damage" in ds.variables


def lambda_method(ds) -> dict:
    """The lambda-method of EN 1993-2 9.5.3 [R] at the fatigue sections: Delta sigma_71
    (the LM71 moment range, alpha = 1, static, divided by W), Phi_2 for the deck's L_Phi,
    lambda from the profile's lambda_1 and lambda_4, lambda_2 from the traffic's tonnage
    and lambda_3 from the design life.  NaN where the deck gives no static moments."""
    from vsi_numba.analysis.checks.common import profile_of
    from vsi_numba.analysis.checks.determinant import determinant_length
    from vsi_numba.analysis.checks.load_effects import lm71_envelope, static_deck_of
    from vsi_numba.en1991 import dynamic_factor, lm71
    from vsi_numba.model.fatigue import lambda_method as factors
    from vsi_numba.model.influence import LoadEffectError, influence

    xs = np.asarray(ds["fatigue_section"].values, float)
    w = np.asarray(ds["fatigue_section_modulus"].values, float)
    profile = profile_of(ds, None)
    years = float(ds.attrs.get("fatigue_design_life_years", 100.0))
    tonnes = float(ds.attrs.get("fatigue_tonnes_per_year", np.nan))
    nan = np.full(xs.size, np.nan)
    out = {"delta_sigma_71": nan, "equivalent": nan, "lambda": nan, "phi_2": np.nan,
           "length": np.nan, "text": ""}
    static = static_deck_of(ds)
    lphi = determinant_length(ds, None, profile)
    if isinstance(static, str) or not np.isfinite(lphi.value):
        return out
    try:
        env = lm71_envelope(lambda x: influence(static, "moment", xs, x),
                            np.concatenate([static.supports, xs]), (0.0, static.length),
                            n_at=xs.size, model=lm71(profile))
    except LoadEffectError:
        return out
    phi2 = dynamic_factor(lphi.value, "careful", profile)
    ds71 = (env.max - env.min) / w / 1e6
    rows = [factors(float(d), phi2, tonnes, years, profile) for d in ds71]
    r = rows[0]
    return {"delta_sigma_71": ds71, "equivalent": np.array([x.equivalent_range for x in rows]),
            "lambda": np.array([x.factor for x in rows]), "phi_2": phi2,
            "length": lphi.value,
            "text": (f"λ₁ = {r.lambda_1:.3g}, λ₂ = {r.lambda_2:.3g}, λ₃ = {r.lambda_3:.3g}, "
                     f"λ₄ = {r.lambda_4:.3g}, λ = {r.factor:.3g} ≤ {r.lambda_max:g}")}


def _rows(ds, lm=None) -> pd.DataFrame:
    lm = lambda_method(ds) if lm is None else lm
    d = np.asarray(ds["fatigue_damage"].values, float)
    cat = np.asarray(ds["fatigue_detail_category"].values, float)
    gff = np.asarray(ds["fatigue_gamma_Ff"].values, float)
    gmf = np.asarray(ds["fatigue_gamma_Mf"].values, float)
    e2 = np.asarray(ds["fatigue_equivalent_stress_range"].values, float)
    lam = np.asarray(lm["equivalent"], float)
    strength = cat / gmf
    lam_util = gff * lam / strength
    names = [str(n) for n in ds["fatigue_section_name"].values]
    x = np.asarray(ds["fatigue_section"].values, float)
    return pd.DataFrame({
        "section": names, "x": x, "W": np.asarray(ds["fatigue_section_modulus"].values),
        "category": cat, "gamma_Ff": gff, "gamma_Mf": gmf, "damage": d,
        "e2": e2, "lambda": lam, "lambda_util": lam_util,
        "ratio": np.where(lam > 0, e2 / np.where(lam > 0, lam, 1.0), np.nan),
    })


def has_studs(ds) -> bool:
    """True when the results hold the stud fatigue variables."""
    return "fatigue_stud_damage" in ds.variables


def _stud_rows(ds) -> pd.DataFrame:
    d = np.asarray(ds["fatigue_stud_damage"].values, float)
    cat = np.asarray(ds["fatigue_stud_category"].values, float)
    gff = np.asarray(ds["fatigue_stud_gamma_Ff"].values, float)
    gmf = np.asarray(ds["fatigue_stud_gamma_Mf"].values, float)
    e2 = np.asarray(ds["fatigue_stud_equivalent_shear_stress_range"].values, float)
    return pd.DataFrame({
        "section": [str(n) for n in ds["fatigue_stud_name"].values],
        "x": np.asarray(ds["fatigue_stud"].values, float),
        "d": np.asarray(ds["fatigue_stud_diameter"].values, float),
        "n": np.asarray(ds["fatigue_stud_per_row"].values, float),
        "s": np.asarray(ds["fatigue_stud_row_spacing"].values, float),
        "factor": np.asarray(ds["fatigue_stud_shear_stress_per_shear_force"].values, float),
        "category": cat, "gamma_Ff": gff, "gamma_Mf": gmf, "damage": d, "e2": e2,
        "util": gff * e2 / (cat / gmf),
    })


def summary_rows(ds) -> list[dict]:
    """Rows of the report's summary table (columns of
    :data:`vsi_numba.analysis.checks.SUMMARY_COLUMNS`): Miner's damage per section."""
    if not has_fatigue(ds):
        return []
    out = []
    per_train = np.asarray(ds["fatigue_damage_per_train"].values, float)
    trains = [str(t) for t in ds["fatigue_traffic"].values]
    speeds = np.asarray(ds["fatigue_speed_kmh"].values, float)
    for j, r in _rows(ds).iterrows():
        k = int(np.argmax(per_train[:, j]))
        out.append({"check": f"Fatigue damage (Miner), {r['section']}", "value": r["damage"],
                    "units": "1", "limit": 1.0, "margin": 1.0 - r["damage"],
                    "utilisation": r["damage"],
                    "result": "pass" if r["damage"] <= 1.0 else "FAIL",
                    "governing_train": trains[k], "governing_speed_kmh": float(speeds[k]),
                    "clause": "EN 1993-1-9 8(3), EN 1991-2 6.4.6.6 [R]"})
    if has_studs(ds):
        per_train = np.asarray(ds["fatigue_stud_damage_per_train"].values, float)
        for j, r in _stud_rows(ds).iterrows():
            k = int(np.argmax(per_train[:, j]))
            out.append({"check": f"Stud fatigue damage (Miner), {r['section']}",
                        "value": r["damage"], "units": "1", "limit": 1.0,
                        "margin": 1.0 - r["damage"], "utilisation": r["damage"],
                        "result": "pass" if r["damage"] <= 1.0 else "FAIL",
                        "governing_train": trains[k],
                        "governing_speed_kmh": float(speeds[k]),
                        "clause": "EN 1994-2 6.8.7.2(1), EN 1994-1-1 6.8.3 [R]"})
    return out


def fatigue_section(ds) -> Section | None:
    """The report section, or None without fatigue results."""
    if not has_fatigue(ds):
        return None
    a = ds.attrs
    lm = lambda_method(ds)
    rows = _rows(ds, lm)
    years = float(a.get("fatigue_design_life_years", np.nan))
    mix = str(a.get("fatigue_mix", "") or "")
    trains = [str(t) for t in ds["fatigue_traffic"].values]
    per_day = np.asarray(ds["fatigue_trains_per_day"].values, float)
    speeds = np.asarray(ds["fatigue_speed_kmh"].values, float)
    free = np.asarray(ds["fatigue_free_vibration"].values, float)
    blocks: list = []
    verdicts = []
    for _, r in rows.iterrows():
        ok = r["damage"] <= 1.0
        verdicts.append(f"- {md(r['section'])} (x = {r['x']:g} m, detail category "
                        f"{r['category']:g} MPa): Miner's damage over {years:g} years "
                        f"**{r['damage']:.3g}** → **{'pass' if ok else 'FAIL'}** "
                        f"(margin {1 - r['damage']:+.3g}); λ-method utilisation "
                        f"γ_Ff·λ·Φ₂·Δσ₇₁ / (Δσ_C/γ_Mf) = {r['lambda_util']:.3g} "
                        f"({'pass' if r['lambda_util'] <= 1 else 'FAIL'}).")
    blocks.append("\n".join(verdicts))
    blocks.append(
        "Method: every train of the fatigue traffic"
        + (f" (EN 1991-2 Annex D {md(mix)} mix [R], and the trains listed in "
           "`[[fatigue.traffic]]`)" if mix else "")
        + " runs once at its speed over the bridge of this study; the bending moment at each "
        "section gives the stress history σ = M / W, counted by rainflow (ASTM E1049, the "
        "`rainflow` package) including the free vibration after the train, which is "
        f"simulated until every mode has decayed to 1 % of its amplitude ({free.min():.3g} "
        f"to {free.max():.3g} s here; EN 1991-2 6.4.6.6 [R]). The factored ranges "
        "γ_Ff·Δσ meet the S-N curve of EN 1993-1-9 7.1 [R] (slope 3 to N_D = 5·10⁶, slope "
        "5 to the cut-off at N_L = 10⁸) divided by γ_Mf; Miner's sum over the design life "
        "is the damage D (pass when D ≤ 1). The damage-equivalent range Δσ_E2 is the range "
        "whose 2·10⁶ cycles do the same damage (γ_Ff·Δσ_E2 = (Δσ_C/γ_Mf)·D^(1/3)); the "
        "λ-method value λ·Φ₂·Δσ₇₁ of EN 1993-2 9.5.3 [R] is shown beside it "
        f"({lm['text'] or 'not available: the deck gives no static moments'}; Φ₂ = "
        f"{lm['phi_2']:.3f} for L_Φ = {lm['length']:g} m; Δσ₇₁ the LM71 moment range, "
        "α = 1, over W; traffic "
        f"{float(a.get('fatigue_tonnes_per_year', np.nan)) / 1e6:.3g}·10⁶ t per year).")
    frame = pd.DataFrame({
        "Section": rows["section"], "x [m]": rows["x"], "W [m³]": rows["W"],
        "Δσ_C [MPa]": rows["category"], "γ_Ff": rows["gamma_Ff"], "γ_Mf": rows["gamma_Mf"],
        "Miner D": rows["damage"],
        "Δσ_E2 dynamic [MPa]": rows["e2"], "λ·Φ₂·Δσ₇₁ [MPa]": rows["lambda"],
        "dynamic / λ-method": rows["ratio"],
        "Result": [Markdown("pass") if d <= 1 else Markdown("**FAIL**")
                   for d in rows["damage"]],
    })
    blocks.append(Table(frame, "Fatigue verdict per section (" + CLAUSES + ")"))
    per_train = np.asarray(ds["fatigue_damage_per_train"].values, float)
    max_range = np.asarray(ds["fatigue_max_stress_range"].values, float)
    tab = {"Train": trains, "Speed [km/h]": speeds, "Trains per day": per_day,
           "Free vibration [s]": free}
    for j, name in enumerate(rows["section"]):
        tab[f"max Δσ [MPa], {name}"] = max_range[:, j]
        tab[f"D, {name}"] = per_train[:, j]
    blocks.append(Table(pd.DataFrame(tab), "Fatigue damage per train over the design life "
                                           "and the largest stress range of one passage "
                                           "(unfactored)"))
    if has_studs(ds):
        blocks += _stud_blocks(ds, trains, speeds, per_day, years)
    blocks.append(Figure(_figure(ds, rows), "fatigue_spectra.png",
                         "Rainflow stress-range spectra over the design life (all trains, "
                         "cycles per range bin, cumulative from the largest range) and the "
                         "design S-N curve of each section"))
    return Section("Fatigue", blocks)


def _stud_blocks(ds, trains, speeds, per_day, years) -> list:
    """The verdicts, the method and the tables of the headed stud shear connectors."""
    rows = _stud_rows(ds)
    slope = float(np.asarray(ds["fatigue_stud_slope"].values, float)[0])
    verdicts = []
    for _, r in rows.iterrows():
        ok = r["damage"] <= 1.0
        verdicts.append(f"- {md(r['section'])} (studs at x = {r['x']:g} m, {r['n']:g} × "
                        f"⌀{1e3 * r['d']:g} mm every {r['s']:g} m): Miner's damage over "
                        f"{years:g} years **{r['damage']:.3g}** → "
                        f"**{'pass' if ok else 'FAIL'}** (margin {1 - r['damage']:+.3g}); "
                        f"γ_Ff·Δτ_E2 / (Δτ_c/γ_Mf,s) = {r['util']:.3g}.")
    method = (
        "Studs: the vertical shear V(t) of each passage at the studs' x gives the "
        "longitudinal shear flow of the uncracked composite section v_L = V·S/I (S the "
        "first moment of the slab about the composite neutral axis, I the composite "
        "second moment); a row of n studs every s takes v_L·s, each stud its share over "
        "its shank πd²/4: τ = V·S·s / (I·n·πd²/4). The history τ(t), free vibration "
        "included, is counted by rainflow; the factored ranges γ_Ff·Δτ meet the stud S-N "
        f"curve of EN 1994-1-1 6.8.3 [R] (Δτ_c at 2·10⁶ cycles, slope m = {slope:g}, no "
        "cut-off) divided by γ_Mf,s; the check of EN 1994-2 6.8.7.2(1) [R] "
        "γ_Ff·Δτ_E2 ≤ Δτ_c/γ_Mf,s with the damage-equivalent range of the dynamic "
        f"histories (γ_Ff·Δτ_E2 = (Δτ_c/γ_Mf,s)·D^(1/{slope:g})) is Miner's D ≤ 1. Not "
        "made here: the λ_v value of EN 1994-2 6.8.6.2 (not computed) and the interaction "
        "with the stress of a steel flange in tension, EN 1994-2 6.8.7.2(2).")
    frame = pd.DataFrame({
        "Studs": rows["section"], "x [m]": rows["x"], "d [mm]": 1e3 * rows["d"],
        "per row": rows["n"], "row spacing [m]": rows["s"],
        "τ / V [MPa/MN]": rows["factor"], "Δτ_c [MPa]": rows["category"],
        "γ_Ff": rows["gamma_Ff"], "γ_Mf,s": rows["gamma_Mf"], "Miner D": rows["damage"],
        "Δτ_E2 dynamic [MPa]": rows["e2"],
        "Result": [Markdown("pass") if d <= 1 else Markdown("**FAIL**")
                   for d in rows["damage"]],
    })
    per_train = np.asarray(ds["fatigue_stud_damage_per_train"].values, float)
    max_range = np.asarray(ds["fatigue_stud_max_shear_stress_range"].values, float)
    tab = {"Train": trains, "Speed [km/h]": speeds, "Trains per day": per_day}
    for j, name in enumerate(rows["section"]):
        tab[f"max Δτ [MPa], {name}"] = max_range[:, j]
        tab[f"D, {name}"] = per_train[:, j]
    return ["\n".join(verdicts), method,
            Table(frame, "Stud fatigue verdict per layout (" + STUD_CLAUSES + ")"),
            Table(pd.DataFrame(tab), "Stud fatigue damage per train over the design life "
                                     "and the largest shear-stress range of one passage "
                                     "(unfactored)")]


def variants_section(ds) -> Section | None:
    """The fatigue results over the variants of a parametric study: Miner's damage per
    section (and studs) and variant, and the variant where fatigue governs; None without
    fatigue results or without a ``variant`` dimension on them."""
    if not has_fatigue(ds) or "variant" not in ds["fatigue_damage"].dims:
        return None
    from vsi_numba.analysis.variants import variant_label

    n = ds.sizes["variant"]
    names = [str(x) for x in ds["fatigue_section_name"].values]
    cols = {f"D, {m}": np.asarray(ds["fatigue_damage"].values, float)[:, j]
            for j, m in enumerate(names)}
    if has_studs(ds):
        studs = [str(x) for x in ds["fatigue_stud_name"].values]
        cols.update({f"D studs, {m}": np.asarray(ds["fatigue_stud_damage"].values,
                                                 float)[:, j]
                     for j, m in enumerate(studs)})
    d = np.column_stack(list(cols.values()))
    worst = d.max(axis=1)
    gov = int(np.nanargmax(worst))
    which = list(cols)[int(np.nanargmax(d[gov]))].removeprefix("D, ").removeprefix(
        "D studs, ")
    labels = [variant_label(ds, k) for k in range(n)]
    frame = pd.DataFrame({"Variant": np.arange(n), "Varied values": labels, **cols,
                          "Result": [Markdown("pass") if w <= 1 else Markdown("**FAIL**")
                                     for w in worst]})
    n_fail = int((worst > 1.0).sum())
    text = (f"Every variant's fatigue runs are its own bridge under the same traffic "
            f"(`[fatigue]` is the same in every variant). **Fatigue governs in variant "
            f"{gov}** ({md(labels[gov])}): Miner's damage **{worst[gov]:.3g}** at "
            f"{md(which)} → **{'pass' if worst[gov] <= 1 else 'FAIL'}**; variants that "
            f"FAIL the fatigue check: **{n_fail}** of {n}. The full fatigue section (per "
            "train, λ-method, spectra) is in the governing variant's report, for the "
            "variant that governs the deck acceleration.")
    return Section("Fatigue over the variants",
                   [text, Table(frame, "Miner's damage over the design life per variant "
                                       "and section (" + CLAUSES + ")")])


def _figure(ds, rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vsi_numba.model.fatigue import SNCurve

    cyc = np.asarray(ds["fatigue_cycles"].values, float)  # (traffic, section, bin)
    per_day = np.asarray(ds["fatigue_trains_per_day"].values, float)
    years = float(ds.attrs.get("fatigue_design_life_years", 100.0))
    centres = np.asarray(ds["stress_range"].values, float)
    life = (cyc * per_day[:, None, None] * 365.0 * years).sum(axis=0)  # (section, bin)
    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    for j, r in rows.iterrows():
        n = np.cumsum(life[j][::-1])[::-1]  # cycles with range >= bin
        keep = life[j] > 0
        ax.step(n[keep], centres[keep] * r["gamma_Ff"], where="post", color=f"C{j}",
                label=f"{r['section']}: γ_Ff·Δσ, cumulative cycles")
        sn = SNCurve.of(r["category"], r["gamma_Mf"])
        s = np.geomspace(sn.cutoff_limit * 0.8, max(sn.strength * 3, 1.0), 200)
        ax.plot(sn.cycles(s), s, color=f"C{j}", ls="--", lw=0.9,
                label=f"{r['section']}: Δσ_C/γ_Mf = {sn.strength:.3g} MPa S-N curve")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(1e4, 1e10)
    ax.set_xlabel("cycles")
    ax.set_ylabel("stress range (MPa)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="upper right")
    return fig
