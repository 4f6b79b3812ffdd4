"""The keys of ``[study]``: the speeds, the output and the variants."""

from typing import Annotated, Any, ClassVar

from pydantic import Field, ValidationInfo, field_validator

from vsi_numba import en1991
from vsi_numba.config.limits import MAX_SPEEDS
from vsi_numba.config.schema._fields import (
    Num,
    PosNum,
    Section,
    Speed,
    key,
    one_of,
    rule,
)
from vsi_numba.model.irregularity import SPEED_BOUND_KMH

# ------------------------------------------------------------------------------ [study]

class SpeedGrid(Section):
    """``{start, stop, step}`` in km/h (stop included when on the grid)."""

    start: Speed = key(required=True, unit="km/h", doc="first speed",
                       expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    stop: Speed = key(required=True, unit="km/h", doc="last speed",
                      expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    step: PosNum = key(required=True, unit="km/h", doc="speed step",
                       expected="a step > 0 km/h")

    @field_validator("stop")
    @classmethod
    def _stop_after_start(cls, v: float, info: ValidationInfo) -> float:
        start = info.data.get("start")
        if start is not None and v < start:
            raise rule("study.speeds_kmh.stop", v, f"a speed >= start = {start:g} km/h")
        return v

    @field_validator("step")
    @classmethod
    def _not_too_many_speeds(cls, v: float, info: ValidationInfo) -> float:
        start, stop = info.data.get("start"), info.data.get("stop")
        if start is not None and stop is not None and (stop - start) / v >= MAX_SPEEDS:
            raise rule("study.speeds_kmh.step", v,
                        f"a step giving at most {MAX_SPEEDS} speeds")
        return v




_SPEED_EXPECTED = f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})"


class Study(Section):
    """``[study]``: the speeds, the output file, what is kept and the variants."""

    TABLE: ClassVar[str] = "a table [study] with speeds_kmh"

    speeds_kmh: Speed | Annotated[list[Speed], Field(min_length=1, max_length=MAX_SPEEDS)] \
            | SpeedGrid = key(
        None, unit="km/h", default_text="required (or line_speed_kmh)",
        doc=f"a list of speeds (at most {MAX_SPEEDS}), or {{start, stop, step}}",
        expected="a list of speeds > 0 km/h, or a table {start, stop, step} in km/h",
        each=_SPEED_EXPECTED)

    @field_validator("speeds_kmh")
    @classmethod
    def _distinct_speeds(cls, v):
        if isinstance(v, list) and len(set(v)) != len(v):
            raise rule("study.speeds_kmh", v, "distinct speeds")
        return v

    line_speed_kmh: Speed = key(
        None, unit="km/h", doc="instead of speeds_kmh: 140 km/h to 1.2 x line speed "
                               "(included), step 5; next to speeds_kmh: a warning when "
                               "they stop below 1.2 x line speed (EN 1991-2 6.4.6.2 [R])",
        expected=f"a line speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    output: Annotated[str, Field(pattern=r"^[^\x00]*\.nc$")] = key(
        None, default_text="results/<stem>.nc",
        doc="the netCDF results file, relative to the config's directory",
        expected="a path to a netCDF file ending in .nc")
    save_time_histories: bool = key(True, doc="write time histories (envelopes always are)")
    history_speeds_kmh: Speed | list[Speed] = key(
        None, unit="km/h", default_text="every speed",
        doc="keep time histories only for these speeds",
        expected="a list of speeds (km/h) taken from study.speeds_kmh", each=_SPEED_EXPECTED)
    classification_factor: Num() = key(
        None, default_text="1.0", expected="a load classification factor alpha of LM71 "
                                            "(a number in the code profile's range)",
        doc="alpha of LM71 in the load-effect checks, in the code profile's range "
            "(0.75-1.46, EN 1991-2 6.3.2(3) [R])")
    track_maintenance: one_of(en1991.TRACK_MAINTENANCE) = key(
        None, default_text="standard",
        doc="dynamic factor of LM71: standard Phi_3, careful Phi_2 (EN 1991-2 6.4.5.2 [R])",
        note=" (the dynamic factor of LM71: 'careful' maintenance Phi_2, 'standard' Phi_3, "
             "EN 1991-2 6.4.5.2)")
    load_effects: bool = key(True, doc="reduce bending moments, shears, reactions and "
                                       "rotations in the runs (built-in decks)")
    refine_resonance: bool = key(False, doc="add the resonance speeds v = f1 D / i of every "
                                            "train (and variant) inside the grid")
    vary: dict[str, list[Any]] = key(
        None, doc="variants: key paths, each with a list of values",
        expected="a table of key paths, each with a list of values, e.g. \"bridge.EI\" = "
                 "[7e10, 8e10]", each="a non-empty list of values, one per variant")
    vary_together: list[dict[str, Any]] | dict[str, Any] = key(
        None, doc="variants: tables of key paths varied together (optional label)",
        expected="tables ([[study.vary_together]]) of key paths whose value lists are "
                 "varied together", each="a table of key paths, each with a list of values")
    mass_bounds: Annotated[list[PosNum], Field(min_length=1)] = key(
        None, doc="factors on bridge.mass_per_length, e.g. [0.9, 1.1] (EN 1991-2 6.4.6.3.2)",
        expected="factors on bridge.mass_per_length, e.g. [0.9, 1.1] (EN 1991-2 6.4.6.3.2: "
                 "lower and upper bound)", each="a factor on bridge.mass_per_length > 0")
