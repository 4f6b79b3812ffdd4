"""Trains and vehicles built from the library's specs: HSLM-A moving forces, railway cars,
articulated vehicles with shared (Jacobs) bogies, interaction and moving-force trains."""

from __future__ import annotations

import difflib
from collections.abc import Mapping

import numpy as np

from vsi_numba.model.library.data import (
    _STATUS_RANK,
    MODELS,
    HslmSpec,
    TrainSpec,
    UnknownTrainError,
    VehicleSpec,
    _all_vehicles,
    _lib,
    _spec,
)
from vsi_numba.model.vehicle import (
    MultibodyBuilder,
    Train,
    Vehicle,
    point_loads,
    railway_car,
)

# -------------------------------------------------------------------------------- HSLM


def hslm_axle_positions(N: int, D: float, d: float, rule: Mapping | None = None) -> np.ndarray:
    """Axle positions (m from the first axle) of an HSLM-A train, EN 1991-2 rule.

    Parameters
    ----------
    N : int
        Number of intermediate coaches.
    D : float
        Coach length (m) = spacing of consecutive articulated bogie centres.
    d : float
        Axle spacing within a bogie (m).
    rule : mapping, optional
        ``[hslm.rule]`` of the data file (power-car axles, first end-coach axle, coupling
        point); default: the package file.

    Returns
    -------
    ndarray, shape (2 N + 14,)
        Ascending; the last is ``2 c0 + (N + 2) D = 37.525 + (N + 2) D``.  Rounded to
        1e-9 m so decimal data compare exactly.

    Notes
    -----
    Leading power car at 0, 3, 14, 17 m; end coach axles at 20.525 and 20.525 + d;
    articulated bogie centres at ``c0 + i D`` (i = 1 .. N+1, c0 = 18.7625 m) with axles at
    -/+ d/2; the trailing end coach and power car mirror the front about the centre.
    """
    rule = _lib().rule if rule is None else rule
    pc = np.asarray(rule["power_car_axles"], float)
    e = float(rule["end_coach_first_axle"])
    c0 = float(rule["coupling_point"])
    front = np.concatenate([pc, [e, e + d]])
    centres = c0 + D * np.arange(1, N + 2)
    middle = np.ravel(np.column_stack([centres - 0.5 * d, centres + 0.5 * d]))
    last = 2.0 * c0 + (N + 2) * D
    rear = last - front[::-1]
    return np.round(np.concatenate([front, middle, rear]), 9)


def _hslm_train(canon: str, h: HslmSpec) -> Train:
    pos = hslm_axle_positions(h.N, h.D, h.d)
    veh = point_loads(pos, h.P, name=canon, status="standard")
    return Train(canon, (veh,), (0.0,), status="standard", regular_length=h.D)


# ---------------------------------------------------------------------- real vehicles


def vehicle_ids() -> list[str]:
    """Return the ids of every vehicle entry (data file, then user files)."""
    return list(_all_vehicles())


