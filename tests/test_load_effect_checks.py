"""EN 1991-2 6.4.6 checks of load effects on a constructed results file whose answers are
known by hand: one moving force P on a simply supported span L."""

import json

import numpy as np
import pytest
import xarray as xr

from vsi_numba.analysis.checks.load_effects import (
    LM71_GOVERNS,
    REAL_GOVERNS,
    load_effect_checks,
    phi_dyn,
    verdict,
)
from vsi_numba.analysis.report.load_effects import FIGURE_NAME, load_effects_section

L, EI, P = 20.0, 5e10, 2.0e6
F1 = 6.0
# LM71 by hand on the simply supported span (see tests/test_lm71.py for the derivation)
LM71_M_MID = 250e3 * (L - 3.2) + 80e3 * (L**2 / 8 - (1.6 * L - (3.2**2 + 0.8**2) / 2))
LM71_R = 250e3 * (4 - 9.6 / L) + 80e3 * (L - 5.6) ** 2 / (2 * L)   # = max shear at 0+
PHI3 = 2.16 / (np.sqrt(L) - 0.2) + 0.73


def phi2_by_hand(v):
    a = min(v / 22.0, 1.0)
    return a * (0.56 * np.exp(-(L / 10) ** 2) + 0.5 * (F1 * L / 80 - 1) * np.exp(-(L / 20) ** 2))


def results(study=None, load_effects=True) -> xr.Dataset:
    """Two speeds, one train of one axle P; dynamic envelopes = factor x static."""
    speeds = np.array([40.0, 80.0])                    # m/s
    amp = np.array([1.3, 1.1])                         # dynamic / static at each speed
    cfg = {"bridge": {"kind": "simply_supported", "spans": [L], "EI": EI},
           "study": study or {}}
    pts = np.array([L / 2])
    sup = np.array([0.0, L])
    m_st = P * L / 4                                   # midspan moment, load at midspan
    v_st = P / 2                                       # |V| at midspan
    r_st = np.array([P, P])
    # max end rotation over placements: P a (L - a)(2L - a) / (6 L EI), largest at
    # a = L (1 - 1/sqrt 3): P L^2 / (9 sqrt(3) EI)
    th_st = np.array([1.0, -1.0]) * P * L**2 / (9 * np.sqrt(3) * EI)
    w_st = P * L**3 / (48 * EI)
    case = ("speed", "train", "irregularity")

    def env(values, dim):
        a = amp[:, None, None, None] * np.asarray(values, float)[None, None, None, :]
        return (case + (dim,), a)

    ds = xr.Dataset(
        {
            "max_deck_displacement": env([w_st], "point"),
            "max_deck_acceleration": env([1.0], "point"),
            "frequency": (("mode",), [F1]),
            "wheel_position": (("train", "wheel"), [[0.0]]),
            "static_wheel_load": (("train", "wheel"), [[P]]),
        },
        coords={"speed": speeds, "speed_kmh": ("speed", speeds * 3.6), "train": ["one"],
                "irregularity": [-1], "point": pts, "mode": [1]},
        attrs={"config_json": json.dumps(cfg), "bridge_length": L},
    )
    if load_effects:
        ds = ds.assign_coords(support=sup, deck_x=np.linspace(0, L, 5))
        x = ds["deck_x"].values
        m_line = P * np.minimum(x, L - x) / 2        # max M over placements: load at x
        ds["max_bending_moment"] = env([m_st], "point")
        ds["min_bending_moment"] = env([0.0], "point")
        ds["max_shear_force"] = env([v_st], "point")
        ds["min_shear_force"] = env([-v_st], "point")
        ds["max_support_reaction"] = env(r_st, "support")
        ds["min_support_reaction"] = env([0.0, 0.0], "support")
        ds["max_end_rotation"] = env([th_st[0], 0.0], "support")
        ds["min_end_rotation"] = env([0.0, th_st[1]], "support")
        ds["max_bending_moment_whole_deck"] = env(m_line, "deck_x")
        ds["min_bending_moment_whole_deck"] = env(0 * x, "deck_x")
        ds["max_shear_force_whole_deck"] = env(P * (1 - x / L), "deck_x")
        ds["min_shear_force_whole_deck"] = env(-P * x / L, "deck_x")
    return ds


