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
import math

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


def lowpass_sections(fs: float, cutoff: float):
    """``(sos, zi)`` of :func:`lowpass` at ``fs`` Hz: its second-order sections and
    their steady state for a unit step (:func:`scipy.signal.sosfilt_zi`); None when the
    cut-off is at or above the Nyquist frequency (no filter)."""
    if not cutoff < 0.5 * fs * 0.999:
        return None
    sos = _sos(float(fs), float(cutoff))
    return sos, scipy.signal.sosfilt_zi(sos)


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


def kept_correlation(fs: float, cutoff: float, spacing: float) -> float:
    """The factor ``kappa = sum_k rho(k spacing)`` (all integers ``k``) of white noise
    sampled at ``fs`` after :func:`lowpass`, ``rho`` its autocorrelation: the ratio of
    the spectral density at low frequency of the filtered noise taken every ``spacing``
    seconds to that of independent samples of the same variance (1 without a filter).

    ``rho`` from the filter's zero-phase impulse response ``y`` (``rho(j) = sum_n y[n]
    y[n + j] / sum_n y[n]^2`` at the lags ``j / fs``), linearly interpolated at the
    multiples of ``spacing``.
    """
    if not cutoff < 0.5 * fs * 0.999:
        return 1.0
    half = int(math.ceil(64.0 * fs / cutoff))  # the response is below 1e-12 of its peak
    x = np.zeros(2 * half + 1)
    x[half] = 1.0
    y = lowpass(x, fs, cutoff)
    r = np.correlate(y, y, mode="full")[y.size - 1:]
    r = r / r[0]
    lags = np.arange(1, int(r.size / (spacing * fs)) + 1) * spacing * fs
    return float(1.0 + 2.0 * np.sum(np.interp(lags, np.arange(r.size), r)))


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


def decimation(dt: float, cutoff: float) -> int:
    """Samples of the model grid per sample of the coarse alignment search: the grid
    thinned to at least 8 samples per period of the cut-off frequency (the filtered
    histories have no content above about twice the cut-off: 0.4 % at 2 f_c)."""
    return max(1, int(math.floor(1.0 / (COARSE_SAMPLES_PER_PERIOD * cutoff * dt))))


#: Samples per period of the cut-off frequency of the coarse alignment search.
COARSE_SAMPLES_PER_PERIOD = 8


def best_shifts(m: np.ndarray, S: np.ndarray, lag0: int, max_lag: int, dec: int,
                m_fft=None) -> np.ndarray:
    """:func:`best_shift` of every column of ``S`` (J, n) against ``m`` (K,), at once
    (numpy; the calibration runs the compiled equivalent,
    :class:`vsi_numba.existing.misfit.RecordFit`).

    A coarse search on the grid thinned by ``dec`` (one FFT cross-correlation of all the
    columns: :func:`scipy.fft.rfft` along the time axis), then the sums of squares at
    the integer lags within ``dec`` of the coarse minimum on the full grid, refined by a
    parabola through the minimum and its neighbours.  ``m_fft``: a dict in which the
    thinned record's transforms are kept between calls.  Returns the lags (n,), in
    samples of the full grid.
    """
    import scipy.fft

    m = np.asarray(m, float)
    S = np.asarray(S, float)
    K, J = m.size, S.shape[0]
    n = S.shape[1]
    lo, hi = max(lag0 - max_lag, -(K - 1)), min(lag0 + max_lag, J - 1)
    if lo > hi or n == 0:
        return np.full(n, float(lag0))
    md, Sd = m[::dec], S[::dec]
    Kd, Jd = md.size, Sd.shape[0]
    nfft = scipy.fft.next_fast_len(Kd + Jd, real=True)
    key = (nfft, dec, K)
    cache = m_fft if m_fft is not None else {}
    if key not in cache:
        cache[key] = (np.conj(scipy.fft.rfft(md, nfft)), float(md @ md))
    mf, mmd = cache[key]
    c = scipy.fft.irfft(scipy.fft.rfft(Sd, nfft, axis=0) * mf[:, None], nfft, axis=0)
    lo_c, hi_c = max(-(-lo // dec), -(Kd - 1)), min(hi // dec, Jd - 1)
    if lo_c > hi_c:
        lo_c = hi_c = int(np.clip(round(lag0 / dec), -(Kd - 1), Jd - 1))
    lags_c = np.arange(lo_c, hi_c + 1)
    csd = np.concatenate([np.zeros((1, n)), np.cumsum(Sd * Sd, axis=0)])
    energy = csd[np.clip(lags_c + Kd, 0, Jd)] - csd[np.clip(lags_c, 0, Jd)]
    sse_c = mmd - 2.0 * c[lags_c % nfft] + energy
    coarse = lags_c[np.argmin(sse_c, axis=0)] * dec
    # the full grid near the coarse minimum: s zero outside its samples
    pad = np.zeros((n, K + J + K))  # a row per column of S: contiguous dot products
    pad[:, K: K + J] = S.T
    cs = np.concatenate([np.zeros((1, n)), np.cumsum(S * S, axis=0)])
    mm = float(m @ m)
    out = np.empty(n)
    for j in range(n):
        lags = np.arange(max(lo, coarse[j] - dec), min(hi, coarse[j] + dec) + 1)
        col = pad[j]
        cj = np.array([m @ col[K + L: 2 * K + L] for L in lags])
        e = cs[np.clip(lags + K, 0, J), j] - cs[np.clip(lags, 0, J), j]
        sse = mm - 2.0 * cj + e
        i = int(np.argmin(sse))
        frac = 0.0
        if 0 < i < sse.size - 1:
            a, b, d = sse[i - 1], sse[i], sse[i + 1]
            den = a - 2.0 * b + d
            if den > 0:
                frac = float(np.clip(0.5 * (a - d) / den, -0.5, 0.5))
        out[j] = lags[i] + frac
    return out
