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
