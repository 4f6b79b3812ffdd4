"""Files at the edges of a study: no input overwritten, nothing lost while cleaning up.

* the output is refused before any computation when it is a file the configuration
  reads (the configuration, a profile CSV, a modes file, a user train file, also
  through a symbolic or hard link), a directory, a device or a FIFO;
* the case store is removed by an atomic rename to a tombstone, then deleted: a kill
  at any step leaves either the whole store (resumable) or a tombstone that the next
  run deletes; ``--fresh`` deletes the manifest last;
* ``vsi run`` and ``vsi sweep`` on one output keep separate stores;
* process-pool workers die with a parent killed while they start, and the resource
  tracker and the pool's semaphores go with them;
* output names too long for the file system are refused clearly, a legal long name
  works (the store name is shortened with a hash);
* the disk need is estimated before a study starts (refused when it cannot fit);
* a failed final write says what happened, to which file, the space needed and free,
  and that the finished batches are kept.

No test races the machine: kills are sent from inside the process at a known step.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import psutil
import pytest
from study_trains import TRAINS_TOML

from vsi_numba.cli.run import run_command
from vsi_numba.cli.sweep import sweep_command
from vsi_numba.config import load_config
from vsi_numba.study import store as store_mod
from vsi_numba.study.runner import execute_study
from vsi_numba.study.store import MANIFEST, CaseStore, OutputNotWritableError, store_path

REPO = Path(__file__).resolve().parents[1]


def write_case(directory: Path, speeds=(100.0, 150.0), histories=True) -> Path:
    """A small study naming two input files: a user train file and a profile CSV."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "trains.toml").write_text(TRAINS_TOML.rsplit("[[train]]", 1)[0])
    x = np.arange(-100.0, 200.0, 0.25)
    r = 1e-3 * np.sin(2 * np.pi * x / 7.0)
    (directory / "profile.csv").write_text(
        "x,r\n" + "\n".join(f"{a:.3f},{b:.6e}" for a, b in zip(x, r, strict=True)) + "\n")
    hist = (f"save_time_histories = true\nhistory_speeds_kmh = [{speeds[0]}]" if histories
            else "save_time_histories = false")
    path = directory / "case.toml"
    path.write_text(textwrap.dedent(f"""
        title = "file edges"
        [bridge]
        kind = "simply_supported"
        spans = [10.0]
        EI = 2.0e9
        mass_per_length = 10000.0
        damping_ratio = 0.02
        n_modes = 2
        [train]
        file = "trains.toml"
        [irregularity]
        kind = "file"
        path = "profile.csv"
        [solver]
        dt = 2e-3
        free_vibration = 0.1
        [study]
        speeds_kmh = {list(speeds)}
        output = "results/case.nc"
    """) + hist + "\n")
    return path


def digest(path: Path) -> bytes:
    return path.read_bytes()


# ------------------------------------------------------------------ 8: outputs that are inputs


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("target", ["trains.toml", "profile.csv", "case.toml",
                                    "link-to-profile.csv", "hardlink-to-trains.toml"])
def test_edges__output_that_is_an_input_is_refused(tmp_path, capsys, command, target):
    """Every file the configuration reads (also through a symbolic or a hard link) is
    refused as the output before anything runs, and is left byte for byte as it was."""
    config = write_case(tmp_path)
    (tmp_path / "link-to-profile.csv").symlink_to(tmp_path / "profile.csv")
    os.link(tmp_path / "trains.toml", tmp_path / "hardlink-to-trains.toml")
    inputs = {p: digest(p) for p in tmp_path.iterdir() if p.is_file()}
    out = tmp_path / target
    if command == "run":
        code = run_command(config, out, quiet=True)
    else:
        code = sweep_command(config, out, None, None, quiet=True)
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2, err
    assert "an input of this configuration" in err and "refusing to overwrite" in err, err
    assert "Traceback" not in err
    assert {p: digest(p) for p in inputs} == inputs
    assert (tmp_path / "link-to-profile.csv").is_symlink()
    assert not store_path(out).exists() and not store_path(out, "run").exists()


