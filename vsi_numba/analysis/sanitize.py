"""Text from a configuration or a results file, made safe for every output format.

Train, vehicle, variant and fatigue section names, the ``[report]`` fields, code-profile
clauses, warnings, messages quoting the configuration and the attributes of a results
file are data, not markup. Each output format has one sanitiser, applied by the writer of
that format where the text leaves the program:

- **Markdown** (``report.md``): :func:`md` (and :func:`cell`, :func:`code`) show a piece of
  text literally where the report puts it; :func:`markdown_document`, applied by the
  Markdown writers to the whole file, neutralises whatever is left that would make a
  renderer fetch or link outside the report (raw HTML, autolinks, a link to a URL, an image
  that is not one of the report's figures).
- **HTML** (``report.html``): rendered from the same Markdown by markdown-it with raw HTML
  off and :func:`local_link` as the only links allowed; attributes through
  :func:`html.escape`.
- **CSV / XLSX cells**: :func:`sheet_frame` (and :func:`write_csv`): every text cell and
  header shown as one line (:func:`clean`) and, when it starts with ``=``, ``+``, ``-``,
  ``@``, a tab or a carriage return, prefixed with a single quote (OWASP, CSV injection) so
  that no spreadsheet reads it as a formula; numbers stay numbers.
- **Plot labels**: :func:`plot_labels`, applied to a figure before it is saved, shows every
  text of the figure literally (:func:`mathtext`: ``$`` escaped, control characters as
  escapes), except the report's own math labels (:data:`MATH_GID`).

Control characters are accepted in the configuration (a title may hold a tab) and
neutralised on output by these sanitisers, so that a results file written elsewhere is
safe too. :func:`natural_key` orders train names as people read them (HSLM-A2 before
HSLM-A10).
"""

from __future__ import annotations

import functools
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
    """``text`` for a matplotlib label that is drawn with math text on: control characters
    shown as Python escapes (:func:`printable`) and every ``$`` escaped, so that nothing
    in it is parsed as math text (``$\\frac{$`` is shown, not parsed)."""
    return printable(text, keep="").replace("$", r"\$")


def printable(text, keep: str = "\n") -> str:
    """``text`` with its control and format characters shown as Python escapes (``\\r``,
    ``\\x1b``, ``\\u202e``: the figure fonts have no control pictures), except those in
    ``keep`` (a label's own line breaks)."""
    out = []
    for ch in str(text):
        if ch not in keep and unicodedata.category(ch) in _INVISIBLE:
            out.append(repr(ch)[1:-1] if ord(ch) < 0x10000 else f"\\U{ord(ch):08x}")
        else:
            out.append(ch)
    return "".join(out)


_INVISIBLE = ("Cc", "Cf", "Zl", "Zp", "Cs", "Co", "Cn")


# --------------------------------------------------------------------------------------
# Markdown documents
# --------------------------------------------------------------------------------------


def local_link(url: str) -> bool:
    """Links a report may hold: anchors and relative paths (another file of the report),
    never a URL with a scheme (http:, file:, javascript:, data:) or a network path
    (//host)."""
    url = url.strip()
    return not (url.startswith(("//", "\\\\")) or re.match(r"^[A-Za-z][A-Za-z0-9+.-]*:", url))


@functools.cache
def _markdown_parser():
    from markdown_it import MarkdownIt

    # as permissive as a renderer may be: raw HTML on, every link destination accepted
    parser = MarkdownIt("commonmark", {"html": True}).enable("table")
    parser.validateLink = lambda url: True
    return parser


def markdown_offences(text: str, images=()) -> list[str]:
    """What in the Markdown ``text`` would make a renderer fetch or link outside the
    report: raw HTML (blocks and inline tags), autolinks and links to anything but
    :func:`local_link` targets, and images other than the files ``images``.  Empty for a
    safe document."""
    images = set(images)
    found = []
    for tok in _markdown_parser().parse(text):
        if tok.type == "html_block":
            found.append(f"raw HTML {tok.content.strip()[:60]!r}")
        for t in tok.children or []:
            if t.type == "html_inline":
                found.append(f"raw HTML {t.content[:60]!r}")
            elif t.type == "link_open" and not local_link(str(t.attrs.get("href", ""))):
                found.append(f"link to {str(t.attrs.get('href'))[:60]!r}")
            elif t.type == "image" and str(t.attrs.get("src", "")) not in images:
                found.append(f"image {str(t.attrs.get('src'))[:60]!r}")
    return found


