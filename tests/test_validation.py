"""Validation of the engine against independent reference solutions.

Every reference is computed here by ``tests/reference.py`` (numpy/scipy only: closed
forms, ``solve_ivp`` of the coupled equations, an event-driven contact solution,
analytic beam frequencies, lever-rule statics), never taken from the engine's output.
Each tolerance carries a one-line reason.

Time origin: the engine's ``t = 0`` has the first axle at ``x = -approach``; the
references are started at the same point (``x_start = -approach``) or shifted by
``approach / v``.
"""

from __future__ import annotations

import numpy as np
import pytest
import reference as ref

from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import cosine_defect, no_irregularity
from vsi_numba.solver.simulate import SolverSettings, simulate

G = ref.GRAVITY


def _run(bridge, vehicles, speed, *, dt, alpha=0.0, approach=5.0, free_vibration=0.5,
         profile=None, points=None, offsets=None):
    vehicles = tuple(vehicles) if isinstance(vehicles, (list, tuple)) else (vehicles,)
    offsets = tuple(offsets) if offsets is not None else (0.0,) * len(vehicles)
    train = vh.Train(name="validation", vehicles=vehicles, offsets=offsets)
    settings = SolverSettings(dt=dt, hht_alpha=alpha, approach=approach,
                              free_vibration=free_vibration)
    ds = simulate(bridge, train, speed=speed,
                  profile=profile if profile is not None else no_irregularity(),
                  settings=settings, output_points=points)
    assert ds.attrs["status"] == 0, ds.attrs.get("message")
    return ds


def _events_from_flags(time, flags, x_of_t):
    """(kind, x) of each contact change; x midway between the two samples."""
    f = np.asarray(flags).astype(int)
    idx = np.flatnonzero(np.diff(f) != 0)
    out = []
    for i in idx:
        kind = "detach" if f[i] == 1 else "attach"
        out.append((kind, 0.5 * (x_of_t(time[i]) + x_of_t(time[i + 1]))))
    return out


# ------------------------------------------------------------------ moving force

MF_BEAM = dict(L=20.0, m=10000.0, f1=5.0)
MF_BEAM["EI"] = MF_BEAM["m"] * (2 * np.pi * MF_BEAM["f1"] / (np.pi / MF_BEAM["L"]) ** 2) ** 2


@pytest.mark.parametrize("alpha", [0.2, 0.5, 0.62, 1.0, 1.5])
def test_moving_force__peak_midspan_deflection_matches_fryba_series(alpha):
    L, EI, m, f1 = MF_BEAM["L"], MF_BEAM["EI"], MF_BEAM["m"], MF_BEAM["f1"]
    P, n, approach = 1.7e5, 10, 1.0
    v = alpha * 2.0 * f1 * L
    beam = br.simply_supported(L, EI, m, n_modes=n, damping_ratio=0.0)
    ds = _run(beam, vh.moving_force(P), v, dt=5e-4, approach=approach, free_vibration=0.3,
              points=[0.5 * L])
    t = ds.time.values
    w_eng = ds.deck_displacement.isel(point=0).values
    # same 10-mode series, same sampling instants, force entering at t = approach / v
    w_ref = ref.moving_force_series(P, L, EI, m, v, [0.5 * L], t - approach / v, n)[:, 0]
    # trapezoidal period error (w dt)^2/12: 2e-5 for mode 1, 2e-3 for mode 3 (whose free
    # vibration matters at alpha = 1.5, where the peak comes after the passage); observed
    # <= 1e-3: 0.5 % on the peak as asked
    assert w_eng.max() == pytest.approx(w_ref.max(), rel=5e-3)
    # whole history incl. 0.3 s of free vibration: phase drift of modes 3-5 (observed
    # <= 3e-3 of the peak)
    np.testing.assert_allclose(w_eng, w_ref, atol=1e-2 * w_ref.max())


# ------------------------------------------------------------------ sprung mass / quarter car

VBI_BEAM = dict(L=25.0, EI=8.323e9, m=2303.0)  # f1 = 4.78 Hz
VBI_CAR = dict(body_mass=5750.0, stiffness=1.595e6)  # 2.65 Hz
VBI_V = 25.0  # m/s; entry at t = 0.2 s, exit at 1.2 s: on every time grid used below
VBI_APPROACH = 5.0


