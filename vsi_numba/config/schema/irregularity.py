"""The keys of ``[irregularity]`` and ``[[irregularity.defects]]``: one model per kind."""

from typing import Annotated, ClassVar, Literal

from pydantic import (
    AfterValidator,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)

from vsi_numba.config.schema._fields import (
    Int,
    PosNum,
    Section,
    Text,
    key,
    one_of,
    rule,
)
from vsi_numba.model import irregularity as _irr

# ------------------------------------------------------------------------ [irregularity]



def _not_zero(x: float) -> float:
    if x == 0.0:
        raise ValueError("zero")
    return x


#: A depth or level change in metres: not zero, |x| < 1 m.
Amplitude = Annotated[float, Field(gt=-1, lt=1), AfterValidator(_not_zero)]


class _Defects(Section):
    TABLE: ClassVar[str] = ("a table [irregularity] with kind = 'none' | 'cosine' | 'psd' | "
                            "'file'")
    #: the keys of the other kinds given (ignored, warned by the reader)
    _ignored: list[str] = PrivateAttr(default_factory=list)

    defects: Annotated[list["Defect"], Field(min_length=1, max_length=1000)] = key(
        None, doc="isolated defects added to every realisation ([[irregularity.defects]])",
        expected="an array of tables [[irregularity.defects]] with kind = 'cosine' | "
                 "'step'")

    @model_validator(mode="wrap")
    @classmethod
    def _ignore_the_keys_of_other_kinds(cls, data, handler):
        """A key of another kind of profile is ignored (the reader warns): the table
        validates without it."""
        ignored = []
        if isinstance(data, dict):
            ignored = [k for k in data if k not in cls.model_fields and k in _EVERY_KEY]
            data = {k: v for k, v in data.items() if k not in ignored}
        out = handler(data)
        out._ignored = ignored
        return out


class _CosineKeys(Section):
    depth: Amplitude = key(required=True, unit="m", doc="depth (> 0 dip, < 0 bump)",
                                  expected="a depth != 0 m (> 0: dip, < 0: bump), "
                                           "|depth| < 1 m")
    wavelength: PosNum = key(required=True, unit="m", doc="wavelength",
                             expected="a wavelength > 0 m")
    position: float = key(required=True, unit="m", doc="where the defect starts",
                          expected="a position x (m) where the defect starts")


class _StepKeys(Section):
    height: Amplitude = key(required=True, unit="m",
                                   doc="level change (> 0: the rail ends lower)",
                                   expected="a level change != 0 m (> 0: the rail ends "
                                            "lower), |height| < 1 m")
    length: PosNum = key(required=True, unit="m", doc="transition length",
                         expected="a transition length > 0 m")
    position: float = key(required=True, unit="m", doc="where the transition starts",
                          expected="a position x (m) where the transition starts")
    shape: one_of(_irr.STEP_SHAPES) = key("cosine", doc="transition shape")


class CosineDefect(_CosineKeys):
    """An isolated cosine dip or bump."""

    TABLE: ClassVar[str] = "a table with kind = 'cosine' | 'step'"

    kind: Literal["cosine"] = key(required=True, doc="defect kind")


class StepDefect(_StepKeys):
    """A level change that persists (a settled transition)."""

    TABLE: ClassVar[str] = "a table with kind = 'cosine' | 'step'"

    kind: Literal["step"] = key(required=True, doc="defect kind")


Defect = Annotated[CosineDefect | StepDefect, Field(discriminator="kind")]
_Defects.model_rebuild()


class NoIrregularity(_Defects):
    """``kind = "none"``: a smooth track (plus any defects)."""

    kind: Literal["none"] = key("none", doc="track profile")


class CosineIrregularity(_Defects, _CosineKeys):
    """``kind = "cosine"``: an isolated cosine dip or bump."""

    kind: Literal["cosine"] = key(required=True, doc="track profile")


class StepIrregularity(_Defects, _StepKeys):
    """``kind = "step"``: a level change that persists."""

    kind: Literal["step"] = key(required=True, doc="track profile")


class PsdIrregularity(_Defects):
    """``kind = "psd"``: random track from a spectrum, one realisation per seed."""

    kind: Literal["psd"] = key(required=True, doc="track profile")
    spectrum: one_of(_irr.SPECTRA) = key(required=True, doc="the track spectrum")
    wavelength_min: PosNum = key(required=True, unit="m", doc="shortest wavelength",
                                 expected="a wavelength > 0 m")
    wavelength_max: PosNum = key(required=True, unit="m", doc="longest wavelength",
                                 expected="a wavelength > 0 m")
    seeds: Int(ge=0, lt=2 ** 63) | Annotated[list[Int(ge=0, lt=2 ** 63)],
                                             Field(min_length=1, max_length=10_000)] = key(
        required=True, doc="random seeds, one realisation each",
        expected="a non-empty list of distinct integer seeds >= 0",
        each="an integer seed 0 <= seed < 2^63")
    dx: PosNum = key(None, unit="m", default_text="wavelength_min / 20",
                     doc="sample spacing", expected="a sample spacing > 0 m")

    @field_validator("wavelength_max")
    @classmethod
    def _band_in_order(cls, v: float, info: ValidationInfo) -> float:
        lo = info.data.get("wavelength_min")
        if lo is not None and not v > lo:
            raise rule("irregularity.wavelength_max", v,
                        f"a wavelength > wavelength_min = {lo:g} m")
        return v

    @field_validator("seeds")
    @classmethod
    def _distinct_seeds(cls, v):
        if isinstance(v, list) and len(set(v)) != len(v):
            raise rule("irregularity.seeds", v, "distinct seeds")
        return v

    @field_validator("dx")
    @classmethod
    def _resolves_the_band(cls, v: float, info: ValidationInfo) -> float:
        lo = info.data.get("wavelength_min")
        if v is not None and lo is not None and v > lo / 2:
            raise rule("irregularity.dx", v, f"a sample spacing <= wavelength_min / 2 = "
                                              f"{lo / 2:g} m (Nyquist)")
        return v


#: A column name of a CSV file: not blank.
_Column = Annotated[str, Field(min_length=1, pattern=r"\S")]


class FileIrregularity(_Defects):
    """``kind = "file"``: a measured profile (CSV)."""

    kind: Literal["file"] = key(required=True, doc="track profile")
    path: Text = key(required=True, doc="the profile (CSV, columns x and r)")
    x_column: _Column = key("x", doc="column of the position",
                            expected="a column name (string)")
    r_column: _Column = key("r", doc="column of the profile",
                            expected="a column name (string)")
    r_unit: Literal["m", "mm"] = key("m", doc="unit of the profile column")
    dx: PosNum = key(None, unit="m", default_text="the file's", doc="resampling spacing",
                     expected="a sample spacing > 0 m")


def _irregularity_kind(v):
    return v.get("kind", "none") if isinstance(v, dict) else getattr(v, "kind", None)


Irregularity = Annotated[
    Annotated[NoIrregularity, Tag("none")] | Annotated[CosineIrregularity, Tag("cosine")]
    | Annotated[StepIrregularity, Tag("step")] | Annotated[PsdIrregularity, Tag("psd")]
    | Annotated[FileIrregularity, Tag("file")],
    Discriminator(_irregularity_kind)]


#: Every key of the kinds of ``[irregularity]``.
_EVERY_KEY = frozenset().union(*(m.model_fields for m in (
    NoIrregularity, CosineIrregularity, StepIrregularity, PsdIrregularity, FileIrregularity)))
