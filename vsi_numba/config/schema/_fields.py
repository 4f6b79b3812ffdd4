"""The building blocks of the declared schema: numbers with bounds, and :func:`key`, the
one declaration of a configuration key (type, bounds, default, unit, description and the
expectation its error message states).

A key is declared once, as a field of a section model (:mod:`.models`)::

    dt: Num(gt=0) = key(1e-3, unit="s", doc="time step", expected="a time step > 0 s")

From that declaration come the JSON Schema shipped with the package, the key reference of
the documentation, the ``vsi init`` template and the checks of the section readers
(:meth:`vsi_numba.config._check._Checker.fields` validates a key with :func:`adapter` and
reports it with its declared expectation).
"""

from __future__ import annotations

import functools
import math
import types
import typing
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter
from pydantic_core import PydanticCustomError, PydanticUndefined

from vsi_numba.model.irregularity import SPEED_BOUND_KMH

#: Every section model: unknown keys are errors, numbers are TOML numbers (no strings, no
#: booleans), integers stay integers, nan and inf are refused.
STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False,
                    populate_by_name=False, use_attribute_docstrings=False)


class Section(BaseModel):
    """Base of every section model (one TOML table)."""

    model_config = STRICT


def Num(*, gt=None, ge=None, lt=None, le=None):  # noqa: N802 (reads as a type)
    """A finite real number (a TOML integer or float) within the given bounds."""
    return Annotated[float, Field(gt=gt, ge=ge, lt=lt, le=le)]


def Int(*, gt=None, ge=None, lt=None, le=None):  # noqa: N802
    """A TOML integer within the given bounds."""
    return Annotated[int, Field(gt=gt, ge=ge, lt=lt, le=le)]


#: A non-empty string.
Text = Annotated[str, Field(min_length=1)]
#: A number > 0; a speed in km/h (up to the bound of the track models); a matrix of rows.
PosNum = Num(gt=0)
Speed = Num(gt=0, le=SPEED_BOUND_KMH)
Matrix = list[list[float]]


def one_of(values) -> Any:
    """``Literal[...]`` of the names a module defines (one list of choices)."""
    return Literal[tuple(values)]

#: The error type of a rule of the models whose message is already in the style of the
#: configuration's messages (:func:`rule_error`).
RULE = "vsi_rule"


def rule_error(message: str) -> PydanticCustomError:
    """An error of a rule of the models (a validator of a key against another), raised
    with its whole message (key path, value, expectation)."""
    return PydanticCustomError(RULE, "{message}", {"message": message})


def rules_here(problems, *, field: bool = False) -> PydanticCustomError:
    """The errors of a rule of a table met wherever the table is (an item of a list):
    ``problems`` are ``(key, value, expected)`` of its keys (``value`` :data:`MISSING`
    for a missing key), each reported at the table's key path (:func:`~vsi_numba.config.
    _errors.messages` adds it, and puts it for :data:`TABLE_PATH` in an expectation), all
    at once. ``field``: raised by a validator of one key (the table is the key's)."""
    from vsi_numba.config._show import _show

    lines = [f"{k}: missing required key; expected {exp}" if v is MISSING else
             f"{k} = {_show(v)}: expected {exp}" for k, v, exp in problems]
    return PydanticCustomError(RULE, "{message}", {"message": "\n".join(lines),
                                                   "here": "field" if field else True})


#: The value of a missing key in :func:`rules_here`.
MISSING = "<missing>"
#: Stands for the key path of the table in an expectation of :func:`rules_here`
#: ("a symmetric matrix (<table>.K[1][0] = ...)").
TABLE_PATH = "<table>"


def rule(path: str, value, expected: str) -> PydanticCustomError:
    """:func:`rule_error` of the message ``path = value: expected ...``."""
    from vsi_numba.config._show import _show

    return rule_error(f"{path} = {_show(value)}: expected {expected}")


#: Marks a key without a default (required, or required under a condition the
#: description states).
REQUIRED: Any = PydanticUndefined


