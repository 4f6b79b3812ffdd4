"""Deck checks: peak deck acceleration (EN 1990 A2.4.4.2.1(4)P), dynamic increment and
design factor (EN 1991-2 6.4.6.5, Annex C), maximum deck displacement."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.checks.common import (
    DEFAULT_Q,
    _case_realisation,
    _summarise,
    design_value,
    profile_of,
)
from vsi_numba.analysis.checks.determinant import determinant_length
from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    ResultsError,
    bridge_frequencies,
    nanmax,
    prepare,
    require,
    track_type,
    track_type_assumed,
)
from vsi_numba.en1990 import (
    DECK_ACCELERATION_KEYS,
    deck_acceleration_limits,
    frequency_cutoff,
)
from vsi_numba.en1991 import irregularity_allowance


def _not_together(ds, what: str) -> None:
    """Refuse ``what`` for interaction trains that ran in one run with the trains of
    ``train.other_trains`` (``other_trains_loading = "together"``): the deck
    displacement is then that of every train loaded, ``max_static_deck_displacement``
    the static deflection of one train, and their ratio no dynamic increment."""
    from vsi_numba.io.schema import TOGETHER

    if ds.attrs.get("other_trains_loading") == TOGETHER:
        raise ResultsError(
            f"{what}: train.other_trains: the interaction trains ran in one run with the "
            "trains on the other tracks, so the deck displacement holds every train "
            "loaded and the static deflection one train, whose ratio is no dynamic "
            "increment; the load effects give the dynamic increments with every train "
            "loaded (Several tracks loaded)")

def deck_acceleration_check(
    ds: xr.Dataset, limit: float | None = None, q: float = DEFAULT_Q, n_boot: int = 2000,
    seed: int = 0, profile=None,
) -> xr.Dataset:
    """Peak vertical deck acceleration against EN 1990 A2.4.4.2.1(4)P.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_deck_acceleration(speed, train, irregularity, point)`` (m s-2)
        and, from the solver, the whole-deck envelope
        ``max_deck_acceleration_whole_deck(speed, train, irregularity)`` with its
        ``position_of_max_deck_acceleration_whole_deck`` (m): the maximum over a grid
        along every span plus the output points, so the check does not depend on where
        the output points are.  Files without it are checked at the output points only
        (attribute ``whole_deck`` = 0).  A deck in space (attribute ``loaded_track``)
        adds ``max_track_acceleration`` of the loaded track at the output points and its
        ``max_track_acceleration_whole_deck`` (with its position) on the whole-deck grid
        along the track line when present (attribute ``loaded_track_whole_deck`` = 1).  The
        solver band-limits both to the modes up to
        the cut-off ``max(30 Hz, 1.5 f1, f3)`` (:func:`frequency_cutoff`), as the clause
        requires.
    limit : float, optional
        Limit (m s-2). Default from the ``track_type`` attribute and the code profile:
        3.5 ballasted, 5.0 direct fastening (recommended values); a file that does
        not state its track type gets the stricter ballasted limit
        (attribute ``track_type_assumed`` = 1).
    q : float
        Characteristic fractile over irregularity realisations.
    n_boot, seed
        Bootstrap settings of the realisation statistics.
    profile : CodeProfile, optional
        Code profile; default: the one of the results (:func:`profile_of`).

    Returns
    -------
    xarray.Dataset
        ``value(speed, train)``: max over the deck (whole-deck envelope and output
        points) of the peak acceleration, design value over realisations
        (:func:`design_value`); ``point_of_max(speed, train)`` (m: the deck abscissa of
        the peak, grid point or output point); ``margin``, ``utilisation``, ``passed``;
        the realisation statistics; summary attrs (module docstring) plus
        ``track_type``, ``frequency_cutoff`` (Hz, NaN without ``frequency``),
        ``highest_frequency`` (highest mode in the model), ``governing_point`` (m, the x
        of the governing peak), ``governing_output_point`` (m, the output point with the
        largest peak in the governing case: where the histories are),
        ``value_at_output_points`` (m s-2, the max over the output points in the
        governing case) and ``whole_deck`` (1 if the whole-deck envelope was used).

    Raises
    ------
    ResultsError
        Without ``max_deck_acceleration`` or with an unknown ``track_type``.
    """
    ds = prepare(ds)
    require(ds, ["max_deck_acceleration"], "the deck acceleration check")
    track = track_type(ds)
    profile = profile_of(ds, profile)
    limits = deck_acceleration_limits(profile)
    clause = profile.clause(DECK_ACCELERATION_KEYS["ballasted"])
    if limit is None:
        if track not in limits:
            raise ResultsError(
                f"track_type = {track!r} is not one of {sorted(limits)}; "
                "pass the acceleration limit explicitly"
            )
        limit = limits[track]
        clause = profile.clause(DECK_ACCELERATION_KEYS[track])
    limit = float(limit)
    acc = ds["max_deck_acceleration"]
    at_points = nanmax(acc, "point")
    wd, wd_x = None, None
    if ("max_deck_acceleration_whole_deck" in ds
            and bool(ds["max_deck_acceleration_whole_deck"].notnull().any())):
        wd = ds["max_deck_acceleration_whole_deck"]
        wd_x = ds["position_of_max_deck_acceleration_whole_deck"]
    loaded = ds.attrs.get("loaded_track")
    track_whole = False
    if loaded is not None and "max_track_acceleration" in ds:
        # a deck in space: the loaded track's line counts too (EN 1990 A2.4.4.2.1 takes
        # the acceleration along the track), at the output points and on the whole-deck
        # grid along the track when the file has it
        along = nanmax(ds["max_track_acceleration"].sel(track=int(loaded)), "point")
        at_points = np.fmax(at_points, along)
        acc = np.fmax(acc, ds["max_track_acceleration"].sel(track=int(loaded)).drop_vars(
            "track"))
        name = "max_track_acceleration_whole_deck"
        if name in ds and bool(ds[name].sel(track=int(loaded)).notnull().any()):
            tw = ds[name].sel(track=int(loaded)).drop_vars("track")
            tw_x = ds[f"position_of_{name}"].sel(track=int(loaded)).drop_vars("track")
            if wd is None:
                wd, wd_x = tw, tw_x
            else:
                wd_x = xr.where(tw.fillna(-np.inf) >= wd.fillna(-np.inf), tw_x, wd_x)
                wd = np.fmax(wd, tw)
            track_whole = True
    whole = wd is not None
    peak = at_points
    if whole:
        peak = np.fmax(at_points, wd)
    peak = peak.assign_attrs(units="m s-2")
    out = design_value(peak, q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="m s-2",
                              long_name="peak vertical deck acceleration (design value)")
    worst = nanmax(acc, "irregularity")
    out_point = worst.fillna(-np.inf).idxmax("point").where(worst.notnull().any("point"))
    point_of_max = out_point
    if whole:
        i_wd = wd.fillna(-np.inf).argmax("irregularity")
        wd_worst = wd.isel(irregularity=i_wd)
        wd_x = wd_x.isel(irregularity=i_wd)
        better = wd_worst.fillna(-np.inf) >= nanmax(worst, "point").fillna(-np.inf)
        point_of_max = xr.where(better & wd_worst.notnull(), wd_x, out_point)
        point_of_max = point_of_max.drop_vars("irregularity", errors="ignore")
    out["point_of_max"] = point_of_max.assign_attrs(
        units="m", long_name="deck abscissa of the peak acceleration")
    f = bridge_frequencies(ds)
    extra = {
        "track_type": track,
        "track_type_assumed": int(track_type_assumed(ds)),
        "frequency_cutoff": frequency_cutoff(f) if f.size else np.nan,
        "highest_frequency": float(f[-1]) if f.size else np.nan,
        "basis": out.attrs["basis"],
        "whole_deck": int(whole),
        **({"loaded_track": int(loaded), "loaded_track_whole_deck": int(track_whole)}
           if loaded is not None else {}),
    }
    note = rail_mass_note(ds)
    if note:
        extra["accuracy_note"] = note
    out = _summarise(out, "Peak deck acceleration", clause, "m s-2", limit, extra=extra)
    if out.attrs["governing_train"]:
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        out.attrs["governing_point"] = float(out["point_of_max"].sel(train=t, speed=v))
        out.attrs["governing_output_point"] = float(out_point.sel(train=t, speed=v))
        out.attrs["value_at_output_points"] = float(nanmax(worst.sel(train=t, speed=v),
                                                           "point"))
        out.attrs["governing_irregularity"] = _case_realisation(peak, t, v)
    else:
        out.attrs["governing_point"] = np.nan
        out.attrs["governing_output_point"] = np.nan
        out.attrs["value_at_output_points"] = np.nan
    return out


def rail_mass_note(ds: xr.Dataset) -> str:
    """The sign and size of the deck acceleration's error when the runs put interaction
    trains on an elastic track with rail mass
    (:func:`vsi_numba.model.track.rail_mass_acceleration_note`), else ""."""
    from vsi_numba.analysis.checks.determinant import results_config
    from vsi_numba.analysis.checks.wheels import prescribed_wheels
    from vsi_numba.model.track import rail_mass_acceleration_note

    track = results_config(ds).get("track")
    if not isinstance(track, dict) or track.get("model") != "elastic":
        return ""
    try:
        mass = float(track.get("rail_mass", 0.0))
    except (TypeError, ValueError):
        return ""
    if "static_wheel_load" in ds and "min_contact_force" in ds:
        pres = np.asarray(prescribed_wheels(ds).values, bool)
        has = np.isfinite(np.asarray(ds["static_wheel_load"].values, float))
        if has.shape == pres.shape and bool(pres[has].all()):
            return ""  # moving forces only: the track element is not used
    return rail_mass_acceleration_note(
        mass, bool(int(ds.attrs.get("rail_inertia_in_deck_load", 0))))


def dynamic_amplification(
    ds: xr.Dataset, length: float | None = None, q: float = DEFAULT_Q, profile=None,
) -> xr.Dataset:
    """Dynamic increment phi'_dyn of the deck displacement, phi'' and the design factor.

    ``phi'_dyn = max|y_dyn| / max|y_stat| - 1`` per train, speed and point, with
    y_stat the static response of the same model (``max_static_deck_displacement``,
    max over train positions); the two maxima need not occur at the same time
    (EN 1991-2 §6.4.6.5).

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_deck_displacement`` and ``max_static_deck_displacement``.
    length : float, optional
        Determinant length L_phi (m) for phi''; wins over everything. Default: from the
        results (:func:`determinant_length`: the ``determinant_length`` attribute, else
        EN 1991-2 Table 6.2 from the configuration's bridge kind and spans).
    q : float
        Fractile used only when the file has random realisations and no deterministic
        track (phi'_dyn then includes the irregularity effect, see ``basis``).
    profile : CodeProfile, optional
        Code profile (L_Phi factors, phi'' constants); default: the results'.

    Returns
    -------
    xarray.Dataset
        ``phi_dyn(speed, train, point)`` and ``phi_dyn_max(train, point)`` (max over
        speed); ``value(speed, train)`` = deck phi'_dyn = max over points of
        max|y_dyn| / max over points of max|y_stat| - 1, the summary quantity;
        ``phi2(speed)`` = phi'' of EN 1991-2 Annex C (needs L_phi and ``frequency``);
        ``design_factor(speed, train)`` = 1 + phi'_dyn + phi''/2, the factor of
        EN 1991-2 eq. (6.16)/(6.17) applied to the real train or HSLM to compare with
        Phi x LM71 (information, no limit). Attributes ``phi2_max``, ``design_factor_max``,
        ``length`` (L_phi, m), ``length_rule`` (how L_phi was obtained),
        ``length_assumed`` (1 when that is an assumption), ``n0`` and ``basis``.
    """
    ds = prepare(ds)
    require(ds, ["max_deck_displacement", "max_static_deck_displacement"],
            "the dynamic increment φ'dyn")
    _not_together(ds, "the dynamic increment φ'dyn")
    dyn = ds["max_deck_displacement"]
    irr = np.asarray(ds["irregularity"].values)
    if (irr == DETERMINISTIC).any():
        dyn = nanmax(dyn.isel(irregularity=np.flatnonzero(irr == DETERMINISTIC)),
                     "irregularity")
        basis = "deterministic track (irregularity = -1)"
    else:
        stats = design_value(dyn, q=q, n_boot=0)
        dyn = stats["value"]
        basis = (stats.attrs["basis"] + "; includes the effect of the irregularities, so "
                 "adding φ''/2 double counts them")
    stat = abs(ds["max_static_deck_displacement"])
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = (abs(dyn) / stat.where(stat > 0) - 1.0)
    phi = phi.transpose("speed", "train", "point")
    deck_dyn = nanmax(abs(dyn), "point")
    deck_stat = nanmax(stat, "point")
    value = (deck_dyn / deck_stat.where(deck_stat > 0) - 1.0).transpose("speed", "train")
    out = xr.Dataset(
        {
            "phi_dyn": phi.assign_attrs(units="1", long_name="dynamic increment phi'_dyn"),
            "phi_dyn_max": nanmax(phi, "speed").assign_attrs(
                units="1", long_name="dynamic increment phi'_dyn, max over speed"),
            "value": value.assign_attrs(
                units="1", long_name="dynamic increment of the deck maximum displacement"),
        }
    )
    profile = profile_of(ds, profile)
    lphi = determinant_length(ds, length, profile)
    L = lphi.value
    f = bridge_frequencies(ds)
    n0 = float(f[0]) if f.size else np.nan
    if np.isfinite(L) and L > 0 and np.isfinite(n0):
        phi2 = irregularity_allowance(ds["speed"].values, L, n0, profile)
    else:
        phi2 = np.full(ds.sizes["speed"], np.nan)
    phi2 = xr.DataArray(phi2, dims="speed", coords={"speed": ds["speed"]})
    out["phi2"] = phi2.assign_attrs(units="1",
                                    long_name="irregularity allowance phi'' (EN 1991-2 Annex C)")
    out["design_factor"] = (1.0 + value + phi2 / 2.0).transpose("speed", "train").assign_attrs(
        units="1", long_name="1 + phi'_dyn + phi''/2")
    extra = {
        "basis": basis,
        "length": L,
        "length_rule": lphi.rule,
        "length_assumed": int(lphi.assumed),
        "length_clause": profile.clause("determinant_length_k2"),
        "n0": n0,
        "phi2_max": float(phi2.max()) if bool(phi2.notnull().any()) else np.nan,
        "design_factor_max": float(nanmax(out["design_factor"], ["speed", "train"])),
    }
    return _summarise(out, "Dynamic increment φ'dyn", "EN 1991-2 6.4.6.5", "1", None,
                      extra=extra)


def max_deck_displacement(ds: xr.Dataset, q: float = DEFAULT_Q) -> xr.Dataset:
    """Maximum deck displacement (information, no limit).

    The L/600 limit of EN 1990 A2.4.4.2.3 is for LM71, not for these trains.
    """
    ds = prepare(ds)
    require(ds, ["max_deck_displacement"], "the deck displacement summary")
    out = design_value(nanmax(ds["max_deck_displacement"], "point"), q=q, n_boot=0)
    out["value"].attrs.update(units="m", long_name="maximum vertical deck displacement")
    out = _summarise(out, "Max deck displacement", "information", "m", None,
                     extra={"basis": out.attrs["basis"]})
    if out.attrs["governing_train"]:  # the output point of the governing case's maximum
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        case = nanmax(ds["max_deck_displacement"].sel(train=t, speed=v), "irregularity")
        if bool(case.notnull().any()):
            out.attrs["governing_point"] = float(case.fillna(-np.inf).idxmax("point"))
    return out
