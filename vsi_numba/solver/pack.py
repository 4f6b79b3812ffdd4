"""Packing a model for the kernels: contiguous float64 arrays of the bridge (with its
track), the vehicles and the profile, the effective-stiffness inverses, and the static
equilibrium the runs start from."""

from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.distribution import expand
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.vehicle import NL_KINDS, Train
from vsi_numba.solver import driver
from vsi_numba.solver.settings import CONTACT_MODELS, SolverSettings


class ModelError(ValueError):
    """The model cannot be analysed (e.g. a singular vehicle)."""


@dataclass(frozen=True)
class Packed:
    """Kernel inputs of one case, plus what the wrapper needs to label the outputs."""

    bridge: ek.BridgeArrays
    vehicles: ek.VehicleArrays
    profile: ek.ProfileArrays
    params: ek.Params
    n_dof: int
    wheel_positions: np.ndarray  # m behind the first axle, per wheel (dynamic wheels first)
    load_positions: np.ndarray
    vehicle_names: list  # one per reported car body
    run_length: float = 0.0  # m the first axle travels until the last force leaves the bridge
    free_vibration: float = 0.0  # s simulated after that
    static_loads: np.ndarray | None = None  # N, static contact force of every wheel
    #: the vehicles as the kernels see them: ``vehicles`` with each moving force replaced
    #: by the forces of the bridge's load distribution (None: ``vehicles`` itself, whose
    #: moving forces are the axles the outputs report)
    distributed: ek.VehicleArrays | None = None
    #: trains on other tracks the runs last for (``train.other_trains`` with a train or
    #: speed of their own): per train (m its first axle travels until its last force
    #: leaves the deck, speed factor on the run's speed, fixed speed in m/s or 0); the
    #: runs last until the last of them has left too
    other_runs: tuple = ()

    @property
    def kernel_vehicles(self) -> ek.VehicleArrays:
        """The vehicle arrays the kernels run (:attr:`distributed` or :attr:`vehicles`)."""
        return self.vehicles if self.distributed is None else self.distributed

    def n_steps(self, speed: float) -> int:
        """Time steps of a run at ``speed`` (m/s)."""
        t_exit = self.run_length / speed
        for length, factor, fixed in self.other_runs:
            t_exit = max(t_exit, length / (fixed if fixed > 0.0 else factor * speed))
        return int(math.ceil((t_exit + self.free_vibration) / self.params.dt - 1e-9))


#: Load the deck with the rail's inertia (VehicleArrays.track_kappa).
RAIL_INERTIA_IN_DECK_LOAD = True


def _pack_bridge(bridge: ModalBridge, wheels: bool = True) -> ek.BridgeArrays:
    """Kernel arrays of the bridge; its track's filtered shapes only when there are
    ``wheels`` (prescribed moving forces load the deck line directly)."""
    n_m = bridge.n_modes
    f64 = np.float64
    if bridge.kind == 1:
        amp = np.ascontiguousarray(bridge.values[0], dtype=f64)
        k = np.pi * np.arange(1, n_m + 1, dtype=f64) / bridge.length
    else:
        amp = np.zeros(n_m)
        k = np.zeros(n_m)
    nodes = np.ascontiguousarray(bridge.nodes if bridge.kind == 2 else np.zeros(2), dtype=f64)
    vals = bridge.values if bridge.kind == 2 else np.zeros((2, n_m))
    slopes = bridge.slopes if bridge.kind == 2 else np.zeros((2, n_m))
    track = {}
    if bridge.track is not None and wheels:
        t_nodes, t_vals, t_slopes = bridge.track.filtered_shapes(bridge)
        track = dict(track=1, t_nodes=t_nodes, t_values=np.ascontiguousarray(t_vals, f64),
                     t_slopes=np.ascontiguousarray(t_slopes, f64))
    return ek.BridgeArrays(
        kind=int(bridge.kind),
        length=float(bridge.length),
        omega=np.ascontiguousarray(bridge.omega, dtype=f64),
        zeta=np.ascontiguousarray(bridge.damping, dtype=f64),
        sine_amp=amp,
        sine_k=k,
        nodes=nodes,
        values=np.ascontiguousarray(vals, dtype=f64),
        slopes=np.ascontiguousarray(slopes, dtype=f64),
        **track,
    )


