"""Moving forces on a simply supported beam: Frýba's dynamic amplification (V01, and
V13 on a deck imported as a modes table), the resonance and cancellation of a train of
equal forces (V05, V06, V14) and HSLM-A1 at resonance (V07)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.verification import reference as ref
from vsi_numba.verification.cases.common import Row, ei_for, forces_toml, ss_bridge, sweep


# ------------------------------------------------------------------ V01 Fryba moving force
def _fryba_run(approach: float, speeds) -> str:
    """The rigid-track, undamped-integration part of the moving-force cases' config."""
    return f"""
        [track]
        model = "rigid"
        [solver]
        dt = 2e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = {speeds!r}
        save_time_histories = true
        """


def _daf(ds, i: int, approach: float, L: float, P: float, EI: float) -> float:
    """Peak midspan deflection while the force is on the span / P L^3 / (48 EI), speed i."""
    v = float(ds["speed"].values[i])
    t = ds["time"].values
    on = (t >= approach / v) & (t <= (approach + L) / v)
    w = ds["deck_displacement"].isel(speed=i, train=0, irregularity=0, point=0).values
    return float(np.nanmax(w[on])) / (P * L**3 / (48.0 * EI))


def v01_fryba(workdir: Path) -> list[Row]:
    L, m, f1, P, approach = 20.0, 1.0e4, 2.0, 1.0e5, 0.5
    EI = ei_for(f1, L, m)
    alphas = sorted(ref.FRYBA_DAF)
    speeds = [a * 2.0 * f1 * L * 3.6 for a in alphas]
    text = (ss_bridge(L, EI, m, 0.0, 10, [L / 2]) + "[train]\n" + forces_toml([0.0], P)
            + _fryba_run(approach, speeds))
    ds = sweep(workdir, "v01_fryba", text)
    rows = []
    for i, a in enumerate(alphas):
        rows.append(Row(
            f"V01-{a:g}", f"Moving force on a simply supported beam, alpha = {a:g}",
            ref.FRYBA_SOURCE, "moving force, 10 modes, undamped, HHT alpha = 0, dt 0.2 ms",
            "DAF of midspan deflection while the force is on the span", "-",
            ref.FRYBA_DAF[a], _daf(ds, i, approach, L, P, EI), 1e-3 if a == 1.0 else 1e-4,
            "the table's alpha = 1.0 entry is 4e-4 above its own series (1.5481)" if a == 1.0
            else "table rounded to 4 decimals (<= 5e-5); modes 11-60, the period error and the "
            "peak sampled at dt 0.2 ms: < 2e-5"))
    return rows


# ------------------------------------------------------------------ V05/V06 trains of forces
def _train_case(workdir, cid, L, d, label, quick_title, i=1):
    m, f1, zeta, P, n, approach = 1.0e4, 4.0, 0.01, 1.0e5, 10, 1.0
    EI = ei_for(f1, L, m)
    v = f1 * d / i  # the i-th resonance
    offsets = [k * d for k in range(n)]
    text = ss_bridge(L, EI, m, zeta, 1, [L / 2]) + "[train]\n" + forces_toml(offsets, P) + f"""
        [track]
        model = "rigid"
        [solver]
        dt = 5e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 1.0
        [study]
        speeds_kmh = [{v * 3.6!r}]
        save_time_histories = false
        """
    ds = sweep(workdir, cid.lower(), text).isel(speed=0, train=0,
                                                                  irregularity=0)
    t_end = (approach + L + offsets[-1]) / v + 1.0
    _, w, a = ref.train_of_forces(offsets, [P] * n, L, EI, m, zeta, 1, v, [L / 2], t_end,
                                  x_start=-approach, nt=200001)
    src = ("closed-form modal response of a force, superposed force by force "
           "(Frýba); resonance v = n0 d / i, cancellation L/d = (2j - 1)/(2i) "
           "(EN 1991-2 / ERRI D214 [R])")
    model = "10 moving forces of 100 kN, 1 mode (4 Hz), 1 % damping, HHT alpha = 0, dt 0.5 ms"
    reason = (f"trapezoidal period error (w dt)^2/12 = 3e-5 a cycle over ~{20 * i} cycles "
              "of build-up, peak sampled at dt: measured <= "
              + ("3.4e-5" if i == 1 else "1.0e-4"))
    tol = 1e-4 if i == 1 else 3e-4
    speed = "n0 d" if i == 1 else f"n0 d / {i}"
    title = (f"{quick_title}: L = {L:g} m, d = {d:.4g} m, v = {speed} = {v * 3.6:.1f} km/h "
             f"({label})")
    return [
        Row(f"{cid}-w", title, src, model, "max midspan deflection", "m", float(w.max()),
            float(ds["max_deck_displacement"].values[0]), tol, reason),
        Row(f"{cid}-a", title, src, model, "max |midspan acceleration|", "m/s2",
            float(abs(a).max()), float(ds["max_deck_acceleration"].values[0]), tol, reason),
    ]


