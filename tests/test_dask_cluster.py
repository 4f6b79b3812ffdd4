"""A Dask cluster of separate processes (``dask scheduler`` + ``dask worker``, all on
127.0.0.1) gives the same file as the local backend, bit for bit; the chunking of batches
into Dask tasks covers every batch once.

Reference: the local default backend (threads of one process) on the same configuration;
both run the same serial kernel on the same inputs, so every variable must be identical
(no tolerance).  The study is tiny (12 m span, 3 modes, 2 HSLM trains x 3 speeds x 2
damping variants, dt = 2 ms, one run keeping its histories) so the cost is the cluster's
start-up (a few seconds) plus the workers' numba cache load.
"""

from __future__ import annotations

import importlib
import ipaddress
import textwrap
import time

import dask
import numpy as np
import psutil
import xarray as xr
from dask.distributed import Client

from vsi_numba.study.backends import QUIET_DASK
from vsi_numba.study.batches import Batch
from vsi_numba.study.cluster import (
    CHUNK_SECONDS,
    TAIL_CHUNKS_PER_THREAD,
    LoopbackCluster,
    chunk_seconds,
    dask_chunks,
)
from vsi_numba.study.runner import run_study

CONFIG = """
title = "separate-process cluster"
[bridge]
kind = "simply_supported"
spans = [12.0]
EI = 6.0e9
mass_per_length = 12000.0
damping_ratio = 0.02
n_modes = 3
[train]
preset = ["HSLM-A1", "HSLM-A3"]
[solver]
dt = 2e-3
approach = 1.0
free_vibration = 0.1
[study]
speeds_kmh = [180.0, 260.0, 340.0]
save_time_histories = true
history_speeds_kmh = [260.0]
[study.vary]
"bridge.damping_ratio" = [0.01, 0.025]
"""


def _listeners(pids):
    out = []
    for pid in pids:
        try:
            conns = psutil.Process(pid).net_connections(kind="inet")
        except psutil.Error:
            continue
        out += [(pid, c.laddr.ip) for c in conns if c.status == psutil.CONN_LISTEN]
    return out


def _alive(pids, wait: float) -> list[int]:
    """The processes of ``pids`` still running (zombies count as gone) once they are all
    gone or ``wait`` seconds have passed (polled: no fixed sleep)."""
    t_end = time.monotonic() + wait
    while True:
        alive = []
        for pid in pids:
            try:
                if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                    alive.append(pid)
            except psutil.NoSuchProcess:
                pass
        if not alive or time.monotonic() > t_end:
            return alive
        time.sleep(0.1)


def test_dask_cluster__separate_processes_bit_identical_to_local(tmp_path):
    """``vsi sweep --scheduler`` on 2 separate ``dask worker`` processes: every variable
    and attribute but the history line equals the local run's; the workers use the
    models the client built (model building is switched off on them); every listener of
    the cluster is on the loopback interface; no cluster process is left afterwards."""
    cfg = tmp_path / "study.toml"
    cfg.write_text(textwrap.dedent(CONFIG))
    local = run_study(cfg, tmp_path / "local.nc").load()
    tree: list[int] = []
    try:
        with LoopbackCluster(2, tmp_path / "cluster") as cluster:
            tree = cluster.pids
            assert len(tree) >= 5  # scheduler, 2 nannies, 2 workers (+ resource trackers)
            found = _listeners(tree)
            with Client(cluster.address) as client:  # the workers must not build a model:
                client.run(lambda: setattr(importlib.import_module(  # the client's are sent
                    "vsi_numba.study.spec"), "_build_model", None))
                # the cluster's processes run without the profiler and with slow ticks
                quiet = client.run(lambda: {k: dask.config.get(k) for k in QUIET_DASK})
                quiet_sched = client.run_on_scheduler(
                    lambda: {k: dask.config.get(k) for k in QUIET_DASK})
                dist = run_study(cfg, tmp_path / "cluster.nc",
                                 scheduler=cluster.address).load()
    finally:  # the cluster waits for its processes to go on exit, also after a failure
        left = _alive(tree, wait=60.0)
    assert not left, left
    assert len(quiet) == 2 and all(q == QUIET_DASK for q in quiet.values()), quiet
    assert quiet_sched == QUIET_DASK, quiet_sched
    assert len(found) >= 5, found  # scheduler, nannies, workers (and dashboards)
    assert all(ipaddress.ip_address(ip).is_loopback for _, ip in found), found
    assert sorted(local.variables) == sorted(dist.variables)
    for name in local.variables:  # no tolerance: same kernel, same inputs
        xr.testing.assert_identical(local[name], dist[name])
    assert np.isfinite(local["max_deck_acceleration"]).all()  # something was computed
    a, b = dict(local.attrs), dict(dist.attrs)
    a.pop("history"), b.pop("history")
    assert a == b


