"""Entry points from Python to kernels that only other kernels call.

Those kernels are compiled without numba's CPython wrapper (``njit(kernel_only=True)``,
:mod:`vsi_numba._jit`), so Python cannot call them; the tests and benchmarks that check
one on its own call its shim here instead, a jitted function of the same name and
arguments that calls it.  A shim is compiled (and cached) the first time it is called;
a study never compiles one.
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit
from vsi_numba.kernels import linalg, schur, shapes, step


@njit
def eval_modes(br, x, out, dout, d2out):
    """:func:`~vsi_numba.kernels.shapes.eval_modes`."""
    return shapes.eval_modes(br, x, out, dout, d2out, np.int64(0))


@njit
def eval_profile(pr, x, out):
    """:func:`~vsi_numba.kernels.shapes.eval_profile`."""
    shapes.eval_profile(pr, x, out, np.int64(0))


@njit
def skyline_cholesky_solve(A, idx, m, first, Lw, b, x):
    """:func:`~vsi_numba.kernels.linalg.skyline_cholesky_solve`."""
    return linalg.skyline_cholesky_solve(A, idx, m, first, Lw, b, x)


@njit
def solve_active_set(cw, scale, max_iter, tol_gap, tol_force):
    """:func:`~vsi_numba.kernels.schur.solve_active_set`."""
    return schur.solve_active_set(cw, scale, max_iter, tol_gap, tol_force)


@njit
def hht_step(br, veh, pr, prm, st, wk, t1, dt, level):
    """:func:`~vsi_numba.kernels.step.hht_step`."""
    return step.hht_step(br, veh, pr, prm, st, wk, t1, dt, level)
