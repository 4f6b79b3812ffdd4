"""Small dense linear algebra on the vehicle blocks and the contact matrices: block
matrix-vector products, the skyline Cholesky solve of the active Schur block, the
Gauss-Jordan inverse of a vehicle block, plain-loop copies (the kernels allocate nothing).
"""

from __future__ import annotations

import numpy as np

from vsi_numba._jit import njit


@njit(inline="always")
def copy_into(src, dst):
    """``dst[:] = src`` for two distinct 1-D arrays of one length, as a plain loop (a slice
    assignment may allocate a temporary, and the kernels run without NRT)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(inline="always")
def block_matvec(veh, A, x, y, accumulate, scale):
    """y (+)= scale * blockdiag(A) x over the vehicle DOFs."""
    n_veh = veh.start.shape[0] - 1
    for b in range(n_veh):
        s = veh.start[b]
        n = veh.start[b + 1] - s
        # four rows at a time: four independent sums (each in the order of one row's),
        # so the adds overlap instead of waiting for each other (same bits as row by row)
        r = 0
        while r + 4 <= n:
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            a3 = 0.0
            for c in range(n):
                xc = x[s + c]
                a0 += A[b, r, c] * xc
                a1 += A[b, r + 1, c] * xc
                a2 += A[b, r + 2, c] * xc
                a3 += A[b, r + 3, c] * xc
            if accumulate:
                y[s + r] += scale * a0
                y[s + r + 1] += scale * a1
                y[s + r + 2] += scale * a2
                y[s + r + 3] += scale * a3
            else:
                y[s + r] = scale * a0
                y[s + r + 1] = scale * a1
                y[s + r + 2] = scale * a2
                y[s + r + 3] = scale * a3
            r += 4
        while r < n:
            acc = 0.0
            for c in range(n):
                acc += A[b, r, c] * x[s + c]
            if accumulate:
                y[s + r] += scale * acc
            else:
                y[s + r] = scale * acc
            r += 1


@njit(inline="always")
def block_matvec_nz(veh, A, m, x, y, scale):
    """y += scale * blockdiag(A) x over the columns of pattern ``m`` (``veh.blk_*``): the
    nonzeros of A = M, C or K (``m`` = 0, 1, 2; x finite), or the wheel DOFs (3; x = B^T X,
    zero elsewhere, A finite).  The sums of :func:`block_matvec` bit for bit: the skipped
    terms are zeros."""
    n_veh = veh.start.shape[0] - 1
    for b in range(n_veh):
        s = veh.start[b]
        n = veh.start[b + 1] - s
        for r in range(n):
            acc = 0.0
            for p in range(veh.blk_ptr[m, b, r], veh.blk_ptr[m, b, r + 1]):
                c = veh.blk_col[m, b, p]
                acc += A[b, r, c] * x[s + c]
            y[s + r] += scale * acc


@njit(kernel_only=True)
def skyline_cholesky_solve(A, idx, m, first, Lw, b, x):
    """Solve A[idx, idx] x = b for the ``m`` indices in ``idx`` by Cholesky, within the
    envelope ``first`` (see contact_profile; ``first = 0`` is the dense factorisation).

    Cholesky keeps the envelope of a symmetric matrix, so entries left of ``first`` are
    zero in the factor too and are never touched.  ``b`` and ``x`` are indexed 0..m-1.
    Returns 0, or 1 if the block is not positive definite.
    """
    for i in range(m):
        ii = idx[i]
        fi = first[i]
        for j in range(fi, i + 1):
            jj = idx[j]
            s = A[ii, jj]
            k0 = fi if fi > first[j] else first[j]
            for k in range(k0, j):
                s -= Lw[i, k] * Lw[j, k]
            if i == j:
                if s <= 0.0:
                    return 1
                Lw[i, i] = np.sqrt(s)
            else:
                Lw[i, j] = s / Lw[j, j]
    for i in range(m):
        s = b[i]
        for k in range(first[i], i):
            s -= Lw[i, k] * x[k]
        x[i] = s / Lw[i, i]
    for i in range(m - 1, -1, -1):
        x[i] = x[i] / Lw[i, i]
        xi = x[i]
        for k in range(first[i], i):
            x[k] -= Lw[i, k] * xi
    return 0


@njit(kernel_only=True)
def invert_small(A, n, out):
    """Inverse of ``A[:n, :n]`` into ``out[:n, :n]`` by Gauss-Jordan elimination with
    partial pivoting (``A`` is destroyed).  Returns 0, or 1 if ``A`` is singular."""
    for i in range(n):
        for j in range(n):
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        p = c
        big = abs(A[c, c])
        for r in range(c + 1, n):
            if abs(A[r, c]) > big:
                big = abs(A[r, c])
                p = r
        if not big > 0.0 or not np.isfinite(big):
            return 1
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
                out[c, j], out[p, j] = out[p, j], out[c, j]
        piv = A[c, c]
        for j in range(n):
            A[c, j] /= piv
            out[c, j] /= piv
        for r in range(n):
            if r != c:
                f = A[r, c]
                if f != 0.0:
                    for j in range(n):
                        A[r, j] -= f * A[c, j]
                        out[r, j] -= f * out[c, j]
    return 0
