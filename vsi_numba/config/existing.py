"""``[calibration]`` and ``[reliability]``: the sections of existing bridges.

```toml
[calibration]                     # vsi calibrate CONFIG -o POSTERIOR.nc
parameters = [
  { key = "bridge.EI", prior = "lognormal", median = 2.0e10, cov = 0.2 },
  { key = "bridge.damping_ratio", prior = "uniform", lower = 0.005, upper = 0.05 },
]
[[calibration.records]]
file = "passage_01.csv"           # columns t (s), value; '#' comments
quantity = "deck_acceleration"    # or "deck_displacement"
point = 10.0
train = "HSLM-A1"
speed_kmh = 250.0

[reliability]                     # vsi reliability CONFIG -o RELIABILITY.nc
check = "deck_acceleration"
method = "subset"                 # or "monte_carlo"
target_cov = 0.1
variables = [
  { key = "bridge.damping_ratio", distribution = "lognormal", median = 0.015, cov = 0.3 },
]
```

The keys are declared in :mod:`vsi_numba.config.schema.models` (``Calibration``,
``CalibrationParameter``, ``CalibrationRecord``, ``Reliability``,
``ReliabilityVariable``); the readers here keep the cross-key rules: the parameters a
distribution needs, a key path that names a numeric key of the configuration (the
configuration with the key set to its central value must validate), readable records.
:mod:`vsi_numba.config.core` calls :func:`_calibration_section` and
:func:`_reliability_section`.
"""

from __future__ import annotations

import copy
from pathlib import Path

from vsi_numba.config._check import _BAD, _MISSING, ConfigError, _ok, _show
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import keys_of

#: The parameters each distribution takes.
NEEDS = {"uniform": ("lower", "upper"), "normal": ("mean", "std"),
         "lognormal": ("median", "cov")}
#: Sections whose numeric keys may be parameters or random variables.
KEY_SECTIONS = ("bridge", "train", "solver", "track", "contact", "irregularity")
#: Sections a trial configuration (the base with a key set) leaves out.
OWN_SECTIONS = ("calibration", "reliability")
#: Largest number of parameters (and of random variables).
MAX_PARAMETERS = 20
#: Largest number of records of a calibration.
MAX_RECORDS = 50


def central_value(spec: dict) -> float:
    """The central value of a distribution (median, mean or mid-range)."""
    kind = spec.get("prior", spec.get("distribution"))
    if kind == "lognormal":
        return float(spec["median"])
    if kind == "normal":
        return float(spec["mean"])
    return 0.5 * (float(spec["lower"]) + float(spec["upper"]))


def base_data(data: dict) -> dict:
    """A deep copy of the configuration's mapping without its own sections."""
    return {k: copy.deepcopy(v) for k, v in data.items() if k not in OWN_SECTIONS}


def _distribution(chk, item: dict, path: str, kind_key: str) -> dict | object:
    """Check the parameters of one distribution (those its kind needs, no others)."""
    kind = item[kind_key]
    need = NEEDS[kind]
    bad = False
    for k in need:
        if item.get(k) is None:
            chk.error(f"{path}.{k}", _MISSING, f"the {k} of a {kind} distribution")
            bad = True
    for k in sorted(set().union(*NEEDS.values()) - set(need)):
        if item.get(k) is not None:
            chk.error(f"{path}.{k}", item[k], f"no {k} for a {kind} distribution (it takes "
                      f"{' and '.join(need)})")
            bad = True
    if not bad and kind == "uniform" and not item["lower"] < item["upper"]:
        chk.error(f"{path}.upper", item["upper"], f"an upper bound > lower = "
                  f"{item['lower']:g}")
        bad = True
    return _BAD if bad else item


def _trial(data, base, set_keys: dict, validate):
    """Validate the base configuration with ``set_keys`` set (``validate``: the
    validator of :mod:`vsi_numba.config.core`); the errors (or [])."""
    from vsi_numba.config.variants import _set_path

    trial = base_data(data)
    try:
        for k, v in set_keys.items():
            _set_path(trial, k, v)
    except KeyError as exc:
        return [f"key path not found: {exc.args[0]}"]
    try:
        validate(trial, None, base, "<trial>")
    except ConfigError as exc:
        return list(exc.errors)
    return []


def _key_checks(chk, data, base, items, path: str, validate) -> None:
    """Each key path names a numeric key of the configuration: the base with the key at
    the distribution's central value validates; every key once."""
    seen = set()
    for i, it in enumerate(items):
        k = it["key"]
        p = f"{path}[{i}].key"
        if k in seen:
            chk.error(p, k, "each key once")
            continue
        seen.add(k)
        if k.split(".")[0].split("[")[0] not in KEY_SECTIONS:
            chk.error(p, k, "a numeric key of " + ", ".join(f"[{s}]" for s in KEY_SECTIONS))
            continue
        from vsi_numba.config.variants import _set_path

        probe = base_data(data)
        try:
            _set_path(probe, k, None)
        except KeyError as exc:
            chk.error(p, k, f"a numeric key of the configuration ({exc.args[0]})")
            continue
        errors = _trial(data, base, {k: central_value(it)}, validate)
        if errors:
            chk.error(p, k, f"a numeric key of the configuration (set to "
                      f"{central_value(it):g}: {errors[0]})")


def _records(chk, items, base: Path):
    from vsi_numba.io.records import RecordError, read_record

    out = []
    for i, r in enumerate(items):
        p = f"calibration.records[{i}]"
        f = Path(r["file"])
        f = f if f.is_absolute() else base / f
        try:
            read_record(f)
        except RecordError as exc:
            chk.error(f"{p}.file", r["file"], f"a readable record: {exc}")
            out = _BAD
            continue
        if out is not _BAD:
            out.append(dict(r))  # the file as written: resolved against base_dir by its reader
    return out


