"""Outputs of a results file kept when their inputs are unchanged (``vsi report``, the
governing results of ``vsi sweep``).

An output that follows from a results file alone - the report directory, the governing
lines the sweep prints - is the same when it is made again from the same inputs.  Its
*signature* is the SHA-256 of those inputs:

* the bytes of the results file;
* the package's sources (:func:`vsi_numba._sources.package_hash`: an edit of the code or
  another version of it), the versions of Python and of the libraries whose output the
  report holds (numpy, matplotlib's PNG, openpyxl's workbook, ...), the machine and
  numba's target CPU settings;
* where it is made: the results file's absolute path, the output's, the working
  directory (the stored configuration's relative paths resolve against them);
* the files the stored configuration names (every string of ``config_json`` that names
  an existing file relative to one of the directories the report tries), by content.

After an output is written its signature is stored in a record of the user's cache
(``$VSI_OUTPUT_CACHE``, else ``$XDG_CACHE_HOME/vsi_numba/outputs``, else
``~/.cache/vsi_numba/outputs``; ``VSI_OUTPUT_CACHE=off`` keeps nothing), written
atomically; for a report directory the record holds the SHA-256 of every file in it.  The
next command with the same signature keeps the output as it is, provided the directory
holds exactly the recorded files with the recorded contents (a file edited, removed or
added makes the report again); anything unreadable makes the output again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from pathlib import Path

#: Environment variable of the records' directory (``off``: no records).
CACHE_ENV = "VSI_OUTPUT_CACHE"
#: Record format (a change makes every record stale).
_FORMAT = "vsi-kept-1"
#: Distributions whose versions can change the bytes of an output.
_LIBRARIES = ("numpy", "scipy", "numba", "pandas", "xarray", "netCDF4", "matplotlib",
              "openpyxl", "markdown-it-py", "pillow")
_CHUNK = 1 << 20


def cache_dir() -> Path | None:
    """The records' directory, or None when records are off."""
    value = os.environ.get(CACHE_ENV)
    if value is not None:
        return None if value.strip().lower() in ("", "off", "0", "no") else Path(value)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"),
                                                            ".cache")
    return Path(base) / "vsi_numba" / "outputs"


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(_CHUNK):
            h.update(chunk)
    return h.hexdigest()


#: Environment variables that can change the bytes of a re-run (numba's target CPU).
_ENVIRONMENT = ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_OPT")


def _versions() -> list[str]:
    """Python's and the libraries' versions, the machine (its name, architecture) and
    :data:`_ENVIRONMENT`: a record in a cache shared between machines is not another
    machine's."""
    import platform

    out = [f"python {sys.version}", f"machine {platform.node()} {platform.machine()}"]
    out += [f"{k}={os.environ.get(k, '')}" for k in _ENVIRONMENT]
    return out + list(library_versions())


@functools.lru_cache(maxsize=1)
def library_versions() -> tuple[str, ...]:
    """``name version`` of each of :data:`_LIBRARIES` (``name -``: not installed), looked
    up once per process (the installed distributions, ~50 ms the first time; a study
    looks them up while its batches run, :func:`vsi_numba.study.runner._run_pending`)."""
    from importlib import metadata

    out = []
    for name in _LIBRARIES:
        try:
            out.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            out.append(f"{name} -")
    return tuple(out)


def _stored_config(results: Path) -> tuple[str, str]:
    """``config_json`` and ``config_directory`` of a results file ('' when absent)."""
    import netCDF4

    with netCDF4.Dataset(results) as nc:
        names = set(nc.ncattrs())
        return tuple(str(nc.getncattr(k)) if k in names else ""
                     for k in ("config_json", "config_directory"))


def _named_files(config_json: str, dirs: list[Path], sha=file_sha256) -> list[str]:
    """``name -> sha256`` lines of the files the stored configuration names, tried
    against ``dirs`` in order (the directories the report resolves against); ``sha``
    gives a file's SHA-256."""
    try:
        data = json.loads(config_json) if config_json else {}
    except ValueError:
        return [f"config_json unreadable {hashlib.sha256(config_json.encode()).hexdigest()}"]
    strings: set[str] = set()

    def walk(value):
        if isinstance(value, dict):
            for v in value.values():
                walk(v)
        elif isinstance(value, list):
            for v in value:
                walk(v)
        elif isinstance(value, str) and value.strip() and "\x00" not in value:
            strings.add(value)

    walk(data)
    lines = []
    for s in sorted(strings):
        for d in dirs:
            try:
                p = d / Path(s).expanduser()
                if p.is_file():
                    lines.append(f"{s} {d} {sha(p)}")
            except (OSError, ValueError, RuntimeError):
                continue
    return lines


