"""Modal bridge models: simply supported span, continuous deck (2-D FE), rigid track.

Mode shapes are mass-normalised (``int m phi_i phi_j dx = delta_ij``), so the modal
equations are ``q'' + 2 zeta w q' + w^2 q = sum_k P_k phi(x_k)``.  Deflections are
positive down.  Mode shapes are carried to the kernels either analytically (sine modes)
or as a table of values and slopes at FE nodes, evaluated inside an element with the
Hermite cubic shape functions of that element (exact for the FE solution).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

RIGID, SINE, HERMITE = 0, 1, 2


@dataclass(frozen=True)
class ModalBridge:
    """A bridge reduced to ``n_modes`` modes along one track line.

    Parameters
    ----------
    kind : int
        ``RIGID`` (no structure), ``SINE`` (simply supported, analytic) or ``HERMITE``
        (mode shapes tabulated at nodes with slopes).
    length : float
        Total length along the track (m); x = 0 at the left end.
    frequencies : ndarray, shape (n_modes,)
        Natural frequencies (Hz), ascending.
    damping : ndarray, shape (n_modes,)
        Modal damping ratios (-).
    nodes, values, slopes : ndarray
        HERMITE tables: node abscissae (n_nodes,), phi and dphi/dx at nodes
        (n_nodes, n_modes).  SINE: ``values[0]`` holds the amplitudes sqrt(2/(m L)).
    supports : ndarray
        Abscissae of the supports (m), for plots and reports.
    description : str
        One line saying where the modes come from.
    effective_mass_fraction : ndarray or None
        Effective (participating) vertical mass of each retained mode as a fraction of
        the structure's vertical mass, shape (n_modes,), when known (modes computed from
        matrices, see :mod:`vsi_numba.model.imported`); None otherwise.
    """

    kind: int
    length: float
    frequencies: np.ndarray
    damping: np.ndarray
    nodes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    slopes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    supports: np.ndarray = field(default_factory=lambda: np.zeros(0))
    description: str = ""
    effective_mass_fraction: np.ndarray | None = None

    @property
    def n_modes(self) -> int:
        return self.frequencies.size

    @property
    def omega(self) -> np.ndarray:
        return 2.0 * np.pi * self.frequencies

    def shapes(self, x, derivative: int = 0) -> np.ndarray:
        """Mode shapes (or derivatives) at ``x``: array of shape (len(x), n_modes).

        Zero outside ``[0, length]``.
        """
        x = np.atleast_1d(np.asarray(x, float))
        out = np.zeros((x.size, self.n_modes))
        if self.kind == RIGID or self.n_modes == 0:
            return out
        inside = (x >= 0.0) & (x <= self.length)
        xi = x[inside]
        if self.kind == SINE:
            k = np.pi * np.arange(1, self.n_modes + 1) / self.length
            amp = self.values[0]
            arg = np.outer(xi, k)
            if derivative == 0:
                out[inside] = amp * np.sin(arg)
            elif derivative == 1:
                out[inside] = amp * k * np.cos(arg)
            else:
                out[inside] = -amp * k**2 * np.sin(arg)
            return out
        e = np.clip(np.searchsorted(self.nodes, xi, side="right") - 1, 0, self.nodes.size - 2)
        h = self.nodes[e + 1] - self.nodes[e]
        s = (xi - self.nodes[e]) / h
        n = _hermite(s, h, derivative)
        out[inside] = (
            n[0][:, None] * self.values[e]
            + n[1][:, None] * self.slopes[e]
            + n[2][:, None] * self.values[e + 1]
            + n[3][:, None] * self.slopes[e + 1]
        )
        return out


def _hermite(s, h, derivative):
    """Hermite cubic shape functions (w1, theta1, w2, theta2) on an element of length h."""
    if derivative == 0:
        return (1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3,
                h * (-(s**2) + s**3))
    if derivative == 1:
        return ((-6 * s + 6 * s**2) / h, 1 - 4 * s + 3 * s**2, (6 * s - 6 * s**2) / h,
                -2 * s + 3 * s**2)
    return ((-6 + 12 * s) / h**2, (-4 + 6 * s) / h, (6 - 12 * s) / h**2, (-2 + 6 * s) / h)


def _per_mode(value, n, name):
    v = np.asarray(value, float)
    if v.ndim == 0:
        return np.full(n, float(v))
    if v.size < n:
        raise ValueError(f"{name}: {v.size} values given, {n} modes retained")
    return v[:n].copy()


def _n_keep(freqs, n_modes, max_frequency):
    if n_modes is None and max_frequency is None:
        raise ValueError("give n_modes or max_frequency")
    n = freqs.size if n_modes is None else min(int(n_modes), freqs.size)
    if max_frequency is not None:
        n = min(n, int(np.count_nonzero(freqs <= max_frequency)))
    if n < 1:
        raise ValueError("no mode retained (n_modes < 1 or max_frequency below the first mode)")
    return n


def simply_supported(
    length: float,
    EI: float,
    mass_per_length: float,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
) -> ModalBridge:
    """Simply supported Euler-Bernoulli span with analytic sine modes.

    ``phi_j = sqrt(2 / (m L)) sin(j pi x / L)``, ``w_j = (j pi / L)^2 sqrt(EI / m)``.
    """
    nmax = int(n_modes) if n_modes is not None else 400
    j = np.arange(1, nmax + 1)
    freqs = (j * np.pi / length) ** 2 * np.sqrt(EI / mass_per_length) / (2 * np.pi)
    n = _n_keep(freqs, n_modes, max_frequency)
    amp = np.full(n, np.sqrt(2.0 / (mass_per_length * length)))
    return ModalBridge(
        kind=SINE,
        length=float(length),
        frequencies=freqs[:n],
        damping=_per_mode(damping_ratio, n, "damping_ratio"),
        values=amp[None, :],
        supports=np.array([0.0, length]),
        description=f"simply supported, L={length} m, EI={EI} N m2, m={mass_per_length} kg/m",
    )


def beam_matrices(spans, EI, mass_per_length, elements_per_span):
    """Assemble the 2-D Euler-Bernoulli beam (Hermite cubic elements, consistent mass).

    Returns ``nodes, K, M, fixed`` with DOFs (w_i, theta_i) per node, ``theta = dw/dx``,
    and the DOFs fixed by the vertical supports at the span ends.
    """
    spans = np.atleast_1d(np.asarray(spans, float))
    ns = spans.size
    EI = np.broadcast_to(np.asarray(EI, float), (ns,))
    mass = np.broadcast_to(np.asarray(mass_per_length, float), (ns,))
    ne = int(elements_per_span)
    supports = np.concatenate([[0.0], np.cumsum(spans)])
    nodes = [0.0]
    props = []
    for s in range(ns):
        h = spans[s] / ne
        for e in range(ne):
            nodes.append(supports[s] + (e + 1) * h)
            props.append((h, EI[s], mass[s]))
    nodes = np.array(nodes)
    nodes[[ne * (s + 1) for s in range(ns)]] = supports[1:]  # exact support coordinates
    ndof = 2 * nodes.size
    K = np.zeros((ndof, ndof))
    M = np.zeros((ndof, ndof))
    for e, (h, ei, m) in enumerate(props):
        ke = ei / h**3 * np.array(
            [[12, 6 * h, -12, 6 * h],
             [6 * h, 4 * h * h, -6 * h, 2 * h * h],
             [-12, -6 * h, 12, -6 * h],
             [6 * h, 2 * h * h, -6 * h, 4 * h * h]]
        )
        me = m * h / 420.0 * np.array(
            [[156, 22 * h, 54, -13 * h],
             [22 * h, 4 * h * h, 13 * h, -3 * h * h],
             [54, 13 * h, 156, -22 * h],
             [-13 * h, -3 * h * h, -22 * h, 4 * h * h]]
        )
        idx = np.arange(2 * e, 2 * e + 4)
        K[np.ix_(idx, idx)] += ke
        M[np.ix_(idx, idx)] += me
    fixed = np.array([2 * ne * s for s in range(ns + 1)])
    return nodes, K, M, fixed, supports


def continuous(
    spans,
    EI,
    mass_per_length,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    elements_per_span: int = 40,
) -> ModalBridge:
    """Continuous multi-span deck on vertical point supports (2-D FE, Hermite cubics).

    Modes come from the generalised eigenproblem ``K phi = w^2 M phi``
    (``scipy.linalg.eigh``), mass-normalised by construction.
    """
    nodes, K, M, fixed, supports = beam_matrices(spans, EI, mass_per_length, elements_per_span)
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    n = _n_keep(freqs, n_modes, max_frequency)
    full = np.zeros((K.shape[0], n))
    full[free] = vec[:, :n]
    # sign: make the largest displacement of each mode positive (down)
    w = full[0::2]
    sign = np.sign(w[np.argmax(np.abs(w), axis=0), np.arange(n)])
    full *= sign
    return ModalBridge(
        kind=HERMITE,
        length=float(supports[-1]),
        frequencies=freqs[:n],
        damping=_per_mode(damping_ratio, n, "damping_ratio"),
        nodes=nodes,
        values=np.ascontiguousarray(full[0::2]),
        slopes=np.ascontiguousarray(full[1::2]),
        supports=supports,
        description=f"continuous deck, spans={list(np.atleast_1d(spans))} m",
    )


def rigid(length: float) -> ModalBridge:
    """No structure: the track lies on rigid ground over ``length`` metres."""
    return ModalBridge(
        kind=RIGID,
        length=float(length),
        frequencies=np.zeros(0),
        damping=np.zeros(0),
        supports=np.array([0.0, length]),
        description=f"rigid track, {length} m",
    )


def from_table(
    x, shapes, frequencies, damping_ratio=0.0, slopes=None, supports=None, description=""
) -> ModalBridge:
    """Modes given as a table ``shapes[k, j] = phi_j(x_k)`` (mass-normalised).

    Slopes, when not given, come from a C2 cubic spline through each mode, so that the
    Hermite evaluation in the kernels is that spline.
    """
    import scipy.interpolate

    x = np.asarray(x, float)
    shapes = np.asarray(shapes, float)
    if slopes is None:
        slopes = scipy.interpolate.CubicSpline(x, shapes, axis=0, bc_type="not-a-knot")(x, 1)
    freqs = np.asarray(frequencies, float)
    return ModalBridge(
        kind=HERMITE,
        length=float(x[-1] - x[0]) if x[0] == 0 else float(x[-1]),
        frequencies=freqs,
        damping=_per_mode(damping_ratio, freqs.size, "damping_ratio"),
        nodes=x,
        values=np.ascontiguousarray(shapes),
        slopes=np.ascontiguousarray(slopes),
        supports=np.asarray(supports if supports is not None else [x[0], x[-1]], float),
        description=description,
    )
