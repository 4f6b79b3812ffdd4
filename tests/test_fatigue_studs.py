"""Fatigue of headed stud shear connectors and fatigue with ``study.vary``, through the
user's path (configuration -> ``vsi sweep`` -> netCDF -> ``vsi report``), against
references computed here: the closed-form shear of forces crawling over a simply
supported span and a resonant train's shear by a modal integration (scipy), each counted
by the rainflow of tests/reference.py (ASTM E1049, written from the standard) and summed
by Miner on the stud S-N curve written here; and a study of two bridge variants against
each variant's configuration run alone."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import xarray as xr
from typer.testing import CliRunner

from tests import reference as ref
from vsi_numba.cli.app import app
from vsi_numba.config import ConfigError, load_config

L, EI, M = 20.0, 2.0e10, 12000.0
ZETA = 0.02
#: A stud layout: shank diameter (m), studs per row, row spacing (m), S (m^3), I (m^4).
STUDS = {"diameter": 0.022, "per_row": 4, "row_spacing": 0.15, "first_moment": 0.06,
         "second_moment": 0.12}


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _toml(table):
    return "".join(f'{k} = "{v}"\n' if isinstance(v, str) else
                   f"{k} = {v}\n" if isinstance(v, int) else f"{k} = {float(v)!r}\n"
                   for k, v in table.items())


def _config(tmp_path, traffic, studs, *, name="fatigue.toml", ei=EI, study_extra="",
            dt=5e-4, output="results/out.nc"):
    text = f"""title = "stud fatigue test"
[bridge]
kind = "simply_supported"
spans = [{L}]
EI = {ei!r}
mass_per_length = {M}
damping_ratio = {ZETA}
n_modes = 3
[train]
preset = "HSLM-A1"
model = "moving_force"
[solver]
dt = {dt}
hht_alpha = 0.0
approach = 2.0
[study]
speeds_kmh = [100.0]
save_time_histories = false
output = "{output}"
{study_extra}
[fatigue]
design_life_years = 100
[[fatigue.sections]]
x = 10.0
section_modulus = 0.05
detail_category = 71
name = "bottom flange"
"""
    for s in studs:
        text += "[[fatigue.studs]]\n" + _toml(s)
    for t in traffic:
        text += "[[fatigue.traffic]]\n" + _toml(t)
    path = tmp_path / name
    path.write_text(text)
    return path


def _axles(tmp_path, name, positions, loads_kn):
    (tmp_path / name).write_text("position,load\n" + "".join(
        f"{x},{q}\n" for x, q in zip(positions, loads_kn, strict=True)))
    return name


def _tau_per_shear(s):
    """Stud shear stress per unit vertical shear (Pa/N): V S / I per m, times the row
    spacing, over the row's shank areas."""
    return (s["first_moment"] / s["second_moment"] * s["row_spacing"]
            / (s["per_row"] * np.pi * s["diameter"] ** 2 / 4))


def _stud_damage(ranges, counts, gamma_Ff=1.0, gamma_Mf=1.0):
    """Miner's sum on the stud curve of EN 1994-1-1 6.8.3: N = 2e6 (90 / gamma_Mf /
    (gamma_Ff range))^8, no cut-off."""
    r = gamma_Ff * np.asarray(ranges, float)
    c = np.asarray(counts, float)
    keep = r > 0
    return float(np.sum(c[keep] / (2e6 * (90.0 / gamma_Mf / r[keep]) ** 8)))


def _static_shear(positions, loads, fronts, x_s):
    """Shear V = dM/dx at x_s of forces (loads, N) at fronts - positions on the span
    (the value just right of x_s)."""
    v = np.zeros(fronts.size)
    for p, f in zip(positions, loads, strict=True):
        xk = fronts - p
        on = (xk >= 0) & (xk <= L)
        v += np.where(on, np.where(xk > x_s, f * (1 - xk / L), -f * xk / L), 0.0)
    return v