def test_edges__modes_file_output_refused(tmp_path, capsys):
    """The netCDF modes table of ``kind = "modes_file"`` is an input too."""
    shutil.copytree(REPO / "configs" / "data", tmp_path / "data")
    config = tmp_path / "modes.toml"
    config.write_text((REPO / "configs" / "two_span_modes_file.toml").read_text())
    modes = tmp_path / "data" / "two_span_modes.nc"
    before = digest(modes)
    assert run_command(config, modes, quiet=True) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "bridge.file" in err and "refusing to overwrite" in err, err
    assert digest(modes) == before


def test_edges__library_refuses_an_input_as_output(tmp_path):
    """``execute_study`` (the library entry) refuses the same outputs as the CLI."""
    config = write_case(tmp_path)
    before = digest(tmp_path / "profile.csv")
    with pytest.raises(OutputNotWritableError, match="irregularity.path"):
        execute_study(load_config(config), tmp_path / "profile.csv")
    assert digest(tmp_path / "profile.csv") == before


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_edges__device_fifo_directory_outputs_refused(tmp_path, capsys, command):
    """/dev/null (a character device, still one afterwards), a FIFO (no hang, still a
    FIFO) and a directory are refused with what they are."""
    config = write_case(tmp_path)
    fifo = tmp_path / "pipe.nc"
    os.mkfifo(fifo)
    folder = tmp_path / "folder.nc"
    folder.mkdir()
    null_mode = os.stat("/dev/null").st_mode
    for out, what in ((Path("/dev/null"), "a character device"),
                      (fifo, "a FIFO"), (folder, "a directory")):
        if command == "run":
            code = run_command(config, out, quiet=True)
        else:
            code = sweep_command(config, out, None, None, quiet=True)
        err = " ".join(capsys.readouterr().err.split())
        assert code == 2, (out, err)
        assert f"{out} is {what}" in err and "Traceback" not in err, err
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert os.stat("/dev/null").st_mode == null_mode
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and folder.is_dir()
    assert not list(folder.iterdir())
    assert not Path("/dev/null.cases").exists() and not Path("/dev/null.run-cases").exists()


# ------------------------------------------------------------------ 9: kill-safe removal


def make_store(directory: Path, n_batches=3) -> CaseStore:
    st = CaseStore(directory / "o.nc.cases", "sha-a", "{}").open()
    for k in range(n_batches):
        st.write(f"t000_i000_s{k:04d}-{k:04d}", {"status": np.zeros(1, np.int32)})
    return st


class _Killed(BaseException):
    """Stands for a kill: nothing after it runs (no cleanup handler sees an Exception)."""


def _fs_calls(monkeypatch, kill_at: int | None):
    """Count the file-system changes (unlink, rmdir, rename, replace); raise
    :class:`_Killed` at the ``kill_at``-th one (1-based) before it happens."""
    count = [0]
    for name in ("unlink", "rmdir", "rename", "replace"):
        real = getattr(os, name)

        def wrapped(*a, _real=real, **k):
            count[0] += 1
            if kill_at is not None and count[0] == kill_at:
                raise _Killed
            return _real(*a, **k)

        monkeypatch.setattr(os, name, wrapped)
    return count


def tombstone_path(store: Path) -> Path:
    """The store's tombstone (``.NAME.removing``, also where no version made one)."""
    return getattr(store_mod, "tombstone_path",
                   lambda p: p.with_name(f".{p.name}.removing"))(store)


def assert_resumable_or_removable(directory: Path, keys: set[str]) -> str:
    """After an interrupted removal: the store is either whole (reopened by a run of the
    same configuration, every batch there) or gone, and then the next run deletes the
    tombstone.  Returns which."""
    path = directory / "o.nc.cases"
    st = CaseStore(path, "sha-a", "{}").open()  # never StoreMismatchError
    try:
        found = st.done()
        state = "whole" if found == keys else "gone"
        assert found in (keys, set()), found
        assert not tombstone_path(path).exists()  # the next run finished the removal
    finally:
        st.remove()
    assert not path.exists() and not tombstone_path(path).exists()
    assert sorted(p.name for p in directory.iterdir()) == []
    return state


