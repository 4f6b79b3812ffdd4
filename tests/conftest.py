"""Session set-up shared by every test process.

The kernels compile once for the whole run: at the start, the main pytest process (the
pytest-xdist controller, or the only process) starts one helper process per kernel
family that is not in the numba cache yet (:mod:`vsi_numba.solver.warm`), waits until
each holds its family's compile lock, and lets the tests start.  A test process that
needs a family meanwhile waits for that lock and loads the kernels from the cache
instead of compiling them a second time; tests that need no kernel run at once.
"""

from __future__ import annotations

import subprocess
import time

_HELPERS: list = []


def pytest_configure(config):
    if hasattr(config, "workerinput"):  # a pytest-xdist worker: the controller did it
        return
    import fcntl

    from vsi_numba.solver import warm
    from vsi_numba.study.backends import _term_with_parent

    for family in warm.FAMILIES:
        path = warm.lock_path(family)
        if path is None or warm.is_cached(family):
            continue
        proc = subprocess.Popen(warm.helper_command(family), stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                preexec_fn=_term_with_parent())
        _HELPERS.append(proc)
        # wait until the helper holds the lock (or has exited): then no test process
        # can take the lock first and compile the family itself
        path.parent.mkdir(parents=True, exist_ok=True)
        t_end = time.monotonic() + 60.0
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
