"""The figures and result tables of the gallery (docs/gallery.md), from real runs.

Every bundled config in ``configs/`` runs through the public path, as the gallery says
(``vsi sweep CONFIG -o OUT``, or ``vsi run`` where the config's header says so), into a
temporary directory; the script then reads the netCDF results and writes, beside
itself,

* ``<config>.png``: one figure per config (matplotlib, Agg canvas);
* ``<config>.csv``: its main results, one row per check of
  :func:`vsi_numba.analysis.summary_table` that applies (value, limit, result, governing
  train and speed), and for a deck in space the twist and the acceleration along each
  track (:func:`vsi_numba.analysis.checks.twist.twist_checks`).

Usage (from the repository root; about 2 minutes on 2 cores with a warm numba cache)::

    python docs/gallery/make_figures.py [CONFIG_STEM ...]

The docs build does not run it: the PNG and CSV files are committed, and
``tests/test_gallery.py`` recomputes the CSV tables (the same commands and
:func:`results_rows`, no figure) and compares them with the committed ones.
"""

from __future__ import annotations

import argparse
import csv
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vsi_numba.analysis import run_checks, summary_table
from vsi_numba.analysis.checks.load_effects import load_effect_checks
from vsi_numba.analysis.checks.twist import twist_checks

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WIDTH, DPI = 6.5, 150  # in, dots per inch: the size of the report's figures


def run_vsi(command: str, config: Path, out: Path) -> None:
    """``vsi COMMAND CONFIG -o OUT`` as a subprocess (the public command line)."""
    cmd = [sys.executable, "-m", "vsi_numba.cli", command, str(config), "-o", str(out)]
    if command != "modes":
        cmd.append("--quiet")
    res = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if res.returncode not in (0, 1) or not out.exists():  # 1: a check failed (a result)
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {res.returncode}):\n{res.stderr}")


# ------------------------------------------------------------------------ tables


def _num(x: float, digits: int = 3) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:#.{digits}g}".rstrip(".")


def _value(value: float, units: str) -> str:
    if units == "m":
        return f"{_num(value * 1e3)} mm"
    if units == "m s-2":
        return f"{_num(value)} m/s²"
    if units == "N m":
        return f"{_num(value / 1e3)} kN m"
    return _num(value)


def results_rows(ds) -> list[dict]:
    """The main results of a results file: the checks that apply, then the twist and
    the acceleration along each track of a deck in space."""
    rows = []
    for _, r in summary_table(run_checks(ds)).iterrows():
        if r["result"] == "n/a":
            continue
        speed = float(r["governing_speed_kmh"])
        rows.append({
            "result": str(r["check"]), "value": _value(float(r["value"]), str(r["units"])),
            "limit": _value(float(r["limit"]), str(r["units"]))
            if math.isfinite(float(r["limit"])) else "-",
            "verdict": str(r["result"]),
            "where": f"{r['governing_train']}, {speed:g} km/h" if math.isfinite(speed)
            else "-"})
    tw = twist_checks(ds)
    if not isinstance(tw, str):
        for k, value, train, speed, at in tw.dynamic:
            rows.append({"result": f"Deck twist over 3 m, track {k} (dynamic runs)",
                         "value": _value(value, "m"), "limit": _value(tw.limit, "m"),
                         "verdict": "pass" if value <= tw.limit else "FAIL",
                         "where": f"{train}, {speed:g} km/h, window from x = {at:.1f} m"})
        for c in tw.static:
            if c.track == c.loaded:
                rows.append({
                    "result": f"Deck twist over 3 m, track {c.track} (LM71 × Φ × α on it)",
                    "value": _value(c.value, "m"), "limit": _value(c.limit, "m"),
                    "verdict": "pass" if c.value <= c.limit else "FAIL",
                    "where": f"Φ = {c.phi:.3f}, α = {c.alpha:g}, window from "
                             f"x = {c.at:.1f} m"})
        le = {"": load_effect_checks(ds), " (both tracks loaded)":
              load_effect_checks(ds, all_tracks=True)}
        for what, c in le.items():
            if isinstance(c, str):
                continue
            for r in c.verdict.itertuples(index=False):
                if r.effect != "moment":
                    continue
                rows.append({
                    "result": f"Bending moment, EN 1991-2 6.4.6.5(3){what}",
                    "value": _value(r.real_design, "N m"),
                    "limit": _value(r.lm71_design, "N m") + " (Φ × α × LM71)",
                    "verdict": r.governs,
                    "where": f"{r.train}, {r.speed_kmh:g} km/h, x = {r.location:g} m"})
        for k, value, train, speed, x in tw.acceleration:
            rows.append({"result": f"Peak deck acceleration along track {k}",
                         "value": _value(value, "m s-2"),
                         "limit": _value(tw.acceleration_limit, "m s-2"),
                         "verdict": "pass" if value <= tw.acceleration_limit else "FAIL",
                         "where": f"{train}, {speed:g} km/h, x = {x:.1f} m"})
    return rows


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", encoding="utf-8", newline="") as fh:
        w = csv.DictWriter(fh, ["result", "value", "limit", "verdict", "where"],
                           lineterminator="\n")
        w.writeheader()
        w.writerows(rows)


