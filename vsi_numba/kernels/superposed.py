"""The histories of several trains on a deck in space summed run by run
(:mod:`vsi_numba.solver.superpose`), one pass over the time steps per train: the
deck-in-space channels of each train (the static part of its loads and the modal parts
of its modal coordinates) added into one array, and the static load effects of its
loads at the sections of a beam deck.

Each value is computed with the operations of the numpy expressions these replace, in
their order (:meth:`vsi_numba.solver.results.BatchResult.space_series`,
:func:`vsi_numba.kernels.influence.beam_section_history`), so the sums are those
expressions' bit for bit without their temporaries of the histories' size.
"""

from __future__ import annotations

from vsi_numba._jit import njit
from vsi_numba.kernels.record import cb_static, le_sort


@njit
def channel_sum(acc, first, fqEf, qEq, x0, v, X, load_p, mirror, y, d, dt, sup, Linv,
                cX, sec0, ptr, idx, coef, lx, lp, ss, st):
    """Add one train's deck-in-space channels to ``acc`` (n, n_cb), or store them when
    ``first``.

    The channels of step i (time ``i dt``) are ``(S y - fqEf) d + qEq``: ``fqEf``,
    ``qEq`` (n, n_cb) the train's modal forces times ``Ef`` and modal coordinates times
    ``Eq`` (:class:`~vsi_numba.solver.space_effects.SpaceChannels`), ``S`` the static
    part per unit eccentricity of its loads (:func:`~vsi_numba.kernels.record.cb_history`;
    +0 for every channel with no load on the deck), 0 when ``y`` = 0, and ``d`` the
    speed factor.  Its loads: the wheels' contact forces ``X`` (n, n_w) then the moving
    forces ``load_p``, at ``x0 + v t`` (``x0``, ``v``: m, m/s, wheels first), at
    ``mirror - x`` when ``mirror`` >= 0 (a train in -x); ``sup``, ``Linv``, ``cX``,
    ``sec0``, ``ptr``, ``idx``, ``coef`` the channels' tables (``Reduce.cb_*``, ``coef``
    per unit eccentricity); ``lx``, ``lp`` (n_w + n_l,), ``ss`` (2 n_cs,) and ``st``
    (n_cb,) are scratch.
    """
    n, n_cb = acc.shape
    n_w = X.shape[1]
    n_load = x0.shape[0]
    lo = sup[0]
    hi = sup[sup.shape[0] - 1]
    for c in range(n_cb):
        st[c] = 0.0
    for i in range(n):
        t = i * dt
        if y != 0.0:
            nl = 0
            for k in range(n_load):
                xk = x0[k] + v[k] * t
                if mirror >= 0.0:
                    xk = mirror - xk
                f = X[i, k] if k < n_w else load_p[k - n_w]
                if f != 0.0 and xk >= lo and xk <= hi:
                    lx[nl] = xk
                    lp[nl] = f
                    nl += 1
            if nl > 0:
                le_sort(lx, lp, nl)
                cb_static(sup, Linv, cX, sec0, ss, lx, lp, nl)
                for c in range(n_cb):
                    s = 0.0
                    for k in range(ptr[c], ptr[c + 1]):
                        s += coef[k] * ss[idx[k]]
                    st[c] = s * y
            else:  # every static value is +0 (cb_static of no load), times y
                for c in range(n_cb):
                    st[c] = 0.0 * y
        a = acc[i]
        g = fqEf[i]
        h = qEq[i]
        if first:
            for c in range(n_cb):
                a[c] = (st[c] - g[c]) * d + h[c]
        else:
            for c in range(n_cb):
                a[c] += (st[c] - g[c]) * d + h[c]
    return acc
