"""Process helpers shared by the layers that start processes (the study backends, the
compile processes of :mod:`vsi_numba.cli.compile_kernels`); standard library only."""

from __future__ import annotations

import os
from collections.abc import Callable


def available_cores() -> int:
    """Cores this process may use (affinity-aware)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def term_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` after which Linux sends the child SIGTERM when the parent thread
    ends (``PR_SET_PDEATHSIG``); None where there is no ``prctl``.  The C library is
    loaded here, in the parent: nothing is loaded between fork and exec."""
    import signal

    try:
        import ctypes

        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        return None
    sig = int(signal.SIGTERM)
    return lambda: prctl(1, sig)  # PR_SET_PDEATHSIG
