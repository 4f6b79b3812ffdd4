"""Nothing a command writes is destroyed or left half-written, found adversarially:
another process writing into a report's directory while the report is built (both
orders), a kill while the verification manual is written, a full disk under every
command, and the figure paths of ``vsi trains --signature --plot``.

Deterministic: the second writer runs at a fixed point of the report build (after its
files are written, before the swap: ``build_report`` wrapped), a real second process is
synchronised through the file the study's hold hook writes, a kill comes from the
process itself at a fixed point of its write, and a full disk is either a failing
``fsync`` (every atomic write flushes its file: the place a real disk reports it with
delayed allocation) or a real tmpfs of 64 kB (skipped where it cannot be mounted).
"""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import vsi_numba.analysis.report as report_mod
from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.cli import app
from vsi_numba.cli.report import report_command
from vsi_numba.study.outlock import lock_path
from vsi_numba.study.runner import HOLD_ENV
from vsi_numba.study.store import store_path

ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def one_line(text: str) -> str:
    return " ".join(text.split())


def squeezed(text: str) -> str:
    """``text`` without any whitespace: the terminal wraps a long path at any character."""
    return "".join(text.split())


def write_config(directory: Path) -> Path:
    """Two HSLM trains (moving forces) on a 15 m span, two speeds: two batches of a
    second or so (the hold hook stops after the first)."""
    path = directory / "study.toml"
    path.write_text(textwrap.dedent("""
        title = "writes test"
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


def results_file(path: Path) -> Path:
    """A small results file with its histories (the report re-runs nothing)."""
    ds = synthetic_results(speeds_kmh=(250.0, 300.0),
                           trains=(("HSLM-A1", 18.0, 6, "standard"),), n_vehicles=0,
                           histories=True, n_time=30)
    ds = ds.drop_vars([v for v in ds.data_vars if "contact" in v or "wheel" in v
                       or "carbody" in v])
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return path


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture
def during_report(monkeypatch):
    """``during_report(action)``: the next report runs ``action()`` once its files are
    all written, just before its directory is swapped in."""
    real = report_mod.build_report

    def arm(action):
        def build(*a, **k):
            out = real(*a, **k)
            action()
            return out

        monkeypatch.setattr(report_mod, "build_report", build)

    return arm


def start_held_sweep(config: Path, out: Path) -> subprocess.Popen:
    """``vsi sweep CONFIG -o OUT`` in a process of its own, held after its first stored
    batch (the study's test hook, reached only with the output lock and store held)."""
    env = dict(os.environ, **{HOLD_ENV: "1"})
    return subprocess.Popen([sys.executable, "-m", "vsi_numba.cli", "sweep", str(config),
                             "-o", str(out), "-q"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def held_or_ended(proc: subprocess.Popen, marker: Path, timeout: float = 600.0) -> bool:
    """Wait until the held process holds (True) or has ended (False); no sleep decides
    the outcome, the loop only polls for one of the two."""
    t0 = time.monotonic()
    while not marker.exists():
        if proc.poll() is not None:
            return False
        if time.monotonic() - t0 > timeout:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail("the sweep neither held nor ended")
        time.sleep(0.02)
    return True


# --------------------------------------------------------------- report and sweep


@pytest.mark.parametrize("name", ["x.nc", "sub/x.nc"])
def test_writes__sweep_into_the_report_directory_while_it_is_built(tmp_path, capsys,
                                                                   during_report, name):
    """``vsi sweep -o DIR/x.nc`` run (and finished) while ``vsi report -o DIR`` is built:
    the sweep is refused at once (exit 2, naming DIR and the report's process), so no
    exit 0 is followed by a results file that the report's swap deletes; the report is
    whole and nothing of the sweep is left in DIR (into ``DIR/sub/``: not even ``sub``)."""
    results = results_file(tmp_path / "r.nc")
    config = write_config(tmp_path)
    assert report_command(results, tmp_path / "ref") == 0  # the undisturbed report
    rep = tmp_path / "rep"
    out = rep / name
    seen = {}
    during_report(lambda: seen.setdefault("sweep", invoke("sweep", config, "-o", out, "-q")))
    assert report_command(results, rep) == 0
    capsys.readouterr()
    res = seen["sweep"]
    msg = one_line(res.output)
    if res.exit_code == 0:  # what a sweep that said it wrote x.nc must find afterwards
        assert out.is_file(), f"the sweep said it wrote {out}; the report deleted it"
    assert res.exit_code == 2, msg
    assert f"the directory {rep} is being replaced by another process (pid {os.getpid()}" \
        in msg, msg  # a subdirectory of DIR: refused before it is made
    assert "Traceback" not in msg
    assert names(rep) == names(tmp_path / "ref")  # the report, whole, and nothing else
    assert not out.exists() and not store_path(out).exists() and not lock_path(out).exists()
    assert names(tmp_path) == ["r.nc", "ref", "rep", "study.toml"]


def test_writes__two_reports_into_one_directory(tmp_path, capsys, during_report):
    """A second ``vsi report -o DIR`` while the first is being built: refused (exit 2,
    naming the first's process), not a second exit 0 whose report the first replaces."""
    results = results_file(tmp_path / "r.nc")
    rep = tmp_path / "rep"
    seen = []
    during_report(lambda: seen or seen.append(report_command(results, rep)))
    assert report_command(results, rep) == 0
    err = one_line(capsys.readouterr().err)
    assert seen == [2], err
    assert f"the directory {rep} is in use: another process is writing into it (pid " \
           f"{os.getpid()}" in err, err
    assert names(tmp_path) == ["r.nc", "rep"] and (rep / "report.md").is_file()


def test_writes__a_file_dropped_into_the_report_directory_meanwhile_is_kept(tmp_path,
                                                                           during_report):
    """A program that knows nothing of the lock drops files into DIR while the report is
    built: they are in DIR afterwards, byte for byte, beside the whole report; the old
    report's own files are gone."""
    results = results_file(tmp_path / "r.nc")
    rep = tmp_path / "rep"
    assert report_command(results, rep) == 0  # an earlier report there
    ref = snapshot(rep)

    def drop():
        (rep / "notes.txt").write_bytes(b"keep me\n")
        (rep / "data").mkdir()
        (rep / "data" / "log.bin").write_bytes(bytes(range(256)))
        (rep / "tables" / "mine.csv.bak").write_bytes(b"mine")

    during_report(drop)
    assert report_command(results, rep) == 0
    now = snapshot(rep)
    assert now.pop("notes.txt") == b"keep me\n"
    assert now.pop("data/log.bin") == bytes(range(256))
    assert now.pop("tables/mine.csv.bak") == b"mine"
    assert now == ref  # the new report (the same results: the same bytes), nothing mixed
    assert names(tmp_path) == ["r.nc", "rep"]  # no temporary directory left


def test_writes__killed_at_every_step_of_the_swap_a_dropped_file_survives(tmp_path, capsys,
                                                                          during_report):
    """SIGKILL at each step of the swap of a report into DIR, a file having been dropped
    into DIR during the build: DIR holds one whole report, and the next report into DIR
    tidies what the killed one left, with the dropped file back in DIR, byte for byte,
    whatever the step (that report then refuses DIR: it holds a file of another
    program)."""
    from vsi_numba.analysis.report import atomic

    results = results_file(tmp_path / "r.nc")
    # an undisturbed report, and its steps: the swap's are the last ones
    os.environ[atomic.KILL_ENV] = "100000"
    atomic._checkpoints[0] = 0
    try:
        assert report_command(results, tmp_path / "ref") == 0
    finally:
        del os.environ[atomic.KILL_ENV]
    n_steps = atomic._checkpoints[0]
    whole = snapshot(tmp_path / "ref")
    rep = tmp_path / "rep"
    parent = os.getpid()
    during_report(lambda: os.getpid() != parent and (rep / "notes.txt").write_bytes(b"x"))
    killed = 0
    # after the rename of the new directory beside the old one, after the exchange (the
    # last step, after the old one is emptied, leaves nothing to tidy)
    for k in (n_steps - 2, n_steps - 1):
        shutil.rmtree(rep, ignore_errors=True)
        shutil.copytree(tmp_path / "ref", rep)  # the earlier report
        pid = os.fork()
        if pid == 0:  # the child: never returns into pytest
            code = 3
            try:
                os.environ[atomic.KILL_ENV] = str(k)
                atomic._checkpoints[0] = 0
                code = report_command(results, rep)
            finally:
                os._exit(code)
        status = os.waitpid(pid, 0)[1]
        killed += os.WIFSIGNALED(status)
        now = snapshot(rep)
        now.pop("notes.txt", None)
        assert now == whole, f"kill at step {k}: DIR is not one whole report"
        assert report_command(results, rep) == 2  # tidied, then refused: notes.txt
        assert "notes.txt" in capsys.readouterr().err
        assert (rep / "notes.txt").read_bytes() == b"x", f"kill at step {k}"
        assert not [n for n in names(tmp_path) if n.startswith(".rep")], names(tmp_path)
    assert killed == 2


def test_writes__report_during_a_running_sweep_in_its_directory(tmp_path, capsys,
                                                               during_report):
    """A real ``vsi sweep -o DIR/x.nc`` started while ``vsi report -o DIR`` is built (and
    still running at the swap): it is refused at once, before it makes a case store or
    an output lock there, so none of its state can be swapped away under it."""
    results = results_file(tmp_path / "r.nc")
    config = write_config(tmp_path)
    rep = tmp_path / "rep"
    out = rep / "x.nc"
    procs = []

    def sweep():
        proc = start_held_sweep(config, out)
        procs.append(proc)
        procs.append(held_or_ended(proc, store_path(out) / ".held"))

    during_report(sweep)
    try:
        assert report_command(results, rep) == 0
        proc, held = procs
        if held:  # running at the swap: its store and lock must still be there
            assert store_path(out).is_dir() and lock_path(out).is_file(), (
                "the report's swap took the running sweep's case store and lock")
        assert not held, "the sweep ran into a directory being replaced"
        err = one_line(proc.communicate(timeout=60)[1])
        assert proc.returncode == 2, err
        assert f"the directory {rep} is being replaced by another process (pid " \
               f"{os.getpid()}" in err, err
        assert "Traceback" not in err
        assert not out.exists() and not store_path(out).exists()
        assert not lock_path(out).exists()
    finally:
        for p in procs[:1]:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.communicate()
    capsys.readouterr()


def test_writes__report_refused_while_a_sweep_writes_into_its_directory(tmp_path, capsys):
    """The other order: a running sweep into DIR, then ``vsi report -o DIR``: exit 2 with
    the sweep's process named; the sweep's store and lock untouched; after the sweep is
    killed, the same sweep resumes and finishes."""
    results = results_file(tmp_path / "r.nc")
    config = write_config(tmp_path)
    rep = tmp_path / "rep"
    out = rep / "x.nc"
    proc = start_held_sweep(config, out)
    try:
        assert held_or_ended(proc, store_path(out) / ".held"), proc.communicate()[1]
        before = {p.name: p.stat().st_ino for p in store_path(out).iterdir()}
        lock_ino = lock_path(out).stat().st_ino
        assert report_command(results, rep) == 2
        err = one_line(capsys.readouterr().err)
        assert f"pid {proc.pid}: vsi sweep {config}" in err, err
        assert "Traceback" not in err
        assert {p.name: p.stat().st_ino for p in store_path(out).iterdir()} == before
        assert lock_path(out).stat().st_ino == lock_ino
        assert not [n for n in names(tmp_path) if n.startswith(".rep")]
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
    res = invoke("sweep", config, "-o", out)
    assert res.exit_code == 0, res.output
    assert "2 done earlier" in one_line(res.output), res.output  # the held sweep's batch
    with xr.open_dataset(out) as ds:
        assert np.isfinite(ds["max_deck_acceleration"].values).all()


# ------------------------------------------------------------------------ verify

#: ``vsi verify`` with one quick case, killed (SIGKILL, by itself) when it has written
#: the first half of verification.csv.
_VERIFY_KILLED = """
import os, signal, sys
from vsi_numba.cli import app
from vsi_numba.verification import cases, manual
cases.CASES = tuple(c for c in cases.CASES if c.id == "V03")
real = manual.write_csv

def half_then_kill(rows, path):
    real(rows, path)
    data = open(path, "rb").read()
    with open(path, "wb") as f:
        f.write(data[: len(data) // 2])
    os.kill(os.getpid(), signal.SIGKILL)

manual.write_csv = half_then_kill
sys.argv = ["vsi", "verify", "--quick", "-o", sys.argv[1]]
app()
"""


@pytest.fixture
def one_case(monkeypatch):
    from vsi_numba.verification import cases

    monkeypatch.setattr(cases, "CASES", tuple(c for c in cases.CASES if c.id == "V03"))


def test_writes__verify_killed_while_writing_keeps_the_earlier_manual(tmp_path, one_case):
    """SIGKILL half-way through verification.csv: the directory still holds the earlier
    manual, byte for byte (no truncated CSV beside the earlier HTML); the next run tidies
    what the killed one left and writes a whole manual."""
    out = tmp_path / "manual"
    assert invoke("verify", "--quick", "-o", out).exit_code == 0
    earlier = snapshot(out)
    r = subprocess.run([sys.executable, "-c", _VERIFY_KILLED, str(out)], capture_output=True,
                       text=True, timeout=600, check=False)
    assert r.returncode == -signal.SIGKILL, r.stderr[-2000:]
    assert snapshot(out) == earlier
    res = invoke("verify", "--quick", "-o", out)
    assert res.exit_code == 0, res.output
    assert names(tmp_path) == ["manual"]  # the killed run's directory is gone
    text = (out / "verification.csv").read_text()
    assert text.endswith("\n") and text.count("\n") == earlier["verification.csv"].count(
        b"\n")


def test_writes__verify_on_a_full_disk_says_so_and_leaves_nothing(tmp_path, one_case,
                                                                  monkeypatch):
    """ENOSPC as the HTML is flushed: exit 2, one line naming the manual's directory and
    the full disk, no traceback; the earlier manual kept, no ``cases/`` of the failed
    run, nothing beside the directory."""
    out = tmp_path / "manual"
    assert invoke("verify", "--quick", "-o", out).exit_code == 0
    earlier = snapshot(out)
    real = os.fsync

    def full(fd):
        if "verification.html" in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd)

    monkeypatch.setattr(os, "fsync", full)
    res = invoke("verify", "--quick", "-o", out)
    msg = one_line(res.output)
    assert res.exit_code == 2, msg
    assert f"--output {out}: cannot write the verification manual" in msg, msg
    assert "No space left on device: the disk is full" in msg and "Traceback" not in msg
    assert res.exception is None or isinstance(res.exception, SystemExit)
    assert snapshot(out) == earlier
    assert names(tmp_path) == ["manual"]
    # a new directory on a full disk: nothing at all is left
    res = invoke("verify", "--quick", "-o", tmp_path / "new")
    assert res.exit_code == 2 and names(tmp_path) == ["manual"], res.output


# --------------------------------------------------------------- full disk


def _full_fsync(monkeypatch):
    """Every flush of a file fails as on a full disk (ENOSPC)."""

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)


@pytest.mark.parametrize("command", ["init", "schema", "modes", "profile", "signature"])
def test_writes__full_disk_refused_cleanly_and_earlier_file_kept(tmp_path, monkeypatch,
                                                                command):
    """A full disk while each single-file command writes: exit 2, a message naming the
    file and the full disk, no traceback, the earlier file untouched (or no file)."""
    cfg = ROOT / "configs" / "hslm_25m.toml"
    target = tmp_path / {"init": "c.toml", "schema": "s.json", "modes": "m.png",
                         "profile": "p.png", "signature": "sig.png"}[command]
    args = {"init": ["init", target], "schema": ["schema", "-o", target],
            "modes": ["modes", cfg, "-o", target], "profile": ["profile", cfg, "--plot",
                                                              target],
            "signature": ["trains", "ICE3", "--signature", "--plot", target]}[command]
    if command != "init":
        target.write_bytes(b"earlier")
    _full_fsync(monkeypatch)
    res = invoke(*args)
    msg = one_line(res.output)
    assert res.exit_code == 2, msg
    assert f"cannot write {target}: No space left on device: the disk is full" in msg, msg
    assert "Traceback" not in msg and not isinstance(res.exception, OSError)
    if command == "init":
        assert names(tmp_path) == []
        monkeypatch.undo()  # room again: the same command works (no empty file blocks it)
        assert invoke(*args).exit_code == 0 and target.read_text().startswith("#")
    else:
        assert names(tmp_path) == [target.name] and target.read_bytes() == b"earlier"


def _tmpfs(path: Path) -> bool:
    if os.geteuid() != 0:
        return False
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(path)],
                       capture_output=True, timeout=60, check=False)
    return r.returncode == 0


@pytest.fixture
def full_disk(tmp_path):
    """A 64 kB tmpfs filled to the last byte (skipped where it cannot be mounted)."""
    disk = tmp_path / "disk"
    if not _tmpfs(disk):
        pytest.skip("a tmpfs cannot be mounted here (needs root)")
    try:
        with open(disk / "filler", "wb", buffering=0) as f:
            try:
                while True:
                    f.write(b"\0" * 512)
            except OSError as exc:
                assert exc.errno == errno.ENOSPC
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], capture_output=True, timeout=60,
                       check=False)


