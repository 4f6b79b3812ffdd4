"""``[solver]``, ``[contact]`` and ``[track]``: the settings of the time integration, the
wheel-rail contact, the rail on its foundation and the distribution of moving forces by
the track.

The admissible values of the solver keys are those of
:class:`vsi_numba.solver.settings.SolverSettings` (its ``BOUNDS`` and defaults), which the
validated section becomes (:meth:`vsi_numba.config.Config.solver_settings`).
"""

from __future__ import annotations

from vsi_numba.config._check import _BAD, _Sentinel
from vsi_numba.config.schema import models as _m
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


def _solver_section(chk, s) -> dict | _Sentinel:
    """The settings of a validated ``[solver]`` (:class:`~.schema.models.Solver`): every
    numeric key, and the escapes given."""
    if s is _BAD:
        return _BAD
    vals = {k: getattr(s, k) for k in _SOLVER_FIELDS}
    vals.update({k: getattr(s, k) for k in SOLVER_OVERRIDES if k in s.model_fields_set})
    vals["hht_alpha"] = max(vals["hht_alpha"], HHT_ALPHA_MIN)
    return vals


def _contact_section(chk, c) -> dict | _Sentinel:
    """The resolved ``[contact]`` of a validated one (:class:`~.schema.models.Contact`;
    its rule: a Hertz model has its constant)."""
    if c is _BAD:
        return _BAD
    if c.model == "rigid":
        if "hertz_coefficient" in c.model_fields_set:
            chk.warn("contact.hertz_coefficient is ignored: not used by contact.model = 'rigid'")
        return {"model": "rigid"}
    return {"model": c.model, "hertz_coefficient": c.hertz_coefficient}


def _rail_track_section(chk, t, fe_layer: bool) -> dict | _Sentinel:
    """[track]: the rail on an elastic foundation (default) or the rigid idealisation,
    from a validated ``[track]`` (:class:`~.schema.models.Track`, or ``_MISSING`` with
    the FE track layer of ``[bridge.track]``, which is the track)."""
    if fe_layer:
        return {"model": "bridge_layer"}
    if t is _BAD:
        return _BAD
    keys = ("foundation_stiffness", "rail_EI", "foundation_damping", "rail_mass")
    dist = _load_distribution(chk, t)
    if t.model == "rigid":
        for key in keys:
            if key in t.model_fields_set:
                chk.warn(f"track.{key} is ignored: not used by track.model = 'rigid'")
        return {"model": "rigid", **dist}
    return {"model": "elastic", **{k: float(getattr(t, k)) for k in keys}, **dist}


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


def _load_distribution(chk, t) -> dict:
    """track.load_distribution and its lengths: the resolved keys (none for 'none', so
    a configuration without the key keeps its stored form and hash)."""
    kind = t.load_distribution
    out = {"load_distribution": kind} if kind != "none" else {}
    for key in _USED_BY:
        if kind not in _USED_BY[key]:
            if key in t.model_fields_set:
                chk.warn(f"track.{key} is ignored: not used by track.load_distribution = "
                         f"'{kind}' (used by {' and '.join(_USED_BY[key])})")
            continue
        v = getattr(t, key)
        lo, hi, usual = _PLAUSIBLE[key]
        if not lo <= v <= hi:
            chk.warn(f"track.{key} = {v:g} m looks implausible: {usual} (units: m)",
                     kind="plausibility", keys=[f"track.{key}"])
        out[key] = float(v)
    return out
