"""The gallery's committed numbers are recomputed: docs/gallery.md's tables are tests.

docs/gallery/make_figures.py runs every bundled config through the public command line
and writes, beside its figure, the config's main results (``<config>.csv``: each check
that applies, its value, limit, verdict and governing case).  Here the same commands run
in process on the same configs, the same function of the script reads the results file
(:func:`results_rows`, no figure drawn), and the rows must be the committed ones: the
values and limits as written (3 significant digits), the verdicts and the governing
train, speed and place exactly.  The engine gives the same numbers bit for bit
(``benchmarks/check_identity.py``), so any difference is a change of the gallery's
results: make_figures.py writes the tables again (and the figures) once the change is
meant.

Every entry is recomputed whole but the two viaducts' (HSLM-A over 45 speeds: the
double-track one, a deck in space, about 35 s of CPU; the 25 + 32 + 25 m one about 4 s):
they run on the governing cases their committed tables name (2 trains x 2 speeds, about
2 s; 1 train x 1 speed, under 1 s), which give every number of the tables, but not the
proof that no other case governs.  The file takes about 17 s of CPU with compiled
kernels.
"""

from __future__ import annotations

import csv
import importlib.util
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

import vsi_numba as vsi
from vsi_numba.cli import app

ROOT = Path(__file__).resolve().parent.parent
GALLERY = ROOT / "docs" / "gallery"

#: The configs recomputed whole: 0.6 to 2.5 s of CPU each with compiled kernels.
WHOLE = ("quickstart", "sprung_mass_25m", "hslm_25m", "ice3_continuous",
         "ice3_hertz_german_low", "track_layer_20m", "two_span_imported", "two_span_modes_file")
#: The configs recomputed on the governing cases of their committed table.
GOVERNING = ("viaduct_25_32_25", "double_track_viaduct")


def _script():
    spec = importlib.util.spec_from_file_location("make_figures",
                                                  GALLERY / "make_figures.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    return script


def _committed(stem: str) -> list[dict]:
    with open(GALLERY / f"{stem}.csv", encoding="utf-8", newline="") as fh:
        return list(csv.DictReader(fh))


def _recomputed(script, stem: str, config: Path, tmp_path: Path) -> list[dict]:
    """``vsi COMMAND CONFIG -o OUT --quiet`` as make_figures.py runs it (in process), then
    its table of the results file."""
    command, _ = script.GALLERY[stem]
    out = tmp_path / f"{stem}.nc"
    res = CliRunner().invoke(app, [command, str(config), "-o", str(out), "--quiet"])
    assert res.exit_code in (0, 1), res.output  # 1: a check failed (a result)
    with vsi.open_results(out) as ds:
        ds = ds.load()
    return script.results_rows(ds)


def _assert_rows(rows: list[dict], committed: list[dict], stem: str):
    assert [r["result"] for r in rows] == [r["result"] for r in committed], stem
    for new, old in zip(rows, committed, strict=True):
        assert new == old, f"{stem}: {new['result']}: recomputed {new}, committed {old}"


def test_gallery__every_entry_is_recomputed():
    assert sorted(WHOLE + GOVERNING) == sorted(_script().GALLERY)


@pytest.mark.parametrize("stem", WHOLE)
def test_gallery__committed_numbers_are_recomputed(stem, tmp_path):
    script = _script()
    rows = _recomputed(script, stem, ROOT / "configs" / f"{stem}.toml", tmp_path)
    _assert_rows(rows, _committed(stem), stem)


def _governing_config(stem: str, tmp_path: Path) -> Path:
    """The config of ``stem`` restricted to the trains and speeds its committed table
    names as governing ("HSLM-A3, 360 km/h"): ``train.preset`` and ``study.speeds_kmh``
    rewritten, everything else as committed."""
    cases = [re.match(r"(HSLM-A\d+), (\d+(?:\.\d+)?) km/h", r["where"])
             for r in _committed(stem)]
    trains = sorted({m.group(1) for m in cases if m})
    speeds = sorted({float(m.group(2)) for m in cases if m})
    assert trains and speeds, stem
    text = (ROOT / "configs" / f"{stem}.toml").read_text(encoding="utf-8")
    text, n_preset = re.subn(r"(?m)^preset = \[[^\]]*\]", f"preset = {trains!r}".replace(
        "'", '"'), text)
    text, n_study = re.subn(r"(?m)^\[study\]$", f"[study]\nspeeds_kmh = {speeds!r}", text)
    assert n_preset == 1 and n_study == 1, stem
    path = tmp_path / f"{stem}.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("stem", GOVERNING)
def test_gallery__committed_numbers_are_recomputed_on_the_governing_cases(stem, tmp_path):
    script = _script()
    rows = _recomputed(script, stem, _governing_config(stem, tmp_path), tmp_path)
    _assert_rows(rows, _committed(stem), stem)


def test_gallery__the_recomputation_can_fail(tmp_path):
    """The comparison sees a change of the results: the quick start with its body mass
    3 % heavier gives other numbers than its committed table."""
    script = _script()
    text = (ROOT / "configs" / "quickstart.toml").read_text(encoding="utf-8")
    changed = tmp_path / "quickstart.toml"
    marker = "mass = 5750.0"
    assert marker in text
    changed.write_text(text.replace(marker, "mass = 5922.5", 1), encoding="utf-8")
    rows = _recomputed(script, "quickstart", changed, tmp_path)
    with pytest.raises(AssertionError, match="recomputed"):
        _assert_rows(rows, _committed("quickstart"), "quickstart")