def v05_resonance(workdir: Path) -> list[Row]:
    return _train_case(workdir, "V05", 20.0, 15.0, "L/d = 4/3: build-up", "Resonance of a "
                       "train of equal forces")


def v14_second_resonance(workdir: Path) -> list[Row]:
    return _train_case(workdir, "V14", 20.0, 15.0, "i = 2: a force every second cycle",
                       "Second resonance of a train of equal forces", i=2)


def v06_cancellation(workdir: Path) -> list[Row]:
    return _train_case(workdir, "V06", 20.0, 20.0 / 1.5, "L/d = 3/2: cancelled, j = 2",
                       "Cancellation of the resonance of a train of equal forces")


# ------------------------------------------------------------------ V07 HSLM-A1
def v07_hslm(workdir: Path) -> list[Row]:
    L, m, f1, zeta, approach = 15.0, 1.5e4, 6.0, 0.01, 1.0
    EI = ei_for(f1, L, m)
    v = f1 * 18.0  # HSLM-A1: coach length D = 18 m
    text = ss_bridge(L, EI, m, zeta, 2, [L / 2]) + f"""
        [train]
        preset = "HSLM-A1"
        model = "moving_force"
        [track]
        model = "rigid"
        [solver]
        dt = 2e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.5
        [study]
        speeds_kmh = [{v * 3.6!r}]
        save_time_histories = false
        """
    ds = sweep(workdir, "v07_hslm", text).isel(speed=0, train=0,
                                                                 irregularity=0)
    pos = ds["wheel_position"].values.ravel()
    loads = ds["static_wheel_load"].values.ravel()
    ok = np.isfinite(pos)
    pos, loads = pos[ok], loads[ok]
    t_end = (approach + L + pos.max()) / v + 0.5
    _, w, a = ref.train_of_forces(pos, loads, L, EI, m, zeta, 2, v, [L / 2], t_end,
                                  x_start=-approach, nt=400001)
    title = f"HSLM-A1 at its first resonance on a 15 m span (f1 = 6 Hz, {v * 3.6:.1f} km/h)"
    src = ("numpy modal integration: closed-form modal response superposed axle by axle "
           "(the axles and loads read from the results file)")
    model = "HSLM-A1 moving forces, 2 modes, 1 % damping, HHT alpha = 0, dt 0.2 ms"
    reason = ("resonance build-up over ~35 cycles: trapezoidal period error 1e-5 a cycle; "
              "peak sampled at dt: measured <= 1.3e-5")
    return [
        Row("V07-w", title, src, model, "max midspan deflection", "m", float(w.max()),
            float(ds["max_deck_displacement"].values[0]), 5e-5, reason),
        Row("V07-a", title, src, model, "max |midspan acceleration|", "m/s2",
            float(abs(a).max()), float(ds["max_deck_acceleration"].values[0]), 5e-5, reason
            + "; the second mode (24 Hz) at 200 steps a period"),
    ]


# ------------------------------------------------------------------ V13 imported modes
def v13_imported_modes(workdir: Path) -> list[Row]:
    L, m, f1, P, approach = 20.0, 1.0e4, 2.0, 1.0e5, 0.5
    EI = ei_for(f1, L, m)
    alphas = (0.3, 0.5, 1.0)
    table = workdir / "modes.csv"
    lines = ["mode,frequency,modal_mass,x,shape,slope"]
    lines += [",".join(repr(float(v)) for v in row)
              for row in ref.ss_mode_table(L, EI, m, 10, 0.25)]
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    speeds = [a * 2.0 * f1 * L * 3.6 for a in alphas]
    text = f"""
        [bridge]
        kind = "modes_file"
        file = "modes.csv"
        spans = [{L!r}]
        n_modes = 10
        damping_ratio = 0.0
        output_points = [{L / 2!r}]
        [train]
        """ + forces_toml([0.0], P) + _fryba_run(approach, speeds)
    ds = sweep(workdir, "v13_imported", text)
    rows = []
    for i, a in enumerate(alphas):
        rows.append(Row(
            f"V13-{a:g}", f"Moving force on a deck imported as a modes table, alpha = {a:g}",
            ref.FRYBA_SOURCE + "; the table: the sine modes at 0.25 m stations with slopes "
            "(vsi_numba.verification.reference.ss_mode_table)",
            "modes_file (CSV, 10 modes, Hermite cubics between stations), moving force, "
            "HHT alpha = 0, dt 0.2 ms", "DAF of midspan deflection while the force is on "
            "the span", "-", ref.FRYBA_DAF[a], _daf(ds, i, approach, L, P, EI),
            1e-3 if a == 1.0 else 1e-4,
            "as V01 (the table's alpha = 1.0 entry is 4e-4 above its series); the Hermite "
            "cubic of mode 10 between 0.25 m stations: < 1e-4 of its ordinates"))
    return rows
