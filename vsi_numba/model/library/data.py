"""The library's data: specs of vehicles, trains and HSLM-A trains read (and checked) from
``vsi_numba/data/trains.toml`` and user train files, the registry of user entries and
the resolution of train names (aliases, case, close matches)."""

from __future__ import annotations

import difflib
import tomllib
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import numpy as np

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
    "user-given": ("EN 1991-2 HSLM-B with the number of forces N and their spacing d given "
                   "in the configuration (Fig. 6.13 is not available here)"),
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
