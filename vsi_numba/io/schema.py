"""Output variables, declared once: name -> (dims, units, long_name, extra attrs).

Single runs carry the time histories on dims (time, point | wheel | vehicle) and the
envelopes without ``time`` (on point | wheel | vehicle, or none: the whole-deck
envelopes are one value per case).  Studies add the leading dims ``speed``, ``train`` and
``irregularity`` to every variable (see ``vsi_numba.study``).

Signs: deck displacement/acceleration and vehicle accelerations are positive DOWN;
contact forces are positive in compression.  Load effects (:data:`LOAD_EFFECTS`): bending
moment positive sagging, shear force V = dM/dx, support reactions positive upward,
rotations dw/dx with w positive down (see :mod:`vsi_numba.model.influence`).
"""

from __future__ import annotations

DOWN = {"positive": "down"}

#: Dynamic load effects: name -> (dim, units, long name, sign attrs).  The mode-
#: acceleration method (static beam response to the current loads on the deck + the
#: modal inertia and damping correction), see :mod:`vsi_numba.model.influence`.
LOAD_EFFECTS = {
    "bending_moment": (
        "point", "N m", "bending moment of the deck",
        {"positive": "sagging", "sign_convention": "positive sagging: tension in the "
         "bottom fibre (EI w'' = -M with w positive down)"},
    ),
    "shear_force": (
        "point", "N", "shear force of the deck",
        {"sign_convention": "V = dM/dx (positive just right of the left support of a "
         "span under downward load); at a section holding a load or a support the value "
         "just right of it, at the right end of the deck the value just left of it"},
    ),
    "bending_moment_whole_deck": (
        "deck_x", "N m", "bending moment of the deck on the whole-deck grid",
        {"positive": "sagging", "sign_convention": "positive sagging: tension in the "
         "bottom fibre (EI w'' = -M with w positive down)"},
    ),
    "shear_force_whole_deck": (
        "deck_x", "N", "shear force of the deck on the whole-deck grid",
        {"sign_convention": "V = dM/dx (positive just right of the left support of a "
         "span under downward load); at a section holding a load or a support the value "
         "just right of it, at the right end of the deck the value just left of it"},
    ),
    "support_reaction": (
        "support", "N", "vertical support reaction",
        {"positive": "up", "sign_convention": "positive upward: the support pushes the "
         "deck up"},
    ),
    "end_rotation": (
        "support", "rad", "rotation of the deck at the support",
        {"sign_convention": "dw/dx with w positive down: positive at the left end of a "
         "sagging span, negative at its right end"},
    ),
}

#: Load-effect histories: name -> (envelope name in LOAD_EFFECTS, dim).
LOAD_EFFECT_HISTORIES = {
    "bending_moment": ("bending_moment", "point"),
    "shear_force": ("shear_force", "point"),
    "support_reaction": ("support_reaction", "support"),
    "rotation": ("end_rotation", "support"),
}


def _load_effect_envelopes() -> dict:
    out = {}
    for name, (dim, units, long_name, sign) in LOAD_EFFECTS.items():
        for ext, word, cell in (("max", "maximum", "time: maximum"),
                                ("min", "minimum", "time: minimum")):
            out[f"{ext}_{name}"] = ((dim,), units, f"{word} {long_name}",
                                    {**sign, "cell_methods": cell})
            out[f"time_of_{ext}_{name}"] = ((dim,), "s", f"time of the {word} {long_name}",
                                            {})
    return out


#: Time histories (optional in sweeps).
HISTORIES = {
    "deck_displacement": (("time", "point"), "m", "vertical deck displacement", DOWN),
    "deck_acceleration": (
        ("time", "point"), "m s-2",
        "vertical deck acceleration, modes up to the EN 1990 A2.4.4.2.1 cut-off", DOWN,
    ),
    "contact_force": (
        ("time", "wheel"), "N", "wheel-rail vertical contact force per axle",
        {"positive": "compression"},
    ),
    "in_contact": (
        ("time", "wheel"), "1", "wheel in contact with the rail",
        {"flag_values": [0, 1], "flag_meanings": "separated in_contact"},
    ),
    "carbody_acceleration": (
        ("time", "vehicle"), "m s-2", "vertical car-body acceleration at the centre of gravity",
        DOWN,
    ),
    **{name: (("time", dim), LOAD_EFFECTS[env][1], LOAD_EFFECTS[env][2], LOAD_EFFECTS[env][3])
       for name, (env, dim) in LOAD_EFFECT_HISTORIES.items()},
}

