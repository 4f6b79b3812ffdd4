"""Every documented output, for every bridge kind, train model, track model and contact
model, through the public path: a config file, ``vsi sweep``, the netCDF file, ``vsi
report``.

The expected offer is written here, from the documentation, not read from the package:
the load effects (M, V, R, end rotations) come with the built-in decks (simply supported,
continuous, continuous with a track layer) and not with imported modes or matrices or a
rigid track; the whole-deck acceleration with every deck; the car-end accelerations with
car bodies; everything else always.  A variable the combination offers must hold a
finite value for every train, point, support and wheel the train has; one it does not
offer must be absent from the file and named, with a reason, in its ``not_computed``
attribute.  A column of NaN is never a result.
"""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.io.schema import (
    ALL_TRACKS,
    ENVELOPES,
    HISTORIES,
    LOAD_EFFECT_HISTORIES,
    LOAD_EFFECTS,
    SPACE_ENVELOPES,
    SPACE_HISTORIES,
)

ROOT = Path(__file__).resolve().parents[1]

BRIDGES = {
    "simply_supported": """
        kind = "simply_supported"
        spans = [15.0]
        EI = 5e9
        mass_per_length = 10000.0
        damping_ratio = 0.02
        n_modes = 4""",
    "continuous": """
        kind = "continuous"
        spans = [12.0, 15.0]
        EI = 5e9
        mass_per_length = 10000.0
        damping_ratio = 0.02
        n_modes = 4
        elements_per_span = 12""",
    "track_layer": """
        kind = "continuous"
        spans = [12.0]
        EI = 5e9
        mass_per_length = 10000.0
        damping_ratio = 0.02
        n_modes = 60
        elements_per_span = 12
        [bridge.track]
        rail_EI = 1.284e7
        rail_mass_per_length = 120.6
        pad_stiffness = 2.4e8
        pad_damping = 1.0e5
        sleeper_mass = 280.0
        sleeper_spacing = 0.6
        ballast_stiffness = 2.0e8
        ballast_damping = 1.2e5""",
    "modes_file": """
        kind = "modes_file"
        file = "data/two_span_modes.nc"
        track_line = "track1"
        n_modes = 4
        damping_ratio = 0.02""",
    "matrices": """
        kind = "matrices"
        stiffness_matrix = "data/two_span_K.mtx"
        mass_matrix = "data/two_span_M.mtx"
        station_map = "data/two_span_stations.csv"
        track_line = "track1"
        fixed_dofs = [0, 40, 80, 82, 122, 162]
        spans = [20.0, 20.0]
        n_modes = 4
        damping_ratio = 0.02""",
    "rigid": """
        kind = "rigid"
        spans = [15.0]""",
}

#: Train sets: a railway car and an articulated train (interaction) beside an axle-load
#: list (moving forces); or explicit vehicles: a sprung mass with its wheel and a force.
TRAINS = {
    "cars": """
        [train]
        preset = ["manchester_benchmark_single", "Eurostar"]
        model = "interaction"
        axles = { file = "axles.csv", load_unit = "kN", name = "axles" }""",
    "vehicles": """
        [train]
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = 5750.0
        stiffness = 1.595e6
        wheel_mass = 500.0
        [[train.vehicles]]
        kind = "force"
        offset = 5.0
        load = 100e3""",
}

#: (bridge, trains, track model, contact model); the track layer is its own track.
CASES = [(b, t, track, contact)
         for b in BRIDGES for t, track, contact in (("cars", "elastic", "rigid"),
                                                    ("cars", "rigid", "hertz"),
                                                    ("vehicles", "elastic", "hertz"),
                                                    ("vehicles", "rigid", "rigid"))]

LOAD_EFFECT_VARIABLES = {f"{pre}{ext}_{n}" for n in LOAD_EFFECTS for ext in ("max", "min")
                         for pre in ("", "time_of_")} | set(LOAD_EFFECT_HISTORIES)