def signature(kind: str, results: Path, output: Path | None = None) -> str | None:
    """The signature of the output ``kind`` of ``results`` written to ``output`` (see the
    module), or None when records are off or an input cannot be read."""
    if cache_dir() is None:
        return None
    from vsi_numba._sources import package_hash

    hashes: dict[Path, str] = {}

    def sha(path: Path) -> str:
        # each file read once: the results file is also a file its configuration names
        # (study.output), found in several of the directories tried
        key = Path(path).resolve()
        if key not in hashes:
            hashes[key] = file_sha256(key)
        return hashes[key]

    try:
        results = Path(results).resolve()
        config_json, stored_dir = _stored_config(results)
        here = results.parent
        dirs = [Path(stored_dir)] if stored_dir else []
        dirs += [here, *list(here.parents)[:3], Path.cwd()]
        parts = [_FORMAT, kind, str(results), sha(results),
                 str(Path(output).resolve()) if output is not None else "-",
                 str(Path.cwd()), package_hash(Path(__file__).resolve().parents[1]),
                 *_versions(), *_named_files(config_json, dirs, sha)]
    except Exception:  # noqa: BLE001 - an input that cannot be read: make the output
        return None
    return hashlib.sha256("\n".join(parts).encode("utf-8", "surrogateescape")).hexdigest()


def _record_path(kind: str, target: Path) -> Path | None:
    base = cache_dir()
    if base is None:
        return None
    key = hashlib.sha256(f"{kind}\0{Path(target).resolve()}".encode("utf-8",
                                                                    "surrogateescape"))
    return base / f"{kind}-{key.hexdigest()[:32]}.json"


def _read(kind: str, target: Path, sig: str | None) -> dict | None:
    if sig is None:
        return None
    path = _record_path(kind, target)
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, AttributeError):
        return None
    if not isinstance(record, dict) or record.get("signature") != sig:
        return None
    return record


def _write(kind: str, target: Path, record: dict) -> None:
    """Store a record (atomically); a cache that cannot be written keeps nothing."""
    from vsi_numba.io.atomic import make_parents, write_text_atomic

    path = _record_path(kind, target)
    if path is None:
        return
    try:
        make_parents(path.parent)
        write_text_atomic(path, json.dumps(record, sort_keys=True))
    except OSError:
        pass


def directory_digest(directory: Path) -> dict[str, str]:
    """``relative path -> sha256`` of every file under ``directory``."""
    directory = Path(directory)
    out = {}
    for root, dirs, files in os.walk(directory):
        dirs.sort()
        for name in sorted(files):
            p = Path(root) / name
            out[p.relative_to(directory).as_posix()] = file_sha256(p)
    return out


def kept_directory(kind: str, directory: Path, sig: str | None) -> dict | None:
    """The record of ``directory`` when its signature is ``sig`` and the directory holds
    exactly the recorded files, unchanged; else None (make it again)."""
    record = _read(kind, directory, sig)
    if record is None or not Path(directory).is_dir():
        return None
    try:
        if directory_digest(directory) != record.get("files"):
            return None
    except OSError:
        return None
    return record


def remember_directory(kind: str, directory: Path, sig: str | None, **payload) -> None:
    """Record the directory just written from the inputs of signature ``sig``."""
    if sig is None:
        return
    try:
        files = directory_digest(directory)
    except OSError:
        return
    _write(kind, directory, {"signature": sig, "files": files, **payload})


def kept_value(kind: str, target: Path, sig: str | None) -> dict | None:
    """The record of an output that is not a file (printed lines) for ``sig``."""
    return _read(kind, target, sig)


def remember_value(kind: str, target: Path, sig: str | None, **payload) -> None:
    """Record such an output."""
    if sig is not None:
        _write(kind, target, {"signature": sig, **payload})


def study_signature(cfg, output: Path) -> str | None:
    """The signature of a study's results file ``output`` as the study ``cfg`` would write
    it: the configuration's hash (:attr:`~vsi_numba.config.core.Config.sha256`), the
    contents of the files it reads (:func:`vsi_numba.io.paths.input_files`), the package's
    sources and the libraries' versions, and the bytes of ``output``; None when records
    are off or something cannot be read.  Equal signatures mean that the model, the plan
    and the code the file was written with are those the study would use now, without
    building the model."""
    if cache_dir() is None:
        return None
    from vsi_numba._sources import package_hash
    from vsi_numba.io.paths import input_files

    try:
        output = Path(output).resolve()
        parts = [_FORMAT, "study", str(cfg.sha256), str(output), file_sha256(output),
                 package_hash(Path(__file__).resolve().parents[1]), *_versions()]
        parts += [f"{what} {path} {file_sha256(path)}" for what, path in input_files(cfg)]
    except Exception:  # noqa: BLE001 - an input that cannot be read: decide the long way
        return None
    return hashlib.sha256("\n".join(parts).encode("utf-8", "surrogateescape")).hexdigest()
