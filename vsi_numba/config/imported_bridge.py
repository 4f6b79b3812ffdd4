"""Imported decks (``bridge.kind = 'modes_file'`` or ``'matrices'``): their files, degrees of
freedom and tracks, read and checked at load time."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsi_numba.config._check import (
    _BAD,
    _MISSING,
    _join,
    _ok,
)
from vsi_numba.config.limits import MAX_ECCENTRICITY, MAX_FIXED_DOFS  # noqa: F401
from vsi_numba.model import bridge as _bridge

_IMPORTED = ("modes_file", "matrices")
_IMPORT_FILES = {
    "file": "the deck modes (frequencies, modal masses, mode shapes at stations)",
    "stiffness_matrix": "the stiffness matrix K (Matrix Market)",
    "mass_matrix": "the mass matrix M (Matrix Market)",
    "station_map": "the station map (CSV: x, dof, rotation_dof, line)",
}


def _files_of_a_refused_deck(chk, d, base_dir) -> None:
    """The files of an imported deck whose table the model refused: each given path is
    checked (it exists) with the table's other errors."""
    from collections.abc import Mapping

    if not isinstance(d, Mapping) or d.get("kind") not in _IMPORTED:
        return
    for key, what in _IMPORT_FILES.items():
        if isinstance(d.get(key), str) and (key == "file") == (d["kind"] == "modes_file"):
            chk.file(d, "bridge", key, base_dir, what)


@dataclass(frozen=True)
class _Imported:
    """An imported deck as read: the model along the first track (or the track line)."""

    bridge: _bridge.ModalBridge
    all_frequencies: np.ndarray
    #: the deck with its tracks (:class:`~vsi_numba.model.imported.lines.LineDeck3D`)
    #: when ``bridge.tracks`` is given, else None
    space: Any = None


def _imported_track_keys(chk, b, res):
    """``bridge.tracks`` of a validated imported deck (each its own line, not with
    track_line: rules of the model): the list of resolved tracks, None when not given;
    the warnings about them."""
    if b.tracks is None:
        return None
    tracks = [t.model_dump(exclude_none=True) for t in b.tracks]
    for i, tr in enumerate(tracks):
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


def _imported_bridge(chk, b, base_dir, res, spans, damping, n_modes, fmax, cutoff,
                     tracks=None):
    """kind = modes_file | matrices: read the files now (errors join the others); with
    ``tracks`` (:func:`_imported_track_keys`), the deck with its tracks."""
    from vsi_numba.model import imported as _imp

    path, kind = "bridge", b.kind
    files = ("file",) if kind == "modes_file" else ("stiffness_matrix", "mass_matrix",
                                                    "station_map")
    given, full = {}, {}
    for key in files:
        given[key], full[key] = chk.file({key: getattr(b, key)}, path, key, base_dir,
                                         _IMPORT_FILES[key])
        res[key] = given[key]
    line = res["track_line"] = b.track_line
    extra: dict[str, Any] = {}
    if kind == "modes_file":
        extra["mass_normalised"] = res["mass_normalised"] = b.mass_normalised
    else:
        base, sign, fixed, vert = b.dof_base, float(b.rotation_sign), list(b.fixed_dofs), \
            b.vertical_dofs
        if vert is not None and not isinstance(vert, list):  # {start, step}
            vert = {"start": base if vert.start is None else vert.start, "step": vert.step}
        res.update(dof_base=base, rotation_sign=sign, fixed_dofs=fixed, vertical_dofs=vert)
        extra = {"dof_base": base, "rotation_sign": sign, "fixed_dofs": fixed,
                 "vertical_dofs": vert}
    if not _ok(*full.values()):
        return _BAD
    zeta = damping if "damping_ratio" in b.model_fields_set else None
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
