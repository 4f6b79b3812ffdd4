"""The configuration's keys, declared once: one model per TOML table.

Each field is one key: its type and bounds (the annotation), default, unit, description
and the expectation of its error message (:func:`~._fields.key`).  Tables with a ``kind``
(``[bridge]``, ``[[train.vehicles]]``, ``[irregularity]``, ``[[irregularity.defects]]``)
are unions of one model per kind.  :class:`VsiConfig` is the whole file.

Adding a key: add one field to the model of its table (and read it where it is used);
the JSON Schema, the key reference of the documentation, the ``vsi init`` template and
the unknown-key checks follow (``python -m vsi_numba.config.schema.generate`` rewrites
the committed files, a test says when they are stale).  Adding a table: a model here and
a field of :class:`VsiConfig`.
"""

from typing import Annotated, Any, Literal, Union

from pydantic import Discriminator, Field, Tag

from vsi_numba import en1990, en1991
from vsi_numba.code_profile import ANNEX_D_MIXES, DEFAULT_NAME, TABLE, limits_of
from vsi_numba.config.limits import MAX_ELEMENTS, MAX_MODES, MAX_OUTPUT_POINTS, MAX_SPEEDS
from vsi_numba.config.schema._fields import Int, Num, Section, Text, key
from vsi_numba.model import distribution as _dist
from vsi_numba.model import irregularity as _irr
from vsi_numba.model import library as _lib
from vsi_numba.model import track as _track
from vsi_numba.model.irregularity import SPEED_BOUND_KMH
from vsi_numba.model.library import extra as _extra
from vsi_numba.solver.settings import BOUNDS, CONTACT_MODELS, SolverSettings


def one_of(values) -> Any:
    """``Literal[...]`` of the names a module defines (one list of choices)."""
    return Literal[tuple(values)]


PosNum = Num(gt=0)
Speed = Num(gt=0, le=SPEED_BOUND_KMH)
Matrix = list[list[float]]


# ------------------------------------------------------------------------------ [bridge]

class BridgeTrack(Section):
    """``[bridge.track]``: a ballasted track layer assembled with a ``continuous`` deck
    before the modal reduction (values per track, both rails); the train runs on the rail.
    """

    rail_EI: PosNum = key(required=True, unit="N m^2", doc="bending stiffness of both rails",
                          expected="a bending stiffness of both rails > 0 N m^2 "
                                   "(2 x 6.42e6 for UIC60)")
    rail_mass_per_length: PosNum = key(required=True, unit="kg/m", doc="mass of both rails",
                                       expected="a mass of both rails > 0 kg/m "
                                                "(2 x 60.3 for UIC60)")
    pad_stiffness: PosNum = key(required=True, unit="N/m",
                                doc="rail pad stiffness per sleeper (both rail seats)",
                                expected="a rail pad stiffness per sleeper (both rail "
                                         "seats) > 0 N/m")
    pad_damping: Num(ge=0) = key(0.0, unit="N s/m", doc="rail pad damping per sleeper",
                                 expected="a rail pad damping per sleeper >= 0 N s/m")
    sleeper_mass: PosNum = key(required=True, unit="kg", doc="mass of one sleeper",
                               expected="a sleeper mass > 0 kg")
    sleeper_spacing: PosNum = key(required=True, unit="m", doc="sleeper spacing",
                                  expected="a sleeper spacing > 0 m")
    ballast_stiffness: PosNum = key(required=True, unit="N/m",
                                    doc="ballast stiffness per sleeper",
                                    expected="a ballast stiffness per sleeper > 0 N/m")
    ballast_damping: Num(ge=0) = key(0.0, unit="N s/m", doc="ballast damping per sleeper",
                                     expected="a ballast damping per sleeper >= 0 N s/m")
    rail_elements_per_bay: Int(ge=1, le=8) = key(
        2, doc="rail beam elements between two sleepers",
        expected="an integer number of rail elements between sleepers, 1 .. 8")


PerSpan = PosNum | list[PosNum]
Damping = Num(ge=0, lt=1) | list[Num(ge=0, lt=1)] | Literal["EN1991-2"]
Points = float | list[float]


