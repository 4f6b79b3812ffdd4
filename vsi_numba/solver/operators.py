"""The deck's output operators of a batch: the mode shapes at the output points and on
the whole-deck grid, the load-effect tables and, for a deck in space, the per-track rows
stacked under the deck's (:class:`DeckOperators`, :class:`SpaceLayout`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from vsi_numba.en1990 import frequency_cutoff
from vsi_numba.model import hermite
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.solver.pack import LoadEffectTables, load_effect_tables
from vsi_numba.solver.settings import SolverSettings


def acceleration_cutoff(frequencies: np.ndarray) -> float:
    """EN 1990 A2.4.4.2.1: frequencies up to max(30 Hz, 1.5 f1, f3) enter the check
    (:func:`vsi_numba.en1990.frequency_cutoff`)."""
    return frequency_cutoff(frequencies)


#: Intervals per span of the whole-deck acceleration grid (see :func:`deck_grid`).
DECK_GRID_INTERVALS = 32


def deck_grid(bridge: ModalBridge, points=(), intervals: int = DECK_GRID_INTERVALS
              ) -> np.ndarray:
    """Abscissae (m) where the whole-deck acceleration envelope is evaluated.

    ``intervals`` equal intervals on every span (supports included) plus the user's
    output ``points``, sorted, duplicates removed.

    Notes
    -----
    The grid maximum underestimates the maximum over the continuous deck by at most the
    relative amount (K h)^2 / 8, with h the grid spacing and K the largest wavenumber
    of the band-limited modes (|f''| <= K^2 max|f| for a trigonometric polynomial of
    degree K, Bernstein; the true maximum x* is a stationary point of |a(., t*)| and a
    grid point lies within h/2 of it).  Three half-waves per span (a 15 m span, f1 = 8 Hz:
    the modes up to the cut-off f3) give 1.1 % with 32 intervals, 4.3 % with 16.
    """
    s = np.asarray(bridge.supports, float)
    if s.size < 2:
        s = np.array([0.0, float(bridge.length)])
    grid = [np.linspace(a, b, int(intervals) + 1) for a, b in zip(s[:-1], s[1:], strict=True)]
    grid.append(np.atleast_1d(np.asarray(points, float)))
    grid = np.unique(np.round(np.concatenate(grid), 12))
    return grid[(grid >= 0.0) & (grid <= bridge.length)]


def deck_operators(bridge: ModalBridge, points, settings: SolverSettings,
                   load_effects: bool = True) -> DeckOperators:
    """Mode shapes of the deck line at ``points`` and on the whole-deck grid, and the
    load-effect tables.

    Returns
    -------
    DeckOperators
        ``(phi_d, phi_a, cutoff, grid_x, phi_g, effects)`` (``layout`` None): ``phi_d``
        (n_p, n_m) at the points;
        ``phi_a`` the same with zero columns for the modes above the EN 1990
        A2.4.4.2.1 cut-off (Hz, ``cutoff``), so ``phi_a @ qdd`` is the band-limited deck
        acceleration; ``grid_x`` (n_g,) the whole-deck grid (:func:`deck_grid`) and
        ``phi_g`` (n_ka, n_g) its band-limited shapes, transposed, for the first ``n_ka``
        modes (those up to the last mode below the cut-off); ``effects`` the
        :class:`~vsi_numba.solver.pack.LoadEffectTables` at the points and on the
        whole-deck grid (:func:`deck_grid`), None when ``load_effects`` is false or the
        bridge has no static deck (:mod:`vsi_numba.model.influence`).
    """
    points = np.atleast_1d(np.asarray(points, float))
    phi_d = np.ascontiguousarray(bridge.output_shapes(points), dtype=np.float64)
    phi_d = phi_d.reshape(points.size, bridge.n_modes)
    cutoff = settings.acceleration_cutoff
    if cutoff is None:
        cutoff = acceleration_cutoff(bridge.frequencies)
    keep = np.asarray(bridge.frequencies) <= cutoff + 1e-9
    phi_a = np.ascontiguousarray(np.where(keep[None, :], phi_d, 0.0))
    n_ka = int(np.flatnonzero(keep)[-1]) + 1 if keep.any() else 0
    grid_x = deck_grid(bridge, points) if n_ka else np.zeros(0)
    shapes = np.asarray(bridge.output_shapes(grid_x), float).reshape(grid_x.size,
                                                                      bridge.n_modes)
    phi_g = np.ascontiguousarray(np.where(keep[None, :n_ka], shapes[:, :n_ka], 0.0).T)
    effects = (load_effect_tables(bridge, points, deck_grid(bridge, points))
               if load_effects else None)
    return DeckOperators(phi_d, phi_a, float(cutoff), grid_x, phi_g, effects)


@dataclass(frozen=True)
class SpaceLayout:
    """Where the per-track rows sit under the planar output operators (stacked by
    :func:`space_operators`): after the ``n_points`` deck rows come the track-line rows
    (n_tracks x n_points), the twist at the output points (n_tracks x n_points), the
    twist on the whole-deck grid ``twist_x`` (n_tracks x n_twist) and the band-limited
    acceleration rows on the whole-deck grid ``grid_x`` along each track line
    (n_tracks x n_grid; their displacement rows are zero).  A deck that does not twist
    has no twist rows; a beam deck without torsion (every track line is the axis, the
    per-track values are the deck's) no whole-deck rows either (``whole_from_deck``:
    the deck's own whole-deck envelope is each track's), so that a deck declared with
    tracks but no torsion costs little more than the planar one.  When the
    mode-acceleration channels give the twist (``channels``), the twist rows are left
    out (``twist_rows`` false): the kernels would reduce them for nothing.

    The torsional moment at the output points, when computed, is the shear-force
    channel ``torque_channel`` of the load-effect tables scaled by ``torque_scale``
    (see :func:`torsional_moment_tables`); ``torque_reason`` says why it is not
    computed otherwise."""

    n_points: int
    eccentricity: np.ndarray  # (n_tracks,) m (NaN: not known, imported decks)
    twist_x: np.ndarray  # (n_twist,) window starts, m
    has_twist: bool  # the deck twists (it has torsion or imported rails)
    grid_x: np.ndarray  # (n_grid,) whole-deck acceleration grid, m
    lines: tuple[str, ...] = ()  # imported decks: the track names in the data
    no_twist: str = ""  # why there is no twist (has_twist false), "" for the default
    torque_channel: np.ndarray | None = None  # (n_points,) load-effect channels
    torque_scale: float = 0.0  # N m per channel unit: the loaded track's eccentricity
    torque_reason: str = ""  # why the torsional moment is not computed ("" if it is)
    whole_from_deck: bool = False  # the tracks' whole-deck acceleration is the deck's
    channels: object | None = None  # space_effects.SpaceChannels (mode-acceleration)
    twist_rows: bool = True  # the twist rows are stacked (False: the channels give it)

    @property
    def n_tracks(self) -> int:
        return int(self.eccentricity.size)

    @property
    def has_torque(self) -> bool:
        """Whether the torsional moment at the output points is computed."""
        return self.torque_channel is not None or (
            self.channels is not None and bool(np.any(self.channels.torque >= 0)))

    @property
    def n_whole(self) -> int:
        """Points of the whole-deck grid with a row along each track line (0: none, the
        deck's own whole-deck envelope is each track's)."""
        return 0 if self.whole_from_deck else int(self.grid_x.size)

    @property
    def n_rows(self) -> int:
        """Rows before the whole-deck rows along the track lines (the kernels reduce
        those to one envelope per track: ``Reduce.tw_*``)."""
        n_p, n_k = self.n_points, self.n_tracks
        n_t = n_p if self.has_twist and self.twist_rows else 0
        n_w = self.twist_x.size if self.has_twist and self.twist_rows else 0
        return n_p + n_k * (n_p + n_t + n_w)

    def split(self, a: np.ndarray) -> dict[str, np.ndarray]:
        """Columns of ``a`` (n_runs, n_rows): ``deck`` (n_runs, n_p), ``track`` and
        ``twist`` (n_runs, n_tracks, n_p), ``twist_whole`` (n_runs, n_tracks, n_twist),
        ``track_whole`` (n_runs, n_tracks, n_grid); the twist blocks are empty without
        ``twist_rows``, ``track_whole`` when ``a`` stops at :attr:`n_rows` (the kernels'
        envelopes: ``Reduce.tw_*``)."""
        n_p, n_k = self.n_points, self.n_tracks
        n_t = n_p if self.has_twist and self.twist_rows else 0
        n_w = self.twist_x.size if self.has_twist and self.twist_rows else 0
        n_g = self.n_whole if a.shape[1] > self.n_rows else 0
        r = a.shape[0]
        o1 = n_p + n_k * n_p
        o2 = o1 + n_k * n_t
        o3 = o2 + n_k * n_w
        return {"deck": a[:, :n_p], "track": a[:, n_p:o1].reshape(r, n_k, n_p),
                "twist": a[:, o1:o2].reshape(r, n_k, n_t),
                "twist_whole": a[:, o2:o3].reshape(r, n_k, n_w),
                "track_whole": a[:, o3:o3 + n_k * n_g].reshape(r, n_k, n_g)}


class DeckOperators(NamedTuple):
    """What the kernels read of the deck besides its modes (:func:`deck_operators`,
    :func:`space_operators`).

    ``phi_d`` (n_rows, n_m): the mode shapes at the output points (then, for a deck in
    space, the rows of :class:`SpaceLayout`); ``phi_a`` the same with zero columns for the
    modes above the EN 1990 A2.4.4.2.1 cut-off ``cutoff`` (Hz), so ``phi_a @ qdd`` is the
    band-limited deck acceleration; ``grid_x`` (n_g,) the whole-deck grid
    (:func:`deck_grid`, empty: no whole-deck envelope) and ``phi_g`` (n_ka, n_g) its
    band-limited shapes, transposed, for the first ``n_ka`` modes; ``effects`` the
    load-effect tables (None: not computed); ``layout`` the rows of the deck in space
    (None: a planar deck)."""

    phi_d: np.ndarray
    phi_a: np.ndarray
    cutoff: float
    grid_x: np.ndarray | None = None
    phi_g: np.ndarray | None = None
    effects: LoadEffectTables | None = None
    layout: SpaceLayout | None = None

    @classmethod
    def of(cls, deck) -> DeckOperators:
        """``deck`` as a :class:`DeckOperators` (also from a plain tuple of its first 3
        to 7 fields), the missing whole-deck grid empty."""
        d = deck if isinstance(deck, cls) else cls(*deck)
        if d.grid_x is None or d.phi_g is None or not np.size(d.grid_x):
            d = d._replace(grid_x=np.zeros(0), phi_g=np.zeros((0, 0)))
        return d

    @property
    def n_grid(self) -> int:
        """Points of the whole-deck grid (0: no whole-deck envelope)."""
        return 0 if self.grid_x is None else int(np.size(self.grid_x))



def torsional_moment_tables(space, points, effects: LoadEffectTables | None,
                            loaded: int = 0) -> tuple:
    """The load-effect tables with one more section per output point whose shear-force
    channel, times the eccentricity e of the loaded track, is the St-Venant torsional
    moment ``T = GJ dtheta/dx`` there, by the mode-acceleration method.

    Returns ``(effects, channel, scale, reason)``: the tables (``effects`` itself when
    the moment is not computed), the channels of the points' moments, ``scale`` = e (m)
    and the reason it is not computed ("" when it is).

    Notes
    -----
    T(x, t) = sum_k P_k e G_T(x, x_k) + sum_j T_j (q_j - F_j / w_j^2), with T_j =
    GJ theta_j'(x).  On a span with fork supports the static torque of a point torque
    P e at a is P e (1 - a/L) left of it and -P e a/L right of it: e times the shear
    force of the simply supported span, which the kernels already compute for every
    section (the value just right of a load).  The extra sections' shear columns of
    ``E`` are T_j / e (their moment columns zero), so the channel is T / e.  On a
    continuous deck the kernels add the bending support moments to the shear of every
    section, so this static part is not available without a kernel change.
    """
    points = np.atleast_1d(np.asarray(points, float))
    if not getattr(space, "has_torsion", False):
        return effects, None, 0.0, "the deck has no torsion (no bridge.torsion)"
    e = float(space.tracks[loaded].eccentricity)
    if effects is None:
        return effects, None, 0.0, ("needs the load effects (mode-acceleration method), "
                                    "which are not computed")
    if effects.n_supports != 2:
        return effects, None, 0.0, (
            "continuous deck: the static torque of the mode-acceleration method needs a "
            "kernel channel of its own (only simply_supported decks have it)")
    if e == 0.0:
        return effects, None, 0.0, ("the loaded track is on the deck's axis: the train "
                                    "does not twist the deck")
    n_s = effects.n_sections
    sections = np.concatenate([effects.sections, points])
    order = np.argsort(sections, kind="stable")
    where = np.empty_like(order)
    where[order] = np.arange(order.size)  # new index of every old / extra section
    n_new, n_sup = sections.size, effects.n_supports
    gj = float(space.GJ[0])
    slope = hermite.evaluate(space.theta.nodes, space.theta.values, space.theta.slopes,
                             points, 1)
    E = np.zeros((effects.E.shape[0], 2 * n_new + 2 * n_sup))
    E[:, where[:n_s]] = effects.E[:, :n_s]
    E[:, n_new + where[:n_s]] = effects.E[:, n_s:2 * n_s]
    E[:, n_new + where[n_s:]] = (gj * slope / e).T
    E[:, 2 * n_new:] = effects.E[:, 2 * n_s:]
    sup = effects.supports
    span = np.clip(np.searchsorted(sup, sections[order], side="right") - 1, 0,
                   effects.spans.size - 1).astype(np.int64)
    tables = dataclasses.replace(
        effects, sections=sections[order], point_index=where[effects.point_index],
        grid_index=where[effects.grid_index],
        X=np.ascontiguousarray(sections[order] - sup[span]), span=span,
        E=np.ascontiguousarray(E))
    return tables, (n_new + where[n_s:]).astype(np.int64), e, ""


def space_operators(space, points, deck: DeckOperators, loaded: int = 0,
                    one_track_loaded: bool = True, lines=None) -> DeckOperators:
    """``deck`` (:func:`deck_operators`) with the rows of the deck in space
    (:func:`vsi_numba.model.deck3d.output_rows`) stacked under ``phi_d`` / ``phi_a``:
    the kernels' envelopes of every row are then the per-track displacement,
    acceleration (band-limited like the deck's, at the output points and on the
    whole-deck grid :func:`deck_grid`) and twist, no kernel change.  With torsion, the
    load-effect tables gain the torsional moment at the points for a train on track
    ``loaded`` (0-based; :func:`torsional_moment_tables`).  Returns the operators with
    these rows and their :class:`SpaceLayout` (``layout``).  ``one_track_loaded``
    False (interaction trains on several tracks in one run): the mode-acceleration
    channels take each load's own track, ``lines`` (0-based tracks of the run's track
    lines, the kernels' ``wheel_line``), and are reduced from the runs' histories
    (:func:`~vsi_numba.solver.space_effects.reduce_channels`); without ``lines`` no
    channels and no torsional moment (the twist and the track lines from the modes)."""
    from vsi_numba.model import deck3d

    points = np.atleast_1d(np.asarray(points, float))
    deck = DeckOperators.of(deck)
    phi_d, phi_a, cutoff = deck.phi_d, deck.phi_a, deck.cutoff
    grid = deck3d.twist_grid(space.supports)
    starts = np.concatenate([points, grid])
    rows = deck3d.output_rows(space, points, starts)
    n_m = phi_d.shape[1]
    keep = np.asarray(space.frequencies) <= cutoff + 1e-9  # as deck_operators' phi_a
    disp = rows.disp.reshape(-1, n_m)
    twist_p = rows.twist[:, :points.size].reshape(-1, n_m)
    twist_g = rows.twist[:, points.size:].reshape(-1, n_m)
    grid_x = np.asarray(deck.grid_x, float)
    has_twist = bool(getattr(space, "has_torsion", True) and rows.has_twist.all())
    if not has_twist:
        twist_p, twist_g = np.zeros((0, n_m)), np.zeros((0, n_m))
    from_deck = getattr(space, "has_torsion", None) is False  # every track is the axis
    whole = np.concatenate([space.track_shapes(k, grid_x) for k in range(len(space.tracks))]
                           ) if grid_x.size and not from_deck else np.zeros((0, n_m))
    whole = np.where(keep[None, :], whole, 0.0)
    effects = deck.effects
    from vsi_numba.solver.space_effects import space_channels

    channels = (space_channels(space, points, starts, effects.w2inv, loaded,
                               grid=effects.sections[effects.grid_index],
                               lines=None if one_track_loaded else list(lines))
                if effects is not None and isinstance(space, deck3d.BeamDeck3D)
                and (one_track_loaded or lines is not None) else None)
    # the channels' twist replaces the rows' (SpaceLayout.split, BatchResult)
    twist_rows = not (channels is not None and channels.n_channels > 0
                      and channels.twist.size > 0)
    if not twist_rows:
        twist_p, twist_g = np.zeros((0, n_m)), np.zeros((0, n_m))
    extra = np.nan_to_num(np.concatenate([disp, twist_p, twist_g, np.zeros_like(whole)]))
    extra_a = np.concatenate([np.where(keep[None, :], disp, 0.0),
                              np.zeros((twist_p.shape[0] + twist_g.shape[0], n_m)), whole])
    if channels is not None:  # twist, track displacement and torque by mode acceleration
        reason = "" if np.any(channels.torque >= 0) else (
            "no output point on the deck" if np.any(channels.torque_grid >= 0) else
            "every loaded track is on the deck's axis: the trains do not twist the deck"
            if channels.per_line else
            "the loaded track is on the deck's axis: the train does not twist the deck"
            if channels.y_load == 0.0 else "no output point on the deck")
        channel, scale = None, 0.0
    elif not one_track_loaded:
        channel, scale = None, 0.0
        reason = ("interaction trains on several tracks in one run: the torsional moment "
                  "needs the load effects of a beam deck (bridge.kind simply_supported "
                  "or continuous) with every train at the run's speed "
                  "(train.other_trains[].speed_factor = 1)")
    else:
        effects, channel, scale, reason = torsional_moment_tables(space, points, effects,
                                                                  loaded)
    ecc = getattr(space, "eccentricities", None)
    if ecc is None:
        ecc = np.array([t.eccentricity for t in space.tracks], float)
    layout = SpaceLayout(points.size, np.asarray(ecc, float), grid, has_twist, grid_x,
                         tuple(t.line for t in space.tracks if t.line),
                         getattr(space, "no_twist", ""), channel, scale, reason, from_deck,
                         channels, twist_rows)
    return deck._replace(phi_d=np.ascontiguousarray(np.vstack([phi_d, extra])),
                         phi_a=np.ascontiguousarray(np.vstack([phi_a, extra_a])),
                         effects=effects, layout=layout)
