"""Convergence of the governing cases: each re-run at half the time step, and at the
resonance speeds of its train that fall between the speeds of the grid.

A checked result is only as good as its time step and its speed grid.  For the governing
case of each check of the summary (deck acceleration, deck displacement, wheel
unloading, the EN 1991-2 6.4.6.5(3) bending-moment ratio) the report re-runs the case
through the study engine from the file's stored configuration
(:meth:`~vsi_numba.analysis.recompute.CaseRunner.study`: the same outputs, the same
track lines, every realisation) at the study's time step and at half of it, and applies
the summary's own check to the re-run: the quantity at dt is the summary's value (the
table shows both), and its change at dt/2 above :data:`DT_THRESHOLD` is flagged.  The
resonance speeds v_i = f1 D / i of the governing train (D its regular length, from the
axle positions for a train given by its axles) inside the study's range and off its
grid are re-run too, and a value above the grid's by more than
:data:`RESONANCE_THRESHOLD` is flagged.  A check that could not be made (no regular
length, no frequency, a re-run refused) says so on its own line; the section then never
reads as converged.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis.governing import governing_cases
from vsi_numba.analysis.recompute import CaseRunner, RecomputeError
from vsi_numba.analysis.report.document import Markdown, Section, Table
from vsi_numba.analysis.report.safe import md

#: Relative change of a governing result between dt and dt/2 above which it is flagged.
DT_THRESHOLD = 0.05

#: Relative excess of the value at an exact resonance speed over the grid's governing
#: value above which it is flagged.
RESONANCE_THRESHOLD = 0.05

#: What a re-run may raise (it is reported, the report goes on).
_RERUN_ERRORS = (RecomputeError, ValueError, ArithmeticError, MemoryError, KeyError)

#: Resonance orders i of v_i = f1 D / i looked at.
ORDERS = (1, 2, 3, 4)

#: Relative difference between the re-run at the study's time step and the summary's
#: value above which the re-run is said not to reproduce it (the same engine and inputs
#: give the same numbers; the netCDF file keeps float64 envelopes).
REPRODUCE_TOLERANCE = 1e-6

#: check name -> (quantity, units) as the summary names it.
QUANTITIES = {
    "deck_acceleration": ("Peak deck acceleration", "m s-2"),
    "deck_displacement": ("Max deck displacement", "m"),
    "wheel_unloading": ("Wheel unloading ΔQ/Q₀", "1"),
    "bending_moment": ("6.4.6.5(3) bending moment M ratio (1 + φ'dyn + φ''/2) × train / "
                       "(Φ × α × LM71)", "1"),
}


def _fmt(v: float, units: str) -> str:
    """A value as the summary shows it (m/s², mm, plain)."""
    if not np.isfinite(v):
        return "–"
    if units == "m s-2":
        return f"{v:.4g} m/s²"
    if units == "m":
        return f"{1e3 * v:.4g} mm"
    return f"{v:.4g}"


def _acceleration_place(a: dict) -> str:
    """Where the summary's deck acceleration is taken (the deck, along the loaded
    track, whole-deck grid or output points)."""
    if a.get("loaded_track") is not None and "loaded_track" in a:
        line = f"the deck and the line of track {int(a['loaded_track'])}"
    else:
        line = "the deck"
    grid = "whole-deck grid and output points" if a.get("whole_deck") else "output points"
    return f"max over {line} ({grid})"


def quantities(mini: xr.Dataset, q: float, le_check=None, names=None
               ) -> dict[str, tuple[float, str]]:
    """The summary's checks applied to a re-run (:meth:`CaseRunner.study`): name ->
    (value, where), the value the summary would give for this train and speed.

    ``names``: the checks to make (default: every one of :data:`QUANTITIES`)."""
    from vsi_numba.analysis.dataset import prepare

    wanted = set(QUANTITIES) if names is None else set(names)
    mini = prepare(mini)  # once: each check would prepare it again
    out: dict[str, tuple[float, str]] = {}
    if "deck_acceleration" in wanted:
        try:
            a = chk.deck_acceleration_check(mini, q=q, n_boot=0)
            out["deck_acceleration"] = (float(a.attrs["value"]),
                                        f"x = {a.attrs['governing_point']:g} m, "
                                        + _acceleration_place(a.attrs))
        except chk.ResultsError:
            pass
    if "deck_displacement" in wanted:
        try:
            d = chk.max_deck_displacement(mini, q=q)
            x = d.attrs.get("governing_point", np.nan)
            out["deck_displacement"] = (float(d.attrs["value"]),
                                        "max over the output points"
                                        + (f", x = {float(x):g} m" if np.isfinite(x) else ""))
        except chk.ResultsError:
            pass
    if "wheel_unloading" in wanted:
        try:
            w = chk.wheel_unloading(mini, q=q, n_boot=0)
            if np.isfinite(float(w.attrs.get("value", np.nan))):
                out["wheel_unloading"] = (float(w.attrs["value"]),
                                          f"axle {w.attrs.get('governing_wheel', '–')}, "
                                          + w.attrs.get("zone", "every axle"))
        except chk.ResultsError:
            pass
    if le_check is not None and "bending_moment" in wanted:
        from vsi_numba.analysis.checks.load_effects import load_effect_checks

        try:
            c = load_effect_checks(mini, length=le_check.get("length"))
        except (chk.ResultsError, ValueError, KeyError):
            c = None
        if c is not None and not isinstance(c, str):
            v = c.verdict[c.verdict["effect"] == "moment"]
            if not v.empty:
                out["bending_moment"] = (float(v["ratio"].iloc[0]),
                                         f"x = {float(v['location'].iloc[0]):g} m")
    return out


def _grid_kmh(env: xr.Dataset, speed: float) -> float:
    """The grid's own km/h value of the grid speed ``speed`` (m/s)."""
    kmh = np.asarray(env["speed_kmh"].values, float)
    return float(kmh[int(np.argmin(abs(kmh - 3.6 * speed)))])


