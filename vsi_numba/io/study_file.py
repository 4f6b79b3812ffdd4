"""The study results file, written by slices (never assembled in memory).

:class:`StudyFile` creates the CF netCDF-4 file with every dimension and variable of the
study preallocated (``_FillValue`` NaN for floats), then takes finished batches one at a
time and writes each run into its slice (the envelopes of consecutive batches of one
train and realisation in one slice).  Peak memory is one batch and the envelopes of one
train and realisation, whatever the size of the study.  The layout (names, dims,
attributes, encodings) is the one :mod:`vsi_numba.io.netcdf` documents and
``xarray.open_dataset`` reads back:

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
from vsi_numba.io.schema import (
    ALL_TRACKS,
    DIAGNOSTICS,
    ENVELOPES,
    HISTORIES,
    SPACE_ENVELOPES,
    SPACE_HISTORIES,
    attrs_for,
    loading_attrs,
)

#: Non-dimension coordinates and their dims.
_COORDS = {
    "speed_kmh": ("speed",),
    "wheel_position": ("train", "wheel"),
    "static_wheel_load": ("train", "wheel"),
    "vehicle_name": ("train", "vehicle"),
}



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
    points : list of ndarray
        Deck output points (m), one array per variant (one in all without variants).
    frequencies : list of ndarray
        Bridge natural frequencies (Hz), one array per variant.
    n_wheel, n_vehicle : int
        Largest wheel and vehicle counts over the trains.
    n_time : int or None
        Time steps + 1 of the longest run that keeps histories (None: no histories).
    dt : float or sequence of float
        Time step (s), or one per variant: when they differ, ``time`` is the step index
        and ``variant_time`` (variant, time) each variant's time (s).
    trains_info : list of dict
        Per variant: ``wheel_position`` and ``static_wheel_load`` (lists per train, m and
        N), ``vehicle_name`` (lists per train), ``regular_length``, ``status``,
        ``max_static_deck_displacement`` (n_train, n_point).
    deck_x, supports : list of ndarray, optional
        Per variant: the whole-deck grid of the load-effect envelopes and the support
        abscissae (m), for the ``deck_x`` and ``support`` dims (default: none; the
        load-effect variables then have those dims of length 0).
    variants : dict, optional
        A study of variants: ``coords`` maps a coordinate name to ``(values, attrs)``
        (one value per variant), ``bridge_length`` and ``acceleration_cutoff`` (one per
        variant), ``config_json`` (the resolved configuration of each variant).
    damping : tuple, optional
        ``(ratios, additional)``: per variant the modal damping ratios the runs used
        (per mode) and the moving-force trains' additional damping; written as
        ``damping_ratio`` (mode) and ``additional_damping`` () without variants (with
        variants they come from ``variants``).
    loading : str, optional
        How the trains of ``train.other_trains`` are in the runs
        (:func:`~vsi_numba.io.schema.loading_attrs`: None, ``"superposed"`` or
        ``"together"``): the variables' ``loading`` attribute says what each holds.
    """

    def __init__(self, path, speeds_kmh, trains, irregularities, points, frequencies,
                 n_wheel, n_vehicle, n_time, dt, trains_info, variants=None, deck_x=None,
                 supports=None, omit=None, space=None, damping=None, loading=None):
        import netCDF4

        self.loading = loading
        #: variables not written (the study's model does not compute them) -> reason
        self.omit = dict(omit or {})
        #: written case variables -> whether a finite value went in (see :meth:`close`)
        self.found: dict[str, bool] = {}

        self.nc = netCDF4.Dataset(path, "w", format="NETCDF4")
        nc = self.nc
        # auxiliary coordinates (name -> dims) named in the variables' ``coordinates``
        self.aux = dict(_COORDS)
        if variants is not None:
            self.aux = {"speed_kmh": ("speed",),
                        **{k: ("variant",) for k in variants["coords"]},
                        **{k: ("variant", *d) for k, d in _COORDS.items() if k != "speed_kmh"}}
            if not all(np.array_equal(points[0], p) for p in points):
                self.aux["point_position"] = ("variant", "point")
            if np.unique(np.atleast_1d(np.asarray(dt, float))).size > 1:
                self.aux["variant_time"] = ("variant", "time")
        speeds_kmh = np.asarray(speeds_kmh, float)
        n_s, n_t, n_i = speeds_kmh.size, len(trains), len(irregularities)
        self.lead = ("variant",) if variants is not None else ()
        self.case_dims = (*self.lead, *CASE_DIMS)
        n_v = len(points)
        shared_points = all(np.array_equal(points[0], p) for p in points)
        n_p = max(len(p) for p in points)
        n_m = max(len(f) for f in frequencies)
        sizes = {"speed": n_s, "train": n_t, "irregularity": n_i, "point": n_p,
                 "wheel": n_wheel, "vehicle": n_vehicle, "mode": n_m}
        deck_x = [np.zeros(0)] * n_v if deck_x is None else [np.asarray(a, float)
                                                              for a in deck_x]
        supports = [np.zeros(0)] * n_v if supports is None else [np.asarray(a, float)
                                                                  for a in supports]
        sizes["deck_x"] = max(a.size for a in deck_x)
        sizes["support"] = max(a.size for a in supports)
        # a deck in space (per variant: solver.batch.SpaceLayout, or None): the track and
        # twist-window dims, only then (planar studies keep their variables as they are)
        self.space = None if space is None or all(x is None for x in space) else [
            x for x in space]
        if self.space is not None:
            first = next(x for x in self.space if x is not None)
            twist_xs = [np.asarray(x.twist_x if x is not None else [], float)
                        for x in self.space]
            sizes["track"] = max(x.n_tracks for x in self.space if x is not None)
            sizes["twist_x"] = max(a.size for a in twist_xs)
        if variants is not None:
            sizes = {"variant": n_v, **sizes}
        if n_time is not None:
            sizes["time"] = n_time
        self.sizes = sizes
        self.n_points = [len(p) for p in points]
        for dim, size in sizes.items():
            nc.createDimension(dim, size)
        lead = self.lead

        def coord(name, dims, values, dtype, attrs):
            var = nc.createVariable(name, dtype, dims)
            var[...] = values
            _put_attrs(var, attrs)
            return var

        def per_variant(arrays, width, fill=np.nan):
            """Stack one array per variant (padded), or the single one without variants."""
            out = np.full((n_v, *width), fill, dtype=object if fill == "" else float)
            for k, a in enumerate(arrays):
                a = np.asarray(a, dtype=out.dtype)
                out[(k, *[slice(0, s) for s in a.shape])] = a
            return out if variants is not None else out[0]

        if variants is not None:
            coord("variant", ("variant",), np.arange(n_v, dtype=np.int64), "i8",
                  attrs_for("variant"))
            for name, (values, attrs) in variants["coords"].items():
                values = np.asarray(values)
                kind = str if values.dtype.kind in "OUS" else "f8"
                coord(name, ("variant",), values.astype(object) if kind is str else values,
                      kind, attrs)
            for name in ("bridge_length", "acceleration_cutoff", "additional_damping"):
                self._float(name, ("variant",), attrs_for(name))[...] = np.asarray(
                    variants[name], float)
            n_m0 = max(len(f) for f in frequencies)
            self._float("damping_ratio", ("variant", "mode"), attrs_for("damping_ratio"))[
                ...] = per_variant(variants["damping"], (n_m0,))
            for name, key in (("damping_rule", "damping_rule"),
                              ("variant_config_json", "config_json")):
                var = nc.createVariable(name, str, ("variant",))
                var[...] = np.array(list(variants[key]), dtype=object)
                _put_attrs(var, attrs_for(name))
        coord("speed", ("speed",), speeds_kmh / 3.6, "f8", attrs_for("speed"))
        coord("speed_kmh", ("speed",), speeds_kmh, "f8", attrs_for("speed_kmh"))
        coord("train", ("train",), np.array(list(trains), dtype=object), str,
              attrs_for("train"))
        coord("irregularity", ("irregularity",), np.asarray(irregularities, np.int64), "i8",
              attrs_for("irregularity"))
        if shared_points:
            coord("point", ("point",), np.asarray(points[0], float), "f8", attrs_for("point"))
        else:  # the points move with the spans: an index, and their x per variant
            coord("point", ("point",), np.arange(n_p, dtype=np.int64), "i8",
                  {"units": "1", "long_name": "output point index (x: point_position)"})
            self._float("point_position", (*lead, "point"), attrs_for("point"))[...] = \
                per_variant(points, (n_p,))
        per_dim = [("deck_x", deck_x), ("support", supports)]
        if self.space is not None:
            per_dim.append(("twist_x", twist_xs))
            coord("track", ("track",), np.arange(1, sizes["track"] + 1, dtype=np.int64),
                  "i8", attrs_for("track"))
            if np.isfinite(first.eccentricity).all():  # imported decks: when given
                ecc = np.full(sizes["track"], np.nan)
                ecc[:first.n_tracks] = first.eccentricity
                self._float("track_eccentricity", ("track",),
                            attrs_for("track_eccentricity"))[...] = ecc
            if first.lines:
                coord("track_line", ("track",), np.array(list(first.lines), dtype=object),
                      str, attrs_for("track_line"))
        for dim, per in per_dim:
            if all(np.array_equal(per[0], a) for a in per):
                coord(dim, (dim,), per[0], "f8", attrs_for(dim))
            else:  # they move with the spans: an index, and their x per variant
                coord(dim, (dim,), np.arange(sizes[dim], dtype=np.int64), "i8",
                      {"units": "1", "long_name": f"{dim} index (x: {dim}_position)"})
                self._float(f"{dim}_position", (*lead, dim), attrs_for(dim))[...] = \
                    per_variant(per, (sizes[dim],))
        coord("wheel", ("wheel",), np.arange(n_wheel, dtype=np.int64), "i8",
              attrs_for("wheel"))
        coord("vehicle", ("vehicle",), np.arange(n_vehicle, dtype=np.int64), "i8",
              attrs_for("vehicle"))
        coord("mode", ("mode",), np.arange(1, n_m + 1, dtype=np.int64), "i8",
              attrs_for("mode"))
        if n_time is not None:
            dts = np.atleast_1d(np.asarray(dt, float))
            if np.all(dts == dts[0]):
                coord("time", ("time",), np.arange(n_time) * dts[0], "f8", attrs_for("time"))
            else:  # variants of different time steps: each its own time axis
                coord("time", ("time",), np.arange(n_time, dtype=np.int64), "i8",
                      {"units": "1", "long_name": "time step index (time: variant_time)"})
                self._float("variant_time", ("variant", "time"), attrs_for("time"))[...] = \
                    dts[:, None] * np.arange(n_time)[None, :]

        wps, q0s, names = [], [], []
        for info in trains_info:
            wp = np.full((n_t, n_wheel), np.nan)
            q0 = np.full((n_t, n_wheel), np.nan)
            nm = np.full((n_t, n_vehicle), "", dtype=object)
            for t in range(n_t):
                a, b = info["wheel_position"][t], info["static_wheel_load"][t]
                wp[t, : len(a)] = a
                q0[t, : len(b)] = b
                v = list(info["vehicle_name"][t])
                nm[t, : len(v)] = v
            wps.append(wp)
            q0s.append(q0)
            names.append(nm)
        self._float("wheel_position", (*lead, "train", "wheel"),
                    attrs_for("wheel_position"))[...] = per_variant(wps, (n_t, n_wheel))
        self._float("static_wheel_load", (*lead, "train", "wheel"),
                    attrs_for("static_wheel_load"))[...] = per_variant(q0s, (n_t, n_wheel))
        coord("vehicle_name", (*lead, "train", "vehicle"),
              per_variant(names, (n_t, n_vehicle), fill=""), str, attrs_for("vehicle_name"))

        case = self.case_dims
        self.vars = {}
        self._staged = None  # write_batch's gathered slices
        for name, (dims, *_rest) in ENVELOPES.items():
            if name in self.omit:
                continue
            self.vars[name] = self._float(name, (*case, *dims), self._attrs(name))
            self.found[name] = False
        for name, (dims, *_rest) in SPACE_ENVELOPES.items():
            if self.space is None or name in self.omit:
                continue
            self.vars[name] = self._float(name, (*case, *dims), self._attrs(name))
            self.found[name] = False
        for name, (dims, *_rest) in ALL_TRACKS.items():
            if name in self.omit or not set(dims) <= set(sizes):  # per-track: a deck in space
                continue
            self.vars[name] = self._float(name, (*case, *dims), self._attrs(name))
            self.found[name] = False
        for name in DIAGNOSTICS:
            var = nc.createVariable(name, "i4", case)
            _put_attrs(var, {**attrs_for(name), "coordinates": self._coords_attr(case)})
            self.vars[name] = var
        if n_time is not None:
            space_histories = SPACE_HISTORIES.items() if self.space is not None else ()
            for name, (dims, *_rest) in (*HISTORIES.items(), *space_histories):
                if name in self.omit:
                    continue
                self.found[name] = False
                full = (*case, *dims)
                chunks = tuple(1 if d in case else
                               max(1, min(sizes[d], MAX_TIME_CHUNK)) if d == "time" else
                               max(1, sizes[d]) for d in full)
                attrs = self._attrs(name)
                if name == "in_contact":
                    attrs = {**attrs, "flag_values": np.array([0.0, 1.0], np.float32),
                             "comment": "NaN where the train has no such wheel (or the wheel "
                             "is a prescribed moving force) or the run no such step"}
                kw = {}
                if 0 not in [sizes[d] for d in full]:
                    kw["chunksizes"] = chunks
                var = nc.createVariable(name, "f4", full, zlib=True, complevel=4,
                                        shuffle=True, fill_value=np.float32(np.nan), **kw)
                _put_attrs(var, {**attrs, "coordinates": self._coords_attr(full)})
                self.vars[name] = var
        msg = nc.createVariable("message", str, case)
        _put_attrs(msg, {**attrs_for("message"), "coordinates": self._coords_attr(case)})
        self.vars["message"] = msg
        self._float("max_static_deck_displacement", (*lead, "train", "point"),
                    attrs_for("max_static_deck_displacement"))[...] = per_variant(
            [i["max_static_deck_displacement"] for i in trains_info], (n_t, n_p))
        info = trains_info[0]
        self._float("train_regular_length", ("train",), attrs_for("train_regular_length"))[
            ...] = np.asarray(info["regular_length"], float)
        status = nc.createVariable("train_status", str, ("train",))
        status[...] = np.array([str(s) for s in info["status"]], dtype=object)
        _put_attrs(status, attrs_for("train_status"))
        self._float("frequency", (*lead, "mode"), attrs_for("frequency"))[...] = per_variant(
            frequencies, (n_m,))
        if damping is not None and variants is None:  # the values the runs used
            ratios, additional = damping
            self._float("damping_ratio", ("mode",), attrs_for("damping_ratio"))[...] = \
                per_variant(ratios, (n_m,))
            self._float("additional_damping", (), attrs_for("additional_damping"))[...] = \
                float(np.ravel(np.asarray(additional, float))[0])

    def _attrs(self, name: str) -> dict:
        """The CF attributes of a case variable, with what loads it (``loading``)."""
        return loading_attrs(name, attrs_for(name), self.loading)

    def _coords_attr(self, dims) -> str:
        """CF ``coordinates`` attribute: the auxiliary coordinates a variable spans."""
        return " ".join(n for n, d in self.aux.items() if set(d) <= set(dims))

    def _float(self, name, dims, attrs):
        var = self.nc.createVariable(name, "f8", dims, fill_value=np.nan)
        coords = self._coords_attr(dims) if name not in self.aux else ""
        _put_attrs(var, {**attrs, **({"coordinates": coords} if coords else {})})
        return var

    def write_batch(self, batch, data: dict, n_wheel: int, n_vehicle: int) -> None:
        """Write the runs of one finished batch (:func:`~vsi_numba.study.batches.
        run_batch_task` output) into their slices; the train has ``n_wheel`` wheels and
        ``n_vehicle`` vehicles.

        The envelopes, diagnostics and messages of consecutive batches of one train and
        realisation (and variant) whose speeds follow on are gathered and written in one
        slice per variable (:meth:`flush`): netCDF's per-write cost, not the data, is
        what a batch of a few runs pays for (the 570 ICE3 runs in 90 batches: ~4,300
        writes of a few numbers each).  The histories are written at once."""
        i_t, i_i = batch.i_train, batch.i_irregularity
        s0, s1 = batch.speeds[0], batch.speeds[-1] + 1
        if list(batch.speeds) != list(range(s0, s1)):
            raise ValueError(f"batch {batch.key}: speeds are not contiguous")
        v = (batch.variant,) if self.lead else ()
        n_p = self.n_points[batch.variant or 0]
        parts = {}
        for name, (dims, *_rest) in ENVELOPES.items():
            if name in self.omit:
                continue
            if not dims:  # one value per case
                parts[name] = (None, np.asarray(data[name], float))
                continue
            width = min({"point": n_p, "wheel": n_wheel, "vehicle": n_vehicle}.get(
                dims[0], data[name].shape[1]), data[name].shape[1])
            if width:  # 0: not computed (load effects off or not available)
                parts[name] = (width, data[name][:, :width])
        if self.space is not None:
            for name, (dims, *_rest) in SPACE_ENVELOPES.items():
                if name in self.omit or name not in data:
                    continue
                a = np.asarray(data[name], float)
                block = np.full((a.shape[0], *(self.sizes[d] for d in dims)), np.nan)
                block[(slice(None), *(slice(0, n) for n in a.shape[1:]))] = a
                parts[name] = (None, block)
        for name, (dims, *_rest) in ALL_TRACKS.items():
            if name not in self.vars or name not in data:
                continue
            a = np.asarray(data[name], float)
            block = np.full((a.shape[0], *(self.sizes[d] for d in dims)), np.nan)
            block[(slice(None), *(slice(0, k) for k in a.shape[1:]))] = a
            parts[name] = (None, block)
        for name in DIAGNOSTICS:
            parts[name] = (None, data[name].astype(np.int32))
        parts["message"] = (None, np.array([str(m) for m in data["message"]], dtype=object))
        group = (v, i_t, i_i, {k: w for k, (w, _) in parts.items()})
        st = self._staged
        if st is not None and (st["group"] != group or st["s1"] != s0):
            self.flush()
            st = None
        if st is None:
            self._staged = st = {"group": group, "s0": s0, "s1": s0,
                                 "parts": {k: [] for k in parts}}
        for k, (_, a) in parts.items():
            st["parts"][k].append(a)
        st["s1"] = s1
        if "hist_runs" in data and "time" in self.sizes:
            for h, (r, n) in enumerate(zip(data["hist_runs"], data["hist_steps"],
                                           strict=True)):
                s = s0 + int(r)
                n = int(n)
                for name in (*HISTORIES, *SPACE_HISTORIES):
                    if data.get(name) is None or name not in self.vars:  # not computed
                        continue
                    block = data[name][h, :n]
                    if block.shape[1]:  # moving forces only: no contact histories
                        if not self.found[name]:
                            self.found[name] = bool(np.isfinite(block).any())
                        self.vars[name][(*v, s, i_t, i_i, slice(0, n),
                                         *(slice(0, k) for k in block.shape[1:]))] = block

    def flush(self) -> None:
        """Write the gathered envelopes, diagnostics and messages (:meth:`write_batch`)."""
        st, self._staged = self._staged, None
        if st is None:
            return
        v, i_t, i_i, widths = st["group"]
        speeds = slice(st["s0"], st["s1"])
        for name, arrays in st["parts"].items():
            block = np.concatenate(arrays)
            width = widths[name]
            if self.found.get(name) is False and block.dtype.kind == "f":
                self.found[name] = bool(np.isfinite(block).any())
            if width is None:
                self.vars[name][(*v, speeds, i_t, i_i)] = block
            else:
                self.vars[name][(*v, speeds, i_t, i_i, slice(0, width))] = block

    def close(self, attrs: dict) -> None:
        """Write what is gathered and the global attributes, and close the file."""
        self.flush()
        for k, v in attrs.items():
            self.nc.setncattr(k, v)
        self.nc.close()

    def abort(self) -> None:
        """Close the file without finishing it (the caller deletes it)."""
        try:
            self.nc.close()
        except Exception:  # noqa: BLE001 - already failing; the file is discarded
            pass
