"""Checks of the whole model at load time: the physics warnings (time-step resolution of
the modes, the vehicles, the contact and track springs and the irregularities; modes left
out below the EN 1990 cut-off) and the plausibility refusals (static deflection, Hertz
penetration, vehicle stiffness, run and memory budget), each with its override key."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from vsi_numba.config._check import _refuse
from vsi_numba.config.irregularity import _defect_profile
from vsi_numba.config.limits import (
    DT_DEFAULT_MIN,
    DT_ERROR,
    DT_RESOLUTION,
    HARD_MAX_STEPS,
    LONG_TRAIN,
    MAX_HERTZ_PENETRATION,
    MAX_HISTORY_BYTES,
    MAX_PROFILE_AMPLITUDE,
    MAX_PROFILE_SAMPLES,
    MAX_STATIC_DEFLECTION,
    MAX_STEPS,
    STEPS_PER_WAVELENGTH,
)
from vsi_numba.config.slips import (
    _deck_mass_slip,
    _speed_slips,
    _unit_slips,
    _vehicle_unit_slips,
)
from vsi_numba.config.track_physics import (
    _hertz_warning,
    _rigid_massive_warning,
    _track_approach_warning,
    _track_mode_warning,
    _track_restraint_warning,
    _track_warning,
    _train_loads,
)
from vsi_numba.en1990 import frequency_cutoff
from vsi_numba.model import irregularity as _irr
from vsi_numba.model.irregularity import profile_range
from vsi_numba.model.psd import PSD_PERIOD, psd_grid
from vsi_numba.solver.settings import SolverSettings


def train_extent(train) -> float:
    """How far (m) the last axle runs behind the train's reference point (its first axle,
    offset 0): the train length, or more when the first vehicle has an offset."""
    return max(float(train.length), float(np.max(train.axle_positions, initial=0.0)))


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
    _speed_slips(chk, study.resolved, train)
    for msg in _vehicle_unit_slips(train):
        _refuse(chk, solver, "allow_implausible", msg)
    if _deck_mass_slip(chk, bridge, solver) or _unit_slips(bridge, train, solver):
        return  # the units are the cause: no time-step messages about their consequences
    dt = solver["dt"]
    if track["model"] == "elastic":
        f_track, where, spring = _track_warning(chk, train, dt, track, contact)
        _track_mode_warning(chk, dt, f_track, where, spring, irr,
                            float(study.speeds_m_s.max()))
        _track_approach_warning(chk, solver, track)
        if any(v.n_wheels for tr in train.trains for v in tr.vehicles):
            # moving forces load the deck's modes directly: the track enters no run
            _track_restraint_warning(chk, bridge, track)
    elif contact["model"] != "rigid":
        _hertz_warning(chk, train, dt, contact["hertz_coefficient"], contact["model"])
    else:
        _rigid_massive_warning(chk, train, solver["hht_alpha"])
    vmax = float(study.speeds_m_s.max())
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
                f"{max(study.resolved['speeds_kmh']):g} km/h (dt = {dt:g} s); fewer than "
                f"{STEPS_PER_WAVELENGTH} "
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
        vmin = float(study.speeds_m_s.min())
        steps = ((solver["approach"] + model.length + length) / vmin
                 + solver["free_vibration"]) / dt
        if steps > 2e7:
            chk.warn(f"solver.dt = {dt:g} s: the slowest run needs about {steps:.3g} time "
                     "steps; check the time step")


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
    vmin = float(study.speeds_m_s.min())
    run = (solver["approach"] + model.length + length + later) / vmin
    # a train of its own or at a speed of its own: until it has left too
    speeds = getattr(train, "other_speeds_m_s", ()) or [None] * len(others)
    for o, own, speed in zip(others, getattr(train, "others", ()) or [None] * len(others),
                             speeds, strict=False):
        ext = length if own is None else train_extent(own)
        v = speed if speed is not None else o.get("speed_factor", 1.0) * vmin
        run = max(run, (solver["approach"] + model.length + ext + float(o["offset"])) / v)
    steps = (run + solver["free_vibration"]) / dt
    keys = ("solver.dt, study.speeds_kmh (slowest), solver.free_vibration, "
            "solver.approach, the train length (vehicle offsets)"
            + (", train.other_trains[].offset, .speed_kmh, .speed_factor" if others else ""))
    if not steps <= HARD_MAX_STEPS:
        chk.errors.append(f"the slowest run needs {steps:.3g} time steps, more than the hard "
                          f"budget of {HARD_MAX_STEPS:.3g} that no machine runs (solver."
                          f"allow_large_problem does not lift it); check {keys}")
    elif steps > MAX_STEPS:
        _refuse(chk, solver, "allow_large_problem",
                f"the slowest run needs {steps:.3g} time steps, more than the budget of "
                f"{MAX_STEPS:.3g}; check {keys}")
    elif study.resolved["save_time_histories"] or others:
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