def test_fatigue_studs__crawl_gives_the_closed_form_shear_ranges_and_miner(tmp_path):
    positions, loads_kn = [0.0, 3.0], [200.0, 150.0]
    name = _axles(tmp_path, "pair.csv", positions, loads_kn)
    b = {**STUDS, "diameter": 0.019, "per_row": 3, "row_spacing": 0.2,
         "first_moment": 0.05, "second_moment": 0.1, "gamma_Ff": 1.1, "gamma_Mf": 1.15}
    studs = [{"x": 2.0, **STUDS, "name": "near the bearing"}, {"x": 10.0, **b}]
    cfg = _config(tmp_path, [{"train": name, "speed_kmh": 1.0, "per_day": 50.0}], studs,
                  dt=2e-3)
    rep = tmp_path / "report"
    r = _cli("sweep", cfg, "-q", "--report", rep)
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "out.nc")
    fronts = np.arange(0.0, L + 3.0 + 1e-9, 1e-3)
    loads = np.array(loads_kn) * 1e3
    gff, gmf = np.array([1.0, 1.1]), np.array([1.0, 1.15])
    d_mine, r_mine = [], []
    for s, g, m in zip(studs, gff, gmf, strict=True):
        tau = _static_shear(np.array(positions), loads, fronts, s["x"]) \
            * _tau_per_shear(s) / 1e6
        cyc = ref.rainflow_astm(tau)
        rng = np.array([c[0] for c in cyc])
        cnt = np.array([c[1] for c in cyc])
        r_mine.append(rng.max())
        d_mine.append(_stud_damage(rng, cnt, g, m))
    # the largest range by hand: at x = 2 m from -20 kN (200 kN just left of it) to
    # +285 kN (both forces just right of it); at x = 10 m from -152.5 kN (200 kN just
    # left, 150 kN 3 m before) to +145 kN (200 kN at 13 m, 150 kN just right)
    np.testing.assert_allclose(r_mine, [305e3 * _tau_per_shear(studs[0]) / 1e6,
                                        297.5e3 * _tau_per_shear(studs[1]) / 1e6],
                               rtol=1e-4)  # the 1 mm sampling of the crawl
    got = ds["fatigue_stud_max_shear_stress_range"].values[0]
    # crawl at 1 km/h: the deck's dynamics add at most ~ v / (2 f L) = 0.14 % to the
    # moment ranges, less to the shear jumps
    np.testing.assert_allclose(got, r_mine, rtol=1e-3)
    # damage ~ range^8: 8 x 0.1 %, and the crawl's ripple cycles add ~ nothing
    np.testing.assert_allclose(ds["fatigue_stud_damage_per_passage"].values[0], d_mine,
                               rtol=1e-2)
    np.testing.assert_allclose(ds["fatigue_stud_damage"].values,
                               ds["fatigue_stud_damage_per_passage"].values[0]
                               * 50 * 365 * 100, rtol=1e-12)  # passages: exact product
    # damage-equivalent range at 2e6 cycles (m = 8): (90 / gamma_Mf) D^(1/8) / gamma_Ff
    d = ds["fatigue_stud_damage"].values
    np.testing.assert_allclose(ds["fatigue_stud_equivalent_shear_stress_range"].values,
                               90.0 / gmf * d ** 0.125 / gff, rtol=1e-12)
    assert ds["fatigue_stud_damage"].attrs["units"] == "1"
    assert ds["fatigue_stud_max_shear_stress_range"].attrs["units"] == "MPa"
    assert "sign_convention" in ds["fatigue_stud_max_shear_stress_range"].attrs
    assert list(ds["fatigue_stud_name"].values) == ["near the bearing", "studs at x = 10 m"]
    # the report: the verdict per stud layout, and the summary rows with the file's values
    text = (rep / "report.md").read_text()
    assert "near the bearing (studs at x = 2 m, 4 × ⌀22 mm every 0.15 m)" in text
    assert "Stud fatigue verdict per layout" in text
    import pandas as pd

    summ = pd.read_csv(rep / "summary.csv")
    rows = summ[summ["check"].str.startswith("Stud fatigue damage (Miner)")]
    # 7 significant digits in the CSV
    np.testing.assert_allclose(rows["value"].to_numpy(float), d, rtol=1e-6)
    ds.close()
    r = _cli("report", tmp_path / "results" / "out.nc", "-o", rep)
    assert r.exit_code == 0, r.output


