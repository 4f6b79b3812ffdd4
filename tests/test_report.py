"""`vsi report`: files written from a real netCDF round trip, Markdown content, exit codes."""

from __future__ import annotations

import struct

import numpy as np
import pytest
import xarray as xr

from vsi_numba.analysis.report import write_report
from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.cli.report import report_command

FIGURES = ["deck_acceleration.png", "dynamic_amplification.png", "wheel_unloading.png",
           "comfort.png", "time_history.png"]


def _png_size(path):
    """(width, height) in pixels from the PNG IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def _results(tmp_path, name="results.nc", **kw):
    kw.setdefault("speeds_kmh", (250.0, 300.0, 325.0, 350.0))
    kw.setdefault("trains", (("HSLM-A1", 18.0, 6, "standard"),
                             ("ICE3", 0.0, 4, "suspect")))
    kw.setdefault("n_vehicles", 2)
    ds = synthetic_results(**kw)
    ds["max_deck_acceleration"][:] = 1.0
    ds["max_deck_acceleration"].loc[{"train": "HSLM-A1", "point": 10.0}] = 4.0
    ds["max_deck_acceleration"].loc[{"speed": ds["speed"].values[2], "train": "HSLM-A1"}] = 4.5
    path = tmp_path / name
    ds.to_netcdf(path)
    return path


def test_write_report__all_files_from_a_netcdf_round_trip(tmp_path):
    path = _results(tmp_path, histories=True, n_time=80, seeds=(1, 2, 3))
    with xr.open_dataset(path) as ds:
        md = write_report(ds, tmp_path / "rep", source_path=path, n_boot=200)
    assert md == tmp_path / "rep" / "report.md"
    for name in FIGURES:
        assert (tmp_path / "rep" / name).is_file(), name
    assert _png_size(tmp_path / "rep" / "deck_acceleration.png") == (975, 600)  # 6.5x4 in
    text = md.read_text(encoding="utf-8")
    assert text.startswith("# Synthetic results")
    for section in ("## Provenance", "## Bridge", "## Summary of checks", "## Trains",
                    "## Statistics over irregularity realisations", "## Figures"):
        assert section in text
    # the summary table, with the governing case set by construction (4.5 at 325 km/h)
    assert "| Check | Value | Limit | Margin (limit − value) |" in text
    row = next(line for line in text.splitlines() if line.startswith("| Peak deck accel"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1:8] == ["4.5 m/s²", "3.5 m/s²", "-1 m/s²", "128.6 %", "**FAIL**",
                          "HSLM-A1", "325"]
    assert "EN 1990 A2.4.4.2.1" in row
    assert "Wheel unloading ΔQ/Q₀" in text and "Car-body acceleration" in text
    # provenance, frequencies and cut-off
    assert "0" * 64 in text and "CF-1.12" in text
    assert "= **45.00 Hz**" in text
    # train status warning for the suspect train
    assert "WARNING" in text and "ICE3" in text and "SUSPECT" in text
    # statistics with n and the call for more realisations
    assert "| Peak deck acceleration | HSLM-A1, 325 km/h | 3 |" in text
    assert "More realisations needed" in text and "n ≥ 59" in text
    for name in FIGURES:
        assert f"]({name})" in text
    summary = (tmp_path / "rep" / "summary.csv").read_text()
    assert summary.splitlines()[0].startswith("check,value,units,limit,margin")


def test_write_report__single_run_layout_and_deterministic_track(tmp_path):
    path = _results(tmp_path, histories=True, n_time=60)
    with xr.open_dataset(path) as ds:
        one = ds.isel(train=0, irregularity=0).drop_vars(["train", "irregularity"])
        one.to_netcdf(tmp_path / "run.nc")
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        md = write_report(ds, tmp_path / "rep")
    text = md.read_text(encoding="utf-8")
    assert "Deterministic track only" in text
    assert (tmp_path / "rep" / "time_history.png").is_file()
    assert "WARNING" not in text


def test_write_report__failed_cases_listed_and_history_fallback(tmp_path):
    path = _results(tmp_path, histories=True, n_time=40)
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    gov = {"speed": ds["speed"].values[2], "train": "HSLM-A1"}
    ds["deck_acceleration"].loc[gov] = np.nan  # no history stored for the governing case
    ds["status"].loc[{"speed": ds["speed"].values[0], "train": "ICE3"}] = 1
    md = write_report(ds, tmp_path / "rep")
    text = md.read_text(encoding="utf-8")
    assert "failed: 1" in text and "contact_not_converged" in text
    assert "No history was stored for the governing case" in text


def test_write_report__moving_force_model_skips_comfort_figure(tmp_path):
    path = _results(tmp_path, n_vehicles=0)
    with xr.open_dataset(path) as ds:
        write_report(ds, tmp_path / "rep")
    assert not (tmp_path / "rep" / "comfort.png").exists()
    assert not (tmp_path / "rep" / "time_history.png").exists()  # no histories stored
    assert (tmp_path / "rep" / "deck_acceleration.png").exists()


def test_write_report__moving_force_results_and_no_stale_figures(tmp_path):
    path = _results(tmp_path, n_vehicles=0, histories=True, n_time=30)
    with xr.open_dataset(path) as ds:
        write_report(ds, tmp_path / "rep")  # with wheel unloading and time history
        assert (tmp_path / "rep" / "wheel_unloading.png").exists()
        ds = ds.drop_vars(["deck_acceleration"]).load()
    ds["max_wheel_unloading"] = ds["max_wheel_unloading"] * 0.0
    ds["max_contact_force"] = ds["min_contact_force"]
    md = write_report(ds, tmp_path / "rep")
    assert not (tmp_path / "rep" / "wheel_unloading.png").exists()
    assert not (tmp_path / "rep" / "time_history.png").exists()
    text = md.read_text(encoding="utf-8")
    assert "Wheel unloading: not applicable" in text and "Comfort: not applicable" in text


def test_report_command__writes_default_directory(tmp_path, capsys):
    path = _results(tmp_path)
    assert report_command(path, None) == 0
    assert (tmp_path / "results_report" / "report.md").is_file()
    assert "report written to" in capsys.readouterr().out


def test_report_command__missing_file_exits_2_with_message(tmp_path, capsys):
    assert report_command(tmp_path / "nope.nc", None) == 2
    err = capsys.readouterr().err
    assert "nope.nc" in err and "does not exist" in err and "Traceback" not in err


def test_report_command__unreadable_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.nc"
    bad.write_text("not a netCDF file")
    assert report_command(bad, None) == 2
    assert "cannot read" in capsys.readouterr().err


def test_report_command__file_lacking_variables_exits_2(tmp_path, capsys):
    path = _results(tmp_path)
    with xr.open_dataset(path) as ds:
        ds.drop_vars(["max_deck_acceleration"]).to_netcdf(tmp_path / "partial.nc")
    assert report_command(tmp_path / "partial.nc", tmp_path / "rep") == 2
    err = capsys.readouterr().err
    assert "max_deck_acceleration" in err
    xr.Dataset({"x": ("a", [1.0])}).to_netcdf(tmp_path / "other.nc")
    assert report_command(tmp_path / "other.nc", tmp_path / "rep") == 2
    assert "speed" in capsys.readouterr().err
    assert not (tmp_path / "rep").exists()


def test_cli_report__exit_code_2_on_missing_file(tmp_path):
    typer_testing = pytest.importorskip("typer.testing")
    from vsi_numba.cli import app

    result = typer_testing.CliRunner().invoke(app, ["report", str(tmp_path / "x.nc")])
    assert result.exit_code == 2
    assert result.exception is None or isinstance(result.exception, SystemExit)


def test_end_to_end__tiny_real_study_then_report(tmp_path, capsys):
    """configs/quickstart.toml (2 speeds) on a random track, 2 realisations: run_study,
    then `vsi report` on the file it wrote."""
    import tomllib
    from pathlib import Path

    from vsi_numba.study.runner import run_study

    root = Path(__file__).resolve().parents[1]
    config = tomllib.loads((root / "configs" / "quickstart.toml").read_text())
    config["irregularity"] = {"kind": "psd", "spectrum": "german_low",
                              "wavelength_min": 3.0, "wavelength_max": 30.0, "seeds": [1, 2]}
    out = tmp_path / "quick.nc"
    ds = run_study(config, out, backend="serial")
    assert int((ds["status"] != 0).sum()) == 0
    assert report_command(out, tmp_path / "rep") == 0
    capsys.readouterr()
    for name in FIGURES:
        assert (tmp_path / "rep" / name).is_file(), name
    text = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    # the governing value, recomputed here: per case max over the points and the whole
    # deck, 95 % fractile over the two realisations (linear: x_min + 0.95 (x_max - x_min)),
    # max over speeds
    peak = np.fmax(ds["max_deck_acceleration"].max("point"),
                   ds["max_deck_acceleration_whole_deck"]).values  # (speed, train, irr.)
    expected = np.quantile(peak, 0.95, axis=-1).max()
    row = next(line for line in text.splitlines() if line.startswith("| Peak deck accel"))
    assert f"| {expected:.3g} m/s² | 3.5 m/s² |" in row
    assert "| 2 |" in text  # n = 2 realisations in the statistics table
    assert ds.attrs["config_sha256"] in text


# --- per-train applicability of wheel unloading (synthetic) -----------------------------


def _mixed_synthetic(**kw):
    """HSLM-A1 with prescribed forces (min = max = Q0) and ICE3 with varying forces."""
    ds = synthetic_results(speeds_kmh=(250.0, 300.0, 350.0), n_vehicles=2,
                           trains=(("HSLM-A1", 18.0, 6, "standard"),
                                   ("ICE3", 0.0, 4, "standard")), **kw)
    hslm = {"train": "HSLM-A1"}
    q0 = ds["static_wheel_load"].sel(hslm).broadcast_like(ds["min_contact_force"].sel(hslm))
    for name in ("min_contact_force", "max_contact_force"):
        ds[name].loc[hslm] = q0.transpose(*ds[name].sel(hslm).dims)
    ds["max_wheel_unloading"].loc[hslm] = 0.0
    ds["contact_loss_duration"].loc[hslm] = 0.0
    return ds


def test_write_report__mixed_models_show_wheel_unloading_for_the_interaction_train_only(
        tmp_path):
    from vsi_numba.analysis import checks, plots

    ds = _mixed_synthetic()
    text = write_report(ds, tmp_path / "rep", n_boot=0).read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if x.startswith("- Wheel unloading"))
    assert "checked for ICE3" in line and "**not applicable** to HSLM-A1" in line
    row = next(x for x in text.splitlines() if x.startswith("| Wheel unloading"))
    assert "| ICE3 |" in row
    assert "| HSLM-A1 | standard |" in text and "prescribed (moving forces)" in text
    ice3_row = next(x for x in text.splitlines() if x.startswith("| ICE3 | standard |"))
    assert "| interaction |" in ice3_row
    assert "not drawn: HSLM-A1" in text
    # the figure has curves for ICE3 only
    fig = plots.plot_wheel_unloading(ds, checks.wheel_unloading(ds, n_boot=0))
    labels = {ln.get_label() for ax in fig.axes for ln in ax.get_lines()}
    assert "ICE3" in labels and "HSLM-A1" not in labels


def test_write_report__contact_loss_total_longest_and_one_step_flag(tmp_path):
    ds = synthetic_results(speeds_kmh=(250.0, 300.0), n_vehicles=2,
                           trains=(("A", 18.0, 6, "standard"),), contact_loss_events=True)
    case = {"speed": ds["speed"].values[1], "train": "A"}
    ds["contact_loss_duration"].loc[{**case, "wheel": 2}] = 0.05
    ds["longest_contact_loss"].loc[{**case, "wheel": 2}] = 0.02
    ds["single_step_contact_losses"].loc[{**case, "wheel": 2}] = 3.0
    ds["single_step_contact_losses"].loc[{**case, "wheel": 4}] = 2.0
    text = write_report(ds, tmp_path / "rep", n_boot=0).read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if x.startswith("- Wheel unloading"))
    assert "longest single loss of contact 0.02 s" in line
    assert "total time separated (one wheel, one case) up to 0.05 s" in line
    assert "## One-step contact losses" in text and "spurious ringing" in text
    assert "| A | 300 | 5 |" in text  # 3 + 2 one-step losses over the wheels of that case
    # without the longest single loss: the total, labelled as such
    ds = ds.drop_vars(["longest_contact_loss", "single_step_contact_losses"])
    text = write_report(ds, tmp_path / "rep2", n_boot=0).read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if x.startswith("- Wheel unloading"))
    assert "longest single loss of contact is not in the file" in line
    assert "## One-step contact losses" not in text


# --- governing case re-run when the file holds no history for it (real engine) ---------
# Tiny models (10 m span, 2 modes, dt = 2 ms) as in tests/test_study.py.


def _study_toml(directory, trains_block, irregularity, speeds, history):
    text = f"""
    title = "report test"
    [bridge]
    kind = "simply_supported"
    spans = [10.0]
    EI = 2.0e9
    mass_per_length = 10000.0
    damping_ratio = 0.02
    n_modes = 2
    [train]
    {trains_block}
    [irregularity]
    {irregularity}
    [solver]
    dt = 2e-3
    approach = 2.0
    free_vibration = 0.1
    [study]
    speeds_kmh = {list(speeds)}
    output = "results/study.nc"
    save_time_histories = {"true" if history else "false"}
    history_speeds_kmh = {list(history) or list(speeds)}
    """
    import textwrap

    path = directory / "study.toml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def user_train_study(tmp_path_factory):
    from study_trains import TRAINS_TOML

    from vsi_numba.study.runner import run_study

    d = tmp_path_factory.mktemp("report_study")
    (d / "trains.toml").write_text(TRAINS_TOML)
    cfg = _study_toml(d, 'file = "trains.toml"',
                      'kind = "psd"\nspectrum = "fra4"\nwavelength_min = 2.0\n'
                      'wavelength_max = 30.0\nseeds = [1]', (100.0, 150.0, 200.0), (100.0,))
    out = d / "results" / "study.nc"
    run_study(cfg, out, backend="serial")
    return out


def _governing(da):
    """(train, speed_kmh) of the largest value of da(speed, train), found here by argmax."""
    i, j = np.unravel_index(np.nanargmax(da.values), da.shape)
    return str(da["train"].values[j]), float(da["speed_kmh"].values[i])


def test_write_report__governing_case_without_history_is_re_run_and_drawn(
        user_train_study, tmp_path):
    with xr.open_dataset(user_train_study) as ds:
        ds = ds.load()
    # one seed: the design value is that realisation's value, so the governing case is
    # the argmax of the envelope (max over points and the whole deck / wheels)
    acc = np.fmax(ds["max_deck_acceleration"].max("point"),
                  ds["max_deck_acceleration_whole_deck"]).isel(irregularity=0)
    train, kmh = _governing(acc)
    assert kmh != 100.0  # precondition: only 100 km/h has stored histories
    md = write_report(ds, tmp_path / "rep", source_path=user_train_study, n_boot=0)
    text = md.read_text(encoding="utf-8")
    assert (f"Time histories of {train} at {kmh:.0f} km/h (irregularity seed 1), the "
            "governing case of the deck acceleration check") in text
    assert "it was re-run from the file's configuration" in text and "they differ" not in text
    wu = ds["max_wheel_unloading"].max("wheel").isel(irregularity=0)
    wtrain, wkmh = _governing(wu)
    assert (f"of {wtrain} at {wkmh:.0f} km/h (irregularity seed 1), the governing case of "
            "the wheel unloading check") in text
    assert "position_of_min_contact_force" in text
    for name in ("time_history.png", "wheel_unloading_history.png"):
        assert (tmp_path / "rep" / name).is_file()
    # without re-running, the old fallback (stored case of the governing train)
    text = write_report(ds, tmp_path / "rep2", n_boot=0, recompute=False).read_text(
        encoding="utf-8")
    assert "No history was stored for the governing case" in text


def test_case_runner__re_run_reproduces_the_stored_envelope_and_history(user_train_study):
    from vsi_numba.analysis.recompute import CaseRunner

    with xr.open_dataset(user_train_study) as ds:
        ds = ds.load()
    runner = CaseRunner(ds, source_path=user_train_study)
    speed = float(ds["speed"].values[2])  # 200 km/h: envelope only
    sim = runner.run("two-cars", speed, 1)
    stored = ds["max_deck_acceleration"].sel(speed=speed, train="two-cars", irregularity=1)
    # same model, profile (same seed over the same track range) and code: equal up to
    # rounding, rel 1e-9
    np.testing.assert_allclose(abs(sim["deck_acceleration"]).max("time"), stored, rtol=1e-9)
    np.testing.assert_allclose(sim["min_contact_force"],
                               ds["min_contact_force"].sel(speed=speed, train="two-cars",
                                                           irregularity=1)
                               .isel(wheel=slice(0, sim.sizes["wheel"])), rtol=1e-9)
    # 100 km/h was stored: the re-run history matches it (stored as float32: rel 1e-6 of
    # the peak)
    speed = float(ds["speed"].values[0])
    sim = runner.run("one-car", speed, 1)
    hist = ds["deck_acceleration"].sel(speed=speed, train="one-car", irregularity=1)
    hist = hist.isel(time=slice(0, sim.sizes["time"]))
    peak = float(abs(hist).max())
    np.testing.assert_allclose(sim["deck_acceleration"].values, hist.values, rtol=0,
                               atol=1e-6 * peak)


def test_write_report__real_mixed_study_hslm_moving_forces_and_ice3(tmp_path):
    """HSLM-A1 (moving forces) and ICE3 (interaction), no stored histories: ΔQ/Q₀ for ICE3
    only, and its governing case re-run for the history figure."""
    from vsi_numba.study.runner import run_study

    cfg = _study_toml(tmp_path, 'preset = ["HSLM-A1", "ICE3"]', 'kind = "none"',
                      (150.0, 200.0), ())
    out = tmp_path / "results" / "study.nc"
    run_study(cfg, out, backend="serial")
    with xr.open_dataset(out) as ds:
        assert "time" not in ds.dims
        md = write_report(ds, tmp_path / "rep", source_path=out, n_boot=0)
        wu = ds["max_wheel_unloading"].sel(train="ICE3").max("wheel").isel(irregularity=0)
        kmh = float(wu["speed_kmh"].values[int(np.argmax(wu.values))])
    text = md.read_text(encoding="utf-8")
    assert "**not applicable** to HSLM-A1" in text
    assert (f"of ICE3 at {kmh:.0f} km/h (deterministic track), the governing case of the "
            "wheel unloading check") in text
    assert (tmp_path / "rep" / "wheel_unloading_history.png").is_file()
