"""The keys of ``[report]``, ``[code_profile]``, ``[fatigue]`` and ``[compatibility]``."""

from typing import Annotated, ClassVar

from pydantic import AfterValidator, Field, PrivateAttr, model_validator

from vsi_numba.code_profile import ANNEX_D_MIXES, DEFAULT_NAME, TABLE, limits_of
from vsi_numba.config.schema._fields import (
    Int,
    Num,
    Section,
    key,
    one_of,
    rule,
)

# ---------------------------------------------------------------- [report] [code_profile]

MAX_TEXT = 200
#: One line of text, not blank (stripped).
_Line = Annotated[str, Field(min_length=1, max_length=MAX_TEXT, pattern=r"^[^\n]*\S[^\n]*$"),
                  AfterValidator(str.strip)]
#: A number that stands for its text (revision = 2 means "2").
_NumberText = Annotated[int | float, AfterValidator(str)]
_LINE = f"one line of text (1 to {MAX_TEXT} characters)"
#: A name: not blank (stripped).
_NotBlank = Annotated[str, Field(min_length=1, pattern=r"\S")]
_Name = Annotated[_NotBlank, AfterValidator(str.strip)]


class Report(Section):
    """``[report]``: the title block of the report (one line of text each)."""

    TABLE: ClassVar[str] = "a table [report] of text fields (project, revision, checked_by, ...)"

    project: _Line = key(None, doc="project", expected=_LINE)
    client: _Line = key(None, doc="client", expected=_LINE)
    document: _Line | _NumberText = key(None, doc="document number", expected=_LINE)
    revision: _Line | _NumberText = key(None, doc="revision", expected=_LINE)
    prepared_by: _Line = key(None, doc="prepared by", expected=_LINE)
    checked_by: _Line = key(None, doc="checked by", expected=_LINE)
    approved_by: _Line = key(None, doc="approved by", expected=_LINE)
    date: _Line = key(None, doc="date", expected=_LINE)


class SourcedValue(Section):
    """``{value, clause}``: an override with the clause or rule it comes from."""

    value: float = key(required=True, doc="the value in the entry's SI unit",
                       expected="the value in the entry's SI unit (a number)")
    clause: _NotBlank = key(None, doc="the clause or rule the value comes from",
                            expected="the clause or rule the value comes from (a string)")


_EXAMPLE = "{deck_acceleration_limit_ballasted = 3.0}"


def _entry_expected(e) -> str:
    """The expectation of an override of entry ``e`` of the code profile."""
    unit = "" if e.unit == "1" else f" {e.unit}"
    kind = "a whole number" if e.integer else "a number"
    return (f"{kind} {e.limits.text()}{unit} ({e.description}; recommended {e.value:g}"
            f"{unit}, {e.clause}), or a table {{value = ..., clause = \"...\"}}")


def _within_entry(e, number):
    """The check of a ``{value, clause}`` override against the bounds of its entry (those
    of its number)."""
    from vsi_numba.config.schema._fields import number_of

    def check(v):
        if isinstance(v, SourcedValue) and number_of(number, v.value) is None:
            raise rule(f"code_profile.overrides.{e.key}.value", v.value, _entry_expected(e))
        return v
    return check


def _override_fields():
    out = {}
    for e in TABLE:
        if e.applies == "fixed":
            continue
        unit = "" if e.unit == "1" else e.unit
        number = (Int if e.integer else Num)(**e.limits.as_dict())
        tp = Annotated[number | SourcedValue, AfterValidator(_within_entry(e, number))]
        out[e.key] = (tp, key(None, unit=unit, default_text=f"{e.value:g}",
                              doc=f"{e.description} ({e.clause})", expected=_entry_expected(e)))
    return out


#: The entries of the code profile that no profile overrides.
FIXED = frozenset(e.key for e in TABLE if e.applies == "fixed")


class _OverridesBase(Section):
    TABLE: ClassVar[str] = f"a table of code profile keys and values, e.g. {_EXAMPLE}"
    #: the fixed entries given (refused by the reader, which names why)
    _fixed: dict = PrivateAttr(default_factory=dict)
    #: the entries as given, in the order given (the stored section keeps it)
    _given: dict = PrivateAttr(default_factory=dict)

    @model_validator(mode="wrap")
    @classmethod
    def _set_aside_the_fixed_entries(cls, data, handler):
        fixed, given = {}, {}
        if isinstance(data, dict):
            fixed = {k: v for k, v in data.items() if k in FIXED}
            given = {k: v for k, v in data.items() if k not in FIXED}
            data = given
        out = handler(data)
        out._fixed, out._given = fixed, given
        return out


def _overrides_model():
    from pydantic import create_model

    return create_model("Overrides", __base__=_OverridesBase, **_override_fields())