@pytest.fixture(scope="module")
def sprung_mass_reference():
    n, t_end = 5, (VBI_BEAM["L"] + VBI_APPROACH) / VBI_V + 0.5
    return ref.sprung_mass_crossing(VBI_CAR["body_mass"], VBI_CAR["stiffness"], 0.0,
                                    **VBI_BEAM, speed=VBI_V, n_modes=n, t_end=t_end,
                                    x_start=-VBI_APPROACH)


def test_sprung_mass__crossing_simply_supported_beam_matches_solve_ivp(sprung_mass_reference):
    L = VBI_BEAM["L"]
    beam = br.simply_supported(L, VBI_BEAM["EI"], VBI_BEAM["m"], n_modes=5)
    car = vh.sprung_mass(VBI_CAR["body_mass"], VBI_CAR["stiffness"], 0.0, wheel_mass=0.0)
    ds = _run(beam, car, VBI_V, dt=2.5e-4, approach=VBI_APPROACH, points=[0.5 * L])
    t = ds.time.values
    e = sprung_mass_reference.evaluate(t)
    w_ref, a_ref = e["deck_displacement"][:, 0], e["body_acceleration"]
    w = ds.deck_displacement.isel(point=0).values
    a = ds.carbody_acceleration.isel(vehicle=0).values
    # HHT alpha = 0 at dt = 2.5e-4: O(dt^2) errors ~1e-3 of peak; 1 % of peak per brief
    np.testing.assert_allclose(w, w_ref, atol=1e-2 * np.abs(w_ref).max())
    np.testing.assert_allclose(a, a_ref, atol=1e-2 * np.abs(a_ref).max())
    # contact force of the massless contact point = suspension force: its dynamic part
    # (P - Mg, ~3 % of Mg here) within 2 % of its peak (a differenced, smaller quantity)
    P = ds.contact_force.isel(wheel=0).values
    Mg = VBI_CAR["body_mass"] * G
    dP_ref = e["contact_force"] - Mg
    np.testing.assert_allclose(P - Mg, dP_ref, atol=2e-2 * np.abs(dP_ref).max())


QC_ON_BEAM = dict(c=1e4, mw=1000.0, n=5)


@pytest.fixture(scope="module")
def quarter_car_reference():
    t_end = (VBI_BEAM["L"] + VBI_APPROACH) / VBI_V + 0.5
    return ref.quarter_car_crossing(VBI_CAR["body_mass"], VBI_CAR["stiffness"],
                                    QC_ON_BEAM["c"], QC_ON_BEAM["mw"], **VBI_BEAM, speed=VBI_V,
                                    n_modes=QC_ON_BEAM["n"], t_end=t_end, x_start=-VBI_APPROACH)


def _quarter_car_run(dt, alpha):
    L = VBI_BEAM["L"]
    beam = br.simply_supported(L, VBI_BEAM["EI"], VBI_BEAM["m"], n_modes=QC_ON_BEAM["n"])
    car = vh.sprung_mass(VBI_CAR["body_mass"], VBI_CAR["stiffness"], QC_ON_BEAM["c"],
                         wheel_mass=QC_ON_BEAM["mw"])
    return _run(beam, car, VBI_V, dt=dt, alpha=alpha, approach=VBI_APPROACH, points=[0.5 * L])


def test_quarter_car__crossing_simply_supported_beam_matches_solve_ivp(quarter_car_reference):
    dt = 2.5e-4
    ds = _quarter_car_run(dt, 0.0)
    t = ds.time.values
    e = quarter_car_reference.evaluate(t)
    w_ref, a_ref = e["deck_displacement"][:, 0], e["body_acceleration"]
    w = ds.deck_displacement.isel(point=0).values
    a = ds.carbody_acceleration.isel(vehicle=0).values
    # O(dt^2) errors ~2e-4 of peak; 1 % of peak per brief
    np.testing.assert_allclose(w, w_ref, atol=1e-2 * np.abs(w_ref).max())
    # while the wheel is on the deck (the exit is tested on its own below)
    t_exit = (VBI_BEAM["L"] + VBI_APPROACH) / VBI_V
    on = t < t_exit
    np.testing.assert_allclose(a[on], a_ref[on], atol=1e-2 * np.abs(a_ref).max())
    # contact force: its dynamic part is only ~1.5 % of the static load here and the
    # wheel-inertia term m_w y'' carries the O((w5 dt)^2) ~ 3 % acceleration error of the
    # highest mode: 0.5 % of the static load
    P = ds.contact_force.isel(wheel=0).values
    Q0 = (VBI_CAR["body_mass"] + QC_ON_BEAM["mw"]) * G
    np.testing.assert_allclose(P[on], e["contact_force"][on], atol=5e-3 * Q0)


