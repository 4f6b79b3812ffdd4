"""Statistics over track-irregularity realisations.

Each realisation (one random irregularity profile, one seed) gives one value of a response
envelope; the design value is a high fractile of that sample (the characteristic value,
95 % by default, as for the characteristic value of an action in EN 1990 §1.5.3.14 [R]).
With few realisations the empirical fractile is uncertain, so a bootstrap confidence
interval and the number of realisations come with it.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.special
import xarray as xr

#: Largest number of doubles held at once by the vectorised bootstrap.
_BOOT_CHUNK = 4_000_000


def wilks_sample_size(q: float = 0.95, confidence: float = 0.95) -> int:
    """Smallest n for which the sample maximum bounds the q-fractile with ``confidence``.

    First-order Wilks tolerance limit: ``1 - q**n >= confidence`` (59 for 95 %/95 %).
    """
    if not (0.0 < q < 1.0 and 0.0 < confidence < 1.0):
        raise ValueError("q and confidence must lie in (0, 1)")
    return math.ceil(math.log(1.0 - confidence) / math.log(q))


def realisation_statistics(
    da: xr.DataArray,
    dim: str = "irregularity",
    q: float = 0.95,
    n_boot: int = 2000,
    seed: int = 0,
    limit: float | None = None,
    confidence: float = 0.95,
) -> xr.Dataset:
    """Mean, spread and characteristic q-fractile of ``da`` over realisations.

    Parameters
    ----------
    da : xarray.DataArray
        One value per realisation along ``dim`` (any other dims are kept). NaN entries
        (failed cases) are left out cell by cell.
    dim : str
        The realisation dimension. If ``da`` lacks it, ``da`` is one realisation.
    q : float
        Fractile of the characteristic value, in (0, 1): 0.95 for quantities whose large
        values are unfavourable, 0.05 for e.g. the minimum contact force.
    n_boot : int
        Bootstrap resamples for the confidence interval of the fractile (0: no interval).
    seed : int
        Seed of the bootstrap random generator (results are reproducible).
    limit : float, optional
        If given, the probability that a realisation exceeds ``limit`` is estimated.
    confidence : float
        Two-sided level of the bootstrap interval.

    Returns
    -------
    xarray.Dataset
        On the dims of ``da`` without ``dim``:

        ``n``
            Number of finite realisations.
        ``mean``, ``std``
            Sample mean and standard deviation (ddof = 1; NaN for n < 2).
        ``characteristic``
            Empirical q-fractile (linear interpolation between order statistics,
            ``numpy.quantile`` default; the value itself for n = 1).
        ``ci_low``, ``ci_high``
            Percentile-bootstrap interval of the q-fractile (NaN for n < 2).
        ``exceedance_probability``
            Fraction of realisations with value > ``limit`` (only with ``limit``).
        ``exceedance_probability_normal``
            P(X > limit) of a normal law with the sample mean and std (only with
            ``limit``; NaN for n < 2). Informative: resolves probabilities below 1/n.

        Attributes ``q``, ``confidence``, ``n_boot``, ``method`` and
        ``wilks_sample_size`` (n needed for the sample maximum to bound the q-fractile
        with 95 % confidence; 59 for q = 0.95) describe the estimate.

    Notes
    -----
    Percentile bootstrap (Efron & Tibshirani 1993, ch. 13): resample the n realisations
    with replacement ``n_boot`` times, take the q-fractile of each resample, report the
    (1 ± confidence)/2 percentiles of those. For extreme fractiles and small n the
    interval is too narrow (a resample never exceeds the sample maximum), which is why
    ``n`` and ``wilks_sample_size`` are reported alongside.
    """
    if not 0.0 < q < 1.0:
        raise ValueError(f"q must lie in (0, 1), got {q}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if n_boot < 0:
        raise ValueError(f"n_boot must be >= 0, got {n_boot}")
    if dim not in da.dims:
        da = da.expand_dims(dim)
    da = da.astype(float)
    other = [d for d in da.dims if d != dim]
    x = da.transpose(*other, dim).values
    shape = x.shape[:-1]
    n_all = x.shape[-1]
    flat = x.reshape(-1, n_all)
    finite = np.isfinite(flat)
    counts = finite.sum(axis=1)
    ordered = np.sort(np.where(finite, flat, np.inf), axis=1)  # finite values first

    m = flat.shape[0]
    mean = np.full(m, np.nan)
    std = np.full(m, np.nan)
    char = np.full(m, np.nan)
    ci = np.full((m, 2), np.nan)
    p_emp = np.full(m, np.nan)
    alpha = 1.0 - confidence
    rng = np.random.default_rng(seed)
    for k in np.unique(counts):
        if k == 0:
            continue
        rows = np.flatnonzero(counts == k)
        sample = ordered[rows, :k]
        mean[rows] = sample.mean(axis=1)
        char[rows] = np.quantile(sample, q, axis=1)
        if limit is not None:
            p_emp[rows] = (sample > limit).mean(axis=1)
        if k < 2 or n_boot == 0:
            continue
        std[rows] = sample.std(axis=1, ddof=1)
        idx = rng.integers(0, k, size=(n_boot, k))
        step = max(1, _BOOT_CHUNK // (n_boot * k))
        for start in range(0, rows.size, step):
            block = sample[start:start + step][:, idx]  # (rows, n_boot, k)
            boot = np.quantile(block, q, axis=-1)  # (rows, n_boot)
            ci[rows[start:start + step]] = np.quantile(
                boot, [alpha / 2, 1 - alpha / 2], axis=1
            ).T

    def wrap(values, long_name, units=None):
        attrs = {"long_name": long_name}
        if units is None and "units" in da.attrs:
            attrs["units"] = da.attrs["units"]
        elif units is not None:
            attrs["units"] = units
        return xr.DataArray(values.reshape(shape), dims=other, attrs=attrs)

    pct = f"{100 * q:g} %"
    out = xr.Dataset(
        {
            "n": wrap(counts, "number of realisations", "1"),
            "mean": wrap(mean, "mean over realisations"),
            "std": wrap(std, "standard deviation over realisations (ddof=1)"),
            "characteristic": wrap(char, f"characteristic value: {pct} fractile"),
            "ci_low": wrap(ci[:, 0], f"lower bound of the {100 * confidence:g} % "
                           f"bootstrap interval of the {pct} fractile"),
            "ci_high": wrap(ci[:, 1], f"upper bound of the {100 * confidence:g} % "
                            f"bootstrap interval of the {pct} fractile"),
        },
        coords={c: v for c, v in da.coords.items() if dim not in v.dims},
        attrs={
            "q": q,
            "confidence": confidence,
            "n_boot": n_boot,
            "seed": seed,
            "method": "empirical fractile (numpy linear interpolation), percentile bootstrap",
            "wilks_sample_size": wilks_sample_size(max(q, 1 - q)),
        },
    )
    if limit is not None:
        out["exceedance_probability"] = wrap(p_emp, f"fraction of realisations above {limit:g}",
                                             "1")
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (limit - mean) / std
        p_norm = np.where(counts >= 2, 0.5 * scipy.special.erfc(z / math.sqrt(2.0)), np.nan)
        p_norm = np.where((counts >= 2) & (std == 0), (mean > limit).astype(float), p_norm)
        out["exceedance_probability_normal"] = wrap(
            p_norm, f"P(value > {limit:g}) for a normal law fitted to the realisations", "1"
        )
        out.attrs["limit"] = float(limit)
    return out
