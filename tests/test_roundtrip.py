"""The stored configuration (``config_json`` of every results file) reloads and reproduces
its run: load -> store -> reload gives the same Config (SHA-256, stored JSON) and the same
resolved study (speeds, trains, realisations, bridge and damping, solver settings,
variants), for every bundled config and for one generated config per documented key."""

from __future__ import annotations

import copy
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from vsi_numba.config import load_config
from vsi_numba.study.spec import _build_model, model_fingerprint

ROOT = Path(__file__).resolve().parents[1]
BUNDLED = sorted((ROOT / "configs").glob("*.toml")) + sorted(
    (ROOT / "studies").glob("*/study.toml"))


def study_of(cfg) -> dict:
    """What a study computes from, in plain data (compared with ==)."""
    trains = cfg.trains()
    settings = cfg.solver_settings()
    bridge = cfg.build_bridge()
    profiles = cfg.irregularities(-50.0, 100.0)
    out = {
        "title": cfg.title,
        "speeds_kmh": cfg.speeds_kmh.tolist(),
        "history_speeds_kmh": (None if cfg.history_speeds_kmh is None
                               else cfg.history_speeds_kmh.tolist()),
        "save_time_histories": cfg.save_time_histories,
        "output_path": str(cfg.output_path),
        "trains": [(t.name, len(t.vehicles), float(t.length)) for t in trains],
        "frequencies": np.asarray(bridge.frequencies).tolist(),
        # the numbers the runs are computed from (built bridge, trains, profiles,
        # settings, points): what a resumed store and every Dask worker must agree on
        "model_fingerprint": model_fingerprint(_build_model(cfg)),
        "damping": [np.asarray(cfg.bridge_for(t).damping).tolist() for t in trains],
        "damping_rules": (cfg.damping_rule, cfg.additional_damping_rule),
        "output_points": cfg.output_points.tolist(),
        "settings": asdict(settings) if hasattr(settings, "__dataclass_fields__")
        else repr(settings),
        "track": (cfg.track_model, repr(cfg.rail_track)),
        "contact": cfg.contact_model,
        "realisations": [(i, p.x0, p.dx, np.asarray(p.coef).tobytes(), p.label)
                         for i, p in profiles],
        "variants": [(json.dumps(lab, sort_keys=True), v.sha256) for lab, v in cfg.variants],
    }
    return out


def assert_roundtrip(cfg) -> None:
    """Stored JSON -> reload: same hash, same stored JSON (a fixed point), same study;
    the same for every variant's stored configuration (``variant_config_json``)."""
    stored = cfg.to_json()
    again = load_config(json.loads(stored), base_dir=cfg.base_dir)
    assert again.sha256 == cfg.sha256
    assert again.to_json() == stored
    assert study_of(again) == study_of(cfg)
    for _, v in cfg.variants:
        assert_roundtrip(v)


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: str(p.relative_to(ROOT)))
def test_roundtrip__bundled(path):
    assert_roundtrip(load_config(path))


# ------------------------------------------------------------------ one config per feature

BASE = {
    "title": "feature",
    "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 2.0e10,
               "mass_per_length": 12000.0, "n_modes": 3},
    "train": {"vehicles": [{"kind": "force", "load": 170e3}]},
    "solver": {"dt": 1e-3, "free_vibration": 0.0},
    "study": {"speeds_kmh": [100.0, 200.0], "output": "out.nc"},
}
SPRUNG = {"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6, "damping": 1.0e3,
          "wheel_mass": 500.0, "offset": 0.0, "name": "quarter car"}
CAR = {"kind": "car", "body_mass": 34000.0, "body_pitch_inertia": 1.7e6, "bogie_mass": 3000.0,
       "bogie_pitch_inertia": 2000.0, "wheelset_mass": 1800.0, "bogie_spacing": 17.5,
       "wheelbase": 2.5, "primary_stiffness": 2.4e6, "primary_damping": 2.0e4,
       "secondary_stiffness": 6.0e5, "secondary_damping": 4.0e4,
       "body_cg_to_front_bogie": 8.0}
USER = {"kind": "user", "M": [[2000.0, 0.0], [0.0, 500.0]], "C": [[1e3, -1e3], [-1e3, 1e3]],
        "K": [[1e6, -1e6], [-1e6, 1e6]], "wheel_dofs": [1], "wheel_positions": [0.0],
        "gravity": [19620.0, 4905.0], "body_dof": 0}
