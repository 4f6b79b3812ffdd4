"""One packed model at several speeds in one kernel call: workspaces, deck operators,
the envelopes reduced in the time loop and the raw histories (:class:`BatchResult`)."""

from __future__ import annotations

import dataclasses
import time as _time
from dataclasses import dataclass

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.en1990 import frequency_cutoff
from vsi_numba.model import hermite
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile
from vsi_numba.solver import driver, kernel_cache
from vsi_numba.solver.pack import (
    LoadEffectTables,
    ModelError,
    Packed,
    initial_states,
    load_effect_tables,
)
from vsi_numba.solver.settings import SolverSettings

STATUS_MESSAGES = {
    ek.OK: "ok",
    ek.NOT_CONVERGED: "contact iterations did not converge (also with the step subdivided)",
    ek.SINGULAR_SCHUR: "singular contact (Schur) system: dependent contact constraints",
    ek.NON_FINITE: "non-finite (NaN/inf) state: the integration diverged",
    ek.SINGULAR_IMPACT: "singular impact system at a wheel landing",
}


def acceleration_cutoff(frequencies: np.ndarray) -> float:
    """EN 1990 A2.4.4.2.1: frequencies up to max(30 Hz, 1.5 f1, f3) enter the check
    (:func:`vsi_numba.en1990.frequency_cutoff`)."""
    return frequency_cutoff(frequencies)


def _workspace(n_m, n_v, n_w, veh: ek.VehicleArrays | None = None) -> ek.Work:
    z = np.zeros
    # variable steps (deck-end events) and nonlinear suspensions need per-vehicle blocks
    n_veh, nb = (veh.M.shape[0], veh.M.shape[1]) if veh is not None else (0, 0)
    n_e = veh.nl_veh.shape[0] if veh is not None else 0
    return ek.Work(
        khv=z((n_veh, nb, nb)), kh_dt=z(n_veh), kh_sig=z(n_veh, np.int64), kscr=z((nb, nb)),
        nlb=z(n_e, np.int64), nbk=z(4 * n_m + 4 * n_v + 4 * n_w), imp=z(n_w),
        phi=z((n_w, n_m)), dphi=z((n_w, n_m)), d2phi=z((n_w, n_m)),
        onb=z(n_w, np.int64), rr=z((n_w, 3)), S=z((n_w, n_w)), L=z((n_w, n_w)),
        idx=z(n_w, np.int64), rhs=z(n_w), sol=z(n_w), gstar=z(n_w), X=z(n_w),
        active=np.ones(n_w, np.int64), was_active=np.ones(n_w, np.int64),
        yq=z(n_m), yv=z(n_v), rq=z(n_m), rv=z(n_v), fq=z(n_m), phil=z(n_m), hq=z(n_m),
        hv=z(n_v), ones=np.ones(n_m), khat=z(n_m), xout=z(n_w), vq=z(n_m), vv=z(n_v),
        av=z(n_v), act0=z(n_w, np.int64), J=z((n_w, n_w)),
        first=z(n_w, np.int64), onb_prev=z(n_w, np.int64), onb0=z(n_w, np.int64),
        cand=z(n_w, np.int64), lq=z(n_w), lz=z(n_w), lw=z(n_w), lin=z(n_w, np.int64),
        impulse=z(n_w), trk=z((n_w, 4)), trk0=z((n_w, 3)), phz=z(n_w, np.int64),
        pf=z(1 + 2 * n_w, np.int64),
    )