def _skip_code(line: str, i: int) -> int:
    """End of the code span opening at ``line[i]`` (a backtick run), or of the run itself
    when nothing closes it."""
    j = i
    while j < len(line) and line[j] == "`":
        j += 1
    close = re.compile(rf"(?<!`)`{{{j - i}}}(?!`)").search(line, j)
    return close.end() if close else j


def _is_image(line: str, i: int) -> bool:
    """Whether the ``]`` at ``line[i]`` closes the text of an image (``![``)."""
    depth = 0
    for k in range(i - 1, -1, -1):
        if line[k] == "]" and (k == 0 or line[k - 1] != "\\"):
            depth += 1
        elif line[k] == "[" and (k == 0 or line[k - 1] != "\\"):
            if depth == 0:
                return k > 0 and line[k - 1] == "!"
            depth -= 1
    return False


def _target(line: str, i: int) -> str:
    """The destination of a link or image whose ``(`` is at ``line[i]``."""
    rest = line[i + 1:].lstrip()
    if rest.startswith("<"):
        return rest[1:].split(">", 1)[0]
    return re.split(r"[\s)]", rest, maxsplit=1)[0]


def _neutralise_line(line: str, images: set, strict: bool) -> str:
    out, i, n = [], 0, len(line)
    while i < n:
        ch = line[i]
        if ch == "\\":
            out.append(line[i:i + 2])
            i += 2
            continue
        if ch == "`" and not strict:
            j = _skip_code(line, i)
            out.append(line[i:j])
            i = j
            continue
        nxt = line[i + 1] if i + 1 < n else ""
        if ch == "<" and (strict or re.match(r"[A-Za-z/!?]", nxt)):
            out.append("\\<")
        elif strict and ch in "[]`":
            out.append("\\" + ch)
        elif ch == "]" and nxt in "[:":
            out.append("\\]")  # a reference link or a link reference definition
        elif ch == "]" and nxt == "(":
            dest = _target(line, i + 1)
            ok = dest in images if _is_image(line, i) else local_link(dest)
            out.append("]" if ok else "\\]")
        else:
            out.append(ch)
        i += 1
    return "".join(out)


def markdown_document(text: str, images=()) -> str:
    """The Markdown file ``text`` as its writer saves it: unchanged when it is safe
    (:func:`markdown_offences` finds nothing), else with every raw HTML tag and autolink
    (``<`` before a letter, ``/``, ``!``, ``?``), reference link, and link or image
    whose destination is not allowed (a URL; an image that is not one of ``images``, the
    report's figures) backslash-escaped outside code spans, so that it shows as text.
    Should anything remain (a construct the escapes do not cover), every ``<``, ``[``,
    ``]`` and backtick of the offending lines is escaped."""
    images = set(images)
    if not markdown_offences(text, images):
        return text
    lines = [_neutralise_line(ln, images, strict=False) for ln in text.split("\n")]
    if markdown_offences("\n".join(lines), images):
        lines = [ln if not markdown_offences(ln, images) else
                 _neutralise_line(ln, images, strict=True) for ln in lines]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# CSV and XLSX cells
# --------------------------------------------------------------------------------------

#: What a spreadsheet may read as the start of a formula in a cell (OWASP, CSV injection).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def sheet_text(text) -> str:
    """A text cell of a CSV or XLSX file: one line of printable characters (:func:`clean`),
    with a single quote in front when it starts with ``=``, ``+``, ``-``, ``@``, a tab or a
    carriage return, so that no spreadsheet evaluates it (``=HYPERLINK(...)`` is shown as
    ``'=HYPERLINK(...)``)."""
    text = str(text)
    out = clean(text)
    return "'" + out if text.startswith(FORMULA_START) or out.startswith(FORMULA_START) else out


