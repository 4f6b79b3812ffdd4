"""A report as a list of sections, rendered to Markdown (for diffs) and to one
self-contained HTML file (for the client: figures embedded, a print stylesheet).

A :class:`Section` is a title and blocks: Markdown text (a string or a list of lines),
:class:`Table` (a :class:`pandas.DataFrame` with a caption) and :class:`Figure` (a
matplotlib figure, or PNG bytes, with a caption). Anything that produces those renders to
both formats without knowing either, e.g. a section of load effects::

    Section("Load effects", ["Bending moments from ...", Table(df, "Maxima"),
                             Figure(fig, "moment.png", "Bending moment envelope")])

:func:`write_markdown` writes the PNG files next to ``report.md`` and links them;
:func:`write_html` embeds them as base64 PNG, renders the Markdown with markdown-it
(CommonMark + tables) and needs nothing outside the file (no fonts, scripts or images
from the network; links other than anchors and relative paths are not rendered).

Text blocks and captions are Markdown written by the report: a name or field from a
configuration or a results file goes into them through
:func:`~vsi_numba.analysis.report.safe.md` (shown literally). Table cells are text
unless marked :class:`Markdown`.
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from vsi_numba.analysis.figure_file import savefig
from vsi_numba.analysis.report.atomic import checkpoint
from vsi_numba.analysis.report.safe import clean, local_link, markdown_document, md

#: Resolution of the embedded and written PNGs (dots per inch).
DPI = 150


class Markdown(str):
    """A string that is Markdown written by the report (``**FAIL**``), shown as markup in
    a :class:`Table`; every other string of a table is shown literally."""

    __slots__ = ()


@dataclass
class Table:
    """A table block: ``frame`` rendered as is (column names are the header).

    Cells are shown with ``str`` (floats with :attr:`float_format`). Strings are text,
    shown literally (:func:`~vsi_numba.analysis.report.safe.md`: names from a
    configuration or a results file cannot make a link, an image or a row); a
    :class:`Markdown` string is inline Markdown (``Markdown("**FAIL**")``).
    """

    frame: pd.DataFrame
    caption: str = ""
    float_format: str = "{:.4g}"

    def cells(self) -> tuple[list[str], list[list[str]]]:
        """Header and rows as strings."""

        def show(v) -> str:
            if isinstance(v, float | np.floating):
                return "–" if not np.isfinite(v) else self.float_format.format(float(v))
            if v is None or (isinstance(v, str) and not v):
                return "–"
            return str(v) if isinstance(v, Markdown) else md(v)

        header = [str(c) if isinstance(c, Markdown) else md(c) for c in self.frame.columns]
        rows = [[show(v) for v in row] for row in self.frame.itertuples(index=False)]
        return header, rows


@dataclass
class Figure:
    """A figure block: a matplotlib figure (or PNG bytes) saved as ``name``."""

    figure: object
    name: str
    caption: str = ""
    _png: bytes | None = field(default=None, repr=False)

    def png(self) -> bytes:
        """The PNG bytes, rendered once at :data:`DPI` and the figure's own size (the
        figures of :mod:`vsi_numba.analysis.plots` use constrained layout with legends
        outside the axes, so nothing is clipped); the matplotlib figure is released
        afterwards."""
        if self._png is None:
            if isinstance(self.figure, bytes | bytearray):
                self._png = bytes(self.figure)
            else:
                buf = io.BytesIO()
                savefig(self.figure, buf, format="png", dpi=DPI)
                self._png = buf.getvalue()
                self.figure = None  # let matplotlib free it
        return self._png


Block = str | list | Table | Figure


@dataclass
class Section:
    """A titled section of blocks; ``level`` 2 is a chapter (a new page in print)."""

    title: str
    blocks: list = field(default_factory=list)
    level: int = 2
    anchor: str = ""

    @classmethod
    def from_markdown(cls, lines: list[str]) -> Section | None:
        """A section from Markdown lines starting with a ``## Title`` line (None if
        empty)."""
        lines = list(lines)
        while lines and not lines[0].strip():
            lines.pop(0)
        if not lines:
            return None
        head = lines[0]
        if head.startswith("#"):
            level = len(head) - len(head.lstrip("#"))
            return cls(head.lstrip("#").strip(), ["\n".join(lines[1:])], level=level)
        return cls("", ["\n".join(lines)], level=0)

    def slug(self) -> str:
        """The anchor of the title, as GitHub makes it (lower case, spaces to ``-``)."""
        if self.anchor:
            return self.anchor
        keep = "".join(ch for ch in self.title.lower() if ch.isalnum() or ch in " -_")
        return keep.strip().replace(" ", "-")


# --------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------


def markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A GitHub pipe table (``|`` in cells escaped)."""

    def row(cells):
        return "| " + " | ".join(clean(c).replace("|", "\\|") for c in cells) + " |"

    return [row(header), "|" + "|".join("---" for _ in header) + "|", *map(row, rows)]


def _text(block) -> str:
    return "\n".join(block) if isinstance(block, list) else str(block)


