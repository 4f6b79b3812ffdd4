"""The report directory is written whole or not at all: a report killed at any moment
(SIGKILL at every step of the writer, SIGTERM, Ctrl-C) leaves the complete earlier
report or the complete new one, never files of two results files side by side; the
next report tidies what a killed one left; SIGTERM exits 130 in every phase.

References: two reports written undisturbed from two different results files; every
file of the directory after a kill is compared, byte for byte, with those two.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from vsi_numba.analysis.report import atomic
from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.cli.report import report_command

TRAINS = (("HSLM-A1", 18.0, 6, "standard"), ("HSLM-A2", 19.0, 6, "standard"))


def _results(path: Path, scale: float) -> Path:
    """A small results file (histories stored: no case is re-run); ``scale`` sets the
    deck accelerations, so two scales give two different reports."""
    ds = synthetic_results(speeds_kmh=(250.0, 300.0), trains=TRAINS, n_vehicles=0,
                           histories=True, n_time=30)
    # deck outputs only (fewer figures and tables: each kill re-runs the report)
    ds = ds.drop_vars([v for v in ds.data_vars if "contact" in v or "wheel" in v
                       or "carbody" in v])
    ds["max_deck_acceleration"][:] = scale
    ds["max_deck_acceleration"].loc[{"train": "HSLM-A2"}] = 2.0 * scale
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return path


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _run_forked(results: Path, outdir: Path, kill_at: int) -> int:
    """``vsi report`` (its command function) in a forked process that SIGKILLs itself at
    its ``kill_at``-th step; the wait status."""
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 3
        try:
            os.environ[atomic.KILL_ENV] = str(kill_at)
            atomic._checkpoints[0] = 0
            code = report_command(results, outdir)
        finally:
            os._exit(code)
    return os.waitpid(pid, 0)[1]


def _vsi(*args, cwd, env_extra=None, timeout=600) -> subprocess.CompletedProcess:
    env = {**os.environ, **(env_extra or {})}
    return subprocess.run([sys.executable, "-m", "vsi_numba.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout, check=False)


@pytest.fixture(scope="module")
def two_reports(tmp_path_factory):
    """Reports of results files A and B written undisturbed, each from ``<dir>/r.nc``
    into ``<dir>/rep`` (the same relative layout as the runs under test)."""
    base = tmp_path_factory.mktemp("atomic")
    snaps = {}
    for name, scale in (("A", 1.0), ("B", 3.0)):
        res = _results(base / name / "r.nc", scale)
        assert report_command(res, base / name / "rep") == 0
        snaps[name] = _snapshot(base / name / "rep")
    assert snaps["A"]["summary.csv"] != snaps["B"]["summary.csv"]
    assert snaps["A"]["report.md"] != snaps["B"]["report.md"]
    return base, snaps


def test_report_atomic__sigkill_at_every_step_leaves_one_whole_report(two_reports, tmp_path,
                                                                       capfd):
    base, snaps = two_reports
    work = tmp_path / "w"
    work.mkdir()
    shutil.copy(base / "B" / "r.nc", work / "r.nc")
    outcomes = []
    for k in range(1, 60):
        shutil.rmtree(work / "rep", ignore_errors=True)
        shutil.copytree(base / "A" / "rep", work / "rep")  # the earlier report, of A
        status = _run_forked(work / "r.nc", work / "rep", k)
        now = _snapshot(work / "rep")
        which = [name for name, snap in snaps.items() if now == snap]
        assert which, f"kill at step {k}: the directory mixes files of two reports"
        if os.WIFEXITED(status):
            assert os.WEXITSTATUS(status) == 0
            assert which == ["B"]
            # a normal end leaves nothing beside the report, and it removed what the
            # killed runs before it left
            assert sorted(p.name for p in work.iterdir()) == ["r.nc", "rep"]
            break
        assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
        outcomes.append(which[0])
    else:
        pytest.fail("the report never finished")
    capfd.readouterr()
    # at least 10 steps (summary, tables, spreadsheet, figures, Markdown, HTML, the swap);
    # killed before the swap: the old report; after it: the new one
    assert len(outcomes) >= 10
    assert outcomes[0] == "A" and outcomes[-1] == "B"
    assert outcomes == sorted(outcomes)  # A ... A B ... B: one switch, at the swap


def test_report_atomic__stale_leftovers_removed_and_old_report_put_back(two_reports,
                                                                        tmp_path):
    """The two-rename fallback killed between its renames leaves the old report aside
    and the new one in the temporary directory: the next run puts the old one back
    first, then replaces it."""
    base, snaps = two_reports
    shutil.copy(base / "B" / "r.nc", tmp_path / "r.nc")
    dead = 2 ** 22 + 12345  # beyond the default pid_max: no such process
    shutil.copytree(base / "A" / "rep", tmp_path / f".rep.vsi-old-{dead}")
    shutil.copytree(base / "B" / "rep", tmp_path / f".rep.vsi-tmp-{dead}")
    atomic._tidy(tmp_path / "rep")
    assert _snapshot(tmp_path / "rep") == snaps["A"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc", "rep"]
    assert report_command(tmp_path / "r.nc", tmp_path / "rep") == 0
    assert _snapshot(tmp_path / "rep") == snaps["B"]


def test_report_atomic__directory_with_other_files_refused(two_reports, tmp_path, capsys,
                                                           monkeypatch):
    base, _ = two_reports
    shutil.copy(base / "A" / "r.nc", tmp_path / "r.nc")
    (tmp_path / "notes.txt").write_text("keep me")
    # the directory holds the results file and notes: refused, nothing is touched
    assert report_command(tmp_path / "r.nc", tmp_path) == 2
    err = capsys.readouterr().err
    assert "not part of a report" in err and "notes.txt" in err and "r.nc" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "r.nc"]
    # -o . : the working directory is never replaced
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    assert report_command(Path("../r.nc"), Path(".")) == 2
    assert "working directory" in capsys.readouterr().err
    assert (tmp_path / "sub").is_dir() and not any((tmp_path / "sub").iterdir())
    monkeypatch.chdir(tmp_path)
    # an earlier report with a file added by hand is refused too
    shutil.copytree(base / "A" / "rep", tmp_path / "rep")
    (tmp_path / "rep" / "tables" / "mine.xlsx").write_bytes(b"x")
    assert report_command(Path("r.nc"), Path("rep")) == 2
    assert "tables/mine.xlsx" in capsys.readouterr().err
    assert (tmp_path / "rep" / "tables" / "mine.xlsx").read_bytes() == b"x"


@pytest.mark.parametrize("spec", ["3:TERM", "5:INT"])
def test_report_atomic__sigterm_and_ctrl_c_exit_130_old_report_kept(two_reports, tmp_path,
                                                                   spec):
    """``vsi report`` (the CLI, a process of its own) stopped by SIGTERM or Ctrl-C while
    it writes: exit 130 as the sweep phase, the earlier report whole, no temp dir."""
    base, snaps = two_reports
    shutil.copy(base / "B" / "r.nc", tmp_path / "r.nc")
    shutil.copytree(base / "A" / "rep", tmp_path / "rep")
    res = _vsi("report", "r.nc", "-o", "rep", cwd=tmp_path,
               env_extra={atomic.KILL_ENV: spec})
    assert res.returncode == 130, res.stderr[-2000:]
    assert "interrupted" in res.stderr and "Traceback" not in res.stderr
    assert _snapshot(tmp_path / "rep") == snaps["A"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc", "rep"]


#: ``vsi sweep`` with SIGTERM sent to itself as it prints the governing results (the
#: phase between the study and the report).
_TERM_IN_GOVERNING = """
import os, signal, sys
from vsi_numba.cli import app, sweep
sweep._print_governing = lambda path, pr: os.kill(os.getpid(), signal.SIGTERM)
sys.argv = ["vsi", *sys.argv[1:]]
app()
"""


@pytest.mark.parametrize("phase", ["report", "governing"])
def test_report_atomic__sweep_sigterm_after_the_study_exits_130(tmp_path, phase):
    """SIGTERM in the report phase of ``vsi sweep --report`` (and while it prints the
    governing results) exits 130, as in the sweep phase; the results file is kept and
    no report directory is left half-written."""
    (tmp_path / "c.toml").write_text(
        'title = "t"\n[bridge]\nkind = "simply_supported"\nspans = [20.0]\nEI = 1e10\n'
        "mass_per_length = 1e4\nn_modes = 2\n"
        '[[train.vehicles]]\nkind = "force"\nload = 170e3\n'
        '[[train.vehicles]]\nkind = "force"\nload = 170e3\noffset = 3.0\n'
        "[solver]\ndt = 2e-3\nfree_vibration = 0.1\n"
        "[study]\nspeeds_kmh = [200.0]\noutput = \"r.nc\"\n")
    args = ["sweep", "c.toml", "-q", "--report", "rep"]
    if phase == "report":
        res = _vsi(*args, cwd=tmp_path, env_extra={atomic.KILL_ENV: "2:TERM"})
    else:
        res = subprocess.run([sys.executable, "-c", _TERM_IN_GOVERNING, *args], cwd=tmp_path,
                             capture_output=True, text=True, timeout=600, check=False)
    assert res.returncode == 130, res.stderr[-2000:]
    assert "interrupted" in res.stderr and "Traceback" not in res.stderr
    with xr.open_dataset(tmp_path / "r.nc") as ds:
        assert np.isfinite(ds["max_deck_acceleration"].values).all()
    left = [p.name for p in tmp_path.iterdir()]
    assert "rep" not in left and not [n for n in left if n.startswith(".rep.")], left
