"""Where the time of one engine step goes: the kernel's parts timed in numba loops.

Each driver below calls one function (or one stretch) of ``vsi_numba.kernels``
``n`` times inside a jitted loop, from a mid-passage state (the train on the deck), so
the per-call time excludes Python.  The drivers are compiled WITHOUT the on-disk cache on
purpose: numba does not track callees in another module, so a cached driver could run a
stale copy of the engine (docs/manual/developer.md, "The numba cache").  Compiling them
costs a minute or two on this machine, hence the micro-profile only runs in the
``normal`` and ``full`` modes.

The model is a study's (``study_spec`` of a config dict: the packed train, the profile of
the first realisation and the deck operators with the load effects, as ``vsi sweep``
runs it), advanced by :func:`~vsi_numba.kernels.loop.time_loop` to the middle of the
passage.  The parts of a step (``step`` = copy_state + hht_step + state_is_finite +
record, as in the time loop) are timed one by one; a part that reads ``wk.S`` or the
predictor gaps sees the step's own (the ``hht_step`` driver leaves them there).

Run on the ICE3 benchmark model (``c1``)::

    python -m benchmarks.microprofile
"""

from __future__ import annotations

import time

import numba
import numpy as np

_OPTS = {"cache": False, "nogil": True, "error_model": "numpy"}
_DRIVERS: dict = {}


