"""``[irregularity]``: none, an isolated defect, random (PSD) or measured profiles, and the
``[[irregularity.defects]]`` added to every realisation."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _as_list,
    _drop_none,
    _is_number,
    _join,
    _ok,
    _Sentinel,
)
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import expected_of, item_type
from vsi_numba.model import irregularity as _irr

IRREGULARITY_KINDS = ("none", "cosine", "step", "psd", "file")
DEFECT_KINDS = ("cosine", "step")
#: The numeric keys of the isolated defects (cosine, step) and their declarations
#: (:mod:`vsi_numba.config.schema.models`).
_DEFECT_FIELDS = {"cosine": ("depth", "wavelength", "position"),
                  "step": ("height", "length", "position")}
_DEFECT_MODELS = {"cosine": _m.CosineDefect, "step": _m.StepDefect}
_PSD_FIELDS = ("wavelength_min", "wavelength_max", "dx")


def _defect(chk, d, path, kind) -> dict | _Sentinel:
    """Read the keys of an isolated defect (cosine, step) at ``path``."""
    model = _DEFECT_MODELS[kind]
    vals = chk.fields(d, path, model, _DEFECT_FIELDS[kind])
    amp = "depth" if kind == "cosine" else "height"
    if _ok(vals[amp]) and vals[amp] == 0.0:
        vals[amp] = chk.error(_join(path, amp), d[amp], expected_of(model, amp))
    if kind == "step":
        vals.update(chk.fields(d, path, model, ["shape"]))
    if not _ok(*vals.values()):
        return _BAD
    return {"kind": kind, **vals}


_IRR_KEYS = {
    "none": {"kind", "defects"},
    "cosine": {"kind", "depth", "wavelength", "position", "defects"},
    "step": {"kind", "height", "length", "position", "shape", "defects"},
    "psd": {"kind", "spectrum", "wavelength_min", "wavelength_max", "seeds", "dx", "defects"},
    "file": {"kind", "path", "x_column", "r_column", "r_unit", "dx", "defects"},
}


@dataclass(frozen=True)
class _IrregularitySpec:
    """The validated ``[irregularity]``; ``file_profile``: the profile read from
    ``path`` (kind = 'file')."""

    resolved: dict
    kind: str = "none"
    file: Path | None = None
    file_profile: Any = None


def _irregularity_section(chk, d, base_dir: Path) -> _IrregularitySpec | _Sentinel:
    path = "irregularity"
    if d is _MISSING:
        return _IrregularitySpec(resolved={"kind": "none"})
    if not isinstance(d, Mapping):
        return chk.error(path, d, "a table [irregularity] with kind = 'none' | 'cosine' | "
                                  "'psd' | 'file'")
    kind = chk.choice(d, path, "kind", IRREGULARITY_KINDS, default="none")
    every = set().union(*_IRR_KEYS.values())
    if kind is _BAD:
        chk.table(d, path, every)
        return _BAD
    allowed = _IRR_KEYS[kind]
    ignored = {k: f"not used by irregularity.kind = '{kind}'" for k in every - allowed}
    chk.table(d, path, allowed, ignored=ignored)
    res: dict[str, Any] = {"kind": kind}
    ok = True
    file = profile = None
    if kind in _DEFECT_FIELDS:
        vals = _defect(chk, d, path, kind)
        ok = _ok(vals)
        if ok:
            res.update(vals)
    elif kind == "psd":
        res["spectrum"] = chk.fields(d, path, _m.PsdIrregularity, ["spectrum"])["spectrum"]
        vals = chk.fields(d, path, _m.PsdIrregularity, _PSD_FIELDS)
        if _ok(vals["wavelength_min"], vals["wavelength_max"]) and not (
            vals["wavelength_max"] > vals["wavelength_min"]
        ):
            vals["wavelength_max"] = chk.error(
                "irregularity.wavelength_max", d["wavelength_max"],
                f"a wavelength > wavelength_min = {vals['wavelength_min']:g} m")
        if _ok(vals["wavelength_min"], vals["dx"]) and vals["dx"] is not None and (
            vals["dx"] > vals["wavelength_min"] / 2
        ):
            vals["dx"] = chk.error("irregularity.dx", d["dx"],
                                   f"a sample spacing <= wavelength_min / 2 = "
                                   f"{vals['wavelength_min'] / 2:g} m (Nyquist)")
        if "seeds" not in d:
            seeds = chk.error("irregularity.seeds", _MISSING,
                              "a list of integer seeds >= 0, one per realisation")
        else:
            seeds = chk.number_list(
                d["seeds"], "irregularity.seeds",
                item_type(_m.PsdIrregularity, "seeds"), "an integer seed 0 <= seed < 2^63",
                expected=expected_of(_m.PsdIrregularity, "seeds"), max_len=10_000,
                scalar_ok=True)
            if _is_number(seeds):
                seeds = [seeds]
            if isinstance(seeds, list) and len(set(seeds)) != len(seeds):
                seeds = chk.error("irregularity.seeds", d["seeds"], "distinct seeds")
        res.update(_drop_none(vals), seeds=seeds)
        ok = _ok(res["spectrum"], seeds, *vals.values())
    elif kind == "file":
        given, full = chk.file(d, path, "path", base_dir, "the profile (CSV, columns x and r)")
        res["path"] = given
        xcol = chk.string(d, path, "x_column", expected_of(_m.FileIrregularity, "x_column"),
                          default="x")
        rcol = chk.string(d, path, "r_column", expected_of(_m.FileIrregularity, "r_column"),
                          default="r")
        unit, dx = chk.fields(d, path, _m.FileIrregularity, ["r_unit", "dx"]).values()
        res.update(_drop_none({"x_column": xcol, "r_column": rcol, "r_unit": unit, "dx": dx}))
        ok = _ok(given, full, xcol, rcol, unit, dx)
        if ok:
            file = full
            try:
                profile = _irr.profile_from_file(full, xcol, rcol, unit, dx)
            except (ValueError, OSError) as exc:
                msg = " ".join(str(exc).split())
                ok = _ok(chk.error("irregularity.path", given, f"a readable profile: {msg}"))
    defects = []
    if "defects" in d:
        raw = _as_list(d["defects"])
        if not isinstance(raw, list) or not raw or len(raw) > 1000:
            ok = _ok(chk.error("irregularity.defects", raw,
                               "an array of tables [[irregularity.defects]] with kind = "
                               "'cosine' | 'step'"))
        else:
            for i, item in enumerate(raw):
                p = f"irregularity.defects[{i}]"
                if not isinstance(item, Mapping):
                    ok = _ok(chk.error(p, item, "a table with kind = 'cosine' | 'step'"))
                    continue
                dk = chk.choice(item, p, "kind", DEFECT_KINDS)
                if dk is _BAD:
                    ok = False
                    continue
                chk.table(item, p, {"kind", *_DEFECT_FIELDS[dk],
                                    *(("shape",) if dk == "step" else ())})
                vals = _defect(chk, item, p, dk)
                if _ok(vals):
                    defects.append(vals)
                else:
                    ok = False
        if ok:
            res["defects"] = defects
    if not ok:
        return _BAD
    return _IrregularitySpec(resolved=res, kind=kind, file=file, file_profile=profile)


def _defect_profile(spec, x_stop: float):
    """The Profile of a resolved cosine or step defect (a step persists to ``x_stop``)."""
    if spec["kind"] == "cosine":
        return _irr.cosine_defect(spec["depth"], spec["wavelength"], spec["position"])
    stop = max(x_stop, spec["position"] + spec["length"])
    return _irr.step_defect(spec["height"], spec["length"], spec["position"], stop,
                            spec["shape"])


def _check_file_coverage(chk, irr, x_start, x_stop):
    prof = irr.file_profile
    if prof.x0 > x_start + 1e-9 or prof.x_end < x_stop - 1e-9:
        chk.error("irregularity.path", irr.resolved["path"],
                  f"a profile covering the approach and the bridge, x = {x_start:g} .. "
                  f"{x_stop:g} m (the file covers {prof.x0:g} .. {prof.x_end:g} m and the "
                  "profile is zero outside)")
