"""TOML configuration: parse, validate (every error at once), build the model objects.

The keys are the contract of the design note, section 4: same names, same meaning, SI
units unless the key says otherwise (``speeds_kmh``).  A config is data only: nothing in
it is evaluated or imported.

Validation runs before any computation and collects *all* problems of a file in one
:class:`ConfigError`.  Each message is one line naming the key path, the bad value and
what was expected, e.g.::

    bridge.spans[1] = -3.0: expected a span length > 0 m
    bridge.spna = [25.0]: unknown key; did you mean 'spans'?

Physically suspicious but legal input (time step too coarse for the retained modes,
modes missing below the EN 1990 A2 cut-off, ...) is reported in :attr:`Config.warnings`.

Keys (units; default)
---------------------
``title`` (file stem).
``[bridge]`` ``kind`` = simply_supported | continuous | rigid | modes_file (required);
``spans`` (m, one per span; one value for simply_supported and rigid); ``EI`` (N m^2) and
``mass_per_length`` (kg/m), a number or one per span; ``damping_ratio`` (-, a number or
one per mode; 0); ``n_modes`` (10 unless ``max_frequency``, Hz, is given; both: the
smaller set); ``elements_per_span`` (continuous; 40); ``output_points`` (m; every
mid-span).  Imported bridges (formats: :mod:`vsi_numba.model.imported`), read and
checked at load time: modes_file (``file``, netCDF or CSV; ``track_line`` when it has
several; ``mass_normalised`` true when there is no modal_mass; n_modes default: every mode
of the file) | matrices (``stiffness_matrix``, ``mass_matrix`` Matrix Market;
``station_map`` CSV; ``fixed_dofs`` [] = supports already applied; ``dof_base`` 0;
``rotation_sign`` 1; ``vertical_dofs`` station DOFs, or {start, step}; ``track_line``);
both: ``spans`` optional (m along the track line; the table must cover their sum).
``[bridge.track]`` (continuous only; values per track, both rails): ``rail_EI`` (N m^2),
``rail_mass_per_length`` (kg/m), ``pad_stiffness`` (N/m per sleeper), ``pad_damping``
(N s/m; 0), ``sleeper_mass`` (kg), ``sleeper_spacing`` (m), ``ballast_stiffness`` (N/m
per sleeper), ``ballast_damping`` (N s/m; 0), ``rail_elements_per_bay`` (2): a track
layer assembled with the deck before the modal reduction; the train runs on the rail
(see :class:`vsi_numba.model.bridge.TrackLayer` for when it is needed and what it costs:
a warning says how many modes keep 95 % of the rail's static flexibility).
``[train]`` exactly one of ``preset`` (library name or list; one train each), ``file``
(user train TOML, see :func:`vsi_numba.model.library.load_user_trains`) or
``[[train.vehicles]]`` (one train, ``name``: default ``title``, else "custom"); ``model`` =
interaction | moving_force for presets (default: interaction where the library has
vehicle dynamics, moving forces for the HSLM load models).  A vehicle has ``kind`` =
force (``load``, N) | sprung_mass (``mass``, ``stiffness``, ``damping`` 0,
``wheel_mass`` 0) | car (the [whole] values of ``data/trains.toml`` plus
``body_cg_to_front_bogie``, default mid-way) | user (``M``, ``C``, ``K``, ``wheel_dofs``,
``wheel_positions``, ``gravity`` g diag(M), ``body_dof`` -1); ``offset`` (m behind the
train's first axle; 0) and ``name``.  Vehicles are listed front to back, not overlapping.
``[irregularity]`` ``kind`` = none (default) | cosine (``depth``, ``wavelength``,
``position``, m) | step (``height``, ``length``, ``position``, ``shape`` cosine) | psd
(``spectrum``, ``wavelength_min``, ``wavelength_max``, ``seeds``, ``dx``) | file
(``path``, ``x_column`` x, ``r_column`` r, ``r_unit`` m, ``dx``); ``[[irregularity.defects]]``
(cosine / step) are added to every realisation.
``[solver]`` ``dt`` (s; 1e-3), ``hht_alpha`` (-0.3), ``approach`` (m; 5),
``free_vibration`` (s; 1), ``max_iterations`` (50), ``max_subdivisions`` (4),
``acceleration_cutoff`` (Hz; EN 1990 A2 rule).
``[contact]`` ``model`` = rigid (default) | hertz | hertz_linear (as offered by
:mod:`vsi_numba.solver.settings`), ``hertz_coefficient`` G (m N^-2/3; required for Hertz).
``[track]`` ``model`` = elastic (default: the rail on a Winkler foundation over the deck
and the approaches, :mod:`vsi_numba.model.track`) | rigid (the rigid-track idealisation:
a kink at the deck ends); ``foundation_stiffness`` (N/m per metre of track, both rails;
8.51e7: 150 kN/mm per axle with UIC60 rails) and ``rail_EI`` (N m^2, both rails; 1.283e7,
UIC60).  Not with ``[bridge.track]``, whose FE track layer is then the track.
``[study]`` ``speeds_kmh`` (list, or {start, stop, step} with stop included when on the
grid) or ``line_speed_kmh`` (then 140 .. 1.2 x line speed, step 5, 1.2 x line speed
included); ``output`` (results/<stem>.nc); ``save_time_histories`` (true);
``history_speeds_kmh`` (all).

Example
-------
>>> cfg = load_config("configs/quickstart.toml")            # doctest: +SKIP
>>> bridge, trains = cfg.build_bridge(), cfg.trains()        # doctest: +SKIP
"""

from __future__ import annotations

import difflib
import hashlib
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsi_numba.model import bridge as _bridge
from vsi_numba.model import irregularity as _irr
from vsi_numba.model import track as _track
from vsi_numba.model import vehicle as _veh
from vsi_numba.solver import settings as _settings
from vsi_numba.solver.settings import SolverSettings

__all__ = ["Config", "ConfigError", "load_config"]

BRIDGE_KINDS = ("simply_supported", "continuous", "rigid", "modes_file", "matrices")
VEHICLE_KINDS = ("force", "sprung_mass", "car", "user")
IRREGULARITY_KINDS = ("none", "cosine", "step", "psd", "file")
DEFECT_KINDS = ("cosine", "step")
TRAIN_MODELS = ("interaction", "moving_force")
CONTACT_MODELS = tuple(_settings.CONTACT_MODELS) if hasattr(_settings, "CONTACT_MODELS") else (
    "rigid",)

DT_RESOLUTION = 0.1  # dt * f above this: fewer than 10 steps per period (warning)
STEPS_PER_WAVELENGTH = 10  # fewer time steps per shortest irregularity wavelength: warning
MAX_SPEEDS = 10_000  # cap on the number of speeds of one study
MAX_MODES = 1000  # cap on bridge.n_modes
MAX_ELEMENTS = 1000  # cap on spans * elements_per_span (the eigenproblem runs at load time)
MAX_USER_DOFS = 200  # cap on the size of a user vehicle
MAX_VEHICLES = 500  # cap on explicit vehicles
DT_ERROR = 0.25  # dt * f above this (fewer than 4 steps per period): error
MAX_STEPS = 50_000_000  # time steps of the slowest run: above this the run is refused
MAX_HISTORY_BYTES = 2 * 1024**3  # time histories of one run kept in memory: at most 2 GiB
MAX_PROFILE_SAMPLES = 20_000_000  # samples of one irregularity profile (its FFT included)
MAX_STATIC_DEFLECTION = 1.0 / 50.0  # static deck deflection / span: above this, error
MAX_HERTZ_PENETRATION = 0.010  # m, static Hertz penetration of a wheel: above this, error
MAX_PROFILE_AMPLITUDE = 0.050  # m, |r| of a profile: above this, error
LONG_TRAIN = 1000.0  # m, a longer train gets a warning

#: Keys that accept a result the checks below refuse (never listed in hints).
SOLVER_OVERRIDES = {
    "allow_coarse_dt": "fewer than 4 time steps per period of a retained frequency",
    "allow_large_problem": "runs or profiles beyond the memory/time budget",
    "allow_implausible": "implausible physical input (deflection, penetration, profile "
                         "amplitude, vehicle stiffness)",
}


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


# ------------------------------------------------------------------------------ helpers


class _Sentinel:
    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return f"<{self.name}>"


_MISSING = _Sentinel("missing")  # key absent (as default: the key is required)
_BAD = _Sentinel("bad")  # value present but invalid (already reported)

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


@dataclass(frozen=True)
class _Num:
    """A numeric key: expectation text, limits, default (``_MISSING`` = required)."""

    expected: str
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    default: Any = _MISSING
    integer: bool = False


class _Checker:
    """Collects errors and warnings while walking the config."""

    def __init__(self):
        self.errors: list[str] = []
        self.warnings: list[str] = []
        self.records: list[dict] = []  # one per warning: message, kind, keys

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
    def number(self, value, path: str, spec: _Num):
        """Validate one number against ``spec``; return float/int or ``_BAD``."""
        if spec.integer:
            ok = isinstance(value, int) and not isinstance(value, bool)
        else:
            ok = _is_number(value) and _finite(value)
        if ok:
            x = int(value) if spec.integer else float(value)
            ok = (
                (spec.gt is None or x > spec.gt)
                and (spec.ge is None or x >= spec.ge)
                and (spec.lt is None or x < spec.lt)
                and (spec.le is None or x <= spec.le)
            )
        if not ok:
            return self.error(path, value, spec.expected)
        return x

    def get_number(self, tbl, path: str, key: str, spec: _Num):
        """Read ``tbl[key]`` as a number; default, ``None`` (optional) or ``_BAD``."""
        p = _join(path, key)
        if key not in tbl:
            if spec.default is _MISSING:
                return self.error(p, _MISSING, spec.expected)
            return spec.default
        return self.number(tbl[key], p, spec)

    def numbers(self, tbl, path, specs: dict[str, _Num]) -> dict:
        """Read several numeric keys; the result maps key -> value (or ``_BAD``)."""
        return {k: self.get_number(tbl, path, k, s) for k, s in specs.items()}

    def number_list(self, value, path: str, item: _Num, *, expected: str,
                    scalar_ok: bool = False, min_len: int = 1, max_len: int | None = None):
        """Read a list of numbers (or a single number when ``scalar_ok``)."""
        value = _as_list(value)
        if scalar_ok and _is_number(value):
            return self.number(value, path, item)
        if not isinstance(value, list):
            return self.error(path, value, expected)
        if len(value) < min_len or (max_len is not None and len(value) > max_len):
            return self.error(path, value, expected)
        out = [self.number(v, f"{path}[{i}]", item) for i, v in enumerate(value)]
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


# ---------------------------------------------------------------------------- sections


@dataclass
class _BridgeSpec:
    kind: str
    resolved: dict
    length: float | None = None
    model: _bridge.ModalBridge | None = None
    all_frequencies: np.ndarray | None = None  # the spectrum up to the EN 1990 cut-off
    output_points: np.ndarray | None = None


_POS = _Num("a value > 0", gt=0)


def _per_span(chk, tbl, path, key, expected, n_spans):
    """EI / mass_per_length: a number > 0 or one per span."""
    p = _join(path, key)
    if key not in tbl:
        return chk.error(p, _MISSING, f"{expected} (a number, or one per span)")
    item = _Num(expected, gt=0)
    v = chk.number_list(
        tbl[key], p, item, scalar_ok=True,
        expected=f"{expected} (a number, or a list with one value per span)",
    )
    if isinstance(v, list) and n_spans is not None and len(v) != n_spans:
        return chk.error(
            p, tbl[key],
            f"one value per span ({n_spans} span{'s' if n_spans != 1 else ''}) or a single number",
        )
    return v


TRACK_TYPES = ("ballasted", "direct_fastening")


