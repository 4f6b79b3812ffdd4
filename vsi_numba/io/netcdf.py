"""netCDF writing and reading: CF encodings, atomic writes, provenance attributes.

Layout rules (docs/manual/developer.md, "Results files"):

* floats get ``_FillValue = NaN``; integers get no ``_FillValue`` (xarray cannot put NaN
  in an integer variable); coordinates that index a dimension get none either;
* time histories (any variable with a ``time`` dimension) are stored as float32,
  ``zlib`` level 4 with ``shuffle``, one chunk per case and at most 4096 time steps;
  envelopes and coordinates stay float64;
* strings are netCDF-4 variable-length strings (the xarray default);
* attributes are str or numbers only: bools, None and dicts are refused by netCDF4, so the
  resolved configuration travels as one JSON string ``config_json``;
* a file is never written in place (:func:`vsi_numba.io.atomic.write_atomic`): it goes to
  a temporary file in the same directory, is flushed to disk, then renamed over the
  target (``os.replace`` is atomic on POSIX), so a crash or Ctrl-C leaves either the old
  file or the new one, never half a file.
"""

from __future__ import annotations

import os
from collections.abc import Hashable
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vsi_numba.io.atomic import fsync_dir, write_atomic, write_bytes_atomic  # noqa: F401

if TYPE_CHECKING:  # xarray is imported where a Dataset is made (it takes ~1 s to import)
    import xarray as xr

CONVENTIONS = "CF-1.12"
HISTORY_ENCODING = {"zlib": True, "complevel": 4, "shuffle": True, "dtype": "float32"}
MAX_TIME_CHUNK = 4096
#: Case dimensions of a study: one chunk per case along them.
CASE_DIMS = ("speed", "train", "irregularity")


def source_string() -> str:
    """``source`` attribute: package and numba versions and the method."""
    import numba

    return f"vsi_numba {package_version()} (numba {numba.__version__}, HHT-alpha, modal bridge)"


def package_version() -> str:
    """Installed version of vsi_numba (``"unknown"`` when not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vsi_numba")
    except PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        return "unknown"


def history_line(command: str) -> str:
    """One ``history`` line: ISO-8601 UTC time stamp and the command."""
    stamp = datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")
    return f"{stamp} {command}"


def encoding_for(ds: xr.Dataset) -> dict[Hashable, dict]:
    """Return the netCDF encodings of every variable and coordinate of ``ds`` (module notes)."""
    enc: dict[Hashable, dict] = {}
    for name, var in ds.variables.items():
        kind = var.dtype.kind
        if kind in "OUS":
            enc[name] = {}
        elif kind in "iub":
            enc[name] = {"_FillValue": None}
        elif kind == "f":
            if name in ds.dims:  # dimension coordinate: never missing
                enc[name] = {"_FillValue": None}
            elif "time" in var.dims:
                chunks = []
                for dim, size in zip(var.dims, var.shape, strict=True):
                    if dim in CASE_DIMS:
                        chunks.append(1)
                    elif dim == "time":
                        chunks.append(max(1, min(size, MAX_TIME_CHUNK)))
                    else:
                        chunks.append(max(1, size))
                enc[name] = {**HISTORY_ENCODING, "_FillValue": np.float32(np.nan)}
                if 0 not in var.shape:
                    enc[name]["chunksizes"] = tuple(chunks)
            else:
                enc[name] = {"dtype": "float64", "_FillValue": np.nan}
    return enc


#: Atomic writes live in :mod:`vsi_numba.io.atomic`; these names stay for the callers.
_fsync_dir = fsync_dir


def open_results(path: str | os.PathLike) -> xr.Dataset:
    """Open the results of ``vsi run`` or ``vsi sweep`` (lazily, like ``xarray.open_dataset``).

    ``time`` stays float seconds (its units are plain ``"s"``).  Use as a context manager
    (``with open_results(p) as ds:``) or call ``.load()`` / ``.close()``; the resolved
    configuration is in ``ds.attrs["config_json"]``.
    """
    import xarray as xr

    from vsi_numba.io.lazy_dask import defer_dask_array_import

    defer_dask_array_import()  # no dask array in the file: dask.array is not imported
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no results file {path}")
    return xr.open_dataset(path, engine="netcdf4", decode_timedelta=False)
