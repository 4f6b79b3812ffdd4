"""What the commands print: ``-q`` as the README describes it, ``vsi trains`` axle
counts as integers, ``vsi check``'s modes, damping and speed grid."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np
from typer.testing import CliRunner
from userpath import vsi

from vsi_numba.cli import app

ROOT = Path(__file__).resolve().parents[1]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def warned_config(directory: Path) -> Path:
    """A moving-force study with two config warnings (a short approach, a mode below the
    EN 1990 A2 cut-off): 15 m span, EI 1e10 N m2, 12 t/m, 2 modes."""
    path = directory / "q.toml"
    path.write_text(textwrap.dedent("""
        title = "quiet test"
        [bridge]
        kind = "simply_supported"
        spans = [15.0]
        EI = 1.0e10
        mass_per_length = 12000.0
        damping_ratio = [0.02, 0.015]
        n_modes = 2
        [train]
        preset = ["HSLM-A1"]
        [solver]
        dt = 2e-3
        approach = 2.0
        free_vibration = 0.1
        [study]
        speeds_kmh = { start = 200.0, stop = 250.0, step = 25.0 }
        output = "out.nc"
        """))
    return path


def test_quiet__run_and_sweep_print_no_warning_progress_or_summary(tmp_path):
    """README: ``-q`` = no progress bar, summary lines or config warnings (errors are
    still printed; the sweep's governing results stay on stdout).  Without ``-q`` the
    same commands print the two warnings once each (so the test can fail)."""
    config = warned_config(tmp_path)
    loud = vsi("sweep", config, "-o", tmp_path / "l.nc", "--report", tmp_path / "lr")
    assert loud.returncode == 0, loud.stderr
    assert loud.stderr.count("warning: solver.approach = 2 m") == 2  # sweep, report
    assert "runs in 1 batches" in loud.stderr
    run = vsi("run", config, "-o", tmp_path / "r.nc", "-q")
    assert run.returncode == 0 and (tmp_path / "r.nc").is_file()
    assert run.stderr == "" and run.stdout == ""
    sweep = vsi("sweep", config, "-o", tmp_path / "s.nc", "-q", "--report", tmp_path / "sr")
    assert sweep.returncode == 0 and (tmp_path / "sr" / "report.md").is_file()
    assert sweep.stderr == "", sweep.stderr
    assert sweep.stdout.startswith("governing results") and "report written to" in sweep.stdout
    bad = vsi("run", tmp_path / "missing.toml", "-q")
    assert bad.returncode == 2 and "missing.toml: file not found" in bad.stderr


def test_trains__axle_counts_are_integers():
    """The library table printed '50.0' axles (a float column after the HSLM-B row)."""
    from vsi_numba.model import library as lib

    res = invoke("trains")
    assert res.exit_code == 0, res.output
    table = lib.library_table()
    for name, axles in zip(table["name"], table["axles"], strict=True):
        row = next(line for line in res.output.splitlines() if line.startswith(name + " "))
        assert re.search(rf"\s{int(axles)}\s", row), row
        assert f"{int(axles)}.0" not in row
    assert not re.search(r"^\S+\s+\S+\s+\d+\.0\s", res.output, re.M)


def test_check__prints_modes_damping_and_speed_grid(tmp_path):
    """Frequencies against the closed form f_n = n^2 pi/(2 L^2) sqrt(EI/m) (4 digits
    printed), the damping ratios as given, the speed grid's first, last, step, count."""
    config = warned_config(tmp_path)
    res = invoke("check", config)
    assert res.exit_code == 0, res.output
    f = [n**2 * np.pi / (2 * 15.0**2) * np.sqrt(1e10 / 12000.0) for n in (1, 2)]
    line = next(x for x in res.output.splitlines() if x.startswith("modes:"))
    printed = [float(v) for v in re.search(r"f = ([\d., ]+) Hz", line).group(1).split(",")]
    np.testing.assert_allclose(printed, f, rtol=1e-3)  # 4 significant digits printed
    assert "damping ratios 2.00, 1.50 %" in line  # as given (2 %, 1.5 %)
    assert re.search(r"speeds: 3 from 200 to 250 km/h, step 25 km/h", res.output)


def test_run__many_seeds_generates_the_first_profile_only(tmp_path, monkeypatch):
    """``vsi run`` computes the first realisation: of 2,000 seeds it generates one
    profile (all 2,000 took minutes and gigabytes), and its results are those of the
    first realisation of a 2-seed sweep of the same track range, bit for bit."""
    import xarray as xr

    from vsi_numba.model import irregularity as irr

    def config(name, seeds):
        path = tmp_path / f"{name}.toml"
        path.write_text(warned_config(tmp_path).read_text().replace(
            "[solver]", "[irregularity]\nkind = \"psd\"\nspectrum = \"german_low\"\n"
            f"wavelength_min = 3.0\nwavelength_max = 30.0\nseeds = {seeds}\n[solver]"))
        return path

    calls = []
    real = irr.psd_profile
    monkeypatch.setattr(irr, "psd_profile", lambda *a, **k: calls.append(a) or real(*a, **k))
    res = invoke("run", config("many", list(range(7, 2007))), "-o", tmp_path / "r.nc", "-q")
    assert res.exit_code == 0, res.output
    assert len(calls) == 1 and calls[0][3] == 7, [c[3] for c in calls[:5]]
    monkeypatch.undo()
    res = invoke("sweep", config("two", [7, 8]), "-o", tmp_path / "s.nc", "-q")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "r.nc") as r, xr.open_dataset(tmp_path / "s.nc") as s:
        for name in ("max_deck_acceleration", "max_deck_displacement"):
            np.testing.assert_array_equal(r[name].values,
                                          s[name].sel(irregularity=[7]).values)


def test_check__results_file_and_peak_disk_within_1_5x(tmp_path):
    """vsi check states the peak disk (the case store with every batch plus the results
    file, written as a temporary file inside the store); estimated within 1.5x of the
    measured file and of store + file (measured deterministically: the store kept after
    the write).  1.5x: the bar the estimates are held to (docs/check_estimates.md)."""
    import shutil

    from vsi_numba.cli.check import estimate_study
    from vsi_numba.config import load_config
    from vsi_numba.study.runner import execute_study
    from vsi_numba.study.store import store_path

    quick = tmp_path / "quickstart.toml"
    shutil.copy(ROOT / "configs" / "quickstart.toml", quick)
    for config in (warned_config(tmp_path), quick):
        res = invoke("check", config)
        assert res.exit_code == 0, res.output
        assert re.search(r"peak disk ~[\d.]+ [kM]B \(the file and the case store",
                         " ".join(res.output.split())), res.output
        out = tmp_path / f"{config.stem}.nc"
        execute_study(load_config(config), out, keep_cases=True)
        file = out.stat().st_size
        peak = file + sum(p.stat().st_size for p in store_path(out).iterdir())
        est = estimate_study(load_config(config))
        assert 1 / 1.5 <= est.disk_bytes / file <= 1.5, (config.name, est.disk_bytes, file)
        assert 1 / 1.5 <= est.peak_disk_bytes / peak <= 1.5, (config.name,
                                                               est.peak_disk_bytes, peak)
