"""The contact problem of a step on the Schur complement S = B K^-1 B^T of the contact
forces (Neves et al. 2014, Sec. 3): its matrix and the skyline envelope of the active
block, rigid unilateral contact by the active-set method, Hertzian contact by Newton.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.linalg import skyline_cholesky_solve
from vsi_numba.kernels.types import NOT_CONVERGED, OK, SINGULAR_SCHUR, ContactArrays


@njit(inline="always")
def contact_arrays(veh, wk):
    """The :class:`~vsi_numba.kernels.types.ContactArrays` of a model and workspace."""
    return ContactArrays(veh.wheel_veh, veh.compliance, wk.onb, wk.S, wk.L, wk.J, wk.idx,
                         wk.rhs, wk.sol, wk.gstar, wk.X, wk.active, wk.first, wk.pf, wk.cand,
                         wk.lq, wk.lz, wk.lw, wk.lin)


@njit(inline="always")
def contact_profile(cw, m):
    """Envelope of the active Schur block: ``cw.first[a]`` is the first active position
    coupled to active position ``a`` (same vehicle, both wheels on the bridge, or close
    enough to share the deflection of an elastic rail).

    Wheels are numbered vehicle by vehicle along the train, so the block is a narrow
    skyline (a vehicle's wheels, plus the wheels on the bridge) and Cholesky costs
    O(m b^2) instead of O(m^3).

    The envelope depends only on the active wheels and their on-bridge flags (the
    vehicles and the rail's coupling are fixed over a run): when those are the ones of
    the previous call (``cw.pf``: m + 1, then the wheels, then their flags; 0 after
    :func:`reset_work`), ``cw.first`` is kept - most steps change neither.
    """
    n_w = cw.X.shape[0]
    same = cw.pf[0] == m + 1
    a = 0
    while same and a < m:
        i = cw.idx[a]
        same = cw.pf[1 + a] == i and cw.pf[1 + n_w + a] == cw.onb[i]
        a += 1
    if same:
        return
    cw.pf[0] = m + 1
    for a in range(m):
        i = cw.idx[a]
        cw.pf[1 + a] = i
        cw.pf[1 + n_w + a] = cw.onb[i]
        f = a
        for b in range(a):
            k = cw.idx[b]
            if (cw.wheel_veh[k] == cw.wheel_veh[i] or (cw.onb[i] == 1 and cw.onb[k] == 1)
                    or (cw.compliance.shape[0] > 0 and cw.compliance[i, k] != 0.0)):
                f = b
                break
        cw.first[a] = f


@njit(inline="always")
def build_schur(veh, wk, khat_q, A):
    """S_ik = B_i K^-1 B_k^T for all wheel pairs (or B_i M^-1 B_k^T with ``A = M_inv``
    and unit modal masses in ``khat_q``).

    The bridge part couples every pair of wheels on the bridge through the modes; the
    vehicle part couples the wheels of one vehicle.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = khat_q.shape[0]
    for i in range(n_w):
        # row i's flags in locals: the stores to S below could alias them for the compiler
        on_i = wk.onb[i] == 1
        b = veh.wheel_veh[i]
        st = veh.start[b]
        d_i = veh.wheel_dof[i] - st
        for k in range(i + 1):
            s = 0.0
            if on_i and wk.onb[k] == 1:
                for j in range(n_m):
                    s += wk.phi[i, j] * wk.phi[k, j] / khat_q[j]
            if veh.wheel_veh[k] == b:
                s += A[b, d_i, veh.wheel_dof[k] - st]
            wk.S[i, k] = s
            wk.S[k, i] = s


@njit(kernel_only=True)
def solve_active_set(cw, scale, max_iter, tol_gap, tol_force):
    """Unilateral contact by the active-set method on S X = -gap* / scale.

    On entry ``cw.active`` holds the initial guess and ``cw.gstar`` the gaps of the
    predictor (all X = 0).  A wheel in tension is released, a free wheel that
    penetrates is attached, until both sets are stable (Neves et al. 2014, Sec. 3).
    Returns (status, iterations); ``cw.X`` holds the contact forces.
    """
    n_w = cw.X.shape[0]
    for it in range(1, max_iter + 1):
        m = np.int64(0)
        for i in range(n_w):
            cw.X[i] = 0.0
            if cw.active[i] == 1:
                cw.idx[m] = i
                cw.rhs[m] = -cw.gstar[i] / scale
                m += 1
        if m > 0:
            contact_profile(cw, m)
            if skyline_cholesky_solve(cw.S, cw.idx, m, cw.first, cw.L, cw.rhs, cw.sol) != 0:
                return SINGULAR_SCHUR, it
            for a in range(m):
                cw.X[cw.idx[a]] = cw.sol[a]
        changed = False
        for i in range(n_w):
            if cw.active[i] == 1:
                if cw.X[i] < -tol_force:
                    cw.active[i] = 0
                    changed = True
            else:
                g = cw.gstar[i]
                for a in range(m):
                    g += scale * cw.S[i, cw.idx[a]] * cw.sol[a]
                if g < -tol_gap:
                    cw.active[i] = 1
                    changed = True
        if not changed:
            for i in range(n_w):
                if cw.X[i] < 0.0:
                    cw.X[i] = 0.0
            return OK, it
    return NOT_CONVERGED, max_iter


@njit(kernel_only=True)
def solve_hertz(cw, scale, g_hertz, max_iter, tol_force):
    """Hertzian contact: X_i = (delta_i / G)^(3/2) with the penetration
    delta_i = -gap_i = -(g*_i + scale (S X)_i), X_i = 0 where the wheel is separated.

    Newton on the active wheels with the tangent compliance d(delta)/dX on the diagonal
    of S; the active set follows the sign of each wheel's gap with its own force
    removed.  ``cw.X`` holds the starting guess (the forces at t_n) and the result.
    Returns (status, iterations).
    """
    n_w = cw.X.shape[0]
    for it in range(1, max_iter + 1):
        m = np.int64(0)
        changed = False
        for i in range(n_w):
            gf = cw.gstar[i]
            for k in range(n_w):
                if k != i:
                    gf += scale * cw.S[i, k] * cw.X[k]
            if gf < 0.0:
                if cw.X[i] <= 0.0:
                    # below both the rigid and the bare-Hertz single-wheel solutions
                    x_rigid = -gf / (scale * cw.S[i, i])
                    x_hertz = (-gf / g_hertz) ** 1.5
                    cw.X[i] = 0.5 * min(x_rigid, x_hertz)
                    changed = True
                cw.idx[m] = i
                m += 1
                cw.active[i] = 1
            else:
                if cw.X[i] != 0.0:
                    changed = True
                cw.X[i] = 0.0
                cw.active[i] = 0
        if m == 0:
            return OK, it
        xmax = 0.0
        for a in range(m):
            i = cw.idx[a]
            xi = cw.X[i]
            if xi > xmax:
                xmax = xi
            r = (cw.gstar[i] + g_hertz * xi ** (2.0 / 3.0)) / scale
            for b in range(m):
                k = cw.idx[b]
                r += cw.S[i, k] * cw.X[k]
                cw.J[i, k] = cw.S[i, k]
            cw.J[i, i] += (2.0 / 3.0) * g_hertz * xi ** (-1.0 / 3.0) / scale
            cw.rhs[a] = -r
        contact_profile(cw, m)
        if skyline_cholesky_solve(cw.J, cw.idx, m, cw.first, cw.L, cw.rhs, cw.sol) != 0:
            return SINGULAR_SCHUR, it
        dmax = 0.0
        for a in range(m):
            i = cw.idx[a]
            d = cw.sol[a]
            xn = cw.X[i] + d
            if xn <= 0.0:
                xn = 0.1 * cw.X[i]  # stay in the domain of X^(2/3)
            dd = abs(xn - cw.X[i])
            if dd > dmax:
                dmax = dd
            cw.X[i] = xn
        if not changed and dmax <= tol_force + 1e-12 * xmax:
            return OK, it
    return NOT_CONVERGED, max_iter