def _build():
    if _DRIVERS:
        return _DRIVERS
    from vsi_numba.kernels.contact import assemble_loads, contact_search
    from vsi_numba.kernels.integrator import (
        copy_state,
        hht_coefficients,
        hht_correct,
        restore_state,
        save_state,
        state_is_finite,
        update_force_totals,
    )
    from vsi_numba.kernels.linalg import block_matvec, skyline_cholesky_solve
    from vsi_numba.kernels.record import le_finish, le_list, le_static, record, step_arrays
    from vsi_numba.kernels.schur import (
        build_schur,
        contact_arrays,
        contact_profile,
        solve_active_set,
    )
    from vsi_numba.kernels.step import hht_step, vsi_step
    from vsi_numba.kernels.track import track_element, track_predict

    @numba.njit(**_OPTS)
    def d_search(br, veh, pr, prm, st, bk, wk, red, out, n):
        t1 = (prm.n_steps + 1) * prm.dt
        for _k in range(n):
            contact_search(br, veh, pr, t1, prm.speed, wk)

    @numba.njit(**_OPTS)
    def d_loads(br, veh, pr, prm, st, bk, wk, red, out, n):
        t1 = (prm.n_steps + 1) * prm.dt
        for _k in range(n):
            assemble_loads(br, veh, t1, prm.speed, wk.fq, wk.phil, wk.hq, wk.rq)

    @numba.njit(**_OPTS)
    def d_predictor(br, veh, pr, prm, st, bk, wk, red, out, n):
        # the predictor of hht_step: residual, vehicle blocks, modal increments, gaps
        alpha = prm.alpha
        a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, prm.dt)
        khat_v = veh.Khat_inv[0]
        n_m = st.q.shape[0]
        n_v = st.u.shape[0]
        for _k in range(n):
            for j in range(n_m):
                cq = 2.0 * br.zeta[j] * br.omega[j]
                wk.khat[j] = a0 + scale * (a1 * cq + br.omega[j] ** 2)
                r = (scale * wk.fq[j] - alpha * st.fq_tot[j] + a2 * st.qd[j]
                     + a3 * st.qdd[j] - cq * (cv * st.qd[j] + ca * st.qdd[j])
                     - br.omega[j] ** 2 * st.q[j])
                wk.yq[j] = r / wk.khat[j]
            for k in range(n_v):
                wk.rv[k] = scale * veh.gravity[k] - alpha * st.fv_tot[k]
                wk.hv[k] = a2 * st.ud[k] + a3 * st.udd[k]
                wk.vv[k] = cv * st.ud[k] + ca * st.udd[k]
            block_matvec(veh, veh.M, wk.hv, wk.rv, True, 1.0)
            block_matvec(veh, veh.C, wk.vv, wk.rv, True, -1.0)
            block_matvec(veh, veh.K, st.u, wk.rv, True, -1.0)
            block_matvec(veh, khat_v, wk.rv, wk.yv, False, 1.0)
            for i in range(veh.wheel_dof.shape[0]):
                d = veh.wheel_dof[i]
                g = wk.rr[i, 0] - (st.u[d] + wk.yv[d])
                for j in range(n_m):
                    g += wk.phi[i, j] * (st.q[j] + wk.yq[j])
                wk.gstar[i] = g

    @numba.njit(**_OPTS)
    def d_block_matvec(br, veh, pr, prm, st, bk, wk, red, out, n):
        kh = veh.Khat_inv[0]
        for _k in range(n):
            block_matvec(veh, kh, wk.rv, wk.yv, False, 1.0)

    @numba.njit(**_OPTS)
    def d_schur(br, veh, pr, prm, st, bk, wk, red, out, n):
        for _k in range(n):
            build_schur(veh, wk, wk.khat, veh.Khat_inv[0])

    @numba.njit(**_OPTS)
    def d_compliance(br, veh, pr, prm, st, bk, wk, red, out, n):
        # the dense n_w x n_w add of the compliance of the whole build (on a copy of S)
        inv = 1.0 / (1.0 + prm.alpha)
        n_w = veh.wheel_dof.shape[0]
        S = wk.J
        for _k in range(n):
            if veh.compliance.shape[0] > 0:
                for i in range(n_w):
                    for k in range(n_w):
                        S[i, k] = wk.S[i, k] + veh.compliance[i, k] * inv

    @numba.njit(**_OPTS)
    def d_track_predict(br, veh, pr, prm, st, bk, wk, red, out, n):
        # on copies: the step's S, gaps and track state stay as they are
        alpha = prm.alpha
        a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, prm.dt)
        S = wk.S.copy()
        g = wk.gstar.copy()
        trk = wk.trk.copy()
        for _k in range(n):
            if track_element(veh):
                track_predict(veh, wk, st, alpha, a0, a1, a2, a3, cv, ca, scale)
        wk.S[:, :] = S
        wk.gstar[:] = g
        wk.trk[:, :] = trk

    @numba.njit(**_OPTS)
    def d_active(br, veh, pr, prm, st, bk, wk, red, out, n):
        # the active-set solve of the step (its S and predictor gaps are in wk; the rows
        # of the factor before the wheels on the deck are kept from the step's, as from
        # one step to the next while no wheel enters or leaves the deck)
        act0 = wk.act0.copy()
        scale = 1.0 + prm.alpha
        for _k in range(n):
            for i in range(act0.shape[0]):
                wk.active[i] = act0[i]
            solve_active_set(contact_arrays(veh, wk), scale, prm.max_iter, prm.tol_gap,
                             prm.tol_force)

    @numba.njit(**_OPTS)
    def d_profile(br, veh, pr, prm, st, bk, wk, red, out, n):
        m = 0
        for i in range(wk.act0.shape[0]):
            if wk.act0[i] == 1:
                wk.idx[m] = i
                m += 1
        for _k in range(n):
            contact_profile(contact_arrays(veh, wk), m)

    @numba.njit(**_OPTS)
    def d_cholesky(br, veh, pr, prm, st, bk, wk, red, out, n):
        m = 0
        scale = 1.0 + prm.alpha
        for i in range(wk.act0.shape[0]):
            if wk.act0[i] == 1:
                wk.idx[m] = i
                wk.rhs[m] = -wk.gstar[i] / scale
                m += 1
        contact_profile(contact_arrays(veh, wk), m)
        for _k in range(n):
            skyline_cholesky_solve(wk.S, wk.idx, m, wk.first, wk.L, wk.rhs, wk.sol)

    @numba.njit(**_OPTS)
    def d_gaps(br, veh, pr, prm, st, bk, wk, red, out, n):
        # the gap check of the free wheels against the active forces (one sweep)
        scale = 1.0 + prm.alpha
        n_w = veh.wheel_dof.shape[0]
        m = 0
        for i in range(n_w):
            if wk.act0[i] == 1:
                m += 1
        acc = 0.0
        for _k in range(n):
            for i in range(n_w):
                g = wk.gstar[i]
                for a in range(m):
                    g += scale * wk.S[i, wk.idx[a]] * wk.sol[a]
                acc += g
        return acc

    @numba.njit(**_OPTS)
    def d_corrector(br, veh, pr, prm, st, bk, wk, red, out, n):
        # corrector and Newmark updates (on a copy of the state)
        alpha = prm.alpha
        a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, prm.dt)
        khat_v = veh.Khat_inv[0]
        for _k in range(n):
            copy_state(bk, st)
            hht_correct(veh, st, wk, khat_v, a0, a2, a3, gamma, scale, prm.dt)
            update_force_totals(br, veh, wk, st)

    @numba.njit(**_OPTS)
    def d_record(br, veh, pr, prm, st, bk, wk, red, out, n):
        t = prm.n_steps * prm.dt
        for _k in range(n):
            nl = 0
            if red.le_E.shape[1] > 0:
                nl = le_list(red, veh.wheel_x0, veh.wheel_sf, st.X, veh.load_x0,
                             veh.load_sf, veh.load_p, t, prm.speed)
            record(step_arrays(veh, st, wk), red, 0, prm.n_steps, t, prm.speed, out, -1, 1,
                   nl)

    @numba.njit(**_OPTS)
    def d_load_effects(br, veh, pr, prm, st, bk, wk, red, out, n):
        t = prm.n_steps * prm.dt
        for _k in range(n):
            if red.le_E.shape[1] > 0:
                nl = le_list(red, veh.wheel_x0, veh.wheel_sf, st.X, veh.load_x0,
                             veh.load_sf, veh.load_p, t, prm.speed)
                le_static(red.le_sup, red.le_L, red.le_Linv, red.le_c6, red.le_A, red.le_B,
                          red.le_X, red.le_xi, red.le_sec0, red.le_val, red.le_Ms,
                          red.le_acc, red.le_lx, red.le_lp, red.le_ls, nl)
                le_finish(red.le_E, red.le_w2inv, red.le_val, st.q, st.fq_tot, red.le_max,
                          red.le_max_t, red.le_min, red.le_min_t, 0, prm.n_steps, t)

    @numba.njit(**_OPTS)
    def d_copy(br, veh, pr, prm, st, bk, wk, red, out, n):
        for _k in range(n):
            copy_state(bk, st)

    @numba.njit(**_OPTS)
    def d_save(br, veh, pr, prm, st, bk, wk, red, out, n):
        for _k in range(n):
            save_state(st, wk.nbk)
            restore_state(wk.nbk, st)

    @numba.njit(**_OPTS)
    def back_to_mid(bk, st, wk, act0, trk0):
        # the mid-run state ``bk``, its contact set and track state, again
        copy_state(bk, st)
        wk.trk[:, :] = trk0
        for i in range(act0.shape[0]):
            wk.active[i] = act0[i]
            wk.was_active[i] = act0[i]

    @numba.njit(**_OPTS)
    def d_hht(br, veh, pr, prm, st, bk, wk, red, out, n):
        # the same step, from the mid-run state ``bk``, n times
        act0 = wk.act0.copy()
        trk0 = wk.trk.copy()
        t1 = (prm.n_steps + 1) * prm.dt
        for _k in range(n):
            back_to_mid(bk, st, wk, act0, trk0)
            hht_step(br, veh, pr, prm, st, wk, t1, prm.dt, 0)
        wk.trk[:, :] = trk0

    @numba.njit(**_OPTS)
    def d_step(br, veh, pr, prm, st, bk, wk, red, out, n):
        # a whole step of the time loop: copy_state, hht_step, the finiteness check, record
        act0 = wk.act0.copy()
        trk0 = wk.trk.copy()
        t1 = (prm.n_steps + 1) * prm.dt
        for _k in range(n):
            back_to_mid(bk, st, wk, act0, trk0)
            copy_state(st, bk)
            vsi_step(br, veh, pr, prm, st, wk, t1, prm.dt, 0)
            state_is_finite(st)
            nl = 0
            if red.le_E.shape[1] > 0:
                nl = le_list(red, veh.wheel_x0, veh.wheel_sf, st.X, veh.load_x0,
                             veh.load_sf, veh.load_p, t1,
                                prm.speed)
            record(step_arrays(veh, st, wk), red, 0, prm.n_steps + 1, t1, prm.speed, out,
                   -1, 1, nl)
        wk.trk[:, :] = trk0

    # order: the step first (leaves the step's S, gaps and contact set in wk for the
    # solve's parts), the parts that overwrite S or the gaps last
    _DRIVERS.update(step=d_step, hht_step=d_hht, solve_active_set=d_active,
                    contact_profile=d_profile, skyline_cholesky=d_cholesky, gaps=d_gaps,
                    corrector=d_corrector, contact_search=d_search, assemble_loads=d_loads,
                    predictor=d_predictor, block_matvec=d_block_matvec, build_schur=d_schur,
                    compliance_add=d_compliance,
                    track_predict=d_track_predict, record=d_record, load_effects=d_load_effects,
                    copy_state=d_copy, save_restore=d_save)
    return _DRIVERS


