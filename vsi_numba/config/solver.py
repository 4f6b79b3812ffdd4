"""``[solver]``, ``[contact]`` and ``[track]``: the settings of the time integration, the
wheel-rail contact, the rail on its foundation and the distribution of moving forces by
the track.

The admissible values of the solver keys are those of
:class:`vsi_numba.solver.settings.SolverSettings` (its ``BOUNDS`` and defaults), which the
validated section becomes (:meth:`vsi_numba.config.Config.solver_settings`).
"""

from __future__ import annotations

from dataclasses import asdict

from vsi_numba.config._check import _BAD, _MISSING, _Num, _ok, _Sentinel
from vsi_numba.model import distribution as _dist
from vsi_numba.model import track as _track
from vsi_numba.solver.settings import BOUNDS, HHT_ALPHA_MIN, SolverSettings
from vsi_numba.solver.settings import CONTACT_MODELS as _SOLVER_CONTACT_MODELS

CONTACT_MODELS = tuple(_SOLVER_CONTACT_MODELS)
TRACK_MODELS = ("elastic", "rigid")

#: Keys that accept a result the checks below refuse (never listed in hints).
SOLVER_OVERRIDES = {
    "allow_coarse_dt": "fewer than 4 time steps per period of a retained frequency",
    "allow_large_problem": "runs or profiles beyond the memory/time budget",
    "allow_implausible": "implausible physical input (deflection, penetration, profile "
                         "amplitude, vehicle stiffness)",
}


def _setting(key: str, expected: str, **kw) -> _Num:
    """The spec of a ``[solver]`` key: the bounds of :data:`BOUNDS`, the default of
    :class:`SolverSettings`."""
    return _Num(expected, **asdict(BOUNDS[key]), **kw)


_SOLVER_FIELDS = {
    "dt": _setting("dt", "a time step > 0 s", default=SolverSettings.dt),
    "hht_alpha": _setting("hht_alpha", "-1/3 <= hht_alpha <= 0",
                          default=SolverSettings.hht_alpha),
    "approach": _setting("approach", "a length of approach track >= 0 m",
                         default=SolverSettings.approach),
    "free_vibration": _setting("free_vibration", "a duration >= 0 s",
                               default=SolverSettings.free_vibration),
    "max_iterations": _setting("max_iterations", "an integer 1 <= max_iterations <= 10000",
                               integer=True, default=SolverSettings.max_iterations),
    "max_subdivisions": _setting("max_subdivisions", "an integer 0 <= max_subdivisions <= 30",
                                 integer=True, default=SolverSettings.max_subdivisions),
    "acceleration_cutoff": _setting("acceleration_cutoff", "a frequency > 0 Hz",
                                    default=SolverSettings.acceleration_cutoff),
}
#: contact.hertz_coefficient: > 0 (SolverSettings), and < 1 (a G of 1 m N^-2/3 is a typo)
_HERTZ_MAX = 1.0


def _solver_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        d = {}
    if chk.table(d, "solver", set(_SOLVER_FIELDS), what=" [solver] (dt, hht_alpha, ...)",
                 hidden=SOLVER_OVERRIDES) is _BAD:
        return _BAD
    vals = chk.numbers(d, "solver", _SOLVER_FIELDS)
    for key in SOLVER_OVERRIDES:
        if key in d:
            vals[key] = chk.boolean(d, "solver", key, False)
    if not _ok(*vals.values()):
        return _BAD
    vals["hht_alpha"] = max(vals["hht_alpha"], HHT_ALPHA_MIN)
    return vals