def test_edges__store_removal_killed_at_every_step(tmp_path, monkeypatch):
    """A kill before each file-system change of the removal (simulated: the change
    raises and nothing else runs) leaves the store resumable or cleanly removable."""
    st = make_store(tmp_path / "clean")
    keys = st.done()
    st.close()
    st = CaseStore(tmp_path / "clean" / "o.nc.cases", "sha-a", "{}").open()
    with monkeypatch.context() as m:
        count = _fs_calls(m, None)
        st.remove()
    n_steps = count[0]
    assert n_steps >= 4 and not (tmp_path / "clean" / "o.nc.cases").exists()
    states = []
    for k in range(1, n_steps + 1):
        d = tmp_path / f"k{k}"
        st = make_store(d)
        with monkeypatch.context() as m:
            _fs_calls(m, k)
            with pytest.raises(_Killed):
                st.remove()
        st.close()
        states.append(assert_resumable_or_removable(d, keys))
    assert states[0] == "whole" and states[-1] == "gone"


def test_edges__fresh_clear_killed_at_every_step_keeps_a_valid_store(tmp_path, monkeypatch):
    """``--fresh`` clears an old store: a kill at any step of the clear leaves a store
    with its manifest (fewer batches) or an empty one, never batches without a
    manifest (which a re-run would refuse as "not a vsi case store")."""
    for k in range(1, 5):
        d = tmp_path / f"k{k}"
        make_store(d).close()
        st = CaseStore(d / "o.nc.cases", "sha-b", "{}", fresh=True)
        with monkeypatch.context() as m:
            _fs_calls(m, k)
            with pytest.raises(_Killed):
                st.open()
        st.close()
        names = {p.name for p in (d / "o.nc.cases").iterdir()}
        assert MANIFEST in names or not (names - {".lock"}), names
        CaseStore(d / "o.nc.cases", "sha-a", "{}").open().close()  # a valid store


_KILL_SCRIPT = """
import os, signal, sys
from pathlib import Path
sys.path.insert(0, {repo!r})
import numpy as np
from vsi_numba.study.store import CaseStore
directory, kill_at = Path(sys.argv[1]), int(sys.argv[2])
st = CaseStore(directory / "o.nc.cases", "sha-a", "{{}}").open()
for k in range(3):
    st.write(f"t000_i000_s{{k:04d}}-{{k:04d}}", {{"status": np.zeros(1, np.int32)}})
count = [0]
for name in ("unlink", "rmdir", "rename", "replace"):
    real = getattr(os, name)
    def wrapped(*a, _real=real, **k):
        count[0] += 1
        if count[0] == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)
        return _real(*a, **k)
    setattr(os, name, wrapped)
st.remove()
print(count[0])
"""


