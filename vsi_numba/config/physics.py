"""Checks of the whole model at load time: the physics warnings (time-step resolution of
the modes, the vehicles, the contact and track springs and the irregularities; modes left
out below the EN 1990 cut-off) and the plausibility refusals (static deflection, Hertz
penetration, vehicle stiffness, run and memory budget), each with its override key."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from vsi_numba.config.irregularity import _defect_profile
from vsi_numba.config.limits import (
    DECK_FREQUENCY_FACTOR,
    DT_DEFAULT_MIN,
    DT_ERROR,
    DT_RESOLUTION,
    HARD_MAX_STEPS,
    LONG_TRAIN,
    MAX_AXLE_LOAD,
    MAX_HERTZ_PENETRATION,
    MAX_HISTORY_BYTES,
    MAX_PROFILE_AMPLITUDE,
    MAX_PROFILE_SAMPLES,
    MAX_STATIC_DEFLECTION,
    MAX_STEPS,
    MAX_TRACK_DEFLECTION,
    MAX_TRACK_FILTER,
    MAX_TRACK_STIFFNESS,
    MIN_AXLE_LOAD,
    MIN_DECK_MASS,
    MIN_RAILWAY_AXLE_LOAD,
    MIN_STUDY_SPEED_KMH,
    STEPS_PER_WAVELENGTH,
    TRACK_RANGES,
)
from vsi_numba.en1990 import frequency_cutoff
from vsi_numba.en1991 import frequency_band
from vsi_numba.model import irregularity as _irr
from vsi_numba.model import track as _track
from vsi_numba.model.irregularity import profile_range
from vsi_numba.model.library import static_axle_loads
from vsi_numba.model.psd import PSD_PERIOD, psd_grid
from vsi_numba.solver.settings import SolverSettings

#: The defaults of the [track] values (messages).
_DEFAULT_TRACK = {"foundation_stiffness": _track.FOUNDATION_DEFAULT,
                  "rail_EI": _track.RAIL_EI_UIC60}
#: The nonlinear Hertz spring is checked at this multiple of the static wheel load.
HERTZ_LOAD_FACTOR = 2.0
#: Rigid contact with massive wheels needs at least this much numerical damping.
RIGID_MASSIVE_ALPHA = -0.02
#: dt x f the wheel-on-track mode needs when the irregularity excites it: for the bogie
#: of tests/test_track_damping.py (ICE3 wheelsets, 45.9 Hz, German low 1-80 m, 400 km/h,
#: damped track) dt x f = 0.023 gives the peak deck acceleration within 0.05 % and
#: dQ/Q0 within 0.004 of the dt -> 0 limit, dt x f = 0.046 (dt = 1 ms) 1.2 % and 0.015;
#: on the undamped track the mode rings and dt = 1 ms was up to 19 % off
TRACK_MODE_DT = 0.025
#: The wheel-on-track mode counts as excited when the irregularity reaches this share
#: of its frequency (v / shortest wavelength)
TRACK_MODE_EXCITED = 0.5
#: Share of a mode's modal stiffness above which the rail stiffness left out of the
#: deck is reported: 2 %, i.e. 1 % on the mode's frequency (a light 20 m deck with
#: f1 = 4.8 Hz is at 1.0 % of the stiffness and is not worth a warning)
TRACK_RESTRAINT_WARN = 0.02


def train_extent(train) -> float:
    """How far (m) the last axle runs behind the train's reference point (its first axle,
    offset 0): the train length, or more when the first vehicle has an offset."""
    return max(float(train.length), float(np.max(train.axle_positions, initial=0.0)))


def _wheel_loads(v) -> np.ndarray:
    """Static load (N) of each wheel of a vehicle; the weight shared equally when the
    static state cannot be solved."""
    try:
        return static_axle_loads(v)[: v.n_wheels]
    except (ValueError, np.linalg.LinAlgError):
        return np.full(v.n_wheels, v.total_weight / v.n_wheels)


def _highest_wheel_frequency(train, wheel_stiffness) -> tuple[float, str]:
    """The highest frequency (Hz) of a wheel with mass on its spring, and where it is;
    ``wheel_stiffness(vehicle)`` gives each wheel's stiffness (N/m) and which to check."""
    f_max, where = 0.0, ""
    for tr in train.trains:
        for v in tr.vehicles:
            if not v.n_wheels or v.total_weight <= 0:
                continue
            m_w = np.diag(v.M)[v.wheel_dofs]
            k, ok = wheel_stiffness(v)
            ok = ok & (m_w > 0)
            if not ok.any():
                continue
            f = float(np.max(np.sqrt(k[ok] / m_w[ok]))) / (2 * math.pi)
            if f > f_max:
                f_max, where = f, f"train '{tr.name}', vehicle '{v.name}'"
    return f_max, where


def _vehicle_frequency(v) -> tuple[float, str]:
    """The highest natural frequency (Hz) of a vehicle with its wheels held, and a note
    naming the bump stops when they set it.

    A bump stop adds its stiffness once its gap closes (a landing, a dip): the run must
    resolve the vehicle with every stop closed, ``K + sum k_s e_s e_s^T`` (``e_s`` the
    stop's compression row), as it resolves the same spring put in linearly.
    """
    if not v.n_dof or v.n_dof <= v.n_wheels:
        return 0.0, ""
    stops = [el for el in v.nonlinear if el.kind == "bump_stop"]
    k = np.array(v.K, float)
    for el in stops:
        e = np.asarray(el.row, float)
        k += float(el.params[1]) * np.outer(e, e)
    try:
        lin = v.natural_frequencies(fixed_wheels=True)
        closed = dataclasses.replace(v, K=k).natural_frequencies(fixed_wheels=True) \
            if stops else lin
    except (ValueError, np.linalg.LinAlgError):
        return 0.0, ""
    f_lin = float(lin.max(initial=0.0))
    f_closed = float(closed.max(initial=0.0))
    if f_closed > f_lin * (1 + 1e-6):
        k_max = max(float(el.params[1]) for el in stops)
        return f_closed, (f", vehicle '{v.name}' with its bump stops closed: "
                          f"bump_stop.stiffness up to {k_max:.4g} N/m; {f_lin:.4g} Hz with "
                          "the stops open")
    return f_lin, ""


