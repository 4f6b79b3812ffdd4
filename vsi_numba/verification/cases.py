"""The verification cases: each writes a TOML config, runs it through the study runner
that ``vsi sweep`` calls, reads the netCDF file it wrote and compares figures with
:mod:`vsi_numba.verification.reference`.

A case is a function ``(workdir) -> list[Row]``; :data:`CASES` lists them in the order of
the manual with the ``quick`` flag of ``vsi verify --quick``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.verification import existing as _existing
from vsi_numba.verification import reference as ref


@dataclass(frozen=True)
class Row:
    """One compared figure of a case (a row of verification.csv)."""

    id: str
    title: str
    source: str
    model: str
    quantity: str
    unit: str
    reference: float
    computed: float
    tolerance: float  # on the relative error
    tolerance_reason: str

    @property
    def error(self) -> float:
        """Relative error ``computed / reference - 1``."""
        return float(self.computed / self.reference - 1.0)

    @property
    def passed(self) -> bool:
        """True when the relative error is within the tolerance (NaN fails)."""
        return bool(abs(self.error) <= self.tolerance)


@dataclass(frozen=True)
class Case:
    """A verification case: its id, title, whether ``--quick`` runs it, and its run."""

    id: str
    title: str
    quick: bool
    run: Callable[[Path], list[Row]]


def sweep(workdir: Path, name: str, text: str):
    """Write ``text`` as ``workdir/name.toml``, run it with the study runner of
    ``vsi sweep -q --fresh`` (:func:`vsi_numba.study.runner.execute_study`) and return the
    results file's dataset (loaded; dims speed, train, irregularity kept)."""
    import xarray as xr

    from vsi_numba.study.runner import execute_study

    cfg = workdir / f"{name}.toml"
    out = workdir / f"{name}.nc"
    cfg.write_text(text, encoding="utf-8")
    outcome = execute_study(cfg, out, fresh=True, quiet=True,
                            command=f"vsi verify: vsi sweep {cfg} -o {out} --fresh")
    if outcome.n_failed:
        raise RuntimeError(f"{outcome.n_failed} of {outcome.n_runs} runs of {cfg} failed "
                           f"numerically (see the status and message variables of {out})")
    with xr.open_dataset(out) as ds:
        return ds.load()


def _ss_bridge(L, EI, m, zeta, n_modes, points):
    return f"""
        [bridge]
        kind = "simply_supported"
        spans = [{L!r}]
        EI = {EI!r}
        mass_per_length = {m!r}
        damping_ratio = {zeta!r}
        n_modes = {n_modes}
        output_points = {list(points)!r}
        """


def _forces(offsets, load):
    return "".join(f'\n[[train.vehicles]]\nkind = "force"\noffset = {o!r}\nload = {load!r}\n'
                   for o in offsets)


