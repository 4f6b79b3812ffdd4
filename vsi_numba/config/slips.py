"""Unit slips at load time: values whose magnitude says that a key was given in another
unit (a deck mass in t/m, axle loads in t or kN, speeds in m/s for km/h), refused with the
unit they were probably written in unless the override key is set."""

from __future__ import annotations

import math

import numpy as np

from vsi_numba.config._check import _refuse
from vsi_numba.config.limits import (
    DECK_FREQUENCY_FACTOR,
    MAX_AXLE_LOAD,
    MIN_AXLE_LOAD,
    MIN_DECK_MASS,
    MIN_RAILWAY_AXLE_LOAD,
    MIN_STUDY_SPEED_KMH,
)
from vsi_numba.en1991 import frequency_band


def first_bending_frequency(bridge) -> float:
    """f1 (Hz) of the deck's bending: its first mode that is not mostly torsion (a deck
    in space also has torsional modes, :attr:`~vsi_numba.model.deck3d.SpaceDeck.
    torsional_share`)."""
    freqs = np.asarray(bridge.model.frequencies, float)
    space = getattr(bridge, "space", None)
    share = getattr(space, "torsional_share", None) if space is not None else None
    if share is not None and np.size(share) == freqs.size:
        bending = freqs[np.asarray(share, float) < 0.5]
        if bending.size:
            return float(bending[0])
    return float(freqs[0])


def _deck_mass_slip(chk, bridge, solver) -> bool:
    """``bridge.mass_per_length`` below :data:`MIN_DECK_MASS` (kg/m): t/m typed as kg/m,
    refused (unless ``solver.allow_implausible``: every result would be meaningless).
    The message quotes the deck's first bending frequency f1 with the mass as given and
    with the kg/m it looks like, against EN 1991-2 Fig. 6.10 [R]; the time-step messages
    the mass would cause are left out (the mass is their cause), and so is a deck whose
    f1 is implausible in t/m too (:data:`DECK_FREQUENCY_FACTOR` x the upper limit of Fig.
    6.10: left to the other checks).  True when refused; ``chk = None`` only answers."""
    res, model = bridge.resolved, bridge.model
    if bridge.kind not in ("simply_supported", "continuous") or not model.n_modes:
        return False
    masses = np.atleast_1d(np.asarray(res.get("mass_per_length", []), float))
    spans = res.get("spans") or []
    if not masses.size or not spans or masses.min() >= MIN_DECK_MASS:
        return False
    m = float(masses.min())
    span = float(max(spans))
    hi = 94.76 * span ** -0.748  # Fig. 6.10's upper limit (extrapolated off 4-100 m)
    if 4.0 <= span <= 100.0:
        hi = frequency_band(span)[1]
    f1 = first_bending_frequency(bridge)
    if f1 / math.sqrt(1e3) > DECK_FREQUENCY_FACTOR * hi:
        return False  # not a deck in t/m either: left to the other checks
    key = "bridge.mass_per_length"
    shown = f"{m:g}" if masses.size == 1 else f"{m:g} (span {int(np.argmin(masses)) + 1})"
    text = (f"{key} = {shown} kg/m looks like t/m ({m:g} t/m = {m * 1e3:g} kg/m): "
            f"lighter than any railway deck (expected >= {MIN_DECK_MASS:g} kg/m)")
    if chk is None:
        return not solver.get("allow_implausible")
    where = (f"far above the {hi:.3g} Hz upper limit of EN 1991-2 Fig. 6.10 [R]"
             if f1 > DECK_FREQUENCY_FACTOR * hi else
             f"against the {hi:.3g} Hz upper limit of EN 1991-2 Fig. 6.10 [R]")
    _refuse(chk, solver, "allow_implausible",
            f"{text}; with bridge.EI it gives f1 = {f1:.4g} Hz (first bending mode) on the "
            f"{span:g} m span, {where} (with {m * 1e3:g} kg/m: f1 = "
            f"{f1 / math.sqrt(1e3):.3g} Hz); give the mass in kg/m")
    return not solver.get("allow_implausible")


