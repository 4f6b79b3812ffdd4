"""The code profile: every value the checks take from a standard, in one visible table.

Each entry of :data:`TABLE` is a clause value: its key, value, SI unit, clause, a
description and whether it was *recalled* from the standard and not re-read against the
primary text ([R], ``docs/manual/theory.md``, "The checks and their clauses").  The
default profile is :data:`DEFAULT_NAME`; a configuration may override any entry that is
not marked fixed (``[code_profile]``: a national annex, a client's rule), and the
profile used travels with the results (the ``code_profile`` section of the stored
configuration, ``config_json``), so that ``vsi report`` on a results file checks it with the
profile of its study.

Where an entry applies (:attr:`Entry.applies`):

- ``"checks"``: read by the checks of a results file (``vsi report``, ``vsi sweep``'s
  governing summary) from the stored profile;
- ``"input"``: applied when the configuration is read (damping rules, the range of the
  classification factor, the HSLM applicability and HSLM-B's N and d);
- ``"fixed"``: part of a model or of the run itself (the HSLM-B force, the acceleration
  cut-off of the solver): not overridable here; :attr:`Entry.note` says what to set
  instead.

This module imports nothing of the package (the rules of :mod:`vsi_numba.en1990` and
:mod:`vsi_numba.en1991` read it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import NamedTuple

#: Name of the default profile.
DEFAULT_NAME = "EN 1990 A2 / EN 1991-2:2003 recommended values"
#: Marker of a recalled value in the report's profile table.
RECALLED = "[R]"
#: What the [R] marker means (printed once, under the profile table).
RECALLED_MEANING = ("recalled from the standard and not re-read against the primary text: "
                    "check it before relying on it as a hard value")


@dataclass(frozen=True)
class Limits:
    """The values an entry may take (an override outside them is refused): strict or
    inclusive bounds, None for none.  The keys of a configuration that stand for an
    entry (``fatigue.sections[].gamma_Mf`` for ``fatigue_gamma_Mf``) share them
    (:func:`limits_of`)."""

    gt: float | None = 0.0
    ge: float | None = None
    lt: float | None = None
    le: float | None = None

    def as_dict(self) -> dict:
        """``{gt, ge, lt, le}`` (the keywords of a declared number)."""
        return {"gt": self.gt, "ge": self.ge, "lt": self.lt, "le": self.le}

    def __contains__(self, x) -> bool:
        return not ((self.gt is not None and not x > self.gt)
                    or (self.ge is not None and not x >= self.ge)
                    or (self.lt is not None and not x < self.lt)
                    or (self.le is not None and not x <= self.le))

    def text(self, unit: str = "") -> str:
        """The bounds in words: "> 0", ">= 1 and <= 10"."""
        parts = [f"{op} {v:g}" for op, v in ((">", self.gt), (">=", self.ge),
                                              ("<", self.lt), ("<=", self.le))
                 if v is not None]
        return " and ".join(parts) + (f" {unit}" if unit and parts else "")


#: The limits of most entries: a positive number.
POSITIVE = Limits()
#: A fraction of something (a ratio strictly between 0 and 1).
FRACTION = Limits(gt=0.0, lt=1.0)
#: A partial factor (EN 1990 6.3: never below 1; 10 is no factor of a standard).
PARTIAL_FACTOR = Limits(gt=None, ge=1.0, le=10.0)
#: A dynamic factor or an upper bound of one (never below 1).
AT_LEAST_ONE = Limits(gt=None, ge=1.0)
#: A percentage of critical damping (Table 6.6), below 100 %.
PERCENT = Limits(gt=0.0, lt=100.0)


@dataclass(frozen=True)
class Entry:
    """One clause value of the code profile.

    Attributes
    ----------
    key : str
        Name in ``[code_profile] overrides``.
    value : float
        Value in SI units (``unit``).
    unit : str
        Units (``"1"`` dimensionless, ``"%"`` for the Table 6.6 percentages).
    clause : str
        Clause of the standard (or, for an override, the source the configuration names).
    description : str
        What the value is.
    recalled : bool
        True when the value was recalled and not re-read ([R]); False for an override.
    applies : str
        "checks", "input" or "fixed" (module notes).
    integer : bool
        A whole number (counts).
    note : str
        For a fixed entry, what to set instead.
    limits : Limits
        The values it may take (an override outside them is refused).
    overridden : bool
        Set by the configuration.
    default : float
        The recommended value (equal to ``value`` unless overridden).
    default_clause : str
        The clause of the recommended value (equal to ``clause`` unless overridden).
    """

    key: str
    value: float
    unit: str
    clause: str
    description: str
    recalled: bool = True
    applies: str = "checks"
    integer: bool = False
    note: str = ""
    limits: Limits = POSITIVE
    overridden: bool = False
    default: float = math.nan
    default_clause: str = ""


_A2_ACC = "EN 1990 A2.4.4.2.1(4)P"
_A2_COMFORT = "EN 1990 A2.4.4.3.2, Table A2.9"
_ROT = "EN 1991-2 6.5.4.5.2"
_TWIST = "EN 1990 A2.4.4.2.2, Table A2.7"
_DEFLECTION = "EN 1990 A2.4.4.2.3(1)"
_COMFORT_DEFLECTION = "EN 1990 A2.4.4.3.2, Fig. A2.3"
_T66 = "EN 1991-2 6.4.6.3.1, Table 6.6"
_T62 = "EN 1991-2 6.4.5.3, Table 6.2"
_PHI = "EN 1991-2 6.4.5.2"
_ANNEX_C = "EN 1991-2 Annex C"
_LM71 = "EN 1991-2 6.3.2, Fig. 6.1"
_HSLM = "EN 1991-2 6.4.6.1.1, Annex E (Table E.4)"
_FIG613 = "EN 1991-2 6.4.6.1.1, Fig. 6.13"
_SIGNATURE = "ERRI D214 RP9 (DER, LIR); EN 1991-2 Annex E, E.2"
_SN = "EN 1993-1-9 7.1, Fig. 7.1"
_LAMBDA = "EN 1993-2 9.5.3"
_SN_STUD = "EN 1994-1-1 6.8.3(3), Fig. 6.12; EN 1994-2 6.8.3"

#: The table: (key, value, unit, clause, description, recalled, applies[, integer/note]).
TABLE: tuple[Entry, ...] = (
    # ---------------------------------------------------------------- EN 1990 Annex A2
    Entry("deck_acceleration_limit_ballasted", 3.5, "m s-2", _A2_ACC,
          "peak deck acceleration, ballasted track (gamma_bt = 0.35 g; the value is "
          "confirmed by a secondary source, the clause is recalled)"),
    Entry("deck_acceleration_limit_direct_fastening", 5.0, "m s-2", _A2_ACC,
          "peak deck acceleration, direct-fastened track (gamma_df)"),
    Entry("acceleration_cutoff_min_frequency", 30.0, "Hz", _A2_ACC,
          "lowest upper frequency of the modes counted in the deck acceleration, "
          "max(30 Hz, 1.5 f1, f3)", applies="fixed",
          note="applied by the solver during the runs: set solver.acceleration_cutoff"),
    Entry("acceleration_cutoff_f1_factor", 1.5, "1", _A2_ACC,
          "factor on the fundamental frequency in the cut-off max(30 Hz, 1.5 f1, f3)",
          applies="fixed",
          note="applied by the solver during the runs: set solver.acceleration_cutoff"),
    Entry("comfort_very_good", 1.0, "m s-2", _A2_COMFORT,
          "car-body vertical acceleration b_v, level of comfort 'very good'"),
    Entry("comfort_good", 1.3, "m s-2", _A2_COMFORT,
          "car-body vertical acceleration b_v, level of comfort 'good'"),
    Entry("comfort_acceptable", 2.0, "m s-2", _A2_COMFORT,
          "car-body vertical acceleration b_v, level of comfort 'acceptable'"),
    Entry("end_rotation_limit_abutment", 6.5e-3, "rad", _ROT,
          "ballasted track: rotation of a deck end relative to the abutment under "
          "LM71 x Phi x alpha"),
    Entry("end_rotation_limit_decks", 10e-3, "rad", _ROT,
          "ballasted track: sum of the rotations of two consecutive decks at a joint "
          "(printed with the rotation check; single decks use the abutment limit)"),
    Entry("twist_limit_up_to_120", 4.5e-3, "m", _TWIST,
          "deck twist over 3 m, V <= 120 km/h (LM71 and the dynamic runs)"),
    Entry("twist_limit_up_to_200", 3.0e-3, "m", _TWIST,
          "deck twist over 3 m, 120 < V <= 200 km/h (LM71 and the dynamic "
          "runs)"),
    Entry("twist_limit_above_200", 1.5e-3, "m", _TWIST,
          "deck twist over 3 m, V > 200 km/h (LM71 and the dynamic runs)"),
    Entry("deflection_span_ratio", 600.0, "1", _DEFLECTION,
          "vertical deflection along any track under LM71 x Phi x alpha, every track "
          "loaded: at most L / this ratio (L the span)"),
    Entry("comfort_deflection_factor_two_spans", 0.7, "1", _COMFORT_DEFLECTION + "; (6)",
          "factor on the L/delta of Fig. A2.3 for a single span, two simply supported "
          "spans or two continuous spans"),
    Entry("comfort_deflection_factor_continuous", 0.9, "1", _COMFORT_DEFLECTION + "; (6)",
          "factor on the L/delta of Fig. A2.3 for a continuous deck of three or more spans"),
    Entry("comfort_deflection_factor_single_deck", 1.0, "1", _COMFORT_DEFLECTION + "; (6)",
          "factor on the L/delta of Fig. A2.3 for a deck of one span modelled alone: 1.0, "
          "the figure's own case (a succession of three or more simply supported spans), "
          "the safe side; a bridge of one or two simply supported spans may take the "
          "two-span factor (override this entry)"),
    Entry("comfort_deflection_max_span", 120.0, "m", _COMFORT_DEFLECTION + "; (7)",
          "Fig. A2.3 is valid for spans up to this length (longer: special analysis)"),
    # ------------------------------------------------------------------ wheel unloading
    Entry("wheel_unloading_limit", 0.6, "1", "EN 14363 / UIC practice",
          "admissible wheel unloading dQ/Q0", limits=Limits(gt=0.0, le=1.0)),
    # ------------------------------------------------------------------ EN 1991-2 damping
    Entry("damping_steel_composite", 0.5, "%", _T66,
          "lower-bound damping, steel and composite decks, L >= 20 m (L of every Table "
          "6.6 entry and of the additional damping: the span of a simply supported deck, "
          "the mean span of a continuous deck [R], DAMPING_SPAN_RULE)", recalled=False,
          applies="input", limits=PERCENT),
    Entry("damping_steel_composite_slope", 0.125, "% per m", _T66,
          "increase per metre below L = 20 m, steel and composite", recalled=False,
          applies="input"),
    Entry("damping_prestressed_concrete", 1.0, "%", _T66,
          "lower-bound damping, prestressed concrete, L >= 20 m", recalled=False,
          applies="input", limits=PERCENT),
    Entry("damping_prestressed_concrete_slope", 0.07, "% per m", _T66,
          "increase per metre below L = 20 m, prestressed concrete", recalled=False,
          applies="input"),
    Entry("damping_filler_beam_reinforced_concrete", 1.5, "%", _T66,
          "lower-bound damping, filler beam and reinforced concrete, L >= 20 m",
          recalled=False, applies="input", limits=PERCENT),
    Entry("damping_filler_beam_reinforced_concrete_slope", 0.07, "% per m", _T66,
          "increase per metre below L = 20 m, filler beam and reinforced concrete",
          recalled=False, applies="input"),
    Entry("additional_damping_max_span", 30.0, "m", "EN 1991-2 6.4.6.3.1(3)",
          "spans below which the additional damping dzeta of moving-force analyses applies",
          applies="input"),
    # -------------------------------------------------------- L_Phi, Phi_2 / Phi_3, phi''
    Entry("determinant_length_k2", 1.2, "1", _T62,
          "L_Phi = k L_m of a continuous deck of 2 spans", limits=AT_LEAST_ONE),
    Entry("determinant_length_k3", 1.3, "1", _T62,
          "L_Phi = k L_m of a continuous deck of 3 spans", limits=AT_LEAST_ONE),
    Entry("determinant_length_k4", 1.4, "1", _T62,
          "L_Phi = k L_m of a continuous deck of 4 spans", limits=AT_LEAST_ONE),
    Entry("determinant_length_k5", 1.5, "1", _T62,
          "L_Phi = k L_m of a continuous deck of 5 or more spans", limits=AT_LEAST_ONE),
    Entry("phi2_a", 1.44, "m^0.5", _PHI,
          "Phi_2 = a / (sqrt(L_Phi) - 0.2) + b (carefully maintained track): a"),
    Entry("phi2_b", 0.82, "1", _PHI, "Phi_2: b"),
    Entry("phi2_max", 1.67, "1", _PHI, "Phi_2 upper bound (lower bound 1.00)", limits=AT_LEAST_ONE),
    Entry("phi3_a", 2.16, "m^0.5", _PHI,
          "Phi_3 = a / (sqrt(L_Phi) - 0.2) + b (standard maintenance): a"),
    Entry("phi3_b", 0.73, "1", _PHI, "Phi_3: b"),
    Entry("phi3_max", 2.00, "1", _PHI, "Phi_3 upper bound (lower bound 1.00)", limits=AT_LEAST_ONE),
    Entry("irregularity_allowance_speed", 22.0, "m s-1", _ANNEX_C,
          "phi'' = a [c1 exp(-(L/10)^2) + c2 (n0 L / 80 - 1) exp(-(L/20)^2)], "
          "a = min(v / this speed, 1)"),
    Entry("irregularity_allowance_c1", 0.56, "1", _ANNEX_C, "phi'': c1"),
    Entry("irregularity_allowance_c2", 0.50, "1", _ANNEX_C, "phi'': c2"),
    # ---------------------------------------------------------------------------- LM71
    Entry("lm71_axle_load", 250e3, "N", _LM71, "LM71: each of the four point forces Q_vk"),
    Entry("lm71_axle_spacing", 1.6, "m", _LM71,
          "LM71: spacing of the four point forces (zone of 4 spacings, centred on them)"),
    Entry("lm71_udl", 80e3, "N m-1", _LM71,
          "LM71: distributed load q_vk outside the zone, where unfavourable"),
    Entry("lm71_factor_several_tracks", 1.0, "1", "EN 1991-2 6.8.1, Table 6.11",
          "LM71 (x alpha) on each loaded track when several tracks are loaded (the study's "
          "trains on other tracks, train.other_trains): full value on two tracks",
          limits=Limits(gt=0.0, le=1.0)),
    Entry("classification_factor_min", 0.75, "1", "EN 1991-2 6.3.2(3)",
          "smallest load classification factor alpha (study.classification_factor)",
          applies="input", limits=Limits(gt=0.0, le=2.0)),
    Entry("classification_factor_max", 1.46, "1", "EN 1991-2 6.3.2(3)",
          "largest load classification factor alpha (study.classification_factor)",
          applies="input", limits=Limits(gt=0.0, le=2.0)),
    # ---------------------------------------------------------------- HSLM applicability
    Entry("hslm_b_max_span", 7.0, "m", _HSLM,
          "HSLM-B for simply supported spans below this; HSLM-A at and above it and for "
          "continuous decks", applies="input"),
    Entry("hslm_b_N_min", 10, "1", _FIG613, "HSLM-B: fewest point forces N", applies="input",
          integer=True),
    Entry("hslm_b_N_max", 20, "1", _FIG613, "HSLM-B: most point forces N", applies="input",
          integer=True),
    Entry("hslm_b_d_min", 2.5, "m", _FIG613, "HSLM-B: smallest spacing d", applies="input"),
    Entry("hslm_b_d_max", 3.5, "m", _FIG613, "HSLM-B: largest spacing d", applies="input"),
    Entry("hslm_b_load", 170e3, "N", _FIG613, "HSLM-B: each point force", applies="fixed",
          note="part of the HSLM-B model: give another train (train.axles) instead"),
    # ------------------------------------------------ train signatures (DER / LIR)
    Entry("signature_wavelength_min", 4.0, "m", _SIGNATURE,
          "shortest wavelength lambda = v / f0 of the comparison of a train's signature "
          "with the HSLM-A envelope"),
    Entry("signature_wavelength_max", 20.0, "m", _SIGNATURE,
          "longest wavelength of the comparison with the HSLM-A envelope"),
    Entry("signature_damping", 0.01, "1", _SIGNATURE,
          "damping ratio of the signatures when none is given (vsi trains --signature)",
          limits=FRACTION),
    Entry("signature_ratio_limit", 1.0, "1", _SIGNATURE,
          "a train is covered by HSLM-A when its DER signature stays below this times "
          "the HSLM-A envelope at every wavelength of the range", limits=POSITIVE),
    # ------------------------------------------------------------- fatigue (steel)
    Entry("fatigue_slope_m1", 3.0, "1", _SN,
          "slope m of the S-N curve up to the constant-amplitude fatigue limit",
          limits=Limits(gt=None, ge=1.0, le=20.0)),
    Entry("fatigue_slope_m2", 5.0, "1", _SN,
          "slope m between the constant-amplitude fatigue limit and the cut-off limit",
          limits=Limits(gt=None, ge=1.0, le=20.0)),
    Entry("fatigue_reference_cycles", 2e6, "1", _SN,
          "N_C: cycles of the detail category Delta sigma_C"),
    Entry("fatigue_constant_amplitude_cycles", 5e6, "1", _SN,
          "N_D: cycles of the constant-amplitude fatigue limit Delta sigma_D"),
    Entry("fatigue_cutoff_cycles", 1e8, "1", _SN,
          "N_L: cycles of the cut-off limit Delta sigma_L (smaller ranges do no damage)"),
    Entry("fatigue_gamma_Ff", 1.0, "1", "EN 1993-2 9.3(1)",
          "partial factor of the fatigue loads gamma_Ff (default of "
          "fatigue.sections.gamma_Ff)", applies="input", limits=PARTIAL_FACTOR),
    Entry("fatigue_gamma_Mf", 1.35, "1", "EN 1993-1-9 3(7), Table 3.1",
          "partial factor of the fatigue strength gamma_Mf (safe life, high consequence; "
          "default of fatigue.sections.gamma_Mf)", applies="input", limits=PARTIAL_FACTOR),
    # ------------------------------------------------ fatigue (headed stud connectors)
    Entry("fatigue_stud_category", 90.0, "MPa", _SN_STUD,
          "reference shear strength Delta tau_c of headed studs at N_C = 2e6 cycles "
          "(normal-weight concrete)"),
    Entry("fatigue_stud_slope", 8.0, "1", _SN_STUD,
          "slope m of the S-N curve of headed studs (one slope, no cut-off)",
          limits=Limits(gt=None, ge=1.0, le=20.0)),
    Entry("fatigue_stud_gamma_Mf", 1.0, "1", "EN 1994-2 2.4.1.2(6)",
          "partial factor of the fatigue strength of headed studs gamma_Mf,s (default of "
          "fatigue.studs.gamma_Mf)", applies="input", limits=PARTIAL_FACTOR),
    Entry("fatigue_lambda_1", 0.65, "1", _LAMBDA + ", Table 9.3",
          "lambda_1 (span and traffic mix): about 0.65 for a 20 m simply supported span "
          "under the standard mix; read Table 9.3 for the span and override"),
    Entry("fatigue_lambda_3", 1.0, "1", _LAMBDA + "(6)",
          "lambda_3 = (design life / 100 years)^(1/5) is computed from "
          "fatigue.design_life_years; this factor multiplies it (1: as the formula)"),
    Entry("fatigue_lambda_4", 1.0, "1", _LAMBDA + "(7)",
          "lambda_4: more than one track loaded (1.0 for a single track)"),
    Entry("fatigue_lambda_max", 1.4, "1", _LAMBDA + "(2)",
          "upper bound lambda_max of lambda = lambda_1 lambda_2 lambda_3 lambda_4",
          limits=AT_LEAST_ONE),
    Entry("fatigue_lambda_volume", 25e6, "t", _LAMBDA + "(5)",
          "lambda_2 = (traffic per track / this volume per year)^(1/5)"),
    Entry("compatibility_speed_factor", 1.1, "1",
          "TSI INF 4.2.8.1.3 / IG02042 practice; EN 1991-2 6.4.6.2",
          "a real train on an existing bridge is checked up to this times the line speed "
          "(new designs: 1.2 x the line speed, EN 1991-2 6.4.6.2(1))", applies="input",
          limits=Limits(gt=None, ge=1.0, le=2.0)),
    Entry("fatigue_free_vibration_decay", 0.01, "1", "EN 1991-2 6.4.6.6(2)",
          "free vibration after each train is simulated until its amplitude has decayed "
          "to this fraction of the amplitude at the exit of the last axle", limits=FRACTION),
)

#: Keys of :data:`TABLE`, in table order.
KEYS = tuple(e.key for e in TABLE)


def limits_of(key: str) -> Limits:
    """The limits of entry ``key`` (those of the keys of a configuration that stand for
    it, e.g. ``fatigue.sections[].gamma_Mf`` for ``fatigue_gamma_Mf``)."""
    for e in TABLE:
        if e.key == key:
            return e.limits
    raise KeyError(f"code profile has no entry {key!r}")
#: Pairs (lower, upper) of entries that must stay ordered.
ORDERED = (
    ("comfort_very_good", "comfort_good"),
    ("comfort_good", "comfort_acceptable"),
    ("classification_factor_min", "classification_factor_max"),
    ("hslm_b_N_min", "hslm_b_N_max"),
    ("hslm_b_d_min", "hslm_b_d_max"),
    ("twist_limit_above_200", "twist_limit_up_to_200"),
    ("twist_limit_up_to_200", "twist_limit_up_to_120"),
    ("comfort_deflection_factor_two_spans", "comfort_deflection_factor_continuous"),
    ("signature_wavelength_min", "signature_wavelength_max"),
    ("fatigue_reference_cycles", "fatigue_constant_amplitude_cycles"),
    ("fatigue_constant_amplitude_cycles", "fatigue_cutoff_cycles"),
)


@dataclass(frozen=True)
class CodeProfile:
    """A code profile: :data:`TABLE` with the overrides of a configuration applied.

    ``profile[key]`` is the value (float, or int for counts); :meth:`entry` the whole
    :class:`Entry`; :attr:`overridden` the keys a configuration set.
    """

    name: str
    entries: tuple[Entry, ...]

    def __getitem__(self, key: str):
        e = self.entry(key)
        return int(e.value) if e.integer else float(e.value)

    def entry(self, key: str) -> Entry:
        """The entry ``key`` (KeyError naming the known keys otherwise)."""
        for e in self.entries:
            if e.key == key:
                return e
        raise KeyError(f"code profile has no entry {key!r}; expected one of {', '.join(KEYS)}")

    def clause(self, *keys: str) -> str:
        """The clause(s) of ``keys`` without the [R] tag (distinct, in order), with
        "(override)" after the source of an overridden entry."""
        out: list[str] = []
        for k in keys:
            e = self.entry(k)
            text = f"{e.clause} (override)" if e.overridden else e.clause
            if text not in out:
                out.append(text)
        return "; ".join(out)

    @property
    def overridden(self) -> tuple[str, ...]:
        """Keys set by the configuration."""
        return tuple(e.key for e in self.entries if e.overridden)

    def summary(self) -> str:
        """One line: the name and the overrides (``key = value``)."""
        if not self.overridden:
            return f"code profile: {self.name}"
        parts = [f"{k} = {self.entry(k).value:g}" for k in self.overridden]
        return f"code profile: {self.name}; overrides: {', '.join(parts)}"

    def rows(self) -> list[dict]:
        """The table as rows: key, value, unit, clause, recalled ("[R]" or ""), default,
        default_clause, overridden (bool), applies, description."""
        return [{"key": e.key, "value": e.value, "unit": e.unit, "clause": e.clause,
                 "recalled": RECALLED if e.recalled else "", "default": e.default,
                 "default_clause": e.default_clause, "overridden": e.overridden,
                 "applies": e.applies, "description": e.description} for e in self.entries]


def _with_defaults() -> tuple[Entry, ...]:
    return tuple(replace(e, default=e.value, default_clause=e.clause) for e in TABLE)


@lru_cache(maxsize=1)
def default_profile() -> CodeProfile:
    """The recommended values (:data:`DEFAULT_NAME`)."""
    return CodeProfile(DEFAULT_NAME, _with_defaults())


def override_value(given):
    """``(value, clause)`` of one override as written: a number, or a table
    ``{value = ..., clause = "..."}``; ``(None, None)`` when neither."""
    if isinstance(given, Mapping):
        clause = given.get("clause")
        return _number(given.get("value")), clause if isinstance(clause, str) else None
    return _number(given), None


def _number(v):
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    try:
        return float(v) if math.isfinite(float(v)) else None
    except OverflowError:
        return None


def profile_from(section) -> CodeProfile:
    """The profile of a ``code_profile`` section (as stored: ``name``, ``overrides``).

    The section has been validated when the configuration was read
    (:mod:`vsi_numba.config.code_profile`); here unknown keys, fixed entries,
    non-numbers and values outside an entry's :attr:`Entry.limits` are skipped, so a
    damaged stored configuration gives the recommended value of those entries rather
    than an error.  None or an empty section: the default.
    """
    if not isinstance(section, Mapping) or not section:
        return default_profile()
    name = section.get("name")
    name = name.strip() if isinstance(name, str) and name.strip() else DEFAULT_NAME
    overrides = section.get("overrides")
    overrides = overrides if isinstance(overrides, Mapping) else {}
    entries = []
    for e in _with_defaults():
        if e.key in overrides and e.applies != "fixed":
            value, clause = override_value(overrides[e.key])
            if value is not None and value in e.limits:  # else: a damaged entry
                source = clause or (name if name != DEFAULT_NAME else "configuration")
                e = replace(e, value=int(value) if e.integer else value, overridden=True,
                            recalled=False, clause=source)
        entries.append(e)
    if name == DEFAULT_NAME:
        if not any(e.overridden for e in entries):
            return default_profile()
        name = f"{DEFAULT_NAME}, with the configuration's overrides"
    return CodeProfile(name, tuple(entries))


def of_config(config) -> CodeProfile:
    """The profile of a stored (resolved) configuration mapping."""
    if not isinstance(config, Mapping):
        return default_profile()
    return profile_from(config.get("code_profile"))


def resolve(profile) -> CodeProfile:
    """``profile`` itself, the default for None, or the profile of a stored section."""
    if profile is None:
        return default_profile()
    if isinstance(profile, CodeProfile):
        return profile
    return profile_from(profile)


# --------------------------------------------------------------- EN 1991-2 Annex D
#: Clause of the fatigue train types and traffic mixes.
ANNEX_D_CLAUSE = "EN 1991-2 Annex D, D.3, Table D.1 (types), Tables D.2-D.4 (mixes)"
#: Fatigue train types of EN 1991-2 Annex D [R]: type -> (description, total load
#: Sum Q (kN), maximum speed (km/h), length first to last axle... (m)).  The totals,
#: speeds and lengths are recalled (their ratio reproduces the q = Sum Q / L column of
#: Table D.1); the axle layouts of Fig. D.1 were not re-read: the builder
#: (:mod:`vsi_numba.model.library.annex_d`) reconstructs each train from the vehicles
#: listed in :data:`ANNEX_D_LAYOUT` scaled to these totals.
ANNEX_D_TYPES = {
    1: ("locomotive-hauled passenger train", 6630.0, 200.0, 262.10),
    2: ("locomotive-hauled passenger train", 5300.0, 160.0, 281.10),
    3: ("high-speed passenger train", 9400.0, 250.0, 385.52),
    4: ("high-speed passenger train", 5100.0, 250.0, 237.60),
    5: ("locomotive-hauled freight train", 21600.0, 80.0, 270.30),
    6: ("locomotive-hauled freight train", 14310.0, 100.0, 333.10),
    7: ("locomotive-hauled freight train", 10350.0, 120.0, 196.50),
    8: ("locomotive-hauled freight train", 10350.0, 100.0, 212.50),
    9: ("suburban multiple unit", 2960.0, 120.0, 134.80),
    10: ("underground", 3600.0, 120.0, 129.60),
    11: ("locomotive-hauled freight train, 25 t axles", 11350.0, 120.0, 198.50),
    12: ("locomotive-hauled freight train, 25 t axles", 11350.0, 100.0, 212.50),
}
#: Reconstructed layouts: type -> (locomotives: (count, axles, axle load kN,
#: length over buffers m), cars: (count, axles), wheelbase of a bogie m).  The cars'
#: axle load and length follow from the totals of :data:`ANNEX_D_TYPES`.
ANNEX_D_LAYOUT = {
    1: ((1, 4, 225.0, 19.0), (11, 4), 2.5),
    2: ((1, 4, 225.0, 19.0), (10, 4), 2.5),
    3: ((2, 4, 200.0, 20.0), (14, 4), 2.5),
    4: ((2, 4, 170.0, 20.0), (8, 4), 2.5),
    5: ((2, 6, 225.0, 20.0), (21, 4), 1.8),
    6: ((1, 6, 225.0, 20.0), (15, 4), 1.8),
    7: ((1, 4, 225.0, 19.0), (11, 4), 1.8),
    8: ((1, 4, 225.0, 19.0), (11, 4), 1.8),
    9: ((0, 0, 0.0, 0.0), (6, 4), 2.5),
    10: ((0, 0, 0.0, 0.0), (8, 4), 2.2),
    11: ((1, 4, 250.0, 19.0), (11, 4), 1.8),
    12: ((1, 4, 250.0, 19.0), (11, 4), 1.8),
}
#: Traffic mixes of EN 1991-2 Annex D [R]: name -> {train type: trains per day}
#: (about 25 million tonnes per year and track each).
ANNEX_D_MIXES = {
    "standard": {1: 12, 2: 12, 3: 5, 4: 5, 5: 7, 6: 12, 7: 8, 8: 6},
    "heavy": {5: 6, 6: 13, 11: 16, 12: 16},
    "light": {1: 10, 2: 5, 5: 2, 9: 190},
}


# ------------------------------------------------------------ EN 1990 A2, Fig. A2.3
#: Clause of the passenger-comfort deflection limit.
COMFORT_DEFLECTION_CLAUSE = "EN 1990 A2.4.4.3.2, Fig. A2.3"
#: Fig. A2.3 of EN 1990 A2 [R]: the largest permissible vertical deflection delta of a
#: railway bridge for a car-body vertical acceleration b_v = 1.0 m/s2 ("very good"), as
#: the least L/delta against the span L, one curve per speed V: V (km/h) -> points
#: ((L m, L/delta), ...), L ascending.  The figure is drawn for a succession of three or
#: more simply supported spans; the factors of A2.4.4.3.2(6) (the ``comfort_deflection_
#: factor_*`` entries of :data:`TABLE`) adapt it to other decks, and for another level
#: of comfort the L/delta is divided by b_v (m/s2) (A2.4.4.3.2(5)).  Between two points
#: the limit is linear in L, between two curves linear in V
#: (:func:`comfort_deflection_ratio`).  The points are a reading of the figure recalled
#: and not re-read against the primary text: every point is [R], those of the curves for
#: V >= 250 km/h the least certain.  Check them against the figure before relying on
#: the comfort verdict.
COMFORT_DEFLECTION_CURVES: dict[float, tuple[tuple[float, float], ...]] = {
    120.0: ((0.0, 800.0), (10.0, 800.0), (22.0, 900.0), (35.0, 600.0), (120.0, 600.0)),
    160.0: ((0.0, 900.0), (12.0, 900.0), (29.0, 1200.0), (63.0, 600.0), (120.0, 600.0)),
    200.0: ((0.0, 1000.0), (14.0, 1000.0), (37.0, 1550.0), (90.0, 600.0), (120.0, 600.0)),
    220.0: ((0.0, 1200.0), (17.0, 1200.0), (40.0, 1700.0), (102.0, 600.0), (120.0, 600.0)),
    250.0: ((0.0, 1400.0), (20.0, 1400.0), (44.0, 1950.0), (118.0, 600.0), (120.0, 600.0)),
    280.0: ((0.0, 1500.0), (22.0, 1500.0), (48.0, 2200.0), (120.0, 900.0)),
    300.0: ((0.0, 1600.0), (24.0, 1600.0), (51.0, 2400.0), (120.0, 1200.0)),
    350.0: ((0.0, 1800.0), (28.0, 1800.0), (57.0, 2800.0), (120.0, 1700.0)),
}


class ComfortDeflectionRatio(NamedTuple):
    """The least L/delta of Fig. A2.3 at one span and speed (:func:`comfort_deflection_ratio`).

    ``ratio``: the figure's L/delta at (L, V) for b_v = 1 m/s2 (NaN when out of the
    figure); ``note``: how it was read (the curves used), or why there is none.
    """

    ratio: float
    note: str


def comfort_deflection_ratio(span: float, speed_kmh: float, profile=None,
                             curves=None) -> ComfortDeflectionRatio:
    """The least L/delta of EN 1990 A2 Fig. A2.3 (b_v = 1 m/s2, before the factors of
    A2.4.4.3.2(6)) at the span ``span`` (m) and speed ``speed_kmh`` (km/h).

    Linear in L between the points of a curve, linear in V between the two curves that
    bracket ``speed_kmh``.  Below the slowest curve the slowest is taken (a lower speed
    needs no more: the safe side); above the fastest, or for a span beyond
    ``comfort_deflection_max_span``, the figure does not give a value (NaN, ``note``
    says why).

    Parameters
    ----------
    span : float
        Span L (m), > 0.
    speed_kmh : float
        Speed V (km/h), > 0.
    profile : CodeProfile, optional
        For ``comfort_deflection_max_span`` (default: the recommended values).
    curves : mapping, optional
        Speed -> points, as :data:`COMFORT_DEFLECTION_CURVES` (the default).
    """
    p = resolve(profile)
    curves = COMFORT_DEFLECTION_CURVES if curves is None else curves
    L, v = float(span), float(speed_kmh)
    if not (math.isfinite(L) and L > 0 and math.isfinite(v) and v > 0):
        raise ValueError(f"span = {span!r} m, speed = {speed_kmh!r} km/h: expected both > 0")
    max_span = p["comfort_deflection_max_span"]
    if L > max_span:
        return ComfortDeflectionRatio(math.nan, f"the span {L:g} m is longer than the "
                                      f"{max_span:g} m of Fig. A2.3: special analysis needed")
    speeds = sorted(float(s) for s in curves)
    if v > speeds[-1]:
        return ComfortDeflectionRatio(math.nan, f"the speed {v:g} km/h is above the "
                                      f"fastest curve of Fig. A2.3 ({speeds[-1]:g} km/h)")

    def at(s):
        pts = curves[s]
        xs, ys = [q[0] for q in pts], [q[1] for q in pts]
        return _interp(L, xs, ys)

    if v <= speeds[0]:
        note = (f"curve V = {speeds[0]:g} km/h" if v == speeds[0] else
                f"curve V = {speeds[0]:g} km/h, the slowest of the figure (V = {v:g} km/h "
                "is below it: the safe side)")
        return ComfortDeflectionRatio(at(speeds[0]), note)
    for lo, hi in zip(speeds[:-1], speeds[1:], strict=True):
        if lo < v <= hi:
            if v == hi:
                return ComfortDeflectionRatio(at(hi), f"curve V = {hi:g} km/h")
            t = (v - lo) / (hi - lo)
            return ComfortDeflectionRatio((1.0 - t) * at(lo) + t * at(hi),
                                          f"linear between the curves V = {lo:g} and "
                                          f"{hi:g} km/h")
    raise AssertionError("unreachable")  # pragma: no cover


def _interp(x: float, xs, ys) -> float:
    """Linear interpolation of (xs, ys) at x (xs ascending; constant beyond the ends)."""
    if x <= xs[0]:
        return float(ys[0])
    for i in range(1, len(xs)):
        if x <= xs[i]:
            t = (x - xs[i - 1]) / (xs[i] - xs[i - 1])
            return float(ys[i - 1] + t * (ys[i] - ys[i - 1]))
    return float(ys[-1])


# ---------------------------------------------------- EN 1991-2 Table 6.6: the span L
#: The span L of EN 1991-2 Table 6.6 (the lower-bound damping, ``damping_ratio =
#: "EN1991-2"``) and of the additional damping of 6.4.6.3.1(3) [R]: the span of a simply
#: supported deck; for a continuous deck, the **mean** of its spans.  The one place the
#: rule is stated; configurations, docs and reports refer to it.
DAMPING_SPAN_RULE = ("L of EN 1991-2 Table 6.6 and 6.4.6.3.1(3): the span of a simply "
                     "supported deck, the mean span of a continuous deck [R]")


def damping_span(spans) -> float:
    """The span L (m) of EN 1991-2 Table 6.6 for a deck of ``spans`` (m):
    :data:`DAMPING_SPAN_RULE`."""
    import numpy as np

    return float(np.mean(np.asarray(spans, float)))