class _Deck(Section):
    track_type: one_of(en1990.DECK_ACCELERATION_LIMITS) = key(
        "ballasted", doc="track form on the deck: the EN 1990 A2 deck-acceleration limit "
                         "(3.5 m/s2 ballasted, 5 m/s2 direct fastening)")
    output_points: Points = key(
        None, unit="m", default_text="every mid-span",
        doc="deck positions of the outputs (from the left end)",
        expected=f"a list of at most {MAX_OUTPUT_POINTS} positions on the deck (m)")


class _Modal(_Deck):
    damping_ratio: Damping = key(
        0.0, doc="damping ratio (fraction of critical): a number, one per mode, or "
                 "\"EN1991-2\" (the EN 1991-2 Table 6.6 lower bound for the span L and "
                 "deck_type, from the code profile; L of a continuous deck: its mean "
                 "span, the profile's DAMPING_SPAN_RULE)",
        expected="a damping ratio 0 <= zeta < 1, a list with one per mode, or 'EN1991-2' "
                 "(Table 6.6 with bridge.deck_type)")
    n_modes: Int(ge=1, le=MAX_MODES) = key(
        None, default_text="every mode up to the deck-acceleration cut-off "
                           "(solver.acceleration_cutoff, else EN 1990 A2 max(30 Hz, 1.5 f1, "
                           "f3)); 10 with [bridge.track] and matrices; modes_file: all",
        doc="modes kept (with max_frequency: the smaller set)",
        expected=f"an integer number of modes 1 <= n_modes <= {MAX_MODES}")
    max_frequency: PosNum = key(None, unit="Hz", doc="keep every mode up to this frequency",
                                expected="a frequency > 0 Hz")


class TrackLine(Section):
    """``[bridge] tracks = [{ eccentricity = y }, ...]``: one track on the deck, its centre
    line at y from the deck's reference axis, its two rails at y +- gauge / 2."""

    eccentricity: float = key(
        0.0, unit="m", doc="y of the track centre line from the deck's reference axis "
                           "(positive to the left looking in +x)",
        expected="a transverse distance y of the track centre line (m)",
        plausible=(-50.0, 50.0), typical="the outer tracks of a four-track deck stand "
                                         "about 7 m off its axis")
    gauge: PosNum = key(1.435, unit="m", doc="distance between the rail centres (the "
                                             "wheel-rail contact points are taken there)",
                        expected="a gauge > 0 m (1.435 standard gauge)",
                        plausible=(0.6, 2.0), typical="1.435 m standard gauge, 0.6 to "
                                                      "1.676 m in service")


class Torsion(Section):
    """``[bridge] torsion = { GJ, polar_mass, damping_ratio }``: St-Venant torsion of the
    deck (fork supports: torsion restrained at every support)."""

    GJ: PerSpan = key(required=True, unit="N m^2", doc="torsional stiffness, a number or "
                      "one per span", expected="a torsional stiffness GJ > 0 N m^2",
                      plausible=(1e7, 1e14), typical="about 1e9 for a slab, 1e11 for a "
                                                     "double-track box girder")
    polar_mass: PerSpan = key(required=True, unit="kg m^2/m",
                              doc="polar mass moment of inertia per length about the "
                                  "reference axis, a number or one per span",
                              expected="a polar mass moment per length > 0 kg m^2/m",
                              plausible=(1e2, 1e8), typical="about 4e5 for a double-track "
                                                            "box girder")
    damping_ratio: Num(ge=0, lt=1) = key(0.0, doc="damping ratio of the torsional modes",
                                         expected="a damping ratio 0 <= zeta < 1")
    n_modes: Int(ge=1, le=MAX_MODES) = key(
        None, default_text="every torsional mode up to the highest bending mode kept",
        doc="torsional modes kept", expected=f"an integer number of torsional modes "
                                             f"1 <= n_modes <= {MAX_MODES}")


