"""EN 1991-2 6.4.6 design checks of load effects: static crawl envelopes of the real
trains, the LM71 x alpha x Phi envelope, phi'_dyn per effect, the 6.4.6.5(3) verdict and
the deck-end rotation check.

Static envelopes work on an influence line given as a callable ``line(x) -> (n_at, n_x)``
(the static effect at ``n_at`` sections or supports of a unit downward force at each
``x``, e.g. :func:`vsi_numba.model.influence.influence` with its ``static`` and ``at``
bound), so they are independent of how the line was obtained.

Placements searched (every placement that matters)
---------------------------------------------------
An effect of a set of point loads at a common position ``s`` is
``E(s) = sum_k P_k I(s - p_k)``.  Between two positions at which some load crosses a
breakpoint of the influence line (a support, the section itself, a deck end) ``E`` is a
smooth function (a cubic polynomial for a beam deck), and for a piecewise-linear line
(a statically determinate deck) a linear one, whose extremes lie at those crossings.  The
search therefore evaluates ``E`` at every crossing (both sides of it, 1e-9 m apart, so the
jump of a shear line is seen) and on a uniform grid of step ``h``: exact for
piecewise-linear lines, and otherwise within ``h^2 / 8 max|E''|`` of the true extreme
(relative error of order ``(h / L)^2``, about 4e-6 for h = 0.05 m on a 25 m span).

Signs follow :mod:`vsi_numba.model.influence`.  Design quantities compare magnitudes:
for every location the extreme of ``|E|`` over both signs (EN 1991-2 6.4.6.5 [R] defines
``phi'_dyn = max|y_dyn| / max|y_stat| - 1``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from vsi_numba.en1991 import (
    LM71_AXLE_LOAD,
    LM71_AXLE_OFFSETS,
    LM71_AXLE_ZONE,
    LM71_UDL,
)

#: Half-gap (m) of the two evaluations either side of a breakpoint crossing.
_EPS = 1e-9
#: Largest number of (section, position, load) products evaluated at once.
_CHUNK = 4_000_000

Line = Callable[[np.ndarray], np.ndarray]


class Envelope(NamedTuple):
    """Maximum and minimum of a static effect over every placement of the loads.

    ``max``, ``min`` : ndarray, shape (n_at,), in the units of the line times N;
    ``at_max``, ``at_min`` : ndarray, shape (n_at,), the governing position (m) of the
    reference load (the train's first axle; the centre of the LM71 axle group).
    """

    max: np.ndarray
    min: np.ndarray
    at_max: np.ndarray
    at_min: np.ndarray

    @property
    def abs(self) -> np.ndarray:
        """max(|max|, |min|) per location."""
        return np.maximum(np.abs(self.max), np.abs(self.min))


def _candidates(lo: float, hi: float, crossings, step: float) -> np.ndarray:
    """Uniform grid of ``step`` on [lo, hi] plus both sides of every crossing in it."""
    n = max(int(np.ceil((hi - lo) / step)), 1)
    grid = np.linspace(lo, hi, n + 1)
    c = np.asarray(crossings, float).ravel()
    c = np.concatenate([c - _EPS, c + _EPS])
    c = c[(c >= lo) & (c <= hi)]
    return np.unique(np.concatenate([grid, c]))


def _reduce(values_of, s: np.ndarray, n_at: int, per_s: int) -> Envelope:
    """Max/min over ``s`` of ``values_of(s_chunk) -> (n_at, n_chunk)``, in chunks."""
    vmax = np.full(n_at, -np.inf)
    vmin = np.full(n_at, np.inf)
    smax = np.zeros(n_at)
    smin = np.zeros(n_at)
    block = max(1, _CHUNK // max(1, n_at * per_s))
    for i in range(0, s.size, block):
        sc = s[i:i + block]
        v = values_of(sc)
        j = np.argmax(v, axis=1)
        k = np.argmin(v, axis=1)
        rows = np.arange(n_at)
        better = v[rows, j] > vmax
        vmax = np.where(better, v[rows, j], vmax)
        smax = np.where(better, sc[j], smax)
        better = v[rows, k] < vmin
        vmin = np.where(better, v[rows, k], vmin)
        smin = np.where(better, sc[k], smin)
    return Envelope(vmax, vmin, smax, smin)


def _loads_effect(line: Line, s: np.ndarray, positions: np.ndarray, loads: np.ndarray,
                  n_at: int) -> np.ndarray:
    """sum_k P_k I(s - p_k) for every s: shape (n_at, n_s)."""
    x = (s[:, None] - positions[None, :]).ravel()
    inf = np.asarray(line(x), float).reshape(n_at, s.size, positions.size)
    return inf @ loads


def crawl_envelope(line: Line, positions, loads, breakpoints, extent, step: float = 0.05,
                   n_at: int | None = None) -> Envelope:
    """Static envelope of a train crawling over the deck (its axle loads, no dynamics).

    Parameters
    ----------
    line : callable
        ``line(x)`` with ``x`` of shape (n,) (m): the effect of a unit downward force
        (1 N) at each ``x``, shape (n_at, n); zero off the deck.
    positions : array_like, shape (n_axle,)
        Axle positions behind the first axle (m, >= 0).
    loads : array_like, shape (n_axle,)
        Axle loads (N, positive down).
    breakpoints : array_like
        Abscissae (m) where the line or one of its derivatives jumps (deck ends,
        supports, the sections themselves).
    extent : (float, float)
        The deck (m): the line is zero outside it.
    step : float
        Grid step h (m) of the first-axle position between crossings (see the module
        notes for the error bound).
    n_at : int, optional
        Number of locations of ``line`` (default: from one evaluation).

    Returns
    -------
    Envelope
        Extremes per location (N times the line's units) and the first-axle position
        (m) that gives them.
    """
    p = np.asarray(positions, float).ravel()
    P = np.asarray(loads, float).ravel()
    if p.size != P.size or p.size == 0:
        raise ValueError(f"positions ({p.size}) and loads ({P.size}): expected the same "
                         "number (> 0) of axles")
    if not step > 0:
        raise ValueError(f"step = {step!r}: expected > 0 m")
    lo, hi = float(extent[0]), float(extent[1]) + float(p.max())
    bp = np.asarray(breakpoints, float).ravel()
    s = _candidates(lo, hi, (bp[:, None] + p[None, :]).ravel(), step)
    if n_at is None:
        n_at = int(np.asarray(line(np.array([0.5 * (extent[0] + extent[1])]))).shape[0])
    return _reduce(lambda sc: _loads_effect(line, sc, p, P, n_at), s, n_at, p.size)


def lm71_envelope(line: Line, breakpoints, extent, step: float = 0.05,
                  n_at: int | None = None, grid_step: float | None = None) -> Envelope:
    """Static envelope of EN 1991-2 LM71 (alpha = 1, no dynamic factor).

    Four point forces of 250 kN at 1.6 m, in a 6.4 m zone centred on them, and 80 kN/m
    on both sides of the zone, unlimited in length and applied only where it is
    unfavourable (EN 1991-2 6.3.2, Fig. 6.1 [R]): for the maximum, wherever the line is
    positive outside the zone; for the minimum, wherever it is negative.  The axle group
    stays together and is placed most unfavourably (its centre anywhere from 3.2 m before
    the deck to 3.2 m beyond it, partly off the deck included).

    The distributed part is the integral of the positive (negative) part of the line
    outside the zone: trapezoidal rule on a grid of ``grid_step`` (default
    min(step, extent / 2000)) that holds every breakpoint (both sides), interpolated
    linearly for the zone ends (error O(grid_step^2)).

    Parameters
    ----------
    line, breakpoints, extent, step, n_at
        As :func:`crawl_envelope`; ``step`` is the grid of the group's centre.
    grid_step : float, optional
        Integration step (m) of the distributed load.

    Returns
    -------
    Envelope
        Extremes per location and the position (m) of the centre of the axle group.
    """
    x0, x1 = float(extent[0]), float(extent[1])
    if not step > 0:
        raise ValueError(f"step = {step!r}: expected > 0 m")
    bp = np.asarray(breakpoints, float).ravel()
    h = grid_step or min(step, (x1 - x0) / 2000.0)
    xs = _candidates(x0, x1, bp, h)
    xs = xs[(xs >= x0) & (xs <= x1)]
    inf = np.asarray(line(xs), float)
    if n_at is None:
        n_at = inf.shape[0]
    cum = []
    for part in (np.maximum(inf, 0.0), np.minimum(inf, 0.0)):
        c = np.zeros_like(part)
        c[:, 1:] = np.cumsum(0.5 * (part[:, 1:] + part[:, :-1]) * np.diff(xs), axis=1)
        cum.append(c)
    half = 0.5 * LM71_AXLE_ZONE
    offs = np.asarray(LM71_AXLE_OFFSETS, float)
    Q = np.full(offs.size, LM71_AXLE_LOAD)

    def udl(c, sc):
        a = np.clip(sc - half, x0, x1)
        b = np.clip(sc + half, x0, x1)
        rows = []
        for r in range(n_at):
            total = c[r, -1]
            rows.append(total - (np.interp(b, xs, c[r]) - np.interp(a, xs, c[r])))
        return LM71_UDL * np.asarray(rows)

    crossings = np.concatenate([(bp[:, None] - offs[None, :]).ravel(), bp - half, bp + half])
    s = _candidates(x0 - half, x1 + half, crossings, step)

    def total(sc, c):
        return _loads_effect(line, sc, -offs, Q, n_at) + udl(c, sc)  # axle k at sc + o_k

    hi = _reduce(lambda sc: total(sc, cum[0]), s, n_at, offs.size)
    lo = _reduce(lambda sc: total(sc, cum[1]), s, n_at, offs.size)
    return Envelope(hi.max, lo.min, hi.at_max, lo.at_min)


# --------------------------------------------------------------------- design values


def phi_dyn(dynamic_abs, static_abs):
    """Dynamic increment ``phi'_dyn = max|y_dyn| / max|y_stat| - 1`` (EN 1991-2
    6.4.6.5 [R]); NaN where the static value is 0 or not finite.

    Parameters
    ----------
    dynamic_abs, static_abs : array_like
        max|y_dyn| and max|y_stat| (same units), broadcastable.
    """
    d = np.asarray(dynamic_abs, float)
    s = np.asarray(static_abs, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isfinite(s) & (s > 0), d / np.where(s > 0, s, 1.0) - 1.0, np.nan)


class Verdict(NamedTuple):
    """EN 1991-2 6.4.6.5(3) [R] comparison of one effect at one location.

    ``real`` = (1 + phi'_dyn + phi''/2) x static effect of the real train / HSLM;
    ``lm71`` = Phi x alpha x LM71; ``ratio = real / lm71``; ``governs`` is
    ``"HSLM / real trains"`` when ratio > 1, else ``"LM71 x Phi x alpha"``.
    """

    real: float
    lm71: float
    ratio: float
    governs: str


REAL_GOVERNS = "HSLM / real trains"
LM71_GOVERNS = "LM71 × Φ × α"


def verdict(phi_dyn_value: float, phi2: float, static_real: float, lm71_static: float,
            phi: float, alpha: float) -> Verdict:
    """EN 1991-2 6.4.6.5(3) [R]: the more unfavourable of
    ``(1 + phi'_dyn + phi''/2) x real`` and ``Phi x alpha x LM71`` (magnitudes).

    Parameters
    ----------
    phi_dyn_value : float
        phi'_dyn of the effect (-).
    phi2 : float
        phi'' of EN 1991-2 Annex C [R] (-); 0 when the dynamic analysis already includes
        the track irregularities.
    static_real : float
        max|static effect| of the real train or HSLM (crawl).
    lm71_static : float
        max|static effect| of LM71 (alpha = 1, no dynamic factor).
    phi, alpha : float
        Dynamic factor Phi_2 or Phi_3 and classification factor.
    """
    real = (1.0 + phi_dyn_value + 0.5 * phi2) * abs(static_real)
    lm = phi * alpha * abs(lm71_static)
    ratio = real / lm if lm > 0 else np.nan
    return Verdict(float(real), float(lm), float(ratio),
                   REAL_GOVERNS if ratio > 1 else LM71_GOVERNS)