def _hertz_warning(chk, train, dt, g, model="hertz"):
    """Wheel on the Hertz spring, stiffness at twice the static wheel load.

    The Hertz spring stiffens with the force, dN/d(delta) = 3 N^(1/3) / (2 G), so its
    frequency grows as N^(1/6).  A dip or a landing that the run should resolve lifts the
    contact force well above its static value Q0; the check takes the stiffness at
    :data:`HERTZ_LOAD_FACTOR` x Q0 (frequency x 2^(1/6) = 1.12), because the static-load
    stiffness let impact peaks be under-resolved without a warning.  The linearised
    model (``hertz_linear``) keeps the static-load stiffness for every force, so it is
    checked there.  Every wheel with mass is checked with its own static load.
    """
    factor = HERTZ_LOAD_FACTOR if model == "hertz" else 1.0

    def hertz(v):  # N/m, d(N)/d(delta) of delta = G N^(2/3) at factor x Q0
        q0 = _wheel_loads(v)
        return 1.5 * np.cbrt(factor * q0) / g, q0 > 0

    f_max, where = _highest_wheel_frequency(train, hertz)
    if dt * f_max > DT_RESOLUTION:
        load = (f"at {factor:g} x the static wheel load: the spring stiffens with the force"
                if factor != 1.0 else "at the static wheel load")
        chk.warn(
            f"solver.dt = {dt:g} s: dt x f = {dt * f_max:.3g} for the wheel on the Hertz "
            f"contact spring ({f_max:.4g} Hz, {where}, {load}); above "
            f"{DT_RESOLUTION} it is under-resolved (impact peaks too low); use "
            f"dt <= {DT_RESOLUTION / f_max:.3g} s",
            "resolution", ["solver.dt", "contact.hertz_coefficient"])


def _track_warning(chk, train, dt, track, contact):
    """Elastic track: every wheel with mass on the track spring 1/G(0) (in series with
    the Hertz spring, at twice the static load for ``hertz``, when there is one).  The
    wheel-on-track mode (~40-60 Hz for a wheelset) must be resolved by the step."""
    k_track = _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"]) \
        .axle_stiffness
    model = contact["model"]
    factor = HERTZ_LOAD_FACTOR if model == "hertz" else 1.0

    def track_and_hertz(v):
        k = np.full(v.n_wheels, k_track)
        if model != "rigid":
            k_h = 1.5 * np.cbrt(factor * np.clip(_wheel_loads(v), 1.0, None)) / \
                contact["hertz_coefficient"]
            k = 1.0 / (1.0 / k + 1.0 / k_h)
        return k, np.ones(v.n_wheels, bool)

    f_max, where = _highest_wheel_frequency(train, track_and_hertz)
    spring = "track" if model == "rigid" else "track and Hertz contact"
    if dt * f_max > DT_RESOLUTION:
        chk.warn(
            f"solver.dt = {dt:g} s: dt x f = {dt * f_max:.3g} for the wheel on the {spring} "
            f"springs ({f_max:.4g} Hz, {where}); above {DT_RESOLUTION} it is under-resolved "
            f"(wheel-rail force peaks too low); use dt <= {DT_RESOLUTION / f_max:.3g} s",
            "resolution", ["solver.dt", "track.foundation_stiffness"]
            + (["contact.hertz_coefficient"] if model != "rigid" else []))
    return f_max, where, spring


def _track_mode_excitation(irr, vmax) -> tuple[float, str] | None:
    """The highest frequency (Hz) at which the irregularity excites the wheels at
    ``vmax`` (m/s), and the key that sets it; inf for a profile read from a file or a
    step (broadband); None without irregularity."""
    r = irr.resolved
    found = []
    if r["kind"] == "psd":
        found.append((vmax / r["wavelength_min"], "irregularity.wavelength_min"))
    elif r["kind"] == "cosine":
        found.append((vmax / r["wavelength"], "irregularity.wavelength"))
    elif r["kind"] == "file":
        found.append((math.inf, "irregularity.path"))
    for i, dfc in enumerate(r.get("defects", [])):
        if dfc["kind"] == "cosine":
            found.append((vmax / dfc["wavelength"], f"irregularity.defects[{i}].wavelength"))
        else:
            found.append((math.inf, f"irregularity.defects[{i}]"))
    return max(found) if found else None