#: The unit slips named when a value is outside its plausible range: unit of the key ->
#: (the unit it looks like, the factor from a value in that unit to the key's unit).
SLIPS: dict[str, tuple[tuple[str, float], ...]] = {
    "m": (("mm", 1e-3),),
    "m^3": (("cm^3", 1e-6), ("mm^3", 1e-9)),
    "kg/m": (("t/m", 1e3),),
    "kg": (("t", 1e3),),
    "N": (("kN", 1e3),),
    "N m^2": (("kN m^2", 1e3), ("MN m^2", 1e6)),
    "kg m^2/m": (("t m^2/m", 1e3),),
    "km/h": (("m/s", 3.6),),
}


def item_type(model: type[BaseModel], name: str) -> Any:
    """The declared type of one number of key ``name``: the key's type, or that of one
    item of its list (``X | list[X]``, ``list[X]``; a table member of a union is not a
    number)."""
    tp = model.model_fields[name].annotation
    members = typing.get_args(tp) if typing.get_origin(tp) in (Union, types.UnionType) \
        else (tp,)
    for m in members:
        if typing.get_origin(m) is list:
            return typing.get_args(m)[0]
    return members[0]


def number_of(tp, value) -> int | float | None:
    """``value`` as a number of the declared type ``tp`` (:func:`Num`, :func:`Int`,
    ``float``, ``int``), or None: a TOML integer for an integer type, a finite number
    otherwise (no boolean), within the bounds ``tp`` declares."""
    base, *meta = typing.get_args(tp) if typing.get_origin(tp) is Annotated else (tp,)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    if base is int:
        if not isinstance(value, int):
            return None
        x = int(value)
    else:
        try:
            if not math.isfinite(float(value)):
                return None
        except OverflowError:  # an int beyond the float range
            return None
        x = float(value)
    for info in meta:
        for b in getattr(info, "metadata", ()):
            gt, ge = getattr(b, "gt", None), getattr(b, "ge", None)
            lt, le = getattr(b, "lt", None), getattr(b, "le", None)
            if ((gt is not None and not x > gt) or (ge is not None and not x >= ge)
                    or (lt is not None and not x < lt) or (le is not None and not x <= le)):
                return None
    return x


def key(default: Any = None, *, doc: str, unit: str = "", expected: str = "",
        default_text: str = "", required: bool = False, example: Any = None,
        plausible: tuple[float, float] | None = None, typical: str = "", each: str = "",
        scalar: str = "", note: str = "", missing: str = ""):
    """Declare a configuration key.

    Parameters
    ----------
    default : object
        The value taken when the key is absent; None when the default is a rule (then
        ``default_text`` states it) or the key is optional.
    doc : str
        What the key is (the key reference, the JSON Schema description, the template's
        comment).
    unit : str
        Its unit ("m", "N m^2", "km/h"; "" for none).
    expected : str
        The expectation of its error message ("a span length > 0 m").
    default_text : str
        The default in words when it is a rule ("every mode up to the cut-off").
    required : bool
        The key must be given (missing-key error).
    example : object
        A value for the ``vsi init`` template and the documentation (optional).
    plausible : (float, float), optional
        The range (inclusive) of the values a railway bridge or train has: a value within
        the bounds but outside this range is refused unless ``solver.allow_implausible``
        (the message names the unit slip it looks like, :data:`SLIPS`).
    typical : str
        A typical value in words, for that message ("1.435 m, standard gauge").
    each : str
        The expectation of one item of the key's list ("a speed > 0 km/h"), when it
        differs from the key's.
    scalar : str
        The expectation of the key given as one number, for a key that takes a number or
        a list ("a span length > 0 m"), when it differs from the key's.
    note : str
        Words after the choices of a closed set in its message (" (the dynamic
        factor of LM71 ...)").
    missing : str
        The expectation of the message of a missing required key, when it differs from
        ``expected`` (what to give, rather than what a given value must be).
    """
    extra = {"unit": unit}
    if plausible is not None:
        extra["plausible"] = [float(plausible[0]), float(plausible[1])]
    if typical:
        extra["typical"] = typical
    if expected:
        extra["expected"] = expected
    if default_text:
        extra["default_text"] = default_text
    if each:
        extra["each"] = each
    if scalar:
        extra["scalar"] = scalar
    if note:
        extra["note"] = note
    if missing:
        extra["missing"] = missing
    if example is not None:
        extra["example"] = example
    if required:
        return Field(description=doc, json_schema_extra=extra)
    return Field(default, description=doc, json_schema_extra=extra)


