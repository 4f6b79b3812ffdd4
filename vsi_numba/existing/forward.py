"""Forward runs of a configuration with some of its keys set: the deck response at the
records' points, and the check's envelopes, for many parameter sets at once.

A parameter set is a row of values of the keys (``bridge.EI``, ``bridge.damping_ratio``,
...).  For each row the configuration's mapping gets the values (the key paths of
``study.vary``, :func:`vsi_numba.config.variants._set_path`) and is validated as any
configuration (a row the validation refuses is no model: its likelihood is zero); then
each train of the records is packed once and run at all its speeds in one kernel call
(:func:`vsi_numba.solver.batch.run_batch`, the call a batch of the study engine makes:
the speeds are the batch axis of the kernel, the rows the batch axis of the thread
pool).  The kernels release the GIL (``nogil``), so the rows run on threads.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.config import ConfigError, load_config
from vsi_numba.config.existing import base_data, record_train_data
from vsi_numba.config.variants import _set_path


class ForwardError(ValueError):
    """A forward model that cannot be built (the message says why)."""


@dataclass(frozen=True)
class Group:
    """The runs of one train: its speeds (km/h) and deck points (m)."""

    train: str | None  # None: the configuration's own train
    speeds_kmh: tuple[float, ...]
    points: tuple[float, ...]


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
    """

    def __init__(self, data: dict, base_dir, keys, groups, histories: bool = True):
        self.data = base_data(data)
        self.base_dir = Path(base_dir)
        self.keys = list(keys)
        self.groups = list(groups)
        self.histories = histories
        self._data = [self.data if g.train is None else
                      record_train_data(self.data, g.train, self.base_dir)
                      for g in self.groups]
        self.n_runs = 0

    def _config(self, i_group: int, row):
        import copy

        d = copy.deepcopy(self._data[i_group])
        for k, v in zip(self.keys, row, strict=True):
            _set_path(d, k, float(v))
        return load_config(d, base_dir=self.base_dir)

    def run_row(self, row) -> list[RunResult]:
        """Run every group for one parameter row."""
        from vsi_numba.model.irregularity import no_irregularity
        from vsi_numba.solver.batch import deck_operators, run_batch
        from vsi_numba.solver.pack import ModelError, pack

        out = []
        for i, g in enumerate(self.groups):
            try:
                cfg = self._config(i, row)
            except ConfigError as exc:
                out.append(RunResult(error=str(exc.errors[0]) if exc.errors else str(exc)))
                continue
            train = cfg.trains()[0]
            bridge = cfg.bridge_for(train)
            settings = cfg.solver_settings()
            speeds = np.asarray(g.speeds_kmh, float) / 3.6
            points = np.asarray(g.points, float)
            try:
                profile = no_irregularity()
                packed = pack(bridge, train, float(speeds[0]), profile, settings)
                deck = deck_operators(bridge, points, settings, load_effects=False)
                res = run_batch(packed, profile, speeds, points, settings, bridge,
                                keep_histories=np.full(speeds.size, self.histories),
                                deck=deck)
            except (ModelError, ValueError) as exc:
                out.append(RunResult(error=str(exc)))
                continue
            self.n_runs += speeds.size
            if np.any(res.status != 0):
                r = int(np.flatnonzero(res.status != 0)[0])
                out.append(RunResult(error=res.message(r)))
                continue
            env = res.envelopes()
            rr = RunResult(cutoff=float(res.cutoff),
                           frequencies=np.asarray(bridge.frequencies, float),
                           envelope_acc=np.fmax(env["max_deck_acceleration_whole_deck"],
                                                env["max_deck_acceleration"].max(axis=1)),
                           envelope_disp=env["max_deck_displacement"].max(axis=1))
            if self.histories:
                # the deck rows of BatchResult.histories, without its other histories
                n_p = points.size
                phi_d, phi_a = res.phi_d[:n_p], res.phi_a[:n_p]
                rr.displacement, rr.acceleration = [], []
                for r in range(speeds.size):
                    h, n = int(res.slots[r]), int(res.n_steps[r]) + 1
                    rr.displacement.append(res.out.q[h, :n] @ phi_d.T)
                    rr.acceleration.append(res.out.qdd[h, :n] @ phi_a.T)
                rr.time = np.arange(int(res.n_steps.max()) + 1) * settings.dt
            out.append(rr)
        return out

    def run(self, rows, n_threads: int | None = None) -> list[list[RunResult]]:
        """Run every row (rows, n_keys) on a pool of threads; results in row order."""
        rows = np.atleast_2d(np.asarray(rows, float))
        n = n_threads or threads()
        if n <= 1 or len(rows) <= 1:
            return [self.run_row(r) for r in rows]
        with ThreadPoolExecutor(max_workers=n) as pool:
            return list(pool.map(self.run_row, rows))
