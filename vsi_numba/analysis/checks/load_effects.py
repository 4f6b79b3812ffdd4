"""EN 1991-2 6.4.6 design checks of load effects: static crawl envelopes of the real
trains, the LM71 x alpha x Phi envelope, phi'_dyn per effect, the 6.4.6.5(3) verdict and
the deck-end rotation check.

Static envelopes work on an influence line given as a callable ``line(x) -> (n_at, n_x)``
(the static effect at ``n_at`` sections or supports of a unit downward force at each
``x``, e.g. :func:`vsi_numba.model.influence.influence` with its ``static`` and ``at``
bound), so they are independent of how the line was obtained.

Placements searched (every placement that matters)
---------------------------------------------------
An effect of a set of point loads at a common position ``s`` is
``E(s) = sum_k P_k I(s - p_k)``.  Between two positions at which some load crosses a
breakpoint of the influence line (a support, the section itself, a deck end) ``E`` is a
smooth function (a cubic polynomial for a beam deck), and for a piecewise-linear line
(a statically determinate deck) a linear one, whose extremes lie at those crossings.  The
search therefore evaluates ``E`` at every crossing (both sides of it, 1e-9 m apart, so the
jump of a shear line is seen) and on a uniform grid of step ``h``: exact for
piecewise-linear lines, and otherwise within ``h^2 / 8 max|E''|`` of the true extreme
(relative error of order ``(h / L)^2``, about 4e-6 for h = 0.05 m on a 25 m span).

Signs follow :mod:`vsi_numba.model.influence`.  Design quantities compare magnitudes:
for every location the extreme of ``|E|`` over both signs (EN 1991-2 6.4.6.5 defines
``phi'_dyn = max|y_dyn| / max|y_stat| - 1``).  LM71, Phi, phi'', the rotation limit and
the HSLM-B span come from the code profile (:mod:`vsi_numba.code_profile`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from vsi_numba.en1991 import LM71, lm71
from vsi_numba.io.schema import ALL_TRACKS_SUFFIX

#: Half-gap (m) of the two evaluations either side of a breakpoint crossing.
_EPS = 1e-9
#: Largest number of (section, position, load) products evaluated at once.
_CHUNK = 4_000_000

Line = Callable[[np.ndarray], np.ndarray]


class Envelope(NamedTuple):
    """Maximum and minimum of a static effect over every placement of the loads.

    ``max``, ``min`` : ndarray, shape (n_at,), in the units of the line times N;
    ``at_max``, ``at_min`` : ndarray, shape (n_at,), the governing position (m) of the
    reference load (the train's first axle; the centre of the LM71 axle group).
    """

    max: np.ndarray
    min: np.ndarray
    at_max: np.ndarray
    at_min: np.ndarray

    @property
    def abs(self) -> np.ndarray:
        """max(|max|, |min|) per location."""
        return np.maximum(np.abs(self.max), np.abs(self.min))


def _candidates(lo: float, hi: float, crossings, step: float) -> np.ndarray:
    """Uniform grid of ``step`` on [lo, hi] plus both sides of every crossing in it."""
    n = max(int(np.ceil((hi - lo) / step)), 1)
    grid = np.linspace(lo, hi, n + 1)
    c = np.asarray(crossings, float).ravel()
    c = np.concatenate([c - _EPS, c + _EPS])
    c = c[(c >= lo) & (c <= hi)]
    return np.unique(np.concatenate([grid, c]))


def _reduce(values_of, s: np.ndarray, n_at: int, per_s: int) -> Envelope:
    """Max/min over ``s`` of ``values_of(s_chunk) -> (n_at, n_chunk)``, in chunks."""
    vmax = np.full(n_at, -np.inf)
    vmin = np.full(n_at, np.inf)
    smax = np.zeros(n_at)
    smin = np.zeros(n_at)
    block = max(1, _CHUNK // max(1, n_at * per_s))
    for i in range(0, s.size, block):
        sc = s[i:i + block]
        v = values_of(sc)
        j = np.argmax(v, axis=1)
        k = np.argmin(v, axis=1)
        rows = np.arange(n_at)
        better = v[rows, j] > vmax
        vmax = np.where(better, v[rows, j], vmax)
        smax = np.where(better, sc[j], smax)
        better = v[rows, k] < vmin
        vmin = np.where(better, v[rows, k], vmin)
        smin = np.where(better, sc[k], smin)
    return Envelope(vmax, vmin, smax, smin)


def _loads_effect(line: Line, s: np.ndarray, positions: np.ndarray, loads: np.ndarray,
                  n_at: int, extent) -> np.ndarray:
    """sum_k P_k I(s - p_k) for every s: shape (n_at, n_s); the line is evaluated only
    for loads on the deck (it is zero elsewhere)."""
    x = (s[:, None] - positions[None, :]).ravel()
    on = (x >= extent[0]) & (x <= extent[1])
    inf = np.zeros((n_at, x.size))
    if on.any():
        inf[:, on] = np.asarray(line(x[on]), float).reshape(n_at, -1)
    return inf.reshape(n_at, s.size, positions.size) @ loads


def crawl_envelope(line: Line, positions, loads, breakpoints, extent, step: float = 0.05,
                   n_at: int | None = None) -> Envelope:
    """Static envelope of a train crawling over the deck (its axle loads, no dynamics).

    Parameters
    ----------
    line : callable
        ``line(x)`` with ``x`` of shape (n,) (m): the effect of a unit downward force
        (1 N) at each ``x``, shape (n_at, n); zero off the deck.
    positions : array_like, shape (n_axle,)
        Axle positions behind the first axle (m, >= 0).
    loads : array_like, shape (n_axle,)
        Axle loads (N, positive down).
    breakpoints : array_like
        Abscissae (m) where the line or one of its derivatives jumps (deck ends,
        supports, the sections themselves).
    extent : (float, float)
        The deck (m): the line is zero outside it.
    step : float
        Grid step h (m) of the first-axle position between crossings (see the module
        notes for the error bound).
    n_at : int, optional
        Number of locations of ``line`` (default: from one evaluation).

    Returns
    -------
    Envelope
        Extremes per location (N times the line's units) and the first-axle position
        (m) that gives them.
    """
    p = np.asarray(positions, float).ravel()
    P = np.asarray(loads, float).ravel()
    if p.size != P.size or p.size == 0:
        raise ValueError(f"positions ({p.size}) and loads ({P.size}): expected the same "
                         "number (> 0) of axles")
    if not step > 0:
        raise ValueError(f"step = {step!r}: expected > 0 m")
    lo, hi = float(extent[0]), float(extent[1]) + float(p.max())
    bp = np.asarray(breakpoints, float).ravel()
    s = _candidates(lo, hi, (bp[:, None] + p[None, :]).ravel(), step)
    if n_at is None:
        n_at = int(np.asarray(line(np.array([0.5 * (extent[0] + extent[1])]))).shape[0])
    return _reduce(lambda sc: _loads_effect(line, sc, p, P, n_at, extent), s, n_at, p.size)


def _cumulative_trapezoid(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The cumulative trapezoidal integral of the rows of ``y`` over ``x``, from 0 (the
    operations of ``scipy.integrate.cumulative_trapezoid(y, x, axis=1, initial=0)``, the
    same numbers, without the ~0.2 s of importing scipy.integrate)."""
    part = np.cumsum(np.diff(x)[None, :] * (y[:, 1:] + y[:, :-1]) / 2.0, axis=1)
    return np.concatenate((np.zeros((y.shape[0], 1), dtype=part.dtype), part), axis=1)


def lm71_envelope(line: Line, breakpoints, extent, step: float = 0.05,
                  n_at: int | None = None, grid_step: float | None = None,
                  model: LM71 | None = None) -> Envelope:
    """Static envelope of EN 1991-2 LM71 (alpha = 1, no dynamic factor).

    Four point forces of 250 kN at 1.6 m, in a 6.4 m zone centred on them, and 80 kN/m
    on both sides of the zone, unlimited in length and applied only where it is
    unfavourable (EN 1991-2 6.3.2, Fig. 6.1; the values of ``model``): for the maximum,
    wherever the line is positive outside the zone; for the minimum, wherever it is
    negative.  The axle group stays together and is placed most unfavourably (its centre
    anywhere from 3.2 m before the deck to 3.2 m beyond it, partly off the deck included).

    The distributed part is the integral of the positive (negative) part of the line
    outside the zone: trapezoidal rule on a grid of ``grid_step`` (default
    min(step, extent / 2000)) that holds every breakpoint (both sides), interpolated
    linearly for the zone ends (error O(grid_step^2)).

    Parameters
    ----------
    line, breakpoints, extent, step, n_at
        As :func:`crawl_envelope`; ``step`` is the grid of the group's centre.
    grid_step : float, optional
        Integration step (m) of the distributed load.
    model : LM71, optional
        LM71 of the code profile (:func:`vsi_numba.en1991.lm71`); default the recommended.

    Returns
    -------
    Envelope
        Extremes per location and the position (m) of the centre of the axle group.
    """
    x0, x1 = float(extent[0]), float(extent[1])
    if not step > 0:
        raise ValueError(f"step = {step!r}: expected > 0 m")
    bp = np.asarray(breakpoints, float).ravel()
    h = grid_step or min(step, (x1 - x0) / 2000.0)
    xs = _candidates(x0, x1, bp, h)
    xs = xs[(xs >= x0) & (xs <= x1)]
    inf = np.asarray(line(xs), float)
    if n_at is None:
        n_at = inf.shape[0]
    cum = [_cumulative_trapezoid(part, xs)
           for part in (np.maximum(inf, 0.0), np.minimum(inf, 0.0))]
    model = lm71() if model is None else model
    half = 0.5 * model.zone
    offs = np.asarray(model.offsets, float)
    Q = np.full(offs.size, model.axle_load)

    def udl(c, sc):
        a = np.clip(sc - half, x0, x1)
        b = np.clip(sc + half, x0, x1)
        rows = []
        for r in range(n_at):
            total = c[r, -1]
            rows.append(total - (np.interp(b, xs, c[r]) - np.interp(a, xs, c[r])))
        return model.udl * np.asarray(rows)

    crossings = np.concatenate([(bp[:, None] - offs[None, :]).ravel(), bp - half, bp + half])
    s = _candidates(x0 - half, x1 + half, crossings, step)

    def total(sc, c):
        # axle k at sc + o_k
        return _loads_effect(line, sc, -offs, Q, n_at, (x0, x1)) + udl(c, sc)

    hi = _reduce(lambda sc: total(sc, cum[0]), s, n_at, offs.size)
    lo = _reduce(lambda sc: total(sc, cum[1]), s, n_at, offs.size)
    return Envelope(hi.max, lo.min, hi.at_max, lo.at_min)


# --------------------------------------------------------------------- design values


def phi_dyn(dynamic_abs, static_abs):
    """Dynamic increment ``phi'_dyn = max|y_dyn| / max|y_stat| - 1`` (EN 1991-2
    6.4.6.5); NaN where the static value is 0 or not finite.

    Parameters
    ----------
    dynamic_abs, static_abs : array_like
        max|y_dyn| and max|y_stat| (same units), broadcastable.
    """
    d = np.asarray(dynamic_abs, float)
    s = np.asarray(static_abs, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isfinite(s) & (s > 0), d / np.where(s > 0, s, 1.0) - 1.0, np.nan)


class Verdict(NamedTuple):
    """EN 1991-2 6.4.6.5(3) comparison of one effect at one location.

    ``real`` = (1 + phi'_dyn + phi''/2) x static effect of the real train / HSLM;
    ``lm71`` = Phi x alpha x LM71; ``ratio = real / lm71``; ``governs`` is
    ``"HSLM / real trains"`` when ratio > 1, else ``"LM71 x Phi x alpha"``.
    """

    real: float
    lm71: float
    ratio: float
    governs: str


REAL_GOVERNS = "HSLM / real trains"
LM71_GOVERNS = "LM71 × Φ × α"


def verdict(phi_dyn_value: float, phi2: float, static_real: float, lm71_static: float,
            phi: float, alpha: float) -> Verdict:
    """EN 1991-2 6.4.6.5(3): the more unfavourable of
    ``(1 + phi'_dyn + phi''/2) x real`` and ``Phi x alpha x LM71`` (magnitudes).

    Parameters
    ----------
    phi_dyn_value : float
        phi'_dyn of the effect (-).
    phi2 : float
        phi'' of EN 1991-2 Annex C (-); 0 when the dynamic analysis already includes
        the track irregularities.
    static_real : float
        max|static effect| of the real train or HSLM (crawl).
    lm71_static : float
        max|static effect| of LM71 (alpha = 1, no dynamic factor).
    phi, alpha : float
        Dynamic factor Phi_2 or Phi_3 and classification factor.
    """
    real = (1.0 + phi_dyn_value + 0.5 * phi2) * abs(static_real)
    lm = phi * alpha * abs(lm71_static)
    ratio = real / lm if lm > 0 else np.nan
    return Verdict(float(real), float(lm), float(ratio),
                   REAL_GOVERNS if ratio > 1 else LM71_GOVERNS)


# ------------------------------------------------------------------ results-file checks

#: Effects checked: name -> (influence effect, dynamic variable stem, location dim, units,
#: label).  The deflection has no stored minimum (positive down: max only).
EFFECTS = {
    "deflection": ("deflection", "deck_displacement", "point", "m", "deflection w"),
    "moment": ("moment", "bending_moment", "point", "N m", "bending moment M"),
    "shear": ("shear", "shear_force", "point", "N", "shear force V"),
    "reaction": ("reaction", "support_reaction", "support", "N", "support reaction R"),
    "rotation": ("rotation", "end_rotation", "support", "rad", "rotation θ"),
}
#: The load-effect variables whose presence says the file has load effects.
_LOAD_EFFECT_VARIABLES = ("max_bending_moment", "max_shear_force", "max_support_reaction",
                          "max_end_rotation")
#: Default classification factor and track maintenance standard (study keys).
DEFAULT_ALPHA = 1.0
DEFAULT_MAINTENANCE = "standard"


class LoadEffectChecks(NamedTuple):
    """The EN 1991-2 6.4.6 checks of the load effects of a results file.

    Attributes
    ----------
    envelopes : pandas.DataFrame
        One row per effect and location: ``effect``, ``location`` (m), ``dynamic``
        (max|E| over speeds and trains), ``train``, ``speed_kmh`` (of it), ``static``
        (max|E| of the static crawl over trains; moving forces distributed as the runs
        distributed them, ``track.load_distribution``), ``lm71`` (LM71 static, alpha = 1),
        ``lm71_design`` (x Phi x alpha), ``real_design`` (max over speeds and trains of
        (1 + phi'_dyn + phi''/2) x static crawl = |dynamic| + phi''/2 x static),
        ``ratio`` (real_design / lm71_design), ``units``.
    phi_dyn : pandas.DataFrame
        One row per effect and train: ``phi_dyn`` (max over speeds of
        max_loc|E_dyn| / max_loc|E_stat| - 1), ``speed_kmh`` of it.
    phi_dyn_speeds : pandas.DataFrame
        One row per effect, train and speed: ``phi_dyn`` at that speed.
    verdict : pandas.DataFrame
        One row per effect: the location of the largest ``ratio``, the values there,
        ``governs`` and ``margin`` (lm71_design / real_design when LM71 governs, else
        real_design / lm71_design; >= 1).
    rotation : pandas.DataFrame
        Deck-end rotation check: per end support ``theta_lm71_design`` (rad, LM71 x
        Phi x alpha), ``theta_real_design`` ((1 + phi'_dyn + phi''/2) x the trains'
        static rotation, max over speeds and trains), ``theta_design`` (the larger, the
        design value of EN 1991-2 6.4.6.5(3)), ``limit``, ``utilisation`` (of
        ``theta_design``), ``result``.
    deck : dict
        Whole-deck data for the figure: ``x`` (m) and per effect ("moment", "shear")
        ``dyn_max``, ``dyn_min`` of the governing train, ``lm71_max``, ``lm71_min``
        (x Phi x alpha), ``train``; empty when the file has no whole-deck envelopes.
    factors : dict
        ``alpha``, ``maintenance``, ``phi_name``, ``phi``, ``length`` (L_phi),
        ``length_rule``, ``phi2_max``, ``phi2_note``, ``notes`` (applicability notes,
        e.g. HSLM-B on a deck it does not cover), ``profile`` (the code profile used).
    """

    envelopes: object
    phi_dyn: object
    phi_dyn_speeds: object
    verdict: object
    rotation: object
    deck: dict
    factors: dict


def _nanmax(a, axis):
    a = np.asarray(a, float)
    m = np.where(np.isnan(a), -np.inf, a).max(axis=axis)
    return np.where(np.isneginf(m), np.nan, m)


def _not_computed(ds) -> dict:
    """The results' ``not_computed`` attribute (variable -> reason), {} if absent or
    unreadable."""
    import json

    try:
        out = json.loads(str(ds.attrs.get("not_computed", "{}")))
    except ValueError:
        return {}
    return {str(k): str(v) for k, v in out.items()} if isinstance(out, dict) else {}


def static_deck_of(ds):
    """The :class:`~vsi_numba.model.influence.StaticDeck` of a results file's beam deck
    (``bridge.kind`` simply_supported or continuous in the stored configuration), or the
    reason (str) why there is none."""
    from vsi_numba.analysis.checks.determinant import results_config
    from vsi_numba.model.influence import beam_deck

    bridge = results_config(ds).get("bridge", {})
    bridge = bridge if isinstance(bridge, dict) else {}
    kind = bridge.get("kind")
    if kind not in ("simply_supported", "continuous"):
        return (f"the static reference (crawl of the trains, LM71) needs the deck's spans "
                f"and bending stiffness; the results' bridge.kind = {kind!r} does not give "
                "them (beam decks only: simply_supported, continuous)")
    try:
        spans = np.atleast_1d(np.asarray(bridge["spans"], float))
        if kind == "simply_supported":
            spans = spans[:1]
        return beam_deck(spans, bridge["EI"])
    except (KeyError, TypeError, ValueError) as exc:
        return f"the stored configuration's bridge.spans / bridge.EI are not usable ({exc})"


def study_factors(ds) -> tuple[float, str]:
    """(alpha, track maintenance) from the stored ``study`` section (defaults 1.0 and
    "standard")."""
    from vsi_numba.analysis.checks.determinant import results_config

    study = results_config(ds).get("study", {})
    study = study if isinstance(study, dict) else {}
    return (float(study.get("classification_factor", DEFAULT_ALPHA)),
            str(study.get("track_maintenance", DEFAULT_MAINTENANCE)))


def load_effect_checks(ds, alpha: float | None = None, maintenance: str | None = None,
                       length: float | None = None, step: float = 0.05, profile=None,
                       all_tracks: bool = False):
    """EN 1991-2 6.4.6 checks of the load effects in a results file.

    Parameters
    ----------
    ds : xarray.Dataset
        Results with the load-effect envelopes (``max_bending_moment``, ...), the trains'
        ``wheel_position`` and ``static_wheel_load`` and a stored configuration of a beam
        deck.
    alpha : float, optional
        Classification factor; default: ``study.classification_factor`` of the stored
        configuration, else 1.0.
    maintenance : {"standard", "careful"}, optional
        Track maintenance (Phi_3 / Phi_2); default: ``study.track_maintenance``, else
        "standard".
    length : float, optional
        Determinant length L_phi (m); default
        :func:`~vsi_numba.analysis.checks.determinant_length`.
    step : float
        Position grid (m) of the envelope searches (module notes).
    profile : CodeProfile, optional
        Code profile (LM71, Phi, phi'', L_Phi, rotation limit, HSLM-B span); default: the
        one stored with the results.
    all_tracks : bool
        Every train of a run loaded (``train.other_trains``): the ``..._all_tracks``
        envelopes against LM71 on each loaded track (x ``lm71_factor_several_tracks``);
        the static effect of the trains is their crawl envelopes added (the trains
        placed most unfavourably each: an upper bound of the run's arrangement), for a
        beam deck whose bending does not depend on where across the deck a load stands.

    Returns
    -------
    LoadEffectChecks or str
        The checks, or why they cannot be made (no load-effect variables, no static
        deck).
    """
    import pandas as pd

    from vsi_numba.analysis.checks.common import profile_of
    from vsi_numba.analysis.checks.determinant import determinant_length, results_config
    from vsi_numba.analysis.checks.wheels import prescribed_wheels
    from vsi_numba.analysis.dataset import DETERMINISTIC, bridge_frequencies, prepare
    from vsi_numba.en1991 import dynamic_factor, irregularity_allowance
    from vsi_numba.model.distribution import expand, from_track_config
    from vsi_numba.model.influence import influence

    ds = prepare(ds)
    sfx = ALL_TRACKS_SUFFIX if all_tracks else ""
    if all_tracks and not any(v + sfx in ds.variables for v in _LOAD_EFFECT_VARIABLES):
        why = _not_computed(ds).get("max_bending_moment" + sfx)
        return (f"the study did not compute them: {why}" if why else
                "the results hold no load effects with every train loaded")
    if not any(v in ds.variables for v in _LOAD_EFFECT_VARIABLES):
        why = _not_computed(ds).get("max_bending_moment")
        if why:  # the study said why when it wrote the file
            return f"the study did not compute the load effects: {why}"
        return ("the results hold no load-effect envelopes (bending moment, shear force, "
                "support reactions, rotations): a file written before they were computed, "
                "or a bridge that cannot give them (imported modes table, rigid track)")
    static = static_deck_of(ds)
    if isinstance(static, str):
        return static
    if ds["wheel_position"].ndim != 2 or ds["static_wheel_load"].ndim != 2:
        return "variant studies (extra dims on the trains' axles) are not covered"
    a0, m0 = study_factors(ds)
    alpha = a0 if alpha is None else float(alpha)
    maintenance = m0 if maintenance is None else maintenance
    profile = profile_of(ds, profile)
    n_loaded = 1
    if all_tracks:
        n_loaded = len(str(ds.attrs.get("loaded_tracks_all", "1 2")).split())
    # LM71 on each loaded track; the trains' static envelopes added (see all_tracks)
    lm_factor = 1.0 if n_loaded == 1 else n_loaded * profile["lm71_factor_several_tracks"]
    rot_limit = profile["end_rotation_limit_abutment"]
    model = lm71(profile)
    lphi = determinant_length(ds, length, profile)
    if not np.isfinite(lphi.value):
        return f"no determinant length L_Φ ({lphi.rule})"
    phi = dynamic_factor(lphi.value, maintenance, profile)
    irr = np.asarray(ds["irregularity"].values)
    det = np.flatnonzero(irr == DETERMINISTIC)
    f = bridge_frequencies(ds)
    speeds = np.asarray(ds["speed"].values, float)
    if det.size:
        isel = {"irregularity": det}
        phi2 = (irregularity_allowance(speeds, lphi.value, float(f[0]), profile) if f.size
                else np.full(speeds.size, np.nan))
        note = "φ'' of EN 1991-2 Annex C on the deterministic track"
    else:
        isel = {}
        phi2 = np.zeros(speeds.size)
        note = ("φ'' = 0: the dynamic analysis runs on random irregularities, which "
                "already hold their effect (max over realisations)")
    sk = np.asarray(ds["speed_kmh"].values, float)
    trains = [str(t) for t in ds["train"].values]
    wp = np.asarray(ds["wheel_position"].values, float)
    wl = np.asarray(ds["static_wheel_load"].values, float)
    # the moving forces as the runs distributed them (track.load_distribution)
    spread = from_track_config(results_config(ds).get("track"))
    moving = prescribed_wheels(ds).values if spread is not None else None
    sup = static.supports
    ext = (0.0, static.length)

    env_rows, phi_rows, ver_rows, speed_rows = [], [], [], []
    crawl_abs = {}
    lm71_abs = {}
    for name, (eff, stem, dim, units, _label) in EFFECTS.items():
        vmax = f"max_{stem}{sfx}"
        if vmax not in ds.variables or dim not in ds.dims or eff not in static.effects:
            continue
        dyn = np.abs(ds[vmax].isel(isel).transpose("speed", "train", "irregularity", dim)
                     .values)
        vmin = f"min_{stem}{sfx}"
        if vmin in ds.variables:
            low = np.abs(ds[vmin].isel(isel).transpose("speed", "train", "irregularity", dim)
                         .values)
            dyn = np.fmax(dyn, low)
        dyn = _nanmax(dyn, 2)  # (speed, train, loc)
        loc = np.asarray(ds[dim].values, float)
        if dim == "support":
            idx = np.array([int(np.argmin(np.abs(sup - x))) if np.isfinite(x) else -1
                            for x in loc])
            keep = (idx >= 0) & np.isin(np.round(loc, 6), np.round(sup, 6))
            at = idx[keep]
            bp = sup
        else:
            keep = np.isfinite(loc)
            at = loc[keep]
            bp = np.concatenate([sup, at])
        if at.size == 0:
            continue
        dyn = dyn[:, :, keep]
        loc = loc[keep]

        def line(x, eff=eff, at=at):
            return influence(static, eff, at, x)

        stat = np.full((len(trains), at.size), np.nan)
        for t in range(len(trains)):
            ok = np.isfinite(wp[t]) & np.isfinite(wl[t]) & (wl[t] > 0)
            if ok.any():
                pos, load = wp[t][ok], wl[t][ok]
                if spread is not None:
                    mf = moving[t][ok]
                    dpos, dload = expand(pos[mf], load[mf], spread)
                    pos = np.concatenate([pos[~mf], dpos])
                    load = np.concatenate([load[~mf], dload])
                e = crawl_envelope(line, pos - pos.min(), load, bp, ext, step=step,
                                   n_at=at.size)
                stat[t] = (e.max if name == "deflection" else e.abs) * n_loaded
        lm = lm71_envelope(line, bp, ext, step=step, n_at=at.size, model=model)
        lm_abs = (lm.max if name == "deflection" else lm.abs) * lm_factor
        crawl_abs[name], lm71_abs[name] = stat, lm_abs
        real = dyn + 0.5 * phi2[:, None, None] * stat[None, :, :]   # (speed, train, loc)
        lm_design = phi * alpha * lm_abs
        for j in range(at.size):
            d = dyn[:, :, j]
            r = real[:, :, j]
            if np.all(np.isnan(d)):
                continue
            i_s, i_t = np.unravel_index(np.nanargmax(d), d.shape)
            k_s, k_t = np.unravel_index(np.nanargmax(r), r.shape)
            rd = float(r[k_s, k_t])
            env_rows.append({
                "effect": name, "location": float(loc[j]), "dynamic": float(d[i_s, i_t]),
                "train": trains[i_t], "speed_kmh": float(sk[i_s]),
                "static": float(_nanmax(stat[:, j], 0)), "lm71": float(lm_abs[j]),
                "lm71_design": float(lm_design[j]), "real_design": rd,
                "real_train": trains[k_t], "real_speed_kmh": float(sk[k_s]),
                "ratio": rd / lm_design[j] if lm_design[j] > 0 else np.nan, "units": units,
            })
        deck_dyn = _nanmax(dyn, 2)                  # (speed, train)
        deck_stat = _nanmax(stat, 1)                # (train,)
        pd_st = phi_dyn(deck_dyn, deck_stat[None, :])
        for t, tr in enumerate(trains):
            col = pd_st[:, t]
            if np.all(np.isnan(col)):
                continue
            speed_rows += [{"effect": name, "train": tr, "speed_kmh": float(v),
                            "phi_dyn": float(p)} for v, p in zip(sk, col, strict=True)]
            i = int(np.nanargmax(col))
            phi_rows.append({"effect": name, "train": tr, "phi_dyn": float(col[i]),
                             "speed_kmh": float(sk[i])})
    envelopes = pd.DataFrame(env_rows)
    if envelopes.empty:
        return "no load effect of the results has a static reference on this deck"
    for name, grp in envelopes.groupby("effect", sort=False):
        if not grp["ratio"].notna().any():  # e.g. the deflection at a support only
            continue
        g = grp.loc[grp["ratio"].idxmax()]
        real_gov = g["ratio"] > 1
        ver_rows.append({
            "effect": name, "location": g["location"], "real_design": g["real_design"],
            "train": g["real_train"], "speed_kmh": g["real_speed_kmh"],
            "lm71_design": g["lm71_design"], "ratio": g["ratio"],
            "governs": REAL_GOVERNS if real_gov else LM71_GOVERNS,
            "margin": g["ratio"] if real_gov else 1.0 / g["ratio"], "units": g["units"],
        })
    rot = []
    if "rotation" in lm71_abs:
        e = envelopes[envelopes["effect"] == "rotation"]
        for end in (0, static.n_supports - 1):
            row = e[np.isclose(e["location"], sup[end])]
            if row.empty:
                continue
            lm = float(row["lm71_design"].iloc[0])
            real = float(row["real_design"].iloc[0])
            th = max(lm, real)   # the design value of 6.4.6.5(3): the more unfavourable
            rot.append({"support": float(sup[end]), "theta_lm71_design": lm,
                        "theta_real_design": real, "theta_design": th,
                        "limit": rot_limit, "utilisation": th / rot_limit,
                        "result": "pass" if th <= rot_limit else "FAIL"})
    deck = {} if all_tracks else _whole_deck(ds, static, isel, phi * alpha, step, model)
    notes = []
    max_span = profile["hslm_b_max_span"]
    if any(t.casefold() == "hslm-b" for t in trains) and not (
            static.n_supports == 2 and static.length < max_span):
        notes.append(f"HSLM-B applies to simply supported spans shorter than "
                     f"{max_span:g} m ({profile.clause('hslm_b_max_span')}); this deck has "
                     f"spans {', '.join(f'{x:g}' for x in static.spans)} m: use HSLM-A")
    factors = {"alpha": alpha, "maintenance": maintenance, "notes": notes,
               "profile": profile, "rotation_clause": "EN 1990 A2.4.4.2.3, " + profile.clause(
                   "end_rotation_limit_abutment"),
               "phi_name": "Φ3" if maintenance == "standard" else "Φ2", "phi": phi,
               "length": lphi.value, "length_rule": lphi.rule,
               "phi2_max": float(_nanmax(phi2, 0)) if phi2.size else np.nan,
               "phi2_note": note, "n_loaded": n_loaded, "lm71_factor": lm_factor,
               "loaded_tracks": ", ".join(str(ds.attrs.get(
                   "loaded_tracks_all" if all_tracks else "loaded_track", 1)).split()),
               # interaction trains on other tracks: every variable holds every train
               "together": ds.attrs.get("other_trains_loading") == "together"}
    return LoadEffectChecks(envelopes, pd.DataFrame(phi_rows), pd.DataFrame(speed_rows),
                            pd.DataFrame(ver_rows), pd.DataFrame(rot), deck, factors)


def _whole_deck(ds, static, isel, factor, step, model: LM71 | None = None) -> dict:
    """Dynamic envelopes of the governing train and LM71 x factor on the whole-deck grid."""
    from vsi_numba.model.influence import influence

    out: dict = {}
    if "deck_x" not in ds.dims:
        return out
    x = np.asarray(ds["deck_x"].values, float)
    keep = np.isfinite(x)
    x = x[keep]
    if x.size == 0:
        return out
    out["x"] = x
    for name, eff, stem in (("moment", "moment", "bending_moment_whole_deck"),
                            ("shear", "shear", "shear_force_whole_deck")):
        if f"max_{stem}" not in ds.variables or eff not in static.effects:
            continue
        hi = ds[f"max_{stem}"].isel(isel).transpose("speed", "train", "irregularity", "deck_x")
        lo = ds[f"min_{stem}"].isel(isel).transpose("speed", "train", "irregularity", "deck_x")
        hi = np.asarray(hi.values, float)[..., keep]
        lo = np.asarray(lo.values, float)[..., keep]
        size = _nanmax(np.fmax(np.abs(hi), np.abs(lo)).reshape(hi.shape[0], hi.shape[1], -1),
                       (0, 2))
        if np.all(np.isnan(size)):
            continue
        t = int(np.nanargmax(size))
        lm = lm71_envelope(lambda xl, eff=eff: influence(static, eff, x, xl),
                           np.concatenate([static.supports, x]), (0.0, static.length),
                           step=step, n_at=x.size, model=model)
        out[name] = {"train": str(ds["train"].values[t]),
                     "dyn_max": _nanmax(hi[:, t].reshape(hi.shape[0], -1, x.size), (0, 1)),
                     "dyn_min": -_nanmax(-lo[:, t].reshape(lo.shape[0], -1, x.size), (0, 1)),
                     "lm71_max": factor * lm.max, "lm71_min": factor * lm.min}
    return out
