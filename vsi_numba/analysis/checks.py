"""Design checks of a results Dataset.

EN 1990 A2 deck acceleration, dynamic increment, wheel unloading, passenger comfort,
resonance speeds.

Every check takes the results Dataset (single run or study, see
:func:`vsi_numba.analysis.dataset.prepare`) and returns an :class:`xarray.Dataset` with

- ``value(speed, train)``: the design value per speed and train (max over deck points,
  wheels or vehicles; over irregularity realisations the characteristic value, see
  :func:`design_value`), and where a limit applies ``margin = limit - value``,
  ``utilisation = value / limit`` and ``passed``;
- the realisation statistics of ``value`` (``n``, ``mean``, ``std``, ``characteristic``,
  ``ci_low``, ``ci_high``, ``exceedance_probability``);
- attributes summarising the check: ``check``, ``clause``, ``units``, ``value``,
  ``limit``, ``margin``, ``utilisation``, ``result`` ("pass", "FAIL", "info", "n/a"),
  ``governing_train``, ``governing_speed`` (m s-1), ``governing_speed_kmh``.

:func:`summary_table` collects those attributes in a :class:`pandas.DataFrame`.

Limits tagged [R] are recalled from the cited standard and not re-read against the
primary text (see ``notes/railway.md`` §4): check them before relying on them as hard
limits.
"""

from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    ResultsError,
    bridge_frequencies,
    nanargmax_case,
    nanmax,
    nanmin,
    prepare,
    require,
    track_type,
    track_type_assumed,
)
from vsi_numba.analysis.statistics import realisation_statistics

#: Peak deck acceleration limits (m s-2) per track type, EN 1990 A2.4.4.2.1(4)P:
#: gamma_bt = 3.5 for ballasted track (0.35 g, value verified; clause [R]) and
#: gamma_df = 5.0 for direct-fastened track [R].
DECK_ACCELERATION_LIMITS = {"ballasted": 3.5, "direct_fastening": 5.0}

#: Clause of the deck acceleration check.
DECK_ACCELERATION_CLAUSE = "EN 1990 A2.4.4.2.1(4)P"

#: Lowest frequency (Hz) of the acceleration cut-off, EN 1990 A2.4.4.2.1(4)P [R].
CUTOFF_MIN_FREQUENCY = 30.0

#: Wheel unloading ratio limit dQ/Q0, EN 14363 / UIC practice [R].
WHEEL_UNLOADING_LIMIT = 0.6
WHEEL_UNLOADING_CLAUSE = "EN 14363 practice [R]"

#: Car-body vertical acceleration b_v (m s-2) per level of comfort, EN 1990 Table A2.9 [R].
COMFORT_LEVELS = {"very good": 1.0, "good": 1.3, "acceptable": 2.0}
COMFORT_CLAUSE = "EN 1990 A2.4.4.3, Table A2.9 [R]"

#: Characteristic fractile over irregularity realisations (upper; 1 - q for minima).
DEFAULT_Q = 0.95

_RESULT_NA = "n/a"

#: Clause of the determinant length L_phi.
DETERMINANT_LENGTH_CLAUSE = "EN 1991-2 6.4.5.3, Table 6.2 [R]"

#: Factor k of L_phi = k L_m for a continuous deck of n spans, EN 1991-2 Table 6.2 [R];
#: n >= 5 takes :data:`CONTINUOUS_K_MANY`.
CONTINUOUS_K = {2: 1.2, 3: 1.3, 4: 1.4}
CONTINUOUS_K_MANY = 1.5

#: Bridge kinds whose mode shapes come from another program (their support layout is
#: not known here).
_IMPORTED_KINDS = ("modes_file", "matrices")


# --------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------


