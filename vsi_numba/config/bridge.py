"""``[bridge]`` and ``[bridge.track]``: the deck, built at load time.

The modes are computed (or read, for imported bridges) while the file is validated: the
time-step and cut-off checks need the frequencies, and a deck that cannot be built is a
configuration error like any other.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsi_numba import en1990, en1991
from vsi_numba.code_profile import damping_span
from vsi_numba.config._check import (
    _BAD,
    _Checker,
    _drop_none,
    _is_number,
    _ok,
    _Sentinel,
)
from vsi_numba.config.imported_bridge import (
    _IMPORTED,
    _imported_bridge,
    _imported_track_keys,
)
from vsi_numba.config.limits import (
    DT_RESOLUTION,
    MAX_DAMPING_RATIO,
    MAX_ECCENTRICITY,
    MAX_MODES,
    MAX_TRACK_DOFS,  # noqa: F401 (re-exported)
)
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import kinds_of
from vsi_numba.config.schema.bridge import EN_DAMPING
from vsi_numba.model import bridge as _bridge

BRIDGE_KINDS = tuple(kinds_of(_m.Bridge))


@dataclass(frozen=True)
class _BridgeSpec:
    """The validated ``[bridge]``: its resolved keys and the model built from them."""

    kind: str
    resolved: dict
    length: float
    model: _bridge.ModalBridge
    all_frequencies: np.ndarray | None  # the spectrum up to the EN 1990 cut-off
    output_points: np.ndarray
    #: the deck in space (tracks, torsion; :mod:`vsi_numba.model.deck3d`) of a beam deck
    #: with ``tracks`` or ``torsion`` given, else None (today's planar deck)
    space: Any = None
    #: the torsional spectrum of a beam deck with torsion up to (at least) the cut-off
    #: of the deck-acceleration check (Hz, ascending), else None
    torsional_frequencies: np.ndarray | None = None

    def frequencies_left_out(self, cutoff: float) -> np.ndarray | None:
        """The natural frequencies (Hz) up to ``cutoff`` of the modes the model does not
        keep (empty: every mode up to the cut-off is kept); None when the spectrum up to
        the cut-off is not known (a rigid deck has no modes: empty)."""
        if self.kind == "rigid":
            return np.zeros(0)
        if self.all_frequencies is None:
            return None
        top = float(cutoff) * (1 + 1e-9)
        kept = np.asarray(self.model.frequencies, float)
        share = getattr(self.space, "torsional_share", None)
        share = np.zeros(kept.size) if share is None else np.asarray(share, float)
        out = []
        families = [(np.asarray(self.all_frequencies, float), kept[share <= 0.5])]
        if self.torsional_frequencies is not None:
            families.append((np.asarray(self.torsional_frequencies, float),
                             kept[share > 0.5]))
        for every, have in families:
            below = np.sort(every[every <= top])
            n_kept = int(np.count_nonzero(have <= top))
            out += list(below[n_kept:])  # the lowest are the ones kept
        return np.sort(np.asarray(out, float))


#: The track forms of EN 1990 A2.4.4.2.1(4)P (each with its deck-acceleration limit).
TRACK_TYPES = tuple(en1990.DECK_ACCELERATION_LIMITS)


def _bridge_section(chk: _Checker, b, base_dir: Path, solver_cutoff) -> _BridgeSpec | _Sentinel:
    """The deck of a validated ``[bridge]`` (:data:`~.schema.models.Bridge`, the rules
    between its keys checked there) and the checks that need more than the table: the
    modes (built or read now), the files of an imported deck, the output points on an
    imported deck."""
    if isinstance(b, _Sentinel):  # refused (reported) or missing
        return _BAD
    kind = b.kind
    for k in b._ignored:
        chk.warn(f"bridge.{k} is ignored: not used by bridge.kind = '{kind}'")
    spans = b.spans
    if _is_number(spans):
        spans = [spans]
    length = float(sum(spans)) if spans is not None else None

    res: dict[str, Any] = {"kind": kind}
    # EN 1990 A2.4.4.2.1(4)P: the deck-acceleration limit depends on the track form
    res["track_type"] = b.track_type
    if spans is not None:
        res["spans"] = spans
    flexible = kind in ("simply_supported", "continuous")
    ei = mass = damping = n_modes = fmax = eps = track = None
    if flexible:
        ei, mass = b.EI, b.mass_per_length
        res.update(EI=ei, mass_per_length=mass)
    if kind != "rigid":
        if b.damping_ratio == EN_DAMPING:
            damping = _en_damping(b, spans, res)
        else:
            damping = _damping_ratio(chk, b.damping_ratio)
        if flexible and b.additional_damping:
            _additional_damping(spans, res)
        n_modes, fmax = b.n_modes, b.max_frequency
        layer = kind == "continuous" and b.track is not None
        if n_modes is None and fmax is None and (kind == "matrices" or layer):
            n_modes = DEFAULT_N_MODES  # modes_file: default every mode of the file
        # simply supported and continuous decks: by default every mode up to the cut-off
        # (_flexible_bridge), n_modes and max_frequency left out of the resolved config
        res.update(damping_ratio=damping, n_modes=n_modes, max_frequency=fmax)
    if kind == "continuous":
        eps = res["elements_per_span"] = b.elements_per_span
        if b.track is not None:
            track = res["track"] = b.track.model_dump()
    tracks = torsion = None
    if flexible:
        tracks, torsion = _space_keys(chk, b, res)
    imported = None
    if kind in _IMPORTED:
        tracks = _imported_track_keys(chk, b, res)
        imported = _imported_bridge(chk, b, base_dir, res, spans, damping, n_modes, fmax,
                                    solver_cutoff, tracks)
        if imported is not _BAD:
            length = imported.bridge.length

    # output points (on a beam or rigid deck: within it, a rule of the model)
    points = _BAD
    if b.output_points is not None:
        points = b.output_points
        if _is_number(points):
            points = [points]
        if kind in _IMPORTED and length is not None:
            for i, x in enumerate(points):
                if not -1e-9 <= x <= length + 1e-9:
                    chk.error(f"bridge.output_points[{i}]", x,
                              f"a position on the bridge, 0 <= x <= {length:g} m")
                    points = _BAD
    elif spans is not None and kind not in _IMPORTED:
        edges = np.concatenate([[0.0], np.cumsum(spans)])
        points = (0.5 * (edges[:-1] + edges[1:])).tolist()
    elif imported is not None and imported is not _BAD:
        edges = np.asarray(imported.bridge.supports, float)
        points = (0.5 * (edges[:-1] + edges[1:])).tolist()
        if edges.size == 2 and spans is None:
            chk.warn(f"bridge.output_points: the supports along the track line are unknown "
                     f"(give bridge.spans); the default output point is the middle of the "
                     f"{edges[-1]:g} m line, x = {points[0]:g} m")
    if isinstance(points, list):
        res["output_points"] = points

    resolved = _drop_none(res)
    if not _ok(points):
        return _BAD
    allf = None
    space = None
    if kind in _IMPORTED:
        if imported is _BAD:
            return _BAD
        model, allf, space = imported.bridge, imported.all_frequencies, imported.space
    elif kind == "rigid":
        model = _bridge.rigid(length)
    elif track is not None:
        built = _track_bridge(chk, spans, ei, mass, n_modes, fmax, eps, damping, track)
        if built is _BAD:
            return _BAD
        model, allf = built
    else:
        built = _flexible_bridge(chk, kind, length, spans, ei, mass, n_modes, fmax, eps,
                                 solver_cutoff)
        if built is _BAD:
            return _BAD
        model, allf = built
        try:
            zeta = _bridge.per_mode(damping, model.n_modes, "damping_ratio")
        except ValueError:
            return chk.error("bridge.damping_ratio", damping, "a single ratio or at least one "
                             f"per retained mode ({model.n_modes} modes)")
        model = dataclasses.replace(model, damping=zeta)
    torsional = None
    if flexible and (tracks is not None or torsion is not None):
        space = _space_deck(chk, kind, spans, ei, mass, model, tracks, torsion, eps)
        if space is _BAD:
            return _BAD
        if torsion is not None and allf is not None:
            torsional = _torsional_spectrum(kind, spans, ei, mass, torsion, eps,
                                            allf, solver_cutoff)
        model = space.bending
    return _BridgeSpec(kind=kind, resolved=resolved, length=length, model=model,
                       all_frequencies=allf, output_points=np.asarray(points, float),
                       space=space, torsional_frequencies=torsional)


def _torsional_spectrum(kind, spans, ei, mass, torsion, eps, allf, solver_cutoff):
    """The torsional frequencies (Hz) of a beam deck with torsion up to the highest
    cut-off the deck-acceleration check may take (``solver.acceleration_cutoff``, else
    max(30 Hz, 1.5 f1, f3) of the bending spectrum, which bounds that of the bending and
    torsional modes together); None when the deck cannot be built so."""
    from vsi_numba.model import deck3d

    cap = (float(solver_cutoff) if solver_cutoff is not None
           else en1990.frequency_cutoff(np.asarray(allf, float)))
    tor = deck3d.Torsion(torsion["GJ"], torsion["polar_mass"], torsion["damping_ratio"])
    try:
        with np.errstate(all="ignore"):
            if kind == "simply_supported":  # f_j = j sqrt(GJ / I_p) / (2 L)
                gj, ip = (float(v[0]) for v in tor.per_span(1))
                f1 = np.sqrt(gj / ip) / (2.0 * float(spans[0]))
                n = min(int(np.floor(cap * (1 + 1e-9) / f1)) + 1, 2 * MAX_MODES)
                return f1 * np.arange(1, n + 1)
            deck = deck3d.continuous(spans, ei, mass, tor, None, 1, cap, 0.0, eps)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):  # SpaceModelError too
        return None
    share = np.asarray(deck.torsional_share, float)
    return np.sort(np.asarray(deck.frequencies, float)[share > 0.5])


def _space_keys(chk, b, res):
    """``bridge.tracks`` and ``bridge.torsion`` of a validated beam deck: their resolved
    values (None when not given; only given keys enter ``res``, so a file without them
    keeps its resolved configuration and hash) and the warnings about them."""
    tracks = torsion = None
    if b.tracks is not None:
        tracks = res["tracks"] = [t.model_dump(exclude_none=True) for t in b.tracks]
    if b.torsion is not None:
        t = b.torsion
        torsion = res["torsion"] = _drop_none({"damping_ratio": t.damping_ratio,
                                               "n_modes": t.n_modes, "GJ": t.GJ,
                                               "polar_mass": t.polar_mass})
    for i, tr in enumerate(tracks or []):
        y = tr["eccentricity"]
        if abs(y) > MAX_ECCENTRICITY:
            chk.warn(f"bridge.tracks[{i}].eccentricity = {y:g} m: farther than "
                     f"{MAX_ECCENTRICITY:g} m from the deck's axis (the outer tracks of a "
                     "four-track deck stand about 7 m off it); a value in mm?",
                     "plausibility", [f"bridge.tracks[{i}].eccentricity"])
    eccentric = [i for i, tr in enumerate(tracks or []) if tr["eccentricity"] != 0.0]
    if eccentric and torsion is None:
        i = eccentric[0]
        chk.warn(f"bridge.tracks[{i}].eccentricity = {tracks[i]['eccentricity']:g} m without "
                 "bridge.torsion: the deck will not twist (its modes have no torsion), a "
                 "train on an eccentric track loads the bending modes only; give "
                 "bridge.torsion = { GJ = ..., polar_mass = ... } for the torsion",
                 "input", ["bridge.tracks", "bridge.torsion"])
    if torsion is not None and not eccentric:
        chk.warn("bridge.torsion with every track on the deck's axis: no train excites "
                 "the torsional modes (give bridge.tracks = [{ eccentricity = y }, ...])",
                 "input", ["bridge.tracks", "bridge.torsion"])
    return tracks, torsion


def _space_deck(chk, kind, spans, ei, mass, planar, tracks, torsion, eps):
    """The deck in space (:class:`~vsi_numba.model.deck3d.BeamDeck3D`) of the planar
    ``planar`` (its bending modes and damping kept as they are) with ``tracks`` and
    ``torsion``, or ``_BAD``."""
    from vsi_numba.model import deck3d

    tr = deck3d.tracks_from(tracks)
    if torsion is None:
        return deck3d.BeamDeck3D(planar, deck3d._zero_table(planar.length, planar.n_modes),
                                 deck3d._zero_table(planar.length, planar.n_modes), tr,
                                 np.asarray(planar.supports, float),
                                 torsional_share=np.zeros(planar.n_modes))
    tor = deck3d.Torsion(torsion["GJ"], torsion["polar_mass"], torsion["damping_ratio"])
    n_t = torsion.get("n_modes")
    zeta = np.asarray(planar.damping, float)
    try:
        with np.errstate(all="ignore"):
            if kind == "simply_supported":
                ei1 = ei[0] if isinstance(ei, list) else ei
                m1 = mass[0] if isinstance(mass, list) else mass
                return deck3d.simply_supported(spans[0], ei1, m1, tor, tr, planar.n_modes,
                                               None, zeta, n_torsion_modes=n_t)
            return deck3d.continuous(spans, ei, mass, tor, tr, planar.n_modes, None, zeta,
                                     eps, n_torsion_modes=n_t)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return chk.error("bridge.torsion", torsion, f"a buildable deck with torsion ({exc})")


FLEXIBILITY_WARNING = 0.95  # share of the static rail flexibility kept by the modes


def _damping_ratio(chk, got):
    """``bridge.damping_ratio`` as a number or one per mode (validated: fractions of
    critical 0 <= zeta < 1, a value >= 1 refused as a percentage by the model): one >=
    :data:`MAX_DAMPING_RATIO` is legal but warned (railway decks have 0.5-4 %, EN 1991-2
    Table 6.6 [R])."""
    path = "bridge.damping_ratio"
    items = [(path, got)] if _is_number(got) else [
        (f"{path}[{i}]", z) for i, z in enumerate(got)]
    high = [(p, z) for p, z in items if z >= MAX_DAMPING_RATIO]
    if high:
        p, z = max(high, key=lambda t: t[1])
        chk.warn(f"{p} = {z:g}: {100 * z:g} % of critical damping, far above the 0.5-4 % "
                 f"of railway decks (EN 1991-2 Table 6.6 [R]); looks like a percentage? "
                 f"({z:g} % = {z / 100:g})", "plausibility", [path])
    return got


def _span_for_damping(kind, spans):
    """The span L of EN 1991-2 Table 6.6 and §6.4.6.3.1:
    :data:`vsi_numba.code_profile.DAMPING_SPAN_RULE`."""
    return damping_span(spans)


def _en_damping(b, spans, res):
    """``damping_ratio = 'EN1991-2'``: the Table 6.6 lower bound of ``deck_type`` (given:
    a rule of the model)."""
    deck = b.deck_type
    span = _span_for_damping(b.kind, spans)
    zeta = en1991.damping_lower_bound(deck, span)
    res["damping_rule"] = (f"EN 1991-2 Table 6.6, {deck.replace('_', ' ')}, L = {span:g} m: "
                           f"zeta = {100 * zeta:.4g} %")
    res["deck_type"] = deck
    return zeta


def _additional_damping(spans, res):
    """``additional_damping = true``: EN 1991-2 §6.4.6.3.1 for moving-force trains."""
    span = _span_for_damping("", spans)
    res["additional_damping"] = en1991.additional_damping(span)
    res["additional_damping_rule"] = (
        f"EN 1991-2 6.4.6.3.1, L = {span:g} m: dzeta = "
        f"{100 * res['additional_damping']:.4g} % added for moving-force trains only")


def _track_bridge(chk, spans, ei, mass, n_modes, fmax, eps, damping, track):
    """Continuous deck + track layer: modes of the assembly, along the rail; returns
    ``(model, all_frequencies)`` or ``_BAD``."""
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
    return model, rep.all_frequencies


#: Modes kept when neither n_modes nor max_frequency is given, for the decks whose
#: modes are not chosen by frequency (the FE track layer, imported matrices).
DEFAULT_N_MODES = 10


def default_max_frequency(frequencies, solver_cutoff=None) -> float:
    """The highest frequency (Hz) a simply supported or continuous deck keeps when
    neither ``bridge.n_modes`` nor ``bridge.max_frequency`` is given: the cut-off of the
    deck-acceleration check (``solver.acceleration_cutoff``, else EN 1990 A2.4.4.2.1
    max(30 Hz, 1.5 f1, f3) [R]).

    The checks need no mode above it, and the load effects need none either: they are
    computed by the mode-acceleration method (the static response to the wheel forces
    from the influence lines plus the modal correction), in which a mode far above the
    excitation adds only its quasi-static part, already exact in the static term.  A
    fixed count instead (10 modes) reached 2 kHz on a 6 m span, which no ordinary time
    step resolves: the under-resolved modes' corrections put shear and reactions of a
    25 m deck ~3 % off at dt = 1 ms.
    """
    f = np.asarray(frequencies, float)
    cut = en1990.frequency_cutoff(f) if solver_cutoff is None else float(solver_cutoff)
    return float(max(cut, f[0])) * (1 + 1e-9)


#: Shortest span (m) named as the cause when a deck gives no finite frequencies.
MIN_SPAN = 1.0


def _flexible_bridge(chk, kind, length, spans, ei, mass, n_modes, fmax, eps, solver_cutoff):
    """Build the modes now (cheap; the checks and warnings need the frequencies): the
    undamped model and the spectrum up to the cut-off, ``(model, all_frequencies)``."""
    try:
        with np.errstate(all="ignore"):
            if kind == "simply_supported":
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
            if fmax is not None and fmax < allf[0]:
                return chk.error("bridge.max_frequency", fmax,
                                 f"a frequency >= the first mode ({allf[0]:.4g} Hz), else no "
                                 "mode is retained")
            if n_modes is None and fmax is None:
                fmax = default_max_frequency(allf, solver_cutoff)
            if kind == "simply_supported":
                return _bridge.simply_supported(length, ei1, m1, n_modes, fmax, 0.0), allf
            keep = _bridge.n_modes_kept(allf, n_modes, fmax)
            return _bridge.ModalBridge(
                kind=full.kind, length=full.length, frequencies=allf[:keep].copy(),
                damping=np.zeros(keep), nodes=full.nodes,
                values=np.ascontiguousarray(full.values[:, :keep]),
                slopes=np.ascontiguousarray(full.slopes[:, :keep]), supports=full.supports,
                description=full.description, static=full.static,
            ), allf
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return chk.error("bridge.spans", spans, f"a buildable bridge ({exc})")