def test_phi_dyn_and_verdict_constructed():
    assert phi_dyn(1.3, 1.0) == pytest.approx(0.3)
    assert np.isnan(phi_dyn(1.0, 0.0))
    # 1.3 x 100 + 0.1/2 x 100 = 135 against 1.2 x 1.1 x 100 = 132: the train governs
    v = verdict(0.3, 0.1, 100.0, 100.0, 1.2, 1.1)
    assert v.real == pytest.approx(135.0) and v.lm71 == pytest.approx(132.0)
    assert v.governs == REAL_GOVERNS and v.ratio == pytest.approx(135 / 132)
    assert verdict(0.3, 0.1, 100.0, 100.0, 1.3, 1.1).governs == LM71_GOVERNS


def test_checks_on_constructed_file():
    c = load_effect_checks(results())
    assert not isinstance(c, str), c
    env = c.envelopes.set_index("effect")
    # static crawl of one axle: closed forms (the crawl is exact for these linear lines)
    assert env.loc["moment", "static"] == pytest.approx(P * L / 4, rel=1e-12)
    assert env.loc["shear", "static"] == pytest.approx(P / 2, rel=1e-8)
    assert env.loc["moment", "lm71"] == pytest.approx(LM71_M_MID, rel=1e-9)
    r = c.envelopes[c.envelopes.effect == "reaction"]
    np.testing.assert_allclose(r["static"], [P, P], rtol=1e-8)
    np.testing.assert_allclose(r["lm71"], [LM71_R, LM71_R], rtol=1e-8)
    th = c.envelopes[c.envelopes.effect == "rotation"]
    # smooth (cubic) line: the 0.05 m grid is within h^2/8 |E''| = 1e-5 relative
    np.testing.assert_allclose(th["static"], P * L**2 / (9 * np.sqrt(3) * EI), rtol=1e-5)
    # phi'_dyn = 1.3 - 1 for every effect, at the first speed (144 km/h)
    pdyn = c.phi_dyn.set_index("effect")
    for e in ("deflection", "moment", "shear", "reaction", "rotation"):
        assert pdyn.loc[e, "phi_dyn"] == pytest.approx(0.3, rel=1e-5), e
        assert pdyn.loc[e, "speed_kmh"] == pytest.approx(144.0)
    # per speed: 1.3 - 1 at 144 km/h and 1.1 - 1 at 288 km/h
    sp = c.phi_dyn_speeds[c.phi_dyn_speeds.effect == "moment"]
    np.testing.assert_allclose(sp["speed_kmh"], [144.0, 288.0])
    np.testing.assert_allclose(sp["phi_dyn"], [0.3, 0.1], rtol=1e-9)
    # verdict: max over speeds of (amp + phi''(v)/2) x static against Phi3 x LM71
    assert c.factors["phi"] == pytest.approx(PHI3, rel=1e-12)
    design = max(1.3 + phi2_by_hand(40.0) / 2, 1.1 + phi2_by_hand(80.0) / 2) * P * L / 4
    ver = c.verdict.set_index("effect")
    assert ver.loc["moment", "real_design"] == pytest.approx(design, rel=1e-9)
    assert ver.loc["moment", "lm71_design"] == pytest.approx(PHI3 * LM71_M_MID, rel=1e-9)
    ratio = design / (PHI3 * LM71_M_MID)
    assert ratio > 1 and ver.loc["moment", "governs"] == REAL_GOVERNS
    assert ver.loc["moment", "margin"] == pytest.approx(ratio, rel=1e-9)
    # deck-end rotation: the design value (the larger of Phi3 x LM71 and the train's)
    # against 6.5 mrad. LM71 by brute force on the closed-form line
    # theta_A(a) = a (L - a)(2L - a) / (6 L EI) (> 0: udl everywhere outside the zone)
    xm = np.arange(0.001, L, 0.002)
    il = xm * (L - xm) * (2 * L - xm) / (6 * L * EI)
    best = 0.0
    for cc in np.arange(-3.2, L + 3.2, 0.02):
        a = cc + np.array([-2.4, -0.8, 0.8, 2.4])
        a = a[(a > 0) & (a < L)]
        out = (xm < cc - 3.2) | (xm > cc + 3.2)
        best = max(best, 250e3 * np.sum(a * (L - a) * (2 * L - a)) / (6 * L * EI)
                   + 80e3 * 0.002 * il[out].sum())
    rot = c.rotation.set_index("support")
    # 2 cm grid near a smooth optimum and the 2 mm midpoint mask: < 1e-4 relative
    assert rot.loc[0.0, "theta_lm71_design"] == pytest.approx(PHI3 * best, rel=1e-4)
    th_real = max(1.3 + phi2_by_hand(40.0) / 2, 1.1 + phi2_by_hand(80.0) / 2) * (
        P * L**2 / (9 * np.sqrt(3) * EI))
    assert rot.loc[0.0, "theta_real_design"] == pytest.approx(th_real, rel=1e-5)
    th = max(th_real, PHI3 * best)
    assert rot.loc[L, "utilisation"] == pytest.approx(th / 6.5e-3, rel=1e-4)
    assert list(c.rotation["result"]) == ["pass" if th <= 6.5e-3 else "FAIL"] * 2


