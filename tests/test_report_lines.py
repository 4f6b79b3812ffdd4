"""Lines of the report a checking engineer signs, through the user's path (config ->
``vsi sweep --report`` / ``vsi report`` -> netCDF -> report): a check that was not made
never reads as passed, every value names its quantity and place, one value per quantity
in every table, a number shown to the digits its verdict hinges on, the configuration's
files found where the configuration was.
"""

from __future__ import annotations

import math
import re
import shutil
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app

ROOT = Path(__file__).resolve().parents[1]

# a 20 m simply supported span with f1 = 6 Hz: f1 = pi / (2 L^2) sqrt(EI / m)
SPAN, MASS = 20.0, 1.0e4
F1 = 6.0
EI = MASS * (F1 * 2 * SPAN**2 / math.pi) ** 2
N_AXLES, SPACING, LOAD_KN = 11, 10.0, 170.0  # a train of axles 10 m apart: D = 10 m


def write_axles(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "axles.csv").write_text(
        "position,load\n" + "".join(f"{SPACING * i:g},{LOAD_KN:g}\n" for i in range(N_AXLES)))


def axle_deck(speeds, extra_study="", output="out.nc") -> str:
    return textwrap.dedent(f"""
        title = "regular axles on a 20 m span"
        [bridge]
        kind = "simply_supported"
        spans = [{SPAN}]
        EI = {EI!r}
        mass_per_length = {MASS}
        damping_ratio = 0.01
        [train]
        axles = {{ file = "axles.csv", load_unit = "kN" }}
        [solver]
        dt = 1e-3
        free_vibration = 0.3
        [study]
        speeds_kmh = {list(speeds)}
        output = "{output}"
        {extra_study}
        """)


def sweep_report(folder: Path, text: str, name: str = "deck") -> tuple[str, Path]:
    """``vsi sweep CONFIG -q --report`` in ``folder``: the report's Markdown and the
    report directory."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text)
    rep = folder / f"{name}_report"
    res = CliRunner().invoke(app, ["sweep", str(path), "-q", "--report", str(rep)])
    assert res.exit_code == 0, res.output
    return (rep / "report.md").read_text(), rep


def section(text: str, title: str) -> str:
    s = text[text.index(f"## {title}"):]
    end = s.find("\n## ", 5)
    return s if end < 0 else s[:end]


def cells(row: str) -> list[str]:
    """The cells of a Markdown table row; a ``\\|`` inside a cell (an escaped bar, as in
    ``|T|``) is the cell's text, not a separator."""
    parts = re.split(r"(?<!\\)\|", row.strip().strip("|"))
    return [c.strip().replace("\\|", "|") for c in parts]