def frequency_cutoff(frequencies) -> float:
    """Upper frequency (Hz) of the modes counted in the deck acceleration check.

    ``max(30 Hz, 1.5 f1, f3)`` with f1 the fundamental and f3 the third natural frequency
    of the member, EN 1990 A2.4.4.2.1(4)P [R].

    Parameters
    ----------
    frequencies : array_like
        Natural frequencies (Hz), any order; non-finite and non-positive values ignored.

    Returns
    -------
    float
        The cut-off (Hz); 30 Hz when no frequency is known. With fewer than three modes
        f3 is unknown and left out (the cut-off may then be too low).
    """
    f = np.sort(np.asarray(frequencies, float).ravel())
    f = f[np.isfinite(f) & (f > 0)]
    cut = CUTOFF_MIN_FREQUENCY
    if f.size:
        cut = max(cut, 1.5 * f[0])
    if f.size >= 3:
        cut = max(cut, f[2])
    return float(cut)


def irregularity_allowance(speed, length: float, n0: float) -> np.ndarray:
    """Dynamic allowance for track irregularities, phi'' of EN 1991-2 Annex C [R].

    ``phi'' = a [0.56 exp(-(L/10)^2) + 0.50 (n0 L / 80 - 1) exp(-(L/20)^2)]``, ``phi'' >= 0``,
    with ``a = min(v / 22, 1)`` (v in m s-1).

    Parameters
    ----------
    speed : array_like
        Speed v (m s-1).
    length : float
        Determinant length L_phi (m), EN 1991-2 Table 6.2 [R]; see
        :func:`determinant_length`.
    n0 : float
        First natural bending frequency of the loaded bridge (Hz).

    Returns
    -------
    ndarray
        phi'' (-), same shape as ``speed``.
    """
    v = np.asarray(speed, float)
    a = np.minimum(v / 22.0, 1.0)
    bracket = 0.56 * np.exp(-((length / 10.0) ** 2)) + 0.50 * (n0 * length / 80.0 - 1.0) * np.exp(
        -((length / 20.0) ** 2)
    )
    return np.maximum(a * bracket, 0.0)


class DeterminantLength(NamedTuple):
    """Determinant length L_phi (m) of a deck and how it was obtained.

    ``value`` is NaN where no L_phi applies (rigid track); ``rule`` says which rule (or
    assumption) gave it, in words, for the report; ``assumed`` is True when the rule is
    an assumption rather than a case of EN 1991-2 Table 6.2 [R] or a value given by the
    user.
    """

    value: float
    rule: str
    assumed: bool


def continuous_determinant_length(spans) -> float:
    """L_phi of a continuous deck of n spans, EN 1991-2 Table 6.2 [R].

    ``L_phi = k L_m``, ``L_m = (L_1 + ... + L_n) / n``, with k = 1.2 (n = 2), 1.3 (n = 3),
    1.4 (n = 4), 1.5 (n >= 5), but not less than the largest span; one span: L_phi = L.

    Parameters
    ----------
    spans : sequence of float
        Span lengths (m), > 0.

    Returns
    -------
    float
        L_phi (m).
    """
    L = np.asarray(spans, float).ravel()
    if L.size == 0 or not np.all(np.isfinite(L) & (L > 0)):
        raise ValueError(f"spans = {list(L)}: expected one or more span lengths > 0 m")
    if L.size == 1:
        return float(L[0])
    k = CONTINUOUS_K.get(L.size, CONTINUOUS_K_MANY)
    return float(max(k * L.mean(), L.max()))


def _continuous_rule(spans) -> str:
    L = np.asarray(spans, float)
    k = CONTINUOUS_K.get(L.size, CONTINUOUS_K_MANY)
    value = continuous_determinant_length(L)
    text = (f"continuous deck of {L.size} spans: L_Φ = k L_m = {k:g} × {L.mean():g} m "
            f"= {k * L.mean():g} m")
    if value > k * L.mean():
        text += f", raised to the largest span {L.max():g} m (L_Φ ≥ max span)"
    else:
        text += f" (≥ the largest span {L.max():g} m)"
    return text


def results_config(ds: xr.Dataset) -> dict:
    """The resolved configuration stored in ``config_json`` (empty dict if none/unreadable)."""
    try:
        config = json.loads(str(ds.attrs.get("config_json", "") or "{}"))
    except ValueError:
        return {}
    return config if isinstance(config, dict) else {}


