"""``[code_profile]``: the code profile of a study (a national annex, a client's rule) and
the applicability of the HSLM load models it decides.

``name`` names the profile; ``overrides`` sets entries of :data:`vsi_numba.code_profile.
TABLE`, each a number in the entry's SI unit or a table ``{value = ..., clause = "..."}``
naming the clause of the rule it comes from::

    [code_profile]
    name = "DE national annex"
    overrides = { deck_acceleration_limit_ballasted = 3.0,
                  wheel_unloading_limit = { value = 0.5, clause = "client rule R-12" } }

The section is stored as written (defaults filled in) in the resolved configuration, so
the profile travels with the results and ``vsi report`` checks a results file with it.
"""

from __future__ import annotations

from collections.abc import Mapping

from vsi_numba.code_profile import (
    KEYS,
    ORDERED,
    CodeProfile,
    default_profile,
    profile_from,
)
from vsi_numba.config._check import _BAD, _join, _show
from vsi_numba.config.schema import models as _m

#: An override further than this factor from the recommended value gets a warning.
IMPLAUSIBLE_FACTOR = 3.0

_EXAMPLE = "{deck_acceleration_limit_ballasted = 3.0}"


def _code_profile_section(chk, c):
    """The ``[code_profile]`` as stored (``name``, ``overrides``) of a validated one
    (:class:`~.schema.models.CodeProfile`; None when the configuration has none: the
    recommended values), and the checks that are not rules of the model: a fixed entry
    is refused with the reason, the ordered pairs of entries stay ordered (with the
    recommended values of the entries not given), an override far from the recommended
    value is warned."""
    if c is None or c is _BAD:
        return c
    p = "code_profile.overrides"
    given = c.overrides
    base = default_profile()
    values, stored = {}, {}
    n_errors = len(chk.errors)
    fixed = given._fixed if given is not None else {}
    for key, raw in fixed.items():
        e = base.entry(key)
        chk.error(_join(p, key), raw, f"an entry the code profile can override: {e.key} "
                  f"({e.description}, {e.clause}) is fixed ({e.note})")
    for key, raw in (given._given.items() if given is not None else ()):
        v = getattr(given, key)
        e = base.entry(key)
        kp = _join(p, key)
        clause, vp, value = None, kp, v
        if isinstance(v, _m.SourcedValue):
            clause, vp, value, raw = v.clause, _join(kp, "value"), v.value, raw["value"]
        unit = "" if e.unit == "1" else f" {e.unit}"
        values[key] = value
        stored[key] = value if clause is None else {"value": value, "clause": clause}
        ratio = value / e.value
        if not 1 / IMPLAUSIBLE_FACTOR <= ratio <= IMPLAUSIBLE_FACTOR:
            chk.warn(f"{vp} = {_show(raw)}: {ratio:.3g} times the recommended "
                     f"{e.value:g}{unit} ({e.clause}); it looks like a slip of units or of "
                     f"the entry (the value is in{unit or ' the unit of the table, -'})",
                     "plausibility", keys=[vp])
    for lo, hi in ORDERED:
        a = values.get(lo, base[lo])
        b = values.get(hi, base[hi])
        if a > b:
            where = hi if hi in values else lo
            chk.error(_join(p, where), values[where],
                      f"{lo} <= {hi} (they would be {a:g} and {b:g})")
    if len(chk.errors) > n_errors:
        return _BAD
    return {"name": c.name, "overrides": stored}


def profile_of_section(section) -> CodeProfile:
    """The :class:`~vsi_numba.code_profile.CodeProfile` of a validated section (None: the
    recommended values)."""
    return default_profile() if section in (None, _BAD) else profile_from(section)


