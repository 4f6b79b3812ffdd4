"""``[fatigue]``: the fatigue check of steel details and of headed stud shear connectors
under the dynamic stress histories (:mod:`vsi_numba.model.fatigue`, :mod:`vsi_numba.study.fatigue`).

```toml
[fatigue]
design_life_years = 100
mix = "standard"                  # optional: an EN 1991-2 Annex D mix [R] (standard,
                                  # heavy, light) at each train type's speed of Table D.1

[[fatigue.sections]]
x = 10.0                          # m from the left end of the deck
section_modulus = 0.045           # m^3: stress per unit bending moment = 1 / this
detail_category = 71              # MPa, EN 1993-1-9 detail category Delta sigma_C
gamma_Ff = 1.0                    # optional (code profile fatigue_gamma_Ff)
gamma_Mf = 1.35                   # optional (code profile fatigue_gamma_Mf)
name = "bottom flange, midspan"   # optional

[[fatigue.studs]]                 # optional: headed stud shear connectors
x = 1.0                           # m from the left end of the deck (the shear there)
diameter = 0.022                  # m, shank diameter d
per_row = 4                       # studs per row n
row_spacing = 0.15                # m, spacing s of the rows
first_moment = 0.06               # m^3, S of the slab about the composite neutral axis
second_moment = 0.12              # m^4, I of the composite section (tau = V S s / (I n A))
gamma_Ff = 1.0                    # optional (code profile fatigue_gamma_Ff)
gamma_Mf = 1.0                    # optional (code profile fatigue_stud_gamma_Mf)
name = "studs near the bearing"   # optional

[[fatigue.traffic]]               # the operator's trains (added to the mix)
train = "ICE3"                    # a library train, AnnexD-1 .. AnnexD-12, or an axle-load
                                  # CSV file (position m, load kN; relative to the config)
speed_kmh = 250.0
per_day = 20
model = "moving_force"            # optional: moving_force (default) | interaction
```

Everything about the section lives here; :mod:`vsi_numba.config.core` calls
:func:`_fatigue_section` and stores what it returns.
"""

from __future__ import annotations

from vsi_numba.config._check import _BAD, _MISSING, _ok
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import expected_of, keys_of

#: Detail categories of EN 1993-1-9 Tables 8.1-8.10 [R] (MPa).
DETAIL_CATEGORIES = (36, 40, 45, 50, 56, 63, 71, 80, 90, 100, 112, 125, 140, 160)
#: Keys of ``[fatigue]``, ``[[fatigue.sections]]``, ``[[fatigue.traffic]]``, as declared
#: (:class:`~vsi_numba.config.schema.models.Fatigue` and its tables).
KEYS = keys_of(_m.Fatigue)
SECTION_KEYS = keys_of(_m.FatigueSection)
STUD_KEYS = keys_of(_m.FatigueStud)
TRAFFIC_KEYS = keys_of(_m.FatigueTraffic)
MODELS = _m.FATIGUE_MODELS
#: The scalar keys of ``[[fatigue.sections]]`` (read by their declaration).
_SECTION_NUMBERS = ("x", "section_modulus", "detail_category", "gamma_Ff", "gamma_Mf")
#: The scalar keys of ``[[fatigue.studs]]``.
_STUD_NUMBERS = ("x", "diameter", "per_row", "row_spacing", "first_moment",
                 "second_moment", "gamma_Ff", "gamma_Mf")


