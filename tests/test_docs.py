"""The documentation builds from the repository with no warning (``-W``), as the README
and docs/conf.py say: ``python -m sphinx -W -b html docs docs/_build/html``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_docs__build_without_warnings(tmp_path):
    pytest.importorskip("sphinx", reason="sphinx is not installed (pip install -e '.[docs]')")
    pytest.importorskip("myst_parser",
                        reason="myst-parser is not installed (pip install -e '.[docs]')")
    out = tmp_path / "html"
    res = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html",
                          "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"), str(out)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    for page in ("index", "manual/user_guide", "manual/theory", "manual/config",
                 "manual/verification", "manual/api"):
        assert (out / f"{page}.html").is_file(), page
    # every .md page others add to docs/ is linked from the index (the glob toctree)
    index = (out / "index.html").read_text(encoding="utf-8")
    for md in (ROOT / "docs").glob("*.md"):
        if md.stem != "index":
            assert f'href="{md.stem}.html"' in index, md.name
    # the key reference is rendered from the config package's docstring
    keys = (out / "manual" / "config.html").read_text(encoding="utf-8")
    assert "hertz_coefficient" in keys and "speeds_kmh" in keys
    # the verification table is rendered from the CSV kept beside the page
    table = (out / "manual" / "verification.html").read_text(encoding="utf-8")
    assert "V01-0.5" in table and "V08-x" in table


def test_gallery__every_bundled_config_has_its_entry():
    """docs/gallery.md shows every config of configs/: its section names the file, its
    figure and results table are committed beside the page, and the script that makes
    them runs it."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "make_figures", ROOT / "docs" / "gallery" / "make_figures.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    page = (ROOT / "docs" / "gallery.md").read_text(encoding="utf-8")
    stems = sorted(p.stem for p in (ROOT / "configs").glob("*.toml"))
    assert sorted(script.GALLERY) == stems
    for stem in stems:
        assert f"`configs/{stem}.toml`" in page, stem
        assert f"(gallery/{stem}.png)" in page and f"gallery/{stem}.csv" in page, stem
        assert (ROOT / "docs" / "gallery" / f"{stem}.png").stat().st_size > 10_000, stem
        rows = (ROOT / "docs" / "gallery" / f"{stem}.csv").read_text("utf-8").splitlines()
        assert rows[0] == "result,value,limit,verdict,where" and len(rows) > 1, stem
