"""Several trains in one run: the run's train on its track and trains on other tracks
(``train.other_trains``): the run's train or one of their own, at the run's speed or one
of their own, same or opposite direction, each with a start offset.

The kernels run one train per run.  The deck is linear and moving forces are prescribed,
so the response to several trains is the sum of the responses to each: every train is
run on its own track line (a train in -x on the deck seen from its far end,
:func:`vsi_numba.model.bridge.reversed_bridge`, whose modal coordinates are the deck's
own), at its own speed over the run's train's time grid (the run lasts until the last
train has left, :attr:`~vsi_numba.solver.pack.Packed.other_runs`), with its modal
histories kept; their sum is the deck's
response to all of them, exact to round-off.  The envelopes with every train loaded
(:data:`vsi_numba.io.schema.ALL_TRACKS`) are reduced from the summed histories as the
kernels reduce a run's: first time (and point) of the largest |value|.  Interaction
trains are refused by the configuration: their wheels and the deck interact, and runs of
separate trains do not add up.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.io.schema import ALL_TRACKS_SUFFIX
from vsi_numba.solver.batch import run_batch
from vsi_numba.solver.operators import DeckOperators
from vsi_numba.solver.pack import Packed
from vsi_numba.solver.reductions import (
    first_absargmax,
    first_absmax,
    first_max_min_of_sum,
)
from vsi_numba.solver.results import BatchResult


@dataclass(frozen=True)
class OtherTrain:
    """A train on another track: its packed model (the bridge it runs on is its track's
    line, reversed for ``reversed``) and where its loads stand on the deck."""

    packed: Packed
    reversed: bool  # runs in -x: its loads stand at length - x
    length: float  # m, the deck's length (the mirror of a reversed run)
    track: int = -1  # 0-based index of its track in bridge.tracks (-1: not known)
    speed_factor: float = 1.0  # its speed: this times the run's speed ...
    speed: float = 0.0  # ... or this speed (m/s) in every run (0: the factor's)

    def speeds(self, speeds) -> np.ndarray:
        """Its speed (m/s) in the runs of the run's train at ``speeds`` (m/s)."""
        v = np.asarray(speeds, float)
        return np.full(v.shape, self.speed) if self.speed > 0.0 else self.speed_factor * v

    @property
    def own_run(self) -> bool:
        """Whether it runs at a speed other than the run's train's (its runs' time grid
        is then the run's train's, :attr:`Packed.other_runs`)."""
        return self.speed > 0.0 or self.speed_factor != 1.0


def shifted(packed: Packed, offset: float) -> Packed:
    """``packed`` starting ``offset`` m further back (it enters the deck offset / v
    later), its run ``offset`` m longer."""
    if offset == 0.0:
        return packed

    def back(v):
        return None if v is None else v._replace(
            load_x0=np.ascontiguousarray(v.load_x0 - offset),
            wheel_x0=np.ascontiguousarray(v.wheel_x0 - offset))

    return dataclasses.replace(packed, vehicles=back(packed.vehicles),
                               distributed=back(packed.distributed),
                               run_length=packed.run_length + offset)


def run_with_others(packed: Packed, profile, speeds, points, settings, bridge,
                    others: list[OtherTrain], deck: DeckOperators
                    ) -> tuple[BatchResult, dict[str, np.ndarray]]:
    """Run the run's train and every other train over one time grid.

    Returns the run's :class:`BatchResult` (its own envelopes: one track loaded; it
    keeps the histories of every run: write those asked for only) and the envelopes
    with every train loaded (:func:`all_tracks_envelopes`).
    """
    every = np.ones(np.size(speeds), bool)
    deck = DeckOperators.of(deck)
    main = run_batch(packed, profile, speeds, points, settings, bridge,
                     keep_histories=every, deck=deck)
    # the other trains' runs give their modal histories only (their own envelopes are
    # not results): no output rows, whole-deck grid, load effects or channels for the
    # kernels to reduce; their histories are read with the run's tables
    n_m = deck.phi_d.shape[1]
    bare = DeckOperators(np.zeros((0, n_m)), np.zeros((0, n_m)), deck.cutoff)
    # each over the run's train's time grid (its steps), at its own speed
    runs = [dataclasses.replace(
        run_batch(o.packed, profile, o.speeds(speeds), points, settings, bridge,
                  keep_histories=every, deck=bare, modal_forces=main.effects is not None,
                  n_steps=main.n_steps),
        phi_d=main.phi_d, phi_a=main.phi_a, grid_x=main.grid_x, effects=main.effects,
        static_deck=main.static_deck, space=main.space) for o in others]
    env = all_tracks_envelopes(main, [(r, o) for r, o in zip(runs, others, strict=True)],
                               deck)
    main.elapsed += sum(r.elapsed for r in runs)  # the kernel time of every train
    return main, env