def _track_mode_warning(chk, dt, f_track, where, spring, irr, vmax):
    """The wheel-on-track mode excited by the irregularity (its frequency within
    :data:`TRACK_MODE_EXCITED` of the highest excitation frequency v / wavelength) needs
    :data:`TRACK_MODE_DT` (dt x f): the deck acceleration and dQ/Q0 follow the wheel
    forces of that mode, which HHT-alpha under-resolves and damps numerically."""
    exc = _track_mode_excitation(irr, vmax)
    if exc is None or f_track <= 0 or exc[0] < TRACK_MODE_EXCITED * f_track:
        return
    if dt * f_track <= TRACK_MODE_DT:
        return
    f_exc = "broadband" if math.isinf(exc[0]) else f"up to {exc[0]:.4g} Hz at " \
        f"{vmax * 3.6:g} km/h"
    chk.warn(
        f"solver.dt = {dt:g} s: the wheel-on-{spring} mode ({f_track:.4g} Hz, {where}) is "
        f"excited by the irregularity ({exc[1]}: {f_exc}); dt x f = {dt * f_track:.3g} "
        f"> {TRACK_MODE_DT} under-resolves the wheel forces of that mode and the deck "
        f"accelerations they drive; use dt <= {TRACK_MODE_DT / f_track:.3g} s",
        "resolution", ["solver.dt", exc[1]])


def _track_approach_warning(chk, solver, track):
    """A first axle that starts within the rail's reach of the deck (its static load
    already spread onto the deck, the train released there at full speed) biases the
    start: warn below ln(100 sqrt 2) / beta, where the rail's deflection line of a wheel
    has fallen below 1 % of its peak (|G(x)| <= sqrt 2 exp(-beta x) G(0))."""
    t = _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"])
    need = math.log(100.0 * math.sqrt(2.0)) / t.beta
    a = solver["approach"]
    if a < need:
        chk.warn(
            f"solver.approach = {a:g} m: the first axle starts within {need:.3g} m of the "
            f"deck, where the rail still carries more than 1 % of its load onto the deck; "
            f"the run then starts from a state the train would not have reached at speed "
            f"(deck acceleration and dQ/Q0 biased by a few %); use solver.approach >= "
            f"{need:.3g} m", "input", ["solver.approach"])


def _track_restraint_warning(chk, bridge, track):
    """The rail's stiffness the deck's modes leave out
    (:meth:`vsi_numba.model.track.ElasticTrack.restraint_ratio`), when above
    :data:`TRACK_RESTRAINT_WARN` of a mode's modal stiffness (short spans)."""
    model = bridge.model
    if not model.n_modes or model.kind == "rigid":
        return
    if any(not lo <= track[key] <= hi for key, (lo, hi, _) in TRACK_RANGES.items()):
        return  # no railway track: said by the plausibility checks, not computed here
    t = _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"])
    if not _track_filter_nodes(t, bridge) * model.n_modes <= MAX_TRACK_FILTER:
        return  # refused by the plausibility checks (the filter's memory), not computed
    with np.errstate(all="ignore"):  # an absurd deck is refused elsewhere, with its cause
        ratio = t.restraint_ratio(model)
    if not (np.all(np.isfinite(ratio)) and ratio.max() < 1.0):
        return  # not a deck on a rail: left to the plausibility checks
    j = int(np.argmax(ratio))
    if ratio[j] > TRACK_RESTRAINT_WARN:
        chk.warn(
            f"track: the rail's bending stiffness and its restraint of the deck ends, left "
            f"out of the deck's modes, are {100 * ratio[j]:.3g} % of the modal stiffness of "
            f"mode {j + 1} ({float(model.frequencies[j]):.4g} Hz; about "
            f"{50 * ratio[j]:.2g} % on its frequency): the deck is modelled slightly too "
            "soft (a short span on a stiff rail)", "input",
            ["track.rail_EI", "track.foundation_stiffness"])


def _rigid_massive_warning(chk, train, alpha):
    """Rigid contact, wheels with mass, alpha > -0.02: the contact forces ring."""
    if alpha <= RIGID_MASSIVE_ALPHA:
        return
    for tr in train.trains:
        for v in tr.vehicles:
            if v.n_wheels and np.any(np.diag(v.M)[v.wheel_dofs] > 0):
                chk.warn(
                    f"solver.hht_alpha = {alpha:g} with contact.model = 'rigid' and wheels "
                    f"with mass (train '{tr.name}', vehicle '{v.name}'): the trapezoidal "
                    "rule is weakly unstable on the position constraint of a massive wheel "
                    "and the contact forces ring from step to step; use hht_alpha <= "
                    f"{RIGID_MASSIVE_ALPHA:g} (the default -0.3 is safe)"
                )
                return


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


def _checked_frequency(model, solver) -> tuple[float, float]:
    """The highest retained bridge mode (Hz) within the checks' cut-off, and the cut-off
    (``solver.acceleration_cutoff``, else EN 1990 A2 max(30 Hz, 1.5 f1, f3) [R])."""
    freqs = np.asarray(model.frequencies, float)
    f_cut = solver["acceleration_cutoff"]
    if f_cut is None:
        f_cut = frequency_cutoff(freqs)
    return float(freqs[freqs <= f_cut * (1 + 1e-9)].max(initial=freqs[0])), f_cut


def default_time_step(bridge, solver) -> float:
    """``solver.dt`` when the config does not give it (s): 1 ms, halved until the
    highest retained bridge mode within the checks' cut-off has at least
    1 / :data:`DT_RESOLUTION` steps per period (0.5 ms for a 6 m deck whose f3 is
    196 Hz; 1 ms on most decks of 15 m and more).  Vehicles, contact and track springs
    keep their own checks."""
    dt = SolverSettings.dt
    model = bridge.model
    if not model.n_modes or model.kind == "rigid":
        return dt
    f_chk, _ = _checked_frequency(model, solver)
    while dt * f_chk > DT_RESOLUTION * (1 + 1e-9) and dt > DT_DEFAULT_MIN:
        dt /= 2.0
    return dt


def _default_time_step(solver, given, bridge) -> None:
    """Fill ``solver["dt"]`` with :func:`default_time_step` when ``given`` (the
    ``[solver]`` table as written) has no ``dt``."""
    if isinstance(given, dict) and "dt" in given:
        return
    solver["dt"] = default_time_step(bridge, solver)


