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

Every limit and clause value comes from the code profile in force
(:mod:`vsi_numba.code_profile`): by default the one stored with the results
(:func:`profile_of`), so a study run with a national annex is checked with it.  The
profile's table says which values were recalled and not re-read ([R]).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.checks.comfort import comfort
from vsi_numba.analysis.checks.common import (
    _RESULT_NA,
    DEFAULT_Q,
    WHEEL_UNLOADING_CLAUSE,
    WHEEL_UNLOADING_LIMIT,
    _governing,
    design_value,
    profile_of,
    resonance_speeds,
)
from vsi_numba.analysis.checks.deck import (
    deck_acceleration_check,
    dynamic_amplification,
    max_deck_displacement,
)
from vsi_numba.analysis.checks.determinant import (
    DeterminantLength,
    determinant_length,
    results_config,
)
from vsi_numba.analysis.checks.wheels import (
    applicable_trains,
    prescribed_wheels,
    wheel_unloading,
)
from vsi_numba.analysis.dataset import ResultsError, prepare
from vsi_numba.en1990 import (
    COMFORT_CLAUSE,
    COMFORT_LEVELS,
    CUTOFF_MIN_FREQUENCY,
    DECK_ACCELERATION_CLAUSE,
    DECK_ACCELERATION_KEYS,
    DECK_ACCELERATION_LIMITS,
    comfort_level,
    frequency_cutoff,
)
from vsi_numba.en1991 import (
    CONTINUOUS_K,
    CONTINUOUS_K_MANY,
    DETERMINANT_LENGTH_CLAUSE,
    continuous_determinant_length,
    irregularity_allowance,
)

__all__ = [
    "COMFORT_CLAUSE",
    "COMFORT_LEVELS",
    "CONTINUOUS_K",
    "CONTINUOUS_K_MANY",
    "CUTOFF_MIN_FREQUENCY",
    "DECK_ACCELERATION_CLAUSE",
    "DECK_ACCELERATION_KEYS",
    "DECK_ACCELERATION_LIMITS",
    "DEFAULT_Q",
    "DETERMINANT_LENGTH_CLAUSE",
    "SUMMARY_COLUMNS",
    "WHEEL_UNLOADING_CLAUSE",
    "WHEEL_UNLOADING_LIMIT",
    "DeterminantLength",
    "ResultsError",
    "applicable_trains",
    "comfort",
    "comfort_level",
    "continuous_determinant_length",
    "deck_acceleration_check",
    "design_value",
    "determinant_length",
    "dynamic_amplification",
    "frequency_cutoff",
    "irregularity_allowance",
    "max_deck_displacement",
    "prescribed_wheels",
    "profile_of",
    "resonance_speeds",
    "results_config",
    "run_checks",
    "summary_table",
    "wheel_unloading",
]


SUMMARY_COLUMNS = ["check", "value", "units", "limit", "margin", "utilisation", "result",
                   "governing_train", "governing_speed_kmh", "where", "clause"]


def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def where_of(name: str, check: xr.Dataset) -> str:
    """Where the governing value of a check lies, in words (the summary's column
    ``where``): the deck abscissa and line, the axle and its position, the vehicle.
    "" when the check has no governing case."""
    a = check.attrs
    if not a.get("governing_train"):
        return ""
    if name == "deck_acceleration":
        x = _num(a.get("governing_point"))
        line = (f"the deck and the line of track {int(a['loaded_track'])}"
                if a.get("loaded_track") is not None else "the deck")
        grid = "whole-deck grid" if a.get("whole_deck") else "output points"
        return (f"x = {x:g} m" if np.isfinite(x) else "") + f" (largest over {line}, {grid})"
    if name == "deck_displacement":
        x = _num(a.get("governing_point"))
        return (f"x = {x:g} m" if np.isfinite(x) else "the deck") \
            + " (largest over the output points)"
    if name == "dynamic_amplification":
        return "the deck (largest displacement over the output points, dynamic over static)"
    if name == "wheel_unloading":
        x = _num(a.get("governing_x"))
        w = int(a.get("governing_wheel", -1))
        return ("upper bound from " if a.get("value_is_upper_bound") else "") + (
            f"axle {w}" if w >= 0 else "an axle") + (
            f", minimum contact force at x = {x:.4g} m" if np.isfinite(x) else "") + (
            " (off the bridge)" if a.get("value_is_upper_bound") else "")
    if name == "comfort":
        d = _num(a.get("governing_position"))
        v = a.get("governing_vehicle", "")
        return (f"vehicle {v}" if v != "" else "a vehicle") + (
            f", {abs(d):g} m {'ahead of' if d > 0 else 'behind'} its centre of gravity"
            if np.isfinite(d) and abs(d) > 1e-9 else ", at its centre of gravity"
            if np.isfinite(d) else "")
    return ""


def run_checks(ds: xr.Dataset, q: float = DEFAULT_Q, comfort_level_required: str = "very good",
               n_boot: int = 2000, seed: int = 0, length: float | None = None,
               profile=None) -> dict[str, xr.Dataset | str]:
    """Every check that the variables of ``ds`` allow.

    ``length`` is the determinant length L_phi (m) given by the user (see
    :func:`dynamic_amplification`); ``profile`` the code profile (default: the one
    stored with the results, :func:`profile_of`).

    Returns
    -------
    dict
        name -> check Dataset, or name -> str (why the check could not be made).
        Names: ``deck_acceleration``, ``deck_displacement``, ``dynamic_amplification``,
        ``wheel_unloading``, ``comfort``.
    """
    ds = prepare(ds)
    p = profile_of(ds, profile)
    calls = {
        "deck_acceleration": lambda: deck_acceleration_check(ds, q=q, n_boot=n_boot,
                                                             seed=seed, profile=p),
        "deck_displacement": lambda: max_deck_displacement(ds, q=q),
        "dynamic_amplification": lambda: dynamic_amplification(ds, length=length, q=q,
                                                               profile=p),
        "wheel_unloading": lambda: wheel_unloading(ds, q=q, n_boot=n_boot, seed=seed,
                                                   profile=p),
        "comfort": lambda: comfort(ds, comfort_level_required, q=q, n_boot=n_boot, seed=seed,
                                   profile=p),
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
    for name, check in checks.items():
        if isinstance(check, str):
            continue
        rows.append({c: check.attrs.get(c, np.nan) for c in SUMMARY_COLUMNS}
                    | {"where": where_of(name, check)})
        if "approach_value" in check.attrs:  # wheel unloading off the bridge's zone
            a = check.attrs
            rows.append({
                "check": "Wheel unloading ΔQ/Q₀ on the approach / exit track "
                         f"(beyond {a['transition_zone']:g} m of the deck ends; "
                         "information, not the bridge's check)",
                "value": a["approach_value"], "units": "1", "limit": np.nan,
                "margin": np.nan, "utilisation": np.nan, "result": "info",
                "governing_train": a["approach_train"],
                "governing_speed_kmh": a["approach_speed_kmh"],
                "where": f"axle {a['approach_wheel']}, minimum contact force at "
                         f"x = {a['approach_x']:.4g} m", "clause": "information"})
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
                "where": where_of(name, check) if gov is not None else "",
                "clause": "EN 1991-2 6.4.6.5(3), Annex C",
            })
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)
