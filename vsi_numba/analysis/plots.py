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

from vsi_numba.analysis.checks import COMFORT_LEVELS, resonance_speeds
from vsi_numba.analysis.dataset import bridge_frequencies, prepare

WIDTH = 6.5  # in, text width of an A4 report
HEIGHT = 4.0  # in, one panel
DPI = 150
LIMIT_COLOR = "#c0392b"


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as PNG at :data:`DPI` and return the path."""
    fig.savefig(path, dpi=DPI)
    return Path(path)


def train_colors(trains) -> dict:
    """A distinct colour per train name (tab10, then tab20)."""
    names = [str(t) for t in trains]
    cmap = matplotlib.colormaps["tab10" if len(names) <= 10 else "tab20"]
    return {n: cmap(i % cmap.N) for i, n in enumerate(names)}


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
           band: bool = True):
    """One line per train of ``check[var](speed, train)`` against km/h, CI band if any."""
    colors = train_colors(ds["train"].values)
    x = ds["speed_kmh"].values
    handles = []
    for train in ds["train"].values:
        name = str(train)
        y = check[var].sel(train=train).values * scale
        (h,) = ax.plot(x, y, color=colors[name], linewidth=1.3, label=name, **_marker(ds))
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


def _resonances(ax, ds, k_max: int = 4):
    """Marks v_i = f1 D / i of every train with D > 0 along the top edge of ``ax``."""
    f = bridge_frequencies(ds)
    if not f.size or "train_regular_length" not in ds:
        return None
    colors = train_colors(ds["train"].values)
    lo, hi = float(ds["speed_kmh"].min()), float(ds["speed_kmh"].max())
    tr = blended_transform_factory(ax.transData, ax.transAxes)
    marked = False
    for train in ds["train"].values:
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
    ax.annotate(f"max {fmt.format(y)} {units}\n{a['governing_train']}, {x:.0f} km/h",
                (x, y), xytext=(-40 if right_half else 40, -28), textcoords="offset points",
                ha="right" if right_half else "left", va="top", fontsize=7.5, zorder=8,
                bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.5", "alpha": 0.95},
                arrowprops={"arrowstyle": "-", "color": "0.4", "linewidth": 0.8})


def _legend(fig, ax, handles):
    """Legend below the axes: it never hides a curve, a limit label or a marker."""
    handles = [h for h in handles if h is not None]
    trains = sum(1 for h in handles if h.get_label() and not h.get_label().startswith(
        ("limit", "required", "resonance", "φ")))
    fig.legend(handles=handles, fontsize=7, loc="outside lower center",
               ncols=max(1, min(5, trains if trains > 1 else 2)), frameon=False)


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
    handles.append(_resonances(ax, ds))
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
    handles.append(_resonances(ax, ds))
    _governing(ax, dyn, fmt="{:.3f}")
    ax.set_ylabel("Dynamic increment φ'$_{dyn}$ [–]", fontsize=9)
    ax.set_title("Dynamic increment of the deck displacement, "
                 "max|y$_{dyn}$| / max|y$_{stat}$| − 1", fontsize=10)
    _legend(fig, ax, handles)
    return fig


def plot_wheel_unloading(ds: xr.Dataset, wu: xr.Dataset) -> Figure:
    """Minimum contact force (top) and wheel unloading dQ/Q0 (bottom) vs speed."""
    ds = prepare(ds)
    has_force = "min_contact_force" in wu
    fig, axes = _figure(2 if has_force else 1, 6.0 if has_force else HEIGHT)
    handles = []
    if has_force:
        ax = axes[0]
        handles = _lines(ax, ds, wu, "min_contact_force", scale=1e-3, band=False)
        ax.axhline(0.0, color=LIMIT_COLOR, linestyle="--", linewidth=1.0)
        _label(ax, 0.0, "contact loss (Q = 0)", LIMIT_COLOR)
        lo, hi = ax.get_ylim()
        ax.set_ylim(min(lo, -0.05 * hi), hi)
        ax.set_ylabel("Min. contact force [kN]", fontsize=9)
        ax.set_title("Wheel–rail contact (per axle)", fontsize=10)
    ax = axes[-1]
    h2 = _lines(ax, ds, wu)
    handles = handles or h2
    a = wu.attrs
    lim = _limit(ax, a["limit"], f"limit ΔQ/Q₀ = {a['limit']:g} (EN 14363 practice)")
    ax.set_ylim(0, max(1.0, ax.get_ylim()[1]))
    _governing(ax, wu, fmt="{:.3f}")
    ax.set_ylabel("Wheel unloading ΔQ/Q₀ [–]", fontsize=9)
    if not has_force:
        ax.set_title("Wheel unloading", fontsize=10)
    _legend(fig, axes[0], [*handles, lim])
    return fig


def plot_comfort(ds: xr.Dataset, cf: xr.Dataset) -> Figure:
    """Car-body vertical acceleration vs speed with the EN 1990 Table A2.9 levels."""
    ds = prepare(ds)
    fig, (ax,) = _figure()
    handles = _lines(ax, ds, cf)
    required = cf.attrs.get("required_level", "")
    styles = {"very good": ":", "good": "-.", "acceptable": "--"}
    for name, value in COMFORT_LEVELS.items():
        color = LIMIT_COLOR if name == required else "0.35"
        h = _limit(ax, value, f"{name} ≤ {value:g} m/s²", color=color, style=styles[name])
        if name == required:
            h.set_label(f"required: {name} ≤ {value:g} m/s² (EN 1990 Table A2.9)")
            handles.append(h)
    peak = float(cf["value"].max()) if bool(cf["value"].notnull().any()) else 0.0
    top = max(2.45, 1.2 * peak)  # room above the 2.0 level for its label and the markers
    ax.set_ylim(0, top)
    handles.append(_resonances(ax, ds))
    _governing(ax, cf, units="m/s²")
    ax.set_ylabel("Car-body acceleration $b_v$ [m/s²]", fontsize=9)
    ax.set_title("Passenger comfort: vertical car-body acceleration", fontsize=10)
    _legend(fig, ax, handles)
    return fig


def plot_time_history(
    ds: xr.Dataset, train, speed: float, irregularity: int, point: float,
    wheel: int | None = None, limit: float | None = None,
) -> Figure:
    """Time histories of one case.

    Deck displacement and acceleration at ``point`` (and the contact force of ``wheel``)
    against time.
    """
    ds = prepare(ds)
    case = ds.sel(train=train, speed=speed, irregularity=irregularity)
    panels = [n for n in ("deck_displacement", "deck_acceleration") if n in case]
    if wheel is not None and wheel >= 0 and "contact_force" in case:
        panels.append("contact_force")
    fig = new_figure(2.1 * len(panels) + 0.8)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    t = case["time"].values
    for ax, name in zip(axes, panels, strict=True):
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
            y = case[name].sel(wheel=wheel).values * 1e-3
            ax.plot(t, y, color="C2", linewidth=0.8)
            if "static_wheel_load" in ds:
                q0 = float(ds["static_wheel_load"].sel(train=train, wheel=wheel)) * 1e-3
                ax.axhline(q0, color="0.4", linestyle=":", linewidth=1.0)
                _label(ax, q0, f"Q₀ = {q0:.0f} kN", "0.3")
            ax.axhline(0.0, color=LIMIT_COLOR, linestyle="--", linewidth=1.0)
            ax.set_ylabel(f"Contact force\naxle {wheel} [kN]", fontsize=9)
    axes[-1].set_xlabel("Time [s]", fontsize=9)
    kmh = float(case["speed_kmh"])
    irr = "deterministic track" if int(irregularity) == -1 else f"irregularity seed {irregularity}"
    name = str(train) if len(str(train)) <= 60 else str(train)[:57] + "…"
    fig.suptitle(f"{name} at {kmh:.0f} km/h\ndeck point x = {point:g} m, {irr}", fontsize=10)
    return fig
