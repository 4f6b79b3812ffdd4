"""``simulate``: one train at one speed over one bridge and track profile.

The wrapper validates and packs the model into contiguous float64 arrays, finds the
static equilibrium of the train on the approach track, runs the numba time loop and
turns the kernel's status code and raw histories into an ``xarray.Dataset`` with the
names and attributes of ``vsi_numba.io.schema`` (design note, section 3).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vsi_numba.io.schema import attrs_for
from vsi_numba.kernels import engine as ek
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.settings import CONTACT_MODELS, SolverSettings

if TYPE_CHECKING:  # imported where a Dataset is made: it takes ~1 s to import
    import xarray as xr

STATUS_MESSAGES = {
    ek.OK: "ok",
    ek.NOT_CONVERGED: "contact iterations did not converge (also with the step subdivided)",
    ek.SINGULAR_SCHUR: "singular contact (Schur) system: dependent contact constraints",
    ek.NON_FINITE: "non-finite (NaN/inf) state: the integration diverged",
    ek.SINGULAR_IMPACT: "singular impact system at a wheel landing",
}


class ModelError(ValueError):
    """The model cannot be analysed (e.g. a singular vehicle)."""


def acceleration_cutoff(frequencies: np.ndarray) -> float:
    """EN 1990 A2.4.4.2.1: frequencies up to max(30 Hz, 1.5 f1, f3) enter the check."""
    f = np.asarray(frequencies, float)
    if f.size == 0:
        return 30.0
    f3 = f[2] if f.size >= 3 else 0.0
    return float(max(30.0, 1.5 * f[0], f3))


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
    run_length: float = 0.0  # m the first axle travels until the last leaves the bridge
    free_vibration: float = 0.0  # s simulated after that
    static_loads: np.ndarray | None = None  # N, static contact force of every wheel

    def n_steps(self, speed: float) -> int:
        """Time steps of a run at ``speed`` (m/s)."""
        t_exit = self.run_length / speed
        return int(math.ceil((t_exit + self.free_vibration) / self.params.dt - 1e-9))


def _pack_bridge(bridge: ModalBridge) -> ek.BridgeArrays:
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
    if bridge.track is not None:
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
        wheel_compliance=np.zeros(len(wdof)),
        body_dof=np.asarray(body, dtype=np.int64),
        load_x0=np.ascontiguousarray(x_front - lpos),
        load_p=np.asarray(lp, dtype=np.float64),
        body_pt_start=np.asarray(pt_start, dtype=np.int64),
        body_pt_pitch=np.asarray(pt_pitch, dtype=np.int64),
        body_pt_d=np.asarray(pt_d, dtype=np.float64),
        track_C=(bridge.track.compliance(x_front - wpos) if bridge.track is not None
                 else np.zeros((len(wdof), len(wdof)))),
    )
    if settings.contact_model == "hertz_linear" and len(wdof):
        q0 = _static_loads(veh)
        if np.any(q0 <= 0):
            raise ModelError("linearised Hertz contact needs a positive static load on every "
                             "wheel")
        # k_H = dN/d(delta) at N0 = 3 N0^(1/3) / (2 G)
        veh = veh._replace(wheel_compliance=2.0 * settings.hertz_coefficient
                           / (3.0 * np.cbrt(q0)))
    all_pos = np.concatenate([wpos, lpos])
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
        bridge=_pack_bridge(bridge), vehicles=veh, profile=pr, params=params,
        n_dof=int(start[-1]), wheel_positions=wpos, load_positions=lpos,
        vehicle_names=body_names, run_length=float(run_length),
        free_vibration=float(settings.free_vibration), static_loads=_static_loads(veh),
    )


def _dense(veh: ek.VehicleArrays, A: np.ndarray) -> np.ndarray:
    n = int(veh.start[-1])
    out = np.zeros((n, n))
    for b in range(veh.start.size - 1):
        s, e = veh.start[b], veh.start[b + 1]
        out[s:e, s:e] = A[b, : e - s, : e - s]
    return out


def _kkt(A, G, rhs_top, rhs_bottom, compliance=None):
    """Solve [A G^T; G -C] [x; y] = [rhs_top; rhs_bottom] (C = 0 without ``compliance``).

    The constraint rows are scaled to the size of ``A`` first: unscaled, a stiffness of
    1e7 N/m next to unit constraint rows makes the system so badly conditioned that the
    constraints are lost to round-off.
    """
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
    G = np.zeros((n_w, n_v))
    G[np.arange(n_w), veh.wheel_dof] = 1.0
    Kd, Md, Cd = _dense(veh, veh.K), _dense(veh, veh.M), _dense(veh, veh.C)
    if np.any(x0 > 0.0):
        raise ModelError("every axle must start on the approach track (x <= 0)")
    r0, r1, r2 = profile(x0), profile(x0, 1), profile(x0, 2)
    br = packed.bridge
    q0 = np.zeros(n_m)
    if br.track == 1 and n_v:
        # elastic track: the rail deflects under the wheels (compliance C) and, within
        # its reach of a deck end, bends the deck too (filtered shapes phit at the
        # wheels): static equilibrium of deck modes and vehicles together,
        # [diag(w^2) 0; 0 K] z + B^T X = [0; g],  B z - C X = r0 with B = [-phit, G]
        from vsi_numba.model.track import hermite_table

        phit = hermite_table(br.t_nodes, br.t_values, br.t_slopes, x0) if n_m else \
            np.zeros((n_w, 0))
        A = np.zeros((n_m + n_v, n_m + n_v))
        A[:n_m, :n_m] = np.diag(br.omega**2)
        A[n_m:, n_m:] = Kd
        Bz = np.hstack([-phit, G])
        top = np.concatenate([np.zeros(n_m), veh.gravity])

        def static(extra):
            z, X = _kkt(A, Bz, top, r0 + extra, compliance=veh.track_C)
            return z[:n_m], z[n_m:], X
    else:
        def static(extra):
            u, X = _kkt(Kd, G, veh.gravity, r0 + extra)
            return q0, u, X
    q0, u, X = static(np.zeros(n_w)) if n_v else (q0, np.zeros(0), np.zeros(0))
    prm = packed.params
    if n_v and prm.contact_model != 0:
        # compliant contact: the wheels sit delta(X) below the rail top; the static
        # forces of an indeterminate vehicle depend on delta, so iterate
        for _ in range(50):
            if prm.contact_model == 1:
                delta = prm.hertz_g * np.cbrt(np.clip(X, 0.0, None)) ** 2
            else:
                delta = veh.wheel_compliance * X
            q0, u, X_new = static(delta)
            done = np.max(np.abs(X_new - X)) <= 1e-9 * max(np.max(np.abs(X)), 1.0)
            X = X_new
            if done:
                break
    init = ek.Initial(
        q=np.zeros((n_r, n_m)), qd=np.zeros((n_r, n_m)), qdd=np.zeros((n_r, n_m)),
        u=np.zeros((n_r, n_v)), ud=np.zeros((n_r, n_v)), udd=np.zeros((n_r, n_v)),
        fq_tot=np.zeros((n_r, n_m)), fv_tot=np.zeros((n_r, n_v)), X=np.zeros((n_r, n_w)),
    )
    for r, v in enumerate(speeds):
        if n_v:
            ud, _ = _kkt(Md, G, np.zeros(n_v), v * r1)
            udd, Xr = _kkt(Md, G, veh.gravity - Cd @ ud - Kd @ u, v * v * r2)
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


def _workspace(n_m, n_v, n_w) -> ek.Work:
    z = np.zeros
    return ek.Work(
        phi=z((n_w, n_m)), dphi=z((n_w, n_m)), d2phi=z((n_w, n_m)),
        onb=z(n_w, np.int64), rr=z((n_w, 3)), S=z((n_w, n_w)), L=z((n_w, n_w)),
        idx=z(n_w, np.int64), rhs=z(n_w), sol=z(n_w), gstar=z(n_w), X=z(n_w),
        active=np.ones(n_w, np.int64), was_active=np.ones(n_w, np.int64),
        yq=z(n_m), yv=z(n_v), rq=z(n_m), rv=z(n_v), fq=z(n_m), phil=z(n_m), hq=z(n_m),
        hv=z(n_v), ones=np.ones(n_m), khat=z(n_m), xout=z(n_w), vq=z(n_m), vv=z(n_v),
        av=z(n_v), act0=z(n_w, np.int64), J=z((n_w, n_w)),
        first=z(n_w, np.int64), onb_prev=z(n_w, np.int64), onb0=z(n_w, np.int64),
        cand=z(n_w, np.int64), lq=z(n_w), lz=z(n_w), lw=z(n_w), lin=z(n_w, np.int64),
        impulse=z(n_w),
    )


def _history_buffers(n_slots, n_t, n_m, n_w, n_b) -> ek.Output:
    return ek.Output(
        q=np.full((n_slots, n_t, n_m), np.nan), qdd=np.full((n_slots, n_t, n_m), np.nan),
        X=np.full((n_slots, n_t, n_w), np.nan), contact=np.zeros((n_slots, n_t, n_w), np.int8),
        body_acc=np.full((n_slots, n_t, n_b), np.nan),
        iters=np.zeros((n_slots, n_t), np.int16),
        body_pitch=np.full((n_slots, n_t, n_b), np.nan),
    )


#: Intervals per span of the whole-deck acceleration grid (see :func:`deck_grid`).
DECK_GRID_INTERVALS = 32


def deck_grid(bridge: ModalBridge, points=(), intervals: int = DECK_GRID_INTERVALS
              ) -> np.ndarray:
    """Abscissae (m) where the whole-deck acceleration envelope is evaluated.

    ``intervals`` equal intervals on every span (supports included) plus the user's
    output ``points``, sorted, duplicates removed.

    Notes
    -----
    The grid maximum underestimates the maximum over the continuous deck by at most the
    relative amount (K h)^2 / 8, with h the grid spacing and K the largest wavenumber
    of the band-limited modes (|f''| <= K^2 max|f| for a trigonometric polynomial of
    degree K, Bernstein; the true maximum x* is a stationary point of |a(., t*)| and a
    grid point lies within h/2 of it).  Three half-waves per span (a 15 m span, f1 = 8 Hz:
    the modes up to the cut-off f3) give 1.1 % with 32 intervals, 4.3 % with 16.
    """
    s = np.asarray(bridge.supports, float)
    if s.size < 2:
        s = np.array([0.0, float(bridge.length)])
    grid = [np.linspace(a, b, int(intervals) + 1) for a, b in zip(s[:-1], s[1:], strict=True)]
    grid.append(np.atleast_1d(np.asarray(points, float)))
    grid = np.unique(np.round(np.concatenate(grid), 12))
    return grid[(grid >= 0.0) & (grid <= bridge.length)]


def deck_operators(bridge: ModalBridge, points, settings: SolverSettings):
    """Mode shapes of the deck line at ``points`` and on the whole-deck grid.

    Returns
    -------
    tuple
        ``(phi_d, phi_a, cutoff, grid_x, phi_g)``: ``phi_d`` (n_p, n_m) at the points;
        ``phi_a`` the same with zero columns for the modes above the EN 1990
        A2.4.4.2.1 cut-off (Hz, ``cutoff``), so ``phi_a @ qdd`` is the band-limited deck
        acceleration; ``grid_x`` (n_g,) the whole-deck grid (:func:`deck_grid`) and
        ``phi_g`` (n_ka, n_g) its band-limited shapes, transposed, for the first ``n_ka``
        modes (those up to the last mode below the cut-off).
    """
    points = np.atleast_1d(np.asarray(points, float))
    phi_d = np.ascontiguousarray(bridge.output_shapes(points), dtype=np.float64)
    phi_d = phi_d.reshape(points.size, bridge.n_modes)
    cutoff = settings.acceleration_cutoff
    if cutoff is None:
        cutoff = acceleration_cutoff(bridge.frequencies)
    keep = np.asarray(bridge.frequencies) <= cutoff + 1e-9
    phi_a = np.ascontiguousarray(np.where(keep[None, :], phi_d, 0.0))
    n_ka = int(np.flatnonzero(keep)[-1]) + 1 if keep.any() else 0
    grid_x = deck_grid(bridge, points) if n_ka else np.zeros(0)
    shapes = np.asarray(bridge.output_shapes(grid_x), float).reshape(grid_x.size,
                                                                      bridge.n_modes)
    phi_g = np.ascontiguousarray(np.where(keep[None, :n_ka], shapes[:, :n_ka], 0.0).T)
    return phi_d, phi_a, float(cutoff), grid_x, phi_g


@dataclass
class BatchResult:
    """Envelopes (one row per run) and raw histories (per history slot) of a batch."""

    packed: Packed
    speeds: np.ndarray  # (R,) m/s
    n_steps: np.ndarray  # (R,)
    status: np.ndarray  # (R,) int
    reached: np.ndarray  # (R,) int
    slots: np.ndarray  # (R,) history slot or -1
    red: ek.Reduce
    out: ek.Output
    phi_d: np.ndarray
    phi_a: np.ndarray
    cutoff: float
    elapsed: float
    grid_x: np.ndarray | None = None  # (n_g,) whole-deck grid, m

    @property
    def static_loads(self) -> np.ndarray:
        """Q0 of every wheel, dynamic wheels then moving forces (N)."""
        return np.concatenate([self.packed.static_loads, self.packed.vehicles.load_p])

    @property
    def wheel_positions(self) -> np.ndarray:
        return np.concatenate([self.packed.wheel_positions, self.packed.load_positions])

    def message(self, r: int) -> str:
        status = int(self.status[r])
        text = STATUS_MESSAGES[status]
        if status != ek.OK:
            k = int(self.reached[r])
            text += f" at t = {k * self.packed.params.dt:.6g} s (step {k})"
        return text

    def envelopes(self) -> dict[str, np.ndarray]:
        """Every envelope variable of ``vsi_numba.io.schema`` (rows: runs; NaN for the
        runs that failed)."""
        red, pk, dt = self.red, self.packed, self.packed.params.dt
        n_r = self.speeds.size
        n_l = pk.load_positions.size
        loads = pk.vehicles.load_p
        q0 = self.static_loads

        def with_loads(dyn, value):
            return np.concatenate([dyn, np.broadcast_to(value, (n_r, n_l))], axis=1)

        xmin = with_loads(red.xmin, loads)
        with np.errstate(invalid="ignore", divide="ignore"):
            unloading = (q0[None, :] - xmin) / q0[None, :]
        data = {
            "max_deck_displacement": red.disp.copy(),
            "max_deck_acceleration": red.acc.copy(),
            "min_contact_force": xmin,
            "max_contact_force": with_loads(red.xmax, loads),
            "max_wheel_unloading": unloading,
            "max_carbody_acceleration": red.body.copy(),
            "contact_loss_duration": with_loads(red.lost * dt, 0.0),
            "longest_contact_loss": with_loads(red.longest * dt, 0.0),
            "contact_loss_events": with_loads(red.events.astype(float), 0.0),
            "single_step_contact_losses": with_loads(red.single.astype(float), 0.0),
            "time_of_max_deck_displacement": red.disp_t.copy(),
            "time_of_max_deck_acceleration": red.acc_t.copy(),
            # a moving force is at its start position at its (first) minimum, t = 0
            "position_of_min_contact_force": with_loads(red.xmin_x, pk.vehicles.load_x0),
            "time_of_max_carbody_acceleration": red.body_t.copy(),
            "position_of_max_carbody_acceleration": red.body_x.copy(),
        }
        grid = self.grid_x if self.grid_x is not None else np.zeros(0)
        if grid.size:
            data["max_deck_acceleration_whole_deck"] = red.gacc.copy()
            data["time_of_max_deck_acceleration_whole_deck"] = red.gacc_t.copy()
            data["position_of_max_deck_acceleration_whole_deck"] = grid[red.gacc_i]
        else:  # no modes in the acceleration band (or no deck)
            for name in ("max_deck_acceleration_whole_deck",
                         "time_of_max_deck_acceleration_whole_deck",
                         "position_of_max_deck_acceleration_whole_deck"):
                data[name] = np.full(n_r, np.nan)
        failed = self.status != ek.OK
        if failed.any():
            for a in data.values():
                a[failed] = np.nan
        return data

    def comfort_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Comfort points of the reported car bodies: (body index, m ahead of the centre
        of gravity), one entry per point (see ``VehicleArrays.body_pt_*``)."""
        veh = self.packed.vehicles
        body = np.repeat(np.arange(veh.body_dof.size), np.diff(veh.body_pt_start))
        return body, veh.body_pt_d.copy()

    def comfort_point_histories(self, r: int) -> np.ndarray:
        """Car-body acceleration (m s-2, positive down) at every comfort point of run
        ``r`` (which must have a slot), shape (time, point of :meth:`comfort_points`):
        CG bounce + d x pitch acceleration."""
        h = int(self.slots[r])
        if h < 0:
            raise ValueError(f"run {r} kept no histories")
        n = int(self.n_steps[r]) + 1
        body, d = self.comfort_points()
        return self.out.body_acc[h, :n][:, body] + d * self.out.body_pitch[h, :n][:, body]

    def histories(self, r: int) -> dict[str, np.ndarray]:
        """Time histories of run ``r`` (which must have a slot): deck at the points,
        contact forces and flags of every wheel (moving forces included), car bodies."""
        h = int(self.slots[r])
        if h < 0:
            raise ValueError(f"run {r} kept no histories")
        pk = self.packed
        n = int(self.n_steps[r]) + 1
        q, qdd = self.out.q[h, :n], self.out.qdd[h, :n]
        disp = q @ self.phi_d.T
        keep = np.any(self.phi_a != 0.0, axis=0)
        acc = qdd[:, keep] @ self.phi_a[:, keep].T
        n_l = pk.load_positions.size
        X = np.concatenate([self.out.X[h, :n], np.broadcast_to(pk.vehicles.load_p, (n, n_l))],
                           axis=1)
        contact = np.concatenate([self.out.contact[h, :n], np.ones((n, n_l), np.int8)], axis=1)
        body = self.out.body_acc[h, :n].copy()
        if self.status[r] != ek.OK:
            for a in (disp, acc, X, body):
                a[...] = np.nan
        return {"deck_displacement": disp, "deck_acceleration": acc, "contact_force": X,
                "in_contact": contact, "carbody_acceleration": body}


