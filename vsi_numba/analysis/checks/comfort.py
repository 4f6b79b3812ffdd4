"""Passenger comfort: car-body vertical acceleration against EN 1990 A2.4.4.3,
Table A2.9 (the levels of the code profile)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.checks.common import (
    DEFAULT_Q,
    _case_realisation,
    _summarise,
    design_value,
    profile_of,
)
from vsi_numba.analysis.dataset import (
    nanmax,
    prepare,
    require,
)
from vsi_numba.en1990 import (
    COMFORT_KEYS,
    comfort_level,
    comfort_levels,
)


def comfort(
    ds: xr.Dataset, required: str = "very good", q: float = DEFAULT_Q, n_boot: int = 2000,
    seed: int = 0, profile=None,
) -> xr.Dataset:
    """Car-body vertical acceleration b_v against the levels of EN 1990 Table A2.9.

    Levels (recommended values of the code profile): very good 1.0, good 1.3, acceptable
    2.0 m s-2. The required level is specified for the project (EN 1990 A2.4.4.3);
    "very good" is the default here.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_carbody_acceleration(speed, train, irregularity, vehicle)``.
    required : str
        Required level of comfort: "very good", "good" or "acceptable".
    profile : CodeProfile, optional
        Code profile; default: the one of the results.

    Returns
    -------
    xarray.Dataset
        ``value(speed, train)`` (m s-2, max over vehicles, design value);
        ``level(speed, train)`` (str: the best level attained, or "not acceptable");
        ``margin``/``utilisation``/``passed`` against the required level; statistics;
        summary attrs plus ``required_level`` and ``level`` (attained in the governing
        case), and, when the results have ``position_of_max_carbody_acceleration``,
        ``governing_vehicle`` (name) and ``governing_position`` (m ahead of that body's
        centre of gravity: the comfort point of the governing peak).  When the results
        have ``max_carbody_acceleration_car_end`` (the car-body ends), the car-end peak
        is reported apart, never mixed into ``value``: ``car_end_value`` (m s-2, largest
        over every case), ``car_end_level``, ``car_end_train``, ``car_end_speed``,
        ``car_end_vehicle`` and ``car_end_position`` (m ahead of that body's centre of
        gravity).  All NaN (result
        "n/a", attribute ``note``) for a moving-force model (no car bodies).
    """
    ds = prepare(ds)
    require(ds, ["max_carbody_acceleration"], "the comfort check")
    profile = profile_of(ds, profile)
    levels = comfort_levels(profile)
    if required not in levels:
        raise ValueError(f"required comfort level {required!r} is not one of "
                         f"{list(levels)}")
    limit = levels[required]
    bv = nanmax(ds["max_carbody_acceleration"], "vehicle")
    out = design_value(bv, q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="m s-2", long_name="car-body vertical acceleration b_v")
    out["level"] = xr.apply_ufunc(np.vectorize(lambda b: comfort_level(b, profile),
                                               otypes=[object]), out["value"])
    out = _summarise(out, "Car-body acceleration (comfort)",
                     profile.clause(COMFORT_KEYS[required]), "m s-2", limit,
                     extra={"required_level": required, "basis": out.attrs["basis"]})
    out.attrs["level"] = comfort_level(out.attrs["value"], profile)
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
    out.attrs.update(_car_end(ds, profile))
    if ds.sizes.get("vehicle", 0) == 0 or not bool(out["value"].notnull().any()):
        out.attrs["note"] = "no car-body accelerations in the results (moving-force model)"
    return out


def _car_end(ds: xr.Dataset, profile=None) -> dict:
    """The largest car-end acceleration over every case and vehicle, with where it is
    (empty when the results have no car-end envelope or no car with known ends)."""
    name = "max_carbody_acceleration_car_end"
    if name not in ds or not bool(ds[name].notnull().any()):
        return {}
    da = ds[name]
    idx = da.fillna(-np.inf).argmax(...)
    peak = float(da.isel(idx))
    out = {"car_end_value": peak, "car_end_level": comfort_level(peak, profile)}
    for dim in ("train", "speed"):
        if dim in idx and dim in da.coords:
            val = da[dim].values[int(idx[dim])]
            out[f"car_end_{dim}"] = str(val) if dim == "train" else float(val)
    pos = f"position_of_{name}"
    if pos in ds:
        out["car_end_position"] = float(ds[pos].isel(idx))
    k = int(idx["vehicle"])
    out["car_end_vehicle"] = (str(ds["vehicle_name"].sel(train=out["car_end_train"])
                                  .isel(vehicle=k).values)
                              if "vehicle_name" in ds and "train" in ds["vehicle_name"].dims
                              and "car_end_train" in out else str(k))
    return out
