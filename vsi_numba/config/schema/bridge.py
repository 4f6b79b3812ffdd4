"""The keys of ``[bridge]`` and ``[bridge.track]``: one model per deck kind."""

from typing import Annotated, Literal, Union

from pydantic import Field

from vsi_numba import en1990, en1991
from vsi_numba.config.limits import MAX_ELEMENTS, MAX_MODES, MAX_OUTPUT_POINTS
from vsi_numba.config.schema._fields import Int, Num, PosNum, Section, Text, key, one_of

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