#: Envelopes (always present).
ENVELOPES = {
    "max_deck_displacement": (
        ("point",), "m", "maximum absolute vertical deck displacement",
        {"cell_methods": "time: maximum"},
    ),
    "max_deck_acceleration": (
        ("point",), "m s-2",
        "maximum absolute vertical deck acceleration, modes up to the EN 1990 A2 cut-off",
        {"cell_methods": "time: maximum"},
    ),
    "min_contact_force": (
        ("wheel",), "N", "minimum wheel-rail contact force", {"cell_methods": "time: minimum"},
    ),
    "max_contact_force": (
        ("wheel",), "N", "maximum wheel-rail contact force", {"cell_methods": "time: maximum"},
    ),
    "max_wheel_unloading": (
        ("wheel",), "1", "maximum wheel unloading ratio (Q0 - Q) / Q0",
        {"cell_methods": "time: maximum"},
    ),
    "max_carbody_acceleration": (
        ("vehicle",), "m s-2",
        "maximum absolute vertical car-body acceleration over the comfort points (centre "
        "of gravity and over each suspension pivot)",
        {"cell_methods": "time: maximum"},
    ),
    "max_deck_acceleration_whole_deck": (
        (), "m s-2",
        "maximum absolute vertical deck acceleration over the whole deck (grid of every "
        "span plus the output points), modes up to the EN 1990 A2 cut-off",
        {"cell_methods": "time: maximum"},
    ),
    "contact_loss_duration": (
        ("wheel",), "s", "total time the wheel is separated from the rail (all events)",
        {"cell_methods": "time: sum"},
    ),
    "longest_contact_loss": (
        ("wheel",), "s", "duration of the longest single separation of the wheel from the rail",
        {"cell_methods": "time: maximum"},
    ),
    "contact_loss_events": (
        ("wheel",), "1", "number of separations of the wheel from the rail", {},
    ),
    "single_step_contact_losses": (
        ("wheel",), "1",
        "number of separations that lasted exactly one time step (suspect: numerical "
        "ringing of the contact force rather than a physical lift-off)", {},
    ),
    "time_of_max_deck_displacement": (
        ("point",), "s", "time of the maximum absolute deck displacement", {},
    ),
    "time_of_max_deck_acceleration": (
        ("point",), "s", "time of the maximum absolute deck acceleration", {},
    ),
    "position_of_min_contact_force": (
        ("wheel",), "m", "wheel position along the track at the minimum contact force", {},
    ),
    "max_carbody_acceleration_car_end": (
        ("vehicle",), "m s-2",
        "maximum absolute vertical car-body acceleration at the car-body ends (bounce plus "
        "pitch times the end's distance from the centre of gravity; NaN: ends not known)",
        {"cell_methods": "time: maximum"},
    ),
    "time_of_max_carbody_acceleration_car_end": (
        ("vehicle",), "s", "time of the maximum absolute car-body acceleration at the car "
        "ends", {},
    ),
    "position_of_max_carbody_acceleration_car_end": (
        ("vehicle",), "m",
        "car-body end of the maximum car-end acceleration: distance ahead of the body's "
        "centre of gravity (positive: front end)", {},
    ),
    "time_of_max_carbody_acceleration": (
        ("vehicle",), "s", "time of the maximum absolute car-body acceleration", {},
    ),
    "position_of_max_carbody_acceleration": (
        ("vehicle",), "m",
        "comfort point of the maximum car-body acceleration: distance ahead of the body's "
        "centre of gravity (positive towards the front, 0 = centre)", {},
    ),
    "time_of_max_deck_acceleration_whole_deck": (
        (), "s", "time of the maximum absolute deck acceleration over the whole deck", {},
    ),
    "position_of_max_deck_acceleration_whole_deck": (
        (), "m", "deck abscissa of the maximum absolute deck acceleration over the whole "
        "deck (distance from the left end of the bridge)", {},
    ),
    **_load_effect_envelopes(),
}

