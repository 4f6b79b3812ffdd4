"""Text from a configuration or a results file, made safe for the report.

Train, vehicle and variant names, the ``[report]`` fields, warnings and the attributes of
a results file are data, not markup: :func:`md` shows them literally in Markdown (and so
in the HTML rendered from it), :func:`clean` shows control characters instead of letting
them break a line or a table, and :func:`mathtext` keeps matplotlib from parsing them as
math text. :func:`natural_key` orders train names as people read them (HSLM-A2 before
HSLM-A10).
"""

from __future__ import annotations

import re
import unicodedata

#: Shown in place of a line break, carriage return or tab (one line, one table cell).
_SHOWN = {"\n": "␊", "\r": "␍", "\t": "␉", "\u2028": "␤", "\u2029": "␤", "\x7f": "␡"}

#: What starts an inline Markdown construct (CommonMark) in text: a backslash, code
#: span, emphasis (``*``; ``_`` at a word boundary), ``]`` closing a link or image text
#: (``](``, ``][``: with it escaped no link or image can form, there being no reference
#: definitions), an autolink or raw HTML (``<``), an entity (``&name;``), ``~``
#: (strikethrough in other renderers).  ``|`` is escaped by the table writers.
_INLINE = re.compile(r"([\\`*~<])|(\](?=[(\[]))|((?<![A-Za-z0-9])_|_(?![A-Za-z0-9]))"
                     r"|(&(?=#?[A-Za-z0-9]+;))")
#: A block marker at the start of a text (heading, quote, list item, setext line).
_LEADING = re.compile(r"^(\s*)(>|[#+=-](?=[\s#=-]|$))|^(\s*\d{1,9})([.)](?=\s|$))")


def clean(text) -> str:
    """``text`` as one line of printable characters: line breaks, tabs and other control
    characters shown as their Unicode control pictures (``␊``, ``␍``, ``␀``), invisible
    format characters (bidirectional overrides, zero-width spaces) as ``⟨U+202E⟩``."""
    out = []
    for ch in str(text):
        if ch in _SHOWN:
            out.append(_SHOWN[ch])
            continue
        cat = unicodedata.category(ch)
        if cat == "Cc":
            out.append(chr(0x2400 + ord(ch)) if ord(ch) < 0x20 else f"⟨U+{ord(ch):04X}⟩")
        elif cat in ("Cf", "Zl", "Zp", "Cs", "Co", "Cn") and ch != "\u00ad":
            out.append(f"⟨U+{ord(ch):04X}⟩")
        else:
            out.append(ch)
    return "".join(out)


def md(text) -> str:
    """``text`` (from a configuration or a results file) as literal inline Markdown:
    :func:`clean`, then every character that could start a link, image, emphasis, code
    span, raw HTML or entity backslash-escaped, and a leading block marker (``#``,
    ``>``, ``-``, ``1.``) too."""
    text = _INLINE.sub(lambda m: "\\" + m[0], clean(text))
    return _LEADING.sub(lambda m: (f"{m[1]}\\{m[2]}" if m[2] else f"{m[3]}\\{m[4]}"),
                        text, count=1)


def code(text) -> str:
    """``text`` as an inline code span (a path, a command), whatever it holds: the fence
    is one backtick more than its longest run of backticks."""
    text = clean(text)
    runs = [len(r) for r in re.findall(r"`+", text)]
    fence = "`" * (max(runs, default=0) + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def cell(text) -> str:
    """:func:`md` for a pipe-table cell (``|`` escaped as well)."""
    return md(text).replace("|", "\\|")


def mathtext(text) -> str:
    """``text`` for a matplotlib label: control characters shown as Python escapes
    (``\\r``, ``\\x01``: the figure fonts have no control pictures) and every ``$``
    escaped, so that nothing in it is parsed as math text (``$\\frac{$`` is shown, not
    parsed)."""
    out = []
    for ch in str(text):
        if unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp", "Cs", "Co", "Cn"):
            out.append(repr(ch)[1:-1] if ord(ch) < 0x10000 else f"\\U{ord(ch):08x}")
        else:
            out.append(ch)
    return "".join(out).replace("$", r"\$")


def natural_key(name) -> tuple:
    """Sort key of a name with its digit runs compared as numbers: HSLM-A1, HSLM-A2, ...,
    HSLM-A10 (not HSLM-A1, HSLM-A10, HSLM-A2)."""
    parts = re.split(r"(\d+)", str(name).casefold())
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in parts)


def natural_order(names) -> list[int]:
    """Indices that put ``names`` in :func:`natural_key` order (stable)."""
    names = [str(n) for n in names]
    return sorted(range(len(names)), key=lambda i: natural_key(names[i]))
