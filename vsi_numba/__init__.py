"""vsi_numba: nonlinear vertical vehicle-structure interaction for railway bridges.

The direct method (Neves, Montenegro, Azevedo, Calcada, Eng. Struct. 69, 2014) on a
modal-reduced bridge, with HHT-alpha time integration and numba kernels.

A few verbs::

    from vsi_numba import load_config, simulate, run_study, open_results
"""

from __future__ import annotations

import os as _os
import sys as _sys

__version__ = "0.2.0"

__all__ = ["__version__", "load_config", "open_results", "run_study", "simulate"]


def _absolute_numba_cache_dir() -> None:
    """A relative ``NUMBA_CACHE_DIR`` (the test command's ``.numba_cache``) is the one in
    the directory the command started in: made absolute before numba reads it, so a
    later change of directory, a worker process or a ``vsi`` started in another directory
    finds the same cache instead of compiling every kernel into a new one."""
    cache = _os.environ.get("NUMBA_CACHE_DIR")
    if not cache or _os.path.isabs(cache):
        return
    _os.environ["NUMBA_CACHE_DIR"] = _os.path.abspath(cache)
    config = getattr(_sys.modules.get("numba"), "config", None)
    if config is not None and getattr(config, "CACHE_DIR", None) == cache:
        config.CACHE_DIR = _os.environ["NUMBA_CACHE_DIR"]


_absolute_numba_cache_dir()


def __getattr__(name):  # lazy: importing the package must not compile or import numba
    if name == "simulate":
        from vsi_numba.solver.simulate import simulate

        return simulate
    if name == "load_config":
        from vsi_numba.config import load_config

        return load_config
    if name == "run_study":
        from vsi_numba.study import run_study

        return run_study
    if name == "open_results":
        from vsi_numba.io.netcdf import open_results

        return open_results
    raise AttributeError(name)