def _positive(value) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) and v > 0 else None


def determinant_length(ds: xr.Dataset, override: float | None = None) -> DeterminantLength:
    """Determinant length L_phi (m) of the deck of a results file, with its rule.

    In order of precedence:

    1. ``override`` (an explicit argument wins over everything);
    2. the global attribute ``determinant_length`` (m) of the results, then the key
       ``bridge.determinant_length`` of the stored configuration;
    3. from the configuration's ``bridge.kind`` and ``bridge.spans``, EN 1991-2
       Table 6.2 [R]: simply supported span L_phi = L; continuous deck of n spans
       L_phi = k L_m (:func:`continuous_determinant_length`); rigid track: not applicable
       (NaN); imported modes or matrices (``modes_file``, ``matrices``): the same rule
       over the spans given, else the bridge length, flagged as an assumption;
    4. without a usable configuration, the ``bridge_length`` attribute, flagged as an
       assumption (right only for a simply supported span).

    Parameters
    ----------
    ds : xarray.Dataset
        Results (attributes ``config_json``, ``bridge_length``, ``determinant_length``).
    override : float, optional
        L_phi (m) given by the user; must be > 0.

    Returns
    -------
    DeterminantLength
        ``(value, rule, assumed)``; value NaN when nothing gives a length.
    """
    if override is not None:
        value = _positive(override)
        if value is None:
            raise ValueError(f"determinant length = {override!r}: expected a length > 0 m")
        return DeterminantLength(value, f"given explicitly: L_Φ = {value:g} m", False)
    value = _positive(ds.attrs.get("determinant_length"))
    if value is not None:
        return DeterminantLength(value, f"L_Φ = {value:g} m from the results attribute "
                                        "`determinant_length`", False)
    bridge = results_config(ds).get("bridge", {})
    bridge = bridge if isinstance(bridge, dict) else {}
    value = _positive(bridge.get("determinant_length"))
    if value is not None:
        return DeterminantLength(value, f"L_Φ = {value:g} m from the configuration "
                                        "(bridge.determinant_length)", False)
    kind = str(bridge.get("kind", ""))
    spans = bridge.get("spans")
    try:
        spans = [float(x) for x in np.atleast_1d(spans)] if spans is not None else None
        if spans is not None:
            continuous_determinant_length(spans)  # validates
    except (TypeError, ValueError):
        spans = None
    length = _positive(ds.attrs.get("bridge_length"))
    if kind == "rigid":
        return DeterminantLength(np.nan, "not applicable: rigid track, no deck", False)
    if kind == "simply_supported" and spans:
        return DeterminantLength(spans[0], f"simply supported span: L_Φ = L = {spans[0]:g} m",
                                 False)
    if kind == "continuous" and spans:
        if len(spans) == 1:
            return DeterminantLength(spans[0], f"one span: L_Φ = L = {spans[0]:g} m", False)
        return DeterminantLength(continuous_determinant_length(spans), _continuous_rule(spans),
                                 False)
    if kind in _IMPORTED_KINDS and spans:
        what = (f"one span: L_Φ = L = {spans[0]:g} m" if len(spans) == 1
                else _continuous_rule(spans))
        return DeterminantLength(
            continuous_determinant_length(spans),
            f"ASSUMPTION — imported deck (bridge.kind = '{kind}', supports not known here), "
            f"taken as a simply supported or continuous deck over the spans given: {what}",
            True)
    if length is not None:
        why = (f"imported deck (bridge.kind = '{kind}') without bridge.spans"
               if kind in _IMPORTED_KINDS else
               "no bridge kind and spans in the results' configuration")
        return DeterminantLength(
            length, f"ASSUMPTION — {why}: L_Φ = the bridge length {length:g} m, right only "
                    "for a simply supported span; give the determinant length for other decks",
            True)
    return DeterminantLength(np.nan, "unknown: no configuration, bridge length or "
                                     "determinant length in the results", True)


