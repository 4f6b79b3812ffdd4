"""EN 1991-2 rules used to set up dynamic analyses (damping, frequency band, resonance).

Clauses tagged [R] are recalled, not re-read against the primary text
(``shared/notes/railway.md``): check them before relying on them as hard values.
"""

from __future__ import annotations

import numpy as np

#: Deck types of EN 1991-2 Table 6.6 and their lower-bound damping (%): (zeta for
#: L >= 20 m, slope per metre below 20 m).
DECK_TYPES = {
    "steel_composite": (0.5, 0.125),
    "prestressed_concrete": (1.0, 0.07),
    "filler_beam_reinforced_concrete": (1.5, 0.07),
}

#: Spans below which the additional damping of moving-force analyses applies (m).
ADDITIONAL_DAMPING_SPAN = 30.0


def damping_lower_bound(deck_type: str, span: float) -> float:
    """Lower-bound critical damping ratio (fraction, not %) of EN 1991-2 Table 6.6.

    zeta = z0 + k (20 - L) % for L < 20 m, z0 % for L >= 20 m, with (z0, k) = (0.5,
    0.125) steel and composite, (1.0, 0.07) prestressed concrete, (1.5, 0.07) filler beam
    and reinforced concrete.
    """
    if deck_type not in DECK_TYPES:
        raise ValueError(f"deck_type = {deck_type!r}: expected one of {', '.join(DECK_TYPES)}")
    if not span > 0:
        raise ValueError(f"span = {span!r}: expected > 0 m")
    z0, k = DECK_TYPES[deck_type]
    return 0.01 * (z0 + k * max(20.0 - span, 0.0))


def additional_damping(span: float) -> float:
    """Additional damping (fraction) of moving-force analyses, EN 1991-2 §6.4.6.3.1 [R]:

    dzeta = (0.0187 L - 0.00064 L^2) / (1 - 0.0441 L - 0.0044 L^2 + 0.000255 L^3) %
    for L < 30 m, 0 otherwise.  It stands for the vehicle-bridge interaction a
    moving-force model leaves out, so it is never added to interaction models.
    """
    if not span > 0:
        raise ValueError(f"span = {span!r}: expected > 0 m")
    if span >= ADDITIONAL_DAMPING_SPAN:
        return 0.0
    L = float(span)
    return 0.01 * (0.0187 * L - 0.00064 * L**2) / (1 - 0.0441 * L - 0.0044 * L**2
                                                   + 0.000255 * L**3)


def frequency_band(span: float) -> tuple[float, float]:
    """First-frequency band (Hz) of EN 1991-2 Fig. 6.10 [R]: lower limit 80/L for
    4 <= L <= 20 m and 23.58 L^-0.592 for 20 < L <= 100 m; upper limit 94.76 L^-0.748."""
    if not 4.0 <= span <= 100.0:
        raise ValueError(f"span = {span!r}: Fig. 6.10 covers 4 <= L <= 100 m")
    lower = 80.0 / span if span <= 20.0 else 23.58 * span ** -0.592
    return float(lower), float(94.76 * span ** -0.748)


def resonance_speeds_kmh(frequency: float, spacing: float, orders=(1, 2, 3)) -> np.ndarray:
    """Resonance speeds v_i = n0 d / i (km/h) of a first frequency n0 (Hz) under loads at
    a regular spacing d (m), EN 1991-2 §6.4.6.2 [R]."""
    return np.array([3.6 * frequency * spacing / i for i in orders])
