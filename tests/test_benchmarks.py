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
    settings = SolverSettings(dt=1e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.1)
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
    settings = SolverSettings(dt=1e-3, free_vibration=0.2)
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

    assert main(["--smoke", "--no-write"]) == 0
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
    suite = run_suite("smoke", write=True, report=path, only=["1"], echo=lambda s: None)
    text = path.read_text()
    assert "## Machine" in text and "load average" in text and "numba" in text
    assert "## Case 1" in text and "| case |" in text
    assert suite.agreement["case 1 deflection"] <= TOL