def resonance_speeds(f: float, D: float, k_max: int = 4) -> pd.DataFrame:
    """Resonance speeds of a train with regular spacing D on a bridge of frequency f.

    ``v_i = f D / i`` for i = 1 .. k_max (EN 1991-2 §6.4.4 [R]): at v_i the regular
    axle groups arrive every i natural periods.

    Parameters
    ----------
    f : float
        Natural frequency (Hz), usually the fundamental.
    D : float
        Regular spacing of the axle groups (m), e.g. the coach length; <= 0: none.
    k_max : int
        Highest order i.

    Returns
    -------
    pandas.DataFrame
        Columns ``i``, ``speed`` (m s-1), ``speed_kmh`` (km h-1); empty when D <= 0 or
        f is not a positive number.
    """
    if not (np.isfinite(f) and np.isfinite(D) and f > 0 and D > 0) or k_max < 1:
        return pd.DataFrame({"i": pd.Series(dtype=int), "speed": pd.Series(dtype=float),
                             "speed_kmh": pd.Series(dtype=float)})
    i = np.arange(1, int(k_max) + 1)
    v = f * D / i
    return pd.DataFrame({"i": i, "speed": v, "speed_kmh": 3.6 * v})


def design_value(
    da: xr.DataArray, q: float = DEFAULT_Q, limit: float | None = None, n_boot: int = 2000,
    seed: int = 0,
) -> xr.Dataset:
    """Design value of ``da`` over the ``irregularity`` realisations, with statistics.

    Parameters
    ----------
    da : xarray.DataArray
        Dims ``(..., irregularity, ...)``; ``irregularity = -1`` is the deterministic track.
    q : float
        Fractile: 0.95 where large values are unfavourable, 0.05 for minima.
    limit, n_boot, seed
        Passed to :func:`~vsi_numba.analysis.statistics.realisation_statistics`.

    Returns
    -------
    xarray.Dataset
        The statistics of :func:`realisation_statistics` plus ``value``:

        - only the deterministic track (or only one realisation): that value;
        - random realisations (seeds >= 0): their characteristic q-fractile;
        - both: the more unfavourable of the deterministic value and the characteristic
          random value (the deterministic case is not one sample of the random track).

        The attribute ``basis`` says which.
    """
    irr = np.asarray(da["irregularity"].values)
    random = irr != DETERMINISTIC
    upper = q >= 0.5
    if random.any():
        sample = da.isel(irregularity=np.flatnonzero(random))
    else:
        sample = da
    stats = realisation_statistics(sample, "irregularity", q=q, n_boot=n_boot, seed=seed,
                                   limit=limit)
    value = stats["characteristic"]
    n_max = int(stats["n"].max()) if stats["n"].size else 0
    if not random.any():
        basis = "deterministic track" if n_max <= 1 else f"{100 * q:g} % fractile"
    else:
        basis = (f"{100 * q:g} % fractile over {n_max} irregularity realisation"
                 f"{'s' if n_max != 1 else ''}")
        if (~random).any():
            det = da.isel(irregularity=np.flatnonzero(~random))
            det = nanmax(det, "irregularity") if upper else nanmin(det, "irregularity")
            value = np.fmax(value, det) if upper else np.fmin(value, det)
            basis += " or the deterministic track, whichever is more unfavourable"
    stats["value"] = value.assign_attrs(da.attrs)
    stats.attrs["basis"] = basis
    return stats


def _governing(value: xr.DataArray, lowest: bool = False) -> dict | None:
    """Coordinates (train, speed) of the governing case, or None if all NaN."""
    return nanargmax_case(-value if lowest else value)