def _bridge_section(chk: _Checker, d, base_dir: Path, solver_cutoff) -> _BridgeSpec | _Sentinel:
    path = "bridge"
    allowed_all = {
        "kind", "spans", "EI", "mass_per_length", "damping_ratio", "n_modes",
        "max_frequency", "elements_per_span", "output_points", "file", *_IMPORT_KEYS,
        "track", "track_type", "deck_type", "additional_damping",
    }
    if not isinstance(d, Mapping):
        return chk.error(path, d, "a table [bridge] with kind, spans, EI, mass_per_length")
    kind = chk.choice(d, path, "kind", BRIDGE_KINDS)
    classic = allowed_all - {"file", "track", *_IMPORT_KEYS}
    modal = {"kind", "damping_ratio", "n_modes", "max_frequency", "output_points", "spans",
             "track_line"}
    used = {
        "simply_supported": classic - {"elements_per_span"},
        "continuous": classic | {"track"},
        "rigid": {"kind", "spans", "output_points"},
        "modes_file": modal | {"file", "mass_normalised"},
        "matrices": modal | {"stiffness_matrix", "mass_matrix", "station_map", "fixed_dofs",
                             "dof_base", "rotation_sign", "vertical_dofs"},
    }
    if kind is _BAD:
        chk.table(d, path, allowed_all)
        return _BAD
    for k in used:
        used[k] = used[k] | {"track_type"}
    ignored = {k: f"not used by bridge.kind = '{kind}'" for k in allowed_all - used[kind]}
    ignored.pop("track", None)
    chk.table(d, path, used[kind], ignored=ignored, elsewhere={"track": (
        f"no [bridge.track] with kind = '{kind}': the track layer is assembled into the FE "
        "model of kind = 'continuous' (use it with a single span for one span)")})

    # spans
    spans = _BAD
    one_span = kind in ("simply_supported", "rigid")
    span_expect = (
        "a span length > 0 m (one value)" if one_span
        else "a list of span lengths > 0 m (one per span)"
    )
    if "spans" in d:
        spans = chk.number_list(
            d["spans"], "bridge.spans", _Num("a span length > 0 m", gt=0),
            expected=span_expect, scalar_ok=True, min_len=1, max_len=200,
        )
        if _is_number(spans):
            spans = [spans]
        if isinstance(spans, list) and one_span and len(spans) != 1:
            more = " (use kind = 'continuous' for several spans)" if kind != "rigid" else ""
            spans = chk.error("bridge.spans", d["spans"], f"one span length for kind = "
                              f"'{kind}'{more}")
    elif kind not in _IMPORTED:
        chk.error("bridge.spans", _MISSING, span_expect)
    if kind in _IMPORTED and "spans" not in d:
        spans = None  # optional: the track line's length comes from the file
    n_spans = len(spans) if isinstance(spans, list) else None
    length = float(sum(spans)) if isinstance(spans, list) else None

    res: dict[str, Any] = {"kind": kind}
    # EN 1990 A2.4.4.2.1(4)P: the deck-acceleration limit depends on the track form
    res["track_type"] = chk.choice(d, path, "track_type", TRACK_TYPES, default="ballasted")
    if isinstance(spans, list):
        res["spans"] = spans
    flexible = kind in ("simply_supported", "continuous")
    ei = mass = damping = n_modes = fmax = _BAD
    eps = None
    if flexible:
        ei = _per_span(chk, d, path, "EI", "a bending stiffness EI > 0 N m^2", n_spans)
        mass = _per_span(chk, d, path, "mass_per_length", "a mass per length > 0 kg/m", n_spans)
        res.update(EI=ei, mass_per_length=mass)
    if kind != "rigid":
        damping = 0.0
        if d.get("damping_ratio") == EN_DAMPING:
            damping = _en_damping(chk, d, kind, spans, res)
        elif "damping_ratio" in d:
            damping = chk.number_list(
                d["damping_ratio"], "bridge.damping_ratio",
                _Num("a damping ratio 0 <= zeta < 1", ge=0, lt=1), scalar_ok=True,
                expected="a damping ratio 0 <= zeta < 1, a list with one per mode, or "
                         f"'{EN_DAMPING}' (Table 6.6 with bridge.deck_type)",
            )
        if "deck_type" in d and d.get("damping_ratio") != EN_DAMPING:
            chk.error("bridge.deck_type", d["deck_type"], "only with damping_ratio = "
                      f"'{EN_DAMPING}' (the Table 6.6 lower bound of that deck type)")
        if "additional_damping" in d:
            _additional_damping(chk, d, kind, spans, res)
        n_spec = _Num(f"an integer number of modes 1 <= n_modes <= {MAX_MODES}", ge=1,
                      le=MAX_MODES, integer=True, default=None)
        n_modes = chk.get_number(d, path, "n_modes", n_spec)
        fmax = chk.get_number(d, path, "max_frequency",
                              _Num("a frequency > 0 Hz", gt=0, default=None))
        if n_modes is None and fmax is None and kind != "modes_file":
            n_modes = 10  # modes_file: default every mode of the file
        res.update(damping_ratio=damping, n_modes=n_modes, max_frequency=fmax)
    if kind == "continuous":
        eps = chk.get_number(d, path, "elements_per_span", _Num(
            "an integer number of elements 1 <= elements_per_span <= 400", ge=1, le=400,
            integer=True, default=40))
        if _ok(eps) and n_spans is not None and n_spans * eps > MAX_ELEMENTS:
            eps = chk.error("bridge.elements_per_span", eps,
                            f"at most {MAX_ELEMENTS} elements in all ({n_spans} spans x "
                            f"{eps} = {n_spans * eps})")
        res["elements_per_span"] = eps
    track = None
    if kind == "continuous" and "track" in d:
        track = _track_section(chk, d["track"], spans)
        res["track"] = track
    imported = None
    if kind in _IMPORTED:
        imported = _imported_bridge(chk, d, base_dir, kind, res, spans, damping, n_modes,
                                    fmax, solver_cutoff)
        if imported is not _BAD:
            length = imported.bridge.length

    # output points
    points = _BAD
    if "output_points" in d:
        points = chk.number_list(d["output_points"], "bridge.output_points",
                                 _Num("a position x (m)"), scalar_ok=True,
                                 expected="a list of positions on the deck (m)")
        if _is_number(points):
            points = [points]
        if isinstance(points, list) and length is not None:
            for i, x in enumerate(points):
                if not -1e-9 <= x <= length + 1e-9:
                    chk.error(f"bridge.output_points[{i}]", x,
                              f"a position on the bridge, 0 <= x <= {length:g} m")
                    points = _BAD
    elif isinstance(spans, list) and kind not in _IMPORTED:
        edges = np.concatenate([[0.0], np.cumsum(spans)])
        points = (0.5 * (edges[:-1] + edges[1:])).tolist()
    elif imported is not None and imported is not _BAD:
        edges = np.asarray(imported.bridge.supports, float)
        points = (0.5 * (edges[:-1] + edges[1:])).tolist()
        if edges.size == 2 and not isinstance(spans, list):
            chk.warn(f"bridge.output_points: the supports along the track line are unknown "
                     f"(give bridge.spans); the default output point is the middle of the "
                     f"{edges[-1]:g} m line, x = {points[0]:g} m")
    if isinstance(points, list):
        res["output_points"] = points

    spec = _BridgeSpec(kind=kind, resolved=_drop_none(res), length=length)
    if not _ok(spans, points) or (flexible and not _ok(ei, mass, damping, n_modes, fmax, eps,
                                                       track)):
        return _BAD
    spec.output_points = np.asarray(points, float)
    if kind in _IMPORTED:
        if imported is None or imported is _BAD:
            return _BAD
        spec.model = imported.bridge
        spec.all_frequencies = imported.all_frequencies
        return spec
    if kind == "rigid":
        spec.model = _bridge.rigid(length)
        return spec
    if track is not None:
        return _track_bridge(chk, spec, spans, ei, mass, n_modes, fmax, eps, damping, track)
    model = _flexible_bridge(chk, spec, spans, ei, mass, n_modes, fmax, eps, solver_cutoff)
    if model is _BAD:
        return _BAD
    n = model.n_modes
    if isinstance(damping, list) and len(damping) < n:
        return chk.error("bridge.damping_ratio", damping,
                         f"a single ratio or at least one per retained mode ({n} modes)")
    zeta = np.asarray(damping[:n] if isinstance(damping, list) else [damping] * n, float)
    spec.model = _bridge.ModalBridge(
        kind=model.kind, length=model.length, frequencies=model.frequencies, damping=zeta,
        nodes=model.nodes, values=model.values, slopes=model.slopes,
        supports=model.supports, description=model.description,
    )
    return spec


_TRACK_FIELDS = {
    "rail_EI": _Num("a bending stiffness of both rails > 0 N m^2 (2 x 6.42e6 for UIC60)",
                    gt=0),
    "rail_mass_per_length": _Num("a mass of both rails > 0 kg/m (2 x 60.3 for UIC60)", gt=0),
    "pad_stiffness": _Num("a rail pad stiffness per sleeper (both rail seats) > 0 N/m", gt=0),
    "pad_damping": _Num("a rail pad damping per sleeper >= 0 N s/m", ge=0, default=0.0),
    "sleeper_mass": _Num("a sleeper mass > 0 kg", gt=0),
    "sleeper_spacing": _Num("a sleeper spacing > 0 m", gt=0),
    "ballast_stiffness": _Num("a ballast stiffness per sleeper > 0 N/m", gt=0),
    "ballast_damping": _Num("a ballast damping per sleeper >= 0 N s/m", ge=0, default=0.0),
    "rail_elements_per_bay": _Num("an integer number of rail elements between sleepers, "
                                  "1 .. 8", ge=1, le=8, integer=True, default=2),
}
MAX_TRACK_DOFS = 4000  # deck + rail + sleepers (dense eigensolution at load time)
FLEXIBILITY_WARNING = 0.95  # share of the static rail flexibility kept by the modes


EN_DAMPING = "EN1991-2"


def _span_for_damping(kind, spans):
    """The span L of EN 1991-2 Table 6.6 and §6.4.6.3.1: the span of a simply supported
    deck, the mean span of a continuous one [R]."""
    return float(np.mean(spans))


def _en_damping(chk, d, kind, spans, res):
    """``damping_ratio = 'EN1991-2'``: the Table 6.6 lower bound of ``deck_type``."""
    from vsi_numba import en1991

    deck = chk.choice(d, "bridge", "deck_type", tuple(en1991.DECK_TYPES))
    if kind not in ("simply_supported", "continuous"):
        return chk.error("bridge.damping_ratio", EN_DAMPING, "a number for bridge.kind = "
                         f"'{kind}' (Table 6.6 is for simply supported and continuous decks)")
    if not _ok(deck) or not isinstance(spans, list):
        return _BAD
    span = _span_for_damping(kind, spans)
    zeta = en1991.damping_lower_bound(deck, span)
    res["damping_rule"] = (f"EN 1991-2 Table 6.6, {deck.replace('_', ' ')}, L = {span:g} m: "
                           f"zeta = {100 * zeta:.4g} %")
    res["deck_type"] = deck
    return zeta


def _additional_damping(chk, d, kind, spans, res):
    """``additional_damping = true``: EN 1991-2 §6.4.6.3.1 for moving-force trains."""
    from vsi_numba import en1991

    on = chk.boolean(d, "bridge", "additional_damping", False)
    if not _ok(on) or not on:
        return
    if kind not in ("simply_supported", "continuous"):
        chk.error("bridge.additional_damping", True, "false for bridge.kind = "
                  f"'{kind}' (the rule is for simply supported and continuous decks)")
        return
    if isinstance(spans, list):
        span = _span_for_damping(kind, spans)
        res["additional_damping"] = en1991.additional_damping(span)
        res["additional_damping_rule"] = (
            f"EN 1991-2 6.4.6.3.1, L = {span:g} m: dzeta = "
            f"{100 * res['additional_damping']:.4g} % added for moving-force trains only")


def _track_section(chk, t, spans):
    """[bridge.track]: the track layer of a continuous deck (values per track)."""
    path = "bridge.track"
    if chk.table(t, path, set(_TRACK_FIELDS), what=" [bridge.track] of track-layer values") \
            is _BAD:
        return _BAD
    vals = chk.numbers(t, path, _TRACK_FIELDS)
    if not _ok(*vals.values()):
        return _BAD
    if isinstance(spans, list):
        a, n_e = vals["sleeper_spacing"], vals["rail_elements_per_bay"]
        if a > 0.5 * min(spans):
            return chk.error(f"{path}.sleeper_spacing", a,
                             f"a spacing of at most half the shortest span ({min(spans):g} m)")
        n_rail = 2 * n_e * (sum(spans) / a + 1)
        if n_rail + sum(spans) / a > MAX_TRACK_DOFS:
            return chk.error(f"{path}.sleeper_spacing", a,
                             f"a track layer of at most {MAX_TRACK_DOFS} rail and sleeper DOFs "
                             f"(this one has about {n_rail + sum(spans) / a:.0f}: fewer "
                             "rail_elements_per_bay, or a shorter deck)")
    return vals


def _track_bridge(chk, spec, spans, ei, mass, n_modes, fmax, eps, damping, track):
    """Continuous deck + track layer: modes of the assembly, along the rail."""
    layer = _bridge.TrackLayer(**track)
    try:
        with np.errstate(all="ignore"):
            model, rep = _bridge.continuous_with_track(
                spans, ei, mass, layer, n_modes, fmax, damping, eps, report=True)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        if "damping_ratio" in str(exc):
            return chk.error("bridge.damping_ratio", damping,
                             f"a single ratio or at least one per retained mode ({exc})")
        return chk.error("bridge.track", track, f"a buildable deck and track layer ({exc})")
    spec.model = model
    spec.all_frequencies = rep.all_frequencies
    if rep.flexibility_fraction < FLEXIBILITY_WARNING:
        chk.warn(
            f"bridge.track: the {model.n_modes} retained modes (up to "
            f"{model.frequencies[-1]:.4g} Hz) keep {100 * rep.flexibility_fraction:.0f}% of "
            f"the static rail deflection under a wheel (x = {rep.probe_x:g} m); the track "
            f"modes start at {rep.first_track_frequency:.4g} Hz and 95% needs "
            f"{rep.modes_for_95} modes (bridge.n_modes = {rep.modes_for_95}, up to "
            f"{rep.frequency_for_95:.4g} Hz, with solver.dt <= "
            f"{DT_RESOLUTION / rep.frequency_for_95:.2g} s); with fewer the track is too stiff "
            "under the wheels"
        )
    return spec


_IMPORTED = ("modes_file", "matrices")
_IMPORT_KEYS = ("track_line", "mass_normalised", "stiffness_matrix", "mass_matrix",
                "station_map", "fixed_dofs", "dof_base", "rotation_sign", "vertical_dofs")
_IMPORT_FILES = {
    "file": "the deck modes (frequencies, modal masses, mode shapes at stations)",
    "stiffness_matrix": "the stiffness matrix K (Matrix Market)",
    "mass_matrix": "the mass matrix M (Matrix Market)",
    "station_map": "the station map (CSV: x, dof, rotation_dof, line)",
}
MAX_FIXED_DOFS = 100_000


def _dof_indices(chk, d, key, base, allow_pattern=False):
    """A list of DOF numbers >= dof_base (or, when allowed, a {start, step} table)."""
    p = _join("bridge", key)
    v = _as_list(d[key])
    if allow_pattern and isinstance(v, Mapping):
        chk.table(v, p, {"start", "step"})
        start = chk.get_number(v, p, "start", _Num(
            f"an integer DOF number >= dof_base ({base})", ge=base, integer=True, default=base))
        step = chk.get_number(v, p, "step", _Num(
            "an integer step >= 1", ge=1, integer=True, default=1))
        return {"start": start, "step": step} if _ok(start, step) else _BAD
    expected = f"a list of integer DOF numbers >= dof_base ({base})" + (
        ", or {start = i, step = s}" if allow_pattern else "")
    if not isinstance(v, list) or len(v) > MAX_FIXED_DOFS:
        return chk.error(p, d[key], expected)
    out = [chk.number(x, f"{p}[{i}]", _Num(f"an integer DOF number >= dof_base ({base})",
                                            ge=base, integer=True)) for i, x in enumerate(v)]
    return out if _ok(*out) else _BAD


