"""The report's re-runs in a second process (:mod:`vsi_numba.analysis.report.background`):
the jobs' results come back from the child, a job the child could not deliver runs in
this process (and raises here as it would have), the child keeps no lock of the report
directory, and a report made with the child is the same files as one made without it."""

from __future__ import annotations

import os
import textwrap

import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.analysis.report import background as bg
from vsi_numba.analysis.report import write_report
from vsi_numba.cli import app

pytestmark = pytest.mark.skipif(not bg.can_fork(), reason="needs fork and two cores")


def test_background__jobs_run_in_a_child_and_come_back_in_any_order():
    here = os.getpid()
    with bg.Background({"a": os.getpid, "b": lambda: [1.5, "x", {"k": (2,)}]}) as jobs:
        assert jobs.forked
        assert jobs.get("b") == [1.5, "x", {"k": (2,)}]  # asked for out of order
        pid = jobs.get("a")
    assert pid != here


def test_background__a_job_that_raises_in_the_child_raises_here():
    calls = []

    def bad():
        calls.append(os.getpid())
        raise ValueError("no such case")

    with bg.Background({"bad": bad, "good": lambda: 3}) as jobs:
        with pytest.raises(ValueError, match="no such case"):
            jobs.get("bad")
        assert jobs.get("good") == 3
    assert calls == [os.getpid()]  # the child's call was in the child


def test_background__a_child_that_dies_leaves_its_jobs_to_this_process():
    with bg.Background({"die": lambda: os._exit(3), "after": os.getpid}) as jobs:
        assert jobs.get("after") == os.getpid()  # the child never got to it
        assert not jobs.forked


def test_background__without_fork_the_jobs_run_here_when_asked_for():
    calls = []
    with bg.Background({"a": lambda: calls.append(1) or 7}, fork=False) as jobs:
        assert not jobs.forked and calls == []
        assert jobs.get("a") == 7 and calls == [1]


def test_background__the_child_holds_no_directory_descriptor_of_this_process(tmp_path):
    fd = os.open(tmp_path, os.O_RDONLY)  # e.g. the flock of the report directory
    try:
        def probe():
            try:
                os.fstat(fd)
            except OSError:
                return "closed"
            return "open"

        with bg.Background({"probe": probe}) as jobs:
            assert jobs.get("probe") == "closed"
        os.fstat(fd)  # still open here
    finally:
        os.close(fd)


def _results(tmp_path):
    """A small study with re-runs (HSLM-A1 on a 15 m span, no stored histories)."""
    path = tmp_path / "study.toml"
    path.write_text(textwrap.dedent("""
        title = "background"
        [bridge]
        kind = "simply_supported"
        spans = [15.0]
        EI = 5e9
        mass_per_length = 1.0e4
        damping_ratio = 0.02
        n_modes = 3
        [train]
        preset = ["HSLM-A1"]
        [solver]
        dt = 0.002
        free_vibration = 0.0
        [study]
        speeds_kmh = [300.0, 310.0, 330.0]
        save_time_histories = false
        output = "results.nc"
        """))
    res = CliRunner().invoke(app, ["sweep", str(path), "-q"])
    assert res.exit_code == 0, res.output
    return tmp_path / "results.nc"


def test_background__a_report_is_the_same_with_and_without_the_child(tmp_path,
                                                                    monkeypatch):
    results = _results(tmp_path)
    made = []
    real = bg.Background.__init__

    def spy(self, jobs, fork=None):
        real(self, jobs, fork)
        made.append(self.forked)

    monkeypatch.setattr(bg.Background, "__init__", spy)
    with xr.open_dataset(results) as ds:
        write_report(ds, tmp_path / "forked", source_path=results)
    monkeypatch.setattr(bg, "can_fork", lambda: False)
    with xr.open_dataset(results) as ds:
        write_report(ds, tmp_path / "here", source_path=results)
    assert made == [True, False]
    a = sorted(p.relative_to(tmp_path / "forked") for p in (tmp_path / "forked").rglob("*"))
    b = sorted(p.relative_to(tmp_path / "here") for p in (tmp_path / "here").rglob("*"))
    assert a == b and len(a) > 5
    for rel in a:
        if (tmp_path / "forked" / rel).is_file():
            assert ((tmp_path / "forked" / rel).read_bytes()
                    == (tmp_path / "here" / rel).read_bytes()), rel
    text = (tmp_path / "forked" / "report.md").read_text()
    assert "re-run from the file's configuration" in text  # the figures' re-runs
    assert "Re-run at dt/2" in text  # the convergence section's


def test_background__a_large_result_does_not_hold_up_the_next_job():
    import time

    t0 = time.monotonic()
    jobs = {"big": lambda: b"x" * 20_000_000, "when": time.monotonic}
    with bg.Background(jobs) as b:
        time.sleep(1.5)  # nothing read meanwhile: "big" fills the pipe
        assert len(b.get("big")) == 20_000_000
        # the second job ran while the first result waited in the pipe
        assert b.get("when") - t0 < 1.4
