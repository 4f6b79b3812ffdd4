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
* a file is never written in place: it goes to a temporary file in the same directory,
  is flushed to disk, then renamed over the target (``os.replace`` is atomic on POSIX), so
  a crash or Ctrl-C leaves either the old file or the new one, never half a file.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Hashable
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

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


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _temp_path(path: Path) -> Path:
    from vsi_numba.io.paths import fitting_name, name_max

    # mkstemp adds 8 random characters and the suffix: the prefix leaves room for them
    prefix = fitting_name(path.name, prefix=".", suffix=".",
                          limit=name_max(path.parent) - 12)
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=path.parent)
    os.close(fd)
    _default_mode(tmp)
    return Path(tmp)


def _default_mode(path) -> None:
    """Give a temporary file the mode of a normally created one (0666 & ~umask):
    mkstemp makes it private (0600), and the rename would keep that."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


def _replace_atomically(path: Path, write) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, flush it to disk and
    rename it over ``path``; on any error the temp file goes and ``path`` is untouched."""
    tmp = _temp_path(path)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)
    return path


def write_atomic(path: str | os.PathLike, write) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, flush it to disk and
    rename it over ``path`` (atomic: ``path`` is the old file or the new one, never half
    of one).  Raises ``OSError``; the temp file is removed and ``path`` left untouched."""
    return _replace_atomically(Path(path), write)


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temp file in the same directory + rename).

    Raises ``OSError`` (e.g. ``PermissionError``, ``ENOSPC``); the temp file is removed and
    an existing ``path`` is left untouched.
    """
    return _replace_atomically(Path(path), lambda tmp: tmp.write_bytes(data))


def open_results(path: str | os.PathLike) -> xr.Dataset:
    """Open the results of ``vsi run`` or ``vsi sweep`` (lazily, like ``xarray.open_dataset``).

    ``time`` stays float seconds (its units are plain ``"s"``).  Use as a context manager
    (``with open_results(p) as ds:``) or call ``.load()`` / ``.close()``; the resolved
    configuration is in ``ds.attrs["config_json"]``.
    """
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no results file {path}")
    return xr.open_dataset(path, engine="netcdf4", decode_timedelta=False)
