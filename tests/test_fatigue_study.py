"""The fatigue check through the user's path: a configuration with ``[fatigue]`` ->
``vsi sweep --report`` -> netCDF -> report, against references computed here: the
closed-form stress range of a force crawling over a simply supported span, a resonant
train against a modal integration (scipy) with a rainflow counting of this file, and a
crawling interaction car on a two-span deck against the three-moment equation."""

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


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _config(tmp_path, traffic, sections, *, extra="", bridge=None, n_modes=3, dt=5e-4):
    bridge = bridge or (f'kind = "simply_supported"\nspans = [{L}]\nEI = {EI}\n'
                        f"mass_per_length = {M}\n")
    text = f"""title = "fatigue test"
[bridge]
{bridge}damping_ratio = {ZETA}
n_modes = {n_modes}
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
output = "results/out.nc"
{extra}
[fatigue]
design_life_years = 100
"""
    def toml(table):
        return "".join(f'{k} = "{v}"\n' if isinstance(v, str) else f"{k} = {float(v)!r}\n"
                       for k, v in table.items())

    for s in sections:
        text += "[[fatigue.sections]]\n" + toml(s)
    for t in traffic:
        text += "[[fatigue.traffic]]\n" + toml(t)
    path = tmp_path / "fatigue.toml"
    path.write_text(text)
    return path


def _axles(tmp_path, name, positions, loads_kn):
    p = tmp_path / name
    p.write_text("position,load\n" + "".join(f"{x},{q}\n" for x, q in
                                             zip(positions, loads_kn, strict=True)))
    return name


def test_fatigue__crawling_force_gives_one_cycle_of_m_max_over_w(tmp_path):
    name = _axles(tmp_path, "force.csv", [0.0], [200.0])
    W = 0.01
    cfg = _config(tmp_path, [{"train": name, "speed_kmh": 1.0, "per_day": 10.0}],
                  [{"x": 10.0, "section_modulus": W, "detail_category": 71,
                    "name": "midspan"},
                   {"x": 5.0, "section_modulus": W, "detail_category": 71,
                    "gamma_Ff": 1.2}], dt=2e-3)
    rep = tmp_path / "report"
    r = _cli("sweep", cfg, "-q", "--report", rep)
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "out.nc")
    # closed form: M_max = P a (L - a) / L at the section, one cycle 0 -> M_max -> 0
    P = 200e3
    a = np.array([10.0, 5.0])
    ds_closed = P * a * (L - a) / L / W / 1e6  # MPa: 100 and 75
    got = ds["fatigue_max_stress_range"].values[0]
    # the force crawls at 1 km/h: dynamic increment ~ v / (2 f L) = 0.14 %
    np.testing.assert_allclose(got, ds_closed, rtol=3e-3)
    gff = np.array([1.0, 1.2])
    d_closed = np.array([ref.sn_damage([g * s], [1.0], 71.0, 1.35)
                         for g, s in zip(gff, ds_closed, strict=True)])
    # damage ~ range^3 (the ripple cycles of the crawl fall below the cut-off)
    np.testing.assert_allclose(ds["fatigue_damage_per_passage"].values[0], d_closed,
                               rtol=1e-2)
    np.testing.assert_allclose(ds["fatigue_damage"].values,
                               d_closed * 10.0 * 365.0 * 100.0, rtol=1e-2)
    assert ds["fatigue_damage"].attrs["units"] == "1"
    assert "Miner" in ds["fatigue_damage"].attrs["long_name"]
    # the cycles per passage: one full cycle of the range, little else above 1 MPa
    cyc = ds["fatigue_cycles"].values[0, 0]
    centres = ds["stress_range"].values
    assert cyc[centres > 50].sum() == pytest.approx(1.0)
    # the report: a fatigue section with the verdict per section, and the summary row
    text = (rep / "report.md").read_text()
    assert "## Fatigue" in text and "midspan (x = 10 m" in text
    assert "Fatigue damage (Miner), midspan" in (rep / "summary.csv").read_text()
    # the lambda-method beside it (EN 1993-2 9.5.3): the largest LM71 moment at mid-span
    # (4 x 250 kN at 1.6 m, 80 kN/m outside the 6.4 m zone) over the group's positions,
    # Phi_2 of L = 20 m, lambda_1 = 0.65, lambda_2 from 10 trains of 200 kN a day,
    # lambda_3 = lambda_4 = 1
    def infl(x):  # mid-span moment of a unit force at x
        return np.where((x < 0) | (x > L), 0.0, np.where(x <= L / 2, x / 2, (L - x) / 2))

    def area(x):  # integral of infl from 0 to x
        x = np.clip(x, 0.0, L)
        return np.where(x <= L / 2, x**2 / 4, 25 + (20 * x - x**2 / 2 - 150) / 2)

    centre = np.arange(-3.2, L + 3.2, 1e-3)
    m71 = np.max(250e3 * sum(infl(centre + o) for o in (-2.4, -0.8, 0.8, 2.4))
                 + 80e3 * (area(centre - 3.2) + area(L) - area(centre + 3.2)))
    lam = 0.65 * (10 * 365 * 200e3 / 9.81 / 1e3 / 25e6) ** 0.2
    phi2 = 1.44 / (np.sqrt(L) - 0.2) + 0.82
    row = next(ln for ln in text.splitlines() if ln.startswith("| midspan |"))
    cell = float(row.split("|")[9])
    # 4 significant digits in the table
    assert cell == pytest.approx(lam * phi2 * m71 / W / 1e6, rel=1e-3)
    ds.close()
    # a report replaces an earlier one, its fatigue figure included
    assert (rep / "fatigue_spectra.png").exists()
    r = _cli("report", tmp_path / "results" / "out.nc", "-o", rep)
    assert r.exit_code == 0, r.output


