"""``[study]``: the speeds, the output file, the time histories kept, the variants
(``vary``, ``vary_together``, ``mass_bounds``) and the resonance-speed refinement."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _as_list,
    _drop_none,
    _is_number,
    _ok,
    _resolve,
    _Sentinel,
)
from vsi_numba.config.limits import MAX_SPEEDS
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import Num, expected_of, item_type, keys_of
from vsi_numba.config.variants import _vary_axes
from vsi_numba.en1991 import (
    ALPHA_CLAUSE,
    ALPHA_RANGE,
    resonance_speeds_kmh,
)
from vsi_numba.model.irregularity import SPEED_BOUND_KMH

#: Orders i of the resonance speeds v_i = f1 D / i that study.refine_resonance adds.
RESONANCE_ORDERS = (1, 2, 3)


@dataclass(frozen=True)
class _StudySpec:
    """The validated ``[study]``: ``resolved`` (the section as written to results and
    hashed), the absolute ``output_path`` and the variant ``axes`` (empty: none)."""

    resolved: dict
    output_path: Path
    axes: list


#: A speed of the study: the declared type of one of study.speeds_kmh, and its expectation
_SPEED = item_type(_m.Study, "speeds_kmh")
_SPEED_EXPECTED = f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})"


def _speed_grid(start, stop, step) -> np.ndarray:
    n = int(math.floor((stop - start) / step + 1e-9))
    return np.round(start + step * np.arange(n + 1), 9)


def _line_speed_grid(line: float) -> list[float]:
    """Speeds (km/h) of a study given its line speed: 5 km/h steps up to 1.2 x line."""
    stop = 1.2 * line
    start = 140.0 if stop >= 140.0 else 5.0
    grid = _speed_grid(start, stop, 5.0)
    if grid[-1] < stop - 1e-9:
        grid = np.append(grid, round(stop, 9))
    return grid.tolist()


def _study_section(chk, d, default_output: str, base_dir: Path, profile=None
                   ) -> _StudySpec | _Sentinel:
    path = "study"
    allowed = keys_of(_m.Study)
    if d is _MISSING:
        return chk.error(path, _MISSING, "a table [study] with speeds_kmh (km/h) or "
                                         "line_speed_kmh")
    if chk.table(d, path, allowed, what=" [study] with speeds_kmh") is _BAD:
        return _BAD
    line = chk.fields(d, path, _m.Study, ["line_speed_kmh"])["line_speed_kmh"]
    speeds = _BAD
    expected = expected_of(_m.Study, "speeds_kmh")
    if "speeds_kmh" in d:
        raw = _as_list(d["speeds_kmh"])
        if isinstance(raw, Mapping):
            g = chk.table(raw, "study.speeds_kmh", keys_of(_m.SpeedGrid))
            if g is not _BAD:
                vals = chk.fields(raw, "study.speeds_kmh", _m.SpeedGrid)
                if _ok(*vals.values()):
                    if vals["stop"] < vals["start"]:
                        chk.error("study.speeds_kmh.stop", vals["stop"],
                                  f"a speed >= start = {vals['start']:g} km/h")
                    elif (vals["stop"] - vals["start"]) / vals["step"] >= MAX_SPEEDS:
                        chk.error("study.speeds_kmh.step", vals["step"],
                                  f"a step giving at most {MAX_SPEEDS} speeds")
                    else:
                        speeds = _speed_grid(vals["start"], vals["stop"], vals["step"]).tolist()
        else:
            speeds = chk.number_list(raw, "study.speeds_kmh", _SPEED, _SPEED_EXPECTED,
                                     expected=expected,
                                     scalar_ok=True, max_len=MAX_SPEEDS)
            if _is_number(speeds):
                speeds = [speeds]
            if isinstance(speeds, list) and len(set(speeds)) != len(speeds):
                speeds = chk.error("study.speeds_kmh", raw, "distinct speeds")
        # both: the speeds are the study's, the line speed the one the EN range must
        # reach (1.2 x line speed, EN 1991-2 6.4.6.2 [R]); checked by the physics checks
    elif line is None:
        chk.error("study.speeds_kmh", _MISSING, expected + " (or give study.line_speed_kmh)")
    elif line is not _BAD:
        speeds = _line_speed_grid(line)
    output = chk.string(d, path, "output", expected_of(_m.Study, "output"),
                        default=default_output)
    out_full = _BAD
    if _ok(output):
        if "\x00" in output or not output.endswith(".nc"):
            output = chk.error("study.output", output, expected_of(_m.Study, "output"))
        else:
            out_full = _resolve(base_dir, output)
            if out_full is None:
                output = chk.error("study.output", output, "a valid path of a netCDF file")
            elif out_full.is_dir():
                output = chk.error("study.output", output, f"a file path ({out_full} is a "
                                                           "directory)")
    save = chk.fields(d, path, _m.Study, ["save_time_histories"])["save_time_histories"]
    hist = None
    if "history_speeds_kmh" in d:
        hist = chk.number_list(d["history_speeds_kmh"], "study.history_speeds_kmh", _SPEED,
                               _SPEED_EXPECTED,
                               expected=expected_of(_m.Study, "history_speeds_kmh"),
                               scalar_ok=True, min_len=0)
        if _is_number(hist):
            hist = [hist]
        if isinstance(hist, list) and isinstance(speeds, list):
            for i, s in enumerate(hist):
                if not any(abs(s - g) <= 1e-6 * max(1.0, g) for g in speeds):
                    chk.error(f"study.history_speeds_kmh[{i}]", s,
                              "one of the speeds of study.speeds_kmh")
                    hist = _BAD
                    break
    axes = _vary_axes(chk, d)
    refine = chk.fields(d, path, _m.Study, ["refine_resonance"])["refine_resonance"]
    lo, hi = ALPHA_RANGE
    clause = ALPHA_CLAUSE
    if profile is not None:  # the code profile's range (a national annex may widen it)
        lo, hi = profile["classification_factor_min"], profile["classification_factor_max"]
        clause = profile.clause("classification_factor_min", "classification_factor_max")
    alpha = chk.get_number(
        d, path, "classification_factor", Num(ge=lo, le=hi),
        f"a load classification factor alpha of LM71 in [{lo:g}, {hi:g}] ({clause})",
        default=None)
    maint = chk.fields(d, path, _m.Study, ["track_maintenance"], notes={
        "track_maintenance": " (the dynamic factor of LM71: 'careful' maintenance Phi_2, "
                             "'standard' Phi_3, EN 1991-2 6.4.5.2)"})["track_maintenance"]
    effects = chk.fields(d, path, _m.Study, ["load_effects"])["load_effects"]
    if not _ok(line, speeds, output, save, hist, out_full, axes, refine, alpha, maint,
               effects):
        return _BAD
    vary = {k: d[k] for k in ("vary", "vary_together", "mass_bounds") if k in d}
    if refine:
        vary["refine_resonance"] = True
    resolved = _drop_none({"speeds_kmh": speeds, "line_speed_kmh": line, "output": output,
                           "save_time_histories": save, "history_speeds_kmh": hist,
                           "classification_factor": alpha, "track_maintenance": maint,
                           "load_effects": None if effects else False, **vary})
    return _StudySpec(resolved=resolved, output_path=out_full, axes=axes)


def _refine_resonance(study, bridge, train):
    """``study.refine_resonance``: add the resonance speeds v_i = 3.6 f1 D / i (km/h,
    i = 1, 2, 3; EN 1991-2 6.4.6.2 [R]) of every train with a regular coach length D, and
    v_i +- 1 km/h, inside the study's speed range (0.1 km/h resolution)."""
    study["speeds_kmh"] = refined_speeds(study["speeds_kmh"], bridge, train)


def refined_speeds(speeds, bridge, train, also=()) -> list:
    """The speeds (km/h) with the resonance speeds of :func:`_refine_resonance` added for
    this bridge and these trains, and the speeds ``also`` (the refinement of other
    variants), inside the range of ``speeds``; sorted, without near-duplicates."""
    speeds = list(speeds)
    if not speeds:
        return speeds
    lo, hi = min(speeds), max(speeds)
    extra = list(also)
    if bridge.model.n_modes:
        f1 = float(bridge.model.frequencies[0])
        for tr in train.trains:
            d = float(tr.regular_length)
            if d > 0:
                for v in resonance_speeds_kmh(f1, d, RESONANCE_ORDERS):
                    extra += [round(v + dv, 1) for dv in (-1.0, 0.0, 1.0)]
    merged = sorted(set(speeds) | {v for v in extra if lo <= v <= hi})
    out = []
    for v in merged:  # drop near-duplicates of listed speeds
        if not out or v - out[-1] > 1e-6:
            out.append(v)
    return out
