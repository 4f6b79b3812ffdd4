"""`vsi report`: files written from a real netCDF round trip, Markdown content, exit codes."""

from __future__ import annotations

import struct

import numpy as np
import pytest
import xarray as xr

from vsi_numba.analysis.report import report_command, write_report
from vsi_numba.analysis.synthetic import synthetic_results

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
    assert cells[1:8] == ["4.5 m/s²", "3.5 m/s²", "-1 m/s²", "129 %", "**FAIL**",
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
    # the governing value, recomputed here: per case max over points, 95 % fractile over
    # the two realisations (linear: x_min + 0.95 (x_max - x_min)), max over speeds
    peak = ds["max_deck_acceleration"].max("point").values  # (speed, train, irregularity)
    expected = np.quantile(peak, 0.95, axis=-1).max()
    row = next(line for line in text.splitlines() if line.startswith("| Peak deck accel"))
    assert f"| {expected:.3g} m/s² | 3.5 m/s² |" in row
    assert "| 2 |" in text  # n = 2 realisations in the statistics table
    assert ds.attrs["config_sha256"] in text
