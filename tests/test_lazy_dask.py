"""xarray without ``import dask.array`` until a dask array exists (vsi_numba.io.lazy_dask).

What is tested is which modules a process imports, so the first test runs in a fresh
interpreter (pytest's own process may have imported dask.array already)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("dask")

REPO = Path(__file__).resolve().parents[1]


def test_files_read_without_dask_array_and_dask_arrays_still_recognised(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        import numpy as np
        import xarray as xr
        from vsi_numba.io.lazy_dask import defer_dask_array_import
        from vsi_numba.io.netcdf import open_results

        import netCDF4
        p = {str(tmp_path / "r.nc")!r}
        a = np.arange(12.0).reshape(3, 4)
        with netCDF4.Dataset(p, "w") as nc:  # written without xarray
            nc.createDimension("speed", 3)
            nc.createDimension("x", 4)
            nc.createVariable("speed", "f8", ("speed",))[:] = [10.0, 20.0, 30.0]
            v = nc.createVariable("a", "f8", ("speed", "x"), fill_value=-1.0)
            v[:] = a
        assert "dask.array" not in sys.modules
        with open_results(p) as ds:  # installs the lazy entry
            m = ds["a"].where(ds["a"] > 2).max("x").values
        assert np.array_equal(m, a.max(axis=1)), m
        assert "dask.array" not in sys.modules, "dask.array imported by reading a file"
        assert "dask" not in sys.modules, "dask imported by reading a file"
        assert defer_dask_array_import()  # already there: True, nothing changed
        import dask.array as da
        from xarray.namedarray.pycompat import array_type, is_chunked_array
        assert array_type("dask") == (da.Array,)
        v = xr.DataArray(da.ones((4, 2), chunks=2), dims=("x", "y"))
        assert is_chunked_array(v.data) and v.chunks == ((2, 2), (2,))
        assert float(v.sum().compute()) == 8.0
        with xr.open_dataset(p, chunks={{"speed": 1}}) as ds:  # dask-backed reading
            assert ds["a"].chunks == ((1, 1, 1), (4,))
            assert np.array_equal(ds["a"].max("x").values, a.max(axis=1))
        print("ok")
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"},
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_an_entry_xarray_made_itself_is_left_alone(monkeypatch):
    from xarray.namedarray import pycompat

    from vsi_numba.io import lazy_dask

    cache = dict(pycompat._cached_duck_array_modules)
    monkeypatch.setattr(pycompat, "_cached_duck_array_modules", cache)
    cache.pop("dask", None)
    real = pycompat.DuckArrayModule("dask")
    cache["dask"] = real
    assert lazy_dask.defer_dask_array_import() is False
    assert cache["dask"] is real
    cache.pop("dask")
    assert lazy_dask.defer_dask_array_import() is True
    entry = cache["dask"]
    assert isinstance(entry, lazy_dask._LazyDask)
    # the fields other than the type are dask's own (imported when asked)
    assert entry.available is True and str(entry.version) == str(real.version)
    assert lazy_dask.defer_dask_array_import() is True and cache["dask"] is entry


def test_an_xarray_without_the_cache_is_left_alone(monkeypatch):
    from xarray.namedarray import pycompat

    from vsi_numba.io import lazy_dask

    monkeypatch.delattr(pycompat, "_cached_duck_array_modules")
    assert lazy_dask.defer_dask_array_import() is False


def test_the_dask_collection_test_asks_dask_only_for_objects_with_a_graph():
    import numpy as np

    from vsi_numba.io import lazy_dask

    asked = []

    def real(x):
        asked.append(x)
        return True

    test = lazy_dask._not_dask_first(real)

    class Graph:
        def __dask_graph__(self):
            return {}

    assert test(np.zeros(3)) is False and test(Graph) is False and not asked
    g = Graph()
    assert test(g) is True and asked == [g]
    da = pytest.importorskip("dask.array")
    from xarray.namedarray import utils

    lazy_dask.defer_dask_array_import()
    assert hasattr(utils.is_dask_collection, "_vsi_real")
    assert utils.is_dask_collection(da.ones(2)) and not utils.is_dask_collection(np.ones(2))
