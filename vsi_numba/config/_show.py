"""How the configuration's messages show a key path and a value (TOML-like, one line)."""

from __future__ import annotations

import json
import re
from collections.abc import Mapping

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(key) -> str:
    s = str(key)
    return s if _BARE_KEY.match(s) else json.dumps(s)


def _join(path: str, key) -> str:
    return f"{path}.{_key(key)}" if path else _key(key)


def _show(value, limit: int = 70) -> str:
    """One-line TOML-like rendering of a value, truncated to ``limit`` characters."""
    s = _render(value, depth=0)
    return s if len(s) <= limit else s[: limit - 3] + "..."


def _render(value, depth: int) -> str:
    if depth > 3:
        return "..."
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, Mapping):
        items = list(value.items())
        body = ", ".join(f"{_key(k)} = {_render(v, depth + 1)}" for k, v in items[:8])
        return "{" + body + (", ..." if len(items) > 8 else "") + "}"
    if isinstance(value, list | tuple):
        body = ", ".join(_render(v, depth + 1) for v in value[:12])
        return "[" + body + (", ..." if len(value) > 12 else "") + "]"
    return json.dumps(str(value), ensure_ascii=False)
