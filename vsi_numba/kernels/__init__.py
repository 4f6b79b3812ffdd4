"""numba kernels of the direct method (Neves et al., Eng. Struct. 69 (2014)): one module
per part of the method.

- :mod:`~vsi_numba.kernels.types`: the arrays the kernels work on, status codes
- :mod:`~vsi_numba.kernels.shapes`: mode shapes, Hermite tables, irregularity profile
- :mod:`~vsi_numba.kernels.linalg`: vehicle-block products, skyline Cholesky, small inverse
- :mod:`~vsi_numba.kernels.contact`: contact search, moving loads, deck-end crossings
- :mod:`~vsi_numba.kernels.integrator`: HHT-alpha coefficients, Newmark updates
- :mod:`~vsi_numba.kernels.schur`: the Schur system of the contact forces, active set, Hertz
- :mod:`~vsi_numba.kernels.impact`: plastic unilateral impacts (LCP)
- :mod:`~vsi_numba.kernels.suspension`: nonlinear suspension elements
- :mod:`~vsi_numba.kernels.track`: the damped track element under each wheel
- :mod:`~vsi_numba.kernels.step`: **the step of the method**, to be read first
- :mod:`~vsi_numba.kernels.record`: envelopes, load effects, histories
- :mod:`~vsi_numba.kernels.loop`: the time loop of the interaction runs
- :mod:`~vsi_numba.kernels.moving_force`: the runs of trains of moving forces

The Python calls that set them up and run them are in :mod:`vsi_numba.solver.driver`.
"""

from vsi_numba.kernels.loop import time_loop
from vsi_numba.kernels.moving_force import run_batch_mf
from vsi_numba.kernels.types import (
    NON_FINITE,
    NOT_CONVERGED,
    OK,
    SINGULAR_IMPACT,
    SINGULAR_SCHUR,
    BridgeArrays,
    Initial,
    Output,
    Params,
    ProfileArrays,
    Reduce,
    State,
    VehicleArrays,
    Work,
)

__all__ = ["NON_FINITE", "NOT_CONVERGED", "OK", "SINGULAR_IMPACT", "SINGULAR_SCHUR",
           "BridgeArrays", "Initial", "Output", "Params", "ProfileArrays", "Reduce", "State",
           "VehicleArrays", "Work", "run_batch_mf", "time_loop"]
