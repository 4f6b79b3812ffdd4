"""Parametric studies: [study.vary], mass bounds, EN 1991-2 damping rules.

References: every variant against a separate single-bridge study of the same values
(computed here from its own config), the EN 1991-2 formulas written out in the test, and
the values tabulated in the project's railway notes.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from vsi_numba import en1991
from vsi_numba.config import ConfigError, load_config
from vsi_numba.io.schema import ENVELOPES
from vsi_numba.study.runner import run_study

BASE = """
title = "variants"
[bridge]
kind = "simply_supported"
spans = [12.0]
EI = 6.0e9
mass_per_length = 12000.0
damping_ratio = {damping}
n_modes = 3
[train]
preset = ["HSLM-A1", "HSLM-A3"]
[solver]
dt = 2e-3
approach = 1.0
free_vibration = 0.0
[study]
speeds_kmh = [180.0, 260.0, 340.0]
save_time_histories = false
"""


def _write(path, damping="0.02", extra=""):
    path.write_text(textwrap.dedent(BASE.format(damping=damping)) + extra)
    return path


def test_vary__mass_and_damping_one_file_equal_to_separate_runs(tmp_path):
    """A study varying mass (mass_bounds) and damping (study.vary) gives one file whose
    variant coordinates name the varied keys; each variant equals a separate study of a
    config that states those values (same model, same kernel: bit for bit)."""
    cfg = _write(tmp_path / "vary.toml", extra=textwrap.dedent("""
        mass_bounds = [0.9, 1.1]
        [study.vary]
        "bridge.damping_ratio" = [0.01, 0.025]
    """))
    with run_study(cfg, tmp_path / "vary.nc", backend="threads", workers=2) as ds:
        ds = ds.load()
    assert ds.sizes["variant"] == 4
    # every combination; study.vary keys first, mass_bounds last (varies fastest)
    assert ds["bridge_damping_ratio"].values.tolist() == [0.01, 0.01, 0.025, 0.025]
    assert ds["mass_factor"].values.tolist() == [0.9, 1.1, 0.9, 1.1]
    assert ds["bridge_damping_ratio"].attrs["key_path"] == "bridge.damping_ratio"
    for k in range(4):
        m = 12000.0 * float(ds["mass_factor"][k])
        z = float(ds["bridge_damping_ratio"][k])
        one = _write(tmp_path / f"one{k}.toml", damping=str(z))
        one.write_text(one.read_text().replace("mass_per_length = 12000.0",
                                               f"mass_per_length = {m!r}"))
        with run_study(one, tmp_path / f"one{k}.nc", backend="serial") as ref:
            for name in ENVELOPES:
                if name not in ref.variables:  # not offered (moving forces: no car body)
                    assert name not in ds.variables, name
                    continue
                np.testing.assert_array_equal(ds[name].isel(variant=k).values,
                                              ref[name].values, err_msg=name)
            np.testing.assert_allclose(ds["frequency"].isel(variant=k), ref["frequency"],
                                       rtol=1e-15)
    # the variants really differ (mass and damping move the response)
    acc = ds["max_deck_acceleration"].max(["speed", "train", "irregularity", "point"])
    assert np.unique(acc.values).size == 4


def test_vary__together_and_changing_spans(tmp_path):
    """Zipped variation of span, EI and mass: the output points move with the spans
    (default mid-span), kept as point_position(variant, point)."""
    cfg = _write(tmp_path / "zip.toml", extra=textwrap.dedent("""
        [[study.vary_together]]
        "bridge.spans" = [[10.0], [14.0]]
        "bridge.EI" = [4.0e9, 9.0e9]
        "bridge.mass_per_length" = [10000.0, 14000.0]
    """))
    with run_study(cfg, tmp_path / "zip.nc", backend="serial") as ds:
        assert ds.sizes["variant"] == 2
        assert ds["bridge_spans"].values.tolist() == [10.0, 14.0]  # one span: a number
        np.testing.assert_array_equal(ds["point_position"].values, [[5.0], [7.0]])
        np.testing.assert_array_equal(ds["bridge_length"].values, [10.0, 14.0])
        f1 = ds["frequency"].isel(mode=0).values
        exact = [np.pi / 2 / L**2 * np.sqrt(ei / m) for L, ei, m in
                 [(10.0, 4e9, 1e4), (14.0, 9e9, 1.4e4)]]
        np.testing.assert_allclose(f1, exact, rtol=1e-12)  # analytic sine modes


def test_vary__bad_key_path_or_value_named_before_anything_runs(tmp_path):
    cfg = _write(tmp_path / "bad.toml", extra=textwrap.dedent("""
        [study.vary]
        "bridge.mass_per_lenght" = [1.0e4]
        "bridge.EI" = [-1.0]
    """))
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    text = str(exc.value)
    assert "bridge.mass_per_lenght" in text and "did you mean" in text
    assert "bridge.EI = -1.0" in text and "EI > 0" in text
    cfg = _write(tmp_path / "bad2.toml", extra='[study.vary]\n"study.speeds_kmh" = [[100.0]]\n')
    with pytest.raises(ConfigError, match=r'study.vary\["study.speeds_kmh"\]'):
        load_config(cfg)
    cfg = _write(tmp_path / "bad3.toml", extra=textwrap.dedent("""
        [[study.vary_together]]
        "bridge.EI" = [4.0e9, 9.0e9]
        "bridge.mass_per_length" = [10000.0]
    """))
    with pytest.raises(ConfigError, match=r"study.vary_together\[0\].*one length"):
        load_config(cfg)


# ------------------------------------------------------------------- EN 1991-2 rules


@pytest.mark.parametrize("span", [5.0, 10.0, 15.0, 19.0, 20.0, 25.0, 40.0])
def test_en1991__table_6_6_lower_bound_damping(span):
    """Table 6.6 (railway notes, [V]): zeta % = z0 + k (20 - L) below 20 m, z0 above."""
    for deck, z0, k in [("steel_composite", 0.5, 0.125),
                        ("prestressed_concrete", 1.0, 0.07),
                        ("filler_beam_reinforced_concrete", 1.5, 0.07)]:
        expected = (z0 + k * (20.0 - span)) if span < 20.0 else z0
        # the same closed form: round-off only
        assert en1991.damping_lower_bound(deck, span) == pytest.approx(expected / 100,
                                                                       rel=1e-14)


@pytest.mark.parametrize("span, tabulated", [(5.0, 0.110), (10.0, 0.329), (12.5, 0.516),
                                             (15.0, 0.653), (17.5, 0.531), (20.0, 0.296),
                                             (25.0, 0.060)])
def test_en1991__additional_damping_formula_and_table(span, tabulated):
    """Delta zeta of 6.4.6.3.1: the formula written here, and the values tabulated in the
    railway notes to 3 decimals (so 5e-4 % absolute)."""
    L = span
    formula = (0.0187 * L - 0.00064 * L**2) / (1 - 0.0441 * L - 0.0044 * L**2
                                               + 0.000255 * L**3)
    assert en1991.additional_damping(span) == pytest.approx(formula / 100, rel=1e-14)
    assert 100 * en1991.additional_damping(span) == pytest.approx(tabulated, abs=5e-4)
    assert en1991.additional_damping(30.0) == 0.0 and en1991.additional_damping(35.0) == 0.0


def test_en1991__damping_rules_in_a_study(tmp_path):
    """damping_ratio = 'EN1991-2' sets Table 6.6 for the span; additional_damping adds
    Delta zeta to moving-force trains only (never to interaction models); both rules are
    stated in the results' attributes."""
    cfg = _write(tmp_path / "en.toml", damping='"EN1991-2"', extra="")
    text = cfg.read_text().replace('damping_ratio = "EN1991-2"', 'damping_ratio = "EN1991-2"\n'
                                   'deck_type = "prestressed_concrete"\n'
                                   'additional_damping = true')
    text = text.replace('preset = ["HSLM-A1", "HSLM-A3"]', 'preset = ["HSLM-A1", "ICE3"]')
    cfg.write_text(text)
    c = load_config(cfg)
    zeta = (1.0 + 0.07 * (20.0 - 12.0)) / 100
    dz = en1991.additional_damping(12.0)
    np.testing.assert_allclose(c.build_bridge().damping, zeta, rtol=1e-14)
    hslm, ice3 = c.trains()
    np.testing.assert_allclose(c.bridge_for(hslm).damping, zeta + dz, rtol=1e-14)
    np.testing.assert_allclose(c.bridge_for(ice3).damping, zeta, rtol=1e-14)
    with run_study(cfg, tmp_path / "en.nc", backend="serial") as ds:
        assert "Table 6.6" in ds.attrs["damping_rule"]
        assert "moving-force trains only" in ds.attrs["additional_damping_rule"]


