"""The declared config schema (vsi_numba.config.schema): the committed generated files
are up to date, every bundled configuration validates against the JSON Schema and the
models, the schema refuses what ``load_config`` refuses key by key, and on the fuzz corpus
(tests/test_config_fuzz.py) the models and ``load_config`` agree: every error the models
find is at a key path that ``load_config`` names, and what ``load_config`` accepts the
models accept."""

from __future__ import annotations

import copy
import json
import random
import re
import tomllib
import types
import typing
from pathlib import Path
from typing import Annotated, Literal, Union

import jsonschema
import pytest
import test_config_fuzz as fuzz
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel, ValidationError
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.config import ConfigError, load_config
from vsi_numba.config.schema import generate
from vsi_numba.config.schema.models import VsiConfig

ROOT = Path(__file__).resolve().parents[1]
BUNDLED = sorted([*ROOT.glob("configs/*.toml"), *ROOT.glob("studies/*/study.toml")])


@pytest.fixture(scope="module")
def validator():
    schema = json.loads(generate.SCHEMA_FILE.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("path", sorted(generate.generated(), key=str),
                         ids=lambda p: p.name)
def test_schema__committed_files_are_generated(path):
    text = generate.generated()[path]
    assert path.read_text(encoding="utf-8") == text, (
        f"{path.relative_to(ROOT)} is stale: run python -m vsi_numba.config.schema.generate")


def test_schema__bundled_configs_validate(validator):
    assert len(BUNDLED) >= 12
    for path in BUNDLED:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        errors = [e.message for e in validator.iter_errors(data)]
        assert not errors, (path.name, errors)
        VsiConfig.model_validate(data)  # raises on a disagreement


BASE = {
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.3e9,
               "mass_per_length": 2303.0, "n_modes": 3},
    "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6}]},
    "study": {"speeds_kmh": [100.0]},
}
# (section, key, bad value): each refused by load_config with the key path in the message
BAD = [
    ("bridge", "spans", [-3.0]), ("bridge", "spna", [25.0]), ("bridge", "kind", "simple"),
    ("bridge", "n_modes", 2.5), ("bridge", "damping_ratio", 1.5), ("bridge", "EI", True),
    ("solver", "dt", 0.0), ("solver", "hht_alpha", -0.5), ("solver", "max_iterations", 0),
    ("contact", "hertz_coefficient", -1.0), ("track", "rail_mass", 5000.0),
    ("track", "load_distribution", "ballast"), ("study", "speeds_kmh", [-10.0]),
    ("study", "output", 3), ("irregularity", "kind", "sine"), ("report", "revision", [1]),
]


@pytest.mark.parametrize("section, key, value", BAD, ids=lambda v: str(v))
def test_schema__refuses_what_load_config_refuses(validator, tmp_path, section, key, value):
    data = copy.deepcopy(BASE)
    data.setdefault(section, {})[key] = value
    if section == "contact":
        data["contact"]["model"] = "hertz"
    with pytest.raises(ConfigError) as exc:
        load_config(data, base_dir=tmp_path)
    assert f"{section}.{key}" in str(exc.value)
    assert list(validator.iter_errors(data)), (section, key, value)
    assert load_config(copy.deepcopy(BASE), base_dir=tmp_path)  # the base itself is valid


def test_schema__cli_prints_and_writes_it(tmp_path):
    res = CliRunner().invoke(app, ["schema"])
    assert res.exit_code == 0
    assert json.loads(res.output) == generate.json_schema()
    out = tmp_path / "vsi_config.schema.json"
    res = CliRunner().invoke(app, ["schema", "-o", str(out)])
    assert res.exit_code == 0 and json.loads(out.read_text()) == generate.json_schema()


def test_schema__init_template_validates(validator, tmp_path):
    from vsi_numba.cli.init import TEMPLATE

    data = tomllib.loads(TEMPLATE.format(name="study.toml", stem="study"))
    assert not [e.message for e in validator.iter_errors(data)]
    VsiConfig.model_validate(data)


# ------------------------------------------------- the models and load_config on the fuzz corpus

def _strip(tp):
    while typing.get_origin(tp) is Annotated:
        tp = typing.get_args(tp)[0]
    return tp


def _is_model(tp) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _tags(member) -> set[str]:
    """The names pydantic gives a member of a union in an error location: its class
    name and, for a model of one kind, that kind."""
    member = _strip(member)
    if not _is_model(member):
        return set()
    kind = member.model_fields.get("kind")
    if kind is not None and typing.get_origin(_strip(kind.annotation)) is Literal:
        return {member.__name__, *typing.get_args(_strip(kind.annotation))}
    return {member.__name__}