def _imported_bridge(chk, d, base_dir, kind, res, spans, damping, n_modes, fmax, cutoff):
    """kind = modes_file | matrices: read the files now (errors join the others)."""
    from vsi_numba.model import imported as _imp

    path = "bridge"
    files = ("file",) if kind == "modes_file" else ("stiffness_matrix", "mass_matrix",
                                                    "station_map")
    given, full = {}, {}
    for key in files:
        given[key], full[key] = chk.file(d, path, key, base_dir, _IMPORT_FILES[key])
        res[key] = given[key]
    line = chk.string(d, path, "track_line", "the name of a track line (string)",
                      default=None)
    res["track_line"] = line
    extra: dict[str, Any] = {}
    if kind == "modes_file":
        extra["mass_normalised"] = chk.boolean(d, path, "mass_normalised", None)
        res["mass_normalised"] = extra["mass_normalised"]
    else:
        base = chk.get_number(d, path, "dof_base", _Num(
            "0 (DOFs numbered from 0) or 1 (from 1)", ge=0, le=1, integer=True, default=0))
        sign = chk.get_number(d, path, "rotation_sign", _Num(
            "1 (rotation DOF = +dw/dx) or -1 (= -dw/dx)", default=1))
        if _ok(sign) and sign not in (1, -1):
            sign = chk.error("bridge.rotation_sign", d["rotation_sign"],
                             "1 (rotation DOF = +dw/dx) or -1 (= -dw/dx)")
        b0 = base if _ok(base) else 0
        fixed = _dof_indices(chk, d, "fixed_dofs", b0) if "fixed_dofs" in d else []
        vert = (_dof_indices(chk, d, "vertical_dofs", b0, allow_pattern=True)
                if "vertical_dofs" in d else None)
        res.update(dof_base=base, rotation_sign=sign, fixed_dofs=fixed, vertical_dofs=vert)
        extra = {"dof_base": base, "rotation_sign": float(sign) if _ok(sign) else sign,
                 "fixed_dofs": fixed, "vertical_dofs": vert}
    if not _ok(*full.values(), line, spans, damping, n_modes, fmax, *extra.values()):
        return _BAD
    zeta = damping if "damping_ratio" in d else None
    span_list = spans if isinstance(spans, list) else None
    try:
        if kind == "modes_file":
            out = _imp.read_modes_table(
                full["file"], track_line=line, n_modes=n_modes, max_frequency=fmax,
                damping_ratio=zeta, mass_normalised=extra["mass_normalised"],
                spans=span_list, name=given["file"])
        else:
            out = _imp.read_matrices(
                full["stiffness_matrix"], full["mass_matrix"], full["station_map"],
                fixed_dofs=extra["fixed_dofs"], dof_base=extra["dof_base"], track_line=line,
                n_modes=n_modes, max_frequency=fmax, damping_ratio=damping,
                rotation_sign=extra["rotation_sign"], vertical_dofs=extra["vertical_dofs"],
                spans=span_list, all_up_to=max(30.0, cutoff or 0.0),
                names={"stiffness": given["stiffness_matrix"], "mass": given["mass_matrix"],
                       "stations": given["station_map"]})
    except _imp.ModelFileError as exc:
        for key, value, expected in exc.problems:
            if key in given:
                value = given[key]
            chk.error(_join(path, key), _MISSING if value is None else value, expected)
        return _BAD
    except (ValueError, OSError, ArithmeticError, MemoryError) as exc:  # unforeseen content
        key = files[0]
        chk.error(_join(path, key), given[key],
                  f"{_IMPORT_FILES[key]} that can be read ({type(exc).__name__}: "
                  f"{' '.join(str(exc).split())[:160]})")
        return _BAD
    for w in out.warnings:
        chk.warn(w)
    return out


#: Shortest span (m) named as the cause when a deck gives no finite frequencies.
MIN_SPAN = 1.0


def _flexible_bridge(chk, spec, spans, ei, mass, n_modes, fmax, eps, solver_cutoff):
    """Build the modes now (cheap; the checks and warnings need the frequencies)."""
    length = spec.length
    try:
        with np.errstate(all="ignore"):
            if spec.kind == "simply_supported":
                ei1 = ei[0] if isinstance(ei, list) else ei
                m1 = mass[0] if isinstance(mass, list) else mass
                f1 = (np.pi / length) ** 2 * math.sqrt(ei1 / m1) / (2 * np.pi)
                cut = max(30.0, 9.0 * f1) if solver_cutoff is None else solver_cutoff
                jmax = min(int(math.floor(math.sqrt(cut / f1) + 1e-9)) + 1, 2 * MAX_MODES)
                allf = f1 * np.arange(1, jmax + 1) ** 2
            else:
                # every mode at once (one eigensolution); truncated below
                full = _bridge.continuous(spans, ei, mass, None, np.inf, 0.0, eps)
                allf = full.frequencies
            if not (allf.size and np.all(np.isfinite(allf)) and allf[0] > 0):
                if min(spans) < MIN_SPAN:  # the span, not EI, is what is off
                    return chk.error("bridge.spans", spans, f"spans of a railway bridge >= "
                                     f"{MIN_SPAN:g} m (with EI and mass_per_length they "
                                     "give no finite natural frequency)")
                return chk.error("bridge.EI", ei, "a value that, with mass_per_length and "
                                 "spans, gives finite natural frequencies > 0 Hz")
            spec.all_frequencies = allf
            if fmax is not None and fmax < allf[0]:
                return chk.error("bridge.max_frequency", fmax,
                                 f"a frequency >= the first mode ({allf[0]:.4g} Hz), else no "
                                 "mode is retained")
            if spec.kind == "simply_supported":
                return _bridge.simply_supported(length, ei1, m1, n_modes, fmax, 0.0)
            keep = allf.size if n_modes is None else min(n_modes, allf.size)
            if fmax is not None:
                keep = min(keep, int(np.count_nonzero(allf <= fmax)))
            return _bridge.ModalBridge(
                kind=full.kind, length=full.length, frequencies=allf[:keep].copy(),
                damping=np.zeros(keep), nodes=full.nodes,
                values=np.ascontiguousarray(full.values[:, :keep]),
                slopes=np.ascontiguousarray(full.slopes[:, :keep]), supports=full.supports,
                description=full.description,
            )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return chk.error("bridge.spans", spans, f"a buildable bridge ({exc})")


# -------------------------------------------------------------------------------- train

_VEHICLE_FIELDS: dict[str, dict[str, _Num]] = {
    "force": {"load": _Num("a force > 0 N (positive down)", gt=0)},
    "sprung_mass": {
        "mass": _Num("a mass > 0 kg", gt=0),
        "stiffness": _Num("a stiffness > 0 N/m", gt=0),
        "damping": _Num("a damping >= 0 N s/m", ge=0, default=0.0),
        "wheel_mass": _Num("a mass >= 0 kg (0 = massless contact point)", ge=0, default=0.0),
    },
    "car": {
        "body_mass": _Num("a mass > 0 kg", gt=0),
        "body_pitch_inertia": _Num("a pitch inertia > 0 kg m^2", gt=0),
        "bogie_mass": _Num("a mass > 0 kg", gt=0),
        "bogie_pitch_inertia": _Num("a pitch inertia > 0 kg m^2", gt=0),
        "wheelset_mass": _Num("a mass > 0 kg", gt=0),
        "bogie_spacing": _Num("a distance between bogie centres > 0 m", gt=0),
        "wheelbase": _Num("an axle distance within a bogie > 0 m", gt=0),
        "primary_stiffness": _Num("a stiffness > 0 N/m (per wheelset)", gt=0),
        "primary_damping": _Num("a damping >= 0 N s/m (per wheelset)", ge=0),
        "secondary_stiffness": _Num("a stiffness > 0 N/m (per bogie)", gt=0),
        "secondary_damping": _Num("a damping >= 0 N s/m (per bogie)", ge=0),
        "body_cg_to_front_bogie": _Num(
            "a distance >= 0 m behind the front bogie centre", ge=0, default=None),
    },
    "user": {},
}
_USER_KEYS = ("M", "C", "K", "wheel_dofs", "wheel_positions", "gravity", "body_dof")
_COMMON_VEHICLE_KEYS = ("kind", "offset", "name")


def _vehicle_keys(kind):
    extra = _USER_KEYS if kind == "user" else tuple(_VEHICLE_FIELDS[kind])
    return set(_COMMON_VEHICLE_KEYS) | set(extra)


def _matrix(chk, value, path, n=None):
    """Read a square matrix (nested lists of finite numbers): ndarray or ``_BAD``."""
    value = _as_list(value)
    expected = "a square matrix (list of rows of numbers)" + (f", {n} x {n}" if n else "")
    if not isinstance(value, list) or not value or len(value) > MAX_USER_DOFS:
        return chk.error(path, value, expected)
    rows = [_as_list(r) for r in value]
    size = len(rows)
    if not all(isinstance(r, list) and len(r) == size for r in rows) or (n and size != n):
        return chk.error(path, value, expected)
    bad = False
    for i, row in enumerate(rows):
        for j, x in enumerate(row):
            if not (_is_number(x) and _finite(x)):
                chk.error(f"{path}[{i}][{j}]", x, "a finite number")
                bad = True
    if bad:
        return _BAD
    a = np.asarray(rows, float)
    scale = np.abs(a).max() + 1.0
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-9 * scale):
        i, j = np.unravel_index(np.argmax(np.abs(a - a.T)), a.shape)
        return chk.error(f"{path}[{i}][{j}]", float(a[i, j]),
                         f"a symmetric matrix ({path}[{j}][{i}] = {float(a[j, i])!r})")
    return a


def _user_vehicle(chk, v, path, name):
    m = _matrix(chk, v["M"], f"{path}.M") if "M" in v else chk.error(
        f"{path}.M", _MISSING, "the mass matrix (list of rows, kg and kg m^2)")
    n = m.shape[0] if isinstance(m, np.ndarray) else None
    mats = {"M": m}
    for key, what in (("C", "damping matrix (N s/m)"), ("K", "stiffness matrix (N/m)")):
        if key not in v:
            mats[key] = chk.error(f"{path}.{key}", _MISSING, f"the {what}, same size as M")
        else:
            mats[key] = _matrix(chk, v[key], f"{path}.{key}", n)
    if isinstance(m, np.ndarray) and np.any(np.diag(m) < 0):
        i = int(np.argmin(np.diag(m)))
        mats["M"] = chk.error(f"{path}.M[{i}][{i}]", float(m[i, i]), "a mass >= 0 (diagonal)")
    hi = (n - 1) if n else MAX_USER_DOFS
    dofs = _BAD
    if "wheel_dofs" not in v:
        chk.error(f"{path}.wheel_dofs", _MISSING, "a list of wheel DOF indices")
    else:
        dofs = chk.number_list(v["wheel_dofs"], f"{path}.wheel_dofs",
                               _Num(f"a DOF index 0 <= i <= {hi}", ge=0, le=hi, integer=True),
                               expected="a non-empty list of wheel DOF indices")
        if isinstance(dofs, list) and len(set(dofs)) != len(dofs):
            dofs = chk.error(f"{path}.wheel_dofs", v["wheel_dofs"], "distinct DOF indices")
    pos = _BAD
    if "wheel_positions" not in v:
        chk.error(f"{path}.wheel_positions", _MISSING,
                  "one position (m behind the vehicle's first axle) per wheel DOF")
    else:
        pos = chk.number_list(v["wheel_positions"], f"{path}.wheel_positions",
                              _Num("a position >= 0 m behind the first axle", ge=0),
                              expected="a list of wheel positions >= 0 m, one per wheel DOF")
        if isinstance(pos, list) and isinstance(dofs, list) and len(pos) != len(dofs):
            pos = chk.error(f"{path}.wheel_positions", v["wheel_positions"],
                            f"one position per wheel DOF ({len(dofs)} wheel DOFs)")
        elif isinstance(pos, list) and any(b <= a for a, b in zip(pos, pos[1:], strict=False)):
            pos = chk.error(f"{path}.wheel_positions", v["wheel_positions"],
                            "strictly increasing positions (wheels front to back)")
    grav = None
    if "gravity" in v:
        grav = chk.number_list(v["gravity"], f"{path}.gravity", _Num("a load in N"),
                               expected="a list of static loads (N, positive down), one per DOF",
                               min_len=n or 1, max_len=n)
    body = chk.get_number(v, path, "body_dof", _Num(
        f"a DOF index -1 <= i <= {hi} (-1: none)", ge=-1, le=hi, integer=True, default=-1))
    if not _ok(*mats.values(), dofs, pos, grav, body) or n is None:
        return _BAD
    try:
        return _veh.user_vehicle(mats["M"], mats["C"], mats["K"], dofs, pos, grav, body, name)
    except ValueError as exc:
        return chk.error(path, dict(v), f"a valid vehicle ({exc})")


def _vehicle(chk, v, path, index):
    if not isinstance(v, Mapping):
        chk.error(path, v, "a table with kind = 'force' | 'sprung_mass' | 'car' | 'user'")
        return _BAD, _BAD, None
    kind = chk.choice(v, path, "kind", VEHICLE_KINDS)
    if kind is _BAD:
        every = set(_COMMON_VEHICLE_KEYS).union(*(_vehicle_keys(k) for k in VEHICLE_KINDS))
        chk.table(v, path, every)
        return _BAD, _BAD, None
    allowed = _vehicle_keys(kind)
    elsewhere = {}
    for other in VEHICLE_KINDS:
        for k in _vehicle_keys(other) - allowed:
            elsewhere.setdefault(k, f"no such key for kind = '{kind}' (it belongs to kind = "
                                    f"'{other}')")
    chk.table(v, path, allowed, elsewhere=elsewhere)
    offset = chk.get_number(v, path, "offset", _Num(
        "an offset >= 0 m behind the train's first axle", ge=0, default=0.0))
    name = chk.string(v, path, "name", "a vehicle name (string)", default=f"{kind}{index}")
    res = {"kind": kind, "offset": offset, "name": name}
    if kind == "user":
        veh = _user_vehicle(chk, v, path, name if _ok(name) else kind)
        for k in _USER_KEYS:
            if k in v:
                res[k] = _as_list(v[k])
        res.setdefault("body_dof", -1)
        return veh, offset, res
    vals = chk.numbers(v, path, _VEHICLE_FIELDS[kind])
    res.update(_drop_none(vals))
    if not _ok(*vals.values(), name):
        return _BAD, offset, res
    if kind == "force":
        veh = _veh.point_loads([0.0], [vals["load"]], name=name)
    elif kind == "sprung_mass":
        veh = _veh.sprung_mass(vals["mass"], vals["stiffness"], vals["damping"],
                               vals["wheel_mass"], name=name)
    else:
        veh = _car(chk, vals, path, name)
    return veh, offset, res


