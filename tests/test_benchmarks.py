"""Tests of the benchmark suite: correctness of the yardstick only, no timing assertions.

The dense baseline (``benchmarks/baseline.py``) is an independent numpy/scipy
implementation of the same direct method; the benchmarks compare its speed with the
engine's, which is only meaningful if both compute the same thing.  Measure of agreement
(as in the report): for each channel, max over time of |engine - baseline| divided by
max over time of |baseline|; the bound 1e-6 is far above round-off (both solve the same
linear systems each step, ~1e-14 observed) and far below any modelling difference (a
different HHT constant, a step-count or position offset of one step shows up at 1e-3..1).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks import cases as C
from benchmarks.baseline import BaselineError, n_steps_for, run_baseline
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import cosine_defect
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import simulate

TOL = 1e-6


def _compare(ds, res):
    return C.agreement_full(ds, res)


def test_case1_small_agreement():
    """Case 1 with 10 modes at 200 km/h (540 steps): sprung mass, massless contact point."""
    bridge = C.light_beam(10)
    train = vh.Train("sm", (vh.sprung_mass(5750.0, 1.595e6, 0.0, 0.0),), (0.0,))
    # max_subdivisions = 0: no refinement of the steps in which a wheel crosses a deck
    # end, which the dense baseline does not implement (tests/test_impact_lcp.py checks
    # that refinement against an event-driven reference)
    settings = SolverSettings(dt=1e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.1,
                              max_subdivisions=0)
    v = 200.0 / 3.6
    ds = simulate(bridge, train, v, settings=settings)
    res = run_baseline(bridge, train, v, settings=settings)
    assert res.n_steps == int(ds.attrs["n_steps"]) == n_steps_for(bridge, train, v, settings)
    agree = _compare(ds, res)
    assert agree["deflection"] <= TOL, agree
    assert agree["contact_force"] <= TOL, agree
    assert np.abs(res.deflection(12.5)).max() > 1e-4  # a real response was compared


def test_case2_small_agreement():
    """Case 2 with one HSLM train at one speed (whole run, 10 modes, dt = 2 ms)."""
    bridge, trains, settings = C.case2_model()
    train = trains["HSLM-A1"]
    v = 360.0 / 3.6
    ds = simulate(bridge, train, v, settings=settings)
    res = run_baseline(bridge, train, v, settings=settings)
    assert res.n_steps == int(ds.attrs["n_steps"])
    agree = _compare(ds, res)
    assert agree["deflection"] <= TOL, agree


def test_landing_agreement():
    """The plastic-impact branch: a sprung mass with a wheel mass loses contact over a
    10 mm dip and lands again; both codes must see the same landings and forces."""
    bridge = C.light_beam(10, 0.01)
    train = vh.Train("smw", (vh.sprung_mass(5750.0, 1.595e6, 1e3, 500.0),), (0.0,))
    settings = SolverSettings(dt=1e-3, free_vibration=0.2, max_subdivisions=0)  # see case 1
    profile = cosine_defect(0.01, 1.0, 10.0)
    v = 200.0 / 3.6
    ds = simulate(bridge, train, v, profile=profile, settings=settings)
    res = run_baseline(bridge, train, v, profile=profile, settings=settings)
    assert res.landings >= 1
    assert float(ds["contact_loss_duration"].max()) > 0
    np.testing.assert_array_equal(ds["in_contact"].values[:, 0], res.active[:, 0])
    agree = _compare(ds, res)
    assert agree["deflection"] <= TOL, agree
    assert agree["contact_force"] <= TOL, agree


def test_multibody_start_on_rail():
    """The baseline's own static start puts every ICE3 wheel on the rail."""
    _, train, settings = C.case3_model()
    res = run_baseline(C.hsr_deck(5), train, 300 / 3.6, settings=settings, n_steps=5)
    assert res.landings == 0
    assert res.active.all()
    assert res.X.min() > 0.5 * res.X[0].mean()


def test_baseline_rejects_hertz():
    settings = SolverSettings(contact_model="hertz_linear", hertz_coefficient=1e-8)
    train = vh.Train("sm", (vh.sprung_mass(5750.0, 1.595e6),), (0.0,))
    with pytest.raises(BaselineError, match="rigid"):
        run_baseline(C.light_beam(2), train, 20.0, settings=settings, n_steps=2)


