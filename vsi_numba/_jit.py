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
from numba.core.registry import CPUDispatcher

JIT_OPTIONS = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy",
               "_nrt": False}


def njit(func=None, *, kernel_only: bool = False, **overrides):
    """``numba.njit`` with the project's options.

    ``kernel_only``: a kernel that only other kernels call, compiled without the CPython
    wrapper (the code that unboxes the arguments of a call from Python: for the
    namedtuples of arrays the engine passes around it is large, and compiling it took
    ~0.4 s per kernel, ~10 s of the interaction kernels' ~49 s of CPU from an empty
    cache).  Calling such a kernel from Python raises a TypeError (:class:`KernelOnly`);
    without this guard numba's entry point would be a null pointer.
    """
    if func is None:
        return lambda f: njit(f, kernel_only=kernel_only, **overrides)
    options = {**JIT_OPTIONS, **overrides}
    if not kernel_only:
        return numba.njit(**options)(func)
    if numba.config.DISABLE_JIT:  # as numba.njit: the Python function itself
        return func
    cache = options.pop("cache")
    disp = KernelOnly(py_func=func, locals={},
                      targetoptions={**options, "nopython": True, "boundscheck": None,
                                     "no_cpython_wrapper": True})
    if cache:
        disp.enable_caching()
    return disp


class KernelOnly(CPUDispatcher):
    """The dispatcher of a kernel compiled without a CPython wrapper (``njit(...,
    kernel_only=True)``): kernels call it as any other; a call from Python raises."""

    def __call__(self, *args, **kwargs):
        name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
        raise TypeError(f"{name} is compiled to be called from kernels only (no entry point "
                        "from Python): call it from a jitted function")


def compile_for(kernel, *args) -> None:
    """Compile ``kernel`` for the numba types of ``args`` (the values it would be called
    with), without calling it."""
    kernel.compile(tuple(numba.typeof(a) for a in args))
