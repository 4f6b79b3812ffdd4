"""Vertical track irregularity profiles r(x).

Convention: ``r > 0`` means the rail is **lower** than nominal (a dip), so with
displacements positive down the rail top sits at ``w_deck(x) + r(x)``.

Every profile is carried to the kernels as a C2 cubic spline on a uniform grid
(``x0``, ``dx``, coefficients per interval).  A cubic spline keeps r, r' and r''
continuous, so the interpolation adds no curvature spikes of its own (linear
interpolation would put a Dirac in r'' at every sample, i.e. a force spike on a rigid
wheel).  Outside the sampled range the profile is zero.

Profiles provided
-----------------
* :func:`no_irregularity`, isolated defects :func:`cosine_defect` (dip / bump) and
  :func:`step_defect` (smooth ramp to a new level, cosine or quintic);
* random profiles from one-sided PSDs in rad/m (:data:`SPECTRA`: FRA classes 1-6,
  German low / high interference), :func:`psd_profile` / :func:`psd_realisation`;
* measured profiles from CSV, :func:`profile_from_file`;
* :func:`combine` (sum on a common grid) and :func:`check_coverage` (does a profile
  cover the run?).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Profile:
    """A sampled profile with its spline coefficients.

    Parameters
    ----------
    x0 : float
        Abscissa of the first sample (m, from the bridge's left end).
    dx : float
        Sample spacing (m).
    coef : ndarray, shape (n_intervals, 4)
        Per interval ``k``, with ``s = x - (x0 + k dx)``:
        ``r = c0 + c1 s + c2 s^2 + c3 s^3``.
    label : str
        Human-readable description (kind and parameters).
    """

    x0: float
    dx: float
    coef: np.ndarray
    label: str = "none"

    @property
    def x_end(self) -> float:
        """Abscissa of the last sample (m)."""
        return self.x0 + self.dx * self.coef.shape[0]

    @property
    def is_zero(self) -> bool:
        """True for the smooth track (no intervals or all coefficients zero)."""
        return self.coef.shape[0] == 0 or not np.any(self.coef)

    def __call__(self, x, derivative: int = 0) -> np.ndarray:
        """Evaluate r (or its derivative) at ``x`` (vectorised, zero outside)."""
        x = np.asarray(x, float)
        out = np.zeros_like(x)
        n = self.coef.shape[0]
        if n == 0:
            return out
        k = np.floor((x - self.x0) / self.dx).astype(np.int64)
        inside = (x >= self.x0) & (x <= self.x_end)
        k = np.clip(k, 0, n - 1)
        s = x - (self.x0 + k * self.dx)
        c = self.coef[k]
        if derivative == 0:
            val = c[..., 0] + s * (c[..., 1] + s * (c[..., 2] + s * c[..., 3]))
        elif derivative == 1:
            val = c[..., 1] + s * (2 * c[..., 2] + 3 * s * c[..., 3])
        elif derivative == 2:
            val = 2 * c[..., 2] + 6 * s * c[..., 3]
        else:
            raise ValueError("derivative must be 0, 1 or 2")
        out[inside] = val[inside]
        return out

    @classmethod
    def from_samples(cls, x, r, label: str = "samples", dx: float | None = None) -> Profile:
        """Spline through samples ``(x, r)`` (x strictly increasing), on a uniform grid.

        Non-uniform samples are first interpolated by a C2 cubic spline and resampled
        at ``dx`` (default: the smallest sample spacing).
        """
        import scipy.interpolate  # here, not at import: it takes ~0.4 s to import

        x = np.asarray(x, float)
        r = np.asarray(r, float)
        if x.ndim != 1 or x.shape != r.shape or x.size < 4:
            raise ValueError("a profile needs at least 4 samples of x and r of equal length")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(r))):
            raise ValueError("profile samples contain NaN or inf")
        if np.any(np.diff(x) <= 0):
            raise ValueError("profile x must be strictly increasing")
        h = np.diff(x)
        uniform = np.allclose(h, h[0], rtol=1e-9, atol=0.0)
        given = dx is not None
        if dx is None:
            dx = float(h.min())
        if not uniform or abs(dx - h[0]) > 1e-9 * dx:
            _check_samples((x[-1] - x[0]) / dx, dx, "the resampled profile (dx = the "
                           "smallest sample spacing unless irregularity.dx is given)")
            spl = scipy.interpolate.CubicSpline(x, r, bc_type="natural")
            n = int(np.floor((x[-1] - x[0]) / dx + 1e-9))
            xu = x[0] + dx * np.arange(n + 1)
            ru = spl(xu)
        else:
            xu, ru = x, r
        spl = scipy.interpolate.CubicSpline(xu, ru, bc_type="natural")
        # scipy stores c[m, k] for (x - x_k)^(3 - m); reorder to ascending powers.
        coef = np.ascontiguousarray(spl.c[::-1].T)
        # the grid step: the one given (exact), else that of the first interval
        step = float(dx) if given else float(xu[1] - xu[0])
        return cls(x0=float(xu[0]), dx=step, coef=coef, label=label)

    @classmethod
    def from_function(
        cls, func: Callable[[np.ndarray], np.ndarray], x_start: float, x_stop: float,
        dx: float, label: str,
    ) -> Profile:
        """Sample ``func`` on ``[x_start, x_stop]`` at spacing ``dx`` and spline it."""
        _check_samples((x_stop - x_start) / dx, dx, label)
        n = max(int(np.ceil((x_stop - x_start) / dx)), 3)
        x = x_start + dx * np.arange(n + 1)
        return cls.from_samples(x, func(x), label=label)


#: Samples one profile may have (its FFT included): beyond this it is refused before any
#: allocation (about 160 MB per array of float64).
MAX_SAMPLES = 20_000_000


def _check_samples(n: float, dx: float, what: str) -> None:
    """Refuse a profile of more than :data:`MAX_SAMPLES` samples (a MemoryError later)."""
    if not n <= MAX_SAMPLES:
        raise ValueError(
            f"{what}: {n:.3g} samples at dx = {dx:.3g} m, more than the budget of "
            f"{MAX_SAMPLES:.3g}; give a coarser sample spacing (irregularity.dx) or a "
            "shorter track (solver.free_vibration, train length, irregularity."
            "wavelength_max)")


def no_irregularity() -> Profile:
    """The perfectly smooth track."""
    return Profile(x0=0.0, dx=1.0, coef=np.zeros((0, 4)), label="none")


def cosine_defect(
    depth: float, wavelength: float, position: float, samples_per_wavelength: int = 200
) -> Profile:
    """Isolated cosine defect: ``r = depth/2 (1 - cos(2 pi (x - position)/wavelength))``.

    ``depth > 0`` is a dip (the rail is lower), ``depth < 0`` a bump.  The defect starts
    at ``position`` and is ``wavelength`` long; r and r' are continuous at its ends.
    """
    if wavelength <= 0:
        raise ValueError("wavelength must be > 0")

    def func(x):
        s = (x - position) / wavelength
        inside = (s >= 0.0) & (s <= 1.0)
        return np.where(inside, 0.5 * depth * (1.0 - np.cos(2.0 * np.pi * s)), 0.0)

    dx = wavelength / samples_per_wavelength
    pad = 4 * dx
    return Profile.from_function(
        func, position - pad, position + wavelength + pad, dx,
        label=f"cosine depth={depth} m wavelength={wavelength} m position={position} m",
    )


# --------------------------------------------------------------------------- isolated defects


def step_defect(
    height: float,
    length: float,
    position: float,
    x_stop: float,
    shape: str = "cosine",
    samples_per_length: int = 200,
) -> Profile:
    """Smooth change of track level (ramp / step) that persists to ``x_stop``.

    ``r`` rises from 0 at ``position`` to ``height`` at ``position + length`` and stays
    at ``height`` up to ``x_stop`` (e.g. a settled transition at an abutment).

    Parameters
    ----------
    height : float
        Final level change (m); ``> 0``: the rail ends up lower (settlement).
    length : float
        Length of the transition (m), ``> 0``.
    position : float
        Start of the transition (m, from the bridge's left end).
    x_stop : float
        End of the profile (m), ``>= position + length``.  Beyond it the profile is
        zero, like every :class:`Profile`: make ``x_stop`` cover the whole run (see
        :func:`check_coverage`), or the wheels meet a step back to zero there.
    shape : {"cosine", "quintic"}
        ``"cosine"``: ``h (1 - cos(pi s)) / 2`` (r, r' continuous, r'' jumps at the ends);
        ``"quintic"``: ``h (10 s^3 - 15 s^4 + 6 s^5)`` (r, r', r'' continuous).
        ``s = (x - position) / length``.
    samples_per_length : int
        Samples over the transition (sets the spline spacing ``length / samples``).

    Returns
    -------
    Profile
    """
    if not length > 0:
        raise ValueError(f"step_defect: length must be > 0 m, got {length!r}")
    if not x_stop >= position + length:
        raise ValueError(
            f"step_defect: x_stop = {x_stop!r} m must be >= position + length = "
            f"{position + length!r} m"
        )
    if shape not in ("cosine", "quintic"):
        raise ValueError(f"step_defect: shape must be 'cosine' or 'quintic', got {shape!r}")

    def func(x):
        s = np.clip((x - position) / length, 0.0, 1.0)
        if shape == "cosine":
            return 0.5 * height * (1.0 - np.cos(np.pi * s))
        return height * s**3 * (10.0 - 15.0 * s + 6.0 * s * s)

    dx = length / samples_per_length
    n = int(np.ceil((x_stop - (position - 4 * dx)) / dx))
    start = x_stop - n * dx  # the grid ends exactly at x_stop
    return Profile.from_function(
        func, start, x_stop, dx,
        label=(
            f"step ({shape}) height={height} m length={length} m position={position} m "
            f"to x={x_stop} m"
        ),
    )


def combine(*profiles: Profile, dx: float | None = None, label: str | None = None) -> Profile:
    """Sum of profiles, resampled on one uniform grid covering all of them.

    Parameters
    ----------
    *profiles : Profile
        Profiles to add (zero profiles are ignored).
    dx : float, optional
        Grid spacing (m); default: the finest spacing among the profiles.
    label : str, optional
        Label of the result; default: the labels joined by ``" + "``.

    Returns
    -------
    Profile
        Zero outside the union of the inputs' ranges.  Each input is zero outside its
        own range, so the sum is what the kernels would see with the profiles applied
        one after another.

    Notes
    -----
    The sum is sampled at the grid nodes and splined again; at the finest input
    spacing the resampling error is that of a cubic spline, O(dx^4).
    """
    live = [p for p in profiles if not p.is_zero]
    if not live:
        return no_irregularity()
    if len(live) == 1 and dx is None:
        p = live[0]
        return Profile(p.x0, p.dx, p.coef.copy(), label or p.label)
    if dx is None:
        dx = min(p.dx for p in live)
    if not dx > 0:
        raise ValueError(f"combine: dx must be > 0 m, got {dx!r}")
    x0 = min(p.x0 for p in live)
    x_end = max(p.x_end for p in live)
    n = int(np.ceil((x_end - x0) / dx - 1e-9))
    if n > 20_000_000:
        raise ValueError(
            f"combine: {n} intervals of {dx} m over [{x0}, {x_end}] m; give a coarser dx"
        )
    x = x0 + dx * np.arange(max(n, 3) + 1)
    r = np.zeros_like(x)
    for p in live:
        r += p(x)
    return Profile.from_samples(x, r, label=label or " + ".join(p.label for p in live))


# ----------------------------------------------------------------------- measured profiles


def profile_from_file(
    path,
    x_column: str = "x",
    r_column: str = "r",
    r_unit: str = "m",
    dx: float | None = None,
) -> Profile:
    """Measured profile from a CSV file (columns of x [m] and r [m or mm]).

    Parameters
    ----------
    path : str or path-like
        CSV file with a header row; lines starting with ``#`` are comments.
    x_column, r_column : str
        Column names of the abscissa (m, strictly increasing) and the irregularity
        (positive = rail lower).
    r_unit : {"m", "mm"}
        Unit of ``r_column``.
    dx : float, optional
        Spline spacing (m); default: the smallest sample spacing (non-uniform samples
        are resampled, see :meth:`Profile.from_samples`).

    Returns
    -------
    Profile
        Zero outside the measured range (see :func:`check_coverage`).

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        Missing columns, non-numeric or NaN values, non-increasing x, fewer than 4
        samples.  Every message names the file.
    """
    import pandas as pd

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"irregularity file {str(p)!r}: no such file")
    scale = {"m": 1.0, "mm": 1e-3}.get(r_unit)
    if scale is None:
        raise ValueError(
            f"irregularity file {str(p)!r}: r_unit must be 'm' or 'mm', got {r_unit!r}"
        )
    try:
        df = pd.read_csv(p, comment="#", skipinitialspace=True)
    except Exception as exc:  # pandas raises several parser error types
        raise ValueError(f"irregularity file {str(p)!r}: cannot read as CSV ({exc})") from exc
    df.columns = [str(c).strip() for c in df.columns]
    missing = [c for c in (x_column, r_column) if c not in df.columns]
    if missing:
        raise ValueError(
            f"irregularity file {str(p)!r}: missing column(s) {missing}; "
            f"found {list(df.columns)}"
        )
    cols = {}
    for c in (x_column, r_column):
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ValueError(
                f"irregularity file {str(p)!r}: column {c!r} has {bad.size} missing, "
                f"non-numeric or infinite value(s), first at data row {bad[0] + 1}"
            )
        cols[c] = v
    x, r = cols[x_column], cols[r_column] * scale
    if x.size < 4:
        raise ValueError(
            f"irregularity file {str(p)!r}: {x.size} sample(s); at least 4 are needed"
        )
    step = np.diff(x)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        i = bad[0]
        raise ValueError(
            f"irregularity file {str(p)!r}: column {x_column!r} must be strictly increasing; "
            f"data rows {i + 1} and {i + 2} have x = {x[i]!r} then {x[i + 1]!r}"
        )
    return Profile.from_samples(x, r, label=f"file {p.name}", dx=dx)


@dataclass(frozen=True)
class Coverage:
    """Result of :func:`check_coverage`; true when the profile covers the run."""

    ok: bool
    x_start: float
    x_stop: float
    profile_start: float
    profile_stop: float
    message: str

    def __bool__(self) -> bool:
        """Return ``ok``."""
        return self.ok


#: Upper bound of train speeds (km/h): the configuration refuses faster ones.
SPEED_BOUND_KMH = 1000.0


def profile_range(bridge_length, train_lengths, approach, free_vibration):
    """Track range (m) the irregularity profiles of a study cover.

    From where the last axle of the longest train starts (``-(approach + length)``) to
    where the first axle is when a run at the highest admissible speed
    (:data:`SPEED_BOUND_KMH`) ends (``L + length + v_bound * free_vibration``), with 1 m
    of margin each side.  One range for the whole study, independent of its speeds: a
    random profile depends on the range it is drawn over, and this way a seed is the same
    realisation at every speed, for every train of the study, and in another study of the
    same bridge, trains and solver settings that lists other speeds.
    """
    length = max(train_lengths) if len(train_lengths) else 0.0
    x_start = -(approach + length) - 1.0
    x_stop = bridge_length + length + SPEED_BOUND_KMH / 3.6 * free_vibration + 1.0
    return float(x_start), float(x_stop)


def check_coverage(profile: Profile, x_start: float, x_stop: float) -> Coverage:
    """Tell whether ``profile`` is defined over the whole run ``[x_start, x_stop]`` (m).

    A profile is zero outside its sampled range, so a measured or random profile that
    ends inside the run gives the wheels a step back to r = 0.  The zero profile covers
    every run.  Isolated defects (cosine dip) are zero by design outside their range and
    need not cover the run; check only profiles meant to describe the whole track.

    Returns
    -------
    Coverage
        ``bool(result)`` is the answer; ``result.message`` says what is missing (m).
    """
    if profile.is_zero:
        return Coverage(True, x_start, x_stop, x_start, x_stop, "zero profile: covers any run")
    lo, hi = profile.x0, profile.x_end
    gaps = []
    if lo > x_start:
        gaps.append(
            f"starts at x = {lo:g} m, {lo - x_start:g} m after the run starts ({x_start:g} m)"
        )
    if hi < x_stop:
        gaps.append(
            f"ends at x = {hi:g} m, {x_stop - hi:g} m before the run ends ({x_stop:g} m)"
        )
    if gaps:
        msg = f"profile {profile.label!r} " + " and ".join(gaps) + "; it is zero outside"
        return Coverage(False, x_start, x_stop, lo, hi, msg)
    return Coverage(True, x_start, x_stop, lo, hi, f"profile covers [{x_start:g}, {x_stop:g}] m")


# ------------------------------------------------------------------------ random profiles


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


#: Default period (m) of a random profile: a realisation is the same function of x for
#: every range up to this length (see :func:`psd_realisation`).
PSD_PERIOD = 8192.0


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
        divides the period exactly, so it may be slightly smaller.
    n_waves : int, optional
        Number of cosine components in the band.  Default: a period of
        :data:`PSD_PERIOD` m (at least ``20 wavelength_max``, i.e. at least 20 components
        in the lowest octave), longer only when the range is longer than that.  A value
        whose period is shorter than the range is refused.

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
    phases refer to x = 0 and the period does not depend on the range, so the same seed
    is the same track under the same x whatever range a study asks for (whichever trains,
    speeds or bridge variants it holds), as long as the range is shorter than
    :data:`PSD_PERIOD`.
    """
    spec = get_spectrum(spectrum)
    _check_band(wavelength_min, wavelength_max)
    if not x_stop > x_start:
        raise ValueError(f"need x_stop > x_start (m), got {x_start!r}, {x_stop!r}")
    if dx is None:
        dx = wavelength_min / 20.0
    if not 0.0 < dx <= wavelength_min / 2.0:
        raise ValueError(
            f"dx = {dx!r} m must be > 0 and <= wavelength_min/2 = {wavelength_min / 2} m "
            "(Nyquist); wavelength_min/20 or less is recommended"
        )
    lo, hi = 2.0 * np.pi / wavelength_max, 2.0 * np.pi / wavelength_min
    run = x_stop - x_start
    per_wave = 1.0 / wavelength_min - 1.0 / wavelength_max  # 1/m: waves in band per metre
    if n_waves is None:
        period = max(PSD_PERIOD, 20.0 * wavelength_max)
        while period < run:
            period *= 2.0
    else:
        if int(n_waves) < 1:
            raise ValueError(f"n_waves must be >= 1, got {n_waves!r}")
        period = int(n_waves) / per_wave
        if period < run * (1.0 - 1e-12):
            raise ValueError(
                f"n_waves = {n_waves} gives a period of {period:.6g} m, shorter than the run "
                f"({run:.6g} m): the profile would repeat; use n_waves >= "
                f"{int(np.ceil(run * per_wave))}"
            )
    _check_samples(period / dx, dx, "the random profile (period max(track length, 20 x "
                   "irregularity.wavelength_max))")
    n_fft = int(np.ceil(period / dx - 1e-9))
    n_fft += n_fft % 2  # even length for irfft
    dx_used = period / n_fft
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
    j0 = int(np.floor(x_start / dx_used + 1e-9))
    j1 = max(int(np.ceil(x_stop / dx_used - 1e-9)), j0 + 3)
    j = np.arange(j0, j1 + 1)
    return j * dx_used, r[j % n_fft], float(period)


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
    wheel.  Sampled at ``dx <= wavelength_min / 20`` by default, the spline reproduces the
    shortest wavelength to about 1e-5 in r and 1 % in r'' (cubic-spline error
    ``(Omega dx)^4 / 384`` and ``(Omega dx)^2 / 12``).

    Returns
    -------
    Profile
    """
    spec = get_spectrum(spectrum)
    x, r, period = psd_realisation(
        spec, wavelength_min, wavelength_max, seed, x_start, x_stop, dx, n_waves
    )
    n_fft = int(round(period / (x[1] - x[0])))
    label = (
        f"psd {spec.name} band=[{wavelength_min:g}, {wavelength_max:g}] m seed={seed} "
        f"x=[{x_start:g}, {x_stop:g}] m period={period:.6g} m"
    )
    return Profile.from_samples(x, r, label=label, dx=period / n_fft)
