"""What the time loops keep of each step: the envelopes of the deck, wheels and car bodies,
the load effects by the mode-acceleration method, and the raw histories of the runs that
keep them.  The bridge's part, :func:`record_modes`, serves both time loops
(interaction and moving forces); :func:`record` adds the wheels and car bodies.
"""

from __future__ import annotations

from vsi_numba._jit import njit
from vsi_numba.kernels.types import StepArrays


@njit(inline="always")
def step_arrays(veh, st, wk):
    """The :class:`~vsi_numba.kernels.types.StepArrays` of a model, state and workspace."""
    return StepArrays(veh.wheel_x0, veh.wheel_sf, veh.body_dof, veh.body_pt_start,
                      veh.body_pt_pitch,
                      veh.body_pt_d, veh.body_end_start, veh.body_end_pitch, veh.body_end_d,
                      st.q, st.qdd, st.udd, st.fq_tot, wk.xout, wk.active)


@njit(kernel_only=True)
def record(sa, red, r, n, t, speed, out, h, iters, nl):
    """Fold step ``n`` (time ``t``) of the interaction loop into the envelopes of run
    ``r`` and, when ``h >= 0``, store it in history slot ``h``: the bridge's part
    (:func:`record_modes`), then the wheels and the car bodies.  ``sa``: the step's
    :class:`~vsi_numba.kernels.types.StepArrays` (:func:`step_arrays`); ``iters``: its
    contact iterations; ``nl``: the loads on the deck (:func:`le_list`)."""
    record_modes(red, sa.q, sa.qdd, sa.fq_tot, r, n, t, nl, out, h, iters)
    for i in range(sa.wheel_x0.shape[0]):
        x = sa.xout[i]
        if n == 0 or x < red.xmin[r, i]:
            red.xmin[r, i] = x
            red.xmin_x[r, i] = sa.wheel_x0[i] + (sa.wheel_sf[i] * speed) * t
        if n == 0 or x > red.xmax[r, i]:
            red.xmax[r, i] = x
        if sa.active[i] == 0:
            red.lost[r, i] += 1
            red.run_len[i] += 1
            if red.run_len[i] > red.longest[r, i]:
                red.longest[r, i] = red.run_len[i]
        elif red.run_len[i] > 0:
            close_separation(red, r, i)
    for b in range(sa.body_dof.shape[0]):
        d = sa.body_dof[b]
        a0 = sa.udd[d] if d >= 0 else 0.0
        k0 = sa.body_pt_start[b]
        for k in range(k0, sa.body_pt_start[b + 1]):
            th = sa.body_pt_pitch[k]
            a = abs(a0 + sa.body_pt_d[k] * sa.udd[th]) if th >= 0 else abs(a0)
            if (n == 0 and k == k0) or a > red.body[r, b]:
                red.body[r, b] = a
                red.body_t[r, b] = t
                red.body_x[r, b] = sa.body_pt_d[k]
        k0 = sa.body_end_start[b]
        for k in range(k0, sa.body_end_start[b + 1]):
            th = sa.body_end_pitch[k]
            a = abs(a0 + sa.body_end_d[k] * sa.udd[th]) if th >= 0 else abs(a0)
            if (n == 0 and k == k0) or a > red.body_end[r, b]:
                red.body_end[r, b] = a
                red.body_end_t[r, b] = t
                red.body_end_x[r, b] = sa.body_end_d[k]
    if iters > red.iters[r]:
        red.iters[r] = iters
    if h >= 0:
        for i in range(sa.wheel_x0.shape[0]):
            out.X[h, n, i] = sa.xout[i]
            out.contact[h, n, i] = sa.active[i]
        for b in range(sa.body_dof.shape[0]):
            d = sa.body_dof[b]
            out.body_acc[h, n, b] = sa.udd[d] if d >= 0 else 0.0
            pa = 0.0
            for k in range(sa.body_pt_start[b], sa.body_pt_start[b + 1]):
                if sa.body_pt_pitch[k] >= 0:
                    pa = sa.udd[sa.body_pt_pitch[k]]
            out.body_pitch[h, n, b] = pa