Overrides = _overrides_model()
Overrides.__doc__ = ("``[code_profile] overrides``: entries of the code profile "
                     "(:mod:`vsi_numba.code_profile`), a number in the entry's SI unit or "
                     "{value, clause}.")


class CodeProfile(Section):
    """``[code_profile]``: the clause values of the checks (a national annex, a client's
    rule), stored with the results."""

    TABLE: ClassVar[str] = ("a table [code_profile] with name and overrides, e.g. overrides = "
                            + _EXAMPLE)

    name: _NotBlank = key(DEFAULT_NAME, doc="the profile's name, printed in the report",
                          expected="the name of the profile (a string), e.g. \"DE national "
                                   "annex\"")
    overrides: Overrides = key(None, doc="entries of the code profile: a number in the "
                                         "entry's SI unit, or {value, clause}")


# ---------------------------------------------------------- [fatigue] [compatibility]

#: The models of a train in ``[[fatigue.traffic]]``.
FATIGUE_MODELS = ("moving_force", "interaction")
_GAMMA_EXPECTED = f"a partial factor {limits_of('fatigue_gamma_Mf').text()}"


class FatigueSection(Section):
    """``[[fatigue.sections]]``: a steel detail of the deck, its stress the bending moment
    at ``x`` over the section modulus."""

    TABLE: ClassVar[str] = "a table with x, section_modulus, detail_category"

    x: Num(ge=0) = key(required=True, unit="m", doc="position of the section from the left "
                       "end of the deck", expected="a position >= 0 m along the deck",
                       example=10.0)
    section_modulus: Num(ge=1e-9) = key(required=True, unit="m^3",
                                  doc="section modulus W at the detail: stress = M / W",
                                  expected="a section modulus > 0 m^3 (stress = M / W; at "
                                           "least 1e-9 m^3)",
                                  example=0.045, plausible=(1e-4, 10.0),
                                  typical="about 0.001 to 5 m^3")
    detail_category: Num(gt=0, le=1000) = key(
        required=True, unit="MPa", doc="EN 1993-1-9 detail category Delta sigma_C (Tables "
                                       "8.1-8.10 [R]: 36 to 160)",
        expected="a detail category > 0 MPa (EN 1993-1-9: 36 to 160)", example=71)
    gamma_Ff: Num(**limits_of("fatigue_gamma_Ff").as_dict()) = key(
        None, default_text="code profile fatigue_gamma_Ff",
        doc="partial factor on the fatigue stress ranges (EN 1993-2 9.3 [R])",
        expected=_GAMMA_EXPECTED)
    gamma_Mf: Num(**limits_of("fatigue_gamma_Mf").as_dict()) = key(
        None, default_text="code profile fatigue_gamma_Mf",
        doc="partial factor on the fatigue strength (EN 1993-1-9 Table 3.1 [R])",
        expected=_GAMMA_EXPECTED)
    name: _Name = key(None, default_text="its position", doc="name of the section in the "
                     "report", expected="a name (string)")


class FatigueStud(Section):
    """``[[fatigue.studs]]``: a row layout of headed stud shear connectors of a composite
    deck; the stud shear stress is tau = V S s / (I n pi d^2 / 4) from the vertical shear
    V at ``x`` (EN 1994-2 6.8 [R])."""

    TABLE: ClassVar[str] = ("a table with x, diameter, per_row, row_spacing, first_moment and "
                            "second_moment")

    x: Num(ge=0) = key(required=True, unit="m", doc="position of the studs from the left "
                       "end of the deck (the shear there)",
                       expected="a position >= 0 m along the deck", example=2.0)
    diameter: Num(gt=0, le=0.1) = key(
        required=True, unit="m", doc="shank diameter d of a stud",
        expected="a stud diameter > 0 m (at most 0.1 m)", example=0.022,
        plausible=(0.010, 0.035), typical="16 to 25 mm (0.016 to 0.025 m)")
    per_row: Int(ge=1, le=20) = key(required=True, doc="studs per row n (across the "
                                    "flange(s) of the section)",
                                    expected="a whole number of studs per row, 1 to 20",
                                    example=4)
    row_spacing: Num(gt=0, le=5) = key(
        required=True, unit="m", doc="spacing s of the rows along the deck",
        expected="a row spacing > 0 m (at most 5 m)", example=0.15,
        plausible=(0.05, 1.0), typical="0.1 to 0.8 m")
    first_moment: Num(gt=0, le=100) = key(
        required=True, unit="m^3", doc="first moment S of the concrete slab (transformed "
                                       "to steel) about the composite neutral axis",
        expected="a first moment > 0 m^3", example=0.06, plausible=(1e-4, 10.0),
        typical="about 0.005 to 1 m^3")
    second_moment: Num(gt=0, le=1000) = key(
        required=True, unit="m^4", doc="second moment I of the composite section "
                                       "(transformed to steel); v_L = V S / I",
        expected="a second moment of area > 0 m^4", example=0.12,
        plausible=(1e-4, 100.0), typical="about 0.005 to 10 m^4")
    gamma_Ff: Num(**limits_of("fatigue_gamma_Ff").as_dict()) = key(
        None, default_text="code profile fatigue_gamma_Ff",
        doc="partial factor on the shear-stress ranges (EN 1993-2 9.3 [R])",
        expected=_GAMMA_EXPECTED)
    gamma_Mf: Num(**limits_of("fatigue_stud_gamma_Mf").as_dict()) = key(
        None, default_text="code profile fatigue_stud_gamma_Mf",
        doc="partial factor gamma_Mf,s on the stud fatigue strength (EN 1994-2 2.4.1.2 "
            "[R])", expected=_GAMMA_EXPECTED)
    name: _Name = key(None, default_text="its position", doc="name of the stud layout in "
                     "the report", expected="a name (string)")


