"""Fatigue of steel details under the dynamic stress histories: S-N curves of
EN 1993-1-9, rainflow counting, Miner's rule, the damage-equivalent stress range and the
simplified lambda-method of EN 1993-2; the S-N curve of headed stud shear connectors of
EN 1994-1-1 6.8.3 (values: :mod:`vsi_numba.code_profile`, [R]).

S-N curve (EN 1993-1-9 7.1, Fig. 7.1 [R]) of a detail category Delta sigma_C (MPa, the
range at N_C = 2e6 cycles), with the design strength Delta sigma_C / gamma_Mf::

    N = N_C (Delta sigma_C / Delta sigma)^3        Delta sigma >= Delta sigma_D
    N = N_D (Delta sigma_D / Delta sigma)^5        Delta sigma_L <= Delta sigma < Delta sigma_D
    N = infinity                                   Delta sigma < Delta sigma_L

with the constant-amplitude limit Delta sigma_D at N_D = 5e6 and the cut-off limit
Delta sigma_L at N_L = 1e8 (so Delta sigma_D = (2/5)^(1/3) Delta sigma_C = 0.737
Delta sigma_C and Delta sigma_L = (5/100)^(1/5) Delta sigma_D = 0.549 Delta sigma_D).
Stress ranges are multiplied by gamma_Ff before they meet the curve.

Counting: rainflow (ASTM E1049-85) by the ``rainflow`` package; half cycles count 0.5.
Damage: Miner's sum D = sum n_i / N_i.  Damage-equivalent stress range at 2e6 cycles:
the range Delta sigma_E2 whose 2e6 cycles on the m = 3 branch through the design curve
give D, i.e. gamma_Ff Delta sigma_E2 = (Delta sigma_C / gamma_Mf) D^(1/3); the check
gamma_Ff Delta sigma_E2 <= Delta sigma_C / gamma_Mf is then D <= 1.

lambda-method (EN 1993-2 9.5.3 [R]): Delta sigma_E2 = lambda Phi_2 Delta sigma_71, with
lambda = lambda_1 lambda_2 lambda_3 lambda_4 <= lambda_max, Delta sigma_71 the stress
range of LM71 (alpha = 1) at the detail and Phi_2 the dynamic factor of carefully
maintained track.  lambda_2 = (traffic volume / 25e6 t per year)^(1/5) and lambda_3 =
(design life / 100 years)^(1/5) are computed; lambda_1 and lambda_4 are profile entries.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsi_numba.code_profile import CodeProfile, resolve

#: Bin width of the stored stress-range histograms (MPa) and their number of bins (the
#: last bin holds every larger range).
BIN_WIDTH = 1.0
N_BINS = 600


@dataclass(frozen=True)
class SNCurve:
    """EN 1993-1-9 S-N curve of a detail category, design values (strength divided by
    gamma_Mf).  Ranges in MPa."""

    detail_category: float  # Delta sigma_C, MPa
    gamma_Mf: float = 1.0
    m1: float = 3.0
    m2: float = 5.0
    n_c: float = 2e6
    n_d: float = 5e6
    n_l: float = 1e8

    @classmethod
    def of(cls, detail_category: float, gamma_Mf: float = 1.0,
           profile: CodeProfile | None = None) -> SNCurve:
        """The curve with the slopes and cycle numbers of ``profile``."""
        p = resolve(profile)
        return cls(float(detail_category), float(gamma_Mf), p["fatigue_slope_m1"],
                   p["fatigue_slope_m2"], p["fatigue_reference_cycles"],
                   p["fatigue_constant_amplitude_cycles"], p["fatigue_cutoff_cycles"])

    @property
    def strength(self) -> float:
        """Design detail category Delta sigma_C / gamma_Mf (MPa)."""
        return self.detail_category / self.gamma_Mf

    @property
    def constant_amplitude_limit(self) -> float:
        """Design Delta sigma_D / gamma_Mf (MPa)."""
        return self.strength * (self.n_c / self.n_d) ** (1.0 / self.m1)

    @property
    def cutoff_limit(self) -> float:
        """Design Delta sigma_L / gamma_Mf (MPa)."""
        return self.constant_amplitude_limit * (self.n_d / self.n_l) ** (1.0 / self.m2)

    def cycles(self, stress_range) -> np.ndarray:
        """Cycles to failure N of each (factored) stress range (MPa); inf below the
        cut-off limit."""
        s = np.asarray(stress_range, float)
        sd, sl = self.constant_amplitude_limit, self.cutoff_limit
        with np.errstate(divide="ignore"):
            upper = self.n_c * (self.strength / s) ** self.m1
            lower = self.n_d * (sd / s) ** self.m2
        return np.where(s >= sd, upper, np.where(s >= sl, lower, np.inf))

    def damage(self, stress_range, counts) -> float:
        """Miner's sum of ``counts`` cycles at each factored ``stress_range`` (MPa)."""
        n = self.cycles(stress_range)
        c = np.asarray(counts, float)
        return float(np.sum(np.where(np.isfinite(n), c / n, 0.0)))

    def equivalent_range(self, damage: float) -> float:
        """Factored range at N_C cycles that does the damage ``damage`` (MPa):
        strength * D^(1/m1)."""
        return self.strength * max(float(damage), 0.0) ** (1.0 / self.m1)


