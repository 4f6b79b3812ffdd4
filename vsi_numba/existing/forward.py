"""Forward runs of a configuration with some of its keys set: the deck response at the
records' points, and the check's envelopes, for many parameter sets at once.

A parameter set is a row of values of the keys (``bridge.EI``, ``bridge.damping_ratio``,
...).  Each train of the records is packed once and run at all its speeds in one kernel
call (:func:`vsi_numba.solver.batch.run_batch`, the call a batch of the study engine
makes: the speeds are the batch axis of the kernel).

Two paths build the model of a row:

* **typed** (the fast path): the model is validated and packed once, at the
  configuration's own values; a row changes only the arrays the kernels read.  It is
  taken for the keys whose action on those arrays is exact for the deck in hand:
  ``bridge.damping_ratio`` (one value for every mode: the modal damping ratios, plus
  the additional damping), ``bridge.EI`` (the circular frequencies scale as
  ``sqrt(EI)``) and ``bridge.mass_per_length`` (frequencies as ``1 / sqrt(m)``, the
  mass-normalised mode shapes as ``1 / sqrt(m)``), for a train of moving forces on a
  deck of one bending stiffness and one mass (a simply supported span or a continuous
  deck, ``n_modes`` fixed).  Each law is checked once when the model is built: the
  model the configuration gives with the key at another value (the full path) must
  equal the law's to 1e-12, or the key takes the full path.  A row's values are checked
  against the key's physical bounds (``EI``, ``m`` > 0; ``0 <= zeta < 1``), not the
  plausibility ranges of the configuration's input (those catch unit slips in what a
  user writes: ``vsi check`` applies them at the distributions' central values).
* **full**: the configuration's mapping gets the values (the key paths of
  ``study.vary``, :func:`vsi_numba.config.variants._set_path`) and is validated as any
  configuration (a row the validation refuses is no model: its likelihood is zero),
  then packed: any numeric key, 10-20 ms a row more.

The rows of one call are cut into chunks of :data:`CHUNK_ROWS` (the same chunks
whatever runs them: :mod:`vsi_numba.existing.parallel`), so that what a chunk computes
is the same on every backend.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.config import ConfigError, load_config
from vsi_numba.config.existing import base_data, record_train_data
from vsi_numba.config.variants import _set_path

#: Rows of a chunk: the unit of work of the backends (a few kernel calls).
CHUNK_ROWS = 4
#: Relative agreement of a typed law with the full path, checked when a model is built.
LAW_RTOL = 1e-12
#: Keys with a typed law (see the module notes).
TYPED_KEYS = ("bridge.damping_ratio", "bridge.EI", "bridge.mass_per_length")


class ForwardError(ValueError):
    """A forward model that cannot be built (the message says why)."""


@dataclass(frozen=True)
class Group:
    """The runs of one train: its speeds (km/h), deck points (m) and track (1-based;
    None: the configuration's).  On a deck in space a group with a track runs its train
    on that track and reads its histories on that track's line (the points' shapes
    ``phi + y_k theta``)."""

    train: str | None  # None: the configuration's own train
    speeds_kmh: tuple[float, ...]
    points: tuple[float, ...]
    track: int | None = None


@dataclass(frozen=True)
class PointHistories:
    """Histories at deck points of a block of rows (:meth:`Forward.point_histories`)."""

    values: list  # per history wanted: (n_rows, n_t) m s-2 or m, zero past its length
    lengths: list  # per history wanted: (n_rows,) samples of each row's history
    errors: list  # per row: why it is no model ('' when it ran)


@dataclass
class RunResult:
    """The outputs of one parameter row for one group (None when the row failed)."""

    time: np.ndarray | None = None  # (n_t,) s, of the slowest speed
    displacement: list | None = None  # per speed: (n_t_i, n_points) m, positive down
    acceleration: list | None = None  # per speed: (n_t_i, n_points) m s-2, band-limited
    envelope_acc: np.ndarray | None = None  # (n_speeds,) max deck acceleration, whole deck
    envelope_disp: np.ndarray | None = None  # (n_speeds,) max deck displacement (points)
    cutoff: float = float("nan")
    frequencies: np.ndarray | None = None
    error: str = ""


def threads() -> int:
    """Threads of the forward runs: ``VSI_THREADS``, else the CPUs this process may use."""
    env = os.environ.get("VSI_THREADS")
    if env and env.isdigit() and int(env) > 0:
        return int(env)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _get_path(data: dict, key_path: str):
    """The value at ``key_path`` of a nested mapping (None when absent)."""
    import re

    node = data
    for part in key_path.split("."):
        m = re.match(r"^(\w+)(?:\[(\d+)\])?$", part)
        if m is None or not isinstance(node, dict) or m.group(1) not in node:
            return None
        node = node[m.group(1)]
        if m.group(2) is not None:
            if not isinstance(node, list) or int(m.group(2)) >= len(node):
                return None
            node = node[int(m.group(2))]
    return node


class _Model:
    """The validated, packed model of one group at the configuration's values."""

    def __init__(self, cfg, group: Group, histories: bool):
        from vsi_numba.model.irregularity import no_irregularity
        from vsi_numba.solver.batch import deck_grid, deck_operators
        from vsi_numba.solver.pack import pack

        self.cfg = cfg
        self.train = cfg.trains()[0]
        self.bridge = cfg.bridge_for(self.train)
        self.settings = cfg.solver_settings()
        self.speeds = np.asarray(group.speeds_kmh, float) / 3.6
        self.points = np.asarray(group.points, float)
        self.profile = no_irregularity()
        self.packed = pack(self.bridge, self.train, float(self.speeds[0]), self.profile,
                           self.settings)
        self.histories = histories
        # the deck operators at the points, and the whole deck's shapes on its grid
        # (envelopes only: the calibration's histories need none)
        self.deck = deck_operators(self.bridge, self.points, self.settings,
                                   load_effects=False)
        if histories:
            self.deck = self.deck[:3]
            self.grid_shapes = None
        else:
            gx = deck_grid(self.bridge, self.points)
            self.grid_x = gx
            self.grid_shapes = np.asarray(self.bridge.output_shapes(gx), float).reshape(
                gx.size, self.bridge.n_modes)
        self.point_shapes = np.ascontiguousarray(
            self.bridge.output_shapes(self.points), dtype=np.float64).reshape(
                self.points.size, self.bridge.n_modes)

    def deck_for(self, freqs: np.ndarray, shape_scale: float):
        """:func:`~vsi_numba.solver.batch.deck_operators` of the model with these
        frequencies and its shapes times ``shape_scale`` (the same arithmetic)."""
        from vsi_numba.solver.batch import acceleration_cutoff

        cutoff = self.settings.acceleration_cutoff
        if cutoff is None:
            cutoff = acceleration_cutoff(freqs)
        keep = np.asarray(freqs) <= cutoff + 1e-9
        phi_d = np.ascontiguousarray(self.point_shapes * shape_scale)
        phi_a = np.ascontiguousarray(np.where(keep[None, :], phi_d, 0.0))
        if self.histories:
            return phi_d, phi_a, float(cutoff)
        n_ka = int(np.flatnonzero(keep)[-1]) + 1 if keep.any() else 0
        gx = self.grid_x if n_ka else np.zeros(0)
        shapes = self.grid_shapes * shape_scale if n_ka else np.zeros((0, freqs.size))
        phi_g = np.ascontiguousarray(np.where(keep[None, :n_ka], shapes[:, :n_ka], 0.0).T)
        return phi_d, phi_a, float(cutoff), gx, phi_g, None