def _car(chk, vals, path, name):
    if vals["bogie_spacing"] <= vals["wheelbase"]:
        return chk.error(f"{path}.bogie_spacing", vals["bogie_spacing"],
                         f"a distance between bogie centres > the wheelbase "
                         f"({vals['wheelbase']:g} m), else the bogies' axles overlap")
    cg = vals["body_cg_to_front_bogie"]
    if cg is not None and cg > vals["bogie_spacing"]:
        return chk.error(f"{path}.body_cg_to_front_bogie", cg,
                         f"a distance between 0 and bogie_spacing = {vals['bogie_spacing']:g} m")
    return _veh.railway_car(**{k: vals[k] for k in _VEHICLE_FIELDS["car"]}, name=name)


@dataclass
class _TrainSpec:
    resolved: dict
    trains: list = field(default_factory=list)
    explicit: bool = False


def _library():
    try:
        from vsi_numba.model import library
    except ImportError:  # the library module ships separately
        return None
    return library


def _preset_names(lib) -> list[str]:
    try:
        names = lib.list_presets()
    except Exception:  # noqa: BLE001 - only used for did-you-mean hints
        return []
    if isinstance(names, Mapping):
        return [str(k) for k in names]
    out = []
    for n in names:
        out.append(str(n if isinstance(n, str) else getattr(n, "name", n)))
    return out


def _get_preset(chk, lib, name, path, model):
    """Build one library train (user files are registered in the library) or ``_BAD``.

    Without ``train.model`` the interaction model is used where the library has vehicle
    dynamics, the moving forces otherwise (HSLM load models).
    """
    if lib is None:
        return chk.error(path, name, "a train name from the library (vsi_numba.model.library "
                                     "is not available in this installation)")
    try:
        if model is None:
            try:
                train = lib.get_train(name, model="interaction")
            except KeyError:
                raise
            except ValueError:
                train = lib.get_train(name, model="moving_force")
        else:
            train = lib.get_train(name, model=model)
    except KeyError:
        guess = _did_you_mean(name, _preset_names(lib))
        hint = f"; did you mean '{guess}'?" if guess else ""
        return chk.error(path, name, f"a train name from the library (`vsi trains` lists "
                                     f"them){hint}")
    except ValueError as exc:
        return chk.error(path, name, f"a train that can be built with train.model = "
                                     f"'{model}' ({' '.join(str(exc).split())})")
    status = getattr(lib, "status_warning", None)
    if status is not None:
        try:
            text = status(name)
        except (KeyError, ValueError):
            text = ""
        if text:
            chk.warn(f"{path} = {_show(name)}: {text}")
    return train


def _train_section(chk, d, base_dir: Path, title) -> _TrainSpec | _Sentinel:
    path = "train"
    allowed = {"preset", "model", "vehicles", "file", "name"}
    ignored = {"name": "it names the train of [[train.vehicles]]; presets keep their names"}
    if isinstance(d, Mapping) and "vehicles" in d:
        ignored = {"model": "it applies to library presets, not to [[train.vehicles]]"}
    if chk.table(d, path, allowed - set(ignored), ignored=ignored,
                 what=" [train] with preset, vehicles or file") is _BAD:
        return _BAD
    given = [k for k in ("preset", "vehicles", "file") if k in d]
    if not given:
        return chk.error(path, _MISSING, "one of train.preset (library names), "
                                         "[[train.vehicles]] or train.file")
    if "vehicles" in d and len(given) > 1:
        other = [k for k in given if k != "vehicles"][0]
        return chk.error(f"train.{other}", d[other],
                         "either [[train.vehicles]] or train.preset/train.file, not both")
    res: dict[str, Any] = {}
    if "vehicles" in d:
        name = chk.string(d, path, "name", "a train name (string)",
                          default=title if title else "custom")
        res["name"] = name
        return _explicit_train(chk, d["vehicles"], name, res)
    model = chk.choice(d, path, "model", TRAIN_MODELS, default=None)
    if model is not None and model is not _BAD:
        res["model"] = model

    lib = _library()
    user_trains: dict = {}
    if "file" in d:
        given_path, full = chk.file(d, path, "file", base_dir, "user trains (TOML)")
        res["file"] = given_path
        if _ok(full):
            user_trains = _load_user_trains(chk, lib, full, given_path)
    if "preset" in d:
        raw = _as_list(d["preset"])
        expected = "a train name, or a non-empty list of names (`vsi trains` lists them)"
        if isinstance(raw, str):
            names, paths = [raw], ["train.preset"]
        elif isinstance(raw, list) and raw and all(isinstance(x, str) for x in raw):
            names, paths = raw, [f"train.preset[{i}]" for i in range(len(raw))]
            if len(set(names)) != len(names):
                return chk.error("train.preset", raw, "distinct train names")
        else:
            return chk.error("train.preset", raw, expected)
        res["preset"] = list(names)
        if model is _BAD or user_trains is _BAD:
            return _BAD
        trains = [_get_preset(chk, lib, n, p, model) for n, p in zip(names, paths, strict=True)]
        if not _ok(*trains):
            return _BAD
        return _TrainSpec(resolved=res, trains=trains)
    if user_trains is _BAD or not _ok(model):
        return _BAD
    if not user_trains:
        return chk.error("train.file", d.get("file"), "a file defining at least one train")
    trains = [_get_preset(chk, lib, n, "train.file", model) for n in user_trains]
    return _TrainSpec(resolved=res, trains=trains) if _ok(*trains) else _BAD


def _load_user_trains(chk, lib, full: Path, given: str):
    if lib is None or not hasattr(lib, "load_user_trains"):
        return chk.error("train.file", given, "a user train file (the train library is not "
                                              "available in this installation)")
    try:
        out = lib.load_user_trains(full)
    except Exception as exc:  # noqa: BLE001 - any failure of a foreign file is a config error
        msg = " ".join(str(exc).split())
        return chk.error("train.file", given, f"a valid user train file ({msg})")
    if isinstance(out, Mapping):
        return dict(out)
    return {t.name: t for t in out}


def _explicit_train(chk, vehicles, name, res) -> _TrainSpec | _Sentinel:
    vehicles = _as_list(vehicles)
    if not isinstance(vehicles, list) or not vehicles or len(vehicles) > MAX_VEHICLES:
        return chk.error("train.vehicles", vehicles,
                         f"an array of tables [[train.vehicles]] (1 to {MAX_VEHICLES})")
    built = []
    resolved = []
    for i, v in enumerate(vehicles):
        veh, offset, r = _vehicle(chk, v, f"train.vehicles[{i}]", i)
        built.append((veh, offset))
        if r is not None:
            resolved.append(r)
    res["vehicles"] = resolved
    if not all(_ok(veh, off) for veh, off in built):
        return _BAD
    # vehicles are listed front to back and must not overlap
    prev_end = None
    for i, (veh, off) in enumerate(built):
        axles = off + veh.axle_positions
        start, end = float(axles.min()), float(axles.max())
        if prev_end is not None and start <= prev_end:
            lo = start - off
            chk.error(f"train.vehicles[{i}].offset", off,
                      f"an offset > {prev_end - lo:g} m: vehicles are listed front to back "
                      f"and must not overlap (train.vehicles[{i - 1}] ends at {prev_end:g} m "
                      f"behind the first axle)")
            return _BAD
        prev_end = end
    if not _ok(name):
        return _BAD
    train = _veh.Train(name=name, vehicles=tuple(v for v, _ in built),
                       offsets=tuple(o for _, o in built), status="user")
    return _TrainSpec(resolved=res, trains=[train], explicit=True)


# -------------------------------------------------------------------------- irregularity

_DEFECT_FIELDS: dict[str, dict[str, _Num]] = {
    "cosine": {
        "depth": _Num("a depth != 0 m (> 0: dip, < 0: bump), |depth| < 1 m", gt=-1, lt=1),
        "wavelength": _Num("a wavelength > 0 m", gt=0),
        "position": _Num("a position x (m) where the defect starts"),
    },
    "step": {
        "height": _Num("a level change != 0 m (> 0: the rail ends lower), |height| < 1 m",
                       gt=-1, lt=1),
        "length": _Num("a transition length > 0 m", gt=0),
        "position": _Num("a position x (m) where the transition starts"),
    },
}
_STEP_SHAPES = ("cosine", "quintic")
_PSD_FIELDS = {
    "wavelength_min": _Num("a wavelength > 0 m", gt=0),
    "wavelength_max": _Num("a wavelength > 0 m", gt=0),
    "dx": _Num("a sample spacing > 0 m", gt=0, default=None),
}


def _spectra():
    return tuple(getattr(_irr, "SPECTRA", {}) or
                 ("fra1", "fra2", "fra3", "fra4", "fra5", "fra6", "german_low", "german_high"))


def _defect(chk, d, path, kind) -> dict | _Sentinel:
    """Read the keys of an isolated defect (cosine, step) at ``path``."""
    vals = chk.numbers(d, path, _DEFECT_FIELDS[kind])
    amp = "depth" if kind == "cosine" else "height"
    if _ok(vals[amp]) and vals[amp] == 0.0:
        vals[amp] = chk.error(_join(path, amp), d[amp], _DEFECT_FIELDS[kind][amp].expected)
    if kind == "step":
        vals["shape"] = chk.choice(d, path, "shape", _STEP_SHAPES, default="cosine")
    if not _ok(*vals.values()):
        return _BAD
    return {"kind": kind, **vals}


_IRR_KEYS = {
    "none": {"kind", "defects"},
    "cosine": {"kind", "depth", "wavelength", "position", "defects"},
    "step": {"kind", "height", "length", "position", "shape", "defects"},
    "psd": {"kind", "spectrum", "wavelength_min", "wavelength_max", "seeds", "dx", "defects"},
    "file": {"kind", "path", "x_column", "r_column", "r_unit", "dx", "defects"},
}


@dataclass
class _IrregularitySpec:
    resolved: dict
    kind: str = "none"
    file: Path | None = None
    file_profile: Any = None


def _irregularity_section(chk, d, base_dir: Path) -> _IrregularitySpec | _Sentinel:
    path = "irregularity"
    if d is _MISSING:
        return _IrregularitySpec(resolved={"kind": "none"})
    if not isinstance(d, Mapping):
        return chk.error(path, d, "a table [irregularity] with kind = 'none' | 'cosine' | "
                                  "'psd' | 'file'")
    kind = chk.choice(d, path, "kind", IRREGULARITY_KINDS, default="none")
    every = set().union(*_IRR_KEYS.values())
    if kind is _BAD:
        chk.table(d, path, every)
        return _BAD
    allowed = _IRR_KEYS[kind]
    ignored = {k: f"not used by irregularity.kind = '{kind}'" for k in every - allowed}
    chk.table(d, path, allowed, ignored=ignored)
    res: dict[str, Any] = {"kind": kind}
    ok = True
    spec = _IrregularitySpec(resolved=res, kind=kind)
    if kind in _DEFECT_FIELDS:
        vals = _defect(chk, d, path, kind)
        ok = _ok(vals)
        if ok:
            res.update(vals)
    elif kind == "psd":
        spectra = _spectra()
        res["spectrum"] = chk.choice(d, path, "spectrum", spectra)
        vals = chk.numbers(d, path, _PSD_FIELDS)
        if _ok(vals["wavelength_min"], vals["wavelength_max"]) and not (
            vals["wavelength_max"] > vals["wavelength_min"]
        ):
            vals["wavelength_max"] = chk.error(
                "irregularity.wavelength_max", d["wavelength_max"],
                f"a wavelength > wavelength_min = {vals['wavelength_min']:g} m")
        if _ok(vals["wavelength_min"], vals["dx"]) and vals["dx"] is not None and (
            vals["dx"] > vals["wavelength_min"] / 2
        ):
            vals["dx"] = chk.error("irregularity.dx", d["dx"],
                                   f"a sample spacing <= wavelength_min / 2 = "
                                   f"{vals['wavelength_min'] / 2:g} m (Nyquist)")
        if "seeds" not in d:
            seeds = chk.error("irregularity.seeds", _MISSING,
                              "a list of integer seeds >= 0, one per realisation")
        else:
            seeds = chk.number_list(
                d["seeds"], "irregularity.seeds",
                _Num("an integer seed 0 <= seed < 2^63", ge=0, lt=2**63, integer=True),
                expected="a non-empty list of distinct integer seeds >= 0", max_len=10_000,
                scalar_ok=True)
            if _is_number(seeds):
                seeds = [seeds]
            if isinstance(seeds, list) and len(set(seeds)) != len(seeds):
                seeds = chk.error("irregularity.seeds", d["seeds"], "distinct seeds")
        res.update(_drop_none(vals), seeds=seeds)
        ok = _ok(res["spectrum"], seeds, *vals.values())
    elif kind == "file":
        given, full = chk.file(d, path, "path", base_dir, "the profile (CSV, columns x and r)")
        res["path"] = given
        xcol = chk.string(d, path, "x_column", "a column name (string)", default="x")
        rcol = chk.string(d, path, "r_column", "a column name (string)", default="r")
        unit = chk.choice(d, path, "r_unit", ("m", "mm"), default="m")
        dx = chk.get_number(d, path, "dx", _Num("a sample spacing > 0 m", gt=0, default=None))
        res.update(_drop_none({"x_column": xcol, "r_column": rcol, "r_unit": unit, "dx": dx}))
        ok = _ok(given, full, xcol, rcol, unit, dx)
        if ok:
            spec.file = full
            try:
                spec.file_profile = _irr.profile_from_file(full, xcol, rcol, unit, dx)
            except (ValueError, OSError) as exc:
                msg = " ".join(str(exc).split())
                ok = _ok(chk.error("irregularity.path", given, f"a readable profile: {msg}"))
    defects = []
    if "defects" in d:
        raw = _as_list(d["defects"])
        if not isinstance(raw, list) or not raw or len(raw) > 1000:
            ok = _ok(chk.error("irregularity.defects", raw,
                               "an array of tables [[irregularity.defects]] with kind = "
                               "'cosine' | 'step'"))
        else:
            for i, item in enumerate(raw):
                p = f"irregularity.defects[{i}]"
                if not isinstance(item, Mapping):
                    ok = _ok(chk.error(p, item, "a table with kind = 'cosine' | 'step'"))
                    continue
                dk = chk.choice(item, p, "kind", DEFECT_KINDS)
                if dk is _BAD:
                    ok = False
                    continue
                chk.table(item, p, {"kind", *_DEFECT_FIELDS[dk],
                                    *(("shape",) if dk == "step" else ())})
                vals = _defect(chk, item, p, dk)
                if _ok(vals):
                    defects.append(vals)
                else:
                    ok = False
        if ok:
            res["defects"] = defects
    return spec if ok else _BAD


