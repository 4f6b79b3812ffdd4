"""Batches: the unit of work of a study.

A batch is a block of runs that share one packed model: one train on one irregularity
realisation at a contiguous block of the study's speeds.  The model is packed once per
process and train, and the whole batch is one call of the numba kernel
(:func:`vsi_numba.solver.simulate.run_batch`) that loops over its runs and reduces the
envelopes while it steps; raw time histories are kept only for the runs that ask for
them.

The batch plan depends on the model alone (never on the number of workers), so a study
resumed with another backend or worker count finds the same batches in its store.
Batches are cut so that each holds about :data:`BATCH_SECONDS` of estimated kernel time
and at most :data:`BATCH_HISTORY_BYTES` of raw histories: small enough to balance two
or more workers and to bound memory, large enough that the per-batch overhead (a few
milliseconds) does not matter.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from dataclasses import dataclass

import numpy as np

from vsi_numba.io.schema import ALL_TRACKS_BASES, ALL_TRACKS_SUFFIX, HISTORIES, SPACE_HISTORIES

#: Estimated kernel seconds per batch (see :func:`run_cost`).
BATCH_SECONDS = 0.5
#: Cap on the raw history buffers of one batch (bytes).
BATCH_HISTORY_BYTES = 64 * 2**20


@dataclass(frozen=True)
class Batch:
    """Runs of one train on one realisation at a block of speeds.

    Attributes
    ----------
    index : int
        Position in the plan.
    i_train, i_irregularity : int
        Indices along the study's ``train`` and ``irregularity`` dimensions.
    speeds : tuple of int
        Indices along the ``speed`` dimension (contiguous, ascending).
    histories : tuple of bool
        Per run: keep its time histories.
    cost : float
        Estimated kernel seconds (scheduling only).
    """

    index: int
    i_train: int
    i_irregularity: int
    speeds: tuple[int, ...]
    histories: tuple[bool, ...]
    cost: float = 0.0
    variant: int | None = None  # index along ``variant`` (None: a study without variants)

    @property
    def key(self) -> str:
        """Name in the store, e.g. ``t001_i002_s0010-0019`` (``v0003_...`` for variants)."""
        v = "" if self.variant is None else f"v{self.variant:04d}_"
        return (f"{v}t{self.i_train:03d}_i{self.i_irregularity:03d}_"
                f"s{self.speeds[0]:04d}-{self.speeds[-1]:04d}")

    @property
    def n_runs(self) -> int:
        return len(self.speeds)


def step_cost(packed, n_points: int) -> float:
    """Estimated kernel seconds per time step of a packed model.

    Calibrated on this project's benchmarks (2-core Xeon): ~0.01 us per mode and output
    point for moving forces; ~18 us for an 8-car ICE3 (32 wheels, 80 DOFs, 20 modes).
    Only the ratios matter: they decide how runs are grouped into batches.
    """
    n_m = packed.bridge.omega.size
    n_w = packed.vehicles.wheel_dof.size
    n_v = packed.n_dof
    if n_w == 0 and n_v == 0:
        return 1e-8 * (3 * n_m + 2 * n_m * n_points)
    return 1e-6 * (0.5 + 0.4 * n_w + 0.05 * n_v + 0.02 * n_m * (1 + n_points))


def history_bytes(packed, n_steps: int) -> int:
    """Raw history buffer of one run (bytes)."""
    n_m = packed.bridge.omega.size
    n_w = packed.vehicles.wheel_dof.size
    n_b = packed.vehicles.body_dof.size
    return (n_steps + 1) * (8 * (2 * n_m + n_w + 2 * n_b) + n_w + 2)


def plan_batches(grid, packed_trains, n_points: int,
                 batch_seconds: float = BATCH_SECONDS,
                 history_limit: int = BATCH_HISTORY_BYTES, variant: int | None = None,
                 start: int = 0, trains_per_run: int = 1) -> list[Batch]:
    """Cut the study grid into batches (deterministic; see the module notes).

    Parameters
    ----------
    grid : StudyGrid
    packed_trains : sequence of Packed
        One packed model per train of the grid (any speed).
    n_points : int
        Deck output points (the reductions cost grows with them).
    trains_per_run : int
        Trains in each run (``train.other_trains``): more than one runs every train and
        keeps every run's histories (:mod:`vsi_numba.solver.superpose`), which both
        count.
    """
    speeds = np.asarray(grid.speeds_m_s, float)
    n_i = len(grid.irregularities)
    batches: list[Batch] = []
    for i_t, packed in enumerate(packed_trains):
        per_step = step_cost(packed, n_points) * trains_per_run
        steps = [packed.n_steps(v) for v in speeds]
        blocks: list[list[int]] = []
        block: list[int] = []
        cost = 0.0
        hist = 0
        for i_s, n in enumerate(steps):
            c = per_step * n
            h = (history_bytes(packed, n) * trains_per_run
                 if grid.history_speeds[i_s] or trains_per_run > 1 else 0)
            if block and (cost + c > batch_seconds or hist + h > history_limit):
                blocks.append(block)
                block, cost, hist = [], 0.0, 0
            block.append(i_s)
            cost += c
            hist += h
        if block:
            blocks.append(block)
        for i_i in range(n_i):
            for b in blocks:
                batches.append(Batch(
                    index=start + len(batches), i_train=i_t, i_irregularity=i_i,
                    speeds=tuple(b), histories=tuple(bool(grid.history_speeds[s]) for s in b),
                    cost=float(per_step * sum(steps[s] for s in b)), variant=variant,
                ))
    return batches


# ------------------------------------------------------------------ running one batch


@functools.lru_cache(maxsize=256)
def _packed_train(spec, i_train: int):
    """The packed model of train ``i_train`` (once per process), smooth track; the
    bridge carries the EN 1991-2 additional damping when the train is moving forces.
    With trains on other tracks its runs last until the last of them has left the deck
    (the largest ``train.other_trains`` offset longer)."""
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.solver.simulate import pack
    from vsi_numba.study.spec import study_model

    model = study_model(spec)
    train = model.trains[i_train]
    others = getattr(model.config, "other_trains", [])
    if others and interacting(train):
        return _packed_together(model, train, others)
    bridge = model.config.bridge_for(train)
    packed = pack(bridge, train, 1.0, no_irregularity(), model.settings)
    if others:
        # the run's train again at the run's speed: its runs are offset m longer; a train
        # or speed of their own: the runs last until it has left (Packed.other_runs)
        own = _other_trains(spec, i_train)
        same = [float(o["offset"]) for o, p in zip(others, own, strict=True)
                if not p.own_run and p.packed.run_length == packed.run_length
                + float(o["offset"])]
        runs = tuple((p.packed.run_length, p.speed_factor, p.speed) for o, p in
                     zip(others, own, strict=True)
                     if p.own_run or p.packed.run_length != packed.run_length
                     + float(o["offset"]))
        packed = dataclasses.replace(packed, run_length=packed.run_length + max(
            same, default=0.0), other_runs=runs)
    return packed


def interacting(train) -> bool:
    """``train`` has vehicles that interact with the deck (not moving forces only)."""
    return any(v.n_dof > 0 for v in train.vehicles)


def _packed_together(model, train, others):
    """An interaction train and the same train on the tracks of ``train.other_trains``,
    each at its ``speed_factor`` times the run's speed, in one run
    (:func:`~vsi_numba.solver.trains.pack_trains`): every wheel and the deck in one contact
    problem per step."""
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.solver.trains import TrainOnTrack, pack_trains

    cfg = model.config
    n_tracks = max([int(cfg.train_track), *(int(o["track"]) for o in others)])
    lines = [cfg.bridge_for(train, k) for k in range(1, n_tracks + 1)]
    trains = [TrainOnTrack(train, line=int(cfg.train_track) - 1)]
    trains += [TrainOnTrack(train, line=int(o["track"]) - 1,
                            direction=-1 if o["direction"] == "opposite" else 1,
                            offset=float(o["offset"]),
                            speed_factor=float(o.get("speed_factor", 1.0))) for o in others]
    return pack_trains(lines, trains, 1.0, no_irregularity(), model.settings)


@functools.lru_cache(maxsize=256)
def _other_trains(spec, i_train: int) -> tuple:
    """The trains on the other tracks of train ``i_train``'s runs
    (``train.other_trains``; :class:`~vsi_numba.solver.superpose.OtherTrain`), packed
    once per process."""
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.solver.simulate import pack
    from vsi_numba.solver.superpose import OtherTrain, shifted
    from vsi_numba.study.spec import study_model

    model = study_model(spec)
    cfg = model.config
    train = model.trains[i_train]
    if interacting(train):  # in the run itself (_packed_together)
        return ()
    out = []
    others = list(getattr(cfg, "other_trains", []))
    models = (cfg.other_train_models() if hasattr(cfg, "other_train_models")
              else [None] * len(others))
    speeds = (cfg.other_train_speeds_m_s() if hasattr(cfg, "other_train_speeds_m_s")
              else [None] * len(others))
    for o, own, speed in zip(others, models, speeds, strict=True):
        tr = train if own is None else own
        bridge = cfg.bridge_on_track(tr, int(o["track"]), o["direction"])
        p = pack(bridge, tr, 1.0, no_irregularity(), model.settings)
        out.append(OtherTrain(shifted(p, float(o["offset"])), o["direction"] == "opposite",
                              float(bridge.length), int(o["track"]) - 1,
                              float(o.get("speed_factor", 1.0)),
                              0.0 if speed is None else float(speed)))
    return tuple(out)


def _spec_of(spec, batch):
    """The spec of a batch: one spec, or one per variant (a tuple of specs)."""
    if batch.variant is None or hasattr(spec, "config_json"):
        return spec
    return spec[batch.variant]


def packed_for(spec, i_train: int, i_irregularity: int):
    """Packed model of one train on one realisation, and that realisation's profile."""
    from vsi_numba import kernels as ek
    from vsi_numba.study.spec import study_model

    model = study_model(spec)
    packed = _packed_train(spec, i_train)
    rid = list(model.profiles)[i_irregularity]
    profile = model.profiles[rid]
    pr = ek.ProfileArrays(
        x0=float(profile.x0), dx=float(profile.dx),
        coef=np.ascontiguousarray(profile.coef, dtype=np.float64).reshape(-1, 4),
    )
    return dataclasses.replace(packed, profile=pr), profile