class _Beam(_Modal):
    tracks: list[TrackLine] = key(
        None, default_text="one track on the axis, [{ eccentricity = 0 }]",
        doc="the tracks on the deck, each { eccentricity, gauge } (beam decks) or "
            "{ line, eccentricity } (imported decks: named by their lines in the data, the "
            "eccentricity a label only); train.track picks the loaded one",
        example=[{"eccentricity": 2.25}, {"eccentricity": -2.25}])
    torsion: Torsion = key(None, default_text="none (the deck does not twist)",
                           doc="{ GJ, polar_mass, damping_ratio }: torsional modes of the "
                               "deck")
    spans: PerSpan = key(required=True, unit="m", doc="span lengths",
                         expected="a span length > 0 m")
    EI: PerSpan = key(required=True, unit="N m^2", doc="bending stiffness, a number or one "
                      "per span", expected="a bending stiffness EI > 0 N m^2")
    mass_per_length: PerSpan = key(required=True, unit="kg/m",
                                   doc="mass per length (deck + ballast + track), a number "
                                       "or one per span",
                                   expected="a mass per length > 0 kg/m")
    deck_type: one_of(en1991.DECK_TYPE_KEYS) = key(
        None, doc="with damping_ratio = \"EN1991-2\": the deck type of Table 6.6")
    additional_damping: bool = key(
        False, doc="add the EN 1991-2 6.4.6.3.1 additional damping (L < 30 m, Fig. 6.15) "
                   "in moving-force analyses")


class SimplySupported(_Beam):
    """``kind = "simply_supported"``: one Euler-Bernoulli span, modes in closed form."""

    kind: Literal["simply_supported"] = key(required=True, doc="bridge model")


class Continuous(_Beam):
    """``kind = "continuous"``: a continuous beam over several spans (finite elements)."""

    kind: Literal["continuous"] = key(required=True, doc="bridge model")
    elements_per_span: Int(ge=1, le=400) = key(
        40, doc=f"beam elements per span (at most {MAX_ELEMENTS} in all)",
        expected="an integer number of elements 1 <= elements_per_span <= 400")
    track: BridgeTrack = key(None, doc="the track layer of the deck ([bridge.track])")


class Rigid(_Deck):
    """``kind = "rigid"``: a rigid deck (the train on the track only)."""

    kind: Literal["rigid"] = key(required=True, doc="bridge model")
    spans: PerSpan = key(required=True, unit="m", doc="the track length covered (one value)",
                         expected="a span length > 0 m")


class ImportedTrack(Section):
    """``[bridge] tracks = [{ line = "T" }, ...]`` of an imported deck: one track, named by
    its lines in the modes file or station map (rails ``T/left`` and ``T/right``, and/or
    the centre line ``T``)."""

    line: Text = key(required=True, doc="the track's name in the data: its rails are the "
                                        "lines 'line/left' and 'line/right', its centre "
                                        "line 'line'",
                     expected="the name of a track of the modes file / station map "
                              "(string)")
    eccentricity: float = key(
        None, unit="m", default_text="unknown (no track_eccentricity in the results)",
        doc="y of the track centre line from the deck's reference axis (positive to the "
            "left looking in +x), a label of the results only: the lines carry the "
            "geometry",
        expected="a transverse distance y of the track centre line (m)")


class _Imported(_Modal):
    spans: PerSpan = key(None, unit="m", default_text="the length of the track line",
                         doc="span lengths along the track line (the table must cover "
                             "their sum)", expected="a span length > 0 m")
    track_line: Text = key(None, default_text="the only line",
                           doc="the track line of the file when it has several (not with "
                               "tracks)",
                           expected="the name of a track line (string)")
    tracks: list[ImportedTrack] = key(
        None, default_text="none: the deck is the track line (track_line)",
        doc="the tracks on the deck, each { eccentricity, gauge } (beam decks) or "
            "{ line, eccentricity } (imported decks: named by their lines in the data, the "
            "eccentricity a label only); train.track picks the loaded one",
        example=[{"line": "up"}, {"line": "down"}])


class ModesFile(_Imported):
    """``kind = "modes_file"``: modes imported from a table (netCDF or CSV,
    :mod:`vsi_numba.model.imported`)."""

    kind: Literal["modes_file"] = key(required=True, doc="bridge model")
    file: Text = key(required=True, doc="the modes table (netCDF or CSV)",
                     expected="the path of the deck modes")
    mass_normalised: bool = key(None, default_text="from the file",
                                doc="true when the shapes are mass-normalised (no "
                                    "modal_mass column)")


