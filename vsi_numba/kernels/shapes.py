"""Mode shapes and the irregularity profile at a point: sine modes, Hermite tables
(FE decks, imported modes, the elastic track's filtered shapes), the profile's spline.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit


@njit(inline="always")
def off_modes(br, x):
    """True where the mode shapes are zero: ``x`` off the bridge (x < 0 or x > length),
    no bridge, or no modes (:func:`eval_modes` and :func:`contact_search`)."""
    return br.kind == 0 or x < 0.0 or x > br.length or br.omega.shape[0] == 0


@njit(kernel_only=True)
def eval_modes(br, x, out, dout, d2out, line):
    """Mode shapes and their first two x-derivatives at ``x`` (zero off the bridge) on
    track line ``line`` (the row block of a Hermite table; sine modes: every line).

    Returns 1 if ``x`` is on the bridge (0 <= x <= length), else 0.
    """
    n_m = br.omega.shape[0]
    if off_modes(br, x):
        for j in range(n_m):
            out[j] = 0.0
            dout[j] = 0.0
            d2out[j] = 0.0
        return 0
    if br.kind == 1:
        # sin(j k1 x), cos(j k1 x) by the angle-addition recurrence: two
        # transcendentals per call instead of two per mode (sine_k[j] = (j+1) k1)
        k1 = br.sine_k[0]
        s1 = np.sin(k1 * x)
        c1 = np.cos(k1 * x)
        s = s1
        c = c1
        for j in range(n_m):
            k = br.sine_k[j]
            a = br.sine_amp[j]
            out[j] = a * s
            dout[j] = a * k * c
            d2out[j] = -a * k * k * s
            s, c = s * c1 + c * s1, c * c1 - s * s1
        return 1
    eval_hermite(br.nodes, br.values, br.slopes, x, out, dout, d2out,
                 line * br.nodes.shape[0])
    return 1


@njit(inline="always")
def eval_hermite(nodes, values, slopes, x, out, dout, d2out, base):
    """Values and two x-derivatives at ``x`` of a Hermite table (values and slopes at
    ``nodes``, in rows ``base ..`` of ``values``/``slopes``), with the cubic Hermite shape
    functions of the element holding ``x``."""
    e = np.searchsorted(nodes, x, side="right") - 1
    if e < 0:
        e = 0
    if e > nodes.shape[0] - 2:
        e = nodes.shape[0] - 2
    h = nodes[e + 1] - nodes[e]
    s = (x - nodes[e]) / h
    s2 = s * s
    s3 = s2 * s
    n1 = 1.0 - 3.0 * s2 + 2.0 * s3
    n2 = h * (s - 2.0 * s2 + s3)
    n3 = 3.0 * s2 - 2.0 * s3
    n4 = h * (s3 - s2)
    d1 = (-6.0 * s + 6.0 * s2) / h
    d2 = 1.0 - 4.0 * s + 3.0 * s2
    d3 = -d1
    d4 = -2.0 * s + 3.0 * s2
    e1 = (-6.0 + 12.0 * s) / (h * h)
    e2 = (-4.0 + 6.0 * s) / h
    e3 = -e1
    e4 = (-2.0 + 6.0 * s) / h
    r = base + e
    for j in range(values.shape[1]):
        w1 = values[r, j]
        t1 = slopes[r, j]
        w2 = values[r + 1, j]
        t2 = slopes[r + 1, j]
        out[j] = n1 * w1 + n2 * t1 + n3 * w2 + n4 * t2
        dout[j] = d1 * w1 + d2 * t1 + d3 * w2 + d4 * t2
        d2out[j] = e1 * w1 + e2 * t1 + e3 * w2 + e4 * t2


@njit(kernel_only=True)
def eval_profile(pr, x, out, line):
    """Irregularity r, r', r'' at ``x`` of track line ``line`` (``pr.n_int`` > 0: the
    line's own profile) into ``out[0:3]`` (zero outside the profile)."""
    n = pr.coef.shape[0]
    base = 0
    if pr.n_int > 0:
        n = pr.n_int
        base = line * n
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    if n == 0:
        return
    t = (x - pr.x0) / pr.dx
    if t < 0.0 or t > n:
        return
    k = int(np.floor(t))
    if k > n - 1:
        k = n - 1
    s = x - (pr.x0 + k * pr.dx)
    k += base
    c0 = pr.coef[k, 0]
    c1 = pr.coef[k, 1]
    c2 = pr.coef[k, 2]
    c3 = pr.coef[k, 3]
    out[0] = c0 + s * (c1 + s * (c2 + s * c3))
    out[1] = c1 + s * (2.0 * c2 + 3.0 * s * c3)
    out[2] = 2.0 * c2 + 6.0 * s * c3
