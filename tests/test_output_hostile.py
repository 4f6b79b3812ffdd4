"""Text from inputs is data in every output format: one set of hostile strings through every
free-text key of a configuration that reaches an output, config -> ``vsi sweep --report``
-> every file of the report (and the terminal).

The strings (:data:`LEADS` + :data:`BODY`): a Markdown image and link to a remote host,
raw HTML (``<script>``, ``<img onerror>``), spreadsheet formulas (``=HYPERLINK(...)``,
``+1``, ``-1+2``, ``@SUM(...)``, a leading tab or carriage return), control characters
(NUL, VT, ESC, CR, tab), math text that does not parse (``$\\frac{$``), and a very long
one.  The keys (:mod:`vsi_numba.config.schema.models`): ``title``, ``train.name``,
``train.vehicles[].name``, ``train.axles.name``, the name of an axle file (the name of
a ``[[fatigue.traffic]]`` train), an imported deck's track (``bridge.tracks[].line`` and the
``line`` column of its modes table), a measured track profile's file and column names
(``irregularity.path``, ``x_column``, ``r_column``), ``[report]``, ``[code_profile] name`` and an
override's ``clause``, ``[[fatigue.sections]] name``, ``[compatibility] train``, with
``train.other_trains`` on a second track; the resolved configuration stored in the
results file carries them all (the report's input echo shows it; a re-run that fails
quotes it).  Each case gives every key another of the leading strings, so that over the
cases every kind of text (the train's name, a clause, a section name, a vehicle, a
[report] field, the title) starts with every one of them.

Every output is checked as a reader would open it: ``report.md`` parsed by markdown-it
with raw HTML on (no raw HTML, no link but anchors and the report's files, no image but
its figures), ``report.html`` parsed (one script, the page's own; images embedded; no
link outside the page), every CSV read with :mod:`csv` and ``tables.xlsx`` with openpyxl
(no formula cell, no text cell starting with ``= + - @``, tab or CR; numbers, a negative
margin among them, stay numbers), and every text drawn in a figure recorded at drawing
time (none parsed as math text but the program's own labels, no control character; the
strings shown literally).
"""

from __future__ import annotations

import csv
import json
import re
from html.parser import HTMLParser

import matplotlib.text
import numpy as np
import openpyxl
import pytest
from markdown_it import MarkdownIt
from typer.testing import CliRunner

from vsi_numba.cli import app

BODY = ("$\\frac{$ ![i](https://example.invalid/i.png) [l](https://example.invalid/x) "
        "<img src=x onerror=alert(1)> <script>alert(1)</script> a\tb\rc\x00d\x0be\x1bf")
LEADS = ('=HYPERLINK("https://example.invalid/x","click")', "+1", "-1+2", "@SUM(1,2)",
         "\t", "\r")
#: What a spreadsheet may take for a formula at the start of a cell (OWASP).
FORMULA = ("=", "+", "-", "@", "\t", "\r")
#: Parts of the strings that every output shows, literally, somewhere.
SHOWN = ("$\\frac{$", "<script>alert(1)</script>", "<img src=x onerror=alert(1)>")
#: Keys of the configuration of a beam deck (case "beam") and of an imported deck ("modes").
BEAM_KEYS = ("title", "train.name", "train.vehicles[0].name", "train.vehicles[1].name",
             "report.project", "report.checked_by", "code_profile.overrides.clause",
             "code_profile.overrides.clause (2)", "fatigue.sections[0].name",
             "fatigue.sections[1].name", "fatigue.studs[0].name", "code_profile.name")
VARIANTS_KEYS = ("title", "train.name", "study.vary_together.label[0]",
                 "study.vary_together.label[1]")
MODES_KEYS = ("title", "train.axles.name", "bridge.tracks[0].line", "report.client",
              "irregularity.x_column", "irregularity.r_column")
#: A file name holds no "/" and no NUL: the axle file named by the strings that can be.
FILE_NAME = "=1+2 $\\frac{$ <img src=x onerror=alert(1)> ![i](x.png) \x1b"