@njit(inline="always")
def record_modes(red, q, qdd, f, r, n, t, nl, out, h, iters):
    """The bridge's part of step ``n`` (time ``t``; modal displacements ``q``,
    accelerations ``qdd``, total modal force ``f``), for both time loops: the deck's
    envelopes at the output points and on the whole-deck grid, the load effects of the
    ``nl`` loads on the deck in ``red.le_lx``/``red.le_lp`` (ascending), and, when
    ``h >= 0``, the modal histories of slot ``h`` with the step's ``iters``.

    Every envelope starts at step 0 (the load effects' at -inf/+inf) and keeps the first
    step and point that reach its extreme (strict comparisons).
    """
    n_m = q.shape[0]
    for p in range(red.phi_d.shape[0]):
        w = 0.0
        a = 0.0
        for j in range(n_m):
            w += red.phi_d[p, j] * q[j]
            a += red.phi_a[p, j] * qdd[j]
        w = abs(w)
        a = abs(a)
        if n == 0 or w > red.disp[r, p]:
            red.disp[r, p] = w
            red.disp_t[r, p] = t
        if n == 0 or a > red.acc[r, p]:
            red.acc[r, p] = a
            red.acc_t[r, p] = t
    # whole-deck grid, only when the bound sum_j max|phi_j| |qdd_j| could raise the
    # envelope (exact: the skipped steps cannot); mode-outer sums
    n_g = red.gwork.shape[0]
    bound = 0.0
    for j in range(red.phi_g.shape[0]):
        bound += red.phi_gmax[j] * abs(qdd[j])
    if n_g > 0 and (n == 0 or bound > red.gacc[r]):
        g = red.gwork
        for p in range(n_g):
            g[p] = 0.0
        for j in range(red.phi_g.shape[0]):
            aj = qdd[j]
            for p in range(n_g):
                g[p] += red.phi_g[j, p] * aj
        for p in range(n_g):
            a = abs(g[p])
            if (n == 0 and p == 0) or a > red.gacc[r]:
                red.gacc[r] = a
                red.gacc_t[r] = t
                red.gacc_i[r] = p
    if red.tw_phi.shape[0] > 0:
        tw_record(red, qdd, r, n, t)
    if red.le_E.shape[1] > 0:
        le_static(red.le_sup, red.le_L, red.le_Linv, red.le_c6, red.le_A, red.le_B,
                  red.le_X, red.le_xi, red.le_sec0, red.le_val, red.le_Ms, red.le_acc,
                  red.le_lx, red.le_lp, red.le_ls, nl)
        le_finish(red.le_E, red.le_w2inv, red.le_val, q, f, red.le_max, red.le_max_t,
                  red.le_min, red.le_min_t, r, n, t)
        if red.cb_Eq.shape[1] > 0:
            cb_static(red.le_sup, red.le_Linv, red.cb_X, red.cb_sec0, red.cb_ss,
                      red.le_lx, red.le_lp, nl)
            cb_finish(red, q, f, r, t)
    if h >= 0:
        for j in range(n_m):
            out.q[h, n, j] = q[j]
            out.qdd[h, n, j] = qdd[j]
        if out.fq.shape[0] > 0:
            for j in range(n_m):
                out.fq[h, n, j] = f[j]
        out.iters[h, n] = iters


@njit(inline="always")
def tw_record(red, qdd, r, n, t):
    """The acceleration along each track line on the whole-deck grid (``Reduce.tw_*``)
    folded into its one envelope per track of run ``r`` (step ``n``, time ``t``).

    The envelope is that of a row per grid point followed by the first point of the
    largest row maximum: a point replaces the current maximum when larger, or equal at
    a smaller point (whose first time is then kept).  Each value sums the modes in
    order from 0 (the row sum's operations), mode-outer over the grid; a track whose
    bound sum_j tw_phimax[k, j] |qdd_j| does not exceed its envelope is skipped (no
    point of it can raise or tie it).
    """
    n_m = qdd.shape[0]
    g = red.tw_work
    n_tg = g.shape[0]
    phi = red.tw_phi
    for k in range(phi.shape[0]):
        bound = 0.0
        for j in range(n_m):
            bound += red.tw_phimax[k, j] * abs(qdd[j])
        if n > 0 and not bound > red.tw_acc[r, k]:
            continue
        for p in range(n_tg):
            g[p] = 0.0
        for j in range(n_m):
            aj = qdd[j]
            for p in range(n_tg):
                g[p] += phi[k, j, p] * aj
        best = red.tw_acc[r, k]
        bi = red.tw_acc_i[r, k]
        for p in range(n_tg):
            a = abs(g[p])
            if (n == 0 and p == 0) or a > best or (a == best and p < bi):
                best = a
                bi = p
                red.tw_acc[r, k] = a
                red.tw_acc_t[r, k] = t
                red.tw_acc_i[r, k] = p