def ice3_c1_config(speed_kmh: float = 300.0, seed: int = 1) -> dict:
    """The ``c1`` benchmark model (``benchmarks.study.ice3_config``) at one speed."""
    from benchmarks.study import ice3_config

    return ice3_config((seed,), (speed_kmh,))


def _setup(model):
    """Kernel arguments of a model's run, advanced to the middle of its passage.

    ``model`` is a config dict (its first train, realisation and speed, as ``vsi sweep``
    packs them, load effects included) or ``(bridge, train, speed m/s, settings)`` (smooth
    track, output point at mid-span of each span).  Returns
    (br, veh, pr, prm, st, bk, wk, red, out) with ``bk`` the mid-passage state and
    ``prm.n_steps`` its step index."""
    from vsi_numba import kernels as ek

    if isinstance(model, dict):
        from vsi_numba.study.batches import packed_for
        from vsi_numba.study.spec import study_model, study_spec

        spec = study_spec(model)
        sm = study_model(spec)
        packed, profile = packed_for(spec, 0, 0)
        speed = float(sm.speeds_kmh[0]) / 3.6
        bridge, settings, points, deck = sm.bridge, sm.settings, sm.output_points, sm.deck
    else:
        from vsi_numba.model.irregularity import no_irregularity
        from vsi_numba.solver import simulate as sim

        bridge, train, speed, settings = model
        profile = no_irregularity()
        packed = sim.pack(bridge, train, speed, profile, settings)
        s = np.asarray(bridge.supports, float)
        points = 0.5 * (s[:-1] + s[1:])
        deck = None
    from benchmarks.cases import kernel_args

    (br, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, slots, status,
     reached) = kernel_args(packed, profile, speed, points, settings, bridge, deck=deck)
    # run to the middle of the passage (train on the span) and profile from that state
    mid = int(n_steps[0]) // 2
    p = ek.Params(prm.dt, prm.alpha, speed, mid, prm.max_iter, prm.tol_gap, prm.tol_force,
                  prm.max_sub, prm.contact_model, prm.hertz_g)
    ek.time_loop(br, veh, pr, p, st, bk, wk, red, 0, out, -1)
    wk.act0[:] = wk.active
    bk = ek.State(*(a.copy() for a in st))
    return (br, veh, pr, p, st, bk, wk, red, out)


