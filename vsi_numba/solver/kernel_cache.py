"""The kernels compile once per machine.

numba compiles a kernel the first time it runs for its argument types, or loads it from
its cache (``cache=True``, keyed on the kernels' sources: :mod:`vsi_numba._jit`).  The two
kernel families share no compiled code: :func:`~vsi_numba.kernels.run_batch_mf`
runs the trains of moving forces, :func:`~vsi_numba.kernels.time_loop` and its
callees the interaction models.

:func:`ensure_compiled` has a family compiled (or loaded) in this process holding a lock
file in the family's cache directory (:func:`compile_lock`): of the processes of a machine
that need the family at the same time (worker processes, Dask workers, test processes),
one compiles it and the others wait, then load it from the cache - N processes starting
on an empty cache compile once, not N times at once (each compilation takes ~1 GB).
After a successful compilation a stamp file named by the kernels' sources, numba's and
Python's versions (:func:`stamp_path`) records that the cache holds the family
(:func:`is_cached`), which decides whether a first run compiles the two families in two
processes at once (:func:`helper_command`).  Only numba's public dispatcher API is used:
``signatures`` and ``stats`` (its cache directory and cache hits).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

#: The kernel families: trains of moving forces, interaction models.
FAMILIES = ("moving_force", "interaction")

#: Seconds a process waits for another's compilation of a family before it compiles the
#: family itself (a compilation takes about a minute on a slow machine).
LOCK_TIMEOUT = 600.0

_thread_lock = threading.Lock()


def family_of(packed) -> str:
    """The kernel family that runs a packed model (as
    :func:`~vsi_numba.solver.driver.run_batch` chooses it)."""
    veh = packed.vehicles
    return ("moving_force" if veh.wheel_dof.size == 0 and veh.start.size == 1
            else "interaction")


def kernel(family: str):
    """The family's top kernel (the one place this module reaches the kernels)."""
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: expected one of {FAMILIES}")
    from vsi_numba import kernels

    return kernels.run_batch_mf if family == "moving_force" else kernels.time_loop


def compiled_here(family: str) -> bool:
    """Compiled (or loaded) in this process already (or no JIT: ``NUMBA_DISABLE_JIT``)."""
    return bool(getattr(kernel(family), "signatures", True))


def cache_path(family: str) -> Path | None:
    """The directory of the family's numba cache (None: no cache, no JIT)."""
    stats = getattr(kernel(family), "stats", None)
    path = getattr(stats, "cache_path", None)
    return Path(path) if path else None


def stamp_path(family: str) -> Path | None:
    """The stamp file written after the family compiled: named by the hash of the
    kernels' sources, numba's and Python's versions and the target CPU
    (``NUMBA_CPU_NAME``), so an edit or an upgrade makes it absent."""
    import numba

    from vsi_numba._jit import package_hash

    path = cache_path(family)
    if path is None:
        return None
    k = kernel(family)
    key = "|".join([package_hash(os.path.dirname(k.py_func.__code__.co_filename)),
                    numba.__version__, sys.version, str(numba.config.CPU_NAME)])
    return path / f"vsi_numba-{family}-{hashlib.sha256(key.encode()).hexdigest()[:16]}.ok"


def is_cached(family: str) -> bool:
    """Compiled here, or compiled into the cache for the current sources (its stamp)."""
    if compiled_here(family):
        return True
    stamp = stamp_path(family)
    return stamp is None or stamp.is_file()


@contextlib.contextmanager
def compile_lock(family: str, timeout: float = LOCK_TIMEOUT):
    """Hold the machine-wide lock of ``family``'s compilation (a no-op where there is no
    ``fcntl`` or no cache directory).  A process that finds it held waits until it is
    free (the other process has compiled and cached the kernels, or died: the lock goes
    with it), or ``timeout`` seconds, then goes on."""
    path = cache_path(family)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        path = None
    fh = None
    if path is not None:
        try:
            path.mkdir(parents=True, exist_ok=True)
            fh = open(path / f"vsi_numba-{family}.lock", "a")  # noqa: SIM115 - closed below
        except OSError:  # an unwritable cache directory: numba has no cache there either
            fh = None
    try:
        if fh is not None:
            t_end = time.monotonic() + timeout
            while True:
                try:
                    fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except OSError:
                    if time.monotonic() > t_end:
                        break
                    time.sleep(0.1)
        yield
    finally:
        if fh is not None:
            fh.close()  # releases the lock


