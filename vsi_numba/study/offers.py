"""Which output variables a study's models offer, and why the others are not written.

A results file holds a variable only when the study's model computes it: the load
effects need a deck with a static model, the whole-deck acceleration needs a mode in the
EN 1990 A2 band, the car-end accelerations need car bodies with ends, the contact-force
histories need wheels in contact (not prescribed moving forces).  A variable a study
does not offer is left out of the file, and the file's ``not_computed`` attribute (JSON,
variable -> reason) says why; :func:`no_values` is the writer's guard that a variable it
does write holds a value (an offered variable with no finite value in any successful run
is a defect, refused rather than written as a column of NaN).
"""

from __future__ import annotations

import json

import numpy as np

from vsi_numba.io.schema import (
    ALL_TRACKS,
    ALL_TRACKS_SUFFIX,
    ENVELOPES,
    HISTORIES,
    LOAD_EFFECT_HISTORIES,
    LOAD_EFFECTS,
    SPACE_ENVELOPES,
    SPACE_HISTORIES,
)

#: The whole-deck acceleration envelope and its time and position.
WHOLE_DECK_ACCELERATION = ("max_deck_acceleration_whole_deck",
                           "time_of_max_deck_acceleration_whole_deck",
                           "position_of_max_deck_acceleration_whole_deck")

#: The car-end (comfort point) accelerations.
CAR_END = ("max_carbody_acceleration_car_end", "time_of_max_carbody_acceleration_car_end",
           "position_of_max_carbody_acceleration_car_end")

#: The car-body accelerations (at the centres of gravity).
CARBODY = ("max_carbody_acceleration", "time_of_max_carbody_acceleration",
           "position_of_max_carbody_acceleration", "carbody_acceleration")

#: The whole-deck acceleration envelope along each track and its time and position.
TRACK_WHOLE_DECK_ACCELERATION = tuple(f"{pre}max_track_acceleration_whole_deck" for pre in
                                      ("", "time_of_", "position_of_"))

#: The torsional moment envelopes on the whole-deck grid.
TORSIONAL_MOMENT_WHOLE_DECK = tuple(f"{pre}{ext}_torsional_moment_whole_deck"
                                    for ext in ("max", "min") for pre in ("", "time_of_"))
#: The torsional moment envelopes and history of a deck in space.
TORSIONAL_MOMENT = tuple(f"{pre}{ext}_torsional_moment" for ext in ("max", "min")
                         for pre in ("", "time_of_")) + ("torsional_moment",
                                                         *TORSIONAL_MOMENT_WHOLE_DECK)

#: Histories of the wheels in contact (a moving force's contact force is its load).
CONTACT_HISTORIES = ("contact_force", "in_contact")


def load_effect_variables() -> tuple[str, ...]:
    """Every envelope and history variable of the load effects."""
    env = tuple(f"{pre}{ext}_{name}" for name in LOAD_EFFECTS for ext in ("max", "min")
                for pre in ("", "time_of_"))
    return env + tuple(LOAD_EFFECT_HISTORIES)


def _kind(cfg) -> str:
    try:
        return str(cfg.resolved["bridge"]["kind"])
    except (AttributeError, KeyError, TypeError):
        return "imported"


def _effects_reason(model) -> str:
    cfg, bridge = model.config, model.bridge
    if getattr(cfg, "load_effects", True) is False:
        return "not asked for: [study] load_effects = false"
    if bridge.n_modes == 0:
        return "no deck: the bridge is rigid (bridge.kind = \"rigid\")"
    if bridge.static is None or "moment" not in bridge.static.effects:
        return ("the deck is imported as modes or matrices (bridge.kind = "
                f"\"{_kind(cfg)}\"), which carry no static deck "
                "model: bending moments, shear forces, support reactions and end rotations "
                "need one (built-in decks: simply_supported or continuous; a modes table "
                "gives bending moments and shear forces with its optional section forces "
                "and influence lines, see vsi_numba.model.imported.effects)")
    return "the deck model gives no load effects"


