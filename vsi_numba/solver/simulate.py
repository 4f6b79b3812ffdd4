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

import numpy as np
import xarray as xr

from vsi_numba.io.schema import attrs_for
from vsi_numba.kernels import engine as ek
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.settings import CONTACT_MODELS, SolverSettings

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
        kh = _effective_stiffness(v.M, v.C, v.K, settings.dt / 2**lev, settings.hht_alpha)
        if np.linalg.cond(kh) > 1e13:
            raise ModelError(
                f"vehicle {v.name!r}: singular effective stiffness (a DOF with neither "
                "mass nor stiffness?)"
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
        for d in v.body_dofs:
            body.append(start[b] + d)
            body_names.append(v.name if len(v.body_dofs) == 1 else f"{v.name}:{v.dof_names[d]}")
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
    t_exit = (bridge.length + settings.approach + last) / speed
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
        vehicle_names=body_names,
    )


def _dense(veh: ek.VehicleArrays, A: np.ndarray) -> np.ndarray:
    n = int(veh.start[-1])
    out = np.zeros((n, n))
    for b in range(veh.start.size - 1):
        s, e = veh.start[b], veh.start[b + 1]
        out[s:e, s:e] = A[b, : e - s, : e - s]
    return out


def _kkt(A, G, rhs_top, rhs_bottom):
    """Solve [A G^T; G 0] [x; y] = [rhs_top; rhs_bottom].

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
    veh = packed.vehicles
    n_m = packed.bridge.omega.size
    n_v = packed.n_dof
    n_w = veh.wheel_dof.size
    v = packed.params.speed
    x0 = veh.wheel_x0
    G = np.zeros((n_w, n_v))
    G[np.arange(n_w), veh.wheel_dof] = 1.0
    Kd, Md, Cd = _dense(veh, veh.K), _dense(veh, veh.M), _dense(veh, veh.C)
    if np.any(x0 > 0.0):
        raise ModelError("every axle must start on the approach track (x <= 0)")
    r0, r1, r2 = profile(x0), profile(x0, 1), profile(x0, 2)
    u, X = _kkt(Kd, G, veh.gravity, r0) if n_v else (np.zeros(0), np.zeros(0))
    prm = packed.params
    if n_v and prm.contact_model != 0:
        # compliant contact: the wheels sit delta(X) below the rail top; the static
        # forces of an indeterminate vehicle depend on delta, so iterate
        for _ in range(50):
            if prm.contact_model == 1:
                delta = prm.hertz_g * np.cbrt(np.clip(X, 0.0, None)) ** 2
            else:
                delta = veh.wheel_compliance * X
            u, X_new = _kkt(Kd, G, veh.gravity, r0 + delta)
            done = np.max(np.abs(X_new - X)) <= 1e-9 * max(np.max(np.abs(X)), 1.0)
            X = X_new
            if done:
                break
    ud, _ = _kkt(Md, G, np.zeros(n_v), v * r1) if n_v else (np.zeros(0), None)
    if n_v:
        udd, X = _kkt(Md, G, veh.gravity - Cd @ ud - Kd @ u, v * v * r2)
    else:
        udd, X = np.zeros(0), np.zeros(0)
    fv = veh.gravity.copy()
    np.subtract.at(fv, veh.wheel_dof, X)
    fq = np.zeros(n_m)
    st = ek.State(
        q=np.zeros(n_m), qd=np.zeros(n_m), qdd=np.zeros(n_m),
        u=np.ascontiguousarray(u), ud=np.ascontiguousarray(ud),
        udd=np.ascontiguousarray(udd),
        fq_tot=fq, fv_tot=fv, X=np.ascontiguousarray(X),
    )
    return st


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
    )


def run_kernel(packed: Packed, profile: Profile):
    """Run the time loop; returns (status, step reached, Output, elapsed seconds)."""
    st = initial_state(packed, profile)
    n_m = packed.bridge.omega.size
    n_v = packed.n_dof
    n_w = packed.vehicles.wheel_dof.size
    n = packed.params.n_steps + 1
    bk = ek.State(*(np.empty_like(a) for a in st))
    wk = _workspace(n_m, n_v, n_w)
    out = ek.Output(
        q=np.full((n, n_m), np.nan), qdd=np.full((n, n_m), np.nan),
        X=np.full((n, n_w), np.nan), contact=np.zeros((n, n_w), np.int8),
        body_acc=np.full((n, packed.vehicles.body_dof.size), np.nan),
        iters=np.zeros(n, np.int16),
    )
    t0 = _time.perf_counter()
    status, reached = ek.time_loop(
        packed.bridge, packed.vehicles, packed.profile, packed.params, st, bk, wk, out
    )
    return int(status), int(reached), out, _time.perf_counter() - t0


def _wheel_positions_in_time(packed: Packed, time: np.ndarray) -> np.ndarray:
    x0 = np.concatenate([packed.vehicles.wheel_x0, packed.vehicles.load_x0])
    return x0[None, :] + packed.params.speed * time[:, None]


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
    the coupled system with the contact forces as unknowns of a Schur system.
    """
    settings = settings or SolverSettings()
    profile = profile if profile is not None else no_irregularity()
    if output_points is None:
        s = np.asarray(bridge.supports, float)
        output_points = 0.5 * (s[:-1] + s[1:])
    points = np.atleast_1d(np.asarray(output_points, float))
    packed = pack(bridge, train, speed, profile, settings)
    status, reached, out, elapsed = run_kernel(packed, profile)
    return to_dataset(bridge, train, packed, profile, settings, points, status, reached, out,
                      elapsed, save_histories)


