"""The client report: one self-contained HTML file and the Markdown from the same
sections, the input echo and title block, tables of maxima (wheel unloading on the deck
and on the approach separately), CSV/XLSX exports, and a real headless browser.

References are brute-force numpy reductions over the envelopes written into the test
file, or values set by construction; the browser test skips where no Chromium is
installed (CI machines with only Python).
"""

from __future__ import annotations

import base64
import json
import re
import shutil
import struct
import subprocess

import numpy as np
import openpyxl
import pandas as pd
import pytest
import xarray as xr

from vsi_numba.analysis.checks import run_checks
from vsi_numba.analysis.dataset import envelopes
from vsi_numba.analysis.plots import new_figure
from vsi_numba.analysis.report import tables as tbl
from vsi_numba.analysis.report import write_report
from vsi_numba.analysis.report.document import Figure, Section, Table, write_html, write_markdown
from vsi_numba.analysis.report.echo import fmt_list, fmt_number
from vsi_numba.analysis.report.text import _provenance
from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.config import ConfigError, load_config

L = 20.0  # m, deck length of the synthetic results

CONFIG = {
    "title": "synthetic",
    "bridge": {"kind": "continuous", "spans": [20.0, 20.0], "EI": 1.508e10,
               "mass_per_length": 15000.0, "damping_ratio": 0.015,
               "additional_damping": 0.004, "n_modes": 4},
    "train": {"preset": ["HSLM-A1", "ICE3"]},
    "solver": {"dt": 0.0005, "hht_alpha": -0.3, "approach": 110.0, "free_vibration": 0.5},
    "track": {"model": "elastic", "foundation_stiffness": 8.5e7, "rail_EI": 1.283e7},
    "contact": {"model": "hertz", "hertz_coefficient": 2.65e-8},
    "irregularity": {"kind": "none"},
    "study": {"speeds_kmh": [250.0, 300.0, 325.0, 350.0]},
    "report": {"project": "Viaduct V-12, km 104+300", "client": "Rail Infra",
               "revision": "C", "prepared_by": "A. Engineer", "checked_by": "B. Checker"},
}


def _results(histories=False, seeds=(-1,)) -> xr.Dataset:
    """HSLM-A1 as moving forces (prescribed contact forces) and ICE3 with interaction."""
    ds = synthetic_results(speeds_kmh=(250.0, 300.0, 325.0, 350.0),
                           trains=(("HSLM-A1", 18.0, 6, "standard"),
                                   ("ICE3", 24.775, 4, "transcribed")),
                           n_vehicles=2, bridge_length=L, histories=histories, n_time=60,
                           seeds=seeds)
    ds = ds.load()
    q0 = ds["static_wheel_load"].sel(train="HSLM-A1")
    for name in ("min_contact_force", "max_contact_force"):  # prescribed: never changes
        ds[name].loc[{"train": "HSLM-A1"}] = q0.broadcast_like(
            ds[name].sel(train="HSLM-A1"))
    ds["max_wheel_unloading"].loc[{"train": "HSLM-A1"}] = 0.0
    rng = np.random.default_rng(3)
    pos = rng.uniform(-120.0, 2 * L + 100.0, ds["position_of_min_contact_force"].shape)
    pos[..., ::2] = rng.uniform(0.0, L, pos[..., ::2].shape)  # half the axles on the deck
    ds["position_of_min_contact_force"][:] = pos
    ds.attrs["config_json"] = json.dumps(CONFIG)
    ds.attrs["config_sha256"] = "ab" * 32
    ds.attrs["dt"] = 0.0005
    return ds


def _png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


# --------------------------------------------------------------------------------------
# number formats and the [report] keys
# --------------------------------------------------------------------------------------


def test_fmt_number__engineering_notation_of_the_report():
    assert fmt_number(1.508e10, "N m²") == "1.508e10 N m²"
    assert fmt_number(7.16e10) == "7.16e10"
    assert fmt_number(18000.0, "kg/m") == "18000 kg/m"
    assert fmt_number(0.0005, "s") == "0.0005 s"
    assert fmt_number(-0.3) == "−0.3"
    assert fmt_number(np.nan) == "–"
    assert fmt_list([20.0, 20.0], "m", " + ") == "20 + 20 m"


