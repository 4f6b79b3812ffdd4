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

from vsi_numba.model import hermite
from vsi_numba.model.distribution import LoadDistribution
from vsi_numba.model.influence import StaticDeck, beam_deck
from vsi_numba.model.track import ElasticTrack

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
    deck : ModalBridge or None
        With a track layer (:func:`continuous_with_track`) the track line is the rail;
        ``deck`` tabulates the same modes along the deck, for the deck outputs
        (:meth:`output_shapes`).  None: the deck is the track line.
    track : ElasticTrack or None
        The rail on its foundation, over the deck and the approaches
        (:mod:`vsi_numba.model.track`): the wheels see the track-filtered mode shapes and
        the rail's compliance.  None: the rigid-track idealisation (the wheel runs on
        the deck line itself and on a rigid approach; a kink at the deck ends).  The
        config's default is an elastic track; a bridge built directly has none.
    static : StaticDeck or None
        What the static load effects of the deck need (bending stiffness per span, or
        the FE stiffness), see :mod:`vsi_numba.model.influence`; None when the model has
        none (a modes table, rigid track): then only deflections and rotations are
        available, from the modes.
    load_distribution : LoadDistribution or None
        How the track spreads the moving forces onto the deck
        (:mod:`vsi_numba.model.distribution`); None: point forces on the track line.
        Interaction trains are not affected (they see :attr:`track`).
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
    deck: ModalBridge | None = None
    track: ElasticTrack | None = None
    static: StaticDeck | None = None
    load_distribution: LoadDistribution | None = None

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
        out[inside] = hermite.evaluate(self.nodes, self.values, self.slopes, xi, derivative)
        return out


    def output_shapes(self, x, derivative: int = 0) -> np.ndarray:
        """Mode shapes for the *deck* outputs at ``x``: shape (len(x), n_modes).

        The deck line when the bridge has a track layer (:attr:`deck`), else the track
        line (:meth:`shapes`).
        """
        return (self.deck if self.deck is not None else self).shapes(x, derivative)


def reversed_bridge(bridge: ModalBridge) -> ModalBridge:
    """The bridge seen from its far end, x' = length - x: the same modes (frequencies,
    damping, modal coordinates), each shape read backwards.  A train running in -x on
    ``bridge`` is a train running in +x on the reversed one (trains meeting,
    ``train.other_trains``).

    Sine modes change sign where sin(n pi (L - x) / L) = (-1)^(n+1) sin(n pi x / L);
    tables are mirrored (values reversed, slopes reversed and negated).  The static deck
    is left out (None): the load effects of a reversed run take the loads back to x.
    """
    length = float(bridge.length)
    if bridge.kind == SINE:
        sign = (-1.0) ** np.arange(bridge.n_modes)
        values = np.ascontiguousarray(bridge.values * sign[None, :])
        nodes, slopes = bridge.nodes, bridge.slopes
    elif bridge.kind == HERMITE:
        nodes = np.ascontiguousarray(length - bridge.nodes[::-1])
        values = np.ascontiguousarray(bridge.values[::-1])
        slopes = np.ascontiguousarray(-bridge.slopes[::-1])
    else:
        nodes, values, slopes = bridge.nodes, bridge.values, bridge.slopes
    deck = bridge.deck
    return ModalBridge(
        kind=bridge.kind, length=length, frequencies=bridge.frequencies,
        damping=bridge.damping, nodes=nodes, values=values, slopes=slopes,
        supports=np.ascontiguousarray(length - np.asarray(bridge.supports)[::-1]),
        description=f"{bridge.description}; seen from its far end (x' = L - x)",
        effective_mass_fraction=bridge.effective_mass_fraction,
        deck=None if deck is None else reversed_bridge(deck), track=bridge.track,
        static=None, load_distribution=bridge.load_distribution)


