"""The user's path in the tests: a config file -> ``vsi sweep`` -> the netCDF file.

:func:`vsi` runs a command in this process (typer's CliRunner) and answers as
``subprocess.run`` does (``returncode``, ``stdout``, ``stderr``): the tests whose subject
is not the process itself (signals, exit at a kill, memory of a fresh process) run the
commands this way, without paying the imports and the kernels' loading again.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from pathlib import Path

import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app


@dataclass(frozen=True)
class Done:
    """What a command gave: its exit code and its two streams, apart."""

    returncode: int
    stdout: str
    stderr: str


def vsi(*args, cwd: str | Path | None = None) -> Done:
    """``vsi ARGS`` in this process (in ``cwd`` when given), as a user's shell runs it.

    An exception that the command let through (a traceback in a real process) is raised
    here, so that the test fails on it rather than on a return code.
    """
    with contextlib.chdir(cwd) if cwd is not None else contextlib.nullcontext():
        res = CliRunner().invoke(app, [os.fspath(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception
    return Done(res.exit_code, res.stdout, res.stderr)


def sweep_file(tmp_path, text: str, **isel) -> xr.Dataset:
    """Write ``text`` as ``tmp_path/deck.toml``, run ``vsi sweep -q`` on it (which must
    exit 0) and return its results file ``out.nc`` (the config's ``study.output``) with
    the first train and realisation and the selections ``isel``, loaded."""
    path = tmp_path / "deck.toml"
    path.write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(path), "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        return ds.isel(train=0, irregularity=0, **isel).load()