# --------------------------------------------------------------------------------- solver

_SOLVER_FIELDS = {
    "dt": _Num("a time step > 0 s", gt=0, default=SolverSettings.dt),
    "hht_alpha": _Num("-1/3 <= hht_alpha <= 0", ge=-1.0 / 3.0 - 1e-12, le=0.0,
                      default=SolverSettings.hht_alpha),
    "approach": _Num("a length of approach track >= 0 m", ge=0,
                     default=SolverSettings.approach),
    "free_vibration": _Num("a duration >= 0 s", ge=0, default=SolverSettings.free_vibration),
    "max_iterations": _Num("an integer 1 <= max_iterations <= 10000", ge=1, le=10_000,
                           integer=True, default=SolverSettings.max_iterations),
    "max_subdivisions": _Num("an integer 0 <= max_subdivisions <= 30", ge=0, le=30,
                             integer=True, default=SolverSettings.max_subdivisions),
    "acceleration_cutoff": _Num("a frequency > 0 Hz", gt=0, default=None),
}


def _solver_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        d = {}
    if chk.table(d, "solver", set(_SOLVER_FIELDS), what=" [solver] (dt, hht_alpha, ...)",
                 hidden=SOLVER_OVERRIDES) is _BAD:
        return _BAD
    vals = chk.numbers(d, "solver", _SOLVER_FIELDS)
    for key in SOLVER_OVERRIDES:
        if key in d:
            vals[key] = chk.boolean(d, "solver", key, False)
    if not _ok(*vals.values()):
        return _BAD
    vals["hht_alpha"] = max(vals["hht_alpha"], -1.0 / 3.0)
    return vals


def _contact_section(chk, d) -> dict | _Sentinel:
    if d is _MISSING:
        return {"model": "rigid"}
    if chk.table(d, "contact", {"model", "hertz_coefficient"},
                 what=" [contact] with model = 'rigid'") is _BAD:
        return _BAD
    model = chk.choice(d, "contact", "model", CONTACT_MODELS, default="rigid")
    spec = _Num("a Hertz constant G > 0 m N^-2/3 (about 4e-8 for a wheel on a rail)", gt=0,
                lt=1.0, default=_MISSING if model not in ("rigid", _BAD) else None)
    if model == "rigid":
        if "hertz_coefficient" in d:
            chk.warn("contact.hertz_coefficient is ignored: not used by contact.model = 'rigid'")
        return {"model": "rigid"}
    g = chk.get_number(d, "contact", "hertz_coefficient", spec)
    if not _ok(model, g):
        return _BAD
    return {"model": model, "hertz_coefficient": g}


TRACK_MODELS = ("elastic", "rigid")


def _rail_track_section(chk, d, fe_layer: bool) -> dict | _Sentinel:
    """[track]: the rail on an elastic foundation (default) or the rigid idealisation."""
    if fe_layer:
        if d is not _MISSING:
            chk.error("track", d, "no [track] with [bridge.track]: the FE track layer of the "
                      "deck is the track")
            return _BAD
        return {"model": "bridge_layer"}
    if d is _MISSING:
        d = {}
    if chk.table(d, "track", {"model", "foundation_stiffness", "rail_EI"},
                 what=" [track] of track values") is _BAD:
        return _BAD
    model = chk.choice(d, "track", "model", TRACK_MODELS, default="elastic")
    if model == "rigid":
        for key in ("foundation_stiffness", "rail_EI"):
            if key in d:
                chk.warn(f"track.{key} is ignored: not used by track.model = 'rigid'")
        return {"model": "rigid"}
    k = chk.get_number(d, "track", "foundation_stiffness", _Num(
        "a foundation modulus > 0 N/m per metre of track (both rails; about 3e7 .. 3e8)",
        gt=0, default=_track.FOUNDATION_DEFAULT))
    ei = chk.get_number(d, "track", "rail_EI", _Num(
        "a bending stiffness of both rails > 0 N m^2 (1.283e7 for two UIC60 rails)",
        gt=0, default=_track.RAIL_EI_UIC60))
    if not _ok(model, k, ei):
        return _BAD
    return {"model": "elastic", "foundation_stiffness": float(k), "rail_EI": float(ei)}


# ---------------------------------------------------------------------------------- study

_SPEED = _Num("a speed > 0 km/h (at most 1000)", gt=0, le=1000)


def _speed_grid(start, stop, step) -> np.ndarray:
    n = int(math.floor((stop - start) / step + 1e-9))
    return np.round(start + step * np.arange(n + 1), 9)


def _line_speed_grid(line: float) -> list[float]:
    """Speeds (km/h) of a study given its line speed: 5 km/h steps up to 1.2 x line."""
    stop = 1.2 * line
    start = 140.0 if stop >= 140.0 else 5.0
    grid = _speed_grid(start, stop, 5.0)
    if grid[-1] < stop - 1e-9:
        grid = np.append(grid, round(stop, 9))
    return grid.tolist()


def _study_section(chk, d, default_output: str, base_dir: Path) -> dict | _Sentinel:
    path = "study"
    allowed = {"speeds_kmh", "output", "save_time_histories", "line_speed_kmh",
               "history_speeds_kmh", "vary", "vary_together", "mass_bounds",
               "refine_resonance"}
    if d is _MISSING:
        return chk.error(path, _MISSING, "a table [study] with speeds_kmh (km/h) or "
                                         "line_speed_kmh")
    if chk.table(d, path, allowed, what=" [study] with speeds_kmh") is _BAD:
        return _BAD
    line = chk.get_number(d, path, "line_speed_kmh", _Num(
        "a line speed > 0 km/h (at most 1000)", gt=0, le=1000, default=None))
    speeds = _BAD
    expected = ("a list of speeds > 0 km/h, or a table {start, stop, step} in km/h")
    if "speeds_kmh" in d:
        raw = _as_list(d["speeds_kmh"])
        if isinstance(raw, Mapping):
            g = chk.table(raw, "study.speeds_kmh", {"start", "stop", "step"})
            if g is not _BAD:
                vals = chk.numbers(raw, "study.speeds_kmh", {
                    "start": _SPEED, "stop": _SPEED, "step": _Num("a step > 0 km/h", gt=0)})
                if _ok(*vals.values()):
                    if vals["stop"] < vals["start"]:
                        chk.error("study.speeds_kmh.stop", vals["stop"],
                                  f"a speed >= start = {vals['start']:g} km/h")
                    elif (vals["stop"] - vals["start"]) / vals["step"] >= MAX_SPEEDS:
                        chk.error("study.speeds_kmh.step", vals["step"],
                                  f"a step giving at most {MAX_SPEEDS} speeds")
                    else:
                        speeds = _speed_grid(vals["start"], vals["stop"], vals["step"]).tolist()
        else:
            speeds = chk.number_list(raw, "study.speeds_kmh", _SPEED, expected=expected,
                                     scalar_ok=True, max_len=MAX_SPEEDS)
            if _is_number(speeds):
                speeds = [speeds]
            if isinstance(speeds, list) and len(set(speeds)) != len(speeds):
                speeds = chk.error("study.speeds_kmh", raw, "distinct speeds")
        if line is not None and line is not _BAD and isinstance(speeds, list) and (
                speeds != _line_speed_grid(line)):  # the resolved config has both: equal
            line = chk.error("study.line_speed_kmh", d["line_speed_kmh"],
                             "either study.speeds_kmh or study.line_speed_kmh, not both "
                             "(line_speed_kmh only builds the speed grid when speeds_kmh "
                             "is absent and would be ignored; remove one of the two keys)")
    elif line is None:
        chk.error("study.speeds_kmh", _MISSING, expected + " (or give study.line_speed_kmh)")
    elif line is not _BAD:
        speeds = _line_speed_grid(line)
    output = chk.string(d, path, "output", "a path to a netCDF file ending in .nc",
                        default=default_output)
    out_full = _BAD
    if _ok(output):
        if "\x00" in output or not output.endswith(".nc"):
            output = chk.error("study.output", output, "a path to a netCDF file ending in .nc")
        else:
            out_full = _resolve(base_dir, output)
            if out_full is None:
                output = chk.error("study.output", output, "a valid path of a netCDF file")
            elif out_full.is_dir():
                output = chk.error("study.output", output, f"a file path ({out_full} is a "
                                                           "directory)")
    save = chk.boolean(d, path, "save_time_histories", True)
    hist = None
    if "history_speeds_kmh" in d:
        hist = chk.number_list(d["history_speeds_kmh"], "study.history_speeds_kmh", _SPEED,
                               expected="a list of speeds (km/h) taken from study.speeds_kmh",
                               scalar_ok=True, min_len=0)
        if _is_number(hist):
            hist = [hist]
        if isinstance(hist, list) and isinstance(speeds, list):
            for i, s in enumerate(hist):
                if not any(abs(s - g) <= 1e-6 * max(1.0, g) for g in speeds):
                    chk.error(f"study.history_speeds_kmh[{i}]", s,
                              "one of the speeds of study.speeds_kmh")
                    hist = _BAD
                    break
    axes = _vary_axes(chk, d)
    refine = chk.boolean(d, path, "refine_resonance", False)
    if not _ok(line, speeds, output, save, hist, out_full, axes, refine):
        return _BAD
    vary = {k: d[k] for k in ("vary", "vary_together", "mass_bounds") if k in d}
    if refine:
        vary["refine_resonance"] = True
    return _drop_none({"speeds_kmh": speeds, "line_speed_kmh": line, "output": output,
                       "save_time_histories": save, "history_speeds_kmh": hist,
                       "_output_path": out_full, "_axes": axes or None, **vary})


# --------------------------------------------------------------------------------- variants

MAX_VARIANTS = 5000  # cap on the bridge/track/contact variants of one study
_KEY_PATH = re.compile(r"^[A-Za-z_]\w*(\[\d+\])?(\.[A-Za-z_]\w*(\[\d+\])?)+$")
_VARY_SECTIONS = ("bridge", "train", "irregularity", "solver", "contact", "track")
#: The variant coordinate of ``study.mass_bounds`` (factors on bridge.mass_per_length).
MASS_FACTOR = "mass_factor"


def _vary_axes(chk, d):
    """``study.vary``, ``study.vary_together`` and ``study.mass_bounds`` as a list of
    axes; an axis is a list of (key path, values) varied together (zipped); the study
    runs every combination of the axes (their cartesian product)."""
    axes = []

    def values(path, v):
        if not isinstance(v, list) or not v:
            return chk.error(path, v, "a non-empty list of values, one per variant")
        return v

    def key_path(path, key):
        if key == "label":  # names the variants (a coordinate), sets no key
            return key
        ok = isinstance(key, str) and _KEY_PATH.match(key) and key.split(".")[0].split("[")[
            0] in _VARY_SECTIONS
        if not ok:
            return chk.error(path, key, "a key path like \"bridge.mass_per_length\" in "
                             + ", ".join(f"[{s}]" for s in _VARY_SECTIONS))
        return key

    if "vary" in d:
        if not isinstance(d["vary"], Mapping) or not d["vary"]:
            return chk.error("study.vary", d["vary"], "a table of key paths, each with a list "
                             "of values, e.g. \"bridge.EI\" = [7e10, 8e10]")
        for key, v in d["vary"].items():
            k = key_path(f"study.vary[{_key(key)}]", key)
            vals = values(f"study.vary[{_key(key)}]", v)
            if _ok(k, vals):
                axes.append([(k, vals)])
    if "vary_together" in d:
        groups = d["vary_together"]
        if isinstance(groups, Mapping):
            groups = [groups]
        if not isinstance(groups, list) or not groups:
            return chk.error("study.vary_together", groups, "tables ([[study.vary_together]])"
                             " of key paths whose value lists are varied together")
        for i, g in enumerate(groups):
            p = f"study.vary_together[{i}]"
            if not isinstance(g, Mapping) or not g:
                chk.error(p, g, "a table of key paths, each with a list of values")
                continue
            axis = []
            for key, v in g.items():
                k = key_path(f"{p}[{_key(key)}]", key)
                vals = values(f"{p}[{_key(key)}]", v)
                if _ok(k, vals):
                    axis.append((k, vals))
            n = {len(v) for _, v in axis}
            if len(n) > 1:
                chk.error(p, {k: len(v) for k, v in axis}, "value lists of one length (they "
                          "are varied together)")
            elif axis:
                axes.append(axis)
    if "mass_bounds" in d:
        f = chk.number_list(d["mass_bounds"], "study.mass_bounds",
                            _Num("a factor on bridge.mass_per_length > 0", gt=0),
                            expected="factors on bridge.mass_per_length, e.g. [0.9, 1.1] "
                                     "(EN 1991-2 6.4.6.3.2: lower and upper bound)",
                            min_len=1)
        if _ok(f):
            axes.append([(MASS_FACTOR, f)])
    paths = [k for axis in axes for k, _ in axis]
    dup = {k for k in paths if paths.count(k) > 1}
    if dup:
        return chk.error("study.vary", sorted(dup), "each key path varied once")
    n = int(np.prod([len(axis[0][1]) for axis in axes])) if axes else 0
    if n > MAX_VARIANTS:
        return chk.error("study.vary", f"{n} variants", f"at most {MAX_VARIANTS} variants")
    return axes