def test_rel_diff():
    b = np.array([[0.0, 1.0], [2.0, -4.0]])
    a = b + np.array([[0.0, 0.0], [0.002, 0.0]])
    assert C.rel_diff(a, b) == pytest.approx(1e-3)
    assert C.rel_diff(np.zeros(3), np.zeros(3)) == 0.0


def test_quick_suite_produces_table(capsys):
    """`python -m benchmarks --smoke --no-write` (the quick suite, smallest sizes) runs
    every case and prints the summary table; only its correctness part is checked."""
    from benchmarks.__main__ import main

    assert main(["--smoke", "--no-write", "--no-study"]) == 0
    out = capsys.readouterr().out
    assert "speed-up" in out and "status" in out
    for case in ("1", "2", "3", "4"):
        assert any(line.startswith(case + " ") for line in out.splitlines()), case
    for line in out.splitlines():
        if line.strip().startswith("case 1 ") or line.strip().startswith("case 2 "):
            assert float(line.rsplit(":", 1)[1]) <= TOL, line


def test_report_written(tmp_path):
    from benchmarks.suite import run_suite

    path = tmp_path / "bench.md"
    study = "<!-- study-benchmark:begin -->\nSTUDY\n<!-- study-benchmark:end -->\n"
    path.write_text("# old report\n\n" + study)
    suite = run_suite("smoke", write=True, report=path, only=["1"], echo=lambda s: None)
    text = path.read_text()
    assert "# old report" not in text and text.rstrip().endswith(study.rstrip())
    assert "## Machine" in text and "load average" in text and "numba" in text
    assert "## Case 1" in text and "| case |" in text
    assert suite.agreement["case 1 deflection"] <= TOL


# ------------------------------------------------------- study level and yardstick

YARDSTICK_TOL = 1e-9


def test_yardstick_agrees_with_engine():
    """The numpy/scipy yardstick vs ``simulate`` (HHT alpha = 0) on a small HSLM grid.

    Newmark beta = 1/4, gamma = 1/2 on decoupled modal equations IS the trapezoidal rule
    on u, u', u'', i.e. the bilinear transform of 1/(s^2 + 2 zeta w s + w^2) that
    ``lfilter`` runs; both start from rest with no load on the span.  The two codes run
    the same recursion and differ only by round-off (~1e-13 observed), hence 1e-9: far
    above round-off, far below any modelling difference (a step offset, another
    integrator, a missing mode or load show up at 1e-4..1).
    """
    from benchmarks.yardstick import check_agreement

    agree = check_agreement(("HSLM-A1", "HSLM-A10"), (160.0, 300.0, 420.0))
    assert agree["displacement"] <= YARDSTICK_TOL, agree
    assert agree["acceleration"] <= YARDSTICK_TOL, agree


def test_yardstick_filter_is_newmark():
    """One mode: the bilinear filter reproduces an explicit Newmark (1/4, 1/2) loop."""
    from scipy.signal import bilinear, lfilter

    w, z, dt = 2 * np.pi * 5.0, 0.02, 1e-3
    f = np.random.default_rng(1).normal(size=400)
    f[0] = 0.0
    u, v, a = np.zeros(400), np.zeros(400), np.zeros(400)
    k_eff = 4 / dt**2 + 2 * z * w * 2 / dt + w * w
    for n in range(399):
        rhs = (f[n + 1] + (4 / dt**2 * u[n] + 4 / dt * v[n] + a[n])
               + 2 * z * w * (2 / dt * u[n] + v[n]))
        u[n + 1] = rhs / k_eff
        a[n + 1] = 4 / dt**2 * (u[n + 1] - u[n]) - 4 / dt * v[n] - a[n]
        v[n + 1] = v[n] + dt / 2 * (a[n] + a[n + 1])
    den = [1.0, 2 * z * w, w * w]
    ud = lfilter(*bilinear([1.0], den, fs=1 / dt), f)
    ad = lfilter(*bilinear([1.0, 0.0, 0.0], den, fs=1 / dt), f)
    assert np.abs(ud - u).max() <= 1e-12 * np.abs(u).max()
    assert np.abs(ad - a).max() <= 1e-12 * np.abs(a).max()