def ensure_compiled(family: str, compile_family: Callable[[], None],
                    timeout: float = LOCK_TIMEOUT) -> str:
    """Have ``family``'s kernels compiled (or loaded from the cache) in this process:
    ``compile_family()`` (a tiny batch of the family) runs under :func:`compile_lock`.
    Returns ``"ready"`` (done in this process before), ``"loaded"`` (from the cache) or
    ``"compiled"``.  The lock is held for the compilation only, never for a batch."""
    if compiled_here(family):
        return "ready"
    with _thread_lock, compile_lock(family, timeout):
        if compiled_here(family):  # another thread of this process did it
            return "ready"
        compile_family()
        stamp = stamp_path(family)
        if stamp is not None:
            with contextlib.suppress(OSError):
                stamp.touch()
        return "loaded" if sum(kernel(family).stats.cache_hits.values()) else "compiled"


def helper_command(family: str) -> list[str]:
    """``python -m vsi_numba.cli compile --family FAMILY --quiet``: the family compiled
    (or loaded) in a process of its own, into the same cache (same environment)."""
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: expected one of {FAMILIES}")
    return [sys.executable, "-m", "vsi_numba.cli", "compile", "--family", family, "--quiet"]


def start_helper(families) -> subprocess.Popen | None:
    """On a first run that needs both families (``families``: those it needs, in the
    order it needs them) with neither in the cache and 2 cores or more, a process of
    its own compiles the last of them (:func:`helper_command`) while this one compiles
    the other: the two compilations run at once.  This process then finds that family's
    compile lock held by the helper, waits for it and loads the kernels from the cache.
    Returns the helper's process (end it with :func:`stop_helper`), or None."""
    from vsi_numba._process import available_cores, term_with_parent

    families = list(dict.fromkeys(families))
    if (len(families) < 2 or available_cores() < 2
            or any(is_cached(f) for f in families)):
        return None
    try:
        return subprocess.Popen(helper_command(families[-1]), stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                preexec_fn=term_with_parent())
    except OSError:  # no process to spare: this process compiles both
        return None


@contextlib.contextmanager
def stop_helper(proc: subprocess.Popen | None):
    """End the helper of :func:`start_helper` (if any) on leaving, also when the work
    stops before the helper is done."""
    try:
        yield proc
    finally:
        if proc is not None:
            if proc.poll() is None:
                proc.terminate()
            proc.wait()


# --------------------------------------------------------- kernels for other machines

def cache_files() -> dict[str, bytes]:
    """The files of this process's kernel cache (numba's index and data files and the
    families' stamps; the cache directory is one for both families), to install in
    another process's cache with :func:`install_cache_files`: the kernels are compiled
    once, by the process that has them, not by every Dask worker.  Empty without a
    cache."""
    path = cache_path(FAMILIES[0])
    if path is None or not path.is_dir():
        return {}
    out = {}
    for p in sorted(path.iterdir()):
        if p.is_file() and p.suffix in (".nbi", ".nbc", ".ok"):
            with contextlib.suppress(OSError):
                out[p.name] = p.read_bytes()
    return out


def install_cache_files(files: dict[str, bytes], generic: bool = False) -> int:
    """Write the kernel cache ``files`` of another process (:func:`cache_files`, for the
    same sources, numba and Python) into this process's cache directory, each file that
    is not there yet; ``generic``: they were compiled for a generic CPU (this process
    then compiles and loads its kernels so, :func:`vsi_numba._jit.use_generic_cpu`).
    numba loads a kernel whose index entry names this process's target CPU; any other is
    compiled here as before.  Returns the number of files written."""
    from vsi_numba._jit import use_generic_cpu

    if not files or (generic and not use_generic_cpu()):
        return 0
    path = cache_path(FAMILIES[0])
    if path is None:
        return 0
    n = 0
    try:
        path.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            target = path / name
            if os.path.basename(name) != name or target.exists():
                continue
            tmp = path / f"{name}.tmp.{os.getpid()}"
            tmp.write_bytes(data)
            os.replace(tmp, target)
            n += 1
    except OSError:  # an unwritable cache: the kernels compile here
        return n
    return n
