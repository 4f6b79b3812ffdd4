"""What every check shares: the characteristic value over irregularity realisations
(:func:`design_value`), the summary attributes of a check (:func:`_summarise`), the code
profile of a results file (:func:`profile_of`), the limits not from EN 1990
(:data:`WHEEL_UNLOADING_LIMIT`) and the resonance speeds."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.checks.determinant import results_config
from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    nanargmax_case,
    nanmax,
    nanmin,
)
from vsi_numba.analysis.statistics import realisation_statistics
from vsi_numba.code_profile import CodeProfile, default_profile, of_config, resolve
from vsi_numba.en1990 import NOT_APPLICABLE

#: Wheel unloading ratio limit dQ/Q0 (recommended value of the code profile).
WHEEL_UNLOADING_LIMIT = default_profile()["wheel_unloading_limit"]
WHEEL_UNLOADING_CLAUSE = default_profile().clause("wheel_unloading_limit")


def profile_of(ds: xr.Dataset, profile=None) -> CodeProfile:
    """The code profile of a results file: ``profile`` when given (a
    :class:`~vsi_numba.code_profile.CodeProfile` or a stored ``code_profile`` section),
    else the ``code_profile`` section of its stored configuration (``config_json``), else
    the recommended values."""
    if profile is not None:
        return resolve(profile)
    return of_config(results_config(ds))

#: Characteristic fractile over irregularity realisations (upper; 1 - q for minima).
DEFAULT_Q = 0.95

#: ``result`` of a check that could not be made.
_RESULT_NA = NOT_APPLICABLE


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
