"""Layer contracts of the package, read from the source with ``ast`` (nothing imported).

kernels -> model -> solver -> study / io -> analysis -> cli: a layer imports only the
layers left of it (and third-party libraries its rules allow).  Every ``import`` counts,
at module level or inside a function (the package imports heavy libraries lazily, so a
function-level import is as much a dependency as a module-level one).

Also here: the CI script runs the README's test command verbatim.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vsi_numba"

#: Everything the numba kernels may import: they are compiled code on arrays.
KERNEL_ALLOWED = ("numpy", "vsi_numba._jit", "typing", "__future__", "math")

#: layer (package prefix) -> import prefixes it must not use.
FORBIDDEN = {
    "vsi_numba.model": ("vsi_numba.config", "vsi_numba.study", "vsi_numba.solver",
                        "vsi_numba.cli", "vsi_numba.analysis", "rich", "matplotlib"),
    "vsi_numba.solver": ("vsi_numba.study", "vsi_numba.config", "vsi_numba.cli",
                         "vsi_numba.analysis"),
    "vsi_numba.io": ("vsi_numba.config", "vsi_numba.study", "vsi_numba.solver",
                     "vsi_numba.analysis", "vsi_numba.cli", "rich", "matplotlib"),
    "vsi_numba.analysis": ("vsi_numba.solver", "vsi_numba.kernels", "vsi_numba.study",
                           "vsi_numba.cli"),
    "vsi_numba.study": ("vsi_numba.cli", "vsi_numba.analysis"),
    "vsi_numba.en1990": ("vsi_numba.",),
    "vsi_numba.en1991": ("vsi_numba.",),
    "vsi_numba.code_profile": ("vsi_numba.",),
    "vsi_numba.config": ("vsi_numba.study", "vsi_numba.cli", "vsi_numba.analysis"),
    "vsi_numba._jit": ("vsi_numba.",),
}

#: (module, imported module) -> why it is allowed.  Keep this short.
KNOWN_EXCEPTIONS = {
    # The report re-runs the governing case of a check when the results file holds no
    # time history of it (vsi report figures): analysis calls the solver on purpose,
    # on the track range of the study (model.irregularity.profile_range) so a seed gives
    # the same realisation.  Documented in the README's code map.
    ("vsi_numba.analysis.recompute", "vsi_numba.solver.simulate"): "re-run one case",
    # The rules of the standards read their values from the code profile, the one table of
    # clause values (which imports nothing of the package).
    ("vsi_numba.en1990", "vsi_numba.code_profile"): "clause values of the code profile",
    ("vsi_numba.en1991", "vsi_numba.code_profile"): "clause values of the code profile",
}


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every module ``source`` imports, anywhere in it; ``from X import a`` gives ``X`` and
    ``X.a`` (``a`` may be a submodule).  Relative imports are resolved against ``module``."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = module.split(".") if is_package else module.split(".")[:-1]
                pkg = pkg[:len(pkg) - (node.level - 1)]
                base = ".".join([*pkg, base] if base else pkg)
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _under(name: str, prefix: str) -> bool:
    if prefix.endswith("."):
        return name.startswith(prefix)
    return name == prefix or name.startswith(prefix + ".")


def violations(module: str, imported: set[str]) -> list[str]:
    """The imports of ``module`` that break a layer rule (known exceptions left out)."""
    bad = []
    if _under(module, "vsi_numba.kernels"):
        # ``from X import a``: X must be allowed (the X.a entries then are too)
        bases = {i for i in imported if not any(i.startswith(j + ".") for j in imported)}
        for name in sorted(bases):
            if not any(_under(name, a) for a in KERNEL_ALLOWED):
                bad.append(f"{module} imports {name} (kernels: numpy, _jit, typing only)")
    for layer, forbidden in FORBIDDEN.items():
        if not _under(module, layer):
            continue
        for name in sorted(imported):
            for prefix in forbidden:
                if _under(name, prefix) and not _under(name, layer) and not any(
                        _under(name, exc) for mod, exc in KNOWN_EXCEPTIONS if mod == module):
                    bad.append(f"{module} imports {name} (layer {layer} must not use "
                               f"{prefix.rstrip('.')})")
    if not _under(module, "vsi_numba.cli"):
        bad += [f"{module} imports {n} (only the CLI imports the CLI)"
                for n in sorted(imported) if _under(n, "vsi_numba.cli")]
    return bad


def package_modules() -> list[tuple[str, Path]]:
    return sorted((module_name(p), p) for p in PACKAGE.rglob("*.py"))


def test_layers__every_module_keeps_its_layer():
    problems = []
    for module, path in package_modules():
        imported = imports_of(path.read_text(encoding="utf-8"), module,
                              path.name == "__init__.py")
        problems += violations(module, imported)
    assert not problems, "\n".join(problems)


def test_layers__known_exceptions_are_still_needed():
    """An exception that the code no longer needs is removed from the list."""
    for (module, name), why in KNOWN_EXCEPTIONS.items():
        path = PACKAGE.joinpath(*module.split(".")[1:]).with_suffix(".py")
        imported = imports_of(path.read_text(encoding="utf-8"), module)
        assert any(_under(i, name) for i in imported), (module, name, why)


def test_layers__the_scan_sees_the_whole_package():
    names = {m for m, _ in package_modules()}
    for expected in ("vsi_numba.kernels.engine", "vsi_numba.model.bridge",
                     "vsi_numba.solver.simulate", "vsi_numba.study.runner",
                     "vsi_numba.analysis.report", "vsi_numba.cli.app", "vsi_numba.cli"):
        assert expected in names


@pytest.mark.parametrize(("module", "source"), [
    ("vsi_numba.model.bridge", "import rich\n"),
    ("vsi_numba.model.bridge", "def f():\n    from vsi_numba.config import load_config\n"),
    ("vsi_numba.model.library", "from vsi_numba import config\n"),
    ("vsi_numba.model.library", "def f():\n    import matplotlib.pyplot as plt\n"),
    ("vsi_numba.model.library", "from ..study import runner\n"),
    ("vsi_numba.solver.run", "from vsi_numba.study.grid import profile_range\n"),
    ("vsi_numba.kernels.engine", "import scipy.linalg\n"),
    ("vsi_numba.kernels.engine", "def f():\n    from vsi_numba.model import bridge\n"),
    ("vsi_numba.analysis.checks", "from vsi_numba.solver.simulate import simulate\n"),
    ("vsi_numba.analysis.recompute", "from vsi_numba.kernels import engine\n"),
    ("vsi_numba.study.runner", "from vsi_numba.cli.common import Printer\n"),
    ("vsi_numba.io.netcdf", "from vsi_numba.study.store import CaseStore\n"),
])
def test_layers__checker_flags_bad_imports(module, source):
    """The checker can fail: each synthetic import breaks a rule."""
    assert violations(module, imports_of(source, module))


@pytest.mark.parametrize(("module", "source"), [
    ("vsi_numba.kernels.engine", "import numpy as np\nfrom vsi_numba._jit import njit\n"),
    ("vsi_numba.model.library", "from vsi_numba.model.vehicle import Train\n"),
    ("vsi_numba.model.library", "from . import vehicle\n"),
    ("vsi_numba.analysis.recompute", "from vsi_numba.solver.simulate import simulate\n"),
    ("vsi_numba.cli.run", "from vsi_numba.study.single import run_config\n"),
])
def test_layers__checker_passes_good_imports(module, source):
    assert violations(module, imports_of(source, module)) == []


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