TRACK_LAYER = {"rail_EI": 1.283e7, "rail_mass_per_length": 120.6, "pad_stiffness": 3.0e8,
               "pad_damping": 1.0e4, "sleeper_mass": 300.0, "sleeper_spacing": 0.6,
               "ballast_stiffness": 2.0e8, "ballast_damping": 5.0e4,
               "rail_elements_per_bay": 1}
IMPORTED = {"spans": [20.0, 20.0], "n_modes": 6, "output_points": [10.0, 30.0],
            "damping_ratio": 0.015}
HSLM = {"preset": ["HSLM-A1", "HSLM-A2"], "model": "moving_force"}
TRAIN_FILE = """
[[vehicle]]
id = "my_coach"
bogie_spacing = 17.5
wheelbase = 2.5
front_overhang = 3.0
rear_overhang = 3.0

[vehicle.whole]
body_mass = 34000.0
body_pitch_inertia = 1.7e6
bogie_mass = 3000.0
bogie_pitch_inertia = 2000.0
wheelset_mass = 1800.0
primary_stiffness = 2.4e6
primary_damping = 2.0e4
secondary_stiffness = 6.0e5
secondary_damping = 4.0e4

[[train]]
id = "my_2car"
vehicles = ["my_coach", "my_coach"]
"""


def _set(data: dict, path: str, value) -> None:
    node = data
    keys = path.split(".")
    for k in keys[:-1]:
        node = node.setdefault(k, {})
    node[keys[-1]] = value


def feature(**changes) -> dict:
    """BASE with ``{"a.b.c": value}`` set (``None`` deletes)."""
    data = copy.deepcopy(BASE)
    for path, value in changes.items():
        path = path.replace("__", ".")
        if value is None:
            node = data
            *head, last = path.split(".")
            for k in head:
                node = node[k]
            node.pop(last, None)
        else:
            _set(data, path, copy.deepcopy(value))
    return data