def test_quarter_car__leaving_the_deck_is_a_consistent_impact(quarter_car_reference):
    """At the far support the deflected deck's slope meets level track: the rail velocity
    under the wheel jumps (by v phi'(L) q), so the wheel velocity must jump with it, as
    at a landing (docs/manual/theory.md, "Contact and impacts": velocity-level impact
    solve).  The reference does exactly that; afterwards the contact force is the static
    load plus the slowly varying suspension force.  A scheme that only imposes the displacement
    constraint leaves a
    velocity inconsistency that makes the contact force ring at the Nyquist frequency
    (and, with alpha = 0, grow until a spurious lift-off)."""
    dt = 2.5e-4
    ds = _quarter_car_run(dt, -0.1)  # the robust default alpha
    t = ds.time.values
    t_exit = (VBI_BEAM["L"] + VBI_APPROACH) / VBI_V
    after = (t >= t_exit + 2 * dt) & (t <= t_exit + 0.2)  # the impulse itself: <= 1 step
    e = quarter_car_reference.evaluate(t[after])
    P = ds.contact_force.isel(wheel=0).values[after]
    Q0 = (VBI_CAR["body_mass"] + QC_ON_BEAM["mw"]) * G
    assert ds.in_contact.isel(wheel=0).values[after].all()
    # the wheel velocity jump is ~6e-4 m/s: nothing physical moves the force by > 1 %
    np.testing.assert_allclose(P, e["contact_force"], atol=1e-2 * Q0)
    a = ds.carbody_acceleration.isel(vehicle=0).values[after]
    a_ref = quarter_car_reference.evaluate(t)["body_acceleration"]
    np.testing.assert_allclose(a, e["body_acceleration"], atol=1e-2 * np.abs(a_ref).max())


# ------------------------------------------------------------------ loss of contact, rigid track

QC = dict(body_mass=2000.0, stiffness=3e6, damping=1e4, wheel_mass=500.0)  # 6.2 Hz body


def test_contact_loss__rigid_track_cosine_dip_matches_event_driven_solution():
    v, approach, length = 30.0, 5.0, 25.0
    depth, lam, x0 = 0.03, 4.0, 5.0
    dt = 2.5e-4
    car = vh.sprung_mass(QC["body_mass"], QC["stiffness"], QC["damping"],
                         wheel_mass=QC["wheel_mass"])
    ds = _run(br.rigid(length), car, v, dt=dt, alpha=-0.1, approach=approach,
              free_vibration=0.1, profile=cosine_defect(depth, lam, x0), points=[0.0])
    t = ds.time.values
    ed = ref.quarter_car_rigid_dip_event_driven(
        **QC, speed=v, profile=ref.CosineDip(depth, lam, x0), t_end=t[-1], x_start=-approach)
    x_end = -approach + v * t[-1] - 1.0  # compare events at least 1 m before the end
    ref_events = [(e.kind, e.x) for e in ed.events if e.x < x_end]
    assert len(ref_events) >= 6  # several lift-offs and landings (self-check of the case)
    eng_events = [(k, x) for k, x in _events_from_flags(
        t, ds.in_contact.isel(wheel=0).values, lambda tt: -approach + v * tt) if x < x_end]
    assert [k for k, _ in eng_events] == [k for k, _ in ref_events], (eng_events, ref_events)
    # event positions within 2 % of the dip length (8 cm = 10 steps of travel at this dt)
    np.testing.assert_allclose([x for _, x in eng_events], [x for _, x in ref_events],
                               atol=0.02 * lam)
    # body acceleration within 2 % of its peak, away from the events (the damper force
    # jumps with the wheel velocity at each landing: skip +-3 steps around them)
    e = ed.evaluate(t)
    a_ref = e["body_acceleration"]
    a = ds.carbody_acceleration.isel(vehicle=0).values
    keep = np.ones(t.size, bool)
    for te in ed.event_times:
        keep &= np.abs(t - te) > 3 * dt
    np.testing.assert_allclose(a[keep], a_ref[keep], atol=2e-2 * np.abs(a_ref).max())