def _calibration_section(chk, d, data, base: Path, ok: bool, validate) -> dict | None:
    """Validate ``[calibration]``; None without it.  ``ok``: the rest of the
    configuration validated (the key paths and trains are checked against it then, with
    ``validate``, the validator of :mod:`vsi_numba.config.core`)."""
    if d is _MISSING:
        return None
    M = _m.Calibration
    if chk.table(d, "calibration", keys_of(M),
                 what=" [calibration] with parameters and records") is _BAD:
        return _BAD
    r = chk.fields(d, "calibration", M, [k for k in M.model_fields
                                          if k not in ("parameters", "records")])
    params = chk.table_list(d.get("parameters", _MISSING), "calibration.parameters",
                            _m.CalibrationParameter,
                            expected=f"a list of 1 to {MAX_PARAMETERS} tables {{key, prior, "
                                     "...}}", what=" {key, prior, ...}",
                            max_len=MAX_PARAMETERS)
    if _ok(params):
        params = [_distribution(chk, it, f"calibration.parameters[{i}]", "prior")
                  for i, it in enumerate(params)]
        params = params if _ok(*params) else _BAD
    records = chk.table_list(d.get("records", _MISSING), "calibration.records",
                             _m.CalibrationRecord,
                             expected=f"1 to {MAX_RECORDS} [[calibration.records]] tables "
                                      "{file, quantity, point, train[, speed_kmh]}",
                             what=" {file, quantity, point, train[, speed_kmh]}",
                             max_len=MAX_RECORDS)
    if _ok(records):
        records = _records(chk, records, base)
    n_par = len(params) if _ok(params) else 1
    if _ok(r["n_walkers"]) and r["n_walkers"] is not None:
        n_dim = n_par + (0 if r["noise_std"] is not None else 1)
        if r["n_walkers"] % 2 or r["n_walkers"] < 2 * n_dim:
            chk.error("calibration.n_walkers", r["n_walkers"],
                      f"an even number of walkers >= {2 * n_dim} (2 x the {n_dim} "
                      "parameters)")
    if not _ok(params, records, *r.values()):
        return _BAD
    if ok:
        _key_checks(chk, data, base, params, "calibration.parameters", validate)
        n_tracks = len(data["bridge"].get("tracks") or [{}]) if isinstance(
            data.get("bridge"), dict) else 1
        for i, rec in enumerate(records):
            track = rec.get("track")
            if track is not None and track > n_tracks:
                chk.error(f"calibration.records[{i}].track", track,
                          "no track for a deck of one track (bridge.tracks not given): "
                          "leave it out" if n_tracks == 1 else
                          f"a track of bridge.tracks, 1 .. {n_tracks}")
                continue
            try:
                validate(record_train_data(data, rec["train"], base, track), None, base,
                         "<trial>")
                errors = []
            except ConfigError as exc:
                errors = list(exc.errors)
            if errors:
                chk.error(f"calibration.records[{i}].train", rec["train"],
                          f"a library train (vsi trains) or an axle CSV file ({errors[0]})")
    return {**{k: v for k, v in r.items() if v is not None}, "parameters": params,
            "records": records}


def record_train_data(data: dict, train: str, base: Path, track: int | None = None) -> dict:
    """The base configuration's mapping running the record's train (as moving forces when
    the base's train is), on ``track`` when given (a deck in space)."""
    out = base_data(data)
    tr = dict(out.get("train", {}))
    model = tr.get("model")
    keep = {k: v for k, v in tr.items() if k in ("model", "track", "direction")}
    keep.pop("model", None)
    if train.lower().endswith(".csv") or (Path(base) / train).is_file():
        keep["file"] = train
    else:
        keep["preset"] = train
    if model is not None:
        keep["model"] = model
    if track is not None:
        keep["track"] = int(track)
    out["train"] = keep
    return out


def _reliability_section(chk, d, data, base: Path, ok: bool, validate) -> dict | None:
    """Validate ``[reliability]``; None without it."""
    if d is _MISSING:
        return None
    M = _m.Reliability
    if chk.table(d, "reliability", keys_of(M),
                 what=" [reliability] with check and variables") is _BAD:
        return _BAD
    r = chk.fields(d, "reliability", M, [k for k in M.model_fields if k != "variables"])
    var = chk.table_list(d.get("variables", _MISSING), "reliability.variables",
                         _m.ReliabilityVariable,
                         expected=f"a list of 1 to {MAX_PARAMETERS} tables {{key, "
                                  "distribution, ...}}", what=" {key, distribution, ...}",
                         max_len=MAX_PARAMETERS)
    if _ok(var):
        var = [_distribution(chk, it, f"reliability.variables[{i}]", "distribution")
               for i, it in enumerate(var)]
        var = var if _ok(*var) else _BAD
    if _ok(r["block_size"], r["max_runs"]) and r["block_size"] > r["max_runs"]:
        chk.error("reliability.block_size", r["block_size"],
                  f"at most reliability.max_runs = {r['max_runs']}")
    if not _ok(var, *r.values()):
        return _BAD
    if ok:
        _key_checks(chk, data, base, var, "reliability.variables", validate)
    return {**{k: v for k, v in r.items() if v is not None}, "variables": var}


__all__ = ["_calibration_section", "_reliability_section", "central_value", "_show"]
