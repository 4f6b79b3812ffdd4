"""The key paths of the configuration language, from its declared models (used by the
tests that generate and mutate configurations)."""

from __future__ import annotations

import typing

from vsi_numba.config.schema._fields import model_for, section_models
from vsi_numba.config.schema.models import SECTIONS, VsiConfig


def required_paths(data, tp=VsiConfig, path: str = "") -> set[str]:
    """The key paths of ``data`` (a parsed configuration) that its tables declare
    required (``bridge``, ``bridge.spans``, ``train.vehicles[0].mass``, ...).  Keys of
    which one of several must be given (``train.preset`` / ``train.vehicles``,
    ``study.speeds_kmh`` / ``line_speed_kmh``) are not among them."""
    model = model_for(tp, data)
    out: set[str] = set()
    if model is None or not isinstance(data, dict):
        return out
    kind_default = any(m.model_fields["kind"].get_default() is not None
                       for m in section_models(tp) if "kind" in m.model_fields)
    for name, f in model.model_fields.items():
        if name not in data:
            continue
        p = f"{path}.{name}" if path else name
        if f.is_required() and not (name == "kind" and kind_default):
            out.add(p)
        sub = data[name]
        if isinstance(sub, dict):
            out |= required_paths(sub, f.annotation, p)
        elif isinstance(sub, list) and typing.get_origin(f.annotation) is list:
            (item,) = typing.get_args(f.annotation)
            for i, v in enumerate(sub):
                out |= required_paths(v, item, f"{p}[{i}]")
    return out


def all_keys() -> set[str]:
    """Every key name of the configuration language (the fields of every table)."""
    return {name for _, tp in SECTIONS for m in section_models(tp) for name in m.model_fields}
