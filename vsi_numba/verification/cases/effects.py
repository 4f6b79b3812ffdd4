"""Static load effects at crawl speed: a simply supported span (V03), a two-span
continuous deck (V04) and LM71's effects in the report (V11)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.verification import reference as ref
from vsi_numba.verification.cases.common import Row, forces_toml, ss_bridge, sweep


# ------------------------------------------------------------------ V03 simply supported effects
def v03_ss_effects(workdir: Path) -> list[Row]:
    L, EI, m, P = 10.0, 5e9, 1.0e4, 1.0e5
    text = ss_bridge(L, EI, m, 0.05, 4, [5.0, 2.5]) + "[train]\n" + forces_toml([0.0], P) + """
        [track]
        model = "rigid"
        [solver]
        dt = 1e-3
        approach = 1.0
        free_vibration = 0.2
        [study]
        speeds_kmh = [3.0]
        save_time_histories = false
        """
    ds = sweep(workdir, "v03_ss_effects", text).isel(speed=0, train=0,
                                                                       irregularity=0)
    mid, quarter = ref.ss_crawl_effects(P, L, EI, 5.0), ref.ss_crawl_effects(P, L, EI, 2.5)
    title = "Load effects of a force crossing a 10 m simply supported span at 3 km/h"
    src = "influence lines of a simply supported span (statics; Roark, beam tables)"
    model = "moving force, 4 modes + mode acceleration, 5 % damping, dt 1 ms"
    reason = ("3 km/h: the dynamic part of the mode-accelerated effects and the effects "
              "sampled at dt (0.8 mm steps of the force): measured <= 7e-4")
    m_ = ds["max_bending_moment"].values
    return [
        Row("V03-M-mid", title, src, model, "max bending moment at x = 5 m", "N m",
            mid["moment"], float(m_[0]), 2e-3, reason),
        Row("V03-M-quarter", title, src, model, "max bending moment at x = 2.5 m", "N m",
            quarter["moment"], float(m_[1]), 2e-3, reason),
        Row("V03-V-quarter", title, src, model, "max shear force at x = 2.5 m", "N",
            quarter["shear_max"], float(ds["max_shear_force"].values[1]), 2e-3, reason),
        Row("V03-R", title, src, model, "max reaction at the left support", "N",
            mid["reaction"], float(ds["max_support_reaction"].values[0]), 2e-3, reason),
        Row("V03-theta", title, src, model, "max end rotation at the left support", "rad",
            mid["rotation"], float(ds["max_end_rotation"].values[0]), 2e-3,
            reason + "; rotations converge fast with modes"),
    ]


# ------------------------------------------------------------------ V04 continuous deck
def v04_continuous(workdir: Path) -> list[Row]:
    L1, L2, EI, m, P = 10.0, 12.0, 5e9, 1.0e4, 1.0e5
    text = f"""
        [bridge]
        kind = "continuous"
        spans = [{L1}, {L2}]
        EI = {EI}
        mass_per_length = {m}
        damping_ratio = 0.05
        n_modes = 4
        elements_per_span = 20
        output_points = [5.0, 16.0]
        [train]
        """ + forces_toml([0.0], P) + """
        [track]
        model = "rigid"
        [solver]
        dt = 1e-3
        approach = 1.0
        free_vibration = 0.2
        [study]
        speeds_kmh = [3.0]
        save_time_histories = false
        """
    ds = sweep(workdir, "v04_continuous", text).isel(speed=0, train=0,
                                                                       irregularity=0)
    r = ref.two_span_crawl_effects(P, L1, L2, EI, [5.0, 16.0])
    k = int(np.argmin(abs(ds["deck_x"].values - L1)))
    title = "Load effects of a force crossing a 10 + 12 m continuous deck at 3 km/h"
    src = "three-moment equation (Clapeyron) and statics; end rotations by quadrature of M/EI"
    model = "moving force, FE deck (20 elements a span), 4 modes + mode acceleration, dt 1 ms"
    reason = ("3 km/h: the dynamic part of the mode-accelerated effects and the effects "
              "sampled at dt: measured <= 1.6e-4")
    return [
        Row("V04-M1", title, src, model, "max bending moment at x = 5 m", "N m",
            r["moment"][0], float(ds["max_bending_moment"].values[0]), 5e-4, reason),
        Row("V04-M2", title, src, model, "max bending moment at x = 16 m", "N m",
            r["moment"][1], float(ds["max_bending_moment"].values[1]), 5e-4, reason),
        Row("V04-MB", title, src, model, "hogging moment over the middle support", "N m",
            r["support_moment"], float(ds["min_bending_moment_whole_deck"].values[k]), 5e-4,
            reason),
        Row("V04-RB", title, src, model, "max reaction at the middle support", "N",
            r["reaction"][1], float(ds["max_support_reaction"].values[1]), 5e-4, reason),
        Row("V04-theta", title, src, model, "max end rotation at the left end", "rad",
            r["rotation_a"], float(ds["max_end_rotation"].values[0]), 5e-4, reason),
    ]


# ------------------------------------------------------------------ V11 LM71 static effects
def v11_lm71(workdir: Path) -> list[Row]:
    import pandas as pd
    import xarray as xr

    from vsi_numba.analysis.report import write_report

    L, EI, m, P = 10.0, 5e9, 1.0e4, 1.0e5
    text = ss_bridge(L, EI, m, 0.05, 4, [5.0, 2.5]) + "[train]\n" + forces_toml([0.0], P) + """
        [track]
        model = "rigid"
        [solver]
        dt = 1e-3
        approach = 1.0
        free_vibration = 0.2
        [study]
        speeds_kmh = [3.0]
        save_time_histories = false
        """
    sweep(workdir, "v11_lm71", text)
    nc = workdir / "v11_lm71.nc"
    with xr.open_dataset(nc) as ds:  # the report of vsi report, written by its function
        write_report(ds, workdir / "report", source_path=nc)
    table = pd.read_excel(workdir / "report" / "tables.xlsx", sheet_name="load_effect_envelopes")

    def lm71(effect, x):
        row = table[(table["effect"] == effect) & (abs(table["location"] - x) < 1e-9)]
        return float(row["lm71"].iloc[0])

    title = "LM71 static effects on a 10 m simply supported span (the report's LM71 column)"
    src = ("influence lines, LM71 of EN 1991-2 6.3.2 Fig. 6.1 [R] (4 x 250 kN at 1.6 m, "
           "80 kN/m beyond 0.8 m on the unfavourable parts) moved in 1 mm steps, "
           "vsi_numba.verification.reference.lm71_extreme")
    model = "vsi report's load-effect table (tables.xlsx, load_effect_envelopes, lm71)"
    reason = ("statics: the lines are piecewise linear and the maxima at positions both "
              "scans hit; round-off, measured <= 2.2e-10")
    reason_theta = ("the rotation's line is cubic: the distributed load's integral by "
                    "trapezoid on the grids of the reference and the report; measured 2.1e-6")
    rows = []
    for rid, effect, x, unit, what in (
            ("V11-M-mid", "moment", 5.0, "N m", "bending moment at x = 5 m"),
            ("V11-M-quarter", "moment", 2.5, "N m", "bending moment at x = 2.5 m"),
            ("V11-V-quarter", "shear", 2.5, "N", "shear force at x = 2.5 m"),
            ("V11-R", "reaction", 0.0, "N", "reaction at the left support"),
            ("V11-theta", "rotation", 0.0, "rad", "end rotation at the left support")):
        reference_value = ref.lm71_extreme(L, ref.ss_influence(L, EI, x, effect))
        theta = effect == "rotation"
        rows.append(Row(rid, title, src, model, f"LM71 {what}", unit, reference_value,
                        lm71(effect, x), 1e-5 if theta else 1e-9,
                        reason_theta if theta else reason))
    return rows