#: name -> config mapping; every key of the documented key reference appears in one
#: (checked by test_roundtrip__features_cover_documented_keys)
FEATURES = {
    "title": feature(title="a title"),
    "simply_supported_damping_per_mode": feature(bridge__damping_ratio=[0.01, 0.02, 0.03]),
    "max_frequency": feature(bridge__n_modes=None, bridge__max_frequency=40.0),
    "n_modes_and_max_frequency": feature(bridge__max_frequency=40.0),
    "output_points": feature(bridge__output_points=[5.0, 10.0]),
    "track_type": feature(bridge__track_type="direct_fastening"),
    "en_damping": feature(bridge__damping_ratio="EN1991-2",
                          bridge__deck_type="prestressed_concrete"),
    "en_damping_additional": feature(bridge__damping_ratio="EN1991-2",
                                     bridge__deck_type="steel_composite",
                                     bridge__additional_damping=True, train=HSLM),
    "additional_damping_numeric_zeta": feature(bridge__damping_ratio=0.01,
                                               bridge__additional_damping=True),
    "continuous": feature(bridge__kind="continuous", bridge__spans=[20.0, 25.0],
                          bridge__EI=[2.0e10, 3.0e10], bridge__mass_per_length=12000.0,
                          bridge__elements_per_span=10, bridge__damping_ratio=0.02),
    "continuous_en_damping": feature(bridge__kind="continuous", bridge__spans=[20.0, 25.0],
                                     bridge__elements_per_span=10,
                                     bridge__damping_ratio="EN1991-2",
                                     bridge__deck_type="filler_beam_reinforced_concrete",
                                     bridge__additional_damping=True),
    "track_layer": feature(bridge__kind="continuous", bridge__elements_per_span=10,
                           bridge__n_modes=None, bridge__max_frequency=200.0,
                           bridge__track=TRACK_LAYER, solver__dt=2e-4,
                           solver__allow_coarse_dt=True),
    "tracks_torsion": feature(
        bridge__tracks=[{"eccentricity": 2.25}, {"eccentricity": -2.25, "gauge": 1.5}],
        bridge__torsion={"GJ": 2e10, "polar_mass": 4e4, "damping_ratio": 0.01,
                         "n_modes": 2}, train__track=2),
    "trains_meeting": feature(
        bridge__kind="continuous", bridge__spans=[20.0, 25.0], bridge__elements_per_span=10,
        bridge__tracks=[{"eccentricity": 2.25}, {"eccentricity": -2.25}],
        bridge__torsion={"GJ": 2e10, "polar_mass": 4e4},
        train={**HSLM, "other_trains": [{"track": 2, "direction": "opposite",
                                         "offset": 12.5}]}),
    "continuous_torsion_en_damping": feature(
        bridge__kind="continuous", bridge__spans=[20.0, 25.0], bridge__elements_per_span=10,
        bridge__damping_ratio="EN1991-2", bridge__deck_type="prestressed_concrete",
        bridge__tracks=[{"eccentricity": 2.25}, {"eccentricity": -2.25}],
        bridge__torsion={"GJ": [2e10, 3e10], "polar_mass": 4e4}),
    "rigid": {**feature(), "bridge": {"kind": "rigid", "spans": [20.0],
                                      "output_points": [10.0]}},
    "modes_file_nc": {**feature(), "bridge": {
        "kind": "modes_file", "file": "data/two_span_modes.nc", "track_line": "track2",
        **IMPORTED}, "train": {"preset": "manchester_benchmark_single",
                               "model": "interaction"}},
    "modes_file_csv": {**feature(), "bridge": {
        "kind": "modes_file", "file": "modes.csv", "mass_normalised": True}},
    "matrices": {**feature(), "bridge": {
        "kind": "matrices", "stiffness_matrix": "data/two_span_K.mtx",
        "mass_matrix": "data/two_span_M.mtx", "station_map": "data/two_span_stations.csv",
        "track_line": "track1", "fixed_dofs": [0, 40, 80, 82, 122, 162], "dof_base": 0,
        "rotation_sign": 1, **IMPORTED}},
    "matrices_vertical_dofs": {**feature(), "bridge": {
        "kind": "matrices", "stiffness_matrix": "data/two_span_K.mtx",
        "mass_matrix": "data/two_span_M.mtx", "station_map": "data/two_span_stations.csv",
        "track_line": "track1", "fixed_dofs": [0, 40, 80, 82, 122, 162],
        "vertical_dofs": {"start": 0, "step": 2}, **IMPORTED}},
    "preset_one": feature(train={"preset": "HSLM-A3"}),
    "preset_list_moving_force": feature(train=HSLM),
    "preset_interaction": feature(train={"preset": "ICE3", "model": "interaction"}),
    "train_file": feature(train={"file": "trains.toml"}),
    "vehicles_named": feature(train={"name": "my train", "vehicles": [SPRUNG]}),
    "vehicles_mixed": feature(train={"vehicles": [
        {"kind": "force", "load": 1.0e5, "offset": 0.0, "name": "loco axle"},
        {**SPRUNG, "offset": 5.0}, {**USER, "offset": 8.0}, {**CAR, "offset": 12.0}]}),
    "cosine": feature(irregularity={"kind": "cosine", "depth": 2e-3, "wavelength": 3.0,
                                    "position": 5.0}),
    "step": feature(irregularity={"kind": "step", "height": 1e-3, "length": 4.0,
                                  "position": 2.0, "shape": "quintic"}),
    "psd": feature(irregularity={"kind": "psd", "spectrum": "german_low",
                                 "wavelength_min": 3.0, "wavelength_max": 60.0,
                                 "seeds": [1, 2], "dx": 0.1}),
    "file": feature(irregularity={"kind": "file", "path": "profile.csv", "x_column": "pos",
                                  "r_column": "dip", "r_unit": "mm", "dx": 0.25}),
    "defects": feature(irregularity={"kind": "none", "defects": [
        {"kind": "cosine", "depth": 1e-3, "wavelength": 2.0, "position": 3.0},
        {"kind": "step", "height": -1e-3, "length": 3.0, "position": 10.0}]}),
    "solver_all": feature(solver={"dt": 5e-4, "hht_alpha": -0.1, "approach": 10.0,
                                  "free_vibration": 0.5, "max_iterations": 20,
                                  "max_subdivisions": 2, "acceleration_cutoff": 40.0,
                                  "allow_coarse_dt": False, "allow_implausible": False,
                                  "allow_large_problem": False}),
    "contact_hertz": feature(train={"vehicles": [SPRUNG]}, solver__dt=2.5e-4,
                             contact={"model": "hertz", "hertz_coefficient": 2.65e-8}),
    "contact_hertz_linear": feature(train={"vehicles": [SPRUNG]}, solver__dt=2.5e-4,
                                    contact={"model": "hertz_linear",
                                             "hertz_coefficient": 2.65e-8}),
    "track_rigid": feature(track={"model": "rigid"}),
    "track_elastic": feature(track={"model": "elastic", "foundation_stiffness": 1.0e8,
                                    "rail_EI": 1.3e7}),
    "speeds_grid": feature(study__speeds_kmh={"start": 100.0, "stop": 200.0, "step": 50.0}),
    "line_speed": feature(study__speeds_kmh=None, study__line_speed_kmh=160.0),
    "histories": feature(study__save_time_histories=True, study__history_speeds_kmh=[200.0]),
    "no_histories": feature(study__save_time_histories=False),
    "refine_resonance": feature(train=HSLM, study__refine_resonance=True,
                                study__speeds_kmh={"start": 140.0, "stop": 300.0,
                                                   "step": 20.0}),
    "refine_resonance_line_speed": feature(train=HSLM, study__speeds_kmh=None,
                                           study__line_speed_kmh=200.0,
                                           study__refine_resonance=True),
    "vary": feature(study__vary={"bridge.damping_ratio": [0.01, 0.02],
                                 "track.foundation_stiffness": [8e7, 1e8]}),
    "vary_together_label": feature(study__vary_together=[{
        "label": ["short", "long"], "bridge.spans": [[20.0], [25.0]],
        "bridge.EI": [2.0e10, 4.0e10], "bridge.mass_per_length": [12000.0, 15000.0]}]),
    "mass_bounds": feature(study__mass_bounds=[0.9, 1.1]),
    "load_effect_checks": feature(study__classification_factor=1.21,
                                  study__track_maintenance="careful"),
    "no_load_effects": feature(study__load_effects=False),
    "damped_massive_track": feature(track={"model": "elastic", "foundation_damping": 1.5e5,
                                           "rail_mass": 120.0}),
    "load_distribution": feature(track={"load_distribution": "rail_ballast",
                                        "sleeper_spacing": 0.65, "sleeper_width": 0.28,
                                        "ballast_depth": 0.45}),
    "load_distribution_elastic": feature(track={"load_distribution": "elastic_track"}),
    "hslm_b": feature(train={"preset": "HSLM-B", "hslm_b": {"N": 10, "d": 3.5}}),
    "code_profile": feature(code_profile={
        "name": "DE national annex",
        "overrides": {"deck_acceleration_limit_ballasted": 3.0,
                      "wheel_unloading_limit": {"value": 0.5, "clause": "client rule R-12"}}}),
    "axle_list": feature(train={"axles": {"file": "axles.csv", "load_unit": "kN",
                                          "name": "axle list"}}),
    "fatigue": feature(fatigue={
        "design_life_years": 80.0, "mix": "light",
        "sections": [{"x": 10.0, "section_modulus": 0.1, "detail_category": 71.0,
                      "gamma_Ff": 1.1, "gamma_Mf": 1.15, "name": "mid-span"}],
        "studs": [{"x": 2.0, "diameter": 0.022, "per_row": 4, "row_spacing": 0.15,
                   "first_moment": 0.06, "second_moment": 0.12, "gamma_Ff": 1.05,
                   "gamma_Mf": 1.1, "name": "bearing"}],
        "traffic": [{"train": "HSLM-A3", "speed_kmh": 200.0, "per_day": 4.0,
                     "model": "moving_force"},
                    {"train": "axles.csv", "speed_kmh": 100.0, "per_day": 2.0}]}),
    "compatibility": feature(study__speeds_kmh=[100.0, 200.0, 220.0], compatibility={
        "train": "feature", "line_speed_kmh": 200.0, "speed_factor": 1.1}),
    "calibration": feature(calibration={
        "parameters": [
            {"key": "bridge.EI", "prior": "lognormal", "median": 2.0e10, "cov": 0.2},
            {"key": "bridge.damping_ratio", "prior": "uniform", "lower": 0.005,
             "upper": 0.05},
            {"key": "bridge.mass_per_length", "prior": "normal", "mean": 12000.0,
             "std": 600.0}],
        "records": [{"file": "passage.csv", "quantity": "deck_acceleration",
                     "point": 10.0, "train": "HSLM-A1", "speed_kmh": 200.0}],
        "noise_std": 0.1, "sampler": "emcee", "n_samples": 64, "n_walkers": 8,
        "burn_in": 16, "seed": 3, "max_lag_s": 1.0, "check_samples": 20}),
    "reliability": feature(reliability={
        "check": "deck_acceleration", "method": "monte_carlo", "target_cov": 0.2,
        "limit": 3.5, "max_runs": 1000, "block_size": 100, "seed": 2,
        "variables": [{"key": "bridge.damping_ratio", "distribution": "lognormal",
                       "median": 0.015, "cov": 0.3}]}),
    "catalogue_pattern": feature(
        train=HSLM, bridge__damping_ratio="EN1991-2", bridge__deck_type="prestressed_concrete",
        bridge__additional_damping=True, study__refine_resonance=True,
        study__speeds_kmh=None, study__line_speed_kmh=200.0,
        study__vary_together=[{"label": ["a", "b"], "bridge.spans": [[10.0], [15.0]],
                               "bridge.EI": [4.0e9, 1.0e10]}],
        study__mass_bounds=[0.9, 1.1]),
}


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """A directory with the files the features name (profile, trains, modes table) and
    the bundled deck data (``data/``)."""
    d = tmp_path_factory.mktemp("features")
    (d / "data").symlink_to(ROOT / "configs" / "data", target_is_directory=True)
    x = np.arange(-60.0, 120.0, 0.5)
    np.savetxt(d / "profile.csv", np.c_[x, 0.5 * np.sin(2 * np.pi * x / 7.0)],
               delimiter=",", header="pos,dip", comments="")
    (d / "trains.toml").write_text(TRAIN_FILE)
    t = np.arange(0.0, 2.0, 0.01)
    np.savetxt(d / "passage.csv", np.c_[t, 0.1 * np.sin(2 * np.pi * 4.0 * t)],
               delimiter=",", header="t,value", comments="")
    (d / "axles.csv").write_text("position,load\n0,200\n2.5,200\n17.5,180\n20,180\n")
    # mass-normalised sine modes of a 20 m span (m = 12 t/m): phi = sqrt(2/(mL)) sin(j pi x/L)
    xs = np.linspace(0.0, 20.0, 41)
    rows = ["mode,frequency,damping_ratio,line,x,shape"]
    for j in (1, 2, 3):
        f = 0.5 * j**2 * np.pi / 20.0**2 * np.sqrt(2.0e10 / 12000.0)
        amp = np.sqrt(2 / (12000.0 * 20.0))
        rows += [f"{j},{f:.17g},0.01,1,{x:.17g},{amp * np.sin(j * np.pi * x / 20.0):.17g}"
                 for x in xs]
    (d / "modes.csv").write_text("\n".join(rows) + "\n")
    return d