def _modal_shear(positions, loads, v, x_outs, t_end, n_modes, x0):
    """Shear histories at each of ``x_outs`` of moving forces on the simply supported
    span: modal ODEs by solve_ivp (once for all the sections), the shear by the
    mode-acceleration method (static shear of the forces minus the modal inertia and
    damping parts (q'' + 2 zeta w q') / w^2 V_j)."""
    om = ref.ss_omega(L, EI, M, n_modes)
    j = np.arange(1, n_modes + 1)

    def phi(x):
        inside = (x >= 0) & (x <= L)
        return np.where(inside[:, None], ref.ss_shapes(L, M, n_modes, np.clip(x, 0, L)), 0.0)

    def force(t):
        return (loads[:, None] * phi(x0 - positions + v * t)).sum(axis=0)

    def rhs(t, y):
        q, qd = y[:n_modes], y[n_modes:]
        return np.concatenate([qd, force(t) - 2 * ZETA * om * qd - om**2 * q])

    breaks = sorted({0.0, t_end, *[b for p in positions for b in ((p - x0) / v,
                                                                 (p - x0 + L) / v)
                                   if 0 < b < t_end]})
    ts, ys = [], []
    y = np.zeros(2 * n_modes)
    for a, b in zip(breaks[:-1], breaks[1:], strict=True):
        te = np.arange(np.ceil(a / 2e-4) * 2e-4, b, 2e-4)
        sol = scipy.integrate.solve_ivp(rhs, (a, b), y, rtol=1e-9, atol=1e-12,
                                        max_step=0.005, dense_output=True)
        ts.append(te)
        ys.append(sol.sol(te))
        y = sol.y[:, -1]
    t = np.concatenate(ts)
    Y = np.concatenate(ys, axis=1)
    q, qd = Y[:n_modes], Y[n_modes:]
    # the modal forces at every sample at once: (sample, force, mode) summed over the
    # forces, as force(t) sums them
    x = (x0 - positions[None, :] + v * t[:, None]).ravel()
    forces = (loads[None, :, None] * phi(x).reshape(t.size, positions.size, n_modes)).sum(
        axis=1)
    qdd = forces.T - 2 * ZETA * om[:, None] * qd - om[:, None] ** 2 * q
    shears = []
    for x_out in x_outs:
        # modal shear per unit q: V = dM/dx with M_j = EI (j pi / L)^2 phi_j
        vj = EI * (j * np.pi / L) ** 2 * ref.ss_shapes(L, M, n_modes, np.array([x_out]),
                                                         derivative=1)[0]
        stat = _static_shear(positions, loads, x0 + v * t, x_out)
        corr = ((qdd + 2 * ZETA * om[:, None] * qd) / om[:, None] ** 2
                * vj[:, None]).sum(axis=0)
        shears.append(stat - corr)
    return t, shears


def _rake(tmp_path, n=10, d=10.0):
    f1 = ref.ss_omega(L, EI, M, 1)[0] / (2 * np.pi)
    return d * np.arange(n), f1 * d, _axles(tmp_path, "rake.csv", d * np.arange(n),
                                            [200.0] * n)


def test_fatigue_studs__resonant_train_against_own_modal_shear_and_counting(tmp_path):
    positions, v, name = _rake(tmp_path)
    studs = [{"x": 1.0, **STUDS, "name": "end"}, {"x": 10.0, **STUDS, "name": "middle"}]
    cfg = _config(tmp_path, [{"train": name, "speed_kmh": v * 3.6, "per_day": 1.0}], studs)
    r = _cli("sweep", cfg, "-q")
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "out.nc")
    fv = float(ds["fatigue_free_vibration"].values[0])
    t_end = (2.0 + L + positions[-1]) / v + fv
    _, shears = _modal_shear(positions, np.full(positions.size, 200e3), v,
                             [s["x"] for s in studs], t_end, 3, -2.0)
    for k, (s, shear) in enumerate(zip(studs, shears, strict=True)):
        tau = shear * _tau_per_shear(s) / 1e6
        cyc = ref.rainflow_astm(tau)
        rng = np.array([c[0] for c in cyc])
        cnt = np.array([c[1] for c in cyc])
        got_r = float(ds["fatigue_stud_max_shear_stress_range"].values[0, k])
        got_d = float(ds["fatigue_stud_damage_per_passage"].values[0, k])
        # HHT (alpha = 0) at dt = 0.5 ms against solve_ivp (rtol 1e-9) sampled at
        # 0.2 ms: the largest ranges to ~0.2 %
        assert got_r == pytest.approx(rng.max(), rel=3e-3)
        # damage ~ range^8: 8 x 0.2 % ~ 2 %
        assert got_d == pytest.approx(_stud_damage(rng, cnt), rel=3e-2)
        if k == 0:  # near the bearing resonance adds to the crawl's shear range
            fronts = np.arange(0.0, L + positions[-1], 1e-3)
            crawl = _static_shear(positions, np.full(positions.size, 200e3), fronts, s["x"])
            assert rng.max() > 1.2 * np.ptp(crawl) * _tau_per_shear(s) / 1e6
    ds.close()


