"""``vsi verify``: the verification manual runs through the CLI, writes its CSV and HTML,
names every case's source, and fails (exit 1) when a figure leaves its tolerance.

The references of the cases live in ``vsi_numba/verification/reference/``, which must
never import the rest of the package (checked here with ``ast``).
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numba
import numpy as np
import pandas as pd
import pytest
import scipy
from typer.testing import CliRunner

import vsi_numba
from vsi_numba.cli import app
from vsi_numba.verification import cases, reference
from vsi_numba.verification.manual import COLUMNS


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_verify__quick_set_through_the_cli(tmp_path):
    res = invoke("verify", "--quick", "-o", tmp_path)
    assert res.exit_code == 0, res.output
    table = pd.read_csv(tmp_path / "verification.csv", keep_default_na=False)
    assert tuple(table.columns) == COLUMNS
    quick = {c.id for c in cases.CASES if c.quick}
    assert set(table["case"]) == quick and len(quick) >= 4
    assert table["id"].is_unique and len(table) >= 12
    for _, row in table.iterrows():
        assert len(row["source"]) > 10, row["id"]  # every figure names its source
        assert row["tolerance_reason"] and row["model"] and row["quantity"], row["id"]
        # the CSV's error is the relative difference of its own columns (10 digits kept)
        assert row["error"] == pytest.approx(row["computed"] / row["reference"] - 1.0,
                                             abs=1e-8)
        assert abs(row["error"]) <= row["tolerance"] and row["pass"], row["id"]
    assert table["pass"].dtype == bool
    assert set(table["vsi_numba"]) == {vsi_numba.__version__}
    assert set(table["numba"]) == {numba.__version__}
    assert set(table["numpy"]) == {np.__version__}
    assert set(table["scipy"]) == {scipy.__version__}
    html = (tmp_path / "verification.html").read_text(encoding="utf-8")
    assert all(i in html for i in table["id"])
    assert "all figures within tolerance" in html and "FAIL" not in html
    # each case shows its inputs: the configuration it ran
    assert html.count('<code class="language-toml">') == len(quick)
    assert len(list((tmp_path / "cases").glob("V*/*.toml"))) == len(quick)
    assert "verification: " in res.output and "all within tolerance" in res.output


def test_verify__a_wrong_reference_fails(tmp_path, monkeypatch):
    """The crawl-speed moments' reference 2 % too high (beyond the 0.2 % tolerance): the
    two moment figures are marked FAIL in the CSV and the HTML, the others pass, and the
    command exits 1."""
    monkeypatch.setattr(cases, "CASES", tuple(c for c in cases.CASES if c.id == "V03"))
    right = reference.ss_crawl_effects

    def wrong(P, L, EI, x):
        out = dict(right(P, L, EI, x))
        out["moment"] *= 1.02
        return out

    monkeypatch.setattr(reference, "ss_crawl_effects", wrong)
    res = invoke("verify", "--quick", "-o", tmp_path)
    assert res.exit_code == 1, res.output
    assert "FAIL V03-M-mid" in res.output
    table = pd.read_csv(tmp_path / "verification.csv").set_index("id")
    assert set(table.index[~table["pass"]]) == {"V03-M-mid", "V03-M-quarter"}
    assert table.loc["V03-M-mid", "error"] == pytest.approx(1 / 1.02 - 1, abs=2e-3)
    assert "2 FAILED" in (tmp_path / "verification.html").read_text(encoding="utf-8")


def test_verify__a_case_that_cannot_run_fails(tmp_path, monkeypatch):
    def broken(workdir: Path):
        raise RuntimeError("reference data missing")

    monkeypatch.setattr(cases, "CASES", (cases.Case("X1", "broken case", True, broken),))
    res = invoke("verify", "--quick", "-o", tmp_path)
    assert res.exit_code == 1, res.output
    assert "FAIL X1: could not run: RuntimeError: reference data missing" in res.output
    assert "could not run" in (tmp_path / "verification.html").read_text(encoding="utf-8")


def test_verify__unwritable_output_is_a_usage_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    res = invoke("verify", "--quick", "-o", blocker / "manual")
    assert res.exit_code == 2
    assert "--output" in res.output and "Traceback" not in res.output


def test_verify__reference_package_imports_only_numpy_and_scipy():
    """Every module of the shipped oracle imports numpy, scipy and the oracle's own
    modules only (import-linter's contract in pyproject.toml says the same of the
    package's imports)."""
    files = sorted(Path(reference.__file__).parent.glob("*.py"))
    assert len(files) >= 5, files
    names = set()
    for path in files:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                assert node.level == 0, f"relative import in {path.name}"
                names.add(node.module)
    own = {n for n in names if n.startswith("vsi_numba.")}
    assert all(n.startswith("vsi_numba.verification.reference.") for n in own), own
    assert {n.split(".")[0] for n in names - own} <= {"__future__", "numpy", "scipy"}, names


def test_verify__importing_the_oracle_loads_no_engine_module():
    """At run time too: importing the oracle loads numpy, scipy and the oracle's modules
    (and the package's two lazy ``__init__`` modules), nothing else of vsi_numba."""
    import subprocess
    import sys

    code = ("import sys, vsi_numba.verification.reference as r; "
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('vsi_numba') "
            "or m.split('.')[0] in ('numba', 'pandas', 'xarray', 'matplotlib'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    extra = {m for m in out if not m.startswith("vsi_numba.verification.reference")}
    assert extra == {"vsi_numba", "vsi_numba.verification"}, extra


def test_verify__fryba_reference_reproduces_the_published_table():
    """The modal series (60 modes) against Frýba's tabulated DAF: 4 decimals, except the
    alpha = 1.0 entry, 6e-4 above the series (its first mode alone gives 1.5481 at t = L/v:
    pi/2 x 96/pi^4)."""
    for alpha, daf in reference.FRYBA_DAF.items():
        tol = 7e-4 if alpha == 1.0 else 1e-4
        assert reference.moving_force_daf(alpha) == pytest.approx(daf, abs=tol), alpha
    assert math.isclose(reference.moving_force_daf(1.0, n_modes=1), np.pi / 2 * 96 / np.pi**4,
                        rel_tol=1e-6)


def test_verify__deck_in_space_references_agree_with_closed_forms():
    """The references of V16-V18 checked on their own: forces on the deck's axis give the
    closed-form modal superposition of V05 (the integration's rtol 1e-10), and the crawl
    twist's sine series tends to the point torque's closed form as 1/n (the rotation's
    kink under the torque)."""
    L, EI, m, zeta, v = 24.0, 1.5e10, 1.2e4, 0.01, 40.0
    offsets = [0.0, 8.0, 16.0]
    t = np.linspace(0.0, 1.5, 3001)
    res = reference.deck_in_space_forces([(1e5, 0.0, -o, v) for o in offsets], L, EI, m,
                                         zeta, 3, 6e9, 6e4, 0.01, 4, t)
    w, _ = reference.deck_in_space_line(res, [6.0, 12.0], 2.5)
    _, w_ref, _ = reference.train_of_forces(offsets, [1e5] * 3, L, EI, m, zeta, 3, v,
                                            [6.0, 12.0], 1.5, nt=3001)
    assert np.abs(res["q"][:, 3:]).max() == 0.0  # forces on the axis do not twist the deck
    # solve_ivp at rtol 1e-10 against the closed form: measured 4.8e-13 of the peak
    np.testing.assert_allclose(w, w_ref, rtol=0, atol=2e-12 * np.abs(w_ref).max())
    closed = reference.point_torque_twist(5e5, 6e9, L, 4.0)
    errors = [reference.point_torque_twist(5e5, 6e9, L, 4.0, n_modes=n) / closed - 1
              for n in (50, 200)]
    assert closed == pytest.approx(1.435 * 5e5 * 3.0 * 17.0 / (6e9 * L), rel=1e-15)
    # the series falls short and converges about as 1/n: 7.3e-3 and 1.5e-3 short with 50
    # and 200 modes (a ratio of 5.0 where 1/n gives 4)
    assert all(e < 0 for e in errors) and 3.5 < errors[0] / errors[1] < 6.0, errors
    assert abs(errors[1]) < 2e-3