def section_markdown(section: Section, figures: list[Figure], numbers: dict) -> list[str]:
    """Markdown lines of one section; figures are appended to ``figures`` and numbered
    in ``numbers`` ("figure", "table")."""
    out = []
    if section.title and section.level:
        out += ["#" * section.level + " " + section.title, ""]
    for block in section.blocks:
        if isinstance(block, Table):
            numbers["table"] += 1
            if block.caption:
                out += [f"*Table {numbers['table']}: {block.caption}*", ""]
            out += [*markdown_table(*block.cells()), ""]
        elif isinstance(block, Figure):
            numbers["figure"] += 1
            figures.append(block)
            n = numbers["figure"]
            out += [f"![Figure {n}]({block.name})", "", f"*Figure {n}: {block.caption}*", ""]
        else:
            text = _text(block).strip("\n")
            if text:
                out += [text, ""]
    return out


def write_markdown(sections: list[Section], path: Path, title: str = "") -> Path:
    """Write ``path`` (Markdown) and the sections' figures as PNG beside it."""
    path = Path(path)
    lines = [f"# {md(title)}", ""] if title else []
    figures: list[Figure] = []
    numbers = {"figure": 0, "table": 0}
    for s in sections:
        lines += section_markdown(s, figures, numbers)
    for fig in figures:
        (path.parent / fig.name).write_bytes(fig.png())
        checkpoint()
    text = markdown_document("\n".join(lines).rstrip("\n") + "\n",
                             images={fig.name for fig in figures})
    path.write_text(text, encoding="utf-8")
    checkpoint()
    return path


# --------------------------------------------------------------------------------------
# HTML
# --------------------------------------------------------------------------------------

_CSS = """
:root { --ink: #1d2327; --muted: #5f6b73; --rule: #c9d1d6; --head: #eef2f4;
        --fail: #b3261e; --pass: #1e6b34; }
html { font-family: "DejaVu Sans", "Segoe UI", Helvetica, Arial, sans-serif;
       color: var(--ink); font-size: 10.5pt; line-height: 1.4; }
body { max-width: 60rem; margin: 1.5rem auto; padding: 0 1.2rem; }
h1 { font-size: 1.7em; margin: 0 0 0.4em; }
h2 { font-size: 1.3em; border-bottom: 2px solid var(--rule); padding-bottom: 0.15em;
     margin-top: 1.8em; }
h3 { font-size: 1.1em; margin-top: 1.3em; }
p, li { orphans: 3; widows: 3; }
code { font-family: "DejaVu Sans Mono", Consolas, monospace; font-size: 0.9em;
       background: #f3f5f6; padding: 0 0.2em; overflow-wrap: anywhere; }
blockquote { margin: 0.8em 0; padding: 0.4em 0.9em; border-left: 4px solid #e0a800;
             background: #fff8e1; }
.table-wrap { overflow-x: auto; margin: 0.6em 0 1em; }
table { border-collapse: collapse; font-size: 0.86em; width: auto; }
th, td { border: 1px solid var(--rule); padding: 0.22em 0.5em; vertical-align: top;
         text-align: left; }
thead th { background: var(--head); }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
.wide table { font-size: 0.74em; }
.wide td { white-space: nowrap; }
.wide th { overflow-wrap: anywhere; }
.wide th:first-child { overflow-wrap: normal; white-space: nowrap; }
caption, .caption { caption-side: top; text-align: left; font-style: italic;
                    color: var(--muted); margin-bottom: 0.3em; }
figure { margin: 1em 0 1.4em; text-align: center; }
figure img { max-width: 100%; height: auto; }
figcaption { font-size: 0.88em; color: var(--muted); text-align: left; margin-top: 0.3em; }
.titleblock { border: 1.5px solid var(--ink); border-collapse: collapse; margin: 0.6em 0 1em; }
.titleblock th { width: 11em; background: var(--head); }
.toc ol { columns: 2; font-size: 0.95em; }
strong.fail, .verdict-fail { color: var(--fail); }
.footer { margin-top: 2em; color: var(--muted); font-size: 0.85em; }
@page { size: A4; margin: 16mm 14mm 18mm; }
@media print {
  html { font-size: 9.5pt; }
  body { max-width: none; margin: 0; padding: 0; }
  h2.chapter { break-before: page; page-break-before: always; }
  h2, h3, .caption { break-after: avoid; page-break-after: avoid; }
  figure, blockquote, .titleblock { break-inside: avoid; page-break-inside: avoid; }
  table { break-inside: auto; }
  tr, td, th { break-inside: avoid; page-break-inside: avoid; }
  thead { display: table-header-group; }
  .table-wrap { overflow: visible; }
  a { color: inherit; text-decoration: none; }
  .toc { display: none; }
}
"""

#: Before printing the title of the browser tab the script reports, for tests and
#: viewers, how many images decoded (``naturalWidth > 0``) out of how many.
_IMAGE_CHECK = """
window.addEventListener("load", function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.documentElement.setAttribute("data-images", ok + "/" + imgs.length);
});
"""


