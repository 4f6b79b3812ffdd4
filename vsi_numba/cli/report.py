"""``vsi report``: the EN 1990 A2 checks, figures and Markdown report of a results file
(:func:`vsi_numba.analysis.report.write_report`, or the variants report of a parametric
study)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, sigterm_as_interrupt


def report_command(results: Path, outdir: Path | None = None, fresh: bool = False) -> int:
    """CLI entry of ``vsi report RESULTS.nc [-o DIR]``: ``report.html``, ``report.md``
    and the tables (:func:`vsi_numba.analysis.report.write_report`). The file is read
    lazily: memory does not grow with the study.

    Parameters
    ----------
    results : Path
        netCDF results file.
    outdir : Path, optional
        Report directory; default ``<results stem>_report`` beside the file.

    Returns
    -------
    int
        0 on success; 2 when the file is missing, unreadable or lacks the variables the
        report needs, or the report directory holds other files (a report replaces its
        directory whole); 1 when the report directory cannot be written; 130 when
        interrupted (Ctrl-C or SIGTERM, as ``vsi sweep``): the directory then holds a
        whole report, never parts of two. The reason goes to stderr as one line (no
        traceback).

    A report directory written from the same results file, options and code, and left
    as it was written, is kept as it is (:mod:`vsi_numba.io.kept`; ``fresh`` writes it
    again).
    """
    pr = Printer()

    def error(message: str) -> None:
        pr.line(f"vsi report: {message}", stderr=True)

    results = Path(results)
    if not results.exists():
        error(f"results file '{results}' does not exist")
        return EXIT_USAGE
    if not results.is_file():
        error(f"'{results}' is not a file")
        return EXIT_USAGE
    from vsi_numba.io import kept

    given = outdir
    if outdir is None:
        outdir = results.with_name(f"{results.stem}_report")
    sig = kept.signature("report", results, outdir)
    record = None if fresh else kept.kept_directory("report", outdir, sig)
    if record is not None:
        for line in record.get("warnings", []):
            error(f"warning: {line}")
        html = Path(outdir) / "report.html"
        listed = "variants.csv" if Path(outdir, "variants.csv").is_file() else "tables/"
        pr.line(f"report up to date: {html} (and report.md, {listed}, tables.xlsx) was "
                "written from this results file with these options and this code; kept as "
                "it is")
        return 0
    import numpy as np
    import xarray as xr

    from vsi_numba.io.lazy_dask import defer_dask_array_import

    defer_dask_array_import()
    from vsi_numba.analysis.dataset import ResultsError, prepare, require
    from vsi_numba.analysis.report import REQUIRED_VARIABLES, stored_warnings, write_report
    from vsi_numba.analysis.report.atomic import ReportDirectoryError

    try:
        ds = xr.open_dataset(results)
    except Exception as exc:  # noqa: BLE001 - any reader failure means "unreadable"
        error(f"cannot read '{results}' as a netCDF results file "
              f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})")
        return EXIT_USAGE
    with ds:
        from vsi_numba.existing.report import kind_of

        if kind_of(ds) is not None:  # a posterior (vsi calibrate) or reliability file
            from vsi_numba.cli.existing import existing_report

            return existing_report(ds, results, given, pr)
        # ds stays lazy: the report loads the envelopes and reads the time histories one
        # case at a time (memory independent of the study's size)
        if "variant" in ds.dims:  # a parametric study: the report over the variants
            from vsi_numba.analysis.report.variants import write_variants_report

            writer, data = write_variants_report, ds
        else:
            try:
                data = prepare(ds)
                require(data, REQUIRED_VARIABLES, "the report")
            except ResultsError as exc:
                error(f"'{results}' is not a usable results file: {exc}")
                return EXIT_USAGE
            writer = write_report
        if "status" in data and data["status"].size and bool(
                (data["status"].values != 0).all()):
            n = int(data["status"].size)
            msgs = (sorted({str(m) for m in np.ravel(data["message"].values)})
                    if "message" in data else [])
            error(f"'{results}': every case ({n}) failed numerically (status != 0, "
                  "outputs NaN): there is nothing to check"
                  + (f"; e.g. {msgs[0]}" if msgs else "") + ". Fix the run (see the "
                  "warnings and docs/reference/troubleshooting.md) and run it again")
            return 1
        warnings = [str(r["message"]) for r in stored_warnings(data)]
        for line in warnings:
            error(f"warning: {line}")
        try:
            with sigterm_as_interrupt():
                path = writer(data, outdir, source_path=results)
        except KeyboardInterrupt:
            error(f"interrupted: '{outdir}' holds a whole report, the earlier one (if any) "
                  "or, when the interrupt came as it was put in place, the new one; run the "
                  "same command again")
            return 130
        except ResultsError as exc:
            error(f"'{results}': {exc}")
            return EXIT_USAGE
        except ReportDirectoryError as exc:
            error(f"cannot write the report: {exc}")
            return EXIT_USAGE
        except OSError as exc:
            from vsi_numba.io.atomic import describe

            error(f"cannot write the report to '{outdir}': {describe(exc)}; nothing was "
                  "written (an earlier report there is kept)")
            return 1
    kept.remember_directory("report", outdir, sig, warnings=warnings)
    pr.line(f"report written to {path.with_suffix('.html')} (and {path.name}, "
            f"{'variants.csv' if path.parent.joinpath('variants.csv').is_file() else 'tables/'}"
            ", tables.xlsx)")
    return 0
