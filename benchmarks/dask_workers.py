"""A study on a 2-worker Dask cluster whose workers start with empty numba caches: the
time to its results, two versions of the code.

For each tree (a checkout; its root first on ``PYTHONPATH``) a :class:`LoopbackCluster`
of 2 ``dask worker`` processes on 127.0.0.1 starts with ``NUMBA_CACHE_DIR`` set to a new
empty directory (as workers on other machines have), then ``vsi sweep CONFIG --scheduler
ADDRESS`` runs as a subprocess with the client's cache warm (``NUMBA_CACHE_DIR`` of this
process: run ``vsi compile`` in each tree first).  The study is small (an HSLM train and
the ICE3: both kernel families; 12 m span, 2 speeds), so its time is the workers' start
with the kernels: compiled on each worker, or loaded from the files the client sends.
Printed per tree: the sweep's wall seconds (from its start to its results file) and the
CPU seconds of the sweep and of the cluster's processes (user + system).

    python -m benchmarks.dask_workers BEFORE_TREE AFTER_TREE
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

CONFIG = """
title = "2 Dask workers from empty caches"
[bridge]
kind = "simply_supported"
spans = [12.0]
EI = 6.0e9
mass_per_length = 12000.0
damping_ratio = 0.02
n_modes = 3
[train]
preset = ["HSLM-A1", "ICE3"]
[solver]
dt = 2e-3
approach = 1.0
free_vibration = 0.1
[study]
speeds_kmh = [200.0, 300.0]
"""


def measure() -> dict:
    """The measure of the code on ``sys.path`` (see the module's text)."""
    from vsi_numba.study.backends import worker_env
    from vsi_numba.study.cluster import LoopbackCluster

    with tempfile.TemporaryDirectory(prefix="vsi-dask-") as tmp:
        tmp = Path(tmp)
        cfg = tmp / "study.toml"
        cfg.write_text(textwrap.dedent(CONFIG))
        env = {**worker_env(), "NUMBA_CACHE_DIR": str(tmp / "worker-cache")}
        with LoopbackCluster(2, tmp / "cluster", env=env) as cluster:
            procs = cluster._tree()  # scheduler, nannies, workers
            c0 = sum(sum(p.cpu_times()[:2]) for p in procs)
            t0 = time.perf_counter()
            r0 = os.times()
            subprocess.run([sys.executable, "-m", "vsi_numba.cli", "sweep", str(cfg), "-o",
                            str(tmp / "out.nc"), "--scheduler", cluster.address, "-q"],
                           check=True, stdin=subprocess.DEVNULL)
            wall = time.perf_counter() - t0
            r1 = os.times()
            c1 = sum(sum(p.cpu_times()[:2]) for p in procs if p.is_running())
    return {"wall": wall, "client_cpu": (r1.children_user - r0.children_user)
            + (r1.children_system - r0.children_system), "cluster_cpu": c1 - c0}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.dask_workers", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trees", nargs="*", help="BEFORE_TREE AFTER_TREE")
    p.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.measure:
        print(json.dumps(measure()))
        return 0
    for tree in args.trees:
        env = {**os.environ, "PYTHONPATH": tree}
        done = subprocess.run([sys.executable, __file__, "--measure"], env=env, cwd=tree,
                              check=True, capture_output=True, text=True)
        r = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{tree}: results in {r['wall']:.1f} s wall; CPU {r['client_cpu']:.1f} s "
              f"(sweep) + {r['cluster_cpu']:.1f} s (scheduler and 2 workers)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
