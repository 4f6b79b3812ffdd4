"""The messages of a configuration the declared models refuse: a pydantic
``ValidationError`` of :mod:`vsi_numba.config.schema` rendered in the house style of
:mod:`vsi_numba.config._check` (key path, value, the declared expectation; a
did-you-mean for an unknown key or a misspelt choice; the kind a key belongs to).

An error location of pydantic names the union members it tried (``spans`` ->
``list[constrained-float]``, ``vehicles[0]`` -> ``car``): :func:`messages` follows the
declared annotations along the location, keeps the member that fits the given value (a
list for a list, a table for a table, the kind given) and states one message per key.
"""

from __future__ import annotations

import functools
import re
import types
import typing
from collections.abc import Mapping
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, Field, TypeAdapter, ValidationError

from vsi_numba.config._check import _did_you_mean
from vsi_numba.config._show import _join, _key, _show
from vsi_numba.config.schema._fields import (  # noqa: F401 (rule_error re-exported)
    RULE,
    TABLE_PATH,
    extras,
    rule_error,
)

#: The errors of a value that is not a table where one is declared.
_TABLE_ERRORS = ("model_type", "dict_type", "model_attributes_type")


def _strip(tp):
    while typing.get_origin(tp) is Annotated:
        tp = typing.get_args(tp)[0]
    return tp


def _members(tp) -> list:
    tp = _strip(tp)
    if typing.get_origin(tp) in (Union, types.UnionType):
        return [_strip(m) for m in typing.get_args(tp)]
    return [tp]


def _is_model(tp) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _kinds(member) -> tuple:
    if not _is_model(member) or "kind" not in member.model_fields:
        return ()
    ann = _strip(member.model_fields["kind"].annotation)
    return typing.get_args(ann) if typing.get_origin(ann) is Literal else ()


def _fits(member, value) -> bool:
    """Whether a union member is the one for this value (its shape)."""
    if typing.get_origin(member) is list:
        return isinstance(value, list)
    if _is_model(member) or typing.get_origin(member) is dict:
        return isinstance(value, Mapping)
    return not isinstance(value, list | Mapping)


def _tag_of(member, x) -> bool:
    """Whether ``x`` (an element of an error location) names this union member."""
    if not isinstance(x, str):
        return False
    if _is_model(member):
        return x == member.__name__ or x in _kinds(member)
    if typing.get_origin(member) is list:
        return x.startswith("list[")
    if typing.get_origin(member) is dict:
        return x.startswith("dict[")
    if typing.get_origin(member) is Literal:
        return x.startswith("literal[")
    if x.startswith(("list[", "dict[")):
        return False
    return "-" in x or x in ("int", "float", "str", "bool") or x.startswith(
        ("constrained", "function"))


class _Where:
    """Where an error is: its key path, the model and field that declare the key, whether
    it is an item of the key's list, the value there, and whether the union members on
    the way are those of the value."""

    def __init__(self):
        self.path = ""
        self.model = None
        self.field: str | None = None
        self.item = False
        self.value: Any = None
        self.fits = True
        #: the path of the last key on the way declared as a union of shapes (a number,
        #: a list, a table), whose member the location names
        self.union_key: str | None = None
        self.table = None  # the model of the table the error is in (or at)
        #: the number member of a key declared as a number or a list was chosen
        self.scalar = False
        self.tp = None  # the declared type at the error's location (None: unknown)


def _walk(loc, root, data, prefix: str) -> _Where:
    w = _Where()
    w.path, w.value, tp = prefix, data, root
    if _is_model(_strip(root)):
        w.table = _strip(root)
    for x in loc:
        members = _members(tp) if tp is not None else []
        if len(members) > 1:
            chosen = [m for m in members if _tag_of(m, x)]
            if chosen:
                tp = chosen[0]
                if not _kinds(tp):
                    w.union_key = w.path
                    w.fits = w.fits and _fits(tp, w.value)
                    w.scalar = not (_is_model(tp) or typing.get_origin(tp) in (list, dict))
                if _is_model(tp):
                    w.table = tp
                continue
            # a discriminated union: the location goes on with the given kind's model
            kind = w.value.get("kind") if isinstance(w.value, Mapping) else None
            tagged = [m for m in members if kind in _kinds(m)]
            tp = tagged[0] if tagged else None
            if tp is not None:
                w.table = tp
        tp = _strip(tp) if tp is not None else None
        if isinstance(x, int):
            w.path += f"[{x}]"
            w.value = w.value[x] if isinstance(w.value, list) and x < len(w.value) else None
            if typing.get_origin(tp) is list:
                tp = typing.get_args(tp)[0]
                w.item = True
                if _is_model(_strip(tp)):  # a table of a list of tables
                    w.table = _strip(tp)
            else:
                tp = None
            continue
        if typing.get_origin(tp) is dict:  # a value of a table of free keys
            w.path += f"[{_key(x)}]"
            w.value = w.value.get(x) if isinstance(w.value, Mapping) else None
            w.item = True
            tp = typing.get_args(tp)[1]
            continue
        w.path = _join(w.path, x)
        w.value = w.value.get(x) if isinstance(w.value, Mapping) else None
        if _is_model(tp) and x in tp.model_fields:
            w.model, w.field, w.item = tp, x, False
            tp = tp.model_fields[x].annotation
        else:
            tp = None
        if _is_model(_strip(tp)):
            w.table = _strip(tp)
    w.tp = tp
    return w


