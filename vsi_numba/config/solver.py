"""``[solver]``, ``[contact]`` and ``[track]``: the settings of the time integration, the
wheel-rail contact, the rail on its foundation and the distribution of moving forces by
the track.

The admissible values of the solver keys are those of
:class:`vsi_numba.solver.settings.SolverSettings` (its ``BOUNDS`` and defaults), which the
validated section becomes (:meth:`vsi_numba.config.Config.solver_settings`).
"""

from __future__ import annotations

from vsi_numba.config._check import _BAD, _MISSING, _ok, _Sentinel
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import keys_of
from vsi_numba.solver.settings import CONTACT_MODELS as _SOLVER_CONTACT_MODELS
from vsi_numba.solver.settings import HHT_ALPHA_MIN

CONTACT_MODELS = tuple(_SOLVER_CONTACT_MODELS)
TRACK_MODELS = ("elastic", "rigid")

#: Keys that accept a result the checks below refuse (never listed in hints).
SOLVER_OVERRIDES = {
    "allow_coarse_dt": "fewer than 4 time steps per period of a retained frequency",
    "allow_large_problem": "runs or profiles beyond the memory/time budget",
    "allow_implausible": "implausible physical input (deflection, penetration, profile "
                         "amplitude, vehicle stiffness)",
}


#: The numeric keys of ``[solver]``, as declared (:class:`~.schema.models.Solver`: the
#: bounds of :data:`~vsi_numba.solver.settings.BOUNDS`, the defaults of
#: :class:`~vsi_numba.solver.settings.SolverSettings`).
_SOLVER_FIELDS = [k for k in _m.Solver.model_fields if k not in SOLVER_OVERRIDES]
#: contact.hertz_coefficient: > 0 (SolverSettings), and < 1 (a G of 1 m N^-2/3 is a typo)
_HERTZ_MAX = _m.HERTZ_MAX


def _solver_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        d = {}
    if chk.table(d, "solver", keys_of(_m.Solver) - set(SOLVER_OVERRIDES),
                 what=" [solver] (dt, hht_alpha, ...)", hidden=SOLVER_OVERRIDES) is _BAD:
        return _BAD
    vals = chk.fields(d, "solver", _m.Solver, _SOLVER_FIELDS)
    vals.update(chk.fields(d, "solver", _m.Solver, [k for k in SOLVER_OVERRIDES if k in d]))
    if not _ok(*vals.values()):
        return _BAD
    vals["hht_alpha"] = max(vals["hht_alpha"], HHT_ALPHA_MIN)
    return vals


def _contact_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        return {"model": "rigid"}
    if chk.table(d, "contact", keys_of(_m.Contact),
                 what=" [contact] with model = 'rigid'") is _BAD:
        return _BAD
    model = chk.fields(d, "contact", _m.Contact, ["model"])["model"]
    if model == "rigid":
        if "hertz_coefficient" in d:
            chk.warn("contact.hertz_coefficient is ignored: not used by contact.model = 'rigid'")
        return {"model": "rigid"}
    g = chk.fields(d, "contact", _m.Contact, ["hertz_coefficient"],
                   required={"hertz_coefficient": model is not _BAD})["hertz_coefficient"]
    if not _ok(model, g):
        return _BAD
    return {"model": model, "hertz_coefficient": g}


def _rail_track_section(chk, d, fe_layer: bool) -> dict | _Sentinel:
    """[track]: the rail on an elastic foundation (default) or the rigid idealisation."""
    if fe_layer:
        if d is not _MISSING:
            chk.error("track", d, "no [track] with [bridge.track]: the FE track layer of the "
                      "deck is the track")
            return _BAD
        return {"model": "bridge_layer"}
    if d is _MISSING:
        d = {}
    keys = ("foundation_stiffness", "rail_EI", "foundation_damping", "rail_mass")
    if chk.table(d, "track", keys_of(_m.Track),
                 what=" [track] of track values") is _BAD:
        return _BAD
    model = chk.fields(d, "track", _m.Track, ["model"])["model"]
    dist = _load_distribution(chk, d, model)
    if model == "rigid":
        for key in keys:
            if key in d:
                chk.warn(f"track.{key} is ignored: not used by track.model = 'rigid'")
        return _BAD if dist is _BAD else {"model": "rigid", **dist}
    k, ei, c, mr = chk.fields(d, "track", _m.Track, keys).values()
    if not _ok(model, k, ei, c, mr, dist):
        return _BAD
    return {"model": "elastic", "foundation_stiffness": float(k), "rail_EI": float(ei),
            "foundation_damping": float(c), "rail_mass": float(mr), **dist}


#: The keys of the distribution of moving forces (:mod:`vsi_numba.model.distribution`)
#: and the kinds that use each length.
_DISTRIBUTION_KEYS = ("load_distribution", "sleeper_spacing", "sleeper_width",
                      "ballast_depth")
_USED_BY = {"sleeper_spacing": ("rail", "rail_ballast", "elastic_track"),
            "sleeper_width": ("rail_ballast",), "ballast_depth": ("rail_ballast",)}
#: Plausible ranges (m): outside them a warning says what the value looks like.
_PLAUSIBLE = {"sleeper_spacing": (0.45, 0.8, "sleepers are 0.55-0.75 m apart"),
              "sleeper_width": (0.15, 0.45, "a sleeper is 0.2-0.35 m wide at its base"),
              "ballast_depth": (0.15, 1.0, "ballast under the sleepers is 0.25-0.6 m deep")}


def _load_distribution(chk, d, model) -> dict | _Sentinel:
    """track.load_distribution and its lengths: the resolved keys (none for 'none', so
    a configuration without the key keeps its stored form and hash)."""
    kind = chk.fields(d, "track", _m.Track, ["load_distribution"])["load_distribution"]
    if kind is _BAD:
        return _BAD
    if kind == "elastic_track" and model == "rigid":
        return chk.error("track.load_distribution", kind, "'none', 'rail' or "
                         "'rail_ballast' with track.model = 'rigid' ('elastic_track' "
                         "spreads the forces by the rail on the elastic foundation)")
    out = {"load_distribution": kind} if kind != "none" else {}
    bad = False
    for key in _USED_BY:
        if kind not in _USED_BY[key]:
            if key in d:
                chk.warn(f"track.{key} is ignored: not used by track.load_distribution = "
                         f"'{kind}' (used by {' and '.join(_USED_BY[key])})")
            continue
        v = chk.fields(d, "track", _m.Track, [key])[key]
        if v is _BAD:
            bad = True
            continue
        lo, hi, usual = _PLAUSIBLE[key]
        if not lo <= v <= hi:
            chk.warn(f"track.{key} = {v:g} m looks implausible: {usual} (units: m)",
                     kind="plausibility", keys=[f"track.{key}"])
        out[key] = float(v)
    return _BAD if bad else out