def _vehicle_unit_slips(train) -> list[str]:
    """Refusals for explicit vehicles and axle-load files whose mean axle load is below
    :data:`MIN_AXLE_LOAD` or above :data:`MAX_AXLE_LOAD`: tonnes typed as kg, kN typed
    as N (and the reverse for an axle file), each naming its key."""
    out = []
    res = train.resolved
    trains = list(train.trains)
    if "axles" in res and trains:
        tr = trains[-1]  # the axle-file train comes after the presets
        unit = res["axles"].get("load_unit", "kN")
        n = tr.n_wheels + tr.n_loads
        loads = np.concatenate([np.asarray(v.loads, float) for v in tr.vehicles])
        mean = float(np.mean(loads)) if loads.size else 0.0
        key = "train.axles.load_unit"
        if n and mean < MIN_AXLE_LOAD and unit == "N":
            out.append(f'{key} = "N": the mean axle load of train.axles.file is {mean:.4g} '
                       f"N (a {float(np.sum(loads)) / 1e3:.4g} kN train); looks like kN "
                       f"({mean:.4g} kN = {mean * 1e3:.0f} N per axle): set load_unit = "
                       '"kN" (expected 50-250 kN per axle)')
        elif n and mean < MIN_RAILWAY_AXLE_LOAD and unit == "kN":
            out.append(axle_tonnes_slip(key, "train.axles.file", mean, loads))
        elif n and mean > MAX_AXLE_LOAD and unit == "kN":
            out.append(f'{key} = "kN": the mean axle load of train.axles.file is '
                       f"{mean / 1e3:.4g} kN ({mean / 9.81e3:.4g} t per axle); looks like N "
                       f"({mean / 1e3:.0f} N = {mean / 1e6:.4g} kN): set load_unit = \"N\" "
                       "(expected 50-250 kN per axle)")
    if not train.explicit or not trains:
        return out
    for i, (v, r) in enumerate(zip(trains[0].vehicles, res.get("vehicles", []),
                                   strict=False)):
        path = f"train.vehicles[{i}]"
        axles = v.n_wheels + int(np.size(v.loads))
        if not axles:
            continue
        mean = v.total_weight / axles
        body = r.get("body_mass")
        if mean >= MIN_AXLE_LOAD and r.get("kind") == "car" and body < MIN_BODY_MASS:
            out.append(f"{path}.body_mass = {body:g} kg looks like tonnes ({body:g} t = "
                       f"{body * 1e3:g} kg): a railway car body weighs 10-60 t, more than "
                       f"its bogies ({path}.bogie_mass = {r['bogie_mass']:g} kg); masses "
                       "are in kg")
            continue
        if mean >= MIN_AXLE_LOAD:
            continue
        if r.get("kind") == "force":
            msg = (f"{path}.load = {r['load']:g} N looks like kN ({r['load']:g} kN = "
                   f"{r['load'] * 1e3:g} N): an axle of railway traffic carries 50-250 kN; "
                   "loads are in N")
        else:
            keys = [k for k in ("mass", "body_mass", "bogie_mass", "wheelset_mass",
                                "wheel_mass") if r.get(k)]
            if not keys:  # a user vehicle: its matrices
                out.append(f"{path}.M, {path}.gravity: a static axle load of {mean:.4g} N "
                           f"({mean / 9.81:.3g} kg per axle; a railway axle carries 5-25 t) "
                           "looks like tonnes typed as kg; masses are in kg, gravity in N")
                continue
            shown = ", ".join(f"{path}.{k} = {r[k]:g}" for k in keys)
            first = float(r[keys[0]])
            verb = "look" if len(keys) > 1 else "looks"
            msg = (f"{shown} kg {verb} like tonnes: a static axle load of {mean:.4g} N "
                   f"({mean / 9.81:.3g} kg per axle; a railway axle carries 5-25 t); "
                   f"masses are in kg ({first:g} t = {first * 1e3:g} kg)")
        out.append(msg)
    return out


def axle_tonnes_slip(key: str, where: str, mean: float, loads) -> str:
    """The message of an axle-load list in kN whose mean axle load (N) is below
    :data:`MIN_RAILWAY_AXLE_LOAD`: tonnes typed as kN."""
    t = mean / 1e3
    return (f'{key} = "kN": the mean axle load of {where} is {t:.4g} kN (a '
            f"{float(np.sum(loads)) / 1e3:.4g} kN train); looks like tonnes ({t:.4g} t = "
            f"{t * 9.81:.4g} kN per axle): give the loads in kN (expected 50-250 kN per "
            "axle)")


