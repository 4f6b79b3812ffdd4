"""Random track profiles from one-sided PSDs in rad/m (:data:`SPECTRA`: FRA classes 1-6,
German low / high interference): :func:`psd_realisation` (samples) and
:func:`psd_profile` (the spline the kernels take)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vsi_numba.model.profile import MAX_SAMPLES, Profile, _check_samples


@dataclass(frozen=True)
class Spectrum:
    """One-sided vertical-profile PSD ``S(Omega)`` in m^2/(rad/m), Omega in rad/m.

    ``sigma^2 = integral of S dOmega`` over the band.  Two analytic families:

    * ``"fra"`` (US FRA track classes 1-6)::

          S = k A Oc^2 / (O^2 (O^2 + Oc^2))  cm^2/(rad/m),   k = 0.25,  Oc = 0.8245 rad/m

      with ``A`` in cm^2 rad/m; stored here converted to m^2 (factor 1e-4).
    * ``"german"`` (German high-speed, low / high interference)::

          S = A Oc^2 / ((O^2 + Or^2)(O^2 + Oc^2))  m^2/(rad/m),  Oc = 0.8246, Or = 0.0206 rad/m

      with ``A`` in m rad.  No extra empirical factor is applied.

    Parameters
    ----------
    name : str
        Key in :data:`SPECTRA`.
    family : {"fra", "german"}
    amplitude : float
        Coefficient in m^2 units: ``k A 1e-4`` (FRA, m^2 rad/m) or ``A`` (German, m rad).
    omega_c, omega_r : float
        Corner wavenumbers (rad/m); ``omega_r`` unused for FRA.
    validity : tuple of float
        Wavelength range (m) over which the source states the spectrum applies.
    """

    name: str
    family: str
    amplitude: float
    omega_c: float
    omega_r: float = 0.0
    validity: tuple[float, float] = (0.0, np.inf)

    def __call__(self, omega) -> np.ndarray:
        """``S(omega)`` in m^2/(rad/m) for ``omega`` in rad/m (> 0)."""
        w2 = np.asarray(omega, float) ** 2
        c2 = self.omega_c**2
        if self.family == "fra":
            return self.amplitude * c2 / (w2 * (w2 + c2))
        return self.amplitude * c2 / ((w2 + self.omega_r**2) * (w2 + c2))

    def _antiderivative(self, omega) -> np.ndarray:
        w = np.asarray(omega, float)
        c = self.omega_c
        if self.family == "fra":
            # c^2 / (w^2 (w^2 + c^2)) = 1/w^2 - 1/(w^2 + c^2)
            return self.amplitude * (-1.0 / w - np.arctan(w / c) / c)
        r = self.omega_r
        # c^2 / ((w^2 + r^2)(w^2 + c^2)) = c^2/(c^2 - r^2) [1/(w^2 + r^2) - 1/(w^2 + c^2)]
        scale = self.amplitude * c * c / (c * c - r * r)
        return scale * (np.arctan(w / r) / r - np.arctan(w / c) / c)

    def integral(self, omega_a, omega_b) -> np.ndarray:
        """Exact ``integral of S`` from ``omega_a`` to ``omega_b`` (m^2); 0 < a <= b."""
        return self._antiderivative(omega_b) - self._antiderivative(omega_a)

    def band_sigma(self, wavelength_min: float, wavelength_max: float) -> float:
        """Return the standard deviation (m) of the profile within a wavelength band (m)."""
        _check_band(wavelength_min, wavelength_max)
        lo, hi = 2.0 * np.pi / wavelength_max, 2.0 * np.pi / wavelength_min
        return float(np.sqrt(self.integral(lo, hi)))


_FRA_K = 0.25
_FRA_OMEGA_C = 0.8245  # rad/m
_FRA_A = {1: 1.2107, 2: 1.0181, 3: 0.6816, 4: 0.5376, 5: 0.2095, 6: 0.0339}  # cm^2 rad/m
_CM2 = 1e-4  # m^2 per cm^2

SPECTRA: dict[str, Spectrum] = {
    **{
        f"fra{c}": Spectrum(f"fra{c}", "fra", _FRA_K * a * _CM2, _FRA_OMEGA_C,
                            validity=(1.524, 304.8))
        for c, a in _FRA_A.items()
    },
    "german_low": Spectrum("german_low", "german", 4.032e-7, 0.8246, 0.0206, (3.0, 150.0)),
    "german_high": Spectrum("german_high", "german", 1.080e-6, 0.8246, 0.0206, (3.0, 150.0)),
}
"""Named spectra: ``fra1`` .. ``fra6`` (FRA classes) and ``german_low`` / ``german_high``."""


def get_spectrum(spectrum: str | Spectrum) -> Spectrum:
    """Look up a named spectrum (case-insensitive); a :class:`Spectrum` passes through."""
    if isinstance(spectrum, Spectrum):
        return spectrum
    key = str(spectrum).strip().lower()
    if key in SPECTRA:
        return SPECTRA[key]
    import difflib

    close = difflib.get_close_matches(key, list(SPECTRA), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise ValueError(
        f"unknown irregularity spectrum {spectrum!r} (known: {', '.join(SPECTRA)}){hint}"
    )


def _check_band(wavelength_min: float, wavelength_max: float) -> None:
    if not (np.isfinite(wavelength_min) and np.isfinite(wavelength_max)):
        raise ValueError("wavelength_min and wavelength_max must be finite (m)")
    if not 0.0 < wavelength_min < wavelength_max:
        raise ValueError(
            f"need 0 < wavelength_min < wavelength_max (m), got {wavelength_min!r}, "
            f"{wavelength_max!r}"
        )


#: Shortest period (m) of a random profile: the period is this or the power of two (m)
#: at least ``20 wavelength_max`` above it; a realisation is the same function of x for
#: every range (see :func:`psd_realisation`).
PSD_PERIOD = 8192.0


def psd_grid(wavelength_min: float, wavelength_max: float, dx: float | None = None,
             n_waves: int | None = None) -> tuple[float, int]:
    """The period (m) and the number of samples per period of a random profile.

    Without ``n_waves``: the period is :data:`PSD_PERIOD` m times the smallest power of
    two reaching ``20 wavelength_max``, and the sample count the smallest power of two
    giving a spacing <= ``dx`` (default ``wavelength_min / 20``), so that every sample
    abscissa ``j period / n`` is exact in floating point.  With ``n_waves``: the period
    holds that many band wavelengths and the count is the smallest even number giving a
    spacing <= ``dx``.  Neither depends on the range of x a study asks for.
    """
    _check_band(wavelength_min, wavelength_max)
    if dx is None:
        dx = wavelength_min / 20.0
    if not 0.0 < dx <= wavelength_min / 2.0:
        raise ValueError(
            f"dx = {dx!r} m must be > 0 and <= wavelength_min/2 = {wavelength_min / 2} m "
            "(Nyquist); wavelength_min/20 or less is recommended"
        )
    if n_waves is None:
        period = PSD_PERIOD * 2.0 ** max(0, math.ceil(math.log2(20.0 * wavelength_max
                                                                 / PSD_PERIOD)))
        _check_samples(period / dx, dx, "the random profile (one period, max(8192 m, 20 x "
                       "irregularity.wavelength_max) rounded up to a power of two)")
        n_fft = 2 ** max(2, math.ceil(math.log2(period / dx - 1e-9)))
    else:
        if int(n_waves) < 1:
            raise ValueError(f"n_waves must be >= 1, got {n_waves!r}")
        per_wave = 1.0 / wavelength_min - 1.0 / wavelength_max  # 1/m: waves in band per m
        period = int(n_waves) / per_wave
        _check_samples(period / dx, dx, "the random profile (one period)")
        n_fft = int(np.ceil(period / dx - 1e-9))
        n_fft += n_fft % 2  # even length for irfft
    if n_fft > MAX_SAMPLES:
        _check_samples(n_fft, period / n_fft, "the random profile (one period)")
    return float(period), int(n_fft)


def _realisation(spec: Spectrum, wavelength_min, wavelength_max, seed, period, n_fft):
    """One period of samples ``r[j]`` at ``x = j period / n_fft`` and its complex
    spectrum (the ``irfft`` input: ``r = n_fft / 2 irfft(c)``)."""
    lo, hi = 2.0 * np.pi / wavelength_max, 2.0 * np.pi / wavelength_min
    d_omega = 2.0 * np.pi / period
    k = np.arange(n_fft // 2 + 1)
    a_edge = np.clip((k - 0.5) * d_omega, lo, hi)
    b_edge = np.clip((k + 0.5) * d_omega, lo, hi)
    power = np.zeros(k.size)
    live = b_edge > a_edge
    live[0] = False  # no mean value
    live[-1] = False  # nor a Nyquist component (it cannot carry a random phase)
    power[live] = spec.integral(a_edge[live], b_edge[live])
    amplitude = np.sqrt(2.0 * np.clip(power, 0.0, None))
    rng = np.random.default_rng(seed)
    phase = np.zeros(k.size)
    phase[live] = rng.uniform(0.0, 2.0 * np.pi, int(live.sum()))
    spectrum_c = amplitude * np.exp(1j * phase)
    # irfft(c, n)[j] = (1/n) (c_0 + 2 Re sum_k c_k e^{2 pi i k j/n}) for c_0 = c_{n/2} = 0
    r = 0.5 * n_fft * np.fft.irfft(spectrum_c, n_fft)
    return r, spectrum_c


def _range_indices(x_start, x_stop, dx_used):
    """First and last sample index covering ``[x_start, x_stop]`` (at least 3 intervals)."""
    n = (x_stop - x_start) / dx_used
    _check_samples(n, dx_used, "the random profile over the track range (the track is "
                   f"{x_stop - x_start:.4g} m long)")
    j0 = int(np.floor(x_start / dx_used + 1e-9))
    j1 = max(int(np.ceil(x_stop / dx_used - 1e-9)), j0 + 3)
    return j0, j1


def psd_realisation(
    spectrum: str | Spectrum,
    wavelength_min: float,
    wavelength_max: float,
    seed: int | None,
    x_start: float,
    x_stop: float,
    dx: float | None = None,
    n_waves: int | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Sample one random profile with a given one-sided PSD (spectral representation).

    Parameters
    ----------
    spectrum : str or Spectrum
        Name in :data:`SPECTRA` (``"fra1"`` .. ``"fra6"``, ``"german_low"``,
        ``"german_high"``) or a :class:`Spectrum`.
    wavelength_min, wavelength_max : float
        Band limits (m): only wavenumbers ``2 pi/wavelength_max <= Omega <= 2
        pi/wavelength_min`` carry power.
    seed : int or None
        Seed of ``numpy.random.default_rng``; the same arguments and seed give the same
        profile.
    x_start, x_stop : float
        Range to sample (m, from the bridge's left end).
    dx : float, optional
        Largest sample spacing (m); default ``wavelength_min / 20``.  The spacing used
        divides the period into a power of two of samples (:func:`psd_grid`), so it may
        be up to two times smaller.
    n_waves : int, optional
        Number of cosine components in the band.  Default: a period of
        :data:`PSD_PERIOD` m, or the power of two above ``20 wavelength_max`` (at least
        20 components in the lowest octave).  A value whose period is shorter than the
        range is refused.

    Returns
    -------
    x : ndarray
        Uniform abscissae from ``x_start`` to at least ``x_stop`` (m).
    r : ndarray
        Irregularity (m, positive = rail lower).
    period : float
        Period of the realisation (m).

    Notes
    -----
    Shinozuka-Jan form ``r(x) = sum_k a_k cos(Omega_k x + phi_k)`` with
    ``Omega_k = k dOmega`` (``dOmega = 2 pi / period``), ``phi_k ~ U[0, 2 pi)`` drawn in
    ascending ``k`` from ``default_rng(seed)``, and ``a_k = sqrt(2 int S dOmega)`` over the
    part of the bin ``[Omega_k -/+ dOmega/2]`` inside the band (exact integral of the
    analytic PSD).  The ensemble variance is therefore exactly ``int S dOmega`` over the
    band, and so is the sample variance over one full period (Parseval).  Evaluated on
    the uniform grid ``x_j = j dx`` (anchored at x = 0) by one inverse real FFT over the
    period, then read at the indices of the range (modulo the period).

    The realisation is a function of x alone given (spectrum, band, seed, dx): the
    phases refer to x = 0 and neither the period nor the grid depends on the range, so
    the same seed is the same track, bit for bit, under the same x whatever range a study
    asks for (whichever trains, speeds or bridge variants it holds).  A range longer than
    the period sees the profile repeat.
    """
    spec = get_spectrum(spectrum)
    period, n_fft, j = _grid_of_range(wavelength_min, wavelength_max, x_start, x_stop, dx,
                                      n_waves)
    r, _ = _realisation(spec, wavelength_min, wavelength_max, seed, period, n_fft)
    return j * (period / n_fft), r[j % n_fft], float(period)