def test_config_report__keys_validated_and_carried_in_the_resolved_config():
    data = {"title": "t", "bridge": {"kind": "simply_supported", "spans": [25.0],
                                     "EI": 8.323e9, "mass_per_length": 2303.0, "n_modes": 3},
            "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0,
                                    "stiffness": 1.595e6}]},
            "solver": {"dt": 1e-3}, "study": {"speeds_kmh": [100.0]}}
    plain = load_config(data)
    assert "report" not in plain.resolved()  # no section: the hash is unchanged
    data["report"] = {"project": " V-12 ", "revision": 2, "checked_by": "B. Checker"}
    cfg = load_config(data)
    assert cfg.resolved()["report"] == {"project": "V-12", "revision": "2",
                                        "checked_by": "B. Checker"}
    assert cfg.sha256 != plain.sha256
    data["report"] = {"checked_by": 3, "cheked_by": "x", "project": "two\nlines"}
    with pytest.raises(ConfigError) as info:
        load_config(data)
    errs = info.value.errors
    assert any(e.startswith("report.checked_by = 3: expected one line of text") for e in errs)
    assert any("report.cheked_by" in e and "did you mean 'checked_by'" in e for e in errs)
    assert any(e.startswith("report.project = ") for e in errs)
    data["report"] = "V-12"
    with pytest.raises(ConfigError, match=r'report = "V-12": expected a table \[report\]'):
        load_config(data)


# --------------------------------------------------------------------------------------
# sections -> Markdown and HTML
# --------------------------------------------------------------------------------------


def test_document__one_section_renders_to_markdown_and_self_contained_html(tmp_path):
    fig = new_figure(2.0)
    fig.subplots().plot([0, 1], [0, 1])
    frame = pd.DataFrame({"Train": ["A", "B|C"], "M [kN m]": [1.5e3, np.nan]})
    sec = Section("Load effects", ["Text with **bold** and `code`.",
                                   Table(frame, "Bending moments"),
                                   Figure(fig, "moment.png", "Moment envelope")])
    md = write_markdown([sec], tmp_path / "r.md", title="T").read_text(encoding="utf-8")
    assert md.startswith("# T\n\n## Load effects\n")
    assert "*Table 1: Bending moments*" in md
    assert "| Train | M [kN m] |" in md and "| B\\|C | – |" in md and "| A | 1500 |" in md
    assert "![Figure 1](moment.png)" in md and "*Figure 1: Moment envelope*" in md
    png = (tmp_path / "moment.png").read_bytes()
    assert _png_size(png) == (975, 300)  # 6.5 x 2 in at 150 dpi
    html = write_html([sec], tmp_path / "r.html", title="T").read_text(encoding="utf-8")
    assert "<strong>bold</strong>" in html and "<code>code</code>" in html
    assert "<caption>Table 1: Bending moments</caption>" in html
    assert '<td class="num">1500</td>' in html and "<td>B|C</td>" in html
    data = re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert len(data) == 1 and base64.b64decode(data[0]) == png
    assert not re.search(r'(src|href)="(https?:)?//|<link|@import|url\(', html)


def test_write_report__extra_section_slots_into_both_formats(tmp_path):
    frame = pd.DataFrame({"Point": ["mid-span"], "M [kN m]": [1234.5]})

    def load_effects(env, results):
        assert "time" not in env.dims and "deck_acceleration" in results
        fig = new_figure(2.0)
        fig.subplots().plot([0, 1], [1, 0])
        return Section("Load effects", ["Bending moment at mid-span.",
                                        Table(frame, "Bending moment"),
                                        Figure(fig, "bending_moment.png", "Bending moment")])

    md = write_report(_results(), tmp_path / "rep", n_boot=0, recompute=False,
                      sections=[load_effects])
    text = md.read_text(encoding="utf-8")
    html = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    assert "## Load effects" in text and "| mid-span | 1234 |" in text
    assert (tmp_path / "rep" / "bending_moment.png").is_file()
    assert ">Load effects</h2>" in html and "<td>mid-span</td>" in html
    # every figure of the Markdown is embedded in the HTML, and nothing else
    n_md = len(re.findall(r"^!\[Figure \d+\]\(", text, flags=re.M))
    assert n_md >= 4 and html.count('<img src="data:image/png;base64,') == n_md


# --------------------------------------------------------------------------------------
# input echo and title block
# --------------------------------------------------------------------------------------


