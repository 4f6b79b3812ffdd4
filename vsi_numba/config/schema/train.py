"""The keys of ``[train]``: the vehicles (one model per kind), the HSLM-B, the axles
and the trains on other tracks, and the rules between them."""

from collections.abc import Mapping
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    Field,
    PrivateAttr,
    ValidationInfo,
    WrapValidator,
    field_validator,
    model_validator,
)

from vsi_numba.config.limits import MAX_USER_DOFS, MAX_VEHICLES
from vsi_numba.config.schema._fields import (
    MISSING,
    TABLE_PATH,
    Int,
    Num,
    PosNum,
    Section,
    Speed,
    Text,
    key,
    one_of,
    rule,
    rule_error,
    rules_here,
)
from vsi_numba.model import library as _lib
from vsi_numba.model import vehicle as _veh
from vsi_numba.model.library import extra as _extra


def _listed(v):
    """A tuple or an array (a mapping built in Python) as the list TOML gives, rows too."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, tuple | list):
        return [_listed(x) if isinstance(x, tuple | np.ndarray) else x for x in v]
    return v


def _keep_integer(v, handler):
    """A TOML integer stays an integer (the stored configuration keeps the input's own
    numbers); any other number is validated as a float."""
    out = handler(v)
    return v if isinstance(v, int) and not isinstance(v, bool) else out


#: A finite number as given (an integer stays one).
Real = Annotated[float, WrapValidator(_keep_integer)]
#: A name: a string that is not blank.
Name = Annotated[str, Field(min_length=1, pattern=r"\S")]
#: A vehicle matrix: rows of finite numbers (square, symmetric: the rules of the vehicle).
VehicleMatrix = Annotated[
    list[Annotated[list[Real], Field(max_length=MAX_USER_DOFS)]],
    Field(min_length=1, max_length=MAX_USER_DOFS), BeforeValidator(_listed)]

_SQUARE = "a square matrix (list of rows of numbers)"


def _given(v):
    """A validated value as the message shows it (a table: its given keys)."""
    return v.model_dump(exclude_unset=True) if isinstance(v, BaseModel) else v


# ------------------------------------------------------------------------------- [train]

class _Vehicle(Section):
    TABLE: ClassVar[str] = "a table with kind = 'force' | 'sprung_mass' | 'car' | 'user'"

    offset: Num(ge=0) = key(0.0, unit="m", doc="offset behind the train's first axle",
                            expected="an offset >= 0 m behind the train's first axle")
    name: Name = key(None, default_text="kind and index", doc="vehicle name",
                     expected="a vehicle name (string)")


class BumpStop(Section):
    """A bump stop: a stiffness added beyond a clearance."""

    TABLE: ClassVar[str] = "a table (gap = ..., stiffness = ...)"

    gap: PosNum = key(required=True, unit="m", doc="clearance (compression beyond the "
                      "static position)", expected="a clearance > 0 m (compression beyond "
                                                   "the static position)")
    stiffness: PosNum = key(required=True, unit="N/m", doc="stiffness added beyond the gap",
                            expected="a stiffness > 0 N/m (added beyond the gap)")


class DamperBlowoff(Section):
    """A damper that blows off: above the force, the post-blow-off damping."""

    TABLE: ClassVar[str] = "a table (force = ..., post_damping = ...)"

    force: PosNum = key(required=True, unit="N", doc="blow-off force",
                        expected="a blow-off force > 0 N")
    post_damping: Num(ge=0) = key(0.0, unit="N s/m", doc="damping beyond the blow-off",
                                  expected="a damping >= 0 N s/m beyond the blow-off")


def _blowoff_problems(vehicle, pairs) -> list:
    """The blow-offs of ``vehicle`` (``(key, the damping key of its damper)``) whose
    post-blow-off damping is not below the damper's own."""
    out = []
    for name, damping_key in pairs:
        b = getattr(vehicle, name)
        c = getattr(vehicle, damping_key)
        if b is not None and not b.post_damping < c:
            at = f"{name}.post_damping" if "post_damping" in b.model_fields_set else name
            out.append((at, b.model_dump(exclude_unset=True),
                        f"a blow-off on a damper: {TABLE_PATH}.{damping_key} = {c!r} N s/m "
                        f"must be > post_damping = {b.post_damping!r} N s/m"))
    return out