@njit(inline="always")
def close_separation(red, r, i):
    """A separation of wheel ``i`` ended (or the run did): count the event."""
    red.events[r, i] += 1
    if red.run_len[i] == 1:
        red.single[r, i] += 1
    red.run_len[i] = 0


@njit(kernel_only=True)
def le_list(red, wheel_x0, wheel_sf, X, load_x0, load_sf, load_p, t, speed):
    """The point loads on the deck at time ``t`` into ``red.le_lx``/``red.le_lp``,
    ascending: the contact forces ``X`` of the wheels in contact on the deck (at the deck
    line) and the moving forces (each at x0 + sf v t, its own speed factor ``sf``).
    Returns their number."""
    lx = red.le_lx
    lp = red.le_lp
    length = red.le_sup[red.le_sup.shape[0] - 1]
    nl = 0
    for i in range(wheel_x0.shape[0] - 1, -1, -1):
        x = wheel_x0[i] + (wheel_sf[i] * speed) * t
        if X[i] != 0.0 and x >= 0.0 and x <= length:
            lx[nl] = x
            lp[nl] = X[i]
            nl += 1
    for k in range(load_x0.shape[0] - 1, -1, -1):
        x = load_x0[k] + (load_sf[k] * speed) * t
        if x >= 0.0 and x <= length:
            lx[nl] = x
            lp[nl] = load_p[k]
            nl += 1
    le_sort(lx, lp, nl)
    return nl


@njit(inline="always")
def le_sort(lx, lp, nl):
    """Sort the first ``nl`` loads by abscissa ``lx`` (with their forces ``lp``): an
    insertion sort (the train's order: nearly sorted)."""
    for k in range(1, nl):
        x = lx[k]
        p = lp[k]
        m = k - 1
        while m >= 0 and lx[m] > x:
            lx[m + 1] = lx[m]
            lp[m + 1] = lp[m]
            m -= 1
        lx[m + 1] = x
        lp[m + 1] = p


