"""One writer per results file: ``vsi run`` and ``vsi sweep`` (and two of either) on the
same output exclude each other, whichever started first, with a message that names the
output and the process holding it.  Deterministic: the first command is held after its
first stored batch (the study's test hook), which it reaches only with the lock held."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.study.outlock import OutputBusyError, OutputLock, lock_path
from vsi_numba.study.runner import HOLD_ENV
from vsi_numba.study.store import store_path


def write_config(directory: Path) -> Path:
    """Two HSLM trains (moving forces) on a 15 m span: a study of a few seconds."""
    path = directory / "lock.toml"
    path.write_text(textwrap.dedent("""
        title = "output lock test"
        [bridge]
        kind = "simply_supported"
        spans = [15.0]
        EI = 1.0e10
        mass_per_length = 12000.0
        damping_ratio = 0.02
        n_modes = 2
        [train]
        preset = ["HSLM-A1", "HSLM-A2"]
        [solver]
        dt = 2e-3
        approach = 2.0
        free_vibration = 0.1
        [study]
        speeds_kmh = [200.0, 250.0]
        output = "out.nc"
        """))
    return path


def start_held(command: str, config: Path, out: Path) -> subprocess.Popen:
    """``vsi COMMAND CONFIG -o OUT`` held after its first stored batch."""
    env = dict(os.environ, **{HOLD_ENV: "1"})
    return subprocess.Popen([sys.executable, "-m", "vsi_numba.cli", command, str(config),
                             "-o", str(out), "-q"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def wait_held(proc: subprocess.Popen, marker: Path, timeout: float = 600.0) -> None:
    t0 = time.monotonic()
    while not marker.exists():
        if proc.poll() is not None:
            pytest.fail(f"ended (rc {proc.returncode}) before it held: {proc.stderr.read()}")
        if time.monotonic() - t0 > timeout:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail("did not hold")
        time.sleep(0.05)


@pytest.mark.parametrize("first, second", [("sweep", "run"), ("run", "sweep"),
                                           ("sweep", "sweep"), ("run", "run")])
def test_output_lock__second_writer_is_refused_naming_the_first(tmp_path, first, second):
    """The second command exits 2 with "the output OUT is being written by another
    process: pid N: vsi FIRST ...", writes nothing and leaves the first's store alone;
    after the first is killed (SIGKILL: the kernel drops its flock) the output is free."""
    config = write_config(tmp_path)
    out = tmp_path / "out.nc"
    proc = start_held(first, config, out)
    held_store = store_path(out, first)
    try:
        wait_held(proc, held_store / ".held")
        assert lock_path(out).is_file()
        before = sorted(p.name for p in held_store.iterdir())
        res = CliRunner().invoke(app, [second, str(config), "-o", str(out), "-q"])
        err = " ".join(res.output.split())
        assert res.exit_code == 2, err
        assert f"the output {out} is being written by another process" in err, err
        assert f"pid {proc.pid}: vsi {first} {config}" in err, err
        assert "Traceback" not in err
        assert not out.exists()
        assert sorted(p.name for p in held_store.iterdir()) == before
        if second != first:
            assert not store_path(out, second).exists()
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
    # the killed holder left its lock file; it is free and taken over
    res = CliRunner().invoke(app, [second, str(config), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    assert out.is_file() and not lock_path(out).exists()


def test_output_lock__released_and_removed_at_exit(tmp_path):
    """Held in a ``with`` block, refused to a second holder, gone afterwards; a lock file
    left by a dead holder (no flock on it) is taken over."""
    out = tmp_path / "o.nc"
    with OutputLock(out, "vsi sweep a.toml"):
        assert "vsi sweep a.toml" in lock_path(out).read_text()
        with pytest.raises(OutputBusyError, match=r"pid \d+: vsi sweep a\.toml"):
            OutputLock(out, "vsi run b.toml").acquire()
    assert not lock_path(out).exists()
    lock_path(out).write_text("pid 1: a dead process\n")
    with OutputLock(out, "vsi run b.toml"):
        assert "vsi run b.toml" in lock_path(out).read_text()
    assert list(tmp_path.iterdir()) == []
