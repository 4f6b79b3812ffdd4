"""The compiled time-axis envelopes give numpy's values and indices exactly."""

from __future__ import annotations

import numpy as np

from vsi_numba.solver.reductions import first_absmax, first_max_min


def _arrays():
    rng = np.random.default_rng(7)
    for trial in range(200):
        n, k = int(rng.integers(1, 40)), int(rng.integers(0, 6))
        # few distinct values: ties everywhere (the first step must win)
        a = rng.integers(-3, 4, (n, k)).astype(float) * 0.5
        if trial % 3 == 0 and k:
            a[rng.integers(0, n, 2), rng.integers(0, k, 2)] = np.nan
        if trial % 4 == 0 and k:
            a[rng.integers(0, n), rng.integers(0, k)] = -0.0
        yield a


def test_reductions__equal_numpy_along_time():
    for a in _arrays():
        _check(a)


def _check(a):
    value, index = first_absmax(a)
    b = np.abs(a)
    expected = np.argmax(b, axis=0) if a.shape[1] else np.zeros(0, np.int64)
    np.testing.assert_array_equal(index, expected)
    np.testing.assert_array_equal(value, np.take_along_axis(b, expected[None], 0)[0])
    hi, hi_i, lo, lo_i = first_max_min(a)
    if a.shape[1]:
        np.testing.assert_array_equal(hi, a.max(axis=0))
        np.testing.assert_array_equal(lo, a.min(axis=0))
        np.testing.assert_array_equal(hi_i, np.argmax(a, axis=0))
        np.testing.assert_array_equal(lo_i, np.argmin(a, axis=0))
