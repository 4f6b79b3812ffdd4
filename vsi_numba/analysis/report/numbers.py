"""How the report writes a number: with its units (kN, mm, mrad, m/s²), with the digits
that keep it on the side of a threshold its verdict says, as ``1.508e10``-style numbers,
and a configuration's hash."""

from __future__ import annotations

import re

import numpy as np

from vsi_numba.analysis.report.safe import md


def _fmt(value, units: str = "", digits: int = 3) -> str:
    """Readable value with units for the Markdown tables (SI in, kN/mm for N/m)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not np.isfinite(v):
        return "–"
    if units == "N":
        return f"{v / 1e3:.1f} kN"
    if units == "m":
        return f"{v * 1e3:.2f} mm"
    if units == "m s-2":
        return f"{v:.{digits}g} m/s²"
    if units == "s":
        return f"{v:.3g} s"
    if units == "rad":
        return f"{v * 1e3:.{digits}g} mrad"
    if units == "N m":  # as the load-effect tables show it
        return f"{v / 1e3:.4g} kN m"
    return f"{v:.{digits}g}"


#: Scale of a unit to the number the report shows (``_fmt``: kN, mm, mrad).
_SHOWN_SCALE = {"N": 1e-3, "N m": 1e-3, "m": 1e3, "rad": 1e3}


def fmt_against(value, threshold, units: str = "", digits: int = 3) -> str:
    """``value`` as :func:`_fmt` shows it, with more significant digits where that
    rounding would put it on the threshold or on the other side of it (a ratio of 1.0049
    to the threshold 1 shows as ``1.005``, not ``1``): the number shown is on the same
    side of ``threshold`` (same units) as the verdict it stands beside."""
    text = _fmt(value, units, digits)
    try:
        v, t = float(value), float(threshold)
    except (TypeError, ValueError):
        return text
    if not (np.isfinite(v) and np.isfinite(t)) or v == t:
        return text
    scale = _SHOWN_SCALE.get(units, 1.0)
    unit = text.split(" ", 1)[1] if " " in text else ""
    for d in range(digits, 16):
        number = float(f"{v * scale:.{d}g}")
        if number != t * scale and (number > t * scale) == (v > t):
            if d == digits:
                return text
            return f"{v * scale:.{d}g}" + (f" {unit}" if unit else "")
    return text


def fixed_against(value, threshold: float, decimals: int = 3, scale: float = 1.0) -> str:
    """``value × scale`` with ``decimals`` decimals, more where that many would show it on
    ``threshold × scale`` or beyond it (a ratio 1.0004 to 1 is ``1.0004``, not
    ``1.000``); "–" when not finite."""
    try:
        v, t = float(value), float(threshold)
    except (TypeError, ValueError):
        return "–"
    if not np.isfinite(v):
        return "–"
    for d in range(decimals, decimals + 12):
        shown = round(v * scale, d)
        if v == t or not np.isfinite(t) or (shown != t * scale
                                             and (shown > t * scale) == (v > t)):
            return f"{v * scale:.{d}f}"
    return f"{v * scale:.{decimals}f}"


def fmt_percent_against(fraction, threshold: float = 1.0) -> str:
    """A utilisation (a fraction) in per cent with one decimal, more where one decimal
    would show it on the threshold (99.96 % is not shown as 100.0 %)."""
    text = fixed_against(fraction, threshold, 1, 100.0)
    return text if text == "–" else f"{text} %"


def fmt_number(value, unit: str = "", digits: int = 4) -> str:
    """``1.508e10 N m²``-style numbers: plain below 1e5, else mantissa e exponent with
    trailing zeros dropped (``7.16e10``)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not np.isfinite(v):
        return "–"
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-4):
        mant, exp = f"{v:.{digits - 1}e}".split("e")
        mant = mant.rstrip("0").rstrip(".")
        text = f"{mant}e{int(exp)}"
    else:
        text = np.format_float_positional(v, precision=digits, unique=True, fractional=False,
                                          trim="-")
    text = text.replace("-", "−")
    return f"{text} {unit}".rstrip()


def fmt_list(values, unit: str = "", joiner: str = ", ") -> str:
    """A list of numbers with one unit at the end (``20 + 20 m`` with ``joiner=" + "``)."""
    vals = np.atleast_1d(np.asarray(values, dtype=float))
    return joiner.join(fmt_number(v) for v in vals) + (f" {unit}" if unit else "")


def sha256_text(sha) -> str:
    """A configuration hash for the report: as code when it is one (64 hex digits), else
    shown literally (a crafted file)."""
    if not sha:
        return "–"
    sha = str(sha)
    return f"`{sha}`" if re.fullmatch(r"[0-9a-fA-F]{64}", sha) else md(sha)
