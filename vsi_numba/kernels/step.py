"""The step of the direct method (Neves et al., "A direct method for analyzing the
nonlinear vehicle-structure interaction", Eng. Struct. 69 (2014) 83-89): bridge, vehicles
and contact advanced together by one HHT-alpha step, the contact forces found on a
system in the forces alone.  The theory manual (docs/manual/theory.md) gives the method;
this module is it, in the order a step runs.

Legend (the symbols of Eqs. (3)-(12) of the 2014 paper)
--------------------------------------------------------
q, u        modal coordinates of the bridge (n_m) and vehicle DOFs (n_v), positive down
phi_j(x)    mass-normalised mode shapes along the track
r(x)        irregularity, positive = rail lower; the rail top is at sum_j phi_j q_j + r
B_i         constraint row of wheel i: B_i u = u_wheel - sum_j phi_j(x_i) q_j
gap_i       r(x_i) - B_i u  (>= 0; 0 in contact); on an elastic track phi_j are the
            track-filtered shapes (vsi_numba.model.track); the constant compliance C
            in series with the contact (the elastic rail's deflection under the
            wheels, linearised Hertz springs) adds sum_k C[i, k] X_k to the gap
X_i         contact force of wheel i (>= 0, compression), generalised force -B_i^T X_i
K^          effective stiffness a0 M + (1 + alpha)(a1 C + K): diagonal for the modes,
            a dense block per vehicle, inverted once per analysis
S           Schur complement B K^-1 B^T on the contact forces
a_e         row of nonlinear suspension element e (vsi_numba.kernels.suspension)

The HHT-alpha equilibrium at t_{n+1} (Eq. (3)),
    M a_{n+1} + (1 + alpha)(C v_{n+1} + K u_{n+1} - F_{n+1}) - alpha (C v_n + K u_n - F_n) = 0,
with the Newmark updates is linear in the increment Delta u: K^ Delta u = R0 - (1 + alpha)
B^T X.  So one step (:func:`hht_step`) is

0. contact search at t_{n+1}: which wheels are on the deck, phi, r there;
1. predictor y = K^-1 R0 (all contact forces zero);
2. predictor gaps g* = r - B (u_n + y), and the contact forces from
   g* + (1 + alpha) S X = gap with the unilateral law gap >= 0, X >= 0, gap X = 0
   (or Hertz: gap = -G X^(2/3));
3. corrector Delta u = y - (1 + alpha) K^-1 B^T X, Newmark updates;
4. a wheel that lands (or crosses an end of the deck) is a plastic impact: velocities
   projected on the constraints, accelerations made consistent
   (vsi_numba.kernels.impact).

:func:`vsi_step` wraps it in Newton on the branches of nonlinear suspension elements;
:func:`crossing_impact` is the impact of a deck-end crossing that falls (within round-off)
on the start of a step piece.
"""

from __future__ import annotations

from vsi_numba._jit import njit
from vsi_numba.kernels.contact import assemble_loads, contact_search
from vsi_numba.kernels.impact import impact_update
from vsi_numba.kernels.integrator import (
    hht_coefficients,
    hht_correct,
    restore_state,
    save_state,
    update_force_totals,
)
from vsi_numba.kernels.linalg import block_matvec, block_matvec_nz
from vsi_numba.kernels.schur import build_schur, contact_arrays, solve_active_set, solve_hertz
from vsi_numba.kernels.suspension import nl_residual, nl_update_branches, prepare_khat
from vsi_numba.kernels.track import track_element, track_predict, track_update
from vsi_numba.kernels.types import NOT_CONVERGED, OK, SINGULAR_SCHUR