def _ss_modal_moment(positions, loads, v, x_out, t_end, n_modes, x0):
    """Midspan moment history of moving forces on the simply supported span: modal ODEs
    by solve_ivp, the moment by the mode-acceleration method (static moment of the
    forces + the modal inertia and damping correction)."""
    om = ref.ss_omega(L, EI, M, n_modes)
    j = np.arange(1, n_modes + 1)

    def phi(x):
        inside = (x >= 0) & (x <= L)
        return np.where(inside[:, None], ref.ss_shapes(L, M, n_modes, np.clip(x, 0, L)), 0.0)

    def force(t):
        xk = x0 - positions + v * t
        return (loads[:, None] * phi(xk)).sum(axis=0)

    def rhs(t, y):
        q, qd = y[:n_modes], y[n_modes:]
        return np.concatenate([qd, force(t) - 2 * ZETA * om * qd - om**2 * q])

    # breaks where an axle enters or leaves the span (the forcing has kinks there)
    breaks = sorted({0.0, t_end, *[b for p in positions for b in ((p - x0) / v,
                                                                 (p - x0 + L) / v)
                                   if 0 < b < t_end]})
    ts, ys = [], []
    y = np.zeros(2 * n_modes)
    for a, b in zip(breaks[:-1], breaks[1:], strict=True):
        te = np.arange(np.ceil(a / 1e-3) * 1e-3, b, 1e-3)
        sol = scipy.integrate.solve_ivp(rhs, (a, b), y, rtol=1e-9, atol=1e-12,
                                        max_step=0.005, dense_output=True)
        ts.append(te)
        ys.append(sol.sol(te))
        y = sol.y[:, -1]
    t = np.concatenate(ts)
    Y = np.concatenate(ys, axis=1)
    q, qd = Y[:n_modes], Y[n_modes:]
    qdd = np.array([force(tt) for tt in t]).T - 2 * ZETA * om[:, None] * qd \
        - om[:, None] ** 2 * q
    # modal moment per unit q: EI (j pi / L)^2 phi_j(x)  (M = -EI w'', w down)
    mj = EI * (j * np.pi / L) ** 2 * ref.ss_shapes(L, M, n_modes, np.array([x_out]))[0]
    stat = np.zeros(t.size)
    for p, f in zip(positions, loads, strict=True):
        xk = x0 - p + v * t
        on = (xk >= 0) & (xk <= L)
        # static moment at x_out of a force f at xk
        stat += np.where(on, f * np.where(x_out >= xk, xk * (L - x_out), x_out * (L - xk))
                         / L, 0.0)
    corr = ((qdd + 2 * ZETA * om[:, None] * qd) / om[:, None] ** 2 * mj[:, None]).sum(axis=0)
    return t, stat - corr


def test_fatigue__resonant_train_against_own_modal_integration_and_counting(tmp_path):
    # 10 forces of 200 kN every 10 m: first-mode resonance at v = f1 d
    n, d = 10, 10.0
    f1 = ref.ss_omega(L, EI, M, 1)[0] / (2 * np.pi)
    v = f1 * d
    positions = d * np.arange(n)
    name = _axles(tmp_path, "rake.csv", positions, [200.0] * n)
    W = 0.05
    cfg = _config(tmp_path, [{"train": name, "speed_kmh": v * 3.6, "per_day": 1.0}],
                  [{"x": 10.0, "section_modulus": W, "detail_category": 71}])
    r = _cli("sweep", cfg, "-q")
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "out.nc")
    fv = float(ds["fatigue_free_vibration"].values[0])
    # free vibration until 1 % of the amplitude: ln(100) / (zeta omega_1)
    assert fv == pytest.approx(np.log(100) / (ZETA * 2 * np.pi * f1), rel=1e-9)
    t_end = (2.0 + L + positions[-1]) / v + fv
    _, m = _ss_modal_moment(positions, np.full(n, 200e3), v, 10.0, t_end, 3, -2.0)
    stress = m / W / 1e6
    cycles = ref.rainflow_astm(stress)
    rng = np.array([c[0] for c in cycles])
    cnt = np.array([c[1] for c in cycles])
    # resonance: the stress range grows well beyond the static one (P L / 4 / W = 20 MPa)
    assert rng.max() > 1.5 * 200e3 * L / 4 / W / 1e6
    mine = ref.sn_damage(rng, cnt, 71.0, 1.35)
    got = float(ds["fatigue_damage_per_passage"].values[0, 0])
    # HHT (alpha = 0) at dt = 0.5 ms against solve_ivp (rtol 1e-9): the largest ranges
    # agree to ~0.1 %; damage ~ range^3..5 -> 1 %
    assert got == pytest.approx(mine, rel=1e-2)
    assert float(ds["fatigue_max_stress_range"].values[0, 0]) == pytest.approx(rng.max(),
                                                                               rel=3e-3)
    ds.close()


