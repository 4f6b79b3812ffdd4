"""Moving-force trains outside the data file: EN 1991-2 HSLM-B with N and d given by the
user, and an axle-load list read from a CSV file.

HSLM-B (EN 1991-2 6.4.6.1.1, Annex E, Fig. 6.13 [R]) is N point forces of 170 kN at a
uniform spacing d, for simply supported spans L < 7 m; N and d are read from the curves
of Fig. 6.13 as functions of the span.  Those curve values are not available here
([NF], ``docs/manual/trains.md``), so the library lists HSLM-B without data and the
configuration gives N and d (``train.hslm_b = {N = ..., d = ...}``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.en1991 import HSLM_B_CLAUSE, HSLM_B_LOAD, HSLM_B_MAX_SPAN
from vsi_numba.model.vehicle import Train, point_loads, regular_length

#: Preset name of HSLM-B.
HSLM_B_NAME = "HSLM-B"
#: Data status of HSLM-B in the library listing: a standard load model whose N and d are
#: not available here (Fig. 6.13 curves [NF]); the configuration gives them.
HSLM_B_STATUS = "no data (NF)"
#: Data status of an HSLM-B train built from the configuration's N and d.
HSLM_B_TRAIN_STATUS = "user-given"
#: Why HSLM-B needs N and d from the user (the message of a config without them).
HSLM_B_MISSING = (
    f"HSLM-B ({HSLM_B_CLAUSE}) is N point forces of {HSLM_B_LOAD / 1e3:g} kN at a uniform "
    "spacing d, with N and d read from EN 1991-2 Fig. 6.13 as functions of the span "
    f"(simply supported spans L < {HSLM_B_MAX_SPAN:g} m); the curve values of Fig. 6.13 "
    "are not available to vsi_numba, so give them: train.hslm_b = {N = <number of "
    "forces>, d = <spacing in m>} read from the figure for your span"
)
#: Units accepted for the load column of an axle-load CSV file -> factor to N.
LOAD_UNITS = {"N": 1.0, "kN": 1e3}
#: Columns of an axle-load CSV file.
POSITION_COLUMN = "position"
LOAD_COLUMN = "load"


def hslm_b_train(n: int, d: float, name: str = HSLM_B_NAME) -> Train:
    """EN 1991-2 HSLM-B: ``n`` point forces of 170 kN at a uniform spacing ``d``.

    Parameters
    ----------
    n : int
        Number of point forces N (>= 1), from EN 1991-2 Fig. 6.13 [R] for the span.
    d : float
        Spacing d (m, > 0), from EN 1991-2 Fig. 6.13 [R].
    name : str
        Train name.

    Returns
    -------
    Train
        Moving forces at 0, d, ..., (n - 1) d (m behind the first axle), status
        "user-given" (the load model is standard, its N and d are the user's), regular
        length d (the resonance spacing).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"HSLM-B N = {n!r}: expected a whole number of forces >= 1")
    if not (np.isfinite(d) and d > 0):
        raise ValueError(f"HSLM-B d = {d!r}: expected a spacing > 0 m")
    pos = float(d) * np.arange(int(n))
    veh = point_loads(pos, HSLM_B_LOAD, name=name, status=HSLM_B_TRAIN_STATUS)
    return Train(name, (veh,), (0.0,), status=HSLM_B_TRAIN_STATUS, regular_length=float(d))


class AxleFileError(ValueError):
    """An axle-load CSV file that cannot be used (the message says where and why)."""