def run_batch_task(spec, batch: Batch) -> dict:
    """Run one batch; return its results as a dict of numpy arrays (picklable).

    Keys: ``status``, ``max_iterations`` (n_runs,), ``message`` (n_runs,) str, every
    envelope of :data:`vsi_numba.io.schema.ENVELOPES` (n_runs, n_dim), ``kernel_seconds``
    and, when some run keeps them, ``hist_runs`` (positions in the batch), ``hist_steps``
    (time steps + 1 of each) and every history of :data:`~vsi_numba.io.schema.HISTORIES`
    as float32 (n_hist, n_time, n_dim), NaN-padded (``in_contact``: 1/0, NaN padding).
    """
    from vsi_numba.solver.simulate import run_batch
    from vsi_numba.study.spec import study_model

    spec = _spec_of(spec, batch)
    model = study_model(spec)
    packed, profile = packed_for(spec, batch.i_train, batch.i_irregularity)
    speeds = np.asarray(model.speeds_m_s, float)[list(batch.speeds)]
    others = _other_trains(spec, batch.i_train)
    if not others:
        res = run_batch(packed, profile, speeds, model.output_points, model.settings,
                        model.bridge, keep_histories=batch.histories, deck=model.deck)
        extra = {}
        if getattr(model.config, "other_trains", []):  # every train in the run itself
            env = res.envelopes()
            extra = {k + ALL_TRACKS_SUFFIX: np.ascontiguousarray(env[k])
                     for k in ALL_TRACKS_BASES if k in env}
        return _task_output(res, extra, packed, speeds, list(batch.histories))
    from vsi_numba.solver.superpose import run_with_others

    # every run of every train keeps its histories until they are summed: a few runs
    # at a time, so that the memory does not grow with the batch
    parts = []
    for chunk in superpose_chunks(packed, speeds, 1 + len(others)):
        res, extra = run_with_others(packed, profile, speeds[chunk], model.output_points,
                                     model.settings, model.bridge, list(others), model.deck)
        parts.append(_task_output(res, extra, packed, speeds[chunk],
                                  [batch.histories[i] for i in chunk]))
    return _joined(parts)