def _effective_stiffness(M, C, K, dt, alpha):
    beta = 0.25 * (1.0 - alpha) ** 2
    gamma = 0.5 - alpha
    return M / (beta * dt * dt) + (1.0 + alpha) * (gamma / (beta * dt) * C + K)


def _vehicle_inverses(v, settings, levels):
    """K^-1 for dt/2^k (k < levels), M^-1 on the DOFs with mass, and that mask."""
    n = v.n_dof
    kh_inv = np.zeros((levels, n, n))
    for lev in range(levels):
        h = settings.dt / 2**lev
        kh = _effective_stiffness(v.M, v.C, v.K, h, settings.hht_alpha)
        # conditioning of the equilibrated matrix D^-1/2 K^ D^-1/2: a massless wheel DOF
        # (K only, ~1e6) next to a body DOF (M / (beta h^2), ~1e16 at h = dt/2^15) is
        # badly scaled, not singular
        d = np.sqrt(np.abs(np.diag(kh)))
        if np.any(d == 0.0) or not np.all(np.isfinite(kh)):
            raise ModelError(
                f"vehicle {v.name!r}: singular effective stiffness at the time step "
                f"{h:.3g} s: a DOF with neither mass nor stiffness (zero on the diagonal)"
            )
        cond = np.linalg.cond(kh / np.outer(d, d))
        if not cond <= 1e13:
            raise ModelError(
                f"vehicle {v.name!r}: singular effective stiffness at the time step "
                f"{h:.3g} s (condition number {cond:.3g} after scaling): a mechanism "
                "(DOFs that move together with neither mass nor stiffness), or masses and "
                "stiffnesses too far apart for double precision"
            )
        kh_inv[lev] = np.linalg.inv(kh)
    massive = np.any(v.M != 0.0, axis=1)
    m_inv = np.zeros((n, n))
    if massive.any():
        mm = v.M[np.ix_(massive, massive)]
        if np.linalg.cond(mm) > 1e13:
            raise ModelError(f"vehicle {v.name!r}: singular mass matrix")
        m_inv[np.ix_(np.flatnonzero(massive), np.flatnonzero(massive))] = np.linalg.inv(mm)
    return kh_inv, m_inv, massive


