"""The report's convergence section, through ``vsi sweep --report``: each governing case
re-run at dt/2 and at the exact resonance speed between two grid speeds, flagged when
the result moves.

HSLM-A1 (coach length D = 18 m) on a 15 m simply supported span, EI = 5e9 N m2, 10 t/m:
f1 = pi / (2 L^2) sqrt(EI / m) = 4.936 Hz, so the first resonance v = f1 D = 319.9 km/h,
which a grid of 300, 310, 330, 340 km/h misses.
"""

from __future__ import annotations

import re
import textwrap

import numpy as np
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app

L, EI, M, D = 15.0, 5e9, 1.0e4, 18.0


def study(tmp_path, name, dt, speeds, extra=""):
    path = tmp_path / f"{name}.toml"
    path.write_text(textwrap.dedent(f"""
        title = "convergence"
        [bridge]
        kind = "simply_supported"
        spans = [{L}]
        EI = {EI}
        mass_per_length = {M}
        damping_ratio = 0.02
        n_modes = 3
        [train]
        preset = ["HSLM-A1"]
        [solver]
        dt = {dt}
        free_vibration = 0.0
        {extra}
        [study]
        speeds_kmh = {speeds}
        output = "{name}.nc"
        """))
    res = CliRunner().invoke(app, ["sweep", str(path), "-q", "--report",
                                   str(tmp_path / f"{name}_report")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / f"{name}_report" / "report.md").read_text()
    section = text[text.index("## Convergence of the governing cases"):]
    return section[:section.index("\n## ", 5)], tmp_path / f"{name}.nc"


#: Columns of the table: quantity and place, case, summary value, dt, dt/2, change,
#: resonance speeds, result.
QUANTITY, CASE, SUMMARY, AT_DT, AT_HALF, CHANGE, RESONANCE, RESULT = range(8)


def rows(section):
    """Table rows: the quantity's name (before its place) -> cells."""
    out = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 8 and cells[0] not in ("Quantity and place", "---"):
            out[cells[0].split(",")[0]] = cells
    return out


def test_convergence__resonance_between_grid_speeds_is_found_and_flagged(tmp_path):
    section, nc = study(tmp_path, "grid", 2e-3, [300.0, 310.0, 330.0, 340.0])
    table = rows(section)
    acc = table["Peak deck acceleration"]
    f1 = np.pi / (2 * L**2) * np.sqrt(EI / M)
    v_res = f1 * D * 3.6
    speed = float(re.match(r"([\d.]+) km/h", acc[RESONANCE]).group(1))
    assert abs(speed - v_res) < 0.06  # printed to 0.1 km/h
    assert acc[RESULT] == "**FLAG**" and "Flagged:" in section
    # the value at the study's dt is the file's own envelope for the governing case
    with xr.open_dataset(nc) as ds:
        peak = float(np.fmax(ds["max_deck_acceleration"].max(),
                             ds["max_deck_acceleration_whole_deck"].max()))
    assert acc[AT_DT] == acc[SUMMARY] == f"{peak:.4g} m/s²"
    # the resonance value really is higher (a run at that speed, as a user would run it)
    res_section, res_nc = study(tmp_path, "exact", 2e-3, [round(float(v_res), 6)])
    with xr.open_dataset(res_nc) as ds:
        at_res = float(np.fmax(ds["max_deck_acceleration"].max(),
                               ds["max_deck_acceleration_whole_deck"].max()))
    assert f"{at_res:.4g}" in acc[RESONANCE] and at_res > 1.05 * peak
    assert rows(res_section)["Peak deck acceleration"][RESONANCE] == "none off the grid"


def test_convergence__coarse_time_step_is_flagged_and_a_fine_one_is_not(tmp_path):
    coarse, _ = study(tmp_path, "coarse", 4e-2, [250.0], "allow_coarse_dt = true")
    acc = rows(coarse)["Peak deck acceleration"]
    change = float(acc[CHANGE].rstrip(" %"))
    assert abs(change) > 5 and acc[RESULT] == "**FLAG**"
    fine, _ = study(tmp_path, "fine", 2e-3, [250.0])
    for cells in rows(fine).values():
        assert abs(float(cells[CHANGE].rstrip(" %"))) < 5 and cells[RESULT] == "converged"
    assert "Every governing result is converged" in fine