def test_fatigue__interaction_car_on_two_spans_crawling_matches_three_moments(tmp_path):
    span = 15.0
    bridge = (f'kind = "continuous"\nspans = [{span}, {span}]\nEI = {EI}\n'
              f"mass_per_length = {M}\nelements_per_span = 20\n")
    W = 0.02
    train = "manchester_benchmark_single"
    cfg = _config(tmp_path, [{"train": train, "speed_kmh": 3.0, "per_day": 5.0,
                              "model": "interaction"}],
                  [{"x": span, "section_modulus": W, "detail_category": 80,
                    "name": "middle support"}], bridge=bridge, n_modes=6, dt=1e-3)
    r = _cli("sweep", cfg, "-q")
    assert r.exit_code == 0, r.output
    ds = xr.open_dataset(tmp_path / "results" / "out.nc")
    # static axle loads of the car, from the library table (positions, loads)
    from vsi_numba.model.library import axle_table

    tab = axle_table(train)
    pos = tab["position_m"].to_numpy()
    q = tab["static_load_kN"].to_numpy() * 1e3
    # hogging moment over the middle support of two equal spans, load P at a from the
    # near end support (three-moment equation): M_B = -P a (l^2 - a^2) / (4 l^2)
    fronts = np.arange(0.0, 2 * span + pos.max() + 0.01, 0.01)
    mb = np.zeros(fronts.size)
    for p, f in zip(pos, q, strict=True):
        x = fronts - p
        a = np.where(x <= span, x, 2 * span - x)
        on = (x >= 0) & (x <= 2 * span)
        mb += np.where(on, -f * a * (span**2 - a**2) / (4 * span**2), 0.0)
    closed = (mb.max() - mb.min()) / W / 1e6
    got = float(ds["fatigue_max_stress_range"].values[0, 0])
    # crawling at 3 km/h: the car's bounce and the deck's dynamics add < 1 %
    assert got == pytest.approx(closed, rel=1e-2)
    assert float(ds["fatigue_damage"].values[0]) > 0
    ds.close()


@pytest.mark.parametrize("section, traffic, message", [
    ({"x": 10.0, "section_modulus": -1.0, "detail_category": 71}, None,
     "fatigue.sections[0].section_modulus = -1.0: expected a section modulus > 0 m^3"),
    ({"x": 99.0, "section_modulus": 0.1, "detail_category": 71}, None,
     "fatigue.sections[0].x = 99.0: expected a position on the deck, 0 to 20 m"),
    ({"x": 10.0, "section_modulus": 0.1, "detail_category": 71},
     {"train": "NoSuchTrain", "speed_kmh": 100.0, "per_day": 3.0},
     'fatigue.traffic[0].train = "NoSuchTrain": expected a train of the library'),
    ({"x": 10.0, "section_modulus": 0.1, "detail_category": 71},
     {"train": "AnnexD-3", "speed_kmh": 100.0, "per_day": 0.0},
     "fatigue.traffic[0].per_day = 0.0: expected a number of trains per day > 0"),
])
def test_fatigue_config__errors_name_the_key_value_and_expectation(tmp_path, section,
                                                                   traffic, message):
    traffic = traffic or {"train": "AnnexD-1", "speed_kmh": 100.0, "per_day": 3.0}
    cfg = _config(tmp_path, [traffic], [section])
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    assert any(e.startswith(message) for e in exc.value.errors), exc.value.errors
    r = _cli("check", cfg)
    assert r.exit_code != 0 and message in r.output and "Traceback" not in r.output


def test_fatigue_config__implausible_values_warn_and_the_mix_expands(tmp_path):
    cfg = _config(tmp_path, [], [{"x": 10.0, "section_modulus": 50.0,
                                  "detail_category": 73}])
    text = cfg.read_text().replace("design_life_years = 100", 'design_life_years = 100\n'
                                   'mix = "heavy"')
    cfg.write_text(text)
    with pytest.raises(ConfigError, match=r"section_modulus = 50 m\^3: expected 0.0001 \.\. "
                                          r"10 m\^3 on a railway bridge"):
        load_config(cfg)  # outside the plausible range of the key: refused
    cfg.write_text(text.replace("section_modulus = 50.0", "section_modulus = 0.05"))
    c = load_config(cfg)
    warnings = " ".join(c.warnings)
    assert "detail_category = 73 MPa is not a detail category" in warnings
    from vsi_numba.config.fatigue import traffic_of

    rows = traffic_of(c.resolved()["fatigue"])
    assert [r["train"] for r in rows] == ["AnnexD-5", "AnnexD-6", "AnnexD-11", "AnnexD-12"]
    assert [r["per_day"] for r in rows] == [6, 13, 16, 16]