def off_grid_resonances(env: xr.Dataset, train: str) -> tuple[list[float], str]:
    """The resonance speeds f1 D / i (km/h, i in :data:`ORDERS`) of ``train`` inside
    the study's speed range and off its grid, and why none can be given ("" when they
    can: the list may then be empty)."""
    if "frequency" not in env:
        return [], "the file has no natural frequencies"
    f = np.asarray(env["frequency"].values, float).ravel()
    f = f[np.isfinite(f) & (f > 0)]
    if not f.size:
        return [], "the file has no natural frequency > 0"
    if "train_regular_length" not in env:
        return [], "the file has no regular length D of the trains"
    try:
        d = float(env["train_regular_length"].sel(train=train))
    except (KeyError, ValueError):
        return [], f"the file has no regular length D of train {train}"
    if not (np.isfinite(d) and d > 0):
        return [], (f"train {train} has no regular length D (its axles have no regular "
                    "spacing between 2 and 40 m), so its resonance speeds are not known")
    grid = np.sort(np.asarray(env["speed_kmh"].values, float))
    steps = np.diff(grid)
    # a speed within 5 % of the grid's spacing of a grid speed is on the grid (the
    # response there differs from the peak's by far less than the thresholds)
    tol = 0.05 * float(steps[steps > 0].min()) if (steps > 0).any() else 1e-3
    out = []
    for i in ORDERS:
        v = 3.6 * f[0] * d / i
        if grid[0] <= v <= grid[-1] and np.min(abs(grid - v)) > tol:
            out.append(float(v))
    return out, ""


