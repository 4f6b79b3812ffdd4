"""Deck twist check of EN 1990 A2.4.4.2.2 (static, from influence lines).

The twist of a track over a base of 3 m, ``t = [w_L - w_R](x) - [w_L - w_R](x + 3)``
(:mod:`vsi_numba.model.deck3d`), under LM71 x Phi x alpha on one track placed most
unfavourably (the axle group and the distributed load where they are unfavourable,
:func:`~vsi_numba.analysis.checks.load_effects.lm71_envelope`), against the limit of the
line speed: ``twist_limit_up_to_120`` for V <= 120 km/h, ``twist_limit_up_to_200`` for
V <= 200 km/h, ``twist_limit_above_200`` above (4.5 / 3.0 / 1.5 mm, the code profile's
values, recalled [R]).  Each track is loaded in turn and the twist of every track is
checked (a beam deck twists as a whole: a train on one track twists the other too).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsi_numba.analysis.checks.load_effects import lm71_envelope
from vsi_numba.code_profile import resolve
from vsi_numba.en1991 import lm71

#: Clause of the check (the profile's twist entries carry it too).
TWIST_CLAUSE = "EN 1990 A2.4.4.2.2"


def twist_limit(speed_kmh: float, profile=None) -> float:
    """Limit (m) of the deck twist over 3 m for a line speed ``speed_kmh`` (km/h), from
    the code profile."""
    v = float(speed_kmh)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"speed = {speed_kmh!r} km/h: expected a line speed > 0")
    p = resolve(profile)
    key = ("twist_limit_up_to_120" if v <= 120.0 else "twist_limit_up_to_200"
           if v <= 200.0 else "twist_limit_above_200")
    return float(p[key])


class TwistCheck(NamedTuple):
    """The static twist of track ``track`` with LM71 x Phi x alpha on track ``loaded``
    (both 1-based).

    ``starts`` (m): window starts; ``twist_max``, ``twist_min`` (m): the design extremes
    per window (already times alpha and Phi); ``value`` (m): the largest |twist|, at the
    window start ``at`` with the centre of the LM71 axle group at ``load_at``;
    ``limit`` (m) for ``speed_kmh``; ``utilisation = value / limit``.
    """

    track: int
    loaded: int
    starts: np.ndarray
    twist_max: np.ndarray
    twist_min: np.ndarray
    value: float
    at: float
    load_at: float
    limit: float
    speed_kmh: float
    alpha: float
    phi: float

    @property
    def utilisation(self) -> float:
        return self.value / self.limit

    @property
    def passed(self) -> bool:
        return bool(self.value <= self.limit)


def static_twist_check(deck, speed_kmh: float, alpha: float, phi: float, profile=None,
                       intervals: int = 32, step: float = 0.05) -> list[TwistCheck]:
    """EN 1990 A2.4.4.2.2 under LM71 x Phi x alpha, every track loaded in turn.

    Parameters
    ----------
    deck : vsi_numba.model.deck3d.BeamDeck3D
        With torsion (else the twist is zero and the check says so by raising).
    speed_kmh : float
        The line speed (km/h) that selects the limit.
    alpha, phi : float
        Classification factor and dynamic factor (Phi_2 or Phi_3 of the deck's
        determinant length, :func:`vsi_numba.en1991.dynamic_factor`).
    profile : CodeProfile, optional
        LM71 and the limits (default: the recommended values).
    intervals : int
        Window starts per span (plus the windows across the deck ends).
    step : float
        Placement step of the LM71 axle group (m), see
        :func:`~vsi_numba.analysis.checks.load_effects.lm71_envelope`.

    Returns
    -------
    list of TwistCheck
        One per (loaded track, twisted track); the governing one is the largest
        utilisation.
    """
    limit = twist_limit(speed_kmh, profile)
    model = lm71(profile)
    starts = deck.twist_grid(intervals)
    bp = deck.twist_breakpoints(starts)
    out = []
    factor = float(alpha) * float(phi)
    for loaded in range(len(deck.tracks)):
        for k in range(len(deck.tracks)):
            env = lm71_envelope(deck.static_twist_line(k, starts, loaded=loaded), bp,
                                (0.0, deck.length), step=step, n_at=starts.size, model=model)
            tmax, tmin = factor * env.max, factor * env.min
            mag = np.maximum(np.abs(tmax), np.abs(tmin))
            i = int(np.argmax(mag))
            load_at = float(env.at_max[i] if abs(tmax[i]) >= abs(tmin[i]) else env.at_min[i])
            out.append(TwistCheck(k + 1, loaded + 1, starts, tmax, tmin, float(mag[i]),
                                  float(starts[i]), load_at, limit, float(speed_kmh),
                                  float(alpha), float(phi)))
    return out