def test_fatigue_vary__each_variant_as_its_own_configuration_run_alone(tmp_path):
    positions, v, name = _rake(tmp_path)
    studs = [{"x": 1.0, **STUDS, "name": "end"}]
    traffic = [{"train": name, "speed_kmh": v * 3.6, "per_day": 3.0}]
    eis = [EI, 1.5 * EI]  # variant 0 at the rake's resonance, variant 1 off it
    vary = 'vary = { "bridge.EI" = [' + ", ".join(repr(e) for e in eis) + "] }"
    cfg = _config(tmp_path, traffic, studs, study_extra=vary, dt=1e-3,
                  output="results/var.nc")
    rep = tmp_path / "report"
    r = _cli("sweep", cfg, "-q", "--report", rep)
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "var.nc")
    names = ["fatigue_damage", "fatigue_damage_per_passage", "fatigue_max_stress_range",
             "fatigue_equivalent_stress_range", "fatigue_free_vibration",
             "fatigue_cycles", "fatigue_stud_damage", "fatigue_stud_damage_per_passage",
             "fatigue_stud_max_shear_stress_range", "fatigue_stud_cycles"]
    for n in names:
        assert ds[n].dims[0] == "variant", n
    for n in ("fatigue_section_modulus", "fatigue_speed_kmh", "fatigue_stud_diameter"):
        assert "variant" not in ds[n].dims, n  # the same in every variant
    for k, ei in enumerate(eis):
        alone = _config(tmp_path, traffic, studs, name=f"alone{k}.toml", ei=ei, dt=1e-3,
                        output=f"results/alone{k}.nc")
        r = _cli("sweep", alone, "-q")
        assert r.exit_code == 0, r.output
        one = xr.open_dataset(tmp_path / "results" / f"alone{k}.nc")
        for n in names:
            # the same runs of the same bridge: the same numbers
            np.testing.assert_allclose(ds[n].values[k], one[n].values, rtol=1e-12,
                                       atol=0, err_msg=n)
        one.close()
    d = ds["fatigue_damage"].values
    # the resonant variant does more damage than the stiffer one (off resonance)
    assert d[0, 0] > 2 * d[1, 0]
    text = (rep / "report.md").read_text()
    assert "## Fatigue over the variants" in text
    assert "**Fatigue governs in variant 0** (bridge.EI = 2e+10)" in text
    row = next(ln for ln in text.splitlines() if ln.startswith("| 1 | bridge.EI = 3e+10"))
    # 4 significant digits in the table
    assert float(row.split("|")[3]) == pytest.approx(d[1, 0], rel=1e-3)
    assert float(row.split("|")[4]) == pytest.approx(
        float(ds["fatigue_stud_damage"].values[1, 0]), rel=1e-3)
    sub = (rep / "governing_variant" / "report.md").read_text()
    assert "## Fatigue" in sub and "end (studs at x = 1 m" in sub
    ds.close()


@pytest.mark.parametrize("change, message", [
    ({"diameter": 22.0}, "fatigue.studs[0].diameter = 22.0: expected a stud diameter > 0 m"),
    ({"diameter": 0.08}, "fatigue.studs[0].diameter = 0.08 m: expected 0.01 .. 0.035 m"),
    ({"per_row": 0}, "fatigue.studs[0].per_row = 0: expected a whole number of studs per "
                     "row, 1 to 20"),
    ({"x": 25.0}, "fatigue.studs[0].x = 25.0: expected a position on the deck, 0 to 20 m"),
    ({"second_moment": -1.0}, "fatigue.studs[0].second_moment = -1.0: expected a second "
                              "moment of area > 0 m^4"),
])
def test_fatigue_studs_config__errors_name_the_key_value_and_expectation(tmp_path, change,
                                                                          message):
    name = _axles(tmp_path, "force.csv", [0.0], [200.0])
    cfg = _config(tmp_path, [{"train": name, "speed_kmh": 100.0, "per_day": 1.0}],
                  [{"x": 2.0, **STUDS, **change}])
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    assert any(e.startswith(message) for e in exc.value.errors), exc.value.errors
    r = _cli("check", cfg)
    assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output
