"""The modal damping the runs used is in every results file (not only with study.vary)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from vsi_numba.study.runner import run_study


def _config(damping, **bridge):
    return {
        "title": "damping in the results file",
        "bridge": {"kind": "simply_supported", "spans": [15.0], "EI": 1e10,
                   "mass_per_length": 12000.0, "damping_ratio": damping, "n_modes": 3,
                   "output_points": [7.5], **bridge},
        "train": {"preset": "HSLM-A1", "model": "moving_force"},
        "irregularity": {"kind": "none"},
        "solver": {"dt": 2e-3, "approach": 2.0, "free_vibration": 0.1},
        "study": {"speeds_kmh": [200.0], "output": "results.nc"},
    }


@pytest.mark.parametrize(("damping", "bridge", "expected", "extra"), [
    # EN 1991-2 Table 6.6, prestressed concrete, L < 20 m: 1.0 + 0.07 (20 - L) per cent
    ("EN1991-2", {"deck_type": "prestressed_concrete"}, [0.0135] * 3, 0.0),
    ([0.01, 0.02, 0.03], {}, [0.01, 0.02, 0.03], 0.0),
])
def test_results_file__holds_the_damping_the_runs_used(tmp_path, damping, bridge, expected,
                                                       extra):
    out = tmp_path / "results.nc"
    run_study(_config(damping, **bridge), out, backend="serial", fresh=True)
    with xr.open_dataset(out) as ds:
        assert ds["damping_ratio"].dims == ("mode",)
        np.testing.assert_allclose(ds["damping_ratio"].values, expected, rtol=1e-12)
        assert float(ds["additional_damping"].values) == extra