def run_batch(packed: Packed, profile: Profile, speeds, points, settings: SolverSettings,
              bridge: ModalBridge, keep_histories=None, deck=None) -> BatchResult:
    """Run one packed model at several speeds (m/s) in one kernel call.

    Parameters
    ----------
    packed : Packed
        From :func:`pack` (any speed: only its speed-independent arrays are used).
    profile : Profile
        The irregularity the model was packed with (for the initial states).
    speeds : array_like
        Speeds (m/s), one run each.
    points : array_like
        Deck output points (m).
    keep_histories : array_like of bool, optional
        Per run: keep its raw histories (default: none).
    deck : tuple, optional
        ``deck_operators(bridge, points, settings)`` when already computed; a 3-tuple
        ``(phi_d, phi_a, cutoff)`` has no whole-deck grid (its envelopes are NaN).
    """
    speeds = np.ascontiguousarray(np.atleast_1d(np.asarray(speeds, float)))
    if np.any(~(speeds > 0)):
        raise ModelError(f"speed = {speeds[~(speeds > 0)][0]!r} m/s: expected > 0")
    n_r = speeds.size
    keep = np.zeros(n_r, bool) if keep_histories is None else np.asarray(keep_histories, bool)
    n_steps = np.array([packed.n_steps(v) for v in speeds], np.int64)
    deck = deck if deck is not None else deck_operators(bridge, points, settings)
    phi_d, phi_a, cutoff = deck[:3]
    grid_x, phi_g = (deck[3], deck[4]) if len(deck) > 3 else (np.zeros(0), np.zeros((0, 0)))
    grid_x = np.ascontiguousarray(grid_x, dtype=np.float64)
    phi_g = (np.ascontiguousarray(phi_g, dtype=np.float64) if grid_x.size
             else np.zeros((0, 0)))
    veh = packed.vehicles
    n_m, n_v, n_w = packed.bridge.omega.size, packed.n_dof, veh.wheel_dof.size
    n_b = veh.body_dof.size
    n_p = phi_d.shape[0]
    slots = np.full(n_r, -1, np.int64)
    slots[keep] = np.arange(int(keep.sum()))
    n_t = int(n_steps[keep].max()) + 1 if keep.any() else 0
    out = _history_buffers(int(keep.sum()), n_t, n_m, n_w, n_b)
    z = np.zeros
    red = ek.Reduce(
        phi_d=phi_d, phi_a=phi_a,
        disp=z((n_r, n_p)), disp_t=z((n_r, n_p)), acc=z((n_r, n_p)), acc_t=z((n_r, n_p)),
        xmin=z((n_r, n_w)), xmin_x=z((n_r, n_w)), xmax=z((n_r, n_w)),
        body=z((n_r, n_b)), body_t=z((n_r, n_b)), body_x=z((n_r, n_b)),
        lost=z((n_r, n_w), np.int64), longest=z((n_r, n_w), np.int64),
        events=z((n_r, n_w), np.int64), single=z((n_r, n_w), np.int64),
        run_len=z(n_w, np.int64), iters=z(n_r, np.int64),
        phi_g=phi_g, phi_gmax=np.abs(phi_g).max(axis=1, initial=0.0) * (1.0 + 1e-12),
        gacc=z(n_r), gacc_t=z(n_r), gacc_i=z(n_r, np.int64),
        gwork=z(grid_x.size),
    )
    init = initial_states(packed, profile, speeds)
    st = ek.State(*(np.empty_like(a[0]) for a in init))
    bk = ek.State(*(np.empty_like(a[0]) for a in init))
    wk = _workspace(n_m, n_v, n_w)
    status = np.zeros(n_r, np.int64)
    reached = np.zeros(n_r, np.int64)
    t0 = _time.perf_counter()
    ek.run_batch(packed.bridge, veh, packed.profile, packed.params, speeds, n_steps, init,
                 st, bk, wk, red, out, slots, status, reached)
    elapsed = _time.perf_counter() - t0
    _flag_non_finite(status, reached, n_steps, slots, red, out)
    return BatchResult(packed, speeds, n_steps, status, reached, slots, red, out, phi_d,
                       phi_a, cutoff, elapsed, np.asarray(grid_x, float))


