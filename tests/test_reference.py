"""Sanity tests of the independent reference solutions in ``tests/reference.py`` and of
those it takes from the shipped oracle, :mod:`vsi_numba.verification.reference`.

These check the references against published values, against differently-derived
formulations of the same problem (direct ODE integration, penalty contact, Rayleigh
quotients, the shipped oracle's summaries of a crossing against the general crossing)
and against limits, before they are used to judge the engine.  No engine code is
involved.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
import reference as ref
import scipy.integrate

from vsi_numba.verification import reference as vref

G = ref.GRAVITY


# ------------------------------------------------------------------ moving force


@pytest.mark.parametrize(
    ("alpha", "daf"),
    [(0.2, 1.0653), (0.5, 1.7054), (0.62, 1.7317), (1.0, 1.5487), (1.5, 1.0238)],
)
def test_moving_force_series__railway_notes_daf_table(alpha, daf):
    # railway.md §3.1 (60 modes, undamped, max while the force is on the span); the
    # table is given to 4 decimals and its alpha = 1.0 entry differs by 6e-4 from the
    # closed form (whose first-mode part alone is pi/2 * 96/pi^4 = 1.5481 at t = L/v).
    assert ref.moving_force_daf(alpha, n_modes=60) == pytest.approx(daf, abs=1e-3)


@pytest.mark.parametrize("zeta", [0.0, 0.03])
@pytest.mark.parametrize("alpha", [0.3, 1.0])  # 1.0: exact resonance of mode 1
def test_moving_force_series__matches_direct_modal_integration(alpha, zeta):
    L, EI, m, P, n = 20.0, 5e9, 8000.0, 2e5, 4
    om = ref.ss_omega(L, EI, m, n)
    v = alpha * 2 * (om[0] / (2 * np.pi)) * L
    T = L / v
    amp = np.sqrt(2 / (m * L))
    k = np.pi * np.arange(1, n + 1) / L

    def rhs(t, s):
        q, qd = s[:n], s[n:]
        f = P * amp * np.sin(k * v * t) if t <= T else 0.0 * k
        return np.concatenate([qd, f - 2 * zeta * om * qd - om**2 * q])

    t = np.linspace(0.0, 3 * T, 301)
    out = np.zeros((t.size, 2 * n))
    s = np.zeros(2 * n)
    for ta, tb in ((0.0, T), (T, 3 * T)):  # split at the exit (forcing switches off)
        sel = (t >= ta) & (t <= tb)
        sol = scipy.integrate.solve_ivp(rhs, (ta, tb), s, method="DOP853", rtol=1e-12,
                                        atol=1e-16, t_eval=t[sel])
        out[sel] = sol.y.T
        s = sol.y[:, -1]
    x = np.array([0.5 * L, 0.3 * L])
    w_ode = out[:, :n] @ ref.ss_shapes(L, m, n, x).T
    w_ref = ref.moving_force_series(P, L, EI, m, v, x, t, n, zeta=zeta)
    # both exact up to the ODE tolerance 1e-12
    np.testing.assert_allclose(w_ref, w_ode, atol=1e-9 * np.abs(w_ode).max())
    _, qd, _ = ref.moving_force_modal(P, L, EI, m, v, t, n, zeta)
    np.testing.assert_allclose(qd, out[:, n:], atol=1e-9 * np.abs(out[:, n:]).max())


def test_static_deflection__formula_and_modal_sum():
    L, EI, m, P = 12.0, 3e9, 4000.0, 1e5
    a = 4.5
    x = np.linspace(0.0, L, 49)
    w = ref.static_deflection_point_load(P, L, EI, a, x)
    b = L - a
    # under the load: P a^2 b^2 / (3 EI L) (textbook)
    assert ref.static_deflection_point_load(P, L, EI, a, a) == pytest.approx(
        P * a**2 * b**2 / (3 * EI * L), rel=1e-14)
    # Maxwell reciprocity w(x; a) = w(a; x)
    recip = np.array([ref.static_deflection_point_load(P, L, EI, xi, a) for xi in x])
    np.testing.assert_allclose(w, recip, rtol=1e-12, atol=1e-18)
    # modal series sum phi(x) phi(a) P / w^2 converges to it (tail ~ n^-3: 400 modes)
    n = 400
    w_modal = ref.ss_shapes(L, m, n, x) @ (ref.ss_shapes(L, m, n, [a])[0] * P
                                            / ref.ss_omega(L, EI, m, n) ** 2)
    np.testing.assert_allclose(w_modal, w, atol=1e-7 * w.max())
    assert ref.static_deflection_point_load(P, L, EI, 0.5 * L, 0.5 * L) == pytest.approx(
        P * L**3 / (48 * EI), rel=1e-14)


# ------------------------------------------------------------------ beam crossing

BEAM = dict(L=10.0, EI=1.2e9, m=3000.0)


def _penalty_quarter_car(M, k, c, mw, L, EI, m, v, n, t_end, x_start, profile, kc,
                         rtol=1e-7):
    """Same problem with the wheel as a DOF and a stiff bilateral contact spring.

    Linear in the state s = [z, z', y, y', q, q']: s' = A(t) s + b(t) (A is also the
    Jacobian for the implicit integrator).
    """
    om = ref.ss_omega(L, EI, m, n)
    cc = 2 * 0.7 * np.sqrt(kc * mw)  # damp the spurious contact mode
    N = 4 + 2 * n
    iq, iqd = slice(4, 4 + n), slice(4 + n, N)

    def system(t):
        x = x_start + v * t
        phi = ref.ss_shapes(L, m, n, [x])[0]
        dphi = ref.ss_shapes(L, m, n, [x], 1)[0]
        # contact force P = kc (y - rail) + cc (y' - rail'), rail = phi q + r,
        # rail' = phi q' + v phi' q + v r'
        dP = np.zeros(N)
        dP[2], dP[3] = kc, cc
        dP[iq] = -kc * phi - cc * v * dphi
        dP[iqd] = -cc * phi
        P0 = -kc * float(profile(x)) - cc * v * float(profile(x, 1))
        dF = np.zeros(N)  # suspension force k (z - y) + c (z' - y')
        dF[0], dF[1], dF[2], dF[3] = k, c, -k, -c
        A = np.zeros((N, N))
        b = np.zeros(N)
        A[0, 1] = 1.0
        A[1] = -dF / M
        b[1] = G
        A[2, 3] = 1.0
        A[3] = (dF - dP) / mw
        b[3] = G - P0 / mw
        A[iq, iqd] = np.eye(n)
        A[iqd] = np.outer(phi, dP)
        A[iqd, iq] -= np.diag(om**2)
        b[iqd] = phi * P0
        return A, b

    def rhs(t, s):
        A, b = system(t)
        return A @ s + b

    s0 = np.zeros(N)
    s0[2] = (M + mw) * G / kc
    s0[0] = s0[2] + M * G / k
    sol = scipy.integrate.solve_ivp(rhs, (0.0, t_end), s0, method="Radau", rtol=rtol,
                                    atol=1e-11, dense_output=True,
                                    jac=lambda t, s: system(t)[0])
    return sol, rhs


def test_quarter_car_on_beam__matches_penalty_contact_formulation():
    # Independent derivation: wheel as its own DOF on a stiff contact spring, no
    # elimination, no convective terms written by hand.  Error O(P/kc) ~ 1e-6 relative.
    M, k, c, mw, v, n = 3000.0, 2e6, 1e4, 800.0, 25.0, 3
    prof = ref.CosineDip(0.004, 3.0, 3.0)
    L = BEAM["L"]
    t_end = (L + 1.0) / v - 1e-3  # up to just before the exit (impulse there)
    r = ref.quarter_car_crossing(M, k, c, mw, **BEAM, speed=v, n_modes=n, t_end=t_end,
                                 x_start=-1.0, profile=prof)
    sol, rhs = _penalty_quarter_car(M, k, c, mw, **BEAM, v=v, n=n, t_end=t_end,
                                    x_start=-1.0, profile=prof, kc=1e11)
    t = np.linspace(0.0, t_end, 400)
    e = r.evaluate(t)
    s = sol.sol(t)
    w_pen = (s[4:4 + n].T @ ref.ss_shapes(L, BEAM["m"], n, [0.5 * L]).T)[:, 0]
    zdd_pen = np.array([rhs(ti, si)[1] for ti, si in zip(t, s.T, strict=True)])
    w = e["deck_displacement"][:, 0]
    np.testing.assert_allclose(w, w_pen, atol=1e-4 * np.abs(w).max())
    np.testing.assert_allclose(e["body_acceleration"], zdd_pen,
                               atol=1e-4 * np.abs(zdd_pen).max())
    # the penalty wheel sinks by P / kc < 1e-6 m into the rail
    np.testing.assert_allclose(e["wheel_displacement"], s[2], atol=1e-6)


def test_sprung_mass_on_beam__is_the_massless_wheel_limit():
    # quarter car with a wheel 1e-4 of the body mass: difference O(m_w / M)
    M, k, c, v, n = 3000.0, 2e6, 5e3, 20.0, 3
    t_end = 0.8
    a = ref.sprung_mass_crossing(M, k, c, **BEAM, speed=v, n_modes=n, t_end=t_end,
                                 x_start=-1.0)
    b = ref.quarter_car_crossing(M, k, c, 1e-4 * M, **BEAM, speed=v, n_modes=n,
                                 t_end=t_end, x_start=-1.0)
    t = np.linspace(0.0, t_end, 200)
    ea, eb = a.evaluate(t), b.evaluate(t)
    for key in ("deck_displacement", "body_acceleration", "contact_force"):
        scale = np.abs(ea[key]).max()
        np.testing.assert_allclose(ea[key], eb[key], atol=1e-3 * scale, err_msg=key)
    # static equilibrium on the level approach until the bridge is reached (t = 0.05 s)
    e0 = a.evaluate([0.0, 0.04])
    np.testing.assert_allclose(e0["contact_force"], M * G, rtol=1e-12)
    np.testing.assert_allclose(e0["body_acceleration"], 0.0, atol=1e-12)


def _grid_extremes(crossing, T, nt=20001, coarse=10, half=2 * 10):
    """Extremes of a general crossing's midspan deflection, |body acceleration| and
    contact force over the grid ``linspace(0, T, nt)`` of the shipped summaries: located
    on every ``coarse``-th point, then taken on the grid within ``half`` points of it."""
    t = np.linspace(0.0, T, nt)
    pick = {"max_midspan": lambda e: e["deck_displacement"][:, 0],
            "max_body_acceleration": lambda e: np.abs(e["body_acceleration"]),
            "max_force": lambda e: e["contact_force"],
            "min_force": lambda e: -e["contact_force"]}
    rough = crossing.evaluate(t[::coarse])
    out = {}
    for key, f in pick.items():
        i = coarse * int(np.argmax(f(rough)))
        fine = t[max(i - half, 0):i + half + 1]
        value = float(f(crossing.evaluate(fine)).max())
        out[key] = -value if key == "min_force" else value
    return out


@pytest.mark.parametrize("wheel", [False, True], ids=["sprung_mass", "quarter_car"])
def test_shipped_crossings__agree_with_the_general_crossing(wheel):
    """The shipped oracle's crossings (``sprung_mass_on_beam``, ``quarter_car_on_beam``:
    the extremes over the span from rest at x = 0, as ``vsi verify`` uses them in V02
    and V09) against the general crossing here (another state and another integration:
    piecewise, dense output): the same model, Yang & Wu's beam and body, the quarter car
    with V09's 1 t wheel, 20 kN s/m and 2 % beam damping.  Both at rtol 1e-10: measured
    below 1e-12 on the 20001-point grid (with 10 modes as with 4)."""
    Y = vref.YANG_WU
    T = Y["L"] / Y["v"]
    n = 4  # modes (V02 and V09 keep 10; 4 keep the test cheap, the model is the same)
    if wheel:
        zeta, c, m_w = 0.02, 2.0e4, 1000.0
        shipped = vref.quarter_car_on_beam(Y["L"], Y["EI"], Y["m"], zeta, Y["mass"],
                                           Y["k"], c, m_w, Y["v"], n_modes=n)
        general = ref.quarter_car_crossing(Y["mass"], Y["k"], c, m_w, Y["L"], Y["EI"],
                                           Y["m"], Y["v"], n, T, zeta=zeta)
    else:
        shipped = vref.sprung_mass_on_beam(Y["L"], Y["EI"], Y["m"], Y["mass"], Y["k"],
                                           Y["v"], n_modes=n)
        general = ref.sprung_mass_crossing(Y["mass"], Y["k"], 0.0, Y["L"], Y["EI"],
                                           Y["m"], Y["v"], n, T)
    ext = _grid_extremes(general, T)
    for key, value in ext.items():
        assert value == pytest.approx(shipped[key], rel=1e-10, abs=0), key


# ------------------------------------------------------------------ event-driven

QC = dict(body_mass=2000.0, stiffness=3e6, damping=1e4, wheel_mass=500.0)


def test_event_driven__no_loss_of_contact_equals_bilateral_solution():
    v = 20.0
    prof = ref.CosineDip(0.002, 4.0, 3.0)
    ed = ref.quarter_car_rigid_dip_event_driven(**QC, speed=v, profile=prof, t_end=0.6,
                                                x_start=0.0)
    assert ed.events == []
    bi = ref.quarter_car_crossing(*QC.values(), L=1.0, EI=1.0, m=1.0, speed=v, n_modes=0,
                                  t_end=0.6, profile=prof)
    t = np.linspace(0.0, 0.6, 301)
    a, b = ed.evaluate(t), bi.evaluate(t)
    for key in ("body_displacement", "body_acceleration", "contact_force"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-7, atol=1e-7 * np.abs(b[key]).max())


def test_event_driven__several_events_consistent_with_unilateral_contact():
    v = 30.0
    prof = ref.CosineDip(0.03, 4.0, 5.0)
    t_end = 1.2
    ed = ref.quarter_car_rigid_dip_event_driven(**QC, speed=v, profile=prof, t_end=t_end)
    kinds = [e.kind for e in ed.events]
    assert len(kinds) >= 6 and kinds[0] == "detach"
    assert all(a != b for a, b in zip(kinds[:-1], kinds[1:], strict=False))  # alternate
    # the first lift-off is where the bilateral contact force first vanishes
    bi = ref.quarter_car_crossing(*QC.values(), L=1.0, EI=1.0, m=1.0, speed=v, n_modes=0,
                                  t_end=0.3, profile=prof)
    t_loss = bi.first_loss_of_contact(np.linspace(0.0, 0.3, 601))
    assert ed.events[0].t == pytest.approx(t_loss, abs=1e-8)
    assert ed.events[0].x > prof.position + 0.05  # a dynamic lift-off, not at the edge
    # landings are plastic impacts of a wheel moving down faster than the rail
    assert all(e.wheel_velocity_jump < 0 for e in ed.events if e.kind == "attach")
    t = np.linspace(0.0, t_end, 6001)
    e = ed.evaluate(t)
    flying = e["in_contact"] == 0
    assert flying.any()
    rail = prof(e["x"])
    assert np.all(rail[flying] - e["wheel_displacement"][flying] >= -1e-9)  # no penetration
    assert np.all(e["contact_force"][~flying] >= -1e-6)  # no tension
    # in flight the centre of mass falls freely: d(M z' + mw y')/dt = (M + mw) g
    for j, tag in enumerate(ed.pieces.tags):
        if tag != "flight" or ed.pieces.t1[j] - ed.pieces.t0[j] < 1e-3:
            continue
        s0, s1 = ed.pieces.sols[j](ed.pieces.t0[j]), ed.pieces.sols[j](ed.pieces.t1[j])
        mom = QC["body_mass"] * (s1[1] - s0[1]) + QC["wheel_mass"] * (s1[3] - s0[3])
        dt = ed.pieces.t1[j] - ed.pieces.t0[j]
        assert mom == pytest.approx((QC["body_mass"] + QC["wheel_mass"]) * G * dt, rel=1e-8)


# ------------------------------------------------------------------ two-span beam


def test_two_span__equal_spans_determinant_matches_closed_form():
    L, EI, m = 20.0, 7e9, 9000.0
    f_det = ref.two_span_continuous_frequencies(L, L, EI, m, 8)
    f_cf = ref.two_span_equal_frequencies(L, EI, m, 8)
    np.testing.assert_allclose(f_det, f_cf, rtol=1e-10)
    # first mode = simply supported span, second = clamped-pinned (beta L = 3.9266)
    f1 = (np.pi / L) ** 2 * np.sqrt(EI / m) / (2 * np.pi)
    assert f_cf[0] == pytest.approx(f1, rel=1e-14)
    assert f_cf[1] == pytest.approx((3.926602312 / L) ** 2 * np.sqrt(EI / m) / (2 * np.pi),
                                    rel=1e-9)


def test_two_span__unequal_spans_modes_satisfy_rayleigh_and_orthogonality():
    L1, L2, EI, m, n = 18.0, 25.0, 6e9, 8000.0, 6
    x = np.linspace(0.0, L1 + L2, 43001)
    f, phi = ref.two_span_continuous_modes(L1, L2, EI, m, n, x)
    _, d2 = ref.two_span_continuous_modes(L1, L2, EI, m, n, x, derivative=2)
    np.testing.assert_allclose(f, ref.two_span_continuous_frequencies(L1, L2, EI, m, n),
                               rtol=1e-14)
    assert np.all(np.diff(f) > 0)
    dx = x[1] - x[0]
    trap = lambda y: dx * (y.sum(axis=0) - 0.5 * (y[0] + y[-1]))  # noqa: E731
    mass = trap(m * phi[:, :, None] * phi[:, None, :])
    np.testing.assert_allclose(mass, np.eye(n), atol=1e-6)  # trapezoid, h = 1 mm
    # Rayleigh quotient int EI phi''^2 / int m phi^2 = omega^2 holds for exact modes only
    rq = trap(EI * d2**2) / np.diag(mass)
    np.testing.assert_allclose(np.sqrt(rq) / (2 * np.pi), f, rtol=1e-5)
    i_sup = np.argmin(np.abs(x - L1))
    assert np.abs(phi[[0, i_sup, -1]]).max() < 1e-9 * np.abs(phi).max()
    # moment continuity across the middle support (curvature from both sides)
    _, cl = ref.two_span_continuous_modes(L1, L2, EI, m, n, [L1 - 1e-9], derivative=2)
    _, cr = ref.two_span_continuous_modes(L1, L2, EI, m, n, [L1 + 1e-9], derivative=2)
    np.testing.assert_allclose(cl, cr, rtol=1e-6, atol=1e-9 * np.abs(d2).max())


def test_two_span__very_short_second_span_clamps_the_first():
    # a short pinned-pinned span acts as a rotational clamp: clamped-pinned limit
    L1, EI, m = 20.0, 7e9, 9000.0
    f = ref.two_span_continuous_frequencies(L1, L1 / 2000.0, EI, m, 2)
    beta = np.array([3.926602312, 7.068582745]) / L1
    np.testing.assert_allclose(f, beta**2 * np.sqrt(EI / m) / (2 * np.pi), rtol=2e-3)


# ------------------------------------------------------------------ railway car

TRAINS = Path(__file__).resolve().parents[1] / "vsi_numba" / "data" / "trains.toml"


def _ice3_car():
    data = tomllib.loads(TRAINS.read_text())
    veh = next(v for v in data["vehicle"] if v["id"] == "ave_s103_c1")
    return veh


def test_railway_car__frequencies_and_axle_loads_match_train_data_checks():
    # values in trains.toml [vehicle.check] were computed there independently (4 decimals)
    veh = _ice3_car()
    w = veh["whole"]
    M, _, K, wheels = ref.railway_car_matrices(
        w["body_mass"], w["body_pitch_inertia"], w["bogie_mass"], w["bogie_pitch_inertia"],
        w["wheelset_mass"], veh["bogie_spacing"], veh["wheelbase"], w["primary_stiffness"],
        w["primary_damping"], w["secondary_stiffness"], w["secondary_damping"],
        veh["body_cg_to_front_bogie"])
    f = ref.fixed_wheel_frequencies(M, K, wheels)
    np.testing.assert_allclose(f, veh["check"]["natural_frequencies_fixed_wheels"],
                               atol=6e-5)
    loads = ref.railway_car_static_axle_loads(w["body_mass"], w["bogie_mass"],
                                              w["wheelset_mass"], veh["bogie_spacing"],
                                              veh["body_cg_to_front_bogie"])
    np.testing.assert_allclose(loads, veh["check"]["static_axle_loads"], rtol=1e-12)


def test_railway_car__lever_rule_equals_static_equilibrium_with_offset_cg():
    M, _, K, wheels = ref.railway_car_matrices(40000.0, 2e6, 3000.0, 2500.0, 1500.0, 19.0,
                                               2.6, 2e6, 0.0, 6e5, 0.0,
                                               body_cg_to_front_bogie=7.5)
    g = G * np.array([40000.0, 0, 3000.0, 0, 3000.0, 0] + [1500.0] * 4)
    free = np.setdiff1d(np.arange(10), wheels)
    u = np.linalg.solve(K[np.ix_(free, free)], g[free])  # wheels held at 0
    reaction = g[wheels] - K[np.ix_(wheels, free)] @ u
    loads = ref.railway_car_static_axle_loads(40000.0, 3000.0, 1500.0, 19.0, 7.5)
    np.testing.assert_allclose(reaction, loads, rtol=1e-10)
    assert loads.sum() == pytest.approx(G * (40000.0 + 2 * 3000.0 + 4 * 1500.0), rel=1e-14)


# ------------------------------------------------------------------ signals


def test_signal_tools__recover_known_frequencies():
    t = np.arange(0.0, 4.0, 1e-3)
    f = np.array([0.8037, 6.3167, 10.5249])
    y = 2.0 * np.cos(2 * np.pi * f[0] * t + 0.3) + 0.4 * np.sin(2 * np.pi * f[1] * t) \
        + 0.1 * np.cos(2 * np.pi * f[2] * t + 1.0)
    assert ref.dominant_frequency(t, y, 0.3, 3.0) == pytest.approx(f[0], rel=3e-3)
    assert ref.free_vibration_fit(t, y, f) < 1e-9
    # a 0.5 % error on the dominant frequency is plainly visible in the residual
    assert ref.free_vibration_fit(t, y, f * np.array([1.005, 1, 1])) > 2e-2