@pytest.mark.parametrize("name", list(FEATURES))
def test_roundtrip__feature(name, files):
    cfg = load_config(FEATURES[name], base_dir=files)
    assert_roundtrip(cfg)


def _keys(node) -> set[str]:
    out = set()
    if isinstance(node, dict):
        for k, v in node.items():
            out.add(k)
            out |= _keys(v)
    elif isinstance(node, list):
        for v in node:
            out |= _keys(v)
    return out


def documented_keys() -> set[str]:
    """The key names of the declared config tables (:mod:`vsi_numba.config.schema`),
    less those of ``[report]`` and ``[code_profile] overrides`` (text and clause values
    that change no run) and the nonlinear suspension tables (their own tests round-trip
    them); the key list of the former docstring reference had none of these."""
    from vsi_numba.config.schema.keys import all_keys
    from vsi_numba.config.schema.models import Overrides, Report, SourcedValue

    free = {"report", *Overrides.model_fields, *Report.model_fields,
            *SourcedValue.model_fields, "gap", "force", "post_damping", "bump_stop",
            "damper_blowoff", "primary_bump_stop", "primary_damper_blowoff",
            "secondary_bump_stop", "secondary_damper_blowoff"}
    return all_keys() - free


def test_roundtrip__features_cover_documented_keys():
    used = set()
    for data in FEATURES.values():
        used |= _keys(data)
        for group in data.get("study", {}).get("vary_together", []):
            used |= set(group)
    used |= {"bridge", "train", "irregularity", "solver", "contact", "track", "study",
             "vehicles", "defects"}
    missing = documented_keys() - used
    assert not missing, f"documented keys no round-trip feature exercises: {sorted(missing)}"
    # the reference is not empty (a parsing error would make this test vacuous)
    assert len(documented_keys()) > 60
