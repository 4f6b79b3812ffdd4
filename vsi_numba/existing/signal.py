"""The records' signal processing: the EN cut-off low-pass, resampling, alignment.

The deck acceleration of the check is band-limited to the modes up to the EN 1990 A2
cut-off ``max(30 Hz, 1.5 f1, f3)`` (:func:`vsi_numba.en1990.frequency_cutoff`, the
frequency the solver uses to drop the modes above it).  A measured record has every
frequency, so both the record and the model's history go through the same zero-phase
low-pass at that frequency (Butterworth, order 4, applied forward and backward:
:func:`scipy.signal.sosfiltfilt`, gain 1/2 (-6 dB) at the cut-off, no phase shift)
before they are compared.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.signal

#: Order of the Butterworth low-pass (applied twice: forward and backward).
ORDER = 4


def lowpass(x: np.ndarray, fs: float, cutoff: float) -> np.ndarray:
    """Zero-phase low-pass of ``x`` (along axis 0) sampled at ``fs`` Hz; unchanged when
    the cut-off is at or above the Nyquist frequency."""
    x = np.asarray(x, float)
    if not cutoff < 0.5 * fs * 0.999:
        return x.copy()
    sos = _sos(float(fs), float(cutoff))
    pad = min(x.shape[0] - 1, 3 * (2 * len(sos) + 1))
    return scipy.signal.sosfiltfilt(sos, x, axis=0, padlen=pad)


@functools.lru_cache(maxsize=64)
def _sos(fs: float, cutoff: float) -> np.ndarray:
    """Second-order sections of the Butterworth low-pass (designed once per pair)."""
    return scipy.signal.butter(ORDER, cutoff, btype="low", fs=fs, output="sos")


def noise_gain(n: int, fs: float, cutoff: float, seed: int = 12345) -> float:
    """Standard deviation of unit white noise (``n`` samples at ``fs``) after
    :func:`lowpass` (a fixed-seed sample: the same figure on every call)."""
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(max(int(n), 256))
    return float(np.std(lowpass(e, fs, cutoff)))


def resample(t: np.ndarray, x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``x(t)`` on the grid ``t[0] + k dt`` inside ``[t[0], t[-1]]`` (cubic spline: its
    error on a component of frequency f sampled every h is of order (2 pi f h)^4 / 384,
    against (2 pi f h)^2 / 8 for linear interpolation)."""
    import scipy.interpolate

    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    tk = t[0] + dt * np.arange(n)
    return tk, scipy.interpolate.CubicSpline(t, x)(tk)


def best_shift(m: np.ndarray, s: np.ndarray, lag0: int, max_lag: int) -> tuple[float, float]:
    """The shift (in samples, sub-sample) of the model history ``s`` that fits the
    measured ``m`` best in least squares: ``m[k] ~ s[k + L]`` (``s`` zero outside its
    samples: the deck at rest before the train), ``L`` in ``lag0 +- max_lag``.

    The sums of squares of all integer lags come from one FFT cross-correlation
    (:func:`scipy.signal.correlate`); the minimum is refined by a parabola through its
    neighbours.  Returns ``(L, sum of squares at the best integer lag)``.
    """
    m = np.asarray(m, float)
    s = np.asarray(s, float)
    K, J = m.size, s.size
    lo, hi = max(lag0 - max_lag, -(K - 1)), min(lag0 + max_lag, J - 1)
    if lo > hi:
        return float(lag0), float(m @ m)
    # c[L] = sum_k m[k] s[k + L] for L = -(K - 1) .. J - 1; only the window is used
    c = scipy.signal.correlate(s, m, mode="full", method="fft")[lo + K - 1: hi + K]
    lags = np.arange(lo, hi + 1)
    cs = np.concatenate([[0.0], np.cumsum(s * s)])
    energy = cs[np.clip(lags + K, 0, J)] - cs[np.clip(lags, 0, J)]  # s[k + L]^2, overlap
    sse = float(m @ m) - 2.0 * c + energy
    i = int(np.argmin(sse))
    frac = 0.0
    if 0 < i < sse.size - 1:
        a, b, d = sse[i - 1], sse[i], sse[i + 1]
        den = a - 2.0 * b + d
        if den > 0:
            frac = float(np.clip(0.5 * (a - d) / den, -0.5, 0.5))
    return float(lags[i] + frac), float(sse[i])