class ForceVehicle(_Vehicle):
    """``kind = "force"``: one moving force."""

    kind: Literal["force"] = key(required=True, doc="vehicle model")
    load: PosNum = key(required=True, unit="N", doc="the force (positive down)",
                       expected="a force > 0 N (positive down)")


class SprungMassVehicle(_Vehicle):
    """``kind = "sprung_mass"``: a mass on a spring-damper (and a wheel mass)."""

    kind: Literal["sprung_mass"] = key(required=True, doc="vehicle model")
    mass: PosNum = key(required=True, unit="kg", doc="sprung mass", expected="a mass > 0 kg")
    stiffness: PosNum = key(required=True, unit="N/m", doc="suspension stiffness",
                            expected="a stiffness > 0 N/m")
    damping: Num(ge=0) = key(0.0, unit="N s/m", doc="suspension damping",
                             expected="a damping >= 0 N s/m")
    wheel_mass: Num(ge=0) = key(0.0, unit="kg", doc="unsprung mass (0: massless contact "
                                "point)", expected="a mass >= 0 kg (0 = massless contact "
                                                   "point)")
    bump_stop: BumpStop = key(None, doc="a bump stop in the suspension")
    damper_blowoff: DamperBlowoff = key(None, doc="a blow-off of the suspension damper")

    @model_validator(mode="after")
    def _blowoff_below_the_damping(self):
        """A blow-off lowers the damping: post_damping < the damper's damping."""
        problems = _blowoff_problems(self, (("damper_blowoff", "damping"),))
        if problems:
            raise rules_here(problems)
        return self


def _car_key(unit, doc, expected, required=True, default=None, **plausible):
    return key(default, required=required, unit=unit, doc=doc, expected=expected,
               **plausible)


class CarVehicle(_Vehicle):
    """``kind = "car"``: a car body on two bogies of two wheelsets (10 DOFs)."""

    kind: Literal["car"] = key(required=True, doc="vehicle model")
    body_mass: PosNum = _car_key("kg", "car body mass", "a mass > 0 kg")
    body_pitch_inertia: PosNum = _car_key("kg m^2", "car body pitch inertia",
                                          "a pitch inertia > 0 kg m^2")
    bogie_mass: PosNum = _car_key("kg", "bogie mass", "a mass > 0 kg")
    bogie_pitch_inertia: PosNum = _car_key("kg m^2", "bogie pitch inertia",
                                           "a pitch inertia > 0 kg m^2")
    wheelset_mass: PosNum = _car_key("kg", "wheelset mass", "a mass > 0 kg")
    bogie_spacing: PosNum = _car_key("m", "distance between bogie centres",
                                     "a distance between bogie centres > 0 m",
                                     plausible=(1.5, 40.0),
                                     typical="about 17.5 m for a coach, 11.5 m for a "
                                             "locomotive")
    wheelbase: PosNum = _car_key("m", "axle distance within a bogie",
                                 "an axle distance within a bogie > 0 m",
                                 plausible=(1.0, 6.0), typical="2.5 m usual")
    primary_stiffness: PosNum = _car_key("N/m", "primary suspension stiffness per wheelset",
                                         "a stiffness > 0 N/m (per wheelset)")
    primary_damping: Num(ge=0) = _car_key("N s/m", "primary damping per wheelset",
                                          "a damping >= 0 N s/m (per wheelset)")
    secondary_stiffness: PosNum = _car_key("N/m", "secondary suspension stiffness per bogie",
                                           "a stiffness > 0 N/m (per bogie)")
    secondary_damping: Num(ge=0) = _car_key("N s/m", "secondary damping per bogie",
                                            "a damping >= 0 N s/m (per bogie)")
    body_cg_to_front_bogie: Num(ge=0) = key(
        None, unit="m", default_text="mid-way between the bogies",
        doc="distance of the body's centre of gravity behind the front bogie centre",
        expected="a distance >= 0 m behind the front bogie centre")
    primary_bump_stop: BumpStop = key(None, doc="a bump stop in the primary suspension")
    primary_damper_blowoff: DamperBlowoff = key(None, doc="a blow-off of the primary damper")
    secondary_bump_stop: BumpStop = key(None, doc="a bump stop in the secondary suspension")
    secondary_damper_blowoff: DamperBlowoff = key(None,
                                                  doc="a blow-off of the secondary damper")

    @model_validator(mode="after")
    def _bogies_apart_body_between(self):
        """The blow-offs below their dampers' damping; the bogies further apart than their
        wheelbase (else their axles overlap); the body's centre between the bogies."""
        problems = _blowoff_problems(self, (("primary_damper_blowoff", "primary_damping"),
                                            ("secondary_damper_blowoff",
                                             "secondary_damping")))
        s, wb, cg = self.bogie_spacing, self.wheelbase, self.body_cg_to_front_bogie
        if s <= wb:
            problems.append(("bogie_spacing", s, f"a distance between bogie centres > the "
                             f"wheelbase ({wb:g} m), else the bogies' axles overlap"))
        elif cg is not None and cg > s:
            problems.append(("body_cg_to_front_bogie", cg,
                             f"a distance between 0 and bogie_spacing = {s:g} m"))
        if problems:
            raise rules_here(problems)
        return self


