"""The configuration's keys, declared once: one model per TOML table.

Each field is one key: its type and bounds (the annotation), default, unit, description
and the expectation of its error message (:func:`~._fields.key`).  Tables with a ``kind``
(``[bridge]``, ``[[train.vehicles]]``, ``[irregularity]``, ``[[irregularity.defects]]``)
are unions of one model per kind.  :class:`VsiConfig` is the whole file.  The models of
the tables live beside this module, one module per part of the file (:mod:`.bridge`,
:mod:`.train`, :mod:`.irregularity`, :mod:`.solver` with ``[contact]`` and ``[track]``,
:mod:`.study`, :mod:`.codes` with ``[report]``, ``[code_profile]``, ``[fatigue]`` and
``[compatibility]``); the existing-bridge tables are here; every model is imported from
here.

Adding a key: add one field to the model of its table (and read it where it is used);
the JSON Schema, the key reference of the documentation, the ``vsi init`` template and
the unknown-key checks follow (``python -m vsi_numba.config.schema.generate`` rewrites
the committed files, a test says when they are stale).  Adding a table: a model here and
a field of :class:`VsiConfig`.
"""

# ruff: noqa: F401 (the models of every table, imported from here)
from typing import Annotated, Any, ClassVar

from pydantic import Field, model_validator

from vsi_numba.config.schema._fields import (
    MISSING,
    Int,
    Matrix,
    Num,
    PosNum,
    Section,
    Speed,
    Text,
    key,
    one_of,
    rule,
    rules_here,
)
from vsi_numba.config.schema.bridge import (
    Bridge,
    BridgeTrack,
    Continuous,
    Damping,
    DofPattern,
    ImportedTrack,
    Matrices,
    ModesFile,
    PerSpan,
    Points,
    Rigid,
    SimplySupported,
    Torsion,
    TrackLine,
)
from vsi_numba.config.schema.codes import (
    FATIGUE_MODELS,
    MAX_TEXT,
    CodeProfile,
    Compatibility,
    Fatigue,
    FatigueSection,
    FatigueStud,
    FatigueTraffic,
    Overrides,
    Report,
    SourcedValue,
)
from vsi_numba.config.schema.irregularity import (
    CosineDefect,
    CosineIrregularity,
    Defect,
    FileIrregularity,
    Irregularity,
    NoIrregularity,
    PsdIrregularity,
    StepDefect,
    StepIrregularity,
)
from vsi_numba.config.schema.solver import HERTZ_MAX, Contact, Solver, Track
from vsi_numba.config.schema.study import SpeedGrid, Study
from vsi_numba.config.schema.train import (
    DIRECTIONS,
    MAX_OTHER_OFFSET,
    Axles,
    BumpStop,
    CarVehicle,
    DamperBlowoff,
    ForceVehicle,
    HslmB,
    OtherTrain,
    SprungMassVehicle,
    Train,
    UserVehicle,
    Vehicle,
)
from vsi_numba.model.irregularity import SPEED_BOUND_KMH

# ------------------------------------------------- existing bridges: [calibration], [reliability]

#: Prior and input distributions of [calibration] and [reliability].
DISTRIBUTIONS = ("uniform", "normal", "lognormal")
#: Quantities a measured record may hold.
RECORD_QUANTITIES = ("deck_acceleration", "deck_displacement")
#: Checks whose probability of exceedance [reliability] estimates.
RELIABILITY_CHECKS = ("deck_acceleration", "deck_displacement")
#: Estimators of [reliability].
RELIABILITY_METHODS = ("subset", "monte_carlo")
#: The parameters each distribution takes.
NEEDS = {"uniform": ("lower", "upper"), "normal": ("mean", "std"),
         "lognormal": ("median", "cov")}
#: Largest number of parameters (and of random variables).
MAX_PARAMETERS = 20
#: Largest number of records of a calibration.
MAX_RECORDS = 50
#: ``key`` is a field name of the tables below: the declaration under another name.
_declare = key
KeyPath = Annotated[str, Field(min_length=3, pattern=r"^[A-Za-z_]\w*(\[\d+\])?"
                               r"(\.[A-Za-z_]\w*(\[\d+\])?)+$")]


