"""Wheel unloading dQ/Q0 (EN 14363 practice; the limit of the code profile) and which
trains and wheels a wheel check applies to (prescribed forces are not checked)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.checks.common import (
    _RESULT_NA,
    DEFAULT_Q,
    _case_realisation,
    _summarise,
    design_value,
    profile_of,
)
from vsi_numba.analysis.dataset import (
    nanargmax_case,
    nanmax,
    nanmin,
    prepare,
    require,
)

#: Length (m) of track beyond each deck end that the bridge's wheel-unloading check
#: takes with the deck: the transition where the deck end and its joint act on the wheels
#: (the kink or the rail's bending over the joint; about three times the elastic
#: rail's characteristic length 1 / beta of ordinary track).  Axles whose minimum contact
#: force lay farther off the deck are the approach (or exit) track's: information.
TRANSITION_ZONE = 3.0


def _bridge_zone(ds: xr.Dataset, transition: float):
    """(mask of the records whose minimum contact force lay on the deck or within
    ``transition`` of a deck end, the deck length), or (None, None) when the file does not
    say where the minimum was."""
    length = ds.attrs.get("bridge_length")
    try:
        length = float(length)
    except (TypeError, ValueError):
        return None, None
    if "position_of_min_contact_force" not in ds or not (np.isfinite(length) and length > 0):
        return None, None
    x = ds["position_of_min_contact_force"]
    return (x >= -transition) & (x <= length + transition), length


def wheel_unloading(
    ds: xr.Dataset, limit: float | None = None, q: float = DEFAULT_Q,
    n_boot: int = 2000, seed: int = 0, profile=None,
    transition: float = TRANSITION_ZONE,
) -> xr.Dataset:
    """Wheel unloading dQ/Q0 against 0.6 (EN 14363 practice) and contact loss.

    Wheels whose contact forces are prescribed (moving forces: min and max contact force
    equal in every case, see :func:`prescribed_wheels`) cannot unload or lose contact:
    they are left out, per train and wheel, so a study mixing HSLM moving forces with an
    interaction model of a real train checks the interaction train only.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_wheel_unloading(speed, train, irregularity, wheel)``; uses
        ``min_contact_force``, ``max_contact_force``, ``contact_loss_duration`` (total
        time separated, s), ``longest_contact_loss`` (longest single separation, s),
        ``single_step_contact_losses`` (separations lasting exactly one time step) and
        ``contact_loss_count`` when present.
    limit : float, optional
        Admissible dQ/Q0; default: ``wheel_unloading_limit`` of the code profile
        (``profile``, else the results', 0.6 recommended).
    q : float
        Characteristic fractile (upper for dQ/Q0, 1 - q for the minimum contact force).
    transition : float
        The bridge's check takes the axles whose minimum contact force
        (``position_of_min_contact_force``) lay on the deck or within this length (m) of
        a deck end (:data:`TRANSITION_ZONE`); the others, on the approach or exit track,
        give the attributes ``approach_value`` (the largest dQ/Q0 there, over every
        case and realisation), ``approach_train``, ``approach_speed_kmh``,
        ``approach_wheel``, ``approach_x`` (information: not the bridge's check).
        Without the position every axle is taken (attribute ``zone`` says which).

    Returns
    -------
    xarray.Dataset
        ``value(speed, train)``: max over wheels of dQ/Q0, design value over realisations
        (NaN for trains with prescribed forces); ``wheel_unloading(speed, train, wheel)``
        (per wheel, design value); ``applicable(train)`` (bool);
        ``min_contact_force(speed, train)`` (N, min over wheels, lower fractile);
        ``contact_loss_duration(speed, train)`` (s, the largest over wheels of the TOTAL
        time a wheel is separated, worst realisation); ``longest_contact_loss(speed,
        train)`` (s, the longest single separation, worst realisation; when the file has
        no ``longest_contact_loss`` it is the total time separated, an upper bound, and
        the attribute ``longest_contact_loss_source`` says so);
        ``single_step_contact_losses(speed, train)`` (one-step separations summed over
        wheels, worst realisation: a flag of possible spurious ringing of the contact);
        ``contact_loss_count(speed, train)`` (events summed over wheels, worst
        realisation); ``wheels_losing_contact(speed, train)``; the statistics of ``value``;
        summary attrs plus ``governing_wheel``, ``min_contact_force`` (smallest over all
        cases, N), ``max_time_separated`` (s, total; alias ``max_contact_loss_duration``),
        ``max_longest_contact_loss`` (s), ``max_single_step_contact_losses``,
        ``max_contact_loss_count``, ``applicable_trains`` and ``not_applicable_trains``
        (comma-separated names). When no train has varying contact forces the result is
        "n/a" and the attribute ``note`` says why.
    """
    ds = prepare(ds)
    require(ds, ["max_wheel_unloading"], "the wheel unloading check")
    profile = profile_of(ds, profile)
    clause = profile.clause("wheel_unloading_limit")
    limit = profile["wheel_unloading_limit"] if limit is None else float(limit)
    fixed = prescribed_wheels(ds)  # (train, wheel)
    applicable = applicable_trains(ds, fixed)

    def free(name):
        """``ds[name]`` with the wheels of prescribed force masked out."""
        return ds[name].where(~fixed)

    dq = free("max_wheel_unloading")
    zone, length = _bridge_zone(ds, float(transition))
    approach = {}
    if zone is not None:
        off = dq.where(~zone & dq.notnull())
        if bool(off.notnull().any()):
            a = np.asarray(off.transpose("speed", "train", "irregularity", "wheel").values,
                           float)
            i = np.unravel_index(int(np.nanargmax(a)), a.shape)
            xs = ds["position_of_min_contact_force"].transpose(
                "speed", "train", "irregularity", "wheel").values
            approach = {"approach_value": float(a[i]),
                        "approach_train": str(ds["train"].values[i[1]]),
                        "approach_speed": float(ds["speed"].values[i[0]]),
                        "approach_speed_kmh": float(ds["speed_kmh"].values[i[0]])
                        if "speed_kmh" in ds.coords else float(ds["speed"].values[i[0]] * 3.6),
                        "approach_wheel": int(ds["wheel"].values[i[3]]),
                        "approach_irregularity": int(ds["irregularity"].values[i[2]]),
                        "approach_x": float(xs[i]),
                        "approach_records": int(off.notnull().sum())}
        dq = dq.where(zone)
        where = (f"axles whose minimum contact force lay on the deck or within "
                 f"{transition:g} m of a deck end (x from {-transition:g} to "
                 f"{length + transition:g} m)")
    else:
        where = ("every axle (the file does not say where an axle's minimum contact force "
                 "was: the approach and exit track are included)")
    out = design_value(nanmax(dq, "wheel"), q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="1", long_name="maximum wheel unloading dQ/Q0")
    per_wheel = design_value(dq, q=q, n_boot=0)["value"]
    out["wheel_unloading"] = per_wheel.transpose("speed", "train", "wheel").assign_attrs(
        units="1", long_name="wheel unloading dQ/Q0 per wheel (design value)")
    out["applicable"] = applicable.assign_attrs(
        long_name="wheel unloading applies (contact forces not prescribed)")
    names = [str(t) for t in ds["train"].values]
    yes = [t for t, a in zip(names, applicable.values, strict=True) if a]
    no = [t for t, a in zip(names, applicable.values, strict=True) if not a]
    extra = {"applicable_trains": ", ".join(yes), "not_applicable_trains": ", ".join(no),
             "zone": where, "transition_zone": float(transition) if zone is not None
             else np.nan, **approach}
    if "min_contact_force" in ds:
        qmin = free("min_contact_force")
        qmin = nanmin(qmin if zone is None else qmin.where(zone), "wheel")
        out["min_contact_force"] = design_value(qmin, q=1.0 - q, n_boot=0)["value"].assign_attrs(
            units="N", long_name="minimum wheel-rail contact force (design value)")
        worst = nanargmax_case(-out["min_contact_force"])
        extra["min_contact_force"] = (np.nan if worst is None else
                                      float(out["min_contact_force"].sel(
                                          speed=worst["speed"], train=worst["train"])))
    if "contact_loss_duration" in ds:
        total = free("contact_loss_duration")
        dur = nanmax(nanmax(total, "wheel"), "irregularity")
        out["contact_loss_duration"] = dur.assign_attrs(
            units="s", long_name="total time separated from the rail, largest over wheels "
                                 "(worst realisation)")
        lost = nanmax((total > 0).where(total.notnull()).sum("wheel", min_count=1),
                      "irregularity")
        out["wheels_losing_contact"] = lost.assign_attrs(
            units="1", long_name="number of wheels losing contact (worst realisation)")
        extra["max_time_separated"] = float(nanmax(dur, ["speed", "train"]))
        extra["max_contact_loss_duration"] = extra["max_time_separated"]  # former name
    if "longest_contact_loss" in ds or "contact_loss_duration" in ds:
        if "longest_contact_loss" in ds:
            source = "longest_contact_loss"
            longest = nanmax(nanmax(free("longest_contact_loss"), "wheel"), "irregularity")
            long_name = "longest single loss of contact of a wheel (worst realisation)"
        else:
            source = ("contact_loss_duration: the file has no longest_contact_loss; this is "
                      "the total time separated, an upper bound of the longest single loss")
            longest = out["contact_loss_duration"]
            long_name = ("total time separated (the longest single loss of contact is not "
                         "in the file; this is an upper bound of it)")
        out["longest_contact_loss"] = longest.copy().assign_attrs(
            units="s", long_name=long_name, source=source)
        extra["max_longest_contact_loss"] = float(nanmax(longest, ["speed", "train"]))
        extra["longest_contact_loss_source"] = source
    if "single_step_contact_losses" in ds:
        one = nanmax(free("single_step_contact_losses").astype(float).sum("wheel", min_count=1),
                     "irregularity")
        out["single_step_contact_losses"] = one.assign_attrs(
            units="1", long_name="losses of contact lasting exactly one time step, all "
                                 "wheels (worst realisation): possible spurious ringing")
        extra["max_single_step_contact_losses"] = float(nanmax(one, ["speed", "train"]))
    if "contact_loss_count" in ds:
        cnt = nanmax(free("contact_loss_count").astype(float).sum("wheel", min_count=1),
                     "irregularity")
        out["contact_loss_count"] = cnt.assign_attrs(
            units="1", long_name="contact-loss events, all wheels (worst realisation)")
        extra["max_contact_loss_count"] = float(nanmax(cnt, ["speed", "train"]))
    out = _summarise(out, "Wheel unloading ΔQ/Q₀", clause, "1", limit,
                     extra={**extra, "basis": out.attrs["basis"]})
    if not yes:
        out.attrs.update(result=_RESULT_NA, value=np.nan, margin=np.nan, utilisation=np.nan,
                         governing_train="", governing_speed=np.nan, governing_speed_kmh=np.nan,
                         note="the contact forces never change (moving-force model): wheel "
                              "unloading does not apply")
    if yes and approach:
        _bound_by_approach(out, limit)
    if out.attrs["governing_train"]:
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        w = nanargmax_case(out["wheel_unloading"].sel(train=t, speed=v))
        out.attrs["governing_wheel"] = -1 if w is None else int(w["wheel"])
        out.attrs["governing_irregularity"] = _case_realisation(nanmax(dq, "wheel"), t, v)
        if w is not None and "position_of_min_contact_force" in ds:
            x = ds["position_of_min_contact_force"].sel(
                train=t, speed=v, irregularity=out.attrs["governing_irregularity"],
                wheel=w["wheel"])
            out.attrs["governing_x"] = float(x)
    else:
        out.attrs["governing_wheel"] = -1
    if out.attrs.get("value_is_upper_bound"):  # the bound's axle (off the bridge)
        out.attrs.update(governing_wheel=out.attrs["approach_wheel"],
                         governing_x=out.attrs["approach_x"],
                         governing_irregularity=out.attrs["approach_irregularity"])
    return out


#: Result of the wheel-unloading check when the file cannot tell (see
#: :func:`_bound_by_approach`).
UNDETERMINED = "not determined"


def _bound_by_approach(out: xr.Dataset, limit: float) -> None:
    """The bridge's value when some axles had their minimum contact force off the
    bridge: the file holds one minimum per axle and run, so such an axle's ΔQ/Q₀ while on
    the bridge is not in it, only that it is at most its value off the bridge.  The
    bridge's maximum then lies between the value of the axles on it and the approach's
    value (attributes ``bridge_lower``, ``bridge_upper``): the verdict stands where both
    give it (pass when the upper is within the limit, FAIL when the lower exceeds it),
    else it is :data:`UNDETERMINED`.  Without any axle whose minimum lay on the bridge
    the value is the upper bound (attribute ``value_is_upper_bound`` = 1)."""
    a = out.attrs
    v, up = float(a.get("value", np.nan)), float(a["approach_value"])
    if np.isfinite(v) and up <= v:
        return  # every axle's value on the bridge is at most v: v is the bridge's maximum
    a["bridge_lower"] = v if np.isfinite(v) else 0.0
    a["bridge_upper"] = up
    if not np.isfinite(v):
        a.update(value=up, value_is_upper_bound=1, governing_train=a["approach_train"],
                 governing_speed=a["approach_speed"],
                 governing_speed_kmh=a["approach_speed_kmh"],
                 margin=float(limit - up), utilisation=float(up / limit) if limit else np.nan)
    if up <= limit:
        a["result"] = "pass"
    elif np.isfinite(v) and v > limit:
        a["result"] = "FAIL"
    else:
        a["result"] = UNDETERMINED


def prescribed_wheels(ds: xr.Dataset) -> xr.DataArray:
    """Wheels whose contact force is prescribed: True per (train, wheel).

    A wheel's force is prescribed, as in a moving-force model, when its minimum and
    maximum contact force coincide (to 1e-9 relative) in every case where it has a
    value; such a wheel cannot unload or lose contact. Wheels a train does not have (NaN
    padding) are False. Without ``min_contact_force`` and ``max_contact_force`` every
    wheel is False (nothing tells them apart).

    Parameters
    ----------
    ds : xarray.Dataset
        Results (any layout :func:`~vsi_numba.analysis.dataset.prepare` accepts).

    Returns
    -------
    xarray.DataArray
        bool, dims ``(train, wheel)``.
    """
    ds = prepare(ds)
    if "min_contact_force" not in ds or "max_contact_force" not in ds:
        n_wheel = ds.sizes.get("wheel", 0)
        coords = {"train": ds["train"].values}
        if "wheel" in ds.coords:
            coords["wheel"] = ds["wheel"].values
        return xr.DataArray(np.zeros((ds.sizes["train"], n_wheel), bool),
                            dims=("train", "wheel"), coords=coords)
    hi, lo = ds["max_contact_force"], ds["min_contact_force"]
    finite = hi.notnull() & lo.notnull()
    same = abs(hi - lo) <= 1e-9 * abs(hi)
    case_dims = ["speed", "irregularity"]
    fixed = (same | ~finite).all(case_dims) & finite.any(case_dims)
    return fixed.transpose("train", "wheel")


def applicable_trains(ds: xr.Dataset, fixed: xr.DataArray | None = None) -> xr.DataArray:
    """Trains to which wheel unloading applies: True per train.

    A train qualifies when at least one of its wheels has a contact force that is not
    prescribed (:func:`prescribed_wheels`) and has a value in some case.

    Parameters
    ----------
    ds : xarray.Dataset
        Results.
    fixed : xarray.DataArray, optional
        :func:`prescribed_wheels` of ``ds`` if already computed.

    Returns
    -------
    xarray.DataArray
        bool, dim ``train``.
    """
    ds = prepare(ds)
    if fixed is None:
        fixed = prescribed_wheels(ds)
    if "max_wheel_unloading" in ds:
        present = ds["max_wheel_unloading"].notnull().any(["speed", "irregularity"])
    else:
        present = xr.ones_like(fixed, dtype=bool)
    return (present & ~fixed).any("wheel")