def test_dask_cluster__workers_load_the_clients_kernels(tmp_path):
    """Workers whose numba cache is empty (``NUMBA_CACHE_DIR`` of their own) load the
    kernels the client sends (``worker_kernels.share_kernels``) instead of compiling
    them: numba counts cache hits and no miss on them (a miss is a compilation), and the
    results equal the local run's."""
    from vsi_numba.solver.batch import compile_family
    from vsi_numba.study.backends import worker_env

    compile_family("moving_force")  # the client's cache holds the family
    cfg = tmp_path / "study.toml"
    cfg.write_text(textwrap.dedent(CONFIG))
    local = run_study(cfg, tmp_path / "local.nc").load()
    empty = tmp_path / "worker-cache"
    env = {**worker_env(), "NUMBA_CACHE_DIR": str(empty)}
    with LoopbackCluster(2, tmp_path / "cluster", env=env) as cluster:
        dist = run_study(cfg, tmp_path / "cluster.nc", scheduler=cluster.address).load()
        with Client(cluster.address) as client:
            # numba's cache hits and misses of the moving-force kernel on each worker (a
            # lambda: sent by value, the workers cannot import this module)
            counts = client.run(lambda: (lambda s: (sum(s.cache_hits.values()),
                                                    sum(s.cache_misses.values())))(
                importlib.import_module("vsi_numba.solver.kernel_cache").kernel(
                    "moving_force").stats))
    assert len(counts) == 2, counts  # a worker that ran no batch loaded nothing
    assert all(misses == 0 for _, misses in counts.values()), counts
    assert sum(hits for hits, _ in counts.values()) >= 1, counts
    assert any(empty.rglob("*.nbc"))
    xr.testing.assert_identical(local["max_deck_acceleration"],
                                dist["max_deck_acceleration"])


class _Boom(Exception):
    pass


def test_loopback_cluster__every_process_goes_when_the_body_fails(tmp_path):
    """An exception inside the ``with`` block still ends the scheduler, the nanny and its
    worker (the worker is a grandchild: found through the nanny before the signals)."""
    tree: list[int] = []
    try:
        with LoopbackCluster(1, tmp_path / "cluster") as cluster:
            tree = cluster.pids
            raise _Boom
    except _Boom:
        pass
    assert len(tree) >= 3, tree  # scheduler, nanny, worker
    left = _alive(tree, wait=0.0)  # the cluster waited for them on exit
    assert not left, left


def _plan(costs, histories=()):
    return [Batch(index=i, i_train=i % 3, i_irregularity=0, speeds=(i,),
                  histories=(i in histories,), cost=c) for i, c in enumerate(costs)]


def test_dask_chunks__every_batch_once_in_plan_order_largest_chunk_first():
    """Chunks hold contiguous plan positions, each batch exactly once, cost within the
    target unless a single batch exceeds it, history batches alone, largest first."""
    rng = np.random.default_rng(7)
    costs = rng.uniform(0.01, 0.3, 200)
    batches = _plan(costs, histories={5, 6, 50})
    shuffled = [batches[i] for i in rng.permutation(len(batches))]
    chunks = dask_chunks(shuffled, 1.0)
    flat = sorted(b.index for c in chunks for b in c)
    assert flat == list(range(200))
    for c in chunks:
        idx = [b.index for b in c]
        assert idx == list(range(idx[0], idx[0] + len(idx)))  # contiguous, plan order
        assert len(c) == 1 or sum(b.cost for b in c) <= 1.0
        assert len(c) == 1 or not any(b.histories[0] for b in c)
    sums = [sum(b.cost for b in c) for c in chunks]
    assert sums == sorted(sums, reverse=True)
    # greedy cutting: a chunk and the next one's first batch together exceed the target
    by_start = sorted(chunks, key=lambda c: c[0].index)
    for c, nxt in zip(by_start, by_start[1:], strict=False):
        if not (any(b.histories[0] for b in c) or nxt[0].histories[0]):
            assert sum(b.cost for b in c) + nxt[0].cost > 1.0


