"""The train library: EN 1991-2 HSLM-A load models and published multibody trains.

Data come from the package file ``vsi_numba/data/trains.toml`` (provenance, checks and
doubts of every entry: ``notes/trains.md``).  All values are SI (m, kg, N); axle loads
are whole-axle loads (both rails), the convention of the file's ``[whole]`` blocks.

Two models of each real train
-----------------------------
``model="interaction"``
    Multibody vehicles (:func:`~vsi_numba.model.vehicle.railway_car`, 10 DOFs) from the
    ``[whole]`` values, placed at the train's ``vehicle_offsets``.  Coupled junctions are
    separate vehicles.  A run of cars joined by articulated junctions (coincident bogie
    centres, the Eurostar trailers) is ONE vehicle with shared (Jacobs) bogies, see
    :func:`articulated_vehicle`.
``model="moving_force"``
    The static axle loads of that multibody model on rigid level track, as moving point
    forces at the same positions (equal to the file's check values).

HSLM-A1 .. A10 exist as moving forces only (they are load models, not vehicles).

Articulation (open question in notes/trains.md section 6, item 8)
------------------------------------------------------------------
The data describe a Jacobs bogie TTB-2D style: each of the two cars brings its own
half-bogie with two wheelsets, placed at the same point.  Here each coincident pair
becomes ONE bogie whose mass and pitch inertia are the sums of the two half-bogies', on
two wheelsets whose masses are the sums of the two coincident wheelsets', joined by the
two primary suspensions in parallel (stiffness and damping summed).  Both car bodies'
secondary springs attach to it at its centre.  This is exactly the TTB-2D model with the
coincident half-bogies and wheelsets tied together, so total mass and static axle loads
equal the file's merged check values.  It keeps the possibly doubled unsprung mass
(2 x 1900 kg per axle position) of the data; whether Domenech's masses are per car or
per physical component is not known.
"""

from __future__ import annotations

import difflib
import tomllib
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vsi_numba.model.vehicle import (
    MultibodyBuilder,
    Train,
    Vehicle,
    point_loads,
    railway_car,
)

if TYPE_CHECKING:
    import pandas

MODELS = ("interaction", "moving_force")

WHOLE_KEYS = (
    "body_mass",
    "body_pitch_inertia",
    "bogie_mass",
    "bogie_pitch_inertia",
    "wheelset_mass",
    "primary_stiffness",
    "primary_damping",
    "secondary_stiffness",
    "secondary_damping",
)
"""Keys of a vehicle's ``[whole]`` block used to build it (SI units)."""

STATUS_MEANING = {
    "standard": "normative load model (EN 1991-2), no vehicle dynamics",
    "cross-checked": "vertical-model values confirmed by an independent transcription",
    "transcribed": "values as coded in TTB-2D with its citation; primary source not read",
    "secondary": "only a third-party transcription of the cited source was available",
    "reconstruction": (
        "derived from a transcribed entry to remove a documented inconsistency; the "
        "reconstruction itself is not from a source"
    ),
    "suspect": "transcribed, but with documented inconsistencies",
    "user": "defined in a user train file",
}
"""One line per data status (``Train.status``)."""

_WARN_STATUSES = ("suspect", "reconstruction", "secondary")
_STATUS_RANK = {s: i for i, s in enumerate(STATUS_MEANING)}  # later = less reliable
_STATUS_RANK["user"] = -1

ALIASES = {"ICE3": "ave_s103_8car", "Eurostar": "eurostar_halfset_reconstructed"}
"""Preset names that stand for a train entry of the data file."""


class UnknownTrainError(KeyError, ValueError):
    """No train of that name; the message suggests the closest names."""

    def __str__(self) -> str:
        """Return the message without KeyError's quotes."""
        return str(self.args[0]) if self.args else ""


# --------------------------------------------------------------------------- data specs