WHOLE_DECK = {"max_deck_acceleration_whole_deck", "time_of_max_deck_acceleration_whole_deck",
              "position_of_max_deck_acceleration_whole_deck"}
CAR_END = {"max_carbody_acceleration_car_end", "time_of_max_carbody_acceleration_car_end",
           "position_of_max_carbody_acceleration_car_end"}


def expected_absent(bridge: str, trains: str) -> set[str]:
    """What the documentation says the combination does not offer."""
    # no bridge.tracks / bridge.torsion: the deck is a line
    out = set(SPACE_ENVELOPES) | set(SPACE_HISTORIES)
    out |= set(ALL_TRACKS)  # one train per run (no train.other_trains)
    if bridge in ("modes_file", "matrices", "rigid"):
        out |= LOAD_EFFECT_VARIABLES
    if bridge == "rigid":
        out |= WHOLE_DECK
    if trains == "vehicles":  # a sprung mass has no car ends
        out |= CAR_END
    return out


def write_config(directory: Path, bridge: str, trains: str, track: str, contact: str):
    shutil.copytree(ROOT / "configs" / "data", directory / "data")
    (directory / "axles.csv").write_text("position,load\n0.0,170\n3.0,170\n")
    dt = "2e-4" if bridge == "track_layer" else "2e-3"
    parts = [f'title = "{bridge} {trains} {track} {contact}"',
             "[bridge]", textwrap.dedent(BRIDGES[bridge]).strip(),
             textwrap.dedent(TRAINS[trains]).strip(),
             f"[solver]\ndt = {dt}\napproach = 5.0\nfree_vibration = 0.2"]
    if bridge != "track_layer":
        parts.append(f'[track]\nmodel = "{track}"')
    if contact == "hertz":
        parts.append('[contact]\nmodel = "hertz"\nhertz_coefficient = 4.57e-8')
    parts.append('[study]\nspeeds_kmh = [150.0]\noutput = "out.nc"\n'
                 "save_time_histories = true")
    path = directory / "study.toml"
    path.write_text("\n".join(parts) + "\n")
    return path


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _valid(ds: xr.Dataset, i_train: int, dim: str) -> np.ndarray:
    """Mask of the entries of ``dim`` that train ``i_train`` has."""
    if dim == "wheel":
        return np.isfinite(ds["static_wheel_load"].values[i_train])
    if dim == "vehicle":
        return ds["vehicle_name"].values[i_train].astype(str) != ""
    return np.ones(ds.sizes[dim], bool)


@pytest.mark.parametrize(("bridge", "trains", "track", "contact"), CASES,
                         ids=["-".join(c) for c in CASES])
def test_outputs__every_documented_variable_finite_or_refused(tmp_path, bridge, trains,
                                                              track, contact):
    path = write_config(tmp_path, bridge, trains, track, contact)
    res = invoke("sweep", path, "-q")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        ds.load()
    absent = expected_absent(bridge, trains)
    reasons = json.loads(ds.attrs["not_computed"])
    assert set(reasons) == absent
    assert all(len(r) > 20 for r in reasons.values())  # a reason, not a flag
    assert (ds["message"].values.astype(str) == "ok").all()
    for name in (*ENVELOPES, *HISTORIES):
        if name in absent:
            assert name not in ds.variables, name
            continue
        assert name in ds.variables, name
        da = ds[name]
        for i_t, train in enumerate(ds["train"].values):
            moving = str(train) == "axles"
            values = da.isel(train=i_t).values
            extra = [d for d in da.dims
                     if d not in ("speed", "train", "irregularity", "time")]
            if extra:
                mask = _valid(ds, i_t, extra[0])
                values = values[..., mask]
                if not mask.any():
                    continue  # the train has no such entry (no vehicles: moving forces)
            if "time" in da.dims:
                if name in ("contact_force", "in_contact"):
                    if moving:
                        continue  # documented: NaN for a prescribed moving force
                    if trains == "vehicles":  # the force (second wheel) is prescribed
                        values = values[..., :1]
                # every point, wheel or vehicle of the train has a value at some time
                # (NaN after the run's last step: the runs differ in length)
                assert np.isfinite(values).any(axis=-2).all(), (name, train)
                continue
            if name in CAR_END | {"max_carbody_acceleration", "time_of_max_carbody_acceleration",
                                  "position_of_max_carbody_acceleration"}:
                # a car body per vehicle of a car train; a sprung mass is a body too
                assert np.isfinite(values).any(), (name, train)
                continue
            assert np.isfinite(values).all(), (name, train)


