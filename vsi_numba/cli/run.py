"""``vsi run``: every speed of one configuration (its first train and first track
realisation) to one netCDF file (:func:`vsi_numba.study.single.run_config`)."""

from __future__ import annotations

import sys
from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config_and_output
from vsi_numba.study.single import run_config


def run_command(config: Path, output: Path | None, quiet: bool) -> int:
    """Entry of ``vsi run``; returns the process exit code.

    0 every speed ran; 1 written, some speeds failed numerically; 2 the run cannot
    start (configuration, output path) or stopped on an error.
    """
    from vsi_numba.io.netcdf import write_netcdf

    pr = Printer()
    loaded = load_config_and_output(config, output, pr)
    if loaded is None:
        return EXIT_USAGE
    cfg, out_path = loaded
    for w in cfg.warnings:
        pr.warning(w)
    show = not quiet and sys.stderr.isatty()

    def progress(done, total, ds):
        if not quiet:
            v = ds.attrs["speed_kmh"]
            flag = "ok" if ds.attrs["status"] == 0 else f"FAILED: {ds.attrs['message']}"
            pr.line(f"[{done}/{total}] {v:7.1f} km/h  {flag}", stderr=True)

    try:
        ds = run_config(cfg, progress if (show or not quiet) else None)
    except (ValueError, OSError) as exc:
        pr.error(exc)
        return EXIT_USAGE
    try:
        write_netcdf(ds, out_path)
    except OSError as exc:
        pr.error(f"cannot write {out_path}: {exc}")
        return EXIT_USAGE
    if not quiet:
        pr.line(f"wrote {out_path}", stderr=True)
    return 1 if ds.attrs["failed_cases"] else 0
