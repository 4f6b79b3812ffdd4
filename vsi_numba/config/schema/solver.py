"""The keys of ``[solver]``, ``[contact]`` and ``[track]``, and their rules between keys."""

from typing import ClassVar, Literal

from pydantic import model_validator

from vsi_numba.config.schema._fields import (
    Int,
    Num,
    PosNum,
    Section,
    key,
    one_of,
    rule_error,
)
from vsi_numba.model import distribution as _dist
from vsi_numba.model import track as _track
from vsi_numba.solver.settings import BOUNDS, CONTACT_MODELS, SolverSettings

# ------------------------------------------------------------------- [solver] [contact]

def _b(name):
    """The bounds of a solver setting (:data:`vsi_numba.solver.settings.BOUNDS`)."""
    b = BOUNDS[name]
    return {k: getattr(b, k) for k in ("gt", "ge", "lt", "le")}


class Solver(Section):
    """``[solver]``: the time integration (HHT-alpha with contact iterations) and the
    escapes from the checks."""

    TABLE: ClassVar[str] = "a table [solver] (dt, hht_alpha, ...)"
    #: the escapes, never listed in the hints of an unknown key
    HIDDEN: ClassVar[frozenset] = frozenset(
        {"allow_coarse_dt", "allow_implausible", "allow_large_problem"})

    dt: Num(**_b("dt")) = key(
        SolverSettings.dt, unit="s", doc="time step",
        default_text="1e-3, halved until the highest bridge mode within the cut-off has 10 "
                     "steps per period", expected="a time step > 0 s")
    hht_alpha: Num(**_b("hht_alpha")) = key(SolverSettings.hht_alpha, doc="HHT-alpha "
                                            "numerical damping", expected="-1/3 <= hht_alpha "
                                                                          "<= 0")
    approach: Num(**_b("approach")) = key(SolverSettings.approach, unit="m",
                                          doc="track ahead of the bridge where the first "
                                              "axle starts",
                                          expected="a length of approach track >= 0 m")
    free_vibration: Num(**_b("free_vibration")) = key(
        SolverSettings.free_vibration, unit="s",
        doc="simulated after the last axle leaves the bridge", expected="a duration >= 0 s")
    max_iterations: Int(**_b("max_iterations")) = key(
        SolverSettings.max_iterations, doc="contact active-set iterations per step",
        expected="an integer 1 <= max_iterations <= 10000")
    max_subdivisions: Int(**_b("max_subdivisions")) = key(
        SolverSettings.max_subdivisions, doc="halvings of a step whose contact iterations "
                                             "fail",
        expected="an integer 0 <= max_subdivisions <= 30")
    acceleration_cutoff: Num(**_b("acceleration_cutoff")) = key(
        None, unit="Hz", default_text="EN 1990 A2 max(30 Hz, 1.5 f1, f3)",
        doc="highest mode in the deck accelerations", expected="a frequency > 0 Hz")
    allow_coarse_dt: bool = key(False, doc="run with fewer than 4 time steps per period of "
                                           "a retained frequency (warned)")
    allow_implausible: bool = key(False, doc="run implausible physical input (deflection, "
                                             "penetration, profile amplitude, ...; warned)")
    allow_large_problem: bool = key(False, doc="run beyond the memory/time budget")


#: contact.hertz_coefficient: > 0, and < 1 (a G of 1 m N^-2/3 is a typo)
HERTZ_MAX = 1.0


class Contact(Section):
    """``[contact]``: the wheel-rail contact."""

    TABLE: ClassVar[str] = "a table [contact] with model = 'rigid'"

    model: one_of(CONTACT_MODELS) = key("rigid", doc="contact model")
    hertz_coefficient: Num(gt=0, lt=HERTZ_MAX) = key(
        None, unit="m N^-2/3", default_text="required for Hertz",
        doc="G of delta = G N^(2/3), per contact force as the model carries it (axle)",
        expected="a Hertz constant G > 0 m N^-2/3 (about 4e-8 for a wheel on a rail)")

    @model_validator(mode="after")
    def _hertz_needs_its_constant(self):
        if self.model != "rigid" and self.hertz_coefficient is None:
            from vsi_numba.config.schema._fields import expected_of

            raise rule_error("contact.hertz_coefficient: missing required key; expected "
                             + expected_of(Contact, "hertz_coefficient"))
        return self


