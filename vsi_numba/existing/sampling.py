"""The sampler's moves and the start of its walkers (:mod:`vsi_numba.existing.calibrate`):
emcee's differential-evolution move, and the Laplace approximation at the maximum a
posteriori point from which the walkers are drawn."""

from __future__ import annotations

import numpy as np

#: First step (prior standard deviations) of the finite differences of the Laplace
#: approximation at the maximum a posteriori point, from which the walkers are drawn.
LAPLACE_PROBE = 1e-3


def moves():
    """The sampler's moves: emcee's differential evolution alone (ter Braak 2006).
    Without its snooker variant: emcee's (3.1) steps along the line through the walker
    and a third one by the distance to it, for which its acceptance factor does not
    correct (20 % of snooker moves gave a standard normal target standard deviations
    0.978, 60 chains of 16 walkers x 1000 steps, against 1.001 for differential
    evolution alone)."""
    import emcee

    return [(emcee.moves.DEMove(), 1.0)]


def laplace_evaluations(n_dim: int) -> int:
    """Evaluations of the Laplace approximation of :func:`laplace_covariance` (n_dim parameters)."""
    return 1 + 2 * n_dim * (n_dim + 1)


def laplace_covariance(f, u: np.ndarray) -> np.ndarray | None:
    """The covariance ``(-H)^-1`` of the Laplace approximation at the maximum ``u`` of
    the log posterior ``f`` (rows (n, n_dim) -> (n,)), ``H`` by central differences of
    one standard deviation (from a first pass of steps ``LAPLACE_PROBE``), in three
    batches of 1, ``2 n_dim`` and ``2 n_dim^2`` evaluations; None when ``H`` is not
    negative definite."""
    n = u.size
    eye = np.eye(n)
    f0 = float(f(u[None])[0])
    h = np.full(n, LAPLACE_PROBE)
    v = f(np.concatenate([u + h[:, None] * eye, u - h[:, None] * eye]))
    curv = (v[:n] + v[n:] - 2.0 * f0) / h ** 2
    if not np.all(np.isfinite(curv)) or np.any(curv >= 0.0):
        return None
    h = 1.0 / np.sqrt(-curv)
    pts, idx = [], []
    for i in range(n):
        pts += [u + h[i] * eye[i], u - h[i] * eye[i]]
        idx.append((i, i))
        for j in range(i + 1, n):
            a, b = h[i] * eye[i], h[j] * eye[j]
            pts += [u + a + b, u + a - b, u - a + b, u - a - b]
            idx.append((i, j))
    v = f(np.array(pts))
    H = np.zeros((n, n))
    k = 0
    for i, j in idx:
        if i == j:
            H[i, i] = (v[k] + v[k + 1] - 2.0 * f0) / h[i] ** 2
            k += 2
        else:
            H[i, j] = H[j, i] = (v[k] - v[k + 1] - v[k + 2] + v[k + 3]) / (4 * h[i] * h[j])
            k += 4
    if not np.all(np.isfinite(H)):
        return None
    w, q = np.linalg.eigh(-H)
    if np.any(w <= 0.0):
        return None
    return (q / w) @ q.T
