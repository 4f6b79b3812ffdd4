"""Load-time checks of the wheel, contact and track springs: their time-step resolution
(Hertz spring, wheel on the elastic track, the wheel-on-track mode the irregularity
excites), the approach a track needs, the rail stiffness left out of the deck, rigid
contact with massive wheels, and the plausibility of the [track] values."""

from __future__ import annotations

import math

import numpy as np

from vsi_numba.config._check import _refuse
from vsi_numba.config.limits import (
    DT_RESOLUTION,
    MAX_TRACK_DEFLECTION,
    MAX_TRACK_FILTER,
    MAX_TRACK_STIFFNESS,
    TRACK_RANGES,
)
from vsi_numba.config.slips import _unit_slips
from vsi_numba.model import track as _track
from vsi_numba.model.library import static_axle_loads

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
