"""The study results file, written by slices (never assembled in memory).

:class:`StudyFile` creates the CF netCDF-4 file with every dimension and variable of the
study preallocated (``_FillValue`` NaN for floats), then takes finished batches one at a
time and writes each run into its slice.  Peak memory is one batch, whatever the size of
the study.  The layout (names, dims, attributes, encodings) is the one
:mod:`vsi_numba.io.netcdf` documents and ``xarray.open_dataset`` reads back:

* dims ``speed``, ``train``, ``irregularity`` (the study axes), ``point``, ``wheel``,
  ``vehicle``, ``mode`` and, when some run keeps them, ``time``;
* envelopes (float64) and ``status`` / ``max_iterations`` (int32) on the study axes
  (envelopes with one more dim ``point``, ``wheel`` or ``vehicle``, or none: the
  whole-deck acceleration envelope is one value per case);
* time histories as float32, zlib level 4 with shuffle, one chunk per run (at most 4096
  steps long); ``in_contact`` as float32 (1, 0, NaN where the train has no such wheel or
  the run no such step); ``contact_force`` and ``in_contact`` are NaN for moving forces
  (their force is the prescribed ``static_wheel_load``, not a result);
* per-train coordinates ``wheel_position``, ``static_wheel_load``, ``vehicle_name``;
  wheels and vehicles a train does not have are NaN / empty.
"""

from __future__ import annotations

import numpy as np

from vsi_numba.io.netcdf import CASE_DIMS, MAX_TIME_CHUNK
from vsi_numba.io.schema import DIAGNOSTICS, ENVELOPES, HISTORIES, attrs_for

#: Non-dimension coordinates and their dims.
_COORDS = {
    "speed_kmh": ("speed",),
    "wheel_position": ("train", "wheel"),
    "static_wheel_load": ("train", "wheel"),
    "vehicle_name": ("train", "vehicle"),
}


def _coordinates_attr(dims) -> str:
    """CF ``coordinates`` attribute of a variable: the auxiliary coordinates it spans."""
    return " ".join(n for n, d in _COORDS.items() if set(d) <= set(dims))


def _put_attrs(var, attrs: dict) -> None:
    for k, v in attrs.items():
        if isinstance(v, list | tuple):
            v = np.asarray(v)
        var.setncattr(k, v)