@dataclass(frozen=True)
class VehicleSpec:
    """One ``[[vehicle]]`` entry (whole-vehicle values, SI units).

    Geometry: ``bogie_spacing`` between bogie centres, ``wheelbase`` within a bogie,
    ``cg_to_front_bogie`` from the front bogie centre to the body's centre of gravity,
    overhangs from the outer bogie centres to the vehicle ends (None if not given).
    """

    id: str
    name: str
    status: str
    whole: dict[str, float]
    bogie_spacing: float
    wheelbase: float
    cg_to_front_bogie: float
    front_overhang: float | None = None
    rear_overhang: float | None = None
    doubts: tuple[str, ...] = ()
    check: dict[str, Any] = field(default_factory=dict)
    origin: str = "library"


@dataclass(frozen=True)
class TrainSpec:
    """One ``[[train]]`` entry: vehicle ids, first-axle offsets (m) and junction kinds."""

    id: str
    name: str
    status: str
    vehicles: tuple[str, ...]
    offsets: tuple[float, ...]
    articulated: tuple[bool, ...]  # junction i joins vehicles i and i+1
    doubts: tuple[str, ...] = ()
    check: dict[str, Any] = field(default_factory=dict)
    origin: str = "library"

    @property
    def regular_length(self) -> float:
        """Most frequent vehicle pitch (m) if it repeats, else 0 (no regular spacing)."""
        if len(self.offsets) < 3:
            return 0.0
        steps = np.diff(self.offsets)
        pitches = Counter(round(float(s), 6) for s in steps)
        value, count = pitches.most_common(1)[0]
        return float(value) if count >= 2 else 0.0


@dataclass(frozen=True)
class HslmSpec:
    """One HSLM-A train.

    ``N`` intermediate coaches, coach length ``D`` (m), bogie axle spacing ``d`` (m),
    axle force ``P`` (N, whole axle).
    """

    name: str
    N: int
    D: float
    d: float
    P: float


@dataclass
class _Library:
    vehicles: dict[str, VehicleSpec]
    trains: dict[str, TrainSpec]
    hslm: dict[str, HslmSpec]
    rule: dict[str, Any]
    hslm_checks: dict[str, Any]


# ------------------------------------------------------------------------------ parsing