def _strings(keys, shift: int, long: bool) -> dict[str, str]:
    """Key ``i`` gets the leading string ``LEADS[(i + shift) % 6]``."""
    out = {}
    for i, key in enumerate(keys):
        text = f"{LEADS[(i + shift) % len(LEADS)]} {key} {BODY}"
        if long:
            text += " " + "long " * 1000
        if key.startswith("report."):  # [report] fields hold one line of <= 200 characters
            text = text[:200]
        if key in ("bridge.tracks[0].line", "irregularity.x_column",
                   "irregularity.r_column"):  # a CSV reader skips a cell's leading blanks
            text = text.lstrip()
        out[key] = text
    return out


def _q(text: str) -> str:
    return json.dumps(text)  # a TOML basic string is a JSON string for these characters


def _beam_config(d, s: dict) -> str:
    (d / f"{FILE_NAME}.csv").write_text("position,load\n0,100\n3,100\n")
    return f"""title = {_q(s['title'])}
[bridge]
kind = "simply_supported"
spans = [10.0]
EI = 5e9
mass_per_length = 5000.0
n_modes = 1
output_points = [5.0]
tracks = [{{ eccentricity = 0.0 }}, {{ eccentricity = -2.0 }}]
[train]
name = {_q(s['train.name'])}
other_trains = [{{ track = 2 }}]
[[train.vehicles]]
kind = "force"
load = 1e5
name = {_q(s['train.vehicles[0].name'])}
[[train.vehicles]]
kind = "force"
offset = 3.0
load = 1e5
name = {_q(s['train.vehicles[1].name'])}
[solver]
dt = 2e-3
free_vibration = 0.1
approach = 1.0
[study]
speeds_kmh = [110.0]
output = "out.nc"
[report]
project = {_q(s['report.project'])}
checked_by = {_q(s['report.checked_by'])}
[code_profile]
name = {_q(s['code_profile.name'])}
# a limit below the response: the check fails and its margin is negative
[code_profile.overrides]
deck_acceleration_limit_ballasted = {{ value = 0.05, clause = {
    _q(s['code_profile.overrides.clause'])} }}
deck_acceleration_limit_direct_fastening = {{ value = 5.0, clause = {
    _q(s['code_profile.overrides.clause (2)'])} }}
[fatigue]
[[fatigue.sections]]
x = 5.0
section_modulus = 0.05
detail_category = 71
name = {_q(s['fatigue.sections[0].name'])}
[[fatigue.sections]]
x = 2.5
section_modulus = 0.05
detail_category = 71
name = {_q(s['fatigue.sections[1].name'])}
[[fatigue.studs]]
x = 2.5
diameter = 0.022
per_row = 4
row_spacing = 0.15
first_moment = 0.057
second_moment = 0.105
name = {_q(s['fatigue.studs[0].name'])}
[[fatigue.traffic]]
train = {_q(FILE_NAME + '.csv')}
speed_kmh = 100.0
per_day = 10
[compatibility]
train = {_q(s['train.name'])}
line_speed_kmh = 100.0
"""


def _variants_config(d, s: dict) -> str:
    """Two variants of the beam deck, named by ``vary_together``'s label."""
    return f"""title = {_q(s['title'])}
[bridge]
kind = "simply_supported"
spans = [10.0]
EI = 5e9
mass_per_length = 5000.0
n_modes = 1
output_points = [5.0]
[train]
name = {_q(s['train.name'])}
[[train.vehicles]]
kind = "force"
load = 1e5
[solver]
dt = 2e-3
free_vibration = 0.1
approach = 1.0
[study]
speeds_kmh = [110.0]
output = "out.nc"
vary_together = [{{ label = [{_q(s['study.vary_together.label[0]'])}, {
    _q(s['study.vary_together.label[1]'])}], "bridge.EI" = [5e9, 6e9] }}]
"""


