"""``vsi compile``: the kernel families compiled into the numba cache (or loaded from it)
under their compile locks (:mod:`vsi_numba.solver.kernel_cache`)."""

from __future__ import annotations

import subprocess
import time

from vsi_numba.cli.common import EXIT_USAGE, Printer


def compile_command(family: str | None = None, quiet: bool = False) -> int:
    """Compile (or load) ``family``'s kernels, or both families'; print per family whether
    they were compiled or loaded and the seconds.  On an empty cache with 2 cores or more
    the moving-force family compiles in a second process while this one compiles the
    interaction family (the longer one).  Returns the exit code."""
    from vsi_numba._process import available_cores, term_with_parent
    from vsi_numba.solver import kernel_cache as kc
    from vsi_numba.solver.batch import compile_family

    pr = Printer()
    if family is not None and family not in kc.FAMILIES:
        pr.error(f"--family {family!r}: expected one of {', '.join(kc.FAMILIES)}")
        return EXIT_USAGE
    families = [family] if family else ["interaction", "moving_force"]
    helper = None
    t0 = time.perf_counter()
    if (len(families) == 2 and available_cores() >= 2
            and not any(kc.is_cached(f) for f in families)):
        try:
            helper = subprocess.Popen(kc.helper_command("moving_force"),
                                      stdin=subprocess.DEVNULL, preexec_fn=term_with_parent())
        except OSError:  # no process to spare: both compile here
            helper = None
    try:
        for f in families:
            how, seconds = compile_family(f)
            if helper is not None and f == "moving_force" and how == "loaded":
                how = "compiled in a second process"
                seconds = time.perf_counter() - t0
            if not quiet:
                pr.out.print(f"{f}: {how} ({seconds:.1f} s)", highlight=False)
    finally:
        if helper is not None:
            if helper.poll() is None:
                helper.terminate()
            helper.wait()
    return 0
