"""Vertical deflection checks of the deck under LM71 (static, from influence lines).

Two checks of EN 1990 A2, both on the static deflection of the deck along each track
centre line under LM71 placed most unfavourably (the axle group and the distributed load
where they are unfavourable,
:func:`~vsi_numba.analysis.checks.load_effects.lm71_envelope`) and multiplied by the
dynamic factor Phi of the deck's determinant length:

- **deflection for the safety of the track** (A2.4.4.2.3(1) [R]): LM71 x Phi x alpha
  (the classification factor of the study) on every track of the deck at once (x the
  code profile's ``lm71_factor_several_tracks`` when there are several), the largest
  deflection of each span along any track at most ``L / deflection_span_ratio``
  (L / 600, L the span);
- **passenger comfort** (A2.4.4.3.2 [R]): LM71 x Phi with alpha = 1 on one track (each
  track in turn, the deflection along the loaded track), ``delta / L`` of each span at
  most ``1 / (L/delta)``, the L/delta of Fig. A2.3 for the span and the line speed (the
  table :data:`vsi_numba.code_profile.COMFORT_DEFLECTION_CURVES`, b_v = 1.0 m/s2) times
  the factor of A2.4.4.3.2(6) for the deck (one span modelled alone: the figure's own
  case, two spans: ``comfort_deflection_factor_two_spans``, three or more continuous
  spans: ``comfort_deflection_factor_continuous``), divided by the b_v of the required
  level of comfort (A2.4.4.3.2(5)).

The static deflection line comes from the deck's model (:class:`DeflectionModel`):

- beam decks (simply supported, continuous; with their tracks and torsion): the exact
  Euler-Bernoulli solution (:func:`vsi_numba.model.influence.influence`) plus, on a deck
  with torsion, the St-Venant rotation times the eccentricities
  (:func:`vsi_numba.model.deck3d.torsion_green`);
- decks given as FE matrices: ``K_ff u = f``;
- decks given as a modes table (no stiffness): the modal flexibility of the retained
  modes, ``w(a, x) = sum_j phi_j(a) phi_j(x) / omega_j^2``: a truncated series that
  underestimates the static deflection; the checks state the share of the last retained
  mode beside the verdict;
- rigid track: no deck, no check (the reason is returned).

Loads stand on the track line itself: the spreading of a load by the rail, sleepers and
ballast is neglected, which can only raise the peak deflection (the safe side).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from vsi_numba.analysis.checks.load_effects import lm71_envelope
from vsi_numba.code_profile import (
    COMFORT_DEFLECTION_CLAUSE,
    comfort_deflection_ratio,
    resolve,
)
from vsi_numba.en1991 import lm71

#: Clause of the deflection check for the safety of the track.
DEFLECTION_CLAUSE = "EN 1990 A2.4.4.2.3(1)"
#: Levels of comfort -> code-profile key of their car-body acceleration b_v.
COMFORT_KEYS = {"very good": "comfort_very_good", "good": "comfort_good",
                "acceptable": "comfort_acceptable"}
#: Sections per span of the deflection search (plus every output point).
SECTIONS_PER_SPAN = 16


class DeflectionModel(NamedTuple):
    """The static deflection of a deck along its track centre lines.

    ``supports`` (m); ``n_tracks``; ``line(k, j, at, n_modes=None)``: callable
    ``x_load -> (len(at), len(x_load))``, the deflection (m per N, positive down) of
    track ``k`` at the deck abscissae ``at`` under a unit downward force on track ``j``
    (0-based; ``n_modes`` limits a modal flexibility to its first modes);
    ``breakpoints`` (m): where the lines have kinks besides the sections (supports,
    stations); ``method``: one line saying how the deflection is computed; ``n_modes``:
    the modes of a modal flexibility (0 when the deflection is exact); ``kind``: the
    bridge kind.
    """

    supports: np.ndarray
    n_tracks: int
    line: Callable
    breakpoints: np.ndarray
    method: str
    n_modes: int
    kind: str

    @property
    def spans(self) -> np.ndarray:
        return np.diff(self.supports)

    @property
    def length(self) -> float:
        return float(self.supports[-1])


def _beam_line(static, GJ=None, ecc=None):
    from vsi_numba.model.deck3d import torsion_green
    from vsi_numba.model.influence import influence

    def line(k, j, at, n_modes=None):
        at = np.atleast_1d(np.asarray(at, float))
        yk = 0.0 if ecc is None else float(ecc[k])
        yj = 0.0 if ecc is None else float(ecc[j])

        def f(x):
            w = influence(static, "deflection", at, x)
            if GJ is not None and yk * yj != 0.0:
                w = w + yk * yj * torsion_green(static.supports, GJ, at, x)
            return w
        return f
    return line


def _modal_line(shapes_of, omega):
    """Modal flexibility: ``shapes_of(k, x) -> (len(x), n_modes)`` of track ``k``."""
    inv = 1.0 / np.asarray(omega, float) ** 2

    def line(k, j, at, n_modes=None):
        m = inv.size if n_modes is None else int(n_modes)
        left = shapes_of(k, np.atleast_1d(np.asarray(at, float)))[:, :m] * inv[None, :m]

        def f(x):
            return left @ shapes_of(j, np.atleast_1d(np.asarray(x, float)))[:, :m].T
        return f
    return line


def _matrices_line(K, fixed, centre_of, load_of):
    """``K_ff u = f`` read along track lines: ``centre_of(k)`` / ``load_of(j)`` give
    [(stations, dofs, weight)] of the read-out and the loaded lines."""
    import scipy.sparse
    import scipy.sparse.linalg

    K = scipy.sparse.csc_matrix(K)
    n = K.shape[0]
    free = np.setdiff1d(np.arange(n), np.unique(np.asarray(fixed, np.int64)))
    lu = scipy.sparse.linalg.splu(K[free][:, free].tocsc())

    def share(x, parts, F):
        cols = np.arange(x.size)
        for st, dofs, weight in parts:
            on = (x >= st[0]) & (x <= st[-1])
            e = np.clip(np.searchsorted(st, x, side="right") - 1, 0, st.size - 2)
            t = np.clip((x - st[e]) / (st[e + 1] - st[e]), 0.0, 1.0)
            np.add.at(F, (dofs[e], cols), weight * (1.0 - t) * on)
            np.add.at(F, (dofs[e + 1], cols), weight * t * on)

    def line(k, j, at, n_modes=None):
        at = np.atleast_1d(np.asarray(at, float))
        C = np.zeros((n, at.size))
        share(at, centre_of(k), C)
        Z = np.zeros((n, at.size))
        Z[free] = lu.solve(np.ascontiguousarray(C[free]))   # w(at) = Z^T f (K symmetric)

        def f(x):
            x = np.atleast_1d(np.asarray(x, float))
            F = np.zeros((n, x.size))
            share(x, load_of(j), F)
            return Z.T @ F
        return f
    return line


def _line_deck_model(space, kind) -> DeflectionModel:
    """An imported deck with its tracks (:class:`~vsi_numba.model.imported.lines.LineDeck3D`)."""
    from vsi_numba.model.imported.lines import rail_names

    n_t = len(space.tracks)
    sup = np.asarray(space.supports, float)
    if space.static is None:
        line = _modal_line(lambda k, x: space.bridges[k].shapes(x),
                           space.bridges[0].omega)
        return DeflectionModel(sup, n_t, line, sup, _modal_method(space.n_modes),
                               space.n_modes, kind)
    K, fixed, lines = space.static

    def parts(k):
        name = space.tracks[k].line
        left, right = rail_names(name)
        if left in lines and right in lines:
            return [(*lines[left], 0.5), (*lines[right], 0.5)]
        return [(*lines[name], 1.0)]

    stations = np.concatenate([lines[n][0] for n in lines])
    return DeflectionModel(sup, n_t, _matrices_line(K, fixed, parts, parts),
                           np.unique(np.concatenate([sup, stations])),
                           "static solution K_ff u = f of the deck's FE matrices (the "
                           "track centre line the mean of its rails where the data has "
                           "them)" + _SHARED, 0, kind)


#: How a load between two stations of FE matrices is applied, and what it does.
_SHARED = ("; a load between two stations shared between them linearly, as in the runs: "
           "an underestimate of order (h/L)² (h the station spacing; 3.5e-4 of the value "
           "for 50 stations on a simply supported span)")


def _modal_method(n: int) -> str:
    return (f"modal flexibility of the {n} retained modes, sum phi_j(a) phi_j(x) / "
            "omega_j^2 (the deck is given by its modes only, no stiffness): a truncated "
            "series, an underestimate")


def _model_of_bridge(bridge, kind) -> DeflectionModel | str:
    """A deck along one track line (:class:`~vsi_numba.model.bridge.ModalBridge`)."""
    from vsi_numba.model.bridge import RIGID

    if bridge.kind == RIGID or bridge.n_modes == 0 and bridge.static is None:
        return ("rigid track (bridge.kind = \"rigid\"): there is no deck whose deflection "
                "could be checked")
    sup = np.asarray(bridge.supports, float)
    if sup.size < 2:
        sup = np.array([0.0, float(bridge.length)])
    static = bridge.static
    if static is not None and "deflection" in static.effects:
        if static.kind == "matrices":
            st = np.asarray(static.stations, float)
            dofs = np.asarray(static.dofs)

            def parts(_k):
                return [(st, dofs, 1.0)]
            return DeflectionModel(sup, 1, _matrices_line(static.K, static.fixed, parts,
                                                          parts),
                                   np.unique(np.concatenate([sup, st])),
                                   "static solution K_ff u = f of the deck's FE matrices"
                                   + _SHARED, 0, kind)
        return DeflectionModel(np.asarray(static.supports, float), 1, _beam_line(static),
                               np.asarray(static.supports, float),
                               "exact static solution of the Euler-Bernoulli beam "
                               "(EI of every span)", 0, kind)
    return DeflectionModel(sup, 1, _modal_line(lambda k, x: bridge.output_shapes(x),
                                               bridge.omega),
                           np.unique(np.concatenate([sup, np.asarray(bridge.nodes, float)])),
                           _modal_method(bridge.n_modes), bridge.n_modes, kind)


def deflection_model(ds, base_dir=None, source_path=None) -> DeflectionModel | str:
    """The :class:`DeflectionModel` of a results file's deck, rebuilt from its stored
    configuration (the files of an imported deck looked for next to ``base_dir``, the
    results file ``source_path`` and up to three folders above it, and the working
    folder), or why there is none (str)."""
    from vsi_numba.analysis.checks.determinant import results_config
    from vsi_numba.analysis.recompute import _candidates
    from vsi_numba.config import ConfigError, load_config
    from vsi_numba.model.deck3d import BeamDeck3D

    cfg = results_config(ds)
    bridge = cfg.get("bridge", {}) if isinstance(cfg, dict) else {}
    if not isinstance(bridge, dict) or not bridge:
        return "the results hold no stored configuration of the bridge (config_json)"
    kind = str(bridge.get("kind", ""))
    if kind == "rigid":
        return ("rigid track (bridge.kind = \"rigid\"): there is no deck whose deflection "
                "could be checked")
    imported = kind in ("modes_file", "matrices")
    why = ""
    for folder in _candidates(base_dir, source_path) if imported else [None]:
        try:
            config = load_config(cfg, base_dir=folder)
            space = config.deck_in_space
            planar = config.build_bridge(1) if space is None else None
        except (ConfigError, OSError, ValueError) as exc:
            why = why or " ".join(str(exc).split())
            continue
        if space is None:
            return _model_of_bridge(planar, kind)
        if isinstance(space, BeamDeck3D):
            static = space.bending.static
            if static is None:
                return _model_of_bridge(space.track_bridge(0), kind)
            ecc = np.array([t.eccentricity for t in space.tracks], float)
            sup = np.asarray(static.supports, float)
            method = ("exact static solution of the Euler-Bernoulli beam (EI of every span)"
                      + (" and of its St-Venant torsion (GJ), the track at its "
                         "eccentricity" if space.has_torsion else ""))
            return DeflectionModel(sup, len(space.tracks),
                                   _beam_line(static, space.GJ if space.has_torsion
                                              else None, ecc), sup, method, 0, kind)
        return _line_deck_model(space, kind)
    return f"the stored configuration cannot be rebuilt ({why})"


def sections(model: DeflectionModel, points=(), per_span: int = SECTIONS_PER_SPAN):
    """Deck abscissae (m) of the deflection search: ``per_span`` intervals of every span
    (the supports left out) and the output points ``points`` inside a span."""
    sup = model.supports
    xs = [np.linspace(a, b, per_span + 1)[1:-1] for a, b in zip(sup[:-1], sup[1:],
                                                                   strict=True)]
    pts = np.asarray(points, float).ravel()
    pts = pts[np.isfinite(pts) & (pts > 0) & (pts < sup[-1])]
    x = np.unique(np.concatenate([*xs, pts]))
    return x[~np.isin(np.round(x, 9), np.round(sup, 9))]


def _refinement(model: DeflectionModel, at, quantities, n: int = 9) -> np.ndarray:
    """Sections (m) between the neighbours of each span's largest value of every one of
    ``quantities`` (arrays over ``at``), ``n`` per interval, not already in ``at``."""
    sup = model.supports
    out = []
    for q in quantities:
        for i in range(model.spans.size):
            idx = np.flatnonzero((at > sup[i]) & (at < sup[i + 1]))
            if idx.size == 0:
                continue
            j = idx[int(np.argmax(q[idx]))]
            lo = at[j - 1] if j - 1 in idx else sup[i]
            hi = at[j + 1] if j + 1 in idx else sup[i + 1]
            out.append(np.linspace(lo, hi, 2 * n + 1)[1:-1])
    if not out:
        return np.zeros(0)
    x = np.unique(np.concatenate(out))
    keep = ~np.isin(np.round(x, 9), np.round(np.concatenate([at, sup]), 9))
    return x[keep]


class SpanDeflection(NamedTuple):
    """The design deflection of one span along one track.

    ``track`` (1-based, the track whose deflection it is), ``span`` (1-based),
    ``length`` (m), ``value`` (m, positive down), ``at`` (m, the section),
    ``limit`` (m), ``utilisation = value / limit``; ``truncation``: for a modal
    flexibility the share of the last retained mode in ``value`` (NaN when exact).
    """

    track: int
    span: int
    length: float
    value: float
    at: float
    limit: float
    truncation: float = float("nan")

    @property
    def utilisation(self) -> float:
        return self.value / self.limit

    @property
    def passed(self) -> bool:
        return bool(self.value <= self.limit)

    @property
    def ratio(self) -> float:
        """L / delta achieved."""
        return self.length / self.value if self.value > 0 else float("inf")


class DeflectionResults(NamedTuple):
    """The deflection checks of a results file (:func:`deflection_checks`).

    ``safety``: :class:`SpanDeflection` per (track, span) under LM71 x Phi x alpha on
    every track; ``comfort``: per (track, span) under LM71 x Phi on that track alone
    (alpha = 1), limit ``L / required_ratio`` (empty when the figure gives no limit:
    ``comfort_note`` says why); ``alpha``, ``phi``, ``phi_name``, ``lphi`` (m),
    ``lphi_rule``, ``maintenance``; ``n_tracks`` (loaded for the safety check),
    ``track_factor`` (the LM71 factor on each of them); ``speed_kmh`` (the line speed
    of the comfort limit) and ``speed_rule``; ``figure_ratio`` per span (the L/delta of
    Fig. A2.3 at b_v = 1), ``figure_note``, ``deck_factor`` and ``deck_rule`` (the
    factor of A2.4.4.3.2(6)), ``level``, ``b_v`` (m s-2), ``required_ratio`` per span
    (figure x factor / b_v), ``levels``: per level of comfort (name, b_v, required
    L/delta per span); ``method``; ``profile``.
    """

    safety: list
    comfort: list
    alpha: float
    phi: float
    phi_name: str
    lphi: float
    lphi_rule: str
    maintenance: str
    n_tracks: int
    track_factor: float
    speed_kmh: float
    speed_rule: str
    figure_ratio: list
    figure_note: str
    deck_factor: float
    deck_rule: str
    level: str
    b_v: float
    required_ratio: list
    levels: list
    method: str
    comfort_note: str
    profile: object

    def governing(self, which: str) -> SpanDeflection | None:
        """The largest utilisation of ``which`` ("safety" or "comfort"), or None."""
        rows = getattr(self, which)
        return max(rows, key=lambda r: r.utilisation) if rows else None


def deck_factor(model: DeflectionModel, profile=None) -> tuple[float, str]:
    """(factor, why) of EN 1990 A2.4.4.3.2(6) on the L/delta of Fig. A2.3 for the deck."""
    p = resolve(profile)
    n = int(model.spans.size)
    if n == 1:
        f = p["comfort_deflection_factor_single_deck"]
        return f, (f"one span modelled alone: × {f:g} (the figure's own case, a succession "
                   "of three or more simply supported spans, the safe side; a bridge of one "
                   "or two simply supported spans may take × "
                   f"{p['comfort_deflection_factor_two_spans']:g}, "
                   "code profile `comfort_deflection_factor_single_deck`)")
    if n == 2:
        f = p["comfort_deflection_factor_two_spans"]
        return f, f"two continuous spans: × {f:g}"
    f = p["comfort_deflection_factor_continuous"]
    return f, f"{n} continuous spans: × {f:g}"


def _per_span(model, at, values, limits, track, trunc=None) -> list[SpanDeflection]:
    sup = model.supports
    out = []
    for i in range(model.spans.size):
        inside = (at > sup[i]) & (at < sup[i + 1])
        if not inside.any():
            continue
        idx = np.flatnonzero(inside)
        j = idx[int(np.argmax(values[idx]))]
        t = float("nan") if trunc is None else float(trunc[j])
        out.append(SpanDeflection(track, i + 1, float(model.spans[i]), float(values[j]),
                                  float(at[j]), float(limits[i]), t))
    return out


def deflection_checks(ds, profile=None, length: float | None = None,
                      comfort_level: str = "very good", base_dir=None, source_path=None,
                      step: float = 0.05):
    """EN 1990 A2.4.4.2.3(1) and A2.4.4.3.2 deflection checks of a results file.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with a stored configuration (``config_json``).
    profile : CodeProfile, optional
        Default: the one stored with the results.
    length : float, optional
        Determinant length L_phi (m) of Phi; default
        :func:`~vsi_numba.analysis.checks.determinant_length`.
    comfort_level : {"very good", "good", "acceptable"}
        The required level of comfort (its b_v divides the L/delta of Fig. A2.3).
    base_dir, source_path
        Where the files of an imported deck are looked for (:func:`deflection_model`).
    step : float
        Placement step of the LM71 axle group (m).

    Returns
    -------
    DeflectionResults or str
        The checks, or why they cannot be made.
    """
    from vsi_numba.analysis.checks.common import profile_of
    from vsi_numba.analysis.checks.determinant import determinant_length, results_config
    from vsi_numba.analysis.checks.load_effects import study_factors
    from vsi_numba.analysis.dataset import prepare
    from vsi_numba.en1991 import dynamic_factor

    if comfort_level not in COMFORT_KEYS:
        raise ValueError(f"comfort level {comfort_level!r}: expected one of "
                         f"{', '.join(map(repr, COMFORT_KEYS))}")
    ds = prepare(ds)
    p = profile_of(ds, profile)
    model = deflection_model(ds, base_dir, source_path)
    if isinstance(model, str):
        return model
    lphi = determinant_length(ds, length, p)
    if not np.isfinite(lphi.value):
        return f"no determinant length L_Φ for the dynamic factor Φ ({lphi.rule})"
    alpha, maintenance = study_factors(ds)
    phi = float(dynamic_factor(lphi.value, maintenance, p))
    lm = lm71(p)
    pts = np.asarray(ds["point"].values, float) if "point" in ds.coords else ()
    n_t = model.n_tracks
    factor = 1.0 if n_t == 1 else p["lm71_factor_several_tracks"]
    ext = (0.0, model.length)

    def lines_at(at):
        """Per track k: the own-track envelope and the sum over the loaded tracks, and
        the last mode's share of each (modal flexibility), at the sections ``at``."""
        bp = np.unique(np.concatenate([model.breakpoints, at]))

        def env(k, j, n_modes=None):
            return lm71_envelope(model.line(k, j, at, n_modes), bp, ext, step=step,
                                 n_at=at.size, model=lm).max

        own = [env(k, k) for k in range(n_t)]
        total = [sum(own[k] if j == k else env(k, j) for j in range(n_t))
                 for k in range(n_t)]
        t_own = [np.full(at.size, np.nan) for _ in range(n_t)]
        t_all = [np.full(at.size, np.nan) for _ in range(n_t)]
        if model.n_modes > 1:
            for k in range(n_t):
                less = [env(k, j, model.n_modes - 1) for j in range(n_t)]
                with np.errstate(divide="ignore", invalid="ignore"):
                    t_own[k] = np.where(own[k] > 0, 1.0 - less[k] / own[k], np.nan)
                    t_all[k] = np.where(total[k] > 0, 1.0 - sum(less) / total[k], np.nan)
        return own, total, t_own, t_all

    # a grid of every span, then a finer one around each span's largest values (the
    # grid alone would miss a peak between two sections by up to ~5 (h/L)^2 of it)
    at = sections(model, pts)
    coarse = lines_at(at)
    extra = _refinement(model, at, [*coarse[0], *coarse[1]])
    at_all = np.concatenate([at, extra])
    fine = lines_at(extra) if extra.size else ([np.zeros(0)] * n_t,) * 4
    order = np.argsort(at_all, kind="stable")
    at = at_all[order]
    own, total, trunc_own, trunc_all = (
        [np.concatenate([c, f])[order] for c, f in zip(cq, fq, strict=True)]
        for cq, fq in zip(coarse, fine, strict=True))
    safe_limits = model.spans / p["deflection_span_ratio"]
    safety = []
    for k in range(n_t):
        w = phi * alpha * factor * total[k]
        trunc = trunc_all[k] if model.n_modes > 1 else None
        safety += _per_span(model, at, w, safe_limits, k + 1, trunc)

    # comfort: the line speed, Fig. A2.3, the deck's factor and the level's b_v
    study = results_config(ds).get("study", {})
    study = study if isinstance(study, dict) else {}
    if study.get("line_speed_kmh"):
        speed = float(study["line_speed_kmh"])
        speed_rule = "the line speed (study.line_speed_kmh)"
    else:
        sk = (ds["speed_kmh"].values if "speed_kmh" in ds.coords
              else np.asarray(ds["speed"].values, float) * 3.6)
        speed = float(np.nanmax(np.asarray(sk, float)))
        speed_rule = ("the highest speed of the study (no study.line_speed_kmh: the "
                      "safe side, a higher speed needs a stiffer deck)")
    dfac, drule = deck_factor(model, p)
    b_v = float(p[COMFORT_KEYS[comfort_level]])
    figure, notes, bad = [], [], []
    for L in model.spans:
        r = comfort_deflection_ratio(float(L), speed, p)
        figure.append(r.ratio)
        group = notes if np.isfinite(r.ratio) else bad
        if r.note not in group:
            group.append(r.note)
    figure_arr = np.asarray(figure, float)
    required = figure_arr * dfac / b_v
    levels = [(name, float(p[key]), list(figure_arr * dfac / float(p[key])))
              for name, key in COMFORT_KEYS.items()]
    comfort: list = []
    comfort_note = ""
    if np.all(np.isfinite(required)):
        lim = model.spans / required
        for k in range(n_t):
            trunc = trunc_own[k] if model.n_modes > 1 else None
            comfort += _per_span(model, at, phi * own[k], lim, k + 1, trunc)
    else:
        comfort_note = "; ".join(bad)
    return DeflectionResults(
        safety, comfort, float(alpha), phi, "Φ3" if maintenance == "standard" else "Φ2",
        float(lphi.value), str(lphi.rule), maintenance, n_t, float(factor), speed,
        speed_rule, list(figure_arr), "; ".join(notes), float(dfac), drule, comfort_level,
        b_v, list(required), levels, model.method, comfort_note, p)


__all__ = ["COMFORT_DEFLECTION_CLAUSE", "COMFORT_KEYS", "DEFLECTION_CLAUSE",
           "DeflectionModel", "DeflectionResults", "SpanDeflection", "deck_factor",
           "deflection_checks", "deflection_model", "sections"]
