"""The validation toolkit: :class:`ConfigError`, the key-path messages, :class:`_Checker`.

Every section reader walks its table with one :class:`_Checker`, which collects all errors
(one line each: key path, bad value, expectation) and the warnings; a value that failed is
``_BAD`` (already reported), an absent key ``_MISSING``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from vsi_numba.config._show import _join, _key, _render, _show  # noqa: F401 (re-exported)


class ConfigError(ValueError):
    """Invalid configuration: every problem found, one line each.

    Parameters
    ----------
    errors : list of str
        One message per problem, each naming the key path, the bad value and what was
        expected.
    source : str, optional
        The file (or "<mapping>") the errors come from.

    Attributes
    ----------
    errors : list of str
    source : str or None
    """

    def __init__(self, errors, source: str | None = None):
        self.errors = [str(e) for e in errors] or ["invalid configuration"]
        self.source = source
        n = len(self.errors)
        where = f" in {source}" if source else ""
        head = f"{n} error{'s' if n != 1 else ''}{where}:"
        super().__init__("\n".join([head, *(f"  {e}" for e in self.errors)]))


class _Sentinel:
    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return f"<{self.name}>"


_MISSING = _Sentinel("missing")  # key absent (as default: the key is required)
_BAD = _Sentinel("bad")  # value present but invalid (already reported)



def _did_you_mean(word: str, choices) -> str | None:
    choices = [str(c) for c in choices]
    low = {c.lower(): c for c in choices}
    if str(word).lower() in low:
        return low[str(word).lower()]
    swapped = [c for c in low if sorted(c) == sorted(str(word).lower())]  # "stpe" -> step
    if len(swapped) == 1:
        return low[swapped[0]]
    close = difflib.get_close_matches(str(word).lower(), list(low), n=1, cutoff=0.6)
    if close:
        return low[close[0]]
    w = str(word).lower()
    part = [c for c in low  # "mass" -> mass_per_length
            if min(len(w), len(c)) >= 3 and (w in c or c in w)]
    return low[part[0]] if len(part) == 1 else None


def _is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _finite(v) -> bool:
    try:
        return math.isfinite(float(v))
    except OverflowError:  # an int beyond the float range
        return False


def _as_list(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, tuple):
        return list(v)
    return v


class _Checker:
    """Collects errors and warnings while walking the config."""

    def __init__(self):
        self.errors: list[str] = []
        self.warnings: list[str] = []
        self.records: list[dict] = []  # one per warning: message, kind, keys
        #: values outside the plausible range of their key (refused unless
        #: solver.allow_implausible: :func:`_refuse`)
        self.implausible: list[str] = []

    # -- reporting
    def error(self, path: str, value, expected: str) -> _Sentinel:
        if value is _MISSING:
            self.errors.append(f"{path}: missing required key; expected {expected}")
        else:
            self.errors.append(f"{path} = {_show(value)}: expected {expected}")
        return _BAD

    def warn(self, message: str, kind: str = "input", keys=()) -> None:
        """Record a warning; ``kind`` is "resolution" for a time-step resolution warning
        (checks computed under it are not reliable), else "input" or "plausibility"."""
        self.warnings.append(message)
        self.records.append({"message": message, "kind": kind, "keys": list(keys)})

    # -- tables
    def table(self, data, path: str, allowed, *, elsewhere=None, ignored=None, what="",
              hidden=()):
        """Check that ``data`` is a table and report unknown keys (with did-you-mean).

        ``elsewhere`` maps keys valid for another kind to a hint; ``ignored`` maps keys
        that are legal but unused here to a reason (warning, not error); ``hidden`` keys
        (overrides) are accepted but not listed in the hints.
        """
        if not isinstance(data, Mapping):
            return self.error(path, data, f"a table{what}")
        for key, value in data.items():
            if not isinstance(key, str):
                self.error(_join(path, key), value, "string keys only")
                continue
            if key in allowed or key in hidden:
                continue
            kp = _join(path, key)
            if ignored and key in ignored:
                self.warn(f"{kp} is ignored: {ignored[key]}")
                continue
            if elsewhere and key in elsewhere:
                self.error(kp, value, elsewhere[key])
                continue
            guess = _did_you_mean(key, allowed)
            hint = (
                f"did you mean '{guess}'?"
                if guess
                else "expected one of " + ", ".join(f"'{a}'" for a in sorted(allowed))
            )
            self.errors.append(f"{kp} = {_show(value)}: unknown key; {hint}")
        return data

    # -- scalars
    def number(self, value, path: str, tp, expected: str):
        """Validate one number against its declared type ``tp`` (:func:`~vsi_numba.config.
        schema._fields.Num`, :func:`~vsi_numba.config.schema._fields.Int` with their
        bounds, or ``float``); return float/int or ``_BAD`` (reported with
        ``expected``)."""
        from vsi_numba.config.schema._fields import number_of

        x = number_of(tp, value)
        if x is None:
            return self.error(path, value, expected)
        return x

    def get_number(self, tbl, path: str, key: str, tp, expected: str, default=_MISSING):
        """Read ``tbl[key]`` as a number of type ``tp`` (:meth:`number`); ``default`` when
        absent (``_MISSING``: a required key, reported missing)."""
        p = _join(path, key)
        if key not in tbl:
            if default is _MISSING:
                return self.error(p, _MISSING, expected)
            return default
        return self.number(tbl[key], p, tp, expected)

    def fields(self, tbl, path: str, model, keys=None, *, required=None, notes=None) -> dict:
        """Read declared keys of ``model`` (:mod:`vsi_numba.config.schema.models`) from
        ``tbl``, each validated by its declaration (type, bounds; pydantic, strict) and
        reported in the message style of this module: key path, value, the declared
        expectation (for a closed set: the choices and a did-you-mean).  An absent key
        takes its declared default; a required one (``required`` overrides the
        declaration per key) is reported missing.  Returns key -> value or ``_BAD``."""
        from pydantic import ValidationError

        from vsi_numba.config.schema._fields import (
            adapter,
            choices_of,
            expected_of,
            implausible,
        )

        out = {}
        for key in (keys if keys is not None else model.model_fields):
            f = model.model_fields[key]
            p = _join(path, key)
            choices = choices_of(model, key)
            expected = expected_of(model, key)
            if choices is not None:
                listing = ", ".join(f"'{c}'" for c in choices)
                expected = (f"one of {listing}" if len(choices) > 1 else listing) + (
                    (notes or {}).get(key, ""))
            if key not in tbl:
                req = f.is_required() if required is None or key not in required \
                    else required[key]
                out[key] = self.error(p, _MISSING, expected) if req else f.get_default()
                continue
            v = tbl[key]
            try:
                out[key] = adapter(model, key).validate_python(v)
                self.implausible += implausible(model, key, p, out[key])
            except ValidationError:
                hint = ""
                if choices is not None and isinstance(v, str):
                    guess = _did_you_mean(v, choices)
                    hint = f" (did you mean '{guess}'?)" if guess else ""
                out[key] = self.error(p, v, expected + hint)
        return out

    def table_list(self, items, path: str, model, *, expected: str, what: str,
                   max_len: int):
        """Read a list of 1 to ``max_len`` tables, each of the declared keys of ``model``
        (:meth:`table`, :meth:`fields`; keys given as None dropped): the list of
        resolved tables, or ``_BAD`` (every problem reported)."""
        from vsi_numba.config.schema._fields import keys_of

        if not isinstance(items, list) or not items or len(items) > max_len:
            return self.error(path, items, expected)
        out = []
        for i, it in enumerate(items):
            p = f"{path}[{i}]"
            if self.table(it, p, keys_of(model), what=what) is _BAD:
                out = _BAD
                continue
            v = self.fields(it, p, model)
            if out is not _BAD and _ok(*v.values()):
                out.append({k: x for k, x in v.items() if x is not None})
            else:
                out = _BAD
        return out

    def number_list(self, value, path: str, item, item_expected: str, *, expected: str,
                    scalar_ok: bool = False, min_len: int = 1, max_len: int | None = None):
        """Read a list of numbers of type ``item`` (:meth:`number`, each reported with
        ``item_expected``), or a single number when ``scalar_ok``; ``expected`` is the
        list's expectation."""
        value = _as_list(value)
        if scalar_ok and _is_number(value):
            return self.number(value, path, item, item_expected)
        if not isinstance(value, list):
            return self.error(path, value, expected)
        if len(value) < min_len or (max_len is not None and len(value) > max_len):
            return self.error(path, value, expected)
        out = [self.number(v, f"{path}[{i}]", item, item_expected)
               for i, v in enumerate(value)]
        return _BAD if any(o is _BAD for o in out) else out

    def string(self, tbl, path: str, key: str, expected: str, default=_MISSING, nonempty=True):
        p = _join(path, key)
        if key not in tbl:
            return self.error(p, _MISSING, expected) if default is _MISSING else default
        v = tbl[key]
        if not isinstance(v, str) or (nonempty and not v.strip()):
            return self.error(p, v, expected)
        return v

    def choice(self, tbl, path: str, key: str, choices, default=_MISSING, note: str = ""):
        p = _join(path, key)
        listing = ", ".join(f"'{c}'" for c in choices)
        listing = f"one of {listing}" if len(choices) > 1 else listing
        if key not in tbl:
            if default is _MISSING:
                return self.error(p, _MISSING, f"{listing}{note}")
            return default
        v = tbl[key]
        if isinstance(v, str) and v in choices:
            return v
        hint = ""
        if isinstance(v, str):
            guess = _did_you_mean(v, choices)
            if guess:
                hint = f" (did you mean '{guess}'?)"
        return self.error(p, v, f"{listing}{note}{hint}")

    def boolean(self, tbl, path: str, key: str, default):
        if key not in tbl:
            return default
        v = tbl[key]
        if not isinstance(v, bool):
            return self.error(_join(path, key), v, "true or false")
        return v

    def file(self, tbl, path: str, key: str, base_dir: Path, what: str, default=_MISSING):
        """Read the path of an existing file (relative to ``base_dir``): (given, resolved)."""
        p = _join(path, key)
        if key not in tbl:
            if default is _MISSING:
                self.error(p, _MISSING, f"the path of {what}")
                return _BAD, _BAD
            return default, default
        v = tbl[key]
        if not isinstance(v, str) or not v.strip() or "\x00" in v:
            self.error(p, v, f"the path of {what} (a string)")
            return _BAD, _BAD
        full = _resolve(base_dir, v)
        if full is None:
            self.error(p, v, f"a valid path of {what}")
            return _BAD, _BAD
        try:
            exists = full.is_file()
        except (OSError, ValueError):
            exists = False
        if not exists:
            self.error(p, v, f"an existing file with {what} (looked for {full})")
            return _BAD, _BAD
        return v, full


def _resolve(base_dir: Path, given: str) -> Path | None:
    """Return ``base_dir / given`` resolved, or None for an unusable path (``~nobody``)."""
    try:
        return (base_dir / Path(given).expanduser()).resolve()
    except (OSError, ValueError, RuntimeError):
        return None


def _ok(*values) -> bool:
    return not any(v is _BAD for v in values)


def _drop_none(d: dict) -> dict:
    return {k: v for k, v in d.items() if v is not None}


def _refuse(chk, solver, override: str, message: str) -> None:
    """An error unless ``solver.<override> = true`` (then a warning)."""
    if solver.get(override):
        chk.warn(f"{message} (accepted: solver.{override} = true)", "plausibility")
    else:
        chk.errors.append(f"{message}; set solver.{override} = true to run it anyway")
