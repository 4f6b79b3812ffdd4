"""Case datasets -> one study dataset (dims speed, train, irregularity, ...).

The study file is built by placing every case into preallocated arrays rather than with
``xarray.combine_by_coords``: cases differ in which variables they hold (time histories
only for some speeds) and in their wheel/vehicle/time lengths, and direct placement makes
the padding explicit (NaN) and the result independent of the order cases finished in.

Padding: trains with fewer wheels or vehicles than the largest one, and the time steps
after the end of a short (fast) run, are NaN.  ``in_contact`` is therefore stored as
float32 in a study (1 = in contact, 0 = separated, NaN = no such wheel / no such step).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.io.netcdf import CASE_DIMS
from vsi_numba.io.schema import DIAGNOSTICS, ENVELOPES, HISTORIES, attrs_for

PER_CASE_DIMS = ("point", "wheel", "vehicle", "time")


def case_dataset(sim: xr.Dataset, case) -> xr.Dataset:
    """Reduce a ``simulate`` result to what a study keeps for one case.

    Envelopes, ``status``, ``max_iterations``, ``message`` and (when the case keeps them)
    the time histories, with length-1 leading dims ``speed``, ``train``, ``irregularity``;
    the per-train coordinates (``wheel_position``, ``static_wheel_load``,
    ``vehicle_name``) ride along without those dims.
    """
    names = [n for n in (*ENVELOPES, *DIAGNOSTICS) if n in sim]
    if case.histories:
        names += [n for n in HISTORIES if n in sim]
    ds = sim[names]
    ds = ds.drop_vars([c for c in ds.coords if c not in
                       ("point", "wheel", "vehicle", "time", "wheel_position",
                        "static_wheel_load")])
    if "vehicle_name" in sim:
        ds = ds.assign_coords(vehicle_name=sim["vehicle_name"])
    ds["message"] = ((), str(sim.attrs.get("message", "")),
                     {"long_name": "analysis status message", "units": "1"})
    ds = ds.expand_dims(
        speed=[case.speed_m_s], train=[case.train], irregularity=[case.irregularity]
    )
    ds = ds.assign_coords(speed_kmh=("speed", [case.speed_kmh]))
    ds.attrs = {
        "case_key": case.key,
        "case_index": int(case.index),
        "speed_kmh": float(case.speed_kmh),
        "train": case.train,
        "irregularity": int(case.irregularity),
        "status": int(sim["status"]) if "status" in sim else int(sim.attrs.get("status", 0)),
        "message": str(sim.attrs.get("message", "")),
        "kernel_seconds": float(sim.attrs.get("kernel_seconds", np.nan)),
        "profile": str(sim.attrs.get("profile", "")),
    }
    return ds


def _check_case(ds: xr.Dataset, case) -> None:
    """Check that a stored case is the case its file name says (defence against stale stores)."""
    ok = (
        ds.attrs.get("case_key") == case.key
        and float(ds["speed_kmh"].values[0]) == case.speed_kmh
        and str(ds["train"].values[0]) == case.train
        and int(ds["irregularity"].values[0]) == case.irregularity
    )
    if not ok:
        raise ValueError(
            f"stored case {ds.attrs.get('case_key')!r} does not match case {case.key} "
            f"({case.speed_kmh} km/h, {case.train}, irregularity {case.irregularity})"
        )


def assemble(grid, cases: list[xr.Dataset], trains_info: dict, frequencies, attrs: dict
             ) -> xr.Dataset:
    """Place the case datasets (in grid order) into one study dataset.

    Parameters
    ----------
    grid : StudyGrid
    cases : list of Dataset
        :func:`case_dataset` of every case of ``grid.cases``, same order.
    trains_info : dict
        ``regular_length`` (n_train,), ``status`` (n_train,) and
        ``max_static_deck_displacement`` (n_train, n_point).
    frequencies : ndarray
        Natural frequencies of the bridge (Hz).
    attrs : dict
        Global attributes.
    """
    n_s, n_t, n_i = grid.shape
    if len(cases) != len(grid.cases):
        raise ValueError(f"{len(cases)} case datasets for {len(grid.cases)} cases")
    for ds, case in zip(cases, grid.cases, strict=True):
        _check_case(ds, case)
    points = cases[0]["point"].values
    for ds, case in zip(cases, grid.cases, strict=True):
        if not np.array_equal(ds["point"].values, points):
            raise ValueError(f"case {case.key}: output points differ from the first case")
    n_wheel = max(ds.sizes.get("wheel", 0) for ds in cases)
    n_veh = max(ds.sizes.get("vehicle", 0) for ds in cases)
    times = [ds["time"].values for ds in cases if "time" in ds.dims]
    time = np.unique(np.concatenate(times)) if times else None
    sizes = {"point": points.size, "wheel": n_wheel, "vehicle": n_veh}
    if time is not None:
        sizes["time"] = time.size

    present = set().union(*(set(ds.data_vars) for ds in cases))
    names = [n for n in (*ENVELOPES, *DIAGNOSTICS, *HISTORIES) if n in present]
    schema = {**ENVELOPES, **DIAGNOSTICS, **HISTORIES}
    data = {}
    for name in names:
        dims = schema[name][0]
        shape = (n_s, n_t, n_i, *(sizes[d] for d in dims))
        if name in DIAGNOSTICS:
            data[name] = np.zeros(shape, np.int32)
        elif name in HISTORIES:
            data[name] = np.full(shape, np.nan, np.float32)
        else:
            data[name] = np.full(shape, np.nan, np.float64)
    message = np.full((n_s, n_t, n_i), "", dtype=object)

    for ds, case in zip(cases, grid.cases, strict=True):
        at = (case.i_speed, case.i_train, case.i_irregularity)
        one = ds.isel(speed=0, train=0, irregularity=0)
        pos = np.searchsorted(time, one["time"].values) if "time" in one.dims else None
        for name in names:
            if name not in one:
                continue
            var = one[name]
            index = list(at)
            for dim in var.dims:
                if dim == "time":
                    index.append(pos)
                else:
                    index.append(slice(0, one.sizes[dim]))
            data[name][tuple(index)] = var.values
        message[at] = str(one["message"].values)

    coords = {
        "speed": ("speed", grid.speeds_kmh / 3.6, attrs_for("speed")),
        "speed_kmh": ("speed", grid.speeds_kmh, attrs_for("speed_kmh")),
        "train": ("train", np.array(grid.trains, dtype=object), attrs_for("train")),
        "irregularity": ("irregularity", np.array(grid.irregularities, np.int64),
                         attrs_for("irregularity")),
        "point": ("point", points, attrs_for("point")),
        "wheel": ("wheel", np.arange(n_wheel, dtype=np.int64), attrs_for("wheel")),
        "vehicle": ("vehicle", np.arange(n_veh, dtype=np.int64), attrs_for("vehicle")),
        "mode": ("mode", np.arange(1, len(frequencies) + 1, dtype=np.int64),
                 attrs_for("mode")),
    }
    if time is not None:
        coords["time"] = ("time", time, attrs_for("time"))

    # per-train data: from the first case of each train (identical for all its cases)
    wheel_position = np.full((n_t, n_wheel), np.nan)
    static_load = np.full((n_t, n_wheel), np.nan)
    vehicle_name = np.full((n_t, n_veh), "", dtype=object)
    seen = set()
    for ds, case in zip(cases, grid.cases, strict=True):
        if case.i_train in seen:
            continue
        seen.add(case.i_train)
        nw, nv = ds.sizes.get("wheel", 0), ds.sizes.get("vehicle", 0)
        if "wheel_position" in ds.coords:
            wheel_position[case.i_train, :nw] = ds["wheel_position"].values
        if "static_wheel_load" in ds.coords:
            static_load[case.i_train, :nw] = ds["static_wheel_load"].values
        if "vehicle_name" in ds.coords:
            vehicle_name[case.i_train, :nv] = ds["vehicle_name"].values.astype(str)
    coords["wheel_position"] = (("train", "wheel"), wheel_position, attrs_for("wheel_position"))
    coords["static_wheel_load"] = (("train", "wheel"), static_load,
                                   attrs_for("static_wheel_load"))
    coords["vehicle_name"] = (("train", "vehicle"), vehicle_name,
                              {"long_name": "vehicle name", "units": "1"})

    out = xr.Dataset(coords=coords)
    for name in names:
        dims = (*CASE_DIMS, *schema[name][0])
        var_attrs = attrs_for(name)
        if name == "in_contact":
            var_attrs = {**var_attrs, "flag_values": np.array([0.0, 1.0], np.float32),
                     "comment": "NaN where the train has no such wheel or the run no such step"}
        out[name] = (dims, data[name], var_attrs)
    out["message"] = (CASE_DIMS, message.astype(str),
                      {"long_name": "analysis status message", "units": "1"})
    out["max_static_deck_displacement"] = (
        ("train", "point"), np.asarray(trains_info["max_static_deck_displacement"], float),
        {"units": "m", "long_name": "maximum static deck displacement as the train's static "
         "axle loads cross the bridge (reference of phi'_dyn)", "positive": "down"},
    )
    out["train_regular_length"] = (
        "train", np.asarray(trains_info["regular_length"], float),
        {"units": "m", "long_name": "regular coach length D of the train (0: none)"},
    )
    out["train_status"] = (
        "train", np.array(trains_info["status"], dtype=object).astype(str),
        {"units": "1", "long_name": "data status of the train model"},
    )
    out["frequency"] = ("mode", np.asarray(frequencies, float), attrs_for("frequency"))
    out.attrs = dict(attrs)
    return out
