"""Reference solutions of the verification cases, independent of the rest of vsi_numba.

This module imports numpy and scipy only, never another module of the package (a test
parses it to keep it so): the figures it computes judge the engine, they do not come
from it.  Closed forms, ``solve_ivp`` integrations of the coupled equations and
published figures, each with its source.

Conventions: SI units; vertical displacements, velocities and accelerations positive
**down**; contact forces positive in compression; ``x`` from the left support; a force
or vehicle that starts at ``x0`` is at ``x0 + v t``.  Simply supported beam:
mass-normalised modes ``phi_j = sqrt(2/(m L)) sin(j pi x / L)``,
``omega_j = (j pi / L)^2 sqrt(EI/m)``.
"""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.optimize

#: Gravity (m s-2), the value of the published cases.
GRAVITY = 9.81

# ----------------------------------------------------------------- published figures
#: Frýba, *Vibration of solids and structures under moving loads* (1972/1999), the
#: undamped simply supported beam under a constant force: the largest midspan deflection
#: while the force is on the span over the static ``P L^3 / (48 EI)``, at the speed
#: parameter ``alpha = v / (2 f1 L)`` (``= v / v_cr`` with ``v_cr = 2 f1 L``).  Values as
#: tabulated to 4 decimals from the modal series (60 modes).
FRYBA_DAF = {0.1: 1.0965, 0.3: 1.4105, 0.5: 1.7054, 0.62: 1.7317, 1.0: 1.5487}
FRYBA_SOURCE = ("Frýba (1999), Vibration of solids and structures under moving loads, "
                "ch. 1: undamped simply supported beam, modal series")

#: Yang & Wu (2001): sprung mass 5750 kg, k = 1595 kN/m, on a 25 m simply supported beam
#: (EI = 2.87e9 x 2.9 N m2, 2303 kg/m, undamped) at 100 km/h, smooth rail.
YANG_WU = dict(L=25.0, EI=2.87e9 * 2.9, m=2303.0, mass=5750.0, k=1595e3, v=100.0 / 3.6)
YANG_WU_MIDSPAN = 2.4073e-3  # m, largest midspan deflection (published)
YANG_WU_BODY_ACC = 0.1480  # m/s2, largest body acceleration (published)
YANG_WU_SOURCE = ("Yang & Wu (2001), Int. J. Struct. Stab. Dyn. 1(1); with the peers' "
                  "figures in docs/data/peer_cases.md, case S1")

#: OpenSees WheelRail on case S1 (Hertz contact of a 0.4575 m wheel, 10 kg wheel mass):
#: the largest midspan deflection, +0.16 % on the rigid contact's 2.40732 mm.
S1_OPENSEES_MIDSPAN = 2.41122e-3  # m
S1_OPENSEES_SOURCE = ("OpenSees WheelRail (xara Tcl), 20 Euler FE, Hertz contact, 10 kg "
                      "wheel; docs/data/peer_cases.md, case S1")

#: OpenSees WheelRail (Hertz contact, 500 kg wheel, 3 mm x 0.5 m half-cosine dip at
#: 12.5 m) on the Yang & Wu beam and sprung mass at 100 km/h, dt = 0.1 ms: case S2 of
#: docs/data/peer_cases.md.
S2_MIDSPAN = 2.674e-3  # m
S2_FIRST_LIFT_OFF = 12.28  # m
S2_SOURCE = ("OpenSees WheelRail (Gu, Liu et al. 2018), Newmark, Hertz contact; "
             "docs/data/peer_cases.md, case S2")


# ----------------------------------------------------------------- simply supported beam
def ss_omega(L: float, EI: float, m: float, n_modes: int) -> np.ndarray:
    """Circular natural frequencies (rad/s) of a simply supported Euler-Bernoulli beam."""
    j = np.arange(1, n_modes + 1)
    return (j * np.pi / L) ** 2 * np.sqrt(EI / m)


def ss_shapes(L: float, m: float, n_modes: int, x) -> np.ndarray:
    """Mass-normalised sine modes at ``x``, shape (len(x), n_modes); zero off the span."""
    x = np.atleast_1d(np.asarray(x, float))
    out = np.sqrt(2.0 / (m * L)) * np.sin(np.outer(x, np.pi * np.arange(1, n_modes + 1) / L))
    out[(x < 0.0) | (x > L)] = 0.0
    return out


def _sdof_sine_from_rest(F, Om, om, zeta, t):
    """``q'' + 2 zeta om q' + om^2 q = F sin(Om t)`` from rest: (q, q'), shape (nt, n).

    Exact, including the undamped resonance ``Om = om``.
    """
    t = np.asarray(t, float)[:, None]
    F, Om, om = (np.asarray(a, float)[None, :] for a in (F, Om, om))
    if zeta == 0.0:
        den = om**2 - Om**2
        res = np.abs(den) <= 1e-12 * om**2
        den_s = np.where(res, 1.0, den)
        q = F * (np.sin(Om * t) - Om / om * np.sin(om * t)) / den_s
        qd = F * Om * (np.cos(Om * t) - np.cos(om * t)) / den_s
        q_r = F / (2 * om**2) * (np.sin(om * t) - om * t * np.cos(om * t))
        qd_r = 0.5 * F * t * np.sin(om * t)
        return np.where(res, q_r, q), np.where(res, qd_r, qd)
    D = (om**2 - Om**2) ** 2 + (2 * zeta * om * Om) ** 2
    ap = F * (om**2 - Om**2) / D
    bp = -F * 2 * zeta * om * Om / D
    wd = om * np.sqrt(1.0 - zeta**2)
    a = -bp
    b = (zeta * om * a - ap * Om) / wd
    e = np.exp(-zeta * om * t)
    c, s = np.cos(wd * t), np.sin(wd * t)
    q = ap * np.sin(Om * t) + bp * np.cos(Om * t) + e * (a * c + b * s)
    qd = (ap * Om * np.cos(Om * t) - bp * Om * np.sin(Om * t)
          + e * ((-zeta * om * a + wd * b) * c + (-zeta * om * b - wd * a) * s))
    return q, qd