# ------------------------------------------------------------------ loss of contact, flexible deck


def test_contact_loss__flexible_deck_first_detachment_where_bilateral_force_vanishes():
    L, m, f1, n, zeta = 12.0, 3000.0, 6.0, 4, 0.02
    EI = m * (2 * np.pi * f1 / (np.pi / L) ** 2) ** 2
    v, approach, dt = 30.0, 5.0, 2.5e-4
    depth, lam, x0 = 0.03, 4.0, 4.0
    beam = br.simply_supported(L, EI, m, n_modes=n, damping_ratio=zeta)
    car = vh.sprung_mass(QC["body_mass"], QC["stiffness"], QC["damping"],
                         wheel_mass=QC["wheel_mass"])
    ds = _run(beam, car, v, dt=dt, alpha=-0.1, approach=approach, free_vibration=0.2,
              profile=cosine_defect(depth, lam, x0), points=[0.5 * L])
    t = ds.time.values
    prof = ref.CosineDip(depth, lam, x0)
    t_ref_end = (x0 + lam + approach) / v
    bil = ref.quarter_car_crossing(*QC.values(), L=L, EI=EI, m=m, speed=v, n_modes=n,
                                   t_end=t_ref_end, x_start=-approach, zeta=zeta, profile=prof)
    t_loss = bil.first_loss_of_contact(np.arange(0.0, t_ref_end, 1e-4))
    x_loss = -approach + v * t_loss
    assert x0 + 0.1 < x_loss < x0 + lam  # inside the dip, decided by the dynamics
    flags = ds.in_contact.isel(wheel=0).values
    i = int(np.flatnonzero(flags == 0)[0])
    x_eng = -approach + v * t[i]  # first sample found separated
    # the engine finds the separation at the end of the step in which it happens
    # (0 to 1 step of travel after it), plus O(dt^2) drift of the contact force
    assert x_loss - v * dt <= x_eng <= x_loss + 3 * v * dt
    # up to the separation the engine follows the bilateral solution (1 % of peak)
    before = t < t_loss - dt
    e = bil.evaluate(t[before])
    w_ref = e["deck_displacement"][:, 0]
    np.testing.assert_allclose(ds.deck_displacement.isel(point=0).values[before], w_ref,
                               atol=1e-2 * np.abs(w_ref).max())
    # the deck matters: on rigid ground the same car would lift off elsewhere
    rigid = ref.quarter_car_crossing(*QC.values(), L=L, EI=EI, m=m, speed=v, n_modes=0,
                                     t_end=t_ref_end, x_start=-approach, profile=prof)
    x_rigid = -approach + v * rigid.first_loss_of_contact(np.arange(0.0, t_ref_end, 1e-4))
    assert abs(x_rigid - x_loss) > 5 * v * dt


# ------------------------------------------------------------------ convergence order


@pytest.fixture(scope="module")
def convergence_reference():
    t_end = (VBI_BEAM["L"] + VBI_APPROACH) / VBI_V + 0.3
    return ref.sprung_mass_crossing(VBI_CAR["body_mass"], VBI_CAR["stiffness"], 0.0,
                                    **VBI_BEAM, speed=VBI_V, n_modes=2, t_end=t_end,
                                    x_start=-VBI_APPROACH)