def _physics_warnings(chk, bridge, train, irr, solver, study, contact, track):
    _speed_slips(chk, study, train)
    for msg in _vehicle_unit_slips(train):
        _refuse(chk, solver, "allow_implausible", msg)
    if _deck_mass_slip(chk, bridge, solver) or _unit_slips(bridge, train, solver):
        return  # the units are the cause: no time-step messages about their consequences
    dt = solver["dt"]
    if track["model"] == "elastic":
        f_track, where, spring = _track_warning(chk, train, dt, track, contact)
        _track_mode_warning(chk, dt, f_track, where, spring, irr,
                            max(study["speeds_kmh"]) / 3.6)
        _track_approach_warning(chk, solver, track)
        if any(v.n_wheels for tr in train.trains for v in tr.vehicles):
            # moving forces load the deck's modes directly: the track enters no run
            _track_restraint_warning(chk, bridge, track)
    elif contact["model"] != "rigid":
        _hertz_warning(chk, train, dt, contact["hertz_coefficient"], contact["model"])
    else:
        _rigid_massive_warning(chk, train, solver["hht_alpha"])
    vmax = max(study["speeds_kmh"]) / 3.6
    model = bridge.model
    if model.n_modes:
        fmax = float(model.frequencies[-1])
        # the modes that enter the checks: those up to the deck-acceleration cut-off
        f_chk, f_cut = _checked_frequency(model, solver)
        if dt * f_chk > DT_ERROR and not solver.get("allow_coarse_dt"):
            chk.errors.append(
                f"solver.dt = {dt:g}: expected a time step giving at least "
                f"{1 / DT_ERROR:.0f} steps per period of the highest retained bridge mode "
                f"within the checks' cut-off ({f_chk:.4g} Hz; cut-off {f_cut:.4g} Hz): "
                f"dt x f = {dt * f_chk:.3g} > {DT_ERROR}; use dt <= "
                f"{DT_RESOLUTION / f_chk:.3g} s (10 steps per period), or set "
                "solver.allow_coarse_dt = true to run anyway (the checks are then marked "
                "not reliable)")
        elif dt * fmax > DT_RESOLUTION:
            chk.warn(
                f"solver.dt = {dt:g} s: dt x f = {dt * fmax:.3g} for the highest retained "
                f"bridge mode ({fmax:.4g} Hz); above {DT_RESOLUTION} (fewer than "
                f"{1 / DT_RESOLUTION:.0f} steps per period) that mode is under-resolved and "
                f"damped numerically; use dt <= {DT_RESOLUTION / fmax:.3g} s or fewer modes",
                # only the modes within the cut-off make the checks unreliable
                "resolution" if dt * f_chk > DT_RESOLUTION else "input",
                ["solver.dt", "bridge.n_modes"])
            if dt * f_chk > DT_RESOLUTION and f_chk < fmax:
                chk.warn(
                    f"solver.dt = {dt:g} s: dt x f = {dt * f_chk:.3g} for the highest "
                    f"retained mode within the checks' cut-off ({f_chk:.4g} Hz); the "
                    "deck accelerations are under-resolved", "resolution",
                    ["solver.dt", "bridge.n_modes"])
        allf = bridge.all_frequencies
        if allf is not None and allf.size:
            cut = solver["acceleration_cutoff"]
            rule = "solver.acceleration_cutoff"
            if cut is None:
                cut = frequency_cutoff(allf)
                rule = "the EN 1990 A2.4.4.2.1 cut-off max(30 Hz, 1.5 f1, f3)"
            missing = int(np.count_nonzero(allf <= cut * (1 + 1e-9))) - model.n_modes
            if missing > 0:
                chk.warn(
                    f"bridge.n_modes: the highest retained mode ({fmax:.4g} Hz) is below "
                    f"{rule} = {cut:.4g} Hz; {missing} mode(s) up to the cut-off are left out "
                    "of the deck accelerations (raise bridge.n_modes or bridge.max_frequency)"
                )
    for tr in train.trains:
        fv, stops = 0.0, ""
        for v in tr.vehicles:
            f, closed = _vehicle_frequency(v)
            if f > fv:
                fv, stops = f, closed
        what = f"({fv:.4g} Hz, wheels held{stops})"
        if dt * fv > DT_ERROR and not solver.get("allow_coarse_dt"):
            chk.errors.append(
                f"solver.dt = {dt:g}: expected a time step giving at least "
                f"{1 / DT_ERROR:.0f} steps per period of the highest vehicle frequency of "
                f"train '{tr.name}' {what}: dt x f = {dt * fv:.3g} > "
                f"{DT_ERROR}; use dt <= {DT_RESOLUTION / fv:.3g} s, or set "
                "solver.allow_coarse_dt = true to run anyway (the results are then marked "
                "not reliable)")
        elif dt * fv > DT_RESOLUTION:
            chk.warn(
                f"solver.dt = {dt:g} s: dt x f = {dt * fv:.3g} for the highest vehicle "
                f"frequency of train '{tr.name}' {what}; above "
                f"{DT_RESOLUTION} it is under-resolved; use dt <= {DT_RESOLUTION / fv:.3g} s",
                "resolution", ["solver.dt", "train"])
    r = irr.resolved
    shortest = []
    if r["kind"] == "psd":
        shortest.append(("irregularity.wavelength_min", r["wavelength_min"]))
    if r["kind"] == "cosine":
        shortest.append(("irregularity.wavelength", r["wavelength"]))
    for i, dfc in enumerate(r.get("defects", [])):
        key = "wavelength" if dfc["kind"] == "cosine" else "length"
        shortest.append((f"irregularity.defects[{i}].{key}", dfc[key]))
    for key, lam in shortest:
        steps = lam / (vmax * dt)
        if steps < STEPS_PER_WAVELENGTH:
            chk.warn(
                f"{key} = {lam:g} m is crossed in {steps:.3g} time steps at "
                f"{vmax * 3.6:g} km/h (dt = {dt:g} s); fewer than {STEPS_PER_WAVELENGTH} "
                "steps per wavelength under-resolve the excitation (reduce solver.dt)",
                "resolution", ["solver.dt", key, "study.speeds_kmh"])
    amps = []
    if r["kind"] in ("cosine", "step"):
        key = "depth" if "depth" in r else "height"
        amps.append((f"irregularity.{key}", abs(r.get(key, 0.0))))
    for i, dfc in enumerate(r.get("defects", [])):
        key = "depth" if dfc["kind"] == "cosine" else "height"
        amps.append((f"irregularity.defects[{i}].{key}", abs(dfc.get(key, 0.0))))
    if irr.file_profile is not None and irr.file_profile.coef.size:
        amps.append(("irregularity.path", float(np.max(np.abs(irr.file_profile.coef[:, 0])))))
    combined = _defects_amplitude(r)
    if combined is not None and all(a <= MAX_PROFILE_AMPLITUDE for _, a in amps):
        amps.append(("irregularity.defects (added up)", combined))
    for key, amp in amps:
        if amp > MAX_PROFILE_AMPLITUDE and not solver.get("allow_implausible"):
            chk.errors.append(
                f"{key}: |r| = {amp:g} m: expected a track irregularity within "
                f"+-{MAX_PROFILE_AMPLITUDE * 1e3:g} mm (irregularities are in metres: was mm "
                "intended?); set solver.allow_implausible = true to run it anyway")
        elif amp > MAX_PROFILE_AMPLITUDE:
            chk.warn(f"{key}: |r| = {amp:g} m is more than "
                     f"{MAX_PROFILE_AMPLITUDE * 1e3:g} mm; irregularities are in metres (was "
                     "mm intended?)", "plausibility", [key])
    prof = irr.file_profile
    if prof is not None and bridge.length is not None and train.trains:
        tl = max(train_extent(t) for t in train.trains)
        lo, hi = -solver["approach"] - tl, bridge.length + tl
        if prof.x0 > lo + 1e-9 or prof.x_end < hi - 1e-9:
            chk.warn(f"irregularity.path: the profile covers x = {prof.x0:g} .. "
                     f"{prof.x_end:g} m; the trailing axles run over {lo:g} .. {hi:g} m and see "
                     "r = 0 outside the measured range")
    if train.trains:
        length = max(train_extent(t) for t in train.trains)
        vmin = min(study["speeds_kmh"]) / 3.6
        steps = ((solver["approach"] + model.length + length) / vmin
                 + solver["free_vibration"]) / dt
        if steps > 2e7:
            chk.warn(f"solver.dt = {dt:g} s: the slowest run needs about {steps:.3g} time "
                     "steps; check the time step")


