"""vsi reliability: config -> vsi reliability -> RELIABILITY.nc -> vsi report, on a
response monotone in one random input (the resonant deck acceleration decreasing with
the damping ratio): P = F(zeta*) with a(zeta*) = limit from the closed form."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.verification import existing as syn


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def limit():
    return syn.rel_limit(0.03)[0]


@pytest.mark.parametrize("method, target, block", [("monte_carlo", 0.2, 200),
                                                   ("subset", 0.2, 200)])
def test_reliability__agrees_with_the_closed_form(tmp_path, limit, method, target, block):
    cfg = syn.write_reliability_case(tmp_path, limit, method=method, target=target,
                                     block=block, max_runs=4000)
    res = _cli("reliability", cfg, "-o", tmp_path / "rel.nc", "-q")
    assert res.exit_code == 0, res.output
    exact = syn.rel_probability(limit)  # root solve on the closed form: 0.03
    with xr.open_dataset(tmp_path / "rel.nc") as ds:
        p = float(ds["probability_of_exceedance"].values[0])
        cov = float(ds["cov"].values[0])
        assert float(ds["reliability_index"].values[0]) == pytest.approx(
            -__import__("scipy").stats.norm.ppf(p))
        assert 0 < cov <= 0.35
        # the estimator's own error: 3 standard deviations (its stated cov), plus the
        # engine's 1 % on the resonant acceleration at dt = 2 ms (about 5 % on P here)
        assert abs(p / exact - 1.0) <= 3.0 * cov + 0.05
        assert float(ds["probability_of_exceedance_range"]) == pytest.approx(p)
        assert int(ds["runs"].values[0]) <= 4000
    res = _cli("report", tmp_path / "rel.nc", "-o", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "P (exceeded)" in md and "deterministic verdict" in md and "| pass |" in md


def test_reliability__same_seed_same_estimate(tmp_path, limit):
    cfg = syn.write_reliability_case(tmp_path, limit, method="monte_carlo", target=0.5,
                                     block=100, max_runs=200)
    out = []
    for k in range(2):
        assert _cli("reliability", cfg, "-o", tmp_path / f"r{k}.nc", "-q").exit_code == 0
        with xr.open_dataset(tmp_path / f"r{k}.nc") as ds:
            out.append(ds["probability_of_exceedance"].values.copy())
    np.testing.assert_array_equal(out[0], out[1])


def test_check__reliability_errors_all_at_once(tmp_path, limit):
    cfg = syn.write_reliability_case(tmp_path, limit)
    text = cfg.read_text().replace('method = "subset"', 'method = "subsets"').replace(
        "target_cov = 0.1", "target_cov = 1.5").replace(
        'distribution = "lognormal", median = 0.015, cov = 0.3',
        'distribution = "normal", median = 0.015')
    cfg.write_text(text)
    res = _cli("check", cfg)
    assert res.exit_code == 2
    out = res.output
    assert 'reliability.method = "subsets"' in out and "'subset'" in out
    assert "reliability.target_cov = 1.5" in out
    assert "reliability.variables[0].mean: missing" in out
    assert "reliability.variables[0].median = 0.015: expected no median" in out


def test_check__reliability_estimate(tmp_path, limit):
    cfg = syn.write_reliability_case(tmp_path, limit, method="subset", block=500)
    res = _cli("check", cfg)
    assert res.exit_code == 0, res.output
    line = next(x for x in res.output.splitlines() if x.startswith("reliability:"))
    assert "500 runs per level" in line and "ms a forward run" in line