# -- reading the declarations back

def extras(model: type[BaseModel], name: str) -> dict:
    """The unit, expectation, default text and example of a field."""
    e = model.model_fields[name].json_schema_extra
    return dict(e) if isinstance(e, dict) else {}


def keys_of(*models: type[BaseModel]) -> set[str]:
    """The key names of one or more section models."""
    return set().union(*(m.model_fields for m in models))


def kinds_of(union) -> dict[str, type[BaseModel]]:
    """``{kind: model}`` of a union of models told apart by their ``kind`` key."""
    return {lit: m for m in section_models(union)
            for lit in typing.get_args(m.model_fields["kind"].annotation)}


def section_models(tp) -> list[type[BaseModel]]:
    """The models of a table's annotation: one, or one per kind of a union."""
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    if typing.get_origin(tp) is Annotated:
        return section_models(typing.get_args(tp)[0])
    if typing.get_origin(tp) in (Union, types.UnionType):
        return [m for a in typing.get_args(tp) for m in section_models(a)]
    return []


def model_for(tp, data) -> type[BaseModel] | None:
    """The model of a table's annotation that reads ``data`` (its kind's, for a union)."""
    models = section_models(tp)
    if len(models) <= 1:
        return models[0] if models else None
    for m in models:
        kind = m.model_fields["kind"]
        given = data.get("kind", kind.get_default()) if isinstance(data, dict) else None
        if given in typing.get_args(kind.annotation):
            return m
    return None


@functools.cache
def adapter(model: type[BaseModel], name: str) -> TypeAdapter:
    """The validator of one declared key (its annotation and bounds, strict)."""
    f = model.model_fields[name]
    tp = Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
    return TypeAdapter(tp, config=ConfigDict(strict=True, allow_inf_nan=False))


def choices_of(model: type[BaseModel], name: str) -> tuple | None:
    """The values of a key declared as a closed set (``Literal``), else None."""
    tp = model.model_fields[name].annotation
    return typing.get_args(tp) if typing.get_origin(tp) is Literal else None


def expected_of(model: type[BaseModel], name: str) -> str:
    """The expectation of a key's error message: its declared one, else from its type."""
    e = extras(model, name).get("expected")
    if e:
        return e
    tp = model.model_fields[name].annotation
    if tp is bool:
        return "true or false"
    return model.model_fields[name].description or name


def implausible(model: type[BaseModel], name: str, path: str, value) -> list[str]:
    """Messages for the numbers of ``value`` (a number or a list of them, validated by
    the declaration of key ``name`` of ``model``) outside the key's plausible range,
    each naming the key path, the value, the unit slip it looks like (:data:`SLIPS`) and
    the range; [] when the key declares none or every value is within it."""
    e = extras(model, name)
    rng = e.get("plausible")
    if rng is None:
        return []
    lo, hi = rng
    unit = e.get("unit", "")
    values = [(path, value)] if not isinstance(value, list) else [
        (f"{path}[{i}]", v) for i, v in enumerate(value)]
    out = []
    for p, v in values:
        if isinstance(v, bool) or not isinstance(v, int | float) or lo <= v <= hi:
            continue
        u = f" {unit}" if unit else ""
        looks = ""
        for slip, factor in SLIPS.get(unit, ()):
            if lo <= v * factor <= hi:
                looks = (f" looks like {slip} ({v:g} {slip} = {v * factor:.6g}{u})")
                break
        typical = f" ({e['typical']})" if e.get("typical") else ""
        out.append(f"{p} = {v:g}{u}{looks}: expected {lo:g} .. {hi:g}{u} on a railway "
                   f"bridge{typical}")
    return out
