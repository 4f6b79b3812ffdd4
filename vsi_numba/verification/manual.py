"""Run the verification cases and write the manual: ``verification.csv`` (one row per
compared figure) and ``verification.html`` (the same, with the installation and each
case's source, inputs and tolerance reasons), in the report's look.

The manual's directory is written whole or not at all
(:func:`vsi_numba.io.atomic.replace_directory`): the cases run and the two files are
written in a new directory beside it, which takes its place when complete; a directory
holding other files is refused, and one that another process writes into is refused
(and locked against such writers while the manual is built)."""

from __future__ import annotations

import contextlib
import io
import math
import platform
import tempfile
import time
import traceback
from pathlib import Path

#: Columns of verification.csv, in order.
COLUMNS = ("id", "case", "title", "source", "model", "quantity", "unit", "reference",
           "computed", "error", "tolerance", "tolerance_reason", "pass", "vsi_numba", "numba",
           "numpy", "scipy", "platform")


def installation() -> dict[str, str]:
    """The versions and machine the verification ran on."""
    import numba
    import numpy
    import scipy

    from vsi_numba import __version__

    return {"vsi_numba": __version__, "numba": numba.__version__,
            "numpy": numpy.__version__, "scipy": scipy.__version__,
            "python": platform.python_version(), "platform": platform.platform(),
            "machine": platform.machine(), "processor": platform.processor() or "-",
            "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}


def run_cases(quick: bool = False, progress=None, workdir: Path | None = None):
    """Run the cases (the ``quick`` subset or all) and return ``(rows, failures)``.

    ``rows`` is a list of dicts with the :data:`COLUMNS`; ``failures`` maps a case id to
    the message of a case that could not run (it counts as failed).  ``progress`` is
    called with a line of text per case.  Each case's output of ``vsi sweep`` is kept in
    ``<case>.log`` of ``workdir`` (a temporary directory by default).
    """
    from vsi_numba.io.atomic import write_text_atomic
    from vsi_numba.verification.cases import CASES

    rows: list[dict] = []
    failures: dict[str, str] = {}
    with contextlib.ExitStack() as stack:
        if workdir is None:
            workdir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vsi-verify-")))
        for case in CASES:
            if quick and not case.quick:
                continue
            start = time.perf_counter()
            sub = Path(workdir) / case.id
            sub.mkdir(parents=True, exist_ok=True)
            log = io.StringIO()
            try:
                with contextlib.redirect_stdout(log), contextlib.redirect_stderr(log):
                    result = case.run(sub)
            except Exception as exc:  # a case that cannot run fails, the others go on
                failures[case.id] = f"{type(exc).__name__}: {exc}"
                write_text_atomic(sub / f"{case.id}.log",
                                  log.getvalue() + traceback.format_exc())
                if progress:
                    progress(f"{case.id} {case.title}: could not run ({failures[case.id]})")
                continue
            write_text_atomic(sub / f"{case.id}.log", log.getvalue())
            for r in result:
                err = r.error
                rows.append({"id": r.id, "case": case.id, "title": r.title, "source": r.source,
                             "model": r.model, "quantity": r.quantity, "unit": r.unit,
                             "reference": r.reference, "computed": r.computed,
                             "error": err, "tolerance": r.tolerance,
                             "tolerance_reason": r.tolerance_reason, "pass": r.passed})
            if progress:
                n_ok = sum(r.passed for r in result)
                progress(f"{case.id} {case.title}: {n_ok}/{len(result)} within tolerance "
                         f"({time.perf_counter() - start:.1f} s)")
    return rows, failures


def write_csv(rows: list[dict], path: Path) -> Path:
    """verification.csv: the :data:`COLUMNS`, one row per compared figure."""
    import pandas as pd

    from vsi_numba.io.atomic import write_atomic

    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    return write_atomic(path, lambda tmp: frame.to_csv(tmp, index=False,
                                                       float_format="%.10g"))


#: What a verification directory holds (anything else is another program's).
MANUAL_ENTRIES = {"verification.csv": False, "verification.html": False, "cases": True}


class ManualDirectoryError(OSError):
    """The directory cannot take the verification manual (other files in it, the
    working directory, or another process writes into it)."""


def _owns(rel: str, is_dir: bool) -> bool:
    head, _, rest = rel.partition("/")
    if head not in MANUAL_ENTRIES:
        return False
    return bool(rest) or is_dir == MANUAL_ENTRIES[head]


def check_directory(target: Path) -> None:
    """Raise :class:`ManualDirectoryError` when ``target`` cannot be replaced by the
    manual: not a directory, the working directory (or one holding it), or holding
    files that are not the manual's."""
    import os

    from vsi_numba.io.atomic import foreign_entries

    if not os.path.lexists(target):
        return
    if not target.is_dir():
        raise ManualDirectoryError(f"'{target}' exists and is not a directory")
    cwd = Path.cwd().resolve()
    if cwd == target.resolve() or target.resolve() in cwd.parents:
        raise ManualDirectoryError(
            f"'{target}' is the working directory or holds it: the manual replaces its "
            "directory whole; give a directory of its own (-o DIR)")
    foreign = foreign_entries(target, _owns)
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more"
                                          if len(foreign) > 3 else "")
        raise ManualDirectoryError(
            f"'{target}' holds files that are not part of the verification manual "
            f"({shown}): the manual replaces its directory whole; give an empty or new "
            "directory, or one that holds only an earlier manual")


