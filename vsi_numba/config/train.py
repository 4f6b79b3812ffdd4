"""``[train]``: library presets, a user train file, or explicit ``[[train.vehicles]]``."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _as_list,
    _did_you_mean,
    _drop_none,
    _finite,
    _is_number,
    _ok,
    _Sentinel,
    _show,
)
from vsi_numba.config.limits import MAX_CONFIG_BYTES, MAX_USER_DOFS, MAX_VEHICLES
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import Int, Num, expected_of, keys_of, kinds_of
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
_VEHICLE_FIELDS["user"] = ()
_USER_KEYS = tuple(k for k in _m.UserVehicle.model_fields if k not in _COMMON_VEHICLE_KEYS)
# nonlinear suspension elements: key -> (model class, fields, the damping key it needs)
_NONLINEAR_KEYS: dict[str, dict[str, tuple]] = {
    "sprung_mass": {
        "bump_stop": (_veh.BumpStop, _m.BumpStop, None),
        "damper_blowoff": (_veh.DamperBlowoff, _m.DamperBlowoff, "damping"),
    },
    "car": {
        "primary_bump_stop": (_veh.BumpStop, _m.BumpStop, None),
        "primary_damper_blowoff": (_veh.DamperBlowoff, _m.DamperBlowoff, "primary_damping"),
        "secondary_bump_stop": (_veh.BumpStop, _m.BumpStop, None),
        "secondary_damper_blowoff": (_veh.DamperBlowoff, _m.DamperBlowoff,
                                     "secondary_damping"),
    },
}


def _vehicle_keys(kind):
    extra = _USER_KEYS if kind == "user" else tuple(_VEHICLE_FIELDS[kind])
    return set(_COMMON_VEHICLE_KEYS) | set(extra) | set(_NONLINEAR_KEYS.get(kind, ()))


def _nonlinear(chk, v, path, kind, vals, res):
    """The vehicle's nonlinear suspension elements (``{key: BumpStop | DamperBlowoff}``),
    or ``_BAD``; their resolved tables go to ``res``."""
    out = {}
    for key, (cls, model, damping_key) in _NONLINEAR_KEYS.get(kind, {}).items():
        fields = model.model_fields
        if key not in v:
            continue
        kp = f"{path}.{key}"
        tbl = v[key]
        what = " (" + ", ".join(f"{k} = ..." for k in fields) + ")"
        if not isinstance(tbl, Mapping):
            out[key] = chk.error(kp, tbl, f"a table{what}")
            continue
        chk.table(tbl, kp, set(fields))
        got = chk.fields(tbl, kp, model)
        if not _ok(*got.values()):
            out[key] = _BAD
            continue
        if damping_key is not None:
            c = vals.get(damping_key)
            if _ok(c) and not got["post_damping"] < c:
                out[key] = chk.error(
                    f"{kp}.post_damping" if "post_damping" in tbl else kp, dict(tbl),
                    f"a blow-off on a damper: {path}.{damping_key} = {c!r} N s/m must be > "
                    f"post_damping = {got['post_damping']!r} N s/m")
                continue
        out[key] = cls(**got)
        res[key] = dict(got)
    return out


def _matrix(chk, value, path, n=None):
    """Read a square matrix (nested lists of finite numbers): ndarray or ``_BAD``."""
    value = _as_list(value)
    expected = "a square matrix (list of rows of numbers)" + (f", {n} x {n}" if n else "")
    if not isinstance(value, list) or not value or len(value) > MAX_USER_DOFS:
        return chk.error(path, value, expected)
    rows = [_as_list(r) for r in value]
    size = len(rows)
    if not all(isinstance(r, list) and len(r) == size for r in rows) or (n and size != n):
        return chk.error(path, value, expected)
    bad = False
    for i, row in enumerate(rows):
        for j, x in enumerate(row):
            if not (_is_number(x) and _finite(x)):
                chk.error(f"{path}[{i}][{j}]", x, "a finite number")
                bad = True
    if bad:
        return _BAD
    a = np.asarray(rows, float)
    try:
        _veh.check_matrix(a, path)
    except _veh.VehicleMatrixError as exc:  # finite by now: not symmetric
        i, j = exc.index
        return chk.error(f"{path}[{i}][{j}]", float(a[i, j]),
                         f"a symmetric matrix ({path}[{j}][{i}] = {float(a[j, i])!r})")
    return a


def _user_vehicle(chk, v, path, name):
    m = _matrix(chk, v["M"], f"{path}.M") if "M" in v else chk.error(
        f"{path}.M", _MISSING, "the mass matrix (list of rows, kg and kg m^2)")
    n = m.shape[0] if isinstance(m, np.ndarray) else None
    mats = {"M": m}
    for key, what in (("C", "damping matrix (N s/m)"), ("K", "stiffness matrix (N/m)")):
        if key not in v:
            mats[key] = chk.error(f"{path}.{key}", _MISSING, f"the {what}, same size as M")
        else:
            mats[key] = _matrix(chk, v[key], f"{path}.{key}", n)
    if isinstance(m, np.ndarray):
        try:
            _veh.check_masses(m)
        except _veh.VehicleMatrixError as exc:
            i = exc.index[0]
            mats["M"] = chk.error(f"{path}.M[{i}][{i}]", float(m[i, i]),
                                  "a mass >= 0 (diagonal)")
    hi = (n - 1) if n else MAX_USER_DOFS
    dofs = _BAD
    if "wheel_dofs" not in v:
        chk.error(f"{path}.wheel_dofs", _MISSING, "a list of wheel DOF indices")
    else:
        dofs = chk.number_list(v["wheel_dofs"], f"{path}.wheel_dofs",
                               Int(ge=0, le=hi), f"a DOF index 0 <= i <= {hi}",
                               expected="a non-empty list of wheel DOF indices")
        if isinstance(dofs, list) and len(set(dofs)) != len(dofs):
            dofs = chk.error(f"{path}.wheel_dofs", v["wheel_dofs"], "distinct DOF indices")
    pos = _BAD
    if "wheel_positions" not in v:
        chk.error(f"{path}.wheel_positions", _MISSING,
                  "one position (m behind the vehicle's first axle) per wheel DOF")
    else:
        pos = chk.number_list(v["wheel_positions"], f"{path}.wheel_positions",
                              Num(ge=0), "a position >= 0 m behind the first axle",
                              expected="a list of wheel positions >= 0 m, one per wheel DOF")
        if isinstance(pos, list) and isinstance(dofs, list) and len(pos) != len(dofs):
            pos = chk.error(f"{path}.wheel_positions", v["wheel_positions"],
                            f"one position per wheel DOF ({len(dofs)} wheel DOFs)")
        elif isinstance(pos, list) and any(b <= a for a, b in zip(pos, pos[1:], strict=False)):
            pos = chk.error(f"{path}.wheel_positions", v["wheel_positions"],
                            "strictly increasing positions (wheels front to back)")
    grav = None
    if "gravity" in v:
        grav = chk.number_list(v["gravity"], f"{path}.gravity", float, "a load in N",
                               expected="a list of static loads (N, positive down), one per DOF",
                               min_len=n or 1, max_len=n)
    body = chk.get_number(v, path, "body_dof", Int(ge=-1, le=hi),
                          f"a DOF index -1 <= i <= {hi} (-1: none)", default=-1)
    if not _ok(*mats.values(), dofs, pos, grav, body) or n is None:
        return _BAD
    try:
        return _veh.user_vehicle(mats["M"], mats["C"], mats["K"], dofs, pos, grav, body, name)
    except ValueError as exc:
        return chk.error(path, dict(v), f"a valid vehicle ({exc})")


def _vehicle(chk, v, path, index):
    if not isinstance(v, Mapping):
        chk.error(path, v, "a table with kind = 'force' | 'sprung_mass' | 'car' | 'user'")
        return _BAD, _BAD, None
    kind = chk.choice(v, path, "kind", VEHICLE_KINDS)
    if kind is _BAD:
        every = set(_COMMON_VEHICLE_KEYS).union(*(_vehicle_keys(k) for k in VEHICLE_KINDS))
        chk.table(v, path, every)
        return _BAD, _BAD, None
    allowed = _vehicle_keys(kind)
    elsewhere = {}
    for other in VEHICLE_KINDS:
        for k in _vehicle_keys(other) - allowed:
            elsewhere.setdefault(k, f"no such key for kind = '{kind}' (it belongs to kind = "
                                    f"'{other}')")
    chk.table(v, path, allowed, elsewhere=elsewhere)
    offset = chk.fields(v, path, _VEHICLE_MODELS[kind], ["offset"])["offset"]
    name = chk.string(v, path, "name", expected_of(_VEHICLE_MODELS[kind], "name"),
                      default=f"{kind}{index}")
    res = {"kind": kind, "offset": offset, "name": name}
    if kind == "user":
        veh = _user_vehicle(chk, v, path, name if _ok(name) else kind)
        for k in _USER_KEYS:
            if k in v:
                res[k] = _as_list(v[k])
        res.setdefault("body_dof", -1)
        return veh, offset, res
    vals = chk.fields(v, path, _VEHICLE_MODELS[kind], _VEHICLE_FIELDS[kind])
    res.update(_drop_none(vals))
    nonlinear = _nonlinear(chk, v, path, kind, vals, res)
    if not _ok(*vals.values(), *nonlinear.values(), name):
        return _BAD, offset, res
    if kind == "force":
        veh = _veh.point_loads([0.0], [vals["load"]], name=name)
    elif kind == "sprung_mass":
        veh = _veh.sprung_mass(vals["mass"], vals["stiffness"], vals["damping"],
                               vals["wheel_mass"], name=name, **nonlinear)
    else:
        veh = _car(chk, vals, path, name, nonlinear)
    return veh, offset, res


def _car(chk, vals, path, name, nonlinear=None):
    if vals["bogie_spacing"] <= vals["wheelbase"]:
        return chk.error(f"{path}.bogie_spacing", vals["bogie_spacing"],
                         f"a distance between bogie centres > the wheelbase "
                         f"({vals['wheelbase']:g} m), else the bogies' axles overlap")
    cg = vals["body_cg_to_front_bogie"]
    if cg is not None and cg > vals["bogie_spacing"]:
        return chk.error(f"{path}.body_cg_to_front_bogie", cg,
                         f"a distance between 0 and bogie_spacing = {vals['bogie_spacing']:g} m")
    return _veh.railway_car(**{k: vals[k] for k in _VEHICLE_FIELDS["car"]}, name=name,
                            **(nonlinear or {}))


@dataclass(frozen=True)
class _TrainSpec:
    """The validated ``[train]``: its resolved keys and the trains built from them."""

    resolved: dict
    trains: list
    explicit: bool = False
    #: per ``train.other_trains`` entry its own train (moving forces), None: the run's
    others: tuple = ()


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
    """``train.other_trains`` (declared: :class:`~.schema.models.OtherTrain`): the list of
    resolved ``{track, direction, offset[, train][, speed_kmh | speed_factor]}`` and,
    per entry, its own train (moving forces; None: the run's train), or ``_BAD``."""
    path = "train.other_trains"
    model = _m.OtherTrain
    if not isinstance(items, list) or not items or len(items) > 19:
        return chk.error(path, items, "a list of 1 to 19 trains on other tracks, each "
                                      "{ track = k, direction = \"same\" | \"opposite\", "
                                      "offset = m[, train = \"name\"][, speed_kmh = v | "
                                      "speed_factor = f] }")
    out, built = [], []
    for i, it in enumerate(items):
        p = f"{path}[{i}]"
        if chk.table(it, p, keys_of(model), what=" { track = k, direction, offset, train, "
                                                "speed_kmh | speed_factor }") is _BAD:
            out = _BAD
            continue
        v = chk.fields(it, p, model, [k for k in model.model_fields if k != "train"])
        if v["speed_kmh"] is not None and v["speed_factor"] is not None:
            v["speed_factor"] = chk.error(
                f"{p}.speed_factor", it["speed_factor"],
                f"either {p}.speed_kmh or {p}.speed_factor, not both (speed_kmh = "
                f"{it['speed_kmh']!r} is given)")
        train, res = None, {}
        if "train" in it:
            train = _own_train(chk, it["train"], f"{p}.train", base_dir, res)
        if out is _BAD or not _ok(*v.values(), train):
            out = _BAD
            continue
        out.append({**{k: x for k, x in v.items() if x is not None}, **res})
        built.append(train)
    return _BAD if out is _BAD else (out, built)


def _own_train(chk, value, path: str, base_dir: Path, res: dict):
    """``train.other_trains[i].train``: a library train name or an axle-load table, built
    as moving forces (its resolved form goes to ``res["train"]``), or ``_BAD``."""
    if isinstance(value, str) and value.strip():
        train = _get_preset(chk, value, path, "moving_force")
        if _ok(train):
            res["train"] = value
        return train
    if isinstance(value, Mapping):
        got: dict = {}
        train = _axle_train(chk, value, base_dir, got, path=path)
        if _ok(train):
            res["train"] = got["axles"]
        return train
    return chk.error(path, value, expected_of(_m.OtherTrain, "train"))


def _train_section(chk, d, base_dir: Path, title) -> _TrainSpec | _Sentinel:
    """The validated ``[train]``, or ``_BAD``."""
    others: list = []
    spec = _train_tables(chk, d, base_dir, title, others)
    if not _ok(spec) or not others:
        return spec
    return dataclasses.replace(spec, others=tuple(others))


def _train_tables(chk, d, base_dir: Path, title, others: list) -> _TrainSpec | _Sentinel:
    path = "train"
    allowed = keys_of(_m.Train)
    ignored = {"name": "it names the train of [[train.vehicles]]; presets keep their names"}
    if isinstance(d, Mapping) and "vehicles" in d:
        ignored = {"model": "it applies to library presets, not to [[train.vehicles]]"}
    if chk.table(d, path, allowed - set(ignored), ignored=ignored,
                 what=" [train] with preset, vehicles or file") is _BAD:
        return _BAD
    given = [k for k in ("preset", "vehicles", "file", "axles") if k in d]
    if not given:
        return chk.error(path, _MISSING, "one of train.preset (library names), "
                                         "[[train.vehicles]], train.file or train.axles")
    if "vehicles" in d and len(given) > 1:
        other = [k for k in given if k != "vehicles"][0]
        return chk.error(f"train.{other}", d[other],
                         "either [[train.vehicles]] or train.preset/train.file, not both")
    res: dict[str, Any] = {}
    if "track" in d:  # only when given: files without it keep their resolved form
        res["track"] = chk.fields(d, path, _m.Train, ["track"])["track"]
    if "other_trains" in d:
        got = _other_trains(chk, d["other_trains"], base_dir)
        if _ok(got):
            res["other_trains"] = got[0]
            others.extend(got[1])
    if "vehicles" in d:
        name = chk.string(d, path, "name", expected_of(_m.Train, "name"),
                          default=title if title else "custom")
        res["name"] = name
        return _explicit_train(chk, d["vehicles"], name, res)
    model = chk.fields(d, path, _m.Train, ["model"])["model"]
    if model is not None and model is not _BAD:
        res["model"] = model
    extra = []
    if "axles" in d:
        extra.append(_axle_train(chk, d["axles"], base_dir, res))
    raw = _as_list(d.get("preset", []))
    names_given = [raw] if isinstance(raw, str) else (raw if isinstance(raw, list) else [])
    wants_b = any(isinstance(n, str) and n.strip().casefold() == "hslm-b"
                  for n in names_given)
    hslm_b = _BAD
    if "hslm_b" in d:
        if not wants_b:
            chk.error("train.hslm_b", d["hslm_b"], "only with 'HSLM-B' in train.preset "
                      "(N and d of the HSLM-B train)")
        else:
            hslm_b = _hslm_b(chk, d["hslm_b"], model, res)
    elif wants_b:
        chk.error("train.hslm_b", _MISSING, _extra.HSLM_B_MISSING)
    if "preset" not in d and "file" not in d:
        if not _ok(model, *extra):
            return _BAD
        return _TrainSpec(resolved=res, trains=extra)

    user_trains: dict = {}
    if "file" in d:
        given_path, full = chk.file(d, path, "file", base_dir, "user trains (TOML)")
        res["file"] = given_path
        if _ok(full):
            user_trains = _load_user_trains(chk, full, given_path)
    if "preset" in d:
        raw = _as_list(d["preset"])
        expected = "a train name, or a non-empty list of names (`vsi trains` lists them)"
        if isinstance(raw, str):
            names, paths = [raw], ["train.preset"]
        elif isinstance(raw, list) and raw and all(isinstance(x, str) for x in raw):
            names, paths = raw, [f"train.preset[{i}]" for i in range(len(raw))]
            if len(set(names)) != len(names):
                return chk.error("train.preset", raw, "distinct train names")
        else:
            return chk.error("train.preset", raw, expected)
        res["preset"] = list(names)
        if model is _BAD or user_trains is _BAD:
            return _BAD
        trains = [hslm_b if n.strip().casefold() == "hslm-b" else _get_preset(chk, n, p, model)
                  for n, p in zip(names, paths, strict=True)]
        if not _ok(*trains, *extra):
            return _BAD
        for t in extra:
            if t.name in names:
                return chk.error("train.axles.name", t.name, "a train name other than the "
                                 "presets' (train.preset has it)")
        return _TrainSpec(resolved=res, trains=trains + extra)
    if user_trains is _BAD or not _ok(model):
        return _BAD
    if not user_trains:
        return chk.error("train.file", d.get("file"), "a file defining at least one train")
    trains = [_get_preset(chk, n, "train.file", model) for n in user_trains]
    return _TrainSpec(resolved=res, trains=trains + extra) if _ok(*trains, *extra) else _BAD


def _hslm_b(chk, v, model, res):
    """``train.hslm_b = {N, d}``: the HSLM-B train, or ``_BAD``."""
    path = "train.hslm_b"
    if not isinstance(v, Mapping):
        return chk.error(path, v, "a table {N = <number of forces>, d = <spacing in m>} "
                                  "read from EN 1991-2 Fig. 6.13 [R]")
    if chk.table(v, path, keys_of(_m.HslmB)) is _BAD:
        return _BAD
    missing = [k for k in ("N", "d") if k not in v]
    for k in missing:
        chk.error(f"{path}.{k}", _MISSING, _extra.HSLM_B_MISSING)
    if missing:
        return _BAD
    vals = chk.fields(v, path, _m.HslmB, ["N", "d"])
    if not _ok(*vals.values()):
        return _BAD
    if model == "interaction":
        return chk.error("train.model", model, "'moving_force' (HSLM-B is a load model: "
                                               "moving forces, no vehicle dynamics)")
    res["hslm_b"] = {"N": int(vals["N"]), "d": float(vals["d"])}
    return _extra.hslm_b_train(int(vals["N"]), float(vals["d"]))


def _axle_train(chk, v, base_dir, res, path: str = "train.axles"):
    """``train.axles = {file, load_unit, name}`` (or the same table at ``path``): a
    moving-force train from an axle-load CSV file (columns position, load), or ``_BAD``;
    its resolved table goes to ``res["axles"]``."""
    if not isinstance(v, Mapping):
        return chk.error(path, v, "a table {file = \"axles.csv\", load_unit = \"kN\"} "
                                  "(CSV columns position in m behind the first axle, load)")
    if chk.table(v, path, keys_of(_m.Axles)) is _BAD:
        return _BAD
    given, full = chk.file(v, path, "file", base_dir, "axle loads (CSV: position, load)")
    unit = chk.fields(v, path, _m.Axles, ["load_unit"])["load_unit"]
    name = chk.string(v, path, "name", expected_of(_m.Axles, "name"), default=None)
    if not _ok(given, full, unit, name):
        return _BAD
    try:
        train = _extra.axle_list_train(full, unit, name)
    except _extra.AxleFileError as exc:
        return chk.error(f"{path}.file", given, f"a valid axle-load file ({exc})")
    res["axles"] = _drop_none({"file": given, "load_unit": unit, "name": name})
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


def _explicit_train(chk, vehicles, name, res) -> _TrainSpec | _Sentinel:
    vehicles = _as_list(vehicles)
    if not isinstance(vehicles, list) or not vehicles or len(vehicles) > MAX_VEHICLES:
        return chk.error("train.vehicles", vehicles,
                         f"an array of tables [[train.vehicles]] (1 to {MAX_VEHICLES})")
    built = []
    resolved = []
    for i, v in enumerate(vehicles):
        veh, offset, r = _vehicle(chk, v, f"train.vehicles[{i}]", i)
        built.append((veh, offset))
        if r is not None:
            resolved.append(r)
    res["vehicles"] = resolved
    if not all(_ok(veh, off) for veh, off in built):
        return _BAD
    # vehicles are listed front to back and must not overlap
    prev_end = None
    for i, (veh, off) in enumerate(built):
        axles = off + veh.axle_positions
        start, end = float(axles.min()), float(axles.max())
        if prev_end is not None and start <= prev_end:
            lo = start - off
            chk.error(f"train.vehicles[{i}].offset", off,
                      f"an offset > {prev_end - lo:g} m: vehicles are listed front to back "
                      f"and must not overlap (train.vehicles[{i - 1}] ends at {prev_end:g} m "
                      f"behind the first axle)")
            return _BAD
        prev_end = end
    if not _ok(name):
        return _BAD
    train = _veh.Train(name=name, vehicles=tuple(v for v, _ in built),
                       offsets=tuple(o for _, o in built), status="user")
    return _TrainSpec(resolved=res, trains=[train], explicit=True)
