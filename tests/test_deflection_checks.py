"""The deflection checks of EN 1990 A2.4.4.2.3(1) (L/600 under LM71 x Phi x alpha) and
A2.4.4.3.2 (passenger comfort, Fig. A2.3) through the user's path: a config file ->
``vsi sweep --report`` -> the netCDF file -> ``summary.csv`` and ``report.md``, against
closed forms written here (LM71 on a simply supported beam, a deck with torsion, the
modal series of a modes table) and the interpolation of the code profile's table."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.code_profile import (
    COMFORT_DEFLECTION_CURVES,
    comfort_deflection_ratio,
    default_profile,
)

L, EI, MASS = 25.0, 7.16e10, 18000.0
Q, SPACING, UDL = 250e3, 1.6, 80e3   # LM71, EN 1991-2 6.3.2 (the test's own values)
#: The envelope integrates the distributed load with the trapezoidal rule on a grid of
#: L/2000 (O(h^2): measured 7e-9 relative on this span) and places the axle group on a
#: 0.05 m grid that holds mid-span; summary.csv keeps 7 significant digits (a rounding
#: of at most 5e-7 relative): 1e-6 is twice that.
RTOL = 1e-6


def phi3(length):
    """EN 1991-2 6.4.5.2(3) Phi_3 (standard maintenance), bounds 1.00 .. 2.00."""
    return min(max(2.16 / (math.sqrt(length) - 0.2) + 0.73, 1.0), 2.0)


def lm71_midspan(span, ei):
    """LM71 centred at mid-span of a simply supported beam: the mid-span deflection (m).

    Mid-span influence line w(a) = a (3 L^2 - 4 a^2) / (48 EI) for a <= L/2 (a from the
    nearer support); the 80 kN/m on both sides of the 6.4 m zone integrates to
    2 q [3 L^2 c^2 / 2 - c^4] / (48 EI) with c = L/2 - 3.2.
    """
    def w(a):
        a = min(a, span - a)
        return a * (3 * span**2 - 4 * a**2) / (48 * ei)
    points = sum(Q * w(span / 2 + o) for o in (-2.4, -0.8, 0.8, 2.4))
    c = span / 2 - 2 * SPACING
    udl = 2 * UDL * (1.5 * span**2 * c**2 - c**4) / (48 * ei)
    return points + udl


def two_span_lm71_max(span, ei, h=0.05):
    """Largest deflection in span 1 of a two-span continuous beam (equal spans) under LM71
    placed most unfavourably, and where: the beam is the simply supported beam of 2 L
    with the middle support's reaction R(x) = w(L; x) / w(L; L) as the redundant,
    w_c(a; x) = w(a; x) - R(x) w(a; L); LM71 by brute force (the group's centre and the
    sections on a grid of ``h``, the distributed load where the line is positive)."""
    total = 2 * span

    def w(a, x):  # simply supported beam of length 2 L, unit load at x, deflection at a
        a, x = np.broadcast_arrays(np.asarray(a, float), np.asarray(x, float))
        lo, hi = np.minimum(a, x), np.maximum(a, x)
        out = lo * (total - hi) * (total**2 - lo**2 - (total - hi) ** 2) / (6 * ei * total)
        return np.where((x >= 0) & (x <= total), out, 0.0)

    def wc(a, x):
        return w(a, x) - w(span, x) / w(span, span) * w(a, span)

    sec = np.arange(h, span, h)[:, None]
    xs = np.linspace(0.0, total, 40001)
    line = np.maximum(wc(sec, xs[None, :]), 0.0)
    cum = np.concatenate([np.zeros((sec.size, 1)), np.cumsum(
        0.5 * (line[:, 1:] + line[:, :-1]) * np.diff(xs), axis=1)], axis=1)
    centres = np.arange(-2 * SPACING, total + 2 * SPACING + h, h)
    pts = sum(Q * wc(sec, centres[None, :] + o) for o in (-2.4, -0.8, 0.8, 2.4))
    lo = np.clip(centres - 2 * SPACING, 0.0, total)
    hi = np.clip(centres + 2 * SPACING, 0.0, total)
    zone = np.stack([np.interp(hi, xs, r) - np.interp(lo, xs, r) for r in cum])
    val = pts + UDL * (cum[:, -1:] - zone)            # (section, centre)
    i, _ = np.unravel_index(int(np.argmax(val)), val.shape)
    best, where = float(val.max()), float(sec[i, 0])
    return best, where


def _config(bridge: str, study: str = "speeds_kmh = [200.0]", train: str = "") -> str:
    return f"""title = "deflection"
