"""Passenger comfort: car-body vertical acceleration against EN 1990 A2.4.4.3,
Table A2.9 [R]."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.checks.common import (
    DEFAULT_Q,
    _case_realisation,
    _summarise,
    design_value,
)
from vsi_numba.analysis.dataset import (
    nanmax,
    prepare,
    require,
)
from vsi_numba.en1990 import (
    COMFORT_CLAUSE,
    COMFORT_LEVELS,
    comfort_level,
)


def comfort(
    ds: xr.Dataset, required: str = "very good", q: float = DEFAULT_Q, n_boot: int = 2000,
    seed: int = 0,
) -> xr.Dataset:
    """Car-body vertical acceleration b_v against the levels of EN 1990 Table A2.9 [R].

    Levels: very good 1.0, good 1.3, acceptable 2.0 m s-2 (:data:`COMFORT_LEVELS`). The
    required level is specified for the project (EN 1990 A2.4.4.3 [R]); "very good" is
    the default here.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_carbody_acceleration(speed, train, irregularity, vehicle)``.
    required : str
        Required level of comfort, a key of :data:`COMFORT_LEVELS`.

    Returns
    -------
    xarray.Dataset
        ``value(speed, train)`` (m s-2, max over vehicles, design value);
        ``level(speed, train)`` (str: the best level attained, or "not acceptable");
        ``margin``/``utilisation``/``passed`` against the required level; statistics;
        summary attrs plus ``required_level`` and ``level`` (attained in the governing
        case), and, when the results have ``position_of_max_carbody_acceleration``,
        ``governing_vehicle`` (name) and ``governing_position`` (m ahead of that body's
        centre of gravity: the comfort point of the governing peak). All NaN (result
        "n/a", attribute ``note``) for a moving-force model (no car bodies).
    """
    ds = prepare(ds)
    require(ds, ["max_carbody_acceleration"], "the comfort check")
    if required not in COMFORT_LEVELS:
        raise ValueError(f"required comfort level {required!r} is not one of "
                         f"{list(COMFORT_LEVELS)}")
    limit = COMFORT_LEVELS[required]
    bv = nanmax(ds["max_carbody_acceleration"], "vehicle")
    out = design_value(bv, q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="m s-2", long_name="car-body vertical acceleration b_v")
    out["level"] = xr.apply_ufunc(np.vectorize(comfort_level, otypes=[object]), out["value"])
    out = _summarise(out, "Car-body acceleration (comfort)", COMFORT_CLAUSE, "m s-2", limit,
                     extra={"required_level": required, "basis": out.attrs["basis"]})
    out.attrs["level"] = comfort_level(out.attrs["value"])
    if out.attrs["governing_train"] and "position_of_max_carbody_acceleration" in ds:
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        irr = _case_realisation(bv, t, v)
        case = ds["max_carbody_acceleration"].sel(train=t, speed=v, irregularity=irr)
        if bool(case.notnull().any()):
            k = int(case.fillna(-np.inf).argmax("vehicle"))
            pos = ds["position_of_max_carbody_acceleration"].sel(train=t, speed=v,
                                                                 irregularity=irr)
            out.attrs["governing_position"] = float(pos.isel(vehicle=k))
            name = (ds["vehicle_name"].sel(train=t).isel(vehicle=k).values
                    if "vehicle_name" in ds and "train" in ds["vehicle_name"].dims else k)
            out.attrs["governing_vehicle"] = str(name)
    if ds.sizes.get("vehicle", 0) == 0 or not bool(out["value"].notnull().any()):
        out.attrs["note"] = "no car-body accelerations in the results (moving-force model)"
    return out
