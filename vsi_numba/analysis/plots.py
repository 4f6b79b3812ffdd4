"""Figures of the checks (matplotlib, object-oriented API, Agg canvas; no pyplot state).

Figures are attached to an Agg canvas explicitly and pyplot is never imported, so making
them neither needs a display nor changes the user's global matplotlib backend.

Every function takes the prepared results Dataset and the check Dataset(s) of
:mod:`vsi_numba.analysis.checks` and returns a :class:`matplotlib.figure.Figure` sized for
print (6.5 in wide, 150 dpi when saved with :func:`save`). Speeds are shown in km/h,
values in the units named on each axis.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.transforms import blended_transform_factory

from vsi_numba.analysis.checks import profile_of, resonance_speeds
from vsi_numba.analysis.dataset import bridge_frequencies, prepare
from vsi_numba.analysis.figure_file import savefig
from vsi_numba.analysis.sanitize import MATH_GID
from vsi_numba.en1990 import comfort_levels

WIDTH = 6.5  # in, text width of an A4 report
HEIGHT = 4.0  # in, one panel
DPI = 150
LIMIT_COLOR = "#c0392b"


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as PNG at :data:`DPI` (whole or not at all) and return the path."""
    from vsi_numba.io.atomic import write_atomic

    return write_atomic(path, lambda tmp: savefig(fig, tmp, dpi=DPI))


def train_colors(trains) -> dict:
    """A distinct colour per train name (tab10, then tab20)."""
    names = [str(t) for t in trains]
    cmap = matplotlib.colormaps["tab10" if len(names) <= 10 else "tab20"]
    return {n: cmap(i % cmap.N) for i, n in enumerate(names)}


#: Line styles cycled over the trains with the colours, so curves stay apart in print
#: (and in grey): solid, dashed, dash-dot, dotted, long dash, dash-dot-dot.
LINE_STYLES = ("-", (0, (5, 2)), (0, (6, 2, 1.5, 2)), (0, (1.2, 1.6)), (0, (10, 3)),
               (0, (6, 2, 1.5, 2, 1.5, 2)))

#: Markers cycled over the trains (drawn every few points), a third distinction.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "h")


def train_styles(trains) -> dict:
    """Per train name: ``color``, ``linestyle`` and ``marker`` (colour, dash and marker
    all differ between neighbours of the list)."""
    colors = train_colors(trains)
    names = [str(t) for t in trains]
    return {n: {"color": colors[n], "linestyle": LINE_STYLES[i % len(LINE_STYLES)],
                "marker": MARKERS[i % len(MARKERS)]} for i, n in enumerate(names)}