def _sdof_free(q0, qd0, om, zeta, tau):
    """Free vibration of ``q'' + 2 zeta om q' + om^2 q = 0`` from (q0, qd0): (q, q')."""
    tau = np.asarray(tau, float)[:, None]
    wd = om * np.sqrt(1.0 - zeta**2)
    e = np.exp(-zeta * om * tau)
    b = (qd0 + zeta * om * q0) / wd
    c, s = np.cos(wd * tau), np.sin(wd * tau)
    q = e * (q0 * c + b * s)
    qd = e * ((-zeta * om * q0 + wd * b) * c + (-zeta * om * b - wd * q0) * s)
    return q, qd


def moving_force_modal(P, L, EI, m, v, t, n_modes, zeta=0.0):
    """Modal response (q, q', q''), each (len(t), n_modes), to a force P entering at t = 0.

    The exact solution of ``q_j'' + 2 zeta w_j q_j' + w_j^2 q_j = P phi_j(v t)`` while the
    force is on the span and free vibration afterwards; zero for ``t < 0``.
    """
    t = np.atleast_1d(np.asarray(t, float))
    om = ss_omega(L, EI, m, n_modes)
    Om = np.arange(1, n_modes + 1) * np.pi * v / L
    F = np.full(n_modes, P * np.sqrt(2.0 / (m * L)))
    T = L / v
    q = np.zeros((t.size, n_modes))
    qd = np.zeros_like(q)
    on = (t >= 0.0) & (t <= T)
    after = t > T
    if np.any(on):
        q[on], qd[on] = _sdof_sine_from_rest(F, Om, om, zeta, t[on])
    if np.any(after):
        qT, qdT = _sdof_sine_from_rest(F, Om, om, zeta, [T])
        q[after], qd[after] = _sdof_free(qT[0], qdT[0], om, zeta, t[after] - T)
    force = np.where(on[:, None], F * np.sin(np.outer(t, Om)), 0.0)
    qdd = force - 2 * zeta * om * qd - om**2 * q
    return q, qd, qdd


def moving_force_daf(alpha: float, n_modes: int = 60) -> float:
    """Frýba's dynamic amplification of the midspan deflection (undamped, modal series).

    ``max_t w(L/2, t) / (P L^3 / 48 EI)`` while the force is on the span, at
    ``alpha = v / (2 f1 L)``; the maximum refined by a bounded scalar search.
    """
    L = EI = m = P = 1.0
    v = alpha * 2.0 * (np.pi / 2.0) * L  # f1 = pi/2 for L = EI = m = 1
    T = L / v
    phi = ss_shapes(L, m, n_modes, [0.5 * L])[0]

    def w(tt):
        return moving_force_modal(P, L, EI, m, v, np.atleast_1d(tt), n_modes)[0] @ phi

    tg = np.linspace(0.0, T, 40001)
    wg = w(tg)
    i = int(np.argmax(wg))
    lo, hi = tg[max(i - 1, 0)], tg[min(i + 1, tg.size - 1)]
    res = scipy.optimize.minimize_scalar(lambda s: -w(s)[0], bounds=(lo, hi),
                                         method="bounded", options={"xatol": 1e-12})
    return float(max(wg[i], -res.fun) * 48.0)


def train_of_forces(positions, loads, L, EI, m, zeta, n_modes, v, x, t_end, x_start=0.0,
                    nt=40001):
    """Deflection and acceleration histories of forces crossing a simply supported beam.

    Superposition, force by force, of the exact modal response
    (:func:`moving_force_modal`); force ``k`` is at ``x_start - positions[k] + v t``.

    Returns
    -------
    t : ndarray, shape (nt,)
    w, a : ndarray, shape (nt, len(x))
        Deflection (m) and acceleration (m/s2), positive down.
    """
    t = np.linspace(0.0, t_end, nt)
    q = np.zeros((t.size, n_modes))
    qdd = np.zeros_like(q)
    for p, load in zip(positions, loads, strict=True):
        tau = t - (p - x_start) / v  # the force enters the span at tau = 0
        qk, _, qddk = moving_force_modal(load, L, EI, m, v, tau, n_modes, zeta)
        q += qk
        qdd += qddk
    phi = ss_shapes(L, m, n_modes, x)
    return t, q @ phi.T, qdd @ phi.T