@njit(kernel_only=True)
def hht_step(br, veh, pr, prm, st, wk, t1, dt, level):
    """Advance the state by one HHT-alpha step of size ``dt`` to time ``t1``.

    ``wk.was_active`` holds the contact set at the start of the step; on return
    ``wk.active`` holds the new one and ``wk.xout`` the step's contact forces.
    ``level`` >= 0: ``dt`` is the analysis step / 2^level, whose vehicle blocks of K^-1
    are packed; < 0: any other size (the blocks are inverted here).
    Returns (status, iterations); the state is garbage when status != 0.
    """
    alpha = prm.alpha
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    n_m = st.q.shape[0]
    n_v = st.u.shape[0]
    n_w = veh.wheel_dof.shape[0]
    speed = prm.speed
    if level < 0 or veh.nl_veh.shape[0] > 0:
        # a step that is not dt/2^level, or nonlinear elements: the blocks of this step
        # size and branch set (refactored only where they changed)
        if prepare_khat(veh, wk, level, dt, alpha) != 0:
            return SINGULAR_SCHUR, 0
        khat_v = wk.khv
    else:
        khat_v = veh.Khat_inv[level]

    for i in range(n_w):
        wk.onb_prev[i] = wk.onb[i]
    # 0. where the wheels and the loads are at t_{n+1}
    contact_search(br, veh, pr, t1, speed, wk)
    assemble_loads(br, veh, t1, speed, wk.fq, wk.phil, wk.hq, wk.rq)
    if veh.track_kappa > 0.0:  # the rail's inertia in the deck load (lagged one step)
        for i in range(n_w):
            if wk.onb[i] == 1 and wk.was_active[i] == 1:
                f = -veh.track_kappa * wk.trk[i, 2]
                for j in range(n_m):
                    wk.fq[j] += f * wk.phi[i, j]

    # 1. predictor y = K^-1 R0: the increment of the HHT equilibrium (Eq. (3)) with all
    #    contact forces at t_{n+1} zero; modes (diagonal K^), then the vehicle blocks
    for j in range(n_m):
        cq = 2.0 * br.zeta[j] * br.omega[j]
        wk.khat[j] = a0 + scale * (a1 * cq + br.omega[j] ** 2)
        r = (scale * wk.fq[j] - alpha * st.fq_tot[j] + a2 * st.qd[j] + a3 * st.qdd[j]
             - cq * (cv * st.qd[j] + ca * st.qdd[j]) - br.omega[j] ** 2 * st.q[j])
        wk.yq[j] = r / wk.khat[j]
    for k in range(n_v):
        wk.rv[k] = scale * veh.gravity[k] - alpha * st.fv_tot[k]
        wk.hv[k] = a2 * st.ud[k] + a3 * st.udd[k]
        wk.vv[k] = cv * st.ud[k] + ca * st.udd[k]
    block_matvec_nz(veh, veh.M, 0, wk.hv, wk.rv, 1.0)
    block_matvec_nz(veh, veh.C, 1, wk.vv, wk.rv, -1.0)
    block_matvec_nz(veh, veh.K, 2, st.u, wk.rv, -1.0)
    if veh.nl_veh.shape[0] > 0:
        nl_residual(veh, wk, st, dt, alpha)
    block_matvec(veh, khat_v, wk.rv, wk.yv, False, 1.0)

    # 2. the contact problem on the forces alone: predictor gaps g*, Schur complement
    #    S = B K^-1 B^T (plus the compliance in series), then rigid unilateral contact
    #    (active set, Sec. 3 of the 2014 paper) or Hertz
    for i in range(n_w):
        d = veh.wheel_dof[i]
        g = wk.rr[i, 0] - (st.u[d] + wk.yv[d])
        if wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
            for j in range(n_m):
                g += wk.phi[i, j] * (st.q[j] + wk.yq[j])
        wk.gstar[i] = g
        wk.active[i] = wk.was_active[i]
    build_schur(veh, wk, wk.khat, khat_v)
    if veh.compliance.shape[0] > 0:
        # compliance in series with the contact: gap = g* + (1 + alpha) S X + C X
        inv = 1.0 / scale
        for i in range(n_w):
            for p in range(veh.comp_ptr[i], veh.comp_ptr[i + 1]):
                k = veh.comp_col[p]
                wk.S[i, k] += veh.compliance[i, k] * inv
    if track_element(veh):
        track_predict(veh, wk, st, alpha, a0, a1, a2, a3, cv, ca, scale)
    cw = contact_arrays(veh, wk)
    if prm.contact_model == 1:
        for i in range(n_w):
            wk.X[i] = st.X[i]
        status, iters = solve_hertz(cw, scale, prm.hertz_g, prm.max_iter, prm.tol_force)
    else:
        status, iters = solve_active_set(cw, scale, prm.max_iter, prm.tol_gap, prm.tol_force)
    if status != OK:
        return status, iters

    # 3. corrector: Delta u = y - (1 + alpha) K^-1 B^T X, Newmark updates
    hht_correct(veh, st, wk, khat_v, a0, a2, a3, gamma, scale, dt)
    if track_element(veh):
        track_update(veh, wk, dt, a0, a1, a2, a3, gamma, scale)

    # 4. Velocity jumps of the rail under a wheel in contact are impacts: a landing, and
    # a wheel crossing an end of the deck, where the rail velocity v phi'(x) q jumps
    # to or from the rigid track's (the slope of the deflected deck at its ends).
    landing = False
    if prm.contact_model == 0 and br.track == 0:  # compliant contact: no impulse
        for i in range(n_w):
            wk.impulse[i] = 0.0
            if wk.active[i] == 1 and (wk.was_active[i] == 0 or wk.onb[i] != wk.onb_prev[i]):
                landing = True
    if landing:
        s = impact_update(br, veh, prm, st, wk, dt)
        if s != OK:
            return s, iters
    update_force_totals(br, veh, wk, st)
    return OK, iters


