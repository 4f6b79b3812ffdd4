"""The numba cache follows the source of the whole package that defines a kernel
(:mod:`vsi_numba._jit`): a kernel whose callee in another file of its package changed is
compiled again instead of being loaded with the old callee, which plain numba does.

A package of two files in a temporary directory (``caller.py`` calls ``callee.py``), each
run in a fresh process on its own numba cache, as a user edits and re-runs.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CALLER = """\
{jit_import}
from {pkg}.callee import value


@{decorator}
def run():
    return value() + 1.0
"""

CALLEE = """\
{jit_import}


@{decorator}
def value():
    return {value}
"""

FLAVOURS = {
    "vsi_numba": ("from vsi_numba._jit import njit", "njit"),
    "numba": ("import numba", "numba.njit(cache=True)"),
}


def _write(tmp_path: Path, pkg: str, flavour: str, value: float) -> None:
    """The package, or (when it exists) its callee alone: the caller's file stays as it
    was, bytes and modification time."""
    jit_import, decorator = FLAVOURS[flavour]
    d = tmp_path / pkg
    if not d.exists():
        d.mkdir()
        (d / "__init__.py").write_text("")
        (d / "caller.py").write_text(CALLER.format(jit_import=jit_import, pkg=pkg,
                                                   decorator=decorator))
    (d / "callee.py").write_text(CALLEE.format(jit_import=jit_import, decorator=decorator,
                                               value=repr(value)))


def _run(tmp_path: Path, pkg: str) -> tuple[float, int]:
    """A fresh process: the caller's result and how many of its signatures it loaded
    from the cache."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    code = (f"from {pkg}.caller import run; r = run(); "
            "print(r, sum(run.stats.cache_hits.values()))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300, check=True).stdout.split()
    return float(out[0]), int(out[1])


@pytest.mark.parametrize("flavour", ["vsi_numba", "numba"])
def test_jit_cache__an_edited_callee_in_another_file(tmp_path, flavour):
    pkg = f"pkg_{flavour}"
    _write(tmp_path, pkg, flavour, 1.0)
    assert _run(tmp_path, pkg) == (2.0, 0)  # compiled
    assert _run(tmp_path, pkg) == (2.0, 1)  # loaded from the cache: the cache works
    _write(tmp_path, pkg, flavour, 5.0)  # the callee's file alone changes
    if flavour == "vsi_numba":
        assert _run(tmp_path, pkg) == (6.0, 0)  # compiled again with the new callee
        assert _run(tmp_path, pkg) == (6.0, 1)  # and cached again
    else:
        # plain numba stamps the caller with its own file only: the old callee, loaded
        assert _run(tmp_path, pkg) == (2.0, 1)


def test_jit_cache__a_kernel_that_cannot_be_cached_warns_and_runs(tmp_path, monkeypatch):
    """A kernel numba cannot cache (it uses dynamic globals: here a large global array,
    as every kernel has with ``NUMBA_OPT=0``) gets numba's own "Cannot cache" warning
    and runs; the package's cache locator gave an AttributeError (``_py_file``)."""
    import importlib

    import numba
    from numba.core.errors import NumbaWarning

    pkg = tmp_path / "pkg_uncachable"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "kernel.py").write_text(
        "import numpy as np\n"
        "from vsi_numba._jit import njit\n"
        "BIG = np.arange(2_000_000, dtype=np.float64)\n\n\n"
        "@njit\n"
        "def value(i):\n"
        "    return BIG[i] + 1.0\n")
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.syspath_prepend(str(tmp_path))
    kernel = importlib.import_module("pkg_uncachable.kernel")
    with pytest.warns(NumbaWarning, match="Cannot cache compiled function"):
        assert kernel.value(41) == 42.0