def _refuse(chk, solver, override: str, message: str) -> None:
    """An error unless ``solver.<override> = true`` (then a warning)."""
    if solver.get(override):
        chk.warn(f"{message} (accepted: solver.{override} = true)", "plausibility")
    else:
        chk.errors.append(f"{message}; set solver.{override} = true to run it anyway")


def _train_loads(tr):
    """Axle positions (m behind the first axle) and static loads (N) of a train: each
    vehicle's weight shared equally by its wheels, plus its moving forces."""
    xs, qs = [], []
    for v, off in zip(tr.vehicles, tr.offsets, strict=True):
        if v.n_wheels and v.total_weight > 0:
            share = (v.total_weight - float(np.sum(v.loads))) / v.n_wheels
            xs.append(off + np.asarray(v.wheel_positions, float))
            qs.append(np.full(v.n_wheels, max(share, 0.0)))
        if np.size(v.loads):
            xs.append(off + np.asarray(v.load_positions, float))
            qs.append(np.asarray(v.loads, float))
    if not xs:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(xs), np.concatenate(qs)


def _defects_amplitude(r) -> float | None:
    """Largest |r| (m) of the deterministic defects added up (a cosine or step base and
    every ``[[irregularity.defects]]``), or None without two of them.  A sweep over the
    defects' extents bounds it first; only a bound above the limit builds the profile."""
    specs = [dict(r)] if r["kind"] in ("cosine", "step") else []
    specs += list(r.get("defects", []))
    if len(specs) < 2:
        return None
    events = []
    for d in specs:
        amp = abs(d.get("depth", d.get("height", 0.0)))
        start = d["position"]
        end = start + (d["wavelength"] if d["kind"] == "cosine" else math.inf)
        events += [(start, amp), (end, -amp)]
    bound = level = 0.0
    for _, a in sorted(events, key=lambda e: (e[0], e[1] < 0)):
        level += a
        bound = max(bound, level)
    if bound <= MAX_PROFILE_AMPLITUDE:
        return bound
    stop = max(d["position"] + d.get("wavelength", d.get("length", 0.0)) for d in specs)
    total = _irr.combine(*[_defect_profile(d, stop) for d in specs])
    x = np.linspace(total.x0, total.x_end, min(200_000, total.coef.shape[0] * 4 + 1))
    return float(np.max(np.abs(total(x))))


