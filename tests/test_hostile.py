"""Hostile input: silently wrong results, implausible or huge input, CLI and report edges.

Each test fails on the code before the fix: a coarse time step passed as "pass", inf
outputs with status ok, MemoryError/RecursionError instead of a config error, rich
markup printed literally or crashing on a path, the input overwritten by its output,
an all-failed file reported as "x = nan".
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.config import ConfigError, load_config

# a 25 m beam: f1 = 4.78 Hz, 3 modes up to 43 Hz
BASE = {
    "title": "hostile",
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
               "mass_per_length": 2303.0, "n_modes": 1},
    "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6}]},
    "solver": {"dt": 2e-3, "free_vibration": 0.1},
    "study": {"speeds_kmh": [100.0], "output": "out.nc"},
}


def cfg(**changes) -> dict:
    """BASE with ``section.key`` (dots) set; a value of ... deletes the key."""
    data = copy.deepcopy(BASE)
    for path, value in changes.items():
        *head, last = path.split("__")
        node = data
        for k in head:
            node = node.setdefault(k, {})
        if value is ...:
            node.pop(last, None)
        else:
            node[last] = value
    return data


def errors_of(data, **kw) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(data, **kw)
    return info.value.errors


def to_toml(data: dict) -> str:
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_config_fuzz import to_toml as write

    return write(data)


@pytest.fixture
def runner():
    return CliRunner()


# ------------------------------------------------------------------ time step resolution


def test_hostile__coarse_dt_is_an_error_naming_the_override():
    errs = errors_of(cfg(solver__dt=0.5))  # the deck (4.78 Hz) and the vehicle (2.65 Hz)
    assert len(errs) == 2 and "vehicle frequency" in errs[1]
    assert errs[0].startswith("solver.dt = 0.5: expected a time step giving at least 4 steps")
    assert "solver.allow_coarse_dt = true" in errs[0]
    c = load_config(cfg(solver__dt=0.5, solver__allow_coarse_dt=True))
    kinds = {r["kind"] for r in c.warning_records}
    assert "resolution" in kinds
    assert c.solver_settings().dt == 0.5  # the override is not a solver setting


def test_hostile__override_keys_stay_out_of_hints_and_hash():
    plain = load_config(cfg())
    assert "allow_coarse_dt" not in plain.to_json()
    errs = errors_of(cfg(solver__zzz=1))
    assert "allow_" not in errs[0]
    errs = errors_of(cfg(solver__allow_coarse_dt="yes"))
    assert errs == ['solver.allow_coarse_dt = "yes": expected true or false']


def test_hostile__warnings_travel_with_the_results_and_checks_are_not_reliable(
        tmp_path, runner, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # dt x f1 = 0.06 x 4.78 = 0.29: accepted only with the override
    data = cfg(solver__dt=0.06, solver__allow_coarse_dt=True)
    (tmp_path / "c.toml").write_text(to_toml(data))
    res = runner.invoke(app, ["run", "c.toml", "-o", "run.nc", "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        recs = json.loads(ds.attrs["warnings_json"])
        assert any(r["kind"] == "resolution" for r in recs)
        assert "under-resolved" in ds.attrs["config_warnings"]
    res = runner.invoke(app, ["report", "run.nc", "-o", "rep"])
    assert res.exit_code == 0, res.output
    table = (tmp_path / "rep" / "summary.csv").read_text()
    assert ",pass," not in table and "not reliable" in table
    md = (tmp_path / "rep" / "report.md").read_text()
    assert md.index("## Warnings of the configuration") < md.index("## Summary of checks")
    # a sweep file carries them too
    res = runner.invoke(app, ["sweep", "c.toml", "-o", "sweep.nc", "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "sweep.nc") as ds:
        assert any(r["kind"] == "resolution" for r in json.loads(ds.attrs["warnings_json"]))


# ------------------------------------------------------------------ non-finite outputs


def test_hostile__huge_force_is_non_finite_state_not_ok():
    import vsi_numba as vsi
    from vsi_numba.model import bridge, vehicle
    from vsi_numba.solver.settings import SolverSettings

    beam = bridge.simply_supported(25.0, EI=8.323e9, mass_per_length=2303.0, n_modes=1)
    train = vehicle.Train("huge", (vehicle.moving_force(1e300),), (0.0,))
    ds = vsi.simulate(beam, train, speed=100 / 3.6,
                      settings=SolverSettings(dt=2e-3, free_vibration=0.1))
    assert ds.attrs["status"] == 3
    assert ds.attrs["message"].startswith("non-finite")


# ------------------------------------------------------------------ plausibility


def test_hostile__implausible_input_is_refused_naming_keys_and_override():
    force = {"vehicles": [{"kind": "force", "load": 1e300}]}
    errs = errors_of(cfg(train=force))
    assert "static deflection" in errs[0] and "bridge.EI" in errs[0]
    assert "solver.allow_implausible = true" in errs[0]
    errs = errors_of(cfg(contact={"model": "hertz", "hertz_coefficient": 1e-3}))
    assert any("Hertz penetration" in e and "contact.hertz_coefficient" in e for e in errs)
    user = {"vehicles": [{"kind": "user", "M": [[1000.0, 0.0], [0.0, 50.0]],
                          "C": [[0.0, 0.0], [0.0, 0.0]],
                          "K": [[1e6, 2e6], [2e6, 1e6]], "wheel_dofs": [1],
                          "wheel_positions": [0.0], "body_dof": 0,
                          "gravity": [9810.0, 490.5]}]}
    errs = errors_of(cfg(train=user))
    assert any("not positive semi-definite" in e for e in errs)
    dip = {"kind": "cosine", "depth": 0.2, "wavelength": 5.0, "position": 5.0}
    errs = errors_of(cfg(irregularity=dip))
    assert errs[0].startswith("irregularity.depth: |r| = 0.2 m")
    ok = load_config(cfg(irregularity=dip, solver__allow_implausible=True))
    assert any("more than 50 mm" in w for w in ok.warnings)


def test_hostile__line_speed_next_to_speeds_sets_the_en_range():
    c = load_config(cfg(study__line_speed_kmh=300.0))  # speeds stop below 360 km/h
    assert c.speeds_kmh.max() < 360.0
    assert any("below the EN range up to 1.2 x study.line_speed_kmh = 360 km/h" in w
               for w in c.warnings), c.warnings
    # the resolved config of a line-speed study keeps both keys, and reloads
    c = load_config(cfg(study__speeds_kmh=..., study__line_speed_kmh=160.0))
    assert load_config(c.resolved()).speeds_kmh.tolist() == c.speeds_kmh.tolist()


# ------------------------------------------------------------------ sizes and parsing


@pytest.mark.parametrize("changes, key", [
    ({"train": {"vehicles": [{"kind": "force", "load": 1e5},
                             {"kind": "force", "load": 1e5, "offset": 1e12}]}},
     "time steps"),
    ({"solver__free_vibration": 1e6}, "time steps"),
    ({"study__speeds_kmh": [1e-6]}, "time steps"),
    ({"irregularity": {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
                       "wavelength_max": 1e6, "seeds": [1]}}, "samples"),
    ({"irregularity": {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
                       "wavelength_max": 60.0, "dx": 1e-7, "seeds": [1]}}, "samples"),
])
def test_hostile__huge_sizes_are_refused_before_allocating(changes, key):
    errs = errors_of(cfg(**{k: v for k, v in changes.items()}))
    assert any(key in e and "budget" in e and "solver.allow_large_problem" in e
               for e in errs), errs


def test_hostile__profile_file_with_tiny_spacing(tmp_path):
    x = np.concatenate([np.arange(-60.0, 80.0, 1.0), [79.0 + 1e-9]])
    x.sort()
    lines = "x,r\n" + "\n".join(f"{v:.12f},0.0" for v in x)
    (tmp_path / "p.csv").write_text(lines)
    errs = errors_of(cfg(irregularity={"kind": "file", "path": "p.csv"}), base_dir=tmp_path)
    assert errs[0].startswith('irregularity.path = "p.csv": expected a readable profile')
    assert "budget" in errs[0] and "irregularity.dx" in errs[0]


def test_hostile__deep_nesting_and_huge_integers(tmp_path):
    deep = tmp_path / "deep.toml"
    deep.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    errs = errors_of(deep)
    assert "nested too deeply" in errs[0]
    big = tmp_path / "big.toml"
    big.write_text("x = " + "9" * 5000 + "\n")
    errs = errors_of(big)
    assert "value not readable" in errs[0]


# ------------------------------------------------------------------ CLI


def test_hostile__run_prints_errors_without_literal_markup(tmp_path, runner, monkeypatch):
    import vsi_numba.cli.run as run_mod

    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_text(to_toml(cfg()))

    def boom(*a, **k):
        raise ValueError("bad value [x]")

    monkeypatch.setattr(run_mod, "run_config", boom)
    res = runner.invoke(app, ["run", "c.toml", "-o", "o.nc"])
    assert res.exit_code == 2
    assert "[bold red]" not in res.output and "error: bad value [x]" in res.output


def test_hostile__paths_with_brackets_print_literally(tmp_path, runner):
    d = tmp_path / "a["  # the path holds "[/]": rich markup would raise MarkupError
    d.mkdir()
    bad = d / "]x[red].toml"
    bad.write_text("title = 1\n")
    res = runner.invoke(app, ["run", str(bad)])
    assert res.exit_code == 2, repr(res.exception)
    first = " ".join(res.output.split("invalid configuration")[0].split())
    assert first == f"error: {bad}:"


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_hostile__output_may_not_be_the_input(tmp_path, runner, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    text = to_toml(cfg())
    (tmp_path / "c.toml").write_text(text)
    res = runner.invoke(app, [command, "c.toml", "-o", "c.toml"])
    assert res.exit_code == 2
    assert "refusing to overwrite the input" in " ".join(res.output.split())
    assert (tmp_path / "c.toml").read_text() == text
    assert not (tmp_path / "c.toml.cases").exists()


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_hostile__unwritable_output_checked_before_computing(tmp_path, runner, monkeypatch,
                                                               command):
    import vsi_numba.cli.run as run_mod
    import vsi_numba.study.runner as study_mod

    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_text(to_toml(cfg()))
    (tmp_path / "file").write_text("a file, not a directory")

    def never(*a, **k):
        raise AssertionError("computed before checking the output")

    monkeypatch.setattr(run_mod, "run_config", never)
    monkeypatch.setattr(study_mod, "execute_study", never)
    res = runner.invoke(app, [command, "c.toml", "-o", str(tmp_path / "file" / "o.nc")])
    assert res.exit_code == 2, res.output
    assert "cannot write the results file" in " ".join(res.output.split())


@pytest.mark.parametrize("option", [["--workers", "0"], ["--workers", "-1"],
                                    ["--scheduler", "notaurl"]])
def test_hostile__bad_sweep_options(tmp_path, runner, monkeypatch, option):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_text(to_toml(cfg()))
    res = runner.invoke(app, ["sweep", "c.toml", "-o", "o.nc", *option])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {option[0]}"), res.output
    assert not (tmp_path / "o.nc.cases").exists()


# ------------------------------------------------------------------ report


def test_hostile__report_single_case_and_all_failed(tmp_path, runner, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_text(to_toml(cfg()))
    res = runner.invoke(app, ["sweep", "c.toml", "-o", "one.nc", "-q"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["report", "one.nc", "-o", "rep"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "one.nc") as ds:
        bad = ds.load()
    bad["status"][...] = 3
    for name in ("max_deck_displacement", "max_deck_acceleration", "min_contact_force"):
        bad[name][...] = np.nan
    bad.to_netcdf(tmp_path / "failed.nc")
    res = runner.invoke(app, ["report", "failed.nc", "-o", "rep2"])
    assert res.exit_code == 1
    assert "every case (1) failed numerically" in res.output
    assert not (tmp_path / "rep2" / "report.md").exists()


def test_hostile__utf8_bom_is_named(tmp_path):
    """A byte-order mark is named as such, not "Invalid statement (line 1, column 1)"."""
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + to_toml(BASE).encode())
    with pytest.raises(ConfigError, match="byte-order mark"):
        load_config(path)


def test_hostile__tiny_span_blames_the_span_not_ei():
    msgs = errors_of(cfg(bridge__spans=[1e-6]))
    assert any(m.startswith("bridge.spans") for m in msgs), msgs
    assert not any(m.startswith("bridge.EI") for m in msgs), msgs


@pytest.mark.parametrize("levels", [15, 30])
def test_hostile__max_subdivisions_up_to_30_run(levels):
    """dt / 2^30 next to a massless contact point is badly scaled, not singular: every
    documented max_subdivisions runs (the sprung mass crosses the beam normally)."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh
    from vsi_numba.solver.settings import SolverSettings
    from vsi_numba.solver.simulate import simulate

    beam = br.simply_supported(10.0, 2e9, 1e4, n_modes=2)
    train = vh.Train("sm", (vh.sprung_mass(5000.0, 1e7, 1e4, 0.0),), (0.0,))
    s = SolverSettings(dt=2e-3, approach=1.0, free_vibration=0.0, max_subdivisions=levels)
    ds = simulate(beam, train, 30.0, settings=s, save_histories=False)
    assert ds.attrs["status"] == 0, ds.attrs["message"]


