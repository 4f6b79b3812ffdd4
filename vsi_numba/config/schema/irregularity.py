"""The keys of ``[irregularity]`` and ``[[irregularity.defects]]``: one model per kind."""

from typing import Annotated, Literal

from pydantic import Discriminator, Field, Tag

from vsi_numba.config.schema._fields import (
    Int,
    Num,
    PosNum,
    Section,
    Text,
    key,
    one_of,
)
from vsi_numba.model import irregularity as _irr

# ------------------------------------------------------------------------ [irregularity]

class _Defects(Section):
    defects: list["Defect"] = key(None, doc="isolated defects added to every realisation "
                                            "([[irregularity.defects]])")


class _CosineKeys(Section):
    depth: Num(gt=-1, lt=1) = key(required=True, unit="m", doc="depth (> 0 dip, < 0 bump)",
                                  expected="a depth != 0 m (> 0: dip, < 0: bump), "
                                           "|depth| < 1 m")
    wavelength: PosNum = key(required=True, unit="m", doc="wavelength",
                             expected="a wavelength > 0 m")
    position: float = key(required=True, unit="m", doc="where the defect starts",
                          expected="a position x (m) where the defect starts")


class _StepKeys(Section):
    height: Num(gt=-1, lt=1) = key(required=True, unit="m",
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

    kind: Literal["cosine"] = key(required=True, doc="defect kind")


class StepDefect(_StepKeys):
    """A level change that persists (a settled transition)."""

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
    seeds: Int(ge=0, lt=2 ** 63) | list[Int(ge=0, lt=2 ** 63)] = key(
        required=True, doc="random seeds, one realisation each",
        expected="a non-empty list of distinct integer seeds >= 0")
    dx: PosNum = key(None, unit="m", default_text="wavelength_min / 20",
                     doc="sample spacing", expected="a sample spacing > 0 m")


class FileIrregularity(_Defects):
    """``kind = "file"``: a measured profile (CSV)."""

    kind: Literal["file"] = key(required=True, doc="track profile")
    path: Text = key(required=True, doc="the profile (CSV, columns x and r)")
    x_column: Text = key("x", doc="column of the position", expected="a column name (string)")
    r_column: Text = key("r", doc="column of the profile", expected="a column name (string)")
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
