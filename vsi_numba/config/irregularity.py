"""``[irregularity]``: none, an isolated defect, random (PSD) or measured profiles, and the
``[[irregularity.defects]]`` added to every realisation."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsi_numba.config._check import (
    _BAD,
    _drop_none,
    _ok,
    _Sentinel,
)
from vsi_numba.model import irregularity as _irr

IRREGULARITY_KINDS = ("none", "cosine", "step", "psd", "file")
DEFECT_KINDS = ("cosine", "step")
#: The numeric keys of the isolated defects (cosine, step) and their declarations
#: (:mod:`vsi_numba.config.schema.models`).
_DEFECT_FIELDS = {"cosine": ("depth", "wavelength", "position"),
                  "step": ("height", "length", "position")}
_PSD_FIELDS = ("wavelength_min", "wavelength_max", "dx")


def _defect(r) -> dict:
    """The resolved keys of a validated isolated defect (cosine, step)."""
    kind = r.kind
    vals = {k: getattr(r, k) for k in _DEFECT_FIELDS[kind]}
    if kind == "step":
        vals["shape"] = r.shape
    return {"kind": kind, **vals}


@dataclass(frozen=True)
class _IrregularitySpec:
    """The validated ``[irregularity]``; ``file_profile``: the profile read from
    ``path`` (kind = 'file')."""

    resolved: dict
    kind: str = "none"
    file: Path | None = None
    file_profile: Any = None


def _irregularity_section(chk, r, base_dir: Path) -> _IrregularitySpec | _Sentinel:
    """The profile of a validated ``[irregularity]`` (:data:`~.schema.models.Irregularity`)
    and the checks that are not rules of the model: the profile file (it exists and
    reads)."""
    path = "irregularity"
    if r is _BAD:
        return _BAD
    kind = r.kind
    for k in r._ignored:
        chk.warn(f"{path}.{k} is ignored: not used by irregularity.kind = '{kind}'")
    res: dict[str, Any] = {"kind": kind}
    ok = True
    file = profile = None
    if kind in _DEFECT_FIELDS:
        res.update(_defect(r))
    elif kind == "psd":
        res["spectrum"] = r.spectrum
        res.update(_drop_none({k: getattr(r, k) for k in _PSD_FIELDS}))
        res["seeds"] = list(r.seeds) if isinstance(r.seeds, list) else [r.seeds]
    elif kind == "file":
        given, full = chk.file({"path": r.path}, path, "path", base_dir,
                               "the profile (CSV, columns x and r)")
        res["path"] = given
        xcol, rcol, unit, dx = r.x_column, r.r_column, r.r_unit, r.dx
        res.update(_drop_none({"x_column": xcol, "r_column": rcol, "r_unit": unit, "dx": dx}))
        ok = _ok(given, full)
        if ok:
            file = full
            try:
                profile = _irr.profile_from_file(full, xcol, rcol, unit, dx)
            except (ValueError, OSError) as exc:
                msg = " ".join(str(exc).split())
                ok = _ok(chk.error("irregularity.path", given, f"a readable profile: {msg}"))
    if r.defects is not None:
        res["defects"] = [_defect(x) for x in r.defects]
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