def per_mode(value, n, name):
    """One value per retained mode: a scalar for every mode, or the first ``n`` of a list
    (ValueError when it has fewer than ``n``)."""
    v = np.asarray(value, float)
    if v.ndim == 0:
        return np.full(n, float(v))
    if v.size < n:
        raise ValueError(f"{name}: {v.size} values given, {n} modes retained")
    return v[:n].copy()


def n_modes_kept(freqs, n_modes, max_frequency):
    """How many of the ascending ``freqs`` are retained: at most ``n_modes``, none above
    ``max_frequency`` (either may be None, not both); ValueError when none is."""
    if n_modes is None and max_frequency is None:
        raise ValueError("give n_modes or max_frequency")
    n = freqs.size if n_modes is None else min(int(n_modes), freqs.size)
    if max_frequency is not None:
        n = min(n, int(np.count_nonzero(freqs <= max_frequency)))
    if n < 1:
        raise ValueError("no mode retained (n_modes < 1 or max_frequency below the first mode)")
    return n


def _num(value) -> str:
    """A number for a description: ``25``, ``7.16e10``, ``18000`` (4 significant digits)."""
    v = float(value)
    return f"{v:.4g}".replace("e+", "e") if abs(v) >= 1e5 else f"{v:.6g}"


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
    n = n_modes_kept(freqs, n_modes, max_frequency)
    amp = np.full(n, np.sqrt(2.0 / (mass_per_length * length)))
    return ModalBridge(
        kind=SINE,
        length=float(length),
        frequencies=freqs[:n],
        damping=per_mode(damping_ratio, n, "damping_ratio"),
        values=amp[None, :],
        supports=np.array([0.0, length]),
        description=(f"simply supported, L = {_num(length)} m, EI = {_num(EI)} N m2, "
                     f"m = {_num(mass_per_length)} kg/m"),
        static=beam_deck([length], EI, mass_per_length),
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
        ke, me = hermite.beam_element(h, ei, m)
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
    import scipy.linalg  # here, not at import: it takes ~0.3 s to import

    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    n = n_modes_kept(freqs, n_modes, max_frequency)
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
        damping=per_mode(damping_ratio, n, "damping_ratio"),
        nodes=nodes,
        values=np.ascontiguousarray(full[0::2]),
        slopes=np.ascontiguousarray(full[1::2]),
        supports=supports,
        description="continuous deck, spans " + " + ".join(
            _num(x) for x in np.atleast_1d(spans)) + " m",
        static=beam_deck(spans, EI, mass_per_length),
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
        damping=per_mode(damping_ratio, freqs.size, "damping_ratio"),
        nodes=x,
        values=np.ascontiguousarray(shapes),
        slopes=np.ascontiguousarray(slopes),
        supports=np.asarray(supports if supports is not None else [x[0], x[-1]], float),
        description=description,
    )


# ------------------------------------------------------------------------ track layer


