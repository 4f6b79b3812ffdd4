"""Cubic Hermite beam elements (Euler-Bernoulli, DOFs w and dw/dx at each node): shape
functions, element matrices, and tables of nodal values and slopes evaluated between the
nodes (how FE mode shapes reach the kernels)."""

from __future__ import annotations

import numpy as np


def shape_functions(s, h, derivative: int = 0):
    """Hermite cubic shape functions (w1, theta1, w2, theta2), or their x-derivatives, at
    the local coordinate ``s`` in [0, 1] of an element of length ``h``."""
    if derivative == 0:
        return (1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3,
                h * (-(s**2) + s**3))
    if derivative == 1:
        return ((-6 * s + 6 * s**2) / h, 1 - 4 * s + 3 * s**2, (6 * s - 6 * s**2) / h,
                -2 * s + 3 * s**2)
    return ((-6 + 12 * s) / h**2, (-4 + 6 * s) / h, (6 - 12 * s) / h**2, (-2 + 6 * s) / h)


def beam_element(h, ei, m):
    """Stiffness and consistent mass matrices (4 x 4) of an element of length ``h``,
    bending stiffness ``ei`` and mass per length ``m`` (with ``m`` a Winkler modulus, the
    second matrix is the element's consistent foundation stiffness)."""
    ke = ei / h**3 * np.array(
        [[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
         [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    me = m * h / 420.0 * np.array(
        [[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
         [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    return ke, me


def evaluate(nodes, values, slopes, x, derivative: int = 0) -> np.ndarray:
    """A table of ``values`` and ``slopes`` (n_nodes, n_cols) at ``x``: shape
    (len(x), n_cols), with the shape functions of the element holding each x (the first
    or last element beyond the ends)."""
    x = np.atleast_1d(np.asarray(x, float))
    e = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    h = nodes[e + 1] - nodes[e]
    n = shape_functions((x - nodes[e]) / h, h, derivative)
    return (n[0][:, None] * values[e] + n[1][:, None] * slopes[e]
            + n[2][:, None] * values[e + 1] + n[3][:, None] * slopes[e + 1])


def table(nodes, values, slopes, x) -> np.ndarray:
    """:func:`evaluate` at ``x``, zero outside ``[nodes[0], nodes[-1]]``."""
    x = np.atleast_1d(np.asarray(x, float))
    out = np.zeros((x.size, values.shape[1]))
    inside = (x >= nodes[0]) & (x <= nodes[-1])
    out[inside] = evaluate(nodes, values, slopes, x[inside])
    return out