def test_hostile__unreachable_scheduler_leaves_no_store(tmp_path, monkeypatch):
    """A study that stored nothing (here: the scheduler cannot be reached) removes the
    store it created."""
    from vsi_numba.study import cluster
    from vsi_numba.study.runner import run_study
    from vsi_numba.study.store import store_path

    def refuse(self):
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:9")

    monkeypatch.setattr(cluster.DaskBackend, "__enter__", refuse)
    out = tmp_path / "out.nc"
    with pytest.raises(OSError, match="Timed out"):
        run_study(cfg(), out, scheduler="tcp://127.0.0.1:9")
    assert not store_path(out).exists() and not out.exists()


def _two_train_study(tmp_path):
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_study import write_study

    return write_study(tmp_path, speeds=(100.0, 150.0), history=(150.0,))  # 4 batches


def test_hostile__damaged_or_swapped_batch_found_before_running(tmp_path):
    """A damaged or swapped stored batch is named before any missing batch runs (the
    missing one is still missing afterwards), never a traceback at the end."""
    from vsi_numba.study.runner import run_study
    from vsi_numba.study.store import CorruptBatchError, store_path

    config = _two_train_study(tmp_path)
    out = tmp_path / "s.nc"
    run_study(config, out, backend="serial", keep_cases=True).close()
    out.unlink()
    files = sorted(store_path(out).glob("batch_*.npz"))
    assert len(files) == 4
    files[0].unlink()  # a batch to run again
    files[1].write_bytes(files[1].read_bytes()[:100])  # damaged
    with pytest.raises(CorruptBatchError, match=files[1].name):
        run_study(config, out, backend="serial")
    assert not files[0].exists() and not out.exists()  # found before running anything
    files[1].unlink()
    files[2].write_bytes(files[3].read_bytes())  # another batch under this name
    with pytest.raises(CorruptBatchError, match="holds batch"):
        run_study(config, out, backend="serial")


