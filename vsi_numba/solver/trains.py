"""Several trains in one run: trains meeting on the tracks of a deck, or side by side.

Every wheel of every train and the deck are one contact problem and one Schur solve per
step (the direct method with any number of vehicles): :func:`pack_trains` stacks the
trains' blocks and the track lines' tables into one :class:`~vsi_numba.solver.pack.Packed`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile
from vsi_numba.model.vehicle import Train
from vsi_numba.solver import driver
from vsi_numba.solver.pack import ModelError, Packed, _pack_bridge, pack
from vsi_numba.solver.settings import SolverSettings


@dataclass(frozen=True)
class TrainOnTrack:
    """A train of a run with several trains (:func:`pack_trains`).

    Attributes
    ----------
    train : Train
    line : int
        Its track line: index into the ``lines`` of :func:`pack_trains`.
    direction : int
        +1: runs in +x (first axle ``settings.approach`` m before x = 0 at t = 0);
        -1: runs in -x (first axle ``settings.approach`` m beyond x = L).
    offset : float
        m further back than that start (it reaches the deck offset / v later).
    speed_factor : float
        Its speed / the run's speed (> 0).
    """

    train: Train
    line: int = 0
    direction: int = 1
    offset: float = 0.0
    speed_factor: float = 1.0


def _stack_lines(lines: list[ModalBridge], wheels: bool) -> ek.BridgeArrays:
    """The kernels' bridge with one block of table rows per track line (the lines of one
    deck: the same modes and nodes, the shapes of each line)."""
    packs = [_pack_bridge(b, wheels=wheels) for b in lines]
    first = packs[0]
    if len(packs) == 1:
        return first
    for k, (b, p) in enumerate(zip(lines, packs, strict=True)):
        same = (p.kind == first.kind and p.length == first.length
                and np.array_equal(p.omega, first.omega) and np.array_equal(p.zeta, first.zeta)
                and np.array_equal(p.nodes, first.nodes) and p.track == first.track
                and np.array_equal(p.t_nodes, first.t_nodes))
        if not same:
            raise ModelError(f"track line {k} ({b.description!r}): expected the modes, "
                             "nodes and track of line 0 (the lines of one deck)")
        if p.kind == 1 and not np.array_equal(p.sine_amp, first.sine_amp):
            raise ModelError(f"track line {k}: sine modes differ from line 0's (a deck "
                             "with torsion has tabulated track lines)")
    cat = lambda name: np.ascontiguousarray(  # noqa: E731
        np.concatenate([getattr(p, name) for p in packs]))
    fields = dict(values=cat("values"), slopes=cat("slopes"))
    if first.track:
        fields.update(t_values=cat("t_values"), t_slopes=cat("t_slopes"))
    return first._replace(**fields)


def _stack_profiles(profiles) -> ek.ProfileArrays:
    """The kernels' profile of one profile per track line (one grid)."""
    live = [p for p in profiles if p.coef.shape[0]]
    if not live:
        return ek.ProfileArrays(x0=0.0, dx=1.0, coef=np.zeros((0, 4)))
    x0, dx = float(live[0].x0), float(live[0].dx)
    n = max(p.coef.shape[0] for p in live)
    coef = np.zeros((len(profiles) * n, 4))
    for k, p in enumerate(profiles):
        m = p.coef.shape[0]
        if m and (float(p.x0) != x0 or float(p.dx) != dx):
            raise ModelError(f"profile of track line {k}: x0 = {p.x0}, dx = {p.dx}; "
                             f"expected the grid of the others (x0 = {x0}, dx = {dx})")
        coef[k * n:k * n + m] = np.asarray(p.coef, float).reshape(-1, 4)
    return ek.ProfileArrays(x0=x0, dx=dx, coef=coef, n_int=n)