def pack(
    bridge: ModalBridge,
    train: Train,
    speed: float,
    profile: Profile | None,
    settings: SolverSettings,
) -> Packed:
    """Turn the model into kernel arrays (SI units, C-contiguous float64)."""
    if not speed > 0:
        raise ModelError(f"speed = {speed!r} m/s: expected > 0")
    profile = profile if profile is not None else no_irregularity()
    dyn = [(i, v, o) for i, (v, o) in enumerate(zip(train.vehicles, train.offsets, strict=True))
           if v.n_dof > 0]
    n_veh = len(dyn)
    nb = max([v.n_dof for _, v, _ in dyn], default=1)
    levels = settings.max_subdivisions + 1
    start = np.zeros(n_veh + 1, dtype=np.int64)
    M = np.zeros((n_veh, nb, nb))
    C = np.zeros_like(M)
    K = np.zeros_like(M)
    Kh = np.zeros((levels, n_veh, nb, nb))
    Mi = np.zeros_like(M)
    grav, wdof, wveh, wpos, wmassless, body, body_names = [], [], [], [], [], [], []
    pt_start, pt_pitch, pt_d = [0], [], []
    end_start, end_pitch, end_d = [0], [], []
    nl_start, nl_veh, nl_kind, nl_rows, nl_p = [0], [], [], [], []
    inverses: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for b, (_, v, off) in enumerate(dyn):
        n = v.n_dof
        start[b + 1] = start[b] + n
        M[b, :n, :n] = v.M
        C[b, :n, :n] = v.C
        K[b, :n, :n] = v.K
        if id(v) not in inverses:  # a train repeats the same car: invert once
            inverses[id(v)] = _vehicle_inverses(v, settings, levels)
        kh_inv, m_inv, massive = inverses[id(v)]
        Kh[:, b, :n, :n] = kh_inv
        Mi[b, :n, :n] = m_inv
        for kdof, p in zip(v.wheel_dofs, v.wheel_positions, strict=True):
            wdof.append(start[b] + kdof)
            wveh.append(b)
            wpos.append(off + p)
            wmassless.append(0 if massive[kdof] else 1)
        grav.append(v.gravity)
        for k, d in enumerate(v.body_dofs):
            body.append(start[b] + d)
            body_names.append(v.name if len(v.body_dofs) == 1 else f"{v.name}:{v.dof_names[d]}")
            for th, dist in v.body_comfort_points(k):
                pt_pitch.append(start[b] + th if th >= 0 else -1)
                pt_d.append(dist)
            pt_start.append(len(pt_d))
            for th, dist in v.body_end_points(k):
                end_pitch.append(start[b] + th if th >= 0 else -1)
                end_d.append(dist)
            end_start.append(len(end_d))
        for el in v.nonlinear:  # nonlinear suspension elements, vehicle by vehicle
            row = np.zeros(nb)
            row[:n] = el.row
            nl_veh.append(b)
            nl_kind.append(NL_KINDS[el.kind])
            nl_rows.append(row)
            nl_p.append(el.params)
        nl_start.append(len(nl_veh))
    lpos, lp = [], []
    for v, off in zip(train.vehicles, train.offsets, strict=True):
        lpos.extend(off + v.load_positions)
        lp.extend(v.loads)
    wpos = np.asarray(wpos, float)
    lpos = np.asarray(lpos, float)
    x_front = -settings.approach
    veh = ek.VehicleArrays(
        start=start,
        M=M, C=C, K=K, Khat_inv=Kh, M_inv=Mi,
        gravity=np.ascontiguousarray(np.concatenate(grav) if grav else np.zeros(0)),
        wheel_dof=np.asarray(wdof, dtype=np.int64),
        wheel_veh=np.asarray(wveh, dtype=np.int64),
        wheel_x0=np.ascontiguousarray(x_front - wpos),
        wheel_massless=np.asarray(wmassless, dtype=np.int64),
        compliance=np.zeros((0, 0)),
        body_dof=np.asarray(body, dtype=np.int64),
        load_x0=np.ascontiguousarray(x_front - lpos),
        load_p=np.asarray(lp, dtype=np.float64),
        body_pt_start=np.asarray(pt_start, dtype=np.int64),
        body_pt_pitch=np.asarray(pt_pitch, dtype=np.int64),
        body_pt_d=np.asarray(pt_d, dtype=np.float64),
        body_end_start=np.asarray(end_start, dtype=np.int64),
        body_end_pitch=np.asarray(end_pitch, dtype=np.int64),
        body_end_d=np.asarray(end_d, dtype=np.float64),
        nl_veh=np.asarray(nl_veh, dtype=np.int64),
        nl_start=np.asarray(nl_start, dtype=np.int64),
        nl_kind=np.asarray(nl_kind, dtype=np.int64),
        nl_a=np.ascontiguousarray(np.reshape(nl_rows, (len(nl_veh), nb)), dtype=np.float64),
        nl_p=np.ascontiguousarray(np.reshape(nl_p, (len(nl_veh), 3)), dtype=np.float64),
        wheel_sf=np.ones(len(wdof)), wheel_line=np.zeros(len(wdof), np.int64),
        load_sf=np.ones(len(lp)), load_line=np.zeros(len(lp), np.int64),
    )
    compliance = np.zeros((len(wdof), len(wdof)))
    if bridge.track is not None and len(wdof):
        compliance += bridge.track.wheel_compliance(x_front - wpos)
    if settings.contact_model == "hertz_linear" and len(wdof):
        q0 = _static_loads(veh)
        if np.any(q0 <= 0):
            raise ModelError("linearised Hertz contact needs a positive static load on every "
                             "wheel")
        # k_H = dN/d(delta) at N0 = 3 N0^(1/3) / (2 G)
        compliance[np.diag_indices(len(wdof))] += (2.0 * settings.hertz_coefficient
                                                   / (3.0 * np.cbrt(q0)))
    if np.any(compliance != 0.0):
        veh = veh._replace(compliance=np.ascontiguousarray(compliance))
    if bridge.track is not None and len(wdof):
        k_t, c_t, m_t = bridge.track.wheel_element
        if c_t > 0.0 or m_t > 0.0:  # damped or massive: the element under each wheel
            tr = bridge.track
            kappa = (float(getattr(tr, "rail_mass", 0.0)) / float(tr.foundation_stiffness)
                     * float(k_t)) if RAIL_INERTIA_IN_DECK_LOAD else 0.0
            veh = veh._replace(track_kt=float(k_t), track_ct=float(c_t), track_mt=float(m_t),
                               track_z0=np.zeros(len(wdof)),  # set by initial_states
                               track_kappa=kappa)
    veh = driver.with_patterns(veh)
    # the moving forces the kernels run: each axle spread by the track (outputs per axle)
    dist, distributed = bridge.load_distribution, None
    if dist is not None and dist.kind != "none" and lpos.size:
        dpos, dp = expand(lpos, lp, dist)
        distributed = veh._replace(load_x0=np.ascontiguousarray(x_front - dpos),
                                   load_p=np.ascontiguousarray(dp, dtype=np.float64),
                                   load_sf=np.ones(len(dp)),
                                   load_line=np.zeros(len(dp), np.int64))
        lpos_run = dpos  # the run ends when the last distributed force leaves
    else:
        lpos_run = lpos
    all_pos = np.concatenate([wpos, lpos_run])
    last = all_pos.max() if all_pos.size else 0.0
    run_length = bridge.length + settings.approach + last
    t_exit = run_length / speed
    n_steps = int(math.ceil((t_exit + settings.free_vibration) / settings.dt - 1e-9))
    wheel_load = max(float(np.max(np.abs(veh.gravity), initial=0.0)), 1.0)
    params = ek.Params(
        dt=float(settings.dt),
        alpha=float(settings.hht_alpha),
        speed=float(speed),
        n_steps=n_steps,
        max_iter=int(settings.max_iterations),
        tol_gap=1e-12 * max(bridge.length, 1.0),
        tol_force=1e-9 * wheel_load,
        max_sub=int(settings.max_subdivisions),
        contact_model=CONTACT_MODELS[settings.contact_model],
        hertz_g=float(settings.hertz_coefficient),
    )
    pr = ek.ProfileArrays(
        x0=float(profile.x0), dx=float(profile.dx),
        coef=np.ascontiguousarray(profile.coef, dtype=np.float64).reshape(-1, 4),
    )
    return Packed(
        bridge=_pack_bridge(bridge, wheels=len(wdof) > 0), vehicles=veh, profile=pr, params=params,
        n_dof=int(start[-1]), wheel_positions=wpos, load_positions=lpos,
        vehicle_names=body_names, run_length=float(run_length),
        free_vibration=float(settings.free_vibration), static_loads=_static_loads(veh),
        distributed=distributed,
    )