def _unit_slips(bridge, train, solver) -> bool:
    """True when a unit slip is refused (no override): the checks that its consequences
    would trip (time step, static deflections) are then left out."""
    if solver.get("allow_implausible"):
        return False
    return bool(_vehicle_unit_slips(train)) or _deck_mass_slip(None, bridge, solver)


#: A car body lighter than this (kg) next to bogies in kg: the body mass in tonnes
MIN_BODY_MASS = 1000.0
#: The speeds of a dynamic study reach this multiple of the line speed (EN 1991-2
#: 6.4.6.2 [R]).
EN_SPEED_FACTOR = 1.2
#: HSLM trains are the load models of lines above this speed (km/h; EN 1991-2
#: 6.4.6.1.1 [R]) ...
HSLM_MIN_SPEED_KMH = 200.0
#: ... so a list of speeds for them that stops at or below this (km/h) while 3.6 x the
#: fastest is above :data:`HSLM_MIN_SPEED_KMH` looks like m/s (120 m/s = 432 km/h).
HSLM_MS_SLIP_KMH = 120.0


def _speed_slips(chk, study, train=None):
    """A line speed, or a study whose fastest speed is, below
    :data:`MIN_STUDY_SPEED_KMH` while 3.6 x it is a railway speed, or HSLM trains whose
    fastest speed is at most :data:`HSLM_MS_SLIP_KMH` while 3.6 x it is a high speed:
    m/s typed as km/h; speeds given next to a line speed that stop short of
    :data:`EN_SPEED_FACTOR` x it."""
    names = [str(t.name) for t in getattr(train, "trains", [])] if train else []
    hslm = [n for n in names if n.casefold().startswith("hslm")]
    line = study.get("line_speed_kmh")
    if line is not None and line < MIN_STUDY_SPEED_KMH:
        chk.warn(f"study.line_speed_kmh = {line:g} km/h looks like m/s ({line:g} m/s = "
                 f"{line * 3.6:.4g} km/h): the grid then runs {min(study['speeds_kmh']):g} .."
                 f" {max(study['speeds_kmh']):g} km/h; the key is in km/h", "plausibility",
                 ["study.line_speed_kmh"])
        return
    top = max(study["speeds_kmh"])
    if line is not None and top < EN_SPEED_FACTOR * line * (1 - 1e-9):
        chk.warn(f"study.speeds_kmh: the fastest speed is {top:g} km/h, below the EN range "
                 f"up to {EN_SPEED_FACTOR:g} x study.line_speed_kmh = "
                 f"{EN_SPEED_FACTOR * line:.4g} km/h (EN 1991-2 6.4.6.2 [R]): the speeds "
                 "between are not checked", "input",
                 ["study.speeds_kmh", "study.line_speed_kmh"])
    if top < MIN_STUDY_SPEED_KMH and top * 3.6 >= MIN_STUDY_SPEED_KMH:
        chk.warn(f"study.speeds_kmh: the fastest speed is {top:g} km/h, which looks like "
                 f"m/s ({top:g} m/s = {top * 3.6:.4g} km/h); the key is in km/h",
                 "plausibility", ["study.speeds_kmh"])
    elif (hslm and len(study["speeds_kmh"]) > 1 and top <= HSLM_MS_SLIP_KMH
          and top * 3.6 > HSLM_MIN_SPEED_KMH):  # a list of speeds, not one crawl speed
        chk.warn(f"study.speeds_kmh: the fastest speed is {top:g} km/h with the HSLM "
                 f"trains ({', '.join(hslm[:3])}{' ...' if len(hslm) > 3 else ''}), the "
                 f"load models of lines above {HSLM_MIN_SPEED_KMH:g} km/h (EN 1991-2 "
                 f"6.4.6.1.1 [R]); the speeds look like m/s ({top:g} m/s = "
                 f"{top * 3.6:.4g} km/h); the key is in km/h", "plausibility",
                 ["study.speeds_kmh"])