def test_edges__store_removal_real_sigkill(tmp_path):
    """A real SIGKILL sent by the process to itself at a known step of the removal (just
    before the rename, and inside the deletion of the tombstone): the next run adopts
    the whole store or deletes the tombstone."""
    script = tmp_path / "kill.py"
    script.write_text(_KILL_SCRIPT.format(repo=str(REPO)))
    probe = subprocess.run([sys.executable, str(script), str(tmp_path / "probe"), "0"],
                           capture_output=True, text=True, timeout=300)
    assert probe.returncode == 0, probe.stderr
    n_steps = int(probe.stdout)
    keys = {f"t000_i000_s{k:04d}-{k:04d}" for k in range(3)}
    seen = set()
    for k in (1, 2, n_steps - 1):
        d = tmp_path / f"k{k}"
        d.mkdir()
        r = subprocess.run([sys.executable, str(script), str(d), str(k)],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == -signal.SIGKILL, r.stderr
        seen.add(assert_resumable_or_removable(d, keys))
    assert seen == {"whole", "gone"}


# ------------------------------------------------------------------ 10: run vs sweep stores


def test_edges__run_on_an_interrupted_sweep_output_keeps_its_batches(tmp_path, capsys):
    """``vsi run`` on the output of an interrupted sweep (both default to study.output)
    leaves the sweep's finished batches alone; the sweep then resumes from them."""
    config = write_case(tmp_path, histories=False)
    out = tmp_path / "results" / "case.nc"
    # an interrupted sweep: its batches stored, no results file yet
    execute_study(load_config(config), out, backend="serial", keep_cases=True)
    out.unlink()
    sweep_store = store_path(out)
    stored = {p.name: digest(p) for p in sweep_store.glob("batch_*.npz")}
    assert stored
    assert run_command(config, None, quiet=True) == 0
    assert {p.name: digest(p) for p in sweep_store.glob("batch_*.npz")} == stored
    assert out.is_file() and not store_path(out, "run").exists()
    capsys.readouterr()
    assert sweep_command(config, None, None, None, quiet=False) == 0
    assert "all done earlier" in capsys.readouterr().err
    assert not sweep_store.exists()


# ------------------------------------------------------------------ 11: orphaned pool workers


_POOL_PARENT = """
import gc, json, os, signal, sys, time
sys.path.insert(0, {repo!r})
ENV = "VSI_TEST_POOL_PARENT"
if __name__ == "__mp_main__":
    # a worker importing its parent's main module, before its initializer: wait until
    # the parent is dead, so the initializer runs in an orphan (what a kill in the pool's
    # first second does)
    parent = int(os.environ[ENV])
    t0 = time.monotonic()
    while os.getppid() == parent and time.monotonic() - t0 < 120:
        time.sleep(0.01)
if __name__ == "__main__":
    os.environ[ENV] = str(os.getpid())
    import multiprocessing.synchronize
    from multiprocessing import resource_tracker
    from vsi_numba.study.backends import ProcessBackend
    be = ProcessBackend(2).__enter__()
    be._pool.submit(abs, -1)  # each submit starts a worker (up to 2)
    be._pool.submit(abs, -2)
    info = {{
        "workers": [p.pid for p in be._pool._processes.values()],
        "tracker": resource_tracker._resource_tracker._pid,
        "semaphores": [o._semlock.name for o in gc.get_objects()
                       if isinstance(o, multiprocessing.synchronize.SemLock)],
    }}
    with open(sys.argv[1], "w") as f:
        json.dump(info, f)
        f.flush()
        os.fsync(f.fileno())
    os.kill(os.getpid(), signal.SIGKILL)
"""


def _alive(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_edges__pool_workers_die_with_a_parent_killed_while_they_start(tmp_path):
    """The pool's parent is SIGKILLed right after starting its workers, before they ran
    their initializer: the workers and the resource tracker end, the semaphores go."""
    script = tmp_path / "parent.py"
    script.write_text(_POOL_PARENT.format(repo=str(REPO)))
    info_file = tmp_path / "info.json"
    with open(tmp_path / "stderr.txt", "w") as err:
        r = subprocess.run([sys.executable, str(script), str(info_file)],
                           stdout=subprocess.DEVNULL, stderr=err, timeout=300)
    assert r.returncode == -signal.SIGKILL, (tmp_path / "stderr.txt").read_text()
    info = json.loads(info_file.read_text())
    pids = [*info["workers"], info["tracker"]]
    assert len(info["workers"]) == 2 and info["semaphores"]
    try:
        t0 = time.monotonic()
        while any(_alive(p) for p in pids) and time.monotonic() - t0 < 90:
            time.sleep(0.1)
        left = [p for p in pids if _alive(p)]
        assert not left, f"orphaned processes {left} (workers {info['workers']})"
        t0 = time.monotonic()
        shm = [Path("/dev/shm") / ("sem." + n.lstrip("/")) for n in info["semaphores"]]
        while any(p.exists() for p in shm) and time.monotonic() - t0 < 30:
            time.sleep(0.1)
        assert not [p for p in shm if p.exists()]
    finally:
        for p in pids:  # only the processes this test started
            if _alive(p):
                with contextlib.suppress(psutil.NoSuchProcess):
                    psutil.Process(p).kill()


# ------------------------------------------------------------------ 17: long output names


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_edges__too_long_output_names_refused_clearly(tmp_path, capsys, command):
    """A path over PATH_MAX and a component over NAME_MAX: exit 2, a message that says
    so (no traceback, no "resume" hint), nothing created."""
    config = write_case(tmp_path)
    longest = os.pathconf(tmp_path, "PC_NAME_MAX")
    for out, needle in ((Path(str(tmp_path) + ("/" + "d" * 200) * 25) / "o.nc", "longest path"),
                        (tmp_path / ("n" * (longest + 1) + ".nc"), "file names here")):
        if command == "run":
            code = run_command(config, out, quiet=True)
        else:
            code = sweep_command(config, out, None, None, quiet=True)
        err = " ".join(capsys.readouterr().err.split())
        assert code == 2, err
        assert needle in err and "Traceback" not in err and "resume" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "profile.csv",
                                                          "trains.toml"]


def test_edges__legal_long_output_name_works(tmp_path, capsys):
    """A legal name of NAME_MAX - 5 bytes: the store, its temporary files and its
    tombstone get hashed names that fit, the run, the sweep and a resume work."""
    config = write_case(tmp_path, histories=False)
    longest = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("r" * (longest - 8) + ".nc")
    assert len(out.name) == longest - 5
    assert run_command(config, out, quiet=True) == 0, capsys.readouterr().err
    out.unlink()
    for command in ("run", "sweep"):
        sp = store_path(out, command)
        assert len(os.fsencode(sp.name)) <= longest and sp.name.endswith("cases")
        assert len(os.fsencode(tombstone_path(sp).name)) <= longest
        assert store_path(out, command) == sp  # the same name every time (resume)
    assert store_path(out) != store_path(out.with_name("r" + out.name[1:-4] + "x.nc"))
    execute_study(load_config(config), out, backend="serial", keep_cases=True)
    out.unlink()
    assert sweep_command(config, out, None, None, quiet=False) == 0
    assert "all done earlier" in capsys.readouterr().err
    assert out.is_file() and not store_path(out).exists()


# ------------------------------------------------------------------ 18: disk need up front


def test_edges__store_size_estimate_matches_the_real_store(tmp_path):
    """The estimate of the case store (from the array shapes) against the bytes of the
    batch files a run really stored: within 5 % (the estimate assumes 32 characters per
    status message and a fixed .npz record size); the results file between the two
    bounds of its estimate."""

    config = write_case(tmp_path, speeds=(80.0, 100.0, 150.0))
    out = tmp_path / "o.nc"
    seen = {}
    real_check = CaseStore.check_space

    def spy(self, need, output):
        seen["need"] = need
        return real_check(self, need, output)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(CaseStore, "check_space", spy)
        execute_study(load_config(config), out, backend="serial", keep_cases=True)
    stored = sum(p.stat().st_size for p in store_path(out).glob("batch_*.npz"))
    need = seen["need"]
    assert abs(need.store - stored) <= 0.05 * stored, (need, stored)
    size = out.stat().st_size
    assert need.final_min <= size <= need.final_max, (need, size)


def test_edges__too_little_disk_refused_before_starting(tmp_path, capsys, monkeypatch):
    """Free space below the estimate: exit 2 before any batch runs, with the need and
    the free space; between the minimum and the maximum: a warning, the study runs."""
    config = write_case(tmp_path)
    out = tmp_path / "o.nc"
    real = shutil.disk_usage
    free = {"bytes": 1000}

    def fake(path):
        u = real(path)
        return type(u)(u.total, u.used, free["bytes"])

    monkeypatch.setattr(store_mod.shutil, "disk_usage", fake)
    ran = []
    from vsi_numba.study import runner

    real_run = runner._run_pending
    monkeypatch.setattr(runner, "_run_pending", lambda *a, **k: (ran.append(1),
                                                                 real_run(*a, **k)))
    assert sweep_command(config, out, None, None, quiet=True) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "not enough disk space for" in err and "only 1.0 kB are free" in err, err
    assert "Traceback" not in err and not ran and not out.exists()
    assert not store_path(out).exists()  # nothing stored, nothing left
    # room for the store and the envelopes, not surely for uncompressed histories
    seen = {}
    real_need = store_mod.study_need
    monkeypatch.setattr(runner, "study_need", lambda *a: seen.setdefault("n", real_need(*a)))
    free["bytes"] = 10**15
    assert sweep_command(config, out, None, None, quiet=True) == 0
    out.unlink()
    need = seen["n"]
    assert need.minimum < need.maximum
    free["bytes"] = (need.minimum + need.maximum) // 2
    assert sweep_command(config, out, None, None, quiet=False) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "warning:" in err and "may run out of space" in err, err


# ------------------------------------------------------------------ 19: full disk, final write


def test_edges__full_disk_in_final_write_says_what_and_keeps_cases(tmp_path, capsys,
                                                                   monkeypatch):
    """The netCDF library fails in the final write with its generic "NetCDF: HDF error"
    while the disk is nearly full: the message names the file, the likely cause, the
    space needed and free, and the kept batches; a re-run with room resumes."""
    from vsi_numba.io import study_file

    config = write_case(tmp_path)
    out = tmp_path / "o.nc"
    real_close = study_file.StudyFile.close

    def full(self, attrs):
        raise RuntimeError("NetCDF: HDF error")

    real = shutil.disk_usage
    state = {"full": True}

    def fake(path):
        u = real(path)
        return type(u)(u.total, u.used, 2000 if state["full"] else u.free)

    monkeypatch.setattr(study_file.StudyFile, "close", full)
    monkeypatch.setattr(store_mod.CaseStore, "check_space", lambda *a: None)
    monkeypatch.setattr(store_mod.shutil, "disk_usage", fake)
    assert sweep_command(config, out, None, None, quiet=True) == 1
    err = " ".join(capsys.readouterr().err.split())
    assert f"cannot write {out} (the results file)" in err, err
    assert "NetCDF: HDF error" in err and "disk is full" in err, err
    assert "The results file needs up to about" in err and "were free for it on the disk" in err
    assert "finished batch(es) are kept in the case store" in err and "resume" in err
    assert "Traceback" not in err and not out.exists()
    n = len(list(store_path(out).glob("batch_*.npz")))
    assert n >= 1 and f"The {n} finished batch(es)" in err
    monkeypatch.setattr(study_file.StudyFile, "close", real_close)
    state["full"] = False
    assert sweep_command(config, out, None, None, quiet=False) == 0
    assert "all done earlier" in capsys.readouterr().err and out.is_file()


def test_edges__enospc_in_final_rename_named_as_full_disk(tmp_path):
    """An ENOSPC (here from the final fsync) is reported as a full disk."""
    from vsi_numba.study.store import final_write_error

    st = make_store(tmp_path)
    exc = OSError(errno.ENOSPC, "No space left on device")
    msg = str(final_write_error(exc, tmp_path / "o.nc", st, 5 * 10**6))
    st.close()
    assert "the disk is full" in msg and "needs up to about 5.0 MB" in msg
    assert "The 3 finished batch(es) are kept" in msg


def test_edges__atomic_write_of_a_longest_name(tmp_path):
    """The temporary file of an atomic write beside a NAME_MAX-long target fits too."""
    from vsi_numba.io.netcdf import write_bytes_atomic

    target = tmp_path / ("w" * os.pathconf(tmp_path, "PC_NAME_MAX"))
    write_bytes_atomic(target, b"data")
    assert target.read_bytes() == b"data" and [p.name for p in tmp_path.iterdir()] == [
        target.name]


def _private_tmpfs_works() -> bool:
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        return False
    r = subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"],
                       capture_output=True, timeout=60)
    return r.returncode == 0


