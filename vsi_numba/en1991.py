"""EN 1991-2 rules used to set up dynamic analyses (damping, frequency band, resonance).

The values are entries of the code profile (:mod:`vsi_numba.code_profile`: clause, [R]
flag); the functions take a profile (default: the recommended values) and the module
constants are the recommended values, kept for callers that need no profile.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsi_numba.code_profile import CodeProfile, default_profile, resolve

_DEFAULT = default_profile()

#: Deck types of EN 1991-2 Table 6.6 -> code profile key of their lower-bound damping
#: (%, L >= 20 m; the key + "_slope" is the increase per metre below 20 m).
DECK_TYPE_KEYS = {
    "steel_composite": "damping_steel_composite",
    "prestressed_concrete": "damping_prestressed_concrete",
    "filler_beam_reinforced_concrete": "damping_filler_beam_reinforced_concrete",
}
#: Deck types of EN 1991-2 Table 6.6 and their lower-bound damping (%): (zeta for
#: L >= 20 m, slope per metre below 20 m), recommended values.
DECK_TYPES = {t: (_DEFAULT[k], _DEFAULT[k + "_slope"]) for t, k in DECK_TYPE_KEYS.items()}


def damping_lower_bound(deck_type: str, span: float, profile: CodeProfile | None = None
                        ) -> float:
    """Lower-bound critical damping ratio (fraction, not %) of EN 1991-2 Table 6.6.

    zeta = z0 + k (20 - L) % for L < 20 m, z0 % for L >= 20 m, with (z0, k) = (0.5,
    0.125) steel and composite, (1.0, 0.07) prestressed concrete, (1.5, 0.07) filler beam
    and reinforced concrete (the recommended values; ``profile`` may set others).
    """
    if deck_type not in DECK_TYPES:
        raise ValueError(f"deck_type = {deck_type!r}: expected one of {', '.join(DECK_TYPES)}")
    if not span > 0:
        raise ValueError(f"span = {span!r}: expected > 0 m")
    p = resolve(profile)
    key = DECK_TYPE_KEYS[deck_type]
    z0, k = p[key], p[key + "_slope"]
    return 0.01 * (z0 + k * max(20.0 - span, 0.0))


def additional_damping(span: float, profile: CodeProfile | None = None) -> float:
    """Additional damping (fraction) of moving-force analyses, EN 1991-2 §6.4.6.3.1:

    dzeta = (0.0187 L - 0.00064 L^2) / (1 - 0.0441 L - 0.0044 L^2 + 0.000255 L^3) %
    for L < 30 m, 0 otherwise.  It stands for the vehicle-bridge interaction a
    moving-force model leaves out, so it is never added to interaction models.  The
    numerator changes sign at L = 0.0187 / 0.00064 = 29.22 m: the formula is slightly
    negative (down to -0.006 %) for 29.22 m < L < 30 m, where it is taken as 0 (an
    additional damping never removes damping).  The span limit 30 m is the profile's
    ``additional_damping_max_span``.
    """
    if not span > 0:
        raise ValueError(f"span = {span!r}: expected > 0 m")
    if span >= resolve(profile)["additional_damping_max_span"]:
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
DETERMINANT_LENGTH_CLAUSE = _DEFAULT.clause("determinant_length_k2")

#: Factor k of L_phi = k L_m for a continuous deck of n spans, EN 1991-2 Table 6.2
#: (recommended values); n >= 5 takes :data:`CONTINUOUS_K_MANY`.
CONTINUOUS_K = {n: _DEFAULT[f"determinant_length_k{n}"] for n in (2, 3, 4)}
CONTINUOUS_K_MANY = _DEFAULT["determinant_length_k5"]


def continuous_k(n_spans: int, profile: CodeProfile | None = None) -> float:
    """Factor k of L_phi = k L_m for a continuous deck of ``n_spans`` >= 2 spans."""
    return resolve(profile)[f"determinant_length_k{min(max(int(n_spans), 2), 5)}"]


def continuous_determinant_length(spans, profile: CodeProfile | None = None) -> float:
    """L_phi of a continuous deck of n spans, EN 1991-2 Table 6.2.

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
    k = continuous_k(L.size, profile)
    return float(max(k * L.mean(), L.max()))


def irregularity_allowance(speed, length: float, n0: float,
                           profile: CodeProfile | None = None) -> np.ndarray:
    """Dynamic allowance for track irregularities, phi'' of EN 1991-2 Annex C.

    ``phi'' = a [0.56 exp(-(L/10)^2) + 0.50 (n0 L / 80 - 1) exp(-(L/20)^2)]``, ``phi'' >= 0``,
    with ``a = min(v / 22, 1)`` (v in m s-1).

    Parameters
    ----------
    speed : array_like
        Speed v (m s-1).
    length : float
        Determinant length L_phi (m), EN 1991-2 Table 6.2; see
        :func:`vsi_numba.analysis.checks.determinant_length`.
    n0 : float
        First natural bending frequency of the loaded bridge (Hz).
    profile : CodeProfile, optional
        Code profile (``irregularity_allowance_speed``, ``_c1``, ``_c2``; default the
        recommended 22 m s-1, 0.56, 0.50).

    Returns
    -------
    ndarray
        phi'' (-), same shape as ``speed``.
    """
    p = resolve(profile)
    v = np.asarray(speed, float)
    a = np.minimum(v / p["irregularity_allowance_speed"], 1.0)
    bracket = (p["irregularity_allowance_c1"] * np.exp(-((length / 10.0) ** 2))
               + p["irregularity_allowance_c2"] * (n0 * length / 80.0 - 1.0)
               * np.exp(-((length / 20.0) ** 2)))
    return np.maximum(a * bracket, 0.0)