def vehicle_spec(vehicle_id: str) -> VehicleSpec:
    """Return the parsed ``[[vehicle]]`` entry ``vehicle_id``."""
    vs = _all_vehicles()
    if vehicle_id not in vs:
        close = difflib.get_close_matches(vehicle_id, list(vs), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise UnknownTrainError(f"unknown vehicle {vehicle_id!r}{hint}")
    return vs[vehicle_id]


def get_vehicle(vehicle_id: str, name: str | None = None) -> Vehicle:
    """Build one vehicle entry as a 10-DOF :func:`railway_car` (``[whole]`` values)."""
    s = vehicle_spec(vehicle_id)
    over = ((s.front_overhang, s.rear_overhang)
            if s.front_overhang is not None and s.rear_overhang is not None else None)
    return railway_car(
        **s.whole, bogie_spacing=s.bogie_spacing, wheelbase=s.wheelbase,
        body_cg_to_front_bogie=s.cg_to_front_bogie, name=name or s.id, status=s.status,
        body_overhangs=over,
    )


def _worst_status(statuses) -> str:
    return max(statuses, key=lambda s: _STATUS_RANK.get(s, len(_STATUS_RANK)))


def articulated_vehicle(
    specs: list[VehicleSpec], offsets: list[float], name: str = "articulated"
) -> Vehicle:
    """One multibody vehicle for cars joined by articulated (Jacobs) bogies.

    Parameters
    ----------
    specs : list of VehicleSpec
        The cars, front to back (whole-vehicle values); equal wheelbases.
    offsets : list of float
        First-axle position of each car behind the first car's first axle (m); car
        ``j + 1`` starts at car ``j``'s rear bogie: ``offsets[j+1] = offsets[j] +
        bogie_spacing[j]``.
    name : str
        Vehicle name.

    Returns
    -------
    Vehicle
        DOFs: per car a body (bounce, pitch); per bogie position a bogie (bounce, pitch)
        and two wheelsets (bounce).  ``body_dof`` is the first car's body bounce.

    Notes
    -----
    Each coincident pair of half-bogies (rear of car j, front of car j+1) is one bogie
    with summed mass and pitch inertia, on wheelsets with summed masses and summed
    (parallel) primary stiffness and damping; both bodies' secondary suspensions attach
    at its centre.  See the module docstring for why.
    """
    n = len(specs)
    if n < 2:
        raise ValueError("articulated_vehicle needs at least two cars")
    wb = specs[0].wheelbase
    for j in range(n - 1):
        if abs(specs[j + 1].wheelbase - wb) > 1e-9:
            raise ValueError(f"{name}: articulated cars need equal wheelbases")
        if abs(offsets[j + 1] - offsets[j] - specs[j].bogie_spacing) > 1e-6:
            raise ValueError(f"{name}: car {j + 1} does not start at car {j}'s rear bogie")
    half = 0.5 * wb
    b = MultibodyBuilder(name)
    # bogie k sits at the front bogie of car k (k < n) or the rear bogie of the last car
    centres = [offsets[j] + half for j in range(n)] + [offsets[-1] + half + specs[-1].bogie_spacing]
    halves: list[list[VehicleSpec]] = [[] for _ in range(n + 1)]
    for j, s in enumerate(specs):
        halves[j].append(s)  # its front half-bogie
        halves[j + 1].append(s)  # its rear half-bogie
    for j, s in enumerate(specs):
        b.add_body(f"body{j + 1}", s.whole["body_mass"], centres[j] + s.cg_to_front_bogie,
                   s.whole["body_pitch_inertia"])
    for k, (pc, hs) in enumerate(zip(centres, halves, strict=True)):
        bogie = f"bogie{k + 1}"
        b.add_body(bogie, sum(h.whole["bogie_mass"] for h in hs), pc,
                   sum(h.whole["bogie_pitch_inertia"] for h in hs))
        kp = sum(h.whole["primary_stiffness"] for h in hs)
        cp = sum(h.whole["primary_damping"] for h in hs)
        for tag, pos in (("a", pc - half), ("b", pc + half)):
            wheel = f"wheelset{k + 1}{tag}"
            b.add_wheel(wheel, sum(h.whole["wheelset_mass"] for h in hs), pos)
            b.connect(bogie, wheel, pos, kp, cp)
    for j, s in enumerate(specs):
        for k in (j, j + 1):
            b.connect(f"body{j + 1}", f"bogie{k + 1}", centres[k],
                      s.whole["secondary_stiffness"], s.whole["secondary_damping"])
    return b.build(body=[f"body{j + 1}" for j in range(len(specs))],
                   status=_worst_status([s.status for s in specs]))


def static_axle_loads(vehicle: Vehicle) -> np.ndarray:
    """Compute the static wheel (axle) loads (N, down) of a vehicle on rigid level track.

    Parameters
    ----------
    vehicle : Vehicle
        A multibody vehicle, or point loads (returned as they are).

    Returns
    -------
    ndarray
        One load per wheel in ``vehicle.wheel_dofs`` order (ascending position), then
        the vehicle's point loads.

    Notes
    -----
    Wheels held at zero: ``K_ff u_f = g_f``, wheel load ``g_w - K_wf u_f`` (the rail's
    reaction with its sign reversed).
    """
    loads = vehicle.loads.copy()
    if vehicle.n_wheels == 0:
        return loads
    wheel = np.zeros(vehicle.n_dof, bool)
    wheel[vehicle.wheel_dofs] = True
    free = ~wheel
    g = vehicle.gravity
    K = vehicle.K
    u = np.zeros(vehicle.n_dof)
    if free.any():
        try:
            u[free] = np.linalg.solve(K[np.ix_(free, free)], g[free])
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"vehicle {vehicle.name!r} is not supported by its wheels") from exc
    r = g[vehicle.wheel_dofs] - K[vehicle.wheel_dofs] @ u
    return np.concatenate([r, loads])


