"""Trains of moving forces (no vehicle DOFs, no contact): the modal HHT-alpha step with
only the loads on the bridge evaluated, every run of a batch in one kernel call.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.integrator import hht_coefficients, newmark
from vsi_numba.kernels.linalg import copy_into
from vsi_numba.kernels.record import le_list, record_modes
from vsi_numba.kernels.shapes import eval_modes
from vsi_numba.kernels.types import NON_FINITE, OK


@njit(kernel_only=True)
def load_windows(br, veh, speed, dt, n_steps, on, off):
    """Steps during which each moving force is on the bridge: load ``k`` is on it at the
    end of steps ``on[k] .. off[k] - 1`` (time ``(n + 1) dt`` at the end of step ``n``).

    Uses the comparison of :func:`assemble_loads` (on iff 0 <= x <= L with
    x = x0 + v t); x grows monotonically with t, so each window is one interval.
    """
    for k in range(veh.load_x0.shape[0]):
        x0 = veh.load_x0[k]
        # first step whose end time puts the load at x >= 0, then at x > L
        n = int(np.floor(-x0 / (speed * dt))) - 2
        if n < 0:
            n = 0
        while n < n_steps and x0 + speed * ((n + 1) * dt) < 0.0:
            n += 1
        on[k] = n
        m = int(np.floor((br.length - x0) / (speed * dt))) - 2
        if m < n:
            m = n
        while m < n_steps and not x0 + speed * ((m + 1) * dt) > br.length:
            m += 1
        off[k] = m


@njit(kernel_only=True)
def window_sums(veh, n, on, off, cs, sums):
    """Phasor sums of the loads on the bridge during step ``n`` (sine modes):
    ``sums[0, j] + i sums[1, j] = sum_k P_k exp(i (j+1) k1 x0_k)``.

    Returns the next step at which a load enters or leaves the bridge.
    """
    n_m = sums.shape[1]
    for j in range(n_m):
        sums[0, j] = 0.0
        sums[1, j] = 0.0
    nxt = 1 << 62
    for k in range(veh.load_x0.shape[0]):
        if on[k] > n:
            if on[k] < nxt:
                nxt = on[k]
            continue
        if off[k] <= n:
            continue
        if off[k] < nxt:
            nxt = off[k]
        p = veh.load_p[k]
        c1 = cs[0, k]
        s1 = cs[1, k]
        c = c1
        s = s1
        for j in range(n_m):
            sums[0, j] += p * c
            sums[1, j] += p * s
            c, s = c * c1 - s * s1, s * c1 + c * s1
    return nxt


@njit
def run_batch_mf(br, veh, prm, speeds, n_steps, init, st, wk, red, out, slots, status,
                 reached, on, off, cs, sums):
    """:func:`run_batch` of a moving-force model: every run in one call (thousands of
    short runs in a design catalogue), each the time loop of a train of moving forces
    only (no vehicle DOFs, no contact).  ``on``, ``off`` (n_loads,) int64, ``cs``
    (2, n_loads) and ``sums`` (2, n_modes) are its scratch arrays.

    Run ``r`` integrates ``n_steps[r]`` steps at ``speeds[r]`` from row ``r`` of ``init``
    (recorded as step 0) into row ``r`` of the envelopes (and history slot ``slots[r]``
    if >= 0); ``status[r]``, ``reached[r]``: its status and the step it reached.  The
    same HHT-alpha arithmetic per mode as :func:`hht_step` with no wheels, without the
    work that has nothing to act on: the modes are uncoupled, and only the loads on the
    bridge are evaluated.  For sine modes (simply supported span) the modal load is
    sum_k P_k a_j sin((j+1) k1 (x0_k + v t)) = a_j Im(exp(i (j+1) k1 v t) Z_j), with the
    phasor sums Z_j = sum_k P_k exp(i (j+1) k1 x0_k) over the loads on the bridge
    rebuilt only when a load enters or leaves it: O(n_m) per step instead of
    O(n_loads n_m), equal to the direct sum to round-off (a few 1e-14 relative: the
    phases are products of up to ~1e3 rad).  Other bridges sum the loads directly, in
    the order of :func:`assemble_loads` (bit for bit the general step's numbers).
    The runs are in this one kernel, not in a kernel per run it calls: numba would emit
    the callee's code again inside this one.
    """
    alpha = prm.alpha
    dt = prm.dt
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    n_m = st.q.shape[0]
    n_l = veh.load_x0.shape[0]
    cq = wk.hq
    w2 = wk.rq
    q = st.q
    qd = st.qd
    qdd = st.qdd
    fq_tot = st.fq_tot
    fq = wk.fq
    khat = wk.khat
    amp = br.sine_amp
    load_x0 = veh.load_x0
    load_p = veh.load_p
    le_on = red.le_E.shape[1] > 0
    order = red.le_order
    k1 = br.sine_k[0] if br.kind == 1 and n_m > 0 else 0.0
    for r in range(speeds.shape[0]):
        # the state from row r; the workspace needs no reset: the moving-force loop writes
        # every scratch value it reads (and has no wheels)
        copy_into(init.q[r], st.q)
        copy_into(init.qd[r], st.qd)
        copy_into(init.qdd[r], st.qdd)
        copy_into(init.fq_tot[r], st.fq_tot)
        speed = speeds[r]
        n_run = n_steps[r]
        h = slots[r]
        for j in range(n_m):
            cq[j] = 2.0 * br.zeta[j] * br.omega[j]
            w2[j] = br.omega[j] ** 2
            khat[j] = a0 + scale * (a1 * cq[j] + w2[j])
        load_windows(br, veh, speed, dt, n_run, on, off)
        lo = n_l  # moving loads on the bridge: order[lo:hi] (ascending x: a window)
        hi = n_l
        first = 0  # loads before ``first`` have left the bridge for good
        nxt = 0  # next step at which the loads on the bridge change (sine modes)
        if br.kind == 1:
            for k in range(n_l):
                cs[0, k] = np.cos(k1 * load_x0[k])
                cs[1, k] = np.sin(k1 * load_x0[k])
        s = OK
        reached_r = n_run
        # n = -1: no step, the initial state recorded as step 0 (t = 0)
        for n in range(-1, n_run):
            t1 = (n + 1) * dt
            if n >= 0:
                for j in range(n_m):
                    fq[j] = 0.0
                if br.kind == 1 and n_m > 0:
                    if n == nxt:
                        nxt = window_sums(veh, n, on, off, cs, sums)
                    ang = k1 * (speed * t1)
                    c1 = np.cos(ang)
                    s1 = np.sin(ang)
                    c = c1
                    sn = s1
                    for j in range(n_m):
                        fq[j] = amp[j] * (sn * sums[0, j] + c * sums[1, j])
                        c, sn = c * c1 - sn * s1, sn * c1 + c * s1
                elif br.kind != 0:
                    while first < n_l and off[first] <= n and on[first] <= n:
                        first += 1
                    for k in range(first, n_l):
                        if n < on[k] or n >= off[k]:
                            continue
                        x = load_x0[k] + speed * t1
                        eval_modes(br, x, wk.phil, wk.yq, wk.vq, np.int64(0))
                        p = load_p[k]
                        for j in range(n_m):
                            fq[j] += p * wk.phil[j]
                finite = 0.0
                for j in range(n_m):
                    rj = (scale * fq[j] - alpha * fq_tot[j] + a2 * qd[j] + a3 * qdd[j]
                          - cq[j] * (cv * qd[j] + ca * qdd[j]) - w2[j] * q[j])
                    dq = rj / khat[j]
                    qd[j], qdd[j] = newmark(dq, qd[j], qdd[j], a0, a2, a3, gamma, dt)
                    q[j] += dq
                    fq_tot[j] = fq[j]
                    finite += q[j] + qd[j] + qdd[j]
                if not np.isfinite(finite):
                    s = NON_FINITE
                    reached_r = n + 1
                    break
            t = float(n + 1) * dt
            nl = np.int64(0)
            if le_on:
                if n < 0:  # the loads on the deck at t = 0
                    nl = le_list(red, veh.wheel_x0, veh.wheel_sf, st.X, load_x0, veh.load_sf,
                                 load_p, t, speed)
                else:  # the window of loads on the bridge, ascending
                    while lo > 0 and on[order[lo - 1]] <= n:
                        lo -= 1
                    while hi > lo and off[order[hi - 1]] <= n:
                        hi -= 1
                    for i in range(lo, hi):
                        k = order[i]
                        red.le_lx[nl] = load_x0[k] + speed * t1
                        red.le_lp[nl] = load_p[k]
                        nl += 1
            record_modes(red, q, qdd, fq_tot, r, n + 1, t, nl, out, h, 1 if n >= 0 else 0)
        if s == OK and n_run > 0 and red.iters[r] < 1:
            red.iters[r] = 1  # the contact "solve" with no wheels: one pass per step
        status[r] = s
        reached[r] = reached_r