@pytest.mark.parametrize("command", ["init", "schema", "sweep", "run", "signature", "report",
                                     "verify"])
def test_writes__real_full_disk_leaves_nothing(full_disk, tmp_path, command):
    """The same on a real full disk (ENOSPC from the writes themselves): no empty config
    that blocks the next ``vsi init``, no truncated schema, no ``.vsi-write-test.PID``
    probe of ``vsi sweep`` / ``vsi run`` / ``vsi verify``, no part of a report; exit code
    != 0 and a message, no traceback."""
    config = write_config(tmp_path)
    target = full_disk / {"init": "c.toml", "schema": "s.json", "sweep": "o.nc",
                          "run": "o.nc", "signature": "sig.png", "report": "rep",
                          "verify": "manual"}[command]
    args = {"init": ["init", target], "schema": ["schema", "-o", target],
            "sweep": ["sweep", config, "-o", target, "-q"],
            "run": ["run", config, "-o", target, "-q"],
            "signature": ["trains", "ICE3", "--signature", "--plot", target],
            "report": ["report", results_file(tmp_path / "r.nc"), "-o", target],
            "verify": ["verify", "--quick", "-o", target]}[command]
    res = invoke(*args)
    msg = one_line(res.output)
    print(msg)
    assert res.exit_code != 0, msg
    assert "No space left on device" in msg and "Traceback" not in msg, msg
    assert not isinstance(res.exception, OSError)
    assert names(full_disk) == ["filler"]
    if command == "init":
        (full_disk / "filler").unlink()
        res = invoke(*args)
        assert res.exit_code == 0, res.output