def _modes_config(d, s: dict) -> str:
    """An imported deck: a modes table of one sine mode on the line of the track, and a
    moving-force train from an axle file."""
    length, ei, m = 10.0, 5e9, 5000.0
    f = (np.pi / length) ** 2 * np.sqrt(ei / m) / (2 * np.pi)
    with open(d / "modes.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["mode", "frequency", "modal_mass", "line", "x", "shape"])
        for x in np.linspace(0.0, length, 41):
            w.writerow([1, f, m * length / 2, s["bridge.tracks[0].line"], x,
                        np.sin(np.pi * x / length)])
    (d / f"{FILE_NAME}.csv").write_text("position,load\n0,100\n3,100\n")
    with open(d / f"{FILE_NAME}.irr.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)  # a measured profile, flat: the results do not depend on it
        w.writerow([s["irregularity.x_column"], s["irregularity.r_column"]])
        w.writerows([[x, 0.0] for x in np.linspace(-50.0, 50.0, 201)])
    return f"""title = {_q(s['title'])}
[irregularity]
kind = "file"
path = {_q(FILE_NAME + '.irr.csv')}
x_column = {_q(s['irregularity.x_column'])}
r_column = {_q(s['irregularity.r_column'])}
[bridge]
kind = "modes_file"
file = "modes.csv"
tracks = [{{ line = {_q(s['bridge.tracks[0].line'])} }}]
output_points = [5.0]
[train]
axles = {{ file = {_q(FILE_NAME + '.csv')}, name = {_q(s['train.axles.name'])} }}
[solver]
dt = 2e-3
free_vibration = 0.1
approach = 1.0
[study]
speeds_kmh = [110.0]
output = "out.nc"
[report]
client = {_q(s['report.client'])}
[compatibility]
train = {_q(s['train.axles.name'])}
line_speed_kmh = 100.0
"""


class _Drawn:
    """Every text matplotlib draws: (text, drawn as math text)."""

    def __init__(self, monkeypatch):
        self.texts: list[tuple[str, bool, str | None]] = []
        draw = matplotlib.text.Text.draw

        def spy(text, renderer):
            s = text.get_text()
            self.texts.append((s, text._preprocess_math(s)[1], text.get_gid()))
            return draw(text, renderer)

        monkeypatch.setattr(matplotlib.text.Text, "draw", spy)


class _Html(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.refs = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for name, value in attrs:
            if name in ("src", "href", "srcset", "action", "poster", "data", "formaction") \
                    or name.startswith("on"):
                self.refs.append((tag, name, value or ""))


def _own_link(page, href: str) -> bool:
    """An anchor, or a file of the report (the governing variant's report)."""
    return href.startswith("#") or (
        "://" not in href and not href.startswith(("/", "\\")) and ".." not in href
        and (page.parent / href).is_file())


def _check_markdown(rep):
    parser = MarkdownIt("commonmark", {"html": True}).enable("table")
    parser.validateLink = lambda url: True  # as permissive as a renderer may be
    pages = sorted(rep.rglob("report.md"))
    assert pages
    for page in pages:
        text = page.read_text(encoding="utf-8")
        figures = {p.name for p in page.parent.glob("*.png")}
        for tok in parser.parse(text):
            assert tok.type != "html_block", (page, tok.content)
            for t in tok.children or []:
                assert t.type != "html_inline", (page, "raw HTML", t.content)
                if t.type == "link_open":
                    assert _own_link(page, t.attrs["href"]), (page, "link", t.attrs)
                elif t.type == "image":
                    assert t.attrs["src"] in figures, (page, "image", t.attrs)
        assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", text), (page, "control character")
        shown = re.sub(r"\\(.)", r"\1", text)
        for part in SHOWN:
            assert part in shown, (page, "does not show", part)


def _check_html(rep):
    pages = sorted(rep.rglob("report.html"))
    assert pages
    for path in pages:
        page = path.read_text(encoding="utf-8")
        p = _Html()
        p.feed(page)
        assert p.tags.count("script") == 1, (path, "a script besides the page's own")
        for tag, name, value in p.refs:
            assert not name.startswith("on"), (path, "event handler", tag, name, value)
            if tag == "img":
                assert value.startswith("data:image/png;base64,"), (path, value[:80])
            else:
                assert name == "href" and _own_link(path, value), (path, tag, name, value)
        assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", page), (path, "control character")
        assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _check_csv(rep, failing: bool):
    files = sorted(rep.rglob("*.csv"))
    assert len(files) > 2
    for path in files:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
        for row in rows:
            for c in row:
                if c.startswith(FORMULA):  # a number written as a number, nothing else
                    assert _is_number(c), (path.name, c[:80])
                assert not re.search(r"[\x00-\x1f\x7f]", c), (path.name, c[:80])
    if not failing:
        return
    with open(rep / "summary.csv", newline="", encoding="utf-8") as fh:
        summary = list(csv.DictReader(fh))
    acc = next(r for r in summary if r["check"].startswith("Peak deck acceleration"))
    assert float(acc["margin"]) < 0 and acc["result"] == "FAIL"  # a number, not a text


def _check_xlsx(rep, failing: bool):
    books = sorted(rep.rglob("*.xlsx"))
    assert books
    n_text = 0
    for path in books:
        for sheet in openpyxl.load_workbook(path).worksheets:
            for row in sheet.iter_rows():
                for c in row:
                    assert c.data_type != "f", (path.name, sheet.title, c.coordinate, c.value)
                    if c.data_type == "s":
                        n_text += 1
                        assert not str(c.value).startswith(FORMULA), (
                            path.name, sheet.title, c.coordinate, str(c.value)[:80])
    assert n_text > 50
    if not failing:
        return
    summary = openpyxl.load_workbook(rep / "tables.xlsx")["summary"]
    head = [c.value for c in summary[1]]
    margins = [r[head.index("margin")] for r in summary.iter_rows(min_row=2)]
    acc = next(r for r in summary.iter_rows(min_row=2)
               if str(r[0].value).startswith("Peak deck acceleration"))
    assert acc[head.index("margin")].data_type == "n" and acc[head.index("margin")].value < 0
    assert all(c.data_type == "n" or c.value is None for c in margins)


def _check_figures(rep, drawn: _Drawn):
    assert len(list(rep.rglob("*.png"))) >= 3
    hostile = [(s, math) for s, math, gid in drawn.texts if "onerror" in s or "frac" in s]
    assert hostile, "no figure shows a hostile string"
    for s, math, _ in drawn.texts:
        assert not re.search(r"[\x00-\x09\x0b-\x1f\x7f]", s), ("figure text", s[:80])
        if "onerror" in s or "frac" in s:
            assert not math, ("figure text parsed as math text", s[:80])
    assert any("$\\frac{$" in s for s, _ in hostile)  # shown literally


def _run(tmp_path, monkeypatch, text):
    drawn = _Drawn(monkeypatch)
    (tmp_path / "study.toml").write_text(text, encoding="utf-8")
    rep = tmp_path / "report"
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "study.toml"), "-q",
                                   "--report", str(rep)])
    assert res.exit_code == 0, res.output + repr(res.exception)
    assert "Traceback" not in res.output
    # the terminal is an output too: no escape sequence, carriage return or NUL
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", res.output), res.output
    return rep, drawn


