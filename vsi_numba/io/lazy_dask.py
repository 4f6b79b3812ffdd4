"""xarray without ``import dask.array`` until a dask array exists.

xarray asks for dask's array type whenever it wraps data in a variable (opening or
decoding a file, every computation): the first ask imports ``dask.array`` when dask is
installed (~0.3 s of CPU, more than reading a study's envelopes).  An object can only be
a dask array once ``dask.array`` is imported, so the answer "no dask array type" is exact
until then.  :func:`defer_dask_array_import` gives xarray that answer: its cached entry
for dask names the array type of ``dask.array`` when that module is imported (by anyone,
at any time) and no type before; the entry's other fields (module, version) import dask
as xarray's own entry does.  Nothing changes when xarray has no such cache (another
version) or has already filled it.

xarray also asks, of every array it wraps, whether it is a dask collection
(``xarray.namedarray.utils.is_dask_collection``), which imports ``dask.base`` (and with
it most of dask, ~0.2 s of CPU) at the first ask.  dask's answer is False for an object
without a ``__dask_graph__`` attribute (or for a class) before anything else is looked
at; :func:`defer_dask_array_import` gives that answer for those objects (a numpy array,
a lazily read netCDF variable) without importing dask, and asks dask for the others.
"""

from __future__ import annotations

import sys

__all__ = ["defer_dask_array_import"]


class _LazyDask:
    """xarray's ``DuckArrayModule("dask")``, its array type looked up when asked."""

    def __init__(self, factory) -> None:
        self._factory = factory
        self._real = None

    @property
    def type(self) -> tuple:
        mod = sys.modules.get("dask.array")
        if mod is None:  # no dask array can exist: nothing imported it
            return ()
        return (mod.Array,)

    def __getattr__(self, name: str):  # module, version, available: as xarray's entry
        if name.startswith("__"):
            raise AttributeError(name)
        if self._real is None:
            self._real = self._factory("dask")
        return getattr(self._real, name)


def _not_dask_first(real):
    """xarray's ``is_dask_collection`` answering False at once for an object dask's own
    test rejects on its first condition (a class, or no ``__dask_graph__``)."""

    def is_dask_collection(x) -> bool:
        if isinstance(x, type) or not hasattr(x, "__dask_graph__"):
            return False  # dask.base.is_dask_collection's first test, without dask
        return real(x)

    is_dask_collection._vsi_real = real
    return is_dask_collection


def _defer_dask_collection_test() -> None:
    """Put :func:`_not_dask_first` in front of xarray's ``is_dask_collection`` (once;
    nothing when xarray has no such function)."""
    try:
        from xarray.namedarray import utils
    except ImportError:  # pragma: no cover - xarray is a dependency
        return
    real = getattr(utils, "is_dask_collection", None)
    if callable(real) and not hasattr(real, "_vsi_real"):
        utils.is_dask_collection = _not_dask_first(real)


def defer_dask_array_import() -> bool:
    """Install the lazy dask entry in xarray's cache of duck-array modules; True when it
    is there (now or from an earlier call), False when xarray's cache is not as expected
    or already holds dask's own entry (nothing changed).  xarray's test for a dask
    collection answers for non-dask objects without importing dask (module notes)."""
    try:
        from xarray.namedarray import pycompat
    except ImportError:  # pragma: no cover - xarray is a dependency
        return False
    _defer_dask_collection_test()
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    factory = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or factory is None:
        return False
    entry = cache.get("dask")
    if isinstance(entry, _LazyDask):
        return True
    if entry is not None:
        return False
    cache["dask"] = _LazyDask(factory)
    return True
