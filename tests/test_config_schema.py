"""The declared config schema (vsi_numba.config.schema): the committed generated files
are up to date, every bundled configuration validates against the JSON Schema and the
models, and the schema refuses what ``load_config`` refuses key by key."""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import jsonschema
import pytest
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
