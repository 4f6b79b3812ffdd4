"""The one place numba options live.

Every kernel is compiled with ``cache=True`` so the JIT cost (tens of seconds here) is
paid once per machine; set ``NUMBA_CACHE_DIR`` where the package directory is read-only.
``fastmath`` stays off: results must be bit-reproducible across serial, process and Dask
runs, and IEEE semantics are needed for the NaN checks in the time loop.

``_nrt=False``: the kernels run without numba's runtime (no reference counting of the
arrays in the model, workspace and output tuples on every call and slice). They allocate
nothing - every array comes from the caller, and copies are plain loops - so nothing is
lost, and the step and the compilation are cheaper without it. A kernel that must
allocate opts back in with ``njit(_nrt=True)`` (numba refuses an allocation in the others
at compile time).

A counter that a kernel passes to another kernel starts as ``np.int64(0)``, not ``0``:
numba types the call as soon as it knows a first type for each argument, and for a
counter that starts as ``0`` that is the literal ``Literal[int](0)``, so the callee
would be compiled once for the literal and once more for ``int64``.

``no_cfunc_wrapper=True``: numba would also compile a C-ABI entry point for every kernel
(for calls through a function pointer, which nothing here makes); for the bundles of
arrays the kernels take, its code is as large as the kernel's prologue.

The cache follows the source of the whole package that defines a kernel: numba keys a
cached kernel on the hash of its own file only, so an edit to a callee in another file of
the package would load the caller with the old callee.  :func:`njit` registers the
kernel's package directory; for those, :class:`PackageSourceLocator` (a locator added to
numba's ``CacheImpl._locator_classes``, its extension point for where and under which
stamp a kernel is cached) stamps the cache with a hash of every ``.py`` file of that
directory and of this module (:func:`package_hash`: the options here decide how the
kernels compile), so an edit to any of them recompiles the package's kernels.
"""

from __future__ import annotations

import os

import numba
from numba.core import caching
from numba.core.registry import CPUDispatcher

from vsi_numba._sources import _sources, package_hash  # noqa: F401 - the API here

JIT_OPTIONS = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy",
               "_nrt": False, "no_cfunc_wrapper": True}


def njit(func=None, *, kernel_only: bool = False, **overrides):
    """``numba.njit`` with the project's options.

    ``kernel_only``: a kernel that only other kernels call, compiled without the CPython
    wrapper (the code that unboxes the arguments of a call from Python: for the
    namedtuples of arrays the engine passes around it is large and slow to compile).
    Calling such a kernel from Python raises a TypeError (:class:`KernelOnly`);
    without this guard numba's entry point would be a null pointer.
    """
    if func is None:
        return lambda f: njit(f, kernel_only=kernel_only, **overrides)
    options = {**JIT_OPTIONS, **overrides}
    if options.get("cache"):
        _PACKAGES.add(_package_dir(func.__code__.co_filename))
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


# ------------------------------------------------------------------ the cache's key

#: Package directories whose kernels :class:`PackageSourceLocator` stamps.
_PACKAGES: set[str] = set()


def _package_dir(py_file: str) -> str:
    return os.path.dirname(os.path.abspath(py_file))


class PackageSourceLocator(caching._CacheLocator):
    """numba's cache locator for the kernels of a registered package, stamped with
    :func:`package_hash` of the package instead of the hash of the defining file alone.

    The directory: with ``NUMBA_CACHE_DIR``, ``NUMBA_CACHE_DIR/PACKAGE-HASH`` (e.g.
    ``vsi_numba.kernels-3f0c...``: the package's dotted name and the first 16 hex digits
    of its :func:`package_hash`), so that a cache directory names no absolute path and can
    be copied to another install of the same sources (numba's own layout names a hash of
    the source directory's absolute path); each version of the sources has a directory of
    its own.  Else the one numba would choose (the ``__pycache__`` beside the file, else
    the user-wide cache)."""

    # numba's own locators, in its order (numba < 0.68 names them with a leading "_")
    _DEFAULT = tuple(getattr(caching, name, None) or getattr(caching, "_" + name)
                     for name in ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                  "UserWideCacheLocator"))

    def __init__(self, inner, py_func, py_file: str, user_dir: bool = False):
        self._inner = inner
        self._package = _package_dir(py_file)
        self._name = py_func.__module__.rpartition(".")[0] or py_func.__module__
        self._user_dir = user_dir
        # numba's cache reads the locator's file where it warns that a kernel cannot be
        # cached (dynamic globals, e.g. with NUMBA_OPT=0): the kernel's own file
        self._py_file = py_file

    def ensure_cache_path(self):
        if self._user_dir:
            super().ensure_cache_path()
        else:
            self._inner.ensure_cache_path()

    def get_cache_path(self):
        if self._user_dir:
            return os.path.join(numba.config.CACHE_DIR,
                                f"{self._name}-{self.get_source_stamp()[:16]}")
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return package_hash(self._package)

    def get_disambiguator(self):
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        if _package_dir(py_file) not in _PACKAGES:
            return None  # not a kernel of this project: numba's own locators
        if numba.config.CACHE_DIR:
            self = cls(cls._DEFAULT[0](py_func, py_file), py_func, py_file, user_dir=True)
            try:
                self.ensure_cache_path()
                return self
            except OSError:  # not writable: where numba would go next
                pass
        for locator in cls._DEFAULT[1:]:
            inner = locator.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner, py_func, py_file)
        return None


if PackageSourceLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, PackageSourceLocator)


# ------------------------------------------------------------------ the target CPU

#: The file that marks a ``NUMBA_CACHE_DIR`` whose kernels are compiled for a generic CPU
#: of the machine's architecture (``vsi compile --into DIR``): a process with that cache
#: directory compiles and loads its kernels for the generic CPU too (:func:`use_generic_cpu`).
GENERIC_MARK = "vsi_numba-generic-cpu"

#: numba's settings of a generic CPU: the architecture's baseline instructions only.
GENERIC_CPU_ENV = {"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}


def _codegen_started() -> bool:
    """numba has made its CPU code generator in this process (it reads the target CPU
    once, then)."""
    from numba.core.registry import cpu_target

    return "_toplevel_target_context" in vars(cpu_target)


def use_generic_cpu() -> bool:
    """Compile and load the kernels of this process for a generic CPU
    (:data:`GENERIC_CPU_ENV`, also for the processes it starts), unless ``NUMBA_CPU_NAME``
    names another CPU or numba has compiled or loaded a function already (its target is
    fixed then).  numba keys a cached kernel on the target CPU: code for a generic CPU
    runs on every machine of the architecture, so such a cache can be copied to another
    machine.  Returns whether this process's kernels target a generic CPU."""
    if numba.config.CPU_NAME is None and not _codegen_started():
        os.environ.update(GENERIC_CPU_ENV)
        numba.config.reload_config()
    return targets_generic_cpu()


def targets_generic_cpu() -> bool:
    """This process compiles and loads its kernels for a generic CPU."""
    return str(numba.config.CPU_NAME).lower() == "generic"


def generic_cache(directory: str | os.PathLike | None) -> bool:
    """``directory`` is a cache of kernels for a generic CPU (holds :data:`GENERIC_MARK`)."""
    return bool(directory) and os.path.isfile(os.path.join(directory, GENERIC_MARK))


if generic_cache(numba.config.CACHE_DIR):
    use_generic_cpu()