@dataclass(frozen=True)
class TrackLayer:
    """Ballasted track on the deck, 2-D (the whole track: both rails together), SI units.

    The rail is an Euler-Bernoulli beam (Hermite elements) on discrete rail pads at the
    sleepers; each sleeper is a mass on a ballast spring that bears on the deck (at the
    sleeper's abscissa, through the deck element's Hermite shape functions).  The train
    runs on the rail.  Values are per track (two rails, one sleeper), consistent with
    the whole-vehicle axle loads of the 2-D model.

    Parameters
    ----------
    rail_EI : float
        Bending stiffness of both rails (N m^2), e.g. 2 x 6.42e6 for UIC60.
    rail_mass_per_length : float
        Mass of both rails (kg/m), e.g. 2 x 60.3 for UIC60.
    pad_stiffness : float
        Rail pads under one sleeper, both rail seats together (N/m).
    sleeper_mass : float
        One sleeper (kg).
    sleeper_spacing : float
        Distance between sleepers (m); the first sleeper is half a spacing from x = 0.
    ballast_stiffness : float
        Ballast under one sleeper (N/m).  The ballast *mass* belongs to the deck's
        ``mass_per_length``.
    pad_damping, ballast_damping : float
        Dashpots per sleeper (N s/m), as modal damping: ``zeta_j += phi_j^T C phi_j /
        (2 w_j)`` (the off-diagonal terms of ``Phi^T C Phi`` are dropped).
    rail_elements_per_bay : int
        Rail elements between two sleepers (2: the pinned-pinned rail mode is resolved
        to a few per cent).

    Notes
    -----
    When is it needed: wheel-rail forces above ~50-100 Hz (short wavelength irregularity,
    rail joints, wheel flats), short spans (L < ~10 m, where the track spreads an axle
    load over a good part of the span and the track mass is a large part of the deck's),
    transition zones and deck-end rotations.  For deck displacements and accelerations
    of ordinary spans (EN 1990 A2 checks up to 30 Hz and more) it changes little: the
    rigid-track model is the default.

    What it costs: the track modes start with the sleepers bouncing on ballast and pads
    (~100-300 Hz) and the rail on its pads (~300-1000 Hz; the pinned-pinned mode near
    1 kHz); there are about two of them per sleeper, i.e. 3-4 per metre of bridge.  The
    quasi-static rail deflection under a wheel is a sum over *all* of them, so a modal
    model keeps only part of the track flexibility unless it keeps modes up to ~1-2 kHz
    -- several hundred modes for a 20-40 m deck -- and then needs dt <= 0.1 / f_max
    (~1e-4 s or less).  :func:`continuous_with_track` reports the share of the static
    rail flexibility under a wheel that the retained modes represent, and how many modes
    reach 95 %.  The approach track of the kernels is rigid: the rail continues onto it,
    so it is clamped (w = 0, dw/dx = 0) at both ends of the deck and within ~1.5-2 m of
    each end the track is stiffer than in reality (a transition from rigid to ballasted
    track: the wheel-rail forces there show that transition, not the real embankment).
    """

    rail_EI: float
    rail_mass_per_length: float
    pad_stiffness: float
    sleeper_mass: float
    sleeper_spacing: float
    ballast_stiffness: float
    pad_damping: float = 0.0
    ballast_damping: float = 0.0
    rail_elements_per_bay: int = 2


@dataclass(frozen=True)
class TrackModel:
    """FE matrices of a deck with a track layer (see :func:`track_matrices`).

    DOFs: deck (w, theta) per deck node, then rail (w, theta) per rail node, then one
    vertical DOF per sleeper.
    """

    K: np.ndarray
    M: np.ndarray
    C: np.ndarray  # track dashpots only (pads, ballast)
    deck_nodes: np.ndarray
    rail_nodes: np.ndarray
    sleepers: np.ndarray
    rail_dof0: int  # first rail DOF
    sleeper_dof0: int  # first sleeper DOF
    fixed: np.ndarray
    supports: np.ndarray


