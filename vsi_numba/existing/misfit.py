"""The likelihood's arithmetic on the histories of a chunk of forward runs, compiled.

What :mod:`vsi_numba.existing.signal` does with numpy and scipy, per history, done here
for every history of a chunk in a few compiled calls that release the GIL (so that the
threads of the ``threads`` backend run the likelihood in parallel, not only the
kernels):

* :func:`point_history` - a deck point's history from the modal histories of a run
  (``phi . q(t)``);
* :func:`first_unstorable` - the first step of a run whose modal histories leave the
  float32 range of the results file (the check of
  :func:`~vsi_numba.solver.batch.run_batch`);
* :func:`filtfilt_rows` - the zero-phase Butterworth low-pass of
  :func:`~vsi_numba.existing.signal.lowpass` (the operations of
  :func:`scipy.signal.sosfiltfilt` in its order: odd extension, the sections' steady
  state scaled by the first sample, forward then backward);
* :func:`align_rows` - the alignment of :func:`~vsi_numba.existing.signal.best_shifts`
  after its coarse FFT cross-correlation (done by the caller with :mod:`scipy.fft`,
  which releases the GIL too): the coarse minimum, the sums of squares at the integer
  lags near it, the parabola, then the misfit at the likelihood's samples (linear
  interpolation as :func:`numpy.interp`, zero outside the history) and, when asked,
  the aligned history on the record's grid (the posterior-predictive records).

The filter equals scipy's output (the same operations in the same order).  The fine
search sums the squares of the residuals at each lag directly (``best_shifts`` expands
them, ``m.m - 2 m.s + s.s``, with BLAS dot products, which cancel near the minimum): the
lags agree with the numpy path to about 1e-9 samples and the misfits to round-off, not
bit for bit.  Every row's numbers are those of the row alone, whatever the chunk.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit

#: Largest magnitude a result may have: histories are stored as float32.
STORABLE = float(np.finfo(np.float32).max)


@njit
def point_history(h, slot, n, shape, out):
    """``out[t] = sum_j shape[j] h[slot, t, j]`` for ``t < n`` (modal histories ``h``
    (slots, n_t, n_m), a point's mode shapes ``shape`` (n_m,))."""
    n_m = shape.shape[0]
    for t in range(n):
        a = 0.0
        for j in range(n_m):
            a += shape[j] * h[slot, t, j]
        out[t] = a


@njit
def first_unstorable(h, slot, n):
    """The first step ``t < n`` at which a value of ``h[slot, t]`` is not finite or
    beyond :data:`STORABLE` in magnitude (-1: none)."""
    for t in range(n):
        for j in range(h.shape[2]):
            if not abs(h[slot, t, j]) <= STORABLE:
                return t
    return -1


@njit
def _sosfilt(sos, zi, state, ext, lo, hi, step):
    """One pass of the sections over the rows ``ext[lo], ext[lo + step], ..`` (``hi``
    excluded) of ``ext`` (samples, n), in place, every column from the steady state
    ``zi`` times its first sample of the pass (scipy's ``_sosfilt``: per column the same
    operations in the same order; the columns interleaved, whose recurrences are
    independent, so that they overlap in the processor); ``state`` (n, n_s, 2):
    scratch."""
    n_s = sos.shape[0]
    n = ext.shape[1]
    for r in range(n):
        x0 = ext[lo, r]
        for s in range(n_s):
            state[r, s, 0] = zi[s, 0] * x0
            state[r, s, 1] = zi[s, 1] * x0
    i = lo
    while i != hi:
        for r in range(n):
            x_cur = ext[i, r]
            for s in range(n_s):
                x_new = sos[s, 0] * x_cur + state[r, s, 0]
                state[r, s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + state[r, s, 1]
                state[r, s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
                x_cur = x_new
            ext[i, r] = x_cur
        i += step


@njit(_nrt=True)
def filtfilt_rows(x, sos, zi, pad, y):
    """Zero-phase low-pass of each row of ``x`` (n, J) into ``y`` (n, J): odd
    extension by ``pad`` samples at both ends (``pad < J``), the sections ``sos``
    (n_s, 6) forward from their steady state ``zi`` (n_s, 2) times the first sample,
    backward from it times the last, the extension dropped
    (:func:`scipy.signal.sosfiltfilt` with ``padlen=pad``)."""
    n, J = x.shape
    m = J + 2 * pad
    ext = np.empty((m, n))
    state = np.empty((n, sos.shape[0], 2))
    for r in range(n):
        x0 = x[r, 0]
        x1 = x[r, J - 1]
        for i in range(pad):
            ext[i, r] = 2.0 * x0 - x[r, pad - i]
        for i in range(J):
            ext[pad + i, r] = x[r, i]
        for i in range(pad):
            ext[pad + J + i, r] = 2.0 * x1 - x[r, J - 2 - i]
    _sosfilt(sos, zi, state, ext, 0, m, 1)
    _sosfilt(sos, zi, state, ext, m - 1, -1, -1)
    for r in range(n):
        for i in range(J):
            y[r, i] = ext[pad + i, r]


@njit
def _squares(m, s, L, K, J):
    """``sum_k (m[k] - s[k + L])^2`` over ``k < K``, ``s`` zero outside its ``J``
    samples (four partial sums: independent additions)."""
    a = min(max(-L, 0), K)
    b = max(min(J - L, K), a)
    e0 = 0.0
    e1 = 0.0
    e2 = 0.0
    e3 = 0.0
    for k in range(a):
        e0 += m[k] * m[k]
    k = a
    while k + 3 < b:
        d0 = m[k] - s[k + L]
        d1 = m[k + 1] - s[k + 1 + L]
        d2 = m[k + 2] - s[k + 2 + L]
        d3 = m[k + 3] - s[k + 3 + L]
        e0 += d0 * d0
        e1 += d1 * d1
        e2 += d2 * d2
        e3 += d3 * d3
        k += 4
    while k < b:
        d0 = m[k] - s[k + L]
        e1 += d0 * d0
        k += 1
    for k in range(b, K):
        e2 += m[k] * m[k]
    return (e0 + e1) + (e2 + e3)


@njit
def _interp(s, x):
    """``numpy.interp(x, arange(J), s, left=0, right=0)``."""
    J = s.shape[0]
    if not x >= 0.0:
        return 0.0 if x < 0.0 else x  # NaN stays NaN
    if x > J - 1:
        return 0.0
    j = int(np.floor(x))
    if j >= J - 1:
        return s[J - 1]
    if x == j:
        return s[j]
    slope = (s[j + 1] - s[j]) / 1.0
    return slope * (x - j) + s[j]


@njit(_nrt=True)
def align_rows(m, y, c, dec, lag0, lo, hi, lo_c, hi_c, step, sig, lags, sse, aligned):
    """The best shift of every row of ``y`` (n, J) against the record ``m`` (K,) and
    the misfit at that shift.

    ``c`` (n, nfft): the circular cross-correlation of the record and the rows thinned
    by ``dec`` (``c[r, L] = sum_k m[k dec] y[r, (k + L) dec]``); ``lo``, ``hi``: the
    lags searched (samples of the full grid; ``lo > hi``: none, the shift is ``lag0``),
    ``lo_c``, ``hi_c``: the same on the thinned grid.  Returns in ``lags`` (n,) the
    shifts (sub-sample: ``m[k] ~ y[k + L]``), in ``sse`` (n,) ``sum ((m[k] - y(k + L))
    / sig[r])^2`` over ``k = 0, step, 2 step, ..``; when ``aligned`` has rows,
    ``aligned[r, k] = y(k + L)`` for every ``k < K``.
    """
    n, J = y.shape
    K = m.shape[0]
    nfft = c.shape[1]
    md = m[::dec]
    Kd = md.shape[0]
    Jd = (J + dec - 1) // dec
    mmd = 0.0
    for k in range(Kd):
        mmd += md[k] * md[k]
    csd = np.empty(Jd + 1)
    fine = np.empty(2 * dec + 1)
    for r in range(n):
        s = y[r]
        if lo > hi:
            lag = float(lag0)
        else:
            # coarse: the thinned grid, every lag of the window
            csd[0] = 0.0
            for k in range(Jd):
                v = s[k * dec]
                csd[k + 1] = csd[k] + v * v
            best = np.inf
            coarse = lo_c
            for L in range(lo_c, hi_c + 1):
                a = min(max(L + Kd, 0), Jd)
                b = min(max(L, 0), Jd)
                e = mmd - 2.0 * c[r, L % nfft] + (csd[a] - csd[b])
                if e < best:
                    best = e
                    coarse = L
            coarse *= dec
            # fine: the full grid within dec of the coarse minimum (s zero outside
            # it), the sums of squares summed directly (no cancellation of
            # m.m - 2 m.s + s.s near the minimum)
            f_lo = max(lo, coarse - dec)
            n_f = min(hi, coarse + dec) - f_lo + 1
            if n_f < 1:
                lag = float(coarse)
            else:
                for i in range(n_f):
                    fine[i] = _squares(m, s, f_lo + i, K, J)
                i = 0
                for j in range(1, n_f):
                    if fine[j] < fine[i]:
                        i = j
                frac = 0.0
                if 0 < i < n_f - 1:
                    den = fine[i - 1] - 2.0 * fine[i] + fine[i + 1]
                    if den > 0:
                        frac = min(max(0.5 * (fine[i - 1] - fine[i + 1]) / den, -0.5), 0.5)
                lag = (f_lo + i) + frac
        lags[r] = lag
        acc = 0.0
        for k in range(0, K, step):
            d = (m[k] - _interp(s, k + lag)) / sig[r]
            acc += d * d
        sse[r] = acc
        if aligned.shape[0] > 0:
            for k in range(K):
                aligned[r, k] = _interp(s, k + lag)


class RecordFit:
    """A record's side of the likelihood: the filtered record on the model's grid and
    what the alignment needs of it, computed once.

    Parameters
    ----------
    m : ndarray (K,)
        The filtered record on the model's grid.
    lag0, max_lag : int
        The lags searched, ``lag0 +- max_lag`` (samples of the model's grid).
    dec : int
        Thinning of the coarse search (:func:`~vsi_numba.existing.signal.decimation`).
    step : int
        The likelihood's samples: every ``step``-th of the record.
    lowpass : tuple or None
        ``(sos, zi)`` of the model histories' low-pass (None: unfiltered, the cut-off at
        or above the Nyquist frequency).
    """

    def __init__(self, m, lag0: int, max_lag: int, dec: int, step: int, lowpass):
        self.m = np.ascontiguousarray(m, dtype=np.float64)
        self.lag0, self.max_lag = int(lag0), int(max_lag)
        self.dec, self.step = int(dec), int(step)
        self.lowpass = lowpass
        self._by_length: dict = {}

    def _window(self, J: int):
        """(lo, hi, lo_c, hi_c, nfft, conj(rfft(thinned record))) of histories of J samples."""
        import scipy.fft

        got = self._by_length.get(J)
        if got is None:
            K, dec = self.m.size, self.dec
            lo = max(self.lag0 - self.max_lag, -(K - 1))
            hi = min(self.lag0 + self.max_lag, J - 1)
            md = self.m[::dec]
            Kd, Jd = md.size, -(-J // dec)
            nfft = scipy.fft.next_fast_len(Kd + Jd, real=True)
            lo_c, hi_c = max(-(-lo // dec), -(Kd - 1)), min(hi // dec, Jd - 1)
            if lo_c > hi_c:
                lo_c = hi_c = int(np.clip(round(self.lag0 / dec), -(Kd - 1), Jd - 1))
            got = (lo, hi, lo_c, hi_c, nfft, np.conj(scipy.fft.rfft(md, nfft)))
            self._by_length[J] = got  # the same values whichever thread stores them
        return got

    def fit(self, x, sig, aligned: bool = False):
        """Filter the raw histories ``x`` (n, J), align each with the record and
        return ``(lags (n,) in samples, sum of squared normalised residuals (n,),
        aligned histories (n, K) or None)``; ``sig`` (n,): the residuals' standard
        deviation of each row."""
        import scipy.fft

        x = np.ascontiguousarray(x, dtype=np.float64)
        n, J = x.shape
        if self.lowpass is not None and J > 1:
            sos, zi = self.lowpass
            y = np.empty_like(x)
            filtfilt_rows(x, sos, zi, min(J - 1, 3 * (2 * sos.shape[0] + 1)), y)
        else:
            y = x
        lo, hi, lo_c, hi_c, nfft, mf = self._window(J)
        if lo > hi:  # no lag in the window: the record taken as it is (lag0)
            c = np.zeros((n, 1))
        else:
            c = scipy.fft.irfft(scipy.fft.rfft(y[:, :: self.dec], nfft, axis=1) * mf,
                                nfft, axis=1)
        lags = np.empty(n)
        sse = np.empty(n)
        out = np.empty((n, self.m.size)) if aligned else np.zeros((0, 0))
        align_rows(self.m, y, np.ascontiguousarray(c), self.dec, self.lag0, lo, hi, lo_c, hi_c,
                   self.step, np.ascontiguousarray(sig, dtype=np.float64), lags, sse, out)
        return lags, sse, (out if aligned else None)
