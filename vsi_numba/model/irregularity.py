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

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.model.profile import (  # noqa: F401  (re-exported)
    MAX_SAMPLES,
    Profile,
    _check_samples,
    no_irregularity,
)
from vsi_numba.model.psd import (  # noqa: F401  (re-exported)
    PSD_PERIOD,
    SPECTRA,
    Spectrum,
    get_spectrum,
    psd_profile,
    psd_realisation,
)


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


#: The transition shapes of :func:`step_defect`.
STEP_SHAPES = ("cosine", "quintic")


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
    if shape not in STEP_SHAPES:
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
