"""Longitudinal distribution of the moving forces by the track (``[track]
load_distribution``).

A moving force (HSLM, an axle list, a moving-force preset) is by default a point force on
the deck line: the track model of ``[track]`` (the rail on its foundation, or the rigid
idealisation) is a model of the wheel-rail contact of the interaction trains and does
not touch the moving forces.  EN 1991-2 allows the distribution of the axle loads by the
rails, sleepers and ballast in the dynamic analysis [R: 6.4.6.4, recalled, not re-read];
on short spans it lowers the peak bending moments noticeably.  A distribution replaces
each axle force P by forces w_i P at fixed offsets d_i from the axle (sum w_i = 1) that
travel with it; the moving-force kernel takes them as any other forces, so the deck's
modal load, the load effects (influence lines of each force) and the static reference of
phi'_dyn all see the same distributed load.  The outputs stay per axle (the
``contact_force`` of a moving force is its axle load).

Kinds
-----
``none``
    The point force on the deck line (the default: results bit for bit those without the
    key).
``rail``
    EN 1991-2 6.3.6.1, Figure 6.4 [R]: the rail shares the force among the sleeper under
    it and its two neighbours, P/4, P/2, P/4 at spacing a (``sleeper_spacing``).
``rail_ballast``
    ``rail``, and each sleeper load spread through the ballast at 4:1 (one horizontal to
    four vertical) down to the top of the deck, EN 1991-2 6.3.6.2, Figure 6.5 [R]: a
    uniform patch of length b + h/2 under each sleeper (b the sleeper's bottom width
    ``sleeper_width``, h the ballast depth under it ``ballast_depth``), taken as equal
    forces at the midpoints of at most :data:`PATCH_STEP`-long pieces (the midpoint rule
    on each patch: the modal force of mode wavenumber k is within (k h_p)^2 / 24 of the
    patch's, 2e-4 for a 6 m span's third mode).
``elastic_track``
    The rail on the Winkler foundation of ``[track]`` (``model = "elastic"``,
    :mod:`vsi_numba.model.track`): the foundation's reaction k G(x) P sampled at the
    sleepers, w_i = a k G(i a), normalised to sum 1 (the sampling changes the sum by
    less than 1e-3 at a = 0.6 m with the default track), for |i a| beta <= :data:`REACH`.
    It is the discrete form of the spreading the interaction trains see through the
    track-filtered mode shapes (phit = k G * phi), so moving forces and interaction
    trains then load the deck through the same track.  With the default track it spreads
    an axle over about +-6 m, but its effect on the deck's low modes is small: its
    wavenumber filter is 1 / (1 + (s / beta)^4 / 4), against (1 + cos s a) / 2 for
    ``rail`` (first mode of a 6 m span: 1.1 % against 2.5 %).

Why the elastic track does not spread moving forces by default: EN 1991-2 defines HSLM
and the real trains as point forces with the rail-sleeper-ballast distribution of 6.3.6
as the permitted refinement [R]; a default that changed every moving-force result of the
existing studies (and made them depend on the track's foundation values) is a design
decision for the user, so the default stays ``none`` and the input echo of the report
and of ``vsi check`` says what the moving forces act on.

Offsets are positive ahead of the axle (in the direction of travel); every kind here is
symmetric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vsi_numba.model.track import ElasticTrack

#: The values of ``track.load_distribution``.
LOAD_DISTRIBUTIONS = ("none", "rail", "rail_ballast", "elastic_track")
#: Sleeper spacing a (m): 0.6 m, the usual spacing of concrete sleepers [R].
SLEEPER_SPACING_DEFAULT = 0.6
#: Bottom width b of a sleeper (m): 0.30 m, about that of a B70 concrete sleeper [R].
SLEEPER_WIDTH_DEFAULT = 0.3
#: Ballast depth h under the sleeper down to the deck (m): 0.35 m [R] (ballasted bridge
#: decks commonly have 0.30-0.50 m under the sleeper).
BALLAST_DEPTH_DEFAULT = 0.35
#: Longest piece (m) of a ballast patch represented by one force.
PATCH_STEP = 0.1
#: elastic_track: sleepers within beta |x| <= REACH of the axle (|k G| there is below
#: 1e-3 of its peak).
REACH = 7.0


@dataclass(frozen=True)
class LoadDistribution:
    """How the track distributes a moving force onto the deck (see the module notes).

    Parameters
    ----------
    kind : str
        One of :data:`LOAD_DISTRIBUTIONS`.
    sleeper_spacing : float
        a, m (> 0).
    sleeper_width : float
        b, m (>= 0; ``rail_ballast`` only).
    ballast_depth : float
        h, m (>= 0; ``rail_ballast`` only).
    track : ElasticTrack or None
        The rail on its foundation (``elastic_track`` only, required there).
    """

    kind: str = "none"
    sleeper_spacing: float = SLEEPER_SPACING_DEFAULT
    sleeper_width: float = SLEEPER_WIDTH_DEFAULT
    ballast_depth: float = BALLAST_DEPTH_DEFAULT
    track: ElasticTrack | None = None

    def __post_init__(self):
        if self.kind not in LOAD_DISTRIBUTIONS:
            raise ValueError(f"track.load_distribution = {self.kind!r}: expected one of "
                             f"{', '.join(LOAD_DISTRIBUTIONS)}")
        for name, positive in (("sleeper_spacing", True), ("sleeper_width", False),
                               ("ballast_depth", False)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)
                    and (v > 0 if positive else v >= 0)):
                raise ValueError(f"track.{name} = {v!r}: expected a finite length "
                                 f"{'> 0' if positive else '>= 0'} m")
        if self.kind == "elastic_track" and self.track is None:
            raise ValueError("track.load_distribution = 'elastic_track' needs the elastic "
                             "track (track.model = 'elastic')")

    @property
    def patch_length(self) -> float:
        """Length (m) of the ballast patch under one sleeper, b + h/2 (4:1 on both sides)."""
        return self.sleeper_width + 0.5 * self.ballast_depth

    def forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The forces that replace a unit axle force.

        Returns
        -------
        offsets : ndarray, shape (n,)
            m ahead of the axle, ascending.
        weights : ndarray, shape (n,)
            Fractions of the axle force, summing to 1.
        """
        a = float(self.sleeper_spacing)
        if self.kind == "none":
            return np.zeros(1), np.ones(1)
        if self.kind == "elastic_track":
            tr = self.track
            n = int(math.floor(REACH / (tr.beta * a)))
            d = a * np.arange(-n, n + 1, dtype=float)
            w = a * tr.foundation_stiffness * tr.green(d)
            return d, w / w.sum()
        sleepers = np.array([-a, 0.0, a])
        shares = np.array([0.25, 0.5, 0.25])
        if self.kind == "rail":
            return sleepers, shares
        length = self.patch_length
        n = max(1, int(math.ceil(length / PATCH_STEP - 1e-9)))
        sub = length * ((np.arange(n) + 0.5) / n - 0.5)
        d = (sleepers[:, None] + sub[None, :]).ravel()
        w = np.repeat(shares / n, n)
        order = np.argsort(d, kind="stable")
        return d[order], w[order]

    @property
    def extent(self) -> float:
        """Largest distance (m) of a distributed force from its axle."""
        d, _ = self.forces()
        return float(np.max(np.abs(d)))

    def describe(self) -> str:
        """One line for the input echo: what the moving forces act on."""
        return describe(self.kind, self.sleeper_spacing, self.sleeper_width,
                        self.ballast_depth)


