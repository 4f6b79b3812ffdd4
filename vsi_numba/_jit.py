"""The one place numba options live.

Every kernel is compiled with ``cache=True`` so the JIT cost (tens of seconds here) is
paid once per machine; set ``NUMBA_CACHE_DIR`` where the package directory is read-only.
``fastmath`` stays off: results must be bit-reproducible across serial, process and Dask
runs, and IEEE semantics are needed for the NaN checks in the time loop.

``_nrt=False``: the kernels run without numba's runtime (no reference counting of the
arrays in the model, workspace and output tuples on every call and slice). They allocate
nothing - every array comes from the caller, and copies are plain loops - so nothing is
lost; the interaction step takes about a third less CPU time and the first compilation
about a fifth less. A kernel that must allocate opts back in with ``njit(_nrt=True)``
(numba refuses an allocation in the others at compile time).
"""

from __future__ import annotations

import numba

JIT_OPTIONS = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy",
               "_nrt": False}


def njit(func=None, **overrides):
    """``numba.njit`` with the project's options."""
    options = {**JIT_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)


def compile_for(kernel, *args) -> None:
    """Compile ``kernel`` for the numba types of ``args`` (the values it would be called
    with), without calling it."""
    kernel.compile(tuple(numba.typeof(a) for a in args))