class Matrices(_Imported):
    """``kind = "matrices"``: stiffness and mass matrices (Matrix Market) with a station
    map, reduced to modes at load time."""

    kind: Literal["matrices"] = key(required=True, doc="bridge model")
    stiffness_matrix: Text = key(required=True, doc="the stiffness matrix K (Matrix Market)")
    mass_matrix: Text = key(required=True, doc="the mass matrix M (Matrix Market)")
    station_map: Text = key(required=True, doc="the station map (CSV: x, dof, rotation_dof, "
                                               "line)")
    fixed_dofs: list[Int(ge=0)] = key([], doc="DOFs to fix ([]: the supports are already "
                                              "applied)")
    dof_base: Literal[0, 1] = key(0, doc="DOF numbering of the files: from 0 or from 1",
                                  expected="0 (DOFs numbered from 0) or 1 (from 1)")
    rotation_sign: Literal[1, -1, 1.0, -1.0] = key(
        1, doc="sign of the rotation DOFs (+dw/dx or -dw/dx)",
        expected="1 (rotation DOF = +dw/dx) or -1 (= -dw/dx)")
    vertical_dofs: Union[list[Int(ge=0)], "DofPattern"] = key(
        None, default_text="the station DOFs",
        doc="the vertical DOFs of the track line: a list, or {start, step}")


class DofPattern(Section):
    """``{start, step}``: every step-th DOF from start."""

    start: Int(ge=0) = key(None, default_text="dof_base", doc="first DOF")
    step: Int(ge=1) = key(1, doc="DOF step", expected="an integer step >= 1")


Matrices.model_rebuild()

Bridge = Annotated[SimplySupported | Continuous | Rigid | ModesFile | Matrices,
                   Field(discriminator="kind")]


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


class OtherTrain(Section):
    """``[train] other_trains = [{ track = 2, direction = "opposite", offset = 0 }]``: the
    run's train once more, on another track of ``bridge.tracks``, in the same run (trains
    meeting on the deck, or side by side); moving forces only."""

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
        doc="the same train on other tracks in the same run, each { track, direction, "
            "offset }: the results add the envelopes with every train loaded "
            "(`..._all_tracks`); moving forces only",
        example=[{"track": 2, "direction": "opposite", "offset": 0.0}])


# ------------------------------------------------------------------------ [irregularity]

class _Defects(Section):
    defects: list["Defect"] = key(None, doc="isolated defects added to every realisation "
                                            "([[irregularity.defects]])")


class _CosineKeys(Section):
    depth: Num(gt=-1, lt=1) = key(required=True, unit="m", doc="depth (> 0 dip, < 0 bump)",
                                  expected="a depth != 0 m (> 0: dip, < 0: bump), "
                                           "|depth| < 1 m")
    wavelength: PosNum = key(required=True, unit="m", doc="wavelength",
                             expected="a wavelength > 0 m")
    position: float = key(required=True, unit="m", doc="where the defect starts",
                          expected="a position x (m) where the defect starts")


class _StepKeys(Section):
    height: Num(gt=-1, lt=1) = key(required=True, unit="m",
                                   doc="level change (> 0: the rail ends lower)",
                                   expected="a level change != 0 m (> 0: the rail ends "
                                            "lower), |height| < 1 m")
    length: PosNum = key(required=True, unit="m", doc="transition length",
                         expected="a transition length > 0 m")
    position: float = key(required=True, unit="m", doc="where the transition starts",
                          expected="a position x (m) where the transition starts")
    shape: one_of(_irr.STEP_SHAPES) = key("cosine", doc="transition shape")


class CosineDefect(_CosineKeys):
    """An isolated cosine dip or bump."""

    kind: Literal["cosine"] = key(required=True, doc="defect kind")


class StepDefect(_StepKeys):
    """A level change that persists (a settled transition)."""

    kind: Literal["step"] = key(required=True, doc="defect kind")


Defect = Annotated[CosineDefect | StepDefect, Field(discriminator="kind")]
_Defects.model_rebuild()


class NoIrregularity(_Defects):
    """``kind = "none"``: a smooth track (plus any defects)."""

    kind: Literal["none"] = key("none", doc="track profile")


class CosineIrregularity(_Defects, _CosineKeys):
    """``kind = "cosine"``: an isolated cosine dip or bump."""

    kind: Literal["cosine"] = key(required=True, doc="track profile")


class StepIrregularity(_Defects, _StepKeys):
    """``kind = "step"``: a level change that persists."""

    kind: Literal["step"] = key(required=True, doc="track profile")