def test_alpha_and_maintenance_from_study_keys():
    c = load_effect_checks(results({"classification_factor": 1.21,
                                    "track_maintenance": "careful"}))
    phi2 = min(1.44 / (np.sqrt(L) - 0.2) + 0.82, 1.67)
    assert c.factors["phi"] == pytest.approx(phi2, rel=1e-12)
    ver = c.verdict.set_index("effect")
    assert ver.loc["moment", "lm71_design"] == pytest.approx(1.21 * phi2 * LM71_M_MID,
                                                             rel=1e-9)


def test_report_section(tmp_path):
    sec = load_effects_section(results(), tmp_path)
    text = "\n".join(sec.lines)
    assert "## Load effects" in text and "Verdict" in text and "Deck-end rotation" in text
    assert (tmp_path / FIGURE_NAME).is_file() and sec.figures[0][0] == FIGURE_NAME
    assert set(sec.tables) == {"load_effect_envelopes", "phi_dyn", "phi_dyn_speeds",
                               "load_effect_verdict", "end_rotation"}


def test_report_section_without_load_effects(tmp_path):
    (tmp_path / FIGURE_NAME).write_text("stale")
    sec = load_effects_section(results(load_effects=False), tmp_path)
    text = "\n".join(sec.lines)
    assert "Not available" in text and "no load-effect envelopes" in text
    assert not (tmp_path / FIGURE_NAME).exists() and sec.tables == {}
    ds = results()
    ds.attrs["config_json"] = json.dumps({"bridge": {"kind": "modes_file"}})
    assert "bridge.kind = 'modes_file'" in "\n".join(load_effects_section(ds).lines)


def test_quasi_static_run_gives_phi_dyn_near_zero(tmp_path):
    """A real run: two moving forces crossing a 10 m span at 2 km/h with 5 % damping and
    rigid track is quasi-static, so the dynamic envelopes of the engine must equal the
    crawl of this module: phi'_dyn ~ 0 for M, V, R and theta. Tolerance 5e-3: the
    speed parameter v / (2 f1 L) = 2.8e-3 (f1 = 9.9 Hz) bounds the dynamic increment,
    and the residual free vibration is damped at 5 %."""
    from vsi_numba.study.runner import run_study

    config = {
        "title": "quasi-static",
        "bridge": {"kind": "simply_supported", "spans": [10.0], "EI": 2e9,
                   "mass_per_length": 5000.0, "damping_ratio": 0.05, "n_modes": 3,
                   "output_points": [2.5, 5.0]},
        "train": {"vehicles": [{"kind": "force", "load": 1e5},
                               {"kind": "force", "load": 6e4, "offset": 3.0}]},
        "track": {"model": "rigid"},
        "solver": {"dt": 2e-3, "free_vibration": 0.0, "approach": 0.5},
        "study": {"speeds_kmh": [2.0], "save_time_histories": False},
    }
    ds = run_study(config, tmp_path / "qs.nc", backend="serial")
    c = load_effect_checks(ds)
    assert not isinstance(c, str), c
    got = c.phi_dyn.set_index("effect")["phi_dyn"]
    for e in ("moment", "shear", "reaction", "rotation"):
        assert abs(got[e]) < 5e-3, (e, got[e])   # measured <= 8e-5


def test_hslm_b_outside_its_span_range_is_noted():
    # HSLM-B covers simply supported spans < 7 m: on the 20 m span the section says so
    ds = results().assign_coords(train=["HSLM-B"])
    c = load_effect_checks(ds)
    assert "shorter than 7 m" in c.factors["notes"][0]
    assert "use HSLM-A" in "\n".join(load_effects_section(ds).lines)
    assert load_effect_checks(results()).factors["notes"] == []