def table_rows(text: str, first: str) -> list[list[str]]:
    """The rows (cells) of the Markdown table whose header starts with ``first``."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith(f"| {first} |"):
            out = []
            for row in lines[i + 2:]:
                if not row.startswith("|"):
                    break
                out.append(cells(row))
            return out
    raise AssertionError(f"no table starting with {first!r}")


# ------------------------------------------------------------------ 1. resonance checked


def test_convergence__train_of_axles_gets_its_resonance_checked(tmp_path):
    write_axles(tmp_path)
    text, _ = sweep_report(tmp_path, axle_deck([190.0, 240.0]))
    conv = section(text, "Convergence of the governing cases")
    v_res = 3.6 * F1 * SPACING  # 216 km/h: f1 D, D the axles' spacing (closed form)
    acc = [r for r in table_rows(conv, "Quantity and place")
           if r[0].startswith("Peak deck acceleration")][0]
    assert f"{v_res:.1f} km/h" in acc[6] and acc[7] == "**FLAG**", acc
    assert "Every governing result is converged" not in conv
    # the regular length the trains table states is the spacing
    train = table_rows(section(text, "Trains"), "Train")[0]
    assert float(train[2]) == SPACING and f"**{v_res:.0f}**" in train[6]
    # the value at the resonance speed is what a run at that speed gives, and above the
    # grid's (a run of it, as a user would make it)
    summary_acc = float(re.match(r"([\d.]+)", acc[2]).group(1))
    res_text, _ = sweep_report(tmp_path / "at", axle_deck([v_res]).replace(
        '"axles.csv"', f'"{(tmp_path / "axles.csv").as_posix()}"'))
    at_res = float(pd.read_csv(tmp_path / "at" / "deck_report" / "summary.csv")
                   .set_index("check").loc["Peak deck acceleration", "value"])
    assert f"{v_res:.1f} km/h: {at_res:.4g} m/s²" in acc[6]
    assert at_res > 1.05 * summary_acc


def test_refine_resonance__adds_the_resonance_speed_of_a_train_of_axles(tmp_path):
    write_axles(tmp_path)
    path = tmp_path / "deck.toml"
    path.write_text(axle_deck([190.0, 240.0], "refine_resonance = true"))
    res = CliRunner().invoke(app, ["sweep", str(path), "-q"])
    assert res.exit_code == 0, res.output
    v_res = 3.6 * F1 * SPACING
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        kmh = np.asarray(ds["speed_kmh"].values, float)
        assert float(ds["train_regular_length"].values[0]) == SPACING
    # v_res and v_res +- 1 km/h, to the 0.1 km/h of the refinement
    for v in (v_res - 1, v_res, v_res + 1):
        assert np.min(abs(kmh - round(v, 1))) < 1e-6, kmh


def test_convergence__a_train_without_regular_length_says_the_check_was_not_made(tmp_path):
    # three axles at irregular spacings: no regular length
    (tmp_path / "axles.csv").write_text("position,load\n0,170\n7.3,170\n19.1,170\n")
    text, _ = sweep_report(tmp_path, axle_deck([190.0, 240.0]))
    conv = section(text, "Convergence of the governing cases")
    assert "**Not checked** — resonance speeds of axles between the grid speeds not " \
           "checked: train axles has no regular length D" in conv
    assert "Every governing result is converged" not in conv
    summary = section(text, "Summary of checks")
    assert "- convergence of the governing cases:" in summary


# ----------------------------------------------- 5, 6. the viaduct: modes, one quantity


def test_report__viaduct_no_missing_modes_note_and_one_acceleration(tmp_path_factory):
    # configs/double_track_viaduct.toml at 300 and 320 km/h with HSLM-A1 through ``vsi
    # sweep --report``, made once per run with test_space_config's test of it
    from test_space_config import viaduct_sweep_and_report

    tmp_path = viaduct_sweep_and_report(tmp_path_factory)
    rep = tmp_path / "r"
    text = (rep / "report.md").read_text()
    bridge = section(text, "Bridge")
    # every mode up to the 30 Hz cut-off is kept (bridge.max_frequency = 30): no note
    assert "left out" not in bridge and "missing" not in bridge, bridge
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        assert int(ds.attrs["modes_left_out_below_cutoff"]) == 0
        assert float(ds["frequency"].max()) < float(ds.attrs["acceleration_cutoff_hz"])
    # the convergence re-run checks the summary's quantity: along track 1, the same value
    summary = pd.read_csv(rep / "summary.csv").set_index("check")
    value = float(summary.loc["Peak deck acceleration", "value"])
    conv = section(text, "Convergence of the governing cases")
    acc = [r for r in table_rows(conv, "Quantity and place")
           if r[0].startswith("Peak deck acceleration")][0]
    assert "track 1" in acc[0] and re.search(r"x = [\d.]+ m", acc[0]), acc
    assert acc[2] == acc[3] == f"{value:.4g} m/s²", (acc, value)
    # the value is the one along track 1 in the file (the check's variable)
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        along = float(ds["max_track_acceleration_whole_deck"].sel(track=1).max())
        axis = float(ds["max_deck_acceleration_whole_deck"].max())
    # summary.csv keeps 7 significant digits
    assert math.isclose(value, max(along, axis), rel_tol=1e-6) and along > 1.2 * axis


def test_report__modes_left_out_below_the_cutoff_are_named(tmp_path):
    # 2 modes kept of a deck whose f3 = 9 f1 = 27 Hz is below the 30 Hz cut-off
    f1 = 3.0
    ei = MASS * (f1 * 2 * SPAN**2 / math.pi) ** 2
    write_axles(tmp_path)
    text, _ = sweep_report(tmp_path, axle_deck([150.0]).replace(
        f"EI = {EI!r}", f"EI = {ei!r}\nn_modes = 2"))
    bridge = section(text, "Bridge")
    assert "1 mode of the deck below the cut-off 30.00 Hz is left out of the model " \
           f"({9 * f1:.2f} Hz)" in bridge, bridge


# ------------------------------------------------------ 7. wheel unloading on the bridge


def exit_dip_deck(tmp_path) -> tuple[str, Path]:
    """A single interaction car on a 20 m span and a cosine dip on the exit track 15 m
    past the deck, reached by the front bogie only (the run ends as the last axle
    leaves the deck): the front axles unload there far more than any axle on the deck."""
    return sweep_report(tmp_path, textwrap.dedent(f"""
        title = "a dip on the exit track"
        [bridge]
        kind = "simply_supported"
        spans = [{SPAN}]
        EI = {EI!r}
        mass_per_length = {MASS}
        damping_ratio = 0.01
        [train]
        preset = "manchester_benchmark_single"
        model = "interaction"
        [irregularity]
        kind = "cosine"
        depth = 0.003
        wavelength = 3.0
        position = {SPAN + 15.0}
        [solver]
        dt = 5e-4
        free_vibration = 0.0
        [study]
        speeds_kmh = [200.0]
        output = "out.nc"
        """))


def test_wheel_unloading__the_bridge_check_takes_the_deck_and_its_transitions(tmp_path):
    from vsi_numba.analysis.checks.wheels import TRANSITION_ZONE

    text, rep = exit_dip_deck(tmp_path)
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        dq = np.asarray(ds["max_wheel_unloading"].values, float).ravel()
        x = np.asarray(ds["position_of_min_contact_force"].values, float).ravel()
    zone = (x >= -TRANSITION_ZONE) & (x <= SPAN + TRANSITION_ZONE)
    assert zone.any() and (~zone).any()  # the case is what it is meant to be
    bridge, approach = np.nanmax(dq[zone]), np.nanmax(dq[~zone])
    assert approach > 5 * bridge and approach < 0.6
    summary = pd.read_csv(rep / "summary.csv").set_index("check")
    row = summary.loc["Wheel unloading ΔQ/Q₀"]
    # summary.csv keeps 7 significant digits
    assert math.isclose(float(row["value"]), bridge, rel_tol=1e-6)
    # the exit-track records bound their axles' unloading on the bridge by 0.44 < 0.6
    assert row["result"] == "pass"
    info = [c for c in summary.index if c.startswith("Wheel unloading ΔQ/Q₀ on the approach")]
    assert len(info) == 1 and summary.loc[info[0], "result"] == "info"
    assert math.isclose(float(summary.loc[info[0], "value"]), approach, rel_tol=1e-6)
    lines = section(text, "Summary of checks").splitlines()
    # the headline bullet: the bridge's value in bold, the approach's labelled information
    line = [ln for ln in lines if ln.startswith("- Wheel unloading by where")][0]
    assert f"**{bridge:.3f}**" in line and f"**{approach:.3f}**" not in line
    assert f"{approach:.3f}" in line and "information, not the bridge's check" in line
    # the bound on the axles whose minimum lay off the bridge, on the check's own line
    check = [ln for ln in lines if ln.startswith("- Wheel unloading (axles whose")][0]
    assert f"between {bridge:.3f} and {approach:.3f}" in check


# ----------------------------------------------------------- 8. digits of a verdict


def ratio_deck(alpha: float) -> str:
    """HSLM-A1 at its second resonance (f1 D / 2 = 320 km/h, f1 = 9.87 Hz) on a 15 m
    span: the trains' bending moment about LM71's."""
    return textwrap.dedent(f"""
        title = "ratio"
        [bridge]
        kind = "simply_supported"
        spans = [15.0]
        EI = 2e10
        mass_per_length = 1.0e4
        damping_ratio = 0.005
        [train]
        preset = ["HSLM-A1"]
        [solver]
        dt = 2e-3
        free_vibration = 0.2
        [study]
        speeds_kmh = [320.0]
        output = "out.nc"
        classification_factor = {alpha!r}
        """)


def test_summary__a_ratio_is_shown_to_the_digits_its_verdict_hinges_on(tmp_path):
    check = "6.4.6.5(3) bending moment M: (1 + φ'dyn + φ''/2) × train / (Φ3 × α × LM71)"
    _, rep = sweep_report(tmp_path / "a", ratio_deck(1.0))
    r1 = float(pd.read_csv(rep / "summary.csv").set_index("check").loc[check, "value"])
    # the ratio is inversely proportional to alpha (LM71 x alpha in the denominator)
    alpha = r1 / 1.0049
    assert 0.75 <= alpha <= 1.46, r1
    text, rep = sweep_report(tmp_path / "b", ratio_deck(alpha))
    row = pd.read_csv(rep / "summary.csv").set_index("check").loc[check]
    assert math.isclose(float(row["value"]), 1.0049, rel_tol=1e-6)
    assert row["result"].startswith("HSLM") or "real" in row["result"] or "train" in \
        row["result"].lower()
    cells = [r for r in table_rows(section(text, "Summary of checks"), "Check")
             if r[0] == check.replace("|", "\\|")][0]
    assert cells[1] == "1.005" and cells[2] == "1", cells
    verdict = [r for r in table_rows(section(text, "Load effects"), "Effect")
               if r[0] == "bending moment M"][0]
    assert verdict[5] == "1.005", verdict


# ------------------------------------------- 10. the configuration's files where it was


def test_report__elsewhere_finds_the_configurations_files_or_says_what_is_missing(
        tmp_path, monkeypatch):
    conf = tmp_path / "project" / "configs"
    write_axles(conf)
    (conf / "deck.toml").write_text(axle_deck([200.0], output="../results/out.nc"))
    res = CliRunner().invoke(app, ["sweep", str(conf / "deck.toml"), "-q"])
    assert res.exit_code == 0, res.output
    results = tmp_path / "project" / "results" / "out.nc"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    res = CliRunner().invoke(app, ["report", str(results), "-o", str(elsewhere / "rep")])
    assert res.exit_code == 0, res.output
    text = (elsewhere / "rep" / "report.md").read_text()
    conv = section(text, "Convergence of the governing cases")
    assert "Not checked" not in conv and table_rows(conv, "Quantity and place")
    # the configuration's folder gone: the summary says which section is missing and why
    shutil.move(conf, tmp_path / "moved")
    res = CliRunner().invoke(app, ["report", str(results), "-o", str(elsewhere / "rep2")])
    assert res.exit_code == 0, res.output
    text = (elsewhere / "rep2" / "report.md").read_text()
    summary = section(text, "Summary of checks")
    assert "- convergence of the governing cases (time step, resonance speeds between " \
           "the grid speeds): the governing cases cannot be re-run" in summary
    assert "axles.csv" in summary


# ------------------------------------------------ every bundled config: signable lines

#: Results of a summary row that are verdicts (info and n/a rows are not).
VERDICTS = ("pass", "**FAIL**", "**not reliable**", "**FAIL (not reliable)**",
            "**not determined**")


def _toml(data: dict, prefix: str = "") -> str:
    """A TOML text of ``data`` (tables, arrays of tables, strings, numbers, booleans,
    arrays): enough for the bundled configurations."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return "[" + ", ".join(value(x) for x in v) + "]"

    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {value(v)}")
    out = "\n".join(lines) + "\n"
    for k, v in tables:
        name = f"{prefix}{k}"
        out += f"\n[{name}]\n" + _toml(v, f"{name}.")
    return out


