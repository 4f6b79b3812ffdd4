"""One configuration's first train on its first track realisation, every speed, as one
dataset (what ``vsi run`` writes).  The full sweep over trains and realisations, with
parallel workers and resume, is :func:`vsi_numba.study.runner.run_study`."""

from __future__ import annotations

import datetime as _dt
import sys

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
