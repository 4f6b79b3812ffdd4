"""What is generated from the declared keys (:mod:`.models`): the JSON Schema shipped
with the package, the key reference of the documentation and the ``vsi init`` template.

``python -m vsi_numba.config.schema.generate`` rewrites the committed files
(:data:`SCHEMA_FILE`, :data:`REFERENCE_FILE`); tests/test_config_schema.py fails when one
is stale.
"""

from __future__ import annotations

import json
import re
import types
import typing
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from vsi_numba.config.schema._fields import extras
from vsi_numba.config.schema.models import SECTIONS, VsiConfig

ROOT = Path(__file__).resolve().parents[3]
#: The JSON Schema of a configuration file (shipped in the package).
SCHEMA_FILE = Path(__file__).resolve().parents[1] / "vsi_config.schema.json"
#: The key reference included by docs/manual/config.md.
REFERENCE_FILE = ROOT / "docs" / "reference" / "config_keys.md"
SCHEMA_ID = "vsi_config.schema.json"


# ------------------------------------------------------------------------- JSON Schema

def _strip_null(node):
    """TOML has no null: drop the ``null`` branches and ``null`` defaults pydantic writes
    for optional keys, and the title pydantic derives from each key name."""
    if isinstance(node, dict):
        out = {}
        for k, v in node.items():
            if k == "default" and v is None:
                continue
            if k == "title" and isinstance(v, str) and "properties" not in node:
                continue
            out[k] = _strip_null(v)
        for k in ("anyOf", "oneOf"):
            if k in out:
                alts = [a for a in out[k] if a != {"type": "null"}]
                if len(alts) == 1:
                    del out[k]
                    out.update(alts[0])
                else:
                    out[k] = alts
        return out
    if isinstance(node, list):
        return [_strip_null(v) for v in node]
    return node


