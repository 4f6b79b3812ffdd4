"""The compile helper of a first run (:mod:`vsi_numba.solver.warm`).

What it must get right: which family a helper compiles (only when both are needed and
neither is cached), that the helper's tiny model compiles the very signature a study
uses (else the helper's work would be lost and the kernels compiled twice), and that a
batch waiting for the helper never runs before the helper has exited.  Real processes,
no timing assertions.
"""

from __future__ import annotations

import subprocess
import sys
import threading

import pytest

from vsi_numba.model import bridge as br
from vsi_numba.model.library.builders import get_train
from vsi_numba.solver import driver as ek
from vsi_numba.solver import warm
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import pack, simulate


def test_helper_family__only_two_uncached_families_and_the_last_one_needed():
    none = lambda f: False  # noqa: E731 - a cache holding nothing
    assert warm.helper_family(["interaction", "moving_force", "interaction"],
                              none) == "moving_force"
    assert warm.helper_family(["moving_force", "moving_force", "interaction"],
                              none) == "interaction"
    assert warm.helper_family(["interaction"] * 3, none) is None  # one family
    assert warm.helper_family([], none) is None
    mf_cached = lambda f: f == "moving_force"  # noqa: E731
    assert warm.helper_family(["interaction", "moving_force"], mf_cached) is None


def test_family_of__hslm_is_moving_forces_and_ice3_interaction():
    beam = br.simply_supported(25.0, 7.16e10, 18000.0, n_modes=3)
    s = SolverSettings(dt=1e-3)
    assert warm.family_of(pack(beam, get_train("HSLM-A1", model="moving_force"), 50.0,
                               None, s)) == "moving_force"
    assert warm.family_of(pack(beam, get_train("ICE3", model="interaction"), 50.0,
                               None, s)) == "interaction"


@pytest.mark.parametrize("family", warm.FAMILIES)
def test_warm_up_family__compiles_the_signature_a_study_uses(family):
    """After the helper's tiny model and a real model of the family (another bridge,
    train, modes and load effects) the family's kernel has one compiled signature: the
    helper's work is what the study loads from the cache."""
    warm.warm_up_family(family)
    beam = br.simply_supported(25.0, 7.16e10, 18000.0, n_modes=3)
    train = (get_train("HSLM-A3", model="moving_force") if family == "moving_force"
             else get_train("ICE3", model="interaction"))
    simulate(beam, train, 60.0, settings=SolverSettings(dt=2e-3, approach=2.0,
                                                        free_vibration=0.0),
             output_points=[12.5], save_histories=True)
    kernel = ek.run_batch_mf if family == "moving_force" else ek.time_loop
    assert len(kernel.signatures) == 1, kernel.signatures
    assert warm.is_cached(family)  # cache=True: the index now names it


def _sleeper(seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])


def test_wait_for__every_waiting_thread_returns_after_the_helper_exited():
    proc = _sleeper(0.5)
    with warm._lock:
        warm._helpers["interaction"] = proc
    seen: list = []

    def batch():
        warm.wait_for("interaction")
        seen.append(proc.poll())  # the helper's exit code: it has exited

    threads = [threading.Thread(target=batch) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert seen == [0, 0, 0]
    assert warm.wait_for("interaction") == 0.0  # gone: no wait, no lock
    assert warm.wait_for("moving_force") == 0.0


def test_stop_helpers__ends_a_helper_still_running():
    proc = _sleeper(600)
    with warm._lock:
        warm._helpers["moving_force"] = proc
    warm.stop_helpers()
    assert proc.poll() is not None
    assert not warm._helpers


def test_start_helper__a_moving_force_helper_runs_at_a_lower_priority():
    """The moving-force helper starts ``MOVING_FORCE_HELPER_NICE`` below this process's
    priority (the interaction compilation, which a first run waits for, goes first); an
    interaction helper at this process's.  The priority is set before the exec, so it is
    there when ``Popen`` returns (and stays while the process is a zombie)."""
    import os

    base = os.getpriority(os.PRIO_PROCESS, 0)
    for family, increment in (("moving_force", warm.MOVING_FORCE_HELPER_NICE),
                              ("interaction", 0)):
        proc = warm.start_helper(family)
        try:
            assert os.getpriority(os.PRIO_PROCESS, proc.pid) == min(base + increment, 19)
        finally:
            warm.stop_helpers()
        assert proc.poll() is not None


def test_is_cached__reads_the_numba_cache_of_another_process(tmp_path):
    """A fresh process (nothing compiled in it) sees the family this process compiled
    into the shared cache, and sees nothing in an empty cache directory."""
    import os

    warm.warm_up_family("moving_force")  # compiled or loaded: in the cache now
    code = "from vsi_numba.solver.warm import is_cached; print(is_cached('moving_force'))"

    def ask(cache_dir):
        env = {**os.environ}
        if cache_dir is not None:
            env["NUMBA_CACHE_DIR"] = str(cache_dir)
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, check=True).stdout.strip()

    assert ask(None) == "True"
    assert ask(tmp_path / "empty") == "False"


_HOLDER = """
import sys, time
from vsi_numba.solver.warm import compile_lock
with compile_lock("moving_force"):
    print("held", flush=True)
    sys.stdin.readline()
    print(time.monotonic(), flush=True)
"""

