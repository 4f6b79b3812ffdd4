"""HSLM-B with N and d from the configuration, axle-load CSV trains, and the study keys
of the load-effect checks (classification factor alpha, track maintenance)."""

import copy

import numpy as np
import pytest

from vsi_numba.config import ConfigError, load_config
from vsi_numba.model.library import extra


def base(train=None, study=None) -> dict:
    """A small valid config: a 5 m simply supported span (HSLM-B range)."""
    d = {
        "title": "test",
        "bridge": {"kind": "simply_supported", "spans": [5.0], "EI": 5e9,
                   "mass_per_length": 8000.0, "n_modes": 2},
        "train": train or {"preset": "HSLM-B", "hslm_b": {"N": 10, "d": 3.5}},
        "solver": {"dt": 1e-3},
        "study": {"speeds_kmh": [100.0], "output": "results/test.nc", **(study or {})},
    }
    return copy.deepcopy(d)


def errors_of(data, **kw) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(data, **kw)
    return info.value.errors


def test_hslm_b_train_loads_and_positions():
    t = load_config(base()).trains()[0]
    # the load model is standard, N and d are the user's: labelled so, not "standard"
    assert t.name == "HSLM-B" and t.status == "user-given"
    pos = np.concatenate([o + v.load_positions for v, o in zip(t.vehicles, t.offsets,
                                                               strict=True)])
    loads = np.concatenate([v.loads for v in t.vehicles])
    # N = 10 forces of 170 kN at 0, 3.5, ..., 31.5 m (EN 1991-2 6.4.6.1.1 definition)
    np.testing.assert_array_equal(pos, 3.5 * np.arange(10))
    np.testing.assert_array_equal(loads, np.full(10, 170e3))
    assert t.regular_length == 3.5


def test_hslm_b_with_other_presets_and_resolved_round_trip():
    cfg = load_config(base({"preset": ["HSLM-A1", "hslm-b"], "hslm_b": {"N": 14, "d": 2.5}}))
    names = [t.name for t in cfg.trains()]
    assert names == ["HSLM-A1", "HSLM-B"]
    again = load_config(cfg.resolved(), base_dir=cfg.base_dir)
    assert [t.n_loads for t in again.trains()] == [50, 14]


def test_hslm_b_missing_data_says_what_and_why():
    data = base({"preset": "HSLM-B"})
    (msg,) = errors_of(data)
    assert msg.startswith("train.hslm_b")
    assert "Fig. 6.13" in msg and "not available" in msg and "{N =" in msg
    errs = errors_of(base({"preset": "HSLM-B", "hslm_b": {"N": 10}}))
    assert errs[0].startswith("train.hslm_b.d") and "Fig. 6.13" in errs[0]


@pytest.mark.parametrize("hslm_b, key, text", [
    ({"N": 0, "d": 3.5}, "train.hslm_b.N", "whole number"),
    ({"N": 2.5, "d": 3.5}, "train.hslm_b.N", "whole number"),
    ({"N": 10, "d": -1.0}, "train.hslm_b.d", "spacing > 0"),
    ({"N": 10, "d": 3.5, "D": 1.0}, "train.hslm_b.D", ""),
    ("10 x 3.5", "train.hslm_b", "table"),
])
def test_hslm_b_bad_values(hslm_b, key, text):
    (msg,) = errors_of(base({"preset": "HSLM-B", "hslm_b": hslm_b}))
    assert msg.startswith(key) and text in msg


def test_hslm_b_key_without_preset():
    (msg,) = errors_of(base({"preset": "HSLM-A1", "hslm_b": {"N": 3, "d": 3.0}}))
    assert msg.startswith("train.hslm_b") and "'HSLM-B' in train.preset" in msg


def test_hslm_b_in_library_listing():
    row = extra.hslm_b_row()
    assert row["name"] == "HSLM-B" and "NF" in row["status"]
    with pytest.raises(ValueError, match="N = 0"):
        extra.hslm_b_train(0, 3.0)