[bridge]
{bridge}
[train]
preset = ["HSLM-A1"]
{train}
[solver]
dt = 4e-3
free_vibration = 0.0
[study]
{study}
output = "out.nc"
save_time_histories = false
"""


def _report(tmp_path, text: str):
    """config -> vsi sweep --report -> (summary.csv as a DataFrame, report.md text)."""
    (tmp_path / "deck.toml").write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "deck.toml"), "-q", "--report",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    # "n/a" is a result, not a missing value
    summary = pd.read_csv(tmp_path / "rep" / "summary.csv", keep_default_na=False,
                          na_values=[""])
    return summary, (tmp_path / "rep" / "report.md").read_text()


def _row(summary, start: str) -> pd.Series:
    rows = summary[summary["check"].str.startswith(start)]
    assert len(rows) == 1, summary["check"].tolist()
    return rows.iloc[0]


SS = f"""kind = "simply_supported"
spans = [{L}]
EI = {EI}
mass_per_length = {MASS}
damping_ratio = 0.01
n_modes = 3
"""


def test_deflection__simply_supported_lm71_against_closed_form(tmp_path):
    summary, report = _report(tmp_path, _config(
        SS, "speeds_kmh = [200.0]\nline_speed_kmh = 260.0\nclassification_factor = 1.21"))
    static = lm71_midspan(L, EI)
    safety = _row(summary, "Vertical deflection δ under LM71 × Φ × α")
    np.testing.assert_allclose(safety["value"], phi3(L) * 1.21 * static, rtol=RTOL)
    np.testing.assert_allclose(safety["limit"], L / 600, rtol=RTOL)
    assert safety["result"] == "pass" and "x = 12.5 m" in safety["check"]
    comfort = _row(summary, "Vertical deflection δ under LM71 × Φ (passenger comfort)")
    np.testing.assert_allclose(comfort["value"], phi3(L) * static, rtol=RTOL)  # alpha = 1
    # 260 km/h: between the curves of 250 and 280 km/h, one span modelled alone (x 1.0),
    # "very good" (b_v = 1): linear in L on each curve, then linear in V
    c250, c280 = (np.interp(L, *np.array(COMFORT_DEFLECTION_CURVES[v]).T)
                  for v in (250.0, 280.0))
    required = c250 + (260 - 250) / (280 - 250) * (c280 - c250)
    np.testing.assert_allclose(comfort["limit"], L / required, rtol=RTOL)
    assert comfort["governing_speed_kmh"] == 260.0
    assert comfort["result"] == ("pass" if comfort["value"] <= L / required else "FAIL")
    assert "## Deck deflection" in report and "between the curves V = 250 and 280" in report


def test_deflection__comfort_level_and_two_span_factor(tmp_path):
    """Two continuous spans take x 0.7 of Fig. A2.3; the summary's level is the report's
    (very good, b_v = 1.0); the section lists every level, L/delta divided by its b_v."""
    bridge = ("kind = \"continuous\"\nspans = [20.0, 20.0]\nEI = 5e10\nmass_per_length = "
              "15000.0\ndamping_ratio = 0.01\nmax_frequency = 30.0\nelements_per_span = 10")
    summary, report = _report(tmp_path, _config(bridge, "speeds_kmh = [200.0]\n"
                                                "line_speed_kmh = 200.0"))
    comfort = _row(summary, "Vertical deflection δ under LM71 × Φ (passenger comfort)")
    fig = np.interp(20.0, *np.array(COMFORT_DEFLECTION_CURVES[200.0]).T)
    np.testing.assert_allclose(comfort["limit"], 20.0 / (0.7 * fig), rtol=RTOL)
    # the deflection against the test's own two-span beam (below), Phi_3 of L_Phi =
    # 1.2 x 20 m (Table 6.2, two spans): measured 4e-6 apart (the 0.05 m grids of the
    # brute force stay just below the peak), 1e-5; the peak within a grid step
    ref, x_ref = two_span_lm71_max(20.0, 5e10)
    np.testing.assert_allclose(comfort["value"], phi3(1.2 * 20.0) * ref, rtol=1e-5)
    x_at = float(comfort["check"].split("x = ")[1].split(" m")[0])
    assert abs(x_at - x_ref) < 0.1, (x_at, x_ref)
    assert "two continuous spans: × 0.7" in report
    for level, b_v in (("good", 1.3), ("acceptable", 2.0)):
        assert f"| {level} | {b_v:g} m/s² | {0.7 * fig / b_v:.4g}" in report


def test_deflection__rigid_track_is_not_computed_on_its_own_line(tmp_path):
    summary, report = _report(tmp_path, _config("kind = \"rigid\"\nspans = [30.0]"))
    rows = summary[summary["check"].str.contains("Vertical deflection")]
    assert len(rows) == 2 and set(rows["result"]) == {"n/a"}
    assert all("not computed (rigid track" in c for c in rows["check"])
    lines = [ln for ln in report.splitlines() if "not checked: rigid track" in ln]
    assert len(lines) == 2, lines


def test_deflection__comfort_out_of_the_figure_says_so(tmp_path):
    """Above the fastest curve (350 km/h) Fig. A2.3 gives no limit: n/a, never a pass."""
    summary, report = _report(tmp_path, _config(SS, "speeds_kmh = [360.0]"))
    comfort = _row(summary, "Vertical deflection δ under LM71 × Φ (passenger comfort)")
    assert comfort["result"] == "n/a" and "above the fastest curve" in comfort["check"]
    assert _row(summary, "Vertical deflection δ under LM71 × Φ × α")["result"] == "pass"
    assert "Passenger-comfort deflection: not checked: the speed 360 km/h" in report


def test_deflection__double_track_deck_with_torsion(tmp_path):
    """Tracks at y = +-2.25 m on a simply supported deck with St-Venant torsion: the
    comfort deflection of the loaded track is bending + y^2 x torsion (one track loaded);
    the safety deflection loads both tracks, whose torques cancel: 2 x bending."""
    gj = 4e10
    bridge = SS + ("tracks = [{ eccentricity = 2.25 }, { eccentricity = -2.25 }]\n"
                   f"torsion = {{ GJ = {gj}, polar_mass = 4.0e5, damping_ratio = 0.01 }}")
    summary, report = _report(tmp_path, _config(bridge, "speeds_kmh = [200.0]\n"
                                                "line_speed_kmh = 200.0"))
    # mid-span rotation of a unit torque at a (<= L/2): a (L/2) / (GJ L) = a / (2 GJ)
    c = L / 2 - 2 * SPACING
    torsion = (sum(Q * (L / 2 - abs(o)) / (2 * gj) for o in (-2.4, -0.8, 0.8, 2.4))
               + 2 * UDL * c**2 / 2 / (2 * gj))
    bending = lm71_midspan(L, EI)
    comfort = _row(summary, "Vertical deflection δ under LM71 × Φ (passenger comfort)")
    np.testing.assert_allclose(comfort["value"], phi3(L) * (bending + 2.25**2 * torsion),
                               rtol=RTOL)
    safety = _row(summary, "Vertical deflection δ under LM71 × Φ × α")
    np.testing.assert_allclose(safety["value"], phi3(L) * 2 * bending, rtol=RTOL)
    assert "every one of the deck's 2 tracks loaded at once" in report


def test_deflection__modes_table_is_the_modal_series_and_says_it_underestimates(tmp_path):
    """A modes table (sine modes of the 25 m span, 3 modes): the deflection is the modal
    flexibility sum_j phi_j(a) phi_j(x) / omega_j^2, written here with LM71 centred at
    mid-span, below the beam's closed form; the report says so and gives the share of
    the last mode."""
    n = 3
    x = np.linspace(0.0, L, 101)
    rows = []
    for j in range(1, n + 1):
        f = (j * np.pi / L) ** 2 * np.sqrt(EI / MASS) / (2 * np.pi)
        rows += [{"mode": j, "frequency": f, "modal_mass": MASS * L / 2, "x": xi,
                  "shape": np.sin(j * np.pi * xi / L)} for xi in x]
    pd.DataFrame(rows).to_csv(tmp_path / "modes.csv", index=False)
    bridge = (f"kind = \"modes_file\"\nfile = \"modes.csv\"\nspans = [{L}]\n"
              "damping_ratio = 0.01")
    summary, report = _report(tmp_path, _config(bridge, "speeds_kmh = [200.0]\n"
                                                "line_speed_kmh = 200.0"))

    def series(a, xs):  # mass-normalised sines: phi_j = sqrt(2 / (m L)) sin(j pi x / L)
        out = 0.0
        for j in range(1, n + 1):
            w2 = (j * np.pi / L) ** 4 * EI / MASS
            out = out + 2 / (MASS * L) * np.sin(j * np.pi * a / L) * np.sin(
                j * np.pi * xs / L) / w2
        return out
    c = L / 2 - 2 * SPACING
    xs = np.linspace(0, c, 20001)
    udl = 2 * UDL * np.trapezoid(series(L / 2, xs), xs)
    static = sum(Q * series(L / 2, L / 2 + o) for o in (-2.4, -0.8, 0.8, 2.4)) + udl
    comfort = _row(summary, "Vertical deflection δ under LM71 × Φ (passenger comfort)")
    # the spline through 0.25 m stations of the table: 1e-5 of the shapes (h^4)
    np.testing.assert_allclose(comfort["value"], phi3(L) * static, rtol=2e-5)
    assert comfort["value"] < phi3(L) * lm71_midspan(L, EI)   # truncation: below
    assert "modal flexibility: an underestimate" in comfort["check"]
    assert "the last retained mode adds" in report


def test_deflection__limit_interpolation_against_the_table():
    """On the points of Fig. A2.3's table the limit is the table; between them linear in
    L, between curves linear in V; out of the figure: NaN with the reason."""
    for v, pts in COMFORT_DEFLECTION_CURVES.items():
        for span, ratio in pts:
            if span > 0:
                assert comfort_deflection_ratio(span, v).ratio == pytest.approx(ratio,
                                                                                rel=1e-12)
        (x0, y0), (x1, y1) = pts[1], pts[2]
        mid = comfort_deflection_ratio(0.5 * (x0 + x1), v).ratio
        assert mid == pytest.approx(0.5 * (y0 + y1), rel=1e-12)
    a = comfort_deflection_ratio(30.0, 200.0).ratio
    b = comfort_deflection_ratio(30.0, 220.0).ratio
    assert comfort_deflection_ratio(30.0, 205.0).ratio == pytest.approx(0.75 * a + 0.25 * b)
    # below the slowest curve: the slowest (the safe side), said so
    low = comfort_deflection_ratio(30.0, 80.0)
    assert low.ratio == comfort_deflection_ratio(30.0, 120.0).ratio
    assert "safe side" in low.note
    assert math.isnan(comfort_deflection_ratio(30.0, 400.0).ratio)
    long = comfort_deflection_ratio(130.0, 200.0)
    assert math.isnan(long.ratio) and "special analysis" in long.note
    # every curve asks for more at a higher speed (the safe side of taking the highest)
    speeds = sorted(COMFORT_DEFLECTION_CURVES)
    for span in np.linspace(1.0, 120.0, 120):
        r = [comfort_deflection_ratio(span, v).ratio for v in speeds]
        assert np.all(np.diff(r) >= 0), (span, r)
    assert default_profile().entry("deflection_span_ratio").recalled


def test_deflection__fe_matrices_against_closed_form(tmp_path):
    """A deck given as FE matrices (the test's own Hermite beam, 50 elements on the 25 m
    span): the deflection is K_ff u = f with the loads shared linearly between stations."""
    import scipy.io
    import scipy.sparse
    from test_imported import hermite_beam

    K, M, x, fixed = hermite_beam([L], EI, MASS, 50)
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(K), symmetry="symmetric")
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(M), symmetry="symmetric")
    pd.DataFrame({"x": x, "dof": 2 * np.arange(x.size),
                  "rotation_dof": 2 * np.arange(x.size) + 1}).to_csv(
        tmp_path / "stations.csv", index=False)
    bridge = ("kind = \"matrices\"\nstiffness_matrix = \"K.mtx\"\nmass_matrix = \"M.mtx\"\n"
              f"station_map = \"stations.csv\"\nfixed_dofs = {list(fixed)}\n"
              f"spans = [{L}]\nn_modes = 3\ndamping_ratio = 0.01")
    summary, report = _report(tmp_path, _config(bridge, "speeds_kmh = [200.0]\n"
                                                "line_speed_kmh = 200.0"))
    safety = _row(summary, "Vertical deflection δ under LM71 × Φ × α")
    # nodal values of cubic elements are exact; sharing a load between the two stations
    # of its element (h = 0.5 m) lowers the deflection by up to (pi h / L)^2 / 8 = 5e-4:
    # measured 3.5e-4 below, 1e-3; the report says it is an underestimate of that order
    np.testing.assert_allclose(safety["value"], phi3(L) * lm71_midspan(L, EI), rtol=1e-3)
    assert safety["value"] < phi3(L) * lm71_midspan(L, EI)
    assert "K_ff u = f" in report and "an underestimate of order (h/L)²" in report


def test_deflection__imported_grillage_track_against_full_stiffness(tmp_path):
    """A deck in space from FE matrices (the grillage of test_imported_space_config: two
    girders, two rail stringers, cross-beams; track T on the stringers): the track's
    deflection is the mean of its rails; the reference is the full K with Hermite
    consistent loads, each load shared by the two rails, LM71 placed every 0.05 m."""
    import test_imported_space_config as g

    fixed = g._write_matrices(tmp_path)
    summary, report = _report(tmp_path, g._text(g._matrices_bridge(fixed), [g.LOW]))
    K, _, fixed_dofs = g._grillage()
    n = K.shape[0]
    free = np.setdiff1d(np.arange(n), fixed_dofs)
    a = np.linspace(0.0, g.L, 1501)
    F = np.zeros((n, a.size))
    for i, x in enumerate(a):
        for line in (g.LEFT_RAIL, g.RIGHT_RAIL):
            g._hermite_load(F[:, i], x, line, 0.5)
    u = np.zeros((n, a.size))
    u[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
    nodes = np.arange(g.NE + 1)
    # the centre line at the FE nodes (the check's sections lie between them too: the
    # deflection peaks at mid-span, a node)
    line = 0.5 * (u[[g._dof(g.LEFT_RAIL, k, 0) for k in nodes]]
                  + u[[g._dof(g.RIGHT_RAIL, k, 0) for k in nodes]])
    part = np.clip(line, 0.0, None)
    cum = np.concatenate([np.zeros((nodes.size, 1)), np.cumsum(
        0.5 * (part[:, 1:] + part[:, :-1]) * np.diff(a), axis=1)], axis=1)
    best = 0.0
    for c in np.arange(-4.0, g.L + 4.0, 0.05):
        axles = sum(Q * np.array([np.interp(c + o, a, row, left=0.0, right=0.0)
                                  for row in line]) for o in (-2.4, -0.8, 0.8, 2.4))
        lo, hi = (np.interp(v, a, np.arange(a.size)) for v in (c - 3.2, c + 3.2))
        inside = np.array([np.interp(hi, np.arange(a.size), r) - np.interp(
            lo, np.arange(a.size), r) for r in cum])
        best = max(best, float((axles + UDL * (cum[:, -1] - inside)).max()))
    safety = _row(summary, "Vertical deflection δ under LM71 × Φ × α")
    # the check shares a load between two stations linearly (0.75 m elements): an
    # underestimate of order (h/L)^2 that the report states; measured 8.5e-4 below, 2e-3
    np.testing.assert_allclose(safety["value"], phi3(g.L) * best, rtol=2e-3)
    assert "K_ff u = f" in report and "mean of its rails" in report