def test_hostile__process_pool_workers_die_with_the_sweep(tmp_path):
    """SIGKILL of a sweep running on a process pool leaves no worker alive (they die with
    their parent: PR_SET_PDEATHSIG); checked within 15 s, polled."""
    import os
    import subprocess
    import sys
    import time

    from vsi_numba.study.runner import HOLD_ENV
    from vsi_numba.study.store import store_path

    config = _two_train_study(tmp_path)
    out = tmp_path / "p.nc"
    code = ("from vsi_numba.study.runner import execute_study\n"
            "if __name__ == '__main__':\n"
            f"    execute_study({str(config)!r}, {str(out)!r}, workers=2, "
            "backend='processes')\n")
    script = tmp_path / "sweep.py"
    script.write_text(code)
    env = dict(os.environ, **{HOLD_ENV: "1"})
    proc = subprocess.Popen([sys.executable, str(script)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    marker = store_path(out) / ".held"
    t0 = time.monotonic()
    while not marker.exists():
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() - t0 < 600, "the sweep did not hold"
        time.sleep(0.05)

    def children(pid):
        kids = []
        for d in Path("/proc").iterdir():
            if d.name.isdigit():
                try:
                    stat = (d / "stat").read_text()
                except OSError:
                    continue
                if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                    kids.append(int(d.name))
        return kids

    workers = children(proc.pid)
    assert workers, "the process pool has no worker"
    proc.kill()
    proc.wait()
    proc.stderr.close()
    t0 = time.monotonic()

    def running(pid):  # exists and is not a zombie waiting for its reaper
        try:
            return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
        except OSError:
            return False

    alive = workers
    while alive and time.monotonic() - t0 < 15.0:
        time.sleep(0.1)
        alive = [w for w in workers if running(w)]
    assert not alive, f"workers still alive 15 s after the sweep was killed: {alive}"


@pytest.mark.parametrize("name, changes, key", [
    ("1e30 kg car body", {"train": {"vehicles": [{"kind": "sprung_mass", "mass": 1e30,
                                                  "stiffness": 1.595e6}]}}, "static deflection"),
    ("1e9 kg wheel", {"train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0,
                                              "stiffness": 1.595e6, "wheel_mass": 1e9}]}},
     "static deflection"),
    ("1.3 km train on a 1 km bridge", {"bridge__spans": [1000.0], "train": {"vehicles": [
        {"kind": "force", "load": 2e5, "offset": 10.0 * i} for i in range(130)]}},
     "static deflection"),
    ("dt = 1e-9", {"solver__dt": 1e-9}, "solver.dt"),
    ("EI = 1e-300", {"bridge__EI": 1e-300}, "static deflection"),
    ("a massless deck", {"bridge__mass_per_length": 1e-3}, "solver.dt"),
    ("1000 stacked dips", {"irregularity": {"kind": "none", "defects": [
        {"kind": "cosine", "depth": 0.0009, "wavelength": 3.0, "position": 5.0}] * 1000}},
     "irregularity.defects (added up): |r| = 0.9 m"),
])
def test_hostile__absurd_models_are_refused_with_their_cause(name, changes, key):
    """Each was accepted without a word (or failed with a misleading "singular effective
    stiffness"); now a config error names the cause and the override."""
    msgs = errors_of(cfg(**changes))
    assert any(key in m for m in msgs), (name, msgs)
    assert not any("singular" in m for m in msgs), (name, msgs)