def reduced(config: Path) -> dict:
    """The bundled configuration ``config`` at one speed, with its first train and
    first realisation and a short free vibration (the same checks, a fraction of the
    runs)."""
    import tomllib

    data = tomllib.loads(config.read_text())
    study = data["study"]
    speeds = study.get("speeds_kmh")
    if isinstance(speeds, dict):
        speed = float(speeds["start"])
    elif speeds:
        speed = float(list(speeds)[-1])
    else:
        speed = float(study["line_speed_kmh"])
    study["speeds_kmh"] = [speed]
    study.pop("history_speeds_kmh", None)
    study["output"] = "out.nc"
    train = data.get("train", {})
    if isinstance(train.get("preset"), list):
        train["preset"] = train["preset"][:1]
    irr = data.get("irregularity", {})
    if isinstance(irr.get("seeds"), list):
        irr["seeds"] = irr["seeds"][:1]
    solver = data.setdefault("solver", {})
    solver["free_vibration"] = min(float(solver.get("free_vibration", 1.0)), 0.2)
    return data


def summary_rows(text: str) -> list[dict]:
    """The summary table's rows as {header: cell}."""
    summary = section(text, "Summary of checks")
    header = cells(summary.splitlines()[2])
    return [dict(zip(header, r, strict=True)) for r in table_rows(summary, "Check")]


