"""Variants of a study: ``study.vary``, ``study.vary_together`` and ``study.mass_bounds``
read as axes of key paths, and every combination validated as a configuration of its own."""

from __future__ import annotations

import copy
import itertools
import re
from collections.abc import Mapping

import numpy as np

from vsi_numba.config._check import ConfigError, _is_number, _key, _Num, _ok, _show
from vsi_numba.config.limits import MAX_VARIANTS

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
    labels = []
    for combo in itertools.product(*[range(len(axis[0][1])) for axis in axes]):
        lab = {}
        for axis, j in zip(axes, combo, strict=True):
            for k, vals in axis:
                lab[k] = vals[j]
        labels.append(lab)
    return labels


def _build_variants(data, axes, validate, path, base, source, base_speeds):
    """Validate every variant (the config with its key paths set, checked by
    ``validate(data, path, base, source)``); all errors at once."""
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
            out.append((lab, validate(vdata, path, base, source)))
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