@njit(inline="always")
def vsi_step(br, veh, pr, prm, st, wk, t1, dt, level):
    """One step of the coupled system: :func:`hht_step` when every vehicle is linear
    (bit for bit); with nonlinear elements, Newton on their branches (Eq. (3) of the 2014
    paper with the tangent stiffness and damping of each branch): solve the step with
    the assumed branches, move the elements whose law the result violates, and solve it
    again from the saved state until no element moves (a piecewise-linear law: the
    iteration ends when the branch set is consistent; the vehicle blocks whose branch
    set changed are refactored).  Returns (status, contact iterations summed)."""
    nl = veh.nl_veh.shape[0] > 0
    n_w = veh.wheel_dof.shape[0]
    track = track_element(veh)
    off = wk.nbk.shape[0] - 3 * n_w
    if nl:
        save_state(st, wk.nbk)
        # the track elements under the wheels (damped/massive track) are state too: kept
        # at the end of the buffer (its last 3 n_w entries)
        if track:
            for i in range(n_w):
                for c in range(3):
                    wk.nbk[off + 3 * i + c] = wk.trk[i, c]
    total = 0
    for _ in range(prm.max_iter if nl else 1):
        status, iters = hht_step(br, veh, pr, prm, st, wk, t1, dt, level)
        total += iters
        if status != OK or not nl:
            return status, total
        if not nl_update_branches(veh, wk, st, prm.tol_force):
            return OK, total
        restore_state(wk.nbk, st)
        if track:
            for i in range(n_w):
                for c in range(3):
                    wk.trk[i, c] = wk.nbk[off + 3 * i + c]
        for i in range(n_w):
            wk.onb[i] = wk.onb_prev[i]
    return NOT_CONVERGED, total


@njit(inline="always")
def crossing_impact(br, veh, pr, prm, st, wk, tc):
    """The impact of wheels that crossed an end of the deck within
    ``CROSSING_MIN_FRACTION`` dt of the state's time: taken on the state as it is, at the
    crossing time ``tc`` (a piece that short is not integrated; see
    :func:`~vsi_numba.kernels.loop.time_loop`).
    Adds the impulses to ``wk.imp``; returns the status."""
    n_w = veh.wheel_dof.shape[0]
    for i in range(n_w):
        wk.onb_prev[i] = wk.onb[i]
        wk.X[i] = st.X[i]
        wk.xout[i] = st.X[i]
        wk.impulse[i] = 0.0
    contact_search(br, veh, pr, tc, prm.speed, wk)
    landing = False
    for i in range(n_w):
        if wk.active[i] == 1 and wk.onb[i] != wk.onb_prev[i]:
            landing = True
    if landing:
        status = impact_update(br, veh, prm, st, wk, prm.dt)
        if status != OK:
            return status
        update_force_totals(br, veh, wk, st)
        for i in range(n_w):
            wk.imp[i] += wk.impulse[i]
    return OK