def _choices(model, name) -> tuple | None:
    tp = _strip(model.model_fields[name].annotation)
    return typing.get_args(tp) if typing.get_origin(tp) is Literal else None


def _listing(choices) -> str:
    listing = ", ".join(f"'{c}'" for c in choices)
    return f"one of {listing}" if len(choices) > 1 else listing


def expectation(model, name: str, *, item: bool = False, scalar: bool = False) -> str:
    """The expectation of key ``name`` of ``model`` in a message: the choices of a
    closed set (with the field's note), the declared expectation of one item of its
    list (``each``), of the key given as one number (``scalar``) or of the key."""
    from vsi_numba.config.schema._fields import expected_of

    e = extras(model, name)
    choices = _choices(model, name)
    if choices is not None and not (e.get("expected") and not all(
            isinstance(c, str) for c in choices)):  # (numbers: the declared words)
        return _listing(choices) + e.get("note", "")
    if item and e.get("each"):
        return e["each"]
    if scalar and e.get("scalar"):
        return e["scalar"]
    return expected_of(model, name)


def _table_expectation(model) -> str:
    return getattr(model, "TABLE", None) or "a table"


def _unknown(w: _Where, union, key: str, value) -> str:
    """The message of an unknown key ``key`` of the table at ``w``: a did-you-mean among
    the table's keys (the ``HIDDEN`` ones of its model left out), or the kind of
    ``union`` it belongs to."""
    path = _join(w.path, key)
    model = w.table
    hidden = getattr(model, "HIDDEN", frozenset())
    allowed = [k for k in model.model_fields if k not in hidden] if model else []
    other = [m for m in _members(union) if _is_model(m) and m is not model
             and key in m.model_fields] if union is not None else []
    if other and _kinds(model):
        mine = _kinds(model)[0]
        return (f"{path} = {_show(value)}: expected no such key for kind = '{mine}' (it "
                f"belongs to kind = '{_kinds(other[0])[0]}')")
    guess = _did_you_mean(key, allowed)
    hint = (f"did you mean '{guess}'?" if guess else
            "expected one of " + ", ".join(f"'{a}'" for a in sorted(allowed)))
    return f"{path} = {_show(value)}: unknown key; {hint}"


