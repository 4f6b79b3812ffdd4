"""The config language: every error kind names key path, value and expectation; examples load."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest

from vsi_numba.config import Config, ConfigError, load_config

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "configs").glob("*.toml"))


def base() -> dict:
    """A small valid config (sprung mass on a 25 m simply supported span)."""
    return {
        "title": "test",
        "bridge": {
            "kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
            "mass_per_length": 2303.0, "n_modes": 3,
        },
        "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6}]},
        "solver": {"dt": 1e-3},
        "study": {"speeds_kmh": [100.0, 200.0], "output": "results/test.nc"},
    }


def errors_of(data, **kw) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(data, **kw)
    err = info.value
    assert isinstance(err, ValueError)
    for e in err.errors:  # every error is listed in str(err), one line each
        assert "\n" not in e
        assert e in str(err)
    return err.errors


def one_error(data, **kw) -> str:
    errs = errors_of(data, **kw)
    assert len(errs) == 1, errs
    return errs[0]


def with_(path: str, value, data=None) -> dict:
    """Copy of ``data`` (default :func:`base`) with ``a.b[0].c`` set (``...`` deletes)."""
    data = copy.deepcopy(base() if data is None else data)
    keys = [int(k) if k.isdigit() else k for k in re.findall(r"[^.\[\]]+", path)]
    node = data
    for k in keys[:-1]:
        if isinstance(k, str) and k not in node:
            node[k] = {}
        node = node[k]
    if value is ...:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


def write(tmp_path: Path, text: str, name="c.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# ------------------------------------------------------------------------ examples


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_config__examples_load_and_build(path):
    cfg = load_config(path)
    assert isinstance(cfg, Config)
    bridge = cfg.build_bridge()
    assert bridge.length > 0
    assert np.all((cfg.output_points >= 0) & (cfg.output_points <= bridge.length))
    trains = cfg.trains()
    assert trains and all(t.vehicles for t in trains)
    settings = cfg.solver_settings()
    assert settings.dt > 0
    assert cfg.speeds_kmh.size >= 1 and np.all(cfg.speeds_kmh > 0)
    assert cfg.output_path.is_absolute() and cfg.output_path.suffix == ".nc"
    x_start = -settings.approach - max(t.length for t in trains) - 1.0
    profiles = cfg.irregularities(x_start, bridge.length + 1.0)
    assert profiles
    json.loads(cfg.to_json())
    again = load_config(cfg.resolved(), base_dir=cfg.base_dir)
    assert again.sha256 == cfg.sha256


def test_config__example_counts():
    hslm = load_config(ROOT / "configs" / "hslm_25m.toml")
    assert [t.name for t in hslm.trains()] == [f"HSLM-A{i}" for i in range(1, 11)]
    assert all(t.n_wheels == 0 and t.n_loads > 0 for t in hslm.trains())  # moving forces
    assert hslm.speeds_kmh[0] == 140.0 and hslm.speeds_kmh[-1] == 420.0
    assert hslm.speeds_kmh.size == 57
    assert hslm.warnings == []
    ice3 = load_config(ROOT / "configs" / "ice3_continuous.toml")
    assert [i for i, _ in ice3.irregularities(-300.0, 41.0)] == [1, 2]
    assert ice3.trains()[0].n_wheels > 0  # interaction model
    np.testing.assert_array_equal(ice3.history_speeds_kmh, [300.0])
    quick = load_config(ROOT / "configs" / "quickstart.toml")
    assert quick.warnings == []
    assert quick.trains()[0].name.startswith("Quick start")


def test_config__explicit_train_name():
    assert load_config(base()).trains()[0].name == "test"  # the title
    untitled = with_("title", ...)
    cfg = load_config(untitled)
    assert cfg.title == "untitled" and cfg.trains()[0].name == "custom"
    # the name is part of the resolved config: a reload (worker process) agrees
    again = load_config(cfg.resolved())
    assert again.trains()[0].name == "custom" and again.sha256 == cfg.sha256
    named = load_config(with_("train.name", "quarter car"))
    assert named.trains()[0].name == "quarter car"
    w = load_config(with_("train.model", "moving_force")).warnings
    assert w == ["train.model is ignored: it applies to library presets, not to "
                 "[[train.vehicles]]"]


# ---------------------------------------------------------------- one error per kind


def test_config__unknown_key_did_you_mean():
    msg = one_error(with_("bridge.spna", [30.0]))
    assert msg == "bridge.spna = [30.0]: unknown key; did you mean 'spans'?"
    msg = one_error(with_("solver.DT", 1e-3))
    assert msg.startswith("solver.DT = 0.001: unknown key; did you mean 'dt'?")
    assert one_error(with_("study.speeds_kmh", {"start": 100, "stop": 200, "stpe": 5,
                                                "step": 5})).startswith(
        "study.speeds_kmh.stpe = 5: unknown key; did you mean 'step'?")  # swapped letters
    msg = one_error(with_("zzz", 1))
    assert msg.startswith("zzz = 1: unknown key; expected one of 'bridge'")


def test_config__key_of_another_vehicle_kind():
    msg = one_error(with_("train.vehicles[0].load", 1e5))
    assert msg.startswith("train.vehicles[0].load = 100000.0: expected no such key for kind = "
                          "'sprung_mass'")


def test_config__wrong_type():
    assert one_error(with_("bridge.EI", "8e9")) == (
        'bridge.EI = "8e9": expected a bending stiffness EI > 0 N m^2 (a number, or a list with '
        "one value per span)"
    )
    assert one_error(with_("study.save_time_histories", "yes")) == (
        'study.save_time_histories = "yes": expected true or false'
    )
    assert one_error(with_("bridge.n_modes", 2.5)).startswith(
        "bridge.n_modes = 2.5: expected an integer number of modes"
    )
    assert one_error(with_("bridge.n_modes", True)).startswith("bridge.n_modes = true: expected")
    assert one_error(with_("solver", 3)).startswith("solver = 3: expected a table")


def test_config__missing_required_key():
    assert one_error(with_("bridge.spans", ...)) == (
        "bridge.spans: missing required key; expected a span length > 0 m (one value)"
    )
    assert one_error(with_("train.vehicles[0].stiffness", ...)) == (
        "train.vehicles[0].stiffness: missing required key; expected a stiffness > 0 N/m"
    )
    assert one_error(with_("train", ...)).startswith("train: missing required key; expected")
    assert one_error(with_("study.speeds_kmh", ...)).startswith(
        "study.speeds_kmh: missing required key; expected a list of speeds > 0 km/h"
    )


@pytest.mark.parametrize(
    ("path", "value", "expected"),
    [
        ("bridge.spans", [25.0, -3.0], "bridge.spans[1] = -3.0: expected a span length > 0 m"),
        ("bridge.mass_per_length", 0.0,
         "bridge.mass_per_length = 0.0: expected a mass per length > 0 kg/m"),
        ("train.vehicles[0].mass", -5.0, "train.vehicles[0].mass = -5.0: expected a mass > 0 kg"),
        ("train.vehicles[0].stiffness", 0,
         "train.vehicles[0].stiffness = 0: expected a stiffness > 0 N/m"),
        ("study.speeds_kmh", [100.0, -20.0],
         "study.speeds_kmh[1] = -20.0: expected a speed > 0 km/h"),
        ("solver.dt", 0.0, "solver.dt = 0.0: expected a time step > 0 s"),
        ("solver.dt", float("nan"), "solver.dt = nan: expected a time step > 0 s"),
        ("solver.hht_alpha", -0.5, "solver.hht_alpha = -0.5: expected -1/3 <= hht_alpha <= 0"),
        ("solver.hht_alpha", 0.05, "solver.hht_alpha = 0.05: expected -1/3 <= hht_alpha <= 0"),
        ("bridge.n_modes", 0, "bridge.n_modes = 0: expected an integer number of modes"),
        ("bridge.output_points", [12.5, 30.0],
         "bridge.output_points[1] = 30.0: expected a position on the bridge, 0 <= x <= 25 m"),
        ("contact.model", "penalty", "contact.model = \"penalty\": expected one of 'rigid', "
                                     "'hertz', 'hertz_linear'"),
        ("bridge.kind", "simply_suported", 'bridge.kind = "simply_suported": expected one of '
                                           "'simply_supported', 'continuous', 'rigid', "
                                           "'modes_file', 'matrices' (did you mean "
                                           "'simply_supported'?)"),
    ],
)
def test_config__bad_values(path, value, expected):
    msg = one_error(with_(path, value))
    assert msg.startswith(expected), msg
    # one-line format: "<key path> = <value>: expected <what>"
    assert re.match(r"^[\w.\[\]\"-]+ = .+: expected .+", msg)


def test_config__hertz_contact():
    data = with_("contact", {"model": "hertz", "hertz_coefficient": 4e-8},
                 with_("train.vehicles[0].wheel_mass", 500.0,
                       with_("track", {"model": "rigid"})))  # the Hertz spring alone
    cfg = load_config(data)
    s = cfg.solver_settings()
    assert (s.contact_model, s.hertz_coefficient) == ("hertz", 4e-8)
    assert cfg.contact_model == "hertz"
    # wheel (500 kg) on the Hertz spring at (5750 + 500) kg g: ~190 Hz > 0.1 / dt
    [w] = cfg.warnings
    assert "Hertz contact spring" in w
    assert load_config(base()).solver_settings().contact_model == "rigid"
    assert one_error(with_("contact", {"model": "hertz"})).startswith(
        "contact.hertz_coefficient: missing required key; expected a Hertz constant G > 0 "
        "m N^-2/3"
    )
    ignored = load_config(with_("contact", {"model": "rigid", "hertz_coefficient": 4e-8}))
    assert ignored.warnings == ["contact.hertz_coefficient is ignored: not used by "
                                "contact.model = 'rigid'"]


def test_config__several_spans_need_continuous():
    msg = one_error(with_("bridge.spans", [20.0, 20.0]))
    assert msg.startswith("bridge.spans = [20.0, 20.0]: expected one span length for kind = "
                          "'simply_supported' (use kind = 'continuous'")


def test_config__per_span_list_length():
    data = with_("bridge.kind", "continuous", with_("bridge.spans", [20.0, 20.0]))
    data["bridge"]["EI"] = [1e10, 1e10, 1e10]
    msg = one_error(data)
    assert msg.startswith("bridge.EI = [10000000000.0, 10000000000.0, 10000000000.0]: expected "
                          "one value per span (2 spans)")


def test_config__max_frequency_below_first_mode():
    data = with_("bridge.max_frequency", 2.0, with_("bridge.n_modes", ...))
    assert one_error(data).startswith("bridge.max_frequency = 2.0: expected a frequency >= the "
                                      "first mode (4.778 Hz)")


def test_config__overlapping_vehicles():
    car = {
        "kind": "car", "body_mass": 4.0e4, "body_pitch_inertia": 2.0e6, "bogie_mass": 3.0e3,
        "bogie_pitch_inertia": 2.0e3, "wheelset_mass": 1.8e3, "bogie_spacing": 17.5,
        "wheelbase": 2.5, "primary_stiffness": 2.4e6, "primary_damping": 2.0e4,
        "secondary_stiffness": 7.0e5, "secondary_damping": 4.0e4,
    }
    ok = with_("train.vehicles", [dict(car, offset=0.0), dict(car, offset=25.0)])
    cfg = load_config(ok)
    np.testing.assert_allclose(cfg.trains()[0].axle_positions[:8],
                               [0, 2.5, 17.5, 20, 25, 27.5, 42.5, 45])
    bad = with_("train.vehicles", [dict(car, offset=0.0), dict(car, offset=19.0)])
    assert one_error(bad).startswith(
        "train.vehicles[1].offset = 19.0: expected an offset > 20 m: vehicles are listed front "
        "to back and must not overlap (train.vehicles[0] ends at 20 m"
    )
    forces = with_("train.vehicles", [{"kind": "force", "load": 1e5},
                                      {"kind": "force", "load": 1e5}])
    assert one_error(forces).startswith("train.vehicles[1].offset = 0.0: expected an offset > 0 m")


def test_config__car_and_user_vehicles():
    user = {"kind": "user", "M": [[100.0, 0.0], [0.0, 10.0]], "C": [[0.0, 0.0], [0.0, 0.0]],
            "K": [[1e5, -1e5], [-1e5, 1e5]], "wheel_dofs": [1], "wheel_positions": [0.0],
            "body_dof": 0}
    cfg = load_config(with_("train.vehicles", [user]))
    v = cfg.trains()[0].vehicles[0]
    assert v.n_dof == 2 and v.body_dof == 0
    np.testing.assert_allclose(v.gravity, 9.81 * np.array([100.0, 10.0]))
    asym = copy.deepcopy(user)
    asym["K"][0][1] = -2e5
    assert one_error(with_("train.vehicles", [asym])).startswith(
        "train.vehicles[0].K[0][1] = -200000.0: expected a symmetric matrix "
        "(train.vehicles[0].K[1][0] = -100000.0)"
    )
    wrong = dict(user, wheel_dofs=[2])
    assert one_error(with_("train.vehicles", [wrong])).startswith(
        "train.vehicles[0].wheel_dofs[0] = 2: expected a DOF index 0 <= i <= 1"
    )
    car = {"kind": "car", "body_mass": 4e4, "body_pitch_inertia": 2e6, "bogie_mass": 3e3,
           "bogie_pitch_inertia": 2e3, "wheelset_mass": 1.8e3, "bogie_spacing": 2.0,
           "wheelbase": 2.5, "primary_stiffness": 2.4e6, "primary_damping": 2e4,
           "secondary_stiffness": 7e5, "secondary_damping": 4e4}
    assert one_error(with_("train.vehicles", [car])).startswith(
        "train.vehicles[0].bogie_spacing = 2.0: expected a distance between bogie centres > the "
        "wheelbase (2.5 m)"
    )


def test_config__unknown_preset():
    msg = one_error(with_("train", {"preset": ["HSLM-A1", "HSLM-A11"]}))
    assert msg.startswith('train.preset[1] = "HSLM-A11": expected a train name from the library')
    assert "did you mean 'HSLM-A1" in msg
    msg = one_error(with_("train", {"preset": "ICE3", "model": "interactoin"}))
    assert msg.startswith('train.model = "interactoin": expected one of \'interaction\', '
                          "'moving_force' (did you mean 'interaction'?)")
    msg = one_error(with_("train", {"preset": "HSLM-A1", "model": "interaction"}))
    assert msg.startswith('train.preset = "HSLM-A1": expected a train that can be built with '
                          "train.model = 'interaction'")


def test_config__preset_models():
    cfg = load_config(with_("train", {"preset": ["HSLM-A1", "ICE3"]}))
    hslm, ice3 = cfg.trains()
    assert hslm.n_wheels == 0 and ice3.n_wheels > 0  # default: interaction where available
    cfg = load_config(with_("train", {"preset": "ICE3", "model": "moving_force"}))
    assert cfg.trains()[0].n_wheels == 0
    assert "model" not in load_config(with_("train", {"preset": "ICE3"})).resolved()["train"]


# --------------------------------------------------------------------------- files


def test_config__toml_syntax_error_has_line_and_column(tmp_path):
    p = write(tmp_path, 'title = "x"\n[bridge]\nspans = [25.0\nEI = 1\n')
    msg = one_error(p)
    assert str(p) in msg and "TOML syntax error" in msg
    assert re.search(r"line \d+, column \d+", msg), msg


def test_config__not_a_toml_file(tmp_path):
    p = tmp_path / "results.nc"
    p.write_bytes(b"\x89HDF\r\n\x1a\n\x00\x00\xff\xfe")
    assert "not a TOML file" in one_error(p)
    q = write(tmp_path, "x,r\n0,0\n1,0\n", name="profile.csv")
    msg = one_error(q)
    assert "TOML syntax error" in msg and "(is this a TOML file?)" in msg
    assert "file not found" in one_error(tmp_path / "nope.toml")
    assert "is a directory" in one_error(tmp_path)
    with pytest.raises(ConfigError, match="expected a path to a TOML file or a mapping"):
        load_config(42)


def test_config__empty_file_reports_every_missing_table(tmp_path):
    errs = errors_of(write(tmp_path, ""))
    assert [e.split(":")[0] for e in errs] == ["bridge", "train", "study"]


PROFILE_OK = "# measured\nx,r\n" + "\n".join(f"{x:.1f},{1e-3 * np.sin(x):.6e}"
                                             for x in np.arange(-10.0, 30.01, 0.5)) + "\n"


def _file_irregularity(tmp_path, text, name="prof.csv"):
    (tmp_path / "data").mkdir(exist_ok=True)
    (tmp_path / "data" / name).write_text(text)
    return with_("irregularity", {"kind": "file", "path": f"data/{name}"})


def test_config__profile_file(tmp_path):
    cfg = load_config(_file_irregularity(tmp_path, PROFILE_OK), base_dir=tmp_path)
    [(rid, prof)] = cfg.irregularities(-5.0, 26.0)
    assert rid == -1
    np.testing.assert_allclose(prof(np.array([3.0])), 1e-3 * np.sin(3.0), atol=1e-5)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (None, "an existing file with the profile"),
        ("x,r\n0,0\n2,0\n1,0\n3,0\n", "strictly increasing"),
        ("x,r\n-10,0\n0,nan\n10,0\n20,0\n30,0\n", "missing, non-numeric or infinite"),
        ("x,r\n-10,0\n30,0\n", "at least 4"),
        ("x,r\n0,0\n5,0\n10,0\n15,0\n30,0\n", "a profile covering the approach and the bridge, "
                                              "x = -5 .. 25 m (the file covers 0 .. 30 m"),
        ("a,b\n0,0\n1,0\n2,0\n3,0\n", "missing column"),
    ],
    ids=["missing", "non-monotonic", "nan", "too-few", "too-short", "columns"],
)
def test_config__bad_profile_file(tmp_path, text, expected):
    if text is None:
        data = with_("irregularity", {"kind": "file", "path": "data/none.csv"})
    else:
        data = _file_irregularity(tmp_path, text)
    msg = one_error(data, base_dir=tmp_path)
    assert msg.startswith('irregularity.path = "data/'), msg
    assert expected in msg, msg


def test_config__relative_paths_resolve_against_the_config_file(tmp_path):
    sub = tmp_path / "cases"
    sub.mkdir()
    (sub / "data").mkdir()
    (sub / "data" / "prof.csv").write_text(PROFILE_OK)
    text = """