def write_csv(tmp_path, text, name="axles.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_axle_csv_train(tmp_path):
    write_csv(tmp_path, "# my loco\nposition,load,comment\n0,200,front\n2.5,210,x\n"
                        "12.0, 190 ,y\n")
    cfg = load_config(base({"axles": {"file": "axles.csv"}}), base_dir=tmp_path)
    (t,) = cfg.trains()
    assert t.name == "axles" and t.status == "user"
    np.testing.assert_array_equal(t.vehicles[0].load_positions, [0.0, 2.5, 12.0])
    np.testing.assert_array_equal(t.vehicles[0].loads, [200e3, 210e3, 190e3])  # kN -> N
    write_csv(tmp_path, "position,load\n0,200000\n2.5,210000\n12.0,190000\n")  # in N
    cfg = load_config(base({"preset": "HSLM-A1", "axles": {
        "file": "axles.csv", "load_unit": "N", "name": "loco"}}), base_dir=tmp_path)
    assert [t.name for t in cfg.trains()] == ["HSLM-A1", "loco"]
    np.testing.assert_array_equal(cfg.trains()[1].vehicles[0].loads, [200e3, 210e3, 190e3])
    again = load_config(cfg.resolved(), base_dir=tmp_path)
    assert again.trains()[1].name == "loco"


@pytest.mark.parametrize("text, expected", [
    ("x,load\n0,200\n", "missing column(s) position"),
    ("position,load\n", "no axle rows"),
    ("position,load\n0,200\n1.5,abc\n", "row 2 (data line), column load = 'abc'"),
    ("position,load\n0,200\n-1,200\n", "row 2, position = -1.0"),
    ("position,load\n0,200\n3,0\n", "row 2, load = 0.0: expected an axle load > 0 kN"),
    ("position,load\n0,200\n3,200\n2,200\n", "row 3, position = 2.0: expected positions "
                                            "strictly increasing"),
])
def test_axle_csv_errors_name_the_key_row_and_column(tmp_path, text, expected):
    write_csv(tmp_path, text)
    (msg,) = errors_of(base({"axles": {"file": "axles.csv"}}), base_dir=tmp_path)
    assert msg.startswith("train.axles.file = \"axles.csv\"") and expected in msg


def test_axle_csv_bad_keys(tmp_path):
    write_csv(tmp_path, "position,load\n0,200\n")
    (msg,) = errors_of(base({"axles": {"file": "axles.csv", "load_unit": "t"}}),
                       base_dir=tmp_path)
    assert msg.startswith("train.axles.load_unit = \"t\"") and "'kN'" in msg
    (msg,) = errors_of(base({"axles": {"file": "nope.csv"}}), base_dir=tmp_path)
    assert msg.startswith("train.axles.file = \"nope.csv\"") and "existing file" in msg


def test_study_keys_alpha_and_maintenance():
    cfg = load_config(base(study={"classification_factor": 1.21,
                                  "track_maintenance": "careful"}))
    assert cfg.resolved()["study"]["classification_factor"] == 1.21
    assert cfg.resolved()["study"]["track_maintenance"] == "careful"
    assert "classification_factor" not in load_config(base()).resolved()["study"]
    (msg,) = errors_of(base(study={"classification_factor": 1.6}))
    assert msg.startswith("study.classification_factor = 1.6") and "[0.75, 1.46]" in msg
    (msg,) = errors_of(base(study={"track_maintenance": "poor"}))
    assert msg.startswith("study.track_maintenance = \"poor\"") and "Phi_3" in msg


def test_vsi_trains_lists_hslm_b(capsys):
    from vsi_numba.cli.trains import trains_command

    assert trains_command(None) == 0
    out = capsys.readouterr().out
    assert "HSLM-B" in out and "no data (NF)" in out and "Fig. 6.13" in out
    assert trains_command("hslm-b") == 0
    out = " ".join(capsys.readouterr().out.split())  # the console wraps lines
    assert "not available" in out and "train.hslm_b" in out