def track_matrices(spans, EI, mass_per_length, elements_per_span, track: TrackLayer):
    """Assemble deck + rail + sleepers (dense; sizes of a few thousand DOFs)."""
    deck_nodes, Kd, Md, fixed_d, supports = beam_matrices(spans, EI, mass_per_length,
                                                          elements_per_span)
    length = float(supports[-1])
    a = float(track.sleeper_spacing)
    sleepers = np.arange(0.5 * a, length - 0.25 * a + 1e-12, a)
    breaks = np.concatenate([[0.0], sleepers, [length]])
    ne = int(track.rail_elements_per_bay)
    rail = [0.0]
    for x0, x1 in zip(breaks[:-1], breaks[1:], strict=True):
        rail.extend(x0 + (x1 - x0) * np.arange(1, ne + 1) / ne)
    rail_nodes = np.array(rail)
    rail_nodes[-1] = length
    at_sleeper = np.searchsorted(rail_nodes, sleepers)  # rail node index of each sleeper
    nd, nr, ns = Kd.shape[0], 2 * rail_nodes.size, sleepers.size
    n = nd + nr + ns
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    C = np.zeros((n, n))
    K[:nd, :nd] = Kd
    M[:nd, :nd] = Md
    for e in range(rail_nodes.size - 1):
        ke, me = hermite.beam_element(rail_nodes[e + 1] - rail_nodes[e], track.rail_EI,
                               track.rail_mass_per_length)
        idx = nd + np.arange(2 * e, 2 * e + 4)
        K[np.ix_(idx, idx)] += ke
        M[np.ix_(idx, idx)] += me
    for s, xs in enumerate(sleepers):
        js = nd + nr + s
        jr = nd + 2 * at_sleeper[s]
        M[js, js] += track.sleeper_mass
        # pad: rail node -- sleeper
        for mat, c in ((K, track.pad_stiffness), (C, track.pad_damping)):
            mat[jr, jr] += c
            mat[js, js] += c
            mat[jr, js] -= c
            mat[js, jr] -= c
        # ballast: sleeper -- deck at xs (Hermite shape functions of the deck element)
        e = int(np.clip(np.searchsorted(deck_nodes, xs, side="right") - 1, 0,
                        deck_nodes.size - 2))
        h = deck_nodes[e + 1] - deck_nodes[e]
        sh = np.array(hermite.shape_functions(np.array([(xs - deck_nodes[e]) / h]), h,
                                              0)).ravel()
        b = np.zeros(n)
        b[js] = 1.0
        b[2 * e: 2 * e + 4] -= sh
        K += track.ballast_stiffness * np.outer(b, b)
        C += track.ballast_damping * np.outer(b, b)
    # the rail continues onto the (rigid) approach track: w = 0 and dw/dx = 0 at both
    # deck ends, so the wheel path stays C1 there (no slope jump = no spurious impact)
    fixed = np.concatenate([fixed_d, [nd, nd + 1, nd + nr - 2, nd + nr - 1]])
    return TrackModel(K, M, C, deck_nodes, rail_nodes, sleepers, nd, nd + nr, fixed,
                      supports)


@dataclass(frozen=True)
class TrackReport:
    """What a track layer costs in modes (see :func:`continuous_with_track`).

    Attributes
    ----------
    all_frequencies : ndarray
        Every natural frequency of the deck + track model (Hz).
    first_track_frequency : float
        The lowest mode whose kinetic energy is mostly in the track (rail, sleepers), Hz.
    flexibility_fraction : float
        Static rail deflection under a unit load at ``probe_x`` from the retained modes,
        as a fraction of the full FE value (1 = every mode).
    modes_for_95 : int
        Number of modes needed for 95 % of that static flexibility.
    frequency_for_95 : float
        Frequency of the last of those modes (Hz).
    probe_x : float
        The load position (m): the sleeper nearest the middle of the first span.
    """

    all_frequencies: np.ndarray
    first_track_frequency: float
    flexibility_fraction: float
    modes_for_95: int
    frequency_for_95: float
    probe_x: float


