"""EN 1990 Annex A2 rules of the railway bridge checks (deck acceleration, passenger
comfort).

Used by :mod:`vsi_numba.analysis.checks`, the solver (which modes enter the deck
acceleration) and the config (time-step checks of those modes).  The values are entries of
the code profile (:mod:`vsi_numba.code_profile`: clause, [R] flag); the functions take a
profile (default: the recommended values) and the module constants are the recommended
values, kept for callers that need no profile.
"""

from __future__ import annotations

import numpy as np

from vsi_numba.code_profile import CodeProfile, default_profile, resolve

_DEFAULT = default_profile()

#: Track type -> code profile key of its peak deck acceleration limit.
DECK_ACCELERATION_KEYS = {"ballasted": "deck_acceleration_limit_ballasted",
                          "direct_fastening": "deck_acceleration_limit_direct_fastening"}
#: Peak deck acceleration limits (m s-2) per track type, recommended values
#: (:func:`deck_acceleration_limits` for a profile).
DECK_ACCELERATION_LIMITS = {t: _DEFAULT[k] for t, k in DECK_ACCELERATION_KEYS.items()}

#: Clause of the deck acceleration check.
DECK_ACCELERATION_CLAUSE = _DEFAULT.clause("deck_acceleration_limit_ballasted")

#: Lowest frequency (Hz) of the acceleration cut-off (recommended value).
CUTOFF_MIN_FREQUENCY = _DEFAULT["acceleration_cutoff_min_frequency"]

#: Level of comfort -> code profile key of its car-body acceleration b_v.
COMFORT_KEYS = {"very good": "comfort_very_good", "good": "comfort_good",
                "acceptable": "comfort_acceptable"}
#: Car-body vertical acceleration b_v (m s-2) per level of comfort (recommended values;
#: :func:`comfort_levels` for a profile).
COMFORT_LEVELS = {n: _DEFAULT[k] for n, k in COMFORT_KEYS.items()}
COMFORT_CLAUSE = _DEFAULT.clause("comfort_very_good")


def deck_acceleration_limits(profile: CodeProfile | None = None) -> dict[str, float]:
    """Track type -> peak deck acceleration limit (m s-2) of ``profile``."""
    p = resolve(profile)
    return {t: p[k] for t, k in DECK_ACCELERATION_KEYS.items()}


def comfort_levels(profile: CodeProfile | None = None) -> dict[str, float]:
    """Level of comfort -> car-body acceleration b_v (m s-2) of ``profile``."""
    p = resolve(profile)
    return {n: p[k] for n, k in COMFORT_KEYS.items()}

#: Level of comfort of an unknown (NaN) acceleration.
NOT_APPLICABLE = "n/a"


def frequency_cutoff(frequencies) -> float:
    """Upper frequency (Hz) of the modes counted in the deck acceleration check.

    ``max(30 Hz, 1.5 f1, f3)`` with f1 the fundamental and f3 the third natural frequency
    of the member, EN 1990 A2.4.4.2.1(4)P (code profile entries
    ``acceleration_cutoff_min_frequency``, ``acceleration_cutoff_f1_factor``).

    Parameters
    ----------
    frequencies : array_like
        Natural frequencies (Hz), any order; non-finite and non-positive values ignored.

    Returns
    -------
    float
        The cut-off (Hz); 30 Hz when no frequency is known. With fewer than three modes
        f3 is unknown and left out (the cut-off may then be too low).
    """
    f = np.sort(np.asarray(frequencies, float).ravel())
    f = f[np.isfinite(f) & (f > 0)]
    cut = CUTOFF_MIN_FREQUENCY
    if f.size:
        cut = max(cut, _DEFAULT["acceleration_cutoff_f1_factor"] * f[0])
    if f.size >= 3:
        cut = max(cut, f[2])
    return float(cut)


def comfort_level(bv: float, profile: CodeProfile | None = None) -> str:
    """Best EN 1990 Table A2.9 level of comfort for car-body acceleration bv (m s-2), with
    the levels of ``profile``."""
    if not np.isfinite(bv):
        return NOT_APPLICABLE
    for name, value in sorted(comfort_levels(profile).items(), key=lambda kv: kv[1]):
        if bv <= value:
            return name
    return "not acceptable"


# ------------------------------------------------------------------ deck-end rotation

#: Clause of the deck-end rotation limits of ballasted track.
END_ROTATION_CLAUSE = "EN 1990 A2.4.4.2.3, " + _DEFAULT.clause("end_rotation_limit_abutment")