def _dense(veh: ek.VehicleArrays, A: np.ndarray) -> np.ndarray:
    n = int(veh.start[-1])
    out = np.zeros((n, n))
    for b in range(veh.start.size - 1):
        s, e = veh.start[b], veh.start[b + 1]
        out[s:e, s:e] = A[b, : e - s, : e - s]
    return out


#: Solutions of :func:`_kkt` by a digest of its inputs: the same dense system is solved
#: again for every batch of a train (its static loads, its start at a speed) and by the
#: report's re-runs; a solution found here is the one the solve gave, bit for bit.
_KKT_SOLVED: OrderedDict = OrderedDict()
_KKT_KEEP = 512
_KKT_LOCK = threading.Lock()


def _kkt(A, G, rhs_top, rhs_bottom, compliance=None):
    """Solve [A G^T; G -C] [x; y] = [rhs_top; rhs_bottom] (C = 0 without ``compliance``).

    The constraint rows are scaled to the size of ``A`` first: unscaled, a stiffness of
    1e7 N/m next to unit constraint rows makes the system so badly conditioned that the
    constraints are lost to round-off.  The last :data:`_KKT_KEEP` solutions are kept
    (by a digest of every input); the arrays returned are the caller's own.
    """
    h = hashlib.blake2b(digest_size=20)
    for a in (A, G, rhs_top, rhs_bottom, compliance):
        a = np.ascontiguousarray(a if a is not None else (), dtype=float)
        h.update(str(a.shape).encode())
        h.update(a.data)
    key = h.digest()
    with _KKT_LOCK:
        got = _KKT_SOLVED.get(key)
        if got is not None:
            _KKT_SOLVED.move_to_end(key)
    if got is None:
        got = _kkt_solve(A, G, rhs_top, rhs_bottom, compliance)
        with _KKT_LOCK:
            _KKT_SOLVED[key] = got
            while len(_KKT_SOLVED) > _KKT_KEEP:
                _KKT_SOLVED.popitem(last=False)
    return got[0].copy(), got[1].copy()


