"""Convergence of the governing cases: each re-run at half the time step, and at the
exact resonance speed where it falls between two speeds of the grid.

A checked result is only as good as its time step and its speed grid.  For the governing
case of each check (deck acceleration, deck displacement, wheel unloading, bending moment)
the report re-runs the case from the file's stored configuration
(:class:`~vsi_numba.analysis.recompute.CaseRunner`) at the study's time step and at half
of it, and prints the change of the checked quantity; a change above
:data:`DT_THRESHOLD` is flagged.  Where the governing train's resonance speed
v_i = f1 D / i lies between the grid speeds next to the governing one (a grid samples
the speeds; the peak of a resonance may fall between two of them), the case is re-run
at that speed and a value above the grid's by more than :data:`RESONANCE_THRESHOLD` is
flagged.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.recompute import CaseRunner, RecomputeError
from vsi_numba.analysis.report.document import Markdown, Section, Table

#: Relative change of a governing result between dt and dt/2 above which it is flagged.
DT_THRESHOLD = 0.05

#: Relative excess of the value at an exact resonance speed over the grid's governing
#: value above which it is flagged.
RESONANCE_THRESHOLD = 0.05

#: What a re-run may raise (it is reported, the report goes on).
_RERUN_ERRORS = (RecomputeError, ValueError, ArithmeticError, MemoryError)

#: Resonance orders i of v_i = f1 D / i looked at.
ORDERS = (1, 2, 3, 4)

#: check name -> (label, units, quantity of a re-run).
QUANTITIES = {
    "deck_acceleration": ("Peak deck acceleration", "m s-2"),
    "deck_displacement": ("Max deck displacement", "m"),
    "wheel_unloading": ("Wheel unloading ΔQ/Q₀", "1"),
    "bending_moment": ("Max |bending moment|", "N m"),
}


def _nanmax(a) -> float:
    a = np.asarray(a, float)
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size else np.nan


def quantity(sim: xr.Dataset, name: str) -> float:
    """The checked quantity of one re-run (:func:`~vsi_numba.solver.simulate.simulate`
    output): the largest over the output points, wheels or the whole deck."""
    if name == "deck_acceleration":
        whole = (sim["max_deck_acceleration_whole_deck"].values
                 if "max_deck_acceleration_whole_deck" in sim else np.nan)
        return float(np.fmax(_nanmax(sim["max_deck_acceleration"].values), _nanmax(whole)))
    if name == "deck_displacement":
        return _nanmax(np.abs(sim["max_deck_displacement"].values))
    if name == "wheel_unloading":
        lo, hi = sim["min_contact_force"].values, sim["max_contact_force"].values
        dyn = ~np.isclose(lo, hi, rtol=1e-9, atol=0.0)  # not a prescribed force
        return _nanmax(np.asarray(sim["max_wheel_unloading"].values)[dyn])
    if name == "bending_moment":
        if "max_bending_moment" not in sim:
            return np.nan
        return float(np.fmax(_nanmax(np.abs(sim["max_bending_moment"].values)),
                             _nanmax(np.abs(sim["min_bending_moment"].values))))
    raise KeyError(name)


def _governing(results: dict, env: xr.Dataset) -> dict[str, tuple[str, float, int]]:
    """check -> (train, speed m/s, realisation) of its governing case."""
    out = {}
    for name in ("deck_acceleration", "deck_displacement", "wheel_unloading"):
        r = results.get(name)
        if r is None or isinstance(r, str):
            continue
        if name == "wheel_unloading" and not bool(np.asarray(r["applicable"]).any()):
            continue
        t = str(r.attrs.get("governing_train", "") or "")
        v = float(r.attrs.get("governing_speed", np.nan))
        if t and np.isfinite(v):
            out[name] = (t, v, int(r.attrs.get("governing_irregularity", -1)))
    if "max_bending_moment" in env:
        m = np.fmax(abs(env["max_bending_moment"]), abs(env["min_bending_moment"]))
        m = m.max([d for d in m.dims if d not in ("speed", "train", "irregularity")])
        if bool(np.isfinite(m).any()):
            i = np.unravel_index(int(np.nanargmax(m.values)), m.shape)
            sel = dict(zip(m.dims, i, strict=True))
            out["bending_moment"] = (str(env["train"].values[sel["train"]]),
                                     float(env["speed"].values[sel["speed"]]),
                                     int(env["irregularity"].values[sel.get("irregularity", 0)])
                                     if "irregularity" in env.dims else -1)
    return out


def _resonance_speed(env: xr.Dataset, train: str, speed: float) -> float | None:
    """The resonance speed f1 D / i of ``train`` strictly between the grid speeds next to
    ``speed`` (m/s), None when there is none or it is on the grid."""
    if "train_regular_length" not in env or "frequency" not in env:
        return None
    try:
        d = float(env["train_regular_length"].sel(train=train))
    except (KeyError, ValueError):
        return None
    f = np.asarray(env["frequency"].values, float).ravel()
    f = f[np.isfinite(f) & (f > 0)]
    if not (np.isfinite(d) and d > 0 and f.size):
        return None
    grid = np.sort(np.asarray(env["speed"].values, float))
    k = int(np.argmin(abs(grid - speed)))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    steps = np.diff(grid)
    # a speed within 5 % of the grid's spacing of a grid speed is on the grid (the
    # response there differs from the peak's by far less than the thresholds)
    tol = 0.05 * float(steps[steps > 0].min()) if (steps > 0).any() else 1e-3 / 3.6
    for i in ORDERS:
        v = f[0] * d / i
        if lo < v < hi and np.min(abs(grid - v)) > tol:
            return float(v)
    return None


def convergence_section(env: xr.Dataset, results: dict, runner: CaseRunner | None
                        ) -> Section:
    """The section "Convergence of the governing cases" (see the module notes)."""
    title = "Convergence of the governing cases"
    if runner is None:
        return Section(title, ["Not checked: the report was written without re-runs."])
    governing = _governing(results, env)
    if not governing:
        return Section(title, ["Not checked: no check has a governing case."])
    try:
        _, _, settings, _ = runner.model()
    except _RERUN_ERRORS as exc:
        return Section(title, [f"Not checked: the governing cases cannot be re-run ({exc})."])
    dt = float(settings.dt)
    cache: dict = {}

    def rerun(train, speed, irr, step):
        key = (train, round(speed, 9), irr, step)
        if key not in cache:
            cache[key] = runner.run(train, speed, irr, dt=step)
        return cache[key]

    rows, flagged, notes = [], [], []
    for name, (train, speed, irr) in governing.items():
        label, units = QUANTITIES[name]
        try:
            a = quantity(rerun(train, speed, irr, dt), name)
            b = quantity(rerun(train, speed, irr, dt / 2), name)
        except _RERUN_ERRORS as exc:
            notes.append(f"{label}: not re-run ({exc}).")
            continue
        change = (b - a) / abs(a) if np.isfinite(a) and a != 0 else np.nan
        flag = bool(np.isfinite(change) and abs(change) > DT_THRESHOLD)
        res_text, res_change = "–", np.nan
        v_res = _resonance_speed(env, train, speed)
        if v_res is not None:
            try:
                c = quantity(rerun(train, v_res, irr, dt), name)
                res_change = (c - a) / abs(a) if np.isfinite(a) and a != 0 else np.nan
                res_text = f"{v_res * 3.6:.1f} km/h: {c:.4g} ({100 * res_change:+.1f} %)"
                if np.isfinite(res_change) and res_change > RESONANCE_THRESHOLD:
                    flag = True
            except _RERUN_ERRORS as exc:
                res_text = f"{v_res * 3.6:.1f} km/h: not re-run ({exc})"
        if flag:
            flagged.append(label)
        unit = "" if units == "1" else f" {units}"
        rows.append({"Check": label, "Governing case": f"{train} at {speed * 3.6:g} km/h"
                     + (f", realisation {irr}" if irr != -1 else ""),
                     f"Value at dt = {dt:g} s": f"{a:.4g}{unit}",
                     f"Value at dt/2 = {dt / 2:g} s": f"{b:.4g}{unit}",
                     "Change": f"{100 * change:+.2f} %" if np.isfinite(change) else "–",
                     "Exact resonance speed": res_text,
                     "Result": Markdown("**FLAG**") if flag else "converged"})
    blocks: list = [
        f"Each governing case re-run from the stored configuration at the study's time step "
        f"and at half of it; where the governing train's resonance speed f₁ D / i "
        f"(i = {', '.join(map(str, ORDERS))}) lies between the grid speeds next to the "
        f"governing one, also at that speed. Flagged: a change above "
        f"{100 * DT_THRESHOLD:g} % with dt/2, or a value at the resonance speed above the "
        f"grid's by more than {100 * RESONANCE_THRESHOLD:g} %."]
    if rows:
        blocks.append(Table(pd.DataFrame(rows), "Convergence of the governing cases"))
    blocks += notes
    if flagged:
        blocks.append(f"**Flagged: {', '.join(flagged)}.** Refine the study (smaller "
                      "`solver.dt`, or `study.refine_resonance = true`) before relying on "
                      "these results.")
    else:
        blocks.append("Every governing result is converged within these thresholds.")
    return Section(title, blocks)