def sheet_frame(frame):
    """``frame`` for a CSV or XLSX writer: every text header and text cell through
    :func:`sheet_text`; numbers (and every cell of a numeric column) untouched, so that a
    negative number stays a number."""
    import pandas as pd

    def fix(v):
        return sheet_text(v) if isinstance(v, str) else v

    out = frame.rename(columns=fix)
    for j in range(out.shape[1]):
        col = out.iloc[:, j]
        if pd.api.types.is_numeric_dtype(col.dtype) or pd.api.types.is_bool_dtype(col.dtype):
            continue
        out.isetitem(j, col.map(fix).astype(object))
    return out


def write_csv(frame, path, **kwargs):
    """Write ``frame`` as CSV (no index; ``kwargs`` to :meth:`pandas.DataFrame.to_csv`)
    with its text cells through :func:`sheet_text`; return the path."""
    sheet_frame(frame).to_csv(path, index=False, **kwargs)
    return path


# --------------------------------------------------------------------------------------
# Plot labels
# --------------------------------------------------------------------------------------

#: Longest line of a text in a figure (characters): longer lines (a very long train name
#: in a legend) are cut and end in "…", so that they cannot squeeze the axes away.
MAX_LABEL = 80

#: Longest text tick label (characters), cut the same way: a tick label sits beside the
#: others along its axis.
MAX_TICK = 30

#: The ``gid`` of a text of a figure that is math text written by the program (a label
#: such as ``$b_v$``): :func:`plot_labels` leaves it as it is.
MATH_GID = "vsi-math"


def plot_labels(fig):
    """``fig`` with every text shown literally, before it is saved: titles, axis labels,
    legends, annotations and text tick labels (``set_xticks(x, labels)``) get their
    control characters shown as escapes (:func:`printable`; a label's line breaks kept),
    lines longer than :data:`MAX_LABEL` (tick labels :data:`MAX_TICK`) cut with "…", and
    are not parsed as math text (a ``$\\frac{$`` in a train name is shown, where it would
    stop the drawing).  The program's own math labels (``gid`` :data:`MATH_GID`) and the
    number tick labels (log axes write ``$10^{4}$``) keep their math text.  Applying it
    twice changes nothing more.  Returns ``fig``."""
    if fig is None:
        return fig
    from matplotlib.axis import Axis
    from matplotlib.text import Text
    from matplotlib.ticker import FixedFormatter, Formatter, FuncFormatter

    class Literal(Formatter):
        """Tick labels given as text (``set_xticks(x, labels)``), shown literally (the
        tick labels keep math text on for the number formatters)."""

        def __init__(self, inner):
            self.inner = inner

        def __call__(self, x, pos=None):
            text = printable(self.inner(x, pos), keep="")
            if len(text) > MAX_TICK:
                text = text[:MAX_TICK - 1] + "…"
            return text.replace("$", r"\$")

        def set_locs(self, locs):
            super().set_locs(locs)
            self.inner.set_locs(locs)

    def texts(artist):
        if isinstance(artist, Axis):  # its label; number ticks are left as they are
            if isinstance(artist.get_major_formatter(), FixedFormatter | FuncFormatter):
                artist.set_major_formatter(Literal(artist.get_major_formatter()))
            if isinstance(artist.get_minor_formatter(), FixedFormatter | FuncFormatter):
                artist.set_minor_formatter(Literal(artist.get_minor_formatter()))
            yield artist.label
            return
        if isinstance(artist, Text):
            yield artist
        for child in artist.get_children():
            yield from texts(child)

    for text in texts(fig):
        if text.get_gid() == MATH_GID:
            continue
        text.set_parse_math(False)
        old = text.get_text()
        new = "\n".join(ln if len(ln) <= MAX_LABEL else ln[:MAX_LABEL - 1] + "…"
                        for ln in printable(old).split("\n"))
        if new != old:
            text.set_text(new)
    return fig


def natural_key(name) -> tuple:
    """Sort key of a name with its digit runs compared as numbers: HSLM-A1, HSLM-A2, ...,
    HSLM-A10 (not HSLM-A1, HSLM-A10, HSLM-A2)."""
    parts = re.split(r"(\d+)", str(name).casefold())
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in parts)


def natural_order(names) -> list[int]:
    """Indices that put ``names`` in :func:`natural_key` order (stable)."""
    names = [str(n) for n in names]
    return sorted(range(len(names)), key=lambda i: natural_key(names[i]))
