"""A synthetic results Dataset in the exact study layout, for tests, demos and docs.

The numbers are not a simulation: resonance-shaped curves around the first resonance speed
``f1 D`` of each train, scaled to plausible magnitudes, with multiplicative lognormal
scatter per irregularity realisation. Tests overwrite single values to set answers by
construction.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from vsi_numba.io.netcdf import CONVENTIONS
from vsi_numba.io.schema import attrs_for


def synthetic_results(
    speeds_kmh=(200.0, 250.0, 300.0, 350.0),
    trains=(("HSLM-A1", 18.0, 50, "standard"), ("HSLM-A4", 21.0, 44, "standard")),
    seeds=(-1,),
    n_points: int = 3,
    n_vehicles: int = 4,
    bridge_length: float = 20.0,
    frequencies=(5.0, 20.0, 45.0, 80.0),
    track_type: str = "ballasted",
    histories: bool = False,
    n_time: int = 400,
    scatter: float = 0.1,
    seed: int = 1,
    bridge_kind: str = "simply_supported",
    spans=None,
    contact_loss_events: bool = False,
) -> xr.Dataset:
    """Build a results Dataset with every declared variable.

    Parameters
    ----------
    speeds_kmh : sequence of float
        Speeds (km h-1); the ``speed`` coordinate is in m s-1.
    trains : sequence of (name, D, n_wheels, status)
        Train name, regular coach length D (m, 0 = none), number of wheels (axles) and
        data status. Fewer wheels than the largest train are NaN-padded.
    seeds : sequence of int
        Irregularity realisations; -1 = deterministic track.
    n_points : int
        Output points, evenly inside the span.
    n_vehicles : int
        Car bodies per train.
    bridge_length : float
        Span (m).
    frequencies : sequence of float
        Bridge natural frequencies (Hz).
    track_type : str
        Global attribute ``track_type``.
    histories : bool
        Add time histories on ``time`` (``n_time`` steps).
    scatter : float
        Coefficient of variation of the lognormal scatter between realisations.
    seed : int
        Random seed of the scatter.
    bridge_kind : str
        ``bridge.kind`` written into ``config_json``.
    spans : sequence of float, optional
        ``bridge.spans`` written into ``config_json``; default ``[bridge_length]``.
    contact_loss_events : bool
        Add ``longest_contact_loss`` (s, longest single separation: here the total) and
        ``single_step_contact_losses`` (0) per wheel.

    Returns
    -------
    xarray.Dataset
    """
    rng = np.random.default_rng(seed)
    speed = np.asarray(speeds_kmh, float) / 3.6
    names = [t[0] for t in trains]
    D = np.array([t[1] for t in trains], float)
    n_wheels_per = [int(t[2]) for t in trains]
    n_wheels = max(n_wheels_per)
    seeds = np.asarray(seeds, dtype=np.int64)
    points = bridge_length * (np.arange(n_points) + 1) / (n_points + 1)
    f1 = float(frequencies[0])
    ns, nt, nr, nv = speed.size, len(trains), seeds.size, n_vehicles

    # Resonance shape per (speed, train): 1 at v = f1 D, decaying with distance.
    v_res = np.where(D > 0, f1 * D, np.inf)
    width = 4.0  # m/s, half width of the synthetic resonance peak
    shape = 1.0 / (1.0 + ((speed[:, None] - v_res[None, :]) / width) ** 2)  # (ns, nt)
    noise = rng.lognormal(0.0, scatter, size=(ns, nt, nr))
    noise[:, :, seeds == -1] = 1.0

    span_shape = np.sin(np.pi * points / bridge_length)  # (npt,)
    static = 2.0e-3 * span_shape[None, :] * np.ones((nt, 1))  # (nt, npt) m
    amp = 1.0 + 0.1 + 0.6 * shape  # dynamic/static
    disp = static[None, :, None, :] * (amp[:, :, None] * noise)[..., None]
    acc = (0.5 + 3.0 * shape)[:, :, None, None] * noise[..., None] * (
        0.6 + 0.4 * span_shape)[None, None, None, :]

    q0 = np.full((nt, n_wheels), np.nan)
    for j, n in enumerate(n_wheels_per):
        q0[j, :n] = 170e3
    dq = (0.1 + 0.3 * shape)[:, :, None, None] * noise[..., None] * np.linspace(
        0.8, 1.0, n_wheels)[None, None, None, :] * np.isfinite(q0)[None, :, None, :]
    dq = np.where(np.isfinite(q0)[None, :, None, :], dq, np.nan)
    qmin = q0[None, :, None, :] * (1.0 - dq)
    qmax = q0[None, :, None, :] * (1.0 + dq)
    loss = np.where(dq >= 1.0, 0.01, 0.0) * np.isfinite(dq)
    loss = np.where(np.isfinite(dq), loss, np.nan)
    carbody = (0.2 + 0.9 * shape)[:, :, None, None] * noise[..., None] * np.ones(nv)

    case = ("speed", "train", "irregularity")
    ds = xr.Dataset(
        {
            "max_deck_displacement": (case + ("point",), disp),
            "max_deck_acceleration": (case + ("point",), acc),
            "time_of_max_deck_displacement": (case + ("point",), np.full(disp.shape, 1.0)),
            "time_of_max_deck_acceleration": (case + ("point",), np.full(acc.shape, 1.0)),
            "min_contact_force": (case + ("wheel",), qmin),
            "max_contact_force": (case + ("wheel",), qmax),
            "max_wheel_unloading": (case + ("wheel",), dq),
            "contact_loss_duration": (case + ("wheel",), loss),
            "contact_loss_count": (case + ("wheel",), np.where(loss > 0, 1.0, 0.0)),
            "position_of_min_contact_force": (case + ("wheel",), np.full(dq.shape, 10.0)),
            "max_carbody_acceleration": (case + ("vehicle",), carbody),
            "status": (case, np.zeros((ns, nt, nr), dtype=np.int32)),
            "static_wheel_load": (("train", "wheel"), q0),
            "max_static_deck_displacement": (("train", "point"), static),
            "train_regular_length": (("train",), D),
            "train_status": (("train",), np.array([t[3] for t in trains], dtype=object)),
            "frequency": (("mode",), np.asarray(frequencies, float)),
        },
        coords={
            "speed": speed,
            "speed_kmh": ("speed", speed * 3.6),
            "train": np.array(names, dtype=object),
            "irregularity": seeds,
            "point": points,
            "wheel": np.arange(n_wheels),
            "vehicle": np.arange(nv),
            "mode": np.arange(1, len(frequencies) + 1),
        },
    )
    if histories:
        t = np.linspace(0.0, 4.0, n_time)
        window = np.sin(np.pi * t / t[-1]) ** 2
        sig = window * np.sin(2 * np.pi * f1 * t)
        sig = sig / np.abs(sig).max()
        ds = ds.assign_coords(time=t)
        ds["deck_displacement"] = (
            case + ("time", "point"),
            np.abs(disp)[:, :, :, None, :] * (0.5 + 0.5 * sig)[None, None, None, :, None],
        )
        ds["deck_acceleration"] = (
            case + ("time", "point"), acc[:, :, :, None, :] * sig[None, None, None, :, None])
        wav = np.sin(2 * np.pi * 2 * f1 * t) * window
        wav = wav / np.abs(wav).max()
        ds["contact_force"] = (
            case + ("time", "wheel"),
            q0[None, :, None, None, :] * (1.0 - dq[:, :, :, None, :] * wav[None, None, None, :,
                                                                           None]),
        )
        ds["in_contact"] = (case + ("time", "wheel"),
                            np.ones(ds["contact_force"].shape, dtype=np.int8))
        ds["carbody_acceleration"] = (
            case + ("time", "vehicle"),
            carbody[:, :, :, None, :] * sig[None, None, None, :, None])
    for name in list(ds.variables):
        try:
            ds[name].attrs.update(attrs_for(name))
        except KeyError:
            pass
    ds["contact_loss_count"].attrs.update(units="1", long_name="number of contact losses")
    if contact_loss_events:
        ds["longest_contact_loss"] = ds["contact_loss_duration"].copy().assign_attrs(
            units="s", long_name="longest single separation of the wheel from the rail")
        ds["single_step_contact_losses"] = (ds["contact_loss_count"] * 0.0).assign_attrs(
            units="1", long_name="separations lasting exactly one time step")
    spans = [float(bridge_length)] if spans is None else [float(x) for x in spans]
    config = {"title": "synthetic", "bridge": {"kind": bridge_kind, "spans": spans}}
    ds.attrs.update(
        title="Synthetic results (vsi_numba.analysis.synthetic)",
        history="synthetic_results()",
        source="vsi_numba synthetic data",
        Conventions=CONVENTIONS,
        config_json=json.dumps(config),
        config_sha256="0" * 64,
        track_type=track_type,
        bridge_length=float(bridge_length),
        bridge_description=f"simply supported span L = {bridge_length:g} m (synthetic)",
    )
    return ds