def json_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a configuration file."""
    schema = _strip_null(VsiConfig.model_json_schema())
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID,
            **schema}


def schema_text() -> str:
    return json.dumps(json_schema(), indent=1, ensure_ascii=False) + "\n"


# ----------------------------------------------------------------------- key reference

def _models(tp) -> list[type[BaseModel]]:
    """The models of a section: one, or one per kind of a union."""
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    if typing.get_origin(tp) is Annotated:
        return _models(typing.get_args(tp)[0])
    return [m for a in typing.get_args(tp) for m in _models(a)]


def type_text(tp) -> str:
    """The type of a key in words ("number > 0 or list", "'a' or 'b'", "table")."""
    origin = typing.get_origin(tp)
    if origin is Annotated:
        base, *meta = typing.get_args(tp)
        bounds = []
        for m in meta:
            for c in getattr(m, "metadata", []):
                for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
                    if getattr(c, attr, None) is not None:
                        bounds.append(f"{sym} {getattr(c, attr):g}")
                if getattr(c, "min_length", None):
                    bounds = []
        return type_text(base) + (" " + ", ".join(bounds) if bounds else "")
    if origin in (Union, types.UnionType):
        return " or ".join(dict.fromkeys(type_text(a) for a in typing.get_args(tp)))
    if origin is Literal:
        return " / ".join(f"`{json.dumps(a)}`" for a in typing.get_args(tp))
    if origin is list:
        (item,) = typing.get_args(tp)
        return f"list of ({type_text(item)})"
    if origin is dict:
        return "table"
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return "table"
    return {float: "number", int: "integer", str: "string", bool: "true / false"}.get(
        tp, "any")


def field_type_text(f) -> str:
    """:func:`type_text` of a field, with the bounds pydantic moved onto the field."""
    text = type_text(f.annotation)
    bounds = [f"{sym} {getattr(c, attr):g}" for c in f.metadata
              for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<="))
              if getattr(c, attr, None) is not None]
    return text + (" " + ", ".join(bounds) if bounds else "")


def _toml(v) -> str:
    from vsi_numba.config._show import _show

    return _show(v, limit=60)


def default_text(model: type[BaseModel], name: str) -> str:
    f = model.model_fields[name]
    e = extras(model, name)
    if f.is_required():
        return "required"
    if e.get("default_text"):
        return e["default_text"]
    d = f.get_default()
    if d is None or d is PydanticUndefined:
        return "–"
    return f"`{_toml(d)}`"


def _rows(tp) -> list[tuple[str, list[str], type[BaseModel]]]:
    """(key, kinds it belongs to, a model declaring it) of a section, in order."""
    models = _models(tp)
    kinds = {}
    for m in models:
        k = m.model_fields.get("kind")
        kinds[m] = [a for a in typing.get_args(k.annotation)] if k is not None and len(
            models) > 1 else []
    order: dict[str, tuple[list[str], type[BaseModel]]] = {}
    for m in models:
        for name in m.model_fields:
            ks, first = order.get(name, ([], m))
            order[name] = (ks + kinds[m], first)
    rows = []
    for name in sorted(order, key=lambda n: n != "kind"):
        ks, m = order[name]
        every = sum((kinds[x] for x in models), [])
        rows.append((name, [] if name == "kind" or ks == every else ks, m))
    return rows


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def reference_markdown() -> str:
    """The key reference: one table per TOML table, generated from the models."""
    out = ["# Configuration keys", "",
           "<!-- generated by `python -m vsi_numba.config.schema.generate` from",
           "     vsi_numba/config/schema/models.py: edit the models, not this file -->", "",
           "Every key of a configuration file, generated from its declaration (type, bounds,",
           "default, unit, meaning, plausible range: a value within the bounds but outside",
           "it is refused as a unit slip unless `solver.allow_implausible = true`).",
           "`kinds`: the kinds of the table the key belongs to",
           "(empty: every kind). Units are SI unless the key says otherwise (`_kmh`).",
           "", "<!-- keys -->", ""]
    for path, tp in SECTIONS:
        models = _models(tp)
        head = f"[{path}]" if path else "top level"
        if path in ("train.vehicles", "irregularity.defects"):
            head = f"[[{path}]]"
        out += [f"## `{head}`", ""]
        if len(models) > 1:
            out += [f"- {_doc_line(m)}" for m in models]
        else:
            out.append(_doc_line(models[0]))
        out += ["", "| key | kinds | type | unit | default | meaning |",
                "|---|---|---|---|---|---|"]
        for name, ks, m in _rows(tp):
            f = m.model_fields[name]
            e = extras(m, name)
            kinds = ", ".join(f"`{k}`" for k in ks)
            typ = field_type_text(f)
            dflt = default_text(m, name)
            if name == "kind" and len(models) > 1:
                typ = " / ".join(f"`{json.dumps(k)}`" for x in models for k in
                                 typing.get_args(x.model_fields["kind"].annotation))
            elif len(models) > 1:
                per = {k: default_text(x, name) for x in models if name in x.model_fields
                       for k in typing.get_args(x.model_fields["kind"].annotation)}
                if len(set(per.values())) > 1:
                    dflt = "; ".join(f"`{k}`: {v}" for k, v in per.items())
            meaning = f.description or ""
            if e.get("plausible"):  # refused outside unless solver.allow_implausible
                lo, hi = e["plausible"]
                meaning += (f"; plausible {lo:g} .. {hi:g} (outside: refused unless "
                            "solver.allow_implausible)")
            out.append(f"| `{name}` | {kinds} | {_cell(typ)} | "
                       f"{_cell(e.get('unit') or '–')} | {_cell(dflt)} | "
                       f"{_cell(meaning)} |")
        out.append("")
    return "\n".join(out)


def _doc_line(m: type[BaseModel]) -> str:
    doc = " ".join((m.__doc__ or "").split())
    return re.sub(r":\w+:`~?([^`]+)`", r"`\1`", doc.replace("``", "`"))


# -------------------------------------------------------------------------- template

def template(values: dict[str, dict[str, Any]], header: str) -> str:
    """A commented configuration: ``values`` (section -> key -> value; "" is the top
    level) written as TOML, each key with its unit and description, and the other keys
    of the section (of the chosen kind) commented out with their default."""
    from vsi_numba.config.schema.models import VsiConfig as Root

    lines = [header.rstrip("\n")]
    for name, v in values.get("", {}).items():
        lines.append(_line(Root, name, v))
    sections = dict(SECTIONS)
    for sec, vals in values.items():
        if not sec:
            continue
        models = _models(sections[sec])
        model = models[0]
        if len(models) > 1:
            kind = vals.get("kind", model.model_fields["kind"].default)
            model = next(m for m in models
                         if kind in typing.get_args(m.model_fields["kind"].annotation))
        lines += ["", f"[{sec}]  # {_doc_line(model)}"]
        for name, v in vals.items():
            lines.append(_line(model, name, v))
        for name, f in model.model_fields.items():
            if name in vals or name in ("kind",) or _is_table(f.annotation):
                continue
            d = f.get_default()
            shown = _toml(d) if d not in (None, PydanticUndefined) else "..."
            e = extras(model, name)
            unit = f"{e['unit']}: " if e.get("unit") else ""
            dflt = e.get("default_text")
            note = f" (default: {dflt})" if dflt and shown == "..." else ""
            lines.append(f"# {name} = {shown}".ljust(32) + f" # {unit}{f.description}{note}")
    return "\n".join(lines) + "\n"


def _is_table(tp) -> bool:
    return bool(_models(tp)) and typing.get_origin(tp) not in (Union, types.UnionType)


def _line(model, name, value) -> str:
    f = model.model_fields[name]
    e = extras(model, name)
    unit = f"{e['unit']}: " if e.get("unit") else ""
    raw = value.raw if isinstance(value, Raw) else _toml(value)
    return f"{name} = {raw}".ljust(32) + f" # {unit}{f.description}"


class Raw(str):
    """A value written as given (a TOML inline table, a ``{stem}`` placeholder)."""

    @property
    def raw(self) -> str:
        return str(self)


# ------------------------------------------------------------------------------ files

def generated() -> dict[Path, str]:
    """Every generated file and its content."""
    return {SCHEMA_FILE: schema_text(), REFERENCE_FILE: reference_markdown() + "\n"}


def main() -> int:
    from vsi_numba.io.atomic import write_text_atomic

    for path, text in generated().items():
        write_text_atomic(path, text)
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
