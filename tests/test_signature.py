"""Dynamic signatures of trains (DER, LIR; ERRI D214, EN 1991-2 Annex E): closed form of
N equal equally spaced axles, HSLM-A1 against an implementation written here, and the
``vsi trains NAME --signature`` command."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from vsi_numba.analysis import signature as sg
from vsi_numba.cli.app import app


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("zeta", [0.0, 0.01, 0.02])
def test_signature__equal_axles_peak_at_d_over_i_with_the_closed_form(zeta):
    n, d, f = 12, 10.0, 200e3
    x = d * np.arange(n)
    loads = np.full(n, f)
    orders = np.arange(1, 4)
    lam = d / orders
    # in phase at lambda = d / i: a geometric sum of the decays q = exp(-2 pi zeta d / lam)
    q = np.exp(-2 * np.pi * zeta * d / lam)
    closed = f * (n if zeta == 0 else (1 - q**n) / (1 - q))
    der = sg.der_signature(x, loads, lam, zeta)
    lir = sg.lir_signature(x, loads, lam, zeta)
    # the recurrence is a sum of 12 terms: round-off only
    np.testing.assert_allclose(der, closed, rtol=1e-12)
    np.testing.assert_allclose(lir, closed, rtol=1e-12)
    # and they are peaks: 1 % off the wavelength the terms drift out of phase
    for lam_i in lam:
        side = sg.der_signature(x, loads, [0.99 * lam_i, 1.01 * lam_i], zeta)
        assert np.all(side < sg.der_signature(x, loads, [lam_i], zeta))
    # away from the peaks, far below N F (lambda = d / 1.5: alternate signs)
    assert sg.der_signature(x, loads, [d / 1.5], zeta)[0] <= f * 1.0 + 1e-6


def _hslm_a1_axles():
    """HSLM-A1 (EN 1991-2 Annex E, Fig. 6.12 / Table E.1 [R]: N = 18, D = 18 m, d = 2 m,
    P = 170 kN) written out here: power car axles 0, 3, 14, 17 m; end coach outer
    bogie at 20.525 m; N + 1 articulated bogies centred 18.7625 + i D; mirror image
    at the rear."""
    N, D, d = 18, 18.0, 2.0
    front = [0.0, 3.0, 14.0, 17.0, 20.525, 20.525 + d]
    mid = []
    for i in range(1, N + 2):
        c = 18.7625 + i * D
        mid += [c - d / 2, c + d / 2]
    last = 2 * 18.7625 + (N + 2) * D
    rear = [last - p for p in reversed(front)]
    return np.array(front + mid + rear), np.full(50, 170e3)


def _der_direct(x, f, lam, zeta):
    """The D214 form: max over i of the modulus of the damped cos / sin sums, O(N^2)."""
    out = []
    for lv in lam:
        best = 0.0
        for i in range(x.size):
            w = np.exp(-2 * np.pi * zeta * (x[i] - x[: i + 1]) / lv) * f[: i + 1]
            c = np.sum(w * np.cos(2 * np.pi * x[: i + 1] / lv))
            s = np.sum(w * np.sin(2 * np.pi * x[: i + 1] / lv))
            best = max(best, np.hypot(c, s))
        out.append(best)
    return np.array(out)


def test_signature__hslm_a1_against_a_direct_implementation():
    x, f = _hslm_a1_axles()
    lib_x, lib_f = sg.train_axles(sg.train_by_name("HSLM-A1"))
    np.testing.assert_allclose(lib_x, x, atol=1e-9)  # the axles: decimal data
    np.testing.assert_allclose(lib_f, f)
    lam = np.linspace(4.0, 20.0, 161)
    mine = _der_direct(x, f, lam, 0.01)
    got = sg.signature("HSLM-A1", 0.01, lam)
    # two summation orders of 50 terms: round-off only
    np.testing.assert_allclose(got.der, mine, rtol=1e-10)
    # the coach-length resonances of HSLM-A1 dominate: lambda = D / i = 18, 9, 6 m
    for lv in (18.0, 9.0, 6.0):
        g = sg.der_signature(x, f, [lv], 0.01)[0]
        assert g > sg.der_signature(x, f, [lv * 1.05], 0.01)[0]
    # LIR is the i = N term of the same sums
    last = []
    for lv in lam:
        w = np.exp(-2 * np.pi * 0.01 * (x[-1] - x) / lv) * f
        last.append(abs(np.sum(w * np.exp(2j * np.pi * x / lv))))
    np.testing.assert_allclose(got.lir, last, rtol=1e-10)


def test_signature__hslm_train_is_covered_by_its_own_envelope():
    cov = sg.compare_with_hslm("HSLM-A5", 0.01)
    assert cov.covered and cov.ratio == pytest.approx(1.0)


def test_signature__ice3_rises_above_hslm_a_between_two_hslm_peaks():
    # The ICE3 (8 coaches of D = 24.775 m, two bogies at each coupling) against HSLM-A at
    # 1 % damping: its third-order coach peak lambda = D / 3 = 8.26 m falls between the
    # third-order peaks of HSLM-A7 (D = 24 m: 8.0 m) and HSLM-A8 (D = 25 m: 8.33 m),
    # where the envelope dips.
    x, f = sg.train_axles(sg.train_by_name("ICE3"))
    coach = x[4] - x[0]  # the axle pattern repeats every coach
    np.testing.assert_allclose(np.diff(x)[4:], np.diff(x)[:-4], atol=1e-9)
    cov = sg.compare_with_hslm("ICE3", 0.01)
    lam = cov.wavelength_at_ratio
    assert not cov.covered and cov.ratio > 1.2
    # the exceedance sits on the flank of the train's own D / 3 peak (within 1.5 %: the
    # peak's half width with 8 coaches is about 1 / (3 x 8) of lambda)
    assert abs(lam / (coach / 3) - 1) < 0.015
    assert 24.0 / 3 < lam < 25.0 / 3
    # the envelope there is well below the HSLM-A7 and HSLM-A8 values at their own peaks
    # (direct sums written here, damping referred to the latest axle of the partial train)
    def der_direct(name, lv):
        xh, fh = sg.train_axles(sg.train_by_name(name))
        return max(abs(np.sum(fh[:i + 1] * np.exp(-2 * np.pi * 0.01 * (xh[i] - xh[:i + 1])
                                                   / lv) * np.exp(2j * np.pi * xh[:i + 1]
                                                                  / lv)))
                   for i in range(xh.size))
    peaks = [der_direct("HSLM-A7", 24.0 / 3), der_direct("HSLM-A8", 25.0 / 3)]
    env_here = max(der_direct(n, lam) for n in sg.HSLM_A)
    assert env_here < 0.8 * min(peaks)
    # the train's value at lam is reached by the envelope a few per cent of speed away
    assert 0 < cov.shift < 0.05
    g = cov.train.der[np.argmax(cov.train.der / cov.envelope)]
    # (shift is the largest over every wavelength above the envelope: at this one, the
    # envelope reaches g no farther away; scanned in steps of 0.05 % of lambda)
    s = np.arange(0.0, cov.shift + 1e-3, 5e-4)
    near = lam * np.concatenate([1 - s, 1 + s])
    env_near = np.max([sg.der_signature(*sg.train_axles(sg.train_by_name(n)), near, 0.01)
                       for n in sg.HSLM_A], axis=0)
    assert env_near.max() >= g


def test_signature__shift_to_the_envelope():
    # a bump of the train at lambda = 10 over a flat envelope of 1 that rises to 3 from
    # lambda = 10.5: the train (2 at lambda = 10) is reached 5 % of lambda away
    lam = np.linspace(9.0, 11.0, 2001)
    env = np.where(lam >= 10.5, 3.0, 1.0)
    der = np.where(np.abs(lam - 10.0) < 1e-9, 2.0, 0.5)
    assert sg._shift(lam, der, env) == pytest.approx(0.05, abs=1e-9)
    assert sg._shift(lam, der, np.full_like(lam, 1.5)) == np.inf
    assert sg._shift(lam, der, np.full_like(lam, 2.0)) == 0.0


def test_signature__influence_factor_of_the_der_method():
    # A(r) = |cos(pi r) / (4 r^2 - 1)|, pi/4 at r = 1/2 (its limit), 0 at r = 1.5, 2.5
    a = sg.influence_factor(10.0, [20.0, 10.0 / 1.5, 4.0, 1e9])
    np.testing.assert_allclose(a[:3], [np.pi / 4, 0.0, 0.0], atol=1e-12)
    assert a[3] == pytest.approx(1.0)


def test_vsi_trains_signature__cli_prints_the_peak_and_the_verdict(tmp_path):
    # 12 axles of 200 kN every 10 m: peaks at lambda = 10 m and 5 m (d / 1, d / 2)
    csv = tmp_path / "rake.csv"
    csv.write_text("position,load\n" + "".join(f"{10.0 * k},200\n" for k in range(12)))
    png = tmp_path / "sig.png"
    r = _cli("trains", csv, "--signature", "--damping", "1", "--plot", png)
    assert r.exit_code == 0, r.output
    q = np.exp(-2 * np.pi * 0.01 * 10.0 / 10.0)
    closed = 200 * (1 - q**12) / (1 - q)  # kN at lambda = 10 m
    rows = [ln.split() for ln in r.output.splitlines()]
    at10 = [row for row in rows if row and row[0] in ("9.99", "10.00", "10.01")]
    assert at10, r.output
    # the grid of the comparison has a step of 8 mm: the peak is sampled within 0.5 %
    assert float(at10[0][1]) == pytest.approx(closed, rel=5e-3)
    assert "by HSLM-A over lambda = 4 to 20 m" in r.output
    assert png.stat().st_size > 10_000
    r = _cli("trains", "HSLM-A1", "--signature")
    assert r.exit_code == 0 and "covered by HSLM-A" in r.output
    assert "NOT" not in r.output and "largest ratio 1.000" in r.output
    r = _cli("trains", "no-such-train", "--signature")
    assert r.exit_code == 2
    r = _cli("trains", "HSLM-A1", "--signature", "--damping", "-3")
    assert r.exit_code == 2 and "--damping" in r.output