def convergence_section(env: xr.Dataset, results: dict, runner: CaseRunner | None,
                        q: float = chk.DEFAULT_Q, le_checks=None,
                        not_made: list | None = None, length: float | None = None
                        ) -> Section:
    """The section "Convergence of the governing cases" (see the module notes).

    ``le_checks``: the load-effect checks of the summary (the bending-moment ratio),
    with the determinant length ``length`` they were made with;
    ``not_made``: a list the reasons of the checks not made are appended to (for the
    summary's list of checks not made)."""
    title = "Convergence of the governing cases"
    missing = not_made if not_made is not None else []

    def refused(why: str) -> Section:
        missing.append(f"convergence of the governing cases (time step, resonance speeds "
                       f"between the grid speeds): {why}")
        return Section(title, [f"Not checked: {md(why)}."])

    if runner is None:
        return refused("the report was written without re-runs")
    governing = governing_cases(results, le_checks)
    if not governing:
        return refused("no check has a governing case")
    try:
        _, _, settings, _ = runner.model()
    except _RERUN_ERRORS as exc:
        return refused(f"the governing cases cannot be re-run ({exc})")
    dt = float(settings.dt)
    le_args = ({"length": length} if le_checks is not None and not isinstance(le_checks, str)
               else None)
    # every re-run the section needs, the checks wanted of each, then one study-engine
    # call per train and time step (all its speeds at once)
    wanted: dict[tuple, set] = {}
    for name, (train, speed, _, _) in governing.items():
        kmh = _grid_kmh(env, speed)
        for key in ((train, kmh, dt), (train, kmh, dt / 2),
                    *((train, v, dt) for v in off_grid_resonances(env, train)[0])):
            names = wanted.setdefault((key[0], round(key[1], 6), key[2]), (key[1], set()))
            names[1].add(name)
    cache = _reruns(runner, wanted, q, le_args)

    def rerun(train, kmh, step):
        found = cache[(train, round(kmh, 6), step)]
        if isinstance(found, Exception):
            raise found
        return found

    rows, flagged, notes, unchecked = [], [], [], []
    for name, (train, speed, value, _) in governing.items():
        label, units = QUANTITIES[name]
        kmh = _grid_kmh(env, speed)
        try:
            qa, qb = rerun(train, kmh, dt), rerun(train, kmh, dt / 2)
        except _RERUN_ERRORS as exc:
            unchecked.append(f"{label}: not re-run ({exc}).")
            continue
        if name not in qa or name not in qb:
            unchecked.append(f"{label}: the re-run of {train} at {kmh:g} km/h gives no value "
                             "of it: not checked.")
            continue
        (a, where), (b, _) = qa[name], qb[name]
        if abs(a - value) > REPRODUCE_TOLERANCE * max(abs(value), 1e-300):
            notes.append(f"{label}: the re-run at dt = {dt:g} s gives {_fmt(a, units)}, the "
                         f"summary {_fmt(value, units)}: the re-run does not reproduce the "
                         "study (the file's configuration or its input files changed?); "
                         "its changes below are relative to the re-run.")
        change = (b - a) / abs(a) if np.isfinite(a) and a != 0 else np.nan
        flag = bool(np.isfinite(change) and abs(change) > DT_THRESHOLD)
        v_res, why = off_grid_resonances(env, train)
        res_parts = []
        if why:
            res_text = "not checked"
            line = f"resonance speeds of {train} between the grid speeds not checked: {why}."
            if line not in unchecked:
                unchecked.append(line)
        elif not v_res:
            res_text = "none off the grid"
        for v in v_res:
            try:
                qc = rerun(train, v, dt)
            except _RERUN_ERRORS as exc:
                res_parts.append(f"{v:.1f} km/h: not re-run")
                unchecked.append(f"{label}: the resonance speed {v:.1f} km/h of {train} was "
                                 f"not re-run ({exc}).")
                continue
            c = qc.get(name, (np.nan, ""))[0]
            rel = (c - value) / abs(value) if np.isfinite(c) and value != 0 else np.nan
            res_parts.append(f"{v:.1f} km/h: {_fmt(c, units)}"
                             + (f" ({100 * rel:+.1f} %)" if np.isfinite(rel) else ""))
            if not np.isfinite(c):
                unchecked.append(f"{label}: the re-run at the resonance speed {v:.1f} km/h "
                                 "gives no value of it.")
            elif rel > RESONANCE_THRESHOLD:
                flag = True
        if res_parts:
            res_text = "; ".join(res_parts)
        if flag:
            flagged.append(label)
        rows.append({"Quantity and place": f"{label}, {where}",
                     "Governing case": f"{train} at {kmh:g} km/h",
                     "Summary value": _fmt(value, units),
                     f"Re-run at dt = {dt:g} s": _fmt(a, units),
                     f"Re-run at dt/2 = {dt / 2:g} s": _fmt(b, units),
                     "Change": f"{100 * change:+.2f} %" if np.isfinite(change) else "–",
                     "At the resonance speeds off the grid": res_text,
                     "Result": Markdown("**FLAG**") if flag else
                     ("converged in dt; resonance not checked" if why else "converged")})
    blocks: list = [
        f"Each governing case of the summary re-run through the study engine from the "
        f"stored configuration (every realisation of the file; the summary's own check "
        f"applied to the re-run) at the study's time step and at half of it, and at the "
        f"governing train's resonance speeds f₁ D / i (i = {', '.join(map(str, ORDERS))}) "
        f"that lie inside the study's range and between its grid speeds. Flagged: a "
        f"change above {100 * DT_THRESHOLD:g} % with dt/2, or a value at a resonance speed "
        f"above the summary's by more than {100 * RESONANCE_THRESHOLD:g} %."]
    if rows:
        blocks.append(Table(pd.DataFrame(rows), "Convergence of the governing cases"))
    blocks += notes
    blocks += [f"**Not checked** — {md(u)}" for u in unchecked]
    others = _other_trains_off_grid(env, {g.train for g in governing.values()})
    if others:
        blocks.append(others)
    if flagged:
        blocks.append(f"**Flagged: {', '.join(flagged)}.** Refine the study (smaller "
                      "`solver.dt`, or `study.refine_resonance = true`) before relying on "
                      "these results.")
    if unchecked:
        missing.append("convergence of the governing cases: "
                       + " ".join(u.rstrip(".") + "." for u in unchecked))
    if not flagged and not unchecked and rows:
        blocks.append("Every governing result is converged within these thresholds.")
    elif not flagged and rows:
        blocks.append("The results re-run are converged within these thresholds; the "
                      "checks listed as not checked above were not made.")
    return Section(title, blocks)


