"""One definition per rule: the config and the model/solver layers check the same ranges."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from vsi_numba.config import ConfigError, load_config
from vsi_numba.model import vehicle as vh
from vsi_numba.solver.settings import BOUNDS, SolverSettings

BASE = {
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
               "mass_per_length": 2303.0, "n_modes": 3},
    "train": {"vehicles": [{"kind": "force", "load": 1e5}]},
    "track": {"model": "rigid"},
    "study": {"speeds_kmh": [100.0], "output": "results/rules.nc"},
}


def _accepted_by_config(key: str, value: float) -> bool:
    data = copy.deepcopy(BASE)
    data["solver"] = {key: value, "allow_coarse_dt": True, "allow_large_problem": True}
    try:
        load_config(data)
    except ConfigError as exc:
        assert any(e.startswith(f"solver.{key} = ") for e in exc.errors), exc.errors
        return False
    return True


def _accepted_by_settings(key: str, value: float) -> bool:
    try:
        SolverSettings(**{key: value})
    except ValueError:
        return False
    return True


@pytest.mark.parametrize(("key", "values"), [
    ("dt", [-1e-3, 0.0, 1e-9, 2e-3]),
    ("hht_alpha", [-0.5, -1.0 / 3.0 - 1e-9, -1.0 / 3.0, -0.1, 0.0, 1e-6]),
    ("approach", [-1.0, 0.0, 5.0]),
    ("free_vibration", [-0.1, 0.0, 0.5]),
])
def test_solver_ranges__config_and_settings_agree(key, values):
    for v in values:
        expected = v in BOUNDS[key]
        assert _accepted_by_settings(key, v) is expected, (key, v)
        assert _accepted_by_config(key, v) is expected, (key, v)


def test_solver_settings__dt_from_toml_reaches_the_settings():
    data = copy.deepcopy(BASE)
    data["solver"] = {"dt": 5e-4}
    cfg = load_config(data)
    assert cfg.solver_settings().dt == 5e-4
    assert math.isclose(cfg.solver_settings().hht_alpha, SolverSettings.hht_alpha)


def test_study_section__no_hidden_keys_output_path_is_an_attribute(tmp_path):
    cfg = load_config(copy.deepcopy(BASE), base_dir=tmp_path)
    assert not [k for k in cfg.resolved()["study"] if k.startswith("_")]
    assert cfg.output_path == (tmp_path / "results" / "rules.nc").resolve()


def test_vehicle_matrix__config_names_the_entry_the_model_refuses():
    k = np.array([[1e6, -1e6], [-0.9e6, 1e6]])
    with pytest.raises(vh.VehicleMatrixError) as model_exc:
        vh.check_matrix(k, "K", "v")
    assert model_exc.value.index == (0, 1) and "K is not symmetric" in str(model_exc.value)
    data = copy.deepcopy(BASE)
    data["train"] = {"vehicles": [{"kind": "user", "M": [[1000.0, 0.0], [0.0, 50.0]],
                                   "C": [[0.0, 0.0], [0.0, 0.0]], "K": k.tolist(),
                                   "wheel_dofs": [1], "wheel_positions": [0.0]}]}
    with pytest.raises(ConfigError) as exc:
        load_config(data)
    assert exc.value.errors == [
        "train.vehicles[0].K[0][1] = -1000000.0: expected a symmetric matrix "
        "(train.vehicles[0].K[1][0] = -900000.0)"]
