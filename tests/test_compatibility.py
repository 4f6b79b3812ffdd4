"""``vsi init --template compatibility`` -> ``vsi sweep --report``: the report answers
whether the train is compatible with the bridge, names the governing check and its
margin, which the test reads back from the report's own summary table of checks."""

from __future__ import annotations

import re

import pandas as pd
import pytest
from typer.testing import CliRunner

from vsi_numba.cli.app import app
from vsi_numba.config import ConfigError, load_config


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _template(tmp_path, speeds="[330.0]", extra=""):
    cfg = tmp_path / "compat.toml"
    r = _cli("init", cfg, "--template", "compatibility")
    assert r.exit_code == 0, r.output
    text = cfg.read_text()
    # fewer speeds than the template (140 to 330 km/h every 5 km/h): the test's time
    text = re.sub(r"speeds_kmh = \{[^}]*\}", f"speeds_kmh = {speeds}", text)
    cfg.write_text(text + extra)
    return cfg


@pytest.mark.parametrize("limit, word", [(None, "COMPATIBLE"), (0.3, "NOT COMPATIBLE")])
def test_compatibility__report_gives_the_verdict_governing_check_and_margin(tmp_path, limit,
                                                                           word):
    extra = ("" if limit is None else
             f"\n[code_profile]\noverrides = {{ deck_acceleration_limit_ballasted = "
             f"{limit} }}\n")
    cfg = _template(tmp_path, extra=extra)
    rep = tmp_path / "report"
    r = _cli("sweep", cfg, "-q", "--report", rep)
    assert r.exit_code == 0, r.output
    text = (rep / "report.md").read_text()
    body = text.split("## Compatibility", 1)[1].split("\n## ", 1)[0]
    assert f"**{word}**: train ICE3" in body
    assert "up to 1.1 × 300 = 330 km/h" in body
    # the governing check is the row of largest utilisation of the report's summary
    summary = pd.read_csv(rep / "summary.csv")
    rated = summary[summary["result"].isin(["pass", "FAIL"])].dropna(subset=["utilisation"])
    gov = rated.loc[rated["utilisation"].idxmax()]
    assert f"Governing check: **{gov['check']}**" in body
    assert f"margin **{100 * (1 - gov['utilisation']):+.1f} %**" in body
    assert ("FAIL" in set(rated["result"])) == (word == "NOT COMPATIBLE")
    assert "HSLM-A envelope" in body and (rep / "signature.png").exists()
    if limit is None:  # a report replaces an earlier one, its signature figure included
        r = _cli("report", tmp_path / "results" / "compat.nc", "-o", rep)
        assert r.exit_code == 0, r.output


def test_compatibility__speeds_must_reach_the_line_speed_plus_margin(tmp_path):
    cfg = _template(tmp_path, speeds="[300.0, 320.0]")
    cfg.write_text(cfg.read_text().replace("history_speeds_kmh = [330.0]",
                                           "history_speeds_kmh = [320.0]"))
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    assert any(e.startswith("study.speeds_kmh = [300.0, 320.0]: expected speeds up to "
                            "330 km/h = 1.1 x compatibility.line_speed_kmh = 300")
               for e in exc.value.errors), exc.value.errors
    text = re.sub(r'^train = "ICE3"', 'train = "ICE4"', cfg.read_text(), flags=re.M)
    cfg.write_text(text.replace("[300.0, 320.0]", "[330.0]").replace("[320.0]", "[330.0]"))
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    assert any(e.startswith('compatibility.train = "ICE4": expected one of the study\'s '
                            "trains (ICE3)") for e in exc.value.errors), exc.value.errors


def test_init__unknown_template_is_refused(tmp_path):
    r = _cli("init", tmp_path / "x.toml", "--template", "bogus")
    assert r.exit_code == 2 and "--template 'bogus'" in r.output
