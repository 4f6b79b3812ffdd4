"""The time loop of the interaction runs: steps of the coupled system
(:func:`~vsi_numba.kernels.step.vsi_step`), split where a wheel crosses an end of the
deck and retried in substeps where the contact problem fails, each recorded.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels.contact import contact_search, crosses_deck_end, next_deck_end
from vsi_numba.kernels.integrator import copy_state, state_is_finite
from vsi_numba.kernels.record import close_separation, le_list, record, step_arrays
from vsi_numba.kernels.step import crossing_impact, vsi_step
from vsi_numba.kernels.track import track_element
from vsi_numba.kernels.types import NON_FINITE, NOT_CONVERGED, OK

# Halvings of a step in which a wheel crosses an end of the deck (16 substeps); never more
# than ``max_subdivisions``.  Retries of a failed substep may still go finer.
CROSSING_LEVELS = 4
# Deck-end events closer than this share of dt to the start or the end of a step piece
# are taken at that end: a piece of ~1e-4 dt still resolves its accelerations (round-off
# of the gap constraint, ~1e-18 m, over (1e-4 dt)^2), and the event moves by <= 1e-4 dt.
CROSSING_MIN_FRACTION = 1e-4
# The kinds of piece of a step in :func:`time_loop`.
WHOLE, CROSS, TAIL, RETRY = 0, 1, 2, 3


@njit
def time_loop(br, veh, pr, prm, st, bk, wk, red, r, out, h):
    """Integrate ``prm.n_steps`` steps from the state ``st`` (recorded as step 0),
    reducing the envelopes of run ``r`` (and storing history slot ``h`` if >= 0).

    A step whose contact problem fails is retried as 2, 4, ... substeps (up to
    ``prm.max_sub`` halvings).  Returns (status, step index reached).
    """
    n_w = veh.wheel_dof.shape[0]
    for i in range(n_w):
        wk.xout[i] = st.X[i]
        red.run_len[i] = 0
    contact_search(br, veh, pr, 0.0, prm.speed, wk)  # on-bridge flags at t = 0
    track = track_element(veh)
    if track:
        for i in range(n_w):  # the static start, at rest
            wk.trk[i, 0] = veh.track_z0[i]
            wk.trk[i, 1] = 0.0
            wk.trk[i, 2] = 0.0
    dt = prm.dt
    # n = -1: no step, the initial state recorded as step 0 (t = 0)
    for n in range(-1, prm.n_steps):
        iters = np.int64(0)
        if n >= 0:
            copy_state(st, bk)
            for i in range(n_w):
                wk.was_active[i] = wk.active[i]
                wk.act0[i] = wk.active[i]  # the set at t_n, for retries
                wk.onb0[i] = wk.onb[i]
            if track:
                for i in range(n_w):
                    for c in range(3):
                        wk.trk0[i, c] = wk.trk[i, c]
            # The step's pieces, all integrated by the one vsi_step call below (the step
            # is compiled once in this kernel, not once per kind of piece):
            # WHOLE  the step (t0, t1];
            # CROSS  the pieces of a step in which wheels pass an end of the deck on the
            #        rigid track, each ending where a wheel meets the kink of the running
            #        surface (event-driven: the impact there, in impact_update, an LCP
            #        whose crossing wheel may only be pushed, sees the true velocity jump
            #        of the rail - a plastic impact where the rail turns towards the
            #        wheel, a free separation where it turns away; docs/manual/theory.md,
            #        "Contact and impacts");
            # TAIL   the rest of such a step after its last event, in 2^CROSSING_LEVELS
            #        substeps (at most max_sub halvings: a wheel the kink released lands
            #        again within microseconds, and landing at the end of a whole step
            #        would leave its impact transient in the step's recorded force);
            # RETRY  after a failed piece, the step again from its start in 2^level
            #        substeps, level = 1 .. max_sub.
            # Pieces of a crossing step shorter than CROSSING_MIN_FRACTION dt are not
            # integrated: the event is taken at the start of the piece (crossing_impact)
            # or the state stands for t1.  The vehicle blocks of the crossing pieces are
            # inverted in the step (level -1).
            t0 = n * dt
            t1 = (n + 1) * dt
            eta = CROSSING_MIN_FRACTION * dt
            status = OK
            level = 0
            phase = WHOLE
            if prm.contact_model == 0 and br.track == 0 and crosses_deck_end(
                    br, veh, t0, t1, prm.speed):
                # a wheel meets the velocity jump of the rail at a deck end in this step
                if wk.khv.shape[0] == veh.start.shape[0] - 1 and prm.max_sub > 0:
                    phase = CROSS  # split at the crossing times
                    for i in range(n_w):
                        wk.imp[i] = 0.0
                else:
                    # no workspace for variable steps (or max_sub = 0: no step is ever
                    # split): 2^CROSSING_LEVELS substeps, at most max_sub halvings
                    status = NOT_CONVERGED
                    level = min(prm.max_sub, CROSSING_LEVELS) - 1
            t = t0  # CROSS, TAIL: where the current piece starts
            tc = t1  # CROSS: where it ends
            k = 0  # TAIL, RETRY: the substep
            m = 1  # TAIL, RETRY: substeps
            h_sub = dt  # TAIL, RETRY: their length
            while True:
                if status != OK:  # the step again, in twice as many substeps
                    if level >= prm.max_sub:
                        break
                    level += 1
                    copy_state(bk, st)
                    for i in range(n_w):
                        wk.active[i] = wk.act0[i]
                        wk.onb[i] = wk.onb0[i]
                    if track:
                        for i in range(n_w):
                            for c in range(3):
                                wk.trk[i, c] = wk.trk0[i, c]
                    phase = RETRY
                    m = 1 << level
                    h_sub = dt / m
                    k = 0
                    iters = np.int64(0)
                # the next piece: (.., ta] of length hs at level lev, or an impact
                impact = False
                if phase == WHOLE:
                    ta = t1
                    hs = dt
                    lev = np.int64(0)
                elif phase == CROSS:
                    tc = next_deck_end(br, veh, t, t1, prm.speed)
                    if tc > t1:  # no more events: the rest of the step
                        if not t1 - t > eta:
                            for i in range(n_w):
                                wk.impulse[i] = wk.imp[i]  # the step's impulses
                            break
                        m = 1 << min(prm.max_sub, CROSSING_LEVELS) if t > t0 else 1
                        while m > 1 and (t1 - t) / m <= eta:
                            m //= 2
                        h_sub = (t1 - t) / m
                        k = 0
                        phase = TAIL
                        continue
                    for i in range(n_w):
                        wk.was_active[i] = wk.active[i]
                    impact = not tc - t > eta
                    ta = tc
                    hs = tc - t
                    lev = np.int64(-1)
                else:  # TAIL, RETRY
                    for i in range(n_w):
                        wk.was_active[i] = wk.active[i]
                    if phase == TAIL:
                        ta = t1 if k == m - 1 else t + (k + 1) * h_sub
                        lev = np.int64(-1)
                    else:
                        ta = t0 + (k + 1) * h_sub
                        lev = level
                    hs = h_sub
                if not impact:
                    status, it = vsi_step(br, veh, pr, prm, st, wk, ta, hs, lev)
                    iters += it
                    if status != OK:
                        continue
                    if phase == WHOLE:
                        break
                    if phase != RETRY:
                        for i in range(n_w):
                            wk.imp[i] += wk.impulse[i]
                    if phase == CROSS:
                        t = tc
                        continue
                    k += 1
                    if k == m:
                        if phase == TAIL:
                            for i in range(n_w):
                                wk.impulse[i] = wk.imp[i]  # the step's impulses, all pieces
                        break
                    continue
                # the wheels crossed within eta of t: the impact on the state there
                status = crossing_impact(br, veh, pr, prm, st, wk, tc)
                t = tc
            if status != OK:
                return status, n + 1
            if not state_is_finite(st):
                return NON_FINITE, n + 1
        tn = float(n + 1) * dt
        nl = np.int64(0)
        if red.le_E.shape[1] > 0:
            nl = le_list(red, veh.wheel_x0, veh.wheel_sf, st.X, veh.load_x0, veh.load_sf,
                         veh.load_p, tn, prm.speed)
        record(step_arrays(veh, st, wk), red, r, n + 1, tn, prm.speed, out, h, iters, nl)
    for i in range(n_w):
        if red.run_len[i] > 0:
            close_separation(red, r, i)
    return OK, prm.n_steps