def test_write_report__input_echo_and_title_block(tmp_path):
    md = write_report(_results(), tmp_path / "rep", n_boot=0, recompute=False)
    text = md.read_text(encoding="utf-8")
    html = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    for doc in (text, html):
        for value in ("Viaduct V-12, km 104+300", "Rail Infra", "B. Checker", "A. Engineer",
                      "ab" * 32, "20 + 20 m", "1.508e10 N m²", "15000 kg/m", "0.0005 s",
                      "−0.3", "110 m", "hertz, G = 2.65e−8 m N^−2/3", "1.283e7 N m²",
                      "5.000, 20.000, 45.000, 80.000 Hz (4 modes)"):
            assert value in doc, value
    # damping per train: Delta-zeta for the moving-force train only (6.4.6.3.1)
    rows = {r.split("|")[1].strip(): [c.strip() for c in r.strip("|").split("|")]
            for r in text.splitlines() if r.startswith(("| HSLM-A1 |", "| ICE3 |"))
            and "%" in r}
    assert rows["HSLM-A1"][1:] == ["moving forces", "1.5 %", "0.4 %",
                                   fmt_number(100 * (0.015 + 0.004), "%")]
    assert rows["ICE3"][1:] == ["interaction (multibody)", "1.5 %", "0 %", "1.5 %"]
    # the provenance names the results file without the machine's path
    text2 = "\n".join(_provenance(_results(), tmp_path / "deep" / "results.nc"))
    assert "`results.nc`" in text2 and str(tmp_path) not in text2


# --------------------------------------------------------------------------------------
# maxima and the deck / approach split
# --------------------------------------------------------------------------------------


def _zones_brute_force(ds):
    """dQ/Q0 per (speed, train) on the deck and the approach by loops over the records."""
    dq = ds["max_wheel_unloading"].values
    x = ds["position_of_min_contact_force"].values
    fixed = (ds["min_contact_force"] == ds["max_contact_force"]).all(
        ["speed", "irregularity"]).values  # (train, wheel)
    ns, nt, nr, nw = dq.shape
    deck = np.full((ns, nt), np.nan)
    appr = np.full((ns, nt), np.nan)
    appr_x = np.full((ns, nt), np.nan)
    for i in range(ns):
        for j in range(nt):
            for r in range(nr):
                for w in range(nw):
                    v = dq[i, j, r, w]
                    if fixed[j, w] or not np.isfinite(v):
                        continue
                    if 0.0 <= x[i, j, r, w] <= L:
                        deck[i, j] = np.fmax(deck[i, j], v)
                    elif not appr[i, j] >= v:
                        appr[i, j], appr_x[i, j] = v, x[i, j, r, w]
    return deck, appr, appr_x


def test_wheel_unloading_by_zone__deck_and_approach_against_loops():
    ds = _results(seeds=(1, 2, 3))
    # by construction: the largest unloading of the study sits on the approach
    at = {"speed": ds["speed"].values[1], "train": "ICE3", "irregularity": 2, "wheel": 1}
    ds["max_wheel_unloading"].loc[at] = 0.93
    ds["position_of_min_contact_force"].loc[at] = -104.6
    env = envelopes(ds)
    zones = tbl.wheel_unloading_by_zone(env)
    deck, appr, appr_x = _zones_brute_force(env)
    # exact: both are maxima of the same float64 values
    np.testing.assert_array_equal(zones["deck"].transpose("speed", "train").values, deck)
    np.testing.assert_array_equal(zones["approach"].transpose("speed", "train").values, appr)
    np.testing.assert_array_equal(zones["approach_x"].transpose("speed", "train").values,
                                  appr_x)
    assert bool(zones["deck"].sel(train="HSLM-A1").isnull().all())  # moving forces
    table = tbl.wheel_unloading_zones_table(zones).set_index("Train")
    row = table.iloc[1]
    assert row["ΔQ/Q₀ max"] == 0.93 and row["x of the axle [m]"] == -104.6
    assert row["Speed [km/h]"] == 300.0 and row["Axle"] == "1"
    assert table.iloc[0]["ΔQ/Q₀ max"] == np.nanmax(deck)
    n_deck = int(((env["position_of_min_contact_force"] >= 0)
                  & (env["position_of_min_contact_force"] <= L)).sel(train="ICE3")
                 .where(env["max_wheel_unloading"].sel(train="ICE3").notnull()).sum())
    assert table.iloc[0]["Records (run × axle)"] == n_deck


