"""Session set-up shared by every test process.

The kernels compile once for the whole run: at the start, the main pytest process (the
pytest-xdist controller, or the only process) starts one helper process per kernel
family that is not in the numba cache yet (:mod:`vsi_numba.solver.warm`), waits until
each holds its family's compile lock, and lets the tests start.  A test process that
needs a family meanwhile waits for that lock and loads the kernels from the cache
instead of compiling them a second time; tests that need no kernel run at once.

The tests are ordered so that there are such tests to run meanwhile: the modules that
run the moving-force kernels only (:data:`MOVING_FORCE_MODULES`, ~13 s to compile) come
after those that need no kernel, and those with a test of the interaction kernels
(:data:`INTERACTION_MODULES`, ~30 s in two processes) last.  The order inside a module is kept; the
grouping only changes when a test waits, never what it checks.  The README's command runs
the tests with ``--dist worksteal``: each test process starts on half of this order (the
second half begins with the last tests that need no kernel, then waits for the kernels
while the first runs the rest of them), and a process that runs out takes half of the
other's remaining tests, which shares the slow interaction tests at the end (from an
empty cache, 5 interleaved pairs: 109-116 s against 114-123 s with ``--dist load``).
"""

from __future__ import annotations

import os
import signal
import threading
import time

from threadpoolctl import threadpool_limits

# Tests interrupt sweeps with SIGINT, as a terminal's Ctrl-C does.  A test run started
# with SIGINT ignored (a background job of a non-interactive shell, nohup) would pass
# that on to the sweeps it starts, which then never see the signal (and the test times
# out): the run takes Python's default back, so its children start with SIG_DFL.
if (threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.SIG_IGN):
    signal.signal(signal.SIGINT, signal.default_int_handler)

# The tests run in 2 processes on 2 cores, beside the compile helpers: BLAS on one thread
# in each (and in the processes the tests start), so that OpenBLAS's own threads (one
# per core, busy-waiting after each call) do not take the cores from the other test
# process and the compilation (the suite from an empty cache: 134 -> 124 s, 243 -> 226 s
# of CPU on 2 cores).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
threadpool_limits(limits=1, user_api="blas")

_HELPERS: list = []

#: Test modules that run the moving-force kernels but not the interaction kernels
#: (measured).
MOVING_FORCE_MODULES = frozenset({
    "test_cluster_listeners", "test_code_profile", "test_continuous_config", "test_dask_cluster",
    "test_load_distribution", "test_load_effect_checks", "test_output_lock",
    "test_foreign_results", "test_cli_outputs",
    "test_report_atomic", "test_report_summary", "test_default_modes",
    "test_report_convergence", "test_torsion", "test_imported_tracks"})

#: Test modules with a test that runs the interaction kernels (measured): one such test
#: early would make its process wait for the compilation.
INTERACTION_MODULES = frozenset({
    "test_batch", "test_benchmarks", "test_cli_conveniences", "test_comfort_car_end",
    "test_comfort_deck", "test_deck_end_impact", "test_engine", "test_files_edges",
    "test_hertz", "test_hostile", "test_impact_lcp", "test_imported", "test_load_effects",
    "test_nonlinear_on_damped_track", "test_nonlinear_suspension", "test_output_matrix",
    "test_report",
    "test_resume", "test_study", "test_track", "test_track_accuracy", "test_track_damping",
    "test_validation", "test_verify",
    "test_variants", "test_variants_edges", "test_warm", "test_space_config"})


def _wait_rank(item) -> int:
    name = item.path.stem
    return 2 if name in INTERACTION_MODULES else 1 if name in MOVING_FORCE_MODULES else 0


def pytest_collection_modifyitems(session, config, items):
    items.sort(key=_wait_rank)  # stable: the order within a module is kept


#: ``nice`` increment of the test processes (the pytest-xdist workers): while the
#: helpers compile, the tests that need no kernel take the cores the helpers leave, and
#: the interaction kernels - the tests that need them wait - are ready sooner.
TEST_NICE = 5


def pytest_configure(config):
    if hasattr(config, "workerinput"):  # a pytest-xdist worker: the controller did it
        if hasattr(os, "nice"):
            os.nice(TEST_NICE)
        return
    import fcntl

    from vsi_numba.solver import warm
    from vsi_numba.study.backends import _term_with_parent

    started = []
    for family in warm.FAMILIES:
        path = warm.lock_path(family)
        if path is None or warm.is_cached(family):
            continue
        # as a study starts them: the moving-force helper at a lower priority (it and the
        # tests take what the interaction compilation, the longest, leaves)
        proc = warm.start_helper(family, preexec_fn=_term_with_parent())
        _HELPERS.append(proc)
        started.append((path, proc))
    # wait until each helper holds its lock (or has exited): then no test process can
    # take a lock first and compile the family itself (the helpers start together)
    t_end = time.monotonic() + 60.0
    for path, proc in started:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a") as fh:
            while proc.poll() is None and time.monotonic() < t_end:
                try:
                    fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:  # held: by the helper
                    break
                fcntl.flock(fh, fcntl.LOCK_UN)
                time.sleep(0.05)


def pytest_unconfigure(config):
    for proc in _HELPERS:  # normally long finished; a run stopped early ends them
        if proc.poll() is None:
            proc.terminate()
        proc.wait()
    _HELPERS.clear()