def test_hostile__store_lock_is_released_last(tmp_path, monkeypatch):
    """While the store is removed its lock stays held, and the store has left its name
    (renamed to its tombstone) before anything is deleted: a second run cannot adopt a
    store that is half gone."""
    import fcntl
    import os
    import shutil

    from vsi_numba.study.store import CaseStore, tombstone_path

    store = CaseStore(tmp_path / "s.cases", "abc", "{}").open()
    store.write("t000_i000_s0000-0000", {"status": np.zeros(1, np.int32)})
    original = shutil.rmtree
    seen = []

    def probe_then_rmtree(path, *args, **kwargs):
        if Path(path) == tombstone_path(store.path) and not seen:
            assert not store.path.exists()
            fd = os.open(Path(path) / ".lock", os.O_RDWR)
            try:
                with pytest.raises(BlockingIOError):
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                seen.append("locked")
            finally:
                os.close(fd)
        return original(path, *args, **kwargs)

    monkeypatch.setattr(shutil, "rmtree", probe_then_rmtree)
    store.remove()
    assert seen == ["locked"] and not store.path.exists()
    assert not tombstone_path(store.path).exists()


def test_hostile__dask_keeps_its_scratch_space_out_of_the_temp_dir(tmp_path, monkeypatch):
    """A Dask study leaves nothing in the system temp directory (scratch space, if any,
    lives in the store and goes with it)."""
    import tempfile

    from vsi_numba.study.runner import run_study

    tmp = tmp_path / "systemp"
    tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    run_study(cfg(), tmp_path / "d.nc", workers=2).close()
    assert sorted(p.name for p in tmp.iterdir()) == []
    assert not (tmp_path / "d.nc.cases").exists()