def _markdown_renderer():
    """markdown-it as the HTML writer uses it: raw HTML shown as text, links to anchors and
    relative paths only (:func:`~vsi_numba.analysis.sanitize.local_link`), and a Markdown
    image shown as its source text (the page's only images are its embedded figures)."""
    from markdown_it import MarkdownIt

    md_ = MarkdownIt("commonmark", {"html": False, "typographer": False}).enable("table")
    md_.validateLink = local_link  # the page fetches and links to nothing outside itself

    def image(tokens, idx, options, env):
        tok = tokens[idx]
        return html.escape(f"![{tok.content}]({tok.attrs.get('src', '')})")

    md_.add_render_rule("image", image)
    return md_


def _is_number(text: str) -> bool:
    t = text.replace("\\", "").replace("−", "-").replace("%", "").replace(" ", "").replace("*", "")
    for unit in ("m/s²", "mm", "kN", "km/h", "s", "m", "Hz"):
        t = t.removesuffix(unit)
    try:
        float(t)
    except ValueError:
        return False
    return True


def _html_table(table: Table, md, number: int) -> str:
    header, rows = table.cells()
    cls = ["num" if rows and all(_is_number(r[j]) or r[j] == "–" for r in rows) else ""
           for j in range(len(header))]

    def cell(tag, text, c):
        inner = md.renderInline(text)
        return f"<{tag}{f' class={chr(34)}{c}{chr(34)}' if c else ''}>{inner}</{tag}>"

    head = "".join(cell("th", h, c) for h, c in zip(header, cls, strict=True))
    body = "\n".join("<tr>" + "".join(cell("td", v, c) for v, c in zip(r, cls, strict=True))
                     + "</tr>" for r in rows)
    cap = (f"<caption>Table {number}: {md.renderInline(table.caption)}</caption>"
           if table.caption else "")
    wide = " wide" if len(header) > 8 else ""
    return (f'<div class="table-wrap{wide}"><table>{cap}<thead><tr>{head}</tr></thead>'
            f"<tbody>\n{body}\n</tbody></table></div>")


def _html_figure(fig: Figure, md, number: int) -> str:
    data = base64.b64encode(fig.png()).decode("ascii")
    alt = html.escape(f"Figure {number}: {fig.caption}", quote=True)
    return (f'<figure id="{html.escape(Path(fig.name).stem)}"><img src="data:image/png;base64,'
            f'{data}" alt="{alt}"><figcaption><strong>Figure {number}:</strong> '
            f"{md.renderInline(fig.caption)}</figcaption></figure>")


def _wrap_tables(rendered: str) -> str:
    """Markdown pipe tables rendered by markdown-it, wrapped so they scroll on screen."""
    return (rendered.replace("<table>", '<div class="table-wrap"><table>')
            .replace("</table>", "</table></div>"))


def write_html(sections: list[Section], path: Path, title: str,
               header: list[Section] | None = None) -> Path:
    """Write one self-contained HTML file of ``sections``.

    Parameters
    ----------
    sections : list of Section
        The chapters (level-2 sections start a new page in print).
    path : path
        The ``.html`` file.
    title : str
        Document title (``<h1>`` and ``<title>``).
    header : list of Section, optional
        Sections shown before the table of contents on the first page (title block,
        warnings), never on a page of their own.
    """
    md = _markdown_renderer()
    numbers = {"figure": 0, "table": 0}
    title = clean(title)
    body: list[str] = [f"<h1>{html.escape(title)}</h1>"]

    def render(section: Section, chapter: bool) -> None:
        if section.title and section.level:
            tag = f"h{min(max(section.level, 2), 6)}"
            cls = ' class="chapter"' if chapter and section.level == 2 else ""
            body.append(f'<{tag} id="{html.escape(section.slug())}"{cls}>'
                        f"{md.renderInline(section.title)}</{tag}>")
        for block in section.blocks:
            if isinstance(block, Table):
                numbers["table"] += 1
                body.append(_html_table(block, md, numbers["table"]))
            elif isinstance(block, Figure):
                numbers["figure"] += 1
                body.append(_html_figure(block, md, numbers["figure"]))
            else:
                text = _text(block).strip("\n")
                if text:
                    body.append(_wrap_tables(md.render(text)))

    for s in header or []:
        render(s, chapter=False)
    chapters = [s for s in sections if s.title and s.level == 2]
    if len(chapters) > 2:
        items = "".join(f'<li><a href="#{html.escape(s.slug())}">{md.renderInline(s.title)}'
                        "</a></li>" for s in chapters)
        body.append(f'<nav class="toc"><strong>Contents</strong><ol>{items}</ol></nav>')
    for i, s in enumerate(sections):
        render(s, chapter=i > 0)
    doc = ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
           "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
           f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n"
           f"<script>{_IMAGE_CHECK}</script>\n</head>\n<body>\n"
           + "\n".join(body) + "\n</body>\n</html>\n")
    path = Path(path)
    path.write_text(doc, encoding="utf-8")
    checkpoint()
    return path