@pytest.mark.skipif(not _private_tmpfs_works(),
                    reason="needs root and unshare for a private tmpfs mount")
def test_edges__real_full_disk_in_final_write(tmp_path):
    """A real ENOSPC: the sweep writes to a small tmpfs (mounted in a private mount
    namespace, gone with the process) that holds the case store and passes the up-front
    check but cannot hold the results file.  Exit 1, the message names the file, the
    full disk, the space needed and free and the kept batch; after the disk is enlarged
    the same command resumes."""
    import math

    config = write_case(tmp_path, speeds=(80.0, 100.0, 150.0))
    text = config.read_text().replace("history_speeds_kmh = [80.0]",
                                      "history_speeds_kmh = [80.0, 100.0, 150.0]")
    config.write_text(text)
    # the sizes on a roomy disk: store file, results file and the estimate
    ref = tmp_path / "ref" / "o.nc"
    seen = {}
    real_check = CaseStore.check_space

    def spy(self, need, output):
        seen["need"] = need
        return real_check(self, need, output)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(CaseStore, "check_space", spy)
        execute_study(load_config(config), ref, backend="serial", keep_cases=True)
    page = 4096
    store_pages = sum(math.ceil(p.stat().st_size / page) for p in store_path(ref).iterdir())
    final = ref.stat().st_size
    need = seen["need"]
    # room for the store and more than the estimate's minimum, less than the real file
    size = page * (store_pages + (need.final_min + final) // 2 // page)
    if size - page * store_pages < need.final_min or size >= page * store_pages + final:
        pytest.skip("no tmpfs size between the estimate's minimum and the real need")
    disk = tmp_path / "disk"
    disk.mkdir()
    out = disk / "o.nc"
    sweep = f"{sys.executable} -m vsi_numba.cli sweep {config} -o {out} --quiet"
    script = (f"mount -t tmpfs -o size={size} tmpfs {disk} || exit 99\n"
              f"{sweep}\necho rc=$? >&2\nls -a {store_path(out)}\n"
              f"mount -o remount,size=4m {disk} || exit 98\n{sweep}\necho rc=$? >&2\n"
              f"ls {out}\n")
    r = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True,
                       text=True, timeout=900)
    err = " ".join(r.stderr.split())
    first, second = err.split("rc=1", 1) if "rc=1" in err else (err, "")
    assert "rc=1" in err, err
    assert f"cannot write {out} (the results file)" in first, first
    assert "disk is full" in first and "The results file needs up to about" in first, first
    assert "were free for it on the disk of" in first and "Traceback" not in first, first
    free = float(first.split(" were free for it")[0].rsplit(" ", 2)[-2])
    assert 0 < free * 1e3 <= size, first  # what the tmpfs had left for the results file
    assert "The 1 finished batch(es) are kept in the case store" in first, first
    assert "batch_t000_i000_s0000-0002.npz" in r.stdout
    assert "rc=0" in second and str(out) in r.stdout.splitlines()[-1], (second, r.stdout)


