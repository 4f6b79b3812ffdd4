"""`vsi report` in flat memory: a parametric file (6 variants x 10 trains) whose time
histories, padded over every speed, would take 1.8 GB if loaded, is reported in < 500 MB.

The peak is measured in a child process (resource.getrusage(RUSAGE_CHILDREN).ru_maxrss of
a wrapper that only starts the report), so nothing of the test process counts.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import xarray as xr

from vsi_numba.analysis.synthetic import synthetic_results

N_VARIANT, N_TRAIN, N_SPEED, N_TIME, N_WHEEL = 6, 10, 50, 2000, 32
HISTORY_SPEED = 25  # index of the one speed whose histories are stored (the governing one)

#: Budget of the whole report process (MB): the bound for any study size.
BUDGET_MB = 500


def _parametric_file(path):
    """6 variants x 10 trains x 40 speeds with histories (time x point/wheel/vehicle)
    declared for every run, stored for one speed only (the rest is the NaN fill value)."""
    import netCDF4

    trains = tuple((f"T{j}", 18.0 + j, N_WHEEL - (j % 3), "standard") for j in range(N_TRAIN))
    speeds = np.linspace(140.0, 420.0, N_SPEED)
    parts = []
    for k in range(N_VARIANT):
        d = synthetic_results(speeds_kmh=speeds, trains=trains, n_points=3, n_vehicles=4,
                              seed=k, bridge_length=20.0)
        # the governing case of every check is at the stored speed: nothing is re-run
        d["max_deck_acceleration"][HISTORY_SPEED, 0] = 20.0 + k
        d["max_wheel_unloading"][HISTORY_SPEED, 0] = 0.5
        d["position_of_min_contact_force"][HISTORY_SPEED, 0, :, 0] = -30.0
        parts.append(d)
    ds = xr.concat(parts, dim="variant", data_vars="all", coords="different",
                   compat="equals", join="outer")
    ds = ds.assign_coords(bridge_EI=("variant", 7e10 * (1 + 0.1 * np.arange(N_VARIANT)),
                                     {"key_path": "bridge.EI", "units": "N m2"}))
    ds["bridge_length"] = ("variant", np.full(N_VARIANT, 20.0))
    ds["variant_config_json"] = ("variant", [json.dumps({"title": "x"})] * N_VARIANT)
    ds["train_status"] = ds["train_status"].isel(variant=0)
    ds.attrs["varied_keys"] = "bridge.EI"
    ds.to_netcdf(path)

    t = np.linspace(0.0, 2.0, N_TIME)
    sig = (np.sin(np.pi * t / t[-1]) ** 2 * np.sin(2 * np.pi * 5.0 * t)).astype(np.float32)
    with netCDF4.Dataset(path, "a") as nc:
        nc.createDimension("time", N_TIME)
        nc.createVariable("time", "f8", ("time",))[:] = t
        nc["time"].units = "s"
        case = ("variant", "speed", "train", "irregularity")
        for name, other, n in (("deck_displacement", "point", 3),
                               ("deck_acceleration", "point", 3),
                               ("contact_force", "wheel", N_WHEEL),
                               ("in_contact", "wheel", N_WHEEL),
                               ("carbody_acceleration", "vehicle", 4)):
            var = nc.createVariable(name, "f4", (*case, "time", other), zlib=True,
                                    complevel=1, fill_value=np.float32(np.nan),
                                    chunksizes=(1, 1, 1, 1, N_TIME, n))
            var.units = {"contact_force": "N", "in_contact": "1",
                         "deck_displacement": "m"}.get(name, "m s-2")
            block = np.broadcast_to(sig[:, None], (N_TIME, n))
            if name == "contact_force":
                block = 170e3 * (1.0 - 0.5 * block)
            for k in range(N_VARIANT):
                for j in range(N_TRAIN):
                    var[k, HISTORY_SPEED, j, 0] = block
    # what the old report loaded: every history over every run
    per_run = N_TIME * (3 + 3 + N_WHEEL + N_WHEEL + 4) * 4
    return per_run * N_VARIANT * N_TRAIN * N_SPEED


def _peak_report_mb(results, outdir) -> float:
    """Peak RSS (MB) of a child running `vsi report` on ``results``."""
    child = textwrap.dedent(f"""
        import sys
        from vsi_numba.cli.report import report_command
        sys.exit(report_command({str(results)!r}, {str(outdir)!r}))
    """)
    wrapper = textwrap.dedent(f"""
        import resource, subprocess, sys
        r = subprocess.run([sys.executable, "-c", {child!r}], capture_output=True, text=True)
        sys.stderr.write(r.stderr)
        print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
    """)
    out = subprocess.run([sys.executable, "-c", wrapper], capture_output=True, text=True,
                         timeout=300, check=True)
    code, kb = out.stdout.split()
    assert int(code) == 0, out.stderr
    return int(kb) / 1024.0


def test_report_memory__6_variants_x_10_trains_stays_under_500_mb(tmp_path):
    path = tmp_path / "parametric.nc"
    padded = _parametric_file(path)
    assert padded > 1.5e9  # loading the histories would alone exceed the budget 3x
    peak = _peak_report_mb(path, tmp_path / "rep")
    print(f"report peak memory: {peak:.0f} MB (histories if loaded: {padded / 1e9:.2f} GB)")
    assert peak < BUDGET_MB
    # the report is complete: the governing variant's time histories were read (stored,
    # not re-run), and both formats and the tables are there
    gov = tmp_path / "rep" / "governing_variant"
    text = (gov / "report.md").read_text(encoding="utf-8")
    figures = text[text.index("## Figures"):]  # (the convergence section re-runs cases)
    assert (gov / "time_history.png").is_file() and "re-run" not in figures
    assert (gov / "report.html").is_file() and (tmp_path / "rep" / "report.html").is_file()
    assert (gov / "tables.xlsx").is_file() and (tmp_path / "rep" / "variants.csv").is_file()