def test_refine_resonance__adds_f1_d_over_i(tmp_path):
    """study.refine_resonance adds v_i = 3.6 f1 D / i (and +-1 km/h) of every train with a
    regular coach length D, inside the speed range; f1 of the sine mode written here."""
    cfg = _write(tmp_path / "res.toml", extra="refine_resonance = true\n")
    cfg.write_text(cfg.read_text().replace("speeds_kmh = [180.0, 260.0, 340.0]",
                                           "speeds_kmh = { start = 140.0, stop = 420.0, "
                                           "step = 20.0 }"))
    c = load_config(cfg)
    f1 = np.pi / 2 / 12.0**2 * np.sqrt(6.0e9 / 12000.0)
    speeds = c.speeds_kmh
    added = 0
    for train in c.trains():  # HSLM-A1 (D = 18 m), HSLM-A3 (D = 20 m)
        for i in (1, 2, 3):
            v = 3.6 * f1 * train.regular_length / i
            if 140.0 <= v <= 420.0:
                added += 1
                # listed to 0.1 km/h, with neighbours 1 km/h either side
                for dv in (-1.0, 0.0, 1.0):
                    assert np.min(np.abs(speeds - (v + dv))) <= 0.05 + 1e-9
    assert added >= 2 and np.all(np.diff(speeds) > 0)
    assert speeds.size == 15 + 3 * added
