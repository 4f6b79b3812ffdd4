"""The calibration's compiled likelihood (vsi_numba.existing.misfit) against scipy and
numpy, the typed rows' kernel arguments against run_batch's, and the predictive records
and the check on the chosen backend."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from vsi_numba.config import load_config
from vsi_numba.existing import misfit
from vsi_numba.existing.signal import best_shifts, decimation, lowpass, lowpass_sections
from vsi_numba.verification import existing as syn

FS, FC = 2000.0, 42.9  # the synthetic case's model sampling and cut-off (Hz)


def _noise_walks(n, size, seed=1):
    return np.cumsum(np.random.default_rng(seed).standard_normal((n, size)), axis=1)


@pytest.mark.parametrize("size", [16, 17, 1500])  # the shortest history padded, and longer
def test_filtfilt_rows__equals_scipy_sosfiltfilt(size):
    x = _noise_walks(5, size)
    sos, zi = lowpass_sections(FS, FC)
    pad = min(size - 1, 3 * (2 * sos.shape[0] + 1))
    y = np.empty_like(x)
    misfit.filtfilt_rows(x, sos, zi, pad, y)
    ref = scipy.signal.sosfiltfilt(sos, x, axis=1, padlen=pad)
    # the same operations in scipy's order: equal to the last bits on this machine; a
    # few ulps allowed for a compiler that fuses multiply-adds in one of the two
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
    # each row alone: the rows of a chunk do not change one another's numbers
    one = np.empty((1, size))
    misfit.filtfilt_rows(x[2:3], sos, zi, pad, one)
    assert np.array_equal(one[0], y[2])


def _pulse(t):
    """A smooth band-limited passage: a 6 Hz tone in a Gaussian envelope (1e-16 of its
    peak beyond 0.5 s of the 7 s history's ends: the deck at rest)."""
    return np.exp(-0.5 * ((t - 3.5) / 0.4) ** 2) * np.sin(2 * np.pi * 6.0 * t)


@pytest.mark.parametrize("shift", [274.3, -180.75, 3.0])
def test_record_fit__finds_a_known_sub_sample_shift(shift):
    # the model history s(t) = pulse(t) and a record m[k] = s(k + shift) (closed form):
    # the shift is found to the parabola's accuracy on a signal sampled at 45 samples
    # a period (1e-3 samples), and the misfit of the exact record is ~0
    dt = 1.0 / FS
    J, K = 14000, 12000
    s = _pulse(np.arange(J) * dt)
    m = _pulse((np.arange(K) + shift) * dt)
    fit = misfit.RecordFit(m, 0, 1000, decimation(dt, FC), 33, None)
    lags, sse, aligned = fit.fit(s[None, :], np.array([1e-3]), aligned=True)
    assert lags[0] == pytest.approx(shift, abs=1e-3)
    # residual of the linear interpolation at the found shift: (h^2/8) max|s''| =
    # 4.4e-5 of the amplitude at most; in units of sig = 1e-3 summed over K / 33 samples
    assert sse[0] < 0.05**2 * (K // 33)
    np.testing.assert_allclose(aligned[0], m, rtol=0, atol=5e-5)


def test_record_fit__agrees_with_the_numpy_alignment():
    # a noisy record against four histories: the numpy path (signal.best_shifts, BLAS
    # dot products) and the compiled one sum in other orders: the same lags to 1e-6
    # samples, the misfit to 1e-9 (relative)
    rng = np.random.default_rng(3)
    dt = 1.0 / FS
    x = _noise_walks(4, 9000, seed=2)
    y = lowpass(x.T, FS, FC).T
    k = np.arange(8000)
    m = np.interp(k + 274.3, np.arange(9000), y[0], left=0, right=0) + 0.01 * \
        rng.standard_normal(k.size)
    dec = decimation(dt, FC)
    fit = misfit.RecordFit(m, 274, 2000, dec, 11, lowpass_sections(FS, FC))
    lags, sse, _ = fit.fit(x, np.full(4, 0.5))
    ref = best_shifts(m, y.T, 274, 2000, dec)
    np.testing.assert_allclose(lags, ref, rtol=0, atol=1e-6)
    kept = np.arange(0, k.size, 11)
    for j in range(4):
        r = (m[kept] - np.interp(kept + ref[j], np.arange(9000), y[j], left=0, right=0)) / 0.5
        assert sse[j] == pytest.approx(float(r @ r), rel=1e-9)


def test_first_unstorable__finds_the_first_step_beyond_float32():
    h = np.zeros((2, 10, 3))
    assert misfit.first_unstorable(h, 1, 10) == -1
    h[1, 7, 2] = 1e39  # beyond float32
    h[1, 8, 0] = np.nan
    assert misfit.first_unstorable(h, 1, 10) == 7
    assert misfit.first_unstorable(h, 1, 7) == -1
    assert misfit.first_unstorable(h, 0, 10) == -1
    h[0, 3, 1] = np.nan
    assert misfit.first_unstorable(h, 0, 10) == 3


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("misfit")
    return load_config(syn.write_case(d, speeds=(240.0, 305.0), n_samples=64))


def test_point_histories__the_typed_rows_kernel_runs_are_run_batchs(case):
    # the typed path's kernel call on arguments built once per thread gives the modal
    # histories of run_row's own run_batch call bit for bit, for rows after other rows
    from vsi_numba.existing.forward import Forward, Group
    from vsi_numba.solver.batch import run_batch

    g = Group("HSLM-A1", (240.0, 305.0), (5.0, 10.0))
    fwd = Forward(case.resolved(), case.base_dir, ["bridge.EI", "bridge.damping_ratio"],
                  [g])
    assert fwd._typed, fwd.typed_reason
    rows = np.array([[2.1e10, 0.015], [1.7e10, 0.04], [2.4e10, 0.01]])
    wanted = [(0, 0, 1, True), (0, 1, 0, False)]
    hist = fwd.point_histories(rows, wanted)
    assert hist.errors == ["", "", ""]
    out = fwd._kernel_args(0)[11]  # the last row's modal histories
    (m, packed, deck, _), _ = fwd._typed_row(0, rows[-1])
    res = run_batch(packed, m.profile, m.speeds, m.points, m.settings, m.bridge,
                    keep_histories=np.ones(2, bool), deck=deck)
    for k in range(2):
        n = int(res.n_steps[k]) + 1
        assert np.array_equal(out.q[k, :n], res.out.q[int(res.slots[k]), :n])
        assert np.array_equal(out.qdd[k, :n], res.out.qdd[int(res.slots[k]), :n])
    # the points' histories: run_row's (BLAS products of the same modal histories)
    for r, row in enumerate(rows):
        rr = fwd.run_row(row)[0]
        for w, (_, si, pi, acc) in enumerate(wanted):
            ref = (rr.acceleration if acc else rr.displacement)[si][:, pi]
            assert hist.lengths[w][r] == ref.size
            np.testing.assert_allclose(hist.values[w][r, : ref.size], ref, rtol=0,
                                       atol=1e-13 * np.abs(ref).max())


def test_point_histories__a_row_out_of_bounds_is_no_model(case):
    from vsi_numba.existing.forward import Forward, Group

    fwd = Forward(case.resolved(), case.base_dir, ["bridge.EI", "bridge.damping_ratio"],
                  [Group("HSLM-A1", (240.0,), (10.0,))])
    hist = fwd.point_histories(np.array([[2.0e10, 1.5], [-1.0, 0.02], [2.0e10, 0.02]]),
                               [(0, 0, 0, True)])
    assert "bridge.damping_ratio = 1.5" in hist.errors[0]
    assert "bridge.EI = -1: expected > 0" in hist.errors[1]
    assert hist.errors[2] == ""


def test_predictive_and_check_run_on_the_worker_processes(case):
    # Evaluator.other on the processes backend: the workers build the evaluations from
    # the configuration; this process's own evaluation is never called
    from vsi_numba.existing.calibrate import _Check, _prepared
    from vsi_numba.existing.parallel import Evaluator, Spec

    prep = _prepared(case)
    rows = np.array([[2.1e10, 0.02], [2.3e10, 0.03], [1.9e10, 0.01], [2.0e10, 0.02],
                     [2.2e10, 0.02]])
    check = _Check(prep)

    def refuse(u):
        raise AssertionError("computed in the parent process")

    base = (case.to_json(), str(case.base_dir))
    n_pred = 1 + sum(m.size for _, m in prep.measured)
    with Evaluator(Spec("calibration", *base), refuse, 1 + len(prep.records),
                   backend="processes", workers=2) as ev:
        pred = ev.other(Spec("calibration_predictive", *base), refuse, n_pred)(rows)
        val = ev.other(Spec("calibration_check", *base), refuse, 3)(rows)
    assert np.array_equal(pred, prep.predictive_rows(rows))
    assert np.array_equal(val, check.values(rows))
    assert np.all(pred[:, 0] == 1.0) and np.all(np.isfinite(val))


@pytest.mark.parametrize("d", [4, 6, 12])
def test_kept_correlation__equals_the_aliased_spectrum(d):
    """kappa = sum_k rho(k d) of the filtered noise, from the impulse response, against
    Poisson's sum on the filter's frequency response: sum_k r[k d] = (1 / d) sum_m
    S(2 pi m / d), S = |H|^4 (the low-pass applied forward and backward), r[0] = mean S."""
    from vsi_numba.existing.signal import kept_correlation

    fs, fc = 500.0, 40.8
    sos, _ = lowpass_sections(fs, fc)
    w_all = 2.0 * np.pi * np.arange(2 ** 16) / 2 ** 16
    s_all = np.abs(scipy.signal.sosfreqz(sos, worN=w_all)[1]) ** 4
    w_m = 2.0 * np.pi * np.arange(d) / d
    s_m = np.abs(scipy.signal.sosfreqz(sos, worN=w_m)[1]) ** 4
    expected = s_m.mean() / s_all.mean()
    assert kept_correlation(fs, fc, d / fs) == pytest.approx(expected, rel=1e-6)


def test_kept_correlation__one_without_filter_and_for_far_samples():
    from vsi_numba.existing.signal import kept_correlation

    assert kept_correlation(50.0, 40.0, 0.01) == 1.0  # cut-off above Nyquist: no filter
    assert kept_correlation(500.0, 40.8, 1.0) == pytest.approx(1.0, abs=1e-9)
