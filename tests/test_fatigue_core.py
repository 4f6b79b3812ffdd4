"""Fatigue core: rainflow counts of ASTM E1049's example history counted by hand and of
a random history against a counting written here, S-N curve of EN 1993-1-9, Miner's sum,
the lambda-method factors and the Annex D train types."""

from __future__ import annotations

import numpy as np
import pytest
import reference as ref

from vsi_numba.code_profile import ANNEX_D_MIXES, ANNEX_D_TYPES
from vsi_numba.model import fatigue as fat
from vsi_numba.model.library import annex_d

#: ASTM E1049-85 (2017), Fig. 6: the rainflow example, peaks and valleys A..I.
ASTM = [-2.0, 1.0, -3.0, 5.0, -1.0, 3.0, -4.0, 4.0, -2.0]
#: Counted by hand (E1049 5.4.4 procedure): range -> cycles (0.5 = half cycle).
ASTM_COUNTS = {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}


def _counts(ranges, counts):
    out: dict = {}
    for r, c in zip(ranges, counts, strict=True):
        out[round(float(r), 9)] = out.get(round(float(r), 9), 0.0) + float(c)
    return out


def test_rainflow__astm_e1049_example_counted_by_hand():
    r, c = fat.rainflow_cycles(ASTM)
    assert _counts(r, c) == ASTM_COUNTS
    assert c.sum() == 4.0


def test_rainflow__random_history_against_a_counting_written_here():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=3000)) + 5 * np.sin(np.arange(3000) / 7.0)
    r, c = fat.rainflow_cycles(x)
    mine = ref.rainflow_astm(x)  # ASTM E1049 5.4.4, written in tests/reference.py
    # the same cycles (ranges sorted; both are exact rainflow counts of the same data)
    np.testing.assert_allclose(np.sort(r), np.sort([m[0] for m in mine]), rtol=1e-12)
    assert c.sum() == pytest.approx(sum(m[1] for m in mine))
    # Miner's sum of the two countings on one S-N curve: identical
    sn = fat.SNCurve.of(71.0, 1.35)
    scale = 10.0  # MPa per unit: the ranges reach the sloped branches
    assert sn.damage(r * scale, c) == pytest.approx(
        sn.damage(np.array([m[0] for m in mine]) * scale, [m[1] for m in mine]), rel=1e-12)


def test_sn_curve__en_1993_1_9_limits_and_miner_of_the_astm_history():
    sn = fat.SNCurve.of(80.0, 1.0)
    # Delta sigma_D = (2/5)^(1/3) Delta sigma_C; Delta sigma_L = (5/100)^(1/5) Delta sigma_D
    assert sn.constant_amplitude_limit == pytest.approx(80.0 * 0.4 ** (1 / 3))
    assert sn.cutoff_limit == pytest.approx(80.0 * 0.4 ** (1 / 3) * 0.05 ** 0.2)
    assert sn.cycles(80.0) == pytest.approx(2e6)
    assert sn.cycles(sn.constant_amplitude_limit) == pytest.approx(5e6)
    assert sn.cycles(sn.cutoff_limit * 1.000001) == pytest.approx(1e8, rel=1e-5)
    assert np.isinf(sn.cycles(sn.cutoff_limit * 0.999))
    # the ASTM history scaled to 20 MPa per unit: damage by hand from the counted table
    scale = 20.0
    by_hand = 0.0
    sd, sl = sn.constant_amplitude_limit, sn.cutoff_limit
    for rng, n in ASTM_COUNTS.items():
        s = rng * scale
        if s >= sd:
            by_hand += n / (2e6 * (80.0 / s) ** 3)
        elif s >= sl:
            by_hand += n / (5e6 * (sd / s) ** 5)
    r, c = fat.rainflow_cycles(np.asarray(ASTM) * scale)
    assert sn.damage(r, c) == pytest.approx(by_hand, rel=1e-12)
    # the equivalent range at 2e6 gives back the damage: (E / C)^3 = D
    d = 0.37
    assert (sn.equivalent_range(d) / sn.strength) ** 3 == pytest.approx(d)


def test_histogram__keeps_every_cycle_and_the_damage_within_a_bin():
    rng = np.random.default_rng(0)
    ranges = rng.uniform(0, 200, 500)
    counts = rng.choice([0.5, 1.0], 500)
    h = fat.histogram(ranges, counts)
    assert h.sum() == pytest.approx(counts.sum())
    sn = fat.SNCurve.of(71.0)
    # the damage from bin centres within the bin width's effect (1 MPa in ~100: m = 5)
    exact = sn.damage(ranges, counts)
    binned = sn.damage(fat.bin_centres(), h)
    assert binned == pytest.approx(exact, rel=0.03)


def test_lambda_method__factors_of_en_1993_2():
    lm = fat.lambda_method(50.0, 1.1, 25e6, 100.0)
    assert lm.lambda_2 == pytest.approx(1.0) and lm.lambda_3 == pytest.approx(1.0)
    assert lm.equivalent_range == pytest.approx(0.65 * 1.1 * 50.0)
    # lambda_2 = (Vol / 25e6)^(1/5), lambda_3 = (years / 100)^(1/5), lambda <= 1.4
    lm = fat.lambda_method(50.0, 1.0, 50e6, 120.0)
    assert lm.lambda_2 == pytest.approx(2 ** 0.2)
    assert lm.lambda_3 == pytest.approx(1.2 ** 0.2)
    assert fat.lambda_method(1.0, 1.0, 1e12, 100.0).factor == 1.4


@pytest.mark.parametrize("kind", sorted(ANNEX_D_TYPES))
def test_annex_d__train_types_keep_the_totals_of_table_d1(kind):
    _desc, total_kn, speed, length = ANNEX_D_TYPES[kind]
    t = annex_d.annex_d_train(kind)
    loads = t.vehicles[0].loads
    assert loads.sum() == pytest.approx(total_kn * 1e3)
    assert t.length == pytest.approx(length)
    # 22.5 t axles (25 t for types 11 and 12)
    assert loads.max() <= (250e3 if kind in (11, 12) else 225e3) + 1e-6
    assert annex_d.type_of(f"annex d type {kind}") == kind


def test_annex_d__mixes_carry_about_25_million_tonnes_a_year():
    for name, mix in ANNEX_D_MIXES.items():
        tonnes = sum(n * ANNEX_D_TYPES[k][1] / 9.81 * 365 for k, n in mix.items())
        # Annex D's mixes are built for ~25e6 t per year (Sum Q in kN / g -> t)
        assert 23e6 < tonnes < 27e6, name