#: Largest magnitude a result may have: histories are stored as float32.
_STORABLE = float(np.finfo(np.float32).max)


def _flag_non_finite(status, reached, n_steps, slots, red, out) -> None:
    """Flag ``non_finite_state`` for the runs the kernel passed as ok whose envelopes or
    histories are not finite or beyond the float32 range of the results file (the
    kernel's check covers the state, not the outputs derived from it, e.g. the deck
    response to a 1e300 N force)."""
    envelopes = (red.disp, red.acc, red.xmin, red.xmax, red.body)
    for r in np.flatnonzero(status == ek.OK):
        bad = any(not np.all(np.abs(a[r]) <= _STORABLE) for a in envelopes)
        step = int(n_steps[r])
        h = int(slots[r])
        if h >= 0:
            n = step + 1
            rows = np.zeros(n, bool)
            for a in (out.q, out.qdd, out.X, out.body_acc):
                v = a[h, :n].reshape(n, -1)
                rows |= ~np.all(np.abs(v) <= _STORABLE, axis=1)
            if rows.any():
                bad, step = True, int(np.argmax(rows))
        if bad:
            status[r] = ek.NON_FINITE
            reached[r] = step


def run_kernel(packed: Packed, profile: Profile):
    """Run the time loop at the packed speed, keeping the raw histories.

    Returns (status, step reached, Output of that one run, elapsed seconds).
    """
    bridge_points = np.zeros((0, packed.bridge.omega.size))
    res = _run_packed(packed, profile, bridge_points)
    out = ek.Output(*(a[0] for a in res.out))
    return int(res.status[0]), int(res.reached[0]), out, res.elapsed


