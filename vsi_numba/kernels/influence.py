"""Static bending moment and shear histories of a beam deck on point supports, summed
over the loads of each step: :func:`vsi_numba.model.influence.influence` ("moment",
"shear") times each load's force, in the same floating-point operations and the same
order, summed step by step in the order of the loads (as ``numpy.bincount`` sums), so
the values are those of the numpy expressions bit for bit, without the (section, load)
arrays.

Two shortcuts keep the bits: a section outside the load's span takes the load's span
term ``same * own`` as +-0, and ``(+-0 + y) + z`` is ``y + z`` but for the sign of a
zero; a section off the deck is +-0 throughout.  A zero's sign never reaches a sum that
starts at +0 (+0 + -0 is +0, and an exact cancellation gives +0), so neither changes a
history.  What is left per section of another span is two products and a sum, and of
the shear in the load's span a choice of two values per load (no division).
"""

from __future__ import annotations

from vsi_numba._jit import njit

#: ``effect`` codes of :func:`beam_section_history`
MOMENT = 0
SHEAR = 1


@njit
def beam_section_history(effect, L, span0, X, xi, sl, a, b, ms, step, fs, out):
    """Add to ``out`` (n_steps, n_sec) the static ``effect`` (:data:`MOMENT`,
    :data:`SHEAR`) at the sections of each (step, load) pair.  The sections, on the
    deck and ordered by span (those of span k are ``span0[k] .. span0[k + 1] - 1``):
    abscissa in their span ``X`` and ``xi`` = X / L; the pairs, on the deck and
    ascending by step: span ``sl``, distances ``a``, ``b`` from the span's ends,
    support moments ``ms`` (n_sup, n_pairs), step ``step`` and force ``fs``.  ``L``: the
    spans' lengths.  Each value is the numpy formula of
    :func:`vsi_numba.model.influence._beam` (see the module notes)."""
    n_span = L.shape[0]
    for p in range(step.shape[0]):
        s = sl[p]
        A = a[p]
        B = b[p]
        f = fs[p]
        o = out[step[p]]
        for k in range(n_span):
            La = L[k]
            MA = ms[k, p]
            MB = ms[k + 1, p]
            c0 = span0[k]
            c1 = span0[k + 1]
            if effect == MOMENT:
                if k == s:
                    for c in range(c0, c1):
                        Xc = X[c]
                        own = (B * Xc if Xc <= A else A * (La - Xc)) / La
                        o[c] += (own + MA * (1.0 - xi[c]) + MB * xi[c]) * f
                else:
                    for c in range(c0, c1):
                        o[c] += (MA * (1.0 - xi[c]) + MB * xi[c]) * f
            else:
                dv = (MB - MA) / La
                if k == s:
                    right = B / La + dv  # the section left of the load
                    left = -A / La + dv
                    for c in range(c0, c1):
                        o[c] += (right if X[c] < A else left) * f
                else:
                    g = dv * f
                    for c in range(c0, c1):
                        o[c] += g
    return out


@njit
def beam_section_histories(L, span0, X, xi, omxi, sl, a, b, ms, step, fs, out_m, out_v):
    """:func:`beam_section_history` of the moment into ``out_m`` and of the shear into
    ``out_v`` (both (n_steps, n_sec)) at the same sections in one pass over the pairs
    (each value the same operations as there); ``omxi`` = 1 - ``xi``.  The sections of
    the spans without the load are swept on slices (loops from 0 that compile to vector
    instructions), those of the load's span one by one (a division each)."""
    n_span = L.shape[0]
    for p in range(step.shape[0]):
        s = sl[p]
        A = a[p]
        B = b[p]
        f = fs[p]
        i = step[p]
        for k in range(n_span):
            La = L[k]
            MA = ms[k, p]
            MB = ms[k + 1, p]
            c0 = span0[k]
            c1 = span0[k + 1]
            dv = (MB - MA) / La
            if k == s:
                right = B / La + dv  # the section left of the load
                left = -A / La + dv
                for c in range(c0, c1):
                    Xc = X[c]
                    own = (B * Xc if Xc <= A else A * (La - Xc)) / La
                    out_m[i, c] += (own + MA * omxi[c] + MB * xi[c]) * f
                    out_v[i, c] += (right if Xc < A else left) * f
            else:
                g = dv * f
                om = out_m[i, c0:c1]
                ov = out_v[i, c0:c1]
                o1 = omxi[c0:c1]
                x1 = xi[c0:c1]
                for c in range(om.shape[0]):
                    om[c] += (MA * o1[c] + MB * x1[c]) * f
                for c in range(ov.shape[0]):
                    ov[c] += g
    return out_m