def _contact_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        return {"model": "rigid"}
    if chk.table(d, "contact", {"model", "hertz_coefficient"},
                 what=" [contact] with model = 'rigid'") is _BAD:
        return _BAD
    model = chk.choice(d, "contact", "model", CONTACT_MODELS, default="rigid")
    spec = _Num("a Hertz constant G > 0 m N^-2/3 (about 4e-8 for a wheel on a rail)",
                gt=BOUNDS["hertz_coefficient"].gt, lt=_HERTZ_MAX,
                default=_MISSING if model not in ("rigid", _BAD) else None)
    if model == "rigid":
        if "hertz_coefficient" in d:
            chk.warn("contact.hertz_coefficient is ignored: not used by contact.model = 'rigid'")
        return {"model": "rigid"}
    g = chk.get_number(d, "contact", "hertz_coefficient", spec)
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
    if chk.table(d, "track", {"model", *keys, *_DISTRIBUTION_KEYS},
                 what=" [track] of track values") is _BAD:
        return _BAD
    model = chk.choice(d, "track", "model", TRACK_MODELS, default="elastic")
    dist = _load_distribution(chk, d, model)
    if model == "rigid":
        for key in keys:
            if key in d:
                chk.warn(f"track.{key} is ignored: not used by track.model = 'rigid'")
        return _BAD if dist is _BAD else {"model": "rigid", **dist}
    k = chk.get_number(d, "track", "foundation_stiffness", _Num(
        "a foundation modulus > 0 N/m per metre of track (both rails; about 3e7 .. 3e8)",
        gt=0, default=_track.FOUNDATION_DEFAULT))
    ei = chk.get_number(d, "track", "rail_EI", _Num(
        "a bending stiffness of both rails > 0 N m^2 (1.283e7 for two UIC60 rails)",
        gt=0, default=_track.RAIL_EI_UIC60))
    c = chk.get_number(d, "track", "foundation_damping", _Num(
        "a foundation damping >= 0 and <= 2e6 N s/m per metre of track (both rails; "
        f"{_track.FOUNDATION_DAMPING_DEFAULT:.3g} for ballasted track, 0 for an elastic "
        "foundation)", ge=0, le=2e6, default=_track.FOUNDATION_DAMPING_DEFAULT))
    mr = chk.get_number(d, "track", "rail_mass", _Num(
        "a mass >= 0 and <= 2000 kg per metre of track moving with the rail (both rails; "
        "120 for two UIC60 rails, 0 for a massless rail)", ge=0, le=2000, default=0.0))
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
    kinds = _dist.LOAD_DISTRIBUTIONS
    kind = chk.choice(d, "track", "load_distribution", kinds, default="none")
    if kind is _BAD:
        return _BAD
    if kind == "elastic_track" and model == "rigid":
        return chk.error("track.load_distribution", kind, "'none', 'rail' or "
                         "'rail_ballast' with track.model = 'rigid' ('elastic_track' "
                         "spreads the forces by the rail on the elastic foundation)")
    specs = {
        "sleeper_spacing": _Num("a sleeper spacing > 0 and <= 2 m (0.6 usual)", gt=0,
                                le=2.0, default=_dist.SLEEPER_SPACING_DEFAULT),
        "sleeper_width": _Num("a sleeper bottom width >= 0 and <= 1 m (about 0.3)", ge=0,
                              le=1.0, default=_dist.SLEEPER_WIDTH_DEFAULT),
        "ballast_depth": _Num("a ballast depth under the sleepers >= 0 and <= 2 m "
                              "(0.3-0.5 usual)", ge=0, le=2.0,
                              default=_dist.BALLAST_DEPTH_DEFAULT),
    }
    out = {"load_distribution": kind} if kind != "none" else {}
    bad = False
    for key, spec in specs.items():
        if kind not in _USED_BY[key]:
            if key in d:
                chk.warn(f"track.{key} is ignored: not used by track.load_distribution = "
                         f"'{kind}' (used by {' and '.join(_USED_BY[key])})")
            continue
        v = chk.get_number(d, "track", key, spec)
        if v is _BAD:
            bad = True
            continue
        lo, hi, usual = _PLAUSIBLE[key]
        if not lo <= v <= hi:
            chk.warn(f"track.{key} = {v:g} m looks implausible: {usual} (units: m)",
                     kind="plausibility", keys=[f"track.{key}"])
        out[key] = float(v)
    return _BAD if bad else out
