"""Outputs kept when their inputs are unchanged (vsi_numba.io.kept): a written study found
by its recorded signature without building the model, the governing lines, the report
directory; every change of an input (a file the configuration reads, the code, the
results file, a file of the report) makes the output again."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from test_resume import SPEEDS, write_study
from userpath import vsi

from vsi_numba.io import kept

REPO = Path(__file__).resolve().parents[1]


def _records(tmp_path, monkeypatch) -> Path:
    cache = tmp_path / "cache"
    monkeypatch.setenv(kept.CACHE_ENV, str(cache))
    return cache


def test_kept__a_written_study_is_found_by_its_signature_and_any_input_change_recomputes(
        tmp_path, monkeypatch):
    """With records on, the second sweep says the study was not recomputed without
    building the model (``_build_model`` made to fail), prints the same governing lines,
    and leaves the file's bytes; a changed trains file, another version of the code or
    ``--fresh`` recompute it."""
    _records(tmp_path, monkeypatch)
    config = write_study(tmp_path / "s", speeds=SPEEDS[:2], seeds=(1,), one_train=True)
    out = tmp_path / "s" / "study.nc"
    first = vsi("sweep", config, "-o", out)
    assert first.returncode == 0 and "2 to run" in first.stderr, first.stderr
    data = out.read_bytes()

    from vsi_numba.study import spec

    def no_model(*a, **k):
        raise AssertionError("the model was built")

    with monkeypatch.context() as m:
        m.setattr(spec, "_build_model", no_model)
        import vsi_numba.study.runner as runner

        m.setattr(runner, "_build_model", no_model)
        again = vsi("sweep", config, "-o", out)
    assert again.returncode == 0, again.stderr
    assert "nothing recomputed (--fresh recomputes them)" in again.stderr
    assert again.stdout == first.stdout and "governing results" in again.stdout
    assert out.read_bytes() == data
    # a file the configuration reads changes (its text does not): recomputed
    trains = tmp_path / "s" / "trains.toml"
    trains.write_text(trains.read_text().replace("body_mass = 30000.0", "body_mass = 31000.0"))
    changed = vsi("sweep", config, "-o", out)
    assert "2 to run" in changed.stderr
    assert "nothing recomputed" in vsi("sweep", config, "-o", out).stderr
    # another version of the code: recomputed
    import vsi_numba._jit as jit
    import vsi_numba._sources as sources

    monkeypatch.setattr(sources, "package_hash", lambda directory: "1" * 64)
    monkeypatch.setattr(jit, "package_hash", lambda directory: "1" * 64)
    assert "2 to run" in vsi("sweep", config, "-o", out).stderr
    assert "2 to run" in vsi("sweep", config, "-o", out, "--fresh").stderr


def test_kept__a_report_of_the_same_inputs_is_kept_and_an_edited_one_made_again(
        tmp_path, monkeypatch):
    """The second ``vsi report`` of the same file into the same directory keeps it (same
    bytes, files not rewritten); a file of the report edited, or the results file
    changed, makes it again, equal to the first."""
    _records(tmp_path, monkeypatch)
    config = write_study(tmp_path / "s", speeds=SPEEDS[:2], seeds=(1,), one_train=True)
    out = tmp_path / "s" / "study.nc"
    assert vsi("sweep", config, "-o", out, "-q").returncode == 0
    rep = tmp_path / "rep"
    first = vsi("report", out, "-o", rep)
    assert first.returncode == 0 and "report written to" in first.stdout, first.stderr
    digest = kept.directory_digest(rep)
    stamp = {p: p.stat().st_mtime_ns for p in rep.rglob("*") if p.is_file()}
    again = vsi("report", out, "-o", rep)
    assert again.returncode == 0 and "report up to date" in again.stdout, again.stdout
    assert again.stderr == first.stderr  # the same warning lines
    assert {p: p.stat().st_mtime_ns for p in rep.rglob("*") if p.is_file()} == stamp
    (rep / "report.md").write_text("edited")
    remade = vsi("report", out, "-o", rep)
    assert "report written to" in remade.stdout
    assert kept.directory_digest(rep) == digest
    # an extra file in the directory: made again (the report replaces its directory)
    (rep / "summary.csv").unlink()
    assert "report written to" in vsi("report", out, "-o", rep).stdout
    assert kept.directory_digest(rep) == digest
    # another results file at the same path: made again
    assert vsi("sweep", config, "-o", out, "-q", "--fresh").returncode == 0
    assert "report written to" in vsi("report", out, "-o", rep).stdout


def test_kept__the_warm_main_job_imports_no_engine_nor_plotting(tmp_path, monkeypatch):
    """``vsi sweep --report`` on a written study whose report is up to date, in a fresh
    interpreter: neither numba, dask, matplotlib, openpyxl nor xarray is imported.  The
    study and its report are written first by the same command in this process (the
    fresh interpreter is the subject of the second run only)."""
    config = write_study(tmp_path / "s", speeds=SPEEDS[:2], seeds=(1,), one_train=True,
                         histories=None)
    env = {**os.environ, kept.CACHE_ENV: str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    argv = [str(config), "-o", str(tmp_path / "s" / "study.nc"), "--report",
            str(tmp_path / "rep"), "-q"]
    monkeypatch.setenv(kept.CACHE_ENV, str(tmp_path / "cache"))
    first = vsi("sweep", *argv)
    assert first.returncode == 0, first.stderr
    assert (tmp_path / "rep" / "report.md").is_file()
    code = ("import sys\nfrom vsi_numba.cli.app import app\n"
            f"sys.argv = ['vsi', 'sweep', *{argv!r}]\n"
            "try:\n    app()\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            "heavy = ('numba', 'dask', 'distributed', 'matplotlib', 'openpyxl', 'xarray')\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & set(heavy)))\n")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "report up to date" in done.stdout, done.stdout
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout


def test_report_package__imports_no_plotting_nor_spreadsheet_until_used():
    """Importing the report package (what ``vsi report`` does before it knows whether the
    file is usable) in a fresh interpreter imports neither matplotlib nor openpyxl; the
    figures' module does when a report is drawn."""
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    code = ("import sys\nimport vsi_numba.analysis.report\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'matplotlib', "
            "'openpyxl'}))\n"
            "import vsi_numba.analysis.plots\n"
            "print('matplotlib' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["[]", "True"], done.stdout