def _square(v, name: str, n: int | None):
    """The problem of a matrix that is not square (n x n when ``n``), else None."""
    if any(len(r) != len(v) for r in v) or (n and len(v) != n):
        return (name, v, _SQUARE + (f", {n} x {n}" if n else ""))
    return None


def _symmetric(v, name: str):
    """The problem of a square matrix the vehicle model refuses (its largest
    asymmetry), else None."""
    a = np.asarray(v, float)
    try:
        _veh.check_matrix(a, name)
    except _veh.VehicleMatrixError as exc:
        i, j = exc.index
        return (f"{name}[{i}][{j}]", float(a[i, j]),
                f"a symmetric matrix ({TABLE_PATH}.{name}[{j}][{i}] = {float(a[j, i])!r})")
    return None


def _size(info: ValidationInfo) -> int | None:
    """The number of DOFs of a user vehicle: the size of its valid M, else None."""
    m = info.data.get("M")
    return len(m) if m is not None else None


def _problem(p):
    if p is not None:
        raise rules_here([p], field=True)


class UserVehicle(_Vehicle):
    """``kind = "user"``: a linear vehicle given by its matrices."""

    kind: Literal["user"] = key(required=True, doc="vehicle model")
    M: VehicleMatrix = key(required=True, unit="kg, kg m^2", doc="mass matrix",
                           expected=_SQUARE, each="a finite number",
                           missing="the mass matrix (list of rows, kg and kg m^2)")
    C: VehicleMatrix = key(required=True, unit="N s/m", doc="damping matrix",
                           expected=_SQUARE, each="a finite number",
                           missing="the damping matrix (N s/m), same size as M")
    K: VehicleMatrix = key(required=True, unit="N/m", doc="stiffness matrix",
                           expected=_SQUARE, each="a finite number",
                           missing="the stiffness matrix (N/m), same size as M")
    wheel_dofs: Annotated[list[Int(ge=0)], Field(min_length=1, max_length=MAX_USER_DOFS),
                          BeforeValidator(_listed)] = key(
        required=True, doc="the DOF of each wheel",
        expected="a non-empty list of wheel DOF indices",
        each="a DOF index >= 0 (an integer below the size of M)",
        missing="a list of wheel DOF indices")
    wheel_positions: Annotated[list[Annotated[Real, Field(ge=0)]],
                               Field(min_length=1, max_length=MAX_USER_DOFS),
                               BeforeValidator(_listed)] = key(
        required=True, unit="m", doc="wheel positions behind the vehicle's first wheel",
        expected="a list of wheel positions >= 0 m, one per wheel DOF",
        each="a position >= 0 m behind the first axle",
        missing="one position (m behind the vehicle's first axle) per wheel DOF")
    gravity: Annotated[list[Real], Field(min_length=1, max_length=MAX_USER_DOFS),
                       BeforeValidator(_listed)] = key(
        None, unit="N", default_text="g diag(M)", doc="static forces on the DOFs",
        expected="a list of static loads (N, positive down), one per DOF", each="a load in N")
    body_dof: Int(ge=-1, le=MAX_USER_DOFS) = key(
        -1, doc="the DOF of the body acceleration (-1: none)",
        expected="a DOF index -1 <= i < the size of M (-1: none)")

    @field_validator("M")
    @classmethod
    def _square_symmetric_masses(cls, v):
        _problem(_square(v, "M", None) or _symmetric(v, "M"))
        d = np.diag(np.asarray(v, float))
        if np.any(d < 0):
            i = int(np.argmin(d))
            _problem((f"M[{i}][{i}]", float(d[i]), "a mass >= 0 (diagonal)"))
        return v

    @field_validator("C", "K")
    @classmethod
    def _square_symmetric_as_m(cls, v, info: ValidationInfo):
        _problem(_square(v, info.field_name, _size(info)) or _symmetric(v, info.field_name))
        return v

    @field_validator("wheel_dofs")
    @classmethod
    def _dofs_of_the_vehicle(cls, v, info: ValidationInfo):
        n = _size(info)
        hi = n - 1 if n else MAX_USER_DOFS
        bad = [(f"wheel_dofs[{i}]", d, f"a DOF index 0 <= i <= {hi}")
               for i, d in enumerate(v) if d > hi]
        if bad:
            raise rules_here(bad, field=True)
        if len(set(v)) != len(v):
            _problem(("wheel_dofs", v, "distinct DOF indices"))
        return v

    @field_validator("wheel_positions")
    @classmethod
    def _one_per_wheel_front_to_back(cls, v, info: ValidationInfo):
        dofs = info.data.get("wheel_dofs")
        if dofs is not None and len(v) != len(dofs):
            _problem(("wheel_positions", v,
                      f"one position per wheel DOF ({len(dofs)} wheel DOFs)"))
        if any(b <= a for a, b in zip(v, v[1:], strict=False)):
            _problem(("wheel_positions", v,
                      "strictly increasing positions (wheels front to back)"))
        return v

    @field_validator("gravity")
    @classmethod
    def _one_load_per_dof(cls, v, info: ValidationInfo):
        n = _size(info)
        if n is not None and len(v) != n:
            _problem(("gravity", v, "a list of static loads (N, positive down), one per DOF"))
        return v

    @field_validator("body_dof")
    @classmethod
    def _a_dof_of_the_vehicle(cls, v, info: ValidationInfo):
        n = _size(info)
        hi = n - 1 if n else MAX_USER_DOFS
        if v > hi:
            _problem(("body_dof", v, f"a DOF index -1 <= i <= {hi} (-1: none)"))
        return v


