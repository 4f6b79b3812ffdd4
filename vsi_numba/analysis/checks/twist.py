"""Deck twist check of EN 1990 A2.4.4.2.2 (static, from influence lines).

The twist of a track over a base of 3 m, ``t = [w_L - w_R](x) - [w_L - w_R](x + 3)``
(:mod:`vsi_numba.model.deck3d`), under LM71 x Phi x alpha on one track placed most
unfavourably (the axle group and the distributed load where they are unfavourable,
:func:`~vsi_numba.analysis.checks.load_effects.lm71_envelope`), against the limit of the
line speed: ``twist_limit_up_to_120`` for V <= 120 km/h, ``twist_limit_up_to_200`` for
V <= 200 km/h, ``twist_limit_above_200`` above (4.5 / 3.0 / 1.5 mm, the code profile's
values, recalled [R]).  Each track is loaded in turn and the twist of every track is
checked (a beam deck twists as a whole: a train on one track twists the other too).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsi_numba.analysis.checks.load_effects import lm71_envelope
from vsi_numba.code_profile import resolve
from vsi_numba.en1991 import lm71
from vsi_numba.io.schema import ALL_TRACKS_SUFFIX

#: Clause of the check (the profile's twist entries carry it too).
TWIST_CLAUSE = "EN 1990 A2.4.4.2.2"


def twist_limit(speed_kmh: float, profile=None) -> float:
    """Limit (m) of the deck twist over 3 m for a line speed ``speed_kmh`` (km/h), from
    the code profile."""
    v = float(speed_kmh)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"speed = {speed_kmh!r} km/h: expected a line speed > 0")
    p = resolve(profile)
    key = ("twist_limit_up_to_120" if v <= 120.0 else "twist_limit_up_to_200"
           if v <= 200.0 else "twist_limit_above_200")
    return float(p[key])


class TwistCheck(NamedTuple):
    """The static twist of track ``track`` with LM71 x Phi x alpha on track ``loaded``
    (both 1-based).

    ``starts`` (m): window starts; ``twist_max``, ``twist_min`` (m): the design extremes
    per window (already times alpha and Phi); ``value`` (m): the largest |twist|, at the
    window start ``at`` with the centre of the LM71 axle group at ``load_at``;
    ``limit`` (m) for ``speed_kmh``; ``utilisation = value / limit``.
    """

    track: int
    loaded: int
    starts: np.ndarray
    twist_max: np.ndarray
    twist_min: np.ndarray
    value: float
    at: float
    load_at: float
    limit: float
    speed_kmh: float
    alpha: float
    phi: float

    @property
    def utilisation(self) -> float:
        return self.value / self.limit

    @property
    def passed(self) -> bool:
        return bool(self.value <= self.limit)


def static_twist_check(deck, speed_kmh: float, alpha: float, phi: float, profile=None,
                       intervals: int = 32, step: float = 0.05) -> list[TwistCheck]:
    """EN 1990 A2.4.4.2.2 under LM71 x Phi x alpha, every track loaded in turn.

    Parameters
    ----------
    deck : vsi_numba.model.deck3d.BeamDeck3D or LineDeck3D
        A beam deck with torsion, or an imported deck from FE matrices with rail lines
        (:class:`~vsi_numba.model.imported.lines.LineDeck3D`; a modes table has no
        stiffness and is refused, raising ``SpaceModelError``).
    speed_kmh : float
        The line speed (km/h) that selects the limit.
    alpha, phi : float
        Classification factor and dynamic factor (Phi_2 or Phi_3 of the deck's
        determinant length, :func:`vsi_numba.en1991.dynamic_factor`).
    profile : CodeProfile, optional
        LM71 and the limits (default: the recommended values).
    intervals : int
        Window starts per span (plus the windows across the deck ends).
    step : float
        Placement step of the LM71 axle group (m), see
        :func:`~vsi_numba.analysis.checks.load_effects.lm71_envelope`.

    Returns
    -------
    list of TwistCheck
        One per (loaded track, twisted track); the governing one is the largest
        utilisation.
    """
    limit = twist_limit(speed_kmh, profile)
    model = lm71(profile)
    starts = deck.twist_grid(intervals)
    bp = deck.twist_breakpoints(starts)
    out = []
    factor = float(alpha) * float(phi)
    for loaded in range(len(deck.tracks)):
        for k in range(len(deck.tracks)):
            env = lm71_envelope(deck.static_twist_line(k, starts, loaded=loaded), bp,
                                (0.0, deck.length), step=step, n_at=starts.size, model=model)
            tmax, tmin = factor * env.max, factor * env.min
            mag = np.maximum(np.abs(tmax), np.abs(tmin))
            i = int(np.argmax(mag))
            load_at = float(env.at_max[i] if abs(tmax[i]) >= abs(tmin[i]) else env.at_min[i])
            out.append(TwistCheck(k + 1, loaded + 1, starts, tmax, tmin, float(mag[i]),
                                  float(starts[i]), load_at, limit, float(speed_kmh),
                                  float(alpha), float(phi)))
    return out


class TwistResults(NamedTuple):
    """The twist checks of a results file (:func:`twist_checks`).

    ``static``: :class:`TwistCheck` per (loaded track, twisted track); ``dynamic``: per
    track, the largest |twist| over 3 m of the study's runs (m) with its train, speed
    and window start (whole-deck grid and output points), or an empty list when the
    file has no twist; ``acceleration``: per track, the peak deck acceleration along the
    track (m s-2, at the output points) with its train and speed; ``limit`` (m) of
    ``line_speed_kmh``; ``acceleration_limit`` (m s-2); ``loaded_track`` (1-based);
    ``lphi`` (m), ``maintenance``; ``static_note``: why there is no static check ("" when
    there is one).
    """

    static: list
    dynamic: list
    acceleration: list
    limit: float
    line_speed_kmh: float
    acceleration_limit: float
    loaded_track: int
    lphi: float
    maintenance: str
    static_note: str = ""
    #: ``dynamic`` and ``acceleration`` with every train of a run loaded
    #: (``train.other_trains``; empty without)
    dynamic_all: list | tuple = ()
    acceleration_all: list | tuple = ()


#: Bridge kinds whose tracks are lines of imported data (their files are read again).
_IMPORTED = ("modes_file", "matrices")


def _deck_of(ds, base_dir=None, source_path=None):
    """The deck in space rebuilt from the stored configuration, or why not (str).  The
    files of an imported deck are looked for next to ``base_dir``, the results file
    ``source_path`` (and up to three folders above it) and the working folder."""
    from vsi_numba.analysis.checks.determinant import results_config
    from vsi_numba.analysis.recompute import _candidates
    from vsi_numba.config import ConfigError, load_config

    cfg = results_config(ds)
    bridge = cfg.get("bridge", {}) if isinstance(cfg, dict) else {}
    imported = isinstance(bridge, dict) and bridge.get("kind") in _IMPORTED
    if not isinstance(bridge, dict) or ("torsion" not in bridge and not imported):
        return "the deck has no torsion (bridge.torsion): it does not twist"
    why = ""
    stored = ds.attrs.get("config_directory")
    for folder in _candidates(base_dir, source_path, stored) if imported else [None]:
        try:
            deck = load_config(cfg, base_dir=folder).deck_in_space
        except (ConfigError, OSError, ValueError) as exc:
            why = why or " ".join(str(exc).split())
            continue
        return deck if deck is not None else "the stored configuration has no deck in space"
    return f"the stored configuration cannot be rebuilt ({why})"


def _worst(da, dims):
    """(value, {dim: label}) of the largest finite entry of ``da``."""
    a = np.asarray(da.values, float)
    if not np.isfinite(a).any():
        return float("nan"), {}
    i = np.unravel_index(int(np.nanargmax(a)), a.shape)
    return float(a[i]), {d: da[d].values[k] for d, k in zip(da.dims, i, strict=True)
                         if d in dims}


def twist_checks(ds, profile=None, length: float | None = None, base_dir=None,
                 source_path=None):
    """EN 1990 A2.4.4.2.2 from a results file of a deck in space: the static check
    under LM71 x Phi x alpha (:func:`static_twist_check`, each track loaded in turn)
    and the largest twist of the dynamic runs, both against the limit of the line speed
    (``study.line_speed_kmh``, else the highest speed of the study), and the peak deck
    acceleration along each track (limit of the track type).

    ``base_dir``, ``source_path``: where to look for the files of an imported deck
    (:func:`_deck_of`).

    Returns
    -------
    TwistResults or str
        The checks, or why they cannot be made.
    """
    from vsi_numba.analysis.checks.common import profile_of
    from vsi_numba.analysis.checks.determinant import determinant_length, results_config
    from vsi_numba.analysis.checks.load_effects import study_factors
    from vsi_numba.analysis.dataset import prepare, track_type
    from vsi_numba.en1990 import deck_acceleration_limits
    from vsi_numba.en1991 import dynamic_factor
    from vsi_numba.model.deck3d import SpaceModelError

    ds = prepare(ds)
    if "max_track_displacement" not in ds:
        return "the results hold no per-track outputs (no bridge.tracks / bridge.torsion)"
    profile = profile_of(ds, profile)
    study = results_config(ds).get("study", {})
    speeds = np.asarray(ds["speed_kmh"].values if "speed_kmh" in ds.coords
                        else ds["speed"].values * 3.6, float)
    line = float(study.get("line_speed_kmh") or np.nanmax(speeds))
    limit = twist_limit(line, profile)
    alpha, maintenance = study_factors(ds)
    lphi = determinant_length(ds, length, profile)
    acc_limits = deck_acceleration_limits(profile)
    acc_limit = float(acc_limits.get(track_type(ds), min(acc_limits.values())))
    dynamic, accel = _dynamic(ds, "")
    dynamic_all, accel_all = _dynamic(ds, ALL_TRACKS_SUFFIX)
    static: list = []
    deck = _deck_of(ds, base_dir, source_path)
    note = deck if isinstance(deck, str) else ""
    if not np.isfinite(lphi.value):
        note = note or "no determinant length"
    elif not note:
        phi = dynamic_factor(lphi.value, maintenance, profile)
        try:
            static = static_twist_check(deck, line, alpha, phi, profile)
        except SpaceModelError as exc:
            note = str(exc)
    return TwistResults(static, dynamic, accel, limit, line, acc_limit,
                        int(ds.attrs.get("loaded_track", 1)), float(lphi.value), maintenance,
                        note, dynamic_all, accel_all)


def _dynamic(ds, sfx: str) -> tuple[list, list]:
    """Per track: the largest |twist| of the runs (whole-deck grid and output points)
    and the peak acceleration along the track, from the variables named with ``sfx``
    (none: empty lists)."""
    dynamic, accel = [], []
    if f"max_track_acceleration{sfx}" not in ds:
        return dynamic, accel
    for k in [int(t) for t in ds["track"].values]:
        if f"max_deck_twist_whole_deck{sfx}" in ds:
            v1, w1 = _worst(ds[f"max_deck_twist_whole_deck{sfx}"].sel(track=k),
                            ("speed", "train", "twist_x"))
            v2, w2 = _worst(ds[f"max_deck_twist{sfx}"].sel(track=k),
                            ("speed", "train", "point"))
            v, w = (v1, w1) if not v2 > v1 else (v2, w2)
            at = w.get("twist_x", w.get("point", np.nan))
            dynamic.append((k, v, str(w.get("train", "")),
                            float(w.get("speed", np.nan)) * 3.6, float(at)))
        a, wa = _worst(ds[f"max_track_acceleration{sfx}"].sel(track=k),
                       ("speed", "train", "point"))
        x = float(wa.get("point", np.nan))
        name = f"max_track_acceleration_whole_deck{sfx}"
        if name in ds:  # the whole-deck grid along the track line
            g = np.asarray(ds[name].sel(track=k).values, float)
            a2, w2 = _worst(ds[name].sel(track=k), ("speed", "train"))
            if np.isfinite(a2) and (a2 > a or not np.isfinite(a)):
                a, wa = a2, w2
                x = float(np.asarray(ds[f"position_of_max_track_acceleration_whole_deck{sfx}"]
                                     .sel(track=k).values)[
                    np.unravel_index(int(np.nanargmax(g)), g.shape)])
        accel.append((k, a, str(wa.get("train", "")), float(wa.get("speed", np.nan)) * 3.6,
                      x))
    return dynamic, accel
