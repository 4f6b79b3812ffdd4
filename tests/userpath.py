"""The user's path in the tests: a config file -> ``vsi sweep`` -> the netCDF file."""

from __future__ import annotations

import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app


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
