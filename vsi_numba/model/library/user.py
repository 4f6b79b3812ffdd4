"""User train files (``[[train]]`` / ``[[vehicle]]`` tables in a TOML file) added to the
library."""

from __future__ import annotations

import tomllib
from pathlib import Path

from vsi_numba.model.library.builders import _interaction_train
from vsi_numba.model.library.data import (
    _USER_TRAINS,
    _USER_VEHICLES,
    ALIASES,
    TrainSpec,
    VehicleSpec,
    _lib,
    _parse_train,
    _parse_vehicle,
    _Where,
)
from vsi_numba.model.vehicle import Train

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
