"""Text from inputs in the reports of :mod:`vsi_numba.existing`."""

from __future__ import annotations


def md(text) -> str:
    """Text from inputs as Markdown data (no markup, one line)."""
    s = str(text).replace("\n", " ")
    for ch in "\\`*_{}[]<>()#+!|":
        s = s.replace(ch, "\\" + ch)
    return s
