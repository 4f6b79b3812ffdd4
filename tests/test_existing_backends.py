"""vsi calibrate and vsi reliability through the CLI on every backend (serial, threads,
processes, a Dask LocalCluster on 127.0.0.1): the same seed gives the same numbers, bit
for bit; an interrupted run continues from its stored evaluations to the numbers of an
uninterrupted one."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from tests.userpath import vsi
from vsi_numba.existing.parallel import INTERRUPT_ENV
from vsi_numba.verification import existing as syn

SMALL = "n_walkers = 8\nburn_in = 4\ncheck_samples = 10\n"


def _data(path) -> dict:
    with xr.open_dataset(path) as ds:
        return {k: ds[k].values for k in ds.data_vars if ds[k].dtype.kind in "fiu"}


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), k


@pytest.fixture(scope="module")
def calibration_case(tmp_path_factory):
    d = tmp_path_factory.mktemp("backends_cal")
    cfg = syn.write_case(d, speeds=(305.0,), n_samples=64, extra=SMALL)
    res = vsi("calibrate", cfg, "-o", d / "serial.nc", "-q", "--backend", "serial")
    assert res.returncode == 0, res.stdout + res.stderr
    return d, cfg, _data(d / "serial.nc")


@pytest.mark.parametrize("args", [("--backend", "threads", "-w", "2"),
                                  ("--backend", "processes", "-w", "2"),
                                  ("--workers", "2")])
def test_calibrate__same_posterior_on_every_backend(calibration_case, args):
    d, cfg, serial = calibration_case
    out = d / f"out_{args[1]}.nc"
    res = vsi("calibrate", cfg, "-o", out, "-q", *args)
    assert res.returncode == 0, res.stdout + res.stderr
    _same(serial, _data(out))
    assert not (d / f"{out.name}.evaluations").exists()  # a finished run removes it
    with xr.open_dataset(out) as ds:
        assert ("Dask" if args[0] == "--workers" else args[1]) in ds.attrs["backend"]


def test_calibrate__interrupted_run_continues_to_the_same_posterior(calibration_case,
                                                                    monkeypatch):
    d, cfg, serial = calibration_case
    out = d / "resumed.nc"
    store = d / "resumed.nc.evaluations"
    monkeypatch.setenv(INTERRUPT_ENV, "6")
    res = vsi("calibrate", cfg, "-o", out)
    assert res.returncode == 130
    assert "interrupted" in res.stderr and str(store) in res.stderr
    assert store.exists() and not out.exists()
    size = store.stat().st_size
    monkeypatch.delenv(INTERRUPT_ENV)
    res = vsi("calibrate", cfg, "-o", out, "--backend", "processes", "-w", "2")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "6 blocks of forward runs replayed" in res.stderr  # the 6 stored, once each
    _same(serial, _data(out))
    assert size > 0 and not store.exists()


def test_calibrate__a_store_of_another_configuration_is_discarded(calibration_case,
                                                                  monkeypatch):
    d, cfg, serial = calibration_case
    other = d / "other"
    cfg2 = syn.write_case(other, speeds=(305.0,), n_samples=64, extra=SMALL + "max_lag_s = 1.5\n")
    monkeypatch.setenv(INTERRUPT_ENV, "3")
    assert vsi("calibrate", cfg2, "-o", d / "mixed.nc", "-q").returncode == 130
    monkeypatch.delenv(INTERRUPT_ENV)
    res = vsi("calibrate", cfg, "-o", d / "mixed.nc")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "discarded: it belongs to another configuration" in res.stderr
    _same(serial, _data(d / "mixed.nc"))


def test_calibrate__an_output_another_process_writes_is_refused_and_its_store_kept(
        calibration_case):
    """One writer per output: while another process holds the output's lock (as a
    running ``vsi calibrate`` does), a second command on it - even with ``--fresh``,
    which would discard the store - is refused, naming the holder, and the holder's
    store of evaluations is left as it wrote it."""
    from vsi_numba.study.outlock import OutputLock

    d, cfg, _ = calibration_case
    out = d / "busy.nc"
    store = d / "busy.nc.evaluations"
    store.write_bytes(b"the other process's evaluations\n")
    with OutputLock(out, "vsi calibrate (the other process)"):
        res = vsi("calibrate", cfg, "-o", out, "-q", "--fresh")
    assert res.returncode == 2, res.stdout + res.stderr
    assert "being written by another process" in res.stderr, res.stderr
    assert "the other process" in res.stderr, res.stderr
    assert store.read_bytes() == b"the other process's evaluations\n"
    assert not out.exists()


@pytest.fixture(scope="module", params=["monte_carlo", "subset"])
def reliability_case(tmp_path_factory, request):
    d = tmp_path_factory.mktemp(f"backends_rel_{request.param}")
    limit, _ = syn.rel_limit(0.05)
    cfg = syn.write_reliability_case(d, limit, method=request.param, target=0.3,
                                     block=100, max_runs=400)
    res = vsi("reliability", cfg, "-o", d / "serial.nc", "-q", "--backend", "serial")
    assert res.returncode == 0, res.stdout + res.stderr
    return d, cfg, _data(d / "serial.nc")


def test_reliability__same_estimate_on_every_backend_and_after_an_interruption(
        reliability_case, monkeypatch):
    d, cfg, serial = reliability_case
    assert 0 < float(serial["probability_of_exceedance"][0]) < 1
    for args in (("--backend", "threads"), ("--backend", "processes", "-w", "2"),
                 ("--workers", "2")):
        out = d / f"out_{args[1]}.nc"
        res = vsi("reliability", cfg, "-o", out, "-q", *args)
        assert res.returncode == 0, res.stdout + res.stderr
        _same(serial, _data(out))
    monkeypatch.setenv(INTERRUPT_ENV, "2")
    assert vsi("reliability", cfg, "-o", d / "resumed.nc").returncode == 130
    assert (d / "resumed.nc.evaluations").exists()
    monkeypatch.delenv(INTERRUPT_ENV)
    res = vsi("reliability", cfg, "-o", d / "resumed.nc", "--workers", "2")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "2 blocks of forward runs replayed" in res.stderr
    _same(serial, _data(d / "resumed.nc"))


def test_backend_refusals_name_the_option(calibration_case):
    d, cfg, _ = calibration_case
    res = vsi("calibrate", cfg, "-o", d / "x.nc", "--backend", "gpu")
    assert res.returncode == 2 and "--backend gpu: expected one of serial, threads" in \
        res.stderr
    res = vsi("calibrate", cfg, "-o", d / "x.nc", "--backend", "threads", "--scheduler",
              "tcp://127.0.0.1:1")
    assert res.returncode == 2 and "--scheduler with --backend threads" in res.stderr
    assert not (d / "x.nc").exists()