class _Distribution(Section):
    """The parameters of a distribution (which are needed depends on its kind)."""

    median: PosNum = _declare(None, doc="median (lognormal)", expected="a median > 0")
    cov: Num(gt=0, le=3) = _declare(None, doc="coefficient of variation (lognormal)",
                               expected="a coefficient of variation > 0 (at most 3)")
    mean: Num() = _declare(None, doc="mean (normal)", expected="a mean (a number)")
    std: PosNum = _declare(None, doc="standard deviation (normal)",
                      expected="a standard deviation > 0")
    lower: Num() = _declare(None, doc="lower bound (uniform)", expected="a lower bound")
    upper: Num() = _declare(None, doc="upper bound (uniform)", expected="an upper bound > lower")
    #: the key naming the distribution (``prior``, ``distribution``)
    KIND: ClassVar[str] = ""

    @model_validator(mode="after")
    def _the_parameters_of_its_kind(self):
        """The parameters its kind needs (and no others); a uniform's bounds in order."""
        kind = getattr(self, self.KIND)
        need = NEEDS[kind]
        problems = [(k, MISSING, f"the {k} of a {kind} distribution") for k in need
                    if getattr(self, k) is None]
        problems += [(k, getattr(self, k), f"no {k} for a {kind} distribution (it takes "
                      f"{' and '.join(need)})")
                     for k in sorted(set().union(*NEEDS.values()) - set(need))
                     if getattr(self, k) is not None]
        if not problems and kind == "uniform" and not self.lower < self.upper:
            problems = [("upper", self.upper, f"an upper bound > lower = {self.lower:g}")]
        if problems:
            raise rules_here(problems)
        return self


class CalibrationParameter(_Distribution):
    """``calibration.parameters[i]``: a numeric configuration key and its prior."""

    TABLE: ClassVar[str] = "a table {key, prior, ...}"
    KIND: ClassVar[str] = "prior"

    key: KeyPath = _declare(required=True, doc="the dotted key path of a numeric configuration "
                                          "key, e.g. bridge.EI or bridge.damping_ratio[0]",
                       expected="a dotted key path of a numeric key, e.g. \"bridge.EI\"",
                       example="bridge.EI")
    prior: one_of(DISTRIBUTIONS) = _declare(required=True, doc="prior distribution")


