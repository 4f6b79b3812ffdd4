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
``ReliabilityVariable``), with the rules between keys of one table (the parameters a
distribution needs, the walkers, the block of runs); the builders here take the validated
tables and check what needs context: a key path that names a numeric key of the
configuration (the configuration with the key set to its central value must validate),
readable records, the records' tracks and trains.  :mod:`vsi_numba.config.core` calls
:func:`_calibration_section` and :func:`_reliability_section`.
"""

from __future__ import annotations

import copy
from pathlib import Path

from pydantic import BaseModel, ValidationError

from vsi_numba.config._check import _BAD, ConfigError, _show
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema.models import MAX_PARAMETERS, MAX_RECORDS, NEEDS  # noqa: F401

#: Sections whose numeric keys may be parameters or random variables.
KEY_SECTIONS = ("bridge", "train", "solver", "track", "contact", "irregularity")
#: Sections a trial configuration (the base with a key set) leaves out.
OWN_SECTIONS = ("calibration", "reliability")


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


def _table(m: BaseModel) -> dict:
    """The keys of a validated table, defaults filled, those without a value left out."""
    return {k: getattr(m, k) for k in type(m).model_fields if getattr(m, k) is not None
            and not isinstance(getattr(m, k), list)}


def _records(chk, items, base: Path):
    """The records (as written: each file resolved against base_dir by its reader) whose
    files are readable records; ``_BAD`` when one is not (reported)."""
    from vsi_numba.io.records import RecordError, read_record

    out = []
    for i, r in enumerate(items):
        if r is None:  # (refused by the model: reported)
            continue
        f = Path(r["file"])
        f = f if f.is_absolute() else base / f
        try:
            read_record(f)
        except RecordError as exc:
            chk.error(f"calibration.records[{i}].file", r["file"],
                      f"a readable record: {exc}")
            out = _BAD
            continue
        if out is not _BAD:
            out.append(r)
    return out


def _valid_records(d) -> list:
    """The records of a ``[calibration]`` the model refused that are valid themselves
    (their files are checked with the table's other errors), ``None`` for the others."""
    items = d.get("records") if isinstance(d, dict) else None
    out = []
    for r in items if isinstance(items, list) else []:
        try:
            out.append(_table(_m.CalibrationRecord.model_validate(r)))
        except ValidationError:
            out.append(None)
    return out


def _calibration_section(chk, c, data, raw, base: Path, ok: bool, validate
                         ) -> dict | None:
    """The resolved ``[calibration]`` of a validated one (:class:`~.schema.models.
    Calibration`), defaults filled (None without it), and the checks that need context:
    readable records, and when the rest of the configuration validated (``ok``) the key
    paths and the records' tracks and trains against it (with ``validate``, the validator
    of :mod:`vsi_numba.config.core`).  ``raw``: the table as given (a refused one's valid
    records are still checked for their files)."""
    if c is None:
        return None
    if c is _BAD:
        _records(chk, _valid_records(raw), base)
        return _BAD
    params = [_table(p) for p in c.parameters]
    records = _records(chk, [_table(r) for r in c.records], base)
    if records is _BAD:
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
    return {**_table(c), "parameters": params, "records": records}


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


def _reliability_section(chk, r, data, base: Path, ok: bool, validate) -> dict | None:
    """The resolved ``[reliability]`` of a validated one (:class:`~.schema.models.
    Reliability`), defaults filled (None without it); its key paths checked against the
    rest of the configuration when that validated (``ok``)."""
    if r is None or r is _BAD:
        return r
    variables = [_table(v) for v in r.variables]
    if ok:
        _key_checks(chk, data, base, variables, "reliability.variables", validate)
    return {**_table(r), "variables": variables}


__all__ = ["_calibration_section", "_reliability_section", "central_value", "_show"]