def _set_path(data: dict, key_path: str, value) -> None:
    """Set ``value`` at ``key_path`` ("bridge.track.pad_stiffness", "train.vehicles[0].mass")
    in a nested mapping, creating missing tables; raises KeyError naming what is missing."""
    parts = key_path.split(".")
    node = data
    for i, part in enumerate(parts):
        m = re.match(r"^(\w+)(?:\[(\d+)\])?$", part)
        name, index = m.group(1), m.group(2)
        last = i == len(parts) - 1
        if index is None:
            if last:
                node[name] = value
                return
            if name not in node:
                node[name] = {}
            if not isinstance(node[name], dict):
                raise KeyError(f"{'.'.join(parts[: i + 1])} is not a table")
            node = node[name]
        else:
            seq = node.get(name)
            if not isinstance(seq, list) or int(index) >= len(seq):
                raise KeyError(f"{'.'.join(parts[:i])}{'.' if i else ''}{name} has no item "
                               f"[{index}]")
            if last:
                seq[int(index)] = value
                return
            node = seq[int(index)]


def variant_labels(axes) -> list[dict]:
    """Every combination of the axes: one ``{key path: value}`` per variant (the last
    axis varies fastest)."""
    import itertools

    labels = []
    for combo in itertools.product(*[range(len(axis[0][1])) for axis in axes]):
        lab = {}
        for axis, j in zip(axes, combo, strict=True):
            for k, vals in axis:
                lab[k] = vals[j]
        labels.append(lab)
    return labels


def _build_variants(data, axes, path, base, source, base_speeds):
    """Validate every variant (the config with its key paths set); all errors at once."""
    import copy

    out, errors = [], []
    for n, lab in enumerate(variant_labels(axes)):
        vdata = copy.deepcopy(dict(data))
        study = dict(vdata.get("study", {}))
        for k in ("vary", "vary_together", "mass_bounds", "refine_resonance"):
            study.pop(k, None)
        # one speed axis for every variant: the base configuration's (refined) speeds
        study.pop("line_speed_kmh", None)
        study["speeds_kmh"] = list(base_speeds)
        vdata["study"] = study
        where = ", ".join(f"{k} = {_show(v, 30)}" for k, v in lab.items())
        try:
            for k, v in lab.items():
                if k == "label":
                    continue
                if k == MASS_FACTOR:
                    m = vdata.get("bridge", {}).get("mass_per_length")
                    if not (_is_number(m) or (isinstance(m, list) and all(map(_is_number, m)))):
                        raise KeyError("study.mass_bounds needs a numeric "
                                       "bridge.mass_per_length")
                    _set_path(vdata, "bridge.mass_per_length",
                              [x * v for x in m] if isinstance(m, list) else m * v)
                else:
                    _set_path(vdata, k, v)
            out.append((lab, _validate(vdata, path, base, source)))
        except KeyError as exc:
            errors.append(f"study.vary (variant {n}: {where}): key path not found: "
                          f"{exc.args[0]}")
        except ConfigError as exc:
            for msg in exc.errors:
                errors.append(f"study.vary (variant {n}: {where}): {msg}")
    if errors:
        # the same problem in every variant is said once
        seen, unique = set(), []
        for e in errors:
            key = e.split("): ", 1)[-1]
            if key not in seen:
                seen.add(key)
                unique.append(e)
        raise ConfigError(unique, source=source)
    return out


# --------------------------------------------------------------------------------- config


class Config:
    """A validated configuration (build it with :func:`load_config`).

    Attributes
    ----------
    title : str
        The run title (default: the file name stem).
    path : pathlib.Path or None
        The config file, or None for a mapping.
    base_dir : pathlib.Path
        Directory relative paths resolve against.
    warnings : list of str
        Physically suspicious but legal input.
    """

    def __init__(self, *, title, path, base_dir, resolved, bridge, train, irregularity,
                 solver, study, warnings):
        self.title: str = title
        self.path: Path | None = path
        self.base_dir: Path = base_dir
        self.warnings: list[str] = list(warnings)
        #: the warnings as records {"message", "kind", "keys"}; kind "resolution" marks a
        #: time-step resolution warning (the results' checks are then not reliable)
        self.warning_records: list[dict] = [
            {"message": w, "kind": "input", "keys": []} for w in self.warnings]
        self._resolved = resolved
        self._bridge = bridge
        self._train = train
        self._irr = irregularity
        self._solver = solver
        self._study = study
        self._built = None  # the bridge with its track (build_bridge)
        #: ``[(labels, Config)]``: the variants of ``study.vary`` (empty: none)
        self.variants: list = []

    def __repr__(self) -> str:
        """Title and hash."""
        return f"Config(title={self.title!r}, sha256={self.sha256[:12]}...)"

    # -- model
    def build_bridge(self) -> _bridge.ModalBridge:
        """Return the bridge model (:class:`~vsi_numba.model.bridge.ModalBridge`).

        Imported bridges (``modes_file``, ``matrices``) are read and checked by
        :func:`load_config` already; this returns that model, with the track of
        ``[track]`` (:attr:`track_model`).

        Raises
        ------
        ConfigError
            If no model could be built for the bridge kind.
        """
        if self._bridge.model is None:
            raise ConfigError(
                [f"bridge.kind = '{self._bridge.kind}' is not supported by this version "
                 "(deck modes from a file come with a later release)"],
                source=str(self.path) if self.path else "<mapping>",
            )
        if self._built is None:
            model = self._bridge.model
            if self.track_model == "elastic":
                track = self._resolved["track"]
                import dataclasses

                model = dataclasses.replace(model, track=_track.ElasticTrack(
                    track["foundation_stiffness"], track["rail_EI"]))
            self._built = model
        return self._built

    @property
    def track_model(self) -> str:
        """'elastic' (rail on a foundation), 'rigid' (idealisation) or 'bridge_layer'
        (the FE track layer of ``[bridge.track]``)."""
        if "track" in self._resolved["bridge"]:
            return "bridge_layer"
        return self._resolved["track"]["model"]

    @property
    def output_points(self) -> np.ndarray:
        """Positions of the deck outputs (m from the left end), shape (n_points,)."""
        return self._bridge.output_points.copy()

    def trains(self) -> list[_veh.Train]:
        """Return the trains: one per preset, or one built from explicit vehicles."""
        return list(self._train.trains)

    @property
    def additional_damping(self) -> float:
        """EN 1991-2 6.4.6.3.1 additional damping (fraction) for moving-force trains
        (0 unless ``bridge.additional_damping = true`` and L < 30 m)."""
        return float(self._resolved["bridge"].get("additional_damping", 0.0))

    def bridge_for(self, train) -> _bridge.ModalBridge:
        """The bridge a train runs on: :meth:`build_bridge`, with the additional damping
        of ``bridge.additional_damping`` added to every mode when ``train`` is moving
        forces only (never for interaction models, which carry that interaction)."""
        bridge = self.build_bridge()
        extra = self.additional_damping
        if extra and all(v.n_dof == 0 for v in train.vehicles):
            import dataclasses

            return dataclasses.replace(bridge, damping=np.asarray(bridge.damping) + extra)
        return bridge

    def irregularities(self, x_start: float, x_stop: float) -> list[tuple[int, Any]]:
        """Track profiles over ``[x_start, x_stop]`` (m) as ``(realisation id, Profile)``.

        The id is the seed for ``kind = 'psd'`` (one profile per seed) and -1 for the
        deterministic kinds (none, cosine, step, file).  Isolated defects listed in
        ``[[irregularity.defects]]`` are added to every profile.
        """
        r = self._resolved["irregularity"]
        kind = r["kind"]

        def defect(spec):
            return _defect_profile(spec, x_stop)

        extra = [defect(s) for s in r.get("defects", [])]
        if kind == "psd":
            base = [
                (int(seed), _irr.psd_profile(r["spectrum"], r["wavelength_min"],
                                             r["wavelength_max"], int(seed), x_start, x_stop,
                                             r.get("dx")))
                for seed in r["seeds"]
            ]
        elif kind == "file":
            base = [(-1, self._irr.file_profile)]
        elif kind == "none":
            base = [(-1, _irr.no_irregularity())]
        else:
            base = [(-1, defect(r))]
        if not extra:
            return base
        return [(i, _irr.combine(p, *extra)) for i, p in base]

    def solver_settings(self) -> SolverSettings:
        """Return the :class:`~vsi_numba.solver.settings.SolverSettings` (SI units).

        The ``[contact]`` keys are part of the settings (``contact_model``,
        ``hertz_coefficient``).
        """
        contact = self._resolved["contact"]
        extra = {}
        if contact["model"] != "rigid":
            extra = {"contact_model": contact["model"],
                     "hertz_coefficient": contact["hertz_coefficient"]}
        fields = {k: v for k, v in self._solver.items() if k not in SOLVER_OVERRIDES}
        return SolverSettings(**fields, **extra)

    # -- study
    @property
    def speeds_kmh(self) -> np.ndarray:
        """Speeds of the study (km/h), shape (n_speeds,)."""
        return np.asarray(self._study["speeds_kmh"], float)

    @property
    def output_path(self) -> Path:
        """The netCDF output file (absolute; relative paths resolve against base_dir)."""
        return self._study["_output_path"]

    @property
    def save_time_histories(self) -> bool:
        """Whether time histories are written (envelopes always are)."""
        return bool(self._study["save_time_histories"])

    @property
    def history_speeds_kmh(self) -> np.ndarray | None:
        """Speeds (km/h) whose time histories are kept; None = every speed."""
        h = self._study.get("history_speeds_kmh")
        return None if h is None else np.asarray(h, float)

    @property
    def track_type(self) -> str:
        """Track form on the deck: 'ballasted' (3.5 m/s2) or 'direct_fastening' (5 m/s2)."""
        return self._resolved["bridge"].get("track_type", "ballasted")

    @property
    def contact_model(self) -> str:
        """Wheel-rail contact model ('rigid', 'hertz', ...)."""
        return self._resolved["contact"]["model"]

    # -- provenance
    def resolved(self) -> dict:
        """Return the configuration with every default filled in (JSON-serialisable).

        Paths stay as written (relative to :attr:`base_dir`), so
        ``load_config(cfg.resolved(), base_dir=cfg.base_dir)`` gives the same config.
        """
        return json.loads(json.dumps(self._resolved))

    def to_json(self) -> str:
        """Return the resolved configuration as JSON with sorted keys (stable)."""
        return json.dumps(self._resolved, sort_keys=True, separators=(",", ":"))

    @property
    def sha256(self) -> str:
        """SHA-256 hex digest of :meth:`to_json`."""
        return hashlib.sha256(self.to_json().encode("utf-8")).hexdigest()


def _read_toml(path: Path) -> tuple[dict | None, list[str]]:
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return None, [f"{path}: file not found; expected a TOML configuration file"]
    except IsADirectoryError:
        return None, [f"{path}: is a directory; expected a TOML configuration file"]
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


def load_config(path_or_mapping, base_dir=None) -> Config:
    """Read and validate a configuration.

    Parameters
    ----------
    path_or_mapping : str, path-like or mapping
        A TOML file, or the already-parsed mapping (same structure).
    base_dir : str or path-like, optional
        Directory that relative paths (profile file, train file, output) resolve
        against; default: the config file's directory, or the working directory for a
        mapping.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        Listing every problem found (key path, bad value, expectation), before any
        computation.
    """
    path = None
    if isinstance(path_or_mapping, Mapping):
        data = path_or_mapping
        source = "<mapping>"
    elif isinstance(path_or_mapping, str | Path):
        path = Path(path_or_mapping).expanduser()
        source = str(path)
        data, errors = _read_toml(path)
        if errors:
            raise ConfigError(errors, source=source)
        path = path.resolve()
    else:
        raise ConfigError([f"config = {_show(path_or_mapping)}: expected a path to a TOML "
                           "file or a mapping"])
    if base_dir is None:
        base = path.parent if path is not None else Path.cwd()
    else:
        base = Path(base_dir).expanduser().resolve()
    cfg = _validate(data, path, base, source)
    axes = cfg._study.get("_axes")
    if axes:
        cfg.variants = _build_variants(data, axes, path, base, source,
                                       cfg._study["speeds_kmh"])
    return cfg


#: Orders i of the resonance speeds v_i = f1 D / i that study.refine_resonance adds.
RESONANCE_ORDERS = (1, 2, 3)


def _refine_resonance(study, bridge, train):
    """``study.refine_resonance``: add the resonance speeds v_i = 3.6 f1 D / i (km/h,
    i = 1, 2, 3; EN 1991-2 6.4.6.2 [R]) of every train with a regular coach length D, and
    v_i +- 1 km/h, inside the study's speed range (0.1 km/h resolution)."""
    from vsi_numba.en1991 import resonance_speeds_kmh

    speeds = list(study["speeds_kmh"])
    if bridge.model is None or not bridge.model.n_modes or not speeds:
        return
    lo, hi = min(speeds), max(speeds)
    f1 = float(bridge.model.frequencies[0])
    extra = []
    for tr in train.trains:
        d = float(getattr(tr, "regular_length", 0.0) or 0.0)
        if d > 0:
            for v in resonance_speeds_kmh(f1, d, RESONANCE_ORDERS):
                extra += [round(v + dv, 1) for dv in (-1.0, 0.0, 1.0)]
    merged = sorted(set(speeds) | {v for v in extra if lo <= v <= hi})
    out = []
    for v in merged:  # drop near-duplicates of listed speeds
        if not out or v - out[-1] > 1e-6:
            out.append(v)
    study["speeds_kmh"] = out


