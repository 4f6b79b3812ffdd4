"""The hash of a package's sources (no numba: a command that only compares it imports
nothing heavy); :mod:`vsi_numba._jit` stamps the kernels' cache with it."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path


def _sources(directory: str) -> list[Path]:
    return sorted(p for p in Path(directory).rglob("*.py") if "__pycache__" not in p.parts)


_hashes: dict[tuple, str] = {}


#: The module whose options and dispatchers decide how the kernels compile and link
#: (``vsi_numba/_jit.py``): part of every package's hash.
_JIT = Path(__file__).with_name("_jit.py")


def package_hash(directory: str | os.PathLike) -> str:
    """SHA-256 of every ``.py`` file under ``directory`` (names and bytes, in name order)
    and of :data:`_JIT`; recomputed when a file's size or modification time changes."""
    files = _sources(str(directory))
    if _JIT not in files:
        files.append(_JIT)
    key = tuple((str(p), st.st_mtime_ns, st.st_size) for p in files for st in [p.stat()])
    if key not in _hashes:
        h = hashlib.sha256()
        for p in files:
            name = p.name if p == _JIT else p.relative_to(directory).as_posix()
            h.update(name.encode() + b"\0")
            h.update(p.read_bytes() + b"\0")
        _hashes[key] = h.hexdigest()
    return _hashes[key]