def _grid_of_range(wavelength_min, wavelength_max, x_start, x_stop, dx, n_waves):
    """Period, samples per period and the sample indices covering the range."""
    if not x_stop > x_start:
        raise ValueError(f"need x_stop > x_start (m), got {x_start!r}, {x_stop!r}")
    period, n_fft = psd_grid(wavelength_min, wavelength_max, dx, n_waves)
    if n_waves is not None and period < (x_stop - x_start) * (1.0 - 1e-12):
        per_wave = 1.0 / wavelength_min - 1.0 / wavelength_max
        raise ValueError(
            f"n_waves = {n_waves} gives a period of {period:.6g} m, shorter than the run "
            f"({x_stop - x_start:.6g} m): the profile would repeat; use n_waves >= "
            f"{int(np.ceil((x_stop - x_start) * per_wave))}"
        )
    j0, j1 = _range_indices(x_start, x_stop, period / n_fft)
    return period, n_fft, np.arange(j0, j1 + 1)


def psd_profile(
    spectrum: str | Spectrum,
    wavelength_min: float,
    wavelength_max: float,
    seed: int | None,
    x_start: float,
    x_stop: float,
    dx: float | None = None,
    n_waves: int | None = None,
) -> Profile:
    """Random profile from a one-sided PSD, as a spline :class:`Profile`.

    Same arguments as :func:`psd_realisation` (which documents the method).  The profile
    covers ``[x_start, x_stop]`` (m) and is zero outside; give a range that covers the
    whole run (approach track, bridge and exit) and use the same profile for every
    wheel.  The spline is the periodic cubic spline through the samples of one whole
    period (its second derivatives solved in the Fourier domain), so each interval's
    coefficients, like the samples, do not depend on the range: two ranges give the same
    track bit for bit where they overlap.  Sampled at ``dx <= wavelength_min / 20`` by
    default, the spline reproduces the shortest wavelength to about 1e-5 in r and 1 % in
    r'' (cubic-spline error ``(Omega dx)^4 / 384`` and ``(Omega dx)^2 / 12``).

    Returns
    -------
    Profile
    """
    spec = get_spectrum(spectrum)
    period, n_fft, jr = _grid_of_range(wavelength_min, wavelength_max, x_start, x_stop, dx,
                                       n_waves)
    h = period / n_fft
    r, c = _realisation(spec, wavelength_min, wavelength_max, seed, period, n_fft)
    # periodic spline: (M[j-1] + 4 M[j] + M[j+1]) / 6 = (r[j-1] - 2 r[j] + r[j+1]) / h^2
    cos = np.cos(2.0 * np.pi * np.arange(c.size) / n_fft)
    m = 0.5 * n_fft * np.fft.irfft(c * (6.0 / h**2) * (2.0 * cos - 2.0) / (4.0 + 2.0 * cos),
                                   n_fft)
    j = jr[:-1] % n_fft
    jn = (j + 1) % n_fft
    coef = np.empty((j.size, 4))
    coef[:, 0] = r[j]
    coef[:, 1] = (r[jn] - r[j]) / h - h * (2.0 * m[j] + m[jn]) / 6.0
    coef[:, 2] = 0.5 * m[j]
    coef[:, 3] = (m[jn] - m[j]) / (6.0 * h)
    label = (
        f"psd {spec.name} band=[{wavelength_min:g}, {wavelength_max:g}] m seed={seed} "
        f"x=[{x_start:g}, {x_stop:g}] m period={period:.6g} m"
    )
    return Profile(x0=float(jr[0] * h), dx=float(h), coef=coef, label=label)
