"""Vehicles crossing a simply supported beam, by ``solve_ivp`` of the coupled equations:
the sprung mass, the quarter car with its wheel held on the beam, and the sprung mass
whose bump stop closes on a rigid rail."""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.optimize

from vsi_numba.verification.reference.beam import GRAVITY, ss_omega, ss_shapes


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