Vehicle = Annotated[ForceVehicle | SprungMassVehicle | CarVehicle | UserVehicle,
                    Field(discriminator="kind")]


class HslmB(Section):
    """``train.hslm_b = {N, d}``: HSLM-B, N forces of 170 kN at spacing d (EN 1991-2 Fig.
    6.13 [R])."""

    TABLE: ClassVar[str] = ("a table {N = <number of forces>, d = <spacing in m>} read from "
                            "EN 1991-2 Fig. 6.13 [R]")

    N: Int(ge=1, le=10_000) = key(required=True, doc="number of point forces",
                                  expected="a whole number of point forces >= 1 "
                                           "(EN 1991-2 Fig. 6.13 [R])",
                                  missing=_extra.HSLM_B_MISSING)
    d: Num(gt=0, le=1000) = key(required=True, unit="m", doc="uniform spacing",
                                expected="a uniform spacing > 0 m (EN 1991-2 Fig. 6.13 [R])",
                                missing=_extra.HSLM_B_MISSING)


class Axles(Section):
    """``train.axles = {file, load_unit, name}``: a moving-force train from an axle-load
    CSV (columns position in m behind the first axle, load)."""

    TABLE: ClassVar[str] = ("a table {file = \"axles.csv\", load_unit = \"kN\"} (CSV columns "
                            "position in m behind the first axle, load)")

    file: Text = key(required=True, doc="the axle-load CSV (position, load)",
                     expected="the path of axle loads (CSV: position, load) (a string)",
                     missing="the path of axle loads (CSV: position, load)")
    load_unit: one_of(_extra.LOAD_UNITS) = key("kN", doc="unit of the load column")
    name: Name = key(None, default_text="the file name", doc="train name",
                     expected="a train name (string)")


#: Largest start offset of a train on another track (m): 10 km behind the run's train
#: (the runs last offset / v longer; a meeting on the deck needs at most a train length).
MAX_OTHER_OFFSET = 10_000.0
#: Directions of travel of a train on another track (``train.other_trains``).
DIRECTIONS = ("same", "opposite")
#: Most trains on other tracks of one run.
MAX_OTHER_TRAINS = 19


#: Bounds of the speed of a train on another track as a multiple of the run's speed
#: (``train.other_trains[].speed_factor``): a slower train lasts 1 / factor longer.
SPEED_FACTOR_BOUNDS = (0.1, 10.0)