# ------------------------------------------------------------------ LM71, Phi, alpha

#: Clause of the static load model LM71.
LM71_CLAUSE = _DEFAULT.clause("lm71_axle_load")
#: LM71's distributed load q_vk (N/m) on both sides of the zone of its four point forces
#: (:class:`LM71`), unlimited in length, applied only where it is unfavourable.
LM71_UDL = _DEFAULT["lm71_udl"]


class LM71(NamedTuple):
    """LM71 of a code profile: four point forces ``axle_load`` (N) at ``spacing`` (m) in a
    zone of 4 spacings centred on them, and ``udl`` (N/m) outside the zone."""

    axle_load: float
    spacing: float
    udl: float

    @property
    def zone(self) -> float:
        """Length of the zone of the point forces (m)."""
        return 4.0 * self.spacing

    @property
    def offsets(self) -> tuple[float, ...]:
        """Axle offsets (m) from the centre of the group (to 1e-12 m: -2.4, not
        -2.4000000000000004)."""
        return tuple(round(k * self.spacing, 12) for k in (-1.5, -0.5, 0.5, 1.5))


def lm71(profile: CodeProfile | None = None) -> LM71:
    """LM71 of ``profile`` (default: 4 x 250 kN at 1.6 m, 80 kN/m)."""
    p = resolve(profile)
    return LM71(p["lm71_axle_load"], p["lm71_axle_spacing"], p["lm71_udl"])


#: Clause and range of the load classification factor alpha, EN 1991-2 6.3.2(3):
#: one of 0.75, 0.83, 0.91, 1.00, 1.10, 1.21, 1.33, 1.46 (any value in the range is
#: accepted; the National Annex chooses).
ALPHA_CLAUSE = _DEFAULT.clause("classification_factor_min")
ALPHA_RANGE = (_DEFAULT["classification_factor_min"], _DEFAULT["classification_factor_max"])

#: Clause of the dynamic factors Phi_2, Phi_3.
PHI_CLAUSE = _DEFAULT.clause("phi3_a")
#: Track maintenance standard -> dynamic factor: "careful" maintenance Phi_2,
#: "standard" maintenance Phi_3, EN 1991-2 6.4.5.2(2)/(3).
TRACK_MAINTENANCE = {"careful": "Phi2", "standard": "Phi3"}
#: (a, b, upper bound) of Phi = a / (sqrt(L_phi) - 0.2) + b, 1.00 <= Phi <= upper
#: (recommended values; the profile's ``phi2_*`` and ``phi3_*``).
_PHI_COEFFICIENTS = {"Phi2": (1.44, 0.82, 1.67), "Phi3": (2.16, 0.73, 2.00)}


def phi_coefficients(maintenance: str, profile: CodeProfile | None = None
                     ) -> tuple[float, float, float]:
    """(a, b, upper bound) of Phi_2 ("careful") or Phi_3 ("standard") of ``profile``."""
    p = resolve(profile)
    stem = "phi2" if TRACK_MAINTENANCE[maintenance] == "Phi2" else "phi3"
    return p[f"{stem}_a"], p[f"{stem}_b"], p[f"{stem}_max"]


def dynamic_factor(length, maintenance: str = "standard", profile: CodeProfile | None = None):
    """Dynamic factor Phi_2 (careful maintenance) or Phi_3 (standard maintenance) of
    EN 1991-2 6.4.5.2.

    ``Phi_2 = 1.44 / (sqrt(L_phi) - 0.2) + 0.82`` with ``1.00 <= Phi_2 <= 1.67``;
    ``Phi_3 = 2.16 / (sqrt(L_phi) - 0.2) + 0.73`` with ``1.00 <= Phi_3 <= 2.00``.
    For a very short L_phi (sqrt(L_phi) <= 0.2 m^0.5) the upper bound applies.

    Parameters
    ----------
    length : float or array_like
        Determinant length L_phi (m), > 0 (EN 1991-2 Table 6.2,
        :func:`continuous_determinant_length`).
    maintenance : {"standard", "careful"}
        Track maintenance standard (:data:`TRACK_MAINTENANCE`).
    profile : CodeProfile, optional
        Code profile (its ``phi2_*`` / ``phi3_*`` entries; default the recommended ones).

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
    a, b, upper = phi_coefficients(maintenance, profile)
    root = np.sqrt(L) - 0.2
    with np.errstate(divide="ignore"):
        phi = np.where(root > 0, a / np.where(root > 0, root, 1.0) + b, upper)
    phi = np.clip(phi, 1.0, upper)
    return float(phi) if phi.ndim == 0 else phi


# ------------------------------------------------------------------------------ HSLM-B

#: HSLM-B: N point forces of this load (N) at a uniform spacing d (m), EN 1991-2
#: 6.4.6.1.1, Fig. 6.13; N and d as functions of the span are read from Fig. 6.13,
#: whose curve values are not available here [NF]: give them (train.hslm_b).
HSLM_B_LOAD = _DEFAULT["hslm_b_load"]
HSLM_B_CLAUSE = "EN 1991-2 6.4.6.1.1, Annex E, Fig. 6.13"
#: HSLM-B applies to simply supported spans shorter than this (m), recommended value.
HSLM_B_MAX_SPAN = _DEFAULT["hslm_b_max_span"]
