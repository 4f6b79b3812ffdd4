"""``vsi run``: every speed of one configuration (its first train and first track
realisation), one netCDF file.  The full sweep over trains and realisations, with
parallel workers and resume, is ``vsi sweep`` (``vsi_numba.study``)."""

from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from vsi_numba.io.schema import attrs_for


def _source() -> str:
    import numba

    from vsi_numba import __version__

    return f"vsi_numba {__version__} (numba {numba.__version__}, HHT-alpha direct method)"


def run_config(cfg, progress=None) -> xr.Dataset:
    """Run every speed of ``cfg`` for its first train and first irregularity realisation."""
    from vsi_numba.solver.simulate import simulate
    from vsi_numba.study.grid import profile_range
    from vsi_numba.study.runner import track_type_of, warnings_json

    bridge = cfg.build_bridge()
    trains = cfg.trains()
    train = trains[0]
    settings = cfg.solver_settings()
    # the same track range as `vsi sweep`, so a seed is the same realisation in both
    x_range = profile_range(bridge.length, [t.length for t in trains], settings.approach,
                            settings.free_vibration)
    realisation, profile = cfg.irregularities(*x_range)[0]
    runs = []
    speeds = np.asarray(cfg.speeds_kmh, float)
    for k, v_kmh in enumerate(speeds):
        ds = simulate(bridge, train, v_kmh / 3.6, profile=profile, settings=settings,
                      output_points=cfg.output_points, save_histories=cfg.save_time_histories)
        runs.append(ds)
        if progress is not None:
            progress(k + 1, speeds.size, ds)
    status = [int(d.attrs["status"]) for d in runs]
    messages = [str(d.attrs["message"]) for d in runs]
    for d in runs:
        d.attrs = {}
    out = xr.concat(runs, dim="speed", join="outer", data_vars="all", coords="minimal",
                    compat="override", combine_attrs="drop")
    for name in ("vehicle_name", "wheel_position", "static_wheel_load"):
        if name in out and "speed" in out[name].dims:
            out[name] = out[name].isel(speed=0, drop=True)
    out = out.assign_coords(
        speed=("speed", speeds / 3.6, attrs_for("speed")),
        speed_kmh=("speed", speeds, attrs_for("speed_kmh")),
    )
    out["status"] = ("speed", np.asarray(status, np.int32), attrs_for("status"))
    out["message"] = ("speed", np.asarray(messages, dtype=str),
                      {"long_name": "analysis status message", "units": "1"})
    out["frequency"] = ("mode", bridge.frequencies, attrs_for("frequency"))
    from vsi_numba.solver.simulate import static_deck_envelope

    out["max_static_deck_displacement"] = (
        "point", static_deck_envelope(bridge, train, out.point.values),
        {"units": "m", "long_name": "maximum static deck displacement under the train "
         "(same modes, crawling speed)", "positive": "down"},
    )
    out["train_regular_length"] = ((), float(train.regular_length),
                                   {"units": "m", "long_name": "regular coach length D"})
    out = out.assign_coords(mode=("mode", np.arange(1, bridge.n_modes + 1), attrs_for("mode")))
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    out.attrs = {
        "title": cfg.title,
        "Conventions": "CF-1.12",
        "source": _source(),
        "history": f"{now} vsi {' '.join(sys.argv[1:])}".strip(),
        "config_json": cfg.to_json(),
        "config_sha256": cfg.sha256,
        "train": train.name,
        "train_status": train.status or "user",
        "irregularity": int(realisation),
        "profile": profile.label,
        "bridge_description": bridge.description,
        "bridge_length": float(bridge.length),
        "dt": float(settings.dt),
        "hht_alpha": float(settings.hht_alpha),
        "failed_cases": int(sum(s != 0 for s in status)),
        "track_type": track_type_of(cfg),
        "warnings_json": warnings_json(cfg),
    }
    if cfg.warnings:
        out.attrs["config_warnings"] = "\n".join(str(w) for w in cfg.warnings)
    return out


def same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file (existing or not)."""
    try:
        if a.exists() and b.exists():
            return a.samefile(b)
        return a.expanduser().resolve() == b.expanduser().resolve()
    except (OSError, ValueError, RuntimeError):
        return False


def output_problem(config: Path, out_path: Path) -> str | None:
    """Why ``out_path`` cannot take the results of ``config`` (checked before any
    computation): the input itself, a directory, an unwritable location; else None."""
    from vsi_numba.study.store import OutputNotWritableError, check_writable

    if same_file(Path(config), out_path):
        return (f"the output {out_path} is the configuration file itself: refusing to "
                "overwrite the input; choose another output (-o PATH, ending in .nc)")
    if out_path.is_dir():
        return f"the output {out_path} is a directory; give a file path (-o PATH)"
    try:
        check_writable(out_path.parent if str(out_path.parent) else Path("."),
                       "results file")
    except OutputNotWritableError as exc:
        return str(exc)
    return None


def run_command(config: Path, output: Path | None, quiet: bool) -> int:
    """Entry of ``vsi run``; returns the process exit code."""
    from rich.console import Console
    from rich.markup import escape

    from vsi_numba.config import load_config_for_cli
    from vsi_numba.io.netcdf import write_netcdf

    err = Console(stderr=True)

    def error(text: str) -> None:  # user text (paths, messages) is printed literally
        err.print(f"[bold red]error[/]: {escape(str(text))}", highlight=False)

    cfg = load_config_for_cli(config, err)
    if cfg is None:
        return 2
    out_path = Path(output) if output is not None else Path(cfg.output_path)
    problem = output_problem(config, out_path)
    if problem is not None:
        error(problem)
        return 2
    for w in cfg.warnings:
        err.print(f"[yellow]warning[/]: {escape(str(w))}", highlight=False)
    show = not quiet and sys.stderr.isatty()

    def progress(done, total, ds):
        if not quiet:
            v = ds.attrs["speed_kmh"]
            flag = "ok" if ds.attrs["status"] == 0 else f"FAILED: {ds.attrs['message']}"
            err.print(f"[{done}/{total}] {v:7.1f} km/h  {flag}", highlight=False,
                      markup=False)

    try:
        ds = run_config(cfg, progress if (show or not quiet) else None)
    except (ValueError, OSError) as exc:
        error(exc)
        return 2
    try:
        write_netcdf(ds, out_path)
    except OSError as exc:
        error(f"cannot write {out_path}: {exc}")
        return 2
    if not quiet:
        err.print(f"wrote {out_path}", highlight=False, markup=False)
    return 1 if ds.attrs["failed_cases"] else 0
