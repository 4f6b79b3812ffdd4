"""The figures of the report: the envelopes of :mod:`vsi_numba.analysis.plots` and the time
histories of the governing cases (re-run when the file holds none,
:mod:`vsi_numba.analysis.recompute`)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from vsi_numba.analysis.dataset import (
    DETERMINISTIC,
    nanargmax_case,
)
from vsi_numba.analysis.governing import governing_case
from vsi_numba.analysis.recompute import CaseRunner, RecomputeError
from vsi_numba.analysis.report.document import Figure
from vsi_numba.analysis.report.safe import md
from vsi_numba.analysis.report.tables import wheel_unloading_by_zone
from vsi_numba.analysis.report.text import _fmt

# --------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------


def _irr_text(irr) -> str:
    return "deterministic track" if int(irr) == DETERMINISTIC else f"irregularity seed {irr}"


class _Histories:
    """Time histories of single cases: from the file when stored, else re-run.

    ``get`` returns ``(case, how)`` with ``case`` a Dataset on ``time`` (and ``point``,
    ``wheel``) and ``how`` = "stored" or "recomputed", or ``(None, reason)``.
    """

    def __init__(self, ds: xr.Dataset, runner: CaseRunner | None):
        self.ds = ds
        self.runner = runner
        self.runs: dict = {}

    def stored(self, train, speed, irr, name: str, **where) -> bool:
        ds = self.ds
        if "time" not in ds.dims or name not in ds:
            return False
        if "status" in ds and int(ds["status"].sel(train=train, speed=speed,
                                                   irregularity=irr)) != 0:
            return False  # a failed case: its outputs are not results
        return bool(ds[name].sel(train=train, speed=speed, irregularity=irr, **where)
                    .notnull().any())

    def all_stored(self, train, speed, irr, needs: dict) -> bool:
        """Every history of ``needs`` (name -> selection) is in the file for the case."""
        return all(self.stored(train, speed, irr, name, **where)
                   for name, where in needs.items())

    def get(self, train, speed, irr, needs: dict):
        if self.all_stored(train, speed, irr, needs):
            return self.ds.sel(train=train, speed=speed, irregularity=irr), "stored"
        if self.runner is None:
            return None, "re-running cases is switched off"
        key = _key(train, speed, irr)
        if key not in self.runs:
            self.runs[key] = _rerun(self.runner, *key)
        return self.runs[key]


def _key(train, speed, irr) -> tuple:
    """The key of a case among the re-runs: (train, speed m/s, realisation)."""
    return (str(train), float(speed), int(irr))


def _rerun(runner: CaseRunner, train: str, speed: float, irr: int) -> tuple:
    """(case, "recomputed") of a re-run with time histories, or (None, why not)."""
    try:
        return runner.run(train, speed, irr), "recomputed"
    except RecomputeError as exc:
        return None, str(exc)
    except Exception as exc:  # noqa: BLE001 - a figure must not stop the report
        first = str(exc).splitlines()[0] if str(exc) else ""
        return None, f"the re-run raised {type(exc).__name__}: {first}"


def rerun_cases(runner: CaseRunner, keys: list) -> dict:
    """The re-runs of the cases ``keys`` (:func:`history_reruns`): key -> (case, how) as
    the time-history figures take them."""
    return {key: _rerun(runner, *key) for key in keys}


def _recompute_note(case, ds, name, envelope, where: dict, train, speed, irr, units,
                    lowest=False) -> str:
    """Say that a case was re-run and compare its extreme with the stored envelope."""
    y = np.asarray(case[name].sel(**where).values, float)
    got = np.nanmin(y) if lowest else np.nanmax(np.abs(y))
    ref = float(ds[envelope].sel(train=train, speed=speed, irregularity=irr, **where))
    text = (" No history was stored for this case: it was re-run from the file's "
            f"configuration (config_json); re-run {'minimum' if lowest else 'peak'} "
            f"{_fmt(got, units)}, stored envelope {_fmt(ref, units)}")
    if np.isfinite(ref) and not np.isclose(got, ref, rtol=1e-6, atol=0.0):
        text += (" — **they differ: the model or the code changed since the study was run; "
                 "the figure may not show the stored case**")
    return text + "."


def _deck_request(ds, results, applicable):
    """((train, speed, realisation), histories needed, point, wheel) of the governing
    deck acceleration case, or None."""
    acc = results.get("deck_acceleration")
    gov = governing_case(acc)
    if gov is None:
        return None
    a = acc.attrs
    train, speed, irr = gov.train, gov.speed, gov.irregularity
    # histories are stored at the output points only: show the one with the largest peak
    point = a.get("governing_output_point", a["governing_point"])
    wheel = None
    if (applicable is not None and bool(applicable.sel(train=train))
            and "max_wheel_unloading" in ds):
        w = nanargmax_case(ds["max_wheel_unloading"].sel(train=train, speed=speed,
                                                         irregularity=irr))
        wheel = None if w is None else int(w["wheel"])
    needs = {"deck_acceleration": {"point": point}}
    if wheel is not None:
        needs["contact_force"] = {"wheel": wheel}
    return (train, speed, irr), needs, point, wheel


def _wheel_request(results):
    """((train, speed, realisation), histories needed, wheel) of the governing wheel
    unloading case, or None."""
    wu = results.get("wheel_unloading")
    gov = governing_case(wu)
    if gov is None:
        return None
    wheel = wu.attrs["governing_wheel"]
    if wheel < 0:
        return None
    return ((gov.train, gov.speed, gov.irregularity), {"contact_force": {"wheel": wheel}},
            wheel)


def _applicable(results):
    """The wheel unloading check's ``applicable`` (per train), or None."""
    wu = results.get("wheel_unloading")
    return None if wu is None or isinstance(wu, str) else wu["applicable"]