_Y = ("y, the transverse coordinate of the deck, is positive to the left looking in +x; "
      "the rails of track k are at y_k +- gauge/2")
_TWIST = {"sign_convention": "t(x) = [w(x, y_L) - w(x, y_R)] - [w(x + 3, y_L) - "
          "w(x + 3, y_R)] over the 3 m base from x (EN 1990 A2.4.4.2.2), w positive down, "
          "y_L / y_R the left / right rail; the envelope is of |t|; " + _Y}

_TORQUE = {"sign_convention": "T = GJ dtheta/dx (St-Venant), theta the rotation of the "
           "section positive when its left side (+y) goes down: a downward load P at "
           "y = e > 0 on a fork-supported span of length L gives T = P e (1 - a/L) between "
           "the left support and the load (a its abscissa) and -P e a/L beyond it; T > 0 "
           "is a moment vector along -x on the face whose outward normal is +x "
           "(right-handed x, y left, z up); at a section holding a load the value just "
           "right of it, at an interior support the value just right of it (the span on "
           "its right), at the right end of the deck the value just left of it; a "
           "continuous deck is restrained in torsion at every support: each span carries "
           "the torque of its own loads",
           "comment": "mode-acceleration method: the closed-form static St-Venant torque "
           "of the loads on the deck plus the torsional modes' inertia and damping "
           "correction; " + _Y,
           "accuracy": "static part times 1 / (1 - (v/c)^2), c = sqrt(GJ / I_p); at crawl "
           "speed within 3e-4 of P e (a continuous deck at and next to its supports: "
           "4e-3, the kept torsional modes ringing after a load enters a span); at "
           "speed the torque fronts a load sends off along the span are carried by the "
           "kept modes only: histories off by up to 10-30 % of "
           "P e at v/c = 0.2-0.4 and envelopes by a few per cent either way against a "
           "converged reference"}

#: Per-track envelopes of a deck in space (``bridge.tracks``, ``bridge.torsion``; see
#: :mod:`vsi_numba.model.deck3d`): along each track line, and the deck twist.
SPACE_ENVELOPES = {
    "max_track_displacement": (
        ("track", "point"), "m", "maximum absolute vertical deck displacement along the "
        "track centre line", {**DOWN, "comment": _Y}),
    "time_of_max_track_displacement": (
        ("track", "point"), "s", "time of the maximum absolute deck displacement along the "
        "track centre line", {}),
    "max_track_acceleration": (
        ("track", "point"), "m s-2", "maximum absolute vertical deck acceleration along the "
        "track centre line (modes up to the EN 1990 A2 cut-off)", {**DOWN, "comment": _Y}),
    "time_of_max_track_acceleration": (
        ("track", "point"), "s", "time of the maximum absolute deck acceleration along the "
        "track centre line", {}),
    "max_deck_twist": (
        ("track", "point"), "m", "maximum absolute deck twist over 3 m along the track, "
        "window from the output point", _TWIST),
    "time_of_max_deck_twist": (
        ("track", "point"), "s", "time of the maximum absolute deck twist over 3 m", {}),
    "max_deck_twist_whole_deck": (
        ("track", "twist_x"), "m", "maximum absolute deck twist over 3 m along the track on "
        "the whole-deck grid of window starts", _TWIST),
    "time_of_max_deck_twist_whole_deck": (
        ("track", "twist_x"), "s", "time of the maximum absolute deck twist over 3 m on the "
        "whole-deck grid", {}),
    "max_track_acceleration_whole_deck": (
        ("track",), "m s-2", "maximum absolute vertical deck acceleration along the track "
        "centre line over the whole deck (grid of every span plus the output points), "
        "modes up to the EN 1990 A2 cut-off", {**DOWN, "comment": _Y}),
    "time_of_max_track_acceleration_whole_deck": (
        ("track",), "s", "time of the maximum absolute deck acceleration along the track "
        "centre line over the whole deck", {}),
    "position_of_max_track_acceleration_whole_deck": (
        ("track",), "m", "deck abscissa of the maximum absolute deck acceleration along the "
        "track centre line over the whole deck (distance from the left end of the bridge)",
        {}),
    **{f"{pre}{ext}_torsional_moment{whole}": (
        (dim,), "s" if pre else "N m",
        f"time of the {word} torsional moment of the deck{where}" if pre else
        f"{word} St-Venant torsional moment of the deck (train on the loaded track){where}",
        {} if pre else {**_TORQUE, "cell_methods": f"time: {word}"})
       for whole, dim, where in (("", "point", ""), ("_whole_deck", "deck_x",
                                                     " on the whole-deck grid"))
       for ext, word in (("max", "maximum"), ("min", "minimum")) for pre in ("", "time_of_")},
}

