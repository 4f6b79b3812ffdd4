"""Vertical track irregularity profiles r(x).

Convention: ``r > 0`` means the rail is **lower** than nominal (a dip), so with
displacements positive down the rail top sits at ``w_deck(x) + r(x)``.

Every profile is carried to the kernels as a C2 cubic spline on a uniform grid
(``x0``, ``dx``, coefficients per interval).  A cubic spline keeps r, r' and r''
continuous, so the interpolation adds no curvature spikes of its own (linear
interpolation would put a Dirac in r'' at every sample, i.e. a force spike on a rigid
wheel).  Outside the sampled range the profile is zero.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.interpolate


@dataclass(frozen=True)
class Profile:
    """A sampled profile with its spline coefficients.

    Parameters
    ----------
    x0 : float
        Abscissa of the first sample (m, from the bridge's left end).
    dx : float
        Sample spacing (m).
    coef : ndarray, shape (n_intervals, 4)
        Per interval ``k``, with ``s = x - (x0 + k dx)``:
        ``r = c0 + c1 s + c2 s^2 + c3 s^3``.
    label : str
        Human-readable description (kind and parameters).
    """

    x0: float
    dx: float
    coef: np.ndarray
    label: str = "none"

    @property
    def x_end(self) -> float:
        return self.x0 + self.dx * self.coef.shape[0]

    @property
    def is_zero(self) -> bool:
        return self.coef.shape[0] == 0 or not np.any(self.coef)

    def __call__(self, x, derivative: int = 0) -> np.ndarray:
        """Evaluate r (or its derivative) at ``x`` (vectorised, zero outside)."""
        x = np.asarray(x, float)
        out = np.zeros_like(x)
        n = self.coef.shape[0]
        if n == 0:
            return out
        k = np.floor((x - self.x0) / self.dx).astype(np.int64)
        inside = (x >= self.x0) & (x <= self.x_end)
        k = np.clip(k, 0, n - 1)
        s = x - (self.x0 + k * self.dx)
        c = self.coef[k]
        if derivative == 0:
            val = c[..., 0] + s * (c[..., 1] + s * (c[..., 2] + s * c[..., 3]))
        elif derivative == 1:
            val = c[..., 1] + s * (2 * c[..., 2] + 3 * s * c[..., 3])
        elif derivative == 2:
            val = 2 * c[..., 2] + 6 * s * c[..., 3]
        else:
            raise ValueError("derivative must be 0, 1 or 2")
        out[inside] = val[inside]
        return out

    @classmethod
    def from_samples(cls, x, r, label: str = "samples", dx: float | None = None) -> Profile:
        """Spline through samples ``(x, r)`` (x strictly increasing), on a uniform grid.

        Non-uniform samples are first interpolated by a C2 cubic spline and resampled
        at ``dx`` (default: the smallest sample spacing).
        """
        x = np.asarray(x, float)
        r = np.asarray(r, float)
        if x.ndim != 1 or x.shape != r.shape or x.size < 4:
            raise ValueError("a profile needs at least 4 samples of x and r of equal length")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(r))):
            raise ValueError("profile samples contain NaN or inf")
        if np.any(np.diff(x) <= 0):
            raise ValueError("profile x must be strictly increasing")
        h = np.diff(x)
        uniform = np.allclose(h, h[0], rtol=1e-9, atol=0.0)
        if dx is None:
            dx = float(h.min())
        if not uniform or abs(dx - h[0]) > 1e-12 * dx:
            spl = scipy.interpolate.CubicSpline(x, r, bc_type="natural")
            n = int(np.floor((x[-1] - x[0]) / dx + 1e-9))
            xu = x[0] + dx * np.arange(n + 1)
            ru = spl(xu)
        else:
            xu, ru = x, r
        spl = scipy.interpolate.CubicSpline(xu, ru, bc_type="natural")
        # scipy stores c[m, k] for (x - x_k)^(3 - m); reorder to ascending powers.
        coef = np.ascontiguousarray(spl.c[::-1].T)
        return cls(x0=float(xu[0]), dx=float(xu[1] - xu[0]), coef=coef, label=label)

    @classmethod
    def from_function(
        cls, func: Callable[[np.ndarray], np.ndarray], x_start: float, x_stop: float,
        dx: float, label: str,
    ) -> Profile:
        """Sample ``func`` on ``[x_start, x_stop]`` at spacing ``dx`` and spline it."""
        n = max(int(np.ceil((x_stop - x_start) / dx)), 3)
        x = x_start + dx * np.arange(n + 1)
        return cls.from_samples(x, func(x), label=label)


def no_irregularity() -> Profile:
    """The perfectly smooth track."""
    return Profile(x0=0.0, dx=1.0, coef=np.zeros((0, 4)), label="none")


def cosine_defect(
    depth: float, wavelength: float, position: float, samples_per_wavelength: int = 200
) -> Profile:
    """Isolated cosine defect: ``r = depth/2 (1 - cos(2 pi (x - position)/wavelength))``.

    ``depth > 0`` is a dip (the rail is lower), ``depth < 0`` a bump.  The defect starts
    at ``position`` and is ``wavelength`` long; r and r' are continuous at its ends.
    """
    if wavelength <= 0:
        raise ValueError("wavelength must be > 0")

    def func(x):
        s = (x - position) / wavelength
        inside = (s >= 0.0) & (s <= 1.0)
        return np.where(inside, 0.5 * depth * (1.0 - np.cos(2.0 * np.pi * s)), 0.0)

    dx = wavelength / samples_per_wavelength
    pad = 4 * dx
    return Profile.from_function(
        func, position - pad, position + wavelength + pad, dx,
        label=f"cosine depth={depth} m wavelength={wavelength} m position={position} m",
    )