def _run_packed(packed, profile, phi):
    """One run with histories and given deck operators (no bridge object needed)."""
    return run_batch(packed, profile, [packed.params.speed], np.zeros(0),
                     SolverSettings(dt=packed.params.dt), None, keep_histories=[True],
                     deck=(phi, phi, float("nan")))


def simulate(
    bridge: ModalBridge,
    train: Train,
    speed: float,
    profile: Profile | None = None,
    settings: SolverSettings | None = None,
    output_points=None,
    save_histories: bool = True,
) -> xr.Dataset:
    """Run one train at one speed (m/s) over the bridge.

    Parameters
    ----------
    bridge : ModalBridge
    train : Train
    speed : float
        Train speed (m/s).
    profile : Profile, optional
        Vertical track irregularity (default: smooth track).
    settings : SolverSettings, optional
    output_points : array_like, optional
        Abscissae (m) of the deck output points; default: mid-span of every span.
    save_histories : bool
        Keep the time histories (else envelopes only).

    Returns
    -------
    xarray.Dataset
        Histories and envelopes named as in ``vsi_numba.io.schema``; ``attrs["status"]``
        is 0 when the analysis succeeded, otherwise the outputs are NaN and
        ``attrs["message"]`` says why.

    Notes
    -----
    Direct method of Neves et al., Eng. Struct. 69 (2014) 83-89, Eq. (3): HHT-alpha on
    the coupled system with the contact forces as unknowns of a Schur system.  This is
    the batch kernel (:func:`run_batch`) restricted to one run.
    """
    settings = settings or SolverSettings()
    profile = profile if profile is not None else no_irregularity()
    points = default_points(bridge, output_points)
    packed = pack(bridge, train, speed, profile, settings)
    res = run_batch(packed, profile, [speed], points, settings, bridge,
                    keep_histories=[save_histories])
    return to_dataset(bridge, train, res, profile, settings, points, save_histories)