def _validate(data, path: Path | None, base: Path, source: str) -> Config:
    chk = _Checker()
    top = {"title", "bridge", "train", "irregularity", "solver", "contact", "track", "study"}
    chk.table(data, "", top)
    default_title = path.stem if path is not None else "untitled"
    title = chk.string(data, "", "title", "a title (string)", default=None, nonempty=False)
    if "bridge" not in data:
        chk.error("bridge", _MISSING, "a table [bridge] with kind, spans, EI, mass_per_length")
    if "train" not in data:
        chk.error("train", _MISSING, "a table [train] with preset, [[train.vehicles]] or file")

    solver = _solver_section(chk, data.get("solver", _MISSING))
    contact = _contact_section(chk, data.get("contact", _MISSING))
    cutoff = solver["acceleration_cutoff"] if _ok(solver) else None
    bridge = _bridge_section(chk, data["bridge"], base, cutoff) if "bridge" in data else _BAD
    fe_layer = isinstance(data.get("bridge"), dict) and "track" in data["bridge"]
    track = _rail_track_section(chk, data.get("track", _MISSING), fe_layer)
    train = (
        _train_section(chk, data["train"], base, title if _ok(title) else None)
        if "train" in data else _BAD
    )
    irr = _irregularity_section(chk, data.get("irregularity", _MISSING), base)
    stem = path.stem if path is not None else "run"
    study = _study_section(chk, data.get("study", _MISSING), f"results/{stem}.nc", base)

    if _ok(bridge, solver, irr) and irr.file_profile is not None and bridge.length is not None:
        _check_file_coverage(chk, irr, -solver["approach"], bridge.length)
    if chk.errors:
        # report in the order of the file's sections (validation order differs)
        order = {k: i for i, k in enumerate(data) if isinstance(k, str)}
        head = re.compile(r"^([^.\[ :=]+)")

        def rank(msg):
            m = head.match(msg)
            return order.get(m.group(1) if m else "", len(order))

        raise ConfigError(sorted(chk.errors, key=rank), source=source)

    if study.get("refine_resonance"):
        _refine_resonance(study, bridge, train)
    spans = bridge.resolved.get("spans") or []
    if spans and min(spans) < MIN_SPAN:
        # the span is the cause: no time-step or frequency message about its consequences
        _refuse(chk, solver, "allow_implausible", f"bridge.spans = {_show(spans)}: expected "
                f"spans of a railway bridge >= {MIN_SPAN:g} m (units: m)")
        if chk.errors:
            raise ConfigError(chk.errors, source=source)
    _physics_warnings(chk, bridge, train, irr, solver, study, contact, track)
    _plausibility(chk, bridge, train, irr, solver, study, contact)
    if chk.errors:  # checks of the whole model (time step, budget, plausibility)
        raise ConfigError(chk.errors, source=source)
    resolved = {
        "title": title if title is not None else default_title,
        "bridge": bridge.resolved,
        "train": train.resolved,
        "irregularity": irr.resolved,
        "solver": _drop_none(dict(solver)),
        "contact": contact,
        # (none with the FE track layer of [bridge.track]: that layer is the track)
        **({"track": track} if track["model"] != "bridge_layer" else {}),
        "study": {k: v for k, v in study.items() if not k.startswith("_")},
    }
    cfg = Config(
        title=resolved["title"], path=path, base_dir=base, resolved=resolved, bridge=bridge,
        train=train, irregularity=irr, solver=solver, study=study, warnings=chk.warnings,
    )
    cfg.warning_records = [dict(r) for r in chk.records]
    return cfg


def _check_file_coverage(chk, irr, x_start, x_stop):
    prof = irr.file_profile
    if prof.x0 > x_start + 1e-9 or prof.x_end < x_stop - 1e-9:
        chk.error("irregularity.path", irr.resolved["path"],
                  f"a profile covering the approach and the bridge, x = {x_start:g} .. "
                  f"{x_stop:g} m (the file covers {prof.x0:g} .. {prof.x_end:g} m and the "
                  "profile is zero outside)")


#: The nonlinear Hertz spring is checked at this multiple of the static wheel load.
HERTZ_LOAD_FACTOR = 2.0
#: Rigid contact with massive wheels needs at least this much numerical damping.
RIGID_MASSIVE_ALPHA = -0.02


def _hertz_warning(chk, train, dt, g, model="hertz"):
    """Wheel on the Hertz spring, stiffness at twice the static wheel load.

    The Hertz spring stiffens with the force, dN/d(delta) = 3 N^(1/3) / (2 G), so its
    frequency grows as N^(1/6).  A dip or a landing that the run should resolve lifts the
    contact force well above its static value Q0; the check takes the stiffness at
    :data:`HERTZ_LOAD_FACTOR` x Q0 (frequency x 2^(1/6) = 1.12), because the static-load
    stiffness let impact peaks be under-resolved without a warning.  The linearised
    model (``hertz_linear``) keeps the static-load stiffness for every force, so it is
    checked there.  Every wheel with mass is checked with its own static load.
    """
    from vsi_numba.model.library import static_axle_loads

    factor = HERTZ_LOAD_FACTOR if model == "hertz" else 1.0
    f_max, where = 0.0, ""
    for tr in train.trains:
        for v in tr.vehicles:
            if not v.n_wheels or v.total_weight <= 0:
                continue
            try:
                q0 = static_axle_loads(v)[: v.n_wheels]
            except (ValueError, np.linalg.LinAlgError):
                q0 = np.full(v.n_wheels, v.total_weight / v.n_wheels)
            m_w = np.diag(v.M)[v.wheel_dofs]
            ok = (m_w > 0) & (q0 > 0)
            if not ok.any():
                continue
            # N/m, d(N)/d(delta) of delta = G N^(2/3) at factor x Q0
            k_h = 1.5 * np.cbrt(factor * q0[ok]) / g
            f = float(np.max(np.sqrt(k_h / m_w[ok]))) / (2 * math.pi)
            if f > f_max:
                f_max, where = f, f"train '{tr.name}', vehicle '{v.name}'"
    if dt * f_max > DT_RESOLUTION:
        load = (f"at {factor:g} x the static wheel load: the spring stiffens with the force"
                if factor != 1.0 else "at the static wheel load")
        chk.warn(
            f"solver.dt = {dt:g} s: dt x f = {dt * f_max:.3g} for the wheel on the Hertz "
            f"contact spring ({f_max:.4g} Hz, {where}, {load}); above "
            f"{DT_RESOLUTION} it is under-resolved (impact peaks too low); use "
            f"dt <= {DT_RESOLUTION / f_max:.3g} s",
            "resolution", ["solver.dt", "contact.hertz_coefficient"])


def _track_warning(chk, train, dt, track, contact):
    """Elastic track: every wheel with mass on the track spring 1/G(0) (in series with
    the Hertz spring, at twice the static load for ``hertz``, when there is one).  The
    wheel-on-track mode (~40-60 Hz for a wheelset) must be resolved by the step."""
    from vsi_numba.model.library import static_axle_loads

    k_track = _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"]) \
        .axle_stiffness
    model = contact["model"]
    factor = HERTZ_LOAD_FACTOR if model == "hertz" else 1.0
    f_max, where = 0.0, ""
    for tr in train.trains:
        for v in tr.vehicles:
            if not v.n_wheels or v.total_weight <= 0:
                continue
            m_w = np.diag(v.M)[v.wheel_dofs]
            k = np.full(v.n_wheels, k_track)
            if model != "rigid":
                try:
                    q0 = static_axle_loads(v)[: v.n_wheels]
                except (ValueError, np.linalg.LinAlgError):
                    q0 = np.full(v.n_wheels, v.total_weight / v.n_wheels)
                k_h = 1.5 * np.cbrt(factor * np.clip(q0, 1.0, None)) / \
                    contact["hertz_coefficient"]
                k = 1.0 / (1.0 / k + 1.0 / k_h)
            ok = m_w > 0
            if not ok.any():
                continue
            f = float(np.max(np.sqrt(k[ok] / m_w[ok]))) / (2 * math.pi)
            if f > f_max:
                f_max, where = f, f"train '{tr.name}', vehicle '{v.name}'"
    if dt * f_max > DT_RESOLUTION:
        spring = "track" if model == "rigid" else "track and Hertz contact"
        chk.warn(
            f"solver.dt = {dt:g} s: dt x f = {dt * f_max:.3g} for the wheel on the {spring} "
            f"springs ({f_max:.4g} Hz, {where}); above {DT_RESOLUTION} it is under-resolved "
            f"(wheel-rail force peaks too low); use dt <= {DT_RESOLUTION / f_max:.3g} s",
            "resolution", ["solver.dt", "track.foundation_stiffness"]
            + (["contact.hertz_coefficient"] if model != "rigid" else []))


def _rigid_massive_warning(chk, train, alpha):
    """Rigid contact, wheels with mass, alpha > -0.02: the contact forces ring."""
    if alpha <= RIGID_MASSIVE_ALPHA:
        return
    for tr in train.trains:
        for v in tr.vehicles:
            if v.n_wheels and np.any(np.diag(v.M)[v.wheel_dofs] > 0):
                chk.warn(
                    f"solver.hht_alpha = {alpha:g} with contact.model = 'rigid' and wheels "
                    f"with mass (train '{tr.name}', vehicle '{v.name}'): the trapezoidal "
                    "rule is weakly unstable on the position constraint of a massive wheel "
                    "and the contact forces ring from step to step; use hht_alpha <= "
                    f"{RIGID_MASSIVE_ALPHA:g} (the default -0.3 is safe)"
                )
                return


def _physics_warnings(chk, bridge, train, irr, solver, study, contact, track):
    dt = solver["dt"]
    if track["model"] == "elastic":
        _track_warning(chk, train, dt, track, contact)
    elif contact["model"] != "rigid":
        _hertz_warning(chk, train, dt, contact["hertz_coefficient"], contact["model"])
    else:
        _rigid_massive_warning(chk, train, solver["hht_alpha"])
    vmax = max(study["speeds_kmh"]) / 3.6
    model = bridge.model
    if model is not None and model.n_modes:
        fmax = float(model.frequencies[-1])
        # the modes that enter the checks: those up to the deck-acceleration cut-off
        freqs = np.asarray(model.frequencies, float)
        f_cut = solver["acceleration_cutoff"]
        if f_cut is None:
            f_cut = max(30.0, 1.5 * freqs[0], freqs[2] if freqs.size >= 3 else 0.0)
        f_chk = float(freqs[freqs <= f_cut * (1 + 1e-9)].max(initial=freqs[0]))
        if dt * f_chk > DT_ERROR and not solver.get("allow_coarse_dt"):
            chk.errors.append(
                f"solver.dt = {dt:g}: expected a time step giving at least "
                f"{1 / DT_ERROR:.0f} steps per period of the highest retained bridge mode "
                f"within the checks' cut-off ({f_chk:.4g} Hz; cut-off {f_cut:.4g} Hz): "
                f"dt x f = {dt * f_chk:.3g} > {DT_ERROR}; use dt <= "
                f"{DT_RESOLUTION / f_chk:.3g} s (10 steps per period), or set "
                "solver.allow_coarse_dt = true to run anyway (the checks are then marked "
                "not reliable)")
        elif dt * fmax > DT_RESOLUTION:
            chk.warn(
                f"solver.dt = {dt:g} s: dt x f = {dt * fmax:.3g} for the highest retained "
                f"bridge mode ({fmax:.4g} Hz); above {DT_RESOLUTION} (fewer than "
                f"{1 / DT_RESOLUTION:.0f} steps per period) that mode is under-resolved and "
                f"damped numerically; use dt <= {DT_RESOLUTION / fmax:.3g} s or fewer modes",
                # only the modes within the cut-off make the checks unreliable
                "resolution" if dt * f_chk > DT_RESOLUTION else "input",
                ["solver.dt", "bridge.n_modes"])
            if dt * f_chk > DT_RESOLUTION and f_chk < fmax:
                chk.warn(
                    f"solver.dt = {dt:g} s: dt x f = {dt * f_chk:.3g} for the highest "
                    f"retained mode within the checks' cut-off ({f_chk:.4g} Hz); the "
                    "deck accelerations are under-resolved", "resolution",
                    ["solver.dt", "bridge.n_modes"])
        allf = bridge.all_frequencies
        if allf is not None and allf.size:
            f1 = float(allf[0])
            f3 = float(allf[2]) if allf.size >= 3 else 0.0
            cut = solver["acceleration_cutoff"]
            rule = "solver.acceleration_cutoff"
            if cut is None:
                cut = max(30.0, 1.5 * f1, f3)
                rule = "the EN 1990 A2.4.4.2.1 cut-off max(30 Hz, 1.5 f1, f3)"
            missing = int(np.count_nonzero(allf <= cut * (1 + 1e-9))) - model.n_modes
            if missing > 0:
                chk.warn(
                    f"bridge.n_modes: the highest retained mode ({fmax:.4g} Hz) is below "
                    f"{rule} = {cut:.4g} Hz; {missing} mode(s) up to the cut-off are left out "
                    "of the deck accelerations (raise bridge.n_modes or bridge.max_frequency)"
                )
    for tr in train.trains:
        fv = 0.0
        for v in tr.vehicles:
            if v.n_dof and v.n_dof > v.n_wheels:
                try:
                    f = v.natural_frequencies(fixed_wheels=True)
                except (ValueError, np.linalg.LinAlgError):
                    continue
                if f.size:
                    fv = max(fv, float(f.max()))
        if dt * fv > DT_ERROR and not solver.get("allow_coarse_dt"):
            chk.errors.append(
                f"solver.dt = {dt:g}: expected a time step giving at least "
                f"{1 / DT_ERROR:.0f} steps per period of the highest vehicle frequency of "
                f"train '{tr.name}' ({fv:.4g} Hz, wheels held): dt x f = {dt * fv:.3g} > "
                f"{DT_ERROR}; use dt <= {DT_RESOLUTION / fv:.3g} s, or set "
                "solver.allow_coarse_dt = true to run anyway (the results are then marked "
                "not reliable)")
        elif dt * fv > DT_RESOLUTION:
            chk.warn(
                f"solver.dt = {dt:g} s: dt x f = {dt * fv:.3g} for the highest vehicle "
                f"frequency of train '{tr.name}' ({fv:.4g} Hz, wheels held); above "
                f"{DT_RESOLUTION} it is under-resolved; use dt <= {DT_RESOLUTION / fv:.3g} s",
                "resolution", ["solver.dt", "train"])
    r = irr.resolved
    shortest = []
    if r["kind"] == "psd":
        shortest.append(("irregularity.wavelength_min", r["wavelength_min"]))
    if r["kind"] == "cosine":
        shortest.append(("irregularity.wavelength", r["wavelength"]))
    for i, dfc in enumerate(r.get("defects", [])):
        key = "wavelength" if dfc["kind"] == "cosine" else "length"
        shortest.append((f"irregularity.defects[{i}].{key}", dfc[key]))
    for key, lam in shortest:
        steps = lam / (vmax * dt)
        if steps < STEPS_PER_WAVELENGTH:
            chk.warn(
                f"{key} = {lam:g} m is crossed in {steps:.3g} time steps at "
                f"{vmax * 3.6:g} km/h (dt = {dt:g} s); fewer than {STEPS_PER_WAVELENGTH} "
                "steps per wavelength under-resolve the excitation (reduce solver.dt)",
                "resolution", ["solver.dt", key, "study.speeds_kmh"])
    amps = []
    if r["kind"] in ("cosine", "step"):
        key = "depth" if "depth" in r else "height"
        amps.append((f"irregularity.{key}", abs(r.get(key, 0.0))))
    for i, dfc in enumerate(r.get("defects", [])):
        key = "depth" if dfc["kind"] == "cosine" else "height"
        amps.append((f"irregularity.defects[{i}].{key}", abs(dfc.get(key, 0.0))))
    if irr.file_profile is not None and irr.file_profile.coef.size:
        amps.append(("irregularity.path", float(np.max(np.abs(irr.file_profile.coef[:, 0])))))
    combined = _defects_amplitude(r)
    if combined is not None and all(a <= MAX_PROFILE_AMPLITUDE for _, a in amps):
        amps.append(("irregularity.defects (added up)", combined))
    for key, amp in amps:
        if amp > MAX_PROFILE_AMPLITUDE and not solver.get("allow_implausible"):
            chk.errors.append(
                f"{key}: |r| = {amp:g} m: expected a track irregularity within "
                f"+-{MAX_PROFILE_AMPLITUDE * 1e3:g} mm (irregularities are in metres: was mm "
                "intended?); set solver.allow_implausible = true to run it anyway")
        elif amp > MAX_PROFILE_AMPLITUDE:
            chk.warn(f"{key}: |r| = {amp:g} m is more than "
                     f"{MAX_PROFILE_AMPLITUDE * 1e3:g} mm; irregularities are in metres (was "
                     "mm intended?)", "plausibility", [key])
    prof = irr.file_profile
    if prof is not None and bridge.length is not None and train.trains:
        tl = max(t.length for t in train.trains)
        lo, hi = -solver["approach"] - tl, bridge.length + tl
        if prof.x0 > lo + 1e-9 or prof.x_end < hi - 1e-9:
            chk.warn(f"irregularity.path: the profile covers x = {prof.x0:g} .. "
                     f"{prof.x_end:g} m; the trailing axles run over {lo:g} .. {hi:g} m and see "
                     "r = 0 outside the measured range")
    if model is not None and train.trains:
        length = max(t.length for t in train.trains)
        vmin = min(study["speeds_kmh"]) / 3.6
        steps = ((solver["approach"] + model.length + length) / vmin
                 + solver["free_vibration"]) / dt
        if steps > 2e7:
            chk.warn(f"solver.dt = {dt:g} s: the slowest run needs about {steps:.3g} time "
                     "steps; check the time step")