def _hslm_applicability(chk, bridge, train, solver, profile: CodeProfile, refuse) -> None:
    """HSLM-A / HSLM-B against the deck (warnings) and HSLM-B's N and d against the range
    of the profile (refused unless ``solver.allow_implausible``).

    EN 1991-2 uses HSLM-B for simply supported spans below ``hslm_b_max_span`` and HSLM-A
    otherwise and for continuous decks ([R]: see the profile's clauses).
    """
    names = [str(t.name) for t in train.trains]
    a_trains = [n for n in names if n.casefold().startswith("hslm-a")]
    has_b = any(n.casefold() == "hslm-b" for n in names)
    if not a_trains and not has_b:
        return
    max_span = profile["hslm_b_max_span"]
    clause = profile.clause("hslm_b_max_span")
    kind = bridge.resolved.get("kind")
    spans = list(bridge.resolved.get("spans") or [])
    simple = kind in ("simply_supported", "continuous") and len(spans) == 1
    shown = " + ".join(f"{x:g}" for x in spans) + " m" if spans else "not given"
    if a_trains and simple and spans[0] < max_span:
        chk.warn(f"train.preset: {', '.join(a_trains)} on a simply supported span of "
                 f"{spans[0]:g} m: EN 1991-2 uses HSLM-B for simply supported spans below "
                 f"{max_span:g} m ({clause}); run HSLM-B (train.preset = \"HSLM-B\" with "
                 "train.hslm_b = {N, d} from Fig. 6.13) for this span", "plausibility",
                 keys=["train.preset"])
    if has_b and not (simple and spans[0] < max_span):
        why = (f"a simply supported span of {spans[0]:g} m" if simple else
               f"a {str(kind).replace('_', ' ')} deck (spans {shown})")
        chk.warn(f"train.preset: HSLM-B on {why}: HSLM-B is for simply supported spans "
                 f"below {max_span:g} m ({clause}); EN 1991-2 uses HSLM-A (HSLM-A1 .. "
                 "HSLM-A10) for this deck", "plausibility", keys=["train.preset"])
    hb = train.resolved.get("hslm_b")
    if has_b and isinstance(hb, Mapping):
        fig = profile.clause("hslm_b_N_min")
        for sym, unit in (("N", ""), ("d", " m")):
            lo, hi = profile[f"hslm_b_{sym}_min"], profile[f"hslm_b_{sym}_max"]
            v = hb.get(sym)
            if v is not None and not lo <= v <= hi:
                refuse(chk, solver, "allow_implausible",
                       f"train.hslm_b.{sym} = {v:g}: expected {sym} in [{lo:g}, {hi:g}]{unit}, "
                       f"the range of HSLM-B in {fig} (code profile hslm_b_{sym}_min, "
                       f"hslm_b_{sym}_max)")


#: Entries of the damping rules applied when the bridge is read.
_TABLE_6_6 = tuple(k for k in KEYS if k.startswith("damping_"))


def _damping_rules(chk, bridge, profile: CodeProfile):
    """The bridge with the damping rules (``damping_ratio = "EN1991-2"``,
    ``additional_damping = true``) evaluated with the profile's Table 6.6 and
    ``additional_damping_max_span`` where it overrides them (the bridge section evaluated
    them with the recommended values); ``bridge`` itself otherwise."""
    import dataclasses

    import numpy as np

    from vsi_numba import en1991
    from vsi_numba.config.bridge import _span_for_damping
    from vsi_numba.model import bridge as _bridge

    changed = set(profile.overridden)
    res = bridge.resolved
    spans = res.get("spans") or []
    if not spans:
        return bridge
    span = _span_for_damping(bridge.kind, spans)
    new = dict(res)
    model = bridge.model
    if "damping_rule" in res and changed & set(_TABLE_6_6):
        if "track" in res:
            keys = sorted(changed & set(_TABLE_6_6))
            chk.error(f"code_profile.overrides.{keys[0]}", profile[keys[0]],
                      "no override of Table 6.6 with [bridge.track] (the damping enters the "
                      "track-layer model before its reduction): give bridge.damping_ratio "
                      "as a number instead")
            return bridge
        deck = res["deck_type"]
        zeta = en1991.damping_lower_bound(deck, span, profile)
        new["damping_ratio"] = zeta
        key = en1991.DECK_TYPE_KEYS[deck]
        new["damping_rule"] = (f"EN 1991-2 Table 6.6 with the code profile '{profile.name}' "
                               f"({profile.clause(key, key + '_slope')}), "
                               f"{deck.replace('_', ' ')}, L = {span:g} m: zeta = "
                               f"{100 * zeta:.4g} %")
        z = _bridge.per_mode(zeta, model.n_modes, "damping_ratio")
        space = getattr(bridge, "space", None)
        if space is not None and space.has_torsion:  # Table 6.6 is for the bending modes
            share = np.asarray(space.torsional_share, float)
            z = (1.0 - share) * z + share * float(res["torsion"]["damping_ratio"])
        model = dataclasses.replace(model, damping=z)
    if "additional_damping_rule" in res and "additional_damping_max_span" in changed:
        dz = en1991.additional_damping(span, profile)
        new["additional_damping"] = dz
        new["additional_damping_rule"] = (
            f"EN 1991-2 6.4.6.3.1, L = {span:g} m: dzeta = {100 * dz:.4g} % added for "
            f"moving-force trains only (spans below {profile['additional_damping_max_span']:g}"
            f" m: code profile '{profile.name}')")
    if new == res:
        return bridge
    space = getattr(bridge, "space", None)
    if space is not None and model is not bridge.model:
        space = dataclasses.replace(space, bending=model)
    return dataclasses.replace(bridge, resolved=new, model=model, space=space)
