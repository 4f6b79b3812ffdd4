"""Decks in space: tracks at a transverse eccentricity, torsion of the deck, rail lines
and the deck twist -- vertical only.

The deck keeps its vertical (modal) model, but a point of it is (x, y): x along the deck
from its left end, y transverse from the deck's reference axis (the shear centre of a
beam model), **positive to the left looking in +x**.  For the beam models a mode's
vertical shape at (x, y) is

    w_j(x, y) = phi_j(x) + y theta_j(x)

with phi_j the bending shape of the axis and theta_j the torsional rotation, positive
when the left side goes down (the same sign logic as w, positive down).  A bending mode
has theta_j = 0; a torsional mode phi_j = 0 (a straight beam whose reference axis is the
shear centre does not couple them; the continuous deck's eigen-solve could mix modes of
equal frequency, which is harmless: w is general).

Tracks (:class:`Track`): a centre line at eccentricity y_k with two rails at
y_k +- s/2, s = 1.435 m (:data:`GAUGE`, between the rail centres; the wheel-rail contact
points are taken at the rail centres too, not at 1.5 m).  An axle's load is shared
equally by its two rails and the planar vehicle (no roll DOF) sees the mean of its two
rails: for the beam models that is the deck at the track centre line,
``w_j(x, y_k) = phi_j + y_k theta_j`` -- by reciprocity the modal force of an axle load P
is ``P w_j(x, y_k)``.  So one train on one eccentric track runs on the kernels as they
are: :meth:`BeamDeck3D.track_bridge` hands them the track line's shapes as a Hermite
table (kind 2), and its ``deck`` is the axis bending table (deck outputs at the axis,
modal load effects of the bending part: the bending moment and shear of a beam do not
depend on where across the deck the load stands).

Torsion
-------
- Simply supported span with fork supports (:func:`simply_supported`):
  ``theta_j = sqrt(2 / (I_p L)) sin(j pi x / L)``, ``omega_j = (j pi / L) sqrt(GJ / I_p)``
  (St-Venant torsion, no warping), each with ``torsion.damping_ratio``.
- Continuous deck (:func:`continuous`): a torsion DOF per FE node (linear elements,
  ``GJ`` and the polar mass ``I_p``), torsion restrained at every support; bending and
  torsion modes come from ONE eigen-solve of the assembled (w, dw/dx, theta) model.
  The FE torsion field is piecewise linear: outputs (twist, rail lines) use it as it
  is; the kernels' track-line table needs one slope per node, so there the torsion part
  is the Hermite cubic of the nodal values with the mean of the two adjacent element
  slopes (a smooth running surface; O(h^2) from the FE field between nodes, exact at
  the nodes).
- Which modes are kept: ``n_modes`` / ``max_frequency`` select the *bending* modes as
  for a planar deck; the torsional modes kept are those up to the highest retained
  bending frequency (or ``max_frequency``), or the lowest ``n_torsion_modes`` when given.

Twist (EN 1990 A2.4.4.2.2) over a base b = 3 m along track k, window from x to x + b:

    t(x) = [w(x, y_L) - w(x, y_R)] - [w(x + b, y_L) - w(x + b, y_R)]
         = s (theta(x) - theta(x + b))                      (beam models)

in metres, a linear map of the modal coordinates (:meth:`BeamDeck3D.twist_operator`),
so it is enveloped like the deck displacement (a row of the output operator per
section).  Off the deck (the abutment, the approach) the deck does not twist: windows
that straddle a deck end see the end's rotation against the fixed abutment.

Limits of the model: vertical only -- no roll of the vehicles, no cross-level
irregularity, no lateral dynamics, no warping torsion, no distortion of the cross
section (the rails of a beam model follow the rigid section).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsi_numba.model import bridge as _br
from vsi_numba.model import hermite
from vsi_numba.model.influence import beam_deck

#: Track gauge s (m) between the rail centres, also taken as the spacing of the
#: wheel-rail contact points.
GAUGE = 1.435
#: Base length of the deck twist (m), EN 1990 A2.4.4.2.2.
TWIST_BASE = 3.0
#: Hermite-table intervals per half wave of the highest sine mode of a simply supported
#: deck with torsion: the cubic's error on sin(k x) is (k h)^4 / 384 of the amplitude,
#: 2.5e-7 at 32 intervals per half wave.
SINE_TABLE_PER_HALF_WAVE = 32


class SpaceModelError(ValueError):
    """A track or torsion input that cannot be used (the message names the key)."""


def _positive(key, value, unit):
    v = np.asarray(value, float)
    if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise SpaceModelError(f"{key} = {np.asarray(value).tolist()!r}: expected a value "
                              f"> 0 {unit}")
    return v


@dataclass(frozen=True)
class Track:
    """One track on the deck.

    Parameters
    ----------
    eccentricity : float
        y of the track centre line from the deck's reference axis (m, positive to the
        left looking in +x).  Beam models only; imported decks take the track from
        ``line``.
    gauge : float
        Distance s between the rail centres (m).
    line : str
        Imported decks: the name of the track in the modes file / station map (the
        centre line ``line``, the rails ``line/left`` and ``line/right``).
    """

    eccentricity: float = 0.0
    gauge: float = GAUGE
    line: str = ""

    def __post_init__(self):
        if not np.isfinite(self.eccentricity):
            raise SpaceModelError(f"bridge.tracks: eccentricity = {self.eccentricity!r}: "
                                  "expected a finite distance in m")
        _positive("bridge.tracks: gauge", self.gauge, "m")

    @property
    def rails(self) -> tuple[float, float]:
        """(y_left, y_right) of the two rails (m)."""
        h = 0.5 * float(self.gauge)
        return float(self.eccentricity) + h, float(self.eccentricity) - h


def tracks_from(items) -> tuple[Track, ...]:
    """Tracks from ``[{eccentricity = ...}, ...]``-like dicts (or :class:`Track`); None or
    empty: one track on the axis (today's model)."""
    if not items:
        return (Track(),)
    out = []
    for i, it in enumerate(items):
        if isinstance(it, Track):
            out.append(it)
            continue
        if not isinstance(it, dict):
            raise SpaceModelError(f"bridge.tracks[{i}] = {it!r}: expected a table "
                                  "{ eccentricity = y } (m)")
        unknown = set(it) - {"eccentricity", "gauge", "line"}
        if unknown:
            raise SpaceModelError(f"bridge.tracks[{i}]: unknown key(s) "
                                  f"{', '.join(sorted(unknown))}; expected eccentricity, "
                                  "gauge, line")
        try:
            out.append(Track(float(it.get("eccentricity", 0.0)),
                             float(it.get("gauge", GAUGE)), str(it.get("line", ""))))
        except SpaceModelError as exc:
            raise SpaceModelError(str(exc).replace("bridge.tracks", f"bridge.tracks[{i}]")
                                  ) from None
    return tuple(out)


@dataclass(frozen=True)
class Torsion:
    """St-Venant torsion of a beam deck.

    Parameters
    ----------
    GJ : float or sequence of float
        Torsional stiffness (N m^2), one value or one per span.
    polar_mass : float or sequence of float
        Polar mass moment of inertia per length I_p (kg m^2/m) about the reference axis,
        one value or one per span.
    damping_ratio : float
        Damping ratio of the torsional modes (-).
    """

    GJ: object
    polar_mass: object
    damping_ratio: float = 0.0

    def __post_init__(self):
        _positive("bridge.torsion.GJ", self.GJ, "N m^2")
        _positive("bridge.torsion.polar_mass", self.polar_mass, "kg m^2/m")
        z = float(self.damping_ratio)
        if not (np.isfinite(z) and 0.0 <= z < 1.0):
            raise SpaceModelError(f"bridge.torsion.damping_ratio = {self.damping_ratio!r}: "
                                  "expected 0 <= zeta < 1")

    def per_span(self, n_spans: int) -> tuple[np.ndarray, np.ndarray]:
        """(GJ, I_p) of every span."""
        out = []
        for key, v in (("GJ", self.GJ), ("polar_mass", self.polar_mass)):
            a = np.atleast_1d(np.asarray(v, float))
            if a.size not in (1, n_spans):
                raise SpaceModelError(f"bridge.torsion.{key} = {a.tolist()}: expected one "
                                      f"value or one per span ({n_spans} spans)")
            out.append(np.broadcast_to(a, (n_spans,)).copy())
        return out[0], out[1]


@dataclass(frozen=True)
class Table:
    """Mode-shape table along x: Hermite cubics of ``values`` and ``slopes`` at
    ``nodes``, or (``linear``) straight lines between the nodal values; zero outside
    ``[nodes[0], nodes[-1]]``.  ``values``, ``slopes``: (n_nodes, n_modes)."""

    nodes: np.ndarray
    values: np.ndarray
    slopes: np.ndarray
    linear: bool = False

    def __call__(self, x) -> np.ndarray:
        x = np.atleast_1d(np.asarray(x, float))
        if not self.linear:
            return hermite.table(self.nodes, self.values, self.slopes, x)
        out = np.zeros((x.size, self.values.shape[1]))
        inside = (x >= self.nodes[0]) & (x <= self.nodes[-1])
        xi = x[inside]
        e = np.clip(np.searchsorted(self.nodes, xi, side="right") - 1, 0,
                    self.nodes.size - 2)
        t = ((xi - self.nodes[e]) / (self.nodes[e + 1] - self.nodes[e]))[:, None]
        out[inside] = (1.0 - t) * self.values[e] + t * self.values[e + 1]
        return out


def _zero_table(length: float, n_m: int) -> Table:
    z = np.zeros((2, n_m))
    return Table(np.array([0.0, float(length)]), z, z.copy(), linear=True)


def span_coordinates(supports, at, x_load):
    """Where the points ``at`` and the loads ``x_load`` are on a deck of spans between
    ``supports`` (m): ``(at, x, span_at, span_load, L, X, a)``, with the span index of
    each (a point on an interior support belongs to the span on its right), L the span
    of each point, X each point and a each load from the left support of its own span
    (``L`` and ``X`` of shape (len(at), 1), ``a`` of shape (1, len(x_load)))."""
    sup = np.asarray(supports, float)
    at = np.atleast_1d(np.asarray(at, float))
    x = np.atleast_1d(np.asarray(x_load, float))
    span = lambda v: np.clip(np.searchsorted(sup, v, side="right") - 1, 0,  # noqa: E731
                             sup.size - 2)
    sa, sl = span(at), span(x)
    L = (sup[1:] - sup[:-1])[sa][:, None]
    X = (at - sup[sa])[:, None]
    a = (x - sup[sl])[None, :]
    return at, x, sa, sl, L, X, a


def torsion_green(supports, GJ, at, x_load) -> np.ndarray:
    """St-Venant rotation (rad per N m) at ``at`` of a unit torque at each ``x_load``,
    torsion restrained at every support (each span a fork-supported span on its own):
    ``theta = X (L - a) / (GJ L)`` for X <= a, ``a (L - X) / (GJ L)`` for X >= a (X, a
    from the span's left support); zero in other spans and off the deck.  Shape
    (len(at), len(x_load))."""
    sup = np.asarray(supports, float)
    gj = np.broadcast_to(np.asarray(GJ, float), (sup.size - 1,))
    at, x, sa, sl, L, X, a = span_coordinates(sup, at, x_load)
    on = (((at >= sup[0]) & (at <= sup[-1]))[:, None] & ((x >= sup[0]) & (x <= sup[-1]))[None, :]
          & (sa[:, None] == sl[None, :]))
    g = np.where(X <= a, X * (L - a), a * (L - X)) / (gj[sa][:, None] * L)
    return np.where(on, g, 0.0)


@dataclass(frozen=True)
class BeamDeck3D:
    """A beam deck (simply supported or continuous) with its tracks and torsion.

    Attributes
    ----------
    bending : ModalBridge
        Every retained mode (bending and torsion, ascending frequencies) with phi_j
        along the reference axis (zero for a torsional mode); its ``static`` is the
        bending beam.  Without torsion: exactly the planar model of today.
    theta : Table
        theta_j(x) of every mode (rad per unit modal coordinate; zero for bending
        modes), as the outputs use it (see the module notes).
    theta_track : Table
        theta_j(x) as the kernels' track-line tables use it (equal to ``theta`` for a
        simply supported deck; smoothed slopes for the FE field).
    tracks : tuple of Track
    supports : ndarray
        Support abscissae (m), torsion restrained at each.
    GJ : ndarray or None
        Torsional stiffness per span (N m^2); None: no torsion.
    torsional_share : ndarray, shape (n_modes,)
        Share of each mode's kinetic energy (modal mass) in torsion (0 bending, 1
        torsion).
    polar_mass : ndarray or None
        Polar mass moment of inertia per length per span (kg m^2/m); None: no torsion.
    """

    bending: _br.ModalBridge
    theta: Table
    theta_track: Table
    tracks: tuple[Track, ...]
    supports: np.ndarray
    GJ: np.ndarray | None = None
    torsional_share: np.ndarray | None = None
    polar_mass: np.ndarray | None = None

    @property
    def n_modes(self) -> int:
        return self.bending.n_modes

    @property
    def frequencies(self) -> np.ndarray:
        return self.bending.frequencies

    @property
    def length(self) -> float:
        return self.bending.length

    @property
    def has_torsion(self) -> bool:
        return self.GJ is not None

    def _track(self, k: int) -> Track:
        if not 0 <= k < len(self.tracks):
            raise SpaceModelError(f"train.track = {k + 1}: expected 1 .. {len(self.tracks)} "
                                  "(bridge.tracks has " f"{len(self.tracks)})")
        return self.tracks[k]

    def phi(self, x) -> np.ndarray:
        """Bending shapes of the reference axis at ``x``: (len(x), n_modes)."""
        return self.bending.shapes(x)

    def shapes(self, x, y) -> np.ndarray:
        """w_j(x, y) = phi_j(x) + y theta_j(x): (len(x), n_modes); ``y`` scalar or one
        per x."""
        x = np.atleast_1d(np.asarray(x, float))
        y = np.broadcast_to(np.asarray(y, float), x.shape)
        return self.phi(x) + y[:, None] * self.theta(x)

    def track_shapes(self, k: int, x) -> np.ndarray:
        """Shapes along the centre line of track ``k`` (0-based): what its train sees."""
        return self.shapes(x, self._track(k).eccentricity)

    def rail_shapes(self, k: int, x) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) rail shapes of track ``k`` at ``x``, each (len(x), n_modes)."""
        yl, yr = self._track(k).rails
        return self.shapes(x, yl), self.shapes(x, yr)

    def twist_operator(self, k: int, x, base: float = TWIST_BASE) -> np.ndarray:
        """T (len(x), n_modes): the twist of track ``k`` over the window [x, x + base]
        is ``T @ q`` (m), ``s (theta(x) - theta(x + base))``."""
        x = np.atleast_1d(np.asarray(x, float))
        s = float(self._track(k).gauge)
        return s * (self.theta(x) - self.theta(x + base))

    def twist_grid(self, intervals: int = 32, base: float = TWIST_BASE) -> np.ndarray:
        """Window starts (m) of the whole-deck twist envelope: every span cut in
        ``intervals`` plus the windows that straddle the deck ends (from -base)."""
        return twist_grid(self.supports, intervals, base)

    def track_bridge(self, k: int = 0) -> _br.ModalBridge:
        """The :class:`~vsi_numba.model.bridge.ModalBridge` the kernels run for a train
        on track ``k``: the track line's shapes as a Hermite table, ``deck`` the axis
        bending table, ``static`` the bending beam.  Without torsion it is
        :attr:`bending` itself (whatever the eccentricity: bit for bit today's model)."""
        tr = self._track(k)
        if not self.has_torsion:
            return self.bending
        ax = self.bending
        nodes = self.theta_track.nodes
        phi = hermite.evaluate(ax.nodes, ax.values, ax.slopes, nodes)
        dphi = hermite.evaluate(ax.nodes, ax.values, ax.slopes, nodes, 1)
        y = float(tr.eccentricity)
        where = f"track {k + 1} at y = {y:g} m"
        return _br.ModalBridge(
            kind=_br.HERMITE, length=ax.length, frequencies=ax.frequencies,
            damping=ax.damping, nodes=nodes,
            values=np.ascontiguousarray(phi + y * self.theta_track.values),
            slopes=np.ascontiguousarray(dphi + y * self.theta_track.slopes),
            supports=ax.supports, description=f"{ax.description}; {where}",
            deck=ax, static=ax.static)

    def static_twist_line(self, k: int, at, base: float = TWIST_BASE,
                          loaded: int | None = None):
        """Influence line of the static twist (m per N) of track ``k`` at the window
        starts ``at`` under a unit downward force on track ``loaded`` (default ``k``): a
        callable ``line(x_load) -> (len(at), len(x_load))`` (closed-form St-Venant
        torsion of the point torque y_loaded per newton; the bending part does not twist
        a beam deck)."""
        if not self.has_torsion:
            raise SpaceModelError("the deck twist needs the deck's torsion: give "
                                  "bridge.torsion = { GJ = ..., polar_mass = ... }")
        s = float(self._track(k).gauge)
        y = float(self._track(k if loaded is None else loaded).eccentricity)
        at = np.atleast_1d(np.asarray(at, float))
        sup, gj = self.supports, self.GJ

        def line(x_load):
            return s * y * (torsion_green(sup, gj, at, x_load)
                            - torsion_green(sup, gj, at + base, x_load))
        return line

    def twist_breakpoints(self, at, base: float = TWIST_BASE) -> np.ndarray:
        """Where the static twist lines at the window starts ``at`` have kinks: the
        supports and both ends of every window (for the LM71 placement search)."""
        at = np.atleast_1d(np.asarray(at, float))
        return np.unique(np.concatenate([self.supports, at, at + base]))


def twist_grid(supports, intervals: int = 32, base: float = TWIST_BASE) -> np.ndarray:
    """Window starts (m) for the whole-deck twist: ``intervals`` per span, the supports
    and the points ``base`` before them (a window ending at a support), from -base."""
    s = np.asarray(supports, float)
    g = [np.linspace(a, b, int(intervals) + 1) for a, b in zip(s[:-1], s[1:], strict=True)]
    g.append(s - base)
    g.append(np.linspace(-base, 0.0, max(2, int(np.ceil(intervals * base / (s[-1] - s[0])))
                                        + 1)))
    g = np.unique(np.round(np.concatenate(g), 12))
    return g[(g >= -base) & (g <= s[-1])]


def _merge(f_b, f_t):
    """Indices that sort bending (first at ties) and torsional frequencies together."""
    f = np.concatenate([f_b, f_t])
    fam = np.concatenate([np.zeros(f_b.size), np.ones(f_t.size)])
    order = np.lexsort((fam, f))
    return f[order], order


def _torsion_kept(f_t, f_top, max_frequency, n_torsion_modes):
    if n_torsion_modes is not None:
        return min(int(n_torsion_modes), f_t.size)
    top = f_top if max_frequency is None else max(f_top, float(max_frequency))
    return int(np.count_nonzero(f_t <= top * (1 + 1e-12)))


def simply_supported(
    length: float,
    EI: float,
    mass_per_length: float,
    torsion: Torsion | None = None,
    tracks=None,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    n_torsion_modes: int | None = None,
) -> BeamDeck3D:
    """Simply supported span on fork supports, with torsion when given.

    Bending modes as :func:`vsi_numba.model.bridge.simply_supported`; torsional modes
    ``theta_j = sqrt(2 / (I_p L)) sin(j pi x / L)``,
    ``omega_j = (j pi / L) sqrt(GJ / I_p)``.  Both families are tabulated (Hermite, exact
    values and slopes at :data:`SINE_TABLE_PER_HALF_WAVE` intervals per half wave of the
    highest mode) when there is torsion; without it the bending bridge is today's
    analytic one.
    """
    tracks = tracks_from(tracks)
    planar = _br.simply_supported(length, EI, mass_per_length, n_modes, max_frequency,
                                  damping_ratio)
    L = float(length)
    if torsion is None:
        return BeamDeck3D(planar, _zero_table(L, planar.n_modes),
                          _zero_table(L, planar.n_modes), tracks, planar.supports,
                          torsional_share=np.zeros(planar.n_modes))
    gj, ip = (float(v[0]) for v in torsion.per_span(1))
    n_b = planar.n_modes
    jt_max = 400 if n_torsion_modes is None else max(int(n_torsion_modes), 1)
    jt = np.arange(1, jt_max + 1)
    f_t = jt * np.sqrt(gj / ip) / (2.0 * L)
    n_t = _torsion_kept(f_t, float(planar.frequencies[-1]), max_frequency, n_torsion_modes)
    f_t = f_t[:n_t]
    freqs, order = _merge(planar.frequencies, f_t)
    half_waves = max(n_b, n_t, 1)
    nodes = np.linspace(0.0, L, SINE_TABLE_PER_HALF_WAVE * half_waves + 1)
    kb = np.pi * np.arange(1, n_b + 1) / L
    kt = np.pi * np.arange(1, n_t + 1) / L
    ab = np.sqrt(2.0 / (float(mass_per_length) * L))
    at = np.sqrt(2.0 / (ip * L))
    phi = np.zeros((nodes.size, n_b + n_t))
    dphi = np.zeros_like(phi)
    th = np.zeros_like(phi)
    dth = np.zeros_like(phi)
    phi[:, :n_b] = ab * np.sin(np.outer(nodes, kb))
    dphi[:, :n_b] = ab * kb * np.cos(np.outer(nodes, kb))
    th[:, n_b:] = at * np.sin(np.outer(nodes, kt))
    dth[:, n_b:] = at * kt * np.cos(np.outer(nodes, kt))
    phi, dphi, th, dth = (np.ascontiguousarray(a[:, order]) for a in (phi, dphi, th, dth))
    phi[[0, -1]] = 0.0
    th[[0, -1]] = 0.0
    zeta = np.concatenate([planar.damping, np.full(n_t, float(torsion.damping_ratio))])[order]
    share = np.concatenate([np.zeros(n_b), np.ones(n_t)])[order]
    bending = _br.ModalBridge(
        kind=_br.HERMITE, length=L, frequencies=freqs, damping=zeta, nodes=nodes,
        values=phi, slopes=dphi, supports=planar.supports,
        description=(f"{planar.description}, GJ = {_br._num(gj)} N m2, I_p = {_br._num(ip)} "
                     f"kg m2/m ({n_b} bending + {n_t} torsional modes)"),
        static=beam_deck([L], EI, mass_per_length))
    theta = Table(nodes, th, dth)
    return BeamDeck3D(bending, theta, theta, tracks, planar.supports,
                      GJ=np.array([gj]), torsional_share=share, polar_mass=np.array([ip]))


def beam_torsion_matrices(spans, EI, mass_per_length, torsion: Torsion,
                          elements_per_span):
    """The 2-D beam of :func:`vsi_numba.model.bridge.beam_matrices` with a torsion DOF
    per node (linear elements: ``GJ/h [[1, -1], [-1, 1]]``, ``I_p h/6 [[2, 1], [1, 2]]``).

    Returns ``nodes, K, M, fixed, supports, support_nodes``; DOFs: the bending (w_i,
    dw/dx_i) of every node first, then theta_i of every node (index ``2 n_nodes + i``);
    ``fixed`` holds w and theta at every support.
    """
    nodes, Kb, Mb, fixed_b, supports = _br.beam_matrices(spans, EI, mass_per_length,
                                                         elements_per_span)
    ns = np.atleast_1d(np.asarray(spans, float)).size
    gj, ip = torsion.per_span(ns)
    ne = int(elements_per_span)
    nn = nodes.size
    K = np.zeros((3 * nn, 3 * nn))
    M = np.zeros_like(K)
    K[:2 * nn, :2 * nn] = Kb
    M[:2 * nn, :2 * nn] = Mb
    for e in range(nn - 1):
        s = e // ne
        h = nodes[e + 1] - nodes[e]
        idx = 2 * nn + np.array([e, e + 1])
        K[np.ix_(idx, idx)] += gj[s] / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
        M[np.ix_(idx, idx)] += ip[s] * h / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
    support_nodes = np.array([ne * s for s in range(ns + 1)])
    fixed = np.concatenate([fixed_b, 2 * nn + support_nodes])
    return nodes, K, M, fixed, supports, support_nodes


def continuous(
    spans,
    EI,
    mass_per_length,
    torsion: Torsion | None = None,
    tracks=None,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    elements_per_span: int = 40,
    n_torsion_modes: int | None = None,
) -> BeamDeck3D:
    """Continuous deck on point supports (2-D FE), with a torsion DOF per node when
    ``torsion`` is given: bending and torsion modes from one eigen-solve
    (``scipy.linalg.eigh``), torsion restrained at every support.

    Damping: a list ``damping_ratio`` applies to the bending modes in ascending order,
    ``torsion.damping_ratio`` to the torsional ones; a mode that mixes both (equal
    frequencies) takes the mean weighted by its kinetic energy shares.
    """
    tracks = tracks_from(tracks)
    if torsion is None:
        planar = _br.continuous(spans, EI, mass_per_length, n_modes, max_frequency,
                                damping_ratio, elements_per_span)
        return BeamDeck3D(planar, _zero_table(planar.length, planar.n_modes),
                          _zero_table(planar.length, planar.n_modes), tracks,
                          planar.supports, torsional_share=np.zeros(planar.n_modes))
    nodes, K, M, fixed, supports, _ = beam_torsion_matrices(spans, EI, mass_per_length,
                                                            torsion, elements_per_span)
    nn = nodes.size
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    import scipy.linalg

    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    full = np.zeros((K.shape[0], free.size))
    full[free] = vec
    tor = slice(2 * nn, 3 * nn)
    share = np.einsum("ij,ij->j", full[tor], M[tor, tor] @ full[tor])
    is_t = share > 0.5
    fb = freqs[~is_t]
    n_b = _br.n_modes_kept(fb, n_modes, max_frequency)
    n_t = _torsion_kept(freqs[is_t], float(fb[n_b - 1]), max_frequency, n_torsion_modes)
    keep = np.sort(np.concatenate([np.flatnonzero(~is_t)[:n_b], np.flatnonzero(is_t)[:n_t]]))
    full, share, freqs = full[:, keep], share[keep], freqs[keep]
    w, th = full[0:2 * nn:2], full[tor]
    # sign: the largest displacement (bending) or rotation (torsion) of each mode positive
    big = np.where(share[None, :] > 0.5, th, w)
    sign = np.sign(big[np.argmax(np.abs(big), axis=0), np.arange(keep.size)])
    sign[sign == 0] = 1.0
    full = full * sign
    w, dw, th = full[0:2 * nn:2], full[1:2 * nn:2], full[tor]
    zb = _br.per_mode(damping_ratio, n_b, "damping_ratio")
    zeta_b = np.zeros(keep.size)
    zeta_b[share <= 0.5] = zb
    zeta_b[share > 0.5] = zb[-1] if np.ndim(damping_ratio) else float(zb[0])
    zeta = (1.0 - share) * zeta_b + share * float(torsion.damping_ratio)
    gj, ip = torsion.per_span(np.atleast_1d(spans).size)
    # the kernels' table: nodal slopes of theta = mean of the adjacent element slopes
    g = np.diff(th, axis=0) / np.diff(nodes)[:, None]
    dth = np.zeros_like(th)
    dth[0], dth[-1] = g[0], g[-1]
    dth[1:-1] = 0.5 * (g[:-1] + g[1:])
    bending = _br.ModalBridge(
        kind=_br.HERMITE, length=float(supports[-1]), frequencies=freqs,
        damping=zeta, nodes=nodes, values=np.ascontiguousarray(w),
        slopes=np.ascontiguousarray(dw), supports=supports,
        description=("continuous deck with torsion, spans " + " + ".join(
            _br._num(x) for x in np.atleast_1d(spans)) + f" m ({n_b} bending + {n_t} "
            "torsional modes)"),
        static=beam_deck(spans, EI, mass_per_length))
    return BeamDeck3D(bending, Table(nodes, np.ascontiguousarray(th), dth, linear=True),
                      Table(nodes, np.ascontiguousarray(th), dth), tracks, supports,
                      GJ=gj, torsional_share=share, polar_mass=ip)


@dataclass(frozen=True)
class OutputRows:
    """Rows of the output operators of a deck in space, to stack under the planar
    ``phi_d`` / ``phi_a`` of :func:`vsi_numba.solver.batch.deck_operators`: the kernels'
    envelope loop takes ``max_t |row @ q|`` and ``max_t |row_a @ qdd|`` of every row, so
    per-track outputs need no kernel change.

    ``disp`` (n_track, n_p, n_m): deck displacement along each track line at the output
    points (acceleration rows: the same, with the modes above the cut-off zeroed by the
    caller); ``twist`` (n_track, n_w, n_m): twist over ``base`` of each track at the
    window starts ``starts`` (n_w,), all-NaN rows for a track without rails.
    """

    disp: np.ndarray
    twist: np.ndarray
    starts: np.ndarray
    has_twist: np.ndarray  # (n_track,) bool


def output_rows(deck, points, starts=None, base: float = TWIST_BASE) -> OutputRows:
    """:class:`OutputRows` of ``deck`` (:class:`BeamDeck3D` or
    :class:`~vsi_numba.model.imported.lines.LineDeck3D`) at the output ``points`` and
    the twist window ``starts`` (default: the output points and the whole-deck twist
    grid, merged)."""
    points = np.atleast_1d(np.asarray(points, float))
    if starts is None:
        starts = np.unique(np.concatenate([deck.twist_grid(base=base), points]))
    starts = np.atleast_1d(np.asarray(starts, float))
    n_t, n_m = len(deck.tracks), deck.n_modes
    disp = np.stack([deck.track_shapes(k, points) for k in range(n_t)])
    twist = np.full((n_t, starts.size, n_m), np.nan)
    has = np.zeros(n_t, bool)
    for k in range(n_t):
        if isinstance(deck, BeamDeck3D) and not deck.has_torsion:
            twist[k] = 0.0  # no torsion: the deck does not twist
            has[k] = True
            continue
        try:
            twist[k] = deck.twist_operator(k, starts, base)
            has[k] = True
        except SpaceModelError:
            pass
    return OutputRows(disp, twist, starts, has)
