"""The messages of the tables the declared models validate (vsi_numba.config._errors):
pydantic's errors rendered as key path, value and the declared expectation; the union
member that fits the value speaks for the key; the rules between keys of a table are
reported with its other errors; a key of another kind is named as such."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from vsi_numba.config import ConfigError, load_config

BASE = {
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.3e9,
               "mass_per_length": 2303.0, "n_modes": 3},
    "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6}]},
    "study": {"speeds_kmh": [100.0]},
}


def errors(**sections) -> list[str]:
    data = copy.deepcopy(BASE)
    for name, value in sections.items():
        data[name] = value
    with pytest.raises(ConfigError) as info:
        load_config(data)
    return info.value.errors


def test_messages__an_item_of_a_list_is_named_with_the_items_expectation():
    assert errors(study={"speeds_kmh": [100.0, -3]}) == [
        "study.speeds_kmh[1] = -3: expected a speed > 0 km/h (at most 1000)"]
    assert errors(study={"speeds_kmh": "fast"}) == [
        'study.speeds_kmh = "fast": expected a list of speeds > 0 km/h, or a table '
        "{start, stop, step} in km/h"]
    assert errors(study={"speeds_kmh": []}) == [
        "study.speeds_kmh = []: expected a list of speeds > 0 km/h, or a table "
        "{start, stop, step} in km/h"]


def test_messages__the_table_member_of_a_union_speaks_for_a_table():
    assert errors(study={"speeds_kmh": {"start": 100.0, "stop": 200.0, "stpe": 5.0}}) == [
        "study.speeds_kmh.stpe = 5.0: unknown key; did you mean 'step'?",
        "study.speeds_kmh.step: missing required key; expected a step > 0 km/h"]


def test_messages__rules_between_keys_are_reported_with_the_other_errors():
    errs = errors(irregularity={"kind": "psd", "spectrum": "german_lo",
                                "wavelength_min": 3.0, "wavelength_max": 1.0,
                                "seeds": [1, 1]},
                  study={"speeds_kmh": {"start": 140.0, "stop": 100.0, "step": 5.0}})
    assert errs == [  # in the order of the file's tables
        "study.speeds_kmh.stop = 100.0: expected a speed >= start = 140 km/h",
        "irregularity.spectrum = \"german_lo\": expected one of 'fra1', 'fra2', 'fra3', "
        "'fra4', 'fra5', 'fra6', 'german_low', 'german_high' (did you mean 'german_low'?)",
        "irregularity.wavelength_max = 1.0: expected a wavelength > wavelength_min = 3 m",
        "irregularity.seeds = [1, 1]: expected distinct seeds",
    ]


def test_messages__kinds_and_tables_of_a_list_of_kinds():
    errs = errors(irregularity={"kind": "none", "defects": [
        3, {"kind": "cosin"}, {"depth": 1e-3},
        {"kind": "step", "height": 0.0, "length": 2.0, "position": 1.0}]})
    assert errs == [
        "irregularity.defects[0] = 3: expected a table with kind = 'cosine' | 'step'",
        "irregularity.defects[1].kind = \"cosin\": expected one of 'cosine', 'step' (did "
        "you mean 'cosine'?)",
        "irregularity.defects[2].kind: missing required key; expected one of 'cosine', "
        "'step'",
        "irregularity.defects[3].height = 0.0: expected a level change != 0 m (> 0: the "
        "rail ends lower), |height| < 1 m",
    ]
    assert errors(irregularity={"kind": "sine"}) == [
        "irregularity.kind = \"sine\": expected one of 'none', 'cosine', 'step', 'psd', "
        "'file' (did you mean 'cosine'?)"]


def test_messages__a_key_of_another_kind():
    data = copy.deepcopy(BASE)
    data["train"]["vehicles"][0]["body_mass"] = 4.0e4
    with pytest.raises(ConfigError) as info:
        load_config(data)
    assert info.value.errors == [
        "train.vehicles[0].body_mass = 40000.0: expected no such key for kind = "
        "'sprung_mass' (it belongs to kind = 'car')"]
    # [irregularity]: a key of another kind of profile is ignored, with a warning
    cfg = load_config({**copy.deepcopy(BASE), "irregularity": {"kind": "none",
                                                               "wavelength": 3.0}})
    assert cfg.warnings == ["irregularity.wavelength is ignored: not used by "
                            "irregularity.kind = 'none'"]


def test_messages__tables_rules_and_hidden_keys():
    assert errors(solver=[1]) == ["solver = [1]: expected a table [solver] (dt, hht_alpha, "
                                  "...)"]
    assert errors(solver={"allow_implausibel": True}) == [
        "solver.allow_implausibel = true: unknown key; expected one of 'acceleration_cutoff', "
        "'approach', 'dt', 'free_vibration', 'hht_alpha', 'max_iterations', "
        "'max_subdivisions'"]
    assert errors(contact={"model": "hertz"}) == [
        "contact.hertz_coefficient: missing required key; expected a Hertz constant G > 0 "
        "m N^-2/3 (about 4e-8 for a wheel on a rail)"]
    assert errors(track={"model": "rigid", "load_distribution": "elastic_track"}) == [
        "track.load_distribution = \"elastic_track\": expected 'none', 'rail' or "
        "'rail_ballast' with track.model = 'rigid' ('elastic_track' spreads the forces by "
        "the rail on the elastic foundation)"]
    assert errors(report={"project": "  "}) == [
        'report.project = "  ": expected one line of text (1 to 200 characters)']
    assert errors(code_profile={"overrides": {"wheel_unloading_limit": {
        "value": -0.5, "clause": "R-12"}}})[0].startswith(
        "code_profile.overrides.wheel_unloading_limit.value = -0.5: expected a number > 0")


def test_messages__the_top_level():
    with pytest.raises(ConfigError) as info:
        load_config({"titel": "x", "bridge": BASE["bridge"], "study": BASE["study"]})
    assert info.value.errors == [
        "titel = \"x\": unknown key; did you mean 'title'?",
        "train: missing required key; expected a table [train] with preset, "
        "[[train.vehicles]] or file"]


def test_messages__a_table_declared_as_a_union_of_kinds_is_read_by_its_kind():
    """A table whose declaration is ``Annotated[A | B, Field(discriminator="kind")]`` (the
    discriminator on the table's field) is validated by the model of the kind given: a
    key of another kind is set aside (as in [irregularity]), a misspelt kind guessed, and
    no member of the union speaks for another's keys."""
    from vsi_numba.config._check import _Checker
    from vsi_numba.config._errors import typed_section
    from vsi_numba.config.schema import VsiConfig

    def typed(**change):
        chk = _Checker()
        out = typed_section(chk, {"bridge": {**BASE["bridge"], **change}}, "bridge", VsiConfig)
        return out, chk.errors

    def bridge_errors(**change):
        return typed(**change)[1]

    deck, errs = typed(elements_per_span=10, file="modes.csv")
    assert errs == [] and type(deck).__name__ == "SimplySupported"
    assert deck._ignored == ["elements_per_span", "file"]
    cfg = load_config({**copy.deepcopy(BASE), "bridge": {**BASE["bridge"],
                                                         "elements_per_span": 10}})
    assert cfg.warnings == ["bridge.elements_per_span is ignored: not used by bridge.kind = "
                            "'simply_supported'"]
    assert bridge_errors(kind="simply_suported") == [
        "bridge.kind = \"simply_suported\": expected one of 'simply_supported', "
        "'continuous', 'rigid', 'modes_file', 'matrices' (did you mean 'simply_supported'?)"]
    assert bridge_errors(EI=-1.0) == ["bridge.EI = -1.0: expected a bending stiffness EI > 0 "
                                      "N m^2"]


def test_messages__bridge_rules_are_reported_with_the_keys_errors():
    """[bridge]: the rules between its keys (one value per span, a percentage as damping,
    deck_type only with Table 6.6, the elements in all, points on the deck) come with the
    errors of its keys, each once; a number given for a number-or-list key is named with
    the expectation of one number."""
    deck = {"kind": "continuous", "spans": [20.0, 25.0], "EI": [1e10, 2e10, 3e10],
            "mass_per_length": -1.0, "n_modes": 0, "damping_ratio": [0.02, 1.5],
            "deck_type": "steel_composite", "elements_per_span": 400,
            "output_points": [10.0, 46.0]}
    got = errors(bridge=deck)
    assert set(got) == {
        "bridge.output_points[1] = 46.0: expected a position on the bridge, 0 <= x <= 45 m",
        "bridge.damping_ratio[1] = 1.5: expected a damping ratio 0 <= zeta < 1 (a fraction "
        "of critical, not a percentage): did you mean 0.015 (1.5 %)?",
        "bridge.n_modes = 0: expected an integer number of modes 1 <= n_modes <= 1000",
        "bridge.mass_per_length = -1.0: expected a mass per length > 0 kg/m",
        "bridge.EI = [10000000000.0, 20000000000.0, 30000000000.0]: expected one value per "
        "span (2 spans) or a single number",
        "bridge.deck_type = \"steel_composite\": expected only with damping_ratio = "
        "'EN1991-2' (the Table 6.6 lower bound of that deck type)"}, got
    many = dict(deck, EI=1e10, mass_per_length=1e4, n_modes=3, damping_ratio=0.02,
                output_points=[10.0], spans=[10.0] * 3)
    many.pop("deck_type")
    assert errors(bridge=many) == [
        "bridge.elements_per_span = 400: expected at most 1000 elements in all (3 spans x "
        "400 = 1200)"]
    assert errors(bridge={**BASE["bridge"], "spans": [10.0, 15.0], "EI": "stiff"}) == [
        "bridge.EI = \"stiff\": expected a bending stiffness EI > 0 N m^2 (a number, or a "
        "list with one value per span)",
        "bridge.spans = [10.0, 15.0]: expected one span length for kind = "
        "'simply_supported' (use kind = 'continuous' for several spans)"]
    assert errors(bridge={**BASE["bridge"], "spans": -3}) == [
        "bridge.spans = -3: expected a span length > 0 m"]
    assert errors(bridge={**BASE["bridge"], "damping_ratio": "EN1991-2"}) == [
        "bridge.deck_type: missing required key; expected one of 'steel_composite', "
        "'prestressed_concrete', 'filler_beam_reinforced_concrete'"]


def test_messages__bridge_kinds_tracks_and_dofs():
    """The keys of another kind of deck are set aside (warned); [bridge.track] of another
    kind, Table 6.6 and additional damping on an imported deck are refused; a table
    without kind names its unknown keys; the tables of an imported deck's tracks are
    named by its own kind; DOF numbers from dof_base."""
    rigid = {"kind": "rigid", "spans": 30.0, "EI": 1e10, "damping_ratio": "garbage"}
    cfg = load_config({**copy.deepcopy(BASE), "bridge": rigid})
    assert cfg.warnings[:2] == [
        "bridge.EI is ignored: not used by bridge.kind = 'rigid'",
        "bridge.damping_ratio is ignored: not used by bridge.kind = 'rigid'"]
    assert errors(bridge={**rigid, "track": {"rail_EI": 1.0}})[0].startswith(
        "bridge.track = {rail_EI = 1.0}: expected no [bridge.track] with kind = 'rigid'")
    assert errors(bridge={"knd": "rigid", "spans": 30.0}) == [
        "bridge.knd = \"rigid\": unknown key; did you mean 'kind'?",
        "bridge.kind: missing required key; expected one of 'simply_supported', "
        "'continuous', 'rigid', 'modes_file', 'matrices'"]
    modes = {"kind": "modes_file", "file": "missing.nc", "damping_ratio": "EN1991-2",
             "additional_damping": True, "tracks": [3, {"line": "A"}, {"line": "A"}]}
    assert errors(bridge=modes) == [
        "bridge.tracks[0] = 3: expected a table { line = \"T\" }",
        "bridge.damping_ratio = \"EN1991-2\": expected a number for bridge.kind = "
        "'modes_file' (Table 6.6 is for simply supported and continuous decks)",
        "bridge.additional_damping = true: expected false for bridge.kind = 'modes_file' "
        "(the rule is for simply supported and continuous decks)",
        f"bridge.file = \"missing.nc\": expected an existing file with the deck modes "
        f"(frequencies, modal masses, mode shapes at stations) (looked for "
        f"{Path.cwd() / 'missing.nc'})"]
    assert errors(bridge={"kind": "modes_file", "file": "m.nc", "track_line": "A",
                          "tracks": [{"line": "A"}]})[0] == (
        "bridge.track_line = \"A\": expected no track_line with bridge.tracks: each track "
        "names its line ({ line = \"T\" })")
    mats = {"kind": "matrices", "stiffness_matrix": "K.mtx", "mass_matrix": "M.mtx",
            "station_map": "s.csv", "dof_base": 1, "fixed_dofs": [0, 3],
            "vertical_dofs": {"start": 0}, "rotation_sign": True}
    got = errors(bridge=mats)
    assert set(got[:3]) == {
        "bridge.rotation_sign = true: expected 1 (rotation DOF = +dw/dx) or -1 (= -dw/dx)",
        "bridge.fixed_dofs[0] = 0: expected an integer DOF number >= dof_base (1)",
        "bridge.vertical_dofs.start = 0: expected an integer DOF number >= dof_base (1)"}, got
    assert errors(bridge={**mats, "fixed_dofs": [0, -1], "vertical_dofs": [1]})[0] == (
        "bridge.fixed_dofs[1] = -1: expected an integer DOF number >= dof_base (0, or 1 "
        "with dof_base = 1)")
    assert all(e.startswith("bridge.") and "existing file" in e for e in got[3:]), got


def test_messages__a_deck_with_torsion_and_absurd_values_is_refused_not_crashed():
    """A simply supported deck with torsion whose bending or torsional frequencies are far
    apart (EI = 1e30, or a polar mass of 1e30) is refused by the plausibility check, or
    loads; its torsional spectrum is bounded (it took all the memory
    before)."""
    from vsi_numba.config import MAX_MODES

    deck = {**BASE["bridge"], "tracks": [{"eccentricity": 2.0}],
            "torsion": {"GJ": 1e10, "polar_mass": 1e30}}
    assert errors(bridge=deck) == [
        "bridge.torsion.polar_mass = 1e+30 kg m^2/m: expected 100 .. 1e+08 kg m^2/m on a "
        "railway bridge (about 4e5 for a double-track box girder); set "
        "solver.allow_implausible = true to run it anyway"]
    deck["torsion"]["polar_mass"] = 4e4
    cfg = load_config({**copy.deepcopy(BASE), "bridge": {**deck, "EI": 1e30}})
    assert 0 < cfg._bridge.torsional_frequencies.size <= 2 * MAX_MODES