def test_study_configs_are_valid():
    """Every config the study benchmark writes passes the package's config loader."""
    from benchmarks import study as S
    from vsi_numba.config import load_config

    hslm = S.hslm_config(S.Y.TRAINS, S.Y.SPEEDS_KMH)
    ice3 = S.ice3_config(range(1, 11), S.Y.SPEEDS_KMH)
    hist = S.hslm_config(S.Y.TRAINS, S.HIST_SPEEDS, histories=True)
    assert (S.n_runs(hslm), S.n_runs(ice3), S.n_runs(hist)) == (570, 570, 1140)
    assert S.n_runs(S.study1_config()) == 627
    for cfg in (hslm, ice3, hist, S.one_run(hslm), S.one_run(ice3),
                S.one_run(S.study1_config())):
        import tomllib

        text = S.to_toml(cfg)
        assert tomllib.loads(text) == tomllib.loads(S.to_toml(tomllib.loads(text)))
        load_config(tomllib.loads(text))
        if cfg is not hslm and cfg is not ice3 and cfg is not hist:
            assert S.n_runs(cfg) == 1


def test_tree_rss_counts_descendants(tmp_path):
    """The peak RSS of a command includes its children (here a 150 MB grandchild)."""
    import sys

    from benchmarks.study import MB, run_command

    child = "b = bytearray(150 * 2**20); import time; time.sleep(1.0)"
    cmd = [sys.executable, "-c",
           f"import subprocess, sys; subprocess.run([sys.executable, '-c', {child!r}])"]
    r = run_command(cmd, tmp_path, None)
    assert r.returncode == 0
    assert r.max_procs >= 2
    assert r.peak_rss >= 150 * MB, r


def test_run_command_cpu_time(tmp_path):
    """CPU time counts the command's children (rusage of the reaped processes): a child
    spinning for 0.4 s of its own CPU clock must show >= 0.35 s (0.05 s for the clock
    resolution), and no more than the parent's wall time allows on 2 cores."""
    from benchmarks.study import run_command

    child = ("import time; t = time.process_time()\n"
             "while time.process_time() - t < 0.4: pass")
    cmd = [sys.executable, "-c",
           f"import subprocess, sys; subprocess.run([sys.executable, '-c', {child!r}])"]
    r = run_command(cmd, tmp_path, None)
    assert r.returncode == 0
    assert 0.35 <= r.cpu <= 2 * r.wall + 0.05, r


def test_dask_cluster_row(tmp_path, monkeypatch):
    """The Dask cluster row reads the Dask path's measure when present (ratio = cluster /
    local from the file's own numbers), else says "not measured"."""
    import json

    import benchmarks.study as S

    monkeypatch.setattr(S, "DASK_CLUSTER", S.REPO / "reports" / "no_such_measure.json")
    res = S.StudyResult("smoke")
    S._measure_j(None, res)
    m = res.measure("j1")
    assert m.verdict == "n/a" and "not measured" in m.note
    path = S.REPO / "reports" / f"dask_cluster_test_{tmp_path.name}.json"
    try:
        path.write_text(json.dumps({"cluster_s": 33.0, "local_s": 30.0, "grid": "g"}))
        monkeypatch.setattr(S, "DASK_CLUSTER", path)
        res = S.StudyResult("smoke")
        S._measure_j(None, res)
        m = res.measure("j1")
        assert m.value == 33.0 / 30.0 and m.bar == 1.1 and m.verdict == "met"
    finally:
        path.unlink(missing_ok=True)


def test_study_verdicts_and_section(tmp_path):
    from benchmarks.study import Measure, extract_section, write_section

    assert Measure("x", "", "", 0.9, "ratio", 1.5, 1.0).verdict == "goal met"
    assert Measure("x", "", "", 1.2, "ratio", 1.5, 1.0).verdict == "bar met, goal missed"
    assert Measure("x", "", "", 3.0, "s", 1.5, 1.0).verdict.startswith("MISSED x2.0")
    assert "EXTRAPOLATED" in Measure("x", "", "", 3.0, "s", 1.5, 1.0,
                                     extrapolated=True).verdict
    path = tmp_path / "r.md"
    path.write_text("# report\n\n## Case 1\n\ntext\n")
    write_section(path, "<!-- study-benchmark:begin -->\nA\n<!-- study-benchmark:end -->\n")
    write_section(path, "<!-- study-benchmark:begin -->\nB\n<!-- study-benchmark:end -->\n")
    text = path.read_text()
    assert text.startswith("# report") and "## Case 1" in text
    assert extract_section(text).count("B") == 1 and "\nA\n" not in text


