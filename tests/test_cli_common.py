"""`vsi_numba.cli.common`: the printer and the config loader every command uses."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import Printer, load_config, load_config_and_output

ROOT = Path(__file__).resolve().parents[1]


def test_printer__user_text_is_literal_and_one_line(capsys):
    pr = Printer()
    text = "a [bold]path[/] :smile: " + "x" * 200
    pr.line(text)
    pr.error(text)
    pr.warning(text)
    cap = capsys.readouterr()
    assert cap.out == text + "\n"
    assert cap.err == f"error: {text}\nwarning: {text}\n"


def test_load_config__error_names_the_file_and_every_problem(tmp_path, capsys):
    bad = tmp_path / "b[x].toml"
    bad.write_text("[bridge]\nkind = 'nope'\n")
    assert load_config(bad, Printer()) is None
    err = capsys.readouterr().err
    assert err.startswith(f"error: {bad}: invalid configuration\n")
    assert "bridge.kind" in err and "train" in err and "study" in err


def test_load_config_and_output__refuses_the_input_as_output(tmp_path, capsys):
    config = tmp_path / "c.toml"
    config.write_text((ROOT / "configs" / "quickstart.toml").read_text(encoding="utf-8"))
    assert load_config_and_output(config, config, Printer()) is None
    err = " ".join(capsys.readouterr().err.split())
    assert err.startswith("error: the output") and "refusing to overwrite the input" in err
    cfg, out = load_config_and_output(config, tmp_path / "r.nc", Printer())
    assert out == tmp_path / "r.nc" and cfg.title