def pack_trains(lines, trains, speed: float, profile, settings: SolverSettings) -> Packed:
    """Several trains in one run (trains meeting on the tracks of a deck, or side by side):
    every wheel and the deck in one contact problem and one Schur solve per step.

    Parameters
    ----------
    lines : sequence of ModalBridge
        The deck along each track line (e.g. ``BeamDeck3D.track_bridge(k)`` of each
        track ``k``): the same modes, each line's shapes.  The outputs are the deck's of
        ``lines[trains[0].line]``.
    trains : sequence of TrainOnTrack
        The trains; the first is the run's (speed factor 1, direction +1 keeps the
        single-train model bit for bit).
    speed : float
        The run's speed (m/s); train k runs at ``speed_factor`` times it.
    profile : Profile, or one per line
        Vertical irregularity of every line (one profile: the same on every line).
    settings : SolverSettings

    Notes
    -----
    Each train is packed on its own line as one train is (:func:`pack`), then the
    vehicles are appended (more blocks of the block-diagonal K^, the wheels of train
    k after those of train k - 1).  A train in -x is the mirror of its own packing:
    x0 -> L - x0 with the speed factor negated.  The rail's compliance couples the
    wheels of a train only (each track its own rail).  The run lasts until the last
    train has left the deck (plus ``settings.free_vibration``).
    """
    lines = list(lines)
    trains = list(trains)
    if not trains:
        raise ModelError("pack_trains: expected at least one train")
    if not speed > 0:
        raise ModelError(f"speed = {speed!r} m/s: expected > 0")
    for k, t in enumerate(trains):
        if not 0 <= int(t.line) < len(lines):
            raise ModelError(f"trains[{k}].line = {t.line!r}: expected 0 .. {len(lines) - 1}")
        if t.direction not in (1, -1):
            raise ModelError(f"trains[{k}].direction = {t.direction!r}: expected 1 or -1")
        if not (t.speed_factor > 0 and np.isfinite(t.speed_factor)):
            raise ModelError(f"trains[{k}].speed_factor = {t.speed_factor!r}: expected > 0")
        if not (t.offset >= 0 and np.isfinite(t.offset)):
            raise ModelError(f"trains[{k}].offset = {t.offset!r} m: expected >= 0")
    single = isinstance(profile, Profile) or profile is None
    one = profile if single else profile[0]
    parts = [pack(lines[t.line], t.train, speed, one if single else profile[t.line], settings)
             for t in trains]
    if len(parts) == 1 and trains[0] == TrainOnTrack(trains[0].train, trains[0].line):
        return parts[0]
    if not any(p.vehicles.wheel_dof.size for p in parts):
        # the moving-force kernel runs one train on line 0 in +x
        raise ModelError("pack_trains: moving-force trains on several tracks or in -x are "
                         "run one by one and superposed (vsi_numba.solver.superpose); "
                         "expected a train with vehicles that interact with the deck")
    length = float(lines[0].length)
    nb = max(int(p.vehicles.M.shape[1]) for p in parts)
    f64, i64 = np.float64, np.int64

    def merged(kind):  # the vehicles (kind 0) or the kernel's vehicles (1) of every train
        blocks = {n: [] for n in ("M", "C", "K", "M_inv")}
        kh, starts, acc = [], [0], {}
        dof0 = veh0 = 0
        pt0 = end0 = nl0 = 0
        for t, p in zip(trains, parts, strict=True):
            v = p.vehicles if kind == 0 else p.kernel_vehicles
            n_veh, n = v.M.shape[0], v.M.shape[1]
            pad = ((0, 0), (0, nb - n), (0, nb - n))
            for name in blocks:
                blocks[name].append(np.pad(getattr(v, name), pad))
            kh.append(np.pad(v.Khat_inv, ((0, 0),) + pad))
            starts.extend(dof0 + v.start[1:])
            sgn = float(t.direction)
            x0 = v.wheel_x0 - t.offset
            l0 = v.load_x0 - t.offset
            if sgn < 0:
                x0, l0 = length - x0, length - l0
            rows = dict(
                gravity=v.gravity, wheel_dof=v.wheel_dof + dof0,
                wheel_veh=v.wheel_veh + veh0, wheel_x0=x0,
                wheel_massless=v.wheel_massless,
                body_dof=np.where(v.body_dof >= 0, v.body_dof + dof0, -1),
                load_x0=l0, load_p=v.load_p,
                body_pt_start=v.body_pt_start[1:] + pt0,
                body_pt_pitch=np.where(v.body_pt_pitch >= 0, v.body_pt_pitch + dof0, -1),
                body_pt_d=v.body_pt_d * 1.0,
                body_end_start=v.body_end_start[1:] + end0,
                body_end_pitch=np.where(v.body_end_pitch >= 0, v.body_end_pitch + dof0, -1),
                body_end_d=v.body_end_d * 1.0,
                nl_veh=v.nl_veh + veh0, nl_start=v.nl_start[1:] + nl0, nl_kind=v.nl_kind,
                nl_a=np.pad(v.nl_a, ((0, 0), (0, nb - v.nl_a.shape[1]))) if v.nl_a.size
                else np.zeros((0, nb)), nl_p=v.nl_p,
                wheel_sf=sgn * t.speed_factor * v.wheel_sf,
                wheel_line=np.full(v.wheel_dof.size, t.line, i64),
                load_sf=sgn * t.speed_factor * v.load_sf,
                load_line=np.full(v.load_x0.size, t.line, i64),
                track_z0=v.track_z0)
            for name, a in rows.items():
                acc.setdefault(name, []).append(np.asarray(a))
            dof0 += int(v.start[-1])
            veh0 += n_veh
            pt0 += int(v.body_pt_start[-1])
            end0 += int(v.body_end_start[-1])
            nl0 += int(v.nl_start[-1])
        cat = {n: np.ascontiguousarray(np.concatenate(a)) for n, a in acc.items()}
        for name in ("body_pt_start", "body_end_start", "nl_start"):
            cat[name] = np.concatenate([[0], cat[name]]).astype(i64)
        cat["nl_a"] = np.ascontiguousarray(cat["nl_a"].reshape(-1, nb), f64)
        cat["nl_p"] = np.ascontiguousarray(cat["nl_p"].reshape(-1, 3), f64)
        n_w = cat["wheel_dof"].size
        comp = np.zeros((0, 0))
        if any(p.vehicles.compliance.size for p in parts):  # each train its own rail
            comp = np.zeros((n_w, n_w))
            w0 = 0
            for p in parts:
                c, m = p.vehicles.compliance, p.vehicles.wheel_dof.size
                if c.size:
                    comp[w0:w0 + m, w0:w0 + m] = c
                w0 += m
        v0 = parts[0].vehicles
        veh = v0._replace(
            start=np.asarray(starts, i64),
            **{n: np.ascontiguousarray(np.concatenate(b), f64) for n, b in blocks.items()},
            Khat_inv=np.ascontiguousarray(np.concatenate(kh, axis=1), f64),
            compliance=comp, **cat)
        if not veh.track_z0.size:
            veh = veh._replace(track_z0=np.zeros(0))
        return driver.with_patterns(veh)

    veh = merged(0)
    distributed = None
    if any(p.distributed is not None for p in parts):
        # the static state's track elements (set in place by initial_states) shared
        distributed = merged(1)._replace(track_z0=veh.track_z0)
    # the run lasts until the slowest train (at its own speed) has left the deck
    run_length = max((p.run_length + t.offset) / t.speed_factor
                     for t, p in zip(trains, parts, strict=True))
    n_steps = int(math.ceil((run_length / speed + settings.free_vibration) / settings.dt
                            - 1e-9))
    wheel_load = max(float(np.max(np.abs(veh.gravity), initial=0.0)), 1.0)
    params = parts[0].params._replace(n_steps=n_steps, tol_force=1e-9 * wheel_load)
    prof = parts[0].profile if single else _stack_profiles(list(profile))
    names = []
    for k, p in enumerate(parts):
        names.extend(p.vehicle_names if k == 0 else [f"train {k + 1}: {n}"
                                                     for n in p.vehicle_names])
    return Packed(
        bridge=_stack_lines(lines, wheels=veh.wheel_dof.size > 0),
        vehicles=veh, profile=prof, params=params, n_dof=int(veh.start[-1]),
        wheel_positions=np.concatenate([p.wheel_positions + t.offset
                                        for t, p in zip(trains, parts, strict=True)]),
        load_positions=np.concatenate([p.load_positions + t.offset
                                       for t, p in zip(trains, parts, strict=True)]),
        vehicle_names=names, run_length=float(run_length),
        free_vibration=float(settings.free_vibration),
        static_loads=np.concatenate([p.static_loads for p in parts]),
        distributed=distributed)


# -------------------------------------------------------------------------- load effects
