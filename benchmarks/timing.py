"""Timing helpers: medians of repeated runs with wall and CPU time, load, machine info.

The machine is shared: wall times are inflated whenever other processes compete for the
cores.  Every measurement therefore records

* the wall time (``time.perf_counter``) and the CPU time of this process
  (``time.process_time``); ``cpu / wall`` well below 1 for a serial run means the run was
  starved of CPU and the wall number is pessimistic;
* the 1-minute load average before and after (``os.getloadavg``).
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BLAS_NOTE = ""  # set by benchmarks.__main__ when it fixes the BLAS threads
BLAS_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
ORIGINAL_BLAS_ENV: dict = {}  # the user's values before limit_blas_threads


def user_env() -> dict:
    """``os.environ`` with the BLAS variables as the user had them (for subprocesses
    that must behave as a user's command would), and Python's bytecode cache on: a
    ``PYTHONDONTWRITEBYTECODE`` of the benchmark machine (set on the one of the report)
    would make every command compile the package's ~70 modules from source, ~0.1 s that
    a user's installed package does not pay."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    for var, val in ORIGINAL_BLAS_ENV.items():
        if val is None:
            env.pop(var, None)
        else:
            env[var] = val
    return env


def limit_blas_threads(n: int) -> str:
    """Set the BLAS/OpenMP thread counts to ``n`` for this process (effective only if
    numpy is not imported yet); returns a note for the report."""
    global BLAS_NOTE
    late = "numpy" in sys.modules
    for var in BLAS_VARS:
        ORIGINAL_BLAS_ENV.setdefault(var, os.environ.get(var))
        os.environ[var] = str(n)
    BLAS_NOTE = (" (set by the runner AFTER numpy was imported: no effect)" if late else
                 " (set by the runner: serial runs, single-threaded linear algebra)")
    return BLAS_NOTE


@dataclass
class Timing:
    """Repeated measurement of one callable."""

    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)
    load_before: float = float("nan")
    load_after: float = float("nan")

    @property
    def n(self) -> int:
        return len(self.wall)

    @property
    def wall_median(self) -> float:
        return statistics.median(self.wall) if self.wall else float("nan")

    @property
    def cpu_median(self) -> float:
        return statistics.median(self.cpu) if self.cpu else float("nan")

    @property
    def wall_min(self) -> float:
        return min(self.wall) if self.wall else float("nan")

    @property
    def load(self) -> float:
        return max(self.load_before, self.load_after)

    def summary(self) -> str:
        return (f"wall median {self.wall_median:.4g} s (min {self.wall_min:.4g}, n={self.n}), "
                f"cpu median {self.cpu_median:.4g} s, load {self.load:.2f}")


def load1() -> float:
    """1-minute load average."""
    return os.getloadavg()[0]


def measure(fn, repeat: int = 5, warmup: int = 0) -> tuple[Timing, object]:
    """Call ``fn()`` ``warmup`` + ``repeat`` times; time the last ``repeat`` calls.

    Returns the :class:`Timing` and the value of the last call.
    """
    value = None
    for _ in range(warmup):
        value = fn()
    t = Timing(load_before=load1())
    for _ in range(max(repeat, 1)):
        c0 = time.process_time()
        w0 = time.perf_counter()
        value = fn()
        t.wall.append(time.perf_counter() - w0)
        t.cpu.append(time.process_time() - c0)
    t.load_after = load1()
    return t, value


def median(values) -> float:
    values = [v for v in values if v == v]
    return statistics.median(values) if values else float("nan")


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _git(*args) -> str:
    try:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True,
                              timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def machine_info() -> dict:
    """Date, machine, load and software versions for the report header."""
    import numba
    import numpy
    import scipy
    import xarray

    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    commit = _git("rev-parse", "--short", "HEAD")
    dirty = _git("status", "--porcelain", "--", "vsi_numba")
    return {
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "host_cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "cores_usable": affinity,
        "loadavg": os.getloadavg(),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "xarray": xarray.__version__,
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR", "(default: __pycache__)"),
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "unset (OpenBLAS default: "
                                       "one thread per core)") + BLAS_NOTE,
        "git_commit": commit + (" (vsi_numba/ has uncommitted changes)" if dirty else ""),
    }