def test_hostile__dask_sweep_interrupted_cleanly(tmp_path):
    """Ctrl-C of a `--workers 2` (Dask) sweep: exit 130, the message, no traceback (no
    "IOLoop is closed"); deterministic: the signal is sent while the sweep holds."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from vsi_numba.study.runner import HOLD_ENV
    from vsi_numba.study.store import store_path

    config = _two_train_study(tmp_path)
    out = tmp_path / "k.nc"
    env = dict(os.environ, **{HOLD_ENV: "1"})
    proc = subprocess.Popen([sys.executable, "-m", "vsi_numba.cli", "sweep", str(config),
                             "-o", str(out), "--workers", "2"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    marker = store_path(out) / ".held"
    t0 = time.monotonic()
    while not marker.exists():
        if proc.poll() is not None:
            pytest.fail(proc.communicate()[1])
        assert time.monotonic() - t0 < 600, "the sweep did not hold"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err and "IOLoop" not in err


def test_hostile__dask_backend_keeps_distributed_quiet_after_an_interrupt():
    """distributed logs at INFO to stderr (with tracebacks, e.g. "Batched Comm Closed")
    once its LocalCluster has closed; an interrupted sweep's comms close late, so the
    Dask backend holds the "distributed" logger at WARNING while in use and leaves it
    there after an interrupt (the race the Ctrl-C test above can hit on a loaded
    machine); a study that ends normally gets the caller's level back."""
    import logging

    from vsi_numba.study.cluster import DaskBackend

    log = logging.getLogger("distributed")
    before = log.level
    try:
        log.setLevel(logging.INFO)
        with DaskBackend(1):
            assert log.getEffectiveLevel() >= logging.WARNING
        assert log.level == logging.INFO
        with pytest.raises(KeyboardInterrupt), DaskBackend(1):
            raise KeyboardInterrupt
        assert log.level == logging.WARNING
    finally:
        log.setLevel(before)


@pytest.mark.parametrize("dt", [5e-3, 20e-3])
def test_hostile__hertz_at_a_coarse_dt_is_flagged_as_a_resolution_warning(dt):
    """ICE3 with Hertz contact at dt = 5 or 20 ms ran to "pass", status ok: now the Hertz
    spring's under-resolution is a resolution warning (the report marks every check
    "not reliable"), naming solver.dt and contact.hertz_coefficient."""
    c = load_config(cfg(train={"preset": "ICE3"}, solver__dt=dt,
                        contact={"model": "hertz", "hertz_coefficient": 3e-8}))
    hertz = [r for r in c.warning_records if "Hertz contact spring" in r["message"]]
    assert hertz and hertz[0]["kind"] == "resolution"
    assert {"solver.dt", "contact.hertz_coefficient"} <= set(hertz[0]["keys"])
