"""Envelopes of time histories (time first) in one pass, compiled: what numpy's
``abs``/``max``/``argmax`` along the time axis give, without the temporaries of the
absolute values and of the transposed copies numpy makes to reduce along axis 0.

The values and indices are those of numpy exactly (comparisons only, no arithmetic):
the first step that reaches the extreme, and a NaN, when there is one, is the extreme at
its first step (as ``np.argmax``/``np.max``).  Used by the superposition of trains on
other tracks (:mod:`vsi_numba.solver.superpose`), where the summed histories of every
run are reduced after the kernels.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit


@njit
def _first_absmax(a, value, index, done):
    n, k = a.shape
    for c in range(k):
        value[c] = -1.0
        index[c] = 0
        done[c] = False
    for i in range(n):
        for c in range(k):
            if done[c]:
                continue
            x = abs(a[i, c])
            if x != x:  # NaN: numpy's maximum from here on
                value[c] = x
                index[c] = i
                done[c] = True
            elif x > value[c]:
                value[c] = x
                index[c] = i


@njit
def _first_max_min(a, hi, hi_i, lo, lo_i, done_hi, done_lo):
    n, k = a.shape
    for c in range(k):
        done_hi[c] = False
        done_lo[c] = False
        hi[c] = a[0, c]
        lo[c] = a[0, c]
        hi_i[c] = 0
        lo_i[c] = 0
        if a[0, c] != a[0, c]:
            done_hi[c] = True
            done_lo[c] = True
    for i in range(1, n):
        for c in range(k):
            x = a[i, c]
            if x != x:
                if not done_hi[c]:
                    hi[c] = x
                    hi_i[c] = i
                    done_hi[c] = True
                if not done_lo[c]:
                    lo[c] = x
                    lo_i[c] = i
                    done_lo[c] = True
                continue
            if not done_hi[c] and x > hi[c]:
                hi[c] = x
                hi_i[c] = i
            if not done_lo[c] and x < lo[c]:
                lo[c] = x
                lo_i[c] = i


def first_absmax(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(|a|.max(axis=0), |a|.argmax(axis=0))`` of ``a`` (n, k), n >= 1."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    value = np.empty(a.shape[1])
    index = np.empty(a.shape[1], np.int64)
    _first_absmax(a, value, index, np.zeros(a.shape[1], np.bool_))
    return value, index


def first_max_min(a: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(a.max(axis=0), a.argmax(axis=0), a.min(axis=0), a.argmin(axis=0))`` of ``a``
    (n, k), n >= 1."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    k = a.shape[1]
    hi, lo = np.empty(k), np.empty(k)
    hi_i, lo_i = np.empty(k, np.int64), np.empty(k, np.int64)
    _first_max_min(a, hi, hi_i, lo, lo_i, np.zeros(k, np.bool_), np.zeros(k, np.bool_))
    return hi, hi_i, lo, lo_i


@njit
def _first_max_min_sum(a, b, cols, hi, hi_i, lo, lo_i, done_hi, done_lo):
    """:func:`_first_max_min` of ``a[:, cols] + b[:, cols]`` (``b`` may have no rows:
    ``a`` alone), without the sum's array."""
    n = a.shape[0]
    k = cols.shape[0]
    with_b = b.shape[0] > 0
    for i in range(n):
        for m in range(k):
            c = cols[m]
            x = a[i, c] + b[i, c] if with_b else a[i, c]
            if i == 0:
                done_hi[m] = False
                done_lo[m] = False
                hi[m] = x
                lo[m] = x
                hi_i[m] = 0
                lo_i[m] = 0
                if x != x:
                    done_hi[m] = True
                    done_lo[m] = True
                continue
            if x != x:
                if not done_hi[m]:
                    hi[m] = x
                    hi_i[m] = i
                    done_hi[m] = True
                if not done_lo[m]:
                    lo[m] = x
                    lo_i[m] = i
                    done_lo[m] = True
                continue
            if not done_hi[m] and x > hi[m]:
                hi[m] = x
                hi_i[m] = i
            if not done_lo[m] and x < lo[m]:
                lo[m] = x
                lo_i[m] = i


def first_max_min_of_sum(a: np.ndarray, b: np.ndarray | None = None,
                         cols: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """:func:`first_max_min` of ``(a + b)[:, cols]`` (``b`` None: of ``a[:, cols]``;
    ``cols`` None: every column), the sum taken value by value as numpy's ``a + b``."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = (np.zeros((0, a.shape[1])) if b is None
         else np.ascontiguousarray(b, dtype=np.float64))
    cols = (np.arange(a.shape[1]) if cols is None
            else np.ascontiguousarray(cols, dtype=np.int64))
    k = cols.size
    hi, lo = np.empty(k), np.empty(k)
    hi_i, lo_i = np.empty(k, np.int64), np.empty(k, np.int64)
    _first_max_min_sum(a, b, cols, hi, hi_i, lo, lo_i, np.zeros(k, np.bool_),
                       np.zeros(k, np.bool_))
    return hi, hi_i, lo, lo_i


@njit
def _first_absargmax(a):
    best = -1.0
    k = 0
    n, m = a.shape
    for i in range(n):
        for j in range(m):
            x = abs(a[i, j])
            if x != x:
                return i * m + j
            if x > best:
                best = x
                k = i * m + j
    return k


def first_absargmax(a: np.ndarray) -> tuple[float, int]:
    """``(|a|.max(), |a|.argmax())`` of ``a`` (n, m) flattened in C order, without the
    absolute values' array (a NaN, when there is one, is the maximum at its first
    position, as numpy's)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    k = int(_first_absargmax(a))
    return float(abs(a.flat[k])), k
