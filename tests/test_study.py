"""Study runner: case grid, backends (serial / spawned processes / Dask), file layout.

Real components throughout: the TOML config loader, the train library (a small user train
file), PSD irregularities and the numba engine.  The model is kept tiny (10 m span, 2
modes, one- and two-car trains, dt = 2 ms) so each case takes tens of ms once the kernels
are compiled; set NUMBA_CACHE_DIR so that compilation happens once per machine.
"""

from __future__ import annotations

import json
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from study_trains import TRAINS_TOML

from vsi_numba.cli.sweep import sweep_command
from vsi_numba.config import ConfigError, load_config
from vsi_numba.io.netcdf import open_results
from vsi_numba.io.schema import ENVELOPES, HISTORIES
from vsi_numba.solver.simulate import simulate
from vsi_numba.study import runner
from vsi_numba.study.grid import history_mask, make_grid
from vsi_numba.study.runner import (
    StudySpec,
    run_case,
    run_study,
    study_grid,
    study_model,
    study_spec,
)
from vsi_numba.study.spec import model_fingerprint
from vsi_numba.study.store import StoreMismatchError, store_path


def write_study(directory: Path, speeds=(100.0, 150.0, 200.0), history=(150.0,),
                damping=0.02, seeds=(1, 2)) -> Path:
    """A small study: 10 m span (2 modes), two user trains, PSD profiles."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "trains.toml").write_text(TRAINS_TOML)
    text = f"""
    title = "study test: two small trains on a 10 m span"
    [bridge]
    kind = "simply_supported"
    spans = [10.0]
    EI = 2.0e9
    mass_per_length = 10000.0
    damping_ratio = {damping}
    n_modes = 2
    [train]
    file = "trains.toml"
    [irregularity]
    kind = "psd"
    spectrum = "fra4"
    wavelength_min = 2.0
    wavelength_max = 30.0
    seeds = {list(seeds)}
    [solver]
    dt = 2e-3
    approach = 2.0
    free_vibration = 0.1
    [study]
    speeds_kmh = {list(speeds)}
    output = "results/study.nc"
    save_time_histories = true
    history_speeds_kmh = {list(history)}
    """
    path = directory / "study.toml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def study_config(tmp_path_factory) -> Path:
    return write_study(tmp_path_factory.mktemp("study"))


@pytest.fixture(scope="module")
def serial_result(study_config) -> xr.Dataset:
    out = study_config.parent / "serial.nc"
    return run_study(study_config, out, backend="serial")


def envelopes(ds: xr.Dataset) -> xr.Dataset:
    names = [*ENVELOPES, "status", "max_iterations"]
    return ds[names].drop_attrs(deep=False)


# ------------------------------------------------------------------------------- grid


def test_make_grid__deterministic_order_and_keys():
    grid = make_grid([100.0, 150.0], ["A", "B"], [7, 9], [False, True],
                     [100.0 / 3.6, 150.0 / 3.6])
    assert grid.shape == (2, 2, 2)
    assert [c.key for c in grid.cases[:3]] == ["s0000_t000_i000", "s0000_t000_i001",
                                               "s0000_t001_i000"]
    assert [c.index for c in grid.cases] == list(range(8))
    assert [c.histories for c in grid.cases] == [False] * 4 + [True] * 4
    assert grid.cases[-1].irregularity == 9 and grid.cases[-1].train == "B"
    assert grid.cases[5].speed_m_s == 150.0 / 3.6


def test_history_mask__none_all_subset():
    speeds = [100.0, 150.0, 200.0]
    assert not history_mask(speeds, False, None).any()
    assert history_mask(speeds, True, None).all()
    assert history_mask(speeds, True, [150.0]).tolist() == [False, True, False]


def test_study_grid__from_config(study_config):
    cfg = load_config(study_config)
    grid = study_grid(study_model(study_spec(cfg)))
    assert grid.trains == ("one-car", "two-cars")
    assert grid.irregularities == (1, 2)
    assert len(grid.cases) == 12
    assert grid.history_speeds.tolist() == [False, True, False]
    # the speeds in m/s come from the configuration, the listed km/h / 3.6 bit for bit
    listed = cfg.resolved()["study"]["speeds_kmh"]
    assert [c.speed_m_s for c in grid.cases[::4]] == [v / 3.6 for v in listed]
    assert grid.speeds_m_s.tolist() == [v / 3.6 for v in listed]


def test_study_spec__carries_the_validated_config_to_a_worker(study_config, monkeypatch):
    """A spec sent to another process (pickled) carries the ``Config``: the worker builds
    the model without validating the file again, and the copy is the same cache key."""
    import pickle

    import vsi_numba.config as config_pkg
    from vsi_numba.study import spec as spec_mod

    cfg = load_config(study_config)
    spec = study_spec(cfg)
    sent = pickle.loads(pickle.dumps(spec))
    assert sent == spec and hash(sent) == hash(spec) and sent.config is not cfg
    assert sent.config.sha256 == cfg.sha256

    def no_validation(*args, **kwargs):
        raise AssertionError("the worker validated the configuration again")

    monkeypatch.setattr(config_pkg, "load_config", no_validation)
    monkeypatch.setattr(spec_mod, "_MODELS", {})
    worker = study_model(sent)
    monkeypatch.undo()
    assert model_fingerprint(worker) == model_fingerprint(study_model(study_spec(cfg)))
    # a spec of a JSON text is validated where its model is first built
    again = study_model(StudySpec(spec.config_json, spec.base_dir))
    assert model_fingerprint(again) == model_fingerprint(worker)


def test_config__first_realisation_keeps_one_seed(study_config):
    cfg = load_config(study_config)
    assert cfg.irregularity_seeds == (1, 2)
    first = cfg.first_realisation()
    assert first.irregularity_seeds == (1,) and cfg.irregularity_seeds == (1, 2)
    assert [rid for rid, _ in first.irregularities(0.0, 50.0)] == [1]
    assert first.first_realisation() is first


def test_run_case__equals_simulate(study_config):
    """A case rebuilt from the resolved JSON equals a direct simulate() call."""
    cfg = load_config(study_config)
    spec = study_spec(cfg)
    assert isinstance(spec, StudySpec) and json.loads(spec.config_json) == cfg.resolved()
    model = study_model(spec)
    case = study_grid(model).cases[7]  # 150 km/h, two-cars, seed 2: keeps histories
    ds = run_case(spec, case)
    assert ds.sizes["speed"] == ds.sizes["train"] == ds.sizes["irregularity"] == 1
    assert "deck_displacement" in ds and "time" in ds.dims
    bridge, train = cfg.build_bridge(), cfg.trains()[1]
    profile = dict(cfg.irregularities(*model.x_range))[2]
    ref = simulate(bridge, train, 150.0 / 3.6, profile, cfg.solver_settings(),
                   output_points=cfg.output_points, save_histories=True)
    for name in ENVELOPES:
        # same inputs, same serial kernel: bit-identical
        np.testing.assert_array_equal(ds[name].values[0, 0, 0], ref[name].values)
    np.testing.assert_array_equal(ds["deck_displacement"].values[0, 0, 0],
                                  ref["deck_displacement"].values)


# ------------------------------------------------------------------------------- backends


def test_run_study__processes_and_dask_equal_serial(study_config, serial_result):
    """Envelopes are bit-identical whichever backend ran the cases."""
    d = study_config.parent
    procs = run_study(study_config, d / "processes.nc", workers=2, backend="processes")
    dask = run_study(study_config, d / "dask.nc", workers=2, backend="dask")
    xr.testing.assert_identical(envelopes(serial_result), envelopes(procs))
    xr.testing.assert_identical(envelopes(serial_result), envelopes(dask))
    # and so is everything else but the history line
    xr.testing.assert_identical(serial_result.drop_attrs(), dask.drop_attrs())
    a, b = dict(serial_result.attrs), dict(procs.attrs)
    assert a.pop("history") != "" and b.pop("history") != ""
    assert a == b
    assert not store_path(d / "dask.nc").exists()  # store removed after success


def test_run_study__existing_dask_scheduler(tmp_path, serial_result):
    """--scheduler: an existing cluster runs the cases; a study of one speed gives the
    same envelopes as that speed of the 3-speed study (same realisation per seed)."""
    from dask.distributed import LocalCluster

    config = write_study(tmp_path, speeds=(150.0,))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0",
                      env={"NUMBA_NUM_THREADS": "1"}) as cluster:
        ds = run_study(config, tmp_path / "sched.nc", scheduler=cluster.scheduler_address)
    ref = envelopes(serial_result.isel(speed=[1]))
    xr.testing.assert_identical(ref, envelopes(ds))


# ------------------------------------------------------------------------------- layout


def test_study_file__documented_names_and_attrs(study_config, serial_result):
    path = study_config.parent / "serial.nc"
    with open_results(path) as ds:
        assert dict(ds.sizes) == {"speed": 3, "train": 2, "irregularity": 2, "point": 1,
                                  "wheel": 8, "vehicle": 2, "mode": 2, "deck_x": 33,
                                  "support": 2, "time": ds.sizes["time"]}
        for name in (*ENVELOPES, *HISTORIES, "status", "max_iterations", "message",
                     "static_wheel_load", "max_static_deck_displacement",
                     "train_regular_length", "train_status", "frequency", "wheel_position"):
            assert name in ds.variables, name
        for name, var in ds.variables.items():
            assert "units" in var.attrs and "long_name" in var.attrs, name
        assert ds["speed"].attrs["units"] == "m s-1"
        np.testing.assert_allclose(ds["speed_kmh"], [100.0, 150.0, 200.0], rtol=0, atol=0)
        np.testing.assert_allclose(ds["speed"], ds["speed_kmh"] / 3.6, rtol=1e-15)
        assert ds["train"].values.tolist() == ["one-car", "two-cars"]
        assert ds["irregularity"].values.tolist() == [1, 2]
        assert ds["time"].dtype == np.float64 and ds["time"].attrs["units"] == "s"
        attrs = ds.attrs
        assert attrs["Conventions"] == "CF-1.12"
        assert attrs["title"] == "study test: two small trains on a 10 m span"
        assert attrs["source"].startswith("vsi_numba ") and "numba " in attrs["source"]
        assert attrs["history"][:4].isdigit() and attrs["history"][19] == "Z"
        cfg = load_config(study_config)
        assert attrs["config_json"] == cfg.to_json()
        assert attrs["config_sha256"] == cfg.sha256
        assert attrs["bridge_length"] == 10.0
        assert "simply supported" in attrs["bridge_description"]
        assert "track_type" in attrs
        assert attrs["n_cases"] == 12 and attrs["n_failed_cases"] == 0
        assert (ds["status"] == 0).all()
        assert ds["status"].dtype == np.int32 and ds["max_iterations"].dtype == np.int32
        # the one-car train has 4 wheels and 1 vehicle: the rest is NaN padding
        one = ds.sel(train="one-car")
        assert np.isnan(one["max_contact_force"].isel(wheel=slice(4, None))).all()
        assert np.isfinite(one["max_contact_force"].isel(wheel=slice(0, 4))).all()
        assert np.isnan(one["static_wheel_load"].isel(wheel=slice(4, None))).all()
        assert np.isnan(one["max_carbody_acceleration"].isel(vehicle=1)).all()
        two = ds.sel(train="two-cars")
        assert np.isfinite(two["max_contact_force"]).all()
        # static wheel loads: the weight of one car shared by its 4 wheelsets
        car_weight = (30000.0 + 2 * 2000.0 + 4 * 1500.0) * 9.81
        np.testing.assert_allclose(two["static_wheel_load"].sum(), 2 * car_weight, rtol=1e-9)
        # histories: only at 150 km/h; float32 in the file; time padded with NaN
        hist = ds["deck_displacement"]
        assert np.isnan(hist.isel(speed=0)).all() and np.isnan(hist.isel(speed=2)).all()
        assert np.isfinite(hist.isel(speed=1, time=0)).all()
        enc = hist.encoding
        assert enc["dtype"] == np.float32 and enc["zlib"] and enc["shuffle"]
        assert enc["complevel"] == 4
        assert ds["max_deck_displacement"].encoding["dtype"] == np.float64
        assert "_FillValue" not in ds["status"].encoding or \
            ds["status"].encoding["_FillValue"] is None
        assert ds["frequency"].attrs["units"] == "Hz"
        np.testing.assert_allclose(ds["frequency"], cfg.build_bridge().frequencies, rtol=0)
        # phi'_dyn ingredients: static envelope positive and below the dynamic one
        assert (ds["max_static_deck_displacement"] > 0).all()


# ------------------------------------------------------------------------------- CLI


def test_sweep_command__config_error_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('title = "x"\n[bridge]\nkind = "simply_supported"\nspans = [-3.0]\n')
    assert sweep_command(bad, None, None, None, True) == 2
    err = capsys.readouterr().err
    assert "bridge.spans" in err and "Traceback" not in err


def test_sweep_command__workers_and_scheduler_exclusive(study_config, capsys):
    assert sweep_command(study_config, None, 2, "tcp://127.0.0.1:1", True) == 2
    assert "not both" in capsys.readouterr().err


def test_sweep_command__failed_cases_exit_1(tmp_path, capsys, monkeypatch):
    """A case that fails numerically is flagged (status, NaN, message) and exits 1."""
    # one core available -> the default backend runs in this process (no spawn start-up)
    monkeypatch.setattr(runner, "available_cores", lambda: 1)
    cfg = tmp_path / "fail.toml"
    cfg.write_text(textwrap.dedent("""
        title = "one case fails"
        [bridge]
        kind = "simply_supported"
        spans = [10.0]
        EI = 2.0e9
        mass_per_length = 10000.0
        n_modes = 2
        [[train.vehicles]]
        kind = "sprung_mass"
        mass = 5000.0
        stiffness = 1.0e7
        wheel_mass = 500.0
        [irregularity]
        kind = "cosine"
        depth = -0.001
        wavelength = 0.5
        position = 5.0
        [solver]
        dt = 2e-3
        approach = 1.0
        free_vibration = 0.05
        max_iterations = 1
        max_subdivisions = 0
        [track]
        model = "rigid"
        [study]
        speeds_kmh = [100.0, 300.0]
        save_time_histories = false
    """))
    out = tmp_path / "fail.nc"
    assert sweep_command(cfg, out, None, None, True) == 1
    assert "1 of 2 cases failed numerically" in capsys.readouterr().err
    with open_results(out) as ds:
        assert ds["status"].values.ravel().tolist() == [0, 1]
        assert ds.attrs["n_failed_cases"] == 1
        assert ds.attrs["failed_cases"] == "s0001_t000_i000"
        assert np.isnan(ds["max_deck_displacement"].isel(speed=1)).all()
        assert "did not converge" in str(ds["message"].isel(speed=1).item())
        assert "time" not in ds.dims  # save_time_histories = false


def test_run_study__changed_config_refused(tmp_path):
    """A store left by another configuration is never mixed in (fresh=True discards it)."""
    cfg = write_study(tmp_path, speeds=(150.0,), seeds=(1,))
    out = tmp_path / "s.nc"
    store = store_path(out)
    run_study(cfg, out, backend="serial", keep_cases=True)
    n = len(list(store.glob("batch_*.npz")))
    assert n == 2  # one batch per train (1 speed, 1 realisation)
    changed = write_study(tmp_path, speeds=(150.0,), seeds=(1,), damping=0.03)
    with pytest.raises(StoreMismatchError, match="DIFFERENT configuration"):
        run_study(changed, out, backend="serial")
    assert len(list(store.glob("batch_*.npz"))) == n  # untouched
    ds = run_study(changed, out, backend="serial", fresh=True)
    assert ds.attrs["config_sha256"] == load_config(changed).sha256


def test_run_study__config_from_dict_and_invalid(tmp_path):
    with pytest.raises(ConfigError):
        run_study({"title": "x"}, tmp_path / "x.nc")
    assert not os.listdir(tmp_path)  # nothing created for an invalid config


def test_run_study__a_seed_is_the_same_track_whatever_the_trains(tmp_path):
    """Adding a longer train to a study widens the track range the profiles cover; the
    realisation of a seed must not change (the shorter train's results stay)."""
    both = write_study(tmp_path / "both", speeds=(150.0,))
    text = (tmp_path / "both" / "trains.toml").read_text()
    (tmp_path / "one").mkdir()
    (tmp_path / "one" / "trains.toml").write_text(text.rsplit("[[train]]", 1)[0])
    one = tmp_path / "one" / "study.toml"
    one.write_text(both.read_text())
    with run_study(both, tmp_path / "both.nc", backend="serial") as a, \
            run_study(one, tmp_path / "one.nc", backend="serial") as b:
        assert list(b.train.values) == ["one-car"] and a.sizes["train"] == 2
        for name in ("max_deck_acceleration", "max_wheel_unloading", "min_contact_force"):
            ref = a[name].sel(train="one-car")
            got = b[name].sel(train="one-car").isel(wheel=slice(0, 4)) if "wheel" in \
                ref.dims else b[name].sel(train="one-car")
            ref = ref.isel(wheel=slice(0, 4)) if "wheel" in ref.dims else ref
            # same samples of the same realisation; the two splines differ by round-off
            # (amplified to ~4e-9 by the wheel-on-track resonance of the elastic track;
            # another realisation would differ by O(1))
            np.testing.assert_allclose(got.values, ref.values, rtol=1e-8, err_msg=name)


def test_vsi_run__is_the_sweep_restricted_to_its_first_case(study_config, serial_result,
                                                            tmp_path, capsys):
    """`vsi run` goes through the study engine: its file has the study layout (train and
    irregularity of length one) and every variable equals the sweep's first train on the
    first realisation, bit for bit; no case store is left behind."""
    from vsi_numba.cli.run import run_command

    out = tmp_path / "run.nc"
    assert run_command(study_config, out, quiet=True) == 0
    assert not store_path(out).exists()
    ref = serial_result.isel(train=[0], irregularity=[0])
    with open_results(out) as ds:
        assert dict(ds.sizes)["train"] == 1 and dict(ds.sizes)["irregularity"] == 1
        assert ds["train"].values.tolist() == ref["train"].values.tolist()
        assert ds["irregularity"].values.tolist() == [1]
        assert ds.attrs["history"].split(" ", 1)[1].startswith("vsi run")
        names = set(ENVELOPES) | set(HISTORIES) | {"status", "message", "static_wheel_load",
                                                   "max_static_deck_displacement"}
        for name in sorted(names & set(ds.variables)):
            got, want = ds[name].load(), ref[name].load()
            if "wheel" in got.dims:  # the sweep pads to the longest train's wheels
                want = want.isel(wheel=slice(0, got.sizes["wheel"]))
            if "vehicle" in got.dims:
                want = want.isel(vehicle=slice(0, got.sizes["vehicle"]))
            if "time" in got.dims:
                want = want.isel(time=slice(0, got.sizes["time"]))
            np.testing.assert_array_equal(got.values, want.values, err_msg=name)


def test_run_study__blas_on_one_thread_while_the_batches_run(tmp_path, monkeypatch):
    """The batch threads are the parallelism: while they run, BLAS in this process has
    one thread (OpenBLAS's own, one per core, busy-wait after each small call on the
    cores the batches need), and the caller's setting is back afterwards."""
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads():
        return sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})

    seen = []
    real = runner.run_batch_task

    def spy(*args, **kwargs):
        seen.append(blas_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(runner, "run_batch_task", spy)
    config = write_study(tmp_path, speeds=(150.0, 200.0))
    with threadpool_limits(limits=2, user_api="blas"):
        before = blas_threads()
        run_study(config, tmp_path / "r.nc", workers=2, backend="threads")
        after = blas_threads()
    assert before == [2] and after == before
    assert len(seen) >= 2 and all(s == [1] for s in seen)


def test_study_file__gathered_batches_land_in_their_slices(tmp_path):
    """The envelopes of consecutive batches of one train and realisation are written in
    one slice: whatever the order of the batches (a train or realisation changes, speeds
    that do not follow on, a speed range left out), every value read back is the one
    its batch gave, and what no batch wrote is the fill (NaN, netCDF's int fill, '')."""
    import collections

    import netCDF4

    from vsi_numba.io.schema import DIAGNOSTICS
    from vsi_numba.io.study_file import StudyFile

    n_s, n_t, n_i, n_p, n_w, n_v = 6, 2, 2, 2, 3, 1
    info = {"wheel_position": [[0.0, 2.5, 5.0], [0.0, 3.0, np.nan]],
            "static_wheel_load": [[1e5, 1e5, 1e5], [9e4, 9e4, np.nan]],
            "vehicle_name": [["a"], ["b"]], "regular_length": [10.0, 12.0],
            "status": ["ok", "ok"], "max_static_deck_displacement": np.ones((n_t, n_p))}
    f = StudyFile(tmp_path / "f.nc", 100.0 + 20.0 * np.arange(n_s), ["t0", "t1"], [1, 2],
                  [np.array([2.0, 5.0])], [np.array([3.0, 9.0])], n_w, n_v, None, 1e-3,
                  [info], deck_x=[np.linspace(0.0, 10.0, 4)], supports=[np.array([0.0, 10.0])])
    Batch = collections.namedtuple("Batch", "key variant i_train i_irregularity speeds")
    width = {"point": n_p, "wheel": n_w, "vehicle": n_v, "deck_x": 4, "support": 2}
    rng = np.random.default_rng(7)
    # (train, realisation, speeds): gathered, a train change, a gap, speeds going back
    plan = [(0, 0, (0, 1)), (0, 0, (2, 3)), (1, 0, (0, 1, 2)), (0, 1, (3, 4)),
            (0, 1, (0, 1)), (0, 1, (5,)), (1, 1, (1,)), (1, 1, (2, 3))]
    expect = {}
    for k, (i_t, i_i, speeds) in enumerate(plan):
        n = len(speeds)
        data = {name: rng.standard_normal((n, width[dims[0]]) if dims else n)
                for name, (dims, *_r) in ENVELOPES.items()}
        data.update({name: rng.integers(0, 50, n) for name in DIAGNOSTICS})
        data["message"] = np.array([f"batch {k} run {r}" for r in range(n)])
        f.write_batch(Batch(f"b{k}", None, i_t, i_i, list(speeds)), data,
                      n_w if i_t == 0 else n_w - 1, n_v)
        for r, s in enumerate(speeds):
            expect[(s, i_t, i_i)] = {name: a[r] for name, a in data.items()}
    f.close({"title": "t"})
    with netCDF4.Dataset(tmp_path / "f.nc") as nc:
        nc.set_auto_mask(False)
        got = {name: nc[name][...] for name in (*ENVELOPES, *DIAGNOSTICS, "message")}
        int_fill = netCDF4.default_fillvals["i4"]
    for s in range(n_s):
        for i_t in range(n_t):
            for i_i in range(n_i):
                e = expect.get((s, i_t, i_i))
                for name, a in got.items():
                    v = a[s, i_t, i_i]
                    if e is None:  # no batch wrote this case
                        fill = ("" if name == "message" else int_fill if name in DIAGNOSTICS
                                else np.nan)
                        assert np.all(v == fill) or np.all(np.isnan(v)), (name, s, i_t, i_i)
                        continue
                    want = e[name]
                    if name in ENVELOPES and ENVELOPES[name][0] == ("wheel",) and i_t == 1:
                        # train 1 has 2 wheels: its third column stays NaN
                        np.testing.assert_array_equal(v[:2], want[:2])
                        assert np.isnan(v[2])
                    else:
                        np.testing.assert_array_equal(v, want, err_msg=name)
    assert (2, 0, 1) not in expect and (0, 1, 1) not in expect  # the plan leaves gaps
