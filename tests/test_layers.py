"""Layer contracts of the package: ``lint-imports`` (import-linter) with the contracts in
``pyproject.toml`` ([tool.importlinter]).

kernels -> model / io -> solver -> config -> study -> analysis -> verification -> cli: a
layer imports only the layers below it (and third-party libraries its rules allow), and no
two sibling modules import each other.  Every ``import`` counts, at module level, inside a
function or under ``TYPE_CHECKING`` (the package imports heavy libraries lazily, so a
function-level import is as much a dependency as a module-level one): the tests below show
import-linter sees each kind on a package of its own.

Also here: the CI script runs the README's test command verbatim.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def _lint_imports(cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    return subprocess.run([str(LINT_IMPORTS), "--no-cache"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_layers__every_contract_of_the_package_is_kept():
    done = _lint_imports(ROOT, ROOT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout


CONTRACT = """
[tool.importlinter]
root_packages = ["toy"]
include_external_packages = true

[[tool.importlinter.contracts]]
name = "low below high"
type = "layers"
containers = ["toy"]
layers = ["high", "low"]

[[tool.importlinter.contracts]]
name = "low without rich"
type = "forbidden"
source_modules = ["toy.low"]
forbidden_modules = ["rich"]
"""


@pytest.mark.parametrize("source", [
    "from toy.high import thing\n",  # module level
    "def f():\n    from toy.high import thing\n",  # inside a function
    "def f():\n    from .high import thing\n",  # relative
    "def f():\n    from toy import high\n",  # a submodule through its package
    "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from toy.high import thing\n",
    "try:\n    import toy.high\nexcept ImportError:\n    pass\n",  # guarded
    "def f():\n    import rich.console\n",  # a forbidden library, in a function
])
def test_layers__lint_imports_sees_every_kind_of_import(tmp_path, source):
    """A toy package whose lower layer imports the upper one (or a forbidden library) in
    each way the package's code does: lint-imports fails on every one, so the contracts
    miss none of them; with the import gone it passes."""
    pkg = tmp_path / "toy"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "high.py").write_text("thing = 1\n")
    (pkg / "low.py").write_text(source)
    (tmp_path / "pyproject.toml").write_text(CONTRACT)
    done = _lint_imports(tmp_path, tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "1 broken" in done.stdout
    (pkg / "low.py").write_text("import math\n")
    assert _lint_imports(tmp_path, tmp_path).returncode == 0


# ------------------------------------------------------------------------------ CI


def test_ci_runs_the_readme_test_command_verbatim():
    """``.ci/run`` runs exactly the README's second command (install, ruff, tests)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```bash\n(.*?)```", readme, flags=re.S)
    command = blocks[1].strip()
    assert "ruff check" in command and "pytest" in command
    script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    lines = [ln for ln in script.splitlines() if ln.strip() and not ln.startswith("#")]
    assert lines[-1] == command


def test_the_timed_test_command_uses_the_readme_pytest_options():
    """``python -m benchmarks --measure i`` times pytest with the README's options (the
    worker count included), not a copy of them."""
    from benchmarks.study import readme_pytest_options

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    command = re.findall(r"```bash\n(.*?)```", readme, flags=re.S)[1].strip()
    assert command.endswith("-m pytest " + readme_pytest_options())
    assert readme_pytest_options().startswith("-q")


#: The longest a module of the package may be: a module over it does several jobs.
MODULE_LINES_MAX = 700


def test_no_module_of_the_package_is_over_its_line_limit():
    sizes = {p.relative_to(ROOT).as_posix(): len(p.read_text(encoding="utf-8").splitlines())
             for p in (ROOT / "vsi_numba").rglob("*.py")}
    assert len(sizes) > 100  # the package was found
    over = {k: v for k, v in sizes.items() if v > MODULE_LINES_MAX}
    assert not over, f"modules over {MODULE_LINES_MAX} lines: {over}"
