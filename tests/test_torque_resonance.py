"""The St-Venant torsional moment of a continuous deck at a torsional resonance, through
the user's path (config -> ``vsi sweep`` -> netCDF), against the test's own dynamic
solution: the exact torsional modes of each span restrained at its supports
(sin(n pi s / l)), their modal equations integrated by ``scipy.integrate.solve_ivp``
and the torque recovered by the mode-acceleration method with the test's own static
finite-element torque (the engine's method, none of its code)."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from test_other_trains_own_speed_torsion import GJ, P, Y, _config, _fe_torque, _forces, _run
from test_space_config import IP, ZT

SPANS = (0.0, 10.0, 20.0)  # the supports (m): torsion restrained at each
N_PER_SPAN = 3  # torsional modes of each span the deck keeps (bridge.torsion n_modes = 6)


def _modes(x):
    """Shapes and slopes (n_modes, x.size) of the spans' torsional modes, span by span,
    and their circular frequencies: psi = sin(n pi s / l) on the span, 0 elsewhere."""
    shapes, slopes, omega = [], [], []
    for x0, x1 in zip(SPANS[:-1], SPANS[1:], strict=True):
        span = x1 - x0
        on = (x >= x0) & (x <= x1)
        for n in range(1, N_PER_SPAN + 1):
            k = n * np.pi / span
            shapes.append(np.where(on, np.sin(k * (x - x0)), 0.0))
            slopes.append(np.where(on, k * np.cos(k * (x - x0)), 0.0))
            omega.append(k * np.sqrt(GJ / IP))
    return np.array(shapes), np.array(slopes), np.array(omega)


def _reference(sections, offsets, e, v, t_eval):
    """Torque T(x, t) at ``sections`` of forces P at ``offsets`` behind the first (which
    is at x = 0 at t = 0), at eccentricity ``e``, speed ``v``: modal equations of the
    exact modes (mass IP l / 2, stiffness GJ k^2 l / 2, damping ratio ZT) by DOP853,
    T = T_static + sum_n GJ psi_n'(x) (q_n - F_n / K_n)."""
    length = SPANS[-1]
    span = np.diff(SPANS)[0]
    _, slopes, omega = _modes(np.asarray(sections, float))
    m_n = IP * span / 2.0
    offsets = np.asarray(offsets, float)
    # each mode's span (x0, x1) and wavenumber, in _modes' order: the generalised force
    # sum_i psi_n(a_i) P e evaluated as one array expression (the integrator calls it
    # ~10^5 times)
    x0 = np.repeat(SPANS[:-1], N_PER_SPAN)[:, None]
    x1 = np.repeat(SPANS[1:], N_PER_SPAN)[:, None]
    k = np.array([n * np.pi / (b - a) for a, b in zip(SPANS[:-1], SPANS[1:], strict=True)
                  for n in range(1, N_PER_SPAN + 1)])[:, None]

    def force(t):
        a = v * t - offsets
        a = a[(a >= 0.0) & (a <= length)]
        if not a.size:
            return np.zeros(omega.size)
        on = (a >= x0) & (a <= x1)
        return np.where(on, np.sin(k * (a - x0)), 0.0).sum(axis=1) * P * e

    def rhs(t, y):
        q, qd = y[:omega.size], y[omega.size:]
        return np.concatenate([qd, force(t) / m_n - 2 * ZT * omega * qd - omega ** 2 * q])

    sol = solve_ivp(rhs, (0.0, t_eval[-1]), np.zeros(2 * omega.size), method="DOP853",
                    t_eval=t_eval, rtol=1e-10, atol=1e-14, max_step=2e-4)
    assert sol.success
    T = np.empty((t_eval.size, len(sections)))
    for i, t in enumerate(t_eval):
        a = v * t - offsets
        loads = [(float(x), P * e) for x in a if 0.0 <= x <= length]
        static = (_fe_torque(np.asarray(sections, float), loads, np.array(SPANS), GJ)
                  if loads else 0.0)
        q_static = force(t) / (m_n * omega ** 2)
        T[i] = static + GJ * (slopes.T @ (sol.y[:omega.size, i] - q_static))
    return T


def test_torsional_moment_of_a_continuous_deck_at_resonance__against_own_modal_solution(
        tmp_path):
    """Fifteen 100 kN forces 5 m apart on track 1 (y = 2.2 m) at v = f_t1 d = 12.5 Hz x
    5 m = 225 km/h over 10 + 10 m, torsion restrained at every support: the spans'
    torsional modes build up (a uniform bar's modes are at n f_t1, so each is resonant
    with a harmonic of the forcing); the torque envelopes at points inside both spans
    (off the sections the forces stand on at a step) against the test's own modal
    solution with the same three modes per span, the deck's elements refined once."""
    d, n_f, kmh = 5.0, 15, 225.0
    v = kmh / 3.6
    pts = [2.6, 5.3, 7.7, 12.9, 16.3]
    base = _config("track = 1", _forces(n_f, d, P), kmh, 0.3, "continuous", 2.5e-4,
                   "[" + ", ".join(map(str, pts)) + "]")
    scale = P * Y[0]
    errors = {}
    for n_el in (40, 80):
        text = base.replace("elements_per_span = 40", f"elements_per_span = {n_el}")
        ds, _ = _run(tmp_path, f"el{n_el}", text)
        assert np.allclose(ds["point"].values, pts)
        assert ds["max_torsional_moment"].attrs["units"] == "N m"
        t = ds["time"].values
        if n_el == 40:
            ref = _reference(pts, [d * i for i in range(n_f)], Y[0], v, t)
            hi, lo = ref.max(axis=0), ref.min(axis=0)
            # the resonance builds up: the torque well above the static envelope
            static = max(np.abs(_fe_torque(np.array(pts), [
                (float(x), scale) for x in v * ti - d * np.arange(n_f)
                if 0.0 <= x <= SPANS[-1]], np.array(SPANS), GJ)).max() for ti in t[::8])
            assert np.abs(ref).max() > 2.5 * static, (np.abs(ref).max(), static)  # 3.2x
        errors[n_el] = max(np.abs(ds["max_torsional_moment"].values - hi).max(),
                           np.abs(ds["min_torsional_moment"].values - lo).max()) / scale
    # measured (of P e, the peak 3.3 P e): 0.126 with 40 linear elements per span, 0.048
    # with 80, largest near mid-span where the first mode's slope vanishes and the
    # second and third modes (their FE frequencies the least accurate, each resonant
    # with a harmonic) carry the torque; halving the step changes it by ~1e-3: the
    # error is the deck's discretisation, and it falls with it (2.6x for h / 2)
    assert errors[40] < 0.3, errors
    assert errors[80] < 0.12, errors
    assert errors[40] > 2.0 * errors[80], errors