def _summarise(out: xr.Dataset, check: str, clause: str, units: str, limit: float | None,
               lowest: bool = False, extra: dict | None = None) -> xr.Dataset:
    """Fill the summary attributes of a check Dataset from its ``value``."""
    value = out["value"]
    gov = _governing(value, lowest)
    attrs = {
        "check": check,
        "clause": clause,
        "units": units,
        "limit": np.nan if limit is None else float(limit),
        "value": np.nan,
        "margin": np.nan,
        "utilisation": np.nan,
        "result": _RESULT_NA,
        "governing_train": "",
        "governing_speed": np.nan,
        "governing_speed_kmh": np.nan,
    }
    if gov is not None:
        case = value.sel(speed=gov["speed"], train=gov["train"])
        attrs.update(
            value=float(case),
            governing_train=str(gov["train"]),
            governing_speed=float(gov["speed"]),
            governing_speed_kmh=float(case["speed_kmh"]),
        )
        if limit is None:
            attrs["result"] = "info"
        else:
            attrs["margin"] = float(limit - attrs["value"])
            attrs["utilisation"] = float(attrs["value"] / limit) if limit else np.nan
            attrs["result"] = "pass" if attrs["value"] <= limit else "FAIL"
    if extra:
        attrs.update(extra)
    out.attrs.update(attrs)
    if limit is not None:
        out["margin"] = (limit - value).assign_attrs(units=units, long_name="limit - value")
        out["utilisation"] = (value / limit).assign_attrs(units="1",
                                                           long_name="value / limit")
        out["passed"] = (value <= limit).where(value.notnull()).assign_attrs(
            long_name="value <= limit (NaN where the case failed)")
    return out


def _case_realisation(da: xr.DataArray, train, speed, lowest: bool = False):
    """The realisation id giving the extreme of ``da`` (speed, train, irregularity)."""
    sub = da.sel(train=train, speed=speed)
    gov = nanargmax_case(-sub if lowest else sub)
    return DETERMINISTIC if gov is None else int(gov["irregularity"])


# --------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------


def deck_acceleration_check(
    ds: xr.Dataset, limit: float | None = None, q: float = DEFAULT_Q, n_boot: int = 2000,
    seed: int = 0,
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
        (attribute ``whole_deck`` = 0).  The solver band-limits both to the modes up to
        the cut-off ``max(30 Hz, 1.5 f1, f3)`` (:func:`frequency_cutoff`), as the clause
        requires.
    limit : float, optional
        Limit (m s-2). Default from the ``track_type`` attribute: 3.5 ballasted, 5.0
        direct fastening (:data:`DECK_ACCELERATION_LIMITS`; 5.0 is [R]); a file that does
        not state its track type gets the stricter ballasted limit
        (attribute ``track_type_assumed`` = 1).
    q : float
        Characteristic fractile over irregularity realisations.
    n_boot, seed
        Bootstrap settings of the realisation statistics.

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
    if limit is None:
        if track not in DECK_ACCELERATION_LIMITS:
            raise ResultsError(
                f"track_type = {track!r} is not one of {sorted(DECK_ACCELERATION_LIMITS)}; "
                "pass the acceleration limit explicitly"
            )
        limit = DECK_ACCELERATION_LIMITS[track]
    limit = float(limit)
    acc = ds["max_deck_acceleration"]
    at_points = nanmax(acc, "point")
    whole = ("max_deck_acceleration_whole_deck" in ds
             and bool(ds["max_deck_acceleration_whole_deck"].notnull().any()))
    peak = at_points
    if whole:
        peak = np.fmax(at_points, ds["max_deck_acceleration_whole_deck"])
    peak = peak.assign_attrs(units="m s-2")
    out = design_value(peak, q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="m s-2",
                              long_name="peak vertical deck acceleration (design value)")
    worst = nanmax(acc, "irregularity")
    out_point = worst.fillna(-np.inf).idxmax("point").where(worst.notnull().any("point"))
    point_of_max = out_point
    if whole:
        wd = ds["max_deck_acceleration_whole_deck"]
        i_wd = wd.fillna(-np.inf).argmax("irregularity")
        wd_worst = wd.isel(irregularity=i_wd)
        wd_x = ds["position_of_max_deck_acceleration_whole_deck"].isel(irregularity=i_wd)
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
    }
    out = _summarise(out, "Peak deck acceleration", DECK_ACCELERATION_CLAUSE, "m s-2", limit,
                     extra=extra)
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


