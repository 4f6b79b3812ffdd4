"""vsi_numba: nonlinear vertical vehicle-structure interaction for railway bridges.

The direct method (Neves, Montenegro, Azevedo, Calcada, Eng. Struct. 69, 2014) on a
modal-reduced bridge, with HHT-alpha time integration and numba kernels.

A few verbs::

    from vsi_numba import load_config, simulate, run_study, open_results
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__", "load_config", "open_results", "run_study", "simulate"]


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
