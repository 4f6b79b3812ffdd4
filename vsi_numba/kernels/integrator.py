"""HHT-alpha (Hilber-Hughes-Taylor) time integration: the step's coefficients, the Newmark
updates of the corrector, the force totals carried to the next step, and copies of the
state for retries.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.linalg import block_matvec_nz, copy_into


@njit(inline="always")
def hht_coefficients(alpha, dt):
    """Newmark/HHT-alpha constants of a step ``dt``: beta = (1 - alpha)^2 / 4,
    gamma = 1/2 - alpha; a0 = 1/(beta dt^2), a1 = gamma/(beta dt), a2 = 1/(beta dt),
    a3 = 1/(2 beta) - 1; cv, ca = weights of v_n, a_n in (1+alpha) C v_{n+1} - alpha C v_n;
    scale = 1 + alpha.  Returns (a0, a1, a2, a3, cv, ca, gamma, scale)."""
    beta = 0.25 * (1.0 - alpha) ** 2
    gamma = 0.5 - alpha
    a0 = 1.0 / (beta * dt * dt)
    a1 = gamma / (beta * dt)
    a2 = 1.0 / (beta * dt)
    a3 = 0.5 / beta - 1.0
    cv = (1.0 + alpha) * (1.0 - gamma / beta) - alpha
    ca = (1.0 + alpha) * dt * (1.0 - 0.5 * gamma / beta)
    return a0, a1, a2, a3, cv, ca, gamma, 1.0 + alpha


@njit(inline="always")
def newmark(d, v, a, a0, a2, a3, gamma, dt):
    """Newmark update of one DOF whose displacement grew by ``d`` over the step, from its
    velocity ``v`` and acceleration ``a`` at the step's start: (velocity, acceleration)
    at its end."""
    acc = a0 * d - a2 * v - a3 * a
    return v + dt * ((1.0 - gamma) * a + gamma * acc), acc


@njit(inline="always")
def hht_correct(veh, st, wk, khat_v, a0, a2, a3, gamma, scale, dt):
    """The corrector of :func:`hht_step` with the contact forces ``wk.X`` of the step:
    Delta u = y - (1 + alpha) K^-1 B^T X (modes and vehicle DOFs), then the Newmark
    updates of the state."""
    n_m = st.q.shape[0]
    n_v = st.u.shape[0]
    n_w = veh.wheel_dof.shape[0]
    for k in range(n_v):
        wk.rv[k] = 0.0
    for i in range(n_w):
        xi = wk.X[i]
        wk.xout[i] = xi
        wk.rv[veh.wheel_dof[i]] = xi
        if xi != 0.0 and wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
            for j in range(n_m):
                wk.yq[j] += scale * wk.phi[i, j] * xi / wk.khat[j]
    block_matvec_nz(veh, khat_v, 3, wk.rv, wk.yv, -scale)
    for j in range(n_m):
        dq = wk.yq[j]
        st.qd[j], st.qdd[j] = newmark(dq, st.qd[j], st.qdd[j], a0, a2, a3, gamma, dt)
        st.q[j] += dq
    for k in range(n_v):
        du = wk.yv[k]
        st.ud[k], st.udd[k] = newmark(du, st.ud[k], st.udd[k], a0, a2, a3, gamma, dt)
        st.u[k] += du


@njit(inline="always")
def update_force_totals(br, veh, wk, st):
    """Total modal and vehicle forces at the new time (external loads + contact)."""
    n_m = st.q.shape[0]
    for j in range(n_m):
        st.fq_tot[j] = wk.fq[j]
    for k in range(st.u.shape[0]):
        st.fv_tot[k] = veh.gravity[k]
    for i in range(veh.wheel_dof.shape[0]):
        xi = wk.X[i]
        st.X[i] = xi
        if xi != 0.0:
            st.fv_tot[veh.wheel_dof[i]] -= xi
            if wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
                for j in range(n_m):
                    st.fq_tot[j] += wk.phi[i, j] * xi


@njit(inline="always")
def copy_state(src, dst):
    copy_into(src.q, dst.q)
    copy_into(src.qd, dst.qd)
    copy_into(src.qdd, dst.qdd)
    copy_into(src.u, dst.u)
    copy_into(src.ud, dst.ud)
    copy_into(src.udd, dst.udd)
    copy_into(src.fq_tot, dst.fq_tot)
    copy_into(src.fv_tot, dst.fv_tot)
    copy_into(src.X, dst.X)


@njit(kernel_only=True)
def save_state(st, buf):
    """State at the start of a step into the flat buffer ``buf``."""
    k = 0
    for a in (st.q, st.qd, st.qdd, st.fq_tot):
        for j in range(a.shape[0]):
            buf[k] = a[j]
            k += 1
    for a in (st.u, st.ud, st.udd, st.fv_tot):
        for j in range(a.shape[0]):
            buf[k] = a[j]
            k += 1
    for j in range(st.X.shape[0]):
        buf[k] = st.X[j]
        k += 1


@njit(kernel_only=True)
def restore_state(buf, st):
    """Inverse of :func:`save_state`."""
    k = 0
    for a in (st.q, st.qd, st.qdd, st.fq_tot):
        for j in range(a.shape[0]):
            a[j] = buf[k]
            k += 1
    for a in (st.u, st.ud, st.udd, st.fv_tot):
        for j in range(a.shape[0]):
            a[j] = buf[k]
            k += 1
    for j in range(st.X.shape[0]):
        st.X[j] = buf[k]
        k += 1


@njit(inline="always")
def state_is_finite(st):
    s = 0.0
    for j in range(st.q.shape[0]):
        s += st.q[j] + st.qd[j] + st.qdd[j]
    for k in range(st.u.shape[0]):
        s += st.u[k] + st.ud[k] + st.udd[k]
    return np.isfinite(s)