def _reruns(runner: CaseRunner, wanted: dict, q: float, le_args) -> dict:
    """``wanted``: (train, km/h rounded, dt) -> (km/h, names of :data:`QUANTITIES`).
    Returns (train, km/h rounded, dt) -> the quantities of :func:`quantities` named, or
    the exception its re-run raised.  The speeds of a train at a time step are re-run in
    one study (:meth:`CaseRunner.study_speeds`)."""
    groups: dict[tuple, list] = {}
    for key in wanted:
        groups.setdefault((key[0], key[2]), []).append(key)
    out: dict = {}
    for (train, step), keys in groups.items():
        speeds = [wanted[k][0] for k in keys]
        try:
            runs = runner.study_speeds(train, speeds, dt=step)
        except _RERUN_ERRORS as exc:
            runs = [exc] * len(keys)
        for key, mini in zip(keys, runs, strict=True):
            if not isinstance(mini, Exception):
                try:
                    mini = quantities(mini, q, le_args, wanted[key][1])
                except _RERUN_ERRORS as exc:
                    mini = exc
            out[key] = mini
    return out


def _other_trains_off_grid(env: xr.Dataset, governing: set[str]) -> str:
    """A line naming the other trains' resonance speeds between the grid speeds, not
    re-run ("" when there are none)."""
    parts, unknown = [], []
    for t in [str(x) for x in env["train"].values]:
        if t in governing:
            continue
        v, why = off_grid_resonances(env, t)
        if why:
            unknown.append(t)
        elif v:
            parts.append(f"{t} ({', '.join(f'{x:.1f}' for x in v)} km/h)")
    out = []
    if parts:
        out.append("the resonance speeds of the other trains between the grid speeds were "
                   "not re-run: " + "; ".join(parts) + " (`study.refine_resonance = true` "
                   "puts them on the grid)")
    if unknown:
        out.append("the resonance speeds of " + ", ".join(unknown) + " are not known (no "
                   "regular length D)")
    return ("**Not checked** — " + "; ".join(out) + ".") if out else ""
