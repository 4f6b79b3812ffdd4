"""Imported decks (``bridge.kind = 'modes_file'`` or ``'matrices'``): their files, degrees of
freedom and tracks, read and checked at load time."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _as_list,
    _join,
    _ok,
)
from vsi_numba.config.limits import MAX_ECCENTRICITY
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import Int, expected_of
from vsi_numba.model import bridge as _bridge

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
        start = chk.get_number(v, p, "start", Int(ge=base),
                               f"an integer DOF number >= dof_base ({base})", default=base)
        step = chk.get_number(v, p, "step", Int(ge=1), "an integer step >= 1", default=1)
        return {"start": start, "step": step} if _ok(start, step) else _BAD
    expected = f"a list of integer DOF numbers >= dof_base ({base})" + (
        ", or {start = i, step = s}" if allow_pattern else "")
    if not isinstance(v, list) or len(v) > MAX_FIXED_DOFS:
        return chk.error(p, d[key], expected)
    out = [chk.number(x, f"{p}[{i}]", Int(ge=base),
                      f"an integer DOF number >= dof_base ({base})") for i, x in enumerate(v)]
    return out if _ok(*out) else _BAD


@dataclass(frozen=True)
class _Imported:
    """An imported deck as read: the model along the first track (or the track line)."""

    bridge: _bridge.ModalBridge
    all_frequencies: np.ndarray
    #: the deck with its tracks (:class:`~vsi_numba.model.imported.lines.LineDeck3D`)
    #: when ``bridge.tracks`` is given, else None
    space: Any = None


def _imported_track_keys(chk, d, res):
    """``bridge.tracks`` of an imported deck (declared:
    :class:`~.schema.models.ImportedTrack`): the list of resolved tracks, None when not
    given, or ``_BAD``."""
    if "tracks" not in d:
        return None
    tracks = chk.table_list(d["tracks"], "bridge.tracks", _m.ImportedTrack,
                            expected="a list of 1 to 20 tracks, each { line = \"T\" } (a "
                                     "track of the data)",
                            what=" { line = \"T\" }", max_len=20)
    if not _ok(tracks):
        return _BAD
    if "track_line" in d:
        return chk.error("bridge.track_line", d["track_line"], "no track_line with "
                         "bridge.tracks: each track names its line ({ line = \"T\" })")
    seen: dict[str, int] = {}
    for i, tr in enumerate(tracks):
        if tr["line"] in seen:
            return chk.error(f"bridge.tracks[{i}].line", tr["line"],
                             f"a track of its own (bridge.tracks[{seen[tr['line']]}] is "
                             "that track already)")
        seen[tr["line"]] = i
        y = tr.get("eccentricity")
        if y is not None and abs(y) > MAX_ECCENTRICITY:
            chk.warn(f"bridge.tracks[{i}].eccentricity = {y:g} m: farther than "
                     f"{MAX_ECCENTRICITY:g} m from the deck's axis (the outer tracks of a "
                     "four-track deck stand about 7 m off it); a value in mm?",
                     "plausibility", [f"bridge.tracks[{i}].eccentricity"])
    given = [i for i, tr in enumerate(tracks) if "eccentricity" in tr]
    if given and len(given) < len(tracks):
        i = next(i for i, tr in enumerate(tracks) if "eccentricity" not in tr)
        chk.warn(f"bridge.tracks[{i}] (line '{tracks[i]['line']}') has no eccentricity "
                 "while other tracks have one: the results label the tracks by their "
                 "eccentricity only when every track gives it", "input",
                 [f"bridge.tracks[{i}].eccentricity"])
    res["tracks"] = tracks
    return tracks


def _imported_bridge(chk, d, base_dir, kind, res, spans, damping, n_modes, fmax, cutoff,
                     tracks=None):
    """kind = modes_file | matrices: read the files now (errors join the others); with
    ``tracks`` (:func:`_imported_track_keys`), the deck with its tracks."""
    from vsi_numba.model import imported as _imp

    path = "bridge"
    files = ("file",) if kind == "modes_file" else ("stiffness_matrix", "mass_matrix",
                                                    "station_map")
    given, full = {}, {}
    for key in files:
        given[key], full[key] = chk.file(d, path, key, base_dir, _IMPORT_FILES[key])
        res[key] = given[key]
    line = chk.string(d, path, "track_line", expected_of(_m.Matrices, "track_line"),
                      default=None)
    res["track_line"] = line
    extra: dict[str, Any] = {}
    if kind == "modes_file":
        extra["mass_normalised"] = chk.boolean(d, path, "mass_normalised", None)
        res["mass_normalised"] = extra["mass_normalised"]
    else:
        base = chk.get_number(d, path, "dof_base", Int(ge=0, le=1),
                              expected_of(_m.Matrices, "dof_base"), default=0)
        sign_expected = expected_of(_m.Matrices, "rotation_sign")
        sign = chk.get_number(d, path, "rotation_sign", float, sign_expected, default=1.0)
        if _ok(sign) and sign not in (1, -1):
            sign = chk.error("bridge.rotation_sign", d["rotation_sign"], sign_expected)
        b0 = base if _ok(base) else 0
        fixed = _dof_indices(chk, d, "fixed_dofs", b0) if "fixed_dofs" in d else []
        vert = (_dof_indices(chk, d, "vertical_dofs", b0, allow_pattern=True)
                if "vertical_dofs" in d else None)
        res.update(dof_base=base, rotation_sign=sign, fixed_dofs=fixed, vertical_dofs=vert)
        extra = {"dof_base": base, "rotation_sign": float(sign) if _ok(sign) else sign,
                 "fixed_dofs": fixed, "vertical_dofs": vert}
    if not _ok(*full.values(), line, spans, damping, n_modes, fmax, tracks,
               *extra.values()):
        return _BAD
    zeta = damping if "damping_ratio" in d else None
    span_list = spans if isinstance(spans, list) else None
    names = {"stiffness": given["stiffness_matrix"], "mass": given["mass_matrix"],
             "stations": given["station_map"]} if kind == "matrices" else None
    space = None
    try:
        if tracks is not None:
            space = _imported_tracks(_imp, kind, full, given, tracks, extra, names,
                                     n_modes=n_modes, max_frequency=fmax, damping=damping,
                                     zeta=zeta, spans=span_list, cutoff=cutoff)
            out = _imp.ImportResult(space.track_bridge(0), space.all_frequencies,
                                    space.warnings)
        elif kind == "modes_file":
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
                spans=span_list, all_up_to=max(30.0, cutoff or 0.0), names=names)
    except _imp.ModelFileError as exc:
        for key, value, expected in exc.problems:
            if key in given:
                value = given[key]
            where = f"{path}.{key}" if key.startswith("tracks[") else _join(path, key)
            chk.error(where, _MISSING if value is None else value, expected)
        return _BAD
    except (ValueError, OSError, ArithmeticError, MemoryError) as exc:  # unforeseen content
        key = files[0]
        chk.error(_join(path, key), given[key],
                  f"{_IMPORT_FILES[key]} that can be read ({type(exc).__name__}: "
                  f"{' '.join(str(exc).split())[:160]})")
        return _BAD
    for w in out.warnings:
        chk.warn(w)
    if space is not None:
        _imported_track_warnings(chk, space)
    return _Imported(out.bridge, out.all_frequencies, space)


def _imported_tracks(_imp, kind, full, given, tracks, extra, names, *, n_modes,
                     max_frequency, damping, zeta, spans, cutoff):
    """The :class:`~vsi_numba.model.imported.lines.LineDeck3D` of ``bridge.tracks``,
    labelled by the eccentricities given (NaN where not given)."""
    from vsi_numba.model.imported import lines

    if kind == "modes_file":
        deck = lines.read_modes_table_tracks(
            full["file"], tracks, n_modes=n_modes, max_frequency=max_frequency,
            damping_ratio=zeta, mass_normalised=extra["mass_normalised"], spans=spans,
            name=given["file"])
    else:
        deck = lines.read_matrices_tracks(
            full["stiffness_matrix"], full["mass_matrix"], full["station_map"], tracks,
            fixed_dofs=extra["fixed_dofs"], dof_base=extra["dof_base"], n_modes=n_modes,
            max_frequency=max_frequency, damping_ratio=damping,
            rotation_sign=extra["rotation_sign"], vertical_dofs=extra["vertical_dofs"],
            spans=spans, all_up_to=max(30.0, cutoff or 0.0), names=names)
    labels = np.array([tr.get("eccentricity", np.nan) for tr in tracks], float)
    return dataclasses.replace(deck, labels=labels)


def _imported_track_warnings(chk, space):
    """Warn about the tracks of an imported deck that will give less than asked."""
    bare = [i for i, r in enumerate(space.rails) if r is None]
    if bare:
        names = ", ".join(f"bridge.tracks[{i}] ('{space.tracks[i].line}')" for i in bare)
        t = space.tracks[bare[0]].line
        chk.warn(f"{names}: no rail lines ('{t}/left' and '{t}/right') in the data, only "
                 "the centre line: the deck twist needs the rails of every track and is "
                 "left out of the results", "input", [f"bridge.tracks[{i}]" for i in bare])
    for i, r in enumerate(space.rails):
        if r is not None and np.array_equal(r[0].values, r[1].values):
            chk.warn(f"bridge.tracks[{i}] (line '{space.tracks[i].line}'): its two rail "
                     "lines have the same mode shapes, so the deck never twists under "
                     "them: are both rails mapped to the same DOFs?", "plausibility",
                     [f"bridge.tracks[{i}]"])
