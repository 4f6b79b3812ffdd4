"""The damped (or massive) elastic track under the wheels: one element per wheel,
integrated with the step by the same HHT-alpha rule (vsi_numba.model.track).
"""

from __future__ import annotations

from vsi_numba._jit import njit
from vsi_numba.kernels.integrator import newmark


@njit(inline="always")
def track_element(veh):
    """True if the track under the wheels has damping or mass (the element is used)."""
    return veh.track_kt > 0.0 and (veh.track_ct > 0.0 or veh.track_mt > 0.0)


@njit(inline="always")
def track_predict(veh, wk, st, alpha, a0, a1, a2, a3, cv, ca, scale):
    """Damped/massive track.  Each wheel drives an element m z'' + c z' + k z = X_i
    (k = 1 / G(0)); the rail deflection under wheel i is y_i = k sum_k G_ik z_k (the
    static deflection basins, each delayed by its wheel's element: the compliance
    matrix times one passive transfer function, so the coupling between wheels stays
    passive at every frequency).  By the step's HHT-alpha rule
    z_{n+1} = z_n + (r_n + (1 + alpha) X_{n+1}) / khat, khat = a0 m + (1 + alpha)
    (a1 c + k), r_n = -alpha X_n + m (a2 z'_n + a3 z''_n) - c (cv z'_n + ca z''_n) - k z_n:
    the known part goes into the predictor gaps and the rail block of S (which holds
    C / (1 + alpha)) becomes G k / khat.  ``wk.trk[:, 3]`` receives r_n."""
    k = veh.track_kt
    c = veh.track_ct
    m = veh.track_mt
    n_w = veh.wheel_dof.shape[0]
    khat = a0 * m + scale * (a1 * c + k)
    change = k / khat - 1.0 / scale
    for i in range(n_w):
        z = wk.trk[i, 0]
        zd = wk.trk[i, 1]
        zdd = wk.trk[i, 2]
        wk.trk[i, 3] = (-alpha * st.X[i] + m * (a2 * zd + a3 * zdd)
                        - c * (cv * zd + ca * zdd) - k * z)
    for i in range(n_w):
        acc = 0.0
        for p in range(veh.comp_ptr[i], veh.comp_ptr[i + 1]):  # the nonzero G_ij
            j = veh.comp_col[p]
            g = 1.0 / k if j == i else veh.compliance[i, j]  # the rail's G_ij
            if g != 0.0:
                acc += g * (wk.trk[j, 0] + wk.trk[j, 3] / khat)
                wk.S[i, j] += g * change
        wk.gstar[i] += k * acc


@njit(inline="always")
def track_update(veh, wk, dt, a0, a1, a2, a3, gamma, scale):
    """Newmark update of the track elements with the step's contact forces ``wk.X``."""
    khat = a0 * veh.track_mt + scale * (a1 * veh.track_ct + veh.track_kt)
    for i in range(veh.wheel_dof.shape[0]):
        dy = (wk.trk[i, 3] + scale * wk.X[i]) / khat
        wk.trk[i, 1], wk.trk[i, 2] = newmark(dy, wk.trk[i, 1], wk.trk[i, 2], a0, a2, a3,
                                             gamma, dt)
        wk.trk[i, 0] += dy
