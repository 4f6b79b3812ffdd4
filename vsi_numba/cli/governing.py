"""The governing results of a results file, one line per check, as ``vsi sweep`` prints
them at its end (the checks of :mod:`vsi_numba.analysis.checks`, with the settings of
the report: characteristic fractile, bootstrap, comfort level "very good")."""

from __future__ import annotations

import math

import numpy as np


def _num(x: float, digits: int = 3) -> str:
    return "nan" if not math.isfinite(x) else f"{x:#.{digits}g}".rstrip(".")


def _where(ds, x: float) -> str:
    """``x = 13.3 m`` (and whether it is on the approach or exit track)."""
    if not math.isfinite(x):
        return ""
    length = float(ds.attrs.get("bridge_length", np.nan))
    side = (" (approach track)" if x < -1e-9 else
            " (exit track)" if math.isfinite(length) and x > length + 1e-9 else "")
    return f", x = {x:.1f} m{side}"


def _head(name: str, a: dict, units: str, limit_note: str = "") -> str:
    result = str(a.get("result", "n/a"))
    value = float(a.get("value", np.nan))
    if result == "n/a" or not math.isfinite(value):
        why = a.get("note") or "not available from these results"
        return f"{name}: n/a ({why})"
    limit = float(a.get("limit", np.nan))
    lim = f" (limit {_num(limit)}{units}{limit_note})" if math.isfinite(limit) else ""
    return (f"{name} {_num(value)}{units} {result}{lim}: {a.get('governing_train', '')}, "
            f"{float(a.get('governing_speed_kmh', np.nan)):g} km/h")


def governing_lines(ds) -> list[str]:
    """One line per check: deck acceleration, wheel unloading dQ/Q0, comfort.

    Parameters
    ----------
    ds : xarray.Dataset
        Results of ``vsi sweep`` or ``vsi run``; a study of variants is judged on its
        governing variant (highest peak deck acceleration), which the lines name.

    Returns
    -------
    list of str
        e.g. ``deck acceleration 17.8 m/s2 FAIL (limit 3.5 m/s2): HSLM-A6, 415 km/h,
        x = 13.3 m``; a check the results do not allow reads ``...: n/a (why)``.
    """
    from vsi_numba.analysis import checks as chk
    from vsi_numba.analysis.dataset import prepare

    lines = []
    if "variant" in ds.dims:
        from vsi_numba.analysis.variants import governing_variant, variant_label, variant_view

        k = governing_variant(ds)
        lines.append(f"governing variant {k} of {ds.sizes['variant']}: {variant_label(ds, k)}")
        ds = variant_view(ds, k)
    if "time" not in ds.dims:
        # the checks read the envelopes many times: read them (of one variant) once
        ds = ds.load()
    ds = prepare(ds)
    try:
        acc = chk.deck_acceleration_check(ds)
        a = acc.attrs
        lines.append(_head("deck acceleration", a, " m/s2")
                     + ("" if a.get("result") == "n/a" else
                        _where(ds, float(a.get("governing_point", np.nan)))))
    except chk.ResultsError as exc:
        lines.append(f"deck acceleration: n/a ({exc})")
    try:
        wu = chk.wheel_unloading(ds)
        a = wu.attrs
        line = _head("wheel unloading dQ/Q0", a, "")
        w = int(a.get("governing_wheel", -1))
        if w >= 0 and "position_of_min_contact_force" in ds and a.get("governing_train"):
            sel = dict(train=a["governing_train"], speed=a["governing_speed"], wheel=w)
            pos = ds["position_of_min_contact_force"].sel(**sel)
            if "irregularity" in pos.dims:
                i = a.get("governing_irregularity")
                pos = (pos.sel(irregularity=i) if i is not None and i in pos["irregularity"]
                       else pos.isel(irregularity=0))
            line += f", axle {w}" + _where(ds, float(pos))
        lines.append(line)
    except chk.ResultsError as exc:
        lines.append(f"wheel unloading dQ/Q0: n/a ({exc})")
    try:
        cf = chk.comfort(ds, "very good")
        a = cf.attrs
        vehicle = a.get("governing_vehicle")
        lines.append(_head("comfort (car-body acceleration)", a, " m/s2",
                           f", {a.get('required_level', 'very good')}")
                     + (f", vehicle {vehicle}" if vehicle else ""))
    except chk.ResultsError as exc:
        lines.append(f"comfort (car-body acceleration): n/a ({exc})")
    return lines