# ------------------------------------------------------------------------ figures


def _figure(nrows: int, height: float = 3.2):
    fig = Figure(figsize=(WIDTH, height * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, 1, squeeze=False)[:, 0]


def _limit_of(ds) -> float:
    """The deck-acceleration limit the checks of ``ds`` use (m s-2)."""
    return float(run_checks(ds)["deck_acceleration"].attrs["limit"])


def _limit_line(ax, value: float, text: str):
    """A dashed limit line, labelled under its right end; the axis starts at 0 (or keeps
    its log scale) and leaves room above the line."""
    ax.axhline(value, color="#c0392b", ls="--", lw=1.2)
    ax.annotate(text, (0.99, value), xycoords=("axes fraction", "data"), color="#c0392b",
                fontsize=8, ha="right", va="top", xytext=(0, -2), textcoords="offset points")
    if ax.get_yscale() == "linear":
        ax.set_ylim(0, max(ax.get_ylim()[1], 1.3 * value))


def _per_train(ax, ds, var: str):
    """One line per train of ``var`` (max over the track realisations) against the
    speed."""
    da = ds[var].max("irregularity")
    kmh = ds["speed_kmh"].values
    for t in ds["train"].values:
        ax.plot(kmh, da.sel(train=t).values, lw=1.0, label=str(t))
    ax.set_xlabel("speed (km/h)")
    ax.grid(alpha=0.3)


def _legend(ax, n: int):
    ax.legend(fontsize=7, ncol=5 if n > 5 else n, loc="upper left", frameon=False)


def acceleration_vs_speed(ds, title: str, log: bool = False):
    """Peak deck acceleration (whole deck) against the speed, one line per train."""
    fig, (ax,) = _figure(1, 3.6)
    _per_train(ax, ds, "max_deck_acceleration_whole_deck")
    if log:
        ax.set_yscale("log")
    limit = _limit_of(ds)
    _limit_line(ax, limit, f"limit {limit:g} m/s²")
    ax.set_ylabel("peak deck acceleration (m/s²)")
    ax.set_title(title, fontsize=10)
    _legend(ax, ds.sizes["train"])
    return fig


def hslm_25m(ds):
    return acceleration_vs_speed(ds, "HSLM-A1..A10 on the light 25 m span (whole deck, "
                                     "log scale)", log=True)


def viaduct(ds):
    return acceleration_vs_speed(ds, "HSLM-A1..A10 on the 25 + 32 + 25 m viaduct "
                                     "(whole deck)")


def double_track(ds):
    """Acceleration of the axis vs speed, twist per track vs speed, acceleration along
    each track vs x, and the bending moment at the central mid-span with one and with
    both tracks loaded vs speed."""
    fig, (a1, a2, a3, a4) = _figure(4, 2.9)
    _per_train(a1, ds, "max_deck_acceleration_whole_deck")
    limit = _limit_of(ds)
    _limit_line(a1, limit, f"limit {limit:g} m/s²")
    a1.set_ylabel("peak deck acc. (m/s²),\nwhole deck, axis")
    a1.set_title("HSLM-A1..A4 on track 1 of the double-track viaduct", fontsize=10)
    _legend(a1, ds.sizes["train"])
    tw = twist_checks(ds)
    kmh = ds["speed_kmh"].values
    twist = ds["max_deck_twist_whole_deck"].max(["train", "irregularity", "twist_x"])
    ecc = ds["track_eccentricity"]
    for k, style in zip(ds["track"].values, ("-", "--"), strict=False):
        a2.plot(kmh, twist.sel(track=k).values * 1e3, style, lw=1.4,
                label=f"track {k} (y = {float(ecc.sel(track=k)):+g} m)")
    a2.set_xlabel("speed (km/h)")
    a2.set_ylabel("max deck twist over 3 m\n(mm, all trains)")
    a2.set_ylim(0, 1.4 * float(twist.max()) * 1e3)
    a2.annotate(f"limit {tw.limit * 1e3:g} mm (line speed {tw.line_speed_kmh:g} km/h), "
                "off the scale; both tracks twist alike (s Δθ)", (0.99, 0.95),
                xycoords="axes fraction", ha="right", va="top", fontsize=8, color="#c0392b")
    a2.grid(alpha=0.3)
    a2.legend(fontsize=7, loc="lower left", frameon=False, ncol=2)
    acc = ds["max_track_acceleration"].max(["train", "speed", "irregularity"])
    axis = ds["max_deck_acceleration"].max(["train", "speed", "irregularity"])
    x = ds["point"].values
    width = 2.2  # m, bar width on the x axis
    a3.bar(x - width, axis.values, width, color="0.55", label="deck axis (y = 0)")
    for j, k in enumerate(ds["track"].values):
        a3.bar(x + j * width, acc.sel(track=k).values, width,
               label=f"track {k} (y = {float(ecc.sel(track=k)):+g} m)")
    for s in ds["support"].values:
        a3.axvline(float(s), color="0.3", lw=0.8, ls=":")
    _limit_line(a3, limit, f"limit {limit:g} m/s²")
    a3.set_xticks(x)
    a3.set_xlabel("output point x along the deck (m); dotted: supports")
    a3.set_ylabel("peak deck acc. (m/s²),\nall trains and speeds")
    a3.grid(alpha=0.3, axis="y")
    a3.legend(fontsize=7, loc="upper left", frameon=False, ncol=3)
    mid = int(np.argmin(np.abs(x - 41.0)))
    for sfx, style, what in (("", "-", "train on track 1"),
                             ("_all_tracks", "--", "trains meeting on tracks 1 and 2")):
        m = ds[f"max_bending_moment{sfx}"].isel(point=mid).max(["train", "irregularity"])
        a4.plot(kmh, m.values / 1e6, style, lw=1.4, label=what)
    a4.set_xlabel("speed (km/h)")
    a4.set_ylabel(f"max bending moment\nat x = {x[mid]:g} m (MN m)")
    a4.set_ylim(0, None)
    a4.grid(alpha=0.3)
    a4.legend(fontsize=7, loc="lower right", frameon=False)
    return fig


def interaction(ds, title: str):
    """Deck acceleration and wheel unloading against the speed, one line per track
    realisation."""
    fig, (a1, a2) = _figure(2, 2.8)
    kmh = ds["speed_kmh"].values
    acc = ds["max_deck_acceleration_whole_deck"].max("train")
    du = ds["max_wheel_unloading"].max(["train", "wheel"])
    for i in ds["irregularity"].values:
        a1.plot(kmh, acc.sel(irregularity=i).values, "o-", lw=1.0,
                label=f"track realisation (seed) {i}")
        a2.plot(kmh, du.sel(irregularity=i).values, "o-", lw=1.0)
    a1.set_ylabel("peak deck acc. (m/s²)")
    a1.set_title(title, fontsize=10)
    a1.legend(fontsize=7, loc="upper left", frameon=False)
    a2.set_ylabel("max wheel unloading ΔQ/Q₀\n(all axles)")
    a2.legend(a1.get_lines(), [ln.get_label() for ln in a1.get_lines()], fontsize=7,
              loc="upper left", frameon=False)
    for ax in (a1, a2):
        ax.set_xlabel("speed (km/h)")
        ax.set_ylim(0, None)
        ax.grid(alpha=0.3)
    checks = run_checks(ds)
    limit = float(checks["deck_acceleration"].attrs["limit"])
    _limit_line(a1, limit, f"limit {limit:g} m/s²")
    limit = float(checks["wheel_unloading"].attrs["limit"])
    _limit_line(a2, limit, f"limit {limit:g}")
    return fig


def histories(ds, title: str):
    """Mid-span deflection and car-body acceleration against time, one line per speed."""
    fig, (a1, a2) = _figure(2, 2.6)
    point = float(ds["point"].values[len(ds["point"]) // 2])
    sel = ds.isel(train=0, irregularity=0)
    for s in sel["speed"].values:
        one = sel.sel(speed=s)
        t = one["time"].values
        label = f"{float(one['speed_kmh']):g} km/h"
        a1.plot(t, one["deck_displacement"].sel(point=point).values * 1e3, lw=1.0,
                label=label)
        a2.plot(t, one["carbody_acceleration"].isel(vehicle=0).values, lw=1.0, label=label)
    a1.set_ylabel(f"deflection at x = {point:g} m\n(mm, positive down)")
    a1.set_title(title, fontsize=10)
    a1.legend(fontsize=8, frameon=False)
    a2.set_ylabel("car-body acceleration\n(m/s², positive down)")
    for ax in (a1, a2):
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    return fig


def track_layer(ds):
    """Wheel-rail contact forces of the vehicle and the deck's deflection in time."""
    fig, (a1, a2) = _figure(2, 2.6)
    one = ds.isel(train=0, irregularity=0, speed=0)
    t = one["time"].values
    for w in one["wheel"].values:
        a1.plot(t, one["contact_force"].sel(wheel=w).values / 1e3, lw=0.8,
                label=f"axle {int(w) + 1}")
    a1.set_ylabel("contact force (kN)")
    a1.set_title(f"{one['train'].values} at {float(one['speed_kmh']):g} km/h on the "
                 "ballasted track layer", fontsize=10)
    a1.legend(fontsize=7, ncol=4, frameon=False)
    for p in ds["point"].values:
        a2.plot(t, one["deck_displacement"].sel(point=p).values * 1e3, lw=1.0,
                label=f"x = {float(p):g} m")
    a2.set_ylabel("deck deflection\n(mm, positive down)")
    a2.legend(fontsize=8, frameon=False)
    for ax in (a1, a2):
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    return fig


#: config stem -> (command, figure of the results; None: the figure of ``vsi modes``, the
#: retained modes along the track line, which the config's header says to look at first)
GALLERY = {
    "quickstart": ("run", lambda ds: histories(ds, "Quick start: sprung mass, 25 m span")),
    "sprung_mass_25m": ("sweep", lambda ds: histories(
        ds, "Sprung mass on a 25 m span at 100 km/h (Yang & Wu 2001)")),
    "hslm_25m": ("sweep", hslm_25m),
    "viaduct_25_32_25": ("sweep", viaduct),
    "double_track_viaduct": ("sweep", double_track),
    "ice3_continuous": ("sweep", lambda ds: interaction(
        ds, "ICE3 on a 2 x 20 m continuous deck, German low track")),
    "ice3_hertz_german_low": ("sweep", lambda ds: interaction(
        ds, "ICE3 with Hertz contact, 25 m span, German low track")),
    "track_layer_20m": ("sweep", track_layer),
    "two_span_imported": ("sweep", None),
    "two_span_modes_file": ("sweep", None),
}


def make(stem: str, tmp: Path, echo=print) -> None:
    import vsi_numba as vsi

    command, plot = GALLERY[stem]
    out = tmp / f"{stem}.nc"
    t0 = time.perf_counter()
    run_vsi(command, ROOT / "configs" / f"{stem}.toml", out)
    with vsi.open_results(out) as ds:
        ds = ds.load()
    if plot is None:
        run_vsi("modes", ROOT / "configs" / f"{stem}.toml", HERE / f"{stem}.png")
    else:
        plot(ds).savefig(HERE / f"{stem}.png", dpi=DPI)
    write_csv(results_rows(ds), HERE / f"{stem}.csv")
    echo(f"{stem}: {time.perf_counter() - t0:.1f} s")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("configs", nargs="*", help=f"config stems (default: all of "
                   f"{', '.join(GALLERY)})")
    args = p.parse_args(argv)
    unknown = sorted(set(args.configs) - set(GALLERY))
    if unknown:
        p.error(f"unknown config(s) {', '.join(unknown)}: expected some of "
                f"{', '.join(GALLERY)}")
    with tempfile.TemporaryDirectory(prefix="vsi_gallery_") as tmp:
        for stem in args.configs or GALLERY:
            make(stem, Path(tmp))
    return 0


if __name__ == "__main__":
    sys.exit(main())
