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
    moving-force model leaves out, so it is never added to interaction models.  The
    numerator changes sign at L = 0.0187 / 0.00064 = 29.22 m: the formula is slightly
    negative (down to -0.006 %) for 29.22 m < L < 30 m, where it is taken as 0 (an
    additional damping never removes damping).
    """
    if not span > 0:
        raise ValueError(f"span = {span!r}: expected > 0 m")
    if span >= ADDITIONAL_DAMPING_SPAN:
        return 0.0
    L = float(span)
    dz = 0.01 * (0.0187 * L - 0.00064 * L**2) / (1 - 0.0441 * L - 0.0044 * L**2
                                                 + 0.000255 * L**3)
    return max(dz, 0.0)


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


#: Clause of the determinant length L_phi.
DETERMINANT_LENGTH_CLAUSE = "EN 1991-2 6.4.5.3, Table 6.2 [R]"

#: Factor k of L_phi = k L_m for a continuous deck of n spans, EN 1991-2 Table 6.2 [R];
#: n >= 5 takes :data:`CONTINUOUS_K_MANY`.
CONTINUOUS_K = {2: 1.2, 3: 1.3, 4: 1.4}
CONTINUOUS_K_MANY = 1.5


def continuous_determinant_length(spans) -> float:
    """L_phi of a continuous deck of n spans, EN 1991-2 Table 6.2 [R].

    ``L_phi = k L_m``, ``L_m = (L_1 + ... + L_n) / n``, with k = 1.2 (n = 2), 1.3 (n = 3),
    1.4 (n = 4), 1.5 (n >= 5), but not less than the largest span; one span: L_phi = L.

    Parameters
    ----------
    spans : sequence of float
        Span lengths (m), > 0.

    Returns
    -------
    float
        L_phi (m).
    """
    L = np.asarray(spans, float).ravel()
    if L.size == 0 or not np.all(np.isfinite(L) & (L > 0)):
        raise ValueError(f"spans = {list(L)}: expected one or more span lengths > 0 m")
    if L.size == 1:
        return float(L[0])
    k = CONTINUOUS_K.get(L.size, CONTINUOUS_K_MANY)
    return float(max(k * L.mean(), L.max()))


def irregularity_allowance(speed, length: float, n0: float) -> np.ndarray:
    """Dynamic allowance for track irregularities, phi'' of EN 1991-2 Annex C [R].

    ``phi'' = a [0.56 exp(-(L/10)^2) + 0.50 (n0 L / 80 - 1) exp(-(L/20)^2)]``, ``phi'' >= 0``,
    with ``a = min(v / 22, 1)`` (v in m s-1).

    Parameters
    ----------
    speed : array_like
        Speed v (m s-1).
    length : float
        Determinant length L_phi (m), EN 1991-2 Table 6.2 [R]; see
        :func:`vsi_numba.analysis.checks.determinant_length`.
    n0 : float
        First natural bending frequency of the loaded bridge (Hz).

    Returns
    -------
    ndarray
        phi'' (-), same shape as ``speed``.
    """
    v = np.asarray(speed, float)
    a = np.minimum(v / 22.0, 1.0)
    bracket = 0.56 * np.exp(-((length / 10.0) ** 2)) + 0.50 * (n0 * length / 80.0 - 1.0) * np.exp(
        -((length / 20.0) ** 2)
    )
    return np.maximum(a * bracket, 0.0)


# ------------------------------------------------------------------ LM71, Phi, alpha

#: Clause of the static load model LM71.
LM71_CLAUSE = "EN 1991-2 6.3.2, Fig. 6.1 [R]"
#: LM71 point forces Q_vk (N): four axles ...
LM71_AXLE_LOAD = 250e3
#: ... at this spacing (m) ...
LM71_AXLE_SPACING = 1.6
#: ... in a zone of this length (m), centred on the axle group (0.8 m beyond the outer
#: axles) ...
LM71_AXLE_ZONE = 6.4
#: ... and the distributed load q_vk (N/m) on both sides of the zone, unlimited in length,
#: applied only where it is unfavourable.
LM71_UDL = 80e3
#: Axle offsets (m) from the centre of the LM71 axle group.
LM71_AXLE_OFFSETS = (-2.4, -0.8, 0.8, 2.4)

#: Clause and range of the load classification factor alpha, EN 1991-2 6.3.2(3) [R]:
#: one of 0.75, 0.83, 0.91, 1.00, 1.10, 1.21, 1.33, 1.46 (any value in the range is
#: accepted; the National Annex chooses).
ALPHA_CLAUSE = "EN 1991-2 6.3.2(3) [R]"
ALPHA_RANGE = (0.75, 1.46)
ALPHA_VALUES = (0.75, 0.83, 0.91, 1.00, 1.10, 1.21, 1.33, 1.46)

#: Clause of the dynamic factors Phi_2, Phi_3.
PHI_CLAUSE = "EN 1991-2 6.4.5.2 [R]"
#: Track maintenance standard -> dynamic factor: "careful" maintenance Phi_2,
#: "standard" maintenance Phi_3, EN 1991-2 6.4.5.2(2)/(3) [R].
TRACK_MAINTENANCE = {"careful": "Phi2", "standard": "Phi3"}
#: (a, b, upper bound) of Phi = a / (sqrt(L_phi) - 0.2) + b, 1.00 <= Phi <= upper [R].
_PHI_COEFFICIENTS = {"Phi2": (1.44, 0.82, 1.67), "Phi3": (2.16, 0.73, 2.00)}


def dynamic_factor(length, maintenance: str = "standard"):
    """Dynamic factor Phi_2 (careful maintenance) or Phi_3 (standard maintenance) of
    EN 1991-2 6.4.5.2 [R].

    ``Phi_2 = 1.44 / (sqrt(L_phi) - 0.2) + 0.82`` with ``1.00 <= Phi_2 <= 1.67``;
    ``Phi_3 = 2.16 / (sqrt(L_phi) - 0.2) + 0.73`` with ``1.00 <= Phi_3 <= 2.00``.
    For a very short L_phi (sqrt(L_phi) <= 0.2 m^0.5) the upper bound applies.

    Parameters
    ----------
    length : float or array_like
        Determinant length L_phi (m), > 0 (EN 1991-2 Table 6.2 [R],
        :func:`continuous_determinant_length`).
    maintenance : {"standard", "careful"}
        Track maintenance standard (:data:`TRACK_MAINTENANCE`).

    Returns
    -------
    float or ndarray
        Phi (-), same shape as ``length``.
    """
    if maintenance not in TRACK_MAINTENANCE:
        raise ValueError(f"maintenance = {maintenance!r}: expected one of "
                         f"{', '.join(map(repr, TRACK_MAINTENANCE))}")
    L = np.asarray(length, float)
    if not np.all(np.isfinite(L) & (L > 0)):
        raise ValueError(f"determinant length = {length!r}: expected a length > 0 m")
    a, b, upper = _PHI_COEFFICIENTS[TRACK_MAINTENANCE[maintenance]]
    root = np.sqrt(L) - 0.2
    with np.errstate(divide="ignore"):
        phi = np.where(root > 0, a / np.where(root > 0, root, 1.0) + b, upper)
    phi = np.clip(phi, 1.0, upper)
    return float(phi) if phi.ndim == 0 else phi


# ------------------------------------------------------------------------------ HSLM-B

#: HSLM-B: N point forces of this load (N) at a uniform spacing d (m), EN 1991-2
#: 6.4.6.1.1, Fig. 6.13 [R]; N and d as functions of the span are read from Fig. 6.13,
#: whose curve values are not available here [NF]: give them (train.hslm_b).
HSLM_B_LOAD = 170e3
HSLM_B_CLAUSE = "EN 1991-2 6.4.6.1.1, Annex E, Fig. 6.13 [R]"
#: HSLM-B applies to simply supported spans shorter than this (m) [R].
HSLM_B_MAX_SPAN = 7.0
