"""The twist, the displacement along each track and the torsional moment of a beam deck in
space by the mode-acceleration method (the kernels' ``cb_`` channels).

A plain modal sum converges slowly for these: the static St-Venant rotation of a point
torque has a kink under the load (its sine series converges as 1/n, the twist over 3 m
of six torsional modes is up to 8 % low on the whole deck, 24 % at a point of a
continuous deck) and the torque jumps there.  As for the bending
moment and shear (:mod:`vsi_numba.model.influence`), each is the static response to the
current loads plus the modes' inertia and damping correction,

    E(t) = D [sum_k P_k G(x_k) - sum_j E_j F_j / w_j^2] + sum_j E_j' q_j,

with, for a deck whose torsion is restrained at every support (each span a fork-supported
span on its own; St-Venant torsion ``GJ_s`` per span):

- static rotation ``theta(X) = y_l M_s(X) / GJ_s``: ``M_s`` the simply supported moment of
  span s of the loads in it, ``y_l`` the loaded track's eccentricity (each load a torque
  ``P y_l``); the torque ``T(X) = GJ theta' = y_l V_s(X)``, ``V_s`` the span's simply
  supported shear (the value just right of a load);
- twist of track k over [x, x + b]: ``s_k (theta(x) - theta(x + b))`` (zero off the deck),
  ``E_j = E_j' = s_k (theta_j(x) - theta_j(x + b))``;
- displacement along track k: the bending modes' sum as it is (it converges fast) and the
  torsion part ``y_k theta`` corrected: ``E_j' = phi_j + y_k theta_j``, ``E_j = y_k theta_j``;
- torque: ``E_j = E_j' = GJ_s theta_j'(x)``.

``D = 1 / (1 - (v / c)^2)``, ``c = sqrt(GJ / I_p)`` the torsional wave speed (the smallest
of the spans'): a torque moving at v over a St-Venant bar is carried by the bar as if its
stiffness were ``GJ (1 - (v / c)^2)`` (the particular solution of
``I_p theta_tt - GJ theta_xx = P y delta(x - v t)`` is the static one with that
stiffness, for every truncated mode alike: its forcing-to-natural frequency ratio is v/c).
The kept modes carry the rest.  What this leaves out is the truncated modes' free
vibration: the torque front a load sends off at c when it enters or leaves a span
(stated with the torque's accuracy in :data:`TORQUE_ACCURACY`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vsi_numba.model import hermite
from vsi_numba.model.deck3d import span_coordinates

#: The file attribute that says how the twist and track displacements were computed.
METHOD = "mode-acceleration"

#: How accurate the torsional moment is (the ``accuracy`` attribute of its variables),
#: measured against a converged reference (V19, ``vsi verify``).
TORQUE_ACCURACY = (
    "mode-acceleration method with the moving torque's speed factor 1 / (1 - (v/c)^2), "
    "c = sqrt(GJ / I_p): at crawl speed within 3e-4 of P e; at speed the torque front "
    "a load sends off along the span when it enters or leaves it is carried by the kept "
    "modes only (see docs/manual/decks_in_space.md, Torsional moment)")


@dataclass(frozen=True)
class SpaceChannels:
    """The kernels' deck-in-space channels (``Reduce.cb_*``) of one loaded track.

    ``twist`` (n_tracks, n_starts), ``track`` (n_tracks, n_points), ``torque``
    (n_points,) and ``torque_grid`` (n_grid, the whole-deck grid) hold the channel index
    of each value (-1: none; ``twist`` is empty when the deck does not twist, ``torque``
    when the loaded track is on the axis).
    """

    supports: np.ndarray  # (n_sup,) m
    sections: np.ndarray  # (n_cs,) abscissae on the deck, ascending, m
    X: np.ndarray  # (n_cs,) in their span, m
    sec0: np.ndarray  # (n_span + 1,) int64
    ptr: np.ndarray  # (n_cb + 1,) int64
    idx: np.ndarray  # (n_nz,) int64
    coef: np.ndarray  # (n_nz,) per metre of the loads' eccentricity
    Eq: np.ndarray  # (n_m, n_cb)
    Ef: np.ndarray  # (n_m, n_cb): times 1 / w_j^2
    wave_speed: float  # m/s, the smallest sqrt(GJ / I_p) of the spans
    y_load: float  # m, the loaded track's eccentricity
    twist: np.ndarray
    track: np.ndarray
    torque: np.ndarray
    #: (n_grid,) channel of the torque at each section of the whole-deck grid (empty:
    #: none)
    torque_grid: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: (n_lines,) m: the eccentricity of each track line a load may stand on (the
    #: kernels' ``wheel_line`` / ``load_line``) when the run carries trains on several
    #: tracks: the static part then takes each load's own eccentricity, and the channels
    #: are reduced from the run's histories (:func:`reduce_channels`), not by the
    #: kernels (whose static part has one eccentricity for every load).  None: every
    #: load on the loaded track (``y_load``), reduced by the kernels.
    line_y: np.ndarray | None = None

    @property
    def per_line(self) -> bool:
        """Whether the loads stand on several track lines (see ``line_y``)."""
        return self.line_y is not None

    @property
    def n_channels(self) -> int:
        return int(self.ptr.size - 1)

    def speed_factor(self, speeds) -> np.ndarray:
        """D = 1 / (1 - (v / c)^2) per run and channel (n_runs, n_cb)."""
        v = np.atleast_1d(np.asarray(speeds, float))
        r = v / self.wave_speed
        if np.any(r >= 0.95):
            from vsi_numba.solver.pack import ModelError

            raise ModelError(
                f"bridge.torsion: the torsional wave speed sqrt(GJ / I_p) = "
                f"{self.wave_speed:.4g} m/s is not well above the speed "
                f"{v[r >= 0.95][0]:.4g} m/s: expected a train speed below 0.95 of it")
        return np.repeat((1.0 / (1.0 - r * r))[:, None], self.n_channels, axis=1)

    def static_unit(self, x, force) -> np.ndarray:
        """Static channels (D = 1, without the modal part) of forces ``force`` (n, n_load)
        at ``x`` (n, n_load) on a track at ``y_load``: (n, n_cb), per unit of y_load
        (:func:`~vsi_numba.kernels.record.cb_history`, the kernels' formula)."""
        from vsi_numba.kernels.record import cb_history

        sup = np.ascontiguousarray(self.supports, np.float64)
        f64 = np.float64
        out = np.zeros((x.shape[0], self.n_channels))
        cb_history(sup, 1.0 / np.diff(sup), np.ascontiguousarray(self.X, f64), self.sec0,
                   self.ptr, self.idx, np.ascontiguousarray(self.coef, f64),
                   np.ascontiguousarray(x, f64), np.ascontiguousarray(force, f64),
                   np.zeros(x.shape[1]), np.zeros(x.shape[1]),
                   np.zeros(2 * self.sections.size), out)
        return out

    def series(self, q, fq, x, force, speed, y_load=None, line=None) -> np.ndarray:
        """Channel histories (n, n_cb) of one run: modal coordinates ``q`` and forces
        ``fq`` (n, n_m), its loads ``force`` at ``x`` (n, n_load) on a track at ``y_load``
        (default the loaded track's) or, with ``line`` (n_load,) and ``line_y``, each
        load on its own track line (eccentricity ``line_y[line]``), at ``speed`` (m/s)."""
        d = self.speed_factor([speed])[0]
        if line is not None and self.per_line:
            line = np.asarray(line, np.int64)
            static = 0.0
            for k, y in enumerate(np.asarray(self.line_y, float)):
                sel = np.flatnonzero(line == k)
                if y != 0.0 and sel.size:
                    static = static + self.static_unit(x[:, sel], force[:, sel]) * y
        else:
            y = self.y_load if y_load is None else float(y_load)
            if y != 0.0:
                static = self.static_unit(x, force)
                static *= y
            else:
                static = 0.0
        # d * (static - fq @ Ef) + q @ Eq, the same operations in place (no temporaries
        # of the history's size)
        out = fq @ self.Ef
        np.subtract(static, out, out=out)
        out *= d
        out += q @ self.Eq
        return out

    def modal_series(self, q) -> np.ndarray:
        """The channels' part of the modal coordinates ``q`` (n, n_m) alone (a train
        whose static part is elsewhere)."""
        return q @ self.Eq


def span_moment_shear(supports, at, x_load) -> tuple[np.ndarray, np.ndarray]:
    """Simply supported moment and shear (per N; shear just right of the load) at ``at``
    of a unit load at each ``x_load`` in the same span, zero in the other spans:
    ``(len(at), len(x_load))`` each (the kernels' :func:`~vsi_numba.kernels.record.cb_static`;
    a load on an interior support belongs to the span on its right)."""
    _, _, sa, sl, L, X, a = span_coordinates(supports, at, x_load)
    same = sa[:, None] == sl[None, :]
    m = np.where(X <= a, X * (L - a), a * (L - X)) / L
    v = np.where(a <= X, -a, L - a) / L
    return np.where(same, m, 0.0), np.where(same, v, 0.0)


def _theta_slope(table, x) -> np.ndarray:
    """d theta_j / dx at ``x`` (len(x), n_m): the Hermite table's derivative, or for the
    FE field (linear) the slope of the element just right of x."""
    x = np.atleast_1d(np.asarray(x, float))
    if not table.linear:
        return hermite.evaluate(table.nodes, table.values, table.slopes, x, 1)
    nodes = table.nodes
    e = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    return (table.values[e + 1] - table.values[e]) / (nodes[e + 1] - nodes[e])[:, None]


def space_channels(space, points, starts, w2inv, loaded: int = 0,
                   torque: bool = True, grid=(), lines=None) -> SpaceChannels | None:
    """The :class:`SpaceChannels` of a :class:`~vsi_numba.model.deck3d.BeamDeck3D` with
    torsion for a train on track ``loaded`` (0-based): the twist at the window ``starts``
    of every track, the displacement along every track at ``points`` and (``torque``,
    the loaded track off the axis) the torque at ``points`` and at the whole-deck
    ``grid`` (m).  None without torsion.  ``lines``: trains on several tracks in one
    run, the tracks (0-based) of the run's track lines in order (the kernels'
    ``wheel_line``): each load takes its own track's eccentricity
    (``SpaceChannels.line_y``) and the torque is computed when any of them is off the
    axis.

    The torque of every span is its own (torsion restrained at every support: each span
    a fork-supported span, simply supported or continuous deck alike): the static part
    is ``y_l`` times the span's simply supported shear, the modal part ``GJ_s
    theta_j'``, the slope of the element just right of the section for the FE field of a
    continuous deck (just left of it at the deck's right end)."""
    from vsi_numba.model.deck3d import TWIST_BASE

    if not getattr(space, "has_torsion", False) or not hasattr(space, "theta"):
        return None
    sup = np.asarray(space.supports, float)
    points = np.atleast_1d(np.asarray(points, float))
    starts = np.atleast_1d(np.asarray(starts, float))
    grid = np.atleast_1d(np.asarray(grid, float))
    gj = np.broadcast_to(np.asarray(space.GJ, float), (sup.size - 1,))
    ip = np.broadcast_to(np.asarray(space.polar_mass, float), (sup.size - 1,))
    c = float(np.min(np.sqrt(gj / ip)))
    y_l = float(space.tracks[loaded].eccentricity)
    line_y = (None if lines is None else
              np.array([float(space.tracks[int(k)].eccentricity) for k in lines]))
    on = lambda v: v[(v >= sup[0]) & (v <= sup[-1])]  # noqa: E731
    with_torque = torque and (y_l != 0.0 if line_y is None else bool(np.any(line_y != 0.0)))
    sections = np.unique(np.concatenate([on(points), on(starts), on(starts + TWIST_BASE)]
                                        + ([on(grid)] if with_torque else [])))
    span = np.clip(np.searchsorted(sup, sections, side="right") - 1, 0, sup.size - 2)
    where = {float(v): i for i, v in enumerate(sections)}
    n_cs = sections.size
    n_m = space.n_modes
    terms: list[list[tuple[int, float]]] = []
    eq: list[np.ndarray] = []
    ef: list[np.ndarray] = []

    def moment(xv, scale):  # the static rotation M_s / GJ_s at x per m of y_l, times scale
        if not sup[0] <= xv <= sup[-1]:
            return []
        i = where[float(xv)]
        return [(i, scale / gj[span[i]])]

    n_k = len(space.tracks)
    twist = np.full((n_k, starts.size), -1, np.int64)
    by_gauge: dict[float, int] = {}  # the tracks of one gauge twist alike: one channel
    for k in range(n_k):
        s = float(space.tracks[k].gauge)
        if s in by_gauge:
            twist[k] = twist[by_gauge[s]]
            continue
        by_gauge[s] = k
        rows = space.twist_operator(k, starts)
        for i, x in enumerate(starts):
            twist[k, i] = len(terms)
            terms.append(moment(x, s) + moment(x + TWIST_BASE, -s))
            eq.append(rows[i])
            ef.append(rows[i])
    track = np.full((n_k, points.size), -1, np.int64)
    th = space.theta(points)
    for k in range(n_k):
        yk = float(space.tracks[k].eccentricity)
        w = space.track_shapes(k, points)
        for i, x in enumerate(points):
            track[k, i] = len(terms)
            terms.append(moment(x, yk))
            eq.append(w[i])
            ef.append(yk * th[i])
    def torque_at(at):  # the torque channels at the sections ``at``
        out = np.full(at.size, -1, np.int64)
        if not with_torque or not at.size:
            return out
        slope = _theta_slope(space.theta, at)
        for i, x in enumerate(at):
            j = where.get(float(x))
            if j is None:
                continue
            out[i] = len(terms)
            terms.append([(n_cs + j, 1.0)])
            col = gj[span[j]] * slope[i]
            eq.append(col)
            ef.append(col)
        return out

    tq = torque_at(points)
    tq_grid = torque_at(grid) if with_torque else np.zeros(0, np.int64)
    ptr = np.concatenate([[0], np.cumsum([len(t) for t in terms])]).astype(np.int64)
    flat = [p for t in terms for p in t]
    idx = np.array([p[0] for p in flat], np.int64)
    coef = np.array([p[1] for p in flat], float)
    Eq = np.ascontiguousarray(np.array(eq, float).reshape(-1, n_m).T)
    Ef = np.ascontiguousarray(np.array(ef, float).reshape(-1, n_m).T
                              * np.asarray(w2inv, float)[:, None])
    sec0 = np.searchsorted(span, np.arange(sup.size), side="left").astype(np.int64)
    return SpaceChannels(sup, sections, np.ascontiguousarray(sections - sup[span]), sec0,
                         ptr, idx, coef, Eq, Ef, c, y_l, twist, track, tq, tq_grid, line_y)


def reduce_channels(res) -> None:
    """The channels' envelopes of a batch whose loads stand on several track lines
    (``SpaceChannels.per_line``), reduced from every run's histories as the kernels
    reduce them (the first time of the largest and of the smallest value) into
    ``res.red``'s ``cb_max``, ``cb_max_t``, ``cb_min``, ``cb_min_t``; NaN for a run
    that failed.  ``res``: a :class:`~vsi_numba.solver.results.BatchResult` whose
    every run kept its histories with the modal forces."""
    from vsi_numba import kernels as ek
    from vsi_numba.solver.reductions import first_max_min

    ch = res.space.channels
    n_r, n_cb = res.speeds.size, ch.n_channels
    hi, hi_t = np.full((n_r, n_cb), np.nan), np.full((n_r, n_cb), np.nan)
    lo, lo_t = np.full((n_r, n_cb), np.nan), np.full((n_r, n_cb), np.nan)
    dt = res.packed.params.dt
    for r in range(n_r):
        if int(res.status[r]) != ek.OK or int(res.slots[r]) < 0:
            continue
        c = res.space_series(r)
        a, ai, b, bi = first_max_min(c)
        hi[r], hi_t[r], lo[r], lo_t[r] = a, ai * dt, b, bi * dt
    res.red = res.red._replace(cb_max=hi, cb_max_t=hi_t, cb_min=lo, cb_min_t=lo_t)


def kernel_fields(ch: SpaceChannels | None, speeds, n_r: int) -> dict:
    """The ``cb_`` fields of :class:`~vsi_numba.kernels.types.Reduce` (none: off)."""
    if ch is None or ch.n_channels == 0 or ch.per_line:  # per line: reduce_channels
        return {}
    n_cb = ch.n_channels
    return dict(
        cb_X=np.ascontiguousarray(ch.X, np.float64), cb_sec0=ch.sec0,
        cb_ss=np.zeros(2 * ch.sections.size), cb_ptr=ch.ptr, cb_idx=ch.idx,
        cb_coef=np.ascontiguousarray(ch.coef * ch.y_load, np.float64), cb_Eq=ch.Eq, cb_Ef=ch.Ef,
        cb_D=np.ascontiguousarray(ch.speed_factor(speeds)), cb_val=np.zeros(n_cb),
        cb_max=np.full((n_r, n_cb), -np.inf), cb_max_t=np.zeros((n_r, n_cb)),
        cb_min=np.full((n_r, n_cb), np.inf), cb_min_t=np.zeros((n_r, n_cb)))