def test_maxima_tables__against_numpy_reductions():
    ds = envelopes(_results(seeds=(1, 2)))
    results = run_checks(ds, n_boot=0)
    zones = tbl.wheel_unloading_by_zone(ds)
    per_train = tbl.maxima_per_train(ds, results, zones).set_index("Train")
    per_point = tbl.maxima_per_point(ds).set_index("x [m]")
    d = ds["max_deck_displacement"].values  # (speed, train, irr, point)
    a = ds["max_deck_acceleration"].values
    kmh = ds["speed_kmh"].values
    for j, train in enumerate(ds["train"].values):
        dj = d[:, j]
        i, _, p = np.unravel_index(np.nanargmax(dj), dj.shape)
        assert per_train.loc[train, "δ max [mm]"] == 1e3 * dj.max()
        assert per_train.loc[train, "δ: speed [km/h]"] == kmh[i]
        assert per_train.loc[train, "δ: x [m]"] == ds["point"].values[p]
        v = results["deck_acceleration"]["value"].sel(train=train).values
        assert per_train.loc[train, "a max [m/s²]"] == np.nanmax(v)
        assert per_train.loc[train, "a: speed [km/h]"] == kmh[np.nanargmax(v)]
    deck, appr, _ = _zones_brute_force(ds)
    assert per_train.loc["ICE3", "ΔQ/Q₀ deck [–]"] == np.nanmax(deck[:, 1])
    assert per_train.loc["ICE3", "ΔQ/Q₀ appr. [–]"] == np.nanmax(appr[:, 1])
    for k, x in enumerate(ds["point"].values):
        ak = a[..., k]
        i, j, _ = np.unravel_index(np.nanargmax(ak), ak.shape)
        assert per_point.loc[x, "a max [m/s²]"] == ak.max()
        assert per_point.loc[x, "a: train"] == ds["train"].values[j]
        assert per_point.loc[x, "a: speed [km/h]"] == kmh[i]


def test_write_report__csv_and_xlsx_with_units_in_every_header(tmp_path):
    ds = _results()
    write_report(ds, tmp_path / "rep", n_boot=0, recompute=False)
    folder = tmp_path / "rep" / "tables"
    names = {p.stem for p in folder.glob("*.csv")}
    assert {"deck_acceleration", "deck_displacement", "dynamic_increment",
            "wheel_unloading_deck", "wheel_unloading_approach", "min_contact_force",
            "carbody_acceleration"} <= names
    unit = re.compile(r".+ \[[^\]]+\]$")
    for name in names:
        frame = pd.read_csv(folder / f"{name}.csv")
        assert all(unit.match(c) for c in frame.columns), (name, list(frame.columns))
        assert list(frame.columns) == ["speed [km/h]", *(
            f"{t} [{frame.columns[1].rsplit('[', 1)[1]}" for t in ds["train"].values)]
    disp = pd.read_csv(folder / "deck_displacement.csv")
    ref = 1e3 * ds["max_deck_displacement"].max(["point", "irregularity"])
    # written with 7 significant digits
    np.testing.assert_allclose(disp["ICE3 [mm]"], ref.sel(train="ICE3").values, rtol=5e-6)
    np.testing.assert_allclose(disp["speed [km/h]"], [250, 300, 325, 350])
    book = openpyxl.load_workbook(tmp_path / "rep" / "tables.xlsx", read_only=True)
    assert {"contents", "summary", "maxima_per_train", "maxima_per_point",
            "wheel_unloading_zones", *names} <= set(book.sheetnames)
    for name in names:
        header = next(book[name].iter_rows(max_row=1, values_only=True))
        assert all(unit.match(str(c)) for c in header), (name, header)
    acc = pd.read_excel(tmp_path / "rep" / "tables.xlsx", sheet_name="deck_acceleration")
    check = run_checks(envelopes(ds), n_boot=0)["deck_acceleration"]["value"]
    # the sheet holds the check's values to 7 significant digits (a rounding of at most
    # 5e-7 relative; the last digits are noise between machines)
    np.testing.assert_allclose(acc["HSLM-A1 [m/s2]"], check.sel(train="HSLM-A1").values,
                               rtol=1e-6)


# --------------------------------------------------------------------------------------
# a real browser
# --------------------------------------------------------------------------------------

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)


def _chromium(tmp_path, *args, timeout=120) -> subprocess.CompletedProcess:
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", f"--user-data-dir={tmp_path / 'chromium-profile'}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium on PATH: the HTML report is not "
                    "checked in a browser here (apt install chromium to run this test)")