def continuous_with_track(
    spans,
    EI,
    mass_per_length,
    track: TrackLayer,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    elements_per_span: int = 40,
    report: bool = False,
):
    """Continuous deck with a track layer, reduced to the modes of the whole assembly.

    The FE matrices of deck, rail and sleepers are assembled first
    (:func:`track_matrices`) and the modes computed from the assembly
    (``scipy.linalg.eigh``), so the track-deck interaction is in the modes.  The
    returned bridge tabulates the modes along the *rail* (the train runs on it); its
    ``damping`` is ``damping_ratio`` plus the modal approximation of the pad and ballast
    dashpots.  See :class:`TrackLayer` for when this is worth it and what it costs.

    Returns
    -------
    ModalBridge, or (ModalBridge, TrackReport) when ``report`` is true.
    """
    tm = track_matrices(spans, EI, mass_per_length, elements_per_span, track)
    n = tm.K.shape[0]
    free = np.setdiff1d(np.arange(n), tm.fixed)
    import scipy.linalg

    lam, vec = scipy.linalg.eigh(tm.K[np.ix_(free, free)], tm.M[np.ix_(free, free)],
                                 driver="gvd")  # divide and conquer: every mode is needed
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    full = np.zeros((n, free.size))
    full[free] = vec
    rail = full[tm.rail_dof0: tm.sleeper_dof0]
    w = rail[0::2]
    sign = np.sign(w[np.argmax(np.abs(w), axis=0), np.arange(w.shape[1])])
    sign[sign == 0] = 1.0
    full *= sign
    keep = n_modes_kept(freqs, n_modes, max_frequency)
    omega = 2 * np.pi * freqs
    zeta_track = np.einsum("ij,ij->j", full, tm.C @ full) / (2 * np.maximum(omega, 1e-300))
    zeta = np.minimum(per_mode(damping_ratio, keep, "damping_ratio") + zeta_track[:keep],
                      0.99)
    rail = full[tm.rail_dof0: tm.sleeper_dof0]
    deck = full[: tm.rail_dof0]
    length = float(tm.supports[-1])
    # static flexibility under a unit load on the rail at the sleeper nearest mid-span 1
    mid = 0.5 * (tm.supports[0] + tm.supports[1])
    k = int(np.argmin(np.abs(tm.sleepers - mid)))
    jr = int(np.searchsorted(tm.rail_nodes, tm.sleepers[k]))
    f = np.zeros(free.size)
    f[np.searchsorted(free, tm.rail_dof0 + 2 * jr)] = 1.0
    static = float(f @ np.linalg.solve(tm.K[np.ix_(free, free)], f))
    contrib = rail[2 * jr] ** 2 / np.maximum(omega, 1e-300) ** 2
    cum = np.cumsum(contrib) / static
    n95 = int(np.searchsorted(cum, 0.95) + 1)
    energy = np.einsum("ij,ij->j", full[tm.rail_dof0:], (tm.M @ full)[tm.rail_dof0:])
    track_modes = np.flatnonzero(energy > 0.5)
    rep = TrackReport(
        all_frequencies=freqs,
        first_track_frequency=float(freqs[track_modes[0]]) if track_modes.size else np.nan,
        flexibility_fraction=float(cum[keep - 1]),
        modes_for_95=min(n95, freqs.size),
        frequency_for_95=float(freqs[min(n95, freqs.size) - 1]),
        probe_x=float(tm.sleepers[k]),
    )
    bridge = ModalBridge(
        kind=HERMITE,
        length=length,
        frequencies=freqs[:keep].copy(),
        damping=zeta,
        nodes=tm.rail_nodes.copy(),
        values=np.ascontiguousarray(rail[0::2, :keep]),
        slopes=np.ascontiguousarray(rail[1::2, :keep]),
        supports=tm.supports,
        static=beam_deck(spans, EI),
        deck=ModalBridge(
            kind=HERMITE, length=length, frequencies=freqs[:keep].copy(), damping=zeta,
            nodes=tm.deck_nodes.copy(), values=np.ascontiguousarray(deck[0::2, :keep]),
            slopes=np.ascontiguousarray(deck[1::2, :keep]), supports=tm.supports,
            description="the deck under the track layer"),
        description=(
            f"continuous deck, spans={[float(v) for v in np.atleast_1d(spans)]} m, with a "
            "track layer "
            f"({tm.sleepers.size} sleepers at {track.sleeper_spacing:g} m; {n} DOFs): modes "
            f"along the rail; {keep} modes keep {100 * rep.flexibility_fraction:.0f}% of the "
            f"static rail flexibility at x = {rep.probe_x:g} m (95% needs "
            f"{rep.modes_for_95} modes, up to {rep.frequency_for_95:.0f} Hz)"
        ),
    )
    return (bridge, rep) if report else bridge
