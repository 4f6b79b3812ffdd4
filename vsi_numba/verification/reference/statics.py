"""Static load effects: influence lines and crawl-speed effects of simply supported and
two-span continuous decks, LM71's extreme effect, and the modes table another program
would export."""

from __future__ import annotations

import numpy as np

from vsi_numba.verification.reference.beam import ss_omega


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
