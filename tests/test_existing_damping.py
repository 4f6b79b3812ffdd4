"""Damping from the free vibration of a measured record (logarithmic decrement), on the
shipped synthetic records (solve_ivp of the modal equations, truth 2 %, noise 0.3 m s-2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vsi_numba.existing.damping import free_vibration_damping
from vsi_numba.io.records import read_record
from vsi_numba.verification import existing as syn
from vsi_numba.verification import reference as ref

CASE = Path(__file__).resolve().parents[1] / "configs" / "calibration_synthetic"


@pytest.mark.parametrize("i", [2, 3])
def test_damping__log_decrement_of_the_free_vibration(i):
    speed = syn.SPEEDS_KMH[i - 1]
    rec = read_record(CASE / f"passage_{i:02d}.csv")
    pos, _ = syn.hslm_a1_axles()
    t_leave = (syn.APPROACH + syn.SPAN + pos.max()) / (speed / 3.6) + syn.CLOCK_OFFSET
    fit = free_vibration_damping(rec.t, rec.value, t_leave, 4.5)
    f1 = ref.ss_omega(syn.SPAN, syn.TRUTH["bridge.EI"], syn.MASS, 1)[0] / (2 * np.pi)
    # the peaks' spacing over about seven periods, sampled at 2 ms: within 1 %
    assert fit.frequency == pytest.approx(f1, rel=1e-2)
    # the fit's own standard error (3 x), at least 2 % (the light-damping formula and
    # the peaks sampled at 2 ms); measured -2.1 % (cov 5 %) and +0.2 % (cov 0.7 %)
    zeta = syn.TRUTH["bridge.damping_ratio"]
    assert abs(fit.damping_ratio / zeta - 1) <= max(3 * fit.cov, 0.02)
    prior = fit.prior()
    assert prior["prior"] == "lognormal" and prior["cov"] >= 0.1


def test_damping__too_short_a_free_vibration_is_refused():
    rec = read_record(CASE / "passage_03.csv")
    with pytest.raises(ValueError, match="at least six"):
        free_vibration_damping(rec.t, rec.value, rec.t[-1] - 0.5, 4.5)