class StudyFile:
    """A study results file being written (see the module notes).

    Parameters
    ----------
    path : path-like
        File to create (a temporary path: the caller renames it into place).
    speeds_kmh, trains, irregularities : sequences
        The study axes.
    points : ndarray
        Deck output points (m).
    frequencies : ndarray
        Bridge natural frequencies (Hz).
    n_wheel, n_vehicle : int
        Largest wheel and vehicle counts over the trains.
    n_time : int or None
        Time steps + 1 of the longest run that keeps histories (None: no histories).
    dt : float
        Time step (s).
    trains_info : dict
        ``wheel_position`` and ``static_wheel_load`` (lists per train, N and m),
        ``vehicle_name`` (lists per train), ``regular_length``, ``status``,
        ``max_static_deck_displacement`` (n_train, n_point).
    """

    def __init__(self, path, speeds_kmh, trains, irregularities, points, frequencies,
                 n_wheel, n_vehicle, n_time, dt, trains_info):
        import netCDF4

        self.nc = netCDF4.Dataset(path, "w", format="NETCDF4")
        nc = self.nc
        speeds_kmh = np.asarray(speeds_kmh, float)
        n_s, n_t, n_i = speeds_kmh.size, len(trains), len(irregularities)
        self.shape = (n_s, n_t, n_i)
        sizes = {"speed": n_s, "train": n_t, "irregularity": n_i, "point": len(points),
                 "wheel": n_wheel, "vehicle": n_vehicle, "mode": len(frequencies)}
        if n_time is not None:
            sizes["time"] = n_time
        self.sizes = sizes
        for dim, size in sizes.items():
            nc.createDimension(dim, size)

        def coord(name, dims, values, dtype, attrs):
            var = nc.createVariable(name, dtype, dims)
            var[...] = values
            _put_attrs(var, attrs)
            return var

        coord("speed", ("speed",), speeds_kmh / 3.6, "f8", attrs_for("speed"))
        coord("speed_kmh", ("speed",), speeds_kmh, "f8", attrs_for("speed_kmh"))
        coord("train", ("train",), np.array(list(trains), dtype=object), str,
              attrs_for("train"))
        coord("irregularity", ("irregularity",), np.asarray(irregularities, np.int64), "i8",
              attrs_for("irregularity"))
        coord("point", ("point",), np.asarray(points, float), "f8", attrs_for("point"))
        coord("wheel", ("wheel",), np.arange(n_wheel, dtype=np.int64), "i8",
              attrs_for("wheel"))
        coord("vehicle", ("vehicle",), np.arange(n_vehicle, dtype=np.int64), "i8",
              attrs_for("vehicle"))
        coord("mode", ("mode",), np.arange(1, len(frequencies) + 1, dtype=np.int64), "i8",
              attrs_for("mode"))
        if n_time is not None:
            coord("time", ("time",), np.arange(n_time) * dt, "f8", attrs_for("time"))

        wp = np.full((n_t, n_wheel), np.nan)
        q0 = np.full((n_t, n_wheel), np.nan)
        names = np.full((n_t, n_vehicle), "", dtype=object)
        for t in range(n_t):
            a, b = trains_info["wheel_position"][t], trains_info["static_wheel_load"][t]
            wp[t, : len(a)] = a
            q0[t, : len(b)] = b
            v = list(trains_info["vehicle_name"][t])
            names[t, : len(v)] = v
        self._float("wheel_position", ("train", "wheel"), attrs_for("wheel_position"))[...] = wp
        self._float("static_wheel_load", ("train", "wheel"),
                    attrs_for("static_wheel_load"))[...] = q0
        coord("vehicle_name", ("train", "vehicle"), names, str, attrs_for("vehicle_name"))

        self.vars = {}
        for name, (dims, *_rest) in ENVELOPES.items():
            self.vars[name] = self._float(name, (*CASE_DIMS, *dims), attrs_for(name))
        for name in DIAGNOSTICS:
            var = nc.createVariable(name, "i4", CASE_DIMS)
            _put_attrs(var, {**attrs_for(name), "coordinates": _coordinates_attr(CASE_DIMS)})
            self.vars[name] = var
        if n_time is not None:
            for name, (dims, *_rest) in HISTORIES.items():
                full = (*CASE_DIMS, *dims)
                chunks = tuple(1 if d in CASE_DIMS else
                               max(1, min(sizes[d], MAX_TIME_CHUNK)) if d == "time" else
                               max(1, sizes[d]) for d in full)
                attrs = attrs_for(name)
                if name == "in_contact":
                    attrs = {**attrs, "flag_values": np.array([0.0, 1.0], np.float32),
                             "comment": "NaN where the train has no such wheel (or the wheel "
                             "is a prescribed moving force) or the run no such step"}
                kw = {}
                if 0 not in [sizes[d] for d in full]:
                    kw["chunksizes"] = chunks
                var = nc.createVariable(name, "f4", full, zlib=True, complevel=4,
                                        shuffle=True, fill_value=np.float32(np.nan), **kw)
                _put_attrs(var, {**attrs, "coordinates": _coordinates_attr(full)})
                self.vars[name] = var
        msg = nc.createVariable("message", str, CASE_DIMS)
        _put_attrs(msg, {"long_name": "analysis status message", "units": "1",
                         "coordinates": _coordinates_attr(CASE_DIMS)})
        self.vars["message"] = msg
        self._float("max_static_deck_displacement", ("train", "point"), {
            "units": "m", "long_name": "maximum static deck displacement as the train's "
            "static axle loads cross the bridge (reference of phi'_dyn)", "positive": "down",
        })[...] = np.asarray(trains_info["max_static_deck_displacement"], float)
        self._float("train_regular_length", ("train",), {
            "units": "m", "long_name": "regular coach length D of the train (0: none)",
        })[...] = np.asarray(trains_info["regular_length"], float)
        status = nc.createVariable("train_status", str, ("train",))
        status[...] = np.array([str(s) for s in trains_info["status"]], dtype=object)
        _put_attrs(status, {"units": "1", "long_name": "data status of the train model"})
        self._float("frequency", ("mode",), attrs_for("frequency"))[...] = np.asarray(
            frequencies, float)

    def _float(self, name, dims, attrs):
        var = self.nc.createVariable(name, "f8", dims, fill_value=np.nan)
        coords = _coordinates_attr(dims) if name not in _COORDS else ""
        _put_attrs(var, {**attrs, **({"coordinates": coords} if coords else {})})
        return var

    def write_batch(self, batch, data: dict, n_wheel: int, n_vehicle: int) -> None:
        """Write the runs of one finished batch (:func:`~vsi_numba.study.batches.
        run_batch_task` output) into their slices; the train has ``n_wheel`` wheels and
        ``n_vehicle`` vehicles."""
        i_t, i_i = batch.i_train, batch.i_irregularity
        s0, s1 = batch.speeds[0], batch.speeds[-1] + 1
        if list(batch.speeds) != list(range(s0, s1)):
            raise ValueError(f"batch {batch.key}: speeds are not contiguous")
        for name, (dims, *_rest) in ENVELOPES.items():
            if not dims:  # one value per case
                self.vars[name][s0:s1, i_t, i_i] = np.asarray(data[name], float)
                continue
            width = {"point": self.sizes["point"], "wheel": n_wheel,
                     "vehicle": n_vehicle}[dims[0]]
            self.vars[name][s0:s1, i_t, i_i, :width] = data[name][:, :width]
        for name in DIAGNOSTICS:
            self.vars[name][s0:s1, i_t, i_i] = data[name].astype(np.int32)
        self.vars["message"][s0:s1, i_t, i_i] = np.array(
            [str(m) for m in data["message"]], dtype=object)
        if "hist_runs" in data and "time" in self.sizes:
            for h, (r, n) in enumerate(zip(data["hist_runs"], data["hist_steps"],
                                           strict=True)):
                s = s0 + int(r)
                n = int(n)
                for name in HISTORIES:
                    block = data[name][h, :n]
                    if block.shape[1]:  # moving forces only: no contact histories
                        self.vars[name][s, i_t, i_i, :n, : block.shape[1]] = block

    def close(self, attrs: dict) -> None:
        """Write the global attributes and close the file."""
        for k, v in attrs.items():
            self.nc.setncattr(k, v)
        self.nc.close()

    def abort(self) -> None:
        """Close the file without finishing it (the caller deletes it)."""
        try:
            self.nc.close()
        except Exception:  # noqa: BLE001 - already failing; the file is discarded
            pass
