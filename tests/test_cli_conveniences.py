"""``vsi --version``, ``vsi check``, ``vsi init``, clean ``--help``, the governing results
printed by ``vsi sweep`` and the worker count of ``--scheduler``."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import vsi_numba
from vsi_numba.cli import app
from vsi_numba.cli.check import estimate_study
from vsi_numba.cli.init import TEMPLATE
from vsi_numba.config import load_config

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ["run", "sweep", "check", "init", "schema", "trains", "modes", "report", "profile"]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_cli__version():
    res = invoke("--version")
    assert res.exit_code == 0
    assert res.output.startswith(f"vsi_numba {vsi_numba.__version__} (numba ")


@pytest.mark.parametrize("command", [None, *COMMANDS])
def test_cli__help_shows_flags_without_types(command):
    res = invoke(*([command] if command else []), "--help")
    assert res.exit_code == 0, res.output
    assert "<bool>" not in res.output
    if command == "sweep":
        assert re.search(r"-q, --quiet\s+no progress bar", res.output)
        assert re.search(r"--fresh\s+discard", res.output)
    if command is None:
        assert "--version" in res.output and "check" in res.output and "init" in res.output


def test_init__writes_a_valid_config_and_never_overwrites(tmp_path):
    path = tmp_path / "bridge.toml"
    res = invoke("init", path)
    assert res.exit_code == 0, res.output
    text = path.read_text()
    assert text == TEMPLATE.format(name=str(path), stem="bridge")
    assert text.count("#") > 20  # commented
    cfg = load_config(path)
    assert cfg.warnings == []
    assert cfg.output_path == tmp_path / "results" / "bridge.nc"
    again = invoke("init", path)
    assert again.exit_code == 2
    assert "refusing to overwrite" in again.output
    assert path.read_text() == text
    assert invoke("init", tmp_path / "bridge.txt").exit_code == 2


def test_check__reports_the_study_and_runs_nothing(tmp_path):
    cfg = tmp_path / "q.toml"
    shutil.copy(ROOT / "configs" / "quickstart.toml", cfg)
    res = invoke("check", cfg)
    assert res.exit_code == 0, res.output
    study = load_config(cfg)
    n = study.speeds_kmh.size * len(study.trains())
    assert f"study: {n} runs = {study.speeds_kmh.size} speeds x 1 train x 1 track " \
        "realisation, in 1 batch;" in res.output
    assert re.search(r"estimate \(warm numba cache, \d+ workers?\): time ~[\d.]+ s, peak "
                     r"memory ~[\d.]+ MB, results file ~[\d.]+ kB", res.output)
    assert not study.output_path.exists() and not list(tmp_path.rglob("*.nc"))
    bad = tmp_path / "bad.toml"
    bad.write_text(cfg.read_text().replace("[bridge]", "[bridge]\nspna = 3"))
    res = invoke("check", bad)
    assert res.exit_code == 2
    assert "bridge.spna = 3: unknown key; did you mean 'spans'?" in res.output


def _measured_sweep(config: Path, out: Path) -> tuple[float, float, int, str]:
    """CPU time (s, all threads), peak RSS (bytes), file size (bytes) and stdout of
    ``vsi sweep`` in a fresh interpreter, as a user runs it."""
    code = ("import resource, sys\n"
            "from vsi_numba.cli import app\n"
            f"rc = app(['sweep', {str(config)!r}, '-o', {str(out)!r}, '-q'], "
            "standalone_mode=False)\n"
            "r = resource.getrusage(resource.RUSAGE_SELF)\n"
            # the peak of this process's own memory (VmHWM): ru_maxrss would also hold
            # the RSS of the test process it was forked from (Linux keeps it across exec)
            "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')]\n"
            "print('MAXRSS', hwm[0], 'CPU', r.ru_utime + r.ru_stime, file=sys.stderr)\n"
            "sys.exit(rc or 0)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    m = re.search(r"MAXRSS (\d+) CPU ([\d.]+)", proc.stderr)
    rss = 1024.0 * float(m.group(1))  # Linux: kB
    return float(m.group(2)), rss, out.stat().st_size, proc.stdout


@pytest.fixture(scope="module")
def init_run(tmp_path_factory):
    """The ``vsi init`` starter config, swept for real (9 runs, ICE3 and HSLM)."""
    d = tmp_path_factory.mktemp("init")
    cfg = d / "study.toml"
    assert invoke("init", cfg).exit_code == 0
    out = d / "results.nc"
    # measured on the warm numba cache (a cold compile is not part of the estimate: it is
    # paid once per machine): the run's ``vsi compile`` (tests/conftest.py) filled it
    # before the first test; a sweep right after an empty cache's ``vsi compile`` takes
    # 3.5 s of CPU, the next one 2.9 s (no kernel compiled: tens of seconds)
    return cfg, out, _measured_sweep(cfg, out)


def test_check__estimate_within_factor_3_of_a_real_run(init_run, tmp_path):
    # factor 3: the cost model is a per-step average calibrated on this machine; what it
    # must give is the order of magnitude.  Time is compared as CPU time (the estimate's
    # kernel time summed over the workers): wall time on this shared machine depends on
    # the other jobs' load.
    cases = [init_run[:2] + (init_run[2],)]
    hslm = ROOT / "configs" / "hslm_25m.toml"  # 570 runs: kernel time, envelopes only
    cases.append((hslm, tmp_path / "hslm.nc", _measured_sweep(hslm, tmp_path / "hslm.nc")))
    for cfg, _, (cpu, rss, size, _) in cases:
        est = estimate_study(load_config(cfg))
        for what, e, m in (("CPU time", est.cpu_seconds, cpu), ("memory", est.memory_bytes, rss),
                           ("disk", est.disk_bytes, size)):
            assert 1 / 3 <= e / m <= 3, f"{cfg.name} {what}: estimate {e:.4g}, measured {m:.4g}"


def _value(line: str) -> float:
    return float(re.search(r" (-?[\d.]+(?:e[-+]\d+)?)(?: m/s2)? (?:pass|FAIL)", line).group(1))


def test_sweep__prints_the_governing_result_of_each_check(init_run):
    _, out, (*_, stdout) = init_run
    lines = [ln.strip() for ln in stdout.splitlines()]
    acc = next(ln for ln in lines if ln.startswith("deck acceleration"))
    dq = next(ln for ln in lines if ln.startswith("wheel unloading dQ/Q0"))
    comfort = next(ln for ln in lines if ln.startswith("comfort"))
    # reference: brute-force maxima of the stored envelopes (one realisation, so the
    # characteristic value is the maximum); printed with 3 significant digits -> 0.5 %
    with xr.open_dataset(out) as ds:
        a = np.fmax(ds["max_deck_acceleration"].max("point"),
                    ds["max_deck_acceleration_whole_deck"]).isel(irregularity=0)
        i_s, i_t = np.unravel_index(int(np.nanargmax(a.values)), a.shape)
        assert _value(acc) == pytest.approx(float(a.max()), rel=5e-3)
        assert f": {ds['train'].values[i_t]}, {float(ds['speed_kmh'][i_s]):g} km/h" in acc
        assert ("FAIL" in acc) == (float(a.max()) > 3.5)
        x = float(ds["position_of_max_deck_acceleration_whole_deck"].isel(
            irregularity=0, speed=i_s, train=i_t))
        assert f"x = {x:.1f} m" in acc
        ice = list(ds["train"].values).index("ICE3")
        dq_ref = float(ds["max_wheel_unloading"].isel(train=ice).max())
        assert _value(dq) == pytest.approx(dq_ref, rel=5e-3)
        assert ": ICE3, " in dq and "axle " in dq
        bv = float(ds["max_carbody_acceleration"].max())
        assert _value(comfort) == pytest.approx(bv, rel=5e-3)


def test_sweep__scheduler_reports_the_real_worker_count(tmp_path):
    from dask.distributed import LocalCluster

    cfg = tmp_path / "q.toml"
    shutil.copy(ROOT / "configs" / "quickstart.toml", cfg)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None, scheduler_port=0) as cluster:
        addr = cluster.scheduler_address
        res = invoke("sweep", cfg, "-o", tmp_path / "q.nc", "--scheduler", addr)
    assert res.exit_code == 0, res.output
    assert f"connected to the Dask scheduler {addr}: 2 workers, 2 threads" in res.output
    assert "0 workers" not in res.output
    assert json.loads(xr.open_dataset(tmp_path / "q.nc").attrs["config_json"])["title"]


# ------------------------------------------------------------------ the design chart

README_VARIANTS = {
    "title": "design chart",
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 7.16e10,
               "mass_per_length": 18000.0, "damping_ratio": 0.01, "n_modes": 1},
    "train": {"preset": ["HSLM-A1"]},
    "solver": {"dt": 2e-3, "free_vibration": 0.0},
    # the README's pattern: vary x vary_together (with a label) x mass_bounds
    "study": {"speeds_kmh": [250.0, 300.0, 350.0], "mass_bounds": [0.9, 1.1],
              "save_time_histories": False,
              "vary": {"bridge.damping_ratio": [0.01, 0.02]},
              "vary_together": [{"label": ["short", "long"],
                                 "bridge.spans": [[20.0], [25.0]],
                                 "bridge.EI": [3.2e10, 7.16e10],
                                 "bridge.mass_per_length": [15000.0, 18000.0]}]},
}


@pytest.fixture(scope="module")
def variants_ds(tmp_path_factory):
    from vsi_numba.study import run_study

    out = tmp_path_factory.mktemp("chart") / "v.nc"
    with run_study(README_VARIANTS, out, backend="serial") as ds:
        return ds.load()


def _reference_peak(ds) -> np.ndarray:
    """Peak deck acceleration per (variant, speed), brute force over the envelopes."""
    acc = ds["max_deck_acceleration"].values  # (variant, speed, train, irregularity, point)
    whole = ds["max_deck_acceleration_whole_deck"].values
    return np.fmax(np.nanmax(acc, axis=(2, 3, 4)), np.nanmax(whole, axis=(2, 3)))


def _chart_data(fig):
    import matplotlib.collections as mc

    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    meshes = [c for ax in panels for c in ax.collections if isinstance(c, mc.QuadMesh)]
    lines = [ln for ax in panels for ln in ax.get_lines()
             if not ln.get_label().startswith("limit")]
    return meshes, lines


@pytest.mark.parametrize("pattern", ["readme", "vary_together_label", "one_variant"])
def test_design_chart__has_the_peaks_of_every_variant(variants_ds, pattern):
    import matplotlib.pyplot as plt

    from vsi_numba.analysis.variants import design_chart_figure

    ds = variants_ds
    if pattern != "readme":  # the label group alone (damping and mass fixed)
        keep = np.flatnonzero((ds["bridge_damping_ratio"].values == 0.01)
                              & (ds["mass_factor"].values == 0.9))
        ds = ds.isel(variant=keep).drop_vars(["bridge_damping_ratio", "mass_factor"])
        if pattern == "one_variant":
            ds = ds.isel(variant=[1])
    ref = _reference_peak(ds)
    assert np.isfinite(ref).all() and ref.max() > 0
    fig, caption = design_chart_figure(ds)
    try:
        meshes, lines = _chart_data(fig)
        if pattern == "one_variant":  # no heat map over one variant: a line per variant
            assert not meshes and len(lines) == 1
            np.testing.assert_allclose(lines[0].get_ydata(), ref[0], rtol=1e-12)
            np.testing.assert_allclose(lines[0].get_xdata(), ds["speed_kmh"].values)
        else:
            # panels: label x mass_factor (x = damping) for the README pattern, one panel
            # over the spans for the label group alone; every variant and speed once
            assert len(meshes) == (4 if pattern == "readme" else 1), caption
            shown = np.concatenate([np.ma.filled(m.get_array(), np.nan).ravel()
                                    for m in meshes])
            assert np.isfinite(shown).all()
            np.testing.assert_allclose(np.sort(shown), np.sort(ref.ravel()), rtol=1e-12)
    finally:
        plt.close(fig)


def test_report__holds_no_machine_path_and_no_clock(init_run, tmp_path):
    """The report of a results file is the same file each time it is written, and it
    names the results file relative to itself."""
    from vsi_numba.analysis.report import write_report

    _, out, _ = init_run
    outdir = tmp_path / "reports" / "r"
    first = []
    for _ in range(2):  # (no re-run of cases without histories: faster, same provenance)
        with xr.open_dataset(out) as ds:
            write_report(ds, outdir, source_path=out, recompute=False, n_boot=100)
        first.append({p.name: p.read_bytes() for p in sorted(outdir.iterdir())
                      if p.suffix in (".md", ".csv", ".xlsx", ".html")})
    assert first[0] == first[1]
    md = first[0]["report.md"].decode()
    assert str(tmp_path) not in md and str(out.parent) not in md
    rel = Path(os.path.relpath(out, outdir))
    assert f"| results file | `{rel}` |" in md
    assert not re.search(r"\d{4}-\d\d-\d\d[T ]\d\d:\d\d", md)


@pytest.mark.parametrize("train,speed_kmh", [("HSLM-A4", 250.0), ("ICE3", 250.0)])
def test_results_file__reproduces_its_runs(init_run, train, speed_kmh):
    """A case re-run from the file's stored configuration alone (as the report does for
    the governing case of a speed without histories) gives the stored envelopes.  The
    starter config uses the rules that did not reload before (Table 6.6 damping and the
    additional damping of moving forces)."""
    from vsi_numba.analysis.recompute import CaseRunner

    _, out, _ = init_run
    with xr.open_dataset(out) as ds:
        assert "Table 6.6" in ds.attrs["damping_rule"]
        assert "moving-force trains only" in ds.attrs["additional_damping_rule"]
        i = int(np.flatnonzero(np.isclose(ds["speed_kmh"].values, speed_kmh))[0])
        stored = ds.sel(train=train).isel(speed=i, irregularity=0)
        sim = CaseRunner(ds, source_path=out).run(train, speed_kmh / 3.6)
        # same model, integrator and steps through another driver (single run vs batch):
        # equal to round-off
        np.testing.assert_allclose(sim["max_deck_acceleration"].values,
                                   stored["max_deck_acceleration"].values, rtol=1e-9)
        np.testing.assert_allclose(sim["max_deck_displacement"].values,
                                   stored["max_deck_displacement"].values, rtol=1e-9)
        if train == "ICE3":
            n = sim.sizes["vehicle"]
            np.testing.assert_allclose(sim["max_carbody_acceleration"].values,
                                       stored["max_carbody_acceleration"].values[:n],
                                       rtol=1e-9)
