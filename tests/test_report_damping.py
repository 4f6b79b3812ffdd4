"""The report's damping table: one ratio when every mode has it, the modes' own ratios
when they differ (the per-mode damping is always in the results file)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.report.echo import _damping_table


def _results(zeta) -> xr.Dataset:
    return xr.Dataset({"damping_ratio": ("mode", np.asarray(zeta, float)),
                       "additional_damping": ((), 0.004)},
                      coords={"train": ["HSLM-A1", "HSLM-A2"]})


def test_damping_table__uniform_modes_written_once():
    row = _damping_table(_results([0.01, 0.01, 0.01]), {"bridge": {}}).frame.iloc[0]
    assert row["ζ (structure)"] == "1 %"
    assert row["Δζ (EN 1991-2 6.4.6.3.1)"] == "0.4 %"
    assert row["ζ + Δζ"] == "1.4 %"


def test_damping_table__modes_of_their_own_each_written():
    row = _damping_table(_results([0.01, 0.02, 0.015]), {"bridge": {}}).frame.iloc[0]
    assert row["ζ (structure)"] == "1, 2, 1.5 % (per mode)"
    assert row["ζ + Δζ"] == "1.4, 2.4, 1.9 %"