#: Histories along the tracks of a deck in space (``[study] save_time_histories``).
SPACE_HISTORIES = {
    "track_displacement": (
        ("time", "track", "point"), "m", "vertical deck displacement along the track centre "
        "line", {**DOWN, "comment": _Y}),
    "track_acceleration": (
        ("time", "track", "point"), "m s-2", "vertical deck acceleration along the track "
        "centre line, modes up to the EN 1990 A2.4.4.2.1 cut-off", {**DOWN, "comment": _Y}),
    "torsional_moment": (
        ("time", "point"), "N m", "St-Venant torsional moment of the deck (train on the "
        "loaded track)", _TORQUE),
    "deck_twist": (
        ("time", "track", "point"), "m", "deck twist over 3 m along the track, window from "
        "the output point", {**_TWIST, "sign_convention": _TWIST["sign_convention"].replace(
            "; the envelope is of |t|", "")}),
}

#: Suffix of the envelopes with every train of a run loaded (``train.other_trains``).
ALL_TRACKS_SUFFIX = "_all_tracks"

#: The variables that have an every-train-loaded twin (:data:`ALL_TRACKS`).
ALL_TRACKS_BASES = (
    "max_deck_displacement", "time_of_max_deck_displacement", "max_deck_acceleration",
    "time_of_max_deck_acceleration", "max_deck_acceleration_whole_deck",
    "time_of_max_deck_acceleration_whole_deck", "position_of_max_deck_acceleration_whole_deck",
    *(f"{pre}{ext}_{name}" for name in ("bending_moment", "shear_force", "support_reaction",
                                        "end_rotation")
      for ext in ("max", "min") for pre in ("", "time_of_")),
    *(f"{pre}{name}" for name in ("max_track_displacement", "max_track_acceleration",
                                  "max_deck_twist", "max_deck_twist_whole_deck")
      for pre in ("", "time_of_")),
    *(f"{pre}max_track_acceleration_whole_deck" for pre in ("", "time_of_", "position_of_")),
    *(f"{pre}{ext}_{name}" for name in ("bending_moment_whole_deck", "shear_force_whole_deck",
                                        "torsional_moment", "torsional_moment_whole_deck")
      for ext in ("max", "min") for pre in ("", "time_of_")),
)


def _all_tracks() -> dict:
    out = {}
    for base in ALL_TRACKS_BASES:
        dims, units, long_name, attrs = {**ENVELOPES, **SPACE_ENVELOPES}[base]
        out[base + ALL_TRACKS_SUFFIX] = (
            dims, units, long_name.replace(" (train on the loaded track)", "")
            + ", every train of the run loaded",
            {**attrs, "loading": "the run's train on train.track and the trains of "
                                 "train.other_trains on their tracks (each the run's "
                                 "train at the run's speed unless it names its own), "
                                 "superposed"})
    return out