# ----------------------------------------------------------------- sprung mass on a beam
def sprung_mass_on_beam(L, EI, m, mass, k, v, n_modes=10, g=GRAVITY, zeta=0.0, times=()):
    """A sprung mass (massless contact point) crossing a simply supported beam.

    The coupled equations, integrated by ``solve_ivp`` (DOP853, rtol 1e-10) from static
    equilibrium at ``x = 0``, ``t = 0`` until the contact point leaves the span::

        M z'' = M g - F,   F = k (z - w(v t)),
        q_j'' + 2 zeta w_j q_j' + w_j^2 q_j = F phi_j(v t).

    Returns
    -------
    dict
        ``max_midspan`` (m), ``max_body_acceleration`` (|z''|, m/s2), ``min_force`` and
        ``max_force`` (N), each the largest over a 20001-point grid of the crossing, and
        ``midspan_at``: the midspan deflection (m) at each of ``times`` (s, dense output).
    """
    om = ss_omega(L, EI, m, n_modes)
    kk = np.pi * np.arange(1, n_modes + 1) / L
    amp = np.sqrt(2.0 / (m * L))
    n = n_modes

    def force(t, s):
        phi = amp * np.sin(kk * v * t)
        return k * (s[2 * n] - phi @ s[:n]), phi

    def rhs(t, s):
        f, phi = force(t, s)
        out = np.empty_like(s)
        out[:n] = s[n:2 * n]
        out[n:2 * n] = f * phi - 2 * zeta * om * s[n:2 * n] - om**2 * s[:n]
        out[2 * n] = s[2 * n + 1]
        out[2 * n + 1] = g - f / mass
        return out

    s0 = np.zeros(2 * n + 2)
    s0[2 * n] = mass * g / k
    T = L / v
    t = np.linspace(0.0, T, 20001)
    sol = scipy.integrate.solve_ivp(rhs, (0.0, T), s0, method="DOP853", rtol=1e-10,
                                    atol=1e-14, t_eval=t, dense_output=True)
    y = sol.y
    phi_mid = ss_shapes(L, m, n, [0.5 * L])[0]
    w_mid = phi_mid @ y[:n]
    at = [float(phi_mid @ sol.sol(ti)[:n]) for ti in times]
    phi_c = amp * np.sin(np.outer(v * t, kk))  # (nt, n): the modes under the vehicle
    f = k * (y[2 * n] - np.einsum("ij,ji->i", phi_c, y[:n]))
    acc = g - f / mass
    return dict(max_midspan=float(w_mid.max()), max_body_acceleration=float(abs(acc).max()),
                min_force=float(f.min()), max_force=float(f.max()), midspan_at=at)


# ----------------------------------------------------------------- static load effects
def ss_crawl_effects(P, L, EI, x):
    """Extreme static effects of a force P crossing a simply supported span.

    Influence lines: the moment at ``x`` is largest with the force there,
    ``P x (L - x) / L``; the shear at ``x`` ranges over ``[-P x / L, P (L - x) / L]``
    (up on the left of the cut); each reaction reaches ``P``; the left end rotation
    ``theta_A(a) = P a b (L + b) / (6 EI L)`` (``b = L - a``, dw/dx with w down) is
    largest at ``a = L (1 - 1/sqrt 3)``: ``P L^2 / (9 sqrt 3 EI)``.
    """
    return dict(moment=P * x * (L - x) / L, shear_max=P * (L - x) / L, shear_min=-P * x / L,
                reaction=P, rotation=P * L**2 / (9.0 * np.sqrt(3.0) * EI))


def two_span_crawl_effects(P, L1, L2, EI, x, n=2201):
    """Extreme static effects of a force P crossing two continuous spans (equal EI).

    Three-moment equation for the support moment ``M_B``, statics for the rest;
    the extremes over ``n`` force positions.  Returns the max sagging moment at ``x``,
    the hogging moment over the middle support, the max reactions (A, B, C) and the end
    rotations ``theta_A`` (max) and ``theta_C`` (min), by quadrature of ``M / EI``.
    """
    lt = L1 + L2
    x = np.asarray(x, float)
    x1 = np.linspace(0, L1, 2001)
    x2 = np.linspace(L1, lt, 2001)

    def moment(a, xs):
        if a <= L1:
            mb = -P * a * (L1**2 - a**2) / (2 * L1 * lt)
            ra = P * (L1 - a) / L1 + mb / L1
            m1 = ra * xs - P * np.clip(xs - a, 0, None)
            span2 = np.zeros_like(xs)
        else:
            b = lt - a
            mb = -P * b * (L2**2 - b**2) / (2 * L2 * lt)
            ra = mb / L1
            m1 = ra * xs
            s, b2 = np.clip(xs - L1, 0, L2), a - L1
            span2 = P * np.where(s <= b2, s * (L2 - b2) / L2, b2 * (L2 - s) / L2)
        m2 = mb * (lt - xs) / L2 + span2
        return np.where(xs <= L1, m1, m2), mb, ra

    grid = np.linspace(0.0, lt, n)
    mom, mbs, reac, th = [], [], [], []
    for a in grid:
        mx, mb, ra = moment(a, x)
        p2, b2 = (0.0, 0.0) if a <= L1 else (P, a - L1)
        rc = p2 * b2 / L2 + mb / L2
        mom.append(mx)
        mbs.append(mb)
        reac.append([ra, P - ra - rc, rc])
        m1 = moment(a, x1)[0]
        m2 = moment(a, x2)[0]
        th.append([np.trapezoid((L1 - x1) * m1, x1) / (EI * L1),
                   -np.trapezoid((x2 - L1) * m2, x2) / (EI * L2)])
    mom, reac, th = np.array(mom), np.array(reac), np.array(th)
    return dict(moment=mom.max(0), support_moment=min(mbs), reaction=reac.max(0),
                rotation_a=th[:, 0].max(), rotation_c=th[:, 1].min())


