"""``vsi run``: every speed of one configuration (its first train and first track
realisation) to one netCDF file, through the study engine
(:func:`vsi_numba.study.single.run_config`)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config_and_output
from vsi_numba.study.single import run_config


def run_command(config: Path, output: Path | None, quiet: bool) -> int:
    """Entry of ``vsi run``; returns the process exit code.

    0 every speed ran; 1 written, some speeds failed numerically; 2 the run cannot
    start (configuration, output path) or stopped on an error; 130 interrupted.
    """
    from vsi_numba.study.store import StudyError

    pr = Printer()
    loaded = load_config_and_output(config, output, pr)
    if loaded is None:
        return EXIT_USAGE
    cfg, out_path = loaded
    if not quiet:  # -q: no progress, summary lines or config warnings; errors stay
        for w in cfg.base_warnings:  # the run is of the base values, not of study.vary
            pr.warning(w)
    parts = ["vsi", "run", str(config)] + (["-o", str(output)] if output is not None else [])
    try:
        outcome = run_config(cfg, out_path, progress=not quiet, quiet=quiet,
                             command=" ".join(parts))
    except StudyError as exc:
        pr.error(exc)
        return exc.exit_code
    except KeyboardInterrupt:
        pr.error("interrupted: nothing written")
        return 130
    except (ValueError, OSError) as exc:
        pr.error(exc)
        return EXIT_USAGE
    if outcome.n_failed:
        pr.error(f"{outcome.n_failed} of {outcome.n_runs} speeds failed numerically "
                 "(status != 0, outputs NaN); see the 'status' and 'message' variables")
        return 1
    return 0
