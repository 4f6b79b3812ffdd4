"""No data loss and resume: Ctrl-C, SIGTERM, SIGKILL (also during the final write),
changed config, read-only output, full disk.

The sweep runs as a real ``python -m vsi_numba.cli sweep`` subprocess (the default
backend) in its own process group, so the test can interrupt it the way a terminal does
(SIGINT to the group) or kill it outright (SIGKILL).  The numba cache directory
(NUMBA_CACHE_DIR) is inherited by the subprocess.

No test races the machine's speed: the sweep is told (``VSI_STUDY_HOLD_AFTER``) to stop
after a given number of stored batches, or inside the final write, and to announce it
with a ``.held`` file in its store; the signal is sent only then.
"""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import xarray as xr
from study_trains import TRAINS_TOML
from userpath import vsi

from vsi_numba.cli.sweep import sweep_command
from vsi_numba.config import load_config
from vsi_numba.io.netcdf import open_results
from vsi_numba.study.runner import HOLD_ENV, run_study
from vsi_numba.study.store import HISTORY_MEMORY_BUDGET, CaseStore, store_path

SPEEDS = [60.0 + 10.0 * i for i in range(12)]  # 12 speeds x 2 trains x 2 seeds = 48 runs


def write_study(directory: Path, name="study.toml", damping=0.02, histories="first",
                speeds=SPEEDS, seeds=(1, 2), one_train=False) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    trains = TRAINS_TOML.rsplit("[[train]]", 1)[0] if one_train else TRAINS_TOML
    (directory / "trains.toml").write_text(trains)
    if histories == "first":
        histories = f"[{speeds[0]}]"
    hist = "save_time_histories = false" if histories is None else (
        f"save_time_histories = true\nhistory_speeds_kmh = {histories}")
    text = textwrap.dedent(f"""
        title = "resume test"
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
        free_vibration = 0.2
        [study]
        speeds_kmh = {list(speeds)}
        output = "results/study.nc"
    """) + hist + "\n"
    path = directory / name
    path.write_text(text)
    return path


def subprocess_env() -> dict[str, str]:
    """The test's environment (NUMBA_CACHE_DIR included), with Python's bytecode cache
    on (tests/conftest.py): the sweep and each of its spawned workers import numpy,
    xarray, numba and dask, which takes seconds per process when nothing is
    byte-compiled."""
    env = os.environ.copy()
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def start_sweep(config: Path, output: Path, *extra, preexec_fn=None, hold=None,
                write_bytecode: bool = True) -> subprocess.Popen:
    """``python -m vsi_numba.cli sweep`` in a new process group (stderr captured); with
    ``hold``, the sweep stops (and waits to be signalled) after that many stored batches
    (an int) or inside the final write (``"write"``).  ``write_bytecode=False`` for a
    sweep whose writes are made to fail: a byte-compiled module it wrote would be cut
    short and break every later process that shares the bytecode cache."""
    cmd = [sys.executable, "-m", "vsi_numba.cli", "sweep", str(config), "-o", str(output),
           *extra]
    env = subprocess_env()
    if not write_bytecode:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    env.pop(HOLD_ENV, None)
    if hold is not None:
        env[HOLD_ENV] = str(hold)
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, env=env, preexec_fn=preexec_fn)


def batch_files(output: Path) -> list[Path]:
    store = store_path(output)
    return sorted(store.glob("batch_*.npz")) if store.is_dir() else []


def n_stored(output: Path) -> int:
    """Runs in the stored batches (a batch file is named ``batch_tTTT_iIII_sAAAA-BBBB``)."""
    n = 0
    for p in batch_files(output):
        a, b = p.stem.rsplit("_s", 1)[1].split("-")
        n += int(b) - int(a) + 1
    return n


def wait_until_held(proc: subprocess.Popen, output: Path, timeout=600.0) -> None:
    """Wait for the sweep to announce its hold; fail if it ended first."""
    marker = store_path(output) / ".held"
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if marker.exists():
            marker.unlink()
            return
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the sweep ended (rc {proc.returncode}) before it held:\n{err}")
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()
    pytest.fail(f"the sweep did not hold within {timeout} s")