def test_report_html__renders_in_headless_chromium_with_every_image_decoded(tmp_path):
    ds = _results(histories=True)
    write_report(ds, tmp_path / "rep", n_boot=0, recompute=False)
    page = tmp_path / "rep" / "report.html"
    html = page.read_text(encoding="utf-8")
    n_img = html.count("<img ")
    assert n_img >= 5
    # self-contained: every image inline, nothing fetched (no links, imports or urls)
    assert html.count('<img src="data:image/png;base64,') == n_img
    assert not re.search(r'(src|href)="(https?:)?//|<link|@import|url\(', html)
    dom = _chromium(tmp_path, "--virtual-time-budget=5000", "--dump-dom", page.as_uri())
    assert dom.returncode == 0, dom.stderr[-2000:]
    # the page's own script counts the images that decoded (naturalWidth > 0) on load
    assert f'data-images="{n_img}/{n_img}"' in dom.stdout, dom.stdout[:300]
    shot = tmp_path / "shot.png"
    res = _chromium(tmp_path, f"--screenshot={shot}", "--window-size=1280,4000",
                    page.as_uri())
    assert res.returncode == 0 and shot.is_file(), res.stderr[-2000:]
    assert _png_size(shot.read_bytes()) == (1280, 4000)
    from matplotlib.image import imread

    pixels = imread(shot)[..., :3]
    assert float(pixels.std()) > 0.05  # text, tables and figures, not a blank page
    pdf = tmp_path / "report.pdf"
    res = _chromium(tmp_path, f"--print-to-pdf={pdf}", "--no-pdf-header-footer",
                    page.as_uri())
    assert res.returncode == 0 and pdf.read_bytes()[:5] == b"%PDF-"
    pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf.read_bytes()))
    assert pages >= 6  # a new page per chapter (print stylesheet)


def test_bridge_description__numbers_formatted_for_reports_and_figures():
    from vsi_numba.model import bridge

    beam = bridge.simply_supported(25.0, EI=1.508e10, mass_per_length=15000.0, n_modes=1)
    assert beam.description == "simply supported, L = 25 m, EI = 1.508e10 N m2, m = 15000 kg/m"
    deck = bridge.continuous([20.0, 20.0], EI=1.508e10, mass_per_length=15000.0, n_modes=2)
    assert deck.description == "continuous deck, spans 20 + 20 m"


def test_figures__legends_inside_the_figure_and_only_for_trains_with_curves():
    from vsi_numba.analysis import plots

    trains = tuple((f"Long train name number {j}", 18.0 + j, 4, "standard") for j in range(11))
    ds = synthetic_results(speeds_kmh=np.arange(140.0, 425.0, 5.0), trains=trains,
                           seeds=(1, 2), n_vehicles=2, bridge_length=L).load()
    ds["max_carbody_acceleration"].loc[{"train": ds["train"].values[:8]}] = np.nan
    env = envelopes(ds)
    results = run_checks(env, n_boot=0)
    zones = tbl.wheel_unloading_by_zone(env)
    figs = {"deck": plots.plot_deck_acceleration(env, results["deck_acceleration"]),
            "wheels": plots.plot_wheel_unloading(env, results["wheel_unloading"], zones),
            "comfort": plots.plot_comfort(env, results["comfort"])}
    for name, fig in figs.items():
        renderer = fig.canvas.get_renderer()
        fig.draw(renderer)
        box = fig.bbox
        for legend in fig.legends:
            ext = legend.get_window_extent(renderer)
            assert ext.x0 >= box.x0 - 0.5 and ext.x1 <= box.x1 + 0.5, name  # not cut
            assert ext.y0 >= box.y0 - 0.5, name
    labels = [t.get_text() for t in figs["comfort"].legends[0].get_texts()]
    drawn = [str(t) for t in ds["train"].values[8:]]
    assert [x for x in labels if x.startswith("Long train")] == drawn
    # the lines of neighbouring trains differ in dash pattern as well as colour
    lines = [ln for ln in figs["deck"].axes[0].get_lines() if ln.get_label() in
             {str(t) for t in ds["train"].values}]
    assert len(lines) == 11
    styles = plots.train_styles(ds["train"].values)
    names = [ln.get_label() for ln in lines]
    for a, b in zip(names[:-1], names[1:], strict=True):
        assert styles[a]["linestyle"] != styles[b]["linestyle"]
        assert styles[a]["color"] != styles[b]["color"]
    assert all(ln.get_color() == styles[ln.get_label()]["color"] for ln in lines)