def _history_buffers(n_slots, n_t, n_m, n_w, n_b, effects: bool = False) -> ek.Output:
    return ek.Output(
        q=np.full((n_slots, n_t, n_m), np.nan), qdd=np.full((n_slots, n_t, n_m), np.nan),
        X=np.full((n_slots, n_t, n_w), np.nan), contact=np.zeros((n_slots, n_t, n_w), np.int8),
        body_acc=np.full((n_slots, n_t, n_b), np.nan),
        iters=np.zeros((n_slots, n_t), np.int16),
        body_pitch=np.full((n_slots, n_t, n_b), np.nan),
        fq=(np.full((n_slots, n_t, n_m), np.nan) if effects and n_slots
            else np.zeros((0, 0, 0))),
    )


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
                   load_effects: bool = True):
    """Mode shapes of the deck line at ``points`` and on the whole-deck grid, and the
    load-effect tables.

    Returns
    -------
    tuple
        ``(phi_d, phi_a, cutoff, grid_x, phi_g, effects)``: ``phi_d`` (n_p, n_m) at the
        points;
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
    return phi_d, phi_a, float(cutoff), grid_x, phi_g, effects


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
    tracks but no torsion costs little more than the planar one.

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

    @property
    def n_tracks(self) -> int:
        return int(self.eccentricity.size)

    @property
    def has_torque(self) -> bool:
        """Whether the torsional moment at the output points is computed."""
        return self.torque_channel is not None or (
            self.channels is not None and bool(np.any(self.channels.torque >= 0)))

    def split(self, a: np.ndarray) -> dict[str, np.ndarray]:
        """Columns of ``a`` (n_runs, n_rows): ``deck`` (n_runs, n_p), ``track`` and
        ``twist`` (n_runs, n_tracks, n_p), ``twist_whole`` (n_runs, n_tracks, n_twist),
        ``track_whole`` (n_runs, n_tracks, n_grid)."""
        n_p, n_k = self.n_points, self.n_tracks
        n_t = n_p if self.has_twist else 0
        n_w = self.twist_x.size if self.has_twist else 0
        n_g = 0 if self.whole_from_deck else self.grid_x.size
        r = a.shape[0]
        o1 = n_p + n_k * n_p
        o2 = o1 + n_k * n_t
        o3 = o2 + n_k * n_w
        return {"deck": a[:, :n_p], "track": a[:, n_p:o1].reshape(r, n_k, n_p),
                "twist": a[:, o1:o2].reshape(r, n_k, n_t),
                "twist_whole": a[:, o2:o3].reshape(r, n_k, n_w),
                "track_whole": a[:, o3:o3 + n_k * n_g].reshape(r, n_k, n_g)}


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


def space_operators(space, points, deck: tuple, loaded: int = 0) -> tuple:
    """``deck`` (:func:`deck_operators`' tuple) with the rows of the deck in space
    (:func:`vsi_numba.model.deck3d.output_rows`) stacked under ``phi_d`` / ``phi_a``:
    the kernels' envelopes of every row are then the per-track displacement,
    acceleration (band-limited like the deck's, at the output points and on the
    whole-deck grid :func:`deck_grid`) and twist, no kernel change.  With torsion, the
    load-effect tables gain the torsional moment at the points for a train on track
    ``loaded`` (0-based; :func:`torsional_moment_tables`).  Returns the tuple with a
    :class:`SpaceLayout` appended (element 6)."""
    from vsi_numba.model import deck3d

    points = np.atleast_1d(np.asarray(points, float))
    phi_d, phi_a, cutoff = deck[:3]
    grid = deck3d.twist_grid(space.supports)
    starts = np.concatenate([points, grid])
    rows = deck3d.output_rows(space, points, starts)
    n_m = phi_d.shape[1]
    keep = np.asarray(space.frequencies) <= cutoff + 1e-9  # as deck_operators' phi_a
    disp = rows.disp.reshape(-1, n_m)
    twist_p = rows.twist[:, :points.size].reshape(-1, n_m)
    twist_g = rows.twist[:, points.size:].reshape(-1, n_m)
    grid_x = np.asarray(deck[3], float) if len(deck) > 3 else np.zeros(0)
    has_twist = bool(getattr(space, "has_torsion", True) and rows.has_twist.all())
    if not has_twist:
        twist_p, twist_g = np.zeros((0, n_m)), np.zeros((0, n_m))
    from_deck = getattr(space, "has_torsion", None) is False  # every track is the axis
    whole = np.concatenate([space.track_shapes(k, grid_x) for k in range(len(space.tracks))]
                           ) if grid_x.size and not from_deck else np.zeros((0, n_m))
    whole = np.where(keep[None, :], whole, 0.0)
    extra = np.nan_to_num(np.concatenate([disp, twist_p, twist_g, np.zeros_like(whole)]))
    extra_a = np.concatenate([np.where(keep[None, :], disp, 0.0),
                              np.zeros((twist_p.shape[0] + twist_g.shape[0], n_m)), whole])
    effects = deck[5] if len(deck) > 5 else None
    from vsi_numba.solver.space_effects import space_channels

    channels = (space_channels(space, points, starts, effects.w2inv, loaded)
                if effects is not None and isinstance(space, deck3d.BeamDeck3D) else None)
    if channels is not None:  # twist, track displacement and torque by mode acceleration
        reason = "" if np.any(channels.torque >= 0) else (
            "the loaded track is on the deck's axis: the train does not twist the deck"
            if channels.y_load == 0.0 else "continuous deck: the torsional moment is "
            "verified on simply supported decks only")
        channel, scale = None, 0.0
    else:
        effects, channel, scale, reason = torsional_moment_tables(space, points, effects,
                                                                  loaded)
    ecc = getattr(space, "eccentricities", None)
    if ecc is None:
        ecc = np.array([t.eccentricity for t in space.tracks], float)
    layout = SpaceLayout(points.size, np.asarray(ecc, float), grid, has_twist, grid_x,
                         tuple(t.line for t in space.tracks if t.line),
                         getattr(space, "no_twist", ""), channel, scale, reason, from_deck,
                         channels)
    return (np.ascontiguousarray(np.vstack([phi_d, extra])),
            np.ascontiguousarray(np.vstack([phi_a, extra_a])), *deck[2:5], effects, layout)


@dataclass
class BatchResult:
    """Envelopes (one row per run) and raw histories (per history slot) of a batch."""

    packed: Packed
    speeds: np.ndarray  # (R,) m/s
    n_steps: np.ndarray  # (R,)
    status: np.ndarray  # (R,) int
    reached: np.ndarray  # (R,) int
    slots: np.ndarray  # (R,) history slot or -1
    red: ek.Reduce
    out: ek.Output
    phi_d: np.ndarray
    phi_a: np.ndarray
    cutoff: float
    elapsed: float
    grid_x: np.ndarray | None = None  # (n_g,) whole-deck grid, m
    effects: LoadEffectTables | None = None  # load effects (None: not computed)
    static_deck: object | None = None  # bridge.static (the effects' static deck)
    space: SpaceLayout | None = None  # per-track rows under phi_d / phi_a (or None)

    @property
    def static_loads(self) -> np.ndarray:
        """Q0 of every wheel, dynamic wheels then moving forces (N)."""
        return np.concatenate([self.packed.static_loads, self.packed.vehicles.load_p])

    @property
    def wheel_positions(self) -> np.ndarray:
        return np.concatenate([self.packed.wheel_positions, self.packed.load_positions])

    def message(self, r: int) -> str:
        status = int(self.status[r])
        text = STATUS_MESSAGES[status]
        if status != ek.OK:
            k = int(self.reached[r])
            text += f" at t = {k * self.packed.params.dt:.6g} s (step {k})"
        return text

    def envelopes(self) -> dict[str, np.ndarray]:
        """Every envelope variable of ``vsi_numba.io.schema`` (rows: runs; NaN for the
        runs that failed)."""
        red, pk, dt = self.red, self.packed, self.packed.params.dt
        n_r = self.speeds.size
        n_l = pk.load_positions.size
        loads = pk.vehicles.load_p
        q0 = self.static_loads

        def with_loads(dyn, value):
            return np.concatenate([dyn, np.broadcast_to(value, (n_r, n_l))], axis=1)

        xmin = with_loads(red.xmin, loads)
        with np.errstate(invalid="ignore", divide="ignore"):
            unloading = (q0[None, :] - xmin) / q0[None, :]
        n_p = red.disp.shape[1] if self.space is None else self.space.n_points
        data = {
            "max_deck_displacement": red.disp[:, :n_p].copy(),
            "max_deck_acceleration": red.acc[:, :n_p].copy(),
            "min_contact_force": xmin,
            "max_contact_force": with_loads(red.xmax, loads),
            "max_wheel_unloading": unloading,
            "max_carbody_acceleration": red.body.copy(),
            "contact_loss_duration": with_loads(red.lost * dt, 0.0),
            "longest_contact_loss": with_loads(red.longest * dt, 0.0),
            "contact_loss_events": with_loads(red.events.astype(float), 0.0),
            "single_step_contact_losses": with_loads(red.single.astype(float), 0.0),
            "time_of_max_deck_displacement": red.disp_t[:, :n_p].copy(),
            "time_of_max_deck_acceleration": red.acc_t[:, :n_p].copy(),
            # a moving force is at its start position at its (first) minimum, t = 0
            "position_of_min_contact_force": with_loads(red.xmin_x, pk.vehicles.load_x0),
            "time_of_max_carbody_acceleration": red.body_t.copy(),
            "position_of_max_carbody_acceleration": red.body_x.copy(),
            "max_carbody_acceleration_car_end": red.body_end.copy(),
            "time_of_max_carbody_acceleration_car_end": red.body_end_t.copy(),
            "position_of_max_carbody_acceleration_car_end": red.body_end_x.copy(),
        }
        grid = self.grid_x if self.grid_x is not None else np.zeros(0)
        if grid.size:
            data["max_deck_acceleration_whole_deck"] = red.gacc.copy()
            data["time_of_max_deck_acceleration_whole_deck"] = red.gacc_t.copy()
            data["position_of_max_deck_acceleration_whole_deck"] = grid[red.gacc_i]
        else:  # no modes in the acceleration band (or no deck)
            for name in ("max_deck_acceleration_whole_deck",
                         "time_of_max_deck_acceleration_whole_deck",
                         "position_of_max_deck_acceleration_whole_deck"):
                data[name] = np.full(n_r, np.nan)
        data.update(self._effect_envelopes())
        data.update(self._space_envelopes())
        failed = self.status != ek.OK
        if failed.any():
            for a in data.values():
                a[failed] = np.nan
        return data

    def _space_envelopes(self) -> dict[str, np.ndarray]:
        """Per-track envelopes (:data:`vsi_numba.io.schema.SPACE_ENVELOPES`) from the rows
        :func:`space_operators` stacked under the deck's; none without them."""
        if self.space is None:
            return {}
        red, sp = self.red, self.space
        d, dt = sp.split(red.disp), sp.split(red.disp_t)
        a, at = sp.split(red.acc), sp.split(red.acc_t)
        out = {"max_track_displacement": d["track"].copy(),
               "time_of_max_track_displacement": dt["track"].copy(),
               "max_track_acceleration": a["track"].copy(),
               "time_of_max_track_acceleration": at["track"].copy()}
        if sp.has_twist:
            out.update({"max_deck_twist": d["twist"].copy(),
                        "time_of_max_deck_twist": dt["twist"].copy(),
                        "max_deck_twist_whole_deck": d["twist_whole"].copy(),
                        "time_of_max_deck_twist_whole_deck": dt["twist_whole"].copy()})
        if sp.grid_x.size and sp.whole_from_deck:  # every track line is the axis
            k = sp.n_tracks
            out.update({"max_track_acceleration_whole_deck": np.repeat(
                red.gacc[:, None], k, axis=1),
                "time_of_max_track_acceleration_whole_deck": np.repeat(
                    red.gacc_t[:, None], k, axis=1),
                "position_of_max_track_acceleration_whole_deck": np.repeat(
                    sp.grid_x[red.gacc_i][:, None], k, axis=1)})
        elif sp.grid_x.size:
            g, gt = a["track_whole"], at["track_whole"]
            i = np.argmax(g, axis=2)[..., None]
            out.update({"max_track_acceleration_whole_deck":
                        np.take_along_axis(g, i, 2)[..., 0].copy(),
                        "time_of_max_track_acceleration_whole_deck":
                        np.take_along_axis(gt, i, 2)[..., 0].copy(),
                        "position_of_max_track_acceleration_whole_deck": sp.grid_x[i[..., 0]]})
        ch = sp.channels
        if ch is not None and red.cb_max.shape[1] > 0:  # mode acceleration (cb_ channels)
            def absmax(idx):
                hi, lo = red.cb_max[:, idx], red.cb_min[:, idx]
                up = hi >= -lo
                return (np.where(up, hi, -lo),
                        np.where(up, red.cb_max_t[:, idx], red.cb_min_t[:, idx]))

            out["max_track_displacement"], out["time_of_max_track_displacement"] = absmax(
                ch.track)
            if sp.has_twist:
                n_p = sp.n_points
                v, t = absmax(ch.twist)
                out.update({"max_deck_twist": v[..., :n_p],
                            "time_of_max_deck_twist": t[..., :n_p],
                            "max_deck_twist_whole_deck": v[..., n_p:],
                            "time_of_max_deck_twist_whole_deck": t[..., n_p:]})
            if np.any(ch.torque >= 0):
                c = ch.torque
                out.update({"max_torsional_moment": red.cb_max[:, c],
                            "time_of_max_torsional_moment": red.cb_max_t[:, c],
                            "min_torsional_moment": red.cb_min[:, c],
                            "time_of_min_torsional_moment": red.cb_min_t[:, c]})
        elif sp.torque_channel is not None:
            e, c = sp.torque_scale, sp.torque_channel
            hi, lo = ((red.le_max, red.le_max_t), (red.le_min, red.le_min_t))[::int(
                np.sign(e))]
            out.update({"max_torsional_moment": e * hi[0][:, c],
                        "time_of_max_torsional_moment": hi[1][:, c].copy(),
                        "min_torsional_moment": e * lo[0][:, c],
                        "time_of_min_torsional_moment": lo[1][:, c].copy()})
        return out

    def _effect_channels(self) -> dict[str, np.ndarray]:
        """Kernel channel of each load-effect envelope's columns (see
        :class:`~vsi_numba.solver.pack.LoadEffectTables`)."""
        e = self.effects
        n_s, k = e.n_sections, np.arange(e.n_supports)
        return {"bending_moment": e.point_index, "shear_force": n_s + e.point_index,
                "bending_moment_whole_deck": e.grid_index,
                "shear_force_whole_deck": n_s + e.grid_index,
                "support_reaction": 2 * n_s + k, "end_rotation": 2 * n_s + e.n_supports + k}

    def _effect_envelopes(self) -> dict[str, np.ndarray]:
        """Load-effect envelopes (:data:`vsi_numba.io.schema.LOAD_EFFECTS`); zero
        columns when the load effects were not computed."""
        from vsi_numba.io.schema import LOAD_EFFECTS

        n_r = self.speeds.size
        if self.effects is None:
            return {f"{pre}{ext}_{name}": np.zeros((n_r, 0)) for name in LOAD_EFFECTS
                    for ext in ("max", "min") for pre in ("", "time_of_")}
        red = self.red
        data = {}
        for name, cols in self._effect_channels().items():
            data[f"max_{name}"] = red.le_max[:, cols]
            data[f"min_{name}"] = red.le_min[:, cols]
            data[f"time_of_max_{name}"] = red.le_max_t[:, cols]
            data[f"time_of_min_{name}"] = red.le_min_t[:, cols]
        return data

    def effect_histories(self, r: int, mirror: float | None = None,
                         static=None) -> dict[str, np.ndarray]:
        """Load-effect histories of run ``r`` (which must have a slot), by the same
        mode-acceleration formula as the kernel but from the stored modal coordinates,
        modal forces and contact forces (:func:`effect_series`): ``bending_moment``,
        ``shear_force`` (time, point), ``support_reaction``, ``rotation`` (time,
        support), and ``torsional_moment`` (time, point) when the :class:`SpaceLayout`
        has it (:func:`torsional_moment_tables`).  Empty when the load effects were not
        computed.  ``mirror``: the run went over the deck seen from its far end (a train
        in -x), its loads stand at ``mirror - x``; ``static``: the static deck (default
        the run's)."""
        e = self.effects
        h = int(self.slots[r])
        if e is None or h < 0:
            return {}
        pk = self.packed
        n = int(self.n_steps[r]) + 1
        t = np.arange(n) * pk.params.dt
        veh = pk.kernel_vehicles  # the forces on the deck (distributed moving forces)
        x0 = np.concatenate([veh.wheel_x0, veh.load_x0])
        force = np.concatenate([self.out.X[h, :n],
                                np.broadcast_to(veh.load_p, (n, veh.load_p.size))], axis=1)
        x = x0[None, :] + self.speeds[r] * t[:, None]  # (n, n_load)
        if mirror is not None:
            x = mirror - x
        c = self.out.q[h, :n] - self.out.fq[h, :n] * e.w2inv  # q - F / w^2
        chan = self._effect_channels()
        out = effect_series(e, self.static_deck if static is None else static, x, force, c,
                            chan)
        sp = self.space
        if sp is not None and sp.channels is not None and np.any(sp.channels.torque >= 0):
            if mirror is None:  # the run's own train (not offered for the others)
                out["torsional_moment"] = self.space_series(r)[:, sp.channels.torque]
        elif sp is not None and sp.torque_channel is not None and "shear_force" in out:
            # the torque channel: the same static shear (simply supported span), its own
            # modal part
            out["torsional_moment"] = sp.torque_scale * (
                out["shear_force"] + c @ (e.E[:, sp.torque_channel]
                                          - e.E[:, chan["shear_force"]]))
        if self.status[r] != ek.OK:
            for a in out.values():
                a[...] = np.nan
        return out

    def comfort_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Comfort points of the reported car bodies: (body index, m ahead of the centre
        of gravity), one entry per point (see ``VehicleArrays.body_pt_*``)."""
        veh = self.packed.vehicles
        body = np.repeat(np.arange(veh.body_dof.size), np.diff(veh.body_pt_start))
        return body, veh.body_pt_d.copy()

    def comfort_point_histories(self, r: int) -> np.ndarray:
        """Car-body acceleration (m s-2, positive down) at every comfort point of run
        ``r`` (which must have a slot), shape (time, point of :meth:`comfort_points`):
        CG bounce + d x pitch acceleration."""
        h = int(self.slots[r])
        if h < 0:
            raise ValueError(f"run {r} kept no histories")
        n = int(self.n_steps[r]) + 1
        body, d = self.comfort_points()
        return self.out.body_acc[h, :n][:, body] + d * self.out.body_pitch[h, :n][:, body]

    def histories(self, r: int) -> dict[str, np.ndarray]:
        """Time histories of run ``r`` (which must have a slot): deck at the points,
        contact forces and flags of every wheel (moving forces included), car bodies."""
        h = int(self.slots[r])
        if h < 0:
            raise ValueError(f"run {r} kept no histories")
        pk = self.packed
        n = int(self.n_steps[r]) + 1
        q, qdd = self.out.q[h, :n], self.out.qdd[h, :n]
        n_p = self.phi_d.shape[0] if self.space is None else self.space.n_points
        disp = q @ self.phi_d[:n_p].T
        keep = np.any(self.phi_a[:n_p] != 0.0, axis=0)
        acc = qdd[:, keep] @ self.phi_a[:n_p, keep].T
        n_l = pk.load_positions.size
        X = np.concatenate([self.out.X[h, :n], np.broadcast_to(pk.vehicles.load_p, (n, n_l))],
                           axis=1)
        contact = np.concatenate([self.out.contact[h, :n], np.ones((n, n_l), np.int8)], axis=1)
        body = self.out.body_acc[h, :n].copy()
        space = self._space_histories(q, qdd, r)
        if self.status[r] != ek.OK:
            for a in (disp, acc, X, body, *space.values()):
                a[...] = np.nan
        return {"deck_displacement": disp, "deck_acceleration": acc, "contact_force": X,
                "in_contact": contact, "carbody_acceleration": body,
                **self.effect_histories(r), **space}

    def space_series(self, r: int, mirror: float | None = None,
                     y_load: float | None = None) -> np.ndarray:
        """The deck-in-space channels of run ``r`` (which must have a slot) by the
        kernels' mode-acceleration formula (:mod:`vsi_numba.solver.space_effects`), from
        the stored modal coordinates, modal forces and contact forces: (time, channel).
        ``mirror``: the run went over the deck seen from its far end (its loads stand
        at ``mirror - x``); ``y_load``: the eccentricity of its track (default the
        loaded track's)."""
        ch = self.space.channels
        h = int(self.slots[r])
        pk = self.packed
        n = int(self.n_steps[r]) + 1
        t = np.arange(n) * pk.params.dt
        veh = pk.kernel_vehicles
        x0 = np.concatenate([veh.wheel_x0, veh.load_x0])
        force = np.concatenate([self.out.X[h, :n],
                                np.broadcast_to(veh.load_p, (n, veh.load_p.size))], axis=1)
        x = x0[None, :] + self.speeds[r] * t[:, None]
        if mirror is not None:
            x = mirror - x
        return ch.series(self.out.q[h, :n], self.out.fq[h, :n], x, force,
                         float(self.speeds[r]), y_load)

    def _space_histories(self, q: np.ndarray, qdd: np.ndarray,
                         r: int | None = None) -> dict[str, np.ndarray]:
        """Histories along the tracks (:data:`vsi_numba.io.schema.SPACE_HISTORIES`) from
        the modal coordinates ``q`` and accelerations ``qdd`` (time, mode) and the rows
        of :func:`space_operators`; none for a planar deck."""
        sp = self.space
        if sp is None:
            return {}
        n = q.shape[0]
        d, a = sp.split(self.phi_d.T), sp.split(self.phi_a.T)  # blocks (n_m, n_k, ...)
        out = {"track_displacement": np.einsum("tm,mkp->tkp", q, d["track"]),
               "track_acceleration": np.einsum("tm,mkp->tkp", qdd, a["track"])}
        if sp.has_twist:
            out["deck_twist"] = np.einsum("tm,mkp->tkp", q, d["twist"])
        ch = sp.channels
        if ch is not None and r is not None and self.out.fq.shape[0] > 0:
            c = self.space_series(r)
            out["track_displacement"] = c[:, ch.track]
            if sp.has_twist:
                out["deck_twist"] = c[:, ch.twist[:, :sp.n_points]]
        return {k: v.reshape(n, sp.n_tracks, sp.n_points) for k, v in out.items()}


def effect_series(e: LoadEffectTables, static, x: np.ndarray, force: np.ndarray,
                  c: np.ndarray, chan: dict) -> dict[str, np.ndarray]:
    """Load-effect histories by the mode-acceleration formula: the static effect of the
    forces ``force`` at ``x`` (both (n, n_load); from
    :func:`vsi_numba.model.influence.influence` of the ``static`` deck) plus ``c @ E``,
    ``c`` = q - F / w^2 (n, n_m); ``chan``: :meth:`BatchResult._effect_channels`.
    Returns ``bending_moment``, ``shear_force`` (n, point), ``support_reaction``,
    ``rotation`` (n, support)."""
    from vsi_numba.model.influence import influence

    n = x.shape[0]
    points = e.sections[e.point_index]
    k = np.arange(e.n_supports)
    # only the (step, load) pairs with a force on the deck: a load is on a short deck
    # for a few per cent of a long train's steps
    step, load = np.nonzero((x >= e.supports[0]) & (x <= e.supports[-1]) & (force != 0.0))
    xs, fs = x[step, load], force[step, load]
    out = {}
    for name, effect, at, cols in (
            ("bending_moment", "moment", points, chan["bending_moment"]),
            ("shear_force", "shear", points, chan["shear_force"]),
            ("support_reaction", "reaction", k, chan["support_reaction"]),
            ("rotation", "rotation", k, chan["end_rotation"])):
        if effect not in e.channels:
            continue
        g = influence(static, effect, at, xs) * fs  # (len(at), pairs)
        total = np.stack([np.bincount(step, weights=row, minlength=n) for row in g],
                         axis=1) if len(at) else np.zeros((n, 0))
        out[name] = total + c @ e.E[:, cols]
    return out


def run_batch(packed: Packed, profile: Profile, speeds, points, settings: SolverSettings,
              bridge: ModalBridge, keep_histories=None, deck=None,
              _ensure: bool = True, _kernel=None) -> BatchResult:
    """Run one packed model at several speeds (m/s) in one kernel call.

    Parameters
    ----------
    packed : Packed
        From :func:`pack` (any speed: only its speed-independent arrays are used).
    profile : Profile
        The irregularity the model was packed with (for the initial states).
    speeds : array_like
        Speeds (m/s), one run each.
    points : array_like
        Deck output points (m).
    keep_histories : array_like of bool, optional
        Per run: keep its raw histories (default: none).
    deck : tuple, optional
        ``deck_operators(bridge, points, settings)`` when already computed; a 3-tuple
        ``(phi_d, phi_a, cutoff)`` has no whole-deck grid (its envelopes are NaN).
    _ensure : bool
        First have the family's kernels compiled once per machine
        (:func:`~vsi_numba.solver.kernel_cache.ensure_compiled`); False inside that.
    _kernel : callable, optional
        Called with the kernel's arguments instead of running the batch (returns None):
        the tests read the arguments a study gives the kernels.
    """
    speeds = np.ascontiguousarray(np.atleast_1d(np.asarray(speeds, float)))
    if np.any(~(speeds > 0)):
        raise ModelError(f"speed = {speeds[~(speeds > 0)][0]!r} m/s: expected > 0")
    n_r = speeds.size
    keep = np.zeros(n_r, bool) if keep_histories is None else np.asarray(keep_histories, bool)
    n_steps = np.array([packed.n_steps(v) for v in speeds], np.int64)
    deck = deck if deck is not None else deck_operators(bridge, points, settings)
    phi_d, phi_a, cutoff = deck[:3]
    grid_x, phi_g = (deck[3], deck[4]) if len(deck) > 3 else (np.zeros(0), np.zeros((0, 0)))
    eff = deck[5] if len(deck) > 5 else None
    grid_x = np.ascontiguousarray(grid_x, dtype=np.float64)
    phi_g = (np.ascontiguousarray(phi_g, dtype=np.float64) if grid_x.size
             else np.zeros((0, 0)))
    veh = packed.kernel_vehicles
    n_m, n_v, n_w = packed.bridge.omega.size, packed.n_dof, veh.wheel_dof.size
    n_b = veh.body_dof.size
    n_p = phi_d.shape[0]
    slots = np.full(n_r, -1, np.int64)
    slots[keep] = np.arange(int(keep.sum()))
    n_t = int(n_steps[keep].max()) + 1 if keep.any() else 0
    out = _history_buffers(int(keep.sum()), n_t, n_m, n_w, n_b, eff is not None)
    z = np.zeros
    red = ek.Reduce(
        phi_d=phi_d, phi_a=phi_a,
        disp=z((n_r, n_p)), disp_t=z((n_r, n_p)), acc=z((n_r, n_p)), acc_t=z((n_r, n_p)),
        xmin=z((n_r, n_w)), xmin_x=z((n_r, n_w)), xmax=z((n_r, n_w)),
        body=z((n_r, n_b)), body_t=z((n_r, n_b)), body_x=z((n_r, n_b)),
        body_end=np.full((n_r, n_b), np.nan), body_end_t=np.full((n_r, n_b), np.nan),
        body_end_x=np.full((n_r, n_b), np.nan),
        lost=z((n_r, n_w), np.int64), longest=z((n_r, n_w), np.int64),
        events=z((n_r, n_w), np.int64), single=z((n_r, n_w), np.int64),
        run_len=z(n_w, np.int64), iters=z(n_r, np.int64),
        phi_g=phi_g, phi_gmax=np.abs(phi_g).max(axis=1, initial=0.0) * (1.0 + 1e-12),
        gacc=z(n_r), gacc_t=z(n_r), gacc_i=z(n_r, np.int64),
        gwork=z(grid_x.size),
        **_effect_fields(eff, packed, n_r),
        **_space_fields(deck, eff, speeds, n_r),
    )
    init = initial_states(packed, profile, speeds)
    st = ek.State(*(np.empty_like(a[0]) for a in init))
    bk = ek.State(*(np.empty_like(a[0]) for a in init))
    wk = _workspace(n_m, n_v, n_w, veh)
    status = np.zeros(n_r, np.int64)
    reached = np.zeros(n_r, np.int64)
    if _kernel is not None:
        _kernel(packed.bridge, veh, packed.profile, packed.params, speeds, n_steps, init,
                st, bk, wk, red, out, slots, status, reached)
        return None
    if _ensure:  # compiled once per machine (another process compiling: wait)
        compile_family(kernel_cache.family_of(packed))
    t0 = _time.perf_counter()
    driver.run_batch(packed.bridge, veh, packed.profile, packed.params, speeds, n_steps, init,
                 st, bk, wk, red, out, slots, status, reached)
    elapsed = _time.perf_counter() - t0
    _flag_non_finite(status, reached, n_steps, slots, red, out)
    return BatchResult(packed, speeds, n_steps, status, reached, slots, red, out, phi_d,
                       phi_a, cutoff, elapsed, np.asarray(grid_x, float), eff,
                       bridge.static if eff is not None else None,
                       deck[6] if len(deck) > 6 else None)


def _space_fields(deck: tuple, eff, speeds, n_r: int) -> dict:
    """The deck-in-space fields of :class:`~vsi_numba.kernels.types.Reduce` (the
    ``SpaceLayout``'s channels, with the load effects on; none: off)."""
    from vsi_numba.solver.space_effects import kernel_fields

    layout = deck[6] if len(deck) > 6 else None
    if eff is None or layout is None:
        return {}
    return kernel_fields(layout.channels, speeds, n_r)


def _effect_fields(eff: LoadEffectTables | None, packed: Packed, n_r: int) -> dict:
    """The load-effect fields of :class:`~vsi_numba.kernels.types.Reduce` (none: off)."""
    if eff is None:
        return {}
    f64 = np.float64
    n_c = eff.E.shape[1]
    veh = packed.kernel_vehicles
    n_load = veh.load_x0.size + veh.wheel_dof.size
    c = np.ascontiguousarray
    return dict(
        le_sup=c(eff.supports, f64), le_L=c(eff.spans, f64), le_Linv=1.0 / eff.spans,
        le_c6=1.0 / (6.0 * eff.EI * eff.spans), le_xi=c(eff.X / eff.spans[eff.span], f64),
        le_A=c(eff.A, f64), le_B=c(eff.B, f64), le_X=c(eff.X, f64),
        le_sec0=c(np.searchsorted(eff.span, np.arange(eff.spans.size + 1)), np.int64),
        le_E=c(eff.E, f64), le_w2inv=c(eff.w2inv, f64),
        le_order=c(np.argsort(veh.load_x0, kind="stable"), np.int64),
        le_val=np.zeros(n_c), le_Ms=np.zeros(eff.n_supports),
        le_acc=np.zeros((4, eff.spans.size)), le_lx=np.zeros(n_load),
        le_lp=np.zeros(n_load), le_ls=np.zeros(n_load, np.int64),
        le_max=np.full((n_r, n_c), -np.inf), le_max_t=np.zeros((n_r, n_c)),
        le_min=np.full((n_r, n_c), np.inf), le_min_t=np.zeros((n_r, n_c)),
    )


#: Largest magnitude a result may have: histories are stored as float32.
_STORABLE = float(np.finfo(np.float32).max)


def _flag_non_finite(status, reached, n_steps, slots, red, out) -> None:
    """Flag ``non_finite_state`` for the runs the kernel passed as ok whose envelopes or
    histories are not finite or beyond the float32 range of the results file (the
    kernel's check covers the state, not the outputs derived from it, e.g. the deck
    response to a 1e300 N force)."""
    envelopes = (red.disp, red.acc, red.xmin, red.xmax, red.body)
    for r in np.flatnonzero(status == ek.OK):
        bad = any(not np.all(np.abs(a[r]) <= _STORABLE) for a in envelopes)
        step = int(n_steps[r])
        h = int(slots[r])
        if h >= 0:
            n = step + 1
            rows = np.zeros(n, bool)
            for a in (out.q, out.qdd, out.X, out.body_acc):
                v = a[h, :n].reshape(n, -1)
                rows |= ~np.all(np.abs(v) <= _STORABLE, axis=1)
            if rows.any():
                bad, step = True, int(np.argmax(rows))
        if bad:
            status[r] = ek.NON_FINITE
            reached[r] = step


def run_kernel(packed: Packed, profile: Profile):
    """Run the time loop at the packed speed, keeping the raw histories.

    Returns (status, step reached, Output of that one run, elapsed seconds).
    """
    bridge_points = np.zeros((0, packed.bridge.omega.size))
    res = _run_packed(packed, profile, bridge_points)
    out = ek.Output(*(a[0] if a.shape[0] else a.reshape(a.shape[1:]) for a in res.out))
    return int(res.status[0]), int(res.reached[0]), out, res.elapsed


def _run_packed(packed, profile, phi):
    """One run with histories and given deck operators (no bridge object needed)."""
    return run_batch(packed, profile, [packed.params.speed], np.zeros(0),
                     SolverSettings(dt=packed.params.dt), None, keep_histories=[True],
                     deck=(phi, phi, float("nan")))


def compile_family(family: str) -> tuple[str, float]:
    """Have ``family``'s kernels compiled (or loaded from the cache) in this process, once
    per machine (:func:`~vsi_numba.solver.kernel_cache.ensure_compiled`): a tiny batch of
    the family, whose kernel arguments have the types of every study's.  Returns
    (``"ready"``, ``"loaded"`` or ``"compiled"``, seconds)."""
    t0 = _time.perf_counter()
    how = kernel_cache.ensure_compiled(family, lambda: _tiny_batch(family))
    return how, _time.perf_counter() - t0


def _tiny_batch(family: str) -> None:
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.model.vehicle import Train
    from vsi_numba.solver.pack import pack

    beam = br.simply_supported(10.0, 1e9, 1e4, n_modes=2)
    if family == "moving_force":
        unit = vh.point_loads([0.0, 3.0], [1e5, 1e5], name="tiny")
    else:
        unit = vh.sprung_mass(1e3, 1e6, 1e3, 100.0)
    settings = SolverSettings(dt=5e-3, approach=0.0, free_vibration=0.0)
    profile = no_irregularity()
    packed = pack(beam, Train("tiny", (unit,), (0.0,)), 50.0, profile, settings)
    run_batch(packed, profile, [50.0], [5.0], settings, beam, _ensure=False)
