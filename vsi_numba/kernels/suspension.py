"""Nonlinear suspension elements (bump stops, damper blow-off): piecewise-linear laws on
top of the linear spring-dashpots of the vehicle matrices, solved by Newton on their
branches (Eq. (3) of Neves et al. 2014).

Element e has the row a_e over its vehicle's DOFs: its compression delta_e = a_e u
(velocity a_e udot); its force beyond the linear spring-dashpot (already in K, C) is
f_e(delta_e, deltadot_e), piecewise linear (bump stop: k_s (delta - delta_on) above
delta_on; damper blow-off: the damper force saturated at F_b plus c2 beyond); on branch
b of each element f_e = k_t delta + c_t deltadot + f_0, so R(u) is solved with the
tangent K_t = K + sum_e k_t a_e^T a_e, C_t likewise.
"""

from __future__ import annotations

from vsi_numba._jit import njit
from vsi_numba.kernels.integrator import hht_coefficients
from vsi_numba.kernels.linalg import invert_small
from vsi_numba.kernels.types import NL_BUMP_STOP


@njit(inline="always")
def nl_law(kind, p, branch):
    """(k_t, c_t, f_0) of a nonlinear element on ``branch``: its force beyond the linear
    spring-dashpot is k_t delta + c_t deltadot + f_0 (N; see the legend)."""
    if branch == 0:
        return 0.0, 0.0, 0.0
    if kind == NL_BUMP_STOP:  # p = (delta_on, k_s, -)
        return p[1], 0.0, -p[1] * p[0]
    # blow-off, p = (c, F_b, c2): F_b + c2 (deldot - F_b / c) beyond +F_b / c, minus c deldot
    return 0.0, p[2] - p[0], branch * (p[1] - p[2] * p[1] / p[0])


@njit(inline="always")
def nl_branch(kind, p, d, dd):
    """Branch of a nonlinear element at compression ``d`` and its rate ``dd``: bump stop
    0 open, 1 closed; blow-off 0 linear, +1 / -1 blown off in compression / extension."""
    if kind == NL_BUMP_STOP:
        return 1 if d > p[0] else 0
    f = p[0] * dd
    if f > p[1]:
        return 1
    if f < -p[1]:
        return -1
    return 0


@njit(inline="always")
def nl_strain(veh, e, x):
    """a_e x: the compression (or its rate, its acceleration) of element ``e``."""
    b = veh.nl_veh[e]
    s0 = veh.start[b]
    s = 0.0
    for c in range(veh.start[b + 1] - s0):
        s += veh.nl_a[e, c] * x[s0 + c]
    return s


@njit(inline="always")
def nl_signature(veh, wk, b):
    """Branch set of vehicle ``b`` as one integer (0: every element on its linear
    branch)."""
    sig = 0
    w = 1
    for e in range(veh.nl_start[b], veh.nl_start[b + 1]):
        k = wk.nlb[e]
        sig += (k if k >= 0 else 2) * w
        w *= 3
    return sig


@njit(kernel_only=True)
def prepare_khat(veh, wk, level, dt, alpha):
    """Fill ``wk.khv`` with the effective-stiffness inverse of every vehicle block for
    the step size ``dt`` and the elements' branches ``wk.nlb``: the packed
    ``Khat_inv[level]`` where that is the one (``level >= 0``, linear branches), else
    a0 M + (1 + alpha)(a1 (C + C_t) + K + K_t) inverted here.  A block is refactored
    only when its step size or branch set changed.  Returns 0, or 1 if one is singular.
    """
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    has_nl = veh.nl_veh.shape[0] > 0
    for b in range(veh.start.shape[0] - 1):
        sig = nl_signature(veh, wk, b) if has_nl else 0
        if wk.kh_dt[b] == dt and wk.kh_sig[b] == sig:
            continue
        n = veh.start[b + 1] - veh.start[b]
        if sig == 0 and level >= 0:
            for r in range(n):
                for c in range(n):
                    wk.khv[b, r, c] = veh.Khat_inv[level, b, r, c]
        else:
            A = wk.kscr
            for r in range(n):
                for c in range(n):
                    A[r, c] = a0 * veh.M[b, r, c] + scale * (a1 * veh.C[b, r, c]
                                                             + veh.K[b, r, c])
            if has_nl:
                for e in range(veh.nl_start[b], veh.nl_start[b + 1]):
                    kt, ct, f0 = nl_law(veh.nl_kind[e], veh.nl_p[e], wk.nlb[e])
                    w = scale * (kt + a1 * ct)
                    if w != 0.0:
                        for r in range(n):
                            for c in range(n):
                                A[r, c] += w * veh.nl_a[e, r] * veh.nl_a[e, c]
            if invert_small(A, n, wk.khv[b]) != 0:
                return 1
        wk.kh_dt[b] = dt
        wk.kh_sig[b] = sig
    return 0


@njit(kernel_only=True)
def nl_residual(veh, wk, st, dt, alpha):
    """Add the nonlinear elements to the HHT residual of the vehicles (``wk.rv``):
    -(1 + alpha) a_e (k_t delta_n + c_t a_e v* + f_0) + alpha a_e f_e(delta_n, deltadot_n)
    on the branches ``wk.nlb`` (v* = udot_{n+1} - a1 Delta u, the part of the new
    velocity known at t_n); the rest, (1 + alpha)(k_t + a1 c_t) a_e^T a_e Delta u, is in
    the block of :func:`prepare_khat`."""
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    beta = 0.25 * (1.0 - alpha) ** 2
    wv = 1.0 - gamma / beta
    wa = dt * (1.0 - 0.5 * gamma / beta)
    for e in range(veh.nl_veh.shape[0]):
        kind = veh.nl_kind[e]
        p = veh.nl_p[e]
        d = nl_strain(veh, e, st.u)
        dd = nl_strain(veh, e, st.ud)
        vs = wv * dd + wa * nl_strain(veh, e, st.udd)
        k0, c0, f00 = nl_law(kind, p, nl_branch(kind, p, d, dd))
        kt, ct, f0 = nl_law(kind, p, wk.nlb[e])
        g = alpha * (k0 * d + c0 * dd + f00) - scale * (kt * d + ct * vs + f0)
        b = veh.nl_veh[e]
        s0 = veh.start[b]
        for c in range(veh.start[b + 1] - s0):
            wk.rv[s0 + c] += veh.nl_a[e, c] * g


@njit(kernel_only=True)
def nl_update_branches(veh, wk, st, tol):
    """Newton update of the branches from the state just computed: an element whose
    assumed branch gives a force more than ``tol`` (N) off its law moves to the branch
    of its new compression and rate.  Returns True if any moved."""
    changed = False
    for e in range(veh.nl_veh.shape[0]):
        kind = veh.nl_kind[e]
        p = veh.nl_p[e]
        d = nl_strain(veh, e, st.u)
        dd = nl_strain(veh, e, st.ud)
        bn = nl_branch(kind, p, d, dd)
        if bn != wk.nlb[e]:
            kt, ct, f0 = nl_law(kind, p, wk.nlb[e])
            kn, cn, fn = nl_law(kind, p, bn)
            if abs((kt - kn) * d + (ct - cn) * dd + f0 - fn) > tol:
                wk.nlb[e] = bn
                changed = True
    return changed