def test_dask_chunks__tail_shrinks_to_the_floor():
    """With the thread count, a chunk's target is min(seconds, max(floor, cost from its
    start to the plan's end / (TAIL_CHUNKS_PER_THREAD x threads))): checked chunk by chunk
    against that formula (greedy: one batch more would pass it); the first tasks are full
    size, the last ones at the floor."""
    lo = CHUNK_SECONDS[0]
    costs = [0.125] * 320  # 40 s in all, exact in binary
    chunks = dask_chunks(_plan(costs), 2.0, n_threads=2)
    assert sorted(b.index for c in chunks for b in c) == list(range(320))
    by_start = sorted(chunks, key=lambda c: c[0].index)
    tail = TAIL_CHUNKS_PER_THREAD * 2
    for c, nxt in zip(by_start, [*by_start[1:], None], strict=True):
        suffix = 0.125 * (320 - c[0].index)
        target = min(2.0, max(lo, suffix / tail))
        cost = sum(b.cost for b in c)
        assert cost <= target, (c[0].index, cost, target)
        if nxt is not None:
            assert cost + nxt[0].cost > target
    assert sum(b.cost for b in chunks[0]) == 2.0  # largest first: full size
    assert sum(b.cost for b in chunks[-1]) == 0.25  # the floor (2 batches)
    assert len(chunks) > 40 / 2.0  # more tasks than equal 2 s chunks


def test_chunk_seconds__eight_tasks_per_thread_within_bounds():
    """total cost / (8 x threads), clipped to CHUNK_SECONDS."""
    lo, hi = CHUNK_SECONDS
    batches = _plan([0.125] * 80)  # 10 s in all (exact in binary)
    assert chunk_seconds(batches, 2) == 10.0 / 16
    assert chunk_seconds(batches, 0) == chunk_seconds(batches, 1) == 10.0 / 8  # no worker
    assert chunk_seconds(_plan([0.125] * 800), 2) == hi  # 100 / 16 s is above the cap
    assert chunk_seconds(batches, 16) == lo  # 10 / 128 s is below the floor


def test_list_schedule__hand_computed_makespans():
    """The 16-worker estimate's scheduler: equal tasks fill the workers evenly; uneven
    tasks go to the worker free first (worked by hand below)."""
    from benchmarks.study import list_schedule, plan_of

    assert list_schedule([1.0] * 10, 4) == 3.0  # 4 + 4 + 2 tasks
    assert list_schedule([1.0] * 10, 4, overhead=0.5) == 4.5
    # 3 -> w1, 3 -> w2, 2 -> w1 (5), 2 -> w2 (5), 2 -> w1 (7)
    assert list_schedule([3.0, 3.0, 2.0, 2.0, 2.0], 2) == 7.0
    assert list_schedule([2.0, 1.0], 16) == 2.0
    plan = plan_of({"v0001_t000_i000_s0000-0056": 2.0, "v0000_t009_i000_s0000-0056": 1.0})
    assert [(b.variant, b.i_train, b.speeds[-1], b.cost) for b in plan] == [
        (0, 9, 56, 1.0), (1, 0, 56, 2.0)]


def test_same_files__names_every_difference(tmp_path):
    """The bit-identity check of benchmark measure j: [] for the same file written twice;
    a last-bit change of one value, an added variable and a changed attribute are named;
    the history line is ignored."""
    from benchmarks.study import same_files

    ds = xr.Dataset({"a": ("x", np.array([1.0, np.nan, 3.0])), "b": ("x", np.zeros(3))},
                    attrs={"title": "t", "history": "one"})
    ds.to_netcdf(tmp_path / "1.nc")
    ds.assign_attrs(history="two").to_netcdf(tmp_path / "2.nc")  # NaN equals NaN
    assert same_files(tmp_path / "1.nc", tmp_path / "2.nc") == []
    a = ds["a"].values.copy()
    a[0] = np.nextafter(a[0], 2.0)
    ds.assign(a=("x", a), c=("x", np.ones(3))).assign_attrs(title="u").to_netcdf(
        tmp_path / "3.nc")
    assert same_files(tmp_path / "1.nc", tmp_path / "3.nc") == ["c", "a", "attrs"]