class OtherTrain(Section):
    """``[train] other_trains = [{ track = 2, direction = "opposite", offset = 0 }]``: a
    train on another track of ``bridge.tracks``, in the same run (trains meeting on the
    deck, or side by side): the run's train at the run's speed unless ``train`` and
    ``speed_kmh`` / ``speed_factor`` say otherwise. Moving-force trains: their runs are
    superposed; interaction trains: every wheel and the deck in one run, the run's train
    again (``speed_factor`` only)."""

    TABLE: ClassVar[str] = ("a table { track = k, direction, offset, train, speed_kmh | "
                            "speed_factor }")

    track: Int(ge=1) = key(required=True, doc="the track of this train (1-based, as in "
                                              "bridge.tracks; not train.track)",
                           expected="a track number >= 1 (1-based, as in bridge.tracks)")
    direction: one_of(DIRECTIONS) = key(
        "same", doc="direction of travel: 'same' as the run's train (+x) or 'opposite' "
                    "(-x: it enters at the far end of the deck; trains meeting)")
    offset: Num(ge=0, le=MAX_OTHER_OFFSET) = key(
        0.0, unit="m", doc="how far behind the run's train it starts: it enters its end of "
                           "the deck offset / v after the run's train enters its own",
        expected=f"a distance >= 0 m (at most {MAX_OTHER_OFFSET:g} m; the runs last until "
                 "the last train has left the deck)")
    train: Name | Axles = key(
        None, default_text="the run's train",
        doc="the train on this track, as moving forces: a library train name (`vsi "
            "trains` lists them) or { file, load_unit, name }, an axle-load CSV as "
            "train.axles (moving-force runs only)",
        expected="a library train name (`vsi trains` lists them) or a table { file = "
                 "\"axles.csv\", load_unit = \"kN\", name = ... } (an axle-load CSV)",
        example="HSLM-A3")
    speed_kmh: Speed = key(
        None, unit="km/h", default_text="the run's speed",
        doc="its own speed, the same in every run of the study (not with speed_factor; "
            "moving-force runs only)",
        expected="a speed > 0 km/h (the same in every run; not with speed_factor)")
    speed_factor: Num(ge=SPEED_FACTOR_BOUNDS[0], le=SPEED_FACTOR_BOUNDS[1]) = key(
        None, default_text="1: the run's speed",
        doc="its speed as a multiple of the run's speed (not with speed_kmh)",
        expected=f"a factor {SPEED_FACTOR_BOUNDS[0]:g} .. {SPEED_FACTOR_BOUNDS[1]:g} of the "
                 "run's speed (not with speed_kmh)")

    @model_validator(mode="after")
    def _one_speed(self):
        if self.speed_kmh is not None and self.speed_factor is not None:
            raise rules_here([("speed_factor", self.speed_factor,
                               f"either {TABLE_PATH}.speed_kmh or {TABLE_PATH}.speed_factor, "
                               f"not both (speed_kmh = {self.speed_kmh!r} is given)")])
        return self


#: The trains of a ``[train]``: at least one of these keys.
SOURCES = ("preset", "vehicles", "file", "axles")
#: The keys a ``[train]`` ignores (warned by the reader): with ``[[train.vehicles]]``
#: (True) and without (False), and why.
IGNORED = {True: {"model": "it applies to library presets, not to [[train.vehicles]]"},
           False: {"name": "it names the train of [[train.vehicles]]; presets keep their "
                           "names"}}


def _line(path: str, value, expected: str) -> str:
    from vsi_numba.config._show import _show

    if value is MISSING:
        return f"{path}: missing required key; expected {expected}"
    return f"{path} = {_show(_given(value))}: expected {expected}"


def is_hslm_b(name: str) -> bool:
    """Whether a preset name is the HSLM-B (its N and d in ``train.hslm_b``)."""
    return name.strip().casefold() == "hslm-b"


