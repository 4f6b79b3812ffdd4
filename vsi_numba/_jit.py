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

The cache follows the source of the whole package that defines a kernel: numba keys a
cached kernel on the hash of its own file only, so an edit to a callee in another file of
the package would load the caller with the old callee.  :func:`njit` registers the
kernel's package directory; for those, :class:`PackageSourceLocator` (a locator added to
numba's ``CacheImpl._locator_classes``, its extension point for where and under which
stamp a kernel is cached) stamps the cache with a hash of every ``.py`` file of that
directory (:func:`package_hash`), so an edit to any of them recompiles the package's
kernels.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba
from numba.core import caching
from numba.core.registry import CPUDispatcher

JIT_OPTIONS = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy",
               "_nrt": False}


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


def _sources(directory: str) -> list[Path]:
    return sorted(p for p in Path(directory).rglob("*.py") if "__pycache__" not in p.parts)


_hashes: dict[tuple, str] = {}


def package_hash(directory: str | os.PathLike) -> str:
    """SHA-256 of every ``.py`` file under ``directory`` (names and bytes, in name order);
    recomputed when a file's size or modification time changes."""
    files = _sources(str(directory))
    key = tuple((str(p), st.st_mtime_ns, st.st_size) for p in files for st in [p.stat()])
    if key not in _hashes:
        h = hashlib.sha256()
        for p in files:
            h.update(p.relative_to(directory).as_posix().encode() + b"\0")
            h.update(p.read_bytes() + b"\0")
        _hashes[key] = h.hexdigest()
    return _hashes[key]


class PackageSourceLocator(caching._CacheLocator):
    """numba's cache locator for the kernels of a registered package: the cache directory
    numba would choose (``NUMBA_CACHE_DIR``, else the ``__pycache__`` beside the file,
    else the user-wide cache), stamped with :func:`package_hash` of the package instead
    of the hash of the defining file alone."""

    # numba's own locators, in its order (numba < 0.68 names them with a leading "_")
    _DEFAULT = tuple(getattr(caching, name, None) or getattr(caching, "_" + name)
                     for name in ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                  "UserWideCacheLocator"))

    def __init__(self, inner, py_file: str):
        self._inner = inner
        self._package = _package_dir(py_file)
        # numba's cache reads the locator's file where it warns that a kernel cannot be
        # cached (dynamic globals, e.g. with NUMBA_OPT=0): the kernel's own file
        self._py_file = py_file

    def ensure_cache_path(self):
        self._inner.ensure_cache_path()

    def get_cache_path(self):
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return package_hash(self._package)

    def get_disambiguator(self):
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        if _package_dir(py_file) not in _PACKAGES:
            return None  # not a kernel of this project: numba's own locators
        for locator in cls._DEFAULT:
            inner = locator.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner, py_file)
        return None


if PackageSourceLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, PackageSourceLocator)