def history_reruns(histories: xr.Dataset, results: dict) -> list:
    """The cases the time-history figures re-run (their histories are not in the file),
    as keys of :func:`rerun_cases`, in the order the figures ask for them."""
    hist = _Histories(histories, None)
    keys = []
    for request in (_deck_request(histories, results, _applicable(results)),
                    _wheel_request(results)):
        if request is not None and not hist.all_stored(*request[0], request[1]):
            key = _key(*request[0])
            if key not in keys:
                keys.append(key)
    return keys


def _deck_history(ds, results, hist: _Histories, applicable):
    """(figure, caption) of the governing deck acceleration case, or (None, reason)."""
    from vsi_numba.analysis import plots  # matplotlib: imported when a figure is made

    request = _deck_request(ds, results, applicable)
    if request is None:
        return None, ""
    (train, speed, irr), needs, point, wheel = request
    a = results["deck_acceleration"].attrs
    case, how = hist.get(train, speed, irr, needs)
    note, fallback = "", case is None
    if case is None:
        reason = md(how)
        if "time" not in ds.dims or "deck_acceleration" not in ds:
            return None, (f"the file holds no time histories and the governing case could "
                          f"not be re-run ({reason})")
        stored = ds["deck_acceleration"].sel(train=train, point=point).notnull().any("time")
        if "status" in ds:
            stored = stored & (ds["status"].sel(train=train) == 0)
        peak = ds["max_deck_acceleration"].sel(train=train, point=point).where(stored)
        alt = nanargmax_case(peak)
        if alt is None:
            return None, (f"no history of train {md(train)} is stored and the governing case "
                          f"could not be re-run ({reason})")
        speed, irr = alt["speed"], alt["irregularity"]
        case = ds.sel(train=train, speed=speed, irregularity=irr)
        if wheel is not None and not hist.stored(train, speed, irr, "contact_force",
                                                 wheel=wheel):
            wheel = None
        note = (" No history was stored for the governing case and it could not be re-run "
                f"({reason}); shown: the stored case of the governing train with the "
                "largest peak.")
    elif how == "recomputed":
        note = _recompute_note(case, ds, "deck_acceleration", "max_deck_acceleration",
                               {"point": point}, train, speed, irr, "m s-2")
    kmh = float(ds["speed_kmh"].sel(speed=speed))
    q0 = (float(ds["static_wheel_load"].sel(train=train, wheel=wheel))
          if wheel is not None and "static_wheel_load" in ds else None)
    fig = plots.plot_case_history(case, plots.case_title(train, kmh, irr, point),
                                  point=point, wheel=wheel, limit=a["limit"], q0=q0)
    role = "governing train" if fallback else "governing case"
    caption = (f"Time histories of {md(train)} at {kmh:.0f} km/h ({_irr_text(irr)}), "
               f"the {role} of the deck acceleration check, at x = {point:g} m"
               + (f", contact force of axle {wheel} (largest unloading)" if wheel is not None
                  else "") + "." + note)
    return fig, caption


