"""Static load effects of the deck line: influence lines of deflection, bending moment,
shear force, support reactions and support rotations.

A :class:`StaticDeck` holds what the static response of the deck needs: the support
abscissae and, for beam decks (simply supported, continuous, the deck of
``continuous_with_track``), the bending stiffness of every span; for decks imported as FE
matrices, the stiffness matrix and the station DOFs.  :func:`influence` gives the static
effect of a unit downward force (1 N) at each load position.

Sign conventions (the results files repeat them in each variable's attrs)
-------------------------------------------------------------------------
- deflection ``w``: positive down (m/N);
- bending moment ``M``: positive sagging, tension in the bottom fibre (N m/N);
  ``EI w'' = -M``;
- shear force ``V = dM/dx`` (N/N): positive just right of the left support of a span
  under a downward load.  At a section abscissa that holds a point load or a support,
  ``V`` is the value just to the RIGHT of it, except at the right end of the deck where
  it is the value just to the left (the only one on the deck);
- support reaction ``R``: positive upward (the support pushes the deck up) (N/N);
- rotation ``theta = dw/dx`` with ``w`` positive down (rad/N): positive at the left end
  of a sagging span, negative at its right end.

Method (beam decks): the exact Euler-Bernoulli solution for point loads.  The support
moments come from the three-moment (Clapeyron) equation, one tridiagonal solve for all
loads at once; each span is then a simply supported span under its own loads plus its
two end moments (closed forms below), vectorised over sections and loads.  Nothing is
discretised: the effects are exact for any load position and any section.

Decks from FE matrices (``bridge.kind = "matrices"``): the static solution
``K_ff u = f`` with a unit load at the stations (a load between two stations is shared
between them linearly), reactions from the fixed DOFs' rows of ``K``, rotations from the
rotation DOFs when the stations have them.  Bending moment and shear force need the
section forces of the elements, which K alone does not give: refused.

Decks from a modes table (``bridge.kind = "modes_file"``) and rigid track: no static
deck (no EI, no K); deflections and rotations are available from the mode shapes only
(:meth:`~vsi_numba.model.bridge.ModalBridge.output_shapes`), the other effects are
refused with :class:`LoadEffectError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Every load effect :func:`influence` knows.
EFFECTS = ("deflection", "moment", "shear", "reaction", "rotation")
#: Effects given per static-deck kind ("beam": EI per span; "matrices": K).
SUPPORTED = {
    "beam": EFFECTS,
    "matrices": ("deflection", "reaction", "rotation"),
}
#: Effects at deck abscissae (``at`` in m); the others are at supports (``at`` indices).
AT_SECTIONS = ("deflection", "moment", "shear")


class LoadEffectError(ValueError):
    """A load effect that the bridge model cannot give (or a bad request)."""


@dataclass(frozen=True)
class StaticDeck:
    """What the static load effects of the deck line need.

    Parameters
    ----------
    kind : {"beam", "matrices"}
        "beam": Euler-Bernoulli spans on point supports (``spans``, ``EI``);
        "matrices": an FE stiffness matrix (``K`` and the station DOFs).
    supports : ndarray, shape (n_supports,)
        Support abscissae along the deck (m), ascending, ``supports[0] = 0``.
    spans : ndarray, shape (n_supports - 1,)
        Span lengths (m).
    EI : ndarray, shape (n_spans,) or None
        Bending stiffness of each span (N m^2); None for "matrices".
    K : scipy.sparse matrix, shape (n_dof, n_dof), or None
        "matrices": the stiffness before the supports are applied (SI).
    fixed : ndarray of int, shape (n_fixed,)
        "matrices": the DOFs held at zero.
    stations : ndarray, shape (n_station,)
        "matrices": station abscissae along the track line (m).
    dofs : ndarray of int, shape (n_station,)
        "matrices": vertical DOF of each station.
    rotation_dofs : ndarray of int, shape (n_station,), or None
        "matrices": rotation DOF of each station (``rotation_sign * dw/dx``), or None.
    rotation_sign : float
        "matrices": +1 or -1 (see :func:`~vsi_numba.model.imported.modes_from_matrices`).
    mass_per_length : ndarray, shape (n_spans,), or None
        "beam": mass per length of each span (kg/m) when the deck's modes are those of
        this beam alone (the effect of a mode is then the static effect of its inertia
        load, see :func:`modal_effects`); None when other parts load the deck in its
        modes (a track layer), or for "matrices".
    section_forces : SectionForces or None
        "beam" of an imported deck (:func:`vsi_numba.model.imported.effects.beam_statics`):
        the modal section forces of the file; the beam (``EI`` relative per span,
        matched to the file's influence lines) gives the static bending moment and shear
        force only.
    """

    kind: str
    supports: np.ndarray
    spans: np.ndarray
    EI: np.ndarray | None = None
    K: object | None = None
    fixed: np.ndarray | None = None
    stations: np.ndarray | None = None
    dofs: np.ndarray | None = None
    rotation_dofs: np.ndarray | None = None
    rotation_sign: float = 1.0
    mass_per_length: np.ndarray | None = None
    section_forces: object | None = None

    @property
    def n_supports(self) -> int:
        return int(self.supports.size)

    @property
    def length(self) -> float:
        return float(self.supports[-1])

    @property
    def effects(self) -> tuple[str, ...]:
        """The load effects this deck gives."""
        if self.kind == "matrices" and self.rotation_dofs is None:
            return ("deflection", "reaction")
        if self.section_forces is not None:  # the file's: moments, and shears if given
            return self.section_forces.effects
        return SUPPORTED[self.kind]


def beam_deck(spans, EI, mass_per_length=None) -> StaticDeck:
    """:class:`StaticDeck` of Euler-Bernoulli spans on point supports.

    Parameters
    ----------
    spans : float or sequence of float
        Span lengths (m), > 0.
    EI : float or sequence of float
        Bending stiffness (N m^2), one value or one per span, > 0.
    mass_per_length : float or sequence of float, optional
        Mass per length (kg/m), one value or one per span (see :class:`StaticDeck`).
    """
    spans = np.atleast_1d(np.asarray(spans, float)).copy()
    ei = np.broadcast_to(np.asarray(EI, float), spans.shape).copy()
    if np.any(~(spans > 0)) or np.any(~(ei > 0)):
        raise LoadEffectError(f"spans {spans.tolist()} m and EI {ei.tolist()} N m^2: "
                              "expected positive values")
    m = (None if mass_per_length is None else
         np.broadcast_to(np.asarray(mass_per_length, float), spans.shape).copy())
    return StaticDeck(kind="beam", supports=np.concatenate([[0.0], np.cumsum(spans)]),
                      spans=spans, EI=ei, mass_per_length=m)


def _why_not(static: StaticDeck | None, effect: str) -> str:
    if static is None:
        return (f"load effect {effect!r} is not available for this bridge: its modes come "
                "from a modes table (bridge.kind = \"modes_file\") or it is rigid track, "
                "with no bending stiffness (EI) and no stiffness matrix, so its static "
                "response is unknown. Available from the modes: deck deflection and "
                "rotation (dw/dx). Not available: bending moment, shear force, support "
                "reactions (give the deck as a beam, bridge.kind = \"continuous\", or as "
                "FE matrices, bridge.kind = \"matrices\", for those)")
    if static.kind == "matrices":
        rot = ("rotation (the stations have rotation DOFs)" if static.rotation_dofs
               is not None else "no rotation (the stations have no rotation DOFs: "
               "bridge.station_map has no rotation_dof column)")
        why = ("the stations have no rotation DOFs" if effect == "rotation" else
               "the bending moment and shear force are section forces of the elements, "
               "which the assembled K and M do not carry")
        return (f"load effect {effect!r} is not available for a deck given as FE matrices "
                f"(bridge.kind = \"matrices\"): {why}. Available: deflection, support "
                f"reactions (from the fixed DOFs' rows of K), {rot}")
    if static.section_forces is not None:
        return (f"load effect {effect!r} is not available for this imported deck: its "
                "modes table gives the section forces (bending moment and shear force) of "
                "the modes and their influence lines, not the support reactions, rotations "
                "or deflections")
    return f"load effect {effect!r} is not available for this deck"


def check_effects(static: StaticDeck | None, effects) -> None:
    """Raise :class:`LoadEffectError` (saying what is available and why) unless
    ``static`` gives every one of ``effects``."""
    for e in effects:
        if e not in EFFECTS:
            raise LoadEffectError(f"load effect {e!r}: expected one of {', '.join(EFFECTS)}")
        if static is None or e not in static.effects:
            raise LoadEffectError(_why_not(static, e))


def influence(static: StaticDeck | None, effect: str, at, x_load) -> np.ndarray:
    """Static effect of a unit downward force (1 N) at each ``x_load``.

    Parameters
    ----------
    static : StaticDeck or None
        ``bridge.static`` (None: refused, see the module notes).
    effect : {"deflection", "moment", "shear", "reaction", "rotation"}
        Signs in the module docstring.
    at : array_like
        "deflection", "moment", "shear": deck abscissae of the sections (m);
        "reaction", "rotation": support indices, 0 .. n_supports - 1.
    x_load : array_like, shape (n_load,)
        Abscissae of the unit force along the deck (m); a force off the deck
        (x < 0 or x > length) has no effect.

    Returns
    -------
    ndarray, shape (len(at), len(x_load))
        m/N (deflection), N m/N (moment), N/N (shear, reaction), rad/N (rotation).

    Raises
    ------
    LoadEffectError
        The effect is unknown, the bridge cannot give it (the message says what is
        available and why), or a support index is out of range.
    """
    return influences(static, ((effect, at),), x_load)[0]


def influences(static: StaticDeck | None, requests, x_load, loads=None) -> list[np.ndarray]:
    """:func:`influence` of each ``(effect, at)`` of ``requests`` for the same unit
    forces at ``x_load``: the same values, the loads' spans and the support moments
    found once for all of them (``loads``: those of :func:`beam_loads` at ``x_load``,
    already found)."""
    x = np.atleast_1d(np.asarray(x_load, float))
    checked = []
    for effect, at in requests:
        check_effects(static, (effect,))
        at = np.atleast_1d(np.asarray(at, float))
        if effect not in AT_SECTIONS:
            k = at.astype(np.int64)
            if np.any(k != at) or np.any((k < 0) | (k >= static.n_supports)):
                raise LoadEffectError(f"{effect}: support indices 0 .. "
                                      f"{static.n_supports - 1} expected, got {at.tolist()}")
            at = k
        checked.append((effect, at))
    if static.kind == "matrices":
        return [_matrices(static, effect, at, x) for effect, at in checked]
    if loads is None:
        loads = _beam_loads(static, x) if checked else None
    return [_beam(static, effect, at, x, loads) for effect, at in checked]


# ------------------------------------------------------------------------------- beams


def _span_of(sup, x):
    return np.clip(np.searchsorted(sup, x, side="right") - 1, 0, sup.size - 2)


def support_moments(static: StaticDeck, x) -> np.ndarray:
    """Support moments (sagging positive, N m/N) of a unit downward force at each ``x``:
    shape (n_supports, len(x)), zero at the deck ends.

    Three-moment equation at internal support i (f = L / EI; a, b the load's distances
    from the ends of its span):
    ``M_{i-1} f_l + 2 M_i (f_l + f_r) + M_{i+1} f_r = -a b (L+a)/(EI L) [load left]
    - a b (L+b)/(EI L) [load right]``.
    """
    sup, L, ei = static.supports, static.spans, static.EI
    x = np.asarray(x, float)
    on = (x >= sup[0]) & (x <= sup[-1])
    s = _span_of(sup, x)
    a = x - sup[s]
    b = L[s] - a
    ms = np.zeros((sup.size, x.size))
    n = L.size
    if n == 1:
        return ms
    f = L / ei
    A = np.zeros((3, n - 1))  # banded: upper, diagonal, lower
    A[0, 1:] = f[1:-1]
    A[1] = 2.0 * (f[:-1] + f[1:])
    A[2, :-1] = f[1:-1]
    k = np.arange(1, n)[:, None]  # internal supports
    ab = (a * b / (ei[s] * L[s]))[None, :]
    rhs = (-ab * (L[s] + a)[None, :] * (s[None, :] == k - 1)
           - ab * (L[s] + b)[None, :] * (s[None, :] == k)) * on[None, :]
    import scipy.linalg

    ms[1:-1] = scipy.linalg.solve_banded((1, 1), A, rhs)
    return ms


def beam_sections(static: StaticDeck, at):
    """What :func:`_beam` needs of the sections ``at`` (m) for the moment and shear:
    their span, abscissa ``X`` in it, ``X / L`` and whether they are on the deck."""
    sup, L = static.supports, static.spans
    at = np.atleast_1d(np.asarray(at, float))
    inside = (at >= sup[0]) & (at <= sup[-1])
    sa = _span_of(sup, at)
    X = at - sup[sa]
    return sa, X, X / L[sa], inside


def beam_loads(static: StaticDeck, x):
    """:func:`_beam_loads` of the unit forces at ``x`` (m): on the deck, span, a, b,
    support moments (n_supports, len(x)), each C-contiguous."""
    return tuple(np.ascontiguousarray(v) for v in _beam_loads(static, np.asarray(x, float)))


def _beam_loads(static: StaticDeck, x):
    """What :func:`_beam` needs of the unit forces at ``x`` whatever the effect: on the
    deck, their span, a and b in it, the support moments."""
    sup, L = static.supports, static.spans
    on = (x >= sup[0]) & (x <= sup[-1])
    sl = _span_of(sup, x)
    a = np.where(on, x - sup[sl], 0.0)
    b = L[sl] - a
    return on, sl, a, b, support_moments(static, x)


def _beam(static: StaticDeck, effect, at, x, loads=None):
    sup, L, ei = static.supports, static.spans, static.EI
    on, sl, a, b, ms = _beam_loads(static, x) if loads is None else loads
    if effect in AT_SECTIONS:
        inside = (at >= sup[0]) & (at <= sup[-1])
        sa = _span_of(sup, at)
        La, Ea = L[sa][:, None], ei[sa][:, None]
        X = (at - sup[sa])[:, None]
        xi = X / La
        same = (sa[:, None] == sl[None, :]) & on[None, :]
        A, B = a[None, :], b[None, :]
        MA, MB = ms[sa], ms[sa + 1]
        if effect == "moment":
            own = np.where(X <= A, B * X, A * (La - X)) / La
            out = same * own + MA * (1.0 - xi) + MB * xi
        elif effect == "shear":
            own = np.where(X < A, B, -A) / La
            out = same * own + (MB - MA) / La
        else:
            R = La - X
            own = np.where(X <= A, B * X * (La**2 - B**2 - X**2),
                           A * R * (La**2 - A**2 - R**2)) / (6.0 * Ea * La)
            out = (same * own + MA * La**2 / (6.0 * Ea) * xi * (1 - xi) * (2 - xi)
                   + MB * La**2 / (6.0 * Ea) * xi * (1 - xi) * (1 + xi))
        return out * inside[:, None]
    n = L.size
    out = np.zeros((at.size, x.size))
    for r, k in enumerate(at):
        if effect == "reaction":
            if k < n:  # left end of span k
                out[r] += ((sl == k) & on) * b / L[k] + (ms[k + 1] - ms[k]) / L[k]
            if k > 0:  # right end of span k - 1
                s = k - 1
                out[r] += ((sl == s) & on) * a / L[s] - (ms[k] - ms[s]) / L[s]
        elif k < n:  # rotation, left end of span k
            c = L[k] / (6.0 * ei[k])
            out[r] = (((sl == k) & on) * a * b * (L[k] + b) / (6.0 * ei[k] * L[k])
                      + 2.0 * c * ms[k] + c * ms[k + 1])
        else:  # rotation, right end of the last span
            s = k - 1
            c = L[s] / (6.0 * ei[s])
            out[r] = (-1.0 * ((sl == s) & on) * a * b * (L[s] + a) / (6.0 * ei[s] * L[s])
                      - c * ms[s] - 2.0 * c * ms[k])
    return out


# ---------------------------------------------------------------------------- matrices


def _matrices(static: StaticDeck, effect, at, x):
    import scipy.sparse
    import scipy.sparse.linalg

    K = scipy.sparse.csr_matrix(static.K)
    n = K.shape[0]
    st = np.asarray(static.stations, float)
    on = (x >= st[0]) & (x <= st[-1])
    # a load between two stations is shared between them linearly
    e = np.clip(np.searchsorted(st, x, side="right") - 1, 0, st.size - 2)
    t = np.clip((x - st[e]) / (st[e + 1] - st[e]), 0.0, 1.0)
    F = np.zeros((n, x.size))
    cols = np.arange(x.size)
    np.add.at(F, (static.dofs[e], cols), (1.0 - t) * on)
    np.add.at(F, (static.dofs[e + 1], cols), t * on)
    fixed = np.unique(np.asarray(static.fixed, np.int64))
    free = np.setdiff1d(np.arange(n), fixed)
    u = np.zeros((n, x.size))
    lu = scipy.sparse.linalg.splu(K[free][:, free].tocsc())
    u[free] = lu.solve(np.ascontiguousarray(F[free]))
    # the vertical DOFs' direction (up or down) cancels: u is in the DOF sense of the
    # load, read back in the same sense
    if effect == "deflection":
        w = u[static.dofs]
        out = np.empty((at.size, x.size))
        for j in range(x.size):
            out[:, j] = np.interp(at, st, w[:, j], left=0.0, right=0.0)
        return out
    k_station = _support_stations(static)
    if effect == "reaction":
        r = K[static.dofs[k_station]] @ u - F[static.dofs[k_station]]
        return -r[at]  # the support pushes against the load: upward positive
    rot = static.rotation_sign * u[static.rotation_dofs[k_station]]
    return rot[at]


def _support_stations(static: StaticDeck) -> np.ndarray:
    st = np.asarray(static.stations, float)
    k = np.array([int(np.argmin(np.abs(st - s))) for s in static.supports])
    if not np.all(np.isin(static.dofs[k], static.fixed)):
        bad = static.supports[~np.isin(static.dofs[k], static.fixed)]
        raise LoadEffectError(
            f"support reactions and rotations of FE matrices need a fixed vertical station "
            f"DOF at every support (bridge.fixed_dofs); none at x = {bad.tolist()} m")
    return k


# ------------------------------------------------------------------------ modal effects


def modal_effects(bridge, effect: str, at) -> np.ndarray:
    """Load effect of each mode shape of the deck: the effect per unit modal coordinate.

    Parameters
    ----------
    bridge : ModalBridge
        With ``bridge.static`` giving ``effect``.
    effect, at
        As in :func:`influence`.

    Returns
    -------
    ndarray, shape (len(at), n_modes)
        Units of the effect per unit modal coordinate (e.g. N m per sqrt(kg) m).

    Notes
    -----
    Simply supported span (sine modes, ``phi_j = a sin(k x)``): ``M_j = EI a k^2 sin(k x)``,
    ``V_j = EI a k^3 cos(k x)``, ``R_j`` from V at the ends, ``theta_j = a k cos(k x)``.

    Beam modes (``static.mass_per_length`` known): mode j is the static response of the
    beam to its own inertia load ``w_j^2 m phi_j``, so its effects are the influence
    lines integrated against that load, with 4-point Gauss-Legendre on every interval
    between the FE nodes, the supports and the sections (exact for the cubic mode shapes
    times the piecewise-cubic influence lines: no differentiation of the cubics, and the
    shear is as accurate as the moment).

    Decks loaded by other parts in their modes (a track layer: the ballast springs): the
    derivatives of the deck's Hermite cubics, ``M = -EI phi''``, ``V = -EI phi'''``
    (piecewise constant per element: accurate to O(h) only), reactions from the jumps of
    V at the supports.
    """
    static = bridge.static
    check_effects(static, (effect,))
    at = np.atleast_1d(np.asarray(at, float))
    deck = bridge.deck if getattr(bridge, "deck", None) is not None else bridge
    sup = static.supports
    n_m = bridge.n_modes
    if n_m == 0:
        return np.zeros((at.size, 0))
    if static.section_forces is not None:  # the file's, linear between its sections
        sf = static.section_forces
        e = sf.modal[effect]
        return np.stack([np.interp(at, sf.sections, e[:, j]) for j in range(n_m)], axis=1)
    if bridge.kind == 1:  # SINE
        k = np.pi * np.arange(1, n_m + 1) / bridge.length
        a = bridge.values[0]
        ei = float(static.EI[0])
        if effect in AT_SECTIONS:
            arg = np.outer(at, k)
            inside = ((at >= 0) & (at <= bridge.length))[:, None]
            out = {"deflection": a * np.sin(arg), "moment": ei * a * k**2 * np.sin(arg),
                   "shear": ei * a * k**3 * np.cos(arg)}[effect]
            return out * inside
        cos_end = np.cos(np.outer(sup[at.astype(int)], k))
        sign = np.where(at.astype(int) == 0, 1.0, -1.0)[:, None]
        if effect == "reaction":
            return sign * ei * a * k**3 * cos_end
        return a * k * cos_end
    if static.kind == "beam" and static.mass_per_length is not None:
        brk = np.unique(np.concatenate([deck.nodes, sup, at if effect in AT_SECTIONS
                                        else np.zeros(0)]))
        brk = brk[(brk >= sup[0]) & (brk <= sup[-1])]
        g, w = np.polynomial.legendre.leggauss(4)
        h = np.diff(brk)
        xq = (0.5 * (brk[:-1] + brk[1:])[:, None] + 0.5 * h[:, None] * g[None, :]).ravel()
        wq = (0.5 * h[:, None] * w[None, :]).ravel()
        s = np.clip(np.searchsorted(sup, xq, side="right") - 1, 0, sup.size - 2)
        load = (wq * static.mass_per_length[s])[:, None] * deck.shapes(xq) * bridge.omega**2
        return influence(static, effect, at, xq) @ load
    # a deck loaded by a track layer in its modes: derivatives of the cubics
    from vsi_numba.model import hermite

    ei_at = lambda x: static.EI[np.clip(np.searchsorted(sup, x, side="right") - 1, 0,  # noqa: E731
                                        sup.size - 2)][:, None]
    if effect == "deflection":
        return deck.shapes(at)
    if effect == "rotation":
        return hermite.evaluate(deck.nodes, deck.values, deck.slopes, sup[at.astype(int)], 1)
    if effect == "moment":
        return -ei_at(at) * hermite.evaluate(deck.nodes, deck.values, deck.slopes, at, 2)
    if effect == "shear":
        return -ei_at(at) * _third_derivative(deck, at)
    xs = sup[at.astype(int)]
    eps = 1e-9 * max(float(sup[-1]), 1.0)
    right = np.where((xs < sup[-1])[:, None],
                     -ei_at(xs + eps) * _third_derivative(deck, xs + eps), 0.0)
    left = np.where((xs > sup[0])[:, None],
                    -ei_at(xs - eps) * _third_derivative(deck, xs - eps), 0.0)
    return right - left


def _third_derivative(deck, x) -> np.ndarray:
    """d3/dx3 of the Hermite table of ``deck`` at ``x`` (constant per element)."""
    nodes = deck.nodes
    e = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    h = (nodes[e + 1] - nodes[e])[:, None]
    return (12.0 / h**3 * (deck.values[e] - deck.values[e + 1])
            + 6.0 / h**2 * (deck.slopes[e] + deck.slopes[e + 1]))
