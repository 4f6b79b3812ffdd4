"""A first run compiles the moving-force and the interaction kernels at the same time.

numba compiles one kernel at a time in a process (a global compiler lock), and the two
kernel families share no compiled code: :func:`~vsi_numba.kernels.engine.run_batch_mf`
runs the trains of moving forces, :func:`~vsi_numba.kernels.engine.time_loop` and its
callees the interaction models.  A study that needs both while neither is in the numba
cache hands the family its batch order needs last to a helper process
(:func:`start_helper`), which compiles it into the same cache (``NUMBA_CACHE_DIR``)
while this process compiles the other family and runs its batches; the first batch of
the helper's family waits for the helper (:func:`wait_for`) and then loads the kernels
from the cache.  With a warm cache, or a study of one family, nothing is started.  A
moving-force helper runs at a lower priority (:data:`MOVING_FORCE_HELPER_NICE`): its
kernels compile in ~12 s, the interaction kernels in ~40 s, which the first run waits for.

Across processes, :func:`ensure_compiled` makes a family compile once per machine: a
process that has not compiled the family compiles it (on a tiny model) holding a lock
file next to the family's numba cache, so the other processes (local workers, Dask
workers of one machine, test processes) that need it meanwhile wait and then load the
kernels from the cache instead of compiling them again - N worker processes starting on
an empty cache compile once, not N times at once (each compile takes ~1 GB).

``python -m vsi_numba.solver.warm FAMILY`` is the helper: it compiles (or loads) the
family's kernels on a tiny model of the same types and exits.  The interaction
kernels' own compilation from an empty cache runs in two processes: while one compiles
the kernels top-down, ``... interaction --leaves`` compiles their largest leaves (which
the first reaches last) into the cache (:func:`ensure_compiled`); the first goes on as
soon as the leaf it reaches is there (:func:`_lookups_wait_for`).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
import time

#: The kernel families: trains of moving forces, interaction models.
FAMILIES = ("moving_force", "interaction")

_helpers: dict[str, subprocess.Popen] = {}
_lock = threading.Lock()


def family_of(packed) -> str:
    """The kernel family that runs a packed model (as :func:`~vsi_numba.kernels.engine.
    run_batch` chooses it)."""
    veh = packed.vehicles
    return ("moving_force" if veh.wheel_dof.size == 0 and veh.start.size == 1
            else "interaction")


def is_cached(family: str) -> bool:
    """Whether the family's top kernel (:func:`run_batch_mf` or :func:`time_loop`) is
    compiled in this process or numba's cache holds a version of it for the current
    source.

    Reads numba's cache index through its internal API; if that API is not there (a
    numba release that changed it) the answer is True, so no helper is started.
    """
    kernel = _kernel(family)
    if _compiled(family):  # compiled (or loaded) in this process already
        return True
    try:
        return bool(kernel._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 - no helper rather than a wrong guess
        return True


#: Seconds a process waits for another's compilation of a family before it compiles the
#: family itself (a compilation takes about a minute on a slow machine).
LOCK_TIMEOUT = 600.0


def _kernel(family: str):
    from vsi_numba import kernels as ek

    return ek.run_batch_mf if family == "moving_force" else ek.time_loop


def _compiled(family: str) -> bool:
    """Compiled in this process (or no JIT at all: ``NUMBA_DISABLE_JIT``)."""
    return bool(getattr(_kernel(family), "signatures", True))


def lock_path(family: str):
    """The lock file of ``family``'s compilation: in the directory of its numba cache
    (None where numba's cache API does not tell it)."""
    from pathlib import Path

    try:
        return Path(_kernel(family)._cache._cache_path) / f"vsi_numba-{family}.lock"
    except Exception:  # noqa: BLE001 - no lock rather than a wrong one
        return None


@contextlib.contextmanager
def compile_lock(family: str, timeout: float = LOCK_TIMEOUT):
    """Hold the machine-wide lock of ``family``'s compilation (a no-op where there is no
    ``fcntl`` or no cache directory).  A process that finds it held waits until it is
    free (the other process has compiled and cached the kernels, or died: the lock goes
    with it), or ``timeout`` seconds, then goes on."""
    path = lock_path(family)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        path = None
    fh = None
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fh = open(path, "a")  # noqa: SIM115 - closed below
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


_warming = threading.local()


def ensure_compiled(family: str, timeout: float = LOCK_TIMEOUT) -> None:
    """Have ``family``'s kernels compiled (or loaded from the cache) in this process, on
    the tiny model of :func:`warm_up_family`, under :func:`compile_lock`: of the
    processes of a machine that need the family at the same time, one compiles it and
    the others wait, then load it from the cache.  Called before every batch; once the
    family is compiled here it returns at once.  The lock is held for the compilation
    only, never for a batch."""
    if _compiled(family) or getattr(_warming, family, False):
        return
    with compile_lock(family, timeout):
        if _compiled(family):  # another thread of this process did it
            return
        setattr(_warming, family, True)
        leaves = _start_leaves(family)
        try:
            with _lookups_wait_for(leaves):
                warm_up_family(family)
        finally:
            setattr(_warming, family, False)
            if leaves is not None:  # done long before, normally; not needed any more
                if leaves.poll() is None:
                    leaves.terminate()
                leaves.wait()


#: Cores below which no second process compiles the interaction kernels' leaves (on
#: one core it would only slow down the main compilation).
LEAVES_MIN_CORES = 2

#: Seconds between two cache look-ups of a leaf the leaves process has not written yet.
LEAF_POLL = 0.05


def leaves_command(family: str) -> list[str]:
    """``python -m vsi_numba.solver.warm FAMILY --leaves``: compile the family's leaves
    only (:func:`~vsi_numba.kernels.engine.compile_leaves`), without the lock."""
    return helper_command(family) + ["--leaves"]


@contextlib.contextmanager
def _lookups_wait_for(leaves):
    """While the interaction kernels compile here: numba's cache look-up of each leaf
    (:data:`~vsi_numba.kernels.engine.LEAVES`) is repeated until it finds the leaf or
    the ``leaves`` process has exited, so that this compilation finds the leaf in the
    cache instead of compiling it a second time when it gets there first (a busy
    machine), and goes on as soon as that leaf is written, while the process still
    compiles the others (numba writes a cache entry's data, then its index, each by
    renaming a complete file).  Uses numba's internal ``_cache.load_overload``; where it
    is missing nothing is changed."""
    if leaves is None:
        yield
        return
    from vsi_numba.solver.driver import LEAVES

    def waiting(load):
        def look_up(*args, **kwargs):
            deadline = time.monotonic() + LOCK_TIMEOUT
            while leaves.poll() is None:
                found = load(*args, **kwargs)
                if found is not None:
                    return found
                if time.monotonic() > deadline:  # pragma: no cover - a stuck process
                    leaves.kill()
                    break
                time.sleep(LEAF_POLL)
            return load(*args, **kwargs)

        return look_up

    patched = []
    for kernel in LEAVES:
        cache = getattr(kernel, "_cache", None)
        load = getattr(cache, "load_overload", None)
        if load is not None:
            cache.load_overload = waiting(load)
            patched.append(cache)
    try:
        yield
    finally:
        for cache in patched:
            del cache.load_overload  # the class's method again


def _start_leaves(family: str):
    """While this process compiles the interaction kernels from an empty cache, a
    second process compiles their largest leaves
    (:func:`~vsi_numba.kernels.engine.compile_leaves`) into the same cache, where the
    compilation here finds them (~10 s of its ~60 s on one core).  None (nothing
    started) for the moving-force family, a cached family or fewer than
    :data:`LEAVES_MIN_CORES` cores."""
    from vsi_numba._process import available_cores, term_with_parent

    if (family != "interaction" or is_cached(family)
            or available_cores() < LEAVES_MIN_CORES):
        return None
    try:
        return subprocess.Popen(leaves_command(family), env=dict(os.environ),
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, preexec_fn=term_with_parent())
    except OSError:  # no process to spare: this process compiles them all, as without
        return None


def helper_family(families_in_order, cached=is_cached) -> str | None:
    """The family a helper should compile: the last one of ``families_in_order`` (the
    families of the batches in the order they run) when two families are needed and
    neither is ``cached``; else None."""
    order = list(dict.fromkeys(families_in_order))
    if len(order) < 2 or any(cached(f) for f in order):
        return None
    return order[-1]


def helper_command(family: str) -> list[str]:
    """The helper's command line: ``python -m vsi_numba.solver.warm FAMILY``."""
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: expected one of {FAMILIES}")
    return [sys.executable, "-m", "vsi_numba.solver.warm", family]


#: ``nice`` increment of a helper compiling the moving-force kernels.  Its family is the
#: short one (~12 s against ~40 s for the interaction kernels, which this process then
#: compiles with a leaves process): with fewer cores than compiling processes, the
#: interaction compilation, which the first run waits for, goes first and the helper
#: takes what is left (main job's first run on 2 cores: 54 -> 47 s).
MOVING_FORCE_HELPER_NICE = 10


def _niced(preexec_fn, increment: int):
    """``preexec_fn`` preceded by ``os.nice(increment)`` (in the child, before exec)."""

    def run():
        os.nice(increment)
        if preexec_fn is not None:
            preexec_fn()

    return run


def start_helper(family: str, preexec_fn=None) -> subprocess.Popen:
    """Start ``python -m vsi_numba.solver.warm FAMILY`` (same environment, so the same
    numba cache; output discarded); ``preexec_fn`` as for :class:`subprocess.Popen`
    (the study runner's makes Linux end the helper when this process dies).  A
    moving-force helper runs at a lower priority (:data:`MOVING_FORCE_HELPER_NICE`)."""
    if family == "moving_force" and hasattr(os, "nice"):
        preexec_fn = _niced(preexec_fn, MOVING_FORCE_HELPER_NICE)
    proc = subprocess.Popen(helper_command(family), env=dict(os.environ),
                            stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            preexec_fn=preexec_fn)
    with _lock:
        _helpers[family] = proc
    return proc


def wait_for(family: str) -> float:
    """Wait until the helper compiling ``family`` (if any) has exited; returns the
    seconds waited.  Whatever its exit status, the caller then runs the kernels: from
    the cache if the helper filled it, compiled here if it did not."""
    proc = _helpers.get(family)
    if proc is None:  # no helper (the usual case)
        return 0.0
    t0 = time.perf_counter()
    proc.wait()  # any number of threads may wait; no lock held meanwhile (Ctrl-C)
    with _lock:
        if _helpers.get(family) is proc:
            del _helpers[family]
    return time.perf_counter() - t0


def stop_helpers() -> None:
    """End every helper still running (the study stopped before it needed them)."""
    with _lock:
        procs = list(_helpers.values())
        _helpers.clear()
    for proc in procs:
        if proc.poll() is None:
            proc.terminate()
        proc.wait()


def warm_up_family(family: str, leaves: bool = False) -> float:
    """Compile (or load from the cache) the kernels of ``family`` on a tiny model;
    returns the seconds it took.  ``leaves``: only the interaction kernels' leaves
    (:func:`~vsi_numba.kernels.engine.compile_leaves`), for the same types."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.model.vehicle import Train
    from vsi_numba.solver.batch import run_batch
    from vsi_numba.solver.pack import pack
    from vsi_numba.solver.settings import SolverSettings

    if leaves and family != "interaction":
        raise ValueError(f"family = {family!r}: only 'interaction' has leaves to compile")
    t0 = time.perf_counter()
    beam = br.simply_supported(10.0, 1e9, 1e4, n_modes=2)
    if family == "moving_force":
        unit = vh.point_loads([0.0, 3.0], [1e5, 1e5], name="warm-up")
    elif family == "interaction":
        unit = vh.sprung_mass(1e3, 1e6, 1e3, 100.0)
    else:
        raise ValueError(f"family = {family!r}: expected one of {FAMILIES}")
    # the batch kernel as a study runs it (no xarray Dataset: nothing else to import)
    settings = SolverSettings(dt=5e-3, approach=0.0, free_vibration=0.0)
    profile = no_irregularity()
    packed = pack(beam, Train("warm-up", (unit,), (0.0,)), 50.0, profile, settings)
    if leaves:
        from vsi_numba.solver.driver import compile_leaves

        run_batch(packed, profile, [50.0], [5.0], settings, beam, _kernel=compile_leaves)
    else:
        run_batch(packed, profile, [50.0], [5.0], settings, beam)
    return time.perf_counter() - t0


if __name__ == "__main__":  # pragma: no cover - the helper process
    # the package's module, not this __main__ copy: one ``_warming`` flag per process
    from vsi_numba.solver import warm as _warm

    if sys.argv[2:] == ["--leaves"]:
        _warm.warm_up_family(sys.argv[1], leaves=True)
    else:
        _warm.ensure_compiled(sys.argv[1])
