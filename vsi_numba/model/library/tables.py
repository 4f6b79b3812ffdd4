"""The library as tables: data status warnings, documented doubts, the library table and
one train's axle table."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vsi_numba.model.library.builders import get_train
from vsi_numba.model.library.data import (
    _WARN_STATUSES,
    STATUS_MEANING,
    _all_vehicles,
    _spec,
    list_presets,
)

if TYPE_CHECKING:
    import pandas


# --------------------------------------------------------------------- status and tables


def status_warning(name: str) -> str:
    """Return a warning text for a train whose data status calls for one, else ``""``.

    Trains with status suspect, reconstruction or secondary get one paragraph: the
    status, its meaning and the entry's documented doubts (``docs/manual/trains.md``).
    """
    canon, kind, spec = _spec(name)
    if kind == "hslm" or spec.status not in _WARN_STATUSES:
        return ""
    text = (f"train {canon!r} has data status {spec.status!r}: "
            f"{STATUS_MEANING.get(spec.status, '')}.")
    doubts = documented_doubts(canon)
    if doubts:
        text += " Documented doubts: " + "; ".join(doubts) + "."
    return text + " See docs/manual/trains.md; do not use it for validation."


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