#: Raw histories (bytes, every train of the runs) the superposition of trains on other
#: tracks holds at once (:func:`superpose_chunks`).
SUPERPOSE_CHUNK_BYTES = 16 * 2**20


def superpose_chunks(packed, speeds, n_trains: int,
                     budget: float | None = None) -> list[np.ndarray]:
    """The runs of a batch (indices into ``speeds``, m/s) cut into consecutive chunks
    whose raw histories of ``n_trains`` trains fit in ``budget`` bytes (default
    :data:`SUPERPOSE_CHUNK_BYTES`; one run at least)."""
    budget = SUPERPOSE_CHUNK_BYTES if budget is None else float(budget)
    chunks: list[list[int]] = [[]]
    used = 0.0
    for i, v in enumerate(np.asarray(speeds, float)):
        need = n_trains * history_bytes(packed, int(packed.n_steps(float(v))))
        if chunks[-1] and used + need > budget:
            chunks.append([])
            used = 0.0
        chunks[-1].append(i)
        used += need
    return [np.array(c, np.int64) for c in chunks]


def _joined(parts: list[dict]) -> dict:
    """The outputs of consecutive chunks of a batch's runs (:func:`_task_output`) as
    one: per-run arrays concatenated, the kernel seconds summed, the histories padded
    to the longest run (NaN)."""
    if len(parts) == 1:
        return parts[0]
    kept = set(_history_names()) | {"kernel_seconds", "hist_runs", "hist_steps"}
    out: dict = {name: np.concatenate([p[name] for p in parts], axis=0)
                 for name in parts[0] if name not in kept}
    out["kernel_seconds"] = np.float64(sum(float(p["kernel_seconds"]) for p in parts))
    offsets = np.cumsum([0] + [int(p["status"].size) for p in parts[:-1]])
    hist = [(p, o) for p, o in zip(parts, offsets, strict=True) if "hist_runs" in p]
    if not hist:
        return out
    n_t = max(int(p["hist_steps"].max()) for p, _ in hist)
    out["hist_runs"] = np.concatenate([p["hist_runs"] + o for p, o in hist])
    out["hist_steps"] = np.concatenate([p["hist_steps"] for p, _ in hist])
    for name in _history_names():
        arrays = [p.get(name) for p, _ in hist]
        if all(a is None for a in arrays):
            out[name] = None
            continue
        tail = next(a.shape[2:] for a in arrays if a is not None)
        blocks = []
        for (p, _), a in zip(hist, arrays, strict=True):
            block = np.full((p["hist_runs"].size, n_t, *tail), np.nan, np.float32)
            if a is not None:
                block[:, :a.shape[1]] = a
            blocks.append(block)
        out[name] = np.concatenate(blocks, axis=0)
    return out