def test_edges__store_removal_without_rename_deletes_manifest_last(tmp_path, monkeypatch):
    """Where the store cannot be renamed (the rename fails), it is deleted in place with
    its manifest after its batches."""
    st = make_store(tmp_path)
    order = []
    real_rename, real_unlink = os.rename, os.unlink

    def no_rename(*a, **k):
        raise OSError(errno.EXDEV, "Invalid cross-device link")

    def unlink(path, *a, **k):
        order.append(Path(path).name)
        return real_unlink(path, *a, **k)

    monkeypatch.setattr(os, "rename", no_rename)
    monkeypatch.setattr(os, "unlink", unlink)
    st.remove()
    assert not st.path.exists() and real_rename is not os.rename
    assert order.index(MANIFEST) > max(i for i, n in enumerate(order) if n.startswith("batch"))


def test_edges__default_output_that_is_an_input_is_refused(tmp_path, capsys):
    """``study.output`` naming an input (no -o; here the modes table, a .nc file like
    every output): refused the same way."""
    shutil.copytree(REPO / "configs" / "data", tmp_path / "data")
    config = tmp_path / "modes.toml"
    text = (REPO / "configs" / "two_span_modes_file.toml").read_text()
    assert 'output = "results/two_span_modes_file.nc"' in text
    config.write_text(text.replace('output = "results/two_span_modes_file.nc"',
                                   'output = "data/two_span_modes.nc"'))
    modes = tmp_path / "data" / "two_span_modes.nc"
    before = digest(modes)
    assert run_command(config, None, quiet=True) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "is the file of bridge.file" in err and "refusing to overwrite" in err, err
    assert digest(modes) == before
