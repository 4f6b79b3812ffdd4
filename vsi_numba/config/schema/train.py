"""The keys of ``[train]``: the vehicles (one model per kind), the HSLM-B, the axles
and the trains on other tracks."""

from typing import Annotated, Literal

from pydantic import Field

from vsi_numba.config.schema._fields import (
    Int,
    Matrix,
    Num,
    PosNum,
    Section,
    Speed,
    Text,
    key,
    one_of,
)
from vsi_numba.model import library as _lib
from vsi_numba.model.library import extra as _extra

# ------------------------------------------------------------------------------- [train]

class _Vehicle(Section):
    offset: Num(ge=0) = key(0.0, unit="m", doc="offset behind the train's first axle",
                            expected="an offset >= 0 m behind the train's first axle")
    name: Text = key(None, default_text="kind and index", doc="vehicle name",
                     expected="a vehicle name (string)")


class BumpStop(Section):
    """A bump stop: a stiffness added beyond a clearance."""

    gap: PosNum = key(required=True, unit="m", doc="clearance (compression beyond the "
                      "static position)", expected="a clearance > 0 m (compression beyond "
                                                   "the static position)")
    stiffness: PosNum = key(required=True, unit="N/m", doc="stiffness added beyond the gap",
                            expected="a stiffness > 0 N/m (added beyond the gap)")


class DamperBlowoff(Section):
    """A damper that blows off: above the force, the post-blow-off damping."""

    force: PosNum = key(required=True, unit="N", doc="blow-off force",
                        expected="a blow-off force > 0 N")
    post_damping: Num(ge=0) = key(0.0, unit="N s/m", doc="damping beyond the blow-off",
                                  expected="a damping >= 0 N s/m beyond the blow-off")


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


class UserVehicle(_Vehicle):
    """``kind = "user"``: a linear vehicle given by its matrices."""

    kind: Literal["user"] = key(required=True, doc="vehicle model")
    M: Matrix = key(required=True, unit="kg, kg m^2", doc="mass matrix")
    C: Matrix = key(required=True, unit="N s/m", doc="damping matrix")
    K: Matrix = key(required=True, unit="N/m", doc="stiffness matrix")
    wheel_dofs: list[Int(ge=0)] = key(required=True, doc="the DOF of each wheel")
    wheel_positions: list[float] = key(required=True, unit="m",
                                       doc="wheel positions behind the vehicle's first wheel")
    gravity: list[float] = key(None, unit="N", default_text="g diag(M)",
                               doc="static forces on the DOFs")
    body_dof: int = key(-1, doc="the DOF of the body acceleration (-1: none)")


Vehicle = Annotated[ForceVehicle | SprungMassVehicle | CarVehicle | UserVehicle,
                    Field(discriminator="kind")]


class HslmB(Section):
    """``train.hslm_b = {N, d}``: HSLM-B, N forces of 170 kN at spacing d (EN 1991-2 Fig.
    6.13 [R])."""

    N: Int(ge=1, le=10_000) = key(required=True, doc="number of point forces",
                                  expected="a whole number of point forces >= 1 "
                                           "(EN 1991-2 Fig. 6.13 [R])")
    d: Num(gt=0, le=1000) = key(required=True, unit="m", doc="uniform spacing",
                                expected="a uniform spacing > 0 m (EN 1991-2 Fig. 6.13 [R])")


class Axles(Section):
    """``train.axles = {file, load_unit, name}``: a moving-force train from an axle-load
    CSV (columns position in m behind the first axle, load)."""

    file: Text = key(required=True, doc="the axle-load CSV (position, load)")
    load_unit: one_of(_extra.LOAD_UNITS) = key("kN", doc="unit of the load column")
    name: Text = key(None, default_text="the file name", doc="train name",
                     expected="a train name (string)")


#: Largest start offset of a train on another track (m): 10 km behind the run's train
#: (the runs last offset / v longer; a meeting on the deck needs at most a train length).
MAX_OTHER_OFFSET = 10_000.0
#: Directions of travel of a train on another track (``train.other_trains``).
DIRECTIONS = ("same", "opposite")


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
    train: Text | Axles = key(
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


class Train(Section):
    """``[train]``: exactly one of ``preset``, ``file`` or ``[[train.vehicles]]`` (``axles``
    may come alone or next to presets / a file)."""

    preset: Text | list[Text] = key(
        None, doc="library train name or list of names, one train each (`vsi trains` "
                  "lists them)", example=["HSLM-A1", "HSLM-A4", "ICE3"])
    model: one_of(_lib.MODELS) = key(
        None, default_text="interaction where the library has vehicle dynamics, "
                           "moving forces for the HSLM load models",
        doc="model of the presets")
    file: Text = key(None, doc="a user train file (TOML)")
    vehicles: list[Vehicle] = key(None, doc="one train of explicit vehicles, front to back "
                                            "([[train.vehicles]])")
    name: Text = key(None, default_text="title, else \"custom\"",
                     doc="name of the train of [[train.vehicles]]",
                     expected="a train name (string)")
    hslm_b: HslmB = key(None, doc="{N, d} of HSLM-B (required with preset \"HSLM-B\")")
    axles: Axles = key(None, doc="{file, load_unit, name}: a moving-force train from an "
                                 "axle-load CSV")
    track: Int(ge=1) = key(1, doc="the track the train runs on (1-based, in the order of "
                                  "bridge.tracks)",
                           expected="a track number >= 1 (1-based, as in bridge.tracks)")
    other_trains: list[OtherTrain] = key(
        None, default_text="none: one train per run",
        doc="trains on other tracks in the same run, each { track, direction, offset, "
            "train, speed_kmh | speed_factor } (default: the run's train at the run's "
            "speed): the results add the envelopes with every train loaded "
            "(`..._all_tracks`); moving forces superposed, interaction trains in the "
            "same run (the run's train, speed_factor only)",
        example=[{"track": 2, "direction": "opposite", "offset": 0.0}])