PLACE = re.compile(r"x = -?[\d.]+ ?m|\bspan \d|\bsection\b|\btrack \d|\baxle \d|vehicle")


BUNDLED = sorted((ROOT / "configs").glob("*.toml"))


def test_bundled_configs__at_least_ten():
    assert len(BUNDLED) >= 10


@pytest.mark.slow  # a sweep and its report per bundled configuration (~7 s each)
@pytest.mark.parametrize("cfg", BUNDLED, ids=[c.stem for c in BUNDLED])
def test_report__every_bundled_config_states_each_verdicts_quantity_place_and_limit(
        tmp_path, cfg):
    shutil.copytree(ROOT / "configs" / "data", tmp_path / "data")
    text, rep = sweep_report(tmp_path, _toml(reduced(cfg)), cfg.stem)
    verdicts = [r for r in summary_rows(text) if r["Result"] in VERDICTS
                or r["Result"].endswith(("govern", "governs"))]
    assert verdicts, cfg.name
    for r in verdicts:
        where = f"{cfg.name}: {r['Check']}"
        assert r["Value"] not in ("", "–"), where  # the quantity's value
        assert r["Limit"] not in ("", "–"), where  # what the verdict is against
        assert r["Where"] != "–" or PLACE.search(r["Check"]), where  # the place
        assert PLACE.search(r["Where"]) or PLACE.search(r["Check"]) or \
            r["Where"].startswith("the deck"), where
    # the convergence rows name quantity and place; a check not made is listed
    conv = section(text, "Convergence of the governing cases")
    for row in (table_rows(conv, "Quantity and place")
                if "| Quantity and place |" in conv else []):
        assert "," in row[0] and row[7] in ("converged", "**FLAG**",
                                            "converged in dt; resonance not checked"), \
            (cfg.name, row)
    if "Not checked" in conv:
        assert "- convergence of the governing cases" in section(
            text, "Summary of checks"), cfg.name
    if "Every governing result is converged" in conv:
        assert "Not checked" not in conv, cfg.name
    shutil.rmtree(rep)
    (tmp_path / "out.nc").unlink()