def test_study_smoke(tmp_path, capsys):
    """`python -m benchmarks --study --smoke`: one 1-run `vsi sweep` subprocess, measured
    (wall, process-tree RSS), checked against the yardstick, written to the report (the
    load-effects pair by the CLI app in this process)."""
    from benchmarks.__main__ import main

    report = tmp_path / "bench.md"
    assert main(["--study", "--smoke", "--report", str(report)]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("a1 "))
    assert "yardstick" in line and ("met" in line or "MISSED" in line)
    # every target of the performance review has its row, with its target
    rows = {x.split()[0]: x for x in out.splitlines() if x[:2] in ("a1", "a3", "i1", "j1")}
    assert set(rows) == {"a1", "a3", "i1", "j1"}, out
    assert "0.80" in rows["a1"] and "1.30" in rows["a3"] and "1.15" in rows["a3"]
    assert "CPU" in rows["a3"] and "120 s" in rows["i1"]
    text = report.read_text()
    assert "## Study level" in text and "| a1 |" in text and "peak RSS" in text
    import re

    agree = re.search(r"output agrees with the yardstick to ([0-9.]+e[-+][0-9]+)", text)
    assert agree and float(agree.group(1)) <= YARDSTICK_TOL


# ------------------------------------------------- decks in space (benchmarks/space.py)


def test_space_configs_differ_only_in_the_deck_in_space():
    """The four configs of ``benchmarks/space.py`` load, and differ only in the keys of
    a deck in space: (a) none, (b) one track at 0, (c) the bundled tracks and torsion,
    (d) the bundled config with its train on track 2."""
    import tomllib

    from benchmarks import space as SP
    from benchmarks.study import to_toml
    from vsi_numba.config import load_config

    cfgs = SP.space_configs((140.0, 250.0, 360.0))
    a, b, c, d = cfgs["a"], cfgs["b"], cfgs["c"], cfgs["d"]
    assert d["train"]["other_trains"] == [{"track": 2, "direction": "opposite",
                                           "offset": 0.0}]
    d["train"].pop("other_trains")
    assert c == d
    assert "tracks" not in a["bridge"] and "torsion" not in a["bridge"]
    assert "track" not in a["train"]
    assert b["bridge"]["tracks"] == [{"eccentricity": 0.0}] and "torsion" not in b["bridge"]
    assert [t["eccentricity"] for t in c["bridge"]["tracks"]] == [2.25, -2.25]
    assert c["bridge"]["torsion"]["GJ"] > 0 and c["train"]["track"] == 1
    for key in ("tracks", "torsion"):
        b["bridge"].pop(key, None)
        c["bridge"].pop(key)
    c["train"].pop("track")
    assert a == b == c
    for cfg in SP.space_configs((140.0, 250.0, 360.0)).values():
        load_config(tomllib.loads(to_toml(cfg)))
        assert SP.n_runs(cfg) == 4 * 3


def test_space_smoke(tmp_path):
    """`python -m benchmarks.space --smoke`: one 1-run `vsi sweep` per variant ((a) as a
    subprocess, the others by the CLI app in this process); the planar results (of the
    subprocess) equal those with one track at 0 in every shared variable, the torsion
    adds modes, and the section is written beside the report's other sections."""
    from benchmarks import space as SP

    report = tmp_path / "bench.md"
    report.write_text("# report\n\n## Case 1\n\ntext\n")
    res = SP.run_space_bench("smoke", report=report, echo=lambda s: None)
    assert not res.errors, res.errors
    assert res.planar_identical == []
    assert res.modes["a"] == res.modes["b"] < res.modes["c"]
    keys = {m.key: m for m in res.measures}
    assert set(keys) == {"b1", "b2", "b3", "c1", "c2", "c3", "d1", "d3", "e1", "e2", "e3",
                         "n1"}
    assert res.modes["e"] == res.modes["c"] and keys["e1"].bar == 3.0
    assert res.modes["d"] == res.modes["c"] and keys["d1"].bar == 2.0
    assert keys["b1"].bar == 1.10 and keys["c1"].bar == res.modes["c"] / res.modes["a"]
    table = SP.text_table(res)
    assert "two tracks + torsion / planar" in table and "one track at 0" in table
    text = report.read_text()
    assert text.startswith("# report") and "## Case 1" in text
    assert "## Decks in space" in text and "| b1 |" in text and "| c1 |" in text
    SP.write_section(report, SP.markdown(res))  # replaced in place, not appended
    assert report.read_text().count("## Decks in space") == 1


# ------------------------------------------------------ the main job (benchmarks/main_job.py)