_WAITER = """
import sys, time
import vsi_numba.kernels  # imported before "trying": the lock is the next step
from vsi_numba.solver.warm import compile_lock
print("trying", flush=True)
with compile_lock("moving_force", timeout=float(sys.argv[1])):
    print(time.monotonic(), flush=True)
"""


def test_compile_lock__a_second_process_waits_until_the_first_releases():
    """Two fresh processes (nothing compiled in them): the second enters only after the
    first has left (monotonic clock, one per machine); with a short timeout it goes on
    while the first still holds the lock."""
    with subprocess.Popen([sys.executable, "-c", _HOLDER], stdin=subprocess.PIPE,
                          stdout=subprocess.PIPE, text=True) as holder:
        try:
            assert holder.stdout.readline().strip() == "held"
            # a waiter with a short timeout goes on although the lock is held
            quick = subprocess.run([sys.executable, "-c", _WAITER, "0.5"],
                                   capture_output=True, text=True, check=True)
            assert float(quick.stdout.split()[-1])  # it entered
            with subprocess.Popen([sys.executable, "-c", _WAITER, "600"],
                                  stdout=subprocess.PIPE, text=True) as waiter:
                assert waiter.stdout.readline().strip() == "trying"  # at the lock now
                holder.stdin.write("\n")
                holder.stdin.flush()
                released = float(holder.stdout.readline())
                entered = float(waiter.communicate(timeout=120)[0].split()[-1])
            assert entered >= released
        finally:
            holder.kill()


def test_ensure_compiled__a_fresh_process_compiles_under_the_lock_without_deadlock():
    """The warm-up batch inside :func:`ensure_compiled` calls ``ensure_compiled`` again
    (every batch does): it must not wait for its own lock.  Both families, in a fresh
    process, end compiled; 120 s is far more than loading them from the cache."""
    code = ("from vsi_numba.solver import warm\n"
            "for f in warm.FAMILIES:\n"
            "    warm.ensure_compiled(f)\n"
            "    print(f, bool(warm._kernel(f).signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout.split()
    assert out == ["moving_force", "True", "interaction", "True"]
    for family in warm.FAMILIES:  # the helper's command (this module as __main__)
        subprocess.run([sys.executable, "-m", "vsi_numba.solver.warm", family], check=True,
                       timeout=120)


def test_kernel_only__a_call_from_python_raises_instead_of_crashing():
    """The kernels compiled without a CPython wrapper (``njit(kernel_only=True)``: only
    kernels call them) have no entry point from Python; calling one from Python raises a
    TypeError that names it (numba's entry point would be a null pointer), and the
    kernels that call them run (the whole suite runs them through time_loop)."""
    from vsi_numba._jit import KernelOnly

    only = [k for k in vars(ek).values() if isinstance(k, KernelOnly)]
    assert {k.py_func.__name__ for k in only} >= {"impact_update", "record", "prepare_khat",
                                                  "load_windows"}
    for kernel in only:
        with pytest.raises(TypeError, match=f"engine.{kernel.py_func.__name__} is compiled "
                                            "to be called from kernels only"):
            kernel(1.0)
    assert not isinstance(ek.time_loop, KernelOnly)  # the entry points keep theirs


def test_compile_leaves__have_the_types_time_loop_passes_them():
    """The leaves a second process compiles while the interaction kernels compile from an
    empty cache (``python -m vsi_numba.solver.warm interaction --leaves``) must be the
    very signatures :func:`time_loop` calls, else that process's work is lost and they
    compile twice: after the family and the leaves, numba's cache index of each leaf
    names one signature (a second would be a leaf compiled for other types)."""
    warm.ensure_compiled("interaction")  # time_loop compiled (or loaded) on this cache
    subprocess.run(warm.leaves_command("interaction"), check=True, timeout=300)
    assert {k.py_func.__name__ for k in ek.LEAVES} == {"impact_update",
                                                       "nl_update_branches", "record"}
    for kernel in ek.LEAVES:
        index = kernel._cache._cache_file._load_index()
        assert len({key[0] for key in index}) == 1, list(index)
    with pytest.raises(ValueError, match="only 'interaction'"):
        warm.warm_up_family("moving_force", leaves=True)


def test_lookups_wait_for__a_leaf_look_up_waits_until_the_leaf_is_cached():
    """During the interaction compile, numba's cache look-up of a leaf finds a leaf that
    is in the cache at once, while the leaves process still runs (it goes on compiling
    the others); a leaf that is not there yet is looked up again until that process
    exits (so the leaf is found instead of compiled a second time).  Afterwards the
    look-up is numba's own again."""
    warm.ensure_compiled("interaction")  # the leaves in the cache, for time_loop's types
    cache = ek.impact_update._cache
    ctx = ek.impact_update.targetctx
    cached_sig = next(iter(cache._cache_file._load_index()))[0]  # (sig, target, ...)
    running = _sleeper(60)  # a leaves process still at work
    try:
        with warm._lookups_wait_for(running):
            assert "load_overload" in vars(cache)
            assert cache.load_overload(cached_sig, ctx) is not None
            assert running.poll() is None  # found without waiting for the process
        ending = _sleeper(1.0)
        with warm._lookups_wait_for(ending):
            assert cache.load_overload((), ctx) is None  # a signature nobody compiles
            assert ending.poll() is not None  # looked up until the process had exited
    finally:
        running.kill()
        running.wait()
    assert "load_overload" not in vars(cache)
    assert "load_overload" not in vars(ek.nl_update_branches._cache)
