"""Static bending moment and shear histories of a beam deck on point supports, summed
over the loads of each step: :func:`vsi_numba.model.influence.influence` ("moment",
"shear") times each load's force, element by element in the same floating-point
operations and the same order, then summed step by step in the order of the loads (as
``numpy.bincount`` sums), so the values are those of the numpy expressions bit for bit,
without the (section, load) arrays.
"""

from __future__ import annotations

from vsi_numba._jit import njit

#: ``effect`` codes of :func:`beam_section_history`
MOMENT = 0
SHEAR = 1


@njit
def beam_section_history(effect, L, sa, X, xi, inside, sl, on, a, b, ms, step, fs, out):
    """Add to ``out`` (n_steps, n_sec) the static ``effect`` (:data:`MOMENT`,
    :data:`SHEAR`) at the sections of each (step, load) pair: the sections' span ``sa``,
    abscissa in it ``X``, ``xi`` = X / L and whether on the deck ``inside``
    (n_sec,); the loads' span ``sl``, on the deck ``on``, distances ``a``, ``b`` from
    the span's ends, support moments ``ms`` (n_sup, n_pairs), step ``step`` and force
    ``fs`` (n_pairs,), the pairs ascending by step.  ``L``: the spans' lengths.  Each
    value is the numpy formula of :func:`vsi_numba.model.influence._beam`, its boolean
    factors as 1.0 / 0.0 (a signed zero kept)."""
    n_sec = X.shape[0]
    for p in range(step.shape[0]):
        i = step[p]
        s = sl[p]
        A = a[p]
        B = b[p]
        f = fs[p]
        onp = on[p]
        for c in range(n_sec):
            k = sa[c]
            La = L[k]
            Xc = X[c]
            MA = ms[k, p]
            MB = ms[k + 1, p]
            same = 1.0 if (k == s and onp) else 0.0
            if effect == MOMENT:
                own = (B * Xc if Xc <= A else A * (La - Xc)) / La
                v = same * own + MA * (1.0 - xi[c]) + MB * xi[c]
            else:
                own = (B if Xc < A else -A) / La
                v = same * own + (MB - MA) / La
            v = v * (1.0 if inside[c] else 0.0)
            out[i, c] += v * f
    return out
