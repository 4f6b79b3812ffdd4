"""``[study]``: the speeds, the output file, the time histories kept, the variants
(``vary``, ``vary_together``, ``mass_bounds``) and the resonance-speed refinement."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _drop_none,
    _ok,
    _resolve,
    _Sentinel,
)
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import expected_of, item_type
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

    @property
    def speeds_m_s(self) -> np.ndarray:
        """The study's speeds in m/s: ``speeds_kmh`` / 3.6, the one conversion of the
        speeds (:attr:`vsi_numba.config.Config.speeds_m_s` is this of its speeds)."""
        return speeds_m_s(self.resolved["speeds_kmh"])


def speeds_m_s(speeds_kmh) -> np.ndarray:
    """Speeds in km/h as m/s (shape kept): the one conversion of the configuration's
    speeds."""
    return np.asarray(speeds_kmh, float) / 3.6


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


def _study_section(chk, s, default_output: str, base_dir: Path, profile=None
                   ) -> _StudySpec | _Sentinel:
    """The study of a validated ``[study]`` (:class:`~.schema.models.Study`) and the
    checks that are not rules of the model: the output path, the kept speeds among the
    study's, the variants and the code profile's range of the classification factor."""
    if s in (_MISSING, _BAD):  # (a missing [study] is reported with the file's keys)
        return _BAD
    line = s.line_speed_kmh
    speeds = _BAD
    expected = expected_of(_m.Study, "speeds_kmh")
    raw = s.speeds_kmh
    if isinstance(raw, _m.SpeedGrid):
        speeds = _speed_grid(raw.start, raw.stop, raw.step).tolist()
    elif raw is not None:
        # both: the speeds are the study's, the line speed the one the EN range must
        # reach (1.2 x line speed, EN 1991-2 6.4.6.2 [R]); checked by the physics checks
        speeds = list(raw) if isinstance(raw, list) else [raw]
    elif line is None:
        chk.error("study.speeds_kmh", _MISSING, expected + " (or give study.line_speed_kmh)")
    else:
        speeds = _line_speed_grid(line)
    output = default_output if s.output is None else s.output
    out_full = _resolve(base_dir, output)
    if out_full is None:
        output = chk.error("study.output", output, "a valid path of a netCDF file")
    elif out_full.is_dir():
        output = chk.error("study.output", output, f"a file path ({out_full} is a "
                                                   "directory)")
    hist = s.history_speeds_kmh
    if hist is not None:
        hist = list(hist) if isinstance(hist, list) else [hist]
        if isinstance(speeds, list):
            for i, v in enumerate(hist):
                if not any(abs(v - g) <= 1e-6 * max(1.0, g) for g in speeds):
                    chk.error(f"study.history_speeds_kmh[{i}]", v,
                              "one of the speeds of study.speeds_kmh")
                    hist = _BAD
                    break
    given = {k: getattr(s, k) for k in ("vary", "vary_together", "mass_bounds")
             if k in s.model_fields_set}
    axes = _vary_axes(chk, given)
    lo, hi = ALPHA_RANGE
    clause = ALPHA_CLAUSE
    if profile is not None:  # the code profile's range (a national annex may widen it)
        lo, hi = profile["classification_factor_min"], profile["classification_factor_max"]
        clause = profile.clause("classification_factor_min", "classification_factor_max")
    alpha = s.classification_factor
    if alpha is not None and not lo <= alpha <= hi:
        alpha = chk.error("study.classification_factor", alpha,
                          f"a load classification factor alpha of LM71 in [{lo:g}, {hi:g}] "
                          f"({clause})")
    if not _ok(speeds, output, hist, out_full, axes, alpha):
        return _BAD
    vary = dict(given)
    if s.refine_resonance:
        vary["refine_resonance"] = True
    resolved = _drop_none({"speeds_kmh": speeds, "line_speed_kmh": line, "output": output,
                           "save_time_histories": s.save_time_histories,
                           "history_speeds_kmh": hist,
                           "classification_factor": alpha,
                           "track_maintenance": s.track_maintenance,
                           "load_effects": None if s.load_effects else False, **vary})
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