def _kkt_solve(A, G, rhs_top, rhs_bottom, compliance):
    """:func:`_kkt` without the memo."""
    n, m = A.shape[0], G.shape[0]
    s = max(float(np.max(np.abs(A), initial=0.0)), 1e-300)
    kkt = np.zeros((n + m, n + m))
    kkt[:n, :n] = A
    kkt[:n, n:] = s * G.T
    kkt[n:, :n] = s * G
    if compliance is not None:
        kkt[n:, n:] = -s * s * compliance
    rhs = np.concatenate([rhs_top, s * np.asarray(rhs_bottom, float)])
    try:
        sol = np.linalg.solve(kkt, rhs)
    except np.linalg.LinAlgError:
        sol = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
    return sol[:n], s * sol[n:]


def _static_loads(veh: ek.VehicleArrays) -> np.ndarray:
    n_w = veh.wheel_dof.size
    if n_w == 0:
        return np.zeros(0)
    G = np.zeros((n_w, int(veh.start[-1])))
    G[np.arange(n_w), veh.wheel_dof] = 1.0
    _, X = _kkt(_dense(veh, veh.K), G, veh.gravity, np.zeros(n_w))
    return X


def static_wheel_loads(packed: Packed) -> np.ndarray:
    """Static contact forces (N) of every wheel on level rigid track."""
    return _static_loads(packed.vehicles)


def initial_state(packed: Packed, profile: Profile) -> ek.State:
    """Static equilibrium on the approach track, with velocities and accelerations
    compatible with the rail (the train enters at constant speed)."""
    init = initial_states(packed, profile, [packed.params.speed])
    return ek.State(*(np.ascontiguousarray(a[0]) for a in init))