@njit(inline="always")
def le_static(sup, L, Linv, c6, A, B, X, xi_s, sec0, val, Ms, acc, lx, lp, ls, nl):
    """Static load effects of the ``nl`` point loads ``lx`` (m, ascending, on the deck)
    of forces ``lp`` (N, down) into ``val`` (the channels of ``Reduce.le_*``): exact
    Euler-Bernoulli beam on point supports (vsi_numba.model.influence).

    Each load adds its span's simply supported reactions and end slopes and, on a
    continuous deck, the support moments of its influence cubic; the sections of each
    span (``sec0[s] .. sec0[s + 1] - 1``, ascending) are then swept left to right with
    the loads (one pass: O(n_s + nl)),
    M(X) = R_A X - sum_{a_k <= X} P_k (X - a_k) + the support moments interpolated,
    V = dM/dx (the value just right of a load or support).  Arrays as in ``Reduce``
    (``le_`` dropped; no division in the step: ``Linv`` = 1/L, ``c6`` = 1/(6 EI L),
    ``xi_s`` = X/L); ``ls`` is scratch.
    """
    n_span = L.shape[0]
    n_sup = n_span + 1
    n_s = X.shape[0]
    if n_span == 1:  # one span from x = 0 (the moving-force hot path): no support moment
        L0 = L[0]
        li = Linv[0]
        c0 = c6[0]
        ra = 0.0
        rb = 0.0
        th0 = 0.0
        th1 = 0.0
        for k in range(nl):
            a = lx[k]
            p = lp[k]
            b = L0 - a
            ra += p * li * b
            rb += p * li * a
            c = p * a * b * c0
            th0 += c * (L0 + b)
            th1 -= c * (L0 + a)
        kk = 0
        s0 = 0.0
        s1 = 0.0
        for q in range(n_s):
            Xq = X[q]
            while kk < nl and lx[kk] <= Xq:
                s0 += lp[kk]
                s1 += lp[kk] * lx[kk]
                kk += 1
            v = ra - s0
            val[q] = Xq * v + s1
            val[n_s + q] = v
        val[2 * n_s] = ra
        val[2 * n_s + 1] = rb
        val[2 * n_s + 2] = th0
        val[2 * n_s + 3] = th1
        return
    for i in range(n_sup):
        Ms[i] = 0.0
    for k in range(n_span):
        acc[0, k] = 0.0
        acc[1, k] = 0.0
        acc[2, k] = 0.0
        acc[3, k] = 0.0
    s = 0
    for k in range(nl):
        x = lx[k]
        p = lp[k]
        while s < n_span - 1 and x >= sup[s + 1]:
            s += 1
        ls[k] = s
        Ls = L[s]
        a = x - sup[s]
        b = Ls - a
        pl = p * Linv[s]
        acc[0, s] += pl * b
        acc[1, s] += pl * a
        c = p * a * b * c6[s]
        acc[2, s] += c * (Ls + b)
        acc[3, s] -= c * (Ls + a)
        if n_span > 1:
            xi = a * Linv[s]
            g = p * xi * (1.0 - xi)
            for i in range(1, n_sup - 1):
                Ms[i] += g * (A[s, i] + B[s, i] * xi)
    kk = 0
    for sp in range(n_span):
        ra = acc[0, sp]
        x0 = sup[sp]
        s0 = 0.0
        s1 = 0.0
        while kk < nl and ls[kk] < sp:
            kk += 1
        for q in range(sec0[sp], sec0[sp + 1]):
            Xq = X[q]
            while kk < nl and ls[kk] == sp and lx[kk] - x0 <= Xq:
                s0 += lp[kk]
                s1 += lp[kk] * (lx[kk] - x0)
                kk += 1
            v = ra - s0
            val[q] = Xq * v + s1
            val[n_s + q] = v
    if n_span > 1:  # the support moments, interpolated in each span
        for sp in range(n_span):
            m0 = Ms[sp]
            m1 = Ms[sp + 1]
            dv = (m1 - m0) * Linv[sp]
            for q in range(sec0[sp], sec0[sp + 1]):
                val[q] += m0 + (m1 - m0) * xi_s[q]
                val[n_s + q] += dv
    o = 2 * n_s
    for k in range(n_sup):
        v = 0.0
        if k < n_span:
            v += acc[0, k] + (Ms[k + 1] - Ms[k]) * Linv[k]
        if k > 0:
            v += acc[1, k - 1] - (Ms[k] - Ms[k - 1]) * Linv[k - 1]
        val[o + k] = v
    o += n_sup
    for k in range(n_span):
        c = L[k] * L[k] * c6[k]  # L / (6 EI)
        val[o + k] = acc[2, k] + c * (2.0 * Ms[k] + Ms[k + 1])
    k = n_span - 1
    c = L[k] * L[k] * c6[k]
    val[o + n_span] = acc[3, k] - c * (Ms[k] + 2.0 * Ms[k + 1])


@njit(inline="always")
def le_finish(E, w2inv, val, q, f, mx, mxt, mn, mnt, r, n, t):
    """Add the modal correction sum_j E[j, c] (q_j - f_j / w_j^2) to the static effects
    in ``val`` and fold them into the envelopes ``mx``/``mn`` (times ``mxt``/``mnt``) of
    run ``r`` (step ``n``, time ``t``)."""
    n_c = E.shape[1]
    for j in range(q.shape[0]):
        cj = q[j] - f[j] * w2inv[j]
        row = E[j]  # a row of the table: the loop over it compiles to vector instructions
        for c in range(n_c):
            val[c] += row[c] * cj
    # most steps raise no envelope: a branch-free test first (the envelopes start at
    # -inf / +inf, so step 0 sets both)
    hi = mx[r]
    lo = mn[r]
    hit = False
    for c in range(n_c):
        hit |= (val[c] > hi[c]) | (val[c] < lo[c])
    if hit:
        for c in range(n_c):
            v = val[c]
            if v > hi[c]:
                hi[c] = v
                mxt[r, c] = t
            if v < lo[c]:
                lo[c] = v
                mnt[r, c] = t