def key_path(loc, root=VsiConfig) -> str:
    """The key path (``bridge.spans[0]``) of a pydantic error location, written for the
    models of ``root``: the union members' names in the location (a kind, a class, a
    ``constrained-float`` or ``list[...]`` of ``number | list``) are not keys."""
    tp, out = root, ""
    for x in loc:
        tp = _strip(tp) if tp is not None else None
        if tp is not None and typing.get_origin(tp) in (Union, types.UnionType):
            members = [_strip(m) for m in typing.get_args(tp)]
            tagged = [m for m in members if isinstance(x, str) and x in _tags(m)]
            lists = [m for m in members if typing.get_origin(m) is list]
            scalars = [m for m in members if typing.get_origin(m) is not list
                       and not _is_model(m)]
            if tagged:
                tp = tagged[0]
                continue
            if isinstance(x, str) and x.startswith("list[") and lists:
                tp = lists[0]
                continue
            if isinstance(x, str) and scalars and ("-" in x or "[" in x or x in (
                    "int", "float", "str", "bool")):
                tp = scalars[0]
                continue
            models = [m for m in members if _is_model(m)]
            tp = models[0] if models else None
        if isinstance(x, int):
            out += f"[{x}]"
            tp = typing.get_args(tp)[0] if typing.get_origin(tp) is list else None
            continue
        out = f"{out}.{x}" if out else str(x)
        if _is_model(tp) and x in tp.model_fields:
            tp = tp.model_fields[x].annotation
        elif typing.get_origin(tp) is dict:
            tp = typing.get_args(tp)[1]
        else:
            tp = None
    return out


def test_schema__key_path_of_an_error_location():
    assert key_path(("bridge", "simply_supported", "spans", "list[constrained-float]", 0)
                    ) == "bridge.spans[0]"
    assert key_path(("study", "speeds_kmh", "SpeedGrid", "start")) == "study.speeds_kmh.start"
    assert key_path(("irregularity", "psd", "defects", 1, "step", "shape")
                    ) == "irregularity.defects[1].shape"
    assert key_path(("irregularity", "file", "r_unit")) == "irregularity.r_unit"
    assert key_path(("train", "vehicles", 0, "user", "M", 0)) == "train.vehicles[0].M[0]"
    assert key_path(("ttile",)) == "ttile"


def _head(message: str) -> str:
    return re.split(r"[ :=]", message, maxsplit=1)[0]


def _inside(path: str, table: str) -> bool:
    return path == table or path.startswith((table + ".", table + "["))


def _parent(path: str) -> str:
    return re.sub(r"(\.[^.\[]+|\[\d+\])$", "", path)


def test_schema__load_config_names_every_error_of_the_models_on_the_fuzz_corpus(tmp_path):
    """The mutated configurations of the fuzz test (deleted keys, wrong types, bounds,
    unknown keys, garbage, several at once): whatever the models refuse, ``load_config``
    refuses, and each error of the models is at a key path that one of ``load_config``'s
    messages names (that key, a key inside it, or the table or list that holds it).
    ``load_config`` refuses more (library names, files, bounds that depend on the built
    deck or another key), never less."""
    (tmp_path / "profile.csv").write_text(fuzz.PROFILE)
    (tmp_path / "tracks_modes.csv").write_text(fuzz.TRACK_MODES)
    rng = random.Random(fuzz.SEED)
    bases = fuzz._bases()
    n_refused = n_errors = 0
    for k in range(fuzz.N_DICT_CASES):
        bname, base = bases[k % len(bases)]
        op, data = fuzz.mutate(base, rng)
        try:
            VsiConfig.model_validate(copy.deepcopy(data))
            continue
        except ValidationError as exc:
            errors = exc.errors()
        n_refused += 1
        with pytest.raises(ConfigError) as refused:
            load_config(data, base_dir=tmp_path)
        heads = [_head(m) for m in refused.value.errors]
        for e in errors:
            path = key_path(e["loc"])
            named = [h for h in heads if _inside(h, path) or h == _parent(path)]
            assert named, (k, bname, op, e["type"], path, refused.value.errors[:4])
            n_errors += 1
    assert n_refused >= 150 and n_errors >= 250, (n_refused, n_errors)  # not vacuous


@settings(max_examples=100, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_schema__models_accept_what_load_config_accepts(data):
    """Any value at any key path of the fuzz test's bases: a configuration that
    ``load_config`` accepts validates with the models (they are never stricter)."""
    _name, base = data.draw(st.sampled_from(fuzz._bases()[:2] + fuzz._bases()[3:]),
                            label="base")
    mutated = copy.deepcopy(base)
    _p, parent, key, _v = data.draw(st.sampled_from(list(fuzz._leaves(mutated))),
                                    label="where")
    parent[key] = data.draw(fuzz._garbage_values, label="value")
    try:
        load_config(copy.deepcopy(mutated))
    except ConfigError:
        return
    VsiConfig.model_validate(mutated)