#: Envelopes with every train of a run on its track (``train.other_trains``: trains
#: meeting or side by side), by superposition of the trains' runs
#: (:mod:`vsi_numba.solver.superpose`); the variables without the suffix are the run's
#: train alone (one track loaded).
ALL_TRACKS = _all_tracks()

#: How the trains of ``train.other_trains`` are in the results (:func:`loading_attrs`):
#: superposed runs of moving forces, or interaction trains together in one run.
SUPERPOSED, TOGETHER = "superposed", "together"


def loading_attrs(name: str, attrs: dict, trains: str | None) -> dict:
    """``attrs`` of variable ``name`` saying which trains load it: ``trains`` None (one
    train per run: unchanged), :data:`SUPERPOSED` (moving forces on other tracks: the
    variables without the suffix are the run's train alone, one track loaded) or
    :data:`TOGETHER` (interaction trains on other tracks in the same run: every
    variable holds every train, the ``_all_tracks`` twins repeat the values)."""
    if trains is None:
        return attrs
    out = dict(attrs)
    twin = name.endswith(ALL_TRACKS_SUFFIX)
    base = name[:-len(ALL_TRACKS_SUFFIX)] if twin else name
    deckwise = base in ALL_TRACKS_BASES or name in SPACE_HISTORIES or name in (
        "deck_displacement", "deck_acceleration", "bending_moment", "shear_force",
        "support_reaction", "rotation")
    if trains == TOGETHER:
        every = ("every train of the run: the run's train on train.track and the trains "
                 "of train.other_trains on their tracks, interaction trains in one run")
        if twin:
            out["loading"] = every + f" (the same values as {base})"
        elif deckwise:
            out["long_name"] = str(out.get("long_name", "")).replace(
                " (train on the loaded track)", " (every train of the run loaded)")
            out["loading"] = every + (f" (repeated as {base}{ALL_TRACKS_SUFFIX})"
                                      if base in ALL_TRACKS_BASES else "")
        elif name in ENVELOPES or name in HISTORIES:
            out["loading"] = every + ("; the wheels and vehicles of every train (those of "
                                      "the other trains named 'train k: ...')")
    elif deckwise and not twin:
        out["loading"] = ("the run's train alone on train.track (one track loaded); "
                          "every train of the run loaded: "
                          + (f"{base}{ALL_TRACKS_SUFFIX}" if base in ALL_TRACKS_BASES
                             else "not in the file"))
    return out


#: Per-case diagnostics.
DIAGNOSTICS = {
    "status": (
        (), "1", "analysis status",
        {
            "flag_values": [0, 1, 2, 3, 4],
            "flag_meanings": (
                "ok contact_not_converged singular_contact_system non_finite_state "
                "singular_impact_system"
            ),
        },
    ),
    "max_iterations": ((), "1", "largest number of contact iterations in one step", {}),
}

#: Variables of a results file beside the per-case outputs: per case (``message``), per
#: train, and per bridge variant (``study.vary``).
STUDY_VARIABLES = {
    "message": ((), "1", "analysis status message", {}),
    "max_static_deck_displacement": (
        ("train", "point"), "m", "maximum static deck displacement as the train's static "
        "axle loads cross the bridge (reference of phi'_dyn)", DOWN,
    ),
    "train_regular_length": (
        ("train",), "m", "regular coach length D of the train (0: none)", {},
    ),
    "train_status": (("train",), "1", "data status of the train model", {}),
    "variant": (("variant",), "1", "bridge variant of the study (study.vary)", {}),
    "bridge_length": (("variant",), "m", "length of the bridge of the variant", {}),
    "acceleration_cutoff": (
        ("variant",), "Hz", "highest frequency of the modes in the deck acceleration "
        "(EN 1990 A2.4.4.2.1)", {},
    ),
    "damping_ratio": (
        ("variant", "mode"), "1", "modal damping ratio the runs used (per variant in a study "
        "of variants; moving forces add additional_damping)", {},
    ),
    "additional_damping": (
        ("variant",), "1", "EN 1991-2 6.4.6.3.1 additional damping of the moving-force "
        "trains", {},
    ),
    "damping_rule": (
        ("variant",), "1", "EN 1991-2 damping rules applied to the variant (empty: damping "
        "as given)", {},
    ),
    "variant_config_json": (
        ("variant",), "1", "resolved configuration of the variant (JSON): runs it alone", {},
    ),
}