def messages(exc: ValidationError, root, data, prefix: str = "") -> list[str]:
    """The house-style messages of ``exc``, raised validating ``data`` (at key path
    ``prefix``) with ``root`` (a model, or a union of models): one per key, in the
    order of the errors (the unknown keys first)."""
    out: list[str] = []
    seen: set[str] = set()
    fitting: set[str] = set()
    errors = exc.errors(include_url=False)
    walked = []
    for e in errors:
        loc = e["loc"]
        if e["type"] == "extra_forbidden":
            w = _walk(loc[:-1], root, data, prefix)  # the table that has the key
            walked.append((e, w))
            if w.union_key is not None and w.fits:
                fitting.add(w.union_key)
            continue
        w = _walk(loc, root, data, prefix)
        walked.append((e, w))
        if w.union_key is not None and w.fits:
            fitting.add(w.union_key)
    for e, w in walked:
        kind = e["type"]
        if kind == "extra_forbidden":
            union = _union_at(e["loc"][:-1], root)
            msg = _unknown(w, union, str(e["loc"][-1]), e["input"])
        elif not w.fits and w.union_key is not None:
            if w.union_key in fitting:
                continue  # another member fits the value: its errors say it
            msg = _plain(w.union_key, _value_at(data, w.union_key, prefix), w, item=False)
        elif kind == RULE:
            msg = e["ctx"]["message"]
            here = e["ctx"].get("here")
            if here:  # keys of the table at the error's location (or of the key's table)
                at = _walk(e["loc"][:-1], root, data, prefix).path if here == "field" \
                    else w.path
                msg = "\n".join(f"{at}.{m}" if at else m for m in msg.split("\n"))
                msg = msg.replace(TABLE_PATH, at)
        elif kind in _TABLE_ERRORS or (kind == "union_tag_not_found"
                                       and not isinstance(e["input"], Mapping)):
            tables = [m for m in _members(_union_at(e["loc"], root)) if _is_model(m)]
            table = tables[0] if tables else w.table
            msg = f"{w.path} = {_show(e['input'])}: expected {_table_expectation(table)}"
        elif kind in ("union_tag_invalid", "union_tag_not_found"):
            members = [m for m in _members(_union_at(e["loc"], root)) if _is_model(m)]
            kinds = [k for m in members for k in _kinds(m)]
            msg = _kind_message(w, e, kind, kinds)
            if kind == "union_tag_not_found":  # no kind: the keys no kind declares
                msg = "\n".join([msg, *_unknown_of_every_kind(w.path, members, e["input"])])
        elif kind == "missing":
            if w.field is None:
                continue
            what = extras(w.model, w.field).get("missing") or expectation(w.model, w.field)
            msg = f"{w.path}: missing required key; expected {what}"
        elif kind == "literal_error" and w.field is not None:
            msg = _plain(w.path, e["input"], w, item=w.item)
            if isinstance(e["input"], str):
                guess = _did_you_mean(e["input"], _choices(w.model, w.field) or ())
                if guess:
                    msg += f" (did you mean '{guess}'?)"
        else:  # (an item that is a list itself, a row of a matrix: the key's expectation)
            row = typing.get_origin(_strip(w.tp)) is list
            msg = _plain(w.path, e["input"], w, item=w.item and not row)
        for line in msg.split("\n"):  # a rule may state several errors
            head = line.split(" ", 1)[0].rstrip(":")
            if head in seen:
                continue
            seen.add(head)
            out.append(line)
    return [m for _, m in sorted(enumerate(out), key=lambda im: (
        " unknown key; " not in im[1] and "no such key for kind" not in im[1], im[0]))]


def _value_at(data, path: str, prefix: str):
    """The value at key path ``path`` of ``data`` (whose own path is ``prefix``)."""
    rest = path[len(prefix):].lstrip(".") if prefix and path.startswith(prefix) else path
    v = data
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", rest):
        if part.startswith("["):
            i = int(part[1:-1])
            v = v[i] if isinstance(v, list) and i < len(v) else None
        else:
            v = v.get(part.strip('"')) if isinstance(v, Mapping) else None
    return v


def _plain(path: str, value, w: _Where, *, item: bool) -> str:
    if w.field is None:
        exp = _table_expectation(w.table) if w.table is not None else "a valid value"
    else:
        number = isinstance(value, int | float) and not isinstance(value, bool)
        exp = expectation(w.model, w.field, item=item,
                          scalar=w.scalar and number and w.path == w.union_key)
    return f"{path} = {_show(value)}: expected {exp}"


def _unknown_of_every_kind(path: str, members, table) -> list[str]:
    """The messages of the keys of ``table`` (a table without its kind) that no kind of
    ``members`` declares, each with a did-you-mean among the keys of every kind."""
    allowed = sorted({k for m in members for k in m.model_fields
                      if k not in getattr(m, "HIDDEN", frozenset())})
    out = []
    for k, v in table.items():
        if isinstance(k, str) and not any(k in m.model_fields for m in members):
            guess = _did_you_mean(k, allowed)
            hint = (f"did you mean '{guess}'?" if guess else
                    "expected one of " + ", ".join(f"'{a}'" for a in allowed))
            out.append(f"{_join(path, k)} = {_show(v)}: unknown key; {hint}")
    return out


def _kind_message(w: _Where, e, kind: str, kinds) -> str:
    """The message of a missing or unknown ``kind`` of a table of ``kinds``."""
    path = _join(w.path, "kind")
    listing = _listing(kinds) if kinds else "a kind"
    if kind == "union_tag_not_found":
        return f"{path}: missing required key; expected {listing}"
    tag = e["input"].get("kind") if isinstance(e["input"], Mapping) else None
    hint = ""
    if isinstance(tag, str):
        guess = _did_you_mean(tag, kinds)
        hint = f" (did you mean '{guess}'?)" if guess else ""
    return f"{path} = {_show(tag)}: expected {listing}{hint}"