class FatigueTraffic(Section):
    """``[[fatigue.traffic]]``: one train of the operator's traffic (added to the mix)."""

    TABLE: ClassVar[str] = "a table with train, speed_kmh, per_day"

    train: _NotBlank = key(required=True, doc="a library train, AnnexD-1 .. AnnexD-12, or an "
                                         "axle-load CSV file (position m, load kN; relative "
                                         "to the config)",
                      expected="a train name (`vsi trains` lists them; AnnexD-1 .. "
                               "AnnexD-12)", example="ICE3")
    speed_kmh: Num(gt=0, le=600) = key(required=True, unit="km/h", doc="its speed",
                                       expected="a speed > 0 km/h (at most 600)",
                                       example=250.0)
    per_day: Num(gt=0, le=10000) = key(required=True, unit="1/day",
                                       doc="passages per day",
                                       expected="a number of trains per day > 0",
                                       example=20)
    model: one_of(FATIGUE_MODELS) = key("moving_force", doc="the train's model: moving "
                                        "forces or the vehicles' dynamics (library trains "
                                        "that have it)")


class Fatigue(Section):
    """``[fatigue]``: the fatigue check of steel details of the deck under the dynamic
    stress histories of a traffic (EN 1991-2 6.4.6.6 [R], EN 1993-1-9)."""

    TABLE: ClassVar[str] = ("a table [fatigue] with design_life_years, [[fatigue.sections]] and "
                            "[[fatigue.traffic]] or mix")

    design_life_years: Num(gt=0, le=1000) = key(
        100.0, unit="years", doc="design life: passages = per_day x 365 x years",
        expected="a design life > 0 years (at most 1000)")
    mix: one_of(ANNEX_D_MIXES) = key(
        None, doc="an EN 1991-2 Annex D traffic mix [R], each train type at its Table D.1 "
                  "speed (added to [[fatigue.traffic]])",
        note=" (EN 1991-2 Annex D traffic mix)")
    sections: Annotated[list[FatigueSection], Field(min_length=1)] = key(
        required=True, doc="the details checked ([[fatigue.sections]], one or more)",
        expected="one or more [[fatigue.sections]] with x, section_modulus and "
                 "detail_category")
    studs: Annotated[list[FatigueStud], Field(min_length=1)] = key(
        None, default_text="none", doc="headed stud shear connectors checked from the "
                                       "shear histories ([[fatigue.studs]])",
        expected="[[fatigue.studs]] with x, diameter, per_row, row_spacing, first_moment "
                 "and second_moment")
    traffic: list[FatigueTraffic] = key(
        None, default_text="required without mix",
        doc="the operator's trains ([[fatigue.traffic]])",
        expected="[[fatigue.traffic]] with train, speed_kmh and per_day, or fatigue.mix")


class Compatibility(Section):
    """``[compatibility]``: is the train compatible with this existing bridge?  The
    study's speeds must reach speed_factor x line_speed_kmh."""

    TABLE: ClassVar[str] = "a table [compatibility] with train and line_speed_kmh"

    train: _NotBlank = key(required=True, doc="the train under check (one of the study's "
                                         "trains)",
                      expected="the name of the train under check (one of train.preset)",
                      example="ICE3")
    line_speed_kmh: Num(gt=0, le=600) = key(
        required=True, unit="km/h", doc="maximum line speed at the bridge",
        expected="a line speed > 0 km/h (at most 600)", example=300.0)
    speed_factor: Num(**limits_of("compatibility_speed_factor").as_dict()) = key(
        None, default_text="code profile compatibility_speed_factor",
        doc="checked up to this factor x the line speed ([R] practice for existing lines)",
        expected=f"a factor {limits_of('compatibility_speed_factor').text()} on the line "
                 "speed")