def quarter_car_on_beam(L, EI, m, zeta, body_mass, k, c, wheel_mass, v, n_modes=10,
                        g=GRAVITY):
    """A quarter car (body on a spring-dashpot over a wheel held on the rail) crossing a
    simply supported beam, integrated by ``solve_ivp`` (DOP853, rtol 1e-10).

    The wheel follows the beam under it, ``u_w = phi(vt) . q``, so its acceleration
    carries the convective terms ``2 v phi'(vt) . q' + v^2 phi''(vt) . q``; the contact
    force ``X = m_w (g - u_w'') + F_s`` with ``F_s = k (z - u_w) + c (z' - u_w')``, and the
    beam's modal equations ``(I + m_w phi phi^T) q'' = phi (m_w g + F_s - m_w a_conv) -
    C q' - K q``.  From static equilibrium on rigid ground at ``x = 0``, ``t = 0``.

    Returns
    -------
    dict
        ``max_midspan`` (m), ``max_body_acceleration`` (|z''|, m/s2), ``min_force`` and
        ``max_force`` (N, the contact force) over the crossing (20001 points).
    """
    n = n_modes
    om = ss_omega(L, EI, m, n)
    kk = np.pi * np.arange(1, n + 1) / L
    amp = np.sqrt(2.0 / (m * L))

    def parts(t, s):
        q, qd, z, zd = s[:n], s[n:2 * n], s[2 * n], s[2 * n + 1]
        x = v * t
        phi, dphi, ddphi = amp * np.sin(kk * x), amp * kk * np.cos(kk * x), \
            -amp * kk**2 * np.sin(kk * x)
        uw, uwd = phi @ q, phi @ qd + v * (dphi @ q)
        conv = 2.0 * v * (dphi @ qd) + v**2 * (ddphi @ q)
        fs = k * (z - uw) + c * (zd - uwd)
        rhs = phi * (wheel_mass * g + fs - wheel_mass * conv) - 2 * zeta * om * qd - om**2 * q
        # (I + m_w phi phi^T)^-1 rhs by Sherman-Morrison
        qdd = rhs - phi * (wheel_mass * (phi @ rhs) / (1.0 + wheel_mass * (phi @ phi)))
        force = wheel_mass * (g - (phi @ qdd + conv)) + fs
        return qdd, fs, force

    def rhs(t, s):
        qdd, fs, _ = parts(t, s)
        return np.concatenate([s[n:2 * n], qdd, [s[2 * n + 1], g - fs / body_mass]])

    s0 = np.zeros(2 * n + 2)
    s0[2 * n] = body_mass * g / k
    T = L / v
    t = np.linspace(0.0, T, 20001)
    sol = scipy.integrate.solve_ivp(rhs, (0.0, T), s0, method="DOP853", rtol=1e-10,
                                    atol=1e-14, t_eval=t)
    y = sol.y
    w_mid = ss_shapes(L, m, n, [0.5 * L])[0] @ y[:n]
    out = [parts(ti, y[:, i]) for i, ti in enumerate(t)]
    fs = np.array([o[1] for o in out])
    force = np.array([o[2] for o in out])
    acc = g - fs / body_mass
    return dict(max_midspan=float(w_mid.max()), max_body_acceleration=float(abs(acc).max()),
                min_force=float(force.min()), max_force=float(force.max()))


def sprung_mass_bump_stop_on_rigid_rail(mass, k, c, gap, k_stop, depth, wavelength,
                                        position, v, x_start, x_end, g=GRAVITY):
    """A sprung mass (massless contact point) with a bump stop, on a rigid rail with an
    isolated cosine defect ``r = depth/2 (1 - cos(2 pi (x - position)/wavelength))``.

    The contact point follows the rail (``u_w = r``, positive down); the suspension force
    ``F = k (z - r) + c (z' - r') + k_stop max(0, z - r - M g / k - gap)`` (compression
    beyond ``gap`` from the static position closes the stop), ``M z'' = M g - F``.
    Integrated by ``solve_ivp`` (DOP853, rtol 1e-11, steps of at most 0.1 ms) piecewise
    between the defect's ends, from static equilibrium at ``x_start``; the stop's force is
    continuous where it closes, so the adaptive steps resolve the kink in its slope.

    Returns
    -------
    dict
        ``max_body_acceleration`` (|z''|, m/s2), ``max_force`` and ``min_force`` (N, the
        contact force), ``max_compression`` (m, beyond the static position).
    """
    z_st = mass * g / k
    a, b = position, position + wavelength

    def rail(x):
        s = (np.asarray(x, float) - a) / wavelength
        inside = (s >= 0.0) & (s <= 1.0)
        r = np.where(inside, 0.5 * depth * (1.0 - np.cos(2 * np.pi * s)), 0.0)
        rp = np.where(inside, np.pi * depth / wavelength * np.sin(2 * np.pi * s), 0.0)
        return r, rp

    def force(t, z, zd):
        r, rp = rail(x_start + v * t)
        comp = z - r - z_st
        return (k * (z - r) + c * (zd - v * rp) + k_stop * np.maximum(comp - gap, 0.0),
                comp)

    t_end = (x_end - x_start) / v
    breaks = [0.0, (a - x_start) / v, (b - x_start) / v, t_end]
    y = np.array([z_st, 0.0])
    ts, ys = [], []
    for t0, t1 in zip(breaks[:-1], breaks[1:], strict=True):
        sol = scipy.integrate.solve_ivp(
            lambda t, s: [s[1], g - force(t, s[0], s[1])[0] / mass], (t0, t1), y,
            method="DOP853", rtol=1e-11, atol=1e-14, max_step=1e-4, dense_output=True)
        tt = np.linspace(t0, t1, max(2, int((t1 - t0) / 1e-5)))
        ts.append(tt)
        ys.append(sol.sol(tt))
        y = sol.y[:, -1]
    t = np.concatenate(ts)
    yy = np.concatenate(ys, axis=1)
    f, comp = force(t, yy[0], yy[1])
    acc = g - f / mass
    return dict(max_body_acceleration=float(abs(acc).max()), max_force=float(f.max()),
                min_force=float(f.min()), max_compression=float(comp.max()))


