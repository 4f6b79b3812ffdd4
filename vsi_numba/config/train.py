"""``[train]``: library presets, a user train file, or explicit ``[[train.vehicles]]``.

The table is validated by its declared model (:class:`~.schema.models.Train`: the keys,
their bounds, the kinds of vehicle and the rules between keys); this module builds the
trains from the validated table and checks what needs more than the table: the library's
train names, the files (a user train file, axle-load CSVs), the vehicles' geometry (front
to back, not overlapping) and the vehicle model's own checks.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _did_you_mean,
    _drop_none,
    _ok,
    _Sentinel,
    _show,
)
from vsi_numba.config.limits import MAX_CONFIG_BYTES
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import kinds_of
from vsi_numba.config.schema.train import IGNORED, is_hslm_b
from vsi_numba.config.study import speeds_m_s
from vsi_numba.model import library as _lib
from vsi_numba.model import vehicle as _veh
from vsi_numba.model.library import extra as _extra

VEHICLE_KINDS = ("force", "sprung_mass", "car", "user")
TRAIN_MODELS = _lib.MODELS
_NONLINEAR_TABLES = ("bump_stop", "damper_blowoff", "primary_bump_stop",
                     "primary_damper_blowoff", "secondary_bump_stop",
                     "secondary_damper_blowoff")
_COMMON_VEHICLE_KEYS = ("kind", "offset", "name")
#: The declaration of each vehicle kind (:mod:`vsi_numba.config.schema.models`) and its
#: numeric keys.
_VEHICLE_MODELS = kinds_of(_m.Vehicle)
_VEHICLE_FIELDS: dict[str, tuple[str, ...]] = {
    kind: tuple(k for k in m.model_fields
                if k not in (*_COMMON_VEHICLE_KEYS, *_NONLINEAR_TABLES))
    for kind, m in _VEHICLE_MODELS.items() if kind != "user"}
_USER_KEYS = tuple(k for k in _m.UserVehicle.model_fields if k not in _COMMON_VEHICLE_KEYS)
#: The nonlinear suspension elements of each kind: key -> the element's model class.
_NONLINEAR_KEYS: dict[str, dict[str, type]] = {
    "sprung_mass": {"bump_stop": _veh.BumpStop, "damper_blowoff": _veh.DamperBlowoff},
    "car": {"primary_bump_stop": _veh.BumpStop, "primary_damper_blowoff": _veh.DamperBlowoff,
            "secondary_bump_stop": _veh.BumpStop,
            "secondary_damper_blowoff": _veh.DamperBlowoff},
}


@dataclass(frozen=True)
class _TrainSpec:
    """The validated ``[train]``: its resolved keys and the trains built from them."""

    resolved: dict
    trains: list
    explicit: bool = False
    #: per ``train.other_trains`` entry its own train (moving forces), None: the run's
    others: tuple = ()
    #: per ``train.other_trains`` entry its own speed (m/s: ``speed_kmh`` converted
    #: here), None: the run's speed (times ``speed_factor``)
    other_speeds_m_s: tuple = ()


def _train_section(chk, r, base_dir: Path, title) -> _TrainSpec | _Sentinel:
    """The trains of a validated ``[train]`` (:class:`~.schema.models.Train`), or
    ``_BAD``."""
    if r is _BAD or r is _MISSING:
        return _BAD
    form = r.vehicles is not None
    for k in r._ignored:
        chk.warn(f"train.{k} is ignored: {IGNORED[form][k]}")
    res: dict[str, Any] = {}
    if "track" in r.model_fields_set:  # only when given: files without it keep their form
        res["track"] = r.track
    others: tuple = ()
    if r.other_trains is not None:
        got = _other_trains(chk, r.other_trains, base_dir)
        if _ok(got):
            res["other_trains"], others = got
    if form:
        res["name"] = r.name if r.name is not None else (title if title else "custom")
        spec = _explicit_train(chk, r.vehicles, res["name"], res)
    else:
        spec = _library_trains(chk, r, base_dir, res)
    if not _ok(spec) or not others:
        return spec
    speeds = tuple(None if o.get("speed_kmh") is None else float(speeds_m_s(o["speed_kmh"]))
                   for o in res["other_trains"])
    return dataclasses.replace(spec, others=others, other_speeds_m_s=speeds)


def _preset_names() -> list[str]:
    return list(_lib.list_presets())


def _get_preset(chk, name, path, model):
    """Build one library train (user files are registered in the library) or ``_BAD``.

    Without ``train.model`` the interaction model is used where the library has vehicle
    dynamics, the moving forces otherwise (HSLM load models).
    """
    try:
        if model is None:
            try:
                train = _lib.get_train(name, model="interaction")
            except KeyError:
                raise
            except ValueError:
                train = _lib.get_train(name, model="moving_force")
        else:
            train = _lib.get_train(name, model=model)
    except KeyError:
        guess = _did_you_mean(name, _preset_names())
        hint = f"; did you mean '{guess}'?" if guess else ""
        return chk.error(path, name, f"a train name from the library (`vsi trains` lists "
                                     f"them){hint}")
    except ValueError as exc:
        return chk.error(path, name, f"a train that can be built with train.model = "
                                     f"'{model}' ({' '.join(str(exc).split())})")
    try:
        text = _lib.status_warning(name)
    except (KeyError, ValueError):
        text = ""
    if text:
        chk.warn(f"{path} = {_show(name)}: {text}")
    return train


def _other_trains(chk, items, base_dir: Path):
    """The validated ``train.other_trains`` (:class:`~.schema.models.OtherTrain`): the
    list of resolved ``{track, direction, offset[, speed_kmh | speed_factor][, train]}``
    and, per entry, its own train (moving forces; None: the run's train), or ``_BAD``."""
    out, built, ok = [], [], True
    for i, o in enumerate(items):
        res = {k: getattr(o, k) for k in _m.OtherTrain.model_fields if k != "train"}
        train = None
        if o.train is not None:
            train = _own_train(chk, o.train, f"train.other_trains[{i}].train", base_dir, res)
        ok = ok and _ok(train)
        out.append(_drop_none(res))
        built.append(train)
    return (out, tuple(built)) if ok else _BAD


def _own_train(chk, value, path: str, base_dir: Path, res: dict):
    """``train.other_trains[i].train``: a library train name or an axle-load table, built
    as moving forces (its resolved form goes to ``res["train"]``), or ``_BAD``."""
    if isinstance(value, str):
        train = _get_preset(chk, value, path, "moving_force")
        if _ok(train):
            res["train"] = value
        return train
    got: dict = {}
    train = _axle_train(chk, value, base_dir, got, path=path)
    if _ok(train):
        res["train"] = got["axles"]
    return train


def _library_trains(chk, r, base_dir: Path, res: dict) -> _TrainSpec | _Sentinel:
    """The library trains of ``train.preset`` or ``train.file``, the HSLM-B of
    ``train.hslm_b`` and the train of ``train.axles``, or ``_BAD``."""
    model = r.model
    if model is not None:
        res["model"] = model
    extra = []
    if r.axles is not None:
        extra.append(_axle_train(chk, r.axles, base_dir, res))
    hslm_b = None
    if r.hslm_b is not None:  # (the model's rules: with the HSLM-B preset, moving forces)
        res["hslm_b"] = {"N": int(r.hslm_b.N), "d": float(r.hslm_b.d)}
        hslm_b = _extra.hslm_b_train(res["hslm_b"]["N"], res["hslm_b"]["d"])
    if r.preset is None and r.file is None:
        return _TrainSpec(resolved=res, trains=extra) if _ok(*extra) else _BAD
    user_trains: dict | _Sentinel = {}
    if r.file is not None:
        res["file"] = r.file
        given, full = chk.file({"file": r.file}, "train", "file", base_dir,
                               "user trains (TOML)")
        user_trains = _load_user_trains(chk, full, given) if _ok(full) else _BAD
    if r.preset is not None:
        if isinstance(r.preset, str):
            names, paths = [r.preset], ["train.preset"]
        else:
            names, paths = list(r.preset), [f"train.preset[{i}]" for i in range(len(r.preset))]
        res["preset"] = list(names)
        if user_trains is _BAD:
            return _BAD
        trains = [hslm_b if is_hslm_b(n) else _get_preset(chk, n, p, model)
                  for n, p in zip(names, paths, strict=True)]
        if not _ok(*trains, *extra):
            return _BAD
        for t in extra:
            if t.name in names:
                return chk.error("train.axles.name", t.name, "a train name other than the "
                                 "presets' (train.preset has it)")
        return _TrainSpec(resolved=res, trains=trains + extra)
    if user_trains is _BAD:
        return _BAD
    if not user_trains:
        return chk.error("train.file", r.file, "a file defining at least one train")
    trains = [_get_preset(chk, n, "train.file", model) for n in user_trains]
    return _TrainSpec(resolved=res, trains=trains + extra) if _ok(*trains, *extra) else _BAD


def _axle_train(chk, a, base_dir, res, path: str = "train.axles"):
    """A validated ``train.axles = {file, load_unit, name}`` (or the same table at
    ``path``; :class:`~.schema.models.Axles`): a moving-force train from an axle-load CSV
    file (columns position, load), or ``_BAD``; its resolved table goes to
    ``res["axles"]``."""
    given, full = chk.file({"file": a.file}, path, "file", base_dir,
                           "axle loads (CSV: position, load)")
    if not _ok(given, full):
        return _BAD
    try:
        train = _extra.axle_list_train(full, a.load_unit, a.name)
    except _extra.AxleFileError as exc:
        return chk.error(f"{path}.file", given, f"a valid axle-load file ({exc})")
    res["axles"] = _drop_none({"file": given, "load_unit": a.load_unit, "name": a.name})
    return train


def _load_user_trains(chk, full: Path, given: str):
    try:
        size = full.stat().st_size
    except OSError:
        size = 0
    if size > MAX_CONFIG_BYTES:
        return chk.error("train.file", given, f"a user train file of at most "
                         f"{MAX_CONFIG_BYTES} bytes (it has {size})")
    try:
        return dict(_lib.load_user_trains(full))
    except Exception as exc:  # noqa: BLE001 - any failure of a foreign file is a config error
        msg = " ".join(str(exc).split())
        return chk.error("train.file", given, f"a valid user train file ({msg})")


def _vehicle(chk, v, path: str, index: int):
    """The vehicle of a validated ``train.vehicles[index]`` (one model per kind) and its
    resolved table; the vehicle ``_BAD`` when the vehicle model refuses it."""
    kind = v.kind
    name = v.name if v.name is not None else f"{kind}{index}"
    res: dict[str, Any] = {"kind": kind, "offset": v.offset, "name": name}
    if kind == "user":
        res.update({k: getattr(v, k) for k in _USER_KEYS if k in v.model_fields_set})
        res.setdefault("body_dof", -1)
        try:
            veh = _veh.user_vehicle(v.M, v.C, v.K, v.wheel_dofs, v.wheel_positions,
                                    v.gravity, v.body_dof, name)
        except ValueError as exc:  # the vehicle model's own checks
            veh = chk.error(path, res, f"a valid vehicle ({exc})")
        return veh, res
    vals = {k: getattr(v, k) for k in _VEHICLE_FIELDS[kind]}
    res.update(_drop_none(vals))
    nonlinear = {}
    for key, cls in _NONLINEAR_KEYS.get(kind, {}).items():
        el = getattr(v, key)
        if el is not None:
            res[key] = el.model_dump()
            nonlinear[key] = cls(**res[key])
    if kind == "force":
        veh = _veh.point_loads([0.0], [vals["load"]], name=name)
    elif kind == "sprung_mass":
        veh = _veh.sprung_mass(vals["mass"], vals["stiffness"], vals["damping"],
                               vals["wheel_mass"], name=name, **nonlinear)
    else:
        veh = _veh.railway_car(**vals, name=name, **nonlinear)
    return veh, res


def _explicit_train(chk, vehicles, name, res) -> _TrainSpec | _Sentinel:
    """The train of validated ``[[train.vehicles]]``, listed front to back, or
    ``_BAD``."""
    built = []
    resolved = []
    for i, v in enumerate(vehicles):
        veh, r = _vehicle(chk, v, f"train.vehicles[{i}]", i)
        built.append((veh, v.offset))
        resolved.append(r)
    res["vehicles"] = resolved
    if not all(_ok(veh) for veh, _ in built):
        return _BAD
    # vehicles are listed front to back and must not overlap (their axles as built)
    prev_end = None
    for i, (veh, off) in enumerate(built):
        axles = off + veh.axle_positions
        start, end = float(axles.min()), float(axles.max())
        if prev_end is not None and start <= prev_end:
            lo = start - off
            return chk.error(f"train.vehicles[{i}].offset", off,
                             f"an offset > {prev_end - lo:g} m: vehicles are listed front to "
                             f"back and must not overlap (train.vehicles[{i - 1}] ends at "
                             f"{prev_end:g} m behind the first axle)")
        prev_end = end
    train = _veh.Train(name=name, vehicles=tuple(v for v, _ in built),
                       offsets=tuple(o for _, o in built), status="user")
    return _TrainSpec(resolved=res, trains=[train], explicit=True)
