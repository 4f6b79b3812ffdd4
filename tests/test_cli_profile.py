"""`vsi profile`: the table and the PNG of a config's irregularity profiles."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from vsi_numba.cli import app

ROOT = Path(__file__).resolve().parents[1]


def test_cli_profile__table_and_png(tmp_path):
    png = tmp_path / "profiles.png"
    res = CliRunner().invoke(app, ["profile", str(ROOT / "configs" / "ice3_continuous.toml"),
                                   "--plot", str(png)])
    assert res.exit_code == 0, res.output
    assert "german_low" in res.output and "seed=2" in res.output
    assert png.stat().st_size > 10_000  # a rendered figure, not an empty file
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_profile__config_error_exits_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[bridge]\nkind = 'nope'\n")
    res = CliRunner().invoke(app, ["profile", str(bad)])
    assert res.exit_code == 2
    assert "bridge.kind" in res.output
