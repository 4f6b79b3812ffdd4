"""Every network listener of a local Dask cluster is on the loopback interface.

The sockets are listed for real (``psutil``) while the cluster runs: first the backend
itself in this process, then a whole ``vsi sweep --workers 2`` subprocess held (with
``VSI_STUDY_HOLD_AFTER``) after its first stored batch, so the listing never races the
machine's speed.
"""

from __future__ import annotations

import contextlib
import ipaddress
import os
import signal
import subprocess
import sys
import textwrap
import time

import psutil
import pytest

from vsi_numba.study.runner import HOLD_ENV
from vsi_numba.study.store import store_path


def listening(pids) -> list[tuple[int, str, int]]:
    """``(pid, address, port)`` of every TCP socket in LISTEN state of these processes."""
    found = []
    for pid in pids:
        try:
            conns = psutil.Process(pid).net_connections(kind="inet")
        except psutil.NoSuchProcess:
            continue
        for c in conns:
            if c.status == psutil.CONN_LISTEN:
                found.append((pid, c.laddr.ip, c.laddr.port))
    return found


def non_loopback(listeners):
    return [entry for entry in listeners
            if not ipaddress.ip_address(entry[1].split("%")[0]).is_loopback]


def test_listeners__local_dask_backend_binds_loopback_only():
    """The local cluster's scheduler, workers, nannies and dashboards: 127.0.0.1 only."""
    from vsi_numba.study.cluster import DaskBackend

    me = os.getpid()
    before = set(listening([me]))
    with DaskBackend(n_workers=2) as be:
        assert be.n_workers == 2
        pids = [me] + [p.pid for p in psutil.Process(me).children(recursive=True)]
        opened = [entry for entry in listening(pids) if entry not in before]
    assert opened, "the cluster opened no listener at all (nothing was checked)"
    assert not non_loopback(opened), opened


def test_listeners__sweep_with_workers_binds_loopback_only(tmp_path):
    """A real ``vsi sweep --workers 2``, held after its first stored batch: every socket
    its process tree listens on is a loopback address."""
    config = tmp_path / "q.toml"
    config.write_text(textwrap.dedent("""
        title = "listeners"
        [bridge]
        kind = "simply_supported"
        spans = [10.0]
        EI = 2.0e9
        mass_per_length = 10000.0
        damping_ratio = 0.02
        n_modes = 2
        [[train.vehicles]]
        kind = "force"
        load = 100000.0
        [solver]
        dt = 2e-3
        free_vibration = 0.1
        [study]
        speeds_kmh = [100.0, 150.0]
        output = "q.nc"
    """))
    out = tmp_path / "q.nc"
    env = os.environ.copy()
    env[HOLD_ENV] = "1"
    proc = subprocess.Popen([sys.executable, "-m", "vsi_numba.cli", "sweep", str(config),
                             "-o", str(out), "--workers", "2", "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, env=env)
    marker = store_path(out) / ".held"
    try:
        t0 = time.monotonic()
        while not marker.exists():
            if proc.poll() is not None:
                pytest.fail(f"the sweep ended (rc {proc.returncode}) before it held:\n"
                            f"{proc.communicate()[1]}")
            if time.monotonic() - t0 > 600:
                pytest.fail("the sweep did not hold within 600 s")
            time.sleep(0.05)
        root = psutil.Process(proc.pid)
        pids = [proc.pid] + [p.pid for p in root.children(recursive=True)]
        found = listening(pids)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
    assert found, "the held sweep listens on nothing (nothing was checked)"
    assert not non_loopback(found), found