title = "rel"
[bridge]
kind = "simply_supported"
spans = [25.0]
EI = 8.323e9
mass_per_length = 2303.0
n_modes = 3
[[train.vehicles]]
kind = "force"
load = 1.0e5
[irregularity]
kind = "file"
path = "data/prof.csv"
[study]
speeds_kmh = [100.0]
output = "out/run.nc"
"""
    p = write(sub, text)
    cfg = load_config(p)
    assert cfg.output_path == (sub / "out" / "run.nc").resolve()
    assert cfg.base_dir == sub.resolve()
    assert cfg.resolved()["irregularity"]["path"] == "data/prof.csv"  # as written
    # the same mapping elsewhere: relative to base_dir (default: the working directory)
    data = cfg.resolved()
    assert load_config(data, base_dir=sub).sha256 == cfg.sha256
    msg = one_error(data, base_dir=tmp_path)
    assert msg.startswith('irregularity.path = "data/prof.csv": expected an existing file')
    default = load_config(with_("study.output", ..., cfg.resolved()), base_dir=sub)
    assert default.output_path == (sub / "results" / "run.nc").resolve()
    assert load_config(with_("study.output", ...)).output_path == (
        Path.cwd() / "results" / "run.nc").resolve()


def test_config__user_train_file(tmp_path):
    from vsi_numba.model import library

    text = """