def _ei_for(f1, L, m):
    """EI (N m2) giving the first frequency ``f1`` (Hz) of a simply supported span."""
    return m * (2.0 * np.pi * f1 / (np.pi / L) ** 2) ** 2


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
    EI = _ei_for(f1, L, m)
    alphas = sorted(ref.FRYBA_DAF)
    speeds = [a * 2.0 * f1 * L * 3.6 for a in alphas]
    text = (_ss_bridge(L, EI, m, 0.0, 10, [L / 2]) + "[train]\n" + _forces([0.0], P)
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


# ------------------------------------------------------------------ V02 Yang & Wu sprung mass
def v02_yang_wu(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    text = _ss_bridge(p["L"], p["EI"], p["m"], 0.0, 10, [p["L"] / 2]) + f"""
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = {p["mass"]!r}
        stiffness = {p["k"]!r}
        [track]
        model = "rigid"
        [solver]
        dt = 2e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = [100.0]
        save_time_histories = true
        """
    ds = sweep(workdir, "v02_yang_wu", text).isel(speed=0, train=0, irregularity=0)
    v = p["v"]
    t = ds["time"].values
    on = (t >= approach / v) & (t <= (approach + p["L"]) / v)
    w = float(np.nanmax(ds["deck_displacement"].isel(point=0).values[on]))
    acc = float(np.nanmax(np.abs(ds["carbody_acceleration"].isel(vehicle=0).values[on])))
    sol = ref.sprung_mass_on_beam(p["L"], p["EI"], p["m"], p["mass"], p["k"], v)
    model = "sprung mass, massless contact, rigid track, 10 modes, HHT alpha = 0, dt 0.2 ms"
    title = "Sprung mass crossing a 25 m simply supported beam (Yang & Wu)"
    ivp = ("solve_ivp (DOP853, rtol 1e-10) of the coupled sprung mass and 10-mode beam, "
           "vsi_numba.verification.reference.sprung_mass_on_beam")
    return [
        Row("V02-w", title, ref.YANG_WU_SOURCE, model, "max midspan deflection while "
            "the vehicle is on the span", "m", ref.YANG_WU_MIDSPAN, w, 3e-4,
            "published to 5 figures (2e-5); 10 modes instead of 30: 1.0e-4 (the peers of "
            "case S1 agree within 2e-4)"),
        Row("V02-a", title, ref.YANG_WU_SOURCE, model, "max |body acceleration| while on "
            "the span", "m/s2", ref.YANG_WU_BODY_ACC, acc, 5e-4,
            "published to 4 figures (up to 3.4e-4); 10 modes instead of 30: 1.9e-4"),
        Row("V02-w-ivp", title, ivp, model, "max midspan deflection while on the span", "m",
            sol["max_midspan"], w, 5e-6, "the same 10-mode model: the trapezoidal rule's "
            "period error and the peak sampled at dt 0.2 ms, (w1 dt)^2/8 = 1e-6"),
        Row("V02-a-ivp", title, ivp, model, "max |body acceleration| while on the span",
            "m/s2", sol["max_body_acceleration"], acc, 1e-4,
            "the same 10-mode model: the body acceleration carries the higher modes through "
            "the spring, period error and peak sampling at dt 0.2 ms (measured 3e-5)"),
    ]


# ------------------------------------------------------------------ V09 quarter car
def v09_quarter_car(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach, zeta, c, m_w = 1.0, 0.02, 2.0e4, 1000.0
    text = _ss_bridge(p["L"], p["EI"], p["m"], zeta, 10, [p["L"] / 2]) + f"""
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = {p["mass"]!r}
        stiffness = {p["k"]!r}
        damping = {c!r}
        wheel_mass = {m_w!r}
        [track]
        model = "rigid"
        [solver]
        dt = 1e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = [100.0]
        save_time_histories = true
        """
    ds = sweep(workdir, "v09_quarter_car", text).isel(speed=0, train=0, irregularity=0)
    v = p["v"]
    t = ds["time"].values
    on = (t >= approach / v) & (t <= (approach + p["L"]) / v)
    w = float(np.nanmax(ds["deck_displacement"].isel(point=0).values[on]))
    acc = float(np.nanmax(np.abs(ds["carbody_acceleration"].isel(vehicle=0).values[on])))
    force = ds["contact_force"].isel(wheel=0).values[on]
    sol = ref.quarter_car_on_beam(p["L"], p["EI"], p["m"], zeta, p["mass"], p["k"], c, m_w, v)
    title = ("Quarter car (5750 kg body, 1000 kg wheel, 20 kN s/m) crossing the Yang & Wu "
             "beam with 2 % damping at 100 km/h")
    src = ("solve_ivp (DOP853, rtol 1e-10) of the body, the wheel held on the beam "
           "(convective terms) and the 10-mode damped beam, "
           "vsi_numba.verification.reference.quarter_car_on_beam")
    model = ("sprung mass with wheel mass and damping, rigid contact and track, 10 modes, "
             "HHT alpha = 0, dt 0.1 ms")
    reason = ("the same model: the trapezoidal rule's period error and the peak sampled at "
              "dt 0.1 ms; measured ")
    return [
        Row("V09-w", title, src, model, "max midspan deflection while on the span", "m",
            sol["max_midspan"], w, 1e-6, reason + "5e-9 ((w1 dt)^2/8 = 3e-8)"),
        Row("V09-a", title, src, model, "max |body acceleration| while on the span",
            "m/s2", sol["max_body_acceleration"], acc, 1e-5, reason + "3.9e-6"),
        Row("V09-Xmin", title, src, model, "min contact force while on the span", "N",
            sol["min_force"], float(force.min()), 5e-5, reason + "5.2e-6 (the wheel's "
            "inertia carries the higher modes)"),
        Row("V09-Xmax", title, src, model, "max contact force while on the span", "N",
            sol["max_force"], float(force.max()), 5e-5, reason + "1.4e-5 (the wheel's "
            "inertia carries the higher modes)"),
    ]


# ------------------------------------------------------------------ V10 bump stop
def v10_bump_stop(workdir: Path) -> list[Row]:
    mass, k, c, gap, k_stop = 5750.0, 1.595e6, 2.0e4, 0.01, 5.0e6
    depth, wavelength, position, length, approach = -0.02, 4.0, 10.0, 30.0, 1.0
    text = f"""
        [bridge]
        kind = "rigid"
        spans = [{length!r}]
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = {mass!r}
        stiffness = {k!r}
        damping = {c!r}
        bump_stop = {{ gap = {gap!r}, stiffness = {k_stop!r} }}
        [irregularity]
        kind = "cosine"
        depth = {depth!r}
        wavelength = {wavelength!r}
        position = {position!r}
        [track]
        model = "rigid"
        [solver]
        dt = 1e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = [100.0]
        save_time_histories = true
        """
    ds = sweep(workdir, "v10_bump_stop", text).isel(speed=0, train=0, irregularity=0)
    v = 100.0 / 3.6
    t = ds["time"].values
    on = t <= (approach + length) / v
    acc = float(np.nanmax(np.abs(ds["carbody_acceleration"].isel(vehicle=0).values[on])))
    force = ds["contact_force"].isel(wheel=0).values[on]
    sol = ref.sprung_mass_bump_stop_on_rigid_rail(mass, k, c, gap, k_stop, depth, wavelength,
                                                  position, v, -approach, length)
    title = (f"Sprung mass whose bump stop closes (by {1e3 * (sol['max_compression'] - gap):.1f}"
             " mm) over a 20 mm, 4 m cosine bump at 100 km/h, rigid track")
    src = ("solve_ivp (DOP853, rtol 1e-11) of the sprung mass with the piecewise-linear stop "
           "on the rigid rail, "
           "vsi_numba.verification.reference.sprung_mass_bump_stop_on_rigid_rail")
    model = ("sprung mass, 20 kN s/m, bump stop 10 mm / 5 MN/m, rigid bridge and track, "
             "HHT alpha = 0, dt 0.1 ms")
    reason = ("the step that closes the stop is solved on its branches (second order in "
              "dt) and the peak sampled at dt; measured ")
    return [
        Row("V10-a", title, src, model, "max |body acceleration|", "m/s2",
            sol["max_body_acceleration"], acc, 2e-5, reason + "4.4e-6"),
        Row("V10-Xmax", title, src, model, "max contact force", "N", sol["max_force"],
            float(force.max()), 1e-5, reason + "2.1e-6"),
        Row("V10-Xmin", title, src, model, "min contact force", "N", sol["min_force"],
            float(force.min()), 5e-5, reason + "1.2e-5 (of a force 13 % of the largest)"),
    ]


# ------------------------------------------------------------------ V11 LM71 static effects
def v11_lm71(workdir: Path) -> list[Row]:
    import pandas as pd
    import xarray as xr

    from vsi_numba.analysis.report import write_report

    L, EI, m, P = 10.0, 5e9, 1.0e4, 1.0e5
    text = _ss_bridge(L, EI, m, 0.05, 4, [5.0, 2.5]) + "[train]\n" + _forces([0.0], P) + """
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


# ------------------------------------------------------------------ V12 order of accuracy
def v12_order(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach, n_modes, v = 1.0, 1, p["v"]
    dts = (2e-3, 1e-3, 5e-4)
    times = (0.5, 0.7)  # s: the vehicle at x = 12.9 and 18.4 m, on every time grid
    errors = []
    sol = ref.sprung_mass_on_beam(p["L"], p["EI"], p["m"], p["mass"], p["k"], v,
                                  n_modes=n_modes, times=[t - approach / v for t in times])
    for dt in dts:
        text = _ss_bridge(p["L"], p["EI"], p["m"], 0.0, n_modes, [p["L"] / 2]) + f"""
            [train]
            [[train.vehicles]]
            kind = "sprung_mass"
            mass = {p["mass"]!r}
            stiffness = {p["k"]!r}
            [track]
            model = "rigid"
            [solver]
            dt = {dt!r}
            hht_alpha = 0.0
            approach = {approach}
            free_vibration = 0.05
            [study]
            speeds_kmh = [100.0]
            save_time_histories = true
            """
        ds = sweep(workdir, f"v12_dt_{dt * 1e3:g}ms", text).isel(speed=0, train=0,
                                                                    irregularity=0)
        t = ds["time"].values
        w = ds["deck_displacement"].isel(point=0).values
        idx = [int(np.argmin(abs(t - ti))) for ti in times]
        assert all(abs(t[i] - ti) < 1e-9 for i, ti in zip(idx, times, strict=True))
        errors.append(max(abs(w[i] - r) for i, r in zip(idx, sol["midspan_at"],
                                                         strict=True)))
    order = float(np.polyfit(np.log(dts), np.log(errors), 1)[0])
    title = ("Order of accuracy in dt of the coupled solution: Yang & Wu's sprung mass, "
             "1 mode, HHT alpha = 0, dt = 2, 1, 0.5 ms")
    src = ("HHT-alpha with alpha = 0 is the trapezoidal rule: second order (Hilber, Hughes & "
           "Taylor 1977); errors against solve_ivp (DOP853, rtol 1e-10) of the same model "
           "at t = 0.5 and 0.7 s")
    model = "sprung mass, massless contact, rigid track, 1 mode, HHT alpha = 0"
    return [Row("V12-order", title, src, model, "slope of log(max error of the midspan "
                "deflection) against log(dt)", "-", 2.0, order, 0.02,
                f"errors {errors[0]:.2e}, {errors[1]:.2e}, {errors[2]:.2e} m, in the "
                "asymptotic range (w dt <= 0.04); the slope of three points, measured "
                "-0.6 %")]


# ------------------------------------------------------------------ V13 imported modes
def v13_imported_modes(workdir: Path) -> list[Row]:
    L, m, f1, P, approach = 20.0, 1.0e4, 2.0, 1.0e5, 0.5
    EI = _ei_for(f1, L, m)
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
        """ + _forces([0.0], P) + _fryba_run(approach, speeds)
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


# ------------------------------------------------------------------ V15 OpenSees S1 (Hertz)
def v15_opensees_s1(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    G = 4.57e-8 * 0.4575 ** (-0.149)
    text = _ss_bridge(p["L"], p["EI"], p["m"], 0.0, 20, [p["L"] / 2]) + f"""
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = {p["mass"]!r}
        stiffness = {p["k"]!r}
        wheel_mass = 10.0
        [contact]
        model = "hertz"
        hertz_coefficient = {G!r}
        [track]
        model = "rigid"
        [solver]
        dt = 1e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = [100.0]
        save_time_histories = true
        """
    ds = sweep(workdir, "v15_s1_hertz", text).isel(speed=0, train=0, irregularity=0)
    v = p["v"]
    t = ds["time"].values
    on = (t >= approach / v) & (t <= (approach + p["L"]) / v)
    w = float(np.nanmax(ds["deck_displacement"].isel(point=0).values[on]))
    return [Row("V15-w", "Yang & Wu's sprung mass on a 10 kg wheel with Hertz contact "
                "(OpenSees S1)", ref.S1_OPENSEES_SOURCE, "Hertz contact (G of R = 0.4575 m), "
                "10 kg wheel, rigid track, 20 modes, HHT alpha = 0, dt 0.1 ms",
                "max midspan deflection while on the span", "m", ref.S1_OPENSEES_MIDSPAN, w,
                5e-4, "peer figure to 6 digits; its 20-element FE beam against 20 exact "
                "modes (the FE peers of S1 differ from the modal reference by up to 1.7e-4);"
                " measured 1.6e-4")]


# ------------------------------------------------------------------ V03 simply supported effects
def v03_ss_effects(workdir: Path) -> list[Row]:
    L, EI, m, P = 10.0, 5e9, 1.0e4, 1.0e5
    text = _ss_bridge(L, EI, m, 0.05, 4, [5.0, 2.5]) + "[train]\n" + _forces([0.0], P) + """
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
        """ + _forces([0.0], P) + """
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


# ------------------------------------------------------------------ V05/V06 trains of forces
def _train_case(workdir, cid, L, d, label, quick_title, i=1):
    m, f1, zeta, P, n, approach = 1.0e4, 4.0, 0.01, 1.0e5, 10, 1.0
    EI = _ei_for(f1, L, m)
    v = f1 * d / i  # the i-th resonance
    offsets = [k * d for k in range(n)]
    text = _ss_bridge(L, EI, m, zeta, 1, [L / 2]) + "[train]\n" + _forces(offsets, P) + f"""
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
    EI = _ei_for(f1, L, m)
    v = f1 * 18.0  # HSLM-A1: coach length D = 18 m
    text = _ss_bridge(L, EI, m, zeta, 2, [L / 2]) + f"""
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


# ------------------------------------------------------------------ V08 OpenSees dip (S2)
def v08_opensees_dip(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    G = 4.57e-8 * 0.4575 ** (-0.149)
    text = _ss_bridge(p["L"], p["EI"], p["m"], 0.0, 20, [p["L"] / 2]) + f"""
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = {p["mass"]!r}
        stiffness = {p["k"]!r}
        wheel_mass = 500.0
        [irregularity]
        kind = "cosine"
        depth = 0.003
        wavelength = 0.5
        position = 12.25
        [contact]
        model = "hertz"
        hertz_coefficient = {G!r}
        [track]
        model = "rigid"
        [solver]
        dt = 1e-4
        hht_alpha = 0.0
        approach = {approach}
        free_vibration = 0.05
        [study]
        speeds_kmh = [100.0]
        save_time_histories = true
        """
    ds = sweep(workdir, "v08_dip", text).isel(speed=0, train=0, irregularity=0)
    v = p["v"]
    t = ds["time"].values
    on = (t >= approach / v) & (t <= (approach + p["L"]) / v)
    w = float(np.nanmax(ds["deck_displacement"].isel(point=0).values[on]))
    flags = ds["in_contact"].isel(wheel=0).values.astype(bool)
    lost = np.flatnonzero(~flags & (t >= approach / v))
    x_off = -approach + v * t[lost[0]] if lost.size else np.nan
    title = "Lift-off on a 3 mm rail dip: sprung mass with a 500 kg wheel (OpenSees S2)"
    model = "Hertz contact (G of R = 0.4575 m), rigid track, 20 modes, HHT alpha = 0, dt 0.1 ms"
    return [
        Row("V08-w", title, ref.S2_SOURCE, model, "max midspan deflection while on the span",
            "m", ref.S2_MIDSPAN, w, 1e-2, "peer figure to 4 digits; the peer's FE beam "
            "(20 elements) and rail-deflection term; its 0.2 and 0.1 ms runs differ 2.2e-3 "
            "(measured 3.2e-3)"),
        Row("V08-x", title, ref.S2_SOURCE, model, "position of the first lift-off", "m",
            ref.S2_FIRST_LIFT_OFF, float(x_off), 1e-3, "peer figure to 1 cm (up to 4e-4) and "
            "v dt = 2.8 mm (2e-4); the lift-off point does not depend on the contact "
            "stiffness"),
    ]


# ------------------------------------------------------------------ V16-V18 decks in space
#: The deck in space of V16-V18: a 24 m fork-supported span (f1 = 3.05 Hz in bending,
#: 6.59 Hz in torsion), its tracks at +-2.5 m (V16, V17) or +-2.0 m (V18).
_SPACE = dict(L=24.0, EI=1.5e10, m=1.2e4, zeta=0.01, GJ=6.0e9, Ip=6.0e4, zeta_t=0.01)


def _space_bridge(points, tracks, n_bending, n_torsion):
    p = _SPACE
    tr = ", ".join(f"{{ eccentricity = {y!r} }}" for y in tracks)
    return (_ss_bridge(p["L"], p["EI"], p["m"], p["zeta"], n_bending, points)
            + f"        tracks = [{tr}]\n"
            + f"        torsion = {{ GJ = {p['GJ']!r}, polar_mass = {p['Ip']!r}, "
              f"damping_ratio = {p['zeta_t']!r}, n_modes = {n_torsion} }}\n")


def _space_run(dt, speed_kmh, free, approach=0.0):
    return f"""
        [track]
        model = "rigid"
        [solver]
        dt = {dt!r}
        hht_alpha = 0.0
        approach = {approach!r}
        free_vibration = {free!r}
        [study]
        speeds_kmh = [{float(speed_kmh)!r}]
        save_time_histories = false
        """


def _space_reference(forces, n_bending, n_torsion, t_end, dt):
    """The deck's modal response to ``forces`` (rows P, y, x0, u) on a grid dt / 4."""
    p = _SPACE
    t = np.linspace(0.0, t_end, int(round(4 * t_end / dt)) + 1)
    return ref.deck_in_space_forces(forces, p["L"], p["EI"], p["m"], p["zeta"], n_bending,
                                    p["GJ"], p["Ip"], p["zeta_t"], n_torsion, t)


_SPACE_IVP = ("solve_ivp (DOP853, rtol 1e-10) of the closed-form bending and St-Venant "
              "torsion sine modes under the moving forces, "
              "vsi_numba.verification.reference.deck_in_space_forces")


_SPACE_CONVERGED = (_SPACE_IVP + " for the bending; the torsion converged: 400 "
                    "torsional modes' exact responses, the twist and rotation by the "
                    "mode-acceleration formula with the closed-form static rotation, "
                    "vsi_numba.verification.reference.fork_torsion_moving_forces")
_TRUNCATED = ("the torsional modes above those kept: at a torsional resonance every "
              "torsional mode is resonant too (f_j = j f_t1), which no static correction "
              "carries; measured ")
#: V16's tolerances (relative) and measured errors (the plain modal sum: -3.8e-2 and
#: -5.4e-3 against the same reference)
V16_TOL = (8e-2, 1e-2)
V16_MEASURED = ("+5.3e-2 (safe side; the plain modal sum before: +9.5e-2)", "-4.0e-3")


def v16_torsion(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.5, 3, 4
    n_f, d, P, dt, free = 8, 12.0, 1.5e5, 2.5e-4, 0.3
    f_t = ref.fork_torsion_frequencies(L, p["GJ"], p["Ip"], n_t)
    v = float(f_t[0] * d)  # the first torsional resonance
    x_twist, x_line = 4.0, 12.0
    text = (_space_bridge([x_twist, x_line], [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + _forces([k * d for k in range(n_f)], P) + _space_run(dt, v * 3.6, free))
    ds = sweep(workdir, "v16_torsion", text).isel(speed=0, train=0, irregularity=0)
    freq = np.asarray(ds["frequency"].values, float).ravel()
    forces = [(P, ecc, -k * d, v) for k in range(n_f)]
    res = _space_reference(forces, n_b, n_t, (L + (n_f - 1) * d) / v + free, dt)
    # the converged torsion (400 modes, mode acceleration) with the bending of the ivp
    tor = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, res["t"])
    th, tw, _ = ref.fork_torsion_channels(tor, [x_twist, x_line])
    twist = float(np.abs(tw[:, 0]).max())
    w = ref.deck_in_space_line(res, [x_line], 0.0)[0].ravel() + ecc * th[:, 1]
    a = ref.deck_in_space_line(res, [x_line], ecc)[1]
    title = (f"Torsion of a {L:g} m fork-supported span with a track at {ecc:g} m: "
             f"{n_f} forces of {P / 1e3:g} kN at d = {d:g} m, v = f_t1 d = "
             f"{v * 3.6:.1f} km/h")
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             f"HHT alpha = 0, dt {dt * 1e3:g} ms")
    src_f = ("St-Venant torsion of a fork-supported span, f_j = (j pi / L) sqrt(GJ / I_p) "
             "/ (2 pi), vsi_numba.verification.reference.fork_torsion_frequencies")
    reason_f = ("closed form in the model too: round-off of the file's frequency; "
                "measured 0")
    reason = ("the resonance builds up over 8 cycles: the trapezoidal rule's period error "
              "(w dt)^2/12 a cycle and the peak sampled at dt; measured ")
    rows = []
    for j in range(n_t):
        got = freq[int(np.argmin(abs(freq - f_t[j])))]
        rows.append(Row(f"V16-f{j + 1}", title, src_f, model,
                        f"torsional frequency {j + 1} (nearest of the file's frequency)",
                        "Hz", float(f_t[j]), float(got), 1e-12, reason_f))
    dsel = ds.sel(track=1)
    rows += [
        Row("V16-twist", title, _SPACE_CONVERGED, model, f"max deck twist over 3 m from "
            f"x = {x_twist:g} m", "m", twist,
            float(dsel["max_deck_twist"].sel(point=x_twist).values), V16_TOL[0],
            _TRUNCATED + V16_MEASURED[0]),
        Row("V16-w", title, _SPACE_CONVERGED, model, f"max displacement of the track line "
            f"at x = {x_line:g} m", "m", float(np.abs(w).max()),
            float(dsel["max_track_displacement"].sel(point=x_line).values), V16_TOL[1],
            _TRUNCATED + V16_MEASURED[1]),
        Row("V16-a", title, _SPACE_IVP, model, f"max |acceleration| of the track line at "
            f"x = {x_line:g} m (every mode below the 30 Hz cut-off)", "m/s2",
            float(np.abs(a).max()),
            float(dsel["max_track_acceleration"].sel(point=x_line).values), 2e-4,
            reason + "8.0e-5"),
    ]
    return rows


def v17_crawl_twist(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t, P, approach = p["L"], 2.5, 3, 40, 2.0e5, 1.0
    points = [4.0, 10.5]
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n" + _forces([0.0], P)
            + _space_run(1e-3, 3.0, 0.2, approach))
    ds = sweep(workdir, "v17_crawl_twist", text).isel(speed=0, train=0, irregularity=0)
    title = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of a "
             f"{L:g} m fork-supported span: a point torque P e")
    src = ("St-Venant rotation of a point torque on a fork-supported span, theta(x) = "
           "P e x (L - a) / (GJ L) for x <= a, max twist at a = x or x + 3 m, "
           "vsi_numba.verification.reference.point_torque_twist")
    model = (f"moving force on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             "HHT alpha = 0, dt 1 ms")
    src_n = (f"the sine series of the same rotation truncated to the {n_t} torsional "
             "modes kept, the torque moved in 1 mm steps, "
             "vsi_numba.verification.reference.point_torque_twist")
    del src_n
    measured = {4.0: "-7.9e-5", 10.5: "+5.5e-5"}
    rows = []
    for i, x in enumerate(points):
        closed = ref.point_torque_twist(P * ecc, p["GJ"], L, x)
        series = ref.point_torque_twist(P * ecc, p["GJ"], L, x, n_modes=n_t)
        got = float(ds["max_deck_twist"].sel(track=1, point=x).values)
        what = f"max deck twist over 3 m from x = {x:g} m"
        rows.append(
            Row(f"V17-twist-{i + 1}", title, src, model, what, "m", closed, got, 3e-4,
                "mode acceleration: the static rotation is the closed form, the modes "
                "add the dynamic part at 3 km/h, the torque's positions sampled at "
                f"v dt = 0.83 mm (the plain series of the {n_t} modes kept is "
                f"{series / closed - 1:+.1e} off); measured {measured[x]}"))
    return rows


_TRUNCATED_V18 = ("the converged torsion (400 modes) against the 4 kept with the "
                  "static correction: the truncated modes' dynamic part; measured ")


def v18_trains_meeting(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.0, 3, 4
    n_f, d, P, off, kmh, dt, free = 5, 8.0, 1.5e5, 10.0, 160.0, 2.5e-4, 0.3
    v = kmh / 3.6
    x = L / 2
    text = (_space_bridge([x], [ecc, -ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + f'other_trains = [{{ track = 2, direction = "opposite", offset = {off!r} }}]\n'
            + _forces([k * d for k in range(n_f)], P) + _space_run(dt, kmh, free))
    ds = sweep(workdir, "v18_trains_meeting", text).isel(speed=0, train=0, irregularity=0)
    forces = ([(P, ecc, -k * d, v) for k in range(n_f)]
              + [(P, -ecc, L + off + k * d, -v) for k in range(n_f)])
    res = _space_reference(forces, n_b, n_t, (L + (n_f - 1) * d + off) / v + free, dt)
    w0, _ = ref.deck_in_space_line(res, [x], 0.0)
    # the converged torsion of each train (the one in -x mirrored: x' = L - x)
    fwd = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, res["t"])
    rev = ref.fork_torsion_moving_forces([off + k * d for k in range(n_f)], P, -ecc, L,
                                         p["GJ"], p["Ip"], p["zeta_t"], v, res["t"])
    th = (ref.fork_torsion_channels(fwd, [x])[0][:, 0]
          + ref.fork_torsion_channels(rev, [L - x])[0][:, 0])
    w1 = w0.ravel() + ecc * th
    w2 = w0.ravel() - ecc * th
    moment = ref.deck_in_space_moment(res, x)
    title = (f"Trains meeting on a twisting {L:g} m deck: {n_f} forces of {P / 1e3:g} kN at "
             f"d = {d:g} m on each track (+-{ecc:g} m), the second in -x {off:g} m behind, "
             f"{kmh:g} km/h")
    model = (f"moving forces on tracks 1 and 2 (other_trains, superposed), {n_b} bending + "
             f"{n_t} torsional modes (1 %), mode acceleration, HHT alpha = 0, "
             f"dt {dt * 1e3:g} ms")
    src = _SPACE_IVP + " (all ten forces at once); the moment by deck_in_space_moment"
    reason = ("HHT alpha = 0 at dt 0.25 ms (no resonance: 5.6 forces a second on each "
              "track, f1 = 3.05 Hz, f_t1 = 6.59 Hz) and the peak sampled at dt; measured ")
    at = dict(point=x)
    return [
        Row("V18-w-axis", title, src, model, f"max deck (axis) displacement at x = {x:g} m, "
            "both trains", "m", float(np.abs(w0).max()),
            float(ds["max_deck_displacement_all_tracks"].sel(**at).values), 3e-5,
            reason + "1.1e-5"),
        Row("V18-w-track1", title, src, model, f"max displacement of track 1 at x = {x:g} m,"
            " both trains", "m", float(np.abs(w1).max()),
            float(ds["max_track_displacement_all_tracks"].sel(track=1, **at).values), 3e-3,
            _TRUNCATED_V18 + "1.3e-3 (the plain modal sum before: 5.6e-3)"),
        Row("V18-w-track2", title, src, model, f"max displacement of track 2 at x = {x:g} m,"
            " both trains", "m", float(np.abs(w2).max()),
            float(ds["max_track_displacement_all_tracks"].sel(track=2, **at).values), 1.5e-3,
            _TRUNCATED_V18 + "5.8e-4 (the plain modal sum before: 1.2e-3)"),
        Row("V18-M", title, src, model, f"max bending moment at x = {x:g} m, both trains",
            "N m", float(moment.max()),
            float(ds["max_bending_moment_all_tracks"].sel(**at).values), 4e-6,
            reason + "1.4e-6"),
    ]


# ------------------------------------------------------------------ V19-V20 mode acceleration
#: V19-V20 measured errors and tolerances (relative), against the converged references.
V19_MEASURED = {"crawl": "3.3e-4 (the plain modal sum before: -1.5e-2 .. -1.0e-1)",
                "res": "+5.3e-2 .. +6.7e-2, safe side (the plain modal sum before: "
                       "-1.2e-1 .. +9.9e-2)"}


def _space_continuous(points, ecc, n_bending, n_torsion, spans):
    p = _SPACE
    torsion = (f"{{ GJ = {p['GJ']!r}, polar_mass = {p['Ip']!r}, "
               f"damping_ratio = {p['zeta_t']!r}, n_modes = {n_torsion} }}")
    return f"""
        [bridge]
        kind = "continuous"
        spans = {list(spans)!r}
        EI = {p['EI']!r}
        mass_per_length = {p['m']!r}
        damping_ratio = {p['zeta']!r}
        n_modes = {n_bending}
        elements_per_span = 40
        output_points = {list(points)!r}
        tracks = [{{ eccentricity = {ecc!r} }}]
        torsion = {torsion}
        """


def v19_continuous_twist(workdir: Path) -> list[Row]:
    p = _SPACE
    spans, ecc, n_b, n_t = (24.0, 24.0), 2.5, 4, 8
    points = [4.0, 10.5, 34.5]
    P = 2.0e5
    title_c = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of a "
               "24 + 24 m continuous deck, torsion restrained at the supports")
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), FE "
             "40 elements a span, mode acceleration, HHT alpha = 0")
    text = (_space_continuous(points, ecc, n_b, n_t, spans) + "[train]\ntrack = 1\n"
            + _forces([0.0], P) + _space_run(2e-3, 3.0, 0.0))
    ds = sweep(workdir, "v19_crawl", text).isel(speed=0, train=0, irregularity=0)
    src_c = ("St-Venant rotation of a point torque P e on each fork-supported span, the "
             "force moved in 1 mm steps, "
             "vsi_numba.verification.reference.fork_spans_crawl_twist")
    closed = ref.fork_spans_crawl_twist(spans, P, ecc, p["GJ"], points)
    grid = np.asarray(ds["twist_x"].values, float)
    closed_g = ref.fork_spans_crawl_twist(spans, P, ecc, p["GJ"], grid).max()
    rows = [Row(f"V19-crawl-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"max deck twist over 3 m from x = {x:g} m", "m", float(closed[i]),
                float(ds["max_deck_twist"].sel(track=1, point=x).values), 1e-3,
                "the dynamic part at 3 km/h and the FE torsion field (linear elements) "
                "between nodes; measured " + V19_MEASURED["crawl"])
            for i, x in enumerate(points)]
    rows.append(Row("V19-crawl-whole", title_c, src_c, model + ", dt 2 ms",
                    "max deck twist over 3 m, whole-deck grid", "m", float(closed_g),
                    float(ds["max_deck_twist_whole_deck"].sel(track=1).max().values), 1e-3,
                    "as above; measured " + V19_MEASURED["crawl"]))
    # the first torsional resonance: eight forces d = 12 m apart at v = f_t1 d
    n_f, d, dt, free = 8, 12.0, 2.5e-4, 0.3
    f_t1 = float(ref.fork_torsion_frequencies(spans[0], p["GJ"], p["Ip"], 1)[0])
    v = f_t1 * d
    text = (_space_continuous(points, ecc, n_b, n_t, spans) + "[train]\ntrack = 1\n"
            + _forces([k * d for k in range(n_f)], 1.5e5) + _space_run(dt, v * 3.6, free))
    ds = sweep(workdir, "v19_resonance", text).isel(speed=0, train=0, irregularity=0)
    t = np.arange(0.0, (sum(spans) + (n_f - 1) * d) / v + free, dt / 2)
    tw = ref.fork_spans_twist(spans, [k * d for k in range(n_f)], 1.5e5, ecc, p["GJ"],
                              p["Ip"], p["zeta_t"], v, t, points)
    title_r = (f"{n_f} forces of 150 kN at d = {d:g} m at the first torsional resonance "
               f"(v = f_t1 d = {v * 3.6:.1f} km/h) on the continuous deck of V19")
    src_r = ("each span a fork-supported span: 400 torsional modes' exact responses, the "
             "twist by the mode-acceleration formula with the closed-form static rotation, "
             "vsi_numba.verification.reference.fork_spans_twist")
    for i, x in enumerate(points):
        rows.append(Row(f"V19-res-{i + 1}", title_r, src_r, model + f", dt {dt * 1e3:g} ms",
                        f"max deck twist over 3 m from x = {x:g} m", "m",
                        float(np.abs(tw[:, i]).max()),
                        float(ds["max_deck_twist"].sel(track=1, point=x).values),
                        V19_RES_TOL, _TRUNCATED + V19_MEASURED["res"]))
    return rows


V19_RES_TOL = 0.1


def v20_torque(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.5, 3, 6
    points = [3.0, 6.0, 12.0]
    P = 2.0e5
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             "mode acceleration with the speed factor 1 / (1 - (v/c)^2), HHT alpha = 0")
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + _forces([0.0], P) + _space_run(2e-3, 3.0, 0.0))
    ds = sweep(workdir, "v20_crawl", text).isel(speed=0, train=0, irregularity=0)
    title_c = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of the "
               f"{L:g} m fork-supported span of V16: the St-Venant torsional moment")
    src_c = ("static St-Venant torque of a point torque P e on a fork-supported span: "
             "P e (1 - a/L) left of it, -P e a/L right of it; largest P e (1 - x/L), "
             "smallest -P e x/L")
    Pe = P * ecc
    rows = []
    for i, x in enumerate(points):
        rows += [
            Row(f"V20-crawl-max-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"max torsional moment at x = {x:g} m", "N m", Pe * (1 - x / L),
                float(ds["max_torsional_moment"].sel(point=x).values), 1e-3,
                "the dynamic part at 3 km/h and the load's positions sampled at v dt; "
                "measured " + V20_MEASURED["crawl"]),
            Row(f"V20-crawl-min-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"min torsional moment at x = {x:g} m", "N m", -Pe * x / L,
                float(ds["min_torsional_moment"].sel(point=x).values), 5e-3,
                "as above; measured " + V20_MEASURED["crawl"])]
    # at speed: eight forces d = 12 m apart at 200 km/h (v/c = 0.18)
    n_f, d, dt, free, kmh = 8, 12.0, 2.5e-4, 0.3, 200.0
    v = kmh / 3.6
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + _forces([k * d for k in range(n_f)], P) + _space_run(dt, kmh, free))
    ds = sweep(workdir, "v20_speed", text).isel(speed=0, train=0, irregularity=0)
    t = np.arange(0.0, (L + (n_f - 1) * d) / v + free, dt / 2)
    res = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, t)
    tq = ref.fork_torsion_channels(res, points)[2]
    title_s = (f"{n_f} forces of {P / 1e3:g} kN at d = {d:g} m at {kmh:g} km/h on the span "
               "of V16: the St-Venant torsional moment")
    src_s = ("400 torsional modes' exact responses, the torque by the mode-acceleration "
             "formula with the closed-form static torque, "
             "vsi_numba.verification.reference.fork_torsion_moving_forces")
    for i, x in enumerate(points):
        for ext, fn in (("max", np.max), ("min", np.min)):
            rows.append(Row(f"V20-speed-{ext}-{i + 1}", title_s, src_s,
                            model + f", dt {dt * 1e3:g} ms",
                            f"{ext} torsional moment at x = {x:g} m", "N m",
                            float(fn(tq[:, i])),
                            float(ds[f"{ext}_torsional_moment"].sel(point=x).values),
                            V20_SPEED_TOL, "the torque fronts a force sends off along the "
                            "span when it enters or leaves it, carried by the kept modes "
                            "only; measured " + V20_MEASURED["speed"]))
    return rows


