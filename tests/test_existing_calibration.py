"""vsi calibrate: config -> vsi calibrate -> POSTERIOR.nc -> vsi report, on synthetic
records computed by an independent integration (solve_ivp of the modal equations)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.verification import existing as syn
from vsi_numba.verification import reference as ref

SMALL = "n_walkers = 8\nburn_in = 4\ncheck_samples = 10\n"


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def posterior(tmp_path_factory):
    d = tmp_path_factory.mktemp("calib")
    cfg = syn.write_case(d, speeds=(305.0,), n_samples=64, extra=SMALL)
    res = _cli("calibrate", cfg, "-o", d / "post.nc", "-q")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(d / "post.nc") as ds:
        return d, ds.load()


def test_calibrate__posterior_file_layout(posterior):
    _, ds = posterior
    assert list(ds["parameter"].values) == ["bridge.EI", "bridge.damping_ratio",
                                           "calibration.noise_std.deck_acceleration"]
    assert ds["posterior"].dims == ("sample", "parameter")
    assert ds.sizes["sample"] == 64
    for name in ("log_likelihood", "acceptance_fraction", "autocorrelation_time",
                 "effective_sample_size", "r_hat", "record_shift"):
        assert name in ds and np.all(np.isfinite(ds[name].values)), name
    assert ds.attrs["vsi_file"] == "posterior" and "config_json" in ds.attrs
    assert ds.attrs["history"].endswith("-q") or "vsi calibrate" in ds.attrs["history"]


def test_calibrate__alignment_finds_the_records_clock(posterior):
    _, ds = posterior
    # the record's clock is CLOCK_OFFSET ahead of the model's; the shift of the best
    # sample is found to a fraction of the model's step (parabolic refinement of the
    # least-squares lag)
    best = int(np.argmax(ds["log_likelihood"].values))
    assert ds["record_shift"].values[best, 0] == pytest.approx(-syn.CLOCK_OFFSET,
                                                                 abs=0.5 * syn.DT)


def test_calibrate__check_with_the_configurations_values_matches_solve_ivp(posterior):
    _, ds = posterior
    pos, loads = syn.hslm_a1_axles()
    x = np.linspace(0.0, syn.SPAN, 33)
    for j, vk in enumerate(ds["check_speed_kmh"].values):
        v = vk / 3.6
        t = np.arange(0.0, (syn.APPROACH + syn.SPAN + pos.max()) / v + syn.FREE_VIBRATION,
                      2.5e-4)
        _, a = ref.moving_forces_ivp(pos, loads, syn.SPAN, 2.0e10, syn.MASS, 0.01,
                                     syn.N_MODES, v, x, t, x_start=-syn.APPROACH)
        # trapezoidal rule at dt = 0.5 ms (second order: 2.7 % at 1 ms, 0.6 % at 0.5 ms,
        # 0.15 % at 0.25 ms at 250 km/h, mode 3 at 41 Hz) and the peak sampled at dt
        assert ds["check_code"].values[j] == pytest.approx(np.abs(a).max(), rel=1.5e-2)


def test_report__posterior_table_corner_records_and_check(posterior):
    d, ds = posterior
    res = _cli("report", d / "post.nc", "-o", d / "rep")
    assert res.exit_code == 0, res.output
    md = (d / "rep" / "report.md").read_text()
    assert "| bridge.EI |" in md and "| bridge.damping\\_ratio |" in md
    assert (d / "rep" / "corner.png").stat().st_size > 1000
    assert (d / "rep" / "records.png").stat().st_size > 1000
    assert "configuration's values" in md and "| 300 |" in md


def test_check__calibration_errors_all_at_once(tmp_path):
    cfg = syn.write_case(tmp_path, speeds=(305.0,), n_samples=64)
    base = cfg.read_text()
    text = base.replace('prior = "uniform", lower = 0.005, upper = 0.05',
                        'prior = "uniforme", lower = 0.005, upper = 0.05')
    text = text.replace('file = "passage_01.csv"', 'file = "missing.csv"')
    text = text.replace("n_samples = 64", "n_samples = 3")
    cfg.write_text(text)
    res = _cli("check", cfg)
    assert res.exit_code == 2
    out = res.output
    assert 'calibration.parameters[1].prior = "uniforme"' in out and "'uniform'" in out
    assert 'calibration.records[0].file = "missing.csv"' in out
    assert "calibration.n_samples = 3" in out


def test_check__calibration_distribution_and_key_path(tmp_path):
    cfg = syn.write_case(tmp_path, speeds=(305.0,), n_samples=64)
    text = cfg.read_text().replace(
        'key = "bridge.EI", prior = "lognormal", median = 2.0e10, cov = 0.2',
        'key = "bridge.EI", prior = "lognormal", median = 2.0e10')
    cfg.write_text(text)
    res = _cli("check", cfg)
    assert res.exit_code == 2
    assert "calibration.parameters[0].cov: missing" in res.output
    text = cfg.read_text().replace('median = 2.0e10', 'median = 2.0e10, cov = 0.2').replace(
        'key = "bridge.EI"', 'key = "bridge.Ei"')
    cfg.write_text(text)
    res = _cli("check", cfg)
    assert res.exit_code == 2
    assert 'calibration.parameters[0].key = "bridge.Ei": expected a numeric key' in res.output


def test_check__calibration_estimate(tmp_path):
    cfg = syn.write_case(tmp_path, speeds=(305.0,), n_samples=64, extra=SMALL)
    res = _cli("check", cfg)
    assert res.exit_code == 0, res.output
    # 4 x 8 start draws + 60 x 3 Nelder-Mead + 1 + 2 x 3 x 4 Laplace + 8 walkers x
    # (4 + 8) steps + 2 x 10
    line = next(x for x in res.output.splitlines() if x.startswith("calibration:"))
    assert line.startswith("calibration: 353 forward runs") and "ms a forward run" in line


def test_calibrate__same_seed_same_posterior(posterior):
    d, ds = posterior
    res = _cli("calibrate", d / "calibration.toml", "-o", d / "again.nc", "-q")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(d / "again.nc") as again:
        np.testing.assert_array_equal(again["posterior"].values, ds["posterior"].values)


def test_moves__sample_a_standard_normal_without_narrowing_it():
    """The sampler's moves on a 3-D standard normal (the synthetic case's dimension and
    walkers): the pooled standard deviation of 24 chains is 1 within 1.2 % (its standard
    error ~0.35 %); emcee's snooker move at 20 % gave 0.978."""
    import emcee
    from threadpoolctl import threadpool_limits

    from vsi_numba.existing.calibrate import moves

    def lp(u):
        return -0.5 * np.sum(np.atleast_2d(u) ** 2, axis=1)

    with threadpool_limits(limits=1):  # BLAS threads only spin on these small products
        sd = _chains_sd(emcee, moves, lp)
    assert np.mean(sd) == pytest.approx(1.0, abs=0.012)


def _chains_sd(emcee, moves, lp):
    sd = []
    for r in range(24):
        s = emcee.EnsembleSampler(16, 3, lp, vectorize=True, moves=moves())
        s.random_state = np.random.RandomState(r).get_state()
        s.run_mcmc(np.random.default_rng(r).standard_normal((16, 3)), 540, progress=False)
        sd.append(s.get_chain()[40:].reshape(-1, 3).std(axis=0))
    return sd
