"""Section forces of imported decks by the mode-acceleration method.

An FE export can carry what the assembled K and M cannot give: the section forces of
every mode and the static influence lines of the same sections.  With them an imported
deck gets the bending moment and shear force like the built-in beam decks
(:mod:`vsi_numba.model.influence`, :class:`vsi_numba.solver.pack.LoadEffectTables`):

    E(t) = sum_k P_k(t) G(x_k(t)) + sum_j E_j (q_j(t) - F_j(t) / w_j^2)

with G the static influence line of the section for a unit downward force on the
loaded track, E_j the section force of mode j (per unit modal coordinate, i.e. of the
mass-normalised shape) and F_j the total modal force of the step.  The static part is
exact for the loads of the step; the modal part corrects it for the inertia and damping
forces, and converges with the few modes a study keeps.  Without these data an imported
deck has deflections and rotations only, and the load effects say so
(:func:`vsi_numba.model.influence.check_effects`).

The data of a netCDF modes table (optional variables next to its own, see
:mod:`vsi_numba.model.imported`; read by
:func:`~vsi_numba.model.imported.read_modes_table` for the track line)::

    section_x(section)                 m      sections along the deck (x from its left end)
    section_moment(section, mode)      N m    bending moment of each mode as stored
                                              (the scale of ``shape``), sagging positive
    section_shear(section, mode)       N      shear force of each mode as stored
    load_x(load)                       m      load positions of the influence lines
    influence_moment(line, section, load)     N m/N  static moment of a unit downward
                                              force at load_x on track line ``line``
    influence_shear(line, section, load)      N/N    static shear force, the same way

The modal section forces are scaled like the shapes (divided by sqrt(modal mass)) and
given the same sign per mode (:class:`SectionForces` takes the scale and sign from the
reader).  Between ``load_x`` the influence lines are interpolated linearly (give the
kinks: supports and the sections themselves, both sides of a shear jump).  Signs as
:mod:`vsi_numba.model.influence`.  ``influence_*`` may also come without the ``line``
dimension: they then serve every line (a beam deck's bending does not depend on where
across it the load stands); with ``bridge.tracks`` the train on track ``T`` takes the
influence lines of the line ``T``.

How the kernels use them (:func:`beam_statics`): the kernels evaluate the static part
of every step in closed form for a beam on point supports (each span's statics plus
the support moments, :class:`vsi_numba.solver.pack.LoadEffectTables`).  The file's
influence lines give that beam: its supports are the file's (``support_x`` or
``bridge.spans``) and its bending stiffness per span, relative to the first span, is
fitted to the file's bending-moment influence lines (least squares; nothing to fit on
one span).  That is exact for a beam exported by another program (a continuous beam
with one EI per span); a deck whose influence lines differ from every such beam by
more than :data:`BEAM_TOLERANCE` of their peak (a grillage girder, a frame) is refused,
and its moments and shears are not computed.  The modal part is the file's: the
modal section forces, linear between the file's sections (give sections at the output
points for exact values there).  Support reactions and rotations are not given by the
file and are not computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Largest deviation (relative to the peak of each influence line) of the file's
#: influence lines from those of the beam the kernels evaluate (:func:`beam_statics`).
BEAM_TOLERANCE = 1e-2


@dataclass(frozen=True)
class SectionForces:
    """Modal section forces and static influence lines of an imported deck.

    Attributes
    ----------
    sections : ndarray, shape (n_sec,)
        Section abscissae (m).
    modal : dict
        ``"moment"`` / ``"shear"`` -> (n_sec, n_modes): per unit modal coordinate of the
        retained (mass-normalised, signed) modes.
    load_x : ndarray, shape (n_load,)
        Load positions of the influence lines (m).
    influence : dict
        (effect, line) -> (n_sec, n_load): per newton.
    """

    sections: np.ndarray
    modal: dict
    load_x: np.ndarray
    influence: dict

    @property
    def effects(self) -> tuple[str, ...]:
        return tuple(e for e in ("moment", "shear") if e in self.modal
                     and any(k[0] == e for k in self.influence))

    def static(self, effect: str, line: str, x_load) -> np.ndarray:
        """Static ``effect`` at the sections of a unit force at each ``x_load`` on track
        line ``line`` (zero off the tabulated range): (n_sec, len(x_load))."""
        g = self.influence[(effect, line)]
        x = np.atleast_1d(np.asarray(x_load, float))
        on = (x >= self.load_x[0]) & (x <= self.load_x[-1])
        e = np.clip(np.searchsorted(self.load_x, x, side="right") - 1, 0,
                    self.load_x.size - 2)
        t = np.clip((x - self.load_x[e]) / (self.load_x[e + 1] - self.load_x[e]), 0, 1)
        return ((1 - t) * g[:, e] + t * g[:, e + 1]) * on


def from_arrays(sections, modal, load_x, influence, scale, sign) -> SectionForces:
    """:class:`SectionForces` from the file's arrays: ``modal[effect]`` (n_sec, n_file
    modes) already restricted to the retained modes in their order, multiplied by
    ``scale * sign`` per mode (the shapes' normalisation and sign)."""
    f = np.asarray(scale, float) * np.asarray(sign, float)
    return SectionForces(np.asarray(sections, float),
                         {k: np.asarray(v, float) * f for k, v in modal.items()},
                         np.asarray(load_x, float),
                         {k: np.asarray(v, float) for k, v in influence.items()})


def mode_acceleration(sf: SectionForces, effect: str, line: str, omega, q, F, x_load,
                      P) -> np.ndarray:
    """Histories of ``effect`` at the sections, mode-acceleration method.

    Parameters
    ----------
    sf : SectionForces
    effect : {"moment", "shear"}
    line : str
        The loaded track's line (the influence lines of its loads).
    omega : ndarray, shape (n_m,)
        Circular frequencies (rad/s).
    q, F : ndarray, shape (n_t, n_m)
        Modal coordinates and total modal forces of every step.
    x_load, P : ndarray, shape (n_t, n_load)
        Position (m) and downward force (N) of every load (wheel contact forces or
        moving forces) at every step.

    Returns
    -------
    ndarray, shape (n_t, n_sec)
    """
    x = np.asarray(x_load, float)
    p = np.asarray(P, float)
    g = sf.static(effect, line, x.ravel()).reshape(sf.sections.size, *x.shape)
    static = np.einsum("stl,tl->ts", g, p)
    return static + (np.asarray(q) - np.asarray(F) / np.asarray(omega) ** 2) @ \
        sf.modal[effect].T


def beam_statics(sf: SectionForces, line: str, supports):
    """The beam on the ``supports`` (m) whose static bending moment and shear force are
    the influence lines of ``sf`` on ``line`` (module notes), as a
    :class:`~vsi_numba.model.influence.StaticDeck` carrying ``sf``, or the reason (str)
    why there is none.

    Parameters
    ----------
    sf : SectionForces
    line : str
        The track line whose influence lines the train loads.
    supports : array_like
        Support abscissae (m), from 0.

    Returns
    -------
    StaticDeck or str
    """
    import scipy.optimize

    from vsi_numba.model.influence import StaticDeck, influence

    sup = np.asarray(supports, float)
    spans = np.diff(sup)
    if ("moment", line) not in sf.influence:
        return f"the file has no influence_moment for the track line {line!r}"

    def deck(log_ratio):
        ei = np.exp(np.concatenate([[0.0], log_ratio]))
        return StaticDeck(kind="beam", supports=sup, spans=spans, EI=ei, section_forces=sf)

    x = sf.load_x
    g = sf.influence[("moment", line)]
    scale = np.maximum(np.max(np.abs(g), axis=1, keepdims=True), 1e-300)

    def misfit(log_ratio):
        return ((influence(deck(log_ratio), "moment", sf.sections, x) - g) / scale).ravel()

    p0 = np.zeros(spans.size - 1)
    p = (scipy.optimize.least_squares(misfit, p0, x_scale=1.0).x if p0.size else p0)
    worst = {"moment": float(np.max(np.abs(misfit(p)), initial=0.0))}
    if ("shear", line) in sf.influence:
        gs = sf.influence[("shear", line)]
        vs = influence(deck(p), "shear", sf.sections, x)
        # a load at the section itself: the shear jumps there (the file gives one side)
        away = np.abs(x[None, :] - sf.sections[:, None]) > 1e-9 * max(sup[-1], 1.0)
        ss = np.maximum(np.max(np.abs(gs), axis=1, keepdims=True), 1e-300)
        worst["shear"] = float(np.max(np.abs(vs - gs) / ss * away, initial=0.0))
    effect = max(worst, key=worst.get)
    if worst[effect] > BEAM_TOLERANCE:
        return (f"the file's influence lines ({effect}) differ by {100 * worst[effect]:.3g} % "
                "of their peak from those of every beam on the supports at "
                f"{', '.join(f'{s:g}' for s in sup)} m (at most "
                f"{100 * BEAM_TOLERANCE:g} %): the static part of the load effects is "
                "evaluated as such a beam")
    return deck(p)