def _fatigue_section(chk, f, profile, bridge=_BAD, study_axes=(), base=None
                     ) -> dict | None:
    """The resolved ``[fatigue]`` of a validated one (:class:`~.schema.models.Fatigue`),
    every default filled (None without it), and the checks that are not rules of the
    model: the traffic is given without a mix, the trains exist (library, Annex D, an
    axle-load file) with the model asked, the positions are on the deck, and the deck
    gives the bending moments (and shear forces for studs).

    ``bridge`` (the validated ``[bridge]``) bounds the sections' x.  With ``study.vary``
    the fatigue runs follow the variants (each variant's own bridge); ``[fatigue]``
    itself is not a section ``study.vary`` may vary, so it is the same in every variant.
    """
    if f is None or f is _BAD:
        return f
    life = float(f.design_life_years)
    out = {"design_life_years": life}
    if f.mix is not None:
        out["mix"] = f.mix
    out["sections"] = _sections(chk, f.sections, profile, bridge)
    out["traffic"] = _traffic(chk, f.traffic, f.mix is not None, base)
    if f.studs is not None:
        out["studs"] = _studs(chk, f.studs, profile, bridge)
    static = getattr(getattr(bridge, "model", None), "static", None) if _ok(bridge) else None
    if _ok(bridge) and bridge.kind != "rigid" and (static is None
                                                   or "moment" not in static.effects):
        chk.error("fatigue", "{...}", "a deck that gives bending moments (a beam deck, or "
                  "matrices with rotation DOFs); this bridge.kind = "
                  f"'{bridge.kind}' gives none")
        return _BAD
    if _ok(bridge) and out.get("studs") and bridge.kind != "rigid" and (
            static is None or "shear" not in static.effects):
        chk.error("fatigue.studs", "[...]", "a deck that gives shear forces (a beam deck, "
                  f"or matrices with rotation DOFs); this bridge.kind = '{bridge.kind}' "
                  "gives none")
        return _BAD
    if _ok(bridge) and bridge.kind == "rigid":
        chk.error("fatigue", "{...}", "a deck with bending moments (bridge.kind "
                  "simply_supported, continuous or a model with load effects), not a "
                  "rigid track")
        return _BAD
    if life < 10 or life > 200:
        chk.warn(f"fatigue.design_life_years = {life:g}: looks implausible for a railway "
                 "bridge (EN 1993-2 designs for 100 years)", kind="plausibility",
                 keys=["fatigue.design_life_years"])
    if not _ok(*out.values()):
        return _BAD
    return out


def _on_deck(chk, p: str, x: float, bridge) -> bool:
    if _ok(bridge) and x > bridge.length + 1e-9:
        chk.error(f"{p}.x", x, f"a position on the deck, 0 to {bridge.length:g} m")
        return False
    return True


def _sections(chk, sections, profile, bridge):
    out = []
    for i, s in enumerate(sections):
        p = f"fatigue.sections[{i}]"
        r = {k: getattr(s, k) for k in _SECTION_NUMBERS}
        for g in ("gamma_Ff", "gamma_Mf"):  # their defaults are the code profile's
            if r[g] is None:
                r[g] = profile[f"fatigue_{g}"]
        r = {k: float(v) for k, v in r.items()}
        if s.name is not None:
            r["name"] = s.name
        if not _on_deck(chk, p, r["x"], bridge):
            out.append(_BAD)
            continue
        if int(r["detail_category"]) != r["detail_category"] or \
                int(r["detail_category"]) not in DETAIL_CATEGORIES:
            chk.warn(f"{p}.detail_category = {r['detail_category']:g} MPa is not a detail "
                     "category of EN 1993-1-9 (" + ", ".join(map(str, DETAIL_CATEGORIES))
                     + "): used as given", kind="plausibility", keys=[f"{p}.detail_category"])
        out.append(r)
    return _BAD if any(o is _BAD for o in out) else out


def _studs(chk, studs, profile, bridge):
    out = []
    for i, s in enumerate(studs):
        p = f"fatigue.studs[{i}]"
        r = {k: getattr(s, k) for k in _STUD_NUMBERS}
        if r["gamma_Ff"] is None:  # the defaults are the code profile's
            r["gamma_Ff"] = profile["fatigue_gamma_Ff"]
        if r["gamma_Mf"] is None:
            r["gamma_Mf"] = profile["fatigue_stud_gamma_Mf"]
        # numbers as floats, the count as an int (the stored configuration reloads)
        r = {k: (int(v) if k == "per_row" else float(v)) for k, v in r.items()}
        if s.name is not None:
            r["name"] = s.name
        if not _on_deck(chk, p, r["x"], bridge):
            out.append(_BAD)
            continue
        out.append(r)
    return _BAD if any(o is _BAD for o in out) else out