def not_offered(models, packed) -> dict[str, str]:
    """Variables of :data:`~vsi_numba.io.schema.ENVELOPES` and
    :data:`~vsi_numba.io.schema.HISTORIES` that none of ``models`` (one per variant)
    computes, with the reason (one line).

    Parameters
    ----------
    models : sequence of StudyModel
        The study's models; ``deck`` is their ``DeckOperators``.
    packed : sequence of sequence of Packed
        Per model, the packed trains.
    """
    out: dict[str, str] = {}
    if all(m.deck.effects is None for m in models):
        why = _effects_reason(models[0])
        out.update(dict.fromkeys(load_effect_variables(), why))
    else:
        computed = {c for m in models if m.deck.effects is not None
                    for c in m.deck.effects.channels}
        for effect, name, history in (("shear", "shear_force", "shear_force"),
                                      ("reaction", "support_reaction", "support_reaction"),
                                      ("rotation", "end_rotation", "rotation")):
            if effect not in computed:
                why = ("the imported deck's section forces are the bending moment and "
                       "shear force only (its modes table gives no support reactions or "
                       "rotations)") if effect != "shear" else (
                    "the imported deck's modes table gives bending moments only (no "
                    "section_shear and influence_shear)")
                names = [name] + ([f"{name}_whole_deck"] if effect == "shear" else [])
                out.update(dict.fromkeys(
                    [f"{pre}{ext}_{n}" for ext in ("max", "min") for n in names
                     for pre in ("", "time_of_")] + [history], why))
    if all(m.deck.n_grid == 0 for m in models):
        b = models[0].bridge
        why = ("no deck: the bridge is rigid" if b.n_modes == 0 else
               f"no mode of the deck up to the EN 1990 A2 acceleration cut-off "
               f"({models[0].deck.cutoff:.4g} Hz)")
        out.update(dict.fromkeys(WHOLE_DECK_ACCELERATION, why))
    layouts = [m.deck.layout for m in models]
    space = [*SPACE_ENVELOPES, *SPACE_HISTORIES]
    if all(x is None for x in layouts):
        out.update(dict.fromkeys(space, "the deck is a line: no bridge.tracks or "
                                        "bridge.torsion (simply_supported and continuous "
                                        "decks)"))
    else:
        if not any(x is not None and x.has_twist for x in layouts):
            why = next((x.no_twist for x in layouts if x is not None and x.no_twist),
                       "the deck does not twist: no bridge.torsion (its modes have no "
                       "torsion)")
            out.update(dict.fromkeys([k for k in space if "twist" in k], why))
        if not any(x is not None and x.grid_x.size for x in layouts):
            out.update(dict.fromkeys(
                TRACK_WHOLE_DECK_ACCELERATION, "no mode of the deck up to the EN 1990 A2 "
                f"acceleration cut-off ({models[0].deck.cutoff:.4g} Hz)"))
        if not any(x is not None and x.has_torque for x in layouts):
            why = next(x.torque_reason for x in layouts if x is not None)
            out.update(dict.fromkeys(TORSIONAL_MOMENT, why))
        elif not any(x is not None and x.channels is not None
                     and np.size(x.channels.torque_grid) for x in layouts):
            out.update(dict.fromkeys(TORSIONAL_MOMENT_WHOLE_DECK, "the torsional moment "
                                     "is computed at the output points only"))
    trains = [p for per in packed for p in per]
    if not any(np.asarray(p.vehicles.body_dof).size for p in trains):
        out.update(dict.fromkeys(CARBODY, "no train has a car body (moving forces only)"))
    if not any(int(p.vehicles.body_end_start[-1]) > 0 for p in trains):
        out.update(dict.fromkeys(CAR_END, "no train has a car body with ends (moving forces "
                                          "or sprung masses only)"))
    if not any(p.wheel_positions.size for p in trains):
        out.update(dict.fromkeys(CONTACT_HISTORIES, "moving forces only: each contact force "
                                                    "is the prescribed axle load "
                                                    "(static_wheel_load)"))
    if not any(getattr(m.config, "other_trains", []) for m in models):
        out.update(dict.fromkeys(ALL_TRACKS, "one train per run: no train.other_trains "
                                             "(trains on other tracks in the same run)"))
    else:  # what the run's train alone cannot give, every train together cannot either
        n = len(ALL_TRACKS_SUFFIX)
        out.update({k: out[k[:-n]] for k in ALL_TRACKS if k[:-n] in out})
    known = (set(ENVELOPES) | set(HISTORIES) | set(SPACE_ENVELOPES) | set(SPACE_HISTORIES)
             | set(ALL_TRACKS))
    return {k: v for k, v in out.items() if k in known}


def no_values(found: dict[str, bool], any_ok: bool) -> list[str]:
    """Variables written but never given a finite value although a run succeeded."""
    return sorted(k for k, v in found.items() if any_ok and not v)


def not_computed_attr(omit: dict[str, str]) -> str:
    """The ``not_computed`` global attribute: JSON, variable -> reason."""
    return json.dumps(omit, sort_keys=True)