REPORTED = [("continuous", "cars", "elastic", "rigid"), ("matrices", "cars", "elastic", "rigid"),
            ("rigid", "vehicles", "rigid", "rigid")]


@pytest.mark.parametrize(("bridge", "trains", "track", "contact"), REPORTED,
                         ids=["-".join(c) for c in REPORTED])
def test_outputs__report_gives_the_load_effect_checks_or_says_why_not(tmp_path, bridge,
                                                                     trains, track, contact):
    path = write_config(tmp_path, bridge, trains, track, contact)
    res = invoke("sweep", path, "-q", "--report", tmp_path / "report")
    assert res.exit_code == 0, res.output
    text = (tmp_path / "report" / "report.md").read_text()
    section = text[text.index("## Load effects"):]
    section = section[:section.index("\n## ", 3)] if "\n## " in section[3:] else section
    if bridge in ("simply_supported", "continuous"):
        assert "6.4.6.5(3)" in section
        assert "Deck-end rotation" in section and "Not available" not in section
    else:  # the reason the study stored, not a guess
        assert "Not available: the study did not compute the load effects" in section
        assert ("no static deck model" in section if bridge == "matrices"
                else "the bridge is rigid" in section)
    # the damped track's accuracy is stated where interaction trains ran on it
    assert ("| Track model accuracy |" in text) == (track == "elastic")


BUNDLED = {  # bundled configs, cut to a grid a test can afford (the text a user has)
    "viaduct_25_32_25.toml": [("line_speed_kmh = 300.0", "speeds_kmh = [300.0, 360.0]"),
                              ('preset = ["HSLM-A1", "HSLM-A2", "HSLM-A3", "HSLM-A4", "HSLM-A5",\n'
                               '          "HSLM-A6", "HSLM-A7", "HSLM-A8", "HSLM-A9", "HSLM-A10"]',
                               'preset = ["HSLM-A3"]')],
    "ice3_continuous.toml": [("speeds_kmh = { start = 200.0, stop = 350.0, step = 50.0 }",
                              "speeds_kmh = [300.0]"), ("seeds = [1, 2]", "seeds = [1]")],
}


@pytest.mark.parametrize("name", list(BUNDLED))
def test_outputs__bundled_continuous_decks_report_every_load_effect(tmp_path, name):
    text = (ROOT / "configs" / name).read_text()
    for old, new in BUNDLED[name]:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    res = invoke("sweep", path, "-q", "-o", tmp_path / "out.nc", "--report", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        assert not set(json.loads(ds.attrs["not_computed"])) & LOAD_EFFECT_VARIABLES
        for v in ("max_bending_moment", "max_shear_force", "max_support_reaction",
                  "max_end_rotation"):
            assert np.isfinite(ds[v].values).all(), v
    import pandas as pd

    summary = pd.read_csv(tmp_path / "rep" / "summary.csv")
    checks = summary["check"].astype(str)
    for effect in ("deflection", "bending moment", "shear force", "support reaction",
                   "rotation"):
        row = summary[checks.str.startswith("6.4.6.5(3)") & checks.str.contains(effect)]
        assert len(row) == 1, (effect, list(checks))
        assert np.isfinite(row["value"].iloc[0]) and row["value"].iloc[0] > 0
    assert checks.str.startswith("Deck-end rotation").any()