def microprofile(models, n_calls=20000):
    """Per-call CPU time (us) of each engine part for each ``(label, config dict)`` or
    ``(label, bridge, train, speed, settings)`` model (see :func:`_setup`); returns
    (compile seconds, {label: {part: us}})."""
    t0 = time.perf_counter()
    drivers = _build()
    out = {}
    compile_s = 0.0
    for label, *model in models:
        args = _setup(model[0] if len(model) == 1 else tuple(model))
        row = {}
        for name, fn in drivers.items():
            if args[1].wheel_dof.size == 0 and name not in (
                    "assemble_loads", "copy_state", "record", "load_effects"):
                continue
            c = time.perf_counter()
            fn(*args, 1)  # compile (first model) and warm
            compile_s += time.perf_counter() - c
            n = max(n_calls // 10, 1) if name in ("step", "hht_step") else n_calls
            c0 = time.process_time()
            fn(*args, n)
            row[name] = (time.process_time() - c0) / n * 1e6
        out[label] = row
    return min(compile_s, time.perf_counter() - t0), out


def main(argv=None) -> int:
    import argparse

    p = argparse.ArgumentParser(description="Per-part CPU time of the ICE3 (c1) step.")
    p.add_argument("--speed", type=float, default=300.0, help="km/h")
    p.add_argument("--calls", type=int, default=20000)
    args = p.parse_args(argv)
    comp, res = microprofile([("c1", ice3_c1_config(args.speed))], args.calls)
    print(f"compile {comp:.0f} s")
    for label, row in res.items():
        print(label)
        for k, v in row.items():
            print(f"  {k:18s} {v:9.3f} us")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