def test_convergence__second_order_in_time_for_hht_alpha_zero(convergence_reference):
    # Two modes: mode 2 vanishes at midspan and every mode is in the asymptotic range
    # (w2 dt < 0.25) over the dt values used; entry/exit times lie on every grid.
    L = VBI_BEAM["L"]
    beam = br.simply_supported(L, VBI_BEAM["EI"], VBI_BEAM["m"], n_modes=2)
    car = vh.sprung_mass(VBI_CAR["body_mass"], VBI_CAR["stiffness"], 0.0)
    dts = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])
    err_w, err_a = [], []
    for dt in dts:
        ds = _run(beam, car, VBI_V, dt=dt, approach=VBI_APPROACH, free_vibration=0.3,
                  points=[0.5 * L])
        t = ds.time.values
        e = convergence_reference.evaluate(t)
        err_w.append(np.abs(ds.deck_displacement.isel(point=0).values
                            - e["deck_displacement"][:, 0]).max())
        err_a.append(np.abs(ds.carbody_acceleration.isel(vehicle=0).values
                            - e["body_acceleration"]).max())
    slope_w = np.polyfit(np.log(dts), np.log(err_w), 1)[0]
    slope_a = np.polyfit(np.log(dts), np.log(err_a), 1)[0]
    # trapezoidal rule (HHT alpha = 0) is second order; the reference is 1e-10 accurate
    assert 1.8 <= slope_w <= 2.2, (dts, err_w)
    assert 1.8 <= slope_a <= 2.2, (dts, err_a)


# ------------------------------------------------------------------ static limit

STATIC_BEAM = dict(L=10.0, m=5000.0, f1=10.0)
STATIC_BEAM["EI"] = (STATIC_BEAM["m"]
                     * (2 * np.pi * STATIC_BEAM["f1"] / (np.pi / STATIC_BEAM["L"]) ** 2) ** 2)


@pytest.mark.parametrize("kind", ["force", "damped_sprung_mass"])
def test_static_limit__slow_crossing_gives_static_deflection(kind):
    L, EI, m = STATIC_BEAM["L"], STATIC_BEAM["EI"], STATIC_BEAM["m"]
    v, approach, zeta = 1.0, 0.5, 0.05  # alpha = v / (2 f1 L) = 0.005
    points = np.array([0.5 * L, 0.3 * L])
    if kind == "force":
        P = 2e5
        veh = vh.moving_force(P)
    else:
        M = 20000.0
        P = M * G
        veh = vh.sprung_mass(M, 2e7, 4e5)  # 5 Hz, 32 % critical
    beam = br.simply_supported(L, EI, m, n_modes=20, damping_ratio=zeta)
    ds = _run(beam, veh, v, dt=2e-3, alpha=-0.1, approach=approach, free_vibration=0.0,
              points=points)
    t = ds.time.values
    a = -approach + v * t
    sel = (a >= 0.2 * L) & (a <= 0.8 * L)  # the entry transient has decayed (zeta w1 t > 6)
    w = ds.deck_displacement.values[sel]
    w_st = np.array([ref.static_deflection_point_load(P, L, EI, ai, points) for ai in a[sel]])
    w_mid = P * L**3 / (48 * EI)
    # quasi-static lag ~ 2 zeta alpha = 5e-4 and 20-mode truncation < 1e-4 of w_mid
    np.testing.assert_allclose(w, w_st, atol=1.5e-3 * w_mid)
    # under the load: P a^2 b^2 / (3 EI L) when it passes the output point 0.3 L
    i = np.argmin(np.abs(a - 0.3 * L))
    b = L - a[i]
    assert ds.deck_displacement.values[i, 1] == pytest.approx(
        P * a[i] ** 2 * b**2 / (3 * EI * L), rel=2e-3)
    if kind == "damped_sprung_mass":
        # contact force = weight when nothing moves (same lag argument)
        np.testing.assert_allclose(ds.contact_force.isel(wheel=0).values[sel], P, rtol=1e-3)


# ------------------------------------------------------------------ continuous deck