[[vehicle]]
id = "cfg_test_coach"
bogie_spacing = 17.5
wheelbase = 2.5
[vehicle.whole]
body_mass = 40000.0
body_pitch_inertia = 2.0e6
bogie_mass = 3000.0
bogie_pitch_inertia = 2000.0
wheelset_mass = 1800.0
primary_stiffness = 2.4e6
primary_damping = 2.0e4
secondary_stiffness = 7.0e5
secondary_damping = 4.0e4

[[train]]
id = "cfg_test_train"
vehicles = ["cfg_test_coach", "cfg_test_coach"]
vehicle_offsets = [0.0, 25.0]
"""
    write(tmp_path, text, name="trains.toml")
    try:
        cfg = load_config(with_("train", {"file": "trains.toml"}), base_dir=tmp_path)
        [train] = cfg.trains()
        assert train.name == "cfg_test_train" and train.n_wheels == 8
        write(tmp_path, text.replace("bogie_spacing = 17.5", "bogie_spacing = -1.0"),
              name="bad.toml")
        msg = one_error(with_("train", {"file": "bad.toml"}), base_dir=tmp_path)
        assert msg.startswith('train.file = "bad.toml": expected a valid user train file')
    finally:
        library.clear_user_trains()


def test_config__modes_file_must_be_a_readable_table(tmp_path):
    (tmp_path / "modes.nc").write_bytes(b"")
    data = with_("bridge", {"kind": "modes_file", "file": "modes.nc", "spans": [25.0]})
    msg = one_error(data, base_dir=tmp_path)
    assert msg.startswith('bridge.file = "modes.nc": expected a netCDF or CSV modes table '
                          "(the file is empty)"), msg
    msg = one_error(data, base_dir=tmp_path / "elsewhere")
    assert msg.startswith('bridge.file = "modes.nc": expected an existing file')


# ------------------------------------------------------------------ several at once


def test_config__all_errors_reported_together():
    data = base()
    data["bridge"]["spans"] = [-25.0]
    data["bridge"]["mass"] = 2303.0
    data["bridge"]["mass_per_length"] = "heavy"
    data["train"]["vehicles"][0]["stiffness"] = -1.0
    data["solver"]["hht_alpha"] = 0.3
    data["study"]["speeds_kmh"] = {"start": 140.0, "stop": 100.0, "step": 5.0}
    data["irregularity"] = {"kind": "psd", "spectrum": "german_lo", "wavelength_min": 3.0,
                            "wavelength_max": 1.0}
    errs = errors_of(data)
    heads = {e.split(" = ")[0].split(":")[0] for e in errs}
    assert heads == {
        "bridge.spans[0]", "bridge.mass", "bridge.mass_per_length",
        "train.vehicles[0].stiffness", "solver.hht_alpha", "study.speeds_kmh.stop",
        "irregularity.spectrum", "irregularity.wavelength_max", "irregularity.seeds",
    }, errs
    # in the order of the sections (bridge, train, solver, study, irregularity)
    firsts = [e.split(".")[0] for e in errs]
    assert firsts == sorted(firsts, key=list(data).index)
    assert any("did you mean 'german_low'?" in e for e in errs)
    assert any("did you mean 'mass_per_length'?" in e for e in errs)


# ---------------------------------------------------------------------------- speeds


@pytest.mark.parametrize(
    ("speeds", "expected"),
    [
        ({"start": 140, "stop": 420, "step": 5}, np.arange(140.0, 420.1, 5.0)),
        ({"start": 140, "stop": 422, "step": 5}, np.arange(140.0, 420.1, 5.0)),
        ({"start": 100, "stop": 100.3, "step": 0.1}, [100.0, 100.1, 100.2, 100.3]),
        ({"start": 200, "stop": 200, "step": 5}, [200.0]),
        ([300.0, 100.0], [300.0, 100.0]),
        (250, [250.0]),
    ],
)
def test_config__speeds_grid(speeds, expected):
    cfg = load_config(with_("study.speeds_kmh", speeds))
    np.testing.assert_array_equal(cfg.speeds_kmh, expected)  # grid values are rounded exactly


def test_config__default_speeds_from_line_speed():
    data = with_("study.speeds_kmh", ..., with_("study.line_speed_kmh", 300.0))
    np.testing.assert_array_equal(load_config(data).speeds_kmh, np.arange(140.0, 360.1, 5.0))
    data = with_("study.line_speed_kmh", 160.0, data)  # 1.2 x 160 = 192 is kept as the last
    np.testing.assert_array_equal(load_config(data).speeds_kmh,
                                  [140, 145, 150, 155, 160, 165, 170, 175, 180, 185, 190, 192])
    assert load_config(data).resolved()["study"]["speeds_kmh"][-1] == 192.0


def test_config__history_speeds_subset():
    cfg = load_config(with_("study.history_speeds_kmh", [200.0]))
    np.testing.assert_array_equal(cfg.history_speeds_kmh, [200.0])
    assert load_config(base()).history_speeds_kmh is None
    assert one_error(with_("study.history_speeds_kmh", [150.0])) == (
        "study.history_speeds_kmh[0] = 150.0: expected one of the speeds of study.speeds_kmh"
    )


# -------------------------------------------------------------------- hash / resolved


def test_config__hash_stable_and_sensitive(tmp_path):
    text = (ROOT / "configs" / "quickstart.toml").read_text()
    a = load_config(write(tmp_path, text, "a.toml"))
    b = load_config(write(tmp_path, text, "b.toml"))
    assert a.sha256 == b.sha256 and len(a.sha256) == 64
    assert a.to_json() == b.to_json()
    # key order and comments do not matter; values do
    lines = text.splitlines()
    i, j = lines.index("[solver]"), lines.index("[study]")
    moved = "\n".join(lines[:i] + lines[j:] + lines[i:j]) + "\n# comment\n"
    assert load_config(write(tmp_path, moved, "c.toml")).sha256 == a.sha256
    changed = text.replace("dt = 1e-3", "dt = 5e-4")
    assert changed != text
    assert load_config(write(tmp_path, changed, "d.toml")).sha256 != a.sha256
    # defaults are explicit: writing a default value gives the same hash
    explicit = text.replace("[solver]", "[solver]\nhht_alpha = -0.3\nmax_iterations = 50")
    assert load_config(write(tmp_path, explicit, "e.toml")).sha256 == a.sha256


def test_config__resolved_fills_defaults():
    r = load_config(base()).resolved()
    assert r["solver"]["hht_alpha"] == -0.3 and r["solver"]["approach"] == 5.0
    assert r["irregularity"] == {"kind": "none"}
    assert r["contact"] == {"model": "rigid"}
    assert r["bridge"]["output_points"] == [12.5]
    assert r["bridge"]["damping_ratio"] == 0.0
    assert r["study"]["save_time_histories"] is True
    assert r["train"]["vehicles"][0]["damping"] == 0.0
    assert r["train"]["vehicles"][0]["wheel_mass"] == 0.0
    json.dumps(r)


def test_config__default_output_points_every_midspan():
    data = with_("bridge", {"kind": "continuous", "spans": [20.0, 30.0, 20.0], "EI": 1e10,
                            "mass_per_length": 1e4, "n_modes": 6, "elements_per_span": 10})
    np.testing.assert_allclose(load_config(data).output_points, [10.0, 35.0, 60.0])


# ----------------------------------------------------------------- irregularities


def test_config__irregularity_kinds():
    cos = {"kind": "cosine", "depth": 2e-3, "wavelength": 5.0, "position": 10.0}
    cfg = load_config(with_("irregularity", cos))
    [(rid, prof)] = cfg.irregularities(-10.0, 30.0)
    assert rid == -1
    np.testing.assert_allclose(prof(np.array([12.5])), 2e-3, rtol=1e-6)  # bottom of the dip
    psd = {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
           "wavelength_max": 80.0, "seeds": [7, 3],
           "defects": [dict(cos), {"kind": "step", "height": 1e-3, "length": 4.0,
                                   "position": 20.0}]}
    cfg = load_config(with_("irregularity", psd))
    out = cfg.irregularities(-30.0, 40.0)
    assert [i for i, _ in out] == [7, 3]
    assert "cosine" in out[0][1].label and "step" in out[0][1].label
    assert one_error(with_("irregularity", dict(cos, depth=0.0))).startswith(
        "irregularity.depth = 0.0: expected a depth != 0 m"
    )
    assert one_error(with_("irregularity", dict(psd, seeds=[1, 1]))) == (
        "irregularity.seeds = [1, 1]: expected distinct seeds"
    )


def test_config__ignored_keys_warn():
    data = with_("irregularity", {"kind": "none", "depth": 1e-3})
    cfg = load_config(data)
    assert cfg.warnings == ["irregularity.depth is ignored: not used by irregularity.kind = "
                            "'none'"]


# ------------------------------------------------------------------------ warnings


def test_config__warning_dt_too_large_for_modes():
    cfg = load_config(with_("bridge.n_modes", 20))
    [w] = [w for w in cfg.warnings if "bridge mode" in w]
    assert w.startswith("solver.dt = 0.001 s: dt x f = 1.91 for the highest retained bridge "
                        "mode (1911 Hz)")


def test_config__warning_modes_below_en1990_cutoff():
    cfg = load_config(with_("bridge.n_modes", 1))
    [w] = cfg.warnings
    assert "highest retained mode (4.778 Hz)" in w
    assert "max(30 Hz, 1.5 f1, f3) = 43 Hz; 2 mode(s)" in w


def test_config__warning_vehicle_frequency():
    stiff = with_("train.vehicles[0].stiffness", 5750.0 * (2 * np.pi * 200.0) ** 2)
    [w] = load_config(stiff).warnings
    assert "highest vehicle frequency" in w and "(200 Hz" in w


def test_config__warning_psd_sampling():
    psd = {"kind": "psd", "spectrum": "fra6", "wavelength_min": 0.5, "wavelength_max": 50.0,
           "seeds": [1]}
    [w] = load_config(with_("irregularity", psd)).warnings
    assert w.startswith("irregularity.wavelength_min = 0.5 m is crossed in 9 time steps at "
                        "200 km/h")


@pytest.mark.parametrize("track", ["one", None, 1.5])
def test_config__bad_train_track_next_to_other_trains_is_an_error(track):
    """A train.track that is refused, next to train.other_trains: the error names it (the
    other trains' tracks are not compared with a refused value; no TypeError)."""
    data = {
        "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 1.5e10,
                   "mass_per_length": 1.0e4, "n_modes": 3, "damping_ratio": 0.01,
                   "tracks": [{"eccentricity": 2.0}, {"eccentricity": -2.0}],
                   "torsion": {"GJ": 1e10, "polar_mass": 4.0e4, "n_modes": 2}},
        "train": {"preset": "HSLM-A1", "model": "moving_force", "track": track,
                  "other_trains": [{"track": 2, "direction": "opposite", "offset": 10.0}]},
        "study": {"speeds_kmh": [200.0]},
    }
    with pytest.raises(ConfigError) as exc:
        load_config(data)
    assert [e for e in exc.value.errors if e.startswith("train.track = ")], exc.value.errors
    data["train"]["track"] = 1  # the same configuration with a valid track loads
    assert load_config(data).other_trains[0]["track"] == 2