def _vehicle_groups(spec: TrainSpec) -> list[list[int]]:
    groups = [[0]]
    for i, art in enumerate(spec.articulated):
        if art:
            groups[-1].append(i + 1)
        else:
            groups.append([i + 1])
    return groups


def _interaction_train(canon: str, spec: TrainSpec) -> Train:
    vs = _all_vehicles()
    vehicles, offsets = [], []
    for grp in _vehicle_groups(spec):
        o0 = spec.offsets[grp[0]]
        if len(grp) == 1:
            i = grp[0]
            vehicles.append(get_vehicle(spec.vehicles[i], name=f"{i + 1}:{spec.vehicles[i]}"))
        else:
            ids = [spec.vehicles[i] for i in grp]
            name = f"{grp[0] + 1}-{grp[-1] + 1}:{ids[0]}..{ids[-1]} (articulated)"
            vehicles.append(articulated_vehicle(
                [vs[v] for v in ids], [spec.offsets[i] - o0 for i in grp], name=name))
        offsets.append(o0)
    return Train(canon, tuple(vehicles), tuple(offsets), status=spec.status,
                 regular_length=spec.regular_length)


def moving_force_train(train: Train, name: str | None = None) -> Train:
    """Return the moving-force model of a train: each axle's static load as a point force.

    Point-load vehicles pass through unchanged; multibody vehicles become
    :func:`point_loads` at their wheel positions with :func:`static_axle_loads`.
    """
    vehicles, offsets = [], []
    for v, o in zip(train.vehicles, train.offsets, strict=True):
        if v.n_dof == 0:
            vehicles.append(v)
            offsets.append(o)
            continue
        loads = static_axle_loads(v)
        pos = np.concatenate([v.wheel_positions, v.load_positions])
        order = np.argsort(pos, kind="stable")
        # point_loads measures from its first load: shift the offset to keep positions
        vehicles.append(point_loads(pos[order], loads[order], name=v.name, status=v.status))
        offsets.append(o + float(pos.min()))
    return Train(name or train.name, tuple(vehicles), tuple(offsets), status=train.status,
                 regular_length=train.regular_length)


def get_train(name: str, model: str = "interaction") -> Train:
    """Build a library train.

    Parameters
    ----------
    name : str
        A name from :func:`list_presets` (case-insensitive), or a data-file train id.
    model : {"interaction", "moving_force"}
        Multibody vehicles for the interaction analysis, or moving point forces (static
        axle loads of the same multibody model).  HSLM trains exist only as moving forces.

    Returns
    -------
    Train
        ``Train.name`` is the canonical preset name; ``Train.status`` the data status
        (see :data:`STATUS_MEANING` and :func:`status_warning`).

    Raises
    ------
    UnknownTrainError
        (a ``KeyError`` and ``ValueError``) for an unknown name, with the closest names.
    ValueError
        For an unknown model, or ``model="interaction"`` with an HSLM train.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    canon, kind, spec = _spec(name)
    if kind == "hslm":
        if model != "moving_force":
            raise ValueError(
                f"{canon} is a load model (moving forces, no vehicle dynamics): use "
                "model='moving_force'"
            )
        return _hslm_train(canon, spec)
    train = _interaction_train(canon, spec)
    return train if model == "interaction" else moving_force_train(train)