def _history_names() -> tuple[str, ...]:
    return (*HISTORIES, *SPACE_HISTORIES)


def _task_output(res, extra: dict, packed, speeds, histories: list) -> dict:
    """:func:`run_batch_task`'s output of the runs of one :class:`BatchResult`
    (``histories``: per run, whether its histories are written)."""
    out: dict = {
        "status": res.status.astype(np.int32),
        "max_iterations": res.red.iters.astype(np.int32),
        "message": np.array([res.message(r) for r in range(speeds.size)], dtype=str),
        "kernel_seconds": np.float64(res.elapsed),
    }
    out.update({name: np.ascontiguousarray(v) for name, v in res.envelopes().items()})
    out.update(extra)
    runs = [r for r in range(speeds.size) if histories[r]]
    if runs:
        # histories of the dynamic wheels only: a moving force's "contact force" is its
        # constant load (static_wheel_load), not a result; the file leaves it NaN
        n_dyn = packed.vehicles.wheel_dof.size
        lengths = np.array([int(res.n_steps[r]) + 1 for r in runs], np.int64)
        n_t = int(lengths.max())
        out["hist_runs"] = np.array(runs, np.int64)
        out["hist_steps"] = lengths
        for name in (*HISTORIES, *SPACE_HISTORIES):
            out[name] = None
        for h, r in enumerate(runs):
            for name, val in res.histories(r).items():
                if name in ("contact_force", "in_contact"):
                    val = val[:, :n_dyn]
                if out[name] is None:
                    out[name] = np.full((len(runs), n_t, *val.shape[1:]), np.nan,
                                        np.float32)
                out[name][h, : val.shape[0]] = val
    return out