def _track_filter_nodes(tr, bridge) -> float:
    """Rail nodes of the FE filter of the mode shapes (:meth:`ElasticTrack.filtered_shapes`)."""
    return ((float(bridge.model.length) + 2.0 * tr.reach) * _track.ELEMENTS_PER_LENGTH
            * tr.beta)


def _track_plausibility(chk, train, solver, track, bridge=None):
    """The elastic track: a value outside its physical range (:data:`TRACK_RANGES`), a
    static rail deflection under the heaviest axle above :data:`MAX_TRACK_DEFLECTION`
    (typically 0.5-2 mm), or a stiffness under one axle above
    :data:`MAX_TRACK_STIFFNESS`, is a unit slip (N vs MN), not a track; an FE rail filter
    of more than :data:`MAX_TRACK_FILTER` nodes x modes is refused (memory)."""
    if not isinstance(track, dict) or track.get("model") != "elastic":
        return
    if bridge is not None and _unit_slips(bridge, train, solver):
        return  # refused for its units (a train 1000 x too heavy deflects any track)
    for key, (lo, hi, units) in TRACK_RANGES.items():
        v = track[key]
        if not lo <= v <= hi:
            _refuse(chk, solver, "allow_implausible",
                    f"track.{key} = {v:g}: expected {lo:g} .. {hi:g} {units} (both rails; "
                    f"the default is {_DEFAULT_TRACK[key]:.4g}); outside this range it is "
                    "no railway track")
    tr = _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"])
    if bridge is not None and bridge.model.n_modes:
        length = float(bridge.model.length)
        nodes = _track_filter_nodes(tr, bridge)
        if not nodes * bridge.model.n_modes <= MAX_TRACK_FILTER:
            chk.errors.append(
                f"track.foundation_stiffness = {track['foundation_stiffness']:g}, "
                f"track.rail_EI = {track['rail_EI']:g}: the rail filter of the mode shapes "
                f"needs {nodes:.3g} rail nodes x {bridge.model.n_modes} modes, more than "
                f"the budget of {MAX_TRACK_FILTER:.3g} (the rail's characteristic length "
                f"1/beta = {1 / tr.beta:.3g} m on a {length:g} m deck); expected the "
                "values of a railway track")
            return
    k_axle = tr.axle_stiffness
    keys = "track.foundation_stiffness, track.rail_EI"
    if k_axle > MAX_TRACK_STIFFNESS:
        _refuse(chk, solver, "allow_implausible",
                f"{keys}: {k_axle / 1e6:.4g} kN/mm under one axle, stiffer than any railway "
                f"track (expected up to {MAX_TRACK_STIFFNESS / 1e6:g} kN/mm; the default is "
                "150 kN/mm; units: N/m per metre and N m^2)")
        return
    loads = [float(np.max(np.abs(_train_loads(tr)[1]), initial=0.0)) for tr in train.trains]
    heaviest = max(loads, default=0.0)
    if heaviest / k_axle > MAX_TRACK_DEFLECTION:
        _refuse(chk, solver, "allow_implausible",
                f"{keys}: a static rail deflection of {heaviest / k_axle * 1e3:.4g} mm under "
                f"the heaviest axle ({heaviest / 1e3:.4g} kN on {k_axle / 1e6:.4g} kN/mm), "
                f"expected at most {MAX_TRACK_DEFLECTION * 1e3:g} mm (units: N/m per metre "
                "and N m^2)")


def _static_deflection_refusal(chk, solver, bridge, too_soft, limit) -> None:
    """One refusal for the trains whose static deflection of the deck exceeds
    :data:`MAX_STATIC_DEFLECTION` x span (``too_soft``: (train name, deflection m)),
    naming the bending stiffness in kN m^2 when 1000 x it would carry them all."""
    span = f"span/{1 / MAX_STATIC_DEFLECTION:.0f} = {limit:.3g} m"
    ws = np.array([w for _, w in too_soft], float)
    ei = np.atleast_1d(np.asarray(bridge.resolved.get("EI", []), float))
    slip = ""
    if ei.size and np.all(np.isfinite(ws)) and ws.max() / 1e3 <= limit:
        shown = f"{ei[0]:g}" if ei.size == 1 else _show_list(ei)
        slip = (f"; bridge.EI = {shown} N m^2 looks like kN m^2 ({ei.min():g} kN m^2 = "
                f"{ei.min() * 1e3:g} N m^2: the deflections would be {ws.max() / 1e3:.3g} m "
                "at most)")
    if len(too_soft) == 1:
        name, w = too_soft[0]
        head = f"train '{name}' on the deck: static deflection {w:.3g} m > {span}"
    else:
        i = int(np.nanargmax(np.where(np.isfinite(ws), ws, np.inf)))
        names = ", ".join(f"'{n}'" for n, _ in too_soft[:4]) + (
            f" and {len(too_soft) - 4} more" if len(too_soft) > 4 else "")
        head = (f"{len(too_soft)} trains on the deck ({names}): static deflections up to "
                f"{ws[i]:.3g} m (train '{too_soft[i][0]}') > {span}")
    _refuse(chk, solver, "allow_implausible",
            f"{head} (check bridge.EI, bridge.mass_per_length, bridge.spans and the "
            f"train's loads/masses: units N, kg, N m^2?){slip}")


def _show_list(values) -> str:
    """One number as itself, several as a list ("1e-300", "[1e+10, 2e+10]")."""
    values = list(values)
    if len(values) == 1:
        return f"{values[0]:g}"
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


#: A built-in deck's modes below this frequency (Hz) cannot be computed: the modal
#: solution divides by omega^2 (1e-154 Hz from GJ = 1e-300 overflows it); no override.
MIN_MODE_FREQUENCY = 1e-3


