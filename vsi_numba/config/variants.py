"""Variants of a study: ``study.vary``, ``study.vary_together`` and ``study.mass_bounds``
read as axes of key paths, and every combination validated as a configuration of its own."""

from __future__ import annotations

import copy
import itertools
import math
import re
from collections.abc import Mapping

from vsi_numba.config._check import ConfigError, _is_number, _key, _ok, _show
from vsi_numba.config.limits import MAX_VARIANTS
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import item_type

_KEY_PATH = re.compile(r"^[A-Za-z_]\w*(\[\d+\])?(\.[A-Za-z_]\w*(\[\d+\])?)+$")
_VARY_SECTIONS = ("bridge", "train", "irregularity", "solver", "contact", "track")
#: Keys that are axes of every study (trains, realisations), not variants, and what to
#: do instead.
_STUDY_AXES = {
    "train.preset": "list several trains in train.preset (one train each, every variant "
                    "runs them all)",
    "train.file": "put the trains in one train file (every variant runs them all)",
    "irregularity.seeds": "list several seeds in irregularity.seeds (every variant runs "
                          "every realisation)",
}
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
        axis_key = isinstance(key, str) and key.split("[")[0] in _STUDY_AXES
        if axis_key:
            return chk.error(path, key, f"a key path that is not an axis of the study: "
                             f"{_STUDY_AXES[key.split('[')[0]]}")
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
                            item_type(_m.Study, "mass_bounds"),
                            "a factor on bridge.mass_per_length > 0",
                            expected="factors on bridge.mass_per_length, e.g. [0.9, 1.1] "
                                     "(EN 1991-2 6.4.6.3.2: lower and upper bound)",
                            min_len=1)
        if _ok(f):
            axes.append([(MASS_FACTOR, f)])
    paths = [k for axis in axes for k, _ in axis]
    dup = {k for k in paths if paths.count(k) > 1}
    if dup:
        return chk.error("study.vary", sorted(dup), "each key path varied once")
    # Python integers: a product of many axes must not wrap around (np.prod would)
    n = math.prod(len(axis[0][1]) for axis in axes) if axes else 0
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
    if not errors and out:
        errors += _same_axes(out)
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


def variant_where(label: dict, width: int = 30) -> str:
    """``"solver.dt = 0.004, bridge.EI = 8e+09"``: the values that make a variant."""
    return ", ".join(f"{k} = {_show(v, width)}" for k, v in label.items())


def merge_variant_warnings(variants) -> list[dict]:
    """The warnings of a study of variants as records ``{"message", "kind", "keys",
    "variants"}``: a warning every variant has is said once, unmarked; a warning of some
    variants is marked with them ("variant 1 (solver.dt = 0.004): ...").

    Parameters
    ----------
    variants : list of (dict, Config)
        :attr:`Config.variants` (labels and configurations, in variant order).
    """
    n = len(variants)
    order: list[tuple[str, str]] = []
    seen: dict[tuple[str, str], dict] = {}
    for k, (_, vcfg) in enumerate(variants):
        for rec in getattr(vcfg, "warning_records", []) or []:
            key = (str(rec.get("message", "")), str(rec.get("kind", "input")))
            if key not in seen:
                seen[key] = {"rec": rec, "variants": []}
                order.append(key)
            if k not in seen[key]["variants"]:
                seen[key]["variants"].append(k)
    out = []
    for key in order:
        rec, ks = seen[key]["rec"], seen[key]["variants"]
        msg = key[0]
        if len(ks) < n:
            if len(ks) == 1:
                where = variant_where(variants[ks[0]][0])
                msg = f"variant {ks[0]}{f' ({where})' if where else ''}: {msg}"
            else:
                shown = ", ".join(str(k) for k in ks[:12]) + (", ..." if len(ks) > 12 else "")
                msg = f"variants {shown}: {msg}"
        out.append({"message": msg, "kind": key[1], "keys": list(rec.get("keys", [])),
                    "variants": list(ks)})
    return out


def _axes_of(cfg) -> tuple[list, list]:
    """Train names and irregularity realisation ids of a configuration."""
    names = [t.name for t in cfg.trains()]
    irr = cfg.resolved()["irregularity"]
    ids = [int(s) for s in irr.get("seeds", [])] if irr.get("kind") == "psd" else [-1]
    return names, ids


def _same_axes(variants) -> list[str]:
    """Errors for variants whose trains or realisations differ from variant 0's (they are
    the study's axes, the same for every variant)."""
    names0, ids0 = _axes_of(variants[0][1])
    errors = []
    for n, (lab, vcfg) in enumerate(variants[1:], start=1):
        names, ids = _axes_of(vcfg)
        if names != names0 or ids != ids0:
            what = (f"the trains ({', '.join(names)} instead of {', '.join(names0)})"
                    if names != names0 else
                    f"the irregularity realisations ({ids} instead of {ids0})")
            errors.append(f"study.vary (variant {n}: {variant_where(lab)}): changes {what}; "
                          "the trains and the realisations are axes of the study, the same "
                          "for every variant: list the trains in train.preset and the seeds "
                          "in irregularity.seeds, and vary bridge, track, contact, solver or "
                          "vehicle data")
    return errors