def _wheel_history(ds, results, hist: _Histories):
    """(figure, caption) of the governing wheel unloading case, or (None, reason)."""
    from vsi_numba.analysis import plots  # matplotlib: imported when a figure is made

    request = _wheel_request(results)
    if request is None:
        return None, ""
    (train, speed, irr), needs, wheel = request
    case, how = hist.get(train, speed, irr, needs)
    kmh = float(ds["speed_kmh"].sel(speed=speed))
    if case is None:
        return None, (f"the governing case of the wheel unloading check ({md(train)}, "
                      f"{kmh:.0f} km/h) has no stored history and could not be re-run "
                      f"({md(how)})")
    sel = {"train": train, "speed": speed, "irregularity": irr, "wheel": wheel}
    pos = (float(ds["position_of_min_contact_force"].sel(sel))
           if "position_of_min_contact_force" in ds else np.nan)
    q0 = (float(ds["static_wheel_load"].sel(train=train, wheel=wheel))
          if "static_wheel_load" in ds else None)
    length = float(ds.attrs["bridge_length"]) if "bridge_length" in ds.attrs else None
    dq = float(ds["max_wheel_unloading"].sel(sel))
    fig = plots.plot_case_history(
        case, plots.case_title(train, kmh, irr) + f", axle {wheel}", wheel=wheel,
        q0=q0,
        min_position=pos if np.isfinite(pos) else None, bridge_length=length,
        speed=float(speed))
    caption = (f"Contact force of axle {wheel} of {md(train)} at {kmh:.0f} km/h "
               f"({_irr_text(irr)}), the governing case of the wheel unloading check "
               f"(ΔQ/Q₀ = {dq:.3f} in this realisation)")
    if np.isfinite(pos):
        caption += (f"; ★ minimum contact force, with the axle at x = {pos:.2f} m along the "
                    "track (position_of_min_contact_force"
                    + (f"; the deck spans 0–{length:g} m, shaded while the axle is on it"
                       if length is not None else "") + ")")
    caption += "."
    if how == "recomputed":
        caption += _recompute_note(case, ds, "contact_force", "min_contact_force",
                                   {"wheel": wheel}, train, speed, irr, "N", lowest=True)
    return fig, caption


def envelope_figures(ds: xr.Dataset, results: dict) -> list[Figure]:
    """The figures of the envelopes against speed as report blocks (``ds``: the
    envelopes, :func:`vsi_numba.analysis.dataset.envelopes`)."""
    from vsi_numba.analysis import plots  # matplotlib: imported when the figures are made

    made = []

    def put(fig, name, caption):
        made.append(Figure(fig, name, caption))

    acc = results.get("deck_acceleration")
    if not isinstance(acc, str):
        put(plots.plot_deck_acceleration(ds, acc), "deck_acceleration.png",
            "Peak vertical deck acceleration (max over the deck points) against speed, "
            "with the EN 1990 A2.4.4.2.1 limit; ▼ resonance speeds f₁D/i; shaded: 95 % "
            "bootstrap interval of the characteristic value where there are realisations.")
    dyn = results.get("dynamic_amplification")
    if not isinstance(dyn, str):
        put(plots.plot_dynamic_amplification(ds, dyn), "dynamic_amplification.png",
            "Dynamic increment φ'dyn of the deck maximum displacement against speed; "
            "dotted: φ''/2 (EN 1991-2 Annex C).")
    wu = results.get("wheel_unloading")
    if not isinstance(wu, str) and "note" not in wu.attrs:
        skipped = wu.attrs.get("not_applicable_trains", "")
        put(plots.plot_wheel_unloading(ds, wu, wheel_unloading_by_zone(ds)),
            "wheel_unloading.png",
            "Minimum wheel–rail contact force and wheel unloading ΔQ/Q₀ (max over axles) "
            f"against speed, with the {wu.attrs['limit']:g} limit ({md(wu.attrs['clause'])}); "
            "thin dash-dot / "
            "dotted: ΔQ/Q₀ of the axles whose minimum contact force lay on the deck / on the "
            "approach or exit track (largest over realisations)"
            + (f"; not drawn: {skipped} (prescribed moving forces, not applicable)"
               if skipped else "") + ".")
    cf = results.get("comfort")
    if not isinstance(cf, str) and bool(cf["value"].notnull().any()):
        put(plots.plot_comfort(ds, cf), "comfort.png",
            "Vertical car-body acceleration (max over vehicles) against speed with the "
            f"levels of comfort of the code profile ({md(cf.attrs['clause'])}).")
    return made


def history_figures(results: dict, runner: CaseRunner | None, histories: xr.Dataset,
                    runs: dict | None = None) -> tuple[list[Figure], list[str]]:
    """The time-history figures of the governing cases and notes on those not drawn
    (``histories``: the whole prepared file, read lazily: each figure reads one case;
    ``runs``: re-runs made already, :func:`rerun_cases` of :func:`history_reruns`)."""
    made, notes = [], []
    hist = _Histories(histories, runner)
    hist.runs.update(runs or {})
    applicable = _applicable(results)
    for name, make in (("time_history.png", lambda: _deck_history(histories, results, hist,
                                                                  applicable)),
                       ("wheel_unloading_history.png", lambda: _wheel_history(
                           histories, results, hist))):
        fig, caption = make()
        if fig is not None:
            made.append(Figure(fig, name, caption))
        elif caption:
            notes.append(f"- Not drawn: {caption}.")
    return made, notes
