"""The deck in space: bending and St-Venant torsion of fork-supported spans under forces
off the deck's axis (closed forms, modal series and ``solve_ivp``), and the deck's twist,
track lines and moments read from them."""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.optimize

from vsi_numba.verification.reference.beam import _sdof_free, _sdof_sine_from_rest


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
            q[on] += _sdof_sine_from_rest(F, Om, om, zeta_t, tau[on], velocity=False)[0]
            force[on] += F * np.sin(np.outer(tau[on], Om))
        if np.any(after):
            qT, qdT = _sdof_sine_from_rest(F, Om, om, zeta_t, [T])
            q[after] += _sdof_free(qT[0], qdT[0], om, zeta_t, tau[after] - T,
                                   velocity=False)[0]
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
