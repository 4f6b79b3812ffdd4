"""Session set-up shared by every test process.

The kernels compile once for the whole run: the main pytest process (the pytest-xdist
controller, or the only process) runs ``vsi compile`` before the tests start, which
compiles both kernel families into the numba cache (or finds them there: a no-op when
cached); the test processes then load them from the cache.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading

import pytest
from threadpoolctl import threadpool_limits

# Tests interrupt sweeps with SIGINT, as a terminal's Ctrl-C does.  A test run started
# with SIGINT ignored (a background job of a non-interactive shell, nohup) would pass
# that on to the sweeps it starts, which then never see the signal (and the test times
# out): the run takes Python's default back, so its children start with SIG_DFL.
if (threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.SIG_IGN):
    signal.signal(signal.SIGINT, signal.default_int_handler)

# The tests run in 2 processes on 2 cores: BLAS on one thread in each (and in the
# processes the tests start), so that OpenBLAS's own threads (one per core, busy-waiting
# after each call) do not take the cores from the other test process.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
threadpool_limits(limits=1, user_api="blas")

# Every command makes its outputs again (no records of written outputs in the user's
# cache, vsi_numba.io.kept): a test that keeps outputs sets a directory of its own.
os.environ["VSI_OUTPUT_CACHE"] = "off"

# Python's bytecode cache on, as a default Python has it, also where the environment
# turns it off (PYTHONDONTWRITEBYTECODE): the test modules (pytest's rewritten asserts)
# and the package are compiled once, then read by every later process of the run - the
# test processes, the ``vsi`` commands, the pools' and Dask's workers the tests start -
# instead of being compiled from source in each (seconds of CPU per test process).
# ``__pycache__`` is ignored by git; a test of unwritable files turns it off in its own
# processes.
if os.environ.pop("PYTHONDONTWRITEBYTECODE", None) is not None:
    sys.dont_write_bytecode = False


def pytest_configure(config):
    if hasattr(config, "workerinput"):  # a pytest-xdist worker: the controller did it
        return
    done = subprocess.run([sys.executable, "-m", "vsi_numba.cli", "compile", "--quiet"],
                          stdin=subprocess.DEVNULL, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"vsi compile failed (exit {done.returncode}):\n{done.stderr}")


#: Test files with the longest single tests (~10-30 s each; reports/benchmarks.md "Test
#: command"), run first, the longest first: pytest-xdist's worksteal gives each worker a
#: contiguous part of the run and an idle worker takes the tail of the other's, so a long
#: test left at the end runs alone on one core while the other waits.  Whole files move
#: (their module-scoped fixtures stay shared); the order within a file is kept.
LONG_FIRST = ("test_verify.py", "test_torque_resonance.py", "test_kept_outputs.py",
              "test_space_config.py", "test_bounds.py", "test_track_damping.py",
              "test_trains_meeting_space.py", "test_report_atomic.py",
              "test_space_accuracy.py", "test_report_reproducible.py",
              "test_fatigue_studs.py", "test_variants_edges.py")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(LONG_FIRST)}
    # stable: the files of LONG_FIRST in its order, then the others as collected
    items.sort(key=lambda item: rank.get(item.path.name, len(LONG_FIRST)))