class CalibrationRecord(Section):
    """``[[calibration.records]]``: one measured passage."""

    TABLE: ClassVar[str] = "a table {file, quantity, point, train[, speed_kmh]}"

    file: Text = _declare(required=True, doc="CSV file with columns t (s) and value ('#' "
                                        "comments), relative to the configuration",
                     expected="a CSV file with columns t, value", example="passage_01.csv")
    quantity: one_of(RECORD_QUANTITIES) = _declare(required=True, doc="what the record measures "
                                                                 "(m s-2 or m, positive down)")
    point: Num(ge=0) = _declare(required=True, unit="m", doc="abscissa along the deck",
                           expected="a deck abscissa >= 0 m")
    track: Int(ge=1) = _declare(None, default_text="the train's track",
                           doc="track of the point (decks in space)",
                           expected="a track number >= 1")
    train: Text = _declare(required=True, doc="a library train (vsi trains) or an axle CSV file",
                      expected="a train name (vsi trains) or an axle CSV file",
                      example="HSLM-A1")
    speed_kmh: Speed = _declare(None, default_text="from the record (the model's best fit in "
                                                   "shape)", unit="km/h",
                           doc="train speed of the passage",
                           expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")


class Calibration(Section):
    """``[calibration]``: Bayesian updating of configuration keys from measured records
    (``vsi calibrate``)."""

    TABLE: ClassVar[str] = "a table [calibration] with parameters and records"

    parameters: Annotated[list[CalibrationParameter],
                          Field(min_length=1, max_length=MAX_PARAMETERS)] = _declare(
        required=True, doc="the keys to update, each with its prior",
        expected=f"a list of 1 to {MAX_PARAMETERS} tables {{key, prior, ...}}")
    records: Annotated[list[CalibrationRecord],
                       Field(min_length=1, max_length=MAX_RECORDS)] = _declare(
        required=True, doc="the measured passages",
        expected=f"1 to {MAX_RECORDS} [[calibration.records]] tables {{file, quantity, point, "
                 "train[, speed_kmh]}")
    noise_std: PosNum = _declare(None, default_text="a parameter of the calibration",
                            doc="standard deviation of the records' measurement noise (unit "
                                "of the records); absent: estimated with the parameters",
                            expected="a noise standard deviation > 0 (unit of the records)")
    sampler: one_of(("emcee",)) = _declare("emcee", doc="MCMC sampler (emcee: affine-invariant "
                                                   "ensemble)")
    n_samples: Int(ge=16, le=1_000_000) = _declare(
        4000, doc="posterior samples kept (walkers x steps after the burn-in)",
        expected="an integer number of samples, 16 .. 1e6")
    n_walkers: Int(ge=4, le=1000) = _declare(None, default_text="max(16, 4 x parameters)",
                                        doc="ensemble size (even, >= 2 x parameters)",
                                        expected="an even number of walkers, 4 .. 1000")
    burn_in: Int(ge=0, le=1_000_000) = _declare(None, default_text="as many steps as kept",
                                           doc="steps per walker discarded first",
                                           expected="an integer number of steps >= 0")
    seed: Int(ge=0) = _declare(0, doc="seed of the sampler (same seed, same posterior)",
                          expected="an integer seed >= 0")
    max_lag_s: PosNum = _declare(2.0, unit="s", doc="largest time shift of a record against the "
                                               "model searched for the alignment",
                            expected="a time shift > 0 s")
    line_speed_kmh: Speed = _declare(None, default_text="study.line_speed_kmh, else the fastest "
                                                   "record",
                                unit="km/h", doc="line speed of the deck-acceleration check "
                                                 "with the calibrated model (+10 %, +20 %)",
                                expected=f"a line speed > 0 km/h (at most "
                                         f"{SPEED_BOUND_KMH:g})")
    check_samples: Int(ge=10, le=100_000) = _declare(
        200, doc="posterior samples run for the check and the predictive records",
        expected="an integer number of samples, 10 .. 100000")

    @model_validator(mode="after")
    def _walkers_span_the_parameters(self):
        """An even number of walkers, at least 2 x the parameters (the noise one too
        when it is estimated)."""
        n = self.n_walkers
        n_dim = len(self.parameters) + (0 if self.noise_std is not None else 1)
        if n is not None and (n % 2 or n < 2 * n_dim):
            raise rule("calibration.n_walkers", n, f"an even number of walkers >= "
                       f"{2 * n_dim} (2 x the {n_dim} parameters)")
        return self


class ReliabilityVariable(_Distribution):
    """``reliability.variables[i]``: a numeric configuration key as a random variable."""

    TABLE: ClassVar[str] = "a table {key, distribution, ...}"
    KIND: ClassVar[str] = "distribution"

    key: KeyPath = _declare(required=True, doc="the dotted key path of a numeric configuration "
                                          "key, e.g. bridge.damping_ratio",
                       expected="a dotted key path of a numeric key, e.g. "
                                "\"bridge.damping_ratio\"", example="bridge.damping_ratio")
    distribution: one_of(DISTRIBUTIONS) = _declare(required=True, doc="its distribution")


class Reliability(Section):
    """``[reliability]``: the probability that a check is exceeded (``vsi reliability``)."""

    TABLE: ClassVar[str] = "a table [reliability] with check and variables"

    check: one_of(RELIABILITY_CHECKS) = _declare("deck_acceleration",
                                            doc="the check (its limit from the code profile "
                                                "or reliability.limit)")
    method: one_of(RELIABILITY_METHODS) = _declare("subset", doc="subset simulation (OpenTURNS) "
                                                           "or crude Monte Carlo")
    target_cov: Num(gt=0, lt=1) = _declare(0.1, doc="stop when the estimate's coefficient of "
                                               "variation is below this",
                                      expected="a coefficient of variation in (0, 1)")
    variables: Annotated[list[ReliabilityVariable],
                         Field(min_length=1, max_length=MAX_PARAMETERS)] = _declare(
        required=True, doc="the random inputs",
        expected=f"a list of 1 to {MAX_PARAMETERS} tables {{key, distribution, ...}}")
    limit: PosNum = _declare(None, default_text="the code profile's limit of the check",
                        doc="limit of the check (m s-2 or m)", expected="a limit > 0")
    max_runs: Int(ge=100, le=10_000_000) = _declare(
        100_000, doc="largest number of forward runs per estimate",
        expected="an integer number of runs, 100 .. 1e7")
    block_size: Int(ge=10, le=100_000) = _declare(
        1000, doc="runs per block (Monte Carlo) or per level (subset simulation)",
        expected="an integer number of runs, 10 .. 100000")
    seed: Int(ge=0) = _declare(0, doc="seed (same seed, same estimate)",
                          expected="an integer seed >= 0")

    @model_validator(mode="after")
    def _a_block_within_the_runs(self):
        if self.block_size > self.max_runs:
            raise rule("reliability.block_size", self.block_size,
                       f"at most reliability.max_runs = {self.max_runs}")
        return self


# ------------------------------------------------------------------------------- a file

class VsiConfig(Section):
    """A vsi_numba configuration file."""

    title: str = key(None, default_text="the file name", doc="title of results and report",
                     expected="a title (string)")
    bridge: Bridge = key(required=True, doc="the deck ([bridge])",
                         expected="a table [bridge] with kind, spans, EI, mass_per_length")
    train: Train = key(required=True, doc="the trains ([train])",
                       expected="a table [train] with preset, [[train.vehicles]] or file")
    irregularity: Irregularity = key(None, default_text="kind = \"none\"",
                                     doc="the track profile ([irregularity])")
    solver: Solver = key(None, default_text="the defaults", doc="the time integration "
                                                                "([solver])")
    contact: Contact = key(None, default_text="rigid", doc="the wheel-rail contact "
                                                           "([contact])")
    track: Track = key(None, default_text="elastic", doc="the track ([track])")
    study: Study = key(required=True, doc="the speeds and the output ([study])",
                       expected="a table [study] with speeds_kmh (km/h) or line_speed_kmh")
    report: Report = key(None, doc="the title block of the report ([report])")
    code_profile: CodeProfile = key(None, doc="the clause values ([code_profile])")
    fatigue: Fatigue = key(None, doc="the fatigue check of steel details ([fatigue])")
    compatibility: Compatibility = key(None, doc="the compatibility of a train with the "
                                                 "bridge ([compatibility])")
    calibration: Calibration = key(None, doc="Bayesian updating from measured records "
                                             "([calibration], vsi calibrate)")
    reliability: Reliability = key(None, doc="probability of exceedance of a check "
                                             "([reliability], vsi reliability)")


#: The tables of a file in the order of the key reference: (path, model or union).
SECTIONS: tuple[tuple[str, Any], ...] = (
    ("", VsiConfig), ("bridge", Bridge), ("bridge.track", BridgeTrack), ("train", Train),
    ("train.vehicles", Vehicle), ("train.hslm_b", HslmB), ("train.axles", Axles),
    ("irregularity", Irregularity), ("irregularity.defects", Defect), ("solver", Solver),
    ("contact", Contact), ("track", Track), ("study", Study), ("report", Report),
    ("code_profile", CodeProfile), ("code_profile.overrides", Overrides),
    ("fatigue", Fatigue), ("fatigue.sections", FatigueSection),
    ("fatigue.studs", FatigueStud),
    ("fatigue.traffic", FatigueTraffic), ("compatibility", Compatibility),
    ("calibration", Calibration), ("calibration.parameters", CalibrationParameter),
    ("calibration.records", CalibrationRecord), ("reliability", Reliability),
    ("reliability.variables", ReliabilityVariable),
)
