"""Plastic unilateral impacts (a wheel landing on the rail, or crossing the kink of the
running surface at an end of the deck): the LCP of the impulses, the velocity projection,
then the accelerations and contact forces consistent with the constraints
(docs/manual/theory.md, "Contact and impacts").
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.linalg import block_matvec, skyline_cholesky_solve
from vsi_numba.kernels.schur import build_schur, contact_arrays, contact_profile
from vsi_numba.kernels.types import NOT_CONVERGED, OK, SINGULAR_IMPACT

# Murty's least-index rule after this many block-pivoting sweeps of :func:`solve_lcp`
# (block pivoting is fast but may cycle; the least-index rule terminates for any
# P-matrix, and S = G M^-1 G^T is symmetric positive definite).
LCP_BLOCK_SWEEPS = 4
# Share of the step's contact impulse dt X_i that an impact may take back from a wheel
# in contact through the step (see :func:`impact_allowance`).
IMPULSE_ALLOWANCE = 1.0


@njit(kernel_only=True)
def solve_lcp(cw, m, max_iter, tol_z, tol_w):
    """The small LCP of the wheels ``cw.cand[0:m]`` (ascending) on the matrix ``cw.S``.

    Finds z >= 0 with w = S z + q >= 0 and z_i w_i = 0 (q in ``cw.lq``, per wheel), by
    principal pivoting: solve S_AA z_A = -q_A on the set A (skyline Cholesky, see
    :func:`skyline_cholesky_solve`), move a wheel with z_i < -tol_z out of A and one with
    w_i < -tol_w into it; block sweeps first, then Murty's least-index rule (finite for
    a positive definite S).  ``cw.lin`` holds the initial set (1 = in A) and the final
    one; ``cw.lz`` receives z (0 off A), ``cw.lw`` w (0 on A).
    Returns (status, iterations): OK, SINGULAR_IMPACT or NOT_CONVERGED.
    """
    for it in range(1, max_iter + 1):
        na = np.int64(0)
        for a in range(m):
            i = cw.cand[a]
            cw.lz[i] = 0.0
            if cw.lin[i] == 1:
                cw.idx[na] = i
                cw.rhs[na] = -cw.lq[i]
                na += 1
        if na > 0:
            contact_profile(cw, na)
            if skyline_cholesky_solve(cw.S, cw.idx, na, cw.first, cw.L, cw.rhs,
                                      cw.sol) != 0:
                return SINGULAR_IMPACT, it
            for a in range(na):
                cw.lz[cw.idx[a]] = cw.sol[a]
        n_bad = 0
        for a in range(m):
            i = cw.cand[a]
            if cw.lin[i] == 1:
                cw.lw[i] = 0.0
                bad = cw.lz[i] < -tol_z
            else:
                w = cw.lq[i]
                for b in range(na):
                    w += cw.S[i, cw.idx[b]] * cw.sol[b]
                cw.lw[i] = w
                bad = w < -tol_w
            if bad:
                n_bad += 1
                if it <= LCP_BLOCK_SWEEPS or n_bad == 1:
                    cw.lin[i] = 1 - cw.lin[i]  # block sweep: flip all; Murty: the first
        if n_bad == 0:
            for a in range(m):
                i = cw.cand[a]
                if cw.lz[i] < 0.0:
                    cw.lz[i] = 0.0
            return OK, it
    return NOT_CONVERGED, max_iter


@njit(inline="always")
def impact_allowance(wk, st, i, dt, alpha):
    """Tensile impulse (N s) the impact may apply to wheel ``i``: the compressive impulse
    that its contact force transmitted in the step, dt ((1 + alpha) X_{n+1} - alpha X_n),
    so that the wheel's net contact impulse over the step stays compressive (Moreau's
    impulse form of the unilateral law).  That covers a wheel that stayed on the same
    rail (an impact elsewhere must not tear it off for less than a step) and a landing
    wheel (the displacement constraint of the landing step overshoots the velocity:
    the projection takes the overshoot back).  0 for a wheel in contact that crosses a
    deck end: the rail's velocity jumps at the end of the step, after the step's force
    was spent on the other rail, and the impact may only push."""
    if wk.was_active[i] == 1 and wk.onb[i] != wk.onb_prev[i]:
        return 0.0
    p = dt * ((1.0 + alpha) * wk.xout[i] - alpha * st.X[i])
    return IMPULSE_ALLOWANCE * p if p > 0.0 else 0.0


@njit(kernel_only=True)
def project_velocities(br, veh, wk, st, speed, dt, alpha, max_iter, tol_force, tol_gap):
    """Plastic unilateral impact: make the velocities of the wheels in contact compatible
    with the rail, with compressive impulses only.

    Design note 1.4: with the pre-impact separation velocity q = rdot_rel - G udot
    (rdot_rel = v_i (r' + sum_j phi_j' q_j) the convective rail velocity, v_i the
    wheel's signed speed) and the
    compressive impulses P (udot += -M^-1 G^T P), the post-impact separation velocity is
    w = q + G M^-1 G^T P.  The LCP  P_i + b_i >= 0, w_i >= 0, (P_i + b_i) w_i = 0  over
    the active massive wheels (:func:`solve_lcp`, shifted by the allowance b of
    :func:`impact_allowance`) gives P; a wheel left separating (w_i > tol) is released
    (``wk.active[i] = 0``), whatever its gap.  ``wk.impulse`` receives P (N s).
    Massless wheels take no impulse: their velocity is set to the rail's afterwards.
    Returns a status code.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = st.q.shape[0]
    tol_z = tol_force * dt
    tol_w = tol_gap / dt
    build_schur(veh, wk, wk.ones, veh.M_inv)
    m = np.int64(0)
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 0:
            g = st.ud[veh.wheel_dof[i]]
            v = veh.wheel_sf[i] * speed  # the wheel's own (signed) speed
            rd = v * wk.rr[i, 1]
            for j in range(n_m):
                g -= wk.phi[i, j] * st.qd[j]
                rd += v * wk.dphi[i, j] * st.q[j]
            wk.cand[m] = i
            wk.lq[i] = rd - g
            wk.lin[i] = 1
            m += 1
    if m > 0:
        # shift P = z - b: w = S z + (q - S b)
        for a in range(m):
            i = wk.cand[a]
            s = wk.lq[i]
            for c in range(m):
                k = wk.cand[c]
                bk = impact_allowance(wk, st, k, dt, alpha)
                if bk != 0.0:
                    s -= wk.S[i, k] * bk
            wk.lq[i] = s
        status, _ = solve_lcp(contact_arrays(veh, wk), m, max_iter, tol_z, tol_w)
        if status != OK:
            return status
        for a in range(m):
            i = wk.cand[a]
            p = wk.lz[i] - impact_allowance(wk, st, i, dt, alpha)
            wk.impulse[i] = p
            b = veh.wheel_veh[i]
            s0 = veh.start[b]
            n = veh.start[b + 1] - s0
            c = veh.wheel_dof[i] - s0
            if p != 0.0:
                for r in range(n):
                    st.ud[s0 + r] -= veh.M_inv[b, r, c] * p
                for j in range(n_m):
                    st.qd[j] += wk.phi[i, j] * p
        for a in range(m):
            i = wk.cand[a]
            if wk.lin[i] == 0 and wk.lw[i] > tol_w:
                wk.active[i] = 0  # separating: released
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            v = veh.wheel_sf[i] * speed
            rd = v * wk.rr[i, 1]
            for j in range(n_m):
                rd += v * wk.dphi[i, j] * st.q[j] + wk.phi[i, j] * st.qd[j]
            st.ud[veh.wheel_dof[i]] = rd
    return OK


@njit(kernel_only=True)
def consistent_accelerations(br, veh, wk, st, speed, scale, dt, max_iter, tol_force,
                             tol_gap):
    """Accelerations and contact forces consistent with equilibrium and the unilateral
    constraints.

    Solves M a = h - scale B^T X with, for the active wheels, the relative acceleration
    w = c - G a >= 0, X >= 0, X_i w_i = 0 (an LCP, :func:`solve_lcp`), where
    ``wk.hq``/``wk.hv`` hold h (the HHT-weighted residual without contact forces) and
    c_i = v^2 (r'' + sum phi'' q) + 2 v sum phi' qdot is the rail acceleration that is
    not carried by qddot; G a = G a0 - scale S X with a0 = M^-1 h, so
    w / scale = S X + (c - G a0) / scale.  A wheel whose force would be tensile is
    released (``wk.active[i] = 0``).  Massless active wheels carry X_i = h_i / scale,
    or are released if that is tensile.  Returns a status code.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = st.q.shape[0]
    tol_w = tol_gap / (dt * dt * scale)
    for i in range(n_w):
        wk.X[i] = 0.0
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            xi = wk.hv[veh.wheel_dof[i]] / scale
            if xi < -tol_force:
                wk.active[i] = 0  # the suspension pulls the contact point off the rail
                continue
            wk.X[i] = xi
            for j in range(n_m):
                wk.hq[j] += scale * wk.phi[i, j] * xi
            wk.hv[veh.wheel_dof[i]] = 0.0
    # unconstrained accelerations a0 = M^-1 h
    for j in range(n_m):
        st.qdd[j] = wk.hq[j]
    block_matvec(veh, veh.M_inv, wk.hv, st.udd, False, 1.0)
    build_schur(veh, wk, wk.ones, veh.M_inv)
    m = np.int64(0)
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 0:
            ga = st.udd[veh.wheel_dof[i]]
            v = veh.wheel_sf[i] * speed
            c = v * v * wk.rr[i, 2]
            for j in range(n_m):
                ga -= wk.phi[i, j] * st.qdd[j]
                c += (v * v * wk.d2phi[i, j] * st.q[j]
                      + 2.0 * v * wk.dphi[i, j] * st.qd[j])
            wk.cand[m] = i
            wk.lq[i] = (c - ga) / scale
            wk.lin[i] = 1
            m += 1
    if m > 0:
        status, _ = solve_lcp(contact_arrays(veh, wk), m, max_iter, tol_force, tol_w)
        if status != OK:
            return status
        for a in range(m):
            i = wk.cand[a]
            xi = wk.lz[i]
            if xi == 0.0:
                if wk.lin[i] == 0 and wk.lw[i] > tol_w:
                    wk.active[i] = 0  # accelerating away from the rail: released
                continue
            wk.X[i] = xi
            b = veh.wheel_veh[i]
            s0 = veh.start[b]
            n = veh.start[b + 1] - s0
            c0 = veh.wheel_dof[i] - s0
            for r in range(n):
                st.udd[s0 + r] -= scale * veh.M_inv[b, r, c0] * xi
            for j in range(n_m):
                st.qdd[j] += scale * wk.phi[i, j] * xi
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            v = veh.wheel_sf[i] * speed
            a = v * v * wk.rr[i, 2]
            for j in range(n_m):
                a += (v * v * wk.d2phi[i, j] * st.q[j]
                      + 2.0 * v * wk.dphi[i, j] * st.qd[j] + wk.phi[i, j] * st.qdd[j])
            st.udd[veh.wheel_dof[i]] = a
    return OK


@njit(kernel_only=True)
def impact_update(br, veh, prm, st, wk, dt):
    """The plastic unilateral impact of the wheels that land or cross a deck end in a
    step of size ``dt`` just completed (``st`` at its end, ``wk.X`` its contact forces,
    ``wk.onb_prev``/``wk.was_active`` the flags at its start).  Returns a status code."""
    alpha = prm.alpha
    scale = 1.0 + alpha
    speed = prm.speed
    n_m = st.q.shape[0]
    n_v = st.u.shape[0]
    n_w = veh.wheel_dof.shape[0]
    # A landing is a plastic, unilateral impact (docs/manual/theory.md, "Contact and
    # impacts"): make the velocities compatible with the rail with compressive
    # impulses only (an LCP: a wheel whose rail moves away is released, whatever its
    # gap), then the
    # accelerations consistent with the HHT equilibrium  M a1 + (1+alpha) B^T X1 = h
    # and X1 >= 0 (a wheel whose force would be tensile is released too).  h of
    # the completed step is h_step = M a1 + (1+alpha) B^T X_step; the velocity jump
    # dv changes it by -(1+alpha) C dv.
    for j in range(n_m):
        wk.vq[j] = st.qd[j]
        wk.hq[j] = st.qdd[j]
    for k in range(n_v):
        wk.vv[k] = st.ud[k]
        wk.av[k] = st.udd[k]
    block_matvec(veh, veh.M, st.udd, wk.hv, False, 1.0)
    for i in range(n_w):
        xi = wk.X[i]
        wk.hv[veh.wheel_dof[i]] += scale * xi
        for j in range(n_m):
            wk.hq[j] -= scale * wk.phi[i, j] * xi
    s = project_velocities(br, veh, wk, st, speed, dt, alpha, prm.max_iter,
                           prm.tol_force, prm.tol_gap)
    if s != OK:
        return s
    for j in range(n_m):
        cq = 2.0 * br.zeta[j] * br.omega[j]
        wk.hq[j] -= scale * cq * (st.qd[j] - wk.vq[j])
    for k in range(n_v):
        wk.vv[k] = st.ud[k] - wk.vv[k]
    block_matvec(veh, veh.C, wk.vv, wk.hv, True, -scale)
    s = consistent_accelerations(br, veh, wk, st, speed, scale, dt, prm.max_iter,
                                 prm.tol_force, prm.tol_gap)
    if s != OK:
        return s
    for i in range(n_w):
        if wk.active[i] == 0:
            wk.xout[i] = 0.0  # released in the impact: separated at t_{n+1}
            if veh.wheel_massless[i] == 1:
                d = veh.wheel_dof[i]
                st.udd[d] = wk.av[d]
    return OK
