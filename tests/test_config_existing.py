"""The messages of ``[calibration]`` and ``[reliability]``, validated by their declared
models (the rules of a distribution, the walkers, the block of runs) and checked on the
typed tables (the record files, the key paths)."""

import copy
import tomllib
from pathlib import Path

import pytest

from vsi_numba.config import ConfigError, load_config

CASE = Path(__file__).resolve().parents[1] / "configs" / "calibration_synthetic"
RELIABILITY = {"check": "deck_acceleration", "variables": [
    {"key": "bridge.damping_ratio", "distribution": "lognormal", "median": 0.015,
     "cov": 0.3}]}


def _errors(change) -> list[str]:
    with open(CASE / "calibration.toml", "rb") as f:
        data = tomllib.load(f)
    data = copy.deepcopy(data)
    change(data)
    with pytest.raises(ConfigError) as exc:
        load_config(data, base_dir=CASE)
    return exc.value.errors


def test_distribution__every_missing_and_extra_parameter_at_once():
    errors = _errors(lambda d: d["calibration"]["parameters"][0].update(prior="normal"))
    assert errors == [
        "calibration.parameters[0].mean: missing required key; expected the mean of a "
        "normal distribution",
        "calibration.parameters[0].std: missing required key; expected the std of a normal "
        "distribution",
        "calibration.parameters[0].cov = 0.2: expected no cov for a normal distribution (it "
        "takes mean and std)",
        "calibration.parameters[0].median = 20000000000.0: expected no median for a normal "
        "distribution (it takes mean and std)"]


def test_distribution__uniform_bounds_in_order_with_the_other_tables_errors():
    def change(d):
        d["calibration"]["parameters"][1].update(lower=0.1)
        d["calibration"]["n_samples"] = 3
    errors = _errors(change)
    assert "calibration.parameters[1].upper = 0.05: expected an upper bound > lower = 0.1" \
        in errors
    assert "calibration.n_samples = 3: expected an integer number of samples, 16 .. 1e6" \
        in errors


@pytest.mark.parametrize("n, msg", [
    (0, "calibration.parameters = []: expected a list of 1 to 20 tables {key, prior, ...}"),
    (21, ": expected a list of 1 to 20 tables {key, prior, ...}")])
def test_parameters__from_1_to_20(n, msg):
    errors = _errors(lambda d: d["calibration"].update(
        parameters=d["calibration"]["parameters"][:1] * n))
    assert len(errors) == 1 and errors[0].startswith("calibration.parameters = ")
    assert errors[0].endswith(msg)


def test_item__unknown_key_guessed_among_its_own_keys():
    errors = _errors(lambda d: d["calibration"]["parameters"][0].update(medain=5))
    assert errors == ["calibration.parameters[0].medain = 5: unknown key; did you mean "
                      "'median'?"]


def test_walkers__even_and_twice_the_parameters():
    errors = _errors(lambda d: d["calibration"].update(n_walkers=4))
    assert errors == ["calibration.n_walkers = 4: expected an even number of walkers >= 6 "
                      "(2 x the 3 parameters)"]


def test_record_file__checked_with_the_errors_of_a_refused_table():
    def change(d):
        d["calibration"]["records"][1]["file"] = "nope.csv"
        d["calibration"]["parameters"][0]["prior"] = "x"
    errors = _errors(change)
    assert errors[0] == ("calibration.parameters[0].prior = \"x\": expected one of "
                         "'uniform', 'normal', 'lognormal'")
    assert errors[1].startswith('calibration.records[1].file = "nope.csv": expected a '
                                "readable record: ")
    assert len(errors) == 2


def test_reliability__block_within_the_runs_and_a_table():
    errors = _errors(lambda d: d.update(reliability={**RELIABILITY, "block_size": 5000,
                                                     "max_runs": 1000}))
    assert errors == ["reliability.block_size = 5000: expected at most reliability.max_runs "
                      "= 1000"]
    errors = _errors(lambda d: d.update(reliability=[1]))
    assert errors == ["reliability = [1]: expected a table [reliability] with check and "
                      "variables"]


def test_reliability__resolved_with_its_defaults():
    with open(CASE / "calibration.toml", "rb") as f:
        data = tomllib.load(f)
    data["reliability"] = copy.deepcopy(RELIABILITY)
    r = load_config(data, base_dir=CASE).resolved()["reliability"]
    assert r == {"check": "deck_acceleration", "method": "subset", "target_cov": 0.1,
                 "max_runs": 100000, "block_size": 1000, "seed": 0,
                 "variables": [{"key": "bridge.damping_ratio", "distribution": "lognormal",
                                "median": 0.015, "cov": 0.3}]}