class Train(Section):
    """``[train]``: exactly one of ``preset``, ``file`` or ``[[train.vehicles]]`` (``axles``
    may come alone or next to presets / a file)."""

    TABLE: ClassVar[str] = "a table [train] with preset, vehicles or file"
    #: the keys given that this train ignores (warned by the reader): :data:`IGNORED`
    _ignored: list[str] = PrivateAttr(default_factory=list)

    preset: Annotated[Text | Annotated[list[Text], Field(min_length=1)],
                      BeforeValidator(_listed)] = key(
        None, doc="library train name or list of names, one train each (`vsi trains` "
                  "lists them)", example=["HSLM-A1", "HSLM-A4", "ICE3"],
        expected="a train name, or a non-empty list of names (`vsi trains` lists them)",
        each="a train name (`vsi trains` lists them)")
    model: one_of(_lib.MODELS) = key(
        None, default_text="interaction where the library has vehicle dynamics, "
                           "moving forces for the HSLM load models",
        doc="model of the presets")
    file: Text = key(None, doc="a user train file (TOML)",
                     expected="the path of user trains (TOML) (a string)")
    vehicles: Annotated[list[Vehicle], Field(min_length=1, max_length=MAX_VEHICLES),
                        BeforeValidator(_listed)] = key(
        None, doc="one train of explicit vehicles, front to back ([[train.vehicles]])",
        expected=f"an array of tables [[train.vehicles]] (1 to {MAX_VEHICLES})")
    name: Name = key(None, default_text="title, else \"custom\"",
                     doc="name of the train of [[train.vehicles]]",
                     expected="a train name (string)")
    hslm_b: HslmB = key(None, doc="{N, d} of HSLM-B (required with preset \"HSLM-B\")")
    axles: Axles = key(None, doc="{file, load_unit, name}: a moving-force train from an "
                                 "axle-load CSV")
    track: Int(ge=1) = key(1, doc="the track the train runs on (1-based, in the order of "
                                  "bridge.tracks)",
                           expected="a track number >= 1 (1-based, as in bridge.tracks)")
    other_trains: Annotated[list[OtherTrain],
                            Field(min_length=1, max_length=MAX_OTHER_TRAINS)] = key(
        None, default_text="none: one train per run",
        doc="trains on other tracks in the same run, each { track, direction, offset, "
            "train, speed_kmh | speed_factor } (default: the run's train at the run's "
            "speed): the results add the envelopes with every train loaded "
            "(`..._all_tracks`); moving forces superposed, interaction trains in the "
            "same run (the run's train, speed_factor only)",
        expected=f"a list of 1 to {MAX_OTHER_TRAINS} trains on other tracks, each "
                 "{ track = k, direction = \"same\" | \"opposite\", offset = m[, train = "
                 "\"name\"][, speed_kmh = v | speed_factor = f] }",
        example=[{"track": 2, "direction": "opposite", "offset": 0.0}])

    @model_validator(mode="wrap")
    @classmethod
    def _ignore_the_keys_of_the_other_form(cls, data, handler):
        """``model`` with ``[[train.vehicles]]``, ``name`` without: ignored (the reader
        warns), the table validates without it."""
        ignored = []
        if isinstance(data, Mapping):
            ignored = [k for k in IGNORED["vehicles" in data] if k in data]
            data = {k: v for k, v in data.items() if k not in ignored}
        out = handler(data)
        out._ignored = ignored
        return out

    @field_validator("preset")
    @classmethod
    def _distinct_presets(cls, v):
        if isinstance(v, list) and len(set(v)) != len(v):
            raise rule("train.preset", v, "distinct train names")
        return v

    @model_validator(mode="after")
    def _one_source_and_hslm_b(self):
        """At least one of the trains' keys (:data:`SOURCES`), explicit vehicles alone;
        ``hslm_b`` with the HSLM-B preset only, and then with it and a moving-force
        model."""
        given = [k for k in SOURCES if getattr(self, k) is not None]
        if not given:
            raise rule_error(_line("train", MISSING, "one of train.preset (library names), "
                                   "[[train.vehicles]], train.file or train.axles"))
        lines = []
        if self.vehicles is not None and len(given) > 1:
            other = [k for k in given if k != "vehicles"][0]
            lines.append(_line(f"train.{other}", getattr(self, other), "either "
                               "[[train.vehicles]] or train.preset/train.file, not both"))
        names = [self.preset] if isinstance(self.preset, str) else (self.preset or [])
        wants_b = any(is_hslm_b(n) for n in names)
        if self.hslm_b is not None and not wants_b:
            lines.append(_line("train.hslm_b", self.hslm_b, "only with 'HSLM-B' in "
                               "train.preset (N and d of the HSLM-B train)"))
        elif wants_b and self.hslm_b is None:
            lines.append(_line("train.hslm_b", MISSING, _extra.HSLM_B_MISSING))
        elif wants_b and self.model == "interaction":
            lines.append(_line("train.model", self.model, "'moving_force' (HSLM-B is a load "
                               "model: moving forces, no vehicle dynamics)"))
        if lines:
            raise rule_error("\n".join(lines))
        return self
