"""Where the wheels and the loads are: contact search (on the deck or not, mode values,
irregularity), the modal loads of the moving forces, and the times at which a wheel
crosses an end of the deck.

Every wheel (and point load) has its own track line and its own signed speed
v_i = sf_i v (``VehicleArrays.wheel_sf``: several trains in one run, some running in
-x); with one train sf_i = 1 and v_i is the run's speed itself.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.shapes import eval_hermite, eval_modes, eval_profile, off_modes


@njit(inline="always")
def contact_search(br, veh, pr, t, speed, wk):
    """Position every wheel at time ``t``: coupled to the deck or not, mode values of its
    track line (the track-filtered ones on an elastic track), its line's irregularity."""
    n_w = veh.wheel_dof.shape[0]
    n_m = br.omega.shape[0]
    for i in range(n_w):
        x = veh.wheel_x0[i] + (veh.wheel_sf[i] * speed) * t
        line = veh.wheel_line[i]
        if br.track == 0:
            off = off_modes(br, x)
        else:
            off = n_m == 0 or x < br.t_nodes[0] or x > br.t_nodes[br.t_nodes.shape[0] - 1]
        if off:
            wk.onb[i] = 0
            if wk.phz[i] == 1:  # the rows are zero from an earlier call otherwise
                for j in range(n_m):
                    wk.phi[i, j] = 0.0
                    wk.dphi[i, j] = 0.0
                    wk.d2phi[i, j] = 0.0
                wk.phz[i] = 0
        elif br.track == 0:
            wk.onb[i] = eval_modes(br, x, wk.phi[i], wk.dphi[i], wk.d2phi[i], line)
            wk.phz[i] = 1
        else:
            wk.onb[i] = 1
            eval_hermite(br.t_nodes, br.t_values, br.t_slopes, x, wk.phi[i], wk.dphi[i],
                         wk.d2phi[i], line * br.t_nodes.shape[0])
            wk.phz[i] = 1
        eval_profile(pr, x, wk.rr[i], line)


@njit(inline="always")
def assemble_loads(br, veh, t, speed, fq, scratch, scratch2, scratch3):
    """Modal load vector of the point loads (moving forces) at time ``t``."""
    n_m = fq.shape[0]
    for j in range(n_m):
        fq[j] = 0.0
    if br.kind == 0 or n_m == 0:
        return
    for k in range(veh.load_x0.shape[0]):
        x = veh.load_x0[k] + (veh.load_sf[k] * speed) * t
        if x < 0.0 or x > br.length:
            continue  # off the bridge: no modal load
        eval_modes(br, x, scratch, scratch2, scratch3, veh.load_line[k])
        p = veh.load_p[k]
        for j in range(n_m):
            fq[j] += p * scratch[j]


@njit(inline="always")
def crosses_deck_end(br, veh, t0, t1, speed):
    """True if a wheel passes an end of the deck in (t0, t1]: on the bridge (0 <= x <= L,
    as :func:`eval_modes`) at one of the two times and not at the other."""
    if br.kind == 0:
        return False
    for i in range(veh.wheel_dof.shape[0]):
        v = veh.wheel_sf[i] * speed
        x0 = veh.wheel_x0[i] + v * t0
        x1 = veh.wheel_x0[i] + v * t1
        if v > 0.0:
            if (x0 < 0.0 <= x1) or (x0 <= br.length < x1):
                return True
        elif (x0 > br.length >= x1) or (x0 >= 0.0 > x1):  # a wheel running in -x
            return True
    return False


@njit(kernel_only=True)
def next_deck_end(br, veh, t, t1, speed):
    """Earliest time in (t, t1] at which a wheel is on the other side of an end of the
    deck than at ``t`` (the first float time whose abscissa x0 + v t the on-bridge test
    of :func:`eval_modes` puts there); > t1 if none."""
    best = t1 + 1.0
    length = br.length
    for i in range(veh.wheel_dof.shape[0]):
        x0 = veh.wheel_x0[i]
        v = veh.wheel_sf[i] * speed
        xa = x0 + v * t
        xb = x0 + v * t1
        if v > 0.0 and xa < 0.0 <= xb:
            tc = (0.0 - x0) / v
            while x0 + v * tc < 0.0:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + v * np.nextafter(tc, -np.inf) >= 0.0:
                tc = np.nextafter(tc, -np.inf)
        elif v > 0.0 and xa <= length < xb:
            tc = (length - x0) / v
            while not x0 + v * tc > length:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + v * np.nextafter(tc, -np.inf) > length:
                tc = np.nextafter(tc, -np.inf)
        elif v < 0.0 and xa > length >= xb:  # running in -x: onto the deck at L
            tc = (length - x0) / v
            while x0 + v * tc > length:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + v * np.nextafter(tc, -np.inf) <= length:
                tc = np.nextafter(tc, -np.inf)
        elif v < 0.0 and xa >= 0.0 > xb:  # off the deck at 0
            tc = (0.0 - x0) / v
            while not x0 + v * tc < 0.0:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + v * np.nextafter(tc, -np.inf) < 0.0:
                tc = np.nextafter(tc, -np.inf)
        else:
            continue
        if tc < best:
            best = tc
    return best