# ------------------------------------------------------------------ the plan


def _packed_trains(spec, model) -> list:
    """The packed model of every train of a study (:func:`_packed_train`)."""
    return [_packed_train(spec, i) for i in range(len(model.trains))]


def deck_rows(model) -> tuple[int, int, int, int]:
    """(output points, deck rows reduced every step (displacement and acceleration),
    whole-deck grid points, load-effect sections) of a study model."""
    deck = model.deck
    n_p = int(np.asarray(model.output_points).size)
    n_rows = int(np.shape(deck.phi_d)[0] + np.shape(deck.phi_a)[0])
    n_grid = deck.n_grid
    eff = deck.effects
    n_sec = int(np.size(eff.sections)) if eff is not None else 0
    return n_p, n_rows, n_grid, n_sec


def superpose_bytes(rows, n_trains: int, n_steps: int) -> float:
    """Peak temporaries (bytes) of the superposition of a run's trains
    (:mod:`vsi_numba.solver.superpose`): the summed response at every deck row
    (:func:`deck_rows`) and its absolute value over the run's steps (float64; measured:
    596 MB peak RSS for configs/double_track_viaduct.toml without load effects, 689 MB
    with them; 632 MB estimated with the batches' histories); 0 for one train per run."""
    if n_trains <= 1:
        return 0.0
    _, n_rows, n_grid, _ = rows
    return 8.0 * (n_steps + 1) * 2 * (n_rows + n_grid)


def superpose_refusal(spec, model) -> str | None:
    """Why the study of ``model`` is refused before anything runs: the superposition of
    its slowest run with trains on other tracks (``train.other_trains``) needs more
    temporaries than :data:`~vsi_numba.config.limits.MAX_HISTORY_BYTES` (unless
    ``solver.allow_large_problem``); None when it fits."""
    from vsi_numba.config.limits import MAX_HISTORY_BYTES

    cfg = model.config
    others = list(getattr(cfg, "other_trains", []) or [])
    if (not others or cfg.resolved()["solver"].get("allow_large_problem")
            or all(interacting(t) for t in model.trains)):  # one run: nothing summed
        return None
    rows = deck_rows(model)
    vmin = float(np.min(model.speeds_m_s))
    steps = max(p.n_steps(vmin) for p in _packed_trains(spec, model))
    need = superpose_bytes(rows, 1 + len(others), steps)
    if need <= MAX_HISTORY_BYTES:
        return None
    largest = max(float(o["offset"]) for o in others)
    return (f"train.other_trains: the trains of the slowest run are summed over {steps:,} "
            f"time steps at {rows[1] + rows[2]:,} deck rows, about {need / 2**30:.3g} GiB "
            f"of temporaries, more than the budget of {MAX_HISTORY_BYTES / 2**30:g} GiB; "
            f"check train.other_trains[].offset (largest {largest:g} m), study.speeds_kmh "
            "(slowest), solver.dt, bridge.output_points; set solver.allow_large_problem = "
            "true to run it anyway")


def study_plan(spec, model, grid, variant: int | None = None, start: int = 0) -> list[Batch]:
    """The batch plan of a study (deterministic, see :func:`plan_batches`)."""
    others = getattr(model.config, "other_trains", [])
    # interaction trains run together (their packed model has every train's wheels)
    per_run = 1 if all(interacting(t) for t in model.trains) else 1 + len(others)
    return plan_batches(grid, _packed_trains(spec, model), model.output_points.size,
                        variant=variant, start=start, trains_per_run=per_run)


def plan_fingerprint(plan: list[Batch]) -> str:
    """SHA-256 of the batch keys and their runs (a store is only resumed by its plan)."""
    text = ";".join(f"{b.key}:{b.histories}" for b in plan)
    return hashlib.sha256(text.encode()).hexdigest()
