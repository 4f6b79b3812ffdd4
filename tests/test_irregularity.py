"""Tests of the track irregularity models (vsi_numba.model.irregularity).

References are computed here independently: the PSD formulas are re-typed from
docs/manual/theory.md, "Track irregularities", in their published units and integrated
with scipy.quad.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.signal import welch

from vsi_numba.model.irregularity import (
    SPECTRA,
    Profile,
    check_coverage,
    combine,
    cosine_defect,
    get_spectrum,
    no_irregularity,
    profile_from_file,
    psd_profile,
    psd_realisation,
    step_defect,
)

# ----------------------------------------------------------------- independent references

FRA_A_CM2 = {1: 1.2107, 2: 1.0181, 3: 0.6816, 4: 0.5376, 5: 0.2095, 6: 0.0339}


def fra_psd_m2(omega, cls):
    """FRA vertical PSD, evaluated in cm^2/(rad/m) as published, returned in m^2/(rad/m)."""
    k, oc = 0.25, 0.8245
    s_cm2 = k * FRA_A_CM2[cls] * oc**2 / (omega**2 * (omega**2 + oc**2))
    return s_cm2 * 1e-4


def german_psd_m2(omega, av):
    """German high-speed PSD in m^2/(rad/m)."""
    oc, orr = 0.8246, 0.0206
    return av * oc**2 / ((omega**2 + orr**2) * (omega**2 + oc**2))


REFERENCE_PSD = {
    **{f"fra{c}": (lambda w, c=c: fra_psd_m2(w, c)) for c in FRA_A_CM2},
    "german_low": lambda w: german_psd_m2(w, 4.032e-7),
    "german_high": lambda w: german_psd_m2(w, 1.080e-6),
}


def band_variance(name, lam_min, lam_max):
    """Sigma^2 (m^2) = int S dOmega over 2 pi/lam_max .. 2 pi/lam_min, by quadrature."""
    val, _ = quad(
        REFERENCE_PSD[name], 2 * np.pi / lam_max, 2 * np.pi / lam_min, limit=200,
        epsabs=0.0, epsrel=1e-12,
    )
    return val


# railway.md section 5, "Band sigma-values implied by the formulas" (mm, 3 decimals)
SIGMA_TABLE_MM = [
    ("german_low", 3, 25, 0.984),
    ("german_low", 25, 70, 1.651),
    ("german_low", 1, 80, 2.074),
    ("german_high", 3, 25, 1.611),
    ("german_high", 25, 70, 2.702),
    ("german_high", 1, 80, 3.394),
    ("fra6", 3, 25, 1.429),
    ("fra6", 25, 70, 2.424),
    ("fra6", 1.524, 304.8, 6.29),
    ("fra5", 3, 25, 3.553),
    ("fra5", 25, 70, 6.027),
    ("fra4", 3, 25, 5.691),
    ("fra1", 3, 25, 8.541),
]


# ------------------------------------------------------------------------------ spectra


@pytest.mark.parametrize(("name", "lmin", "lmax", "sigma_mm"), SIGMA_TABLE_MM)
def test_spectrum__band_sigma_matches_railway_table(name, lmin, lmax, sigma_mm):
    sigma_quad_mm = np.sqrt(band_variance(name, lmin, lmax)) * 1e3
    ndec = len(str(sigma_mm).split(".")[1])
    # the table is rounded to `ndec` decimals: half a unit of the last digit
    assert abs(sigma_quad_mm - sigma_mm) <= 0.5 * 10.0**-ndec + 1e-12
    # the library's analytic band integral agrees with quadrature (quad rtol 1e-12)
    assert SPECTRA[name].band_sigma(lmin, lmax) * 1e3 == pytest.approx(sigma_quad_mm, rel=1e-9)


@pytest.mark.parametrize("name", list(REFERENCE_PSD))
def test_spectrum__values_match_published_formula(name):
    omega = np.geomspace(0.01, 10.0, 50)
    # same formula evaluated in a different order of operations: rounding only
    np.testing.assert_allclose(SPECTRA[name](omega), REFERENCE_PSD[name](omega), rtol=1e-12)


def test_spectrum__unknown_name_suggests_close_match():
    with pytest.raises(ValueError, match="did you mean 'german_low'"):
        get_spectrum("german_lo")
    assert get_spectrum("FRA6") is SPECTRA["fra6"]


# ------------------------------------------------------------------------ random profiles


def test_psd__full_period_sample_variance_equals_band_integral():
    lmin, lmax, n_waves = 3.0, 25.0, 293
    period = n_waves / (1 / lmin - 1 / lmax)
    x, r, p = psd_realisation("german_low", lmin, lmax, 7, 0.0, period, n_waves=n_waves)
    assert p == pytest.approx(period, rel=1e-12)  # same formula, rounding only
    # over exactly one period the cosines are orthogonal (Parseval): the sample variance is
    # the sum of a_k^2/2 = int S over the band; 1e-9 covers quad and FFT rounding
    assert np.var(r[:-1]) == pytest.approx(band_variance("german_low", lmin, lmax), rel=1e-9)
    assert r[-1] == pytest.approx(r[0], abs=1e-15)  # periodic: closing sample repeats the first


def test_psd__ensemble_sigma_over_partial_period():
    lmin, lmax = 3.0, 25.0
    target = band_variance("german_low", lmin, lmax)
    var = np.array(
        [np.var(psd_realisation("german_low", lmin, lmax, s, 0.0, 400.0)[1]) for s in range(16)]
    )
    # a 400 m window of a 500 m period: each sample variance scatters (about 7 % here), so
    # compare the 16-seed mean within 4 standard errors estimated from the ensemble itself
    stderr = var.std(ddof=1) / np.sqrt(var.size)
    assert abs(var.mean() - target) < 4.0 * stderr
    assert stderr < 0.05 * target  # the check above is not vacuous


def test_psd__welch_spectrum_in_rad_per_m():
    lmin, lmax = 3.0, 25.0
    x, r, _ = psd_realisation("german_low", lmin, lmax, 3, 0.0, 20_000.0)
    dx = x[1] - x[0]
    f, pxx = welch(r, fs=1.0 / dx, nperseg=4096)  # f in cycles/m, pxx in m^2/(cycle/m)
    sel = (f >= 1 / 20) & (f <= 1 / 5)
    power_welch = np.trapezoid(pxx[sel], f[sel])
    power_ref = quad(REFERENCE_PSD["german_low"], 2 * np.pi * f[sel][0], 2 * np.pi * f[sel][-1])[0]
    # Welch over ~65 segments and ~75 frequency bins scatters by about 1 %; 5 % still rejects
    # a missing 2 pi (factor 6.3) or a one-/two-sided mix-up (factor 2)
    assert power_welch == pytest.approx(power_ref, rel=0.05)
    # pointwise: S_cycles = 2 pi S_rad; mean over the bins, same Welch scatter argument
    ratio = pxx[sel] / (2 * np.pi * REFERENCE_PSD["german_low"](2 * np.pi * f[sel]))
    assert ratio.mean() == pytest.approx(1.0, rel=0.05)


def test_psd__no_power_outside_the_band():
    lmin, lmax, n_waves = 5.0, 40.0, 700
    period = n_waves / (1 / lmin - 1 / lmax)
    x, r, _ = psd_realisation("fra5", lmin, lmax, 1, 0.0, period, n_waves=n_waves)
    amp = np.abs(np.fft.rfft(r[:-1]))
    wavelength = period / np.arange(1, amp.size)
    # one partial edge bin each side is allowed (the bin straddling the band limit)
    outside = (wavelength < lmin * (1 - 1 / n_waves)) | (wavelength > lmax * (1 + 8 / n_waves))
    # FFT rounding: ~1e-12 of the largest component
    assert amp[1:][outside].max() < 1e-10 * amp.max()


def test_psd__seed_reproducible_and_seeds_differ():
    a = psd_profile("german_high", 2.0, 80.0, 11, -20.0, 300.0)
    b = psd_profile("german_high", 2.0, 80.0, 11, -20.0, 300.0)
    c = psd_profile("german_high", 2.0, 80.0, 12, -20.0, 300.0)
    np.testing.assert_array_equal(a.coef, b.coef)
    assert a.x0 == b.x0 and a.dx == b.dx
    sigma = SPECTRA["german_high"].band_sigma(2.0, 80.0)
    x = np.linspace(-20.0, 300.0, 2001)
    # independent phases: the two realisations differ by about sqrt(2) sigma in rms
    assert np.sqrt(np.mean((a(x) - c(x)) ** 2)) > 0.5 * sigma


def test_psd_profile__spline_through_samples_and_default_spacing():
    lmin = 1.524
    x, r, _ = psd_realisation("fra6", lmin, 304.8, 5, 0.0, 500.0)
    prof = psd_profile("fra6", lmin, 304.8, 5, 0.0, 500.0)
    assert prof.dx <= lmin / 20  # the documented default sampling
    assert prof.x0 == x[0] and prof.x_end >= 500.0
    # the spline interpolates its samples (rounding of the polynomial evaluation)
    np.testing.assert_allclose(prof(x[:-1]), r[:-1], rtol=0, atol=1e-12 * np.abs(r).max())
    assert check_coverage(prof, 0.0, 500.0)


def test_psd__argument_errors():
    with pytest.raises(ValueError, match="Nyquist"):
        psd_realisation("fra6", 2.0, 50.0, 0, 0.0, 100.0, dx=1.5)
    with pytest.raises(ValueError, match="would repeat"):
        psd_realisation("fra6", 2.0, 50.0, 0, 0.0, 1000.0, n_waves=10)
    with pytest.raises(ValueError, match="wavelength_min < wavelength_max"):
        psd_realisation("fra6", 50.0, 2.0, 0, 0.0, 100.0)
    with pytest.raises(ValueError, match="x_stop > x_start"):
        psd_realisation("fra6", 2.0, 50.0, 0, 10.0, 0.0)


# ---------------------------------------------------------------------- isolated defects


def test_cosine_defect__existing_api_unchanged():
    p = cosine_defect(0.004, 2.0, 10.0)
    assert p(np.array([11.0]))[0] == pytest.approx(0.004, rel=1e-6)  # spline error at dx=1cm
    assert p(np.array([9.0, 12.5]))[0] == 0.0
    assert no_irregularity().is_zero


@pytest.mark.parametrize("shape", ["cosine", "quintic"])
def test_step_defect__levels_and_smoothness(shape):
    h, ell, x1, x_stop = 0.01, 4.0, 20.0, 60.0
    p = step_defect(h, ell, x1, x_stop, shape=shape)
    assert p(np.array([x1 - 1.0]))[0] == pytest.approx(0.0, abs=1e-12)  # spline roundoff
    assert p(np.array([x1 + ell + 1.0, x_stop - 0.01]))[0] == pytest.approx(h, rel=1e-9)
    s = 0.5
    expected = 0.5 * h * (1 - np.cos(np.pi * s)) if shape == "cosine" else h * 0.5
    # spline of the analytic shape at dx = ell/200: error O(dx^4) relative
    assert p(np.array([x1 + s * ell]))[0] == pytest.approx(expected, rel=1e-6)
    # slope peaks at mid-transition with the analytic value (pi h / 2 ell or 15 h / 8 ell)
    slope = np.pi * h / (2 * ell) if shape == "cosine" else 15 * h / (8 * ell)
    assert p(np.array([x1 + 0.5 * ell]), 1)[0] == pytest.approx(slope, rel=1e-4)  # O(dx^3)
    # r' is continuous at both ends of the transition (analytically 0 there).  The cosine
    # ramp's r'' jumps by pi^2 h / (2 ell^2) at its ends, which the C2 spline smears over a
    # few samples: r' error about dx * jump / 6; the quintic has no jump
    ends = np.array([x1, x1 + ell])
    jump = np.pi**2 * h / (2 * ell**2) if shape == "cosine" else 0.0
    np.testing.assert_allclose(p(ends, 1), 0.0, atol=p.dx * jump / 3 + 1e-4 * slope)
    assert p(np.array([x_stop + 1.0]))[0] == 0.0  # zero outside, as every Profile
    assert not check_coverage(p, 0.0, x_stop + 10.0)


def test_step_defect__errors():
    with pytest.raises(ValueError, match="length"):
        step_defect(0.01, 0.0, 1.0, 10.0)
    with pytest.raises(ValueError, match="x_stop"):
        step_defect(0.01, 5.0, 1.0, 3.0)
    with pytest.raises(ValueError, match="shape"):
        step_defect(0.01, 5.0, 1.0, 30.0, shape="linear")


def test_combine__sum_on_a_grid_covering_all():
    a = cosine_defect(0.003, 3.0, 5.0)
    b = step_defect(-0.002, 2.0, 30.0, 100.0)  # ends (with a jump to 0) where c ends
    c = psd_profile("german_low", 3.0, 25.0, 1, -10.0, 100.0)
    s = combine(a, b, no_irregularity(), c)
    # the random profile's samples sit on its own grid x_j = j dx, which covers the range
    assert -10.0 - c.dx < s.x0 <= -10.0 + 1e-9 and s.x_end >= 100.0 - 1e-9
    assert s.dx == pytest.approx(min(a.dx, b.dx, c.dx))
    x = np.linspace(-9.0, 99.0, 3001)
    # resampling a sum of C2 splines at the finest spacing: O(dx^4), ~1e-9 of the values
    np.testing.assert_allclose(s(x), a(x) + b(x) + c(x), rtol=0, atol=1e-8)
    assert combine().is_zero and combine(no_irregularity()).is_zero
    single = combine(a)
    np.testing.assert_array_equal(single.coef, a.coef)


# ------------------------------------------------------------------------ measured profiles


def _write(path, text):
    path.write_text(text)
    return path


def test_profile_from_file__reads_and_converts_units(tmp_path):
    x = np.linspace(0.0, 10.0, 41)
    r = 1e-3 * np.sin(x)
    f = tmp_path / "prof.csv"
    rows = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, r, strict=True))
    f.write_text("# measured\nx,r\n" + rows)
    p = profile_from_file(f)
    # spline interpolation of the samples: exact at nodes up to rounding
    np.testing.assert_allclose(p(x[:-1]), r[:-1], atol=1e-15)
    g = tmp_path / "prof_mm.csv"
    rows_mm = "".join(f"{float(a)!r},{float(1e3 * b)!r}\n" for a, b in zip(x, r, strict=True))
    g.write_text("pos, dz\n" + rows_mm)
    q = profile_from_file(g, x_column="pos", r_column="dz", r_unit="mm")
    np.testing.assert_allclose(q(x[:-1]), r[:-1], atol=1e-15)  # mm -> m rounding


def test_profile_from_file__nonuniform_samples(tmp_path):
    x = np.array([0.0, 0.5, 1.5, 2.0, 3.0, 3.25, 4.0])
    f = _write(tmp_path / "nu.csv", "x,r\n" + "".join(f"{a},{1e-3 * a}\n" for a in x))
    p = profile_from_file(f)
    # a linear profile is reproduced exactly by the natural spline (rounding only)
    np.testing.assert_allclose(p(np.array([0.1, 2.2, 3.9])), 1e-3 * np.array([0.1, 2.2, 3.9]),
                               atol=1e-15)


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("x,r\n0,0\n1,0\n1,0\n2,0\n3,0\n", "strictly increasing"),
        ("x,r\n0,0\n2,0\n1,0\n3,0\n4,0\n", "strictly increasing"),
        ("x,r\n0,0\n1,\n2,0\n3,0\n", "missing, non-numeric"),
        ("x,r\n0,0\n1,abc\n2,0\n3,0\n", "missing, non-numeric"),
        ("x,r\n0,0\n1,0\n2,0\n", "at least 4"),
        ("x,z\n0,0\n1,0\n2,0\n3,0\n", "missing column"),
    ],
)
def test_profile_from_file__clear_errors(tmp_path, content, match):
    f = _write(tmp_path / "bad_profile.csv", content)
    with pytest.raises(ValueError, match=match) as exc:
        profile_from_file(f)
    assert "bad_profile.csv" in str(exc.value)


def test_profile_from_file__missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.csv"):
        profile_from_file(tmp_path / "nowhere.csv")


def test_check_coverage():
    p = Profile.from_samples(np.arange(0.0, 11.0), np.zeros(11) + 1e-3)
    assert check_coverage(p, 0.0, 10.0)
    cov = check_coverage(p, -5.0, 12.0)
    assert not cov
    assert "5 m after the run starts" in cov.message and "2 m before the run ends" in cov.message
    assert check_coverage(no_irregularity(), -1e3, 1e3)


def test_psd_profile__same_seed_same_track_whatever_the_range():
    """A realisation is a function of x alone: two studies asking for different ranges
    (another longest train, another bridge) see the same track on the same x."""
    short = psd_profile("german_low", 2.0, 60.0, 11, -250.0, 400.0)
    long = psd_profile("german_low", 2.0, 60.0, 11, -655.0, 1200.0)
    x = np.linspace(-200.0, 350.0, 20001)
    for k in range(3):  # r, r', r'': the splines agree away from their ends
        a, b = short(x, k), long(x, k)
        # same samples; the spline end effects decay by ~0.27 per sample over > 1000
        # samples, and the grid origins j0 dx differ by round-off: 1e-11 of the peak
        # (measured ~2e-13 for r'')
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-11 * np.abs(b).max())
    assert np.abs(short(x)).max() > 1e-4  # a real profile, not zeros
