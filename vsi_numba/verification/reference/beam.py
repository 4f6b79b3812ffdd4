"""The simply supported Euler-Bernoulli beam: its modes, the exact modal response to a
moving force (Frýba's series, trains of forces) and the ``solve_ivp`` integration of the
modal equations under moving forces."""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.optimize

#: Gravity (m s-2), the value of the published cases.
GRAVITY = 9.81


def ss_omega(L: float, EI: float, m: float, n_modes: int) -> np.ndarray:
    """Circular natural frequencies (rad/s) of a simply supported Euler-Bernoulli beam."""
    j = np.arange(1, n_modes + 1)
    return (j * np.pi / L) ** 2 * np.sqrt(EI / m)


def ss_shapes(L: float, m: float, n_modes: int, x, derivative: int = 0) -> np.ndarray:
    """Mass-normalised sine modes (or derivatives) at ``x``: shape (len(x), n_modes).

    Zero outside ``[0, L]`` (the vehicle is on rigid ground there).
    """
    x = np.atleast_1d(np.asarray(x, float))
    k = np.pi * np.arange(1, n_modes + 1) / L
    amp = np.sqrt(2.0 / (m * L))
    arg = np.outer(x, k)
    if derivative == 0:
        out = amp * np.sin(arg)
    elif derivative == 1:
        out = amp * k * np.cos(arg)
    elif derivative == 2:
        out = -amp * k**2 * np.sin(arg)
    else:
        raise ValueError("derivative must be 0, 1 or 2")
    out[(x < 0.0) | (x > L)] = 0.0
    return out


def _sdof_sine_from_rest(F, Om, om, zeta, t, velocity=True):
    """``q'' + 2 zeta om q' + om^2 q = F sin(Om t)``, ``q(0) = q'(0) = 0``: (q, q').

    Arrays ``F, Om, om`` of shape (n,) (one per mode), ``t`` of shape (nt,); returns
    arrays (nt, n).  Exact, including the undamped resonance limit ``Om = om``.
    ``velocity=False``: q' is not evaluated (None), for the callers that read q only.
    """
    t = np.asarray(t, float)[:, None]
    F, Om, om = (np.asarray(a, float)[None, :] for a in (F, Om, om))
    if zeta == 0.0:
        den = om**2 - Om**2
        res = np.abs(den) <= 1e-12 * om**2
        den_s = np.where(res, 1.0, den)
        q = F * (np.sin(Om * t) - Om / om * np.sin(om * t)) / den_s
        # resonance: q = F/(2 om^2) (sin om t - om t cos om t), q' = F t sin(om t) / 2
        q_r = F / (2 * om**2) * (np.sin(om * t) - om * t * np.cos(om * t))
        if not velocity:
            return np.where(res, q_r, q), None
        qd = F * Om * (np.cos(Om * t) - np.cos(om * t)) / den_s
        qd_r = 0.5 * F * t * np.sin(om * t)
        return np.where(res, q_r, q), np.where(res, qd_r, qd)
    D = (om**2 - Om**2) ** 2 + (2 * zeta * om * Om) ** 2
    ap = F * (om**2 - Om**2) / D  # particular: ap sin(Om t) + bp cos(Om t)
    bp = -F * 2 * zeta * om * Om / D
    wd = om * np.sqrt(1.0 - zeta**2)
    a = -bp  # homogeneous: exp(-zeta om t) (a cos wd t + b sin wd t)
    b = (zeta * om * a - ap * Om) / wd
    e = np.exp(-zeta * om * t)
    c, s = np.cos(wd * t), np.sin(wd * t)
    q = ap * np.sin(Om * t) + bp * np.cos(Om * t) + e * (a * c + b * s)
    if not velocity:
        return q, None
    qd = (
        ap * Om * np.cos(Om * t)
        - bp * Om * np.sin(Om * t)
        + e * ((-zeta * om * a + wd * b) * c + (-zeta * om * b - wd * a) * s)
    )
    return q, qd


def _sdof_free(q0, qd0, om, zeta, tau, velocity=True):
    """Free vibration of ``q'' + 2 zeta om q' + om^2 q = 0`` from (q0, qd0): (q, q');
    ``velocity=False``: q' is not evaluated (None)."""
    tau = np.asarray(tau, float)[:, None]
    wd = om * np.sqrt(1.0 - zeta**2)
    e = np.exp(-zeta * om * tau)
    b = (qd0 + zeta * om * q0) / wd
    c, s = np.cos(wd * tau), np.sin(wd * tau)
    q = e * (q0 * c + b * s)
    if not velocity:
        return q, None
    qd = e * ((-zeta * om * q0 + wd * b) * c + (-zeta * om * b - wd * q0) * s)
    return q, qd


def moving_force_modal(P, L, EI, m, v, t, n_modes, zeta=0.0):
    """Modal response to a constant force P entering a SS beam at ``t = 0``.

    Exact solution of each modal equation ``q'' + 2 zeta w q' + w^2 q = P phi_j(v t)``
    for ``0 <= t <= L/v`` and free vibration afterwards; ``q = 0`` for ``t < 0``.

    Returns
    -------
    q, qd, qdd : ndarray, shape (len(t), n_modes)
        Modal displacement, velocity, acceleration.
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
