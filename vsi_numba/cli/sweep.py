"""``vsi sweep``: a study (speeds x trains x realisations), resumable, then optionally its
report.  Exit codes: see :mod:`vsi_numba.study.runner`."""

from __future__ import annotations

import re
from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config_and_output, sigterm_as_interrupt

#: A Dask scheduler address: scheme://host:port or host:port (inproc:// as is).
_SCHEDULER_ADDRESS = re.compile(
    r"^(?:(?:tcp|tls|ucx|ws|wss)://(?:\[[0-9A-Fa-f:.]+\]|[^\s/:\[\]]+):\d{1,5}/?"
    r"|(?:\[[0-9A-Fa-f:.]+\]|[^\s/:\[\]]+):\d{1,5}|inproc://\S+)$")


def sweep_command(config: Path, output: Path | None, workers: int | None,
                  scheduler: str | None, quiet: bool, fresh: bool = False,
                  report_dir: Path | None = None) -> int:
    """``vsi sweep``: run a study; returns the exit code (see :mod:`vsi_numba.study.runner`).

    With ``report_dir``, a written results file (exit code 0 or 1) is then reported
    there (:func:`vsi_numba.cli.report.report_command`); the first non-zero code wins.
    """
    from vsi_numba.config import ConfigError
    from vsi_numba.study.store import StudyError

    pr = Printer()

    def fail(message: str, code: int) -> int:
        pr.error(message)
        return code

    if workers is not None and scheduler is not None:
        return fail("give --workers (local Dask cluster) or --scheduler (existing cluster), "
                    "not both", EXIT_USAGE)
    if workers is not None and workers < 1:
        return fail(f"--workers {workers}: expected a number of workers >= 1", EXIT_USAGE)
    if scheduler is not None and not _SCHEDULER_ADDRESS.match(scheduler):
        return fail(f"--scheduler {scheduler!r}: expected the address of a Dask scheduler, "
                    "tcp://HOST:PORT (or HOST:PORT)", EXIT_USAGE)
    loaded = load_config_and_output(config, output, pr)
    if loaded is None:
        return EXIT_USAGE
    cfg, out_path = loaded
    if not quiet:
        for w in getattr(cfg, "warnings", []) or []:
            pr.warning(w)
    parts = ["vsi", "sweep", str(config)]
    if output is not None:
        parts += ["-o", str(output)]
    if workers is not None:
        parts += ["--workers", str(workers)]
    if scheduler is not None:
        parts += ["--scheduler", scheduler]
    if fresh:
        parts += ["--fresh"]
    try:
        with sigterm_as_interrupt():
            outcome = None if fresh else _written(cfg, out_path, quiet, " ".join(parts))
            if outcome is None:
                from vsi_numba.study import runner

                outcome = runner.execute_study(cfg, output, workers=workers,
                                               scheduler=scheduler, progress=not quiet,
                                               fresh=fresh, quiet=quiet,
                                               command=" ".join(parts))
    except ConfigError as exc:
        pr.config_error(config, exc)
        return EXIT_USAGE
    except StudyError as exc:
        return fail(str(exc), exc.exit_code)
    except KeyboardInterrupt:
        return fail("interrupted: the finished batches are kept; re-run the same command "
                    "to resume", 130)
    except OSError as exc:  # I/O outside the store/output writes (numba cache, temp files)
        return fail(f"{exc}. Finished cases are kept; re-run the same command to resume.", 1)
    code = 0
    n_failed = outcome.n_failed
    if n_failed:
        code = fail(f"{n_failed} of {outcome.n_runs} cases failed numerically "
                    "(status != 0, outputs NaN); see the 'status' and 'message' variables",
                    1)
    try:  # Ctrl-C or SIGTERM between the phases: 130 as in them, no traceback
        with sigterm_as_interrupt():
            _print_governing(out_path, pr)
    except KeyboardInterrupt:
        return fail(f"interrupted: the results file {out_path} is written"
                    + ("; no report was made" if report_dir is not None else ""), 130)
    if report_dir is not None:  # 0 or 1 here: the results file is written
        code = code or _report(out_path, report_dir, quiet)
    return code


def _written(cfg, out_path: Path, quiet: bool, command: str):
    """The study's results file when it is written and its inputs are unchanged
    (:mod:`vsi_numba.study.unchanged`), decided under the output's lock without importing
    the engine; else None."""
    from vsi_numba.study import unchanged
    from vsi_numba.study.outlock import OutputLock
    from vsi_numba.study.progress import _say

    with OutputLock(out_path, command):
        written = unchanged.finished(cfg, out_path)
    if written is not None:
        _say(quiet, unchanged.message(written.n_runs, out_path))
    return written


def _report(out_path: Path, report_dir: Path, quiet: bool) -> int:
    """``vsi report`` of the written file; with ``quiet`` its warning lines (the
    configuration's warnings stored in the file) are left out, its errors kept; a report
    of the same file, options and code is kept (:mod:`vsi_numba.io.kept`: a file written
    again, ``--fresh``, is another file)."""
    import contextlib
    import io
    import sys

    from vsi_numba.cli.report import report_command

    if not quiet:
        return report_command(out_path, report_dir)
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        code = report_command(out_path, report_dir)
    kept = [line for line in buf.getvalue().splitlines()
            if not line.startswith("vsi report: warning:")]
    if kept:
        sys.stderr.write("\n".join(kept) + "\n")
    return code


def _print_governing(path: Path, pr: Printer) -> None:
    """The governing result of every check (:func:`vsi_numba.cli.governing.governing_lines`)
    on stdout; a results file the checks cannot read gives one error line (the sweep's
    exit code stays that of the sweep).  The lines of the same results file and code are
    those recorded when they were computed (:mod:`vsi_numba.io.kept`)."""
    from vsi_numba.io import kept

    sig = kept.signature("governing", path)
    record = kept.kept_value("governing", path, sig)
    lines = record.get("lines") if record is not None else None
    if isinstance(lines, list) and all(isinstance(x, str) for x in lines):
        _show_governing(path, lines, pr)
        return
    import xarray as xr

    from vsi_numba.cli.governing import governing_lines
    from vsi_numba.io.lazy_dask import defer_dask_array_import

    defer_dask_array_import()

    try:
        with xr.open_dataset(path) as ds:
            # the checks read only the envelopes (governing_lines loads those of the
            # governing variant at once); the histories stay on disk
            timed = [n for n, v in ds.variables.items() if "time" in v.dims]
            lines = governing_lines(ds.drop_vars(timed))
    except Exception as exc:  # noqa: BLE001 - the results are written; say why, go on
        pr.error(f"{path}: the governing results cannot be computed ({type(exc).__name__}: "
                 f"{exc}); `vsi report {path}` shows the checks")
        return
    kept.remember_value("governing", path, sig, lines=[str(x) for x in lines])
    _show_governing(path, lines, pr)


def _show_governing(path: Path, lines: list, pr: Printer) -> None:
    pr.line(f"governing results ({path}):")
    for line in lines:
        pr.line(f"  {line}")
