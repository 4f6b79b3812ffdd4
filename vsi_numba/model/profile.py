"""The track profile r(x) as the kernels take it: a C2 cubic spline on a uniform grid
(see :mod:`vsi_numba.model.irregularity` for the sign convention and the profiles)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


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
        """Abscissa of the last sample (m)."""
        return self.x0 + self.dx * self.coef.shape[0]

    @property
    def is_zero(self) -> bool:
        """True for the smooth track (no intervals or all coefficients zero)."""
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
        import scipy.interpolate  # here, not at import: it takes ~0.4 s to import

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
        given = dx is not None
        if dx is None:
            dx = float(h.min())
        if not uniform or abs(dx - h[0]) > 1e-9 * dx:
            _check_samples((x[-1] - x[0]) / dx, dx, "the resampled profile (dx = the "
                           "smallest sample spacing unless irregularity.dx is given)")
            spl = scipy.interpolate.CubicSpline(x, r, bc_type="natural")
            n = int(np.floor((x[-1] - x[0]) / dx + 1e-9))
            xu = x[0] + dx * np.arange(n + 1)
            ru = spl(xu)
        else:
            xu, ru = x, r
        spl = scipy.interpolate.CubicSpline(xu, ru, bc_type="natural")
        # scipy stores c[m, k] for (x - x_k)^(3 - m); reorder to ascending powers.
        coef = np.ascontiguousarray(spl.c[::-1].T)
        # the grid step: the one given (exact), else that of the first interval
        step = float(dx) if given else float(xu[1] - xu[0])
        return cls(x0=float(xu[0]), dx=step, coef=coef, label=label)

    @classmethod
    def from_function(
        cls, func: Callable[[np.ndarray], np.ndarray], x_start: float, x_stop: float,
        dx: float, label: str,
    ) -> Profile:
        """Sample ``func`` on ``[x_start, x_stop]`` at spacing ``dx`` and spline it."""
        _check_samples((x_stop - x_start) / dx, dx, label)
        n = max(int(np.ceil((x_stop - x_start) / dx)), 3)
        x = x_start + dx * np.arange(n + 1)
        return cls.from_samples(x, func(x), label=label)


#: Samples one profile may have (its FFT included): beyond this it is refused before any
#: allocation (about 160 MB per array of float64).
MAX_SAMPLES = 20_000_000


def _check_samples(n: float, dx: float, what: str) -> None:
    """Refuse a profile of more than :data:`MAX_SAMPLES` samples (a MemoryError later)."""
    if not n <= MAX_SAMPLES:
        raise ValueError(
            f"{what}: {n:.3g} samples at dx = {dx:.3g} m, more than the budget of "
            f"{MAX_SAMPLES:.3g}; give a coarser sample spacing (irregularity.dx) or a "
            "shorter track (solver.free_vibration, train length, irregularity."
            "wavelength_max)")


def no_irregularity() -> Profile:
    """The perfectly smooth track."""
    return Profile(x0=0.0, dx=1.0, coef=np.zeros((0, 4)), label="none")