#: LM71 (EN 1991-2 6.3.2, Fig. 6.1 [R]): four point forces of 250 kN at 1.6 m and
#: 80 kN/m beyond 0.8 m of the outer forces, on the unfavourable parts of an influence
#: line only.
LM71_AXLE, LM71_SPACING, LM71_UDL = 250e3, 1.6, 80e3


def lm71_extreme(L, influence, step=1e-3):
    """Largest effect of LM71 on a simply supported span of an influence line.

    ``influence(xi)`` is the effect of a unit force at ``xi`` (zero off the span).  The
    four forces are moved in steps of ``step`` m across the span; the distributed load
    covers the positive parts of the line beyond 0.8 m of the outer forces, integrated
    exactly on a 0.5 mm grid (trapezoid of a piecewise-linear line).
    """
    xi = np.linspace(0.0, L, int(round(L / 5e-4)) + 1)
    eta = np.maximum(influence(xi), 0.0)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (eta[1:] + eta[:-1]) * np.diff(xi))])

    def area(a, b):  # integral of the positive line over [a, b] within the span
        a, b = np.clip(a, 0.0, L), np.clip(b, 0.0, L)
        return np.interp(b, xi, cum) - np.interp(a, xi, cum)

    s = np.arange(-4 * LM71_SPACING, L + step, step)  # the first force's abscissa
    pts = s[:, None] + LM71_SPACING * np.arange(4)[None, :]
    inside = (pts >= 0.0) & (pts <= L)
    forces = LM71_AXLE * np.where(inside, influence(np.clip(pts, 0.0, L)), 0.0).sum(axis=1)
    udl = LM71_UDL * (area(0.0, s - 0.8) + area(s + 3 * LM71_SPACING + 0.8, L))
    return float((forces + udl).max())


def ss_influence(L, EI, x, effect):
    """Influence line of a simply supported span: the effect at ``x`` (m) of a unit force
    at ``xi``: "moment" (sagging), "shear" (just right of x, up on the left of the cut),
    "reaction" (left support, up) or "rotation" (dw/dx at the left end, w down)."""
    def line(xi):
        xi = np.asarray(xi, float)
        if effect == "moment":
            return np.where(xi <= x, xi * (L - x) / L, x * (L - xi) / L)
        if effect == "shear":
            return np.where(xi <= x, -xi / L, 1.0 - xi / L)
        if effect == "reaction":
            return 1.0 - xi / L
        if effect == "rotation":
            b = L - xi
            return xi * b * (L + b) / (6.0 * EI * L)
        raise ValueError(effect)
    return line


def ss_mode_table(L, EI, m, n_modes, dx):
    """Rows ``(mode, frequency Hz, modal_mass kg, x m, shape, slope 1/m)`` of the sine
    modes ``sin(j pi x / L)`` of a simply supported span at stations ``dx`` apart: the
    table another program would export (modal mass ``m L / 2`` of the unit shape)."""
    x = np.linspace(0.0, L, int(round(L / dx)) + 1)
    f = ss_omega(L, EI, m, n_modes) / (2.0 * np.pi)
    rows = []
    for j in range(1, n_modes + 1):
        k = j * np.pi / L
        shape, slope = np.sin(k * x), k * np.cos(k * x)
        shape[[0, -1]] = 0.0
        rows += [(j, f[j - 1], m * L / 2.0, xi, s, d)
                 for xi, s, d in zip(x, shape, slope, strict=True)]
    return rows


# ----------------------------------------------------------------- deck in space
def fork_torsion_frequencies(L: float, GJ: float, Ip: float, n_modes: int) -> np.ndarray:
    """Natural frequencies (Hz) of St-Venant torsion of a span on fork supports (rotation
    about x restrained at both ends): ``f_j = (j pi / L) sqrt(GJ / Ip) / (2 pi)``."""
    return np.arange(1, n_modes + 1) * np.pi / L * np.sqrt(GJ / Ip) / (2.0 * np.pi)


