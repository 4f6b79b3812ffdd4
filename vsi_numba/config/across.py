"""Checks across sections that need several sections' resolved values: the trains on
other tracks against the deck's tracks, and the load distribution of [track] against the
trains and the approach."""

from __future__ import annotations

import numpy as np

from vsi_numba.config._check import _ok
from vsi_numba.model import distribution as _dist


def _other_train_checks(chk, bridge, train) -> None:
    """``train.other_trains`` against the bridge's tracks and the trains: each on a track
    of ``bridge.tracks`` other than ``train.track`` and the others, on a deck without the
    FE track layer. Moving-force trains: their runs are superposed (exact for a linear
    deck under prescribed forces), on a built-in deck or an imported one whose tracks are
    named lines of its data, each with its own train and speed if given. Interaction
    trains: every train in the same run, the run's train on a built-in deck, at its own
    ``speed_factor`` if given (no ``train`` or ``speed_kmh`` of its own)."""
    others = train.resolved["other_trains"]
    n_tracks = len(bridge.resolved.get("tracks", [{}]))
    own = train.resolved.get("track", 1)
    seen = {own}
    # (a train.track already refused: the other trains' tracks are not compared with it)
    for i, o in enumerate(others if _ok(own) else ()):
        k = int(o["track"])
        p = f"train.other_trains[{i}].track"
        if k > n_tracks:
            chk.error(p, k, f"a track of bridge.tracks, 1 .. {n_tracks} (the bridge has "
                            f"{n_tracks} track{'s' if n_tracks != 1 else ''}: give "
                            "bridge.tracks = [{ eccentricity = .. }, ...])")
        elif k in seen:
            chk.error(p, k, f"a track not loaded yet (train.track = {own}"
                            + "".join(f", other_trains[{j}].track = {int(q['track'])}"
                                      for j, q in enumerate(others[:i])) + ")")
        seen.add(k)
    if "track" in bridge.resolved:
        chk.error("train.other_trains", others, "no other trains with the FE track layer "
                  "[bridge.track] (its track is the deck's line: one track)")
    kind = bridge.resolved.get("kind")
    lines = [t.get("line") for t in bridge.resolved.get("tracks") or [] if isinstance(t, dict)]
    imported_lines = kind in ("matrices", "modes_file") and lines and all(lines)
    dyn = [tr.name for tr in train.trains if any(v.n_dof > 0 for v in tr.vehicles)]
    if dyn:
        _interaction_other_train_checks(chk, kind, others, dyn)
    elif kind not in ("simply_supported", "continuous") and not imported_lines:
        chk.error("train.other_trains", others, "a simply_supported or continuous deck, or "
                  "an imported deck (matrices or modes_file) whose tracks are named lines "
                  "of its data (bridge.tracks = [{ line = \"..\" }, ...]; bridge.kind = "
                  f"\"{kind}\" has no track lines to put the trains on)")


def _interaction_other_train_checks(chk, kind, others, dyn) -> None:
    """``train.other_trains`` of interaction trains (``dyn``: their names): every train in
    one run, so the run's train again on a simply_supported or continuous deck, at the
    run's speed times ``speed_factor``."""
    names = f"{', '.join(dyn[:3])}{' ...' if len(dyn) > 3 else ''}"
    if kind not in ("simply_supported", "continuous"):
        chk.error("train.other_trains", others, "a simply_supported or continuous deck "
                  f"with interaction trains ({names}; bridge.kind = \"{kind}\": several "
                  "interaction trains in one run are not offered on imported decks; "
                  "moving-force trains, train.model = \"moving_force\", are superposed "
                  "there)")
    for i, o in enumerate(others):
        p = f"train.other_trains[{i}]"
        if "train" in o:
            chk.error(f"{p}.train", o["train"], "no train of its own with interaction "
                      f"trains ({names}: the run's train again, every train in one run; "
                      "own trains are for moving-force trains, train.model = "
                      "\"moving_force\")")
        if "speed_kmh" in o:
            chk.error(f"{p}.speed_kmh", o["speed_kmh"], "a speed_factor instead with "
                      f"interaction trains ({names}: every train in one run, its speed a "
                      "multiple of the run's speed)")


def _distribution_checks(chk, track, solver, train) -> None:
    """Warn when ``track.load_distribution`` has no moving force to act on (interaction
    trains only), or when its forces reach beyond the approach: the first axle's forward
    forces then start on the deck (a sudden load)."""
    dist = _dist.from_track_config(track) if _ok(track) else None
    if dist is None:
        return
    if _ok(train) and not any(np.size(v.loads) for tr in train.trains
                              for v in tr.vehicles):
        chk.warn(f"track.load_distribution = '{dist.kind}' is not used: no train of the "
                 "study has moving forces (it spreads moving forces only; interaction "
                 "trains see the track of track.model)", keys=["track.load_distribution"])
    elif _ok(solver) and solver["approach"] < dist.extent:
        chk.warn(f"solver.approach = {solver['approach']:g} m is shorter than the reach of "
                 f"track.load_distribution = '{dist.kind}' ({dist.extent:.3g} m ahead of "
                 "an axle): the first axle's forward forces start on the deck, a sudden "
                 "load; expected an approach of at least that length",
                 keys=["solver.approach", "track.load_distribution"])