class PsdIrregularity(_Defects):
    """``kind = "psd"``: random track from a spectrum, one realisation per seed."""

    kind: Literal["psd"] = key(required=True, doc="track profile")
    spectrum: one_of(_irr.SPECTRA) = key(required=True, doc="the track spectrum")
    wavelength_min: PosNum = key(required=True, unit="m", doc="shortest wavelength",
                                 expected="a wavelength > 0 m")
    wavelength_max: PosNum = key(required=True, unit="m", doc="longest wavelength",
                                 expected="a wavelength > 0 m")
    seeds: Int(ge=0, lt=2 ** 63) | list[Int(ge=0, lt=2 ** 63)] = key(
        required=True, doc="random seeds, one realisation each",
        expected="a non-empty list of distinct integer seeds >= 0")
    dx: PosNum = key(None, unit="m", default_text="wavelength_min / 20",
                     doc="sample spacing", expected="a sample spacing > 0 m")


class FileIrregularity(_Defects):
    """``kind = "file"``: a measured profile (CSV)."""

    kind: Literal["file"] = key(required=True, doc="track profile")
    path: Text = key(required=True, doc="the profile (CSV, columns x and r)")
    x_column: Text = key("x", doc="column of the position", expected="a column name (string)")
    r_column: Text = key("r", doc="column of the profile", expected="a column name (string)")
    r_unit: Literal["m", "mm"] = key("m", doc="unit of the profile column")
    dx: PosNum = key(None, unit="m", default_text="the file's", doc="resampling spacing",
                     expected="a sample spacing > 0 m")


def _irregularity_kind(v):
    return v.get("kind", "none") if isinstance(v, dict) else getattr(v, "kind", None)


Irregularity = Annotated[
    Annotated[NoIrregularity, Tag("none")] | Annotated[CosineIrregularity, Tag("cosine")]
    | Annotated[StepIrregularity, Tag("step")] | Annotated[PsdIrregularity, Tag("psd")]
    | Annotated[FileIrregularity, Tag("file")],
    Discriminator(_irregularity_kind)]


# ------------------------------------------------------------------- [solver] [contact]

def _b(name):
    """The bounds of a solver setting (:data:`vsi_numba.solver.settings.BOUNDS`)."""
    b = BOUNDS[name]
    return {k: getattr(b, k) for k in ("gt", "ge", "lt", "le")}


class Solver(Section):
    """``[solver]``: the time integration (HHT-alpha with contact iterations) and the
    escapes from the checks."""

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

    model: one_of(CONTACT_MODELS) = key("rigid", doc="contact model")
    hertz_coefficient: Num(gt=0, lt=HERTZ_MAX) = key(
        None, unit="m N^-2/3", default_text="required for Hertz",
        doc="G of delta = G N^(2/3), per contact force as the model carries it (axle)",
        expected="a Hertz constant G > 0 m N^-2/3 (about 4e-8 for a wheel on a rail)")


# ------------------------------------------------------------------------------ [track]

class Track(Section):
    """``[track]``: the rail on its foundation over the deck and the approaches, and the
    distribution of moving forces (not with ``[bridge.track]``)."""

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


# ------------------------------------------------------------------------------ [study]