def _refuse(chk, solver, override: str, message: str) -> None:
    """An error unless ``solver.<override> = true`` (then a warning)."""
    if solver.get(override):
        chk.warn(f"{message} (accepted: solver.{override} = true)", "plausibility")
    else:
        chk.errors.append(f"{message}; set solver.{override} = true to run it anyway")


def _train_loads(tr):
    """Axle positions (m behind the first axle) and static loads (N) of a train: each
    vehicle's weight shared equally by its wheels, plus its moving forces."""
    xs, qs = [], []
    for v, off in zip(tr.vehicles, tr.offsets, strict=True):
        if v.n_wheels and v.total_weight > 0:
            share = (v.total_weight - float(np.sum(v.loads))) / v.n_wheels
            xs.append(off + np.asarray(v.wheel_positions, float))
            qs.append(np.full(v.n_wheels, max(share, 0.0)))
        if np.size(v.loads):
            xs.append(off + np.asarray(v.load_positions, float))
            qs.append(np.asarray(v.loads, float))
    if not xs:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(xs), np.concatenate(qs)


def _defect_profile(spec, x_stop: float):
    """The Profile of a resolved cosine or step defect (a step persists to ``x_stop``)."""
    if spec["kind"] == "cosine":
        return _irr.cosine_defect(spec["depth"], spec["wavelength"], spec["position"])
    stop = max(x_stop, spec["position"] + spec["length"])
    return _irr.step_defect(spec["height"], spec["length"], spec["position"], stop,
                            spec["shape"])


def _defects_amplitude(r) -> float | None:
    """Largest |r| (m) of the deterministic defects added up (a cosine or step base and
    every ``[[irregularity.defects]]``), or None without two of them.  A sweep over the
    defects' extents bounds it first; only a bound above the limit builds the profile."""
    specs = [dict(r)] if r["kind"] in ("cosine", "step") else []
    specs += list(r.get("defects", []))
    if len(specs) < 2:
        return None
    events = []
    for d in specs:
        amp = abs(d.get("depth", d.get("height", 0.0)))
        start = d["position"]
        end = start + (d["wavelength"] if d["kind"] == "cosine" else math.inf)
        events += [(start, amp), (end, -amp)]
    bound = level = 0.0
    for _, a in sorted(events, key=lambda e: (e[0], e[1] < 0)):
        level += a
        bound = max(bound, level)
    if bound <= MAX_PROFILE_AMPLITUDE:
        return bound
    stop = max(d["position"] + d.get("wavelength", d.get("length", 0.0)) for d in specs)
    total = _irr.combine(*[_defect_profile(d, stop) for d in specs])
    x = np.linspace(total.x0, total.x_end, min(200_000, total.coef.shape[0] * 4 + 1))
    return float(np.max(np.abs(total(x))))


def _plausibility(chk, bridge, train, irr, solver, study, contact):
    """Errors for input that cannot be meant (each names its keys and the override key)
    and for runs beyond the memory/time budget; warnings for the unusual."""
    model = bridge.model
    spans = np.atleast_1d(np.asarray(bridge.resolved.get("spans", [bridge.length or 0.0]),
                                     float))
    dt = solver["dt"]
    trains = list(train.trains)
    # -- static deflection of the deck under each train
    if model is not None and model.n_modes and trains and spans.size and spans.max() > 0:
        limit = MAX_STATIC_DEFLECTION * float(spans.max())
        pts = np.linspace(0.0, model.length, 41)
        phi_p = model.output_shapes(pts)  # (points, modes)
        # upper bound first: the heaviest bridge-length of axles at the most flexible
        # point, W max_x sum_j phi_j(x)^2 / w_j^2; the influence lines only when it exceeds
        # the limit (the bound is cheap; the exact pass costs ~50 ms per train)
        with np.errstate(all="ignore"):
            flex = float(np.max(np.sum(model.shapes(pts) ** 2 / model.omega**2, axis=1)))
        for tr in trains:
            x, q = _train_loads(tr)
            if not x.size:
                continue
            order = np.argsort(x)
            xs, cq = x[order], np.concatenate([[0.0], np.cumsum(np.abs(q[order]))])
            j = np.searchsorted(xs, xs + model.length, side="right")
            heaviest = float(np.max(cq[j] - cq[np.arange(xs.size)]))
            if np.isfinite(flex) and heaviest * flex <= limit:
                continue
            step = max(model.length / 200.0, 0.05)
            reach = model.length + float(x.max())
            n_f = min(reach / step + 2, max(200_000 // x.size, 2))  # keep it cheap
            fronts = np.linspace(0.0, reach, int(n_f))
            xx = fronts[:, None] - x[None, :]
            on = (xx >= 0.0) & (xx <= model.length)
            xx = np.where(on, xx, 0.0)
            phi_k = model.shapes(xx.ravel()).reshape(xx.shape + (model.n_modes,))
            phi_k = phi_k * on[..., None]
            with np.errstate(all="ignore"):  # absurd input: inf/NaN is the answer here
                modal = np.einsum("fkj,k->fj", phi_k, q) / model.omega**2
                w = float(np.max(np.abs(modal @ phi_p.T))) if modal.size else 0.0
            if not np.isfinite(w) or w > limit:
                _refuse(chk, solver, "allow_implausible",
                        f"train '{tr.name}' on the deck: static deflection {w:.3g} m > "
                        f"span/{1 / MAX_STATIC_DEFLECTION:.0f} = {limit:.3g} m (check "
                        "bridge.EI, bridge.mass_per_length, bridge.spans and the train's "
                        "loads/masses: units N, kg, N m^2?)")
    # -- Hertz static penetration
    if contact["model"] != "rigid":
        g = contact["hertz_coefficient"]
        for tr in trains:
            x, q = _train_loads(tr)
            if q.size and q.max() > 0:
                pen = g * float(q.max()) ** (2.0 / 3.0)
                if pen > MAX_HERTZ_PENETRATION:
                    _refuse(chk, solver, "allow_implausible",
                            f"contact.hertz_coefficient = {g:g}: static Hertz penetration "
                            f"{pen * 1e3:.3g} mm under the heaviest wheel of train "
                            f"'{tr.name}' ({float(q.max()):.4g} N) > "
                            f"{MAX_HERTZ_PENETRATION * 1e3:g} mm (G is in m N^-2/3, about "
                            "4e-8 for a wheel on a rail)")
    # -- vehicle stiffness
    for tr in trains:
        for v in tr.vehicles:
            if v.n_dof == 0:
                continue
            k = np.asarray(v.K, float)
            ks = 0.5 * (k + k.T)
            try:
                lam = np.linalg.eigvalsh(ks)
            except np.linalg.LinAlgError:
                continue
            scale = max(float(np.max(np.abs(lam))), 1e-300)
            if lam.size and lam.min() < -1e-9 * scale:
                _refuse(chk, solver, "allow_implausible",
                        f"train '{tr.name}', vehicle '{v.name}': the stiffness matrix K is "
                        f"not positive semi-definite (eigenvalue {lam.min():.4g} N/m; check "
                        "the signs of train.vehicles[].K or the spring stiffnesses)")
    # -- long trains
    for tr in trains:
        if tr.length > LONG_TRAIN:
            chk.warn(f"train '{tr.name}' is {tr.length:.4g} m long (more than "
                     f"{LONG_TRAIN:g} m): check the vehicle offsets", "plausibility",
                     ["train.vehicles[].offset"])
    # -- budget: time steps, histories, profile samples
    if model is None or not trains:
        return
    length = max(t.length for t in trains)
    vmin = min(study["speeds_kmh"]) / 3.6
    steps = ((solver["approach"] + model.length + length) / vmin
             + solver["free_vibration"]) / dt
    keys = ("solver.dt, study.speeds_kmh (slowest), solver.free_vibration, "
            "solver.approach, the train length (vehicle offsets)")
    if steps > MAX_STEPS:
        _refuse(chk, solver, "allow_large_problem",
                f"the slowest run needs {steps:.3g} time steps, more than the budget of "
                f"{MAX_STEPS:.3g}; check {keys}")
    elif study["save_time_histories"]:
        n_w = max(t.n_wheels + t.n_loads for t in trains)
        n_b = max(len(t.vehicles) for t in trains)
        nbytes = steps * 8.0 * (2 * model.n_modes + 2 * n_w + n_b)
        if nbytes > MAX_HISTORY_BYTES:
            _refuse(chk, solver, "allow_large_problem",
                    f"the time histories of the slowest run need about {nbytes / 2**30:.3g} "
                    f"GiB in memory ({steps:.3g} steps), more than the budget of "
                    f"{MAX_HISTORY_BYTES / 2**30:g} GiB; set study.save_time_histories = "
                    f"false or study.history_speeds_kmh, or check {keys}")
    r = irr.resolved
    if r["kind"] == "psd":
        from vsi_numba.study.grid import profile_range

        x0, x1 = profile_range(model.length, [t.length for t in trains],
                               solver["approach"], solver["free_vibration"])
        dx = r.get("dx") or r["wavelength_min"] / 20.0
        n = max(x1 - x0, 20.0 * r["wavelength_max"]) / dx
        if n > MAX_PROFILE_SAMPLES:
            _refuse(chk, solver, "allow_large_problem",
                    f"irregularity: each random profile needs {n:.3g} samples, more than "
                    f"the budget of {MAX_PROFILE_SAMPLES:.3g} (track length {x1 - x0:.4g} m "
                    f"and 20 x irregularity.wavelength_max = {20 * r['wavelength_max']:g} m "
                    f"at irregularity.dx = {dx:g} m, default wavelength_min / 20); check "
                    "irregularity.wavelength_min, wavelength_max, dx, solver.free_vibration "
                    "and the train length")


def load_config_for_cli(path, console) -> Config | None:
    """``load_config`` for a command: on a config error print every message on
    ``console`` (a rich Console) and return None (the command then exits with 2)."""
    try:
        return load_config(path)
    except ConfigError as exc:
        from rich.markup import escape

        console.print(f"[bold red]error[/]: {escape(str(path))}: invalid configuration",
                      highlight=False)
        console.print(str(exc), highlight=False, markup=False)
        return None