#: Fatigue results of a study with ``[fatigue]`` (:mod:`vsi_numba.study.fatigue`).
FATIGUE = {
    "fatigue_damage": (
        ("fatigue_section",), "1", "Miner's damage sum over the design life (all trains of "
        "the fatigue traffic), design S-N curve and factored stress ranges",
        {"cell_methods": "fatigue_traffic: sum"}),
    "fatigue_damage_per_train": (
        ("fatigue_traffic", "fatigue_section"), "1",
        "Miner's damage sum of one train of the fatigue traffic over the design life", {}),
    "fatigue_damage_per_passage": (
        ("fatigue_traffic", "fatigue_section"), "1",
        "Miner's damage of one passage of the train (free vibration included)", {}),
    "fatigue_cycles": (
        ("fatigue_traffic", "fatigue_section", "stress_range"), "1",
        "rainflow cycles per passage in each stress-range bin (unfactored ranges; half "
        "cycles count 0.5)", {}),
    "fatigue_max_stress_range": (
        ("fatigue_traffic", "fatigue_section"), "MPa",
        "largest rainflow stress range of one passage (unfactored)", {}),
    "fatigue_equivalent_stress_range": (
        ("fatigue_section",), "MPa",
        "damage-equivalent stress range at 2e6 cycles, unfactored (from the Miner sum)", {}),
    "fatigue_section_modulus": (("fatigue_section",), "m3", "section modulus W (stress = "
                                "M / W)", {}),
    "fatigue_detail_category": (("fatigue_section",), "MPa", "detail category Delta "
                                "sigma_C (EN 1993-1-9)", {}),
    "fatigue_gamma_Ff": (("fatigue_section",), "1", "partial factor of the fatigue loads",
                         {}),
    "fatigue_gamma_Mf": (("fatigue_section",), "1", "partial factor of the fatigue "
                         "strength", {}),
    "fatigue_speed_kmh": (("fatigue_traffic",), "km h-1", "speed of the train in the "
                          "fatigue traffic", {}),
    "fatigue_trains_per_day": (("fatigue_traffic",), "d-1", "trains per day", {}),
    "fatigue_train_mass": (("fatigue_traffic",), "t", "total static axle load of the "
                           "train / g", {}),
    "fatigue_free_vibration": (("fatigue_traffic",), "s", "free vibration simulated after "
                               "the last axle left (until decayed)", {}),
    # headed stud shear connectors ([[fatigue.studs]]): tau = V S s / (I n pi d^2 / 4)
    "fatigue_stud_damage": (
        ("fatigue_stud",), "1", "Miner's damage sum of the studs over the design life (all "
        "trains), stud S-N curve (EN 1994-1-1 6.8.3) and factored shear-stress ranges",
        {"cell_methods": "fatigue_traffic: sum"}),
    "fatigue_stud_damage_per_train": (
        ("fatigue_traffic", "fatigue_stud"), "1",
        "Miner's damage sum of the studs of one train over the design life", {}),
    "fatigue_stud_damage_per_passage": (
        ("fatigue_traffic", "fatigue_stud"), "1",
        "Miner's damage of the studs of one passage of the train (free vibration "
        "included)", {}),
    "fatigue_stud_cycles": (
        ("fatigue_traffic", "fatigue_stud", "stress_range"), "1",
        "rainflow cycles of the stud shear stress per passage in each range bin "
        "(unfactored ranges; half cycles count 0.5)", {}),
    "fatigue_stud_max_shear_stress_range": (
        ("fatigue_traffic", "fatigue_stud"), "MPa",
        "largest rainflow range of the stud shear stress of one passage (unfactored)",
        {"sign_convention": "ranges: the sign of the shear (V = dM/dx) does not enter"}),
    "fatigue_stud_equivalent_shear_stress_range": (
        ("fatigue_stud",), "MPa",
        "damage-equivalent stud shear-stress range Delta tau_E2 at 2e6 cycles, unfactored "
        "(from the Miner sum, slope m of the stud curve)", {}),
    "fatigue_stud_shear_stress_per_shear_force": (
        ("fatigue_stud",), "m-2", "stud shear stress per unit vertical shear force: "
        "S s / (I n pi d^2 / 4)", {}),
    "fatigue_stud_diameter": (("fatigue_stud",), "m", "shank diameter d of the studs", {}),
    "fatigue_stud_per_row": (("fatigue_stud",), "1", "studs per row n", {}),
    "fatigue_stud_row_spacing": (("fatigue_stud",), "m", "spacing s of the stud rows", {}),
    "fatigue_stud_first_moment": (("fatigue_stud",), "m3", "first moment S of the slab "
                                  "about the composite neutral axis", {}),
    "fatigue_stud_second_moment": (("fatigue_stud",), "m4", "second moment I of the "
                                   "composite section", {}),
    "fatigue_stud_category": (("fatigue_stud",), "MPa", "reference shear strength Delta "
                              "tau_c of the studs at 2e6 cycles", {}),
    "fatigue_stud_slope": (("fatigue_stud",), "1", "slope m of the stud S-N curve", {}),
    "fatigue_stud_gamma_Ff": (("fatigue_stud",), "1", "partial factor of the fatigue loads "
                              "(studs)", {}),
    "fatigue_stud_gamma_Mf": (("fatigue_stud",), "1", "partial factor gamma_Mf,s of the "
                              "stud fatigue strength", {}),
}