def default_points(bridge: ModalBridge, output_points=None) -> np.ndarray:
    """Deck output points (m): the given ones, else the mid-span of every span."""
    if output_points is None:
        s = np.asarray(bridge.supports, float)
        output_points = 0.5 * (s[:-1] + s[1:])
    return np.atleast_1d(np.asarray(output_points, float))


def to_dataset(bridge, train, res: BatchResult, profile, settings, points,
               save_histories, r: int = 0) -> xr.Dataset:
    """Histories and envelopes of run ``r`` of a batch as a Dataset (schema names and
    attrs)."""
    import xarray as xr

    from vsi_numba.io.schema import ENVELOPES, HISTORIES

    packed = res.packed
    dt = settings.dt
    status = int(res.status[r])
    wheel_pos = res.wheel_positions
    Q0 = res.static_loads
    n_body = packed.vehicles.body_dof.size
    coords = {
        "point": ("point", points, attrs_for("point")),
        "wheel": ("wheel", np.arange(wheel_pos.size), attrs_for("wheel")),
        "vehicle": ("vehicle", np.arange(n_body), attrs_for("vehicle")),
        "wheel_position": ("wheel", wheel_pos, attrs_for("wheel_position")),
        "static_wheel_load": ("wheel", Q0, attrs_for("static_wheel_load")),
    }
    variables = {
        "vehicle_name": ("vehicle", np.array(packed.vehicle_names, dtype=str),
                         attrs_for("vehicle_name")),
    }
    for name, val in res.envelopes().items():
        variables[name] = (ENVELOPES[name][0], np.asarray(val[r], float), attrs_for(name))
    if save_histories:
        n = int(res.n_steps[r]) + 1
        coords["time"] = ("time", np.arange(n) * dt, attrs_for("time"))
        for name, val in res.histories(r).items():
            variables[name] = (HISTORIES[name][0], val, attrs_for(name))
    variables["status"] = ((), np.int32(status), attrs_for("status"))
    variables["max_iterations"] = ((), np.int32(res.red.iters[r]),
                                   attrs_for("max_iterations"))
    # one constructor call: assigning variables one by one re-aligns the whole
    # dataset each time and cost more than the time loop of a short run
    ds = xr.Dataset(variables, coords=coords)
    ds.attrs.update(
        status=status,
        message=res.message(r),
        speed=float(res.speeds[r]),
        speed_kmh=float(res.speeds[r] * 3.6),
        train=train.name,
        train_status=train.status,
        dt=float(dt),
        hht_alpha=float(settings.hht_alpha),
        acceleration_cutoff_hz=float(res.cutoff),
        n_steps=int(res.n_steps[r]),
        kernel_seconds=float(res.elapsed),
        profile=profile.label,
        bridge_description=bridge.description,
    )
    return ds