def without_history_line(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` without the attributes of the run rather than of its results: the command
    line and time (``history``) and the directory the configuration was read from
    (``config_directory``: the reference study's config is in a directory of its own)."""
    ds = ds.copy()
    ds.attrs.pop("history")
    ds.attrs.pop("config_directory", None)
    return ds


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted study (computed in this process)."""
    d = tmp_path_factory.mktemp("reference")
    return run_study(write_study(d), d / "reference.nc", backend="serial")


def test_resume__interrupt_and_kill_then_rerun_equals_uninterrupted(tmp_path, reference):
    config = write_study(tmp_path)
    out = tmp_path / "out" / "study.nc"
    total = 48

    # 1. Ctrl-C (SIGINT to the process group, as a terminal does), then 2. SIGTERM,
    #    handled like it: exit 130, the message, one more batch kept each time
    for n_batches, sig in enumerate((signal.SIGINT, signal.SIGTERM), start=1):
        before = n_stored(out)
        proc = start_sweep(config, out, hold=1)
        wait_until_held(proc, out)
        os.killpg(proc.pid, sig)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 130, (sig, err)
        assert "interrupted" in err and "Traceback" not in err
        assert len(batch_files(out)) == n_batches
        assert before < n_stored(out) < total and not out.exists()

    # 3. SIGKILL of the whole group inside the final write (no chance to clean up):
    #    every batch is kept, no results file, a temp file left in the store
    proc = start_sweep(config, out, hold="write")
    wait_until_held(proc, out)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=120)
    assert n_stored(out) == total and not out.exists()
    assert [p for p in store_path(out).iterdir() if p.name.endswith(".tmp")]

    # 4. re-run the same command (in this process: what is tested is the store the
    #    killed process left): nothing left to run; the stale temp file is removed and
    #    the file equals the uninterrupted run's
    done = vsi("sweep", config, "-o", out)
    assert done.returncode == 0, done.stderr
    assert f"{total} runs: all done earlier" in done.stderr
    assert not store_path(out).exists()
    assert not [p for p in out.parent.iterdir() if p.name.endswith(".tmp")]
    with open_results(out) as ds:
        xr.testing.assert_identical(without_history_line(ds.load()),
                                    without_history_line(reference.load()))
        assert "vsi sweep" in ds.attrs["history"]


def test_resume__kill_after_batches_then_rerun_runs_the_rest(tmp_path, reference):
    """SIGKILL with some batches stored: the re-run computes only the missing ones."""
    config = write_study(tmp_path)
    out = tmp_path / "study.nc"
    proc = start_sweep(config, out, hold=3)
    wait_until_held(proc, out)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=120)
    k = n_stored(out)
    assert len(batch_files(out)) == 3 and k < 48 and not out.exists()
    done = vsi("sweep", config, "-o", out)  # in this process: the store is the subject
    assert done.returncode == 0, done.stderr
    assert f"{k} done earlier, {48 - k} to run" in done.stderr
    with open_results(out) as ds:
        xr.testing.assert_identical(without_history_line(ds.load()),
                                    without_history_line(reference.load()))


def test_resume__changed_config_refused_and_store_kept(tmp_path, capsys):
    config = write_study(tmp_path, speeds=SPEEDS[:2])
    out = tmp_path / "study.nc"
    run_study(config, out, backend="serial", keep_cases=True)  # a store as a crash leaves it
    before = sorted(p.name for p in store_path(out).iterdir())
    changed = write_study(tmp_path, name="changed.toml", damping=0.05, speeds=SPEEDS[:2])
    assert sweep_command(changed, out, None, None, True) == 2
    err = capsys.readouterr().err
    assert "DIFFERENT configuration" in err and str(store_path(out)) in err
    assert "-o PATH" in err and "Traceback" not in err
    assert sorted(p.name for p in store_path(out).iterdir()) == before
    # the owner of the store still resumes (nothing left to run: just assembles)
    assert sweep_command(config, out, None, None, True) == 0


def test_resume__store_in_use_refused(tmp_path, capsys):
    """Two runs never write one store: the second is refused while the first holds it."""
    config = write_study(tmp_path, speeds=SPEEDS[:1])
    out = tmp_path / "study.nc"
    cfg = load_config(config)
    holder = CaseStore(store_path(out), cfg.sha256, cfg.to_json()).open()
    try:
        assert sweep_command(config, out, None, None, True) == 2
    finally:
        holder.close()
    assert "another run is using the case store" in capsys.readouterr().err


def _make_read_only(directory: Path):
    """Make ``directory`` unwritable even for root (chattr +i); return the undo."""
    if os.geteuid() != 0:
        directory.chmod(0o555)
        return lambda: directory.chmod(0o755)
    if shutil.which("chattr") is None:
        pytest.skip("running as root without chattr: cannot make a directory read-only")
    r = subprocess.run(["chattr", "+i", str(directory)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"chattr +i not supported here: {r.stderr.decode().strip()}")
    return lambda: subprocess.run(["chattr", "-i", str(directory)], check=True)


def test_resume__read_only_output_dir_clear_error_cases_kept(tmp_path, capsys):
    config = write_study(tmp_path, speeds=SPEEDS[:2])
    outdir = tmp_path / "ro"
    out = outdir / "study.nc"
    run_study(config, out, backend="serial", keep_cases=True)
    out.unlink()
    before = sorted(p.name for p in store_path(out).iterdir())
    undo = _make_read_only(outdir)
    try:
        assert sweep_command(config, out, None, None, True) == 2
    finally:
        undo()
    err = capsys.readouterr().err
    assert f"cannot write the results file in {outdir}" in err and "Traceback" not in err
    assert sorted(p.name for p in store_path(out).iterdir()) == before
    assert not out.exists()


def _file_size_limit(limit: int):
    """preexec_fn: writes beyond ``limit`` bytes fail with EFBIG, as on a full disk."""

    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of a fatal signal
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_resume__full_disk_clear_error_cases_kept(tmp_path):
    """Writes that fail for lack of space (simulated with RLIMIT_FSIZE, which makes a
    write past the limit fail like a full disk) -> exit 1, a clear message, cases kept."""
    # a single case: the sweep runs it in-process (no worker start-up to wait for)
    config = write_study(tmp_path, speeds=SPEEDS[:1], seeds=(1,), one_train=True,
                         histories=None)
    out = tmp_path / "study.nc"
    # the kernels this model needs are compiled (cached) here, not under the size limit
    run_study(config, out, backend="serial", keep_cases=True)
    out.unlink()
    size = max(p.stat().st_size for p in store_path(out).glob("batch_*.npz"))
    # 1. room for the case files but not for the final file: every case is kept
    proc = start_sweep(config, out, "--quiet", preexec_fn=_file_size_limit(size + 1024),
                       write_bytecode=False)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 1, err
    assert f"cannot write {out}" in err and "re-run the same command" in err
    assert "Traceback" not in err
    assert n_stored(out) == 1 and not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    # 2. no room for even one case file (the store manifest, ~1 KiB, still fits)
    other = tmp_path / "other.nc"
    proc = start_sweep(config, other, "--quiet", preexec_fn=_file_size_limit(size // 2),
                       write_bytecode=False)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 1, err
    assert "cannot write" in err and "batch_t" in err and "re-run the same command" in err
    assert "Traceback" not in err and n_stored(other) == 0
    # 3. with room again the same command (in this process) completes from the stored
    #    cases
    done = vsi("sweep", config, "-o", out)
    assert done.returncode == 0, done.stderr
    assert "all done earlier" in done.stderr and out.exists()


def test_store__final_write_reads_batches_of_this_process_from_memory(tmp_path):
    """A batch the store wrote is loaded once from its copy in memory - equal to its
    file, unaffected by later changes of the caller's arrays - then from the file;
    batches with time histories are kept up to their own budget, the others come from
    their files."""
    import numpy as np

    store = CaseStore(tmp_path / "s.cases", "0" * 64, "{}").open()
    try:
        env = {"status": np.array([0, 3], np.int32), "message": np.array(["", "diverged"]),
               "kernel_seconds": np.float64(0.25), "deck_acceleration": np.arange(6.0)}
        key = "t000_i000_s0000-0002"
        store.write(key, env)
        expected = {k: np.array(v, copy=True) for k, v in env.items()}
        env["deck_acceleration"][:] = -1.0  # the caller reuses its arrays
        with np.load(store.batch_path(key), allow_pickle=False) as z:
            on_disk = {k: z[k] for k in z.files}
        first = store.load(key)
        assert store._memory_bytes == 0 and not store._memory
        again = store.load(key)  # now from the file
        for got in (first, again):
            assert sorted(got) == sorted(on_disk) == sorted([*expected, "batch_key"])
            for k, v in on_disk.items():
                assert got[k].dtype == v.dtype and got[k].shape == v.shape
                np.testing.assert_array_equal(got[k], v)
            for k, v in expected.items():
                np.testing.assert_array_equal(got[k], v)
        # time histories: in memory up to their own budget, then from their files
        hist = {**expected, "hist_runs": np.array([0]), "deflection": np.zeros((1, 5, 2))}
        store.write("t000_i001_s0000-0002", hist)
        assert list(store._memory) == ["t000_i001_s0000-0002"]
        n_big = HISTORY_MEMORY_BUDGET // 8 - 10
        big = {**hist, "deflection": np.ones((1, n_big, 1))}
        store.write("t000_i002_s0000-0002", big)  # over the history budget: not kept
        assert list(store._memory) == ["t000_i001_s0000-0002"]
        assert store._memory_history_bytes == store._memory_bytes > 0
        for key, want in (("t000_i001_s0000-0002", hist), ("t000_i002_s0000-0002", big)):
            got = store.load(key)
            assert sorted(got) == sorted([*want, "batch_key"])
            for k, v in want.items():
                np.testing.assert_array_equal(got[k], v)
        assert store._memory_bytes == store._memory_history_bytes == 0 and not store._memory
    finally:
        store.close()


def test_rerun__a_written_study_is_not_recomputed_unless_fresh_or_changed(tmp_path,
                                                                          monkeypatch):
    """The same ``vsi sweep`` on a study it wrote leaves the file as it is and says so
    (the governing results still printed); ``--fresh`` recomputes it, and so does a
    change the configuration's text does not show (the trains file it names) or another
    version of the code."""
    config = write_study(tmp_path, speeds=SPEEDS[:2], seeds=(1,), one_train=True)
    out = tmp_path / "study.nc"

    def sweep(*extra):
        done = vsi("sweep", config, "-o", out, *extra)
        assert done.returncode == 0, done.stderr
        with open_results(out) as ds:
            return done, ds.attrs["history"]

    first, history = sweep()
    assert "2 to run" in first.stderr
    data = out.read_bytes()
    again, same = sweep()
    assert "nothing recomputed (--fresh recomputes them)" in again.stderr
    assert "to run" not in again.stderr and same == history and out.read_bytes() == data
    assert again.stdout == first.stdout and "governing results" in again.stdout
    fresh, new = sweep("--fresh")
    assert "2 to run" in fresh.stderr and new != history
    # the trains file changes, the configuration's text does not: recomputed
    trains = tmp_path / "trains.toml"
    trains.write_text(trains.read_text().replace("body_mass = 30000.0", "body_mass = 31000.0"))
    changed, _ = sweep()
    assert "2 to run" in changed.stderr
    # another version of the code (its sources' hash): recomputed
    import vsi_numba._jit as jit

    monkeypatch.setattr(jit, "package_hash", lambda directory: "0" * 64)
    other, _ = sweep()
    assert "2 to run" in other.stderr
    assert "nothing recomputed" in sweep()[0].stderr