def read_axle_file(path, load_unit: str = "kN") -> tuple[np.ndarray, np.ndarray]:
    """Read an axle-load list: CSV with a header, columns ``position`` (m behind the first
    axle) and ``load`` (whole-axle load, positive down, in ``load_unit``); ``#`` starts a
    comment; other columns are ignored.

    Returns
    -------
    positions, loads : ndarray, shape (n_axle,)
        m from the first axle (the smallest position is taken as 0) and N, in file order.

    Raises
    ------
    AxleFileError
        Missing columns, non-numeric or non-finite values, negative positions, loads
        <= 0, positions not strictly increasing, an empty file.
    """
    import pandas as pd

    if load_unit not in LOAD_UNITS:
        raise AxleFileError(f"load unit {load_unit!r}: expected one of "
                            f"{', '.join(map(repr, LOAD_UNITS))}")
    try:
        df = pd.read_csv(Path(path), comment="#", skipinitialspace=True)
    except (OSError, ValueError) as exc:
        raise AxleFileError(f"cannot read {path} as CSV ({' '.join(str(exc).split())})"
                            ) from None
    df.columns = [str(c).strip() for c in df.columns]
    missing = [c for c in (POSITION_COLUMN, LOAD_COLUMN) if c not in df.columns]
    if missing:
        raise AxleFileError(f"{path}: missing column(s) {', '.join(missing)} (found "
                            f"{', '.join(df.columns) or 'none'}); expected a header "
                            f"'{POSITION_COLUMN},{LOAD_COLUMN}' with position in m behind "
                            f"the first axle and load in {load_unit}")
    if df.empty:
        raise AxleFileError(f"{path}: no axle rows")
    cols = {}
    for c in (POSITION_COLUMN, LOAD_COLUMN):
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            i = int(bad[0])
            raise AxleFileError(f"{path}: row {i + 1} (data line), column {c} = "
                                f"{df[c].iloc[i]!r}: expected a finite number")
        cols[c] = v
    pos, load = cols[POSITION_COLUMN], cols[LOAD_COLUMN]
    for i in np.flatnonzero(pos < 0)[:1]:
        raise AxleFileError(f"{path}: row {i + 1}, {POSITION_COLUMN} = {float(pos[i])!r}: expected "
                            "a position >= 0 m behind the first axle")
    for i in np.flatnonzero(load <= 0)[:1]:
        raise AxleFileError(f"{path}: row {i + 1}, {LOAD_COLUMN} = {float(load[i])!r}: expected "
                            f"an axle load > 0 {load_unit} (positive down)")
    for i in np.flatnonzero(np.diff(pos) <= 0)[:1]:
        raise AxleFileError(f"{path}: row {i + 2}, {POSITION_COLUMN} = {float(pos[i + 1])!r}: "
                            f"expected positions strictly increasing (row {i + 1} has "
                            f"{float(pos[i])!r}); axles are listed front to back")
    return pos - pos[0], load * LOAD_UNITS[load_unit]


def axle_list_train(path, load_unit: str = "kN", name: str | None = None) -> Train:
    """A moving-force train from an axle-load CSV file (:func:`read_axle_file`).

    Returns
    -------
    Train
        One vehicle of point forces, status "user", named ``name`` or the file stem,
        with the regular length D of its axles
        (:func:`~vsi_numba.model.vehicle.regular_length`; 0 when they have none).
    """
    pos, load = read_axle_file(path, load_unit)
    name = name or Path(path).stem
    veh = point_loads(pos, load, name=name, status="user")
    return Train(name, (veh,), (0.0,), status="user",
                 regular_length=regular_length(pos, load))


def hslm_b_row() -> dict:
    """The library-table row of HSLM-B (:func:`~vsi_numba.model.library.library_table`
    columns): no axle data, N and d come from the configuration."""
    return {
        "name": HSLM_B_NAME, "status": HSLM_B_STATUS, "axles": np.nan, "length_m": np.nan,
        "total_mass_t": np.nan, "max_axle_load_kN": HSLM_B_LOAD / 1e3,
        "regular_length_m": np.nan, "models": "moving_force", "data_id": HSLM_B_NAME,
        "description": (f"EN 1991-2 HSLM-B, N x {HSLM_B_LOAD / 1e3:g} kN at spacing d, spans "
                        f"< {HSLM_B_MAX_SPAN:g} m; N, d from Fig. 6.13 [NF here]: give "
                        "train.hslm_b = {N, d}"),
    }