def deck_in_space_forces(forces, L, EI, m, zeta, n_bending, GJ, Ip, zeta_t, n_torsion, t):
    """Moving forces on a simply supported deck that bends and twists (St-Venant torsion,
    fork supports), integrated by ``solve_ivp`` (DOP853, rtol 1e-10) from rest.

    The deck's vertical shape of a mode at ``(x, y)`` is ``phi_j(x) + y theta_j(x)``
    (``y`` positive to the left looking in +x, ``theta`` positive when the left side goes
    down).  Bending modes ``phi_j = sqrt(2/(m L)) sin(j pi x/L)``,
    ``omega_j = (j pi/L)^2 sqrt(EI/m)``, damping ``zeta``; torsional modes
    ``theta_j = sqrt(2/(Ip L)) sin(j pi x/L)``, ``omega_j = (j pi/L) sqrt(GJ/Ip)``,
    damping ``zeta_t``.  A force ``P`` at ``(x, y)`` on the span loads bending mode j
    with ``P phi_j(x)`` and torsional mode j with ``P y theta_j(x)``.

    Parameters
    ----------
    forces : array_like, shape (n_forces, 4)
        Rows ``(P, y, x0, u)``: a force ``P`` (N, down) at eccentricity ``y`` (m) at
        ``x0 + u t`` (m; ``u`` in m/s, negative for a force moving in -x).
    L, EI, m, zeta : float
        Span (m), bending stiffness (N m2), mass per length (kg/m), damping ratio.
    n_bending : int
        Bending modes.
    GJ, Ip, zeta_t : float
        Torsional stiffness (N m2), polar mass moment of inertia per length (kg m2/m),
        torsional damping ratio.
    n_torsion : int
        Torsional modes.
    t : array_like, shape (nt,)
        Increasing output times from 0 (s).

    Returns
    -------
    dict
        ``t``; ``q`` and ``qdd`` (nt, n_bending + n_torsion): the modal coordinates and
        accelerations, bending modes first; ``force`` (nt, n): the modal forces;
        ``k`` (n,): the wave numbers ``j pi / L``; ``omega`` (n,); ``kinds``: "b" or "t"
        per mode; the deck's data for :func:`deck_in_space_line`,
        :func:`deck_in_space_twist` and :func:`deck_in_space_moment`.
    """
    forces = np.atleast_2d(np.asarray(forces, float))
    t = np.asarray(t, float)
    kb = np.pi * np.arange(1, n_bending + 1) / L
    kt = np.pi * np.arange(1, n_torsion + 1) / L
    k = np.concatenate([kb, kt])
    omega = np.concatenate([kb**2 * np.sqrt(EI / m), kt * np.sqrt(GJ / Ip)])
    z = np.concatenate([np.full(n_bending, zeta), np.full(n_torsion, zeta_t)])
    torsion = np.arange(k.size) >= n_bending
    n = k.size
    P, y, x0, u = forces.T
    # modal amplitude of each force: (n_forces, n)
    amp = np.where(torsion[None, :], y[:, None] * np.sqrt(2.0 / (Ip * L)),
                   np.sqrt(2.0 / (m * L)))

    def modal_force(tt):
        x = x0 + u * tt
        on = (x >= 0.0) & (x <= L)
        return (P[on, None] * amp[on] * np.sin(np.outer(x[on], k))).sum(axis=0)

    def rhs(tt, s):
        return np.concatenate([s[n:], modal_force(tt) - 2 * z * omega * s[n:]
                               - omega**2 * s[:n]])

    max_step = 0.05 * 2.0 * np.pi / omega.max()
    sol = scipy.integrate.solve_ivp(rhs, (0.0, t[-1]), np.zeros(2 * n), method="DOP853",
                                    rtol=1e-10, atol=1e-14, t_eval=t, max_step=max_step)
    q = sol.y[:n].T
    f = np.array([modal_force(tt) for tt in t])
    qdd = f - 2 * z * omega * sol.y[n:].T - omega**2 * q
    return dict(t=t, q=q, qdd=qdd, force=f, k=k, omega=omega,
                kinds=np.where(torsion, "t", "b"), forces=forces, L=L, EI=EI, m=m, Ip=Ip)


def _deck_in_space_shapes(res, x):
    """Bending shapes and torsional rotations of every mode at ``x``, each (len(x), n);
    each family zero in the other's columns and off the span."""
    x = np.atleast_1d(np.asarray(x, float))
    L, tors = res["L"], res["kinds"] == "t"
    s = np.sin(np.outer(x, res["k"]))
    s[(x < 0.0) | (x > L)] = 0.0
    phi = np.where(tors, 0.0, np.sqrt(2.0 / (res["m"] * L)) * s)
    theta = np.where(tors, np.sqrt(2.0 / (res["Ip"] * L)) * s, 0.0)
    return phi, theta


def deck_in_space_line(res, x, y, max_frequency=np.inf):
    """Displacement and acceleration histories (nt, len(x)), positive down, of the deck
    at ``(x, y)`` from :func:`deck_in_space_forces`; the acceleration of the modes up to
    ``max_frequency`` (Hz)."""
    phi, theta = _deck_in_space_shapes(res, x)
    shape = phi + y * theta
    band = res["omega"] / (2.0 * np.pi) <= max_frequency
    return res["q"] @ shape.T, res["qdd"][:, band] @ shape[:, band].T


def deck_in_space_twist(res, x, gauge=1.435, base=3.0):
    """Deck twist histories (nt, len(x)) over ``base`` from ``x`` along any track:
    ``gauge (theta(x) - theta(x + base))`` (m), zero rotation off the span."""
    x = np.atleast_1d(np.asarray(x, float))
    th0 = res["q"] @ _deck_in_space_shapes(res, x)[1].T
    th1 = res["q"] @ _deck_in_space_shapes(res, x + base)[1].T
    return gauge * (th0 - th1)


def deck_in_space_moment(res, x):
    """Bending moment history (nt,) at ``x`` by the mode-acceleration method: the static
    moment of the forces on the span (simply supported beam, ``P x (L - a) / L`` for
    ``x <= a``, ``P a (L - x) / L`` beyond) plus
    ``sum_j EI k_j^2 a sin(k_j x) (q_j - F_j / omega_j^2)`` over the bending modes
    (``a = sqrt(2/(m L))``; sagging positive)."""
    L = res["L"]
    P, _, x0, u = res["forces"].T
    a = x0[None, :] + np.outer(res["t"], u)
    on = (a >= 0.0) & (a <= L)
    static = np.where(x <= a, x * (L - a) / L, a * (L - x) / L)
    out = (np.where(on, static, 0.0) * P[None, :]).sum(axis=1)
    b = res["kinds"] == "b"
    k, om = res["k"][b], res["omega"][b]
    mj = res["EI"] * k**2 * np.sqrt(2.0 / (res["m"] * L)) * np.sin(k * x)
    return out + (res["q"][:, b] - res["force"][:, b] / om**2) @ mj