def _m(x: float) -> str:
    return f"{float(x):.4g} m"


def describe(kind: str, sleeper_spacing=SLEEPER_SPACING_DEFAULT,
             sleeper_width=SLEEPER_WIDTH_DEFAULT, ballast_depth=BALLAST_DEPTH_DEFAULT,
             track_model: str = "elastic") -> str:
    """What the moving forces act on, in words (the input echo of ``vsi report`` and
    ``vsi check``), from the values of ``[track]``."""
    if track_model == "bridge_layer":
        return ("moving forces act on the rail of the FE track layer of [bridge.track] "
                "(its pads, sleepers and ballast spread them)")
    if kind in (None, "none"):
        return ("moving forces act on the deck directly (the track model applies to "
                "interaction trains only)")
    if kind == "rail":
        return (f"moving forces distributed by the rail: P/4, P/2, P/4 on three sleepers "
                f"at a = {_m(sleeper_spacing)} (EN 1991-2 6.3.6.1 [R]); not by the track "
                "model, which applies to interaction trains only")
    if kind == "rail_ballast":
        patch = float(sleeper_width) + 0.5 * float(ballast_depth)
        return (f"moving forces distributed by the rail (P/4, P/2, P/4 on three sleepers at "
                f"a = {_m(sleeper_spacing)}) and the ballast (4:1 from sleepers "
                f"{_m(sleeper_width)} wide through {_m(ballast_depth)}: a uniform "
                f"{_m(patch)} patch per sleeper) (EN 1991-2 6.3.6.1-2 [R])")
    if kind == "elastic_track":
        return (f"moving forces distributed by the elastic track: the rail on its Winkler "
                f"foundation of [track], the foundation's reaction at sleepers "
                f"a = {_m(sleeper_spacing)} apart (the spreading interaction trains see)")
    return f"moving forces: load_distribution = {kind!r}"


def describe_config(cfg: dict) -> str:
    """:func:`describe` from a resolved configuration (``config_json`` of a results
    file): a file without the key had no distribution."""
    bridge = cfg.get("bridge") if isinstance(cfg.get("bridge"), dict) else {}
    if "track" in bridge:
        return describe("none", track_model="bridge_layer")
    track = cfg.get("track") if isinstance(cfg.get("track"), dict) else {}
    return describe(str(track.get("load_distribution", "none")),
                    track.get("sleeper_spacing", SLEEPER_SPACING_DEFAULT),
                    track.get("sleeper_width", SLEEPER_WIDTH_DEFAULT),
                    track.get("ballast_depth", BALLAST_DEPTH_DEFAULT),
                    str(track.get("model", "elastic")))


def from_track_config(track) -> LoadDistribution | None:
    """The distribution of a resolved ``[track]`` table (a results file's stored
    configuration), or None (no distribution, no table, the FE track layer)."""
    if not isinstance(track, dict):
        return None
    kind = track.get("load_distribution", "none")
    if kind == "none":
        return None
    rail = (ElasticTrack(float(track["foundation_stiffness"]), float(track["rail_EI"]))
            if kind == "elastic_track" else None)
    keys = ("sleeper_spacing", "sleeper_width", "ballast_depth")
    return LoadDistribution(kind, **{k: float(track[k]) for k in keys if k in track},
                            track=rail)


def expand(positions, loads, distribution: LoadDistribution | None):
    """The forces of axles at ``positions`` (m behind the train's first axle) with
    ``loads`` (N) under ``distribution``: ``(positions, loads)`` of every distributed
    force, axle by axle (None or ``none``: the inputs unchanged)."""
    positions = np.asarray(positions, float)
    loads = np.asarray(loads, float)
    if distribution is None or distribution.kind == "none" or positions.size == 0:
        return positions, loads
    d, w = distribution.forces()
    return ((positions[:, None] - d[None, :]).ravel(),
            (loads[:, None] * w[None, :]).ravel())
