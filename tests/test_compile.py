"""Compiling the kernels once per machine (:mod:`vsi_numba.solver.kernel_cache`,
``vsi compile``).

What it must get right: the tiny batch that compiles a family has the very signature a
study uses (else the study compiles again), N processes on an empty cache compile a
family once (the others wait for the lock and load it), the stamp that tells another
process the cache holds a family, and ``vsi compile`` saying what it did.  Real
processes, no timing assertions.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import subprocess
import sys

import pytest

from vsi_numba.model import bridge as br
from vsi_numba.model.library.builders import get_train
from vsi_numba.solver import kernel_cache as kc
from vsi_numba.solver.batch import compile_family
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import pack, simulate

VSI = [sys.executable, "-m", "vsi_numba.cli"]


def test_family_of__hslm_is_moving_forces_and_ice3_interaction():
    beam = br.simply_supported(25.0, 7.16e10, 18000.0, n_modes=3)
    s = SolverSettings(dt=1e-3)
    assert kc.family_of(pack(beam, get_train("HSLM-A1", model="moving_force"), 50.0,
                             None, s)) == "moving_force"
    assert kc.family_of(pack(beam, get_train("ICE3", model="interaction"), 50.0,
                             None, s)) == "interaction"


@pytest.mark.parametrize("family", kc.FAMILIES)
def test_compile_family__compiles_the_signature_a_study_uses(family):
    """After the tiny batch and a real model of the family (another bridge, train, modes
    and load effects) the family's kernel has one compiled signature: what ``vsi compile``
    puts in the cache is what the study loads."""
    assert compile_family(family)[0] in ("ready", "loaded", "compiled")
    beam = br.simply_supported(25.0, 7.16e10, 18000.0, n_modes=3)
    train = (get_train("HSLM-A3", model="moving_force") if family == "moving_force"
             else get_train("ICE3", model="interaction"))
    simulate(beam, train, 60.0, settings=SolverSettings(dt=2e-3, approach=2.0,
                                                        free_vibration=0.0),
             output_points=[12.5], save_histories=True)
    kernel = kc.kernel(family)
    assert len(kernel.signatures) == 1, kernel.signatures
    assert kc.is_cached(family)
    assert compile_family(family)[0] == "ready"


def _vsi(*args, cache_dir=None, **kwargs) -> subprocess.CompletedProcess:
    env = {**os.environ}
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    return subprocess.run([*VSI, *args], env=env, capture_output=True, text=True,
                          timeout=900, **kwargs)


def test_vsi_compile__on_a_filled_cache_loads_both_families():
    """The suite's own cache holds both families (the tests' controller ran ``vsi
    compile``): a fresh process loads them and says so, one line per family."""
    done = _vsi("compile")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert [ln.split(":")[0] for ln in lines] == ["interaction", "moving_force"]
    for ln in lines:
        assert ln.split(":")[1].strip().startswith("loaded ("), ln


def test_vsi_compile__an_unknown_family_is_a_usage_error():
    done = _vsi("compile", "--family", "maglev")
    assert done.returncode == 2
    assert "--family 'maglev': expected one of moving_force, interaction" in done.stderr


def _is_cached(family: str, cache) -> bool:
    """``kc.is_cached(family)`` in a fresh process on the cache directory ``cache``."""
    code = f"from vsi_numba.solver import kernel_cache as kc; print(kc.is_cached({family!r}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "NUMBA_CACHE_DIR": str(cache)},
                         check=True).stdout.strip()
    assert out in ("True", "False"), out
    return out == "True"


def _build_generic(root) -> dict:
    """Two ``vsi compile --family moving_force --into DIR`` at once on an empty DIR (the
    one compilation from an empty cache of this file: the two tests below check it), with
    what a fresh process on DIR says of the two families before and after."""
    from vsi_numba._jit import GENERIC_MARK

    built = root / "built"
    built.mkdir()
    (built / GENERIC_MARK).touch()  # as --into marks it: the processes asking see generic
    before = _is_cached("moving_force", built)
    procs = [subprocess.Popen([*VSI, "compile", "--family", "moving_force", "--into",
                               str(built)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
             for _ in range(2)]
    outs = [p.communicate(timeout=900) for p in procs]
    return {"built": str(built), "before": before, "codes": [p.returncode for p in procs],
            "outs": outs, "after": _is_cached("moving_force", built),
            "interaction": _is_cached("interaction", built)}


@pytest.fixture()
def generic_build(tmp_path_factory) -> dict:
    from tests.shared import shared_once

    return shared_once(tmp_path_factory, "compile-generic", _build_generic)[1]


def test_vsi_compile__two_processes_on_an_empty_cache_compile_once(generic_build):
    """Two ``vsi compile --family moving_force`` at once on an empty cache (for a generic
    CPU, ``--into``: the compile lock and the stamp are those of any cache): one compiles
    (holding the lock), the other waits and loads the kernels from the cache; a process
    started afterwards sees the stamp (:func:`is_cached`) without compiling."""
    b = generic_build
    assert b["before"] is False
    assert b["codes"] == [0, 0], b["outs"]
    hows = sorted(out.split(":")[1].split("(")[0].strip() for out, _ in b["outs"])
    assert hows == ["compiled", "loaded"], b["outs"]
    assert b["after"] is True
    assert b["interaction"] is False  # not compiled there


def test_vsi_compile_into__a_copied_generic_cache_loads_elsewhere(generic_build, tmp_path):
    """``vsi compile --into DIR`` compiles for a generic CPU into DIR (its marker file,
    the kernels under ``vsi_numba.kernels-HASH``: no path of this machine); a copy of DIR
    at another path, used as ``NUMBA_CACHE_DIR``, makes the process target the generic
    CPU and load the kernels (a host-CPU process would miss numba's index key and
    compile), and a plain cache directory gives a host-CPU process."""
    import shutil
    from pathlib import Path

    from vsi_numba._jit import GENERIC_MARK

    built = Path(generic_build["built"])
    assert generic_build["codes"] == [0, 0], generic_build["outs"]
    [out] = [o for o, _ in generic_build["outs"] if "compiled (" in o]
    assert out.splitlines()[0].startswith("moving_force: compiled ("), out
    assert f"NUMBA_CACHE_DIR={built}" in out.replace("\n", "")
    assert (built / GENERIC_MARK).is_file()
    subdirs = [p.name for p in built.iterdir() if p.is_dir()]
    assert len(subdirs) == 1 and subdirs[0].startswith("vsi_numba.kernels-"), subdirs
    assert any((built / subdirs[0]).glob("*.nbi"))
    copy = tmp_path / "elsewhere" / "kernels"
    shutil.copytree(built, copy)
    code = "import numba, vsi_numba._jit; print(numba.config.CPU_NAME)"
    for cache, cpu in ((copy, "generic"), (tmp_path / "plain", "None")):
        ask = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env={**os.environ, "NUMBA_CACHE_DIR": str(cache)}, check=True)
        assert ask.stdout.strip() == cpu, (cache, ask.stdout)
    loaded = _vsi("compile", "--family", "moving_force", cache_dir=copy)
    assert loaded.returncode == 0, loaded.stderr
    assert loaded.stdout.startswith("moving_force: loaded ("), loaded.stdout


_HOLDER = """
import sys, time
from vsi_numba.solver.kernel_cache import compile_lock
with compile_lock("moving_force"):
    print("held", flush=True)
    sys.stdin.readline()
    print(time.monotonic(), flush=True)