def initial_states(packed: Packed, profile: Profile, speeds) -> ek.Initial:
    """:func:`initial_state` of every speed (m/s), one row per speed.

    The static part (displacements, static contact forces) does not depend on the speed
    and is solved once; velocities and accelerations are solved per speed.
    """
    veh = packed.vehicles
    speeds = np.atleast_1d(np.asarray(speeds, float))
    n_r = speeds.size
    n_m = packed.bridge.omega.size
    n_v = packed.n_dof
    n_w = veh.wheel_dof.size
    x0 = veh.wheel_x0
    sf = veh.wheel_sf  # the wheels' speed factors (< 0: a train running in -x)
    G = np.zeros((n_w, n_v))
    G[np.arange(n_w), veh.wheel_dof] = 1.0
    Kd, Md, Cd = _dense(veh, veh.K), _dense(veh, veh.M), _dense(veh, veh.C)
    br = packed.bridge
    if np.any(sf < 0.0):
        if np.any(np.where(sf > 0.0, x0 > 0.0, x0 < br.length)):
            raise ModelError("every axle must start on the approach track (x <= 0, or "
                             "x >= the deck's length for a train running in -x)")
    elif np.any(x0 > 0.0):
        raise ModelError("every axle must start on the approach track (x <= 0)")
    r0, r1, r2 = _profile_at(profile, x0, veh.wheel_line)
    q0 = np.zeros(n_m)
    # the constant compliance (elastic rail, linearised Hertz) enters the static solve
    C = veh.compliance if veh.compliance.size else None
    if br.track == 1 and n_v:
        # elastic track: the rail deflects under the wheels (compliance C) and, within
        # its reach of a deck end, bends the deck too (filtered shapes phit at the
        # wheels): static equilibrium of deck modes and vehicles together,
        # [diag(w^2) 0; 0 K] z + B^T X = [0; g],  B z - C X = r0 with B = [-phit, G]
        from vsi_numba.model import hermite

        phit = np.zeros((n_w, n_m))
        n_t = br.t_nodes.size
        for k in np.unique(veh.wheel_line) if n_m else ():
            on = veh.wheel_line == k  # the rows of the wheels' track line
            rows = slice(k * n_t, (k + 1) * n_t)
            phit[on] = hermite.table(br.t_nodes, br.t_values[rows], br.t_slopes[rows],
                                     x0[on])
        A = np.zeros((n_m + n_v, n_m + n_v))
        A[:n_m, :n_m] = np.diag(br.omega**2)
        A[n_m:, n_m:] = Kd
        Bz = np.hstack([-phit, G])
        top = np.concatenate([np.zeros(n_m), veh.gravity])

        def static(extra):
            z, X = _kkt(A, Bz, top, r0 + extra, compliance=C)
            return z[:n_m], z[n_m:], X
    else:
        def static(extra):
            u, X = _kkt(Kd, G, veh.gravity, r0 + extra, compliance=C)
            return q0, u, X
    q0, u, X = static(np.zeros(n_w)) if n_v else (q0, np.zeros(0), np.zeros(0))
    prm = packed.params
    if n_v and prm.contact_model == 1:
        # Hertz contact: the wheels sit delta(X) = G X^(2/3) below the rail top; the
        # static forces of an indeterminate vehicle depend on delta, so iterate
        for _ in range(50):
            delta = prm.hertz_g * np.cbrt(np.clip(X, 0.0, None)) ** 2
            q0, u, X_new = static(delta)
            done = np.max(np.abs(X_new - X)) <= 1e-9 * max(np.max(np.abs(X)), 1.0)
            X = X_new
            if done:
                break
    if veh.track_z0.size:
        # the damped track's elements start from the static forces (k z = X_static): the
        # rail then has the static deflection under the wheels the static state assumes
        veh.track_z0[:] = X / veh.track_kt
    init = ek.Initial(
        q=np.zeros((n_r, n_m)), qd=np.zeros((n_r, n_m)), qdd=np.zeros((n_r, n_m)),
        u=np.zeros((n_r, n_v)), ud=np.zeros((n_r, n_v)), udd=np.zeros((n_r, n_v)),
        fq_tot=np.zeros((n_r, n_m)), fv_tot=np.zeros((n_r, n_v)), X=np.zeros((n_r, n_w)),
    )
    for r, v in enumerate(speeds):
        if n_v:
            vi = sf * v  # each wheel's own speed (v itself for one train)
            ud, _ = _kkt(Md, G, np.zeros(n_v), vi * r1)
            udd, Xr = _kkt(Md, G, veh.gravity - Cd @ ud - Kd @ u, vi * vi * r2)
        else:
            ud, udd, Xr = np.zeros(0), np.zeros(0), np.zeros(0)
        fv = veh.gravity.copy()
        np.subtract.at(fv, veh.wheel_dof, Xr)
        init.q[r] = q0
        init.fq_tot[r] = br.omega**2 * q0  # the static modal load of the wheels
        init.u[r] = u
        init.ud[r] = ud
        init.udd[r] = udd
        init.fv_tot[r] = fv
        init.X[r] = Xr
    return init


def _profile_at(profile, x, line):
    """r, r', r'' at the abscissae ``x`` of wheels on the track lines ``line``:
    ``profile`` one :class:`Profile` (every line's) or one per line."""
    if isinstance(profile, Profile):
        return profile(x), profile(x, 1), profile(x, 2)
    out = np.zeros((3, x.size))
    for k, p in enumerate(profile):
        on = line == k
        if on.any():
            out[:, on] = [p(x[on], d) for d in range(3)]
    return out[0], out[1], out[2]


