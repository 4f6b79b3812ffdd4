"""The report's summary through ``vsi sweep --report``: the EN 1991-2 6.4.6.5(3) verdict
and the deck-end rotation check in the summary table and summary.csv, utilisations to
0.1 %, trains in natural order in every table, and one phi'dyn of the deflection.

References are independent: the end rotation of a simply supported beam under LM71 x
Phi_3 from the closed-form influence line (EN 1991-2 6.3.2 and 6.4.5.2 [R] values
written here), the phi'dyn of the deflection by numpy from the results file.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from userpath import vsi

L, EI = 15.0, 2.0e10  # m, N m2: a stiff deck, LM71 x Phi governs at these speeds
CONFIG = f"""title = "summary"
[bridge]
kind = "simply_supported"
spans = [{L}]
EI = {EI}
mass_per_length = 12000.0
damping_ratio = 0.02
n_modes = 3
[train]
preset = ["HSLM-A10", "HSLM-A2", "HSLM-A1"]
[solver]
dt = 1e-3
free_vibration = 0.1
[study]
speeds_kmh = [150.0, 200.0]
output = "s.nc"
"""
NATURAL = ["HSLM-A1", "HSLM-A2", "HSLM-A10"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    d = tmp_path_factory.mktemp("summary")
    (d / "s.toml").write_text(CONFIG)
    res = vsi("sweep", "s.toml", "-q", "--report", "rep", cwd=d)
    assert res.returncode == 0, res.stderr[-3000:]
    return d


def _lm71_end_rotation() -> float:
    """max over placements of the end rotation (rad) of LM71 (4 x 250 kN at 1.6 m, 80
    kN/m outside the 6.4 m axle zone) on a simply supported span: influence line
    theta(a) = a (L - a) (2L - a) / (6 L EI) of a unit load at a from the far end."""

    def line(a):
        a = np.asarray(a, float)
        return np.where((a >= 0) & (a <= L), a * (L - a) * (2 * L - a) / (6 * L * EI), 0.0)

    x = np.linspace(0.0, L, 30001)
    w = line(x)
    best = 0.0
    for c in np.arange(-4.0, L + 4.0, 0.005):
        axles = 250e3 * line(c + np.array([-2.4, -0.8, 0.8, 2.4])).sum()
        out = (x < c - 3.2) | (x > c + 3.2)
        udl = 80e3 * np.trapezoid(np.where(out, w, 0.0), x)
        best = max(best, axles + udl)
    return best


def test_report_summary__verdict_and_end_rotation_rows(report):
    table = pd.read_csv(report / "rep" / "summary.csv")
    verdict = table[table["check"].str.startswith("6.4.6.5(3)")]
    assert sorted(verdict["check"].str.extract(r"\) (\w+)")[0]) == sorted(
        ["deflection", "bending", "shear", "support", "rotation"])
    assert (verdict["result"].isin(["LM71 × Φ × α governs", "HSLM / real trains govern"])
            ).all()
    rot = table[table["check"].str.startswith("Deck-end rotation")].iloc[0]
    assert rot["units"] == "rad" and rot["limit"] == pytest.approx(6.5e-3)
    assert rot["governing_train"] == "Φ3 × α × LM71"
    phi3 = min(max(2.16 / (np.sqrt(L) - 0.2) + 0.73, 1.0), 2.0)  # 6.4.5.2(3) [R], L_phi = L
    # the package searches placements on a 0.05 m grid: relative error ~(h/L)^2 < 1e-4
    assert rot["value"] == pytest.approx(phi3 * _lm71_end_rotation(), rel=1e-3)
    # summary.csv keeps 7 significant digits (at most 5e-7 relative)
    assert rot["utilisation"] == pytest.approx(rot["value"] / 6.5e-3, rel=1e-6)
    md = (report / "rep" / "report.md").read_text(encoding="utf-8")
    row = next(ln for ln in md.splitlines() if ln.startswith("| Deck-end rotation"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == f"{rot['value'] * 1e3:.3g} mrad"
    assert cells[4] == f"{100 * rot['utilisation']:.1f} %"
    acc = table[table["check"] == "Peak deck acceleration"].iloc[0]
    row = next(ln for ln in md.splitlines() if ln.startswith("| Peak deck acceleration"))
    assert f"| {100 * acc['value'] / acc['limit']:.1f} % |" in row


def test_report_summary__trains_in_natural_order_everywhere(report):
    md = (report / "rep" / "report.md").read_text(encoding="utf-8")
    blocks = re.split(r"\n(?=#+ )", md)
    for title in ("## Trains", "## Maxima", "### Dynamic increment φ'dyn per effect"):
        block = next(b for b in blocks if b.startswith(title))
        rows = [ln.split("|")[1].strip() for ln in block.splitlines()
                if ln.startswith("| HSLM-A")]
        assert rows[:3] == NATURAL, (title, rows)
    for csv in (report / "rep" / "tables").glob("*.csv"):
        cols = [c.split(" [")[0] for c in pd.read_csv(csv).columns[1:]]
        assert cols == NATURAL, csv.name


def test_report_summary__one_phi_dyn_of_the_deflection(report):
    with xr.open_dataset(report / "s.nc") as ds:
        dyn = ds["max_deck_displacement"].max(["irregularity", "point"])  # (speed, train)
        stat = ds["max_static_deck_displacement"].max("point")             # (train,)
        phi = (dyn / stat - 1.0).max("speed")
        kmh = ds["speed_kmh"].values[(dyn / stat).argmax("speed").values]
        ref = {str(t): (float(phi.sel(train=t)), float(k))
               for t, k in zip(ds["train"].values, kmh, strict=True)}
    md = (report / "rep" / "report.md").read_text(encoding="utf-8")
    block = md.split("### Dynamic increment φ'dyn per effect")[1]
    shown = {ln.split("|")[1].strip(): ln.split("|")[2].strip()
             for ln in block.splitlines() if ln.startswith("| HSLM-A")}
    for train, (value, speed) in ref.items():
        assert shown[train] == f"{value:.3f} ({speed:g} km/h)", train
    table = pd.read_csv(report / "rep" / "summary.csv")
    phi_row = table[table["check"] == "Dynamic increment φ'dyn"].iloc[0]
    # summary.csv keeps 7 significant digits (at most 5e-7 relative)
    assert phi_row["value"] == pytest.approx(max(v for v, _ in ref.values()), rel=1e-6)
    assert "one φ'dyn for the deflection" in md