def point_torque_twist(T, GJ, L, x, gauge=1.435, base=3.0, n_modes=None):
    """Largest |twist| over ``base`` from ``x`` of a torque ``T`` (N m) crawling over a
    fork-supported span: St-Venant rotation of a point torque at ``a``,
    ``theta(s) = T s (L - a) / (GJ L)`` for ``s <= a``, ``T a (L - s) / (GJ L)`` beyond,
    twist ``gauge (theta(x) - theta(x + base))``.  The twist is linear in ``a`` between
    the kinks ``a = x`` and ``a = x + base``, so its extreme is at one of them:
    ``gauge T base max(x, L - x - base) / (GJ L)`` (for ``0 <= x <= L - base``).

    With ``n_modes``, the same extreme of the sine series of the rotation truncated to
    the first ``n_modes`` torsional modes,
    ``theta(s) = sum_j 2 T sin(k_j a) sin(k_j s) / (GJ L k_j^2)``, over the torque's
    positions in 1 mm steps (the modal truncation of a model keeping those modes).
    """
    if n_modes is None:
        return gauge * T * base * max(x, L - x - base) / (GJ * L)
    a = np.linspace(0.0, L, int(round(L / 1e-3)) + 1)
    k = np.pi * np.arange(1, n_modes + 1) / L
    coef = 2.0 * T / (GJ * L * k**2)

    def theta(s):
        return (np.sin(np.outer(a, k)) * coef) @ np.sin(k * s) if 0.0 <= s <= L else 0.0 * a

    return float(np.abs(gauge * (theta(x) - theta(x + base))).max())


def fork_torsion_moving_forces(offsets, P, y, L, GJ, Ip, zeta_t, v, t, n_modes=400):
    """Torsion of a fork-supported span under moving forces ``P`` (N, down) at ``y`` (m)
    ``offsets`` (m) behind a first one that enters at t = 0, each mode's exact response
    (:func:`_sdof_sine_from_rest`, :func:`_sdof_free`) superposed over the forces, with
    ``n_modes`` modes ``theta_j = sqrt(2/(Ip L)) sin(j pi x/L)``,
    ``omega_j = (j pi/L) sqrt(GJ/Ip)``: a converged reference of the quantities that
    converge slowly in modes, by the mode-acceleration formula of
    :func:`fork_torsion_channels`.

    Returns a dict: ``q`` (nt, n_modes) and ``force`` (nt, n_modes) the modal forces,
    ``k`` the wave numbers, ``omega``, the inputs.
    """
    t = np.atleast_1d(np.asarray(t, float))
    offsets = np.atleast_1d(np.asarray(offsets, float))
    k = np.pi * np.arange(1, n_modes + 1) / L
    om = k * np.sqrt(GJ / Ip)
    a = np.sqrt(2.0 / (Ip * L))
    F = np.full(n_modes, P * y * a)
    Om = k * v
    T = L / v
    q = np.zeros((t.size, n_modes))
    force = np.zeros_like(q)
    for d in offsets:
        tau = t - d / v
        on = (tau >= 0.0) & (tau <= T)
        after = tau > T
        if np.any(on):
            q[on] += _sdof_sine_from_rest(F, Om, om, zeta_t, tau[on])[0]
            force[on] += F * np.sin(np.outer(tau[on], Om))
        if np.any(after):
            qT, qdT = _sdof_sine_from_rest(F, Om, om, zeta_t, [T])
            q[after] += _sdof_free(qT[0], qdT[0], om, zeta_t, tau[after] - T)[0]
    return dict(t=t, q=q, force=force, k=k, omega=om, a=a, offsets=offsets, P=P, y=y, L=L,
                GJ=GJ, v=v)


def fork_torsion_channels(res, x, gauge=1.435, base=3.0, speed_factor=1.0):
    """Histories (nt, len(x)) of the rotation ``theta(x)``, the twist over ``base`` from
    ``x`` (``gauge (theta(x) - theta(x + base))``, zero off the span) and the St-Venant
    torque ``T(x) = GJ theta'(x)`` (the value just right of a load) of
    :func:`fork_torsion_moving_forces`: the closed-form static rotation and torque of
    the point torques ``P y`` on the span plus ``sum_j (q_j - F_j / omega_j^2)`` of the
    modes (mode acceleration); ``speed_factor`` D multiplies the static part and the
    modes' ``F_j / omega_j^2`` (1: the classical formula).  Returns (theta, twist,
    torque)."""
    x = np.atleast_1d(np.asarray(x, float))
    L, GJ, v, t = res["L"], res["GJ"], res["v"], res["t"]
    D = float(speed_factor)
    c = res["q"] - D * res["force"] / res["omega"] ** 2
    pos = v * t[:, None] - res["offsets"][None, :]  # (nt, n_forces)
    on = (pos >= 0.0) & (pos <= L)
    Pe = D * res["P"] * res["y"]

    def static(at):
        X = np.asarray(at, float)[None, None, :]
        a = pos[:, :, None]
        th = np.where(X <= a, X * (L - a), a * (L - X)) / (GJ * L)
        tq = np.where(a <= X, -a, L - a) / L
        inside = ((X >= 0.0) & (X <= L)) & on[:, :, None]
        return (Pe * np.where(inside, th, 0.0).sum(axis=1),
                Pe * np.where(inside, tq, 0.0).sum(axis=1))

    def modal(at):
        at = np.asarray(at, float)
        s = res["a"] * np.sin(np.outer(at, res["k"]))
        s[(at < 0.0) | (at > L)] = 0.0
        ds = GJ * res["a"] * res["k"] * np.cos(np.outer(at, res["k"]))
        return c @ s.T, c @ ds.T

    th0, tq0 = static(x)
    th1, tq1 = modal(x)
    thb0 = static(x + base)[0]
    thb1 = modal(x + base)[0]
    theta = th0 + th1
    return theta, gauge * (theta - thb0 - thb1), tq0 + tq1