class _Where:
    """Error context: file name and key path."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, msg: str):
        raise ValueError(f"{self.source}: {path}: {msg}")

    def number(self, d: Mapping, path: str, key: str, positive=False, nonneg=False, default=...):
        if key not in d:
            if default is not ...:
                return default
            self.fail(f"{path}.{key}", "missing (a number is expected)")
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            self.fail(f"{path}.{key}", f"{v!r} is not a finite number")
        if positive and not v > 0:
            self.fail(f"{path}.{key}", f"{v!r} must be > 0")
        if nonneg and not v >= 0:
            self.fail(f"{path}.{key}", f"{v!r} must be >= 0")
        return float(v)


def _parse_vehicle(w: _Where, d: Any, path: str, origin: str) -> VehicleSpec:
    if not isinstance(d, Mapping):
        w.fail(path, "a table [[vehicle]] is expected")
    vid = d.get("id")
    if not isinstance(vid, str) or not vid.strip():
        w.fail(f"{path}.id", f"{vid!r}: a non-empty string id is expected")
    whole_d = d.get("whole")
    if not isinstance(whole_d, Mapping):
        w.fail(f"{path}.whole", "missing table [vehicle.whole] (whole-vehicle values)")
    whole = {}
    for k in WHOLE_KEYS:
        positive = k.endswith(("mass", "inertia")) or k.endswith("stiffness")
        whole[k] = w.number(whole_d, f"{path}.whole", k, positive=positive, nonneg=True)
    spacing = w.number(d, path, "bogie_spacing", positive=True)
    wheelbase = w.number(d, path, "wheelbase", positive=True)
    if not spacing > wheelbase:
        w.fail(f"{path}.bogie_spacing", f"{spacing!r} must exceed the wheelbase {wheelbase!r}")
    cg = w.number(d, path, "body_cg_to_front_bogie", nonneg=True, default=0.5 * spacing)
    if cg > spacing:
        w.fail(f"{path}.body_cg_to_front_bogie", f"{cg!r} must be <= bogie_spacing {spacing!r}")
    if "body_cg_to_rear_bogie" in d:
        rear = w.number(d, path, "body_cg_to_rear_bogie", nonneg=True)
        if abs(cg + rear - spacing) > 1e-6:
            w.fail(path, f"body_cg_to_front_bogie + body_cg_to_rear_bogie = {cg + rear!r} "
                         f"differs from bogie_spacing = {spacing!r}")
    front = w.number(d, path, "front_overhang", nonneg=True, default=None)
    rear_o = w.number(d, path, "rear_overhang", nonneg=True, default=None)
    status = str(d.get("status", "user" if origin != "library" else "transcribed"))
    return VehicleSpec(
        id=vid, name=str(d.get("name", vid)), status=status, whole=whole,
        bogie_spacing=spacing, wheelbase=wheelbase, cg_to_front_bogie=cg,
        front_overhang=front, rear_overhang=rear_o, doubts=tuple(d.get("doubts", ())),
        check=dict(d.get("check", {})), origin=origin,
    )


def _parse_train(
    w: _Where, d: Any, path: str, vehicles: Mapping[str, VehicleSpec], origin: str
) -> TrainSpec:
    if not isinstance(d, Mapping):
        w.fail(path, "a table [[train]] is expected")
    tid = d.get("id")
    if not isinstance(tid, str) or not tid.strip():
        w.fail(f"{path}.id", f"{tid!r}: a non-empty string id is expected")
    ids = d.get("vehicles")
    if not isinstance(ids, list) or not ids or not all(isinstance(v, str) for v in ids):
        w.fail(f"{path}.vehicles", "a non-empty list of vehicle ids is expected")
    for i, v in enumerate(ids):
        if v not in vehicles:
            close = difflib.get_close_matches(v, list(vehicles), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            w.fail(f"{path}.vehicles[{i}]", f"unknown vehicle id {v!r}{hint}")
    specs = [vehicles[v] for v in ids]
    n = len(ids)
    # junctions: given as text ("articulated ...", "coupled", "inconsistent: ..."), or
    # derived from the overhangs (zero bogie-centre gap = articulated)
    junc = d.get("junctions")
    if junc is None:
        art = []
        for i in range(n - 1):
            a, b = specs[i].rear_overhang, specs[i + 1].front_overhang
            art.append(a is not None and b is not None and a + b == 0.0)
    else:
        if not isinstance(junc, list) or len(junc) != n - 1:
            w.fail(f"{path}.junctions", f"a list of {n - 1} junction kinds is expected")
        art = [str(j).strip().lower().startswith("articulated") for j in junc]
    offsets = d.get("vehicle_offsets")
    if offsets is None:
        offsets = [0.0]
        for i in range(n - 1):
            a, b = specs[i], specs[i + 1]
            if a.rear_overhang is None or b.front_overhang is None:
                w.fail(f"{path}.vehicle_offsets", "missing, and the vehicles' overhangs are "
                       "not all given to derive them")
            gap = a.rear_overhang + b.front_overhang
            offsets.append(offsets[-1] + 0.5 * a.wheelbase + a.bogie_spacing + gap
                           - 0.5 * b.wheelbase)
    if not isinstance(offsets, list) or len(offsets) != n:
        w.fail(f"{path}.vehicle_offsets", f"a list of {n} offsets (m) is expected")
    offs = []
    for i, o in enumerate(offsets):
        if isinstance(o, bool) or not isinstance(o, int | float) or not np.isfinite(o):
            w.fail(f"{path}.vehicle_offsets[{i}]", f"{o!r} is not a finite number")
        offs.append(float(o))
    if offs[0] != 0.0:
        w.fail(f"{path}.vehicle_offsets[0]", f"{offs[0]!r}: the first vehicle is at 0 m")
    for i in range(n - 1):
        a = specs[i]
        length = a.bogie_spacing + a.wheelbase  # first to last axle of vehicle i
        if art[i]:
            if abs(specs[i + 1].wheelbase - a.wheelbase) > 1e-9:
                w.fail(f"{path}.junctions[{i}]", "articulated cars need equal wheelbases")
            if abs(offs[i + 1] - offs[i] - a.bogie_spacing) > 1e-6:
                w.fail(f"{path}.vehicle_offsets[{i + 1}]",
                       f"{offs[i + 1]!r}: an articulated junction needs coincident bogie "
                       f"centres, i.e. offset {offs[i] + a.bogie_spacing!r}")
        elif not offs[i + 1] > offs[i] + length:
            w.fail(f"{path}.vehicle_offsets[{i + 1}]",
                   f"{offs[i + 1]!r}: vehicle {i + 1} would overlap vehicle {i} (its last "
                   f"axle is at {offs[i] + length!r} m)")
    status = str(d.get("status", "user" if origin != "library" else "transcribed"))
    return TrainSpec(
        id=tid, name=str(d.get("name", tid)), status=status, vehicles=tuple(ids),
        offsets=tuple(offs), articulated=tuple(art), doubts=tuple(d.get("doubts", ())),
        check=dict(d.get("check", {})), origin=origin,
    )


def _read_builtin() -> _Library:
    text = resources.files("vsi_numba").joinpath("data", "trains.toml").read_text("utf-8")
    data = tomllib.loads(text)
    w = _Where("vsi_numba/data/trains.toml")
    vehicles = {}
    for i, d in enumerate(data["vehicle"]):
        spec = _parse_vehicle(w, d, f"vehicle[{i}]", "library")
        vehicles[spec.id] = spec
    trains = {}
    for i, d in enumerate(data["train"]):
        spec = _parse_train(w, d, f"train[{i}]", vehicles, "library")
        trains[spec.id] = spec
    hslm = {
        t["name"]: HslmSpec(t["name"], int(t["N"]), float(t["D"]), float(t["d"]), float(t["P"]))
        for t in data["hslm"]["trains"]
    }
    return _Library(vehicles, trains, hslm, dict(data["hslm"]["rule"]),
                    dict(data["hslm"]["check"]))


_BUILTIN: _Library | None = None
_USER_VEHICLES: dict[str, VehicleSpec] = {}
_USER_TRAINS: dict[str, TrainSpec] = {}


def _lib() -> _Library:
    global _BUILTIN
    if _BUILTIN is None:
        _BUILTIN = _read_builtin()
    return _BUILTIN


def _all_vehicles() -> dict[str, VehicleSpec]:
    return {**_lib().vehicles, **_USER_VEHICLES}


# ------------------------------------------------------------------------------- names


def list_presets() -> list[str]:
    """Return every train name :func:`get_train` accepts, in display order.

    HSLM-A1 .. HSLM-A10, ``ICE3`` (= ``ave_s103_8car``), ``Eurostar``
    (= ``eurostar_halfset_reconstructed``), the other trains of the data file by id,
    then trains loaded with :func:`load_user_trains`.  The ids behind the two aliases
    are accepted too but not listed twice.
    """
    lib = _lib()
    aliased = set(ALIASES.values())
    names = list(lib.hslm) + list(ALIASES)
    names += [t for t in lib.trains if t not in aliased]
    names += [t for t in _USER_TRAINS if t not in names]
    return names


def _accepted() -> dict[str, tuple[str, str]]:
    """Name -> (kind, key) with kind in {"hslm", "train", "user"}."""
    lib = _lib()
    out: dict[str, tuple[str, str]] = {n: ("hslm", n) for n in lib.hslm}
    out.update({a: ("train", t) for a, t in ALIASES.items()})
    out.update({t: ("train", t) for t in lib.trains})
    out.update({t: ("user", t) for t in _USER_TRAINS})
    return out


def _resolve(name: str) -> tuple[str, str, str]:
    """Return (canonical name, kind, key) or raise :class:`UnknownTrainError`."""
    acc = _accepted()
    if not isinstance(name, str):
        raise UnknownTrainError(f"train name must be a string, got {name!r}")
    if name in acc:
        return (name, *acc[name])
    folded = {k.casefold(): k for k in acc}
    key = name.strip().casefold()
    if key in folded:
        k = folded[key]
        return (k, *acc[k])
    listed = list_presets()
    close = difflib.get_close_matches(name, listed, n=3, cutoff=0.5)
    if not close:
        close = [folded[c] for c in difflib.get_close_matches(key, list(folded), n=3)]
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise UnknownTrainError(f"unknown train {name!r}{hint} (`vsi trains` lists the library)")


def _spec(name: str) -> tuple[str, str, HslmSpec | TrainSpec]:
    canon, kind, key = _resolve(name)
    if kind == "hslm":
        return canon, kind, _lib().hslm[key]
    if kind == "user":
        return canon, kind, _USER_TRAINS[key]
    return canon, kind, _lib().trains[key]


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
    return railway_car(
        **s.whole, bogie_spacing=s.bogie_spacing, wheelbase=s.wheelbase,
        body_cg_to_front_bogie=s.cg_to_front_bogie, name=name or s.id, status=s.status,
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


# --------------------------------------------------------------------- status and tables


def status_warning(name: str) -> str:
    """Return a warning text for a train whose data status calls for one, else ``""``.

    Trains with status suspect, reconstruction or secondary get one paragraph: the
    status, its meaning and the entry's documented doubts (``notes/trains.md``).
    """
    canon, kind, spec = _spec(name)
    if kind == "hslm" or spec.status not in _WARN_STATUSES:
        return ""
    text = (f"train {canon!r} has data status {spec.status!r}: "
            f"{STATUS_MEANING.get(spec.status, '')}.")
    doubts = documented_doubts(canon)
    if doubts:
        text += " Documented doubts: " + "; ".join(doubts) + "."
    return text + " See notes/trains.md; do not use it for validation."


def documented_doubts(name: str) -> list[str]:
    """Return the doubts recorded for a train and its uncertain vehicles (data file)."""
    _, kind, spec = _spec(name)
    if kind == "hslm":
        return []
    doubts = list(spec.doubts)
    vs = _all_vehicles()
    for vid in dict.fromkeys(spec.vehicles):
        v = vs[vid]
        if v.status in _WARN_STATUSES:
            doubts += [f"{vid}: {t}" for t in v.doubts]
    return list(dict.fromkeys(doubts))


def _description(kind: str, spec) -> str:
    if kind == "hslm":
        return f"EN 1991-2 HSLM, N={spec.N}, D={spec.D:g} m, d={spec.d:g} m, P={spec.P / 1e3:g} kN"
    return spec.name


def library_table() -> pandas.DataFrame:
    """Return one row per preset: data status, axles, length, mass, loads.

    Columns: ``name``, ``status``, ``axles`` (distinct axle positions), ``length_m``
    (first to last axle), ``total_mass_t`` (vehicle mass, or total load / g for HSLM),
    ``max_axle_load_kN`` (static, whole axle), ``regular_length_m`` (regular coach
    length D, 0 if none), ``models``, ``data_id``, ``description``.
    """
    import pandas as pd

    rows = []
    for name in list_presets():
        canon, kind, spec = _spec(name)
        t = get_train(canon, "moving_force")
        loads = np.concatenate([v.loads for v in t.vehicles])
        rows.append({
            "name": canon,
            "status": t.status,
            "axles": int(loads.size),
            "length_m": t.length,
            "total_mass_t": t.total_mass / 1e3,
            "max_axle_load_kN": float(loads.max()) / 1e3,
            "regular_length_m": t.regular_length,
            "models": "moving_force" if kind == "hslm" else "interaction, moving_force",
            "data_id": spec.name if kind == "hslm" else spec.id,
            "description": _description(kind, spec),
        })
    return pd.DataFrame(rows)


def axle_table(name: str) -> pandas.DataFrame:
    """Return the axles of a train: position and static load.

    Columns: ``axle`` (1 = leading axle), ``position_m`` (behind the first axle),
    ``static_load_kN`` (whole axle, static, on rigid level track), ``vehicle`` (name of
    the vehicle the axle belongs to).  Coincident axles of articulations are one axle.
    """
    import pandas as pd

    t = get_train(name, "moving_force")
    pos, load, owner = [], [], []
    for v, o in zip(t.vehicles, t.offsets, strict=True):
        pos.append(o + v.load_positions)
        load.append(v.loads)
        owner += [v.name] * v.loads.size
    pos = np.concatenate(pos)
    load = np.concatenate(load)
    order = np.argsort(pos, kind="stable")
    return pd.DataFrame({
        "axle": np.arange(1, pos.size + 1),
        "position_m": pos[order],
        "static_load_kN": load[order] / 1e3,
        "vehicle": np.asarray(owner, dtype=object)[order],
    })


# ------------------------------------------------------------------------- user trains


def load_user_trains(path) -> dict[str, Train]:
    """Add the trains of a user TOML file to the library.

    The file uses the schema of ``trains.toml``: ``[[vehicle]]`` entries (``id``,
    ``bogie_spacing``, ``wheelbase``, optional ``body_cg_to_front_bogie`` (default: the
    middle), ``front_overhang`` / ``rear_overhang``, ``status``, ``name``, ``doubts``, and
    a ``[vehicle.whole]`` table with the nine whole-vehicle values of :data:`WHOLE_KEYS`)
    and ``[[train]]`` entries (``id``, ``vehicles`` = list of vehicle ids from this file
    or the library, ``vehicle_offsets`` in m (or derived from the overhangs), optional
    ``junctions`` ("coupled" / "articulated ..."; default: articulated where the bogie
    gap is zero), ``status`` (default "user"), ``name``, ``doubts``).

    Parameters
    ----------
    path : str or path-like
        The TOML file.

    Returns
    -------
    dict of str to Train
        The trains of the file by id, interaction model.  They are registered:
        :func:`get_train`, :func:`list_presets` and the tables know them from now on (a
        later file may redefine a user train; library names cannot be redefined).

    Raises
    ------
    FileNotFoundError, ValueError
        Missing file, invalid TOML, or invalid entries; the message names the file and
        the key path (``train[1].vehicle_offsets[2]: ...``).
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"user train file {str(p)!r}: no such file")
    try:
        data = tomllib.loads(p.read_text("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"user train file {str(p)!r}: invalid TOML ({exc})") from exc
    w = _Where(f"user train file {str(p)!r}")
    raw_v = data.get("vehicle", [])
    raw_t = data.get("train", [])
    if not isinstance(raw_v, list) or not isinstance(raw_t, list):
        w.fail("vehicle/train", "[[vehicle]] and [[train]] must be arrays of tables")
    if not raw_t:
        w.fail("train", "no [[train]] entry")
    lib = _lib()
    new_v: dict[str, VehicleSpec] = {}
    for i, d in enumerate(raw_v):
        s = _parse_vehicle(w, d, f"vehicle[{i}]", str(p))
        if s.id in lib.vehicles:
            w.fail(f"vehicle[{i}].id", f"{s.id!r} is a library vehicle; choose another id")
        if s.id in new_v:
            w.fail(f"vehicle[{i}].id", f"{s.id!r} defined twice")
        new_v[s.id] = s
    known_v = {**lib.vehicles, **_USER_VEHICLES, **new_v}
    reserved = set(lib.hslm) | set(ALIASES) | set(lib.trains)
    reserved_cf = {r.casefold(): r for r in reserved}
    new_t: dict[str, TrainSpec] = {}
    for i, d in enumerate(raw_t):
        s = _parse_train(w, d, f"train[{i}]", known_v, str(p))
        if s.id.casefold() in reserved_cf:
            w.fail(f"train[{i}].id", f"{s.id!r} is a library train name; choose another id")
        if s.id in new_t:
            w.fail(f"train[{i}].id", f"{s.id!r} defined twice")
        new_t[s.id] = s
    # build everything before registering, so a bad file leaves the library unchanged
    _USER_VEHICLES_backup = dict(_USER_VEHICLES)
    _USER_VEHICLES.update(new_v)
    try:
        built = {tid: _interaction_train(tid, s) for tid, s in new_t.items()}
    except ValueError as exc:
        _USER_VEHICLES.clear()
        _USER_VEHICLES.update(_USER_VEHICLES_backup)
        raise ValueError(f"user train file {str(p)!r}: {exc}") from exc
    _USER_TRAINS.update(new_t)
    return built


def clear_user_trains() -> None:
    """Forget every train and vehicle added by :func:`load_user_trains`."""
    _USER_TRAINS.clear()
    _USER_VEHICLES.clear()
