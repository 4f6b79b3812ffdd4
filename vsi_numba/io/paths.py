"""Output paths: what a results file may be, and names that fit the file system.

A study writes its results file by renaming a finished temporary file over the output
(:mod:`vsi_numba.io.netcdf`), and keeps its finished batches in a directory beside it
(:mod:`vsi_numba.study.store`).  A rename replaces whatever the name pointed to, so the
output is checked before any computation (:func:`output_conflict`): it must not be a
file the configuration reads (the configuration itself, a profile CSV, a modes or matrix
file, a user train file), nor a directory, device, FIFO or socket, and its name must fit
the file system (at most ``NAME_MAX`` bytes per component, ``PATH_MAX`` in all).

Names derived from the output (the case store, temporary files) add a prefix or a
suffix; :func:`fitting_name` shortens them with a hash of the full name when they would
not fit, so any legal output name works.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

#: Fallbacks when ``os.pathconf`` cannot tell (Linux values).
_NAME_MAX = 255
_PATH_MAX = 4096


def name_max(directory: str | os.PathLike = ".") -> int:
    """Longest file name (bytes) in ``directory`` (or the nearest existing parent)."""
    d = Path(directory)
    for cand in (d, *d.parents):
        try:
            return int(os.pathconf(cand, "PC_NAME_MAX"))
        except (OSError, ValueError):
            continue
    return _NAME_MAX


def path_max() -> int:
    """Longest path (bytes, with its terminating NUL) the system accepts."""
    try:
        return int(os.pathconf("/", "PC_PATH_MAX"))
    except (OSError, ValueError):  # pragma: no cover - not POSIX
        return _PATH_MAX


def fitting_name(name: str, prefix: str = "", suffix: str = "",
                 limit: int = _NAME_MAX) -> str:
    """``prefix + name + suffix``, or, when that is longer than ``limit`` bytes, a
    shortened ``name`` followed by ``-`` and 16 hex digits of its SHA-256 (unique per
    name, the same on every call, so a resumed study finds the same store)."""
    full = prefix + name + suffix
    if len(os.fsencode(full)) <= limit:
        return full
    digest = hashlib.sha256(os.fsencode(name)).hexdigest()[:16]
    room = limit - len(os.fsencode(prefix + suffix)) - 17
    head = os.fsencode(name)[: max(room, 0)].decode("utf-8", "ignore")
    return f"{prefix}{head}-{digest}{suffix}"


def path_length_problem(path: Path, what: str = "output",
                        remedy: str = "choose a shorter output (-o PATH)") -> str | None:
    """Why ``path`` cannot be a file name here (too long in all or in one component);
    ``what`` names the path in the message, ``remedy`` ends it."""
    path = Path(path)
    text = os.fsencode(str(path))
    if len(text) >= path_max():
        return (f"the {what} path is {len(text)} bytes long; the longest path this system "
                f"accepts is {path_max() - 1} bytes: {remedy}")
    limit = name_max(path.parent if str(path.parent) else ".")
    for part in path.parts:
        if len(os.fsencode(part)) > limit:
            shown = part if len(part) <= 60 else part[:40] + "..." + part[-12:]
            return (f"the {what} path component {shown!r} is {len(os.fsencode(part))} bytes "
                    f"long; file names here are at most {limit} bytes: {remedy}")
    return None


def _kind(mode: int) -> str | None:
    for test, what in ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return None if stat.S_ISREG(mode) else "not a regular file"


def _same(a: Path, st_b: os.stat_result) -> bool:
    try:
        st_a = a.stat()
    except (OSError, ValueError):
        return False
    return (st_a.st_dev, st_a.st_ino) == (st_b.st_dev, st_b.st_ino)


#: String keys of a resolved configuration that never name an input.
_NOT_INPUTS = ("title", "study.output")


def input_files(cfg) -> list[tuple[str, Path]]:
    """Files a configuration reads: ``(what, absolute path)``, the configuration itself
    first, then every string of the resolved configuration (variants included) that
    names an existing file relative to its directory."""
    found: list[tuple[str, Path]] = []
    if getattr(cfg, "path", None):
        found.append(("the configuration file", Path(cfg.path)))
    base = Path(getattr(cfg, "base_dir", None) or ".")
    resolved = cfg.resolved() if hasattr(cfg, "resolved") else {}

    def walk(value, key: str):
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, f"{key}.{k}" if key else str(k))
        elif isinstance(value, list | tuple):
            for i, v in enumerate(value):
                walk(v, f"{key}[{i}]")
        elif (isinstance(value, str) and value.strip() and "\x00" not in value
              and key not in _NOT_INPUTS):
            try:
                p = (base / Path(value).expanduser())
                if p.is_file():
                    found.append((f"the file of {key}", p.resolve()))
            except (OSError, ValueError, RuntimeError):
                pass

    walk(resolved, "")
    return found


def output_conflict(out_path: str | os.PathLike, cfg=None) -> str | None:
    """Why ``out_path`` cannot receive the results (checked before any computation), or
    None: a name too long, an existing directory / device / FIFO / socket, or a file the
    configuration ``cfg`` reads.  Symbolic links are followed (the rename would replace
    the link, but a link to an input says the user meant that file)."""
    out_path = Path(out_path)
    problem = path_length_problem(out_path)
    if problem:
        return problem
    try:
        st = out_path.stat()
    except (FileNotFoundError, NotADirectoryError):  # the writability check says why
        st = None
    except OSError as exc:
        return f"cannot use the output {out_path}: {exc.strerror or exc}"
    if st is not None:
        kind = _kind(st.st_mode)
        if kind is not None:
            return (f"the output {out_path} is {kind}, not a regular file: refusing to "
                    "replace it; give the path of a results file (-o PATH, ending in .nc)")
    if cfg is not None:
        for what, path in input_files(cfg):
            same = _same(path, st) if st is not None else False
            if not same:
                try:
                    same = path.resolve() == out_path.expanduser().resolve()
                except (OSError, ValueError, RuntimeError):
                    same = False
            if same:
                return (f"the output {out_path} is {what} ({path}), an input of this "
                        "configuration: refusing to overwrite the input; choose another output "
                        "(-o PATH, ending in .nc)")
    return None
