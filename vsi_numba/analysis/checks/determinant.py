"""Determinant length L_phi of the deck of a results file (EN 1991-2 6.4.5.3,
Table 6.2), with the rule or assumption that gave it."""

from __future__ import annotations

import json
from typing import NamedTuple

import numpy as np
import xarray as xr

from vsi_numba.code_profile import CodeProfile, of_config, resolve
from vsi_numba.en1991 import continuous_determinant_length, continuous_k

#: Bridge kinds whose mode shapes come from another program (their support layout is
#: not known here).
_IMPORTED_KINDS = ("modes_file", "matrices")


class DeterminantLength(NamedTuple):
    """Determinant length L_phi (m) of a deck and how it was obtained.

    ``value`` is NaN where no L_phi applies (rigid track); ``rule`` says which rule (or
    assumption) gave it, in words, for the report; ``assumed`` is True when the rule is
    an assumption rather than a case of EN 1991-2 Table 6.2 or a value given by the
    user.  (Table 6.2 is the code profile's ``determinant_length_k*``.)
    """

    value: float
    rule: str
    assumed: bool


def _continuous_rule(spans, profile: CodeProfile | None = None) -> str:
    L = np.asarray(spans, float)
    k = continuous_k(L.size, profile)
    value = continuous_determinant_length(L, profile)
    text = (f"continuous deck of {L.size} spans: L_Φ = k L_m = {k:g} × {L.mean():g} m "
            f"= {k * L.mean():g} m")
    if value > k * L.mean():
        text += f", raised to the largest span {L.max():g} m (L_Φ ≥ max span)"
    else:
        text += f" (≥ the largest span {L.max():g} m)"
    return text


def results_config(ds: xr.Dataset) -> dict:
    """The resolved configuration stored in ``config_json`` (empty dict if none/unreadable)."""
    try:
        config = json.loads(str(ds.attrs.get("config_json", "") or "{}"))
    except ValueError:
        return {}
    return config if isinstance(config, dict) else {}


def _positive(value) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) and v > 0 else None


def determinant_length(ds: xr.Dataset, override: float | None = None,
                       profile: CodeProfile | None = None) -> DeterminantLength:
    """Determinant length L_phi (m) of the deck of a results file, with its rule.

    In order of precedence:

    1. ``override`` (an explicit argument wins over everything);
    2. the global attribute ``determinant_length`` (m) of the results, then the key
       ``bridge.determinant_length`` of the stored configuration;
    3. from the configuration's ``bridge.kind`` and ``bridge.spans``, EN 1991-2
       Table 6.2 (the factors k of the code profile): simply supported span L_phi = L;
       continuous deck of n spans L_phi = k L_m (:func:`continuous_determinant_length`);
       rigid track: not applicable (NaN); imported modes or matrices (``modes_file``,
       ``matrices``): the same rule over the spans given, else the bridge length, flagged
       as an assumption;
    4. without a usable configuration, the ``bridge_length`` attribute, flagged as an
       assumption (right only for a simply supported span).

    Parameters
    ----------
    ds : xarray.Dataset
        Results (attributes ``config_json``, ``bridge_length``, ``determinant_length``).
    override : float, optional
        L_phi (m) given by the user; must be > 0.
    profile : CodeProfile, optional
        Code profile; default: the one of the results' stored configuration.

    Returns
    -------
    DeterminantLength
        ``(value, rule, assumed)``; value NaN when nothing gives a length.
    """
    if override is not None:
        value = _positive(override)
        if value is None:
            raise ValueError(f"determinant length = {override!r}: expected a length > 0 m")
        return DeterminantLength(value, f"given explicitly: L_Φ = {value:g} m", False)
    value = _positive(ds.attrs.get("determinant_length"))
    if value is not None:
        return DeterminantLength(value, f"L_Φ = {value:g} m from the results attribute "
                                        "`determinant_length`", False)
    config = results_config(ds)
    profile = resolve(profile) if profile is not None else of_config(config)
    bridge = config.get("bridge", {})
    bridge = bridge if isinstance(bridge, dict) else {}
    value = _positive(bridge.get("determinant_length"))
    if value is not None:
        return DeterminantLength(value, f"L_Φ = {value:g} m from the configuration "
                                        "(bridge.determinant_length)", False)
    kind = str(bridge.get("kind", ""))
    spans = bridge.get("spans")
    try:
        spans = [float(x) for x in np.atleast_1d(spans)] if spans is not None else None
        if spans is not None:
            continuous_determinant_length(spans)  # validates
    except (TypeError, ValueError):
        spans = None
    length = _positive(ds.attrs.get("bridge_length"))
    if kind == "rigid":
        return DeterminantLength(np.nan, "not applicable: rigid track, no deck", False)
    if kind == "simply_supported" and spans:
        return DeterminantLength(spans[0], f"simply supported span: L_Φ = L = {spans[0]:g} m",
                                 False)
    if kind == "continuous" and spans:
        if len(spans) == 1:
            return DeterminantLength(spans[0], f"one span: L_Φ = L = {spans[0]:g} m", False)
        return DeterminantLength(continuous_determinant_length(spans, profile),
                                 _continuous_rule(spans, profile), False)
    if kind in _IMPORTED_KINDS and spans:
        what = (f"one span: L_Φ = L = {spans[0]:g} m" if len(spans) == 1
                else _continuous_rule(spans, profile))
        return DeterminantLength(
            continuous_determinant_length(spans, profile),
            f"ASSUMPTION — imported deck (bridge.kind = '{kind}', supports not known here), "
            f"taken as a simply supported or continuous deck over the spans given: {what}",
            True)
    if length is not None:
        why = (f"imported deck (bridge.kind = '{kind}') without bridge.spans"
               if kind in _IMPORTED_KINDS else
               "no bridge kind and spans in the results' configuration")
        return DeterminantLength(
            length, f"ASSUMPTION — {why}: L_Φ = the bridge length {length:g} m, right only "
                    "for a simply supported span; give the determinant length for other decks",
            True)
    return DeterminantLength(np.nan, "unknown: no configuration, bridge length or "
                                     "determinant length in the results", True)