def dynamic_amplification(
    ds: xr.Dataset, length: float | None = None, q: float = DEFAULT_Q
) -> xr.Dataset:
    """Dynamic increment phi'_dyn of the deck displacement, phi'' and the design factor.

    ``phi'_dyn = max|y_dyn| / max|y_stat| - 1`` per train, speed and point, with
    y_stat the static response of the same model (``max_static_deck_displacement``,
    max over train positions); the two maxima need not occur at the same time
    (EN 1991-2 §6.4.6.5 [R]).

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_deck_displacement`` and ``max_static_deck_displacement``.
    length : float, optional
        Determinant length L_phi (m) for phi''; wins over everything. Default: from the
        results (:func:`determinant_length`: the ``determinant_length`` attribute, else
        EN 1991-2 Table 6.2 [R] from the configuration's bridge kind and spans).
    q : float
        Fractile used only when the file has random realisations and no deterministic
        track (phi'_dyn then includes the irregularity effect, see ``basis``).

    Returns
    -------
    xarray.Dataset
        ``phi_dyn(speed, train, point)`` and ``phi_dyn_max(train, point)`` (max over
        speed); ``value(speed, train)`` = deck phi'_dyn = max over points of
        max|y_dyn| / max over points of max|y_stat| - 1, the summary quantity;
        ``phi2(speed)`` = phi'' of EN 1991-2 Annex C [R] (needs L_phi and ``frequency``);
        ``design_factor(speed, train)`` = 1 + phi'_dyn + phi''/2, the factor of
        EN 1991-2 eq. (6.16)/(6.17) [R] applied to the real train or HSLM to compare with
        Phi x LM71 (information, no limit). Attributes ``phi2_max``, ``design_factor_max``,
        ``length`` (L_phi, m), ``length_rule`` (how L_phi was obtained),
        ``length_assumed`` (1 when that is an assumption), ``n0`` and ``basis``.
    """
    ds = prepare(ds)
    require(ds, ["max_deck_displacement", "max_static_deck_displacement"],
            "the dynamic increment φ'dyn")
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
    lphi = determinant_length(ds, length)
    L = lphi.value
    f = bridge_frequencies(ds)
    n0 = float(f[0]) if f.size else np.nan
    if np.isfinite(L) and L > 0 and np.isfinite(n0):
        phi2 = irregularity_allowance(ds["speed"].values, L, n0)
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
        "length_clause": DETERMINANT_LENGTH_CLAUSE,
        "n0": n0,
        "phi2_max": float(phi2.max()) if bool(phi2.notnull().any()) else np.nan,
        "design_factor_max": float(nanmax(out["design_factor"], ["speed", "train"])),
    }
    return _summarise(out, "Dynamic increment φ'dyn", "EN 1991-2 6.4.6.5 [R]", "1", None,
                      extra=extra)