@dataclass(frozen=True)
class LoadEffectTables:
    """What the kernels need for the dynamic load effects (mode-acceleration method).

    Channels (``n_c = 2 n_s + 2 n_sup``): bending moment at the ``n_s`` sections, shear
    force at the sections, support reactions, rotations at the supports.  Sections are
    the output points and the whole-deck grid, sorted and merged; ``point_index`` and
    ``grid_index`` map them back.  Signs as in :mod:`vsi_numba.model.influence`.

    Attributes
    ----------
    sections : ndarray, shape (n_s,)
        Section abscissae (m), ascending.
    point_index, grid_index : ndarray of int
        Section of each output point / whole-deck grid point.
    grid : ndarray, shape (n_g,)
        Whole-deck grid (m).
    supports : ndarray, shape (n_sup,)
        Support abscissae (m).
    spans, EI : ndarray, shape (n_span,)
        Span lengths (m) and bending stiffness (N m^2).
    A, B : ndarray, shape (n_span, n_sup)
        Support-moment influence lines: a unit load at ``xi = a / L`` of span s gives
        the support moment ``M_i = xi (1 - xi) (A[s, i] + B[s, i] xi)`` (N m/N; exact: the
        influence line of a support moment is a cubic in each span, zero at supports).
    X : ndarray, shape (n_s,)
        Section abscissa from the left support of its span (m).
    span : ndarray of int, shape (n_s,)
        Span of each section (the span to the right of a support; the last span at the
        right end of the deck).
    E : ndarray, shape (n_m, n_c)
        Effect of a unit modal coordinate on each channel
        (:func:`vsi_numba.model.influence.modal_effects`).
    w2inv : ndarray, shape (n_m,)
        1 / omega_j^2 (s^2).
    """

    sections: np.ndarray
    point_index: np.ndarray
    grid_index: np.ndarray
    grid: np.ndarray
    supports: np.ndarray
    spans: np.ndarray
    EI: np.ndarray
    A: np.ndarray
    B: np.ndarray
    X: np.ndarray
    span: np.ndarray
    E: np.ndarray
    w2inv: np.ndarray
    #: the channels computed (an imported deck's section forces: moment and shear only;
    #: the others' columns of ``E`` are zero and their envelopes are not written)
    channels: tuple[str, ...] = ("moment", "shear", "reaction", "rotation")

    @property
    def n_sections(self) -> int:
        return int(self.sections.size)

    @property
    def n_supports(self) -> int:
        return int(self.supports.size)


def load_effect_tables(bridge: ModalBridge, points, grid) -> LoadEffectTables | None:
    """:class:`LoadEffectTables` of a bridge at the output ``points`` and on the
    whole-deck ``grid`` (m); None when the bridge has no static beam deck (modes tables
    without section forces, rigid track, FE matrices: see
    :mod:`vsi_numba.model.influence`)."""
    from vsi_numba.model import influence as inf

    st = bridge.static
    if st is None or "moment" not in st.effects or bridge.n_modes == 0:
        return None
    f64 = np.float64
    points = np.atleast_1d(np.asarray(points, f64))
    grid = np.atleast_1d(np.asarray(grid, f64))
    sections, inv = np.unique(np.concatenate([points, grid]), return_inverse=True)
    sup = np.asarray(st.supports, f64)
    spans = np.asarray(st.spans, f64)
    n_span = spans.size
    span = np.clip(np.searchsorted(sup, sections, side="right") - 1, 0, n_span - 1)
    A = np.zeros((n_span, sup.size))
    B = np.zeros((n_span, sup.size))
    if n_span > 1:
        xi = np.array([1.0 / 3.0, 2.0 / 3.0])
        for s in range(n_span):
            u = inf.support_moments(st, sup[s] + xi * spans[s]) * 4.5  # / (xi (1 - xi))
            B[s] = 3.0 * (u[:, 1] - u[:, 0])
            A[s] = u[:, 0] - B[s] / 3.0
    k = np.arange(sup.size)
    channels = tuple(c for c in ("moment", "shear", "reaction", "rotation")
                     if c in st.effects)
    E = np.concatenate([inf.modal_effects(bridge, c, at) if c in channels
                        else np.zeros((at.size, bridge.n_modes))
                        for c, at in (("moment", sections), ("shear", sections),
                                      ("reaction", k), ("rotation", k))], axis=0)
    return LoadEffectTables(
        sections=sections, point_index=inv[: points.size].astype(np.int64),
        grid_index=inv[points.size:].astype(np.int64), grid=grid, supports=sup,
        spans=spans, EI=np.asarray(st.EI, f64), A=A, B=B,
        X=np.ascontiguousarray(sections - sup[span]), span=span.astype(np.int64),
        E=np.ascontiguousarray(E.T), w2inv=1.0 / np.asarray(bridge.omega, f64) ** 2,
        channels=channels)