def _same(a, b) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= LAW_RTOL * np.maximum(
        np.abs(a), np.abs(b)) + 1e-300))


class Forward:
    """Forward model: a configuration's mapping, the keys set per row, the groups run.

    Parameters
    ----------
    data : dict
        The configuration's mapping (its own sections are left out of every run).
    base_dir : path-like
        Where its relative paths resolve.
    keys : sequence of str
        The key paths a row sets, in the order of its values.
    groups : sequence of Group
    histories : bool
        Keep the time histories (the calibration's records); False: envelopes only.
    typed : bool
        Take the typed path for the keys it has (False: the full path for every key).
    """

    def __init__(self, data: dict, base_dir, keys, groups, histories: bool = True,
                 typed: bool = True):
        self.data = base_data(data)
        self.base_dir = Path(base_dir)
        self.keys = list(keys)
        self.groups = list(groups)
        self.histories = histories
        self._data = [self._group_data(g) for g in self.groups]
        self.n_runs = 0
        self._models: list = [None] * len(self.groups)
        self._local = threading.local()  # each thread's kernel arguments
        self._typed = typed and bool(self.keys) and all(k in TYPED_KEYS for k in self.keys)
        self.typed_reason = "" if self._typed else (
            "not requested" if not typed else "a key without a typed law")
        if self._typed:
            self._typed = self._build_typed()

    def _group_data(self, g: Group) -> dict:
        if g.train is not None:
            return record_train_data(self.data, g.train, self.base_dir, g.track)
        d = self.data
        if g.track is not None:
            d = copy.deepcopy(d)
            d.setdefault("train", {})["track"] = int(g.track)
        return d

    # ------------------------------------------------------------------ typed path
    def _build_typed(self) -> bool:
        """Build each group's model at the configuration's values and check every law
        against the full path at another value; False (full path) when one fails."""
        self.base_values = {}
        for k in self.keys:
            v = _get_path(self.data, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(
                    float(v)):
                self.typed_reason = f"{k} is not one number in the configuration"
                return False
            self.base_values[k] = float(v)
        bridge = self.data.get("bridge", {})
        if any(k != "bridge.damping_ratio" for k in self.keys) and (
                bridge.get("kind") not in ("simply_supported", "continuous")
                or bridge.get("max_frequency") is not None or "track" in bridge
                or bridge.get("tracks") or bridge.get("torsion")):
            self.typed_reason = "a deck whose modes do not scale with EI and m"
            return False
        for i, g in enumerate(self.groups):
            try:
                cfg = load_config(self._data[i], base_dir=self.base_dir)
                model = _Model(cfg, g, self.histories)
            except (ConfigError, ValueError) as exc:
                raise ForwardError(_message(exc)) from None
            if model.packed.kernel_vehicles.wheel_dof.size or model.packed.n_dof:
                self.typed_reason = "a train with vehicle degrees of freedom"
                return False
            self._models[i] = model
            for k in self.keys:
                v0 = self.base_values[k]
                probe = v0 + 0.01 if k == "bridge.damping_ratio" else v0 * 1.1
                d = copy.deepcopy(self._data[i])
                _set_path(d, k, probe)
                try:
                    ref = load_config(d, base_dir=self.base_dir).bridge_for(model.train)
                except (ConfigError, ValueError):
                    self.typed_reason = f"{k} at {probe:g} is refused by the configuration"
                    return False
                law = self._law_bridge(model, {**self.base_values, k: probe})
                if not (_same(law.frequencies, ref.frequencies)
                        and _same(law.damping, ref.damping)
                        and _same(law.values, ref.values) and _same(law.slopes, ref.slopes)
                        and _same(law.output_shapes(model.points),
                                  ref.output_shapes(model.points))):
                    self.typed_reason = f"the model does not follow the law of {k}"
                    return False
        return True

    def _factors(self, values: dict) -> tuple[float, float, float]:
        """(frequency factor, damping change, shape factor) of a row's values."""
        f, dz, s = 1.0, 0.0, 1.0
        for k, v in values.items():
            v0 = self.base_values[k]
            if k == "bridge.damping_ratio":
                dz = v - v0
            elif k == "bridge.EI":
                f *= math.sqrt(v / v0)
            elif k == "bridge.mass_per_length":
                f *= math.sqrt(v0 / v)
                s *= math.sqrt(v0 / v)
        return f, dz, s

    def _law_bridge(self, model: _Model, values: dict):
        f, dz, s = self._factors(values)
        b = model.bridge
        return dataclasses.replace(
            b, frequencies=b.frequencies * f, damping=b.damping + dz, values=b.values * s,
            slopes=b.slopes * s,
            deck=None if b.deck is None else dataclasses.replace(
                b.deck, frequencies=b.deck.frequencies * f, values=b.deck.values * s,
                slopes=b.deck.slopes * s))

    @staticmethod
    def _bounds(values: dict) -> str:
        for k, v in values.items():
            if not math.isfinite(v):
                return f"{k} = {v!r}: expected a finite number"
            if k == "bridge.damping_ratio" and not 0.0 <= v < 1.0:
                return f"{k} = {v:g}: expected a damping ratio in [0, 1)"
            if k != "bridge.damping_ratio" and not v > 0.0:
                return f"{k} = {v:g}: expected > 0"
        return ""

    def _typed_parts(self, i: int, row):
        """(model, kernel bridge arrays, frequencies, shape factor) of a typed row, or
        (None, the reason the row is no model)."""
        values = {k: float(v) for k, v in zip(self.keys, row, strict=True)}
        bad = self._bounds(values)
        if bad:
            return None, bad
        m = self._models[i]
        f, dz, s = self._factors(values)
        br = m.packed.bridge
        zeta = br.zeta + dz
        if np.any(zeta < 0.0) or np.any(zeta >= 1.0):
            return None, f"bridge.damping_ratio = {values.get('bridge.damping_ratio')!r}: " \
                         "expected modal damping ratios in [0, 1)"
        arrays = br._replace(omega=np.ascontiguousarray(br.omega * f),
                             zeta=np.ascontiguousarray(zeta),
                             sine_amp=np.ascontiguousarray(br.sine_amp * s),
                             values=np.ascontiguousarray(br.values * s),
                             slopes=np.ascontiguousarray(br.slopes * s))
        return (m, arrays, m.bridge.frequencies * f, s), ""

    def _typed_row(self, i: int, row):
        built, bad = self._typed_parts(i, row)
        if built is None:
            return None, bad
        m, arrays, freqs, s = built
        packed = dataclasses.replace(m.packed, bridge=arrays)
        return (m, packed, m.deck_for(freqs, s), freqs), ""

    # ------------------------------------------------------------------- full path
    def _full_row(self, i: int, row):
        from vsi_numba.solver.batch import deck_operators
        from vsi_numba.solver.pack import pack

        d = copy.deepcopy(self._data[i])
        for k, v in zip(self.keys, row, strict=True):
            _set_path(d, k, float(v))
        cfg = load_config(d, base_dir=self.base_dir)
        m = _Model.__new__(_Model)
        from vsi_numba.model.irregularity import no_irregularity

        m.cfg, m.train = cfg, cfg.trains()[0]
        m.bridge = cfg.bridge_for(m.train)
        m.settings = cfg.solver_settings()
        g = self.groups[i]
        m.speeds = np.asarray(g.speeds_kmh, float) / 3.6
        m.points = np.asarray(g.points, float)
        m.profile = no_irregularity()
        m.histories = self.histories
        packed = pack(m.bridge, m.train, float(m.speeds[0]), m.profile, m.settings)
        deck = deck_operators(m.bridge, m.points, m.settings, load_effects=False)
        if self.histories:
            deck = deck[:3]
            if g.track is not None and cfg.deck_in_space is not None:
                # the record's point is on its track's line (phi + y_k theta), not on
                # the deck's axis that the deck outputs read
                phi_d = np.ascontiguousarray(m.bridge.shapes(m.points), dtype=np.float64)
                keep = np.asarray(m.bridge.frequencies) <= deck[2] + 1e-9
                deck = (phi_d, np.ascontiguousarray(np.where(keep[None, :], phi_d, 0.0)),
                        deck[2])
        return m, packed, deck, np.asarray(m.bridge.frequencies, float)

    # ------------------------------------------------------------------------ runs
    def run_row(self, row) -> list[RunResult]:
        """Run every group for one parameter row."""
        from vsi_numba.solver.batch import run_batch
        from vsi_numba.solver.pack import ModelError

        out = []
        for i in range(len(self.groups)):
            try:
                if self._typed:
                    built, bad = self._typed_row(i, row)
                    if built is None:
                        out.append(RunResult(error=bad))
                        continue
                else:
                    built = self._full_row(i, row)
                m, packed, deck, freqs = built
                speeds = m.speeds
                res = run_batch(packed, m.profile, speeds, m.points, m.settings, m.bridge,
                                keep_histories=np.full(speeds.size, self.histories),
                                deck=deck)
            except (ConfigError, ModelError, ValueError) as exc:
                out.append(RunResult(error=_message(exc)))
                continue
            self.n_runs += speeds.size
            if np.any(res.status != 0):
                r = int(np.flatnonzero(res.status != 0)[0])
                out.append(RunResult(error=res.message(r)))
                continue
            rr = RunResult(cutoff=float(res.cutoff), frequencies=freqs)
            if self.histories:
                # the deck rows of BatchResult.histories, without its other histories
                n_p = m.points.size
                phi_d, phi_a = res.phi_d[:n_p], res.phi_a[:n_p]
                rr.displacement, rr.acceleration = [], []
                for r in range(speeds.size):
                    h, n = int(res.slots[r]), int(res.n_steps[r]) + 1
                    rr.displacement.append(res.out.q[h, :n] @ phi_d.T)
                    rr.acceleration.append(res.out.qdd[h, :n] @ phi_a.T)
                rr.time = np.arange(int(res.n_steps.max()) + 1) * m.settings.dt
                rr.envelope_acc = res.red.acc.max(axis=1)
                rr.envelope_disp = res.red.disp.max(axis=1)
            else:
                env = res.envelopes()
                rr.envelope_acc = np.fmax(env["max_deck_acceleration_whole_deck"],
                                          env["max_deck_acceleration"].max(axis=1))
                rr.envelope_disp = env["max_deck_displacement"].max(axis=1)
            out.append(rr)
        return out

    def run(self, rows, n_threads: int | None = None) -> list[list[RunResult]]:
        """Run every row (rows, n_keys) on a pool of threads; results in row order."""
        from concurrent.futures import ThreadPoolExecutor

        rows = np.atleast_2d(np.asarray(rows, float))
        n = n_threads or threads()
        if n <= 1 or len(rows) <= 1:
            return [self.run_row(r) for r in rows]
        with ThreadPoolExecutor(max_workers=n) as pool:
            return list(pool.map(self.run_row, rows))


    # ------------------------------------------------------- histories at points
    def point_histories(self, rows, wanted) -> PointHistories:
        """Histories at deck points of every row (the calibration's records).

        ``wanted``: per history, ``(group, speed index, point index, acceleration)``
        (acceleration: True, band-limited as the deck outputs; False: displacement).
        The typed path runs each row's kernel call on arguments built once per thread
        and group (:meth:`_kernel_args`: the model's own arrays with the row's
        frequencies, damping and shapes; the histories equal those of
        :meth:`run_row`'s kernel call bit for bit) and reads the points' histories with
        compiled code (:mod:`vsi_numba.existing.misfit`): no Python work per time step
        and little per row, so threads run it in parallel.  The full path takes
        :meth:`run_row`'s histories.
        """
        rows = np.atleast_2d(np.asarray(rows, float))
        n = len(rows)
        errors = [""] * n
        if self._typed:
            lengths = []
            for gi, si, _, _ in wanted:
                m = self._models[gi]
                lengths.append(np.full(n, m.packed.n_steps(float(m.speeds[si])) + 1,
                                       np.int64))
            values = [np.zeros((n, int(ln[0]))) for ln in lengths]
            for r, row in enumerate(rows):
                errors[r] = self._typed_histories(row, wanted, values, r)
            return PointHistories(values, lengths, errors)
        results = [self.run_row(row) for row in rows]
        per = [[None] * n for _ in wanted]
        for r, res in enumerate(results):
            errors[r] = next((x.error for x in res if x.error), "")
            if errors[r]:
                continue
            for w, (gi, si, pi, acc) in enumerate(wanted):
                per[w][r] = (res[gi].acceleration if acc else res[gi].displacement)[si][:, pi]
        values, lengths = [], []
        for hs in per:
            ln = np.array([0 if h is None else h.size for h in hs], np.int64)
            v = np.zeros((n, int(ln.max(initial=1))))
            for r, h in enumerate(hs):
                if h is not None:
                    v[r, : h.size] = h
            values.append(v)
            lengths.append(ln)
        return PointHistories(values, lengths, errors)

    def _kernel_args(self, i: int) -> list:
        """This thread's kernel arguments of group ``i`` (those
        :func:`~vsi_numba.solver.batch.run_batch` builds for the model at the
        configuration's values with every history kept), built on first use."""
        args = getattr(self._local, "args", None)
        if args is None:
            args = self._local.args = {}
        if i not in args:
            from vsi_numba.solver import kernel_cache
            from vsi_numba.solver.batch import compile_family, run_batch

            m = self._models[i]
            got = []
            run_batch(m.packed, m.profile, m.speeds, m.points, m.settings, m.bridge,
                      keep_histories=np.ones(m.speeds.size, bool),
                      deck=m.deck_for(m.bridge.frequencies, 1.0)[:3],
                      _kernel=lambda *a: got.extend(a))
            compile_family(kernel_cache.family_of(m.packed))
            args[i] = got
        return args[i]

    def _typed_histories(self, row, wanted, values, r: int) -> str:
        """Run every group of a typed row into row ``r`` of ``values``; the row's error
        ('' when it ran)."""
        from vsi_numba import kernels as ek
        from vsi_numba.existing.misfit import STORABLE, first_unstorable, point_history
        from vsi_numba.solver import driver
        from vsi_numba.solver.results import STATUS_MESSAGES

        for gi in range(len(self.groups)):
            built, bad = self._typed_parts(gi, row)
            if built is None:
                return bad
            m, arrays, freqs, s = built
            phi_d, phi_a, _ = m.deck_for(freqs, s)
            (_, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, slots, status,
             reached) = self._kernel_args(gi)
            red = red._replace(phi_d=phi_d, phi_a=phi_a)
            driver.run_batch(arrays, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red,
                             out, slots, status, reached)
            self.n_runs += speeds.size
            env = (red.disp, red.acc, red.xmin, red.xmax, red.body)
            for k in range(speeds.size):
                code, step = int(status[k]), int(reached[k])
                if code == ek.OK:
                    n = int(n_steps[k]) + 1
                    if not all(np.all(np.abs(a[k]) <= STORABLE) for a in env):
                        code = ek.NON_FINITE
                    bad_q = first_unstorable(out.q, slots[k], n)
                    bad_a = first_unstorable(out.qdd, slots[k], n)
                    if bad_q >= 0 or bad_a >= 0:
                        code = ek.NON_FINITE
                        step = min(x for x in (bad_q, bad_a) if x >= 0)
                if code != ek.OK:
                    return (f"{STATUS_MESSAGES[code]} at t = {step * prm.dt:.6g} s "
                            f"(step {step})")
            for w, (g, si, pi, acc) in enumerate(wanted):
                if g == gi:
                    point_history(out.qdd if acc else out.q, slots[si],
                                  int(n_steps[si]) + 1, (phi_a if acc else phi_d)[pi],
                                  values[w][r])
        return ""


def central_row(section: dict) -> np.ndarray:
    """The priors' (or distributions') medians of a section's keys, in order."""
    from vsi_numba.existing.distributions import Marginals

    items = section.get("parameters", section.get("variables", []))
    return np.array([Marginals([dict(p)]).from_u(np.zeros(1))[0] for p in items])


def record_path(file: str, base_dir) -> Path:
    """A record's file as the configuration names it, relative to its directory."""
    f = Path(file)
    return f if f.is_absolute() else Path(base_dir) / f


def _message(exc) -> str:
    if isinstance(exc, ConfigError) and exc.errors:
        return str(exc.errors[0])
    return str(exc)