def _uncomputable_modes(chk, bridge) -> bool:
    """A beam deck whose lowest bending or torsional mode is below
    :data:`MIN_MODE_FREQUENCY` (or not finite): refused, whatever the overrides, naming
    the keys that set it.  True when refused."""
    if bridge.kind not in ("simply_supported", "continuous") or not bridge.model.n_modes:
        return False
    freqs = np.asarray(bridge.model.frequencies, float)
    space = getattr(bridge, "space", None)
    share = getattr(space, "torsional_share", None) if space is not None else None
    tors = (np.asarray(share, float) > 0.5 if share is not None and np.size(share) ==
            freqs.size else np.zeros(freqs.size, bool))
    bad = ~np.isfinite(freqs) | (freqs < MIN_MODE_FREQUENCY)
    if not bad.any():
        return False
    j = int(np.flatnonzero(bad)[0])
    r = bridge.resolved
    if tors[j]:
        keys = (f"bridge.torsion.GJ = {_show_list(np.atleast_1d(r['torsion']['GJ']))}, "
                f"bridge.torsion.polar_mass = "
                f"{_show_list(np.atleast_1d(r['torsion']['polar_mass']))}")
        what = "torsional"
    else:
        keys = (f"bridge.EI = {_show_list(np.atleast_1d(r['EI']))}, bridge.mass_per_length = "
                f"{_show_list(np.atleast_1d(r['mass_per_length']))}")
        what = "bending"
    chk.errors.append(f"{keys}: the lowest {what} mode has f = {freqs[j]:.3g} Hz; expected "
                      f"modes above {MIN_MODE_FREQUENCY:g} Hz (the modal solution divides by "
                      "omega^2), the values of a railway deck in N m^2 and kg m^2/m or kg/m")
    return True