def _first_max(a: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest |a| over axis 0 and the time of its first occurrence."""
    value, i = first_absmax(a)
    return value, t[i]


def _rows(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` (n_runs, k) widened to ``n`` columns with NaN (rows not computed, whose
    values come from elsewhere)."""
    if a.shape[1] == n:
        return a
    out = np.full((a.shape[0], n), np.nan)
    out[:, :a.shape[1]] = a
    return out


def summed_channels(main: BatchResult, others: list[tuple[BatchResult, OtherTrain]],
                    r: int) -> np.ndarray:
    """The deck-in-space channels (time, channel) of run ``r`` with every train loaded:
    ``main.space_series(r)`` plus each other train's ``space_series`` on its track
    (mirrored for a train in -x), summed train by train in one pass each
    (:func:`~vsi_numba.kernels.superposed.channel_sum`, the same operations)."""
    from vsi_numba.kernels.superposed import channel_sum

    space = main.space
    ch = space.channels
    if ch.per_line:  # each load on its own track line: the histories' formula
        c = main.space_series(r)
        for res, o in others:
            c += res.space_series(r, mirror=o.length if o.reversed else None,
                                  y_load=float(space.eccentricity[o.track]))
        return c
    f64 = np.float64
    sup = np.ascontiguousarray(ch.supports, f64)
    linv = 1.0 / np.diff(sup)
    cx, coef = np.ascontiguousarray(ch.X, f64), np.ascontiguousarray(ch.coef, f64)
    ss, st = np.zeros(2 * ch.sections.size), np.zeros(ch.n_channels)
    acc = None
    for res, o in [(main, None), *others]:
        h = int(res.slots[r])
        n = int(res.n_steps[r]) + 1
        pk = res.packed
        veh = pk.kernel_vehicles
        speed = float(res.speeds[r])
        x0 = np.ascontiguousarray(np.concatenate([veh.wheel_x0, veh.load_x0]), f64)
        v = np.ascontiguousarray(np.concatenate([veh.wheel_sf, veh.load_sf]) * res.speeds[r],
                                 f64)
        q, fq = res.out.q[h, :n], res.out.fq[h, :n]
        fq_ef = fq @ ch.Ef  # the products of SpaceChannels.series, as they are there
        q_eq = q @ ch.Eq
        y = ch.y_load if o is None else float(space.eccentricity[o.track])
        mirror = o.length if o is not None and o.reversed else -1.0
        d = float(ch.speed_factor([speed])[0][0])
        lx, lp = np.zeros(x0.size), np.zeros(x0.size)
        first = acc is None
        acc = channel_sum(fq_ef if first else acc, first, fq_ef, q_eq, x0, v,
                          np.ascontiguousarray(res.out.X[h, :n], f64),
                          np.ascontiguousarray(veh.load_p, f64), float(mirror), float(y), d,
                          float(pk.params.dt), sup, linv, cx, ch.sec0, ch.ptr, ch.idx, coef,
                          lx, lp, ss, st)
        del fq_ef, q_eq  # (the first train's fq_ef is acc) before the next's products
    return acc


def all_tracks_envelopes(main: BatchResult, others: list[tuple[BatchResult, OtherTrain]],
                         deck: DeckOperators) -> dict[str, np.ndarray]:
    """Envelopes of the summed response of ``main`` and ``others`` (every run of each
    kept its histories), named with :data:`~vsi_numba.io.schema.ALL_TRACKS_SUFFIX`: the
    deck at the output points, the whole-deck acceleration, the per-track rows (deck in
    space) and the load effects at the points and supports.  NaN rows where a run of
    any train failed."""
    phi_d, phi_a = main.phi_d, main.phi_a
    deck = DeckOperators.of(deck)
    n_ka = deck.phi_g.shape[0] if deck.n_grid else 0
    phi_g = np.asarray(deck.phi_g) if n_ka else np.zeros((0, 0))
    grid = np.asarray(deck.grid_x, float) if n_ka else np.zeros(0)
    space = main.space
    n_p = phi_d.shape[0] if space is None else space.n_points
    keep_a = np.any(phi_a != 0.0, axis=0)
    n_r = main.speeds.size
    dt = main.packed.params.dt
    rows_d, rows_dt, rows_a, rows_at = [], [], [], []
    # the displacement rows along the tracks and of the twist are the channels' when the
    # deck has them (mode acceleration, below): only the deck's output points then
    with_channels = space is not None and space.channels is not None
    phi_dr = phi_d[:n_p] if with_channels else phi_d
    gacc, gacc_t, gacc_x = np.full(n_r, np.nan), np.full(n_r, np.nan), np.full(n_r, np.nan)
    effects: dict[str, list] = {}
    chan: list[tuple] = []  # the deck-in-space channels' |max| and its time, per run
    # the load effects every train adds to (the torsional moment is the run's train's)
    names = {"bending_moment": "bending_moment", "shear_force": "shear_force",
             "support_reaction": "support_reaction", "rotation": "end_rotation",
             "bending_moment_whole_deck": "bending_moment_whole_deck",
             "shear_force_whole_deck": "shear_force_whole_deck"}
    for r in range(n_r):
        n = int(main.n_steps[r]) + 1
        t = np.arange(n) * dt
        h = int(main.slots[r])
        q = main.out.q[h, :n].copy()
        qdd = main.out.qdd[h, :n].copy()
        for res, _o in others:
            g = int(res.slots[r])
            q += res.out.q[g, :n]
            qdd += res.out.qdd[g, :n]
        d, dtime = _first_max(q @ phi_dr.T, t)
        a, atime = _first_max(qdd[:, keep_a] @ phi_a[:, keep_a].T, t)
        rows_d.append(d)
        rows_dt.append(dtime)
        rows_a.append(a)
        rows_at.append(atime)
        if n_ka:
            gmax, k = first_absargmax(qdd[:, :n_ka] @ phi_g)  # (n, n_g) flattened
            gacc[r], gacc_t[r], gacc_x[r] = gmax, t[k // grid.size], grid[k % grid.size]
        if main.effects is not None:
            # (the torque is the channels' below: not computed here)
            series = main.effect_histories(r, whole=True, torque=False)
            series = {k: v for k, v in series.items() if k in names}
            last = None  # the last train's histories, added in the reduction
            for res, o in others:
                if last is not None:
                    for k, v in series.items():
                        v += last[k]
                last = res.effect_histories(r, mirror=o.length if o.reversed else None,
                                            static=main.static_deck, whole=True)
            for name, v in series.items():
                hi, hi_i, lo, lo_i = first_max_min_of_sum(
                    v, None if last is None else last[name])
                effects.setdefault(name, []).append((hi, t[hi_i], lo, t[lo_i]))
        ch = space.channels if space is not None else None
        if ch is not None:  # twist and track displacement by mode acceleration, summed
            c = summed_channels(main, others, r)
            b, bt = _first_max(c, t)
            tq = np.concatenate([ch.torque[ch.torque >= 0], ch.torque_grid])
            hi, hi_i, lo, lo_i = (first_max_min_of_sum(c, None, tq) if tq.size
                                  else (np.zeros(0),) * 4)
            chan.append((b, bt, (hi, t[hi_i], lo, t[lo_i]) if tq.size else None))
    stack = np.array
    out = {"max_deck_displacement": stack(rows_d)[:, :n_p],
           "time_of_max_deck_displacement": stack(rows_dt)[:, :n_p],
           "max_deck_acceleration": stack(rows_a)[:, :n_p],
           "time_of_max_deck_acceleration": stack(rows_at)[:, :n_p],
           "max_deck_acceleration_whole_deck": gacc,
           "time_of_max_deck_acceleration_whole_deck": gacc_t,
           "position_of_max_deck_acceleration_whole_deck": gacc_x}
    if space is not None:
        d, dtime = (space.split(_rows(stack(v), phi_d.shape[0])) for v in (rows_d, rows_dt))
        a, atime = space.split(stack(rows_a)), space.split(stack(rows_at))
        out.update({"max_track_displacement": d["track"],
                    "time_of_max_track_displacement": dtime["track"],
                    "max_track_acceleration": a["track"],
                    "time_of_max_track_acceleration": atime["track"]})
        if space.has_twist:
            out.update({"max_deck_twist": d["twist"], "time_of_max_deck_twist": dtime["twist"],
                        "max_deck_twist_whole_deck": d["twist_whole"],
                        "time_of_max_deck_twist_whole_deck": dtime["twist_whole"]})
        if chan:
            ch, n_p = space.channels, space.n_points
            b, bt = stack([c[0] for c in chan]), stack([c[1] for c in chan])
            out.update({"max_track_displacement": b[:, ch.track],
                        "time_of_max_track_displacement": bt[:, ch.track]})
            if space.has_twist:
                out.update({"max_deck_twist": b[:, ch.twist[:, :n_p]],
                            "time_of_max_deck_twist": bt[:, ch.twist[:, :n_p]],
                            "max_deck_twist_whole_deck": b[:, ch.twist[:, n_p:]],
                            "time_of_max_deck_twist_whole_deck": bt[:, ch.twist[:, n_p:]]})
            if chan[0][2] is not None:  # the torque: points, then the whole-deck grid
                n_tp = int(np.sum(ch.torque >= 0))
                parts = [stack([c[2][i] for c in chan]) for i in range(4)]
                for sfx, cols in (("", slice(0, n_tp)), ("_whole_deck", slice(n_tp, None))):
                    if sfx and not ch.torque_grid.size or not sfx and not n_tp:
                        continue
                    hi, hi_t, lo, lo_t = (a[:, cols] for a in parts)
                    out.update({f"max_torsional_moment{sfx}": hi,
                                f"time_of_max_torsional_moment{sfx}": hi_t,
                                f"min_torsional_moment{sfx}": lo,
                                f"time_of_min_torsional_moment{sfx}": lo_t})
        if space.grid_x.size and space.whole_from_deck:  # every track line is the axis
            out.update({f"{pre}max_track_acceleration_whole_deck": np.repeat(
                v[:, None], space.n_tracks, axis=1) for pre, v in (
                    ("", gacc), ("time_of_", gacc_t), ("position_of_", gacc_x))})
        elif space.grid_x.size:  # along each track line on the whole-deck grid
            g, gt = a["track_whole"], atime["track_whole"]
            i = np.argmax(g, axis=2)[..., None]
            out.update({"max_track_acceleration_whole_deck": np.take_along_axis(g, i, 2)[..., 0],
                        "time_of_max_track_acceleration_whole_deck":
                        np.take_along_axis(gt, i, 2)[..., 0],
                        "position_of_max_track_acceleration_whole_deck":
                        space.grid_x[i[..., 0]]})
    for name, rows in effects.items():
        stem = names[name]
        hi, hi_t, lo, lo_t = (stack([row[i] for row in rows]) for i in range(4))
        out.update({f"max_{stem}": hi, f"time_of_max_{stem}": hi_t,
                    f"min_{stem}": lo, f"time_of_min_{stem}": lo_t})
    failed = main.status != ek.OK
    for res, _o in others:
        failed |= res.status != ek.OK
    for v in out.values():
        v[failed] = np.nan
    return {k + ALL_TRACKS_SUFFIX: v for k, v in out.items()}
