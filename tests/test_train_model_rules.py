"""``[train]`` validated by its declared models: the rules between keys reported with the
table's other errors, the keys of the other form ignored (warned), the inputs a Python
mapping may hold (tuples, arrays), the user's integers kept in the stored configuration,
and the speeds of the trains on other tracks in m/s from the configuration on."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from vsi_numba.config import ConfigError, load_config

BASE = {"title": "rules", "bridge": {"kind": "simply_supported", "spans": [20.0],
                                     "EI": 2.4e10, "mass_per_length": 15000.0,
                                     "damping_ratio": 0.01, "n_modes": 3},
        "solver": {"dt": 1e-3}, "study": {"speeds_kmh": [200.0], "output": "o.nc"}}
SPRUNG = {"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6}
USER = {"kind": "user", "M": [[100, 0], [0, 10]], "C": [[0, 0], [0, 0]],
        "K": [[100000, -100000], [-100000, 100000]], "wheel_dofs": [1],
        "wheel_positions": [0]}


def _with(train, bridge=None):
    data = copy.deepcopy(BASE)
    data["train"] = train
    if bridge:
        data["bridge"].update(bridge)
    return data


def _errors(train, **kw):
    with pytest.raises(ConfigError) as exc:
        load_config(_with(train, **kw))
    return exc.value.errors


def test_train_rules__every_error_of_a_user_vehicle_at_once():
    bad = dict(USER, M=[[1.0, 2.0], [3.0, 1.0]], wheel_dofs=[300], body_dof=300)
    assert _errors({"vehicles": [bad]}) == [
        "train.vehicles[0].M[0][1] = 2.0: expected a symmetric matrix "
        "(train.vehicles[0].M[1][0] = 3.0)",
        "train.vehicles[0].wheel_dofs[0] = 300: expected a DOF index 0 <= i <= 200",
        "train.vehicles[0].body_dof = 300: expected a DOF index -1 <= i < the size of M "
        "(-1: none)"]
    # a row that is not a list: the matrix's expectation, at the row
    assert _errors({"vehicles": [dict(USER, M=[True, [0.0, 50.0]])]}) == [
        "train.vehicles[0].M[0] = true: expected a square matrix (list of rows of numbers)"]
    # C and K sized by a valid M
    assert _errors({"vehicles": [dict(USER, K=[[1.0]])]}) == [
        "train.vehicles[0].K = [[1.0]]: expected a square matrix (list of rows of numbers), "
        "2 x 2"]


def test_train_rules__hslm_b_only_with_its_preset_also_next_to_vehicles():
    msg = ("train.hslm_b = {N = 10, d = 3.0}: expected only with 'HSLM-B' in train.preset "
           "(N and d of the HSLM-B train)")
    assert _errors({"vehicles": [SPRUNG], "hslm_b": {"N": 10, "d": 3.0}}) == [msg]
    assert _errors({"preset": "ICE3", "hslm_b": {"N": 10, "d": 3.0}}) == [msg]
    assert _errors({"preset": "HSLM-B", "model": "interaction",
                    "hslm_b": {"N": 10, "d": 3.0}}) == [
        "train.model = \"interaction\": expected 'moving_force' (HSLM-B is a load model: "
        "moving forces, no vehicle dynamics)"]


def test_train_rules__a_missing_user_train_file_is_one_message(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_config(_with({"file": "nope.toml"}), base_dir=tmp_path)
    assert exc.value.errors == [
        f'train.file = "nope.toml": expected an existing file with user trains (TOML) '
        f"(looked for {tmp_path / 'nope.toml'})"]


def test_train_rules__keys_of_the_other_form_warned_not_validated():
    cfg = load_config(_with({"vehicles": [SPRUNG], "model": 5}))
    assert cfg.warnings[0] == ("train.model is ignored: it applies to library presets, not "
                               "to [[train.vehicles]]")
    assert "model" not in cfg.resolved()["train"]
    cfg = load_config(_with({"preset": "HSLM-A1", "name": 5}))
    assert ("train.name is ignored: it names the train of [[train.vehicles]]; presets keep "
            "their names") in cfg.warnings


def test_train_rules__python_sequences_accepted_integers_kept():
    """Tuples and arrays of a mapping built in Python read as TOML's lists; the stored
    configuration keeps the user's integers (its hash does not depend on the reader)."""
    as_lists = load_config(_with({"vehicles": [USER]}))
    arrays = dict(USER, M=np.array([[100, 0], [0, 10]]), C=((0, 0), (0, 0)),
                  wheel_dofs=(1,))
    cfg = load_config(_with({"vehicles": (arrays,), "name": "rules"}))
    assert cfg.resolved() == as_lists.resolved() and cfg.sha256 == as_lists.sha256
    stored = cfg.resolved()["train"]["vehicles"][0]
    assert stored["M"] == [[100, 0], [0, 10]] and type(stored["M"][0][0]) is int
    assert stored["wheel_positions"] == [0] and type(stored["wheel_positions"][0]) is int
    np.testing.assert_array_equal(cfg.trains()[0].vehicles[0].M, [[100.0, 0.0], [0.0, 10.0]])
    assert load_config(_with({"preset": ("HSLM-A1", "HSLM-A2"), "model": "moving_force"})
                       ).resolved()["train"]["preset"] == ["HSLM-A1", "HSLM-A2"]


def test_train_rules__other_trains_speeds_in_m_s_stored_in_km_h():
    tracks = {"tracks": [{"eccentricity": 2.0}, {"eccentricity": -2.0},
                         {"eccentricity": 4.0}]}
    cfg = load_config(_with({"preset": "HSLM-A1", "other_trains": [
        {"track": 2, "speed_kmh": 72}, {"track": 3, "speed_factor": 0.5}]}, bridge=tracks))
    assert cfg.other_train_speeds_m_s() == [20.0, None]  # 72 km/h = 20 m/s
    assert [o.get("speed_kmh") for o in cfg.other_trains] == [72.0, None]
    assert load_config(_with({"preset": "HSLM-A1"})).other_train_speeds_m_s() == []
    errs = _errors({"preset": "HSLM-A1", "other_trains": [
        {"track": 2, "speed_kmh": 200, "speed_factor": 2}]}, bridge=tracks)
    assert errs == ["train.other_trains[0].speed_factor = 2.0: expected either "
                    "train.other_trains[0].speed_kmh or train.other_trains[0].speed_factor, "
                    "not both (speed_kmh = 200.0 is given)"]
