"""EN 1990 Annex A2 rules of the railway bridge checks (deck acceleration, passenger
comfort).

Used by :mod:`vsi_numba.analysis.checks`, the solver (which modes enter the deck
acceleration) and the config (time-step checks of those modes).  Values tagged [R] are
recalled from the cited standard and not re-read against the primary text
(``notes/railway.md`` §4): check them before relying on them as hard limits.
"""

from __future__ import annotations

import numpy as np

#: Peak deck acceleration limits (m s-2) per track type, EN 1990 A2.4.4.2.1(4)P:
#: gamma_bt = 3.5 for ballasted track (0.35 g, value verified; clause [R]) and
#: gamma_df = 5.0 for direct-fastened track [R].
DECK_ACCELERATION_LIMITS = {"ballasted": 3.5, "direct_fastening": 5.0}

#: Clause of the deck acceleration check.
DECK_ACCELERATION_CLAUSE = "EN 1990 A2.4.4.2.1(4)P"

#: Lowest frequency (Hz) of the acceleration cut-off, EN 1990 A2.4.4.2.1(4)P [R].
CUTOFF_MIN_FREQUENCY = 30.0

#: Car-body vertical acceleration b_v (m s-2) per level of comfort, EN 1990 Table A2.9 [R].
COMFORT_LEVELS = {"very good": 1.0, "good": 1.3, "acceptable": 2.0}
COMFORT_CLAUSE = "EN 1990 A2.4.4.3, Table A2.9 [R]"

#: Level of comfort of an unknown (NaN) acceleration.
NOT_APPLICABLE = "n/a"


def frequency_cutoff(frequencies) -> float:
    """Upper frequency (Hz) of the modes counted in the deck acceleration check.

    ``max(30 Hz, 1.5 f1, f3)`` with f1 the fundamental and f3 the third natural frequency
    of the member, EN 1990 A2.4.4.2.1(4)P [R].

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
        cut = max(cut, 1.5 * f[0])
    if f.size >= 3:
        cut = max(cut, f[2])
    return float(cut)


def comfort_level(bv: float) -> str:
    """Best EN 1990 Table A2.9 [R] level of comfort for car-body acceleration bv (m s-2)."""
    if not np.isfinite(bv):
        return NOT_APPLICABLE
    for name, value in sorted(COMFORT_LEVELS.items(), key=lambda kv: kv[1]):
        if bv <= value:
            return name
    return "not acceptable"


# ------------------------------------------------------------------ deck-end rotation

#: Clause of the deck-end rotation limits of ballasted track.
END_ROTATION_CLAUSE = "EN 1990 A2.4.4.2.3, EN 1991-2 6.5.4.5.2 [R]"
#: Ballasted track, EN 1991-2 6.5.4.5.2 [R]: the rotation of a deck end relative to the
#: adjacent abutment (rad), under LM71 x Phi x alpha ...
END_ROTATION_LIMIT_ABUTMENT = 6.5e-3
#: ... and the sum theta_1 + theta_2 of the rotations of two consecutive decks at the joint
#: between them (rad) [R].
END_ROTATION_LIMIT_DECKS = 10e-3