def _union_at(loc, root):
    """The union (or model) annotation of the table at ``loc`` (for the keys of the
    other kinds of a table with a kind)."""
    tp, kind = root, None
    for x in loc:
        members = _members(tp)
        if len(members) > 1:
            chosen = [m for m in members if _tag_of(m, x)]
            if chosen:
                if _is_model(chosen[0]) and _kinds(chosen[0]):
                    kind = chosen[0]  # the kind the location names
                    continue  # stay at the union: its kinds are the table's
                tp = chosen[0]
                continue
        tp = _strip(tp)
        if _is_model(tp) and isinstance(x, str) and x in tp.model_fields:
            tp = tp.model_fields[x].annotation
        elif isinstance(x, int) and typing.get_origin(tp) is list:
            tp = typing.get_args(tp)[0]
        elif len(_members(tp)) > 1:
            kinds = [m for m in _members(tp) if _is_model(m) and isinstance(x, str)
                     and x in m.model_fields]
            kinds = [kind] if kind in kinds else kinds
            tp = kinds[0].model_fields[x].annotation if kinds else None
        else:
            tp = None
    return tp


def implausible_of(obj, path: str) -> list[str]:
    """The messages of the given values of a validated table ``obj`` (and the tables
    inside it) outside the plausible range their keys declare (:func:`~vsi_numba.config.
    schema._fields.implausible`)."""
    from vsi_numba.config.schema._fields import implausible

    out: list[str] = []
    if isinstance(obj, list):
        for i, it in enumerate(obj):
            out += implausible_of(it, f"{path}[{i}]")
        return out
    if not isinstance(obj, BaseModel):
        return out
    for name in type(obj).model_fields:
        if name not in obj.model_fields_set:
            continue
        v = getattr(obj, name)
        p = _join(path, name)
        if isinstance(v, BaseModel | list) and (not isinstance(v, list) or any(
                isinstance(x, BaseModel) for x in v)):
            out += implausible_of(v, p)
        else:
            out += implausible(type(obj), name, p, v)
    return out


@functools.cache
def _table_adapter(root, name: str) -> TypeAdapter:
    """The validator of table ``name`` of ``root`` (its models' own strict config)."""
    f = root.model_fields[name]
    meta = [*f.metadata]
    if isinstance(f.discriminator, str):  # Annotated[A | B, Field(discriminator=...)]
        meta.append(Field(discriminator=f.discriminator))
    return TypeAdapter(Annotated[(f.annotation, *meta)] if meta else f.annotation)


_DEFAULTS = object()


def typed_section(chk, data, name: str, root, absent=_DEFAULTS):
    """``data[name]`` validated by the declaration of table ``name`` of ``root`` (the
    file's model): the typed table (when absent: its defaults, or ``absent`` when
    given; ``_MISSING`` for a required one), or ``_BAD`` with the
    messages of every error added to ``chk``; the values outside their plausible range
    go to ``chk.implausible``."""
    from vsi_numba.config._check import _BAD, _MISSING

    f = root.model_fields[name]
    if not isinstance(data, Mapping) or name not in data:
        if f.is_required():
            return _MISSING
        if absent is not _DEFAULTS:
            return absent
        return _table_adapter(root, name).validate_python({})
    value = data[name]
    try:
        typed = _table_adapter(root, name).validate_python(value)
    except ValidationError as exc:
        chk.errors += messages(exc, f.annotation, value, name)
        return _BAD
    chk.implausible += implausible_of(typed, name)
    return typed


@functools.cache
def _file_model(root):
    """The top level of a file of ``root``: its declared keys (each table of any value,
    read by its own model), required and unknown keys as ``root`` declares them."""
    from pydantic import create_model

    fields = {}
    for name, f in root.model_fields.items():
        sub = f.annotation
        table = any(_is_model(m) for m in _members(sub))
        info = dict(description=f.description, json_schema_extra=f.json_schema_extra)
        fields[name] = (Any if table else sub,
                        Field(**info) if f.is_required() else Field(f.default, **info))
    return create_model(f"{root.__name__}File", __config__=root.model_config, **fields)


def typed_file(chk, data, root=None):
    """The top level of ``data`` validated by the keys of the file's model (default
    :class:`~vsi_numba.config.schema.models.VsiConfig`): the missing required tables and
    the unknown ones reported to ``chk`` (then ``_BAD``), else the validated top level
    (``title``; the tables are read by :func:`typed_section`)."""
    from vsi_numba.config._check import _BAD

    if root is None:
        from vsi_numba.config.schema.models import VsiConfig as root
    model = _file_model(root)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        chk.errors += messages(exc, model, data)
        return _BAD