# ------------------------------------------------------------------------------ [track]

class Track(Section):
    """``[track]``: the rail on its foundation over the deck and the approaches, and the
    distribution of moving forces (not with ``[bridge.track]``)."""

    TABLE: ClassVar[str] = "a table [track] of track values"

    model: Literal["elastic", "rigid"] = key(
        "elastic", doc="elastic: the rail on a Winkler foundation; rigid: the rigid-track "
                       "idealisation (a kink at the deck ends)")
    foundation_stiffness: PosNum = key(
        _track.FOUNDATION_DEFAULT, unit="N/m per m",
        doc="foundation modulus per metre of track, both rails (150 kN/mm under one axle "
            "with UIC60 rails)",
        expected="a foundation modulus > 0 N/m per metre of track (both rails; about "
                 "3e7 .. 3e8)")
    rail_EI: PosNum = key(_track.RAIL_EI_UIC60, unit="N m^2", doc="bending stiffness of both "
                          "rails (2 x UIC60)",
                          expected="a bending stiffness of both rails > 0 N m^2 (1.283e7 "
                                   "for two UIC60 rails)")
    foundation_damping: Num(ge=0, le=2e6) = key(
        _track.FOUNDATION_DAMPING_DEFAULT, unit="N s/m per m",
        doc="damping of the foundation (pads and ballast)",
        expected="a foundation damping >= 0 and <= 2e6 N s/m per metre of track (both "
                 f"rails; {_track.FOUNDATION_DAMPING_DEFAULT:.3g} for ballasted track, 0 "
                 "for an elastic foundation)")
    rail_mass: Num(ge=0, le=2000) = key(
        0.0, unit="kg/m", doc="mass per metre of track moving with the rail",
        expected="a mass >= 0 and <= 2000 kg per metre of track moving with the rail (both "
                 "rails; 120 for two UIC60 rails, 0 for a massless rail)")
    load_distribution: one_of(_dist.LOAD_DISTRIBUTIONS) = key(
        "none", doc="how the track spreads moving forces onto the deck: none, rail (EN "
                    "1991-2 6.3.6.1 [R]), rail_ballast (and 4:1 through the ballast, "
                    "6.3.6.2 [R]), elastic_track (the foundation reaction)")
    sleeper_spacing: Num(gt=0, le=2.0) = key(
        _dist.SLEEPER_SPACING_DEFAULT, unit="m",
        doc="sleeper spacing (rail, rail_ballast, elastic_track)",
        expected="a sleeper spacing > 0 and <= 2 m (0.6 usual)")
    sleeper_width: Num(ge=0, le=1.0) = key(
        _dist.SLEEPER_WIDTH_DEFAULT, unit="m", doc="sleeper width at its base (rail_ballast)",
        expected="a sleeper bottom width >= 0 and <= 1 m (about 0.3)")
    ballast_depth: Num(ge=0, le=2.0) = key(
        _dist.BALLAST_DEPTH_DEFAULT, unit="m", doc="ballast depth under the sleepers "
                                                   "(rail_ballast)",
        expected="a ballast depth under the sleepers >= 0 and <= 2 m (0.3-0.5 usual)")

    @model_validator(mode="after")
    def _elastic_track_needs_the_foundation(self):
        if self.load_distribution == "elastic_track" and self.model == "rigid":
            raise rule_error(
                "track.load_distribution = \"elastic_track\": expected 'none', 'rail' or "
                "'rail_ballast' with track.model = 'rigid' ('elastic_track' spreads the "
                "forces by the rail on the elastic foundation)")
        return self