COORDS = {
    "time": ("s", "time since the first axle left its start position", {"axis": "T"}),
    "point": ("m", "output point: distance from the left end of the bridge", {}),
    "wheel": ("1", "wheel (axle) index, 0 = leading", {}),
    "vehicle": ("1", "vehicle index, 0 = leading", {}),
    "speed": ("m s-1", "train speed", {}),
    "speed_kmh": ("km h-1", "train speed", {}),
    "train": ("1", "train name", {}),
    "irregularity": ("1", "track irregularity realisation (seed, -1 = deterministic)", {}),
    "wheel_position": ("m", "axle position behind the first axle", {}),
    "static_wheel_load": ("N", "static wheel (axle) load on level rigid track", {}),
    "frequency": ("Hz", "natural frequency", {}),
    "vehicle_name": ("1", "vehicle name", {}),
    "mode": ("1", "mode number", {}),
    "deck_x": ("m", "whole-deck section of the load-effect envelopes: distance from the "
               "left end of the bridge", {}),
    "support": ("m", "support: distance from the left end of the bridge", {}),
    "track": ("1", "track on the deck (1-based, as in bridge.tracks)", {}),
    "track_eccentricity": ("m", "transverse position y of the track centre line", {
        "comment": _Y}),
    "track_line": ("1", "name of the track in the imported deck's data (its rails are "
                   "the lines <name>/left and <name>/right, its centre line <name>)", {}),
    "twist_x": ("m", "start of the 3 m twist window: distance from the left end of the "
                "bridge (negative: the window straddles the left deck end)", {}),
}


def attrs_for(name: str) -> dict:
    """CF attributes (units, long_name, ...) for a declared variable or coordinate."""
    for table in (HISTORIES, ENVELOPES, SPACE_ENVELOPES, SPACE_HISTORIES, ALL_TRACKS,
                  DIAGNOSTICS,
                  STUDY_VARIABLES, FATIGUE):
        if name in table:
            _, units, long_name, extra = table[name]
            return {"units": units, "long_name": long_name, **extra}
    if name in COORDS:
        units, long_name, extra = COORDS[name]
        return {"units": units, "long_name": long_name, **extra}
    raise KeyError(name)