@pytest.mark.parametrize("spans", [(20.0, 20.0), (18.0, 25.0)])
def test_continuous_beam__frequencies_match_analytic_two_span_values(spans):
    EI, m, n = 6e9, 8000.0, 6
    beam = br.continuous(spans=list(spans), EI=EI, mass_per_length=m, n_modes=n,
                         elements_per_span=40)
    f_ref = ref.two_span_continuous_frequencies(spans[0], spans[1], EI, m, n)
    if spans[0] == spans[1]:
        np.testing.assert_allclose(f_ref, ref.two_span_equal_frequencies(spans[0], EI, m, n),
                                   rtol=1e-10)
    # Hermite cubic FE: frequency error ~ (beta h)^4, below 1e-5 for mode 6 at 40 el/span
    np.testing.assert_allclose(beam.frequencies, f_ref, rtol=1e-4)


def test_continuous_beam__mode_shapes_converge_with_mesh_refinement():
    L1, L2, EI, m, n = 18.0, 25.0, 6e9, 8000.0, 4
    x = np.linspace(0.0, L1 + L2, 2151)
    _, phi_ref = ref.two_span_continuous_modes(L1, L2, EI, m, n, x)
    errs = []
    for ne in (4, 8, 16):
        beam = br.continuous(spans=[L1, L2], EI=EI, mass_per_length=m, n_modes=n,
                             elements_per_span=ne)
        phi = beam.shapes(x)
        phi = phi * np.sign(np.sum(phi * phi_ref, axis=0))  # sign convention aside
        errs.append(np.abs(phi - phi_ref).max(axis=0) / np.abs(phi_ref).max(axis=0))
    errs = np.array(errs)  # (mesh, mode)
    assert np.all(np.diff(errs, axis=0) < 0), errs  # decreasing with refinement
    h = 1.0 / np.array([4, 8, 16])
    for j in range(n):
        order = np.polyfit(np.log(h), np.log(errs[:, j]), 1)[0]
        # cubic Hermite elements: displacement error O(h^4) expected; ask for >= 2
        assert order >= 2.0, (j, errs[:, j])


# ------------------------------------------------------------------ 10-DOF railway car

ICE3 = dict(body_mass=47800.0, body_pitch_inertia=1957888.0, bogie_mass=3500.0,
            bogie_pitch_inertia=1715.0, wheelset_mass=1800.0, bogie_spacing=17.375,
            wheelbase=2.5, primary_stiffness=2.4e6, primary_damping=2e4,
            secondary_stiffness=7e5, secondary_damping=4e4)


def test_railway_car__static_contact_forces_follow_the_lever_rule():
    car_data = dict(ICE3, body_cg_to_front_bogie=7.0)  # cg off-centre: unequal bogie loads
    car = vh.railway_car(**car_data)
    ds = _run(br.rigid(10.0), car, 30.0, dt=1e-3, approach=1.0, free_vibration=0.1)
    loads = ref.railway_car_static_axle_loads(
        ICE3["body_mass"], ICE3["bogie_mass"], ICE3["wheelset_mass"], ICE3["bogie_spacing"],
        7.0)
    total = G * (ICE3["body_mass"] + 2 * ICE3["bogie_mass"] + 4 * ICE3["wheelset_mass"])
    assert loads.sum() == pytest.approx(total, rel=1e-14)
    # statically determinate vehicle on level rigid track: exact up to round-off
    np.testing.assert_allclose(ds["static_wheel_load"].values, loads, rtol=1e-8)
    X = ds.contact_force.values  # stays static for the whole run (nothing excites it)
    np.testing.assert_allclose(X, np.broadcast_to(loads, X.shape), rtol=1e-6)
    np.testing.assert_allclose(X.sum(axis=1), total, rtol=1e-6)