def _traffic(chk, traffic, has_mix: bool, base=None):
    path = "fatigue.traffic"
    if traffic is None:
        if has_mix:
            return []
        return chk.error(path, _MISSING, expected_of(_m.Fatigue, "traffic"))
    if not traffic and not has_mix:
        return chk.error(path, traffic, "a list of tables [[fatigue.traffic]] with train, "
                                        "speed_kmh and per_day")
    from vsi_numba.model.library import UnknownTrainError, annex_d, get_train

    out = []
    for i, t in enumerate(traffic):
        p = f"{path}[{i}]"
        name, model = t.train, t.model
        r = {"speed_kmh": float(t.speed_kmh), "per_day": float(t.per_day)}
        if name.strip().lower().endswith(".csv"):  # the operator's axle-load list
            from pathlib import Path

            import numpy as np

            from vsi_numba.config.limits import MIN_RAILWAY_AXLE_LOAD
            from vsi_numba.model.library.extra import AxleFileError, axle_list_train

            csv = (Path(base or ".") / name.strip()).expanduser()
            try:
                axles = axle_list_train(csv)
            except AxleFileError as exc:
                chk.error(f"{p}.train", name, f"a readable axle-load CSV file ({exc})")
                out.append(_BAD)
                continue
            loads = np.concatenate([np.asarray(v.loads, float) for v in axles.vehicles])
            if loads.size and float(np.mean(loads)) < MIN_RAILWAY_AXLE_LOAD:
                t = float(np.mean(loads)) / 1e3
                chk.implausible.append(
                    f"{p}.train = {name!r}: the mean axle load of the file is {t:.4g} kN (a "
                    f"{float(np.sum(loads)) / 1e3:.4g} kN train); looks like tonnes ({t:.4g} "
                    f"t = {t * 9.81:.4g} kN per axle): the load column is in kN (expected "
                    "50-250 kN per axle)")
            if model == "interaction":
                chk.error(f"{p}.model", model, "'moving_force' for an axle-load list")
                out.append(_BAD)
                continue
        elif annex_d.type_of(name) is not None:
            if model == "interaction":
                chk.error(f"{p}.model", model, "'moving_force' for an Annex D train (its "
                          "types are axle loads, without vehicle dynamics)")
                out.append(_BAD)
                continue
            name = f"{annex_d.PREFIX}{annex_d.type_of(name)}"
        else:
            try:
                name = get_train(name, model).name
            except UnknownTrainError as exc:
                chk.error(f"{p}.train", name, f"a train of the library or AnnexD-1 .. "
                          f"AnnexD-12 ({' '.join(str(exc).split())[:160]})")
                out.append(_BAD)
                continue
            except ValueError as exc:
                chk.error(f"{p}.model", model, f"a model the train has ({exc})")
                out.append(_BAD)
                continue
        out.append({"train": name, "speed_kmh": r["speed_kmh"], "per_day": r["per_day"],
                    "model": model})
    return _BAD if any(o is _BAD for o in out) else out


def fatigue_train(row: dict, base_dir):
    """The train of one row of the fatigue traffic (:func:`traffic_of`): an axle-load
    CSV (relative to ``base_dir``), an Annex D type or a library train."""
    from pathlib import Path

    from vsi_numba.model.library import annex_d, get_train
    from vsi_numba.model.library.extra import axle_list_train

    name = row["train"].strip()
    if name.lower().endswith(".csv"):
        return axle_list_train(Path(base_dir or ".") / name, name=name)
    if annex_d.type_of(name) is not None:
        return annex_d.annex_d_train(name)
    return get_train(name, row["model"])