def fork_spans_twist(spans, offsets, P, y, GJ, Ip, zeta_t, v, t, x, gauge=1.435, base=3.0,
                     n_modes=400):
    """Twist histories (nt, len(x)) over ``base`` from ``x`` of a deck on point supports
    whose torsion is restrained at every support: each span is a fork-supported span of
    its own (:func:`fork_torsion_moving_forces`, :func:`fork_torsion_channels`), loaded by
    the forces while they cross it; zero rotation off the deck."""
    x = np.atleast_1d(np.asarray(x, float))
    sup = np.concatenate([[0.0], np.cumsum(np.asarray(spans, float))])
    offsets = np.atleast_1d(np.asarray(offsets, float))

    def theta(at):
        out = np.zeros((np.size(t), at.size))
        for s, L in enumerate(np.diff(sup)):
            inside = (at >= sup[s]) & (at <= sup[s + 1])
            if not inside.any():
                continue
            res = fork_torsion_moving_forces(offsets + sup[s], P, y, L, GJ, Ip, zeta_t, v,
                                             t, n_modes)
            out[:, inside] += fork_torsion_channels(res, at[inside] - sup[s])[0]
        return out

    return gauge * (theta(x) - theta(x + base))


def fork_spans_crawl_twist(spans, P, y, GJ, x, gauge=1.435, base=3.0, step=1e-3):
    """Largest |twist| over ``base`` from each ``x`` of a force ``P`` at ``y`` crawling
    over a deck whose torsion is restrained at every support (each span fork-supported):
    the closed-form St-Venant rotation ``theta(X) = P y X (L - a) / (GJ L)`` (X <= a) of
    the span holding the load, the load moved in ``step`` m steps."""
    x = np.atleast_1d(np.asarray(x, float))
    sup = np.concatenate([[0.0], np.cumsum(np.asarray(spans, float))])
    a = np.arange(0.0, sup[-1] + step / 2, step)

    def theta(at):
        out = np.zeros((at.size, a.size))
        for s, L in enumerate(np.diff(sup)):
            X = (at - sup[s])[:, None]
            b = (a - sup[s])[None, :]
            g = np.where(X <= b, X * (L - b), b * (L - X)) / (GJ * L)
            on = ((X >= 0) & (X <= L)) & ((b >= 0) & (b <= L))
            out += np.where(on, g, 0.0)
        return P * y * out

    return np.abs(gauge * (theta(x) - theta(x + base))).max(axis=1)


# ----------------------------------------------------------- existing bridges (synthetic)
def moving_forces_ivp(positions, loads, L, EI, m, zeta, n_modes, v, x, t, x_start=0.0,
                      rtol=1e-9, atol=1e-12):
    """Deflection and acceleration of forces crossing a simply supported beam, by
    ``solve_ivp`` of the modal equations (independent of the closed form of
    :func:`train_of_forces`).

    ``q_j'' + 2 zeta w_j q_j' + w_j^2 q_j = sum_k P_k phi_j(x_k(t))`` with force ``k`` at
    ``x_k = x_start - positions[k] + v t`` while ``0 <= x_k <= L``; the state starts at
    rest.  The integration restarts at every time a force enters or leaves the span (the
    load is discontinuous in its derivative there), DOP853 between them.

    Returns
    -------
    w, a : ndarray, shape (len(t), len(x))
        Deflection (m) and acceleration (m s-2), positive down, at the times ``t``.
    """
    positions = np.asarray(positions, float)
    loads = np.asarray(loads, float)
    t = np.asarray(t, float)
    om = ss_omega(L, EI, m, n_modes)
    j = np.arange(1, n_modes + 1)
    amp = np.sqrt(2.0 / (m * L))

    def force(tt):
        xk = x_start - positions + v * tt
        on = (xk >= 0.0) & (xk <= L)
        return amp * (np.sin(np.outer(j, xk[on]) * np.pi / L) @ loads[on])

    def rhs(tt, y):
        q, qd = y[:n_modes], y[n_modes:]
        return np.concatenate([qd, force(tt) - 2 * zeta * om * qd - om**2 * q])

    events = np.concatenate([(positions - x_start) / v, (positions - x_start + L) / v])
    events = np.unique(events[(events > t[0]) & (events < t[-1])])
    edges = np.concatenate([[min(t[0], 0.0)], events, [t[-1]]])
    y = np.zeros(2 * n_modes)
    q = np.zeros((t.size, n_modes))
    qd = np.zeros_like(q)
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if b <= a:
            continue
        inside = (t >= a) & (t < b) if b < t[-1] else (t >= a) & (t <= b)
        te = np.unique(np.concatenate([t[inside], [b]]))
        sol = scipy.integrate.solve_ivp(rhs, (a, b), y, method="DOP853", rtol=rtol,
                                        atol=atol, t_eval=te)
        n_in = int(inside.sum())
        q[inside] = sol.y[:n_modes, :n_in].T
        qd[inside] = sol.y[n_modes:, :n_in].T
        y = sol.y[:, -1]
    qdd = np.array([force(tt) for tt in t]) - 2 * zeta * om * qd - om**2 * q
    phi = ss_shapes(L, m, n_modes, x)
    return q @ phi.T, qdd @ phi.T