def wheel_unloading(
    ds: xr.Dataset, limit: float = WHEEL_UNLOADING_LIMIT, q: float = DEFAULT_Q,
    n_boot: int = 2000, seed: int = 0,
) -> xr.Dataset:
    """Wheel unloading dQ/Q0 against 0.6 (EN 14363 practice [R]) and contact loss.

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
    limit : float
        Admissible dQ/Q0.
    q : float
        Characteristic fractile (upper for dQ/Q0, 1 - q for the minimum contact force).

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
    fixed = prescribed_wheels(ds)  # (train, wheel)
    applicable = applicable_trains(ds, fixed)

    def free(name):
        """``ds[name]`` with the wheels of prescribed force masked out."""
        return ds[name].where(~fixed)

    dq = free("max_wheel_unloading")
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
    extra = {"applicable_trains": ", ".join(yes), "not_applicable_trains": ", ".join(no)}
    if "min_contact_force" in ds:
        qmin = nanmin(free("min_contact_force"), "wheel")
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
    out = _summarise(out, "Wheel unloading ΔQ/Q₀", WHEEL_UNLOADING_CLAUSE, "1", limit,
                     extra={**extra, "basis": out.attrs["basis"]})
    if not yes:
        out.attrs.update(result=_RESULT_NA, value=np.nan, margin=np.nan, utilisation=np.nan,
                         governing_train="", governing_speed=np.nan, governing_speed_kmh=np.nan,
                         note="the contact forces never change (moving-force model): wheel "
                              "unloading does not apply")
    if out.attrs["governing_train"]:
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        w = nanargmax_case(out["wheel_unloading"].sel(train=t, speed=v))
        out.attrs["governing_wheel"] = -1 if w is None else int(w["wheel"])
        out.attrs["governing_irregularity"] = _case_realisation(nanmax(dq, "wheel"), t, v)
    else:
        out.attrs["governing_wheel"] = -1
    return out


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


def _prescribed_contact_forces(ds: xr.Dataset) -> bool:
    """True when no train of ``ds`` has a varying contact force (all moving forces)."""
    return not bool(applicable_trains(ds).any())


def comfort(
    ds: xr.Dataset, required: str = "very good", q: float = DEFAULT_Q, n_boot: int = 2000,
    seed: int = 0,
) -> xr.Dataset:
    """Car-body vertical acceleration b_v against the levels of EN 1990 Table A2.9 [R].

    Levels: very good 1.0, good 1.3, acceptable 2.0 m s-2 (:data:`COMFORT_LEVELS`). The
    required level is specified for the project (EN 1990 A2.4.4.3 [R]); "very good" is
    the default here.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with ``max_carbody_acceleration(speed, train, irregularity, vehicle)``.
    required : str
        Required level of comfort, a key of :data:`COMFORT_LEVELS`.

    Returns
    -------
    xarray.Dataset
        ``value(speed, train)`` (m s-2, max over vehicles, design value);
        ``level(speed, train)`` (str: the best level attained, or "not acceptable");
        ``margin``/``utilisation``/``passed`` against the required level; statistics;
        summary attrs plus ``required_level`` and ``level`` (attained in the governing
        case), and, when the results have ``position_of_max_carbody_acceleration``,
        ``governing_vehicle`` (name) and ``governing_position`` (m ahead of that body's
        centre of gravity: the comfort point of the governing peak). All NaN (result
        "n/a", attribute ``note``) for a moving-force model (no car bodies).
    """
    ds = prepare(ds)
    require(ds, ["max_carbody_acceleration"], "the comfort check")
    if required not in COMFORT_LEVELS:
        raise ValueError(f"required comfort level {required!r} is not one of "
                         f"{list(COMFORT_LEVELS)}")
    limit = COMFORT_LEVELS[required]
    bv = nanmax(ds["max_carbody_acceleration"], "vehicle")
    out = design_value(bv, q=q, limit=limit, n_boot=n_boot, seed=seed)
    out["value"].attrs.update(units="m s-2", long_name="car-body vertical acceleration b_v")
    out["level"] = xr.apply_ufunc(np.vectorize(comfort_level, otypes=[object]), out["value"])
    out = _summarise(out, "Car-body acceleration (comfort)", COMFORT_CLAUSE, "m s-2", limit,
                     extra={"required_level": required, "basis": out.attrs["basis"]})
    out.attrs["level"] = comfort_level(out.attrs["value"])
    if out.attrs["governing_train"] and "position_of_max_carbody_acceleration" in ds:
        t, v = out.attrs["governing_train"], out.attrs["governing_speed"]
        irr = _case_realisation(bv, t, v)
        case = ds["max_carbody_acceleration"].sel(train=t, speed=v, irregularity=irr)
        if bool(case.notnull().any()):
            k = int(case.fillna(-np.inf).argmax("vehicle"))
            pos = ds["position_of_max_carbody_acceleration"].sel(train=t, speed=v,
                                                                 irregularity=irr)
            out.attrs["governing_position"] = float(pos.isel(vehicle=k))
            name = (ds["vehicle_name"].sel(train=t).isel(vehicle=k).values
                    if "vehicle_name" in ds and "train" in ds["vehicle_name"].dims else k)
            out.attrs["governing_vehicle"] = str(name)
    if ds.sizes.get("vehicle", 0) == 0 or not bool(out["value"].notnull().any()):
        out.attrs["note"] = "no car-body accelerations in the results (moving-force model)"
    return out


def comfort_level(bv: float) -> str:
    """Best EN 1990 Table A2.9 [R] level of comfort for car-body acceleration bv (m s-2)."""
    if not np.isfinite(bv):
        return _RESULT_NA
    for name, value in sorted(COMFORT_LEVELS.items(), key=lambda kv: kv[1]):
        if bv <= value:
            return name
    return "not acceptable"


def max_deck_displacement(ds: xr.Dataset, q: float = DEFAULT_Q) -> xr.Dataset:
    """Maximum deck displacement (information, no limit).

    The L/600 limit of EN 1990 A2.4.4.2.3 [R] is for LM71, not for these trains.
    """
    ds = prepare(ds)
    require(ds, ["max_deck_displacement"], "the deck displacement summary")
    out = design_value(nanmax(ds["max_deck_displacement"], "point"), q=q, n_boot=0)
    out["value"].attrs.update(units="m", long_name="maximum vertical deck displacement")
    return _summarise(out, "Max deck displacement", "information", "m", None,
                      extra={"basis": out.attrs["basis"]})


# --------------------------------------------------------------------------------------
# Summary
# --------------------------------------------------------------------------------------


SUMMARY_COLUMNS = ["check", "value", "units", "limit", "margin", "utilisation", "result",
                   "governing_train", "governing_speed_kmh", "clause"]


def run_checks(ds: xr.Dataset, q: float = DEFAULT_Q, comfort_level_required: str = "very good",
               n_boot: int = 2000, seed: int = 0, length: float | None = None
               ) -> dict[str, xr.Dataset | str]:
    """Every check that the variables of ``ds`` allow.

    ``length`` is the determinant length L_phi (m) given by the user (see
    :func:`dynamic_amplification`).

    Returns
    -------
    dict
        name -> check Dataset, or name -> str (why the check could not be made).
        Names: ``deck_acceleration``, ``deck_displacement``, ``dynamic_amplification``,
        ``wheel_unloading``, ``comfort``.
    """
    ds = prepare(ds)
    calls = {
        "deck_acceleration": lambda: deck_acceleration_check(ds, q=q, n_boot=n_boot,
                                                             seed=seed),
        "deck_displacement": lambda: max_deck_displacement(ds, q=q),
        "dynamic_amplification": lambda: dynamic_amplification(ds, length=length, q=q),
        "wheel_unloading": lambda: wheel_unloading(ds, q=q, n_boot=n_boot, seed=seed),
        "comfort": lambda: comfort(ds, comfort_level_required, q=q, n_boot=n_boot, seed=seed),
    }
    out = {}
    for name, call in calls.items():
        try:
            out[name] = call()
        except ResultsError as exc:
            out[name] = str(exc)
    return out


def summary_table(checks: dict) -> pd.DataFrame:
    """One row per check (the summary attrs of each check Dataset).

    Parameters
    ----------
    checks : dict
        As returned by :func:`run_checks` (string entries are skipped).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`SUMMARY_COLUMNS`; SI values; ``result`` in pass / FAIL / info / n/a.
    """
    rows = []
    for check in checks.values():
        if isinstance(check, str):
            continue
        rows.append({c: check.attrs.get(c, np.nan) for c in SUMMARY_COLUMNS})
        if "design_factor" in check:
            a = check.attrs
            gov = _governing(check["design_factor"])
            rows.append({
                "check": "Design factor 1 + φ'dyn + φ''/2",
                "value": a["design_factor_max"], "units": "1", "limit": np.nan,
                "margin": np.nan, "utilisation": np.nan,
                "result": "info" if np.isfinite(a["design_factor_max"]) else _RESULT_NA,
                "governing_train": "" if gov is None else str(gov["train"]),
                "governing_speed_kmh": np.nan if gov is None else float(
                    check["speed_kmh"].sel(speed=gov["speed"])),
                "clause": "EN 1991-2 6.4.6.5(3), Annex C [R]",
            })
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)