def fatigue_budget(chk, section: dict, bridge, solver: dict, profile, base_dir,
                   refuse) -> None:
    """The fatigue runs against the run budget, before anything runs: each train of the
    traffic runs once at its speed, over the approach, the deck and its own length, then
    until the free vibration has decayed to ``fatigue_free_vibration_decay`` (at most
    :data:`~vsi_numba.config.limits.MAX_FATIGUE_FREE_VIBRATION`), keeping its modal and
    moment histories: its time steps against
    :data:`~vsi_numba.config.limits.MAX_STEPS` (``solver.allow_large_problem``) and
    :data:`~vsi_numba.config.limits.HARD_MAX_STEPS`, its histories against
    :data:`~vsi_numba.config.limits.MAX_HISTORY_BYTES`.  The free vibration is taken
    without the additional damping of moving-force runs (the longer one)."""
    from vsi_numba.config.limits import (
        HARD_MAX_STEPS,
        MAX_FATIGUE_FREE_VIBRATION,
        MAX_HISTORY_BYTES,
        MAX_STEPS,
    )
    from vsi_numba.config.physics import train_extent
    from vsi_numba.model import fatigue as fat

    model = bridge.model
    if not model.n_modes:
        return
    free = min(fat.decay_time(model.omega, model.damping,
                              profile["fatigue_free_vibration_decay"]),
               MAX_FATIGUE_FREE_VIBRATION)
    dt = solver["dt"]
    n_sec = len(section["sections"]) + len(section.get("studs") or ())
    n_mix = len(traffic_of({"mix": section["mix"]})) if section.get("mix") else 0
    for i, row in enumerate(traffic_of(section)):
        try:
            train = fatigue_train(row, base_dir)
        except (ValueError, OSError):
            continue  # reported by the section reader
        v = row["speed_kmh"] / 3.6
        steps = ((solver["approach"] + float(bridge.length) + train_extent(train)) / v
                 + free) / dt
        key = (f"fatigue.mix = '{section['mix']}'" if i < n_mix
               else f"fatigue.traffic[{i - n_mix}]")
        where = f"{key}: the fatigue run of {row['train']} at {row['speed_kmh']:g} km/h"
        keys = ("check its speed_kmh, solver.dt, solver.approach and the free vibration "
                f"({free:.3g} s: code profile fatigue_free_vibration_decay)")
        if not steps <= HARD_MAX_STEPS:
            chk.errors.append(f"{where} needs {steps:.3g} time steps, more than the hard "
                              f"budget of {HARD_MAX_STEPS:.3g} that no machine runs "
                              "(solver.allow_large_problem does not lift it); " + keys)
            continue
        if steps > MAX_STEPS:
            refuse(chk, solver, "allow_large_problem",
                   f"{where} needs {steps:.3g} time steps, more than the budget of "
                   f"{MAX_STEPS:.3g}; {keys}")
            continue
        n_w = int(train.n_wheels + train.n_loads)
        nbytes = steps * 8.0 * (2 * model.n_modes + 2 * n_w + len(train.vehicles) + n_sec)
        if nbytes > MAX_HISTORY_BYTES:
            refuse(chk, solver, "allow_large_problem",
                   f"{where} keeps about {nbytes / 2**30:.3g} GiB of time histories "
                   f"({steps:.3g} steps), more than the budget of "
                   f"{MAX_HISTORY_BYTES / 2**30:g} GiB; {keys}")


def traffic_of(section: dict) -> list[dict]:
    """The traffic of a resolved ``[fatigue]``: the Annex D mix (if any) then the
    listed trains, each {train, speed_kmh, per_day, model}."""
    from vsi_numba.model.library import annex_d

    rows = []
    if section.get("mix"):
        rows += [{"train": n, "speed_kmh": v, "per_day": k, "model": "moving_force"}
                 for n, v, k in annex_d.mix(section["mix"])]
    return rows + [dict(t) for t in section.get("traffic", [])]


def describe(section: dict) -> str:
    """One line for ``vsi check``: sections and traffic."""
    t = traffic_of(section)
    studs = len(section.get("studs") or ())
    return (f"fatigue: {len(section['sections'])} section(s)"
            + (f", {studs} stud layout(s)" if studs else "")
            + f", {len(t)} train(s) in the "
            f"traffic ({sum(r['per_day'] for r in t):g} per day), design life "
            f"{section['design_life_years']:g} years" + (
                f", EN 1991-2 Annex D {section['mix']} mix" if section.get("mix") else ""))


__all__ = ["DETAIL_CATEGORIES", "describe", "traffic_of"]
