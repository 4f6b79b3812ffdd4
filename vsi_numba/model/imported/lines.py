"""Tracks and rails of imported decks: the lines of a modes file or of a station map
tied to tracks, for the contact (track centre) and the deck twist (rails).

Line names
----------
A track named ``T`` (``[bridge] tracks = [{ line = "T" }, ...]``) is read from the lines

- ``T/left`` and ``T/right``: its two rails (left = +y, looking in +x), and/or
- ``T``: its centre line.

The contact line of the track (what the planar vehicle sees, an axle's load shared
equally by the two rails) is the mean of the two rails when both are given, else the
centre line.  The twist needs the rails: ``t(x) = [w_L - w_R](x) - [w_L - w_R](x + 3)``
straight from the rail lines (no gauge enters: the lines are the rails; a model whose
girders are not under the rails should export rail lines through its deck elements).
A track without rail lines has no twist output, and the report says so.

Every line of a modes file or station map is a line along x from the deck's left end
(the same x for every line: a skew deck's lines start at their own first support and
say so with their ``support_x``).  All lines share the modes, normalised once and signed
once (by the contact line of the first track), so that w on one line and w on another
combine.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.model import bridge as _br
from vsi_numba.model import hermite
from vsi_numba.model.deck3d import TWIST_BASE, SpaceModelError, Table, Track, twist_grid
from vsi_numba.model.imported import matrices as _mx
from vsi_numba.model.imported import table as _tb
from vsi_numba.model.imported.common import (
    _check_ends,
    _check_stations,
    _damping,
    _keep,
    _Problems,
    _spline_slopes,
    _supports_from,
)

LEFT, RIGHT = "/left", "/right"


def rail_names(track: str) -> tuple[str, str]:
    """(left, right) line names of the rails of track ``track``."""
    return track + LEFT, track + RIGHT


def _mean_line(a, b):
    """The mean of two Hermite lines (x, values, slopes), on the union of their
    stations (exact: each cubic piece stays a cubic on a sub-interval)."""
    xa, va, sa = a
    xb, vb, sb = b
    x = np.union1d(xa, xb)
    v = 0.5 * (hermite.table(xa, va, sa, x) + hermite.table(xb, vb, sb, x))
    s = 0.5 * (hermite.evaluate(xa, va, sa, x, 1) + hermite.evaluate(xb, vb, sb, x, 1))
    return x, v, s


@dataclass(frozen=True)
class LineDeck3D:
    """An imported deck with its tracks: the contact line of every track (for the
    kernels) and its rails when the data has them.

    Attributes
    ----------
    bridges : tuple of ModalBridge
        Per track, the contact line's modes (kind HERMITE).
    rails : tuple of (Table, Table) or None
        Per track, its (left, right) rail lines, None without rail lines.
    tracks : tuple of Track
    all_frequencies : ndarray
        Every frequency known (Hz).
    static : object or None
        Matrices decks: ``(K, fixed, lines)`` for the static rail deflections
        (:meth:`static_twist_line`); None for modes files (no stiffness).
    warnings : tuple of str
    labels : ndarray or None
        Per track, the y of its centre line (m) that labels it in the results, NaN where
        the configuration does not give it; None: every track's ``eccentricity``.  The
        model never uses it: the lines carry the geometry.
    """

    bridges: tuple
    rails: tuple
    tracks: tuple
    all_frequencies: np.ndarray
    static: object | None = None
    warnings: tuple[str, ...] = ()
    labels: np.ndarray | None = None

    @property
    def eccentricities(self) -> np.ndarray:
        """Per track, the y (m) of :attr:`labels` (NaN: not given)."""
        if self.labels is not None:
            return np.asarray(self.labels, float)
        return np.array([t.eccentricity for t in self.tracks], float)

    @property
    def no_twist(self) -> str:
        """Why the deck has no twist output ("" when every track has its rails)."""
        bare = [t.line for t, r in zip(self.tracks, self.rails, strict=True) if r is None]
        if not bare:
            return ""
        return (f"the data has no rail lines for track(s) {', '.join(map(repr, bare))} "
                f"(lines '{bare[0]}/left' and '{bare[0]}/right'): the deck twist needs the "
                "rails of every track")

    @property
    def n_modes(self) -> int:
        return self.bridges[0].n_modes

    @property
    def frequencies(self) -> np.ndarray:
        return self.bridges[0].frequencies

    @property
    def length(self) -> float:
        return self.bridges[0].length

    @property
    def supports(self) -> np.ndarray:
        return self.bridges[0].supports

    def _k(self, k):
        if not 0 <= k < len(self.tracks):
            raise SpaceModelError(f"train.track = {k + 1}: expected 1 .. {len(self.tracks)} "
                                  f"(bridge.tracks has {len(self.tracks)})")
        return k

    def track_bridge(self, k: int = 0) -> _br.ModalBridge:
        return self.bridges[self._k(k)]

    def track_shapes(self, k: int, x) -> np.ndarray:
        return self.bridges[self._k(k)].shapes(x)

    def _rails(self, k):
        r = self.rails[self._k(k)]
        if r is None:
            name = self.tracks[k].line
            left, right = rail_names(name)
            raise SpaceModelError(
                f"bridge.tracks[{k}] (line '{name}'): the deck twist needs the rail lines "
                f"'{left}' and '{right}' in the modes file / station map; the data has the "
                "track's centre line only")
        return r

    def rail_shapes(self, k: int, x) -> tuple[np.ndarray, np.ndarray]:
        left, right = self._rails(k)
        return left(x), right(x)

    def twist_operator(self, k: int, x, base: float = TWIST_BASE) -> np.ndarray:
        """T (len(x), n_modes): the twist of track ``k`` over [x, x + base] is T q (m)."""
        left, right = self._rails(k)
        x = np.atleast_1d(np.asarray(x, float))
        return (left(x) - right(x)) - (left(x + base) - right(x + base))

    def twist_grid(self, intervals: int = 32, base: float = TWIST_BASE) -> np.ndarray:
        return twist_grid(self.supports, intervals, base)

    def twist_breakpoints(self, at, base: float = TWIST_BASE) -> np.ndarray:
        at = np.atleast_1d(np.asarray(at, float))
        nodes = [t.nodes for r in self.rails if r is not None for t in r]
        return np.unique(np.concatenate([self.supports, at, at + base, *nodes]))

    def static_twist_line(self, k: int, at, base: float = TWIST_BASE,
                          loaded: int | None = None):
        """Influence line of the static twist (m per N) of track ``k`` at the window
        starts ``at`` under a unit downward force on track ``loaded`` (default ``k``),
        half on each rail (or all on the centre line): ``K_ff u = f``, the rails' u read
        at the window ends (linear between stations, as the load is shared).  Matrices
        only: a modes file has no stiffness (refused)."""
        if self.static is None:
            raise SpaceModelError(
                "the static twist of a deck given as a modes table needs its static "
                "response, which the modes do not give (no stiffness): give the deck as "
                "FE matrices (bridge.kind = \"matrices\") with rail lines")
        import scipy.sparse
        import scipy.sparse.linalg

        self._rails(k)
        K, fixed, lines = self.static
        tk = self.tracks[self._k(k)].line
        tl = self.tracks[self._k(k if loaded is None else loaded)].line
        at = np.atleast_1d(np.asarray(at, float))
        n = K.shape[0]
        free = np.setdiff1d(np.arange(n), fixed)
        lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(K)[free][:, free].tocsc())
        left, right = rail_names(tl)
        load_lines = ([(left, 0.5), (right, 0.5)] if left in lines and right in lines
                      else [(tl, 1.0)])
        rl, rr = rail_names(tk)

        def share(x_load, name, weight, F):
            st, dofs = lines[name]
            on = (x_load >= st[0]) & (x_load <= st[-1])
            e = np.clip(np.searchsorted(st, x_load, side="right") - 1, 0, st.size - 2)
            t = np.clip((x_load - st[e]) / (st[e + 1] - st[e]), 0.0, 1.0)
            cols = np.arange(x_load.size)
            np.add.at(F, (dofs[e], cols), weight * (1.0 - t) * on)
            np.add.at(F, (dofs[e + 1], cols), weight * t * on)

        # the twist at the window starts read from u (linear between stations, zero off
        # the lines), t = C^T u = C^T K_ff^-1 f = Z^T f with K_ff Z = C (K symmetric):
        # one solve per window start, not per load position
        C = np.zeros((n, at.size))
        for name, x, wgt in ((rl, at, 1.0), (rr, at, -1.0), (rl, at + base, -1.0),
                             (rr, at + base, 1.0)):
            share(x, name, wgt, C)
        Z = np.zeros((n, at.size))
        Z[free] = lu.solve(np.ascontiguousarray(C[free]))

        def line(x_load):
            x_load = np.atleast_1d(np.asarray(x_load, float))
            F = np.zeros((n, x_load.size))
            for name, wgt in load_lines:
                share(x_load, name, wgt, F)
            return Z.T @ F
        return line


def _tracks_of(tracks) -> tuple[Track, ...]:
    out = []
    for i, t in enumerate(tracks):
        t = t if isinstance(t, Track) else Track(float(t.get("eccentricity", 0.0)),
                                                 line=str(t.get("line", "")))
        if not t.line:
            raise SpaceModelError(f"bridge.tracks[{i}]: an imported deck names each track "
                                  "by its line: { line = \"T\" } (rails 'T/left' and "
                                  "'T/right', or the centre line 'T')")
        out.append(t)
    if not out:
        raise SpaceModelError("bridge.tracks: at least one track { line = \"T\" }")
    return tuple(out)


def _track_names(lines) -> str:
    """The tracks a set of line names offers (a rail line ``T/left`` names track ``T``)."""
    names = dict.fromkeys(n.rsplit("/", 1)[0] if n.endswith((LEFT, RIGHT)) else n
                          for n in lines)
    return ", ".join(repr(n) for n in names) or "none"


def _track_lines(p, key, name, tracks, available):
    """For every track: (contact parts, rails or None); records missing lines."""
    plan = []
    for i, t in enumerate(tracks):
        left, right = rail_names(t.line)
        has_rails = left in available and right in available
        if has_rails:
            plan.append(([left, right], (left, right)))
        elif t.line in available:
            plan.append(([t.line], None))
        else:
            p.add(f"tracks[{i}].line", t.line,
                  f"a track of the {'modes file' if key == 'file' else 'station map'} "
                  f"{name}: its rails '{left}' and '{right}', or its "
                  f"centre line '{t.line}' (tracks found: {_track_names(available)}; "
                  f"lines: {', '.join(repr(a) for a in available)})")
            plan.append(None)
    return plan


def _assemble(tracks, plan, shapes, freqs, zeta, supports, description, all_freqs,
              static=None, warnings=(), effective=None, statics=None):
    """The :class:`LineDeck3D`; ``statics``: per track, the static deck of its load
    effects (:mod:`.effects`) or None."""
    bridges, rails = [], []
    statics = [None] * len(tracks) if statics is None else statics
    for t, (parts, rl), st in zip(tracks, plan, statics, strict=True):
        line = shapes[parts[0]] if len(parts) == 1 else _mean_line(shapes[parts[0]],
                                                                    shapes[parts[1]])
        x, v, s = line
        what = "mean of its rails" if len(parts) == 2 else "centre line"
        bridges.append(_br.ModalBridge(
            kind=_br.HERMITE, length=float(x[-1]), frequencies=freqs, damping=zeta,
            nodes=x, values=np.ascontiguousarray(v), slopes=np.ascontiguousarray(s),
            supports=supports, effective_mass_fraction=effective, static=st,
            description=f"{description}; track '{t.line}' ({what})"))
        rails.append(None if rl is None else tuple(Table(*shapes[r]) for r in rl))
    return LineDeck3D(tuple(bridges), tuple(rails), tracks, all_freqs, static,
                      tuple(warnings))


def read_modes_table_tracks(path, tracks, *, n_modes=None, max_frequency=None,
                            damping_ratio=None, mass_normalised=None, spans=None,
                            name=None) -> LineDeck3D:
    """The tracks of a modes table (netCDF or CSV, see :mod:`vsi_numba.model.imported`)
    whose lines name them (module notes).  Checks as
    :func:`~vsi_numba.model.imported.read_modes_table` on every line used."""
    tracks = _tracks_of(tracks)
    tab, name, p = _tb.open_table(path, name)
    plan = _track_lines(p, "file", name, tracks, list(tab.lines))
    p.raise_if_any()
    f = tab.frequency
    if not np.all(np.isfinite(f)) or np.any(f <= 0):
        p.add("file", name, "natural frequencies > 0 Hz")
    mm = tab.modal_mass
    norm = mass_normalised if mass_normalised is not None else tab.normalised_flag
    if mm is None and not norm:
        p.add("file", name, "a modal_mass per mode (kg) -- or bridge.mass_normalised = true")
    elif mm is not None and (not np.all(np.isfinite(mm)) or np.any(mm <= 0)):
        p.add("file", name, "modal masses > 0 kg")
    z = tab.damping
    if z is not None and (not np.all(np.isfinite(z)) or np.any((z < 0) | (z >= 1))):
        p.add("file", name, "damping ratios 0 <= zeta < 1")
    p.raise_if_any()
    length = float(np.sum(spans)) if spans is not None else None
    used = list(dict.fromkeys(n for parts, _ in plan for n in parts))
    for ln in used:
        line = tab.lines[ln]
        bad = [a for a in (line.shape, line.slope) if a is not None
               and not np.all(np.isfinite(a))]
        if bad:
            p.add("file", name, f"finite mode shapes and slopes on line '{ln}'")
            continue
        if _check_stations(p, "file", name, line.x, ln, length):
            _check_ends(p, "file", name, line.x, line.shape, ln, tab.labels)
    p.raise_if_any()
    order = np.argsort(f, kind="stable")
    n = _keep(f[order], n_modes, max_frequency)
    if n < 1:
        p.add("max_frequency", max_frequency, f"a frequency >= the first mode of {name}")
        p.raise_if_any()
    sel = order[:n]
    scale = 1.0 / np.sqrt(mm[sel]) if mm is not None else np.ones(n)
    shapes = {}
    for ln in used:
        line = tab.lines[ln]
        v = line.shape[:, sel] * scale
        s = line.slope[:, sel] * scale if line.slope is not None else _spline_slopes(line.x, v)
        x = line.x.copy()
        x[0] = 0.0
        if length is not None:
            x[-1] = length
        shapes[ln] = (x, v, s)
    # one sign per mode for every line: the largest value on the first contact line > 0
    first = plan[0][0]
    ref = (shapes[first[0]][1] if len(first) == 1
           else _mean_line(shapes[first[0]], shapes[first[1]])[1])
    sign = np.sign(ref[np.argmax(np.abs(ref), axis=0), np.arange(n)])
    sign[sign == 0] = 1.0
    shapes = {k: (x, v * sign, s * sign) for k, (x, v, s) in shapes.items()}
    warnings: list[str] = []
    zeta = _damping(p, damping_ratio, None if tab.damping is None else tab.damping[order],
                    n, warnings)
    p.raise_if_any()
    x0 = shapes[used[0]][0]
    sup = tab.lines[used[0]].supports
    supports = _supports_from(spans, sup, float(x0[-1]))
    statics = None
    if tab.effects is not None:  # per track, the influence lines of its name
        statics = [_tb._section_forces(tab.effects, sel, scale, sign, t.line, supports)
                   for t in tracks]
        for t, st in zip(tracks, statics, strict=True):
            if isinstance(st, str):
                warnings.append(f"bridge.tracks: the section forces of {name} are not used "
                                f"for track '{t.line}', no bending moments or shear forces "
                                f"with the train on it: {st}")
        statics = [None if isinstance(st, str) else st for st in statics]
    return _assemble(tracks, plan, shapes, f[sel], zeta, supports,
                     f"modes table {name}: {n} modes", np.sort(f), warnings=warnings,
                     statics=statics)


def read_matrices_tracks(stiffness, mass, stations, tracks, *, fixed_dofs=None,
                         dof_base=0, n_modes=10, max_frequency=None, damping_ratio=0.0,
                         rotation_sign=1.0, vertical_dofs=None, spans=None,
                         all_up_to=None, names=None) -> LineDeck3D:
    """The tracks of FE matrices whose station map names lines for them (module notes):
    one eigen-solve (:func:`~vsi_numba.model.imported.modes_from_matrices`), the modes
    tabulated on every line a track uses."""
    tracks = _tracks_of(tracks)
    paths = {"stiffness": Path(stiffness), "mass": Path(mass), "stations": Path(stations)}
    names = {k: str(v) for k, v in paths.items()} | (names or {})
    p = _Problems()
    K = _mx._read_mtx(paths["stiffness"], "stiffness_matrix", names["stiffness"], p)
    M = _mx._read_mtx(paths["mass"], "mass_matrix", names["mass"], p)
    df = _mx._read_station_map(paths["stations"], names["stations"], p, dof_base)
    p.raise_if_any()
    available = [str(v) for v in dict.fromkeys(df["line"])]
    plan = _track_lines(p, "station_map", names["stations"], tracks, available)
    p.raise_if_any()
    used = list(dict.fromkeys(n for parts, _ in plan for n in parts))

    def line_of(ln):
        sub = df[df["line"] == ln].sort_values("x", kind="stable")
        rot = sub["rotation_dof"].to_numpy() if "rotation_dof" in sub.columns else None
        return sub["x"].to_numpy(float), sub["dof"].to_numpy(), rot

    main = used[0]
    fixed = _mx._dof_list(p, "fixed_dofs", [] if fixed_dofs is None else fixed_dofs,
                          dof_base)
    vd = _mx._dof_list(p, "vertical_dofs", vertical_dofs, dof_base, K.shape[0])
    if vd is None and vertical_dofs is None:
        vd = df["dof"].to_numpy()
    x, dofs, rot = line_of(main)
    res = _mx.modes_from_matrices(
        K, M, x, dofs, rot, fixed, n_modes=n_modes, max_frequency=max_frequency,
        damping_ratio=damping_ratio, rotation_sign=rotation_sign, vertical_dofs=vd,
        spans=spans, all_up_to=all_up_to, names=names, line=main, dof_base=dof_base,
        extra_lines={ln: line_of(ln) for ln in used[1:]})
    b = res.bridge
    shapes = {main: (b.nodes, b.values, b.slopes), **res.line_shapes}
    static_lines = {}
    for ln in used:
        xs, ds, _ = line_of(ln)
        xs = xs.copy()
        xs[0] = 0.0
        if spans is not None:
            xs[-1] = float(np.sum(spans))
        static_lines[ln] = (xs, ds)
    static = (K, np.unique(np.asarray(fixed, np.int64)), static_lines)
    return _assemble(tracks, plan, shapes, b.frequencies, b.damping, b.supports,
                     b.description, res.all_frequencies, static, res.warnings,
                     b.effective_mass_fraction)
