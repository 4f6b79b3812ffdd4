"""The messages of the tables the declared models validate (vsi_numba.config._errors):
pydantic's errors rendered as key path, value and the declared expectation; the union
member that fits the value speaks for the key; the rules between keys of a table are
reported with its other errors; a key of another kind is named as such."""

from __future__ import annotations

import copy

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
    key of another kind is named with its kind, a misspelt kind guessed, and no member
    of the union speaks for another's keys."""
    from vsi_numba.config._check import _Checker
    from vsi_numba.config._errors import typed_section
    from vsi_numba.config.schema import VsiConfig

    def bridge_errors(**change):
        chk = _Checker()
        typed_section(chk, {"bridge": {**BASE["bridge"], **change}}, "bridge", VsiConfig)
        return chk.errors

    assert bridge_errors(elements_per_span=10) == [
        "bridge.elements_per_span = 10: expected no such key for kind = 'simply_supported' "
        "(it belongs to kind = 'continuous')"]
    assert bridge_errors(kind="simply_suported") == [
        "bridge.kind = \"simply_suported\": expected one of 'simply_supported', "
        "'continuous', 'rigid', 'modes_file', 'matrices' (did you mean 'simply_supported'?)"]
    assert bridge_errors(EI=-1.0) == ["bridge.EI = -1.0: expected a bending stiffness EI > 0 "
                                      "N m^2"]