# ------------------------------------------------------------------ figure paths


@pytest.mark.parametrize("case", ["missing directory", "no suffix", "unknown suffix",
                                  "long name", "pdf"])
def test_writes__trains_signature_plot_paths(tmp_path, case):
    """``vsi trains ICE3 --signature --plot PATH``: a missing directory is made and the
    figure written exactly at PATH; a name without a format suffix or with one matplotlib
    cannot write and a name too long are refused (exit 2, the reason, no traceback,
    nothing written); "wrote PATH" names the file that exists."""
    path = {"missing directory": tmp_path / "a" / "b" / "sig.png",
            "no suffix": tmp_path / "sig",
            "unknown suffix": tmp_path / "sig.xyz",
            "long name": tmp_path / ("s" * 300 + ".png"),
            "pdf": tmp_path / "sig.pdf"}[case]
    res = invoke("trains", "ICE3", "--signature", "--plot", path)
    msg = one_line(res.output)
    assert "Traceback" not in msg, msg
    assert res.exception is None or isinstance(res.exception, SystemExit), msg
    if case in ("missing directory", "pdf"):
        assert res.exit_code == 0, msg
        assert f"wrote{path}" in squeezed(res.output), msg
        head = path.read_bytes()[:8]
        assert head == PNG if case != "pdf" else head.startswith(b"%PDF")
        assert [p.name for p in path.parent.iterdir()] == [path.name]
        return
    assert res.exit_code == 2, msg
    assert f"wrote{path}" not in squeezed(res.output), msg
    expected = {"no suffix": "it has no suffix", "unknown suffix": "it has '.xyz'",
                "long name": "file names here are at most"}[case]
    assert expected in msg, msg
    assert names(tmp_path) == []