def test_railway_car__free_vibration_on_rigid_track_at_its_eigenfrequencies():
    car_data = dict(ICE3, primary_damping=0.0, secondary_damping=0.0)  # undamped
    car = vh.railway_car(**car_data)
    M, _, K, wheels = ref.railway_car_matrices(**car_data)
    f_ref = ref.fixed_wheel_frequencies(M, K, wheels)
    # the model's own eigen-analysis agrees with the independent matrices
    np.testing.assert_allclose(car.natural_frequencies(fixed_wheels=True), f_ref, rtol=1e-10)
    v, approach, length, dt = 30.0, 1.0, 12.0, 5e-4
    bump = cosine_defect(-0.01, 10.0, 1.0)  # 10 mm bump, 10 m long: keeps contact
    # alpha = -0.05: with alpha = 0 the constrained wheel accelerations (hence contact
    # forces) carry an undamped period-2dt oscillation over an irregularity (docs/manual/
    # theory.md, "Contact and impacts"); its numerical damping of the car modes is
    # negligible (w dt <= 0.04)
    ds = _run(br.rigid(length), car, v, dt=dt, alpha=-0.05, approach=approach,
              free_vibration=5.0, profile=bump, points=[0.0])
    assert ds.in_contact.values.all()
    t = ds.time.values
    last_axle = ICE3["bogie_spacing"] + ICE3["wheelbase"]
    t_free = (approach + 11.0 + last_axle) / v + 0.05  # every wheel past the bump
    sel = t >= t_free
    a = ds.carbody_acceleration.isel(vehicle=0).values[sel]
    # body bounce dominates the car-body acceleration: the Hann-window peak over ~4
    # periods is leakage-limited to a few 1e-4
    f_bounce = f_ref[0]
    assert ref.dominant_frequency(t[sel], a, 0.3, 3.0) == pytest.approx(f_bounce, rel=2e-3)
    # a free vibration made of exactly these frequencies: the least-squares residual is
    # set by the HHT period error ((2 pi f dt)^2/12 < 4e-5, phase < 0.01 rad over 5 s)
    # and damping; a 0.1 % bounce-frequency error would already leave ~2 %
    assert ref.free_vibration_fit(t[sel], a, f_ref) < 1e-3


# ------------------------------------------------------------------ articulated train


def test_articulated_train__shared_bogie_static_axle_loads_follow_the_lever_rule():
    mb = dict(a=42000.0, b=36000.0, bogie=3000.0, wheel=1500.0)
    half, s = 1.4, 18.7
    p1, p2, p3 = half, half + s, half + 2 * s  # bogie centres (m behind the first axle)
    pa, pb = p1 + 8.5, p2 + 10.0  # car-body centres of gravity, off-centre on purpose
    b = vh.MultibodyBuilder("articulated")
    b.add_body("car_a", mb["a"], pa, pitch_inertia=2.0e6)
    b.add_body("car_b", mb["b"], pb, pitch_inertia=1.7e6)
    for name, p in (("bogie1", p1), ("bogie2", p2), ("bogie3", p3)):
        b.add_body(name, mb["bogie"], p, pitch_inertia=2500.0)
        for tag, pw in (("f", p - half), ("r", p + half)):
            b.add_wheel(f"{name}_{tag}", mb["wheel"], pw)
            b.connect(name, f"{name}_{tag}", pw, 2e6, 2e4)
    b.connect("car_a", "bogie1", p1, 6e5, 3e4)
    b.connect("car_a", "bogie2", p2, 6e5, 3e4)  # the shared bogie carries both bodies
    b.connect("car_b", "bogie2", p2, 6e5, 3e4)
    b.connect("car_b", "bogie3", p3, 6e5, 3e4)
    unit = b.build(body=["car_a", "car_b"])
    # lever rule: each body on its two bogie centres, each bogie on its two axles
    a1, a2 = ref.lever_rule(mb["a"] * G, pa, p1, p2)
    b2, b3 = ref.lever_rule(mb["b"] * G, pb, p2, p3)
    bogie_loads = np.array([a1, a2 + b2, b3]) + mb["bogie"] * G
    loads = np.repeat(0.5 * bogie_loads, 2) + mb["wheel"] * G
    total = G * (mb["a"] + mb["b"] + 3 * mb["bogie"] + 6 * mb["wheel"])
    assert loads.sum() == pytest.approx(total, rel=1e-14)
    ds = _run(br.rigid(10.0), unit, 30.0, dt=1e-3, approach=1.0, free_vibration=0.1)
    np.testing.assert_allclose(ds["wheel_position"].values,
                               [0.0, 2 * half, s, s + 2 * half, 2 * s, 2 * s + 2 * half])
    # statically determinate (two supports per body and per bogie): exact to round-off
    np.testing.assert_allclose(ds["static_wheel_load"].values, loads, rtol=1e-8)
    X = ds.contact_force.values
    np.testing.assert_allclose(X, np.broadcast_to(loads, X.shape), rtol=1e-6)
