"""Priors and random inputs: a distribution per key, mapped from a standard normal.

Every sampler here works in the standard normal space ``u`` (one independent N(0, 1) per
key): ``x = F^-1(Phi(u))`` with ``F`` the key's distribution (scipy.stats), so a prior
is N(0, I) in ``u`` whatever its kind and the sampler sees well-scaled coordinates.

- ``uniform``: ``lower``, ``upper``;
- ``normal``: ``mean``, ``std``;
- ``lognormal``: ``median``, ``cov`` (coefficient of variation: ``sigma_ln =
  sqrt(ln(1 + cov^2))``).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.stats


def frozen(spec: dict):
    """The scipy.stats distribution of a ``{prior|distribution, ...}`` table."""
    kind = spec.get("prior", spec.get("distribution"))
    if kind == "uniform":
        lo, hi = float(spec["lower"]), float(spec["upper"])
        return scipy.stats.uniform(loc=lo, scale=hi - lo)
    if kind == "normal":
        return scipy.stats.norm(loc=float(spec["mean"]), scale=float(spec["std"]))
    if kind == "lognormal":
        s = math.sqrt(math.log1p(float(spec["cov"]) ** 2))
        return scipy.stats.lognorm(s=s, scale=float(spec["median"]))
    raise ValueError(f"unknown distribution {kind!r}")


def describe(spec: dict) -> str:
    """``"lognormal(median 2e+10, cov 0.2)"``."""
    kind = spec.get("prior", spec.get("distribution"))
    args = {"uniform": ("lower", "upper"), "normal": ("mean", "std"),
            "lognormal": ("median", "cov")}[kind]
    return f"{kind}(" + ", ".join(f"{a} {float(spec[a]):.4g}" for a in args) + ")"


class Marginals:
    """Independent marginals of several keys, mapped from the standard normal space."""

    def __init__(self, specs):
        self.specs = list(specs)
        self.dists = [frozen(s) for s in self.specs]

    @property
    def n(self) -> int:
        return len(self.dists)

    def from_u(self, u) -> np.ndarray:
        """Values (..., n) of standard normal coordinates (..., n)."""
        u = np.asarray(u, float)
        p = scipy.stats.norm.cdf(u)
        # the tails of Phi in float64: keep ppf finite (|u| < 8.2)
        p = np.clip(p, 1e-16, 1.0 - 1e-16)
        return np.stack([d.ppf(p[..., i]) for i, d in enumerate(self.dists)], axis=-1)

    def to_u(self, x) -> np.ndarray:
        """Standard normal coordinates of values (..., n)."""
        x = np.asarray(x, float)
        return np.stack([scipy.stats.norm.ppf(np.clip(d.cdf(x[..., i]), 1e-16, 1 - 1e-16))
                         for i, d in enumerate(self.dists)], axis=-1)

    def logpdf(self, x) -> np.ndarray:
        """Sum of the marginal log densities at values (..., n)."""
        x = np.asarray(x, float)
        return sum(d.logpdf(x[..., i]) for i, d in enumerate(self.dists))