def static_deck_envelope(bridge: ModalBridge, train: Train, output_points, step: float = 0.05
                         ) -> np.ndarray:
    """Maximum static deck displacement (m) at each output point as the train's static
    axle loads pass at crawling speed: sum_j phi_j(x_p) phi_j(x_k) Q_k / w_j^2.

    Uses the same modes as the dynamic analysis, so phi'_dyn compares like with like.
    """
    points = np.atleast_1d(np.asarray(output_points, float))
    if bridge.n_modes == 0:
        return np.zeros(points.size)
    settings = SolverSettings(dt=1e-3, approach=0.0)
    packed = pack(bridge, train, 1.0, None, settings)
    Q = np.concatenate([static_wheel_loads(packed), packed.vehicles.load_p])
    pos = np.concatenate([packed.wheel_positions, packed.load_positions])
    fronts = np.arange(0.0, bridge.length + pos.max() + step, step)
    x = fronts[:, None] - pos[None, :]
    phi_k = bridge.shapes(x.ravel()).reshape(x.shape + (bridge.n_modes,))
    modal = np.einsum("fkj,k->fj", phi_k, Q) / bridge.omega**2
    w = modal @ bridge.output_shapes(points).T
    return np.max(np.abs(w), axis=0)


def warm_up() -> float:
    """Compile (or load from cache) the kernels; returns the seconds it took."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh

    t0 = _time.perf_counter()
    beam = br.simply_supported(10.0, 1e9, 1e4, n_modes=2)
    train = Train("warm-up", (vh.sprung_mass(1e3, 1e6, 1e3, 100.0),), (0.0,))
    simulate(beam, train, 50.0, settings=SolverSettings(dt=5e-3, approach=0.0,
                                                        free_vibration=0.0),
             save_histories=False)
    return _time.perf_counter() - t0
