"""The keys of ``[bridge]`` and ``[bridge.track]``: one model per deck kind, and the rules
between the keys of one deck (:meth:`_Deck._rules`)."""

import math
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import (
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails

from vsi_numba import en1990, en1991
from vsi_numba.config.limits import (
    MAX_ELEMENTS,
    MAX_FIXED_DOFS,
    MAX_MODES,
    MAX_OUTPUT_POINTS,
    MAX_SPANS,
    MAX_TRACK_DOFS,
    MAX_TRACKS,
)
from vsi_numba.config.schema._fields import (
    RULE,
    Int,
    Num,
    PosNum,
    Section,
    Text,
    adapter,
    key,
    one_of,
    rule_error,
)

#: The value of ``damping_ratio`` that applies EN 1991-2 Table 6.6.
EN_DAMPING = "EN1991-2"
#: The words after the expectation of a key given per span.
_PER_SPAN = " (a number, or a list with one value per span)"

# ------------------------------------------------------------------------------ [bridge]

class BridgeTrack(Section):
    """``[bridge.track]``: a ballasted track layer assembled with a ``continuous`` deck
    before the modal reduction (values per track, both rails); the train runs on the rail.
    """

    TABLE: ClassVar[str] = "a table [bridge.track] of track-layer values"

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


#: A number > 0, or one per span (at most :data:`MAX_SPANS`).
PerSpan = PosNum | Annotated[list[PosNum], Field(min_length=1, max_length=MAX_SPANS)]
Spans = PerSpan
Ratio = Num(ge=0, lt=1)
Damping = Ratio | Annotated[list[Ratio], Field(min_length=1)] | Literal["EN1991-2"]
Points = float | Annotated[list[float], Field(min_length=1, max_length=MAX_OUTPUT_POINTS)]
#: A name in the data: not blank.
Name = Annotated[str, Field(min_length=1, pattern=r"\S")]


def _show(v) -> str:
    from vsi_numba.config._show import _show

    return _show(v)


def _number(v) -> bool:
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


class _Deck(Section):
    """The keys of every deck, and the rules between the keys of one deck."""

    TABLE: ClassVar[str] = "a table [bridge] with kind, spans, EI, mass_per_length"
    #: the kind takes one span
    ONE_SPAN: ClassVar[bool] = False
    #: the keys of the other kinds given (set aside, warned by the reader)
    _ignored: list[str] = PrivateAttr(default_factory=list)

    track_type: one_of(en1990.DECK_ACCELERATION_LIMITS) = key(
        "ballasted", doc="track form on the deck: the EN 1990 A2 deck-acceleration limit "
                         "(3.5 m/s2 ballasted, 5 m/s2 direct fastening)")
    output_points: Points = key(
        None, unit="m", default_text="every mid-span",
        doc="deck positions of the outputs (from the left end)",
        expected=f"a list of at most {MAX_OUTPUT_POINTS} positions on the deck (m)",
        each="a position x (m)", scalar="a position x (m)")

    @model_validator(mode="wrap")
    @classmethod
    def _the_deck_of_its_kind(cls, data, handler):
        """A key of another kind of deck is set aside (the reader warns); ``[bridge.track]``
        of another kind is refused; the rules between the keys (:meth:`_rules`) are
        reported with the errors of the keys."""
        if not isinstance(data, dict):
            return handler(data)
        ignored = [k for k in data if k not in cls.model_fields and k in _EVERY_KEY
                   and k != "track"]
        kept = {k: v for k, v in data.items() if k not in ignored}
        problems = []
        if "track" in kept and "track" not in cls.model_fields:
            problems.append((("track",), kept.pop("track"), (
                f"no [bridge.track] with kind = '{data.get('kind')}': the track layer is "
                "assembled into the FE model of kind = 'continuous' (use it with a single "
                "span for one span)")))
        try:
            out, err = handler(kept), None
        except ValidationError as exc:
            out, err = None, exc
        values = dict(out) if out is not None else _valid_values(cls, kept)
        problems += cls._rules(values, data)
        if err is None and not problems:
            out._ignored = ignored
            return out
        raise _with_rules(cls.__name__, err, problems)

    @classmethod
    def _rules(cls, v: dict, given: dict) -> list:
        """The problems ``(location, value, expected)`` of the rules between the keys of
        this deck: ``v`` its valid values (defaults for the keys not given), ``given`` the
        table as written."""
        out: list = []
        kind = given.get("kind")
        spans = v.get("spans")
        span_list = [spans] if isinstance(spans, float) else spans
        if cls.ONE_SPAN and isinstance(spans, list) and len(spans) != 1:
            more = " (use kind = 'continuous' for several spans)" if kind != "rigid" else ""
            out.append((("spans",), given["spans"],
                        f"one span length for kind = '{kind}'{more}"))
            span_list = None
        n = len(span_list) if span_list else None
        beam = "EI" in cls.model_fields
        if beam and n is not None:
            for name in ("EI", "mass_per_length"):
                out += _per_span(v.get(name), (name,), given.get(name), n)
            t = v.get("torsion")
            if t is not None:
                for name in ("GJ", "polar_mass"):
                    out += _per_span(getattr(t, name), ("torsion", name),
                                     given["torsion"].get(name), n)
        if beam and v.get("torsion") is not None and "track" in given:
            out.append((("torsion",), given["torsion"], (
                "no torsion with the FE track layer [bridge.track] (the layer is planar): "
                "leave out one of them")))
        if "damping_ratio" in cls.model_fields:
            out += cls._damping_rules(v, given, beam)
        eps = v.get("elements_per_span")
        if eps is not None and n is not None and n * eps > MAX_ELEMENTS:
            out.append((("elements_per_span",), eps, f"at most {MAX_ELEMENTS} elements in "
                        f"all ({n} spans x {eps} = {n * eps})"))
        if v.get("track") is not None and span_list:
            out += _track_layer(v["track"], span_list)
        points = v.get("output_points")
        if points is not None and span_list and "file" not in cls.model_fields \
                and "station_map" not in cls.model_fields:
            length = float(sum(span_list))
            for i, x in enumerate([points] if isinstance(points, float) else points):
                if not -1e-9 <= x <= length + 1e-9:
                    out.append((("output_points", i), x, f"a position on the bridge, "
                                f"0 <= x <= {length:g} m"))
        return out

    @classmethod
    def _damping_rules(cls, v, given, beam) -> list:
        """``damping_ratio = 'EN1991-2'`` with its ``deck_type`` (beam decks only),
        ``additional_damping`` (beam decks only)."""
        out: list = []
        kind = given.get("kind")
        en = given.get("damping_ratio") == EN_DAMPING
        if en and not beam:
            out.append((("damping_ratio",), EN_DAMPING, (
                f"a number for bridge.kind = '{kind}' (Table 6.6 is for simply supported "
                "and continuous decks)")))
        elif en and "deck_type" not in given:
            listing = ", ".join(f"'{c}'" for c in en1991.DECK_TYPES)
            out.append((("deck_type",), None, f"one of {listing}"))
        if "deck_type" in given and not en:
            out.append((("deck_type",), given["deck_type"], (
                f"only with damping_ratio = '{EN_DAMPING}' (the Table 6.6 lower bound of "
                "that deck type)")))
        extra = given.get("additional_damping", False)
        if not beam and extra is not False:
            out.append((("additional_damping",), extra, "true or false" if not isinstance(
                extra, bool) else f"false for bridge.kind = '{kind}' (the rule is for simply "
                "supported and continuous decks)"))
        return out


def _per_span(value, loc, given, n) -> list:
    if isinstance(value, list) and len(value) != n:
        return [(loc, given, f"one value per span ({n} span{'s' if n != 1 else ''}) or a "
                 "single number")]
    return []


def _track_layer(track, spans) -> list:
    """The sleepers of ``[bridge.track]`` on the spans: at most half the shortest span
    apart, and at most :data:`MAX_TRACK_DOFS` rail and sleeper DOFs."""
    a, n_e = track.sleeper_spacing, track.rail_elements_per_bay
    loc = ("track", "sleeper_spacing")
    if a > 0.5 * min(spans):
        return [(loc, a, f"a spacing of at most half the shortest span ({min(spans):g} m)")]
    n_rail = 2 * n_e * (sum(spans) / a + 1)
    if n_rail + sum(spans) / a > MAX_TRACK_DOFS:
        return [(loc, a, f"a track layer of at most {MAX_TRACK_DOFS} rail and sleeper DOFs "
                 f"(this one has about {n_rail + sum(spans) / a:.0f}: fewer "
                 "rail_elements_per_bay, or a shorter deck)")]
    return []


def _path(loc) -> str:
    out = "bridge"
    for x in loc:
        out += f"[{x}]" if isinstance(x, int) else f".{x}"
    return out


def _valid_values(model, data: dict) -> dict:
    """The keys of ``data`` that are valid alone (each validated by its declaration),
    and the defaults of the keys not given: what the rules see when some key is not
    valid."""
    out = {n: f.get_default() for n, f in model.model_fields.items() if not f.is_required()}
    for k, x in data.items():
        if k in model.model_fields:
            table = model.model_fields[k].annotation
            try:
                out[k] = (table.model_validate(x) if isinstance(table, type) and issubclass(
                    table, Section) else adapter(model, k).validate_python(x))
            except ValidationError:
                out.pop(k, None)
    return out


def _with_rules(title: str, err: ValidationError | None, problems) -> ValidationError:
    """The errors of ``err`` and the problems of the rules in one ValidationError; a rule
    speaks for its key (the errors of the keys at or inside it are left out)."""
    from pydantic_core import PydanticCustomError

    lines: list = []
    locs = [loc for loc, _, _ in problems]
    for e in err.errors(include_url=False) if err is not None else []:
        if any(tuple(e["loc"][:len(loc)]) == loc for loc in locs):
            continue
        tp = e["type"]
        if tp == RULE:
            tp = PydanticCustomError(RULE, "{message}", e["ctx"])
        line = InitErrorDetails(type=tp, loc=e["loc"], input=e["input"])
        if "ctx" in e and not isinstance(tp, PydanticCustomError):
            line["ctx"] = e["ctx"]
        lines.append(line)
    for loc, value, expected in problems:
        path = _path(loc)
        msg = (f"{path}: missing required key; expected {expected}" if value is None else
               f"{path} = {_show(value)}: expected {expected}")
        lines.append(InitErrorDetails(type=rule_error(msg), loc=loc, input=value))
    return ValidationError.from_exception_data(title, lines)


class _Modal(_Deck):
    damping_ratio: Damping = key(
        0.0, doc="damping ratio (fraction of critical): a number, one per mode, or "
                 "\"EN1991-2\" (the EN 1991-2 Table 6.6 lower bound for the span L and "
                 "deck_type, from the code profile; L of a continuous deck: its mean "
                 "span, the profile's DAMPING_SPAN_RULE)",
        expected="a damping ratio 0 <= zeta < 1, a list with one per mode, or 'EN1991-2' "
                 "(Table 6.6 with bridge.deck_type)",
        each="a damping ratio 0 <= zeta < 1", scalar="a damping ratio 0 <= zeta < 1")
    n_modes: Int(ge=1, le=MAX_MODES) = key(
        None, default_text="every mode up to the deck-acceleration cut-off "
                           "(solver.acceleration_cutoff, else EN 1990 A2 max(30 Hz, 1.5 f1, "
                           "f3)); 10 with [bridge.track] and matrices; modes_file: all",
        doc="modes kept (with max_frequency: the smaller set)",
        expected=f"an integer number of modes 1 <= n_modes <= {MAX_MODES}")
    max_frequency: PosNum = key(None, unit="Hz", doc="keep every mode up to this frequency",
                                expected="a frequency > 0 Hz")

    @field_validator("damping_ratio", mode="before")
    @classmethod
    def _a_fraction_not_a_percentage(cls, v):
        """A ratio >= 1 is a percentage (1.5 -> did you mean 0.015?)."""
        path = "bridge.damping_ratio"
        items = [(path, v)] if not isinstance(v, list) else [
            (f"{path}[{i}]", z) for i, z in enumerate(v)]
        if not items or not all(_number(z) and z >= 0 for _, z in items):
            return v
        lines = [f"{p} = {_show(float(z))}: expected a damping ratio 0 <= zeta < 1 (a "
                 f"fraction of critical, not a percentage): did you mean {z / 100:g} "
                 f"({float(z):g} %)?" for p, z in items if z >= 1]
        if lines:
            raise rule_error("\n".join(lines))
        return v


class TrackLine(Section):
    """``[bridge] tracks = [{ eccentricity = y }, ...]``: one track on the deck, its centre
    line at y from the deck's reference axis, its two rails at y +- gauge / 2."""

    TABLE: ClassVar[str] = "a table { eccentricity = y } (m)"

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

    TABLE: ClassVar[str] = "a table { GJ, polar_mass, damping_ratio }"

    GJ: PerSpan = key(required=True, unit="N m^2", doc="torsional stiffness, a number or "
                      "one per span",
                      expected="a torsional stiffness GJ > 0 N m^2" + _PER_SPAN,
                      each="a torsional stiffness GJ > 0 N m^2",
                      scalar="a torsional stiffness GJ > 0 N m^2",
                      plausible=(1e7, 1e14), typical="about 1e9 for a slab, 1e11 for a "
                                                     "double-track box girder")
    polar_mass: PerSpan = key(required=True, unit="kg m^2/m",
                              doc="polar mass moment of inertia per length about the "
                                  "reference axis, a number or one per span",
                              expected="a polar mass moment per length > 0 kg m^2/m"
                                       + _PER_SPAN,
                              each="a polar mass moment per length > 0 kg m^2/m",
                              scalar="a polar mass moment per length > 0 kg m^2/m",
                              plausible=(1e2, 1e8), typical="about 4e5 for a double-track "
                                                            "box girder")
    damping_ratio: Num(ge=0, lt=1) = key(0.0, doc="damping ratio of the torsional modes",
                                         expected="a damping ratio 0 <= zeta < 1")
    n_modes: Int(ge=1, le=MAX_MODES) = key(
        None, default_text="every torsional mode up to the highest bending mode kept",
        doc="torsional modes kept", expected=f"an integer number of torsional modes "
                                             f"1 <= n_modes <= {MAX_MODES}")


_ONE_SPAN = dict(unit="m", expected="a span length > 0 m (one value)",
                 each="a span length > 0 m", scalar="a span length > 0 m")
_SPANS = dict(unit="m", expected="a list of span lengths > 0 m (one per span)",
              each="a span length > 0 m", scalar="a span length > 0 m")


class _Beam(_Modal):
    tracks: Annotated[list[TrackLine], Field(min_length=1, max_length=MAX_TRACKS)] = key(
        None, default_text="one track on the axis, [{ eccentricity = 0 }]",
        doc="the tracks on the deck, each { eccentricity, gauge } (beam decks) or "
            "{ line, eccentricity } (imported decks: named by their lines in the data, the "
            "eccentricity a label only); train.track picks the loaded one",
        expected=f"a list of 1 to {MAX_TRACKS} tracks, each {{ eccentricity = y }} (m)",
        example=[{"eccentricity": 2.25}, {"eccentricity": -2.25}])
    torsion: Torsion = key(None, default_text="none (the deck does not twist)",
                           doc="{ GJ, polar_mass, damping_ratio }: torsional modes of the "
                               "deck")
    spans: Spans = key(required=True, doc="span lengths", **_SPANS)
    EI: PerSpan = key(required=True, unit="N m^2", doc="bending stiffness, a number or one "
                      "per span", expected="a bending stiffness EI > 0 N m^2" + _PER_SPAN,
                      each="a bending stiffness EI > 0 N m^2",
                      scalar="a bending stiffness EI > 0 N m^2")
    mass_per_length: PerSpan = key(required=True, unit="kg/m",
                                   doc="mass per length (deck + ballast + track), a number "
                                       "or one per span",
                                   expected="a mass per length > 0 kg/m" + _PER_SPAN,
                                   each="a mass per length > 0 kg/m",
                                   scalar="a mass per length > 0 kg/m")
    deck_type: one_of(en1991.DECK_TYPE_KEYS) = key(
        None, doc="with damping_ratio = \"EN1991-2\": the deck type of Table 6.6")
    additional_damping: bool = key(
        False, doc="add the EN 1991-2 6.4.6.3.1 additional damping (L < 30 m, Fig. 6.15) "
                   "in moving-force analyses")


class SimplySupported(_Beam):
    """``kind = "simply_supported"``: one Euler-Bernoulli span, modes in closed form."""

    ONE_SPAN: ClassVar[bool] = True

    spans: Spans = key(required=True, doc="span lengths", **_ONE_SPAN)
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

    ONE_SPAN: ClassVar[bool] = True

    kind: Literal["rigid"] = key(required=True, doc="bridge model")
    spans: Spans = key(required=True, doc="the track length covered (one value)",
                       **_ONE_SPAN)


class ImportedTrack(Section):
    """``[bridge] tracks = [{ line = "T" }, ...]`` of an imported deck: one track, named by
    its lines in the modes file or station map (rails ``T/left`` and ``T/right``, and/or
    the centre line ``T``)."""

    TABLE: ClassVar[str] = "a table { line = \"T\" }"

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
    spans: Spans = key(None, default_text="the length of the track line",
                       doc="span lengths along the track line (the table must cover "
                           "their sum)", **_SPANS)
    track_line: Name = key(None, default_text="the only line",
                           doc="the track line of the file when it has several (not with "
                               "tracks)",
                           expected="the name of a track line (string)")
    tracks: Annotated[list[ImportedTrack], Field(min_length=1, max_length=MAX_TRACKS)] = key(
        None, default_text="none: the deck is the track line (track_line)",
        doc="the tracks on the deck, each { eccentricity, gauge } (beam decks) or "
            "{ line, eccentricity } (imported decks: named by their lines in the data, the "
            "eccentricity a label only); train.track picks the loaded one",
        expected=f"a list of 1 to {MAX_TRACKS} tracks, each {{ line = \"T\" }} (a track of "
                 "the data)",
        example=[{"line": "up"}, {"line": "down"}])

    @classmethod
    def _rules(cls, v: dict, given: dict) -> list:
        """The deck's rules, and the tracks of the data: each its own line, named by the
        tracks or by track_line, not both."""
        out = super()._rules(v, given)
        tracks = v.get("tracks")
        if tracks is None:
            return out
        if "track_line" in given:
            return out + [(("track_line",), given["track_line"], (
                "no track_line with bridge.tracks: each track names its line "
                "({ line = \"T\" })"))]
        seen: dict[str, int] = {}
        for i, tr in enumerate(tracks):
            if tr.line in seen:
                return out + [(("tracks", i, "line"), tr.line, (
                    f"a track of its own (bridge.tracks[{seen[tr.line]}] is that track "
                    "already)"))]
            seen[tr.line] = i
        return out


class ModesFile(_Imported):
    """``kind = "modes_file"``: modes imported from a table (netCDF or CSV,
    :mod:`vsi_numba.model.imported`)."""

    kind: Literal["modes_file"] = key(required=True, doc="bridge model")
    file: Text = key(required=True, doc="the modes table (netCDF or CSV)",
                     expected="the path of the deck modes (frequencies, modal masses, mode "
                              "shapes at stations)")
    mass_normalised: bool = key(None, default_text="from the file",
                                doc="true when the shapes are mass-normalised (no "
                                    "modal_mass column)")


#: A DOF number of the files (>= dof_base: a rule of :class:`Matrices`).
_Dof = Int(ge=0)
_DOF_EACH = "an integer DOF number >= dof_base (0, or 1 with dof_base = 1)"
_DOFS = f"a list of at most {MAX_FIXED_DOFS} integer DOF numbers >= dof_base"


class Matrices(_Imported):
    """``kind = "matrices"``: stiffness and mass matrices (Matrix Market) with a station
    map, reduced to modes at load time."""

    kind: Literal["matrices"] = key(required=True, doc="bridge model")
    stiffness_matrix: Text = key(required=True, doc="the stiffness matrix K (Matrix Market)",
                                 expected="the path of the stiffness matrix K (Matrix "
                                          "Market)")
    mass_matrix: Text = key(required=True, doc="the mass matrix M (Matrix Market)",
                            expected="the path of the mass matrix M (Matrix Market)")
    station_map: Text = key(required=True, doc="the station map (CSV: x, dof, rotation_dof, "
                                               "line)",
                            expected="the path of the station map (CSV: x, dof, "
                                     "rotation_dof, line)")
    fixed_dofs: Annotated[list[_Dof], Field(max_length=MAX_FIXED_DOFS)] = key(
        [], doc="DOFs to fix ([]: the supports are already applied)", expected=_DOFS,
        each=_DOF_EACH)
    dof_base: Int(ge=0, le=1) = key(0, doc="DOF numbering of the files: from 0 or from 1",
                                    expected="0 (DOFs numbered from 0) or 1 (from 1)")
    rotation_sign: Literal[1, -1, 1.0, -1.0] = key(
        1, doc="sign of the rotation DOFs (+dw/dx or -dw/dx)",
        expected="1 (rotation DOF = +dw/dx) or -1 (= -dw/dx)")
    vertical_dofs: Union[Annotated[list[_Dof], Field(max_length=MAX_FIXED_DOFS)],
                         "DofPattern"] = key(
        None, default_text="the station DOFs",
        doc="the vertical DOFs of the track line: a list, or {start, step}",
        expected=_DOFS + ", or {start = i, step = s}", each=_DOF_EACH)

    @field_validator("rotation_sign", mode="before")
    @classmethod
    def _a_number(cls, v):
        if isinstance(v, bool):  # (true == 1 for the choices)
            raise ValueError("not a number")
        return v

    @classmethod
    def _rules(cls, v: dict, given: dict) -> list:
        """The deck's rules, and the DOF numbers from dof_base."""
        out = super()._rules(v, given)
        base = v.get("dof_base")
        if base is None:
            return out
        vert = v.get("vertical_dofs")
        items = [(("fixed_dofs", i), x) for i, x in enumerate(v.get("fixed_dofs") or [])]
        if isinstance(vert, list):
            items += [(("vertical_dofs", i), x) for i, x in enumerate(vert)]
        elif vert is not None and vert.start is not None:
            items.append((("vertical_dofs", "start"), vert.start))
        return out + [(loc, x, f"an integer DOF number >= dof_base ({base})")
                      for loc, x in items if x < base]


class DofPattern(Section):
    """``{start, step}``: every step-th DOF from start."""

    TABLE: ClassVar[str] = "a table {start = i, step = s}"

    start: Int(ge=0) = key(None, default_text="dof_base", doc="first DOF",
                           expected="an integer DOF number >= dof_base")
    step: Int(ge=1) = key(1, doc="DOF step", expected="an integer step >= 1")


Matrices.model_rebuild()

Bridge = Annotated[SimplySupported | Continuous | Rigid | ModesFile | Matrices,
                   Field(discriminator="kind")]

#: Every key of the kinds of ``[bridge]``.
_EVERY_KEY: Any = frozenset().union(*(m.model_fields for m in (
    SimplySupported, Continuous, Rigid, ModesFile, Matrices)))