def new_figure(height: float = HEIGHT) -> Figure:
    """A print-sized Figure on an Agg canvas."""
    fig = Figure(figsize=(WIDTH, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _figure(nrows: int = 1, height: float = HEIGHT):
    fig = new_figure(height)
    axes = fig.subplots(nrows, 1, sharex=True, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, color="0.85", linewidth=0.6)
        ax.tick_params(labelsize=8)
    axes[-1].set_xlabel("Speed [km/h]", fontsize=9)
    return fig, axes


def _marker(ds) -> dict:
    return {"marker": "o", "markersize": 3} if ds.sizes["speed"] <= 25 else {}


def _lines(ax, ds, check: xr.Dataset, var: str = "value", scale: float = 1.0,
           band: bool = True, trains=None):
    """One line per train of ``check[var](speed, train)`` against km/h, CI band if any.

    ``trains``: the trains to draw (default all); colours stay those of the whole study.
    """
    styles = train_styles(ds["train"].values)
    colors = {n: st["color"] for n, st in styles.items()}
    x = ds["speed_kmh"].values
    handles = []
    every = max(1, x.size // 10)
    for train in (ds["train"].values if trains is None else trains):
        name = str(train)
        y = check[var].sel(train=train).values * scale
        if not np.isfinite(y).any():
            continue  # no curve: no legend entry
        st = styles[name]
        marker = _marker(ds) or {"marker": st["marker"], "markersize": 3.5,
                                 "markevery": (list(styles).index(name) % every, every)}
        if "marker" in marker:
            marker = {**marker, "marker": st["marker"]}
        (h,) = ax.plot(x, y, color=st["color"], linestyle=st["linestyle"], linewidth=1.3,
                       label=name, markerfacecolor="white", markeredgewidth=0.9, **marker)
        handles.append(h)
        if band and "ci_low" in check and bool(check["ci_low"].sel(train=train).notnull().any()):
            ax.fill_between(x, check["ci_low"].sel(train=train).values * scale,
                            check["ci_high"].sel(train=train).values * scale,
                            color=colors[name], alpha=0.15, linewidth=0)
    return handles


_LABEL_BOX = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85}


def _label(ax, y: float, text: str, color, left: bool = True):
    """Text on a horizontal line at ``y``, at the left (or right) end, over the curves."""
    tr = blended_transform_factory(ax.transAxes, ax.transData)
    ax.text(0.01 if left else 0.99, y, text, transform=tr, ha="left" if left else "right",
            va="bottom", fontsize=7.5, color=color, bbox=_LABEL_BOX, zorder=6)


def _limit(ax, value: float, text: str, color: str = LIMIT_COLOR, style: str = "--",
           left: bool = True):
    """Horizontal limit line, labelled on the plot and returned as a legend handle."""
    ax.axhline(value, color=color, linestyle=style, linewidth=1.2, zorder=4)
    _label(ax, value, text, color, left)
    return Line2D([], [], color=color, linestyle=style, linewidth=1.2, label=text)


def _resonances(ax, ds, k_max: int = 4, handles=None):
    """Marks v_i = f1 D / i of every train with D > 0 along the top edge of ``ax``
    (only the trains with a curve among ``handles``, when given)."""
    f = bridge_frequencies(ds)
    if not f.size or "train_regular_length" not in ds:
        return None
    colors = train_colors(ds["train"].values)
    lo, hi = float(ds["speed_kmh"].min()), float(ds["speed_kmh"].max())
    tr = blended_transform_factory(ax.transData, ax.transAxes)
    marked = False
    drawn = None if handles is None else {h.get_label() for h in handles if h is not None}
    for train in ds["train"].values:
        if drawn is not None and str(train) not in drawn:
            continue
        D = float(ds["train_regular_length"].sel(train=train))
        res = resonance_speeds(f[0], D, k_max)
        v = res["speed_kmh"].to_numpy()
        inside = (v >= lo) & (v <= hi)
        if inside.any():
            ax.plot(v[inside], np.full(inside.sum(), 0.985), linestyle="none", marker="v",
                    markersize=6, color=colors[str(train)], transform=tr, clip_on=False,
                    markeredgecolor="black", markeredgewidth=0.4)
            if ds.sizes["train"] <= 3:  # order labels only while they cannot collide
                for vi, i in zip(v[inside], res["i"].to_numpy()[inside], strict=True):
                    ax.text(vi, 0.955, f"i={i}", transform=tr, fontsize=6, ha="center",
                            va="top", color="0.25")
            marked = True
    if not marked:
        return None
    return Line2D([], [], linestyle="none", marker="v", color="0.5", markeredgecolor="black",
                  markeredgewidth=0.4, label=f"resonance $v_i = f_1 D/i$ ($f_1$ = {f[0]:.2f} Hz)")


def _governing(ax, check: xr.Dataset, scale: float = 1.0, fmt: str = "{:.3g}",
               units: str = ""):
    a = check.attrs
    if not a.get("governing_train"):
        return
    x, y = a["governing_speed_kmh"], a["value"] * scale
    ax.plot([x], [y], marker="*", markersize=11, color="gold", markeredgecolor="black",
            markeredgewidth=0.6, zorder=7, linestyle="none")
    lo, hi = ax.get_xlim()
    right_half = x > 0.5 * (lo + hi)
    y_lo, y_hi = ax.get_ylim()
    low = y < y_lo + 0.5 * (y_hi - y_lo)  # box above a low point: clear of the tick labels
    ax.annotate(f"max {fmt.format(y)} {units}\n{a['governing_train']}, {x:.0f} km/h",
                (x, y), xytext=(-40 if right_half else 40, 28 if low else -28),
                textcoords="offset points", ha="right" if right_half else "left",
                va="bottom" if low else "top", fontsize=7.5, zorder=8,
                bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.5", "alpha": 0.95},
                arrowprops={"arrowstyle": "-", "color": "0.4", "linewidth": 0.8})


def _legend(fig, ax, handles):
    """Legend below the axes: it never hides a curve, a limit label or a marker."""
    handles = [h for h in handles if h is not None]
    trains = sum(1 for h in handles if h.get_label() and not h.get_label().startswith(
        ("limit", "required", "resonance", "φ")))
    # as many columns as fit the figure's width (a legend wider than the figure is cut)
    longest = max((len(h.get_label()) for h in handles), default=1)
    fit = max(1, int(fig.get_figwidth() / (0.055 * longest + 0.45)))
    fig.legend(handles=handles, fontsize=7, loc="outside lower center",
               ncols=max(1, min(5, trains if trains > 1 else 2, fit)), frameon=False)


def _headroom(ax, top_fraction: float = 0.12):
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + top_fraction * (hi - lo))


def plot_deck_acceleration(ds: xr.Dataset, check: xr.Dataset) -> Figure:
    """Peak deck acceleration vs speed per train, limit line, resonance speeds."""
    ds = prepare(ds)
    fig, (ax,) = _figure()
    handles = _lines(ax, ds, check)
    a = check.attrs
    handles.append(_limit(ax, a["limit"], f"limit {a['limit']:g} m/s² ({a['track_type']}, "
                                           "EN 1990 A2.4.4.2.1)"))
    ax.set_ylim(bottom=0)
    _headroom(ax, 0.18)
    handles.append(_resonances(ax, ds, handles=handles))
    _governing(ax, check, units="m/s²")
    ax.set_ylabel("Peak deck acceleration [m/s²]", fontsize=9)
    title = "Vertical deck acceleration"
    if np.isfinite(a.get("frequency_cutoff", np.nan)):
        title += f" (modes ≤ {a['frequency_cutoff']:.1f} Hz)"
    ax.set_title(title, fontsize=10)
    _legend(fig, ax, handles)
    return fig


def plot_dynamic_amplification(ds: xr.Dataset, dyn: xr.Dataset) -> Figure:
    """Deck dynamic increment phi'_dyn vs speed per train, with phi''/2."""
    ds = prepare(ds)
    fig, (ax,) = _figure()
    handles = _lines(ax, ds, dyn, band=False)
    if bool(dyn["phi2"].notnull().any()):
        (h,) = ax.plot(ds["speed_kmh"].values, dyn["phi2"].values / 2, color="black",
                       linestyle=":", linewidth=1.2, label="φ''/2 (EN 1991-2 Annex C)")
        handles.append(h)
    ax.axhline(0.0, color="0.4", linewidth=0.8)
    _headroom(ax, 0.18)
    handles.append(_resonances(ax, ds, handles=handles))
    _governing(ax, dyn, fmt="{:.3f}")
    ax.set_ylabel("Dynamic increment φ'$_{dyn}$ [–]", fontsize=9, gid=MATH_GID)
    ax.set_title("Dynamic increment of the deck displacement, "
                 "max|y$_{dyn}$| / max|y$_{stat}$| − 1", fontsize=10, gid=MATH_GID)
    _legend(fig, ax, handles)
    return fig


def plot_wheel_unloading(ds: xr.Dataset, wu: xr.Dataset, zones: xr.Dataset | None = None
                         ) -> Figure:
    """Minimum contact force (top) and wheel unloading dQ/Q0 (bottom) vs speed.

    ``zones`` (:func:`vsi_numba.analysis.report.tables.wheel_unloading_by_zone`): dQ/Q0
    of the axles whose minimum lay on the approach track is drawn too (thin, dotted), so
    an approach-track maximum is not read as the bridge's.
    """
    ds = prepare(ds)
    has_force = "min_contact_force" in wu
    fig, axes = _figure(2 if has_force else 1, 6.0 if has_force else HEIGHT)
    trains = list(ds["train"].values)
    if "applicable" in wu:  # trains with prescribed forces (moving forces) are left out
        trains = [t for t in trains if bool(wu["applicable"].sel(train=t))]
    skipped = wu.attrs.get("not_applicable_trains", "")
    if len(skipped) > 70:
        names = skipped.split(", ")
        skipped = f"{len(names)} trains ({names[0]} … {names[-1]})"
    handles = []
    if has_force:
        ax = axes[0]
        handles = _lines(ax, ds, wu, "min_contact_force", scale=1e-3, band=False,
                         trains=trains)
        ax.axhline(0.0, color=LIMIT_COLOR, linestyle="--", linewidth=1.0)
        _label(ax, 0.0, "contact loss (Q = 0)", LIMIT_COLOR)
        lo, hi = ax.get_ylim()
        ax.set_ylim(min(lo, -0.05 * hi), hi)
        ax.set_ylabel("Min. contact force [kN]", fontsize=9)
        ax.set_title("Wheel–rail contact (per axle)", fontsize=10)
    ax = axes[-1]
    h2 = _lines(ax, ds, wu, trains=trains)
    handles = handles or h2
    if zones is not None:
        styles = train_styles(ds["train"].values)
        x = ds["speed_kmh"].values
        several = ds.sizes.get("irregularity", 1) > 1
        for zone, style, text in (("deck", (0, (4, 1.5, 1, 1.5)), "on the deck"),
                                  ("approach", ":", "off the deck")):
            if not bool(zones[zone].notnull().any()):
                continue
            for train in trains:
                y = zones[zone].sel(train=train).values
                if np.isfinite(y).any():
                    ax.plot(x, y, color=styles[str(train)]["color"], linestyle=style,
                            linewidth=0.9)
            handles = [*handles, Line2D(
                [], [], color="0.3", linestyle=style, linewidth=0.9,
                label=f"ΔQ/Q₀, minimum {text}" + (" (worst realisation)" if several else ""))]
    a = wu.attrs
    lim = _limit(ax, a["limit"], f"limit ΔQ/Q₀ = {a['limit']:g} (EN 14363 practice)")
    ax.set_ylim(0, max(1.0, ax.get_ylim()[1]))
    _governing(ax, wu, fmt="{:.3f}")
    ax.set_ylabel("Wheel unloading ΔQ/Q₀ [–]", fontsize=9)
    if not has_force:
        ax.set_title("Wheel unloading", fontsize=10)
    if skipped:
        axes[0].set_title(axes[0].get_title() + f"\nnot applicable (prescribed moving forces): "
                          f"{skipped}", fontsize=9)
    _legend(fig, axes[0], [*handles, lim])
    return fig


def plot_comfort(ds: xr.Dataset, cf: xr.Dataset) -> Figure:
    """Car-body vertical acceleration vs speed with the EN 1990 Table A2.9 levels (those
    of the results' code profile)."""
    ds = prepare(ds)
    fig, (ax,) = _figure()
    handles = _lines(ax, ds, cf)
    required = cf.attrs.get("required_level", "")
    styles = {"very good": ":", "good": "-.", "acceptable": "--"}
    for name, value in comfort_levels(profile_of(ds)).items():
        color = LIMIT_COLOR if name == required else "0.35"
        h = _limit(ax, value, f"{name} ≤ {value:g} m/s²", color=color, style=styles[name])
        if name == required:
            h.set_label(f"required: {name} ≤ {value:g} m/s² (EN 1990 Table A2.9)")
            handles.append(h)
    peak = float(cf["value"].max()) if bool(cf["value"].notnull().any()) else 0.0
    top = max(2.45, 1.2 * peak)  # room above the 2.0 level for its label and the markers
    ax.set_ylim(0, top)
    handles.append(_resonances(ax, ds, handles=handles))
    _governing(ax, cf, units="m/s²")
    ax.set_ylabel("Car-body acceleration $b_v$ [m/s²]", fontsize=9, gid=MATH_GID)
    ax.set_title("Passenger comfort: vertical car-body acceleration", fontsize=10)
    _legend(fig, ax, handles)
    return fig


def case_title(train, speed_kmh: float, irregularity: int, point: float | None = None) -> str:
    """Two-line title naming a case: train, speed, deck point, track."""
    irr = "deterministic track" if int(irregularity) == -1 else f"irregularity seed {irregularity}"
    name = str(train) if len(str(train)) <= 60 else str(train)[:57] + "…"
    where = f"deck point x = {point:g} m, " if point is not None else ""
    return f"{name} at {speed_kmh:.0f} km/h\n{where}{irr}"


def plot_case_history(
    case: xr.Dataset, title: str, point: float | None = None, wheel: int | None = None,
    limit: float | None = None, q0: float | None = None, min_position: float | None = None,
    bridge_length: float | None = None, speed: float | None = None,
) -> Figure:
    """Time histories of one case (stored or re-run).

    Parameters
    ----------
    case : xarray.Dataset
        One case: ``deck_displacement``/``deck_acceleration`` on ``(time, point)``,
        ``contact_force`` on ``(time, wheel)`` (any of them may be missing).
    title : str
        Figure title.
    point : float, optional
        Deck point (m) of the deck panels; None: no deck panels.
    wheel : int, optional
        Wheel (axle) of the contact-force panel; None: no contact panel.
    limit : float, optional
        Deck acceleration limit (m s-2), drawn as ±limit.
    q0 : float, optional
        Static wheel load (N), drawn as a reference line.
    min_position : float, optional
        Position along the track (m) of the wheel at its minimum contact force (the
        envelope ``position_of_min_contact_force``): the minimum is marked and labelled
        with it.
    bridge_length, speed : float, optional
        Deck length (m) and speed (m s-1): with ``min_position``, the time the wheel is on
        the deck (x from 0 to L) is shaded, from x(t) = x_min + v (t - t_min).

    Returns
    -------
    matplotlib.figure.Figure
    """
    panels = []
    if point is not None:
        panels += [n for n in ("deck_displacement", "deck_acceleration") if n in case]
    if wheel is not None and wheel >= 0 and "contact_force" in case:
        panels.append("contact_force")
    fig = new_figure(2.1 * max(len(panels), 1) + 0.8)
    axes = fig.subplots(max(len(panels), 1), 1, sharex=True, squeeze=False)[:, 0]
    t = np.asarray(case["time"].values, float)
    for ax, name in zip(axes, panels, strict=False):
        ax.grid(True, color="0.85", linewidth=0.6)
        ax.tick_params(labelsize=8)
        if name == "deck_displacement":
            y = case[name].sel(point=point).values * 1e3
            ax.plot(t, y, color="C0", linewidth=1.0)
            ax.set_ylabel("Deck displ. [mm]\n(+ down)", fontsize=9)
        elif name == "deck_acceleration":
            y = case[name].sel(point=point).values
            ax.plot(t, y, color="C1", linewidth=0.8)
            if limit is not None:
                _limit(ax, limit, f"±{limit:g} m/s²")
                ax.axhline(-limit, color=LIMIT_COLOR, linestyle="--", linewidth=1.2)
                lo, hi = ax.get_ylim()
                m = max(abs(lo), abs(hi), 1.1 * limit)
                ax.set_ylim(-m, m)
            ax.set_ylabel("Deck accel. [m/s²]\n(+ down)", fontsize=9)
        else:
            y = np.asarray(case[name].sel(wheel=wheel).values, float) * 1e-3
            ax.plot(t, y, color="C2", linewidth=0.8)
            if q0 is not None and np.isfinite(q0):
                ax.axhline(q0 * 1e-3, color="0.4", linestyle=":", linewidth=1.0)
                _label(ax, q0 * 1e-3, f"Q₀ = {q0 * 1e-3:.0f} kN", "0.3")
            ax.axhline(0.0, color=LIMIT_COLOR, linestyle="--", linewidth=1.0)
            if min_position is not None and np.isfinite(min_position) and np.isfinite(y).any():
                _mark_minimum(ax, t, y, float(min_position), bridge_length, speed)
            ax.set_ylabel(f"Contact force\naxle {wheel} [kN]", fontsize=9)
    axes[-1].set_xlabel("Time [s]", fontsize=9)
    fig.suptitle(title, fontsize=10)
    return fig


def _mark_minimum(ax, t, y, x_min: float, length, speed):
    """Star at the minimum contact force, labelled with the wheel's track position."""
    k = int(np.nanargmin(y))
    t_min, q_min = t[k], y[k]
    if length is not None and speed is not None and np.isfinite(length) and speed > 0:
        t_on = t_min - x_min / speed
        t_off = t_min + (float(length) - x_min) / speed
        ax.axvspan(t_on, t_off, color="0.5", alpha=0.12, linewidth=0, zorder=0,
                   label="axle on the deck")
        tr = blended_transform_factory(ax.transData, ax.transAxes)
        ax.text(0.5 * (t_on + t_off), 0.97, "axle on the deck", transform=tr, ha="center",
                va="top", fontsize=7, color="0.3")
    ax.plot([t_min], [q_min], marker="*", markersize=11, color="gold", markeredgecolor="black",
            markeredgewidth=0.6, zorder=7, linestyle="none")
    lo, hi = ax.get_xlim()
    right = t_min > 0.5 * (lo + hi)
    ax.annotate(f"min {q_min:.1f} kN\nat x = {x_min:.2f} m", (t_min, q_min),
                xytext=(-30 if right else 30, 12), textcoords="offset points",
                ha="right" if right else "left", va="bottom", fontsize=7.5, zorder=8,
                bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.5", "alpha": 0.95},
                arrowprops={"arrowstyle": "-", "color": "0.4", "linewidth": 0.8})
