"""Text from configurations and results files is shown, never rendered: a Markdown image
or link, a carriage return or line feed, ``|``, ``<script>`` and ``$\\frac{$`` as train
names, ``[report]`` fields, the title and a stored warning, through ``vsi report``. The
report keeps its structure (one title block row per field, one summary), the figures
are drawn, and the HTML makes no request outside itself: checked statically (every
src / href / url() of the page) and, where Chromium is installed, in the browser with a
net log (a page with a remote image is the control that the log shows such a request).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from html.parser import HTMLParser

import pytest
from typer.testing import CliRunner

from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.cli import app

IMAGE = "![i](http://127.0.0.1:9/i.png)"
LINK = "[l](https://example.com/x)"
SCRIPT = "<script>alert(1)</script>"
MATH = "$\\frac{$"
FORGED = "\n## Summary of checks\n- forged | pass |"
TRAINS = (f"HSLM-A10 {IMAGE}", f"HSLM-A2 {LINK} a|b", f"HSLM-A1 {MATH} {SCRIPT}{FORGED}")
REPORT = {"project": IMAGE, "client": LINK, "document": "D\r| **Checked by** | Forged |",
          "revision": "R|S", "prepared_by": MATH, "checked_by": SCRIPT,
          "approved_by": "A" + FORGED}


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    """``vsi report`` of a results file whose train names, [report] fields, title and
    warnings are hostile."""
    d = tmp_path_factory.mktemp("hostile")
    ds = synthetic_results(speeds_kmh=(250.0, 300.0),
                           trains=tuple((name, 18.0, 6, "standard") for name in TRAINS),
                           n_vehicles=2, histories=True, n_time=40)
    cfg = json.loads(ds.attrs["config_json"])
    cfg["report"] = REPORT
    ds.attrs["config_json"] = json.dumps(cfg)
    ds.attrs["title"] = f"Title {IMAGE} {MATH}\r{SCRIPT}"
    ds.attrs["warnings_json"] = json.dumps([{"message": f"warned {LINK}{FORGED}",
                                             "kind": "input", "keys": []}])
    ds.to_netcdf(d / "h.nc")
    res = CliRunner().invoke(app, ["report", str(d / "h.nc"), "-o", str(d / "rep")])
    return d / "rep", res


def test_report_hostile__report_written_with_figures(hostile):
    rep, res = hostile
    assert res.exit_code == 0, res.output
    assert "Traceback" not in res.output
    for name in ("deck_acceleration.png", "time_history.png", "report.md", "report.html",
                 "summary.csv", "tables.xlsx"):
        assert (rep / name).is_file(), name  # the $\frac{$ train did not stop the figures


def _md_tokens(text):
    from markdown_it import MarkdownIt

    return MarkdownIt("commonmark").enable("table").parse(text)


def test_report_hostile__markdown_keeps_its_structure(hostile):
    rep, _ = hostile
    md = (rep / "report.md").read_text(encoding="utf-8")
    lines = md.splitlines()
    # one summary, one row per title-block field, nothing forged
    assert lines.count("## Summary of checks") == 1
    assert not [ln for ln in lines if ln.startswith("- forged")]
    assert sum(ln.startswith("| **Checked by** |") for ln in lines) == 1
    row = next(ln for ln in lines if ln.startswith("| **Revision** |"))
    assert row.count(" | ") == 1  # R|S stays in its cell
    # the only links and images are the report's own (anchors, its PNG files); a CR/LF
    # is shown as a control picture
    inline = [t for tok in _md_tokens(md) for t in (tok.children or [])]
    assert not [t for t in inline if t.type == "html_inline"]
    for t in inline:
        if t.type == "link_open":
            assert t.attrs["href"].startswith("#"), t.attrs
        elif t.type == "image":
            assert (rep / t.attrs["src"]).is_file() and "/" not in t.attrs["src"], t.attrs
    assert "D␍" in md and "␊## Summary of checks␊" in md
    # every hostile text is still there, shown (escapes only)
    shown = re.sub(r"\\(.)", r"\1", md)
    for text in (IMAGE, LINK, SCRIPT, MATH, "R|S"):
        assert text in shown, text


class _Refs(HTMLParser):
    """Every tag, and every attribute that can fetch or link."""

    def __init__(self):
        super().__init__()
        self.tags, self.refs = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for name, value in attrs:
            if name in ("src", "href", "srcset", "action", "poster", "data", "formaction"):
                self.refs.append((tag, name, value or ""))


def test_report_hostile__html_refers_to_nothing_outside_itself(hostile):
    rep, _ = hostile
    html = (rep / "report.html").read_text(encoding="utf-8")
    p = _Refs()
    p.feed(html)
    assert p.tags.count("script") == 1  # the page's own image check only
    for tag, name, value in p.refs:
        if tag == "img":
            assert value.startswith("data:image/png;base64,"), value[:80]
        else:
            assert name == "href" and value.startswith("#"), (tag, name, value)
    assert not re.search(r"url\(|@import|<link|<iframe|<object|<embed", html)
    assert html.count("<strong>Checked by</strong>") == 1  # the title block's own row
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html and IMAGE in html


CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)


def _page_requests(tmp_path, page) -> list[str]:
    """URLs the page itself asked for (net log: requests whose network isolation key is
    the page's file:// site; the browser's own background requests have others)."""
    log = tmp_path / f"{page.stem}.netlog.json"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp_path / 'chromium-profile'}", f"--log-net-log={log}",
           # the network is off: nothing resolves, the proxy is a closed port
           "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
           "--virtual-time-budget=3000", "--dump-dom", page.as_uri()]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
    assert res.returncode == 0, res.stderr[-2000:]
    data = json.loads(log.read_text())
    kinds = {v: k for k, v in data["constants"]["logEventTypes"].items()}
    return [e["params"]["url"] for e in data["events"]
            if kinds.get(e["type"]) == "URL_REQUEST_START_JOB"
            and "file://" in str(e.get("params", {}).get("network_isolation_key", ""))
            and not e["params"].get("url", "").startswith(("file:", "data:"))]


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium on PATH: the hostile report is "
                    "not opened in a browser here (apt install chromium to run this test)")
def test_report_hostile__no_request_leaves_the_page_in_chromium(hostile, tmp_path):
    rep, _ = hostile
    control = tmp_path / "control.html"
    control.write_text('<html><body><img src="http://127.0.0.1:9/x.png"></body></html>')
    assert _page_requests(tmp_path, control) == ["http://127.0.0.1:9/x.png"]
    assert _page_requests(tmp_path, rep / "report.html") == []
