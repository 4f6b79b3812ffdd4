"""What a batch gives back: the envelopes reduced in the time loop and the raw histories,
turned into the variables of the results file (:class:`BatchResult`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.solver.operators import SpaceLayout
from vsi_numba.solver.pack import LoadEffectTables, Packed

STATUS_MESSAGES = {
    ek.OK: "ok",
    ek.NOT_CONVERGED: "contact iterations did not converge (also with the step subdivided)",
    ek.SINGULAR_SCHUR: "singular contact (Schur) system: dependent contact constraints",
    ek.NON_FINITE: "non-finite (NaN/inf) state: the integration diverged",
    ek.SINGULAR_IMPACT: "singular impact system at a wheel landing",
}


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
        elif sp.grid_x.size and red.tw_acc.shape[1]:  # one envelope per track (tw_*)
            out.update({"max_track_acceleration_whole_deck": red.tw_acc.copy(),
                        "time_of_max_track_acceleration_whole_deck": red.tw_acc_t.copy(),
                        "position_of_max_track_acceleration_whole_deck":
                        sp.grid_x[red.tw_acc_i]})
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
            for c, sfx in ((ch.torque, ""), (ch.torque_grid, "_whole_deck")):
                if c.size and np.any(c >= 0):
                    out.update({f"max_torsional_moment{sfx}": red.cb_max[:, c],
                                f"time_of_max_torsional_moment{sfx}": red.cb_max_t[:, c],
                                f"min_torsional_moment{sfx}": red.cb_min[:, c],
                                f"time_of_min_torsional_moment{sfx}": red.cb_min_t[:, c]})
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
                         static=None, whole: bool = False,
                         torque: bool = True) -> dict[str, np.ndarray]:
        """Load-effect histories of run ``r`` (which must have a slot), by the same
        mode-acceleration formula as the kernel but from the stored modal coordinates,
        modal forces and contact forces (:func:`effect_series`): ``bending_moment``,
        ``shear_force`` (time, point), ``support_reaction``, ``rotation`` (time,
        support), and ``torsional_moment`` (time, point) when the :class:`SpaceLayout`
        has it (:func:`torsional_moment_tables`).  Empty when the load effects were not
        computed.  ``mirror``: the run went over the deck seen from its far end (a train
        in -x), its loads stand at ``mirror - x``; ``static``: the static deck (default
        the run's); ``whole``: also ``bending_moment_whole_deck`` and
        ``shear_force_whole_deck`` (time, deck_x) on the whole-deck grid; ``torque``
        False: without ``torsional_moment``."""
        e = self.effects
        h = int(self.slots[r])
        if e is None or h < 0:
            return {}
        pk = self.packed
        n = int(self.n_steps[r]) + 1
        t = np.arange(n) * pk.params.dt
        veh = pk.kernel_vehicles  # the forces on the deck (distributed moving forces)
        x0 = np.concatenate([veh.wheel_x0, veh.load_x0])
        sf = np.concatenate([veh.wheel_sf, veh.load_sf])  # each train's speed factor
        force = np.concatenate([self.out.X[h, :n],
                                np.broadcast_to(veh.load_p, (n, veh.load_p.size))], axis=1)
        x = x0[None, :] + (sf * self.speeds[r])[None, :] * t[:, None]  # (n, n_load)
        if mirror is not None:
            x = mirror - x
        c = self.out.q[h, :n] - self.out.fq[h, :n] * e.w2inv  # q - F / w^2
        chan = self._effect_channels()
        out = effect_series(e, self.static_deck if static is None else static, x, force, c,
                            chan, whole)
        sp = None if not torque else self.space
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
        sf = np.concatenate([veh.wheel_sf, veh.load_sf])
        force = np.concatenate([self.out.X[h, :n],
                                np.broadcast_to(veh.load_p, (n, veh.load_p.size))], axis=1)
        x = x0[None, :] + (sf * self.speeds[r])[None, :] * t[:, None]
        if mirror is not None:
            x = mirror - x
        line = (np.concatenate([veh.wheel_line, veh.load_line]) if ch.per_line
                else None)  # trains on several tracks: each load on its own line
        return ch.series(self.out.q[h, :n], self.out.fq[h, :n], x, force,
                         float(self.speeds[r]), y_load, line)

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
                  c: np.ndarray, chan: dict, whole: bool = False) -> dict[str, np.ndarray]:
    """Load-effect histories by the mode-acceleration formula: the static effect of the
    forces ``force`` at ``x`` (both (n, n_load); from
    :func:`vsi_numba.model.influence.influence` of the ``static`` deck) plus ``c @ E``,
    ``c`` = q - F / w^2 (n, n_m); ``chan``: :meth:`BatchResult._effect_channels`.
    Returns ``bending_moment``, ``shear_force`` (n, point), ``support_reaction``,
    ``rotation`` (n, support) and, with ``whole``, ``bending_moment_whole_deck``,
    ``shear_force_whole_deck`` (n, deck_x)."""
    from vsi_numba.model.influence import influences

    n = x.shape[0]
    points = e.sections[e.point_index]
    k = np.arange(e.n_supports)
    # only the (step, load) pairs with a force on the deck: a load is on a short deck
    # for a few per cent of a long train's steps
    step, load = np.nonzero((x >= e.supports[0]) & (x <= e.supports[-1]) & (force != 0.0))
    xs, fs = x[step, load], force[step, load]
    out = {}
    wanted = [(name, effect, at, cols) for name, effect, at, cols in (
        ("bending_moment", "moment", points, chan["bending_moment"]),
        ("shear_force", "shear", points, chan["shear_force"]),
        ("support_reaction", "reaction", k, chan["support_reaction"]),
        ("rotation", "rotation", k, chan["end_rotation"]),
        *((("bending_moment_whole_deck", "moment", e.sections[e.grid_index],
            chan["bending_moment_whole_deck"]),
           ("shear_force_whole_deck", "shear", e.sections[e.grid_index],
            chan["shear_force_whole_deck"])) if whole else ())) if effect in e.channels]
    # the moment and shear of a beam deck at the sections, load by load and summed step
    # by step in a kernel (the numpy formula's values, without its (section, pair)
    # arrays); the rest by the influence lines
    swept = static is not None and static.kind == "beam" and bool(step.size)
    jit = [w for w in wanted if swept and w[1] in ("moment", "shear") and len(w[2])]
    rest = [w for w in wanted if w not in jit]
    loads = None
    if jit:
        from vsi_numba.kernels.influence import beam_section_histories
        from vsi_numba.model.influence import beam_loads, beam_sections, check_effects

        check_effects(static, {w[1] for w in jit})
        loads = on, sl, a, b, ms = beam_loads(static, xs)
        # the moment and the shear at each section set of ``jit`` in one pass over the
        # pairs (each value the same sum as on its own), the sections on the deck by span
        fs64 = np.ascontiguousarray(fs, np.float64)
        done: dict = {}
        used: set = set()
        for name, effect, at, cols in jit:
            key = np.asarray(at, float).tobytes()
            if (key, effect) in used:  # the same effect at the same sections again
                done.pop(key, None)
                used -= {(key, "moment"), (key, "shear")}
            used.add((key, effect))
            if key not in done:
                sa, X, xi, inside = beam_sections(static, at)
                order = np.flatnonzero(inside)
                order = order[np.argsort(sa[order], kind="stable")]
                span0 = np.searchsorted(sa[order], np.arange(static.spans.size + 1))
                ordered = order.size == len(at) and bool(np.all(order == np.arange(len(at))))
                n_o = len(at) if ordered else order.size
                moment, shear = np.zeros((n, n_o)), np.zeros((n, n_o))
                xo = np.ascontiguousarray(xi[order])
                beam_section_histories(static.spans, span0, np.ascontiguousarray(X[order]),
                                       xo, 1.0 - xo, sl, a, b, ms, step, fs64, moment, shear)
                if not ordered:  # a section off the deck stays 0
                    for part in (moment, shear):
                        full = np.zeros((n, len(at)))
                        full[:, order] = part
                        done.setdefault(key, []).append(full)
                else:
                    done[key] = [moment, shear]
            total = done[key][0 if effect == "moment" else 1]
            total += c @ e.E[:, cols]
            out[name] = total
    lines = influences(static, [(effect, at) for _, effect, at, _ in rest], xs, loads)
    for (name, _, at, cols), line in zip(rest, lines, strict=True):
        g = line * fs  # (len(at), pairs)
        total = np.stack([np.bincount(step, weights=row, minlength=n) for row in g],
                         axis=1) if len(at) else np.zeros((n, 0))
        out[name] = total + c @ e.E[:, cols]
    return {name: out[name] for name, *_ in wanted}
