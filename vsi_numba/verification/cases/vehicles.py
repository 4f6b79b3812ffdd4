"""Vehicles on a simply supported beam: the sprung mass of Yang & Wu (V02), the
OpenSees peer cases (V08 lift-off on a dip, V15 Hertz contact), the quarter car (V09),
the bump stop (V10) and the second-order convergence in the time step (V12)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.verification import reference as ref
from vsi_numba.verification.cases.common import Row, ss_bridge, sweep


# ------------------------------------------------------------------ V02 Yang & Wu sprung mass
def v02_yang_wu(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    text = ss_bridge(p["L"], p["EI"], p["m"], 0.0, 10, [p["L"] / 2]) + f"""
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


# ------------------------------------------------------------------ V08 OpenSees dip (S2)
def v08_opensees_dip(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    G = 4.57e-8 * 0.4575 ** (-0.149)
    text = ss_bridge(p["L"], p["EI"], p["m"], 0.0, 20, [p["L"] / 2]) + f"""
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


# ------------------------------------------------------------------ V09 quarter car
def v09_quarter_car(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach, zeta, c, m_w = 1.0, 0.02, 2.0e4, 1000.0
    text = ss_bridge(p["L"], p["EI"], p["m"], zeta, 10, [p["L"] / 2]) + f"""
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
        text = ss_bridge(p["L"], p["EI"], p["m"], 0.0, n_modes, [p["L"] / 2]) + f"""
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


# ------------------------------------------------------------------ V15 OpenSees S1 (Hertz)
def v15_opensees_s1(workdir: Path) -> list[Row]:
    p = ref.YANG_WU
    approach = 1.0
    G = 4.57e-8 * 0.4575 ** (-0.149)
    text = ss_bridge(p["L"], p["EI"], p["m"], 0.0, 20, [p["L"] / 2]) + f"""
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
