"""``vsi verify``: run the verification cases on this installation and write the
verification manual (``verification.html``, ``verification.csv``).

Exit codes: 0 every figure within its tolerance; 1 a figure out of tolerance or a case
that could not run; 2 the output directory cannot be written.
"""

from __future__ import annotations

from pathlib import Path

import typer

from vsi_numba.cli.common import EXIT_USAGE, Printer


def verify(
    quick: bool = typer.Option(False, "--quick",
                               help="a subset of the cases (well under a minute with "
                                    "compiled kernels)"),
    output: Path = typer.Option(Path("verification"), "-o", "--output",
                                help="directory of verification.html and verification.csv"),
):
    """Run the verification cases (closed forms, scipy integrations, published and peer
    figures) through vsi sweep and write the verification manual."""
    raise typer.Exit(verify_command(quick, output))


def verify_command(quick: bool, output: Path) -> int:
    """``vsi verify``: returns the exit code (see the module docstring)."""
    import os

    from vsi_numba.io.atomic import describe
    from vsi_numba.study.store import OutputNotWritableError, check_writable

    pr = Printer()
    output = Path(output)
    try:  # the manual is built beside its directory: prove that place writable first
        check_writable(Path(os.path.abspath(output)).parent, "verification manual")
    except OutputNotWritableError as exc:
        pr.error(f"--output {output}: {exc}")
        return EXIT_USAGE
    from vsi_numba.verification.manual import ManualDirectoryError, run_verification

    try:
        rows, failures = run_verification(output, quick=quick,
                                          progress=lambda s: pr.line(s, stderr=True))
    except ManualDirectoryError as exc:
        pr.error(f"--output {output}: {exc}")
        return EXIT_USAGE
    except OSError as exc:
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        pr.error(f"--output {output}: cannot write the verification manual{where}: "
                 f"{describe(exc)}; nothing was written (an earlier manual there is kept)")
        return EXIT_USAGE
    bad = [r for r in rows if not r["pass"]]
    for r in bad:
        pr.line(f"FAIL {r['id']}: {r['quantity']}: computed {r['computed']:.6g}, reference "
                f"{r['reference']:.6g} ({r['source']}), error {r['error']:+.2e} > "
                f"tolerance {r['tolerance']:.1e}")
    for cid, msg in failures.items():
        pr.line(f"FAIL {cid}: could not run: {msg}")
    verdict = "all within tolerance" if not bad and not failures else (
        f"{len(bad)} out of tolerance, {len(failures)} case(s) could not run")
    pr.line(f"verification: {len(rows)} figures, {verdict}; manual: "
            f"{output / 'verification.html'}, {output / 'verification.csv'}")
    return 1 if bad or failures else 0