V20_MEASURED = {"crawl": "2.4e-4 (max), 2.1e-3 (min at x = 3 m: 2.6e-4 of P e)",
                "speed": "-6.5e-2 .. +2.2e-2, at most 1.4e-2 of P e (without the speed "
                         "factor before: -8.9e-2 .. +1.7e-2)"}
V20_SPEED_TOL = 0.1


CASES: tuple[Case, ...] = (
    Case("V01", "Moving force on a simply supported beam (Frýba)", True, v01_fryba),
    Case("V02", "Sprung mass on a simply supported beam (Yang & Wu)", True, v02_yang_wu),
    Case("V03", "Load effects of a simply supported span at crawl speed", True,
         v03_ss_effects),
    Case("V04", "Load effects of a two-span continuous deck at crawl speed", False,
         v04_continuous),
    Case("V05", "Resonance of a train of equal forces", True, v05_resonance),
    Case("V06", "Cancellation of the resonance of a train of equal forces", False,
         v06_cancellation),
    Case("V07", "HSLM-A1 at resonance on a simply supported span", False, v07_hslm),
    Case("V08", "Lift-off on a rail dip against OpenSees (peer case S2)", False,
         v08_opensees_dip),
    Case("V09", "Quarter car with wheel mass and damping on a damped beam", False,
         v09_quarter_car),
    Case("V10", "Nonlinear suspension: a bump stop that closes over a bump", False,
         v10_bump_stop),
    Case("V11", "LM71 static load effects on a simply supported span", False, v11_lm71),
    Case("V12", "Second-order convergence in the time step (HHT alpha = 0)", False,
         v12_order),
    Case("V13", "A deck imported as a modes table (CSV) under a moving force", False,
         v13_imported_modes),
    Case("V14", "Second resonance of a train of equal forces (v = n0 d / 2)", False,
         v14_second_resonance),
    Case("V15", "Hertz contact and a light wheel against OpenSees (peer case S1)", False,
         v15_opensees_s1),
    Case("V16", "Torsion of a simply supported deck with an eccentric track", False,
         v16_torsion),
    Case("V17", "Crawl twist of a point torque", True, v17_crawl_twist),
    Case("V18", "Trains meeting on a twisting deck", True, v18_trains_meeting),
    Case("V19", "Twist of a continuous deck at crawl speed and at a torsional resonance",
         False, v19_continuous_twist),
    Case("V20", "Torsional moment at crawl speed and at speed", False, v20_torque),
    Case("V21", "Calibration on three synthetic passages: the truth recovered", False,
         lambda w: _existing.v21_calibration(w, Row)),
    Case("V21Q", "Calibration on one synthetic passage (short chain)", True,
         lambda w: _existing.v21_calibration(w, Row, quick=True)),
    Case("V22", "Probability of exceedance at 1e-3: subset simulation and Monte Carlo "
         "against the closed form", False, lambda w: _existing.v22_reliability(w, Row)),
    Case("V22Q", "Probability of exceedance at 0.03 by Monte Carlo against the closed "
         "form", True, lambda w: _existing.v22_reliability(w, Row, quick=True)),
)
