"""Reading a configuration file: a bounded read of a regular file (no FIFO, device or
oversized file), its UTF-8 text and its TOML, each failure as one message naming the file."""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path

from vsi_numba.config.limits import MAX_CONFIG_BYTES


def _read_bounded(path: Path, limit: int) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes.

    Opened without blocking (a FIFO does not hang the open) and checked on the open
    descriptor: anything but a regular file raises ``ValueError`` naming its kind, a
    larger file ``ValueError`` with its size; at most ``limit + 1`` bytes are ever read.
    """
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError(21, "Is a directory")
        if not stat.S_ISREG(st.st_mode):
            kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else
                    "a character device" if stat.S_ISCHR(st.st_mode) else
                    "a block device" if stat.S_ISBLK(st.st_mode) else
                    "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
            raise ValueError(f"is {kind}, not a regular file")
        if st.st_size > limit:
            raise ValueError(f"is {st.st_size} bytes, more than the {limit} bytes a "
                             "configuration may have")
        chunks, n = [], 0
        while n <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - n))
            if not chunk:
                break
            chunks.append(chunk)
            n += len(chunk)
        if n > limit:
            raise ValueError(f"holds more than the {limit} bytes a configuration may have")
        return b"".join(chunks)
    finally:
        os.close(fd)


def _read_toml(path: Path) -> tuple[dict | None, list[str]]:
    try:
        raw = _read_bounded(path, MAX_CONFIG_BYTES)
    except FileNotFoundError:
        return None, [f"{path}: file not found; expected a TOML configuration file"]
    except IsADirectoryError:
        return None, [f"{path}: is a directory; expected a TOML configuration file"]
    except ValueError as exc:
        return None, [f"{path}: {exc}; expected a TOML configuration file"]
    except OSError as exc:
        return None, [f"{path}: cannot be read ({exc.strerror}); expected a TOML file"]
    if raw.startswith(b"\xef\xbb\xbf"):
        return None, [f"{path}: starts with a UTF-8 byte-order mark (BOM), which TOML does "
                      "not allow; expected a UTF-8 TOML file without BOM (save it as "
                      "'UTF-8', not 'UTF-8 with BOM')"]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        return None, [f"{path}: not a TOML file (byte {exc.start} is not UTF-8 text); expected "
                      "a UTF-8 TOML configuration file"]
    try:
        return tomllib.loads(text), []
    except RecursionError:
        return None, [f"{path}: nested too deeply (arrays or inline tables); expected a "
                      "TOML configuration file"]
    except ValueError as exc:
        if isinstance(exc, tomllib.TOMLDecodeError):
            return _syntax_error(path, text, exc)
        msg = " ".join(str(exc).split())  # e.g. an integer of thousands of digits
        return None, [f"{path}: value not readable ({msg}); expected a TOML configuration "
                      "file with numbers of ordinary size"]


def _syntax_error(path: Path, text: str, exc) -> tuple[None, list[str]]:
    hint = "" if path.suffix.lower() == ".toml" else " (is this a TOML file?)"
    msg = " ".join(str(exc).split())
    if "(at end of document)" in msg:  # tomllib gives no line/column there
        lines = text.split("\n")
        msg = msg.replace("(at end of document)", f"(at end of document, line {len(lines)}, "
                                                  f"column {len(lines[-1]) + 1})")
    return None, [f"{path}: TOML syntax error: {msg}; expected valid TOML{hint}"]