def _plausibility(chk, bridge, train, irr, solver, study, contact):
    """Errors for input that cannot be meant (each names its keys and the override key)
    and for runs beyond the memory/time budget; warnings for the unusual."""
    if _unit_slips(bridge, train, solver):
        return  # refused for its units: the deflections etc. would only repeat it
    model = bridge.model
    spans = np.atleast_1d(np.asarray(bridge.resolved.get("spans", [bridge.length or 0.0]),
                                     float))
    dt = solver["dt"]
    trains = list(train.trains)
    before = len(chk.errors)
    # -- static deflection of the deck under each train
    if model.n_modes and trains and spans.size and spans.max() > 0:
        limit = MAX_STATIC_DEFLECTION * float(spans.max())
        pts = np.linspace(0.0, model.length, 41)
        phi_p = model.output_shapes(pts)  # (points, modes)
        # upper bound first: the heaviest bridge-length of axles at the most flexible
        # point, W max_x sum_j phi_j(x)^2 / w_j^2; the influence lines only when it exceeds
        # the limit (the bound is cheap; the exact pass costs ~50 ms per train)
        with np.errstate(all="ignore"):
            flex = float(np.max(np.sum(model.shapes(pts) ** 2 / model.omega**2, axis=1)))
        too_soft = []
        for tr in trains:
            x, q = _train_loads(tr)
            if not x.size:
                continue
            order = np.argsort(x)
            xs, cq = x[order], np.concatenate([[0.0], np.cumsum(np.abs(q[order]))])
            j = np.searchsorted(xs, xs + model.length, side="right")
            heaviest = float(np.max(cq[j] - cq[np.arange(xs.size)]))
            if np.isfinite(flex) and heaviest * flex <= limit:
                continue
            step = max(model.length / 200.0, 0.05)
            reach = model.length + float(x.max())
            n_f = min(reach / step + 2, max(200_000 // x.size, 2))  # keep it cheap
            fronts = np.linspace(0.0, reach, int(n_f))
            xx = fronts[:, None] - x[None, :]
            on = (xx >= 0.0) & (xx <= model.length)
            xx = np.where(on, xx, 0.0)
            phi_k = model.shapes(xx.ravel()).reshape(xx.shape + (model.n_modes,))
            phi_k = phi_k * on[..., None]
            with np.errstate(all="ignore"):  # absurd input: inf/NaN is the answer here
                modal = np.einsum("fkj,k->fj", phi_k, q) / model.omega**2
                w = float(np.max(np.abs(modal @ phi_p.T))) if modal.size else 0.0
            if not np.isfinite(w) or w > limit:
                too_soft.append((tr.name, w))
        if too_soft:  # one cause (the deck, or its units): one message for every train
            _static_deflection_refusal(chk, solver, bridge, too_soft, limit)
    n_errors = len(chk.errors)
    if (n_errors == before or solver.get("allow_implausible")) and \
            _uncomputable_modes(chk, bridge):
        return  # (after the deflection, which names a deck too soft for its trains)
    # -- Hertz static penetration
    if contact["model"] != "rigid":
        g = contact["hertz_coefficient"]
        for tr in trains:
            x, q = _train_loads(tr)
            if q.size and q.max() > 0:
                pen = g * float(q.max()) ** (2.0 / 3.0)
                if pen > MAX_HERTZ_PENETRATION:
                    _refuse(chk, solver, "allow_implausible",
                            f"contact.hertz_coefficient = {g:g}: static Hertz penetration "
                            f"{pen * 1e3:.3g} mm under the heaviest wheel of train "
                            f"'{tr.name}' ({float(q.max()):.4g} N) > "
                            f"{MAX_HERTZ_PENETRATION * 1e3:g} mm (G is in m N^-2/3, about "
                            "4e-8 for a wheel on a rail)")
    # -- vehicle stiffness
    for tr in trains:
        for v in tr.vehicles:
            if v.n_dof == 0:
                continue
            k = np.asarray(v.K, float)
            ks = 0.5 * (k + k.T)
            try:
                lam = np.linalg.eigvalsh(ks)
            except np.linalg.LinAlgError:
                continue
            scale = max(float(np.max(np.abs(lam))), 1e-300)
            if lam.size and lam.min() < -1e-9 * scale:
                _refuse(chk, solver, "allow_implausible",
                        f"train '{tr.name}', vehicle '{v.name}': the stiffness matrix K is "
                        f"not positive semi-definite (eigenvalue {lam.min():.4g} N/m; check "
                        "the signs of train.vehicles[].K or the spring stiffnesses)")
    # -- long trains
    for tr in trains:
        if tr.length > LONG_TRAIN:
            chk.warn(f"train '{tr.name}' is {tr.length:.4g} m long (more than "
                     f"{LONG_TRAIN:g} m): check the vehicle offsets", "plausibility",
                     ["train.vehicles[].offset"])
    # -- budget: time steps, histories, profile samples
    if not trains:
        return
    # the last axle's distance behind the train's reference (the first vehicle's offset
    # included): the run lasts until it leaves the bridge
    length = max(train_extent(t) for t in trains)
    others = train.resolved.get("other_trains") or []
    # with trains on other tracks the run lasts until the last of them has left the deck
    later = max((float(o["offset"]) for o in others), default=0.0)
    vmin = min(study["speeds_kmh"]) / 3.6
    steps = ((solver["approach"] + model.length + length + later) / vmin
             + solver["free_vibration"]) / dt
    keys = ("solver.dt, study.speeds_kmh (slowest), solver.free_vibration, "
            "solver.approach, the train length (vehicle offsets)"
            + (", train.other_trains[].offset" if others else ""))
    if not steps <= HARD_MAX_STEPS:
        chk.errors.append(f"the slowest run needs {steps:.3g} time steps, more than the hard "
                          f"budget of {HARD_MAX_STEPS:.3g} that no machine runs (solver."
                          f"allow_large_problem does not lift it); check {keys}")
    elif steps > MAX_STEPS:
        _refuse(chk, solver, "allow_large_problem",
                f"the slowest run needs {steps:.3g} time steps, more than the budget of "
                f"{MAX_STEPS:.3g}; check {keys}")
    elif study["save_time_histories"] or others:
        n_w = max(t.n_wheels + t.n_loads for t in trains)
        n_b = max(len(t.vehicles) for t in trains)
        n_p = len(bridge.resolved.get("output_points") or []) or 1
        nbytes = steps * 8.0 * (2 * model.n_modes + 2 * n_w + n_b + 2 * n_p)
        if others:  # every train's modal histories are kept and summed (superposition)
            nbytes = max(nbytes, steps * 8.0 * 2 * model.n_modes * (1 + len(others)))
        if nbytes > MAX_HISTORY_BYTES and others:
            _refuse(chk, solver, "allow_large_problem",
                    f"the time histories of the slowest run need about {nbytes / 2**30:.3g} "
                    f"GiB in memory ({steps:.3g} steps; with train.other_trains every "
                    "train's histories are kept to be summed), more than the budget of "
                    f"{MAX_HISTORY_BYTES / 2**30:g} GiB; check {keys}")
        elif nbytes > MAX_HISTORY_BYTES:
            _refuse(chk, solver, "allow_large_problem",
                    f"the time histories of the slowest run need about {nbytes / 2**30:.3g} "
                    f"GiB in memory ({steps:.3g} steps), more than the budget of "
                    f"{MAX_HISTORY_BYTES / 2**30:g} GiB; set study.save_time_histories = "
                    f"false or study.history_speeds_kmh, or check {keys}")
    r = irr.resolved
    if r["kind"] == "psd":
        x0, x1 = profile_range(model.length, [train_extent(t) for t in trains],
                               solver["approach"], solver["free_vibration"])
        dx = r.get("dx") or r["wavelength_min"] / 20.0
        try:
            period, n_fft = psd_grid(r["wavelength_min"], r["wavelength_max"], r.get("dx"))
            dx = period / n_fft
        except ValueError:  # over the sample budget: the count it would have
            period = PSD_PERIOD * 2.0 ** max(0, math.ceil(math.log2(
                20.0 * r["wavelength_max"] / PSD_PERIOD)))
            n_fft = period / dx
        n = max(n_fft, (x1 - x0) / dx)
        if n > MAX_PROFILE_SAMPLES:
            _refuse(chk, solver, "allow_large_problem",
                    f"irregularity: each random profile needs {n:.3g} samples, more than "
                    f"the budget of {MAX_PROFILE_SAMPLES:.3g} (one period of "
                    f"{period:.6g} m and the track length {x1 - x0:.4g} m at a spacing of "
                    f"{dx:.3g} m, irregularity.dx or wavelength_min / 20 rounded down to a "
                    "power-of-two division of the period); check irregularity."
                    "wavelength_min, wavelength_max, dx, solver.free_vibration and the "
                    "train length")
        elif x1 - x0 > period:
            chk.warn(f"irregularity: the track range of the study ({x1 - x0:.6g} m: "
                     "approach, longest train, bridge and solver.free_vibration at "
                     f"{_irr.SPEED_BOUND_KMH:g} km/h) is longer than the period of the "
                     f"random profiles ({period:.6g} m): the track repeats every "
                     f"{period:.6g} m", "input", ["irregularity", "solver.free_vibration"])