def write_html(rows: list[dict], failures: dict[str, str], info: dict[str, str], path: Path,
               quick: bool, workdir: Path | None = None) -> Path:
    """verification.html: the installation, a summary, then each case with its rows and
    its inputs (the configuration files of ``workdir/<case>/``, when given)."""
    import textwrap

    import pandas as pd

    from vsi_numba.analysis.report.document import Markdown, Section, Table
    from vsi_numba.analysis.report.document import write_html as _write
    from vsi_numba.verification.cases import CASES

    n_fail = sum(not r["pass"] for r in rows) + len(failures)
    verdict = "all figures within tolerance" if n_fail == 0 else f"**{n_fail} FAILED**"
    head = Section("", [
        f"{'Quick subset' if quick else 'Full set'} of the verification cases: "
        f"{len(rows)} figures, {verdict}. Each case writes a configuration, runs it with "
        "the study runner that `vsi sweep` calls, reads the netCDF file and compares with a "
        "reference computed independently of the package "
        "(`vsi_numba.verification.reference`: closed forms, scipy integrations, published "
        "and peer figures). Error = computed / reference - 1.",
        Table(pd.DataFrame(list(info.items()), columns=["installation", "value"]),
              "The installation verified")], level=0)
    summary = pd.DataFrame([{"id": r["id"], "quantity": r["quantity"],
                             "reference": r["reference"], "computed": r["computed"],
                             "error": f"{r['error']:+.2e}", "tolerance": f"{r['tolerance']:.1e}",
                             "pass": Markdown("pass" if r["pass"] else "**FAIL**")}
                            for r in rows])
    sections = [Section("Summary", [Table(summary, "Every compared figure", "{:.6g}")]
                        + [f"- {cid}: could not run: {msg}" for cid, msg in failures.items()])]
    cases: dict[str, list[dict]] = {}
    for r in rows:
        cases.setdefault(r["case"], []).append(r)
    titles = {c.id: c.title for c in CASES}
    for cid, items in cases.items():
        first = items[0]
        lines = [f"- Model: {first['model']}"]
        for r in items:
            lines.append(f"- {r['id']} ({r['title']}; {r['quantity']}, {r['unit']}): "
                         f"reference {r['reference']:.6g}, computed {r['computed']:.6g}, "
                         f"error {r['error']:+.2e}, tolerance {r['tolerance']:.1e} "
                         f"({r['tolerance_reason']}); source: {r['source']}")
        blocks = ["\n".join(lines)]
        for cfg in sorted((Path(workdir) / cid).glob("*.toml")) if workdir else []:
            text = textwrap.dedent(cfg.read_text(encoding="utf-8")).strip()
            blocks.append(f"Input `{cfg.name}`:\n\n```toml\n{text}\n```")
        sections.append(Section(f"{cid}: {titles.get(cid, first['title'])}", blocks))
    title = "vsi_numba verification manual"
    return _write(sections, path, title, header=[head])


def run_verification(outdir, quick: bool = False, progress=None) -> tuple[list[dict], dict]:
    """Run the cases, write ``outdir/verification.csv`` and ``outdir/verification.html``
    and return ``(rows, failures)``; the run failed if any row fails or ``failures``."""
    from vsi_numba.io.atomic import DirectoryBusyError, replace_directory

    info = installation()
    try:
        with replace_directory(outdir, _owns, check=check_directory) as tmp:
            rows, failures = run_cases(quick=quick, progress=progress, workdir=tmp / "cases")
            for r in rows:
                if not math.isfinite(r["error"]):
                    r["pass"] = False
                r.update({k: info[k] for k in ("vsi_numba", "numba", "numpy", "scipy",
                                               "platform")})
            write_csv(rows, tmp / "verification.csv")
            write_html(rows, failures, info, tmp / "verification.html", quick, tmp / "cases")
    except DirectoryBusyError as exc:
        raise ManualDirectoryError(str(exc)) from None
    return rows, failures