"""

_WAITER = """
import sys, time
import vsi_numba.kernels  # imported before "trying": the lock is the next step
from vsi_numba.solver.kernel_cache import compile_lock
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


def test_kernel_only__a_call_from_python_raises_instead_of_crashing():
    """The kernels compiled without a CPython wrapper (``njit(kernel_only=True)``: only
    kernels call them) have no entry point from Python; calling one from Python raises a
    TypeError that names it (numba's entry point would be a null pointer), and the
    kernels that call them run (the whole suite runs them through time_loop)."""
    import vsi_numba.kernels as kernels_package
    from vsi_numba._jit import KernelOnly

    modules = [importlib.import_module(f"vsi_numba.kernels.{m.name}")
               for m in pkgutil.iter_modules(kernels_package.__path__)]
    only = [k for mod in modules for k in vars(mod).values() if isinstance(k, KernelOnly)]
    assert {k.py_func.__name__ for k in only} >= {"impact_update", "record", "prepare_khat",
                                                  "load_windows"}
    for kernel in only:
        with pytest.raises(TypeError, match=f"{kernel.py_func.__name__} is compiled "
                                            "to be called from kernels only"):
            kernel(1.0)
    assert not isinstance(kernels_package.time_loop, KernelOnly)  # the entry points keep theirs