@njit(inline="always")
def cb_static(sup, Linv, X, sec0, ss, lx, lp, nl):
    """Span-wise simply supported moment and shear of the ``nl`` loads ``lx`` (m,
    ascending) of forces ``lp`` (N) at the sections ``X`` (m from their span's left
    support, ascending in each span ``sec0[s] .. sec0[s + 1] - 1``) into ``ss`` (moments
    first, then shears; the shear just right of a load): the static torsion of a deck
    whose torsion is restrained at every support, each span on its own.  A load on an
    interior support belongs to the span on its right (it loads neither)."""
    n_span = sec0.shape[0] - 1
    n_s = X.shape[0]
    kk = 0
    for sp in range(n_span):
        x0 = sup[sp]
        x1 = sup[sp + 1]
        last = sp == n_span - 1
        k1 = kk
        ra = 0.0
        while k1 < nl and (lx[k1] < x1 or last):
            ra += lp[k1] * (x1 - lx[k1]) * Linv[sp]
            k1 += 1
        s0 = 0.0
        s1 = 0.0
        m = kk
        for q in range(sec0[sp], sec0[sp + 1]):
            Xq = X[q]
            while m < k1 and lx[m] - x0 <= Xq:
                s0 += lp[m]
                s1 += lp[m] * (lx[m] - x0)
                m += 1
            v = ra - s0
            ss[q] = Xq * v + s1
            ss[n_s + q] = v
        kk = k1


@njit(inline="always")
def cb_finish(red, q, f, r, t):
    """The deck-in-space channels of the step (see ``Reduce.cb_*``) from the static
    values ``red.cb_ss``, folded into their envelopes of run ``r`` (time ``t``).  The
    modal sums run mode by mode over rows of the tables (loops that compile to vector
    instructions), and a branch-free test first finds whether the step raises any
    envelope (most steps raise none)."""
    val = red.cb_val
    Eq = red.cb_Eq
    Ef = red.cb_Ef
    n_cb = val.shape[0]
    for c in range(n_cb):
        s = 0.0
        for k in range(red.cb_ptr[c], red.cb_ptr[c + 1]):
            s += red.cb_coef[k] * red.cb_ss[red.cb_idx[k]]
        val[c] = s
    for j in range(q.shape[0]):
        fj = f[j]
        row = Ef[j]
        for c in range(n_cb):
            val[c] -= row[c] * fj
    d = red.cb_D[r]
    for c in range(n_cb):
        val[c] *= d[c]
    for j in range(q.shape[0]):
        qj = q[j]
        row = Eq[j]
        for c in range(n_cb):
            val[c] += row[c] * qj
    mx = red.cb_max[r]
    mn = red.cb_min[r]
    hit = False
    for c in range(n_cb):
        hit |= (val[c] > mx[c]) | (val[c] < mn[c])
    if hit:
        for c in range(n_cb):
            v = val[c]
            if v > mx[c]:
                mx[c] = v
                red.cb_max_t[r, c] = t
            if v < mn[c]:
                mn[c] = v
                red.cb_min_t[r, c] = t


@njit
def cb_history(sup, Linv, X, sec0, ptr, idx, coef, x, force, lx, lp, ss, out):
    """The static part of the deck-in-space channels (D = 1; ``Reduce.cb_*`` with
    ``coef`` per unit of the loads' eccentricity) of the forces ``force`` (N) at ``x``
    (m), both (n, n_load), step by step as the kernels' :func:`cb_static`, into ``out``
    (n, n_cb); ``lx``, ``lp`` (n_load,) and ``ss`` (2 n_cs,) are scratch."""
    n, n_load = x.shape
    n_cb = ptr.shape[0] - 1
    lo = sup[0]
    hi = sup[sup.shape[0] - 1]
    for i in range(n):
        nl = 0
        for k in range(n_load):
            xk = x[i, k]
            if force[i, k] != 0.0 and xk >= lo and xk <= hi:
                lx[nl] = xk
                lp[nl] = force[i, k]
                nl += 1
        le_sort(lx, lp, nl)
        cb_static(sup, Linv, X, sec0, ss, lx, lp, nl)
        for c in range(n_cb):
            s = 0.0
            for k in range(ptr[c], ptr[c + 1]):
                s += coef[k] * ss[idx[k]]
            out[i, c] = s
    return out