def to_dataset(bridge, train, packed, profile, settings, points, status, reached, out,
               elapsed, save_histories) -> xr.Dataset:
    """Histories and envelopes of one run as a Dataset (schema names and attrs)."""
    dt = settings.dt
    n = packed.params.n_steps + 1
    time = np.arange(n) * dt
    phi_p = bridge.output_shapes(points)  # the deck line (not the rail of a track layer)
    cutoff = settings.acceleration_cutoff
    if cutoff is None:
        cutoff = acceleration_cutoff(bridge.frequencies)
    keep = bridge.frequencies <= cutoff + 1e-9
    disp = out.q @ phi_p.T
    acc = out.qdd[:, keep] @ phi_p[:, keep].T
    n_lw = packed.load_positions.size
    X = np.concatenate([out.X, np.broadcast_to(packed.vehicles.load_p, (n, n_lw))], axis=1)
    contact = np.concatenate([out.contact, np.ones((n, n_lw), np.int8)], axis=1)
    Q0 = np.concatenate([static_wheel_loads(packed), packed.vehicles.load_p])
    wheel_pos = np.concatenate([packed.wheel_positions, packed.load_positions])
    body_acc = out.body_acc
    if status != ek.OK:
        for a in (disp, acc, X, body_acc):
            a[...] = np.nan
    xw = _wheel_positions_in_time(packed, time)

    def _argmax_time(a):
        if a.shape[1] == 0 or not np.all(np.isfinite(a)):
            return np.full(a.shape[1], np.nan)
        return time[np.argmax(np.abs(a), axis=0)]

    with np.errstate(invalid="ignore", divide="ignore"):
        unloading = (Q0[None, :] - X) / Q0[None, :]
    absmax = lambda a: np.max(np.abs(a), axis=0) if a.shape[0] else np.zeros(a.shape[1])  # noqa: E731
    if X.shape[1] and np.all(np.isfinite(X)):
        imin = np.argmin(X, axis=0)
        pos_min = xw[imin, np.arange(X.shape[1])]
    else:
        pos_min = np.full(X.shape[1], np.nan)
    data = {
        "max_deck_displacement": absmax(disp),
        "max_deck_acceleration": absmax(acc),
        "min_contact_force": X.min(axis=0),
        "max_contact_force": X.max(axis=0),
        "max_wheel_unloading": unloading.max(axis=0),
        "max_carbody_acceleration": absmax(body_acc),
        "contact_loss_duration": (contact[:reached + 1] == 0).sum(axis=0) * dt,
        "time_of_max_deck_displacement": _argmax_time(disp),
        "time_of_max_deck_acceleration": _argmax_time(acc),
        "position_of_min_contact_force": pos_min,
        "time_of_max_carbody_acceleration": _argmax_time(body_acc),
    }
    if status != ek.OK:
        for k in data:
            data[k] = np.full_like(np.asarray(data[k], float), np.nan)
    from vsi_numba.io.schema import ENVELOPES, HISTORIES

    coords = {
        "point": ("point", points, attrs_for("point")),
        "wheel": ("wheel", np.arange(wheel_pos.size), attrs_for("wheel")),
        "vehicle": ("vehicle", np.arange(body_acc.shape[1]), attrs_for("vehicle")),
        "wheel_position": ("wheel", wheel_pos, attrs_for("wheel_position")),
        "static_wheel_load": ("wheel", Q0, attrs_for("static_wheel_load")),
    }
    variables = {
        "vehicle_name": ("vehicle", np.array(packed.vehicle_names, dtype=str),
                         {"long_name": "vehicle name", "units": "1"}),
    }
    for name, val in data.items():
        variables[name] = (ENVELOPES[name][0], np.asarray(val, float), attrs_for(name))
    if save_histories:
        coords["time"] = ("time", time, attrs_for("time"))
        hist = {
            "deck_displacement": disp,
            "deck_acceleration": acc,
            "contact_force": X,
            "in_contact": contact,
            "carbody_acceleration": body_acc,
        }
        for name, val in hist.items():
            variables[name] = (HISTORIES[name][0], val, attrs_for(name))
    variables["status"] = ((), np.int32(status), attrs_for("status"))
    variables["max_iterations"] = ((), np.int32(np.abs(out.iters).max(initial=0)),
                                   attrs_for("max_iterations"))
    # one constructor call: assigning variables one by one re-aligns the whole
    # dataset each time and cost more than the time loop of a short run
    ds = xr.Dataset(variables, coords=coords)
    message = STATUS_MESSAGES[status]
    if status != ek.OK:
        message += f" at t = {reached * dt:.6g} s (step {reached})"
    ds.attrs.update(
        status=int(status),
        message=message,
        speed=float(packed.params.speed),
        speed_kmh=float(packed.params.speed * 3.6),
        train=train.name,
        train_status=train.status,
        dt=float(dt),
        hht_alpha=float(settings.hht_alpha),
        acceleration_cutoff_hz=float(cutoff),
        n_steps=int(packed.params.n_steps),
        kernel_seconds=float(elapsed),
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
