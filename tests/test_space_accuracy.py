"""Accuracy statements beside the verdicts, through ``vsi sweep --report``: the deck
acceleration with a rail mass on the elastic track states the sign and size of its error
in the summary's verdict (the massless rail states none)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from vsi_numba.cli import app

RAIL = """title = "rail mass"
[bridge]
kind = "simply_supported"
spans = [15.0]
EI = 2.0e10
mass_per_length = 12000.0
damping_ratio = 0.02
n_modes = 3
[train]
[[train.vehicles]]
kind = "sprung_mass"
offset = 0.0
mass = 5750.0
stiffness = 1.595e6
damping = 1e4
wheel_mass = 500.0
[track]
model = "elastic"
rail_mass = {mass}
[solver]
dt = 1e-3
free_vibration = 0.1
[study]
speeds_kmh = [150.0]
output = "s.nc"
"""


def _summary_row(tmp_path, text: str, check: str) -> str:
    (tmp_path / "s.toml").write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "s.toml"), "-q", "--report",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    rows = [line for line in md.splitlines() if line.startswith(f"| {check} |")]
    assert rows, md[:3000]
    return rows[0]


@pytest.mark.parametrize("mass", [120.0, 0.0])
def test_space_accuracy__rail_mass_error_beside_the_acceleration_verdict(tmp_path, mass):
    row = _summary_row(tmp_path, RAIL.format(mass=mass), "Peak deck acceleration")
    verdict = row.split("|")[6]
    if mass:
        # the measured error (docs/track_accuracy.md: -5.9 .. -6.8 % at 120 kg/m) with
        # its sign, in the verdict's cell
        assert "pass (the value is up to 6.8 % LOW (unsafe side)" in verdict, row
        assert "120 kg/m" in verdict
    else:
        assert verdict.strip() == "pass", row