class SpeedGrid(Section):
    """``{start, stop, step}`` in km/h (stop included when on the grid)."""

    start: Speed = key(required=True, unit="km/h", doc="first speed",
                       expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    stop: Speed = key(required=True, unit="km/h", doc="last speed",
                      expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    step: PosNum = key(required=True, unit="km/h", doc="speed step",
                       expected="a step > 0 km/h")


class Study(Section):
    """``[study]``: the speeds, the output file, what is kept and the variants."""

    speeds_kmh: Speed | list[Speed] | SpeedGrid = key(
        None, unit="km/h", default_text="required (or line_speed_kmh)",
        doc=f"a list of speeds (at most {MAX_SPEEDS}), or {{start, stop, step}}",
        expected="a list of speeds > 0 km/h, or a table {start, stop, step} in km/h")
    line_speed_kmh: Speed = key(
        None, unit="km/h", doc="instead of speeds_kmh: 140 km/h to 1.2 x line speed "
                               "(included), step 5; next to speeds_kmh: a warning when "
                               "they stop below 1.2 x line speed (EN 1991-2 6.4.6.2 [R])",
        expected=f"a line speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")
    output: Text = key(None, default_text="results/<stem>.nc",
                       doc="the netCDF results file, relative to the config's directory",
                       expected="a path to a netCDF file ending in .nc")
    save_time_histories: bool = key(True, doc="write time histories (envelopes always are)")
    history_speeds_kmh: Speed | list[Speed] = key(
        None, unit="km/h", default_text="every speed",
        doc="keep time histories only for these speeds",
        expected="a list of speeds (km/h) taken from study.speeds_kmh")
    classification_factor: Num(gt=0) = key(
        None, default_text="1.0",
        doc="alpha of LM71 in the load-effect checks, in the code profile's range "
            "(0.75-1.46, EN 1991-2 6.3.2(3) [R])")
    track_maintenance: one_of(en1991.TRACK_MAINTENANCE) = key(
        None, default_text="standard",
        doc="dynamic factor of LM71: standard Phi_3, careful Phi_2 (EN 1991-2 6.4.5.2 [R])")
    load_effects: bool = key(True, doc="reduce bending moments, shears, reactions and "
                                       "rotations in the runs (built-in decks)")
    refine_resonance: bool = key(False, doc="add the resonance speeds v = f1 D / i of every "
                                            "train (and variant) inside the grid")
    vary: dict[str, list[Any]] = key(None, doc="variants: key paths, each with a list of "
                                               "values")
    vary_together: list[dict[str, Any]] = key(
        None, doc="variants: tables of key paths varied together (optional label)")
    mass_bounds: list[PosNum] = key(None, doc="factors on bridge.mass_per_length, e.g. "
                                              "[0.9, 1.1] (EN 1991-2 6.4.6.3.2)",
                                    expected="factors on bridge.mass_per_length, e.g. "
                                             "[0.9, 1.1] (EN 1991-2 6.4.6.3.2: lower and "
                                             "upper bound)")


# ---------------------------------------------------------------- [report] [code_profile]

MAX_TEXT = 200
_Line = Annotated[str, Field(min_length=1, max_length=MAX_TEXT)] | int | float


class Report(Section):
    """``[report]``: the title block of the report (one line of text each)."""

    project: _Line = key(None, doc="project")
    client: _Line = key(None, doc="client")
    document: _Line = key(None, doc="document number")
    revision: _Line = key(None, doc="revision")
    prepared_by: _Line = key(None, doc="prepared by")
    checked_by: _Line = key(None, doc="checked by")
    approved_by: _Line = key(None, doc="approved by")
    date: _Line = key(None, doc="date")


class SourcedValue(Section):
    """``{value, clause}``: an override with the clause or rule it comes from."""

    value: float = key(required=True, doc="the value in the entry's SI unit")
    clause: Text = key(None, doc="the clause or rule the value comes from")


def _override_fields():
    out = {}
    for e in TABLE:
        if e.applies == "fixed":
            continue
        unit = "" if e.unit == "1" else e.unit
        number = (Int if e.integer else Num)(**e.limits.as_dict())
        tp = number | SourcedValue
        out[e.key] = (tp, key(None, unit=unit, default_text=f"{e.value:g}",
                              doc=f"{e.description} ({e.clause})"))
    return out


def _overrides_model():
    from pydantic import create_model

    return create_model("Overrides", __base__=Section, **_override_fields())


Overrides = _overrides_model()
Overrides.__doc__ = ("``[code_profile] overrides``: entries of the code profile "
                     "(:mod:`vsi_numba.code_profile`), a number in the entry's SI unit or "
                     "{value, clause}.")


class CodeProfile(Section):
    """``[code_profile]``: the clause values of the checks (a national annex, a client's
    rule), stored with the results."""

    name: Text = key(DEFAULT_NAME, doc="the profile's name, printed in the report",
                     expected="the name of the profile (a string), e.g. \"DE national "
                              "annex\"")
    overrides: Overrides = key(None, doc="entries of the code profile: a number in the "
                                         "entry's SI unit, or {value, clause}")



# ---------------------------------------------------------- [fatigue] [compatibility]

#: The models of a train in ``[[fatigue.traffic]]``.
FATIGUE_MODELS = ("moving_force", "interaction")
_GAMMA_EXPECTED = f"a partial factor {limits_of('fatigue_gamma_Mf').text()}"


class FatigueSection(Section):
    """``[[fatigue.sections]]``: a steel detail of the deck, its stress the bending moment
    at ``x`` over the section modulus."""

    x: Num(ge=0) = key(required=True, unit="m", doc="position of the section from the left "
                       "end of the deck", expected="a position >= 0 m along the deck",
                       example=10.0)
    section_modulus: Num(ge=1e-9) = key(required=True, unit="m^3",
                                  doc="section modulus W at the detail: stress = M / W",
                                  expected="a section modulus > 0 m^3 (stress = M / W; at "
                                           "least 1e-9 m^3)",
                                  example=0.045, plausible=(1e-4, 10.0),
                                  typical="about 0.001 to 5 m^3")
    detail_category: Num(gt=0, le=1000) = key(
        required=True, unit="MPa", doc="EN 1993-1-9 detail category Delta sigma_C (Tables "
                                       "8.1-8.10 [R]: 36 to 160)",
        expected="a detail category > 0 MPa (EN 1993-1-9: 36 to 160)", example=71)
    gamma_Ff: Num(**limits_of("fatigue_gamma_Ff").as_dict()) = key(
        None, default_text="code profile fatigue_gamma_Ff",
        doc="partial factor on the fatigue stress ranges (EN 1993-2 9.3 [R])",
        expected=_GAMMA_EXPECTED)
    gamma_Mf: Num(**limits_of("fatigue_gamma_Mf").as_dict()) = key(
        None, default_text="code profile fatigue_gamma_Mf",
        doc="partial factor on the fatigue strength (EN 1993-1-9 Table 3.1 [R])",
        expected=_GAMMA_EXPECTED)
    name: Text = key(None, default_text="its position", doc="name of the section in the "
                     "report", expected="a name (string)")


class FatigueTraffic(Section):
    """``[[fatigue.traffic]]``: one train of the operator's traffic (added to the mix)."""

    train: Text = key(required=True, doc="a library train, AnnexD-1 .. AnnexD-12, or an "
                                         "axle-load CSV file (position m, load kN; relative "
                                         "to the config)",
                      expected="a train name (`vsi trains` lists them; AnnexD-1 .. "
                               "AnnexD-12)", example="ICE3")
    speed_kmh: Num(gt=0, le=600) = key(required=True, unit="km/h", doc="its speed",
                                       expected="a speed > 0 km/h (at most 600)",
                                       example=250.0)
    per_day: Num(gt=0, le=10000) = key(required=True, unit="1/day",
                                       doc="passages per day",
                                       expected="a number of trains per day > 0",
                                       example=20)
    model: one_of(FATIGUE_MODELS) = key("moving_force", doc="the train's model: moving "
                                        "forces or the vehicles' dynamics (library trains "
                                        "that have it)")


class Fatigue(Section):
    """``[fatigue]``: the fatigue check of steel details of the deck under the dynamic
    stress histories of a traffic (EN 1991-2 6.4.6.6 [R], EN 1993-1-9)."""

    design_life_years: Num(gt=0, le=1000) = key(
        100.0, unit="years", doc="design life: passages = per_day x 365 x years",
        expected="a design life > 0 years (at most 1000)")
    mix: one_of(ANNEX_D_MIXES) = key(
        None, doc="an EN 1991-2 Annex D traffic mix [R], each train type at its Table D.1 "
                  "speed (added to [[fatigue.traffic]])")
    sections: list[FatigueSection] = key(
        required=True, doc="the details checked ([[fatigue.sections]], one or more)",
        expected="one or more [[fatigue.sections]] with x, section_modulus and "
                 "detail_category")
    traffic: list[FatigueTraffic] = key(
        None, default_text="required without mix",
        doc="the operator's trains ([[fatigue.traffic]])",
        expected="[[fatigue.traffic]] with train, speed_kmh and per_day, or fatigue.mix")


class Compatibility(Section):
    """``[compatibility]``: is the train compatible with this existing bridge?  The
    study's speeds must reach speed_factor x line_speed_kmh."""

    train: Text = key(required=True, doc="the train under check (one of the study's "
                                         "trains)",
                      expected="the name of the train under check (one of train.preset)",
                      example="ICE3")
    line_speed_kmh: Num(gt=0, le=600) = key(
        required=True, unit="km/h", doc="maximum line speed at the bridge",
        expected="a line speed > 0 km/h (at most 600)", example=300.0)
    speed_factor: Num(**limits_of("compatibility_speed_factor").as_dict()) = key(
        None, default_text="code profile compatibility_speed_factor",
        doc="checked up to this factor x the line speed ([R] practice for existing lines)",
        expected=f"a factor {limits_of('compatibility_speed_factor').text()} on the line "
                 "speed")



# ------------------------------------------------- existing bridges: [calibration], [reliability]

#: Prior and input distributions of [calibration] and [reliability].
DISTRIBUTIONS = ("uniform", "normal", "lognormal")
#: Quantities a measured record may hold.
RECORD_QUANTITIES = ("deck_acceleration", "deck_displacement")
#: Checks whose probability of exceedance [reliability] estimates.
RELIABILITY_CHECKS = ("deck_acceleration", "deck_displacement")
#: Estimators of [reliability].
RELIABILITY_METHODS = ("subset", "monte_carlo")
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


class CalibrationParameter(_Distribution):
    """``calibration.parameters[i]``: a numeric configuration key and its prior."""

    key: KeyPath = _declare(required=True, doc="the dotted key path of a numeric configuration "
                                          "key, e.g. bridge.EI or bridge.damping_ratio[0]",
                       expected="a dotted key path of a numeric key, e.g. \"bridge.EI\"",
                       example="bridge.EI")
    prior: one_of(DISTRIBUTIONS) = _declare(required=True, doc="prior distribution")


class CalibrationRecord(Section):
    """``[[calibration.records]]``: one measured passage."""

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
    speed_kmh: Speed = _declare(required=True, unit="km/h", doc="train speed of the passage",
                           expected=f"a speed > 0 km/h (at most {SPEED_BOUND_KMH:g})")


class Calibration(Section):
    """``[calibration]``: Bayesian updating of configuration keys from measured records
    (``vsi calibrate``)."""

    parameters: list[CalibrationParameter] = _declare(
        required=True, doc="the keys to update, each with its prior",
        expected="a list of tables {key, prior, ...}")
    records: list[CalibrationRecord] = _declare(required=True, doc="the measured passages",
                                           expected="[[calibration.records]] tables")
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


class ReliabilityVariable(_Distribution):
    """``reliability.variables[i]``: a numeric configuration key as a random variable."""

    key: KeyPath = _declare(required=True, doc="the dotted key path of a numeric configuration "
                                          "key, e.g. bridge.damping_ratio",
                       expected="a dotted key path of a numeric key, e.g. "
                                "\"bridge.damping_ratio\"", example="bridge.damping_ratio")
    distribution: one_of(DISTRIBUTIONS) = _declare(required=True, doc="its distribution")


class Reliability(Section):
    """``[reliability]``: the probability that a check is exceeded (``vsi reliability``)."""

    check: one_of(RELIABILITY_CHECKS) = _declare("deck_acceleration",
                                            doc="the check (its limit from the code profile "
                                                "or reliability.limit)")
    method: one_of(RELIABILITY_METHODS) = _declare("subset", doc="subset simulation (OpenTURNS) "
                                                           "or crude Monte Carlo")
    target_cov: Num(gt=0, lt=1) = _declare(0.1, doc="stop when the estimate's coefficient of "
                                               "variation is below this",
                                      expected="a coefficient of variation in (0, 1)")
    variables: list[ReliabilityVariable] = _declare(required=True, doc="the random inputs",
                                               expected="a list of tables {key, "
                                                        "distribution, ...}")
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


# ------------------------------------------------------------------------------- a file

class VsiConfig(Section):
    """A vsi_numba configuration file."""

    title: str = key(None, default_text="the file name", doc="title of results and report",
                     expected="a title (string)")
    bridge: Bridge = key(required=True, doc="the deck ([bridge])")
    train: Train = key(required=True, doc="the trains ([train])")
    irregularity: Irregularity = key(None, default_text="kind = \"none\"",
                                     doc="the track profile ([irregularity])")
    solver: Solver = key(None, default_text="the defaults", doc="the time integration "
                                                                "([solver])")
    contact: Contact = key(None, default_text="rigid", doc="the wheel-rail contact "
                                                           "([contact])")
    track: Track = key(None, default_text="elastic", doc="the track ([track])")
    study: Study = key(required=True, doc="the speeds and the output ([study])")
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
    ("fatigue.traffic", FatigueTraffic), ("compatibility", Compatibility),
    ("calibration", Calibration), ("calibration.parameters", CalibrationParameter),
    ("calibration.records", CalibrationRecord), ("reliability", Reliability),
    ("reliability.variables", ReliabilityVariable),
)