def test_main_job_section__medians_ratios_and_replaced_in_place(tmp_path):
    """The main job's section: medians of the rounds per checkout, this checkout's over
    the baseline's as the ratio, the re-run's own line quoted; written in place of an
    earlier one, the rest of the report kept."""
    from benchmarks import main_job as MJ

    res = MJ.Result({"this checkout": Path("."), "baseline": Path("/b")}, rounds=3,
                    date="2026-12-01T00:00:00+00:00", load=(1.0, 1.5))
    for wall, cpu in ((2.0, 3.0), (2.2, 3.3), (9.0, 9.9)):  # median 2.2 s, 3.3 s
        res.add("this checkout", "rerun", wall, cpu)
    for wall, cpu in ((4.4, 6.6), (4.0, 6.0), (5.0, 7.0)):  # median 4.4 s, 6.6 s
        res.add("baseline", "rerun", wall, cpu)
    res.notes["this checkout"] = "627 runs: results.nc holds them"
    text = MJ.markdown(res)
    row = next(ln for ln in text.splitlines() if ln.startswith("| main job re-run"))
    assert row.split(" | ")[1:5] == ["2.20 s", "3.30 s", "4.40 s", "6.60 s"]
    assert row.endswith("| 0.50 | 0.50 |")
    assert "`627 runs: results.nc holds them`" in text
    report = tmp_path / "bench.md"
    report.write_text("# report\n\n" + MJ.markdown(MJ.Result({"this checkout": Path(".")}))
                      + "\n## Later\n")
    MJ.write_section(report, text)
    out = report.read_text()
    assert out.count(MJ.BEGIN) == 1 and "| 0.50 | 0.50 |" in out
    assert out.startswith("# report") and out.rstrip().endswith("## Later")


def test_main_job_section__cold_run_with_its_ratio():
    """The run on an empty numba cache: each checkout's wall and CPU and this checkout's
    over the baseline's; without a baseline's cold run, no ratio."""
    from benchmarks import main_job as MJ

    res = MJ.Result({"this checkout": Path("."), "baseline": Path("/b")}, rounds=1,
                    date="2026-12-01T00:00:00+00:00", load=(1.0, 1.5))
    res.cold = {"this checkout": (30.0, 45.0), "baseline": (60.0, 90.0)}
    row = next(ln for ln in MJ.markdown(res).splitlines() if ln.startswith("| main job, empty"))
    assert row.split(" | ")[1:5] == ["30.00 s", "45.00 s", "60.00 s", "90.00 s"]
    assert row.endswith("| 0.50 | 0.50 |")
    res.cold.pop("baseline")
    row = next(ln for ln in MJ.markdown(res).splitlines() if ln.startswith("| main job, empty"))
    assert row.endswith("| - | - | - | - |")


def test_main_job_stages__the_fresh_sweep_by_its_parts(tmp_path):
    """The in-process profile of a fresh sweep (``STAGES`` with ``fresh``) times each part
    of the command: a part renamed in the package would leave its row out."""
    import json
    import os
    import subprocess
    import sys

    from benchmarks import main_job as MJ

    text = (MJ.REPO / "configs" / "quickstart.toml").read_text()
    (tmp_path / "study.toml").write_text(
        text.replace('output = "results/quickstart.nc"', 'output = "results.nc"'))
    env = {**os.environ, "VSI_OUTPUT_CACHE": "off",
           "PYTHONPATH": os.pathsep.join([str(MJ.REPO), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", MJ.STAGES, "-", "fresh"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    stages = json.loads(done.stdout.strip().splitlines()[-1])
    parts = ["sweep: configuration read", "sweep: model built", "sweep: batches planned",
             "sweep: batches run (kernels loaded, runs)", "sweep: results file written",
             "governing: the results file opened (xarray)", "governing lines"]
    assert all(stages.get(p, 0.0) > 0.0 for p in parts), stages
    assert not any(k.startswith("report") for k in stages), stages
    assert sum(stages[p] for p in parts[:5]) <= stages["total (in process)"]
    assert (tmp_path / "results.nc").is_file() and not (tmp_path / "-").exists()
    # the critical path from the threads' own clocks
    busiest, every = stages["batch threads: CPU, the busiest"], stages["batch threads: CPU, all"]
    outside = stages["main thread: CPU outside the batches"]
    during = stages["main thread: CPU during the batches"]
    estimate = next(v for k, v in stages.items() if k.startswith("estimate: wall"))
    assert 0.0 < busiest <= every and outside > 0.0 and during >= 0.0
    assert max(outside + busiest, outside + (every + during) / 2) == pytest.approx(estimate)
