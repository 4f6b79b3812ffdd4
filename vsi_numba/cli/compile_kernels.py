"""``vsi compile``: the kernel families compiled into the numba cache (or loaded from it)
under their compile locks (:mod:`vsi_numba.solver.kernel_cache`); ``--into DIR``: for a
generic CPU, into a cache directory of their own that other machines can use."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer


def compile_command(family: str | None = None, quiet: bool = False,
                    into: Path | None = None) -> int:
    """Compile (or load) ``family``'s kernels, or both families'; print per family whether
    they were compiled or loaded and the seconds.  On an empty cache with 2 cores or more
    the moving-force family compiles in a second process while this one compiles the
    interaction family (the longer one).  ``into``: compile them for a generic CPU into
    that directory instead (:func:`compile_into`).  Returns the exit code."""
    from vsi_numba.solver import kernel_cache as kc
    from vsi_numba.solver.batch import compile_family

    pr = Printer()
    if family is not None and family not in kc.FAMILIES:
        pr.error(f"--family {family!r}: expected one of {', '.join(kc.FAMILIES)}")
        return EXIT_USAGE
    if into is not None:
        return compile_into(into, family, quiet)
    families = [family] if family else ["interaction", "moving_force"]
    t0 = time.perf_counter()
    with kc.stop_helper(kc.start_helper(families)) as helper:
        for f in families:
            how, seconds = compile_family(f)
            if helper is not None and f == "moving_force" and how == "loaded":
                how = "compiled in a second process"
                seconds = time.perf_counter() - t0
            if not quiet:
                pr.out.print(f"{f}: {how} ({seconds:.1f} s)", highlight=False)
    return 0


def compile_into(directory: Path, family: str | None = None, quiet: bool = False) -> int:
    """The kernels compiled for a generic CPU of this machine's architecture into the
    numba cache directory ``directory`` (``vsi compile`` in a process whose
    ``NUMBA_CACHE_DIR`` is ``directory``, marked with :data:`~vsi_numba._jit.GENERIC_MARK`):
    a process with ``NUMBA_CACHE_DIR`` set to that directory, or to a copy of it on
    another machine with the same Python, numba and sources, loads them instead of
    compiling.  Returns the exit code."""
    from vsi_numba._jit import GENERIC_CPU_ENV, GENERIC_MARK

    pr = Printer()
    directory = Path(directory).expanduser().resolve()
    try:
        directory.mkdir(parents=True, exist_ok=True)
        (directory / GENERIC_MARK).touch()
    except OSError as exc:
        pr.error(f"--into {str(directory)!r}: cannot write there ({exc.strerror})")
        return EXIT_USAGE
    env = {**os.environ, "NUMBA_CACHE_DIR": str(directory), **GENERIC_CPU_ENV}
    cmd = [sys.executable, "-m", "vsi_numba.cli", "compile"]
    cmd += ["--family", family] if family else []
    cmd += ["--quiet"] if quiet else []
    code = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL).returncode
    if code == 0 and not quiet:
        pr.out.print(f"kernels for a generic CPU in {directory}: a study loads them with "
                     f"NUMBA_CACHE_DIR={directory}", highlight=False, soft_wrap=True)
    return code