@dataclass(frozen=True)
class StudCurve:
    """S-N curve of headed stud shear connectors (EN 1994-1-1 6.8.3(3) [R]), design
    values: (Delta tau_R)^m N_R = (Delta tau_c)^m N_C with one slope m = 8 and no
    cut-off, strength Delta tau_c / gamma_Mf,s.  Ranges in MPa."""

    category: float = 90.0  # Delta tau_c, MPa
    gamma_Mf: float = 1.0
    m: float = 8.0
    n_c: float = 2e6

    @classmethod
    def of(cls, gamma_Mf: float, profile: CodeProfile | None = None) -> StudCurve:
        """The curve of ``profile`` (category, slope, N_C) with ``gamma_Mf``."""
        p = resolve(profile)
        return cls(p["fatigue_stud_category"], float(gamma_Mf), p["fatigue_stud_slope"],
                   p["fatigue_reference_cycles"])

    @property
    def strength(self) -> float:
        """Design reference strength Delta tau_c / gamma_Mf,s (MPa)."""
        return self.category / self.gamma_Mf

    def cycles(self, stress_range) -> np.ndarray:
        """Cycles to failure N of each (factored) shear-stress range (MPa); inf at 0."""
        s = np.asarray(stress_range, float)
        with np.errstate(divide="ignore"):
            return self.n_c * (self.strength / s) ** self.m

    def damage(self, stress_range, counts) -> float:
        """Miner's sum of ``counts`` cycles at each factored ``stress_range`` (MPa)."""
        n = self.cycles(stress_range)
        c = np.asarray(counts, float)
        return float(np.sum(np.where(np.isfinite(n), c / n, 0.0)))

    def equivalent_range(self, damage: float) -> float:
        """Factored range at N_C cycles that does ``damage`` (MPa): strength D^(1/m)
        (EN 1994-2 6.8.7.2(1): gamma_Ff Delta tau_E2 <= Delta tau_c / gamma_Mf,s is
        then D <= 1)."""
        return self.strength * max(float(damage), 0.0) ** (1.0 / self.m)


def stud_stress_per_shear(first_moment: float, second_moment: float, row_spacing: float,
                          per_row: float, diameter: float) -> float:
    """Shear stress in the studs per unit vertical shear (Pa per N = m^-2).

    The longitudinal shear flow of the uncracked composite section is v_L = V S / I (N
    per m; S the first moment of the slab about the composite neutral axis, I the second
    moment of the composite section, both in the units of the steel), one row of
    ``per_row`` studs takes the flow of ``row_spacing`` and each stud its share over its
    shank area pi d^2 / 4: tau = V S s / (I n pi d^2 / 4).
    """
    area = per_row * np.pi * diameter**2 / 4.0
    return float(first_moment / second_moment * row_spacing / area)


def rainflow_cycles(series) -> tuple[np.ndarray, np.ndarray]:
    """Rainflow ranges and counts (0.5 for a half cycle) of a history (ASTM E1049-85,
    the ``rainflow`` package).

    Returns
    -------
    ranges, counts : ndarray
        One entry per counted (half) cycle, in the units of ``series``.
    """
    import rainflow

    x = np.asarray(series, float).ravel()
    if x.size < 2:
        return np.zeros(0), np.zeros(0)
    out = [(rng, cnt) for rng, _mean, cnt, _i, _j in rainflow.extract_cycles(x)]
    if not out:
        return np.zeros(0), np.zeros(0)
    r, c = np.asarray(out, float).T
    return r, c


def histogram(ranges, counts, width: float = BIN_WIDTH, n_bins: int = N_BINS) -> np.ndarray:
    """Counts per stress-range bin [k w, (k + 1) w) (last bin: every larger range)."""
    k = np.minimum(np.floor(np.asarray(ranges, float) / width).astype(np.int64), n_bins - 1)
    return np.bincount(k, weights=np.asarray(counts, float), minlength=n_bins)


def bin_centres(width: float = BIN_WIDTH, n_bins: int = N_BINS) -> np.ndarray:
    """Centres of the histogram bins (MPa)."""
    return (np.arange(n_bins) + 0.5) * width


@dataclass(frozen=True)
class LambdaMethod:
    """The lambda-method value of one section (EN 1993-2 9.5.3 [R])."""

    lambda_1: float
    lambda_2: float
    lambda_3: float
    lambda_4: float
    lambda_max: float
    phi_2: float
    delta_sigma_71: float  # MPa

    @property
    def factor(self) -> float:
        """lambda = min(lambda_1 lambda_2 lambda_3 lambda_4, lambda_max)."""
        return min(self.lambda_1 * self.lambda_2 * self.lambda_3 * self.lambda_4,
                   self.lambda_max)

    @property
    def equivalent_range(self) -> float:
        """Delta sigma_E2 = lambda Phi_2 Delta sigma_71 (MPa, unfactored)."""
        return self.factor * self.phi_2 * self.delta_sigma_71


def lambda_method(delta_sigma_71: float, phi_2: float, tonnes_per_year: float,
                  design_life_years: float, profile: CodeProfile | None = None
                  ) -> LambdaMethod:
    """lambda factors of EN 1993-2 9.5.3 [R] for a traffic volume and design life."""
    p = resolve(profile)
    l2 = (max(tonnes_per_year, 0.0) / p["fatigue_lambda_volume"]) ** 0.2
    l3 = (design_life_years / 100.0) ** 0.2 * p["fatigue_lambda_3"]
    return LambdaMethod(p["fatigue_lambda_1"], l2, l3, p["fatigue_lambda_4"],
                        p["fatigue_lambda_max"], float(phi_2), float(delta_sigma_71))


def decay_time(omega, damping, fraction: float) -> float:
    """Free vibration (s) after which every mode has decayed to ``fraction`` of its
    amplitude: ln(1 / fraction) / min_j(zeta_j omega_j).  inf without damping."""
    rate = np.min(np.asarray(damping, float) * np.asarray(omega, float))
    if not rate > 0:
        return float("inf")
    return float(np.log(1.0 / fraction) / rate)
