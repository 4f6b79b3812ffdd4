"""Bring a results Dataset (single run or study) to the full study layout.

Every results file written by this version (``vsi sweep``, and ``vsi run``, which is the
study engine restricted to one case) has every case variable on the leading dims
``(speed, train, irregularity)``; :func:`prepare` then only NaN-masks the cases whose
``status`` is not 0.  Files of earlier versions of ``vsi run``, and datasets made by hand,
may lack ``train`` and ``irregularity`` (one train, one realisation) or even ``speed``
(a scalar coordinate): :func:`prepare` adds the missing dims (length 1) to exactly the
variables that carry them in a study, and ``speed_kmh`` when it is missing, so every
analysis function can assume one layout.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

#: Leading dims of every per-case variable, in this order.
CASE_DIMS = ("speed", "train", "irregularity")

#: Variables that depend on the train only.
TRAIN_VARIABLES = frozenset(
    {"static_wheel_load", "max_static_deck_displacement", "train_regular_length", "train_status",
     "wheel_position", "vehicle_name"}
)

#: Dims of variables that belong to the bridge alone (no case dims).
BRIDGE_DIMS = frozenset({"mode"})

#: Irregularity id of the deterministic (smooth or single-defect) track.
DETERMINISTIC = -1

#: Default values for dims a single-run file may lack.
_DEFAULTS = {"train": "train", "irregularity": DETERMINISTIC}


class ResultsError(ValueError):
    """A results Dataset that lacks what an analysis needs (the message says what)."""


def require(ds: xr.Dataset, names, what: str) -> None:
    """Raise :class:`ResultsError` naming every variable of ``names`` missing from ``ds``."""
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise ResultsError(
            f"{what} needs the variable(s) {', '.join(missing)}, which the results lack"
        )


#: Variables of the schema that hold text, not numbers.
_TEXT_VARIABLES = frozenset({"message", "train_status", "damping_rule", "variant_config_json",
                             "vehicle_name", "train", "variant"})

#: Dims whose coordinate values the analyses use as positions (m) or times (s).
_POSITION_DIMS = {"point": "x of the output points, m", "deck_x": "x of the whole-deck "
                  "sections, m", "support": "x of the supports, m", "time": "time, s"}


def _shown(values, n: int = 4) -> str:
    values = np.ravel(np.asarray(values, dtype=object)).tolist()
    text = ", ".join(repr(v) if isinstance(v, str) else f"{v:g}" if isinstance(v, float)
                     else str(v) for v in values[:n])
    return text + (f", ... ({len(values)} values)" if len(values) > n else "")


def _schema_dims() -> dict[str, tuple[str, ...]]:
    """name -> the dims a variable of the results schema has after the case dims."""
    from vsi_numba.io.schema import DIAGNOSTICS, ENVELOPES, HISTORIES

    return {name: tuple(d) if isinstance(d, tuple) else (d,) if d else ()
            for name, (d, *_r) in {**ENVELOPES, **DIAGNOSTICS, **HISTORIES}.items()}


def validate(ds: xr.Dataset) -> None:
    """Refuse, with what is wrong, a file the analyses cannot use (a foreign or edited
    netCDF file): raises :class:`ResultsError`.

    Checked: ``speed`` numeric, finite, positive, distinct and not empty; ``train`` and
    ``irregularity`` values distinct; every variable of the results schema numeric (text
    variables excepted) and on its dims; a coordinate for every position dim (``point``,
    ``deck_x``, ``support``, ``time``) a variable uses, numeric and finite; ``frequency``
    numeric with a finite positive value when the load-effect envelopes need it; the
    stored configuration's values the checks read (``study.classification_factor``,
    ``bridge.spans``) numbers.
    """
    import json

    sp = ds["speed"]
    if sp.ndim > 1 or (sp.ndim == 1 and sp.dims != ("speed",)):
        raise ResultsError(f"`speed` is on the dims {sp.dims}; expected the dimension "
                           "`speed` (m s-1)")
    if sp.dtype.kind not in "fiu":
        raise ResultsError(f"`speed` holds {sp.dtype} values ({_shown(sp.values)});"
                           " expected numbers (m s-1)")
    v = np.atleast_1d(np.asarray(sp.values, float))
    if v.size == 0:
        raise ResultsError("`speed` is empty: the results hold no case")
    bad = v[~(np.isfinite(v) & (v > 0))]
    if bad.size:
        raise ResultsError(f"`speed` has {bad.size} value(s) that are not finite and "
                           f"positive ({_shown(bad.tolist())}); expected train speeds > 0 "
                           "(m s-1)")
    if np.unique(v).size != v.size:
        dup = sorted({x for x in v.tolist() if v.tolist().count(x) > 1})
        raise ResultsError(f"`speed` repeats the value(s) {_shown(dup)} m s-1: each case "
                           "must have its own speed")
    if "speed_kmh" in ds.variables and ds["speed_kmh"].dims not in ((), ("speed",)):
        raise ResultsError(f"`speed_kmh` is on the dims {ds['speed_kmh'].dims}; expected "
                           "(speed)")
    for dim in ("train", "irregularity", "variant"):
        if dim in ds.variables and ds[dim].ndim == 1:
            vals = [x.item() if hasattr(x, "item") else x for x in ds[dim].values]
            if len(set(map(str, vals))) != len(vals):
                dup = sorted({str(x) for x in vals if list(map(str, vals)).count(str(x)) > 1})
                raise ResultsError(f"`{dim}` repeats {_shown(dup)}: each {dim} must be named "
                                   "once")
    schema = _schema_dims()
    case = set(CASE_DIMS) | {"variant"}
    for name, da in ds.variables.items():
        if name in _TEXT_VARIABLES or name in CASE_DIMS or name == "speed_kmh":
            continue
        if name in schema or name in _POSITION_DIMS or name == "frequency":
            if da.dtype.kind not in "fiub":
                raise ResultsError(f"`{name}` holds {da.dtype} values, not numbers: "
                                   "expected the numbers of the results schema "
                                   f"({da.attrs.get('units', 'see vsi_numba.io.schema')})")
        if name in schema:
            own = tuple(d for d in da.dims if d not in case)
            if own != schema[name]:
                raise ResultsError(f"`{name}` is on the dims {da.dims}; expected the case "
                                   f"dims followed by {schema[name] or '(nothing)'}")
    used = {d for da in ds.data_vars.values() for d in da.dims}
    for dim, what in _POSITION_DIMS.items():
        if dim in used and ds.sizes.get(dim, 0):
            if dim not in ds.variables:
                users = [n for n, da in ds.data_vars.items() if dim in da.dims][:3]
                raise ResultsError(f"the results have no `{dim}` coordinate ({what}) for the "
                                   f"dim {dim} of {', '.join(users)}")
            x = ds[dim]
            if x.dtype.kind not in "fiu" or not np.isfinite(np.asarray(x.values,
                                                                       float)).all():
                raise ResultsError(f"the `{dim}` coordinate ({what}) holds "
                                   f"{_shown(x.values)}: expected finite "
                                   "numbers")
    from vsi_numba.io.schema import LOAD_EFFECTS

    if any(f"max_{n}" in ds.variables for n in LOAD_EFFECTS):
        f = (np.asarray(ds["frequency"].values, float).ravel() if "frequency" in ds.variables
             else np.zeros(0))
        if not (np.isfinite(f) & (f > 0)).any():
            raise ResultsError("the load-effect checks need the bridge's first natural "
                               "frequency, and the results have no finite positive "
                               "`frequency` (Hz)")
    try:
        cfg = json.loads(str(ds.attrs.get("config_json", "") or "{}"))
    except ValueError:
        cfg = {}
    cfg = cfg if isinstance(cfg, dict) else {}
    study = cfg.get("study") if isinstance(cfg.get("study"), dict) else {}
    bridge = cfg.get("bridge") if isinstance(cfg.get("bridge"), dict) else {}

    def number(x) -> bool:
        return (isinstance(x, int | float) and not isinstance(x, bool)
                and bool(np.isfinite(x)))

    alpha = study.get("classification_factor")
    if alpha is not None and not (number(alpha) and alpha > 0):
        raise ResultsError(f"the stored configuration (attribute config_json) has "
                           f"study.classification_factor = {alpha!r}; expected a number > 0")
    maintenance = study.get("track_maintenance")
    if maintenance is not None:
        from vsi_numba.en1991 import TRACK_MAINTENANCE

        if not isinstance(maintenance, str) or maintenance not in TRACK_MAINTENANCE:
            raise ResultsError(
                "the stored configuration (attribute config_json) has "
                f"study.track_maintenance = {maintenance!r}; expected one of "
                + ", ".join(f"'{k}'" for k in TRACK_MAINTENANCE))
    spans = bridge.get("spans")
    if spans is not None and not all(number(x) and x > 0 for x in np.ravel(
            np.asarray(spans, dtype=object))):
        raise ResultsError(f"the stored configuration (attribute config_json) has "
                           f"bridge.spans = {spans!r}; expected span lengths > 0 (m)")


def is_prepared(ds: xr.Dataset) -> bool:
    """True when ``ds`` came out of :func:`prepare`."""
    return bool(ds.attrs.get("_vsi_prepared", 0))


def prepare(ds: xr.Dataset) -> xr.Dataset:
    """Return ``ds`` in the full study layout (idempotent).

    Parameters
    ----------
    ds : xarray.Dataset
        Results of ``vsi run`` or ``vsi sweep`` (see ``vsi_numba.io.schema``).

    Returns
    -------
    xarray.Dataset
        Every per-case variable on ``(speed, train, irregularity, ...)``, train variables
        on ``(train, ...)``, ``speed`` sorted ascending, ``speed_kmh`` present, ``status``
        present (0 when the file has none) and per-case outputs set to NaN where
        ``status != 0``.

    Raises
    ------
    ResultsError
        If there is no ``speed`` coordinate.
    """
    if is_prepared(ds):
        return ds
    if "speed" not in ds.variables:
        raise ResultsError("the results have no `speed` coordinate (m s-1)")
    validate(ds)
    # Train properties written as coordinates become variables, so they get the train dim.
    ds = ds.reset_coords([n for n in TRAIN_VARIABLES if n in ds.coords and n not in ds.dims])
    if "train_status" not in ds.variables and "train_status" in ds.attrs:  # `vsi run` file
        ds = ds.assign(train_status=((), str(ds.attrs["train_status"])))

    # Values of the dims to add, from scalar coordinates or defaults.
    added = {}
    for dim in CASE_DIMS:
        if dim in ds.dims:
            continue
        if dim in ds.variables:
            value = ds[dim].values
            if value.ndim != 0:
                raise ResultsError(f"`{dim}` is a variable on {ds[dim].dims}, not a dimension")
            added[dim] = [value.item()]
        elif dim in ds.attrs and np.ndim(ds.attrs[dim]) == 0:  # `vsi run`: attrs name them
            value = ds.attrs[dim]
            added[dim] = [int(value) if dim == "irregularity" else str(value)]
        elif dim in _DEFAULTS:
            added[dim] = [_DEFAULTS[dim]]
        else:  # pragma: no cover - speed is checked above
            raise ResultsError(f"the results have no `{dim}` dimension")
    drop = [d for d in added if d in ds.variables]
    if "speed" in added and "speed_kmh" in ds.variables and ds["speed_kmh"].ndim == 0:
        drop.append("speed_kmh")
    ds = ds.drop_vars(drop)

    data = {}
    for name, da in ds.data_vars.items():
        if name in TRAIN_VARIABLES:
            wanted = ("train",)
        elif set(da.dims) <= BRIDGE_DIMS:
            wanted = ()
        else:
            wanted = CASE_DIMS
        new = {d: added[d] for d in wanted if d not in da.dims and d in added}
        if new:
            da = da.expand_dims(new)
        lead = [d for d in wanted if d in da.dims]
        data[name] = da.transpose(*lead, ...)
    # one Dataset of them all: one alignment (adding them one by one aligned each)
    out = xr.Dataset(data, attrs=dict(ds.attrs))
    for name, coord in ds.coords.items():
        if name not in out.coords and (name in out.dims or set(coord.dims) <= set(out.dims)):
            out = out.assign_coords({name: coord})
    for dim, value in added.items():
        if dim not in out.coords:
            out = out.assign_coords({dim: value})
    for dim, attrs in (("train", {"long_name": "train name"}),
                       ("irregularity", {"long_name": "track irregularity realisation"})):
        if dim not in out.dims:  # no variable carried the dim: keep it on the coords anyway
            out = out.expand_dims({dim: added.get(dim, [_DEFAULTS[dim]])})
            out[dim].attrs.update(attrs)

    out = out.sortby("speed")
    if "speed_kmh" not in out.coords:
        out = out.assign_coords(speed_kmh=("speed", out["speed"].values * 3.6))
        out["speed_kmh"].attrs.update(units="km h-1", long_name="train speed")
    if "status" not in out.data_vars:
        shape = tuple(out.sizes[d] for d in CASE_DIMS)
        out["status"] = (CASE_DIMS, np.zeros(shape, dtype=np.int32))
        out["status"].attrs.update(
            long_name="analysis status", flag_values=[0], flag_meanings="ok"
        )
    ok = out["status"] == 0
    all_ok = bool(ok.all())  # once, not once per variable
    for name, da in out.data_vars.items():
        if name == "status" or not set(CASE_DIMS) <= set(da.dims):
            continue
        if "time" in da.dims:
            # time histories stay lazy (a file read lazily is never loaded whole): a
            # failed case's histories are NaN in the file already, and the report reads
            # them one case at a time
            continue
        if np.issubdtype(da.dtype, np.number) and not all_ok:
            out[name] = da.where(ok)
            out[name].attrs.update(da.attrs)
    out.attrs["_vsi_prepared"] = 1
    return out


def envelopes(ds: xr.Dataset) -> xr.Dataset:
    """The prepared results without the time histories, loaded into memory.

    Everything on the ``time`` dim is dropped; the rest (envelopes, per-case scalars,
    train and bridge data) is small whatever the study (no dim grows with the run
    length), so the checks and tables work on this while the histories stay in the file,
    read one case at a time.

    Parameters
    ----------
    ds : xarray.Dataset
        Results, read lazily or in memory (:func:`prepare` is applied first).

    Returns
    -------
    xarray.Dataset
        Prepared, in memory, without ``time`` and the variables on it.
    """
    ds = prepare(ds)
    timed = [n for n, v in ds.variables.items() if "time" in v.dims]
    return ds.drop_vars(timed).load()


def status_meanings(ds: xr.Dataset) -> dict[int, str]:
    """Map status code -> meaning from the ``flag_values``/``flag_meanings`` attrs."""
    attrs = ds["status"].attrs if "status" in ds else {}
    values = np.atleast_1d(attrs.get("flag_values", [0]))
    meanings = str(attrs.get("flag_meanings", "ok")).split()
    table = {int(v): m for v, m in zip(values, meanings, strict=False)}
    table.setdefault(0, "ok")
    return table


_TRACK_ALIASES = {
    "ballasted": "ballasted", "ballast": "ballasted",
    "direct_fastening": "direct_fastening", "direct_fastened": "direct_fastening",
    "direct fastening": "direct_fastening", "ballastless": "direct_fastening",
    "slab": "direct_fastening", "slab_track": "direct_fastening",
}
_TRACK_UNSET = {"", "unspecified", "unknown", "none"}


def track_type(ds: xr.Dataset) -> str:
    """Track type from the ``track_type`` attribute: "ballasted" or "direct_fastening".

    Missing or "unspecified" gives "ballasted" (the stricter acceleration limit); see
    :func:`track_type_assumed`. Common aliases (ballastless, slab) are recognised; any
    other value is returned as is (the acceleration check then asks for a limit).
    """
    raw = str(ds.attrs.get("track_type", "")).strip().lower()
    if raw in _TRACK_UNSET:
        return "ballasted"
    return _TRACK_ALIASES.get(raw, raw)


def track_type_assumed(ds: xr.Dataset) -> bool:
    """True when the file does not state the track type (ballasted is then assumed)."""
    return str(ds.attrs.get("track_type", "")).strip().lower() in _TRACK_UNSET


def bridge_frequencies(ds: xr.Dataset) -> np.ndarray:
    """Natural frequencies (Hz), finite and positive, ascending; empty if unknown."""
    if "frequency" not in ds.variables:
        return np.zeros(0)
    f = np.asarray(ds["frequency"].values, float).ravel()
    return np.sort(f[np.isfinite(f) & (f > 0)])


# --- NaN-aware reductions without RuntimeWarnings (pytest runs with -W error) -------------


def nanmax(da: xr.DataArray, dim: str | list[str]) -> xr.DataArray:
    """Maximum over ``dim`` ignoring NaN; NaN where everything is NaN or ``dim`` is empty."""
    return _nanext(da, dim, "max")


def nanmin(da: xr.DataArray, dim: str | list[str]) -> xr.DataArray:
    """Minimum over ``dim`` ignoring NaN; NaN where everything is NaN or ``dim`` is empty."""
    return _nanext(da, dim, "min")


def _nanext(da, dim, how):
    dims = [dim] if isinstance(dim, str) else list(dim)
    da = da.astype(float)
    if any(da.sizes[d] == 0 for d in dims):
        return da.sum(dims) * np.nan
    fill = -np.inf if how == "max" else np.inf
    out = getattr(da.fillna(fill), how)(dims)
    return out.where(out != fill)


def nanargmax_case(da: xr.DataArray) -> dict | None:
    """Coordinates of the largest finite value of ``da`` (any dims), or None if all NaN."""
    values = np.asarray(da.values, float)
    if values.size == 0 or not np.isfinite(values).any():
        return None
    flat = np.where(np.isfinite(values), values, -np.inf).argmax()
    index = np.unravel_index(flat, values.shape)
    return {d: _scalar(da[d].values[i]) for d, i in zip(da.dims, index, strict=True)}


def _scalar(value):
    """A numpy scalar (or a Python object from an object array) as a Python scalar."""
    return value.item() if hasattr(value, "item") else value


#: Result of a check computed under a time-step resolution warning (never "pass").
NOT_RELIABLE = "not reliable"


def stored_warnings(ds: xr.Dataset) -> list[dict]:
    """The configuration warnings a results file carries, as records {"message", "kind",
    "keys"}: from ``warnings_json``, else one record per line of ``config_warnings``
    (kind "resolution" when the line is a time-step resolution warning)."""
    raw = ds.attrs.get("warnings_json")
    if raw:
        try:
            recs = json.loads(str(raw))
            if isinstance(recs, list):
                return [r for r in recs if isinstance(r, dict) and "message" in r]
        except ValueError:
            pass
    text = str(ds.attrs.get("config_warnings", "") or "")
    return [{"message": line, "keys": [],
             "kind": "resolution" if ("under-resolve" in line and "solver.dt" in line)
             else "input"} for line in text.splitlines() if line.strip()]