def _check_all(rep, drawn, failing: bool):
    _check_markdown(rep)
    _check_html(rep)
    _check_csv(rep, failing)
    _check_xlsx(rep, failing)
    _check_figures(rep, drawn)


# Three runs of each deck: key i of the beam deck starts with LEADS[(i + 2k) % 6], key i of
# the imported deck with LEADS[(i + 2k + 1) % 6].  A key given twice (vehicles, [report]
# fields, override clauses, fatigue sections) at an even and an odd index, and a key of
# both decks (title, [report], the train's name: train.name at index 1 of the beam deck,
# train.axles.name at index 1 of the imported one), gets all six; the last beam run has
# the long strings.
# A study of variants (its own report, variants.csv and design chart, and the governing
# variant's report) once, its labels given the leading strings of three runs.
@pytest.mark.parametrize("case", [
    *[("beam", 2 * k, k == 2) for k in range(3)],
    *[("modes", 2 * k + 1, False) for k in range(3)],
    ("variants", 3, False),
], ids=lambda c: f"{c[0]}-{c[1]}{'-long' if c[2] else ''}")
def test_output_hostile__every_key_into_every_format(tmp_path, monkeypatch, case):
    kind, shift, long = case
    keys, config = {"beam": (BEAM_KEYS, _beam_config), "modes": (MODES_KEYS, _modes_config),
                    "variants": (VARIANTS_KEYS, _variants_config)}[kind]
    text = config(tmp_path, _strings(keys, shift, long))
    rep, drawn = _run(tmp_path, monkeypatch, text)
    _check_all(rep, drawn, failing=kind == "beam")
    if kind == "modes":
        # the results moved without their axle file: the report's re-runs fail with a
        # message quoting the stored configuration (the file's hostile name)
        (tmp_path / f"{FILE_NAME}.csv").unlink()
        drawn.texts.clear()
        again = tmp_path / "again"
        res = CliRunner().invoke(app, ["report", str(tmp_path / "out.nc"), "-o", str(again)])
        assert res.exit_code == 0, res.output + repr(res.exception)
        assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", res.output), res.output
        assert "cannot be re-run" in (again / "report.md").read_text(encoding="utf-8")
        _check_all(again, drawn, failing=False)
