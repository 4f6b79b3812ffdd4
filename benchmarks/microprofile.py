"""Where the time of one engine step goes: the kernel's parts timed in numba loops.

Each driver below calls one function of ``vsi_numba.kernels.engine`` ``n`` times inside
a jitted loop, so the per-call time excludes Python.  The drivers are compiled WITHOUT
the on-disk cache on purpose: numba does not track callees in another module, so a cached
driver could run a stale copy of the engine (stack notes 2.4).  Compiling them costs a
minute or two on this machine, hence the micro-profile only runs in the ``normal`` and
``full`` modes.

Two variants of the moving-load assembly make the call-overhead question concrete:
``loads_flat`` does the same sine-mode work as ``engine.assemble_loads`` but takes flat
arrays instead of the ``BridgeArrays``/``VehicleArrays`` named tuples and evaluates only
``phi`` (not ``phi'``, ``phi''``).
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
    from vsi_numba.kernels import engine as ek

    @numba.njit(**_OPTS)
    def d_search(br, veh, pr, prm, st, bk, wk, n):
        for k in range(n):
            ek.contact_search(br, veh, pr, k * prm.dt, prm.speed, wk)

    @numba.njit(**_OPTS)
    def d_loads(br, veh, pr, prm, st, bk, wk, n):
        for k in range(n):
            ek.assemble_loads(br, veh, k * prm.dt, prm.speed, wk.fq, wk.phil, wk.hq, wk.rq)

    @numba.njit(**_OPTS)
    def loads_flat(length, amp, kk, load_x0, load_p, t, speed, fq):
        n_m = fq.shape[0]
        for j in range(n_m):
            fq[j] = 0.0
        for k in range(load_x0.shape[0]):
            x = load_x0[k] + speed * t
            if 0.0 <= x <= length:
                p = load_p[k]
                for j in range(n_m):
                    fq[j] += p * amp[j] * np.sin(kk[j] * x)

    @numba.njit(**_OPTS)
    def d_loads_flat(br, veh, pr, prm, st, bk, wk, n):
        for k in range(n):
            loads_flat(br.length, br.sine_amp, br.sine_k, veh.load_x0, veh.load_p,
                       k * prm.dt, prm.speed, wk.fq)

    @numba.njit(**_OPTS)
    def d_copy(br, veh, pr, prm, st, bk, wk, n):
        for _k in range(n):
            ek.copy_state(st, bk)

    @numba.njit(**_OPTS)
    def d_schur(br, veh, pr, prm, st, bk, wk, n):
        for _k in range(n):
            ek.build_schur(veh, wk, wk.khat, veh.Khat_inv[0])

    @numba.njit(**_OPTS)
    def d_active(br, veh, pr, prm, st, bk, wk, n):
        # the active-set solve of the last step (its S and predictor gaps are in wk)
        act0 = wk.act0.copy()
        scale = 1.0 + prm.alpha
        for _k in range(n):
            for i in range(act0.shape[0]):
                wk.active[i] = act0[i]
            ek.solve_active_set(veh, wk, scale, prm.max_iter, prm.tol_gap, prm.tol_force)

    @numba.njit(**_OPTS)
    def d_matvec(br, veh, pr, prm, st, bk, wk, n):
        kh = veh.Khat_inv[0]
        for _k in range(n):
            ek.block_matvec(veh, kh, wk.rv, wk.yv, False, 1.0)

    @numba.njit(**_OPTS)
    def d_step(br, veh, pr, prm, st, bk, wk, n):
        # the same step, from the mid-run state ``bk``, n times: one full HHT step
        # (time_loop adds copy_state, state_is_finite and record per step)
        act0 = wk.act0.copy()
        t1 = (prm.n_steps + 1) * prm.dt
        for _k in range(n):
            ek.copy_state(bk, st)
            for i in range(act0.shape[0]):
                wk.active[i] = act0[i]
                wk.was_active[i] = act0[i]
            ek.hht_step(br, veh, pr, prm, st, wk, t1, prm.dt, 0)

    _DRIVERS.update(contact_search=d_search, assemble_loads=d_loads,
                    loads_flat_arrays=d_loads_flat, build_schur=d_schur,
                    solve_active_set=d_active, block_matvec=d_matvec, copy_state=d_copy,
                    hht_step=d_step)
    return _DRIVERS


def _setup(bridge, train, speed, settings):
    from vsi_numba.kernels import engine as ek
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.solver import batch as sim_batch
    from vsi_numba.solver import simulate as sim

    prof = no_irregularity()
    packed = sim.pack(bridge, train, speed, prof, settings)
    # run to the middle of the passage (train on the span) and profile from that state
    mid = packed.params.n_steps // 2
    prm = packed.params._replace(n_steps=mid)
    st = sim.initial_state(packed, prof)
    n_m, n_w = packed.bridge.omega.size, packed.vehicles.wheel_dof.size
    wk = sim_batch._workspace(n_m, packed.n_dof, n_w)
    n = mid + 1
    out = ek.Output(q=np.zeros((n, n_m)), qdd=np.zeros((n, n_m)), X=np.zeros((n, n_w)),
                    contact=np.zeros((n, n_w), np.int8),
                    body_acc=np.zeros((n, packed.vehicles.body_dof.size)),
                    iters=np.zeros(n, np.int16))
    scratch = ek.State(*(np.empty_like(a) for a in st))
    ek.time_loop(packed.bridge, packed.vehicles, packed.profile, prm, st, scratch, wk, out)
    wk.act0[:] = wk.active
    bk = ek.State(*(a.copy() for a in st))
    return (packed.bridge, packed.vehicles, packed.profile, prm, st, bk, wk)


def microprofile(models, n_calls=20000):
    """Per-call CPU time (us) of each engine part for each ``(label, bridge, train, speed,
    settings)`` model; returns (compile seconds, {label: {part: us}})."""
    t0 = time.perf_counter()
    drivers = _build()
    out = {}
    compile_s = 0.0
    for label, bridge, train, speed, settings in models:
        args = _setup(bridge, train, speed, settings)
        row = {}
        for name, fn in drivers.items():
            if (name in ("build_schur", "solve_active_set", "block_matvec")
                    and args[1].wheel_dof.size == 0):
                continue
            if name == "loads_flat_arrays" and args[0].kind != 1:
                continue
            c = time.perf_counter()
            fn(*args, 1)  # compile (first model) and warm
            compile_s += time.perf_counter() - c
            c0 = time.process_time()
            fn(*args, n_calls)
            row[name] = (time.process_time() - c0) / n_calls * 1e6
        out[label] = row
    return min(compile_s, time.perf_counter() - t0), out
