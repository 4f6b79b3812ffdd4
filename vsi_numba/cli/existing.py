"""``vsi calibrate`` and ``vsi reliability``: existing bridges (the numerics are in
:mod:`vsi_numba.existing`)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config, output_problem


def _write(ds, out: Path) -> None:
    from vsi_numba.io.netcdf import encoding_for, write_atomic

    write_atomic(out, lambda tmp: ds.to_netcdf(tmp, engine="netcdf4",
                                               encoding=encoding_for(ds)))


def _prepare(config: Path, output: Path, section: str, command: str, pr: Printer):
    cfg = load_config(config, pr)
    if cfg is None:
        return None
    if not cfg.resolved().get(section):
        pr.error(f"{config}: no [{section}] section: `vsi {command}` needs one (see "
                 f"docs/manual/{'calibration' if section == 'calibration' else 'reliability'}"
                 ".md)")
        return None
    problem = output_problem(config, Path(output), cfg)
    if problem is not None:
        pr.error(problem)
        return None
    return cfg


def _store(output: Path) -> Path:
    """The file of the evaluations that makes a run resumable (next to the output)."""
    return Path(f"{output}.evaluations")


def _notes(notes, quiet: bool, pr: Printer) -> None:
    if not quiet:
        for n in notes:
            pr.line(n, stderr=True)


def calibrate_command(config: Path, output: Path, quiet: bool, workers=None, scheduler=None,
                      backend=None, fresh: bool = False) -> int:
    """Entry of ``vsi calibrate CONFIG -o POSTERIOR.nc``; returns the exit code (0
    written, 2 the calibration cannot start or be made, 130 interrupted: nothing
    written)."""
    from vsi_numba.existing.calibrate import CalibrationError, calibrate

    pr = Printer()
    cfg = _prepare(config, output, "calibration", "calibrate", pr)
    if cfg is None:
        return EXIT_USAGE
    if not quiet:
        for w in cfg.warnings:
            pr.warning(w)
    last = [-1]

    def progress(done, total):
        pct = int(100 * done / max(total, 1))
        if not quiet and pct // 10 != last[0]:
            last[0] = pct // 10
            pr.line(f"calibrate: {done} of about {total} forward runs", stderr=True)

    notes: list[str] = []
    ds = _compute_and_write(lambda: calibrate(cfg, progress=progress,
                                              command=f"vsi calibrate {config} -o {output}",
                                              backend=backend, workers=workers,
                                              scheduler=scheduler, store=_store(output),
                                              fresh=fresh, notes=notes),
                            CalibrationError, output, pr, notes, quiet)
    if isinstance(ds, int):
        return ds
    import numpy as np

    x = ds["posterior"].values
    for i, p in enumerate(ds["parameter"].values):
        q = np.percentile(x[:, i], [5, 50, 95])
        pr.line(f"{p}: median {q[1]:.5g} (5 % {q[0]:.5g}, 95 % {q[2]:.5g}), R-hat "
                f"{float(ds['r_hat'].values[i]):.3f}")
    pr.line(f"posterior written to {output} ({ds.attrs['n_forward_runs']} forward runs, "
            f"{ds.attrs['elapsed_s']:.1f} s)")
    return 0


def reliability_command(config: Path, output: Path, quiet: bool, workers=None,
                        scheduler=None, backend=None, fresh: bool = False) -> int:
    """Entry of ``vsi reliability CONFIG -o RELIABILITY.nc``; returns the exit code."""
    from vsi_numba.existing.reliability import ReliabilityError, estimate

    pr = Printer()
    cfg = _prepare(config, output, "reliability", "reliability", pr)
    if cfg is None:
        return EXIT_USAGE
    if not quiet:
        for w in cfg.warnings:
            pr.warning(w)
    notes: list[str] = []
    ds = _compute_and_write(lambda: estimate(cfg, command=f"vsi reliability {config} -o "
                                                         f"{output}", backend=backend,
                                             workers=workers, scheduler=scheduler,
                                             store=_store(output), fresh=fresh, notes=notes),
                            ReliabilityError, output, pr, notes, quiet)
    if isinstance(ds, int):
        return ds
    p = float(ds["probability_of_exceedance_range"].values)
    b = float(ds["reliability_index_range"].values)
    pr.line(f"{ds.attrs['check']}: P(exceeded) = {p:.3g} over the speeds (beta = {b:.3f}, "
            f"cov {float(ds['cov_range'].values):.3f}, {int(ds['runs_range'].values)} runs)")
    pr.line(f"reliability written to {output}")
    return 0


def existing_report(ds, results: Path, outdir: Path | None, pr: Printer) -> int:
    """``vsi report`` of a posterior or reliability file."""
    from vsi_numba.existing.report import write_report

    if outdir is None:
        outdir = results.with_name(f"{results.stem}_report")
    try:
        path = write_report(ds.load(), outdir)
    except KeyboardInterrupt:
        pr.line(f"vsi report: interrupted: '{outdir}' holds a whole report or none",
                stderr=True)
        return 130
    except (KeyError, ValueError) as exc:
        pr.line(f"vsi report: '{results}' is not a usable {ds.attrs.get('vsi_file')} file: "
                f"{exc}", stderr=True)
        return EXIT_USAGE
    except OSError as exc:
        pr.line(f"vsi report: cannot write the report to '{outdir}': {exc}", stderr=True)
        return 1
    pr.line(f"report written to {path}")
    return 0


def _compute_and_write(compute, error_type, output, pr, notes=(), quiet=False):
    """``compute()`` and its dataset written to ``output``, then the store of its
    evaluations removed; the dataset, or the exit code after the message
    (``error_type``: the command's own refusal)."""
    import sys

    from vsi_numba.existing.forward import ForwardError
    from vsi_numba.existing.parallel import BackendError
    from vsi_numba.study.outlock import OutputBusyError, OutputLock

    store = _store(output)
    try:
        # one writer per output, as for a sweep: the store beside it (appended, discarded
        # when it belongs to another configuration) is the holder's alone
        with OutputLock(output, "vsi " + " ".join(sys.argv[1:])):
            ds = compute()
            _notes(notes, quiet, pr)
            _write(ds, Path(output))
            store.unlink(missing_ok=True)
    except OutputBusyError as exc:
        pr.error(exc)
        return EXIT_USAGE
    except (error_type, ForwardError, BackendError) as exc:
        _notes(notes, quiet, pr)
        pr.error(exc)
        return EXIT_USAGE
    except KeyboardInterrupt:
        _notes(notes, quiet, pr)
        kept = f": the forward runs so far are kept in {store}; the same command continues " \
               "from them" if store.exists() else ": nothing written"
        pr.error(f"interrupted{kept}")
        return 130
    except OSError as exc:
        pr.error(f"cannot write {output}: {exc}")
        return EXIT_USAGE
    return ds
