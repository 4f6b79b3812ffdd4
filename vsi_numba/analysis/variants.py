"""Results of parametric studies (``study.vary``): one variant at a time, tables and
design charts over the variants.

A study of variants has a leading ``variant`` dimension, a coordinate per varied key
(``bridge_EI``, ``mass_factor``, ...) and per-variant data (``frequency``,
``bridge_length``, ``point_position`` when the points move with the spans,
``variant_config_json``).  :func:`variant_view` turns one variant back into the layout of
a study without variants, so every check of :mod:`vsi_numba.analysis.checks` applies.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis import checks as chk
from vsi_numba.analysis.dataset import NOT_RELIABLE, ResultsError, stored_warnings, track_type
from vsi_numba.en1990 import deck_acceleration_limits

#: Per-variant variables that become attributes of a variant's view.
_PER_VARIANT = ("bridge_length", "acceleration_cutoff", "variant_config_json",
                "damping_ratio", "additional_damping", "damping_rule", "variant_time")


def variant_config(ds: xr.Dataset, k: int) -> dict:
    """The resolved configuration of variant ``k`` (``variant_config_json``; {} when the
    file does not have it or it is not a JSON table)."""
    if "variant_config_json" not in ds.variables:
        return {}
    try:
        cfg = json.loads(str(ds["variant_config_json"].values[k]))
    except ValueError:
        return {}
    return cfg if isinstance(cfg, dict) else {}


def variant_warnings(ds: xr.Dataset, k: int) -> list[dict]:
    """The warnings stored in a study of variants that concern variant ``k``: the
    records whose ``variants`` list holds ``k``, and those without such a list."""
    out = []
    for r in stored_warnings(ds):
        ks = r.get("variants")
        if not isinstance(ks, list) or k in ks:
            out.append(r)
    return out


def variant_track_type(ds: xr.Dataset, k: int) -> str:
    """Track type of variant ``k``: its configuration's ``bridge.track_type``, else the
    file's ``track_type`` attribute (normalised as :func:`~vsi_numba.analysis.dataset.
    track_type`)."""
    bridge = variant_config(ds, k).get("bridge")
    tt = bridge.get("track_type") if isinstance(bridge, dict) else None
    if tt is None:
        return track_type(ds)
    return track_type(xr.Dataset(attrs={"track_type": str(tt)}))


def variant_limit(ds: xr.Dataset, k: int) -> float:
    """EN 1990 A2 deck-acceleration limit of variant ``k`` (m s-2) from its track type and
    the study's code profile (recommended: 3.5 ballasted, 5 direct fastening; the ballasted
    limit when the type is unknown)."""
    limits = deck_acceleration_limits(chk.profile_of(ds))
    return float(limits.get(variant_track_type(ds, k), limits["ballasted"]))


def _limits(ds: xr.Dataset) -> np.ndarray:
    """Deck-acceleration limit (m s-2) of every variant."""
    return np.array([variant_limit(ds, k) for k in range(ds.sizes["variant"])])


def _limits_text(ds: xr.Dataset) -> str:
    """``"3.5 m/s² (ballasted track)"``, one per track type of the variants."""
    types = sorted({variant_track_type(ds, k) for k in range(ds.sizes["variant"])})
    limits = deck_acceleration_limits(chk.profile_of(ds))
    return ", ".join(f"{limits.get(t, limits['ballasted']):g} m/s² ({t} track)"
                     for t in types)


def varied_coords(ds: xr.Dataset) -> list[str]:
    """Names of the coordinates that label the variants (one per varied key)."""
    return [n for n, c in ds.coords.items() if c.dims == ("variant",) and n != "variant"]


def variant_label(ds: xr.Dataset, k: int) -> str:
    """``"bridge.EI = 7e+10, mass_factor = 0.9"`` for variant ``k``."""
    parts = []
    for n in varied_coords(ds):
        key = ds[n].attrs.get("key_path", n)
        v = ds[n].values[k]
        parts.append(f"{key} = {v:.6g}" if isinstance(v, float | np.floating) else
                     f"{key} = {v}")
    return ", ".join(parts)


def variant_view(ds: xr.Dataset, k: int) -> xr.Dataset:
    """Variant ``k`` in the layout of a study without variants.

    ``point`` gets the variant's positions (m) when they move with the spans, ``time``
    its time axis (s) when the variants' time steps differ, the modes and points it does
    not have are dropped, and ``bridge_length``, ``acceleration_cutoff_hz``,
    ``config_json``, ``track_type``, ``dt`` and the warnings (``warnings_json``,
    ``config_warnings``: those that concern this variant) become the variant's.
    """
    v = ds.isel(variant=k)
    attrs = dict(ds.attrs)
    cfg = variant_config(ds, k)
    if isinstance(cfg.get("bridge"), dict) and cfg["bridge"].get("track_type") is not None:
        attrs["track_type"] = str(cfg["bridge"]["track_type"])
    dt = cfg.get("solver", {}).get("dt") if isinstance(cfg.get("solver"), dict) else None
    if isinstance(dt, int | float) and not isinstance(dt, bool):
        attrs["dt"] = float(dt)
    records = variant_warnings(ds, k)
    attrs["warnings_json"] = json.dumps(records, ensure_ascii=False)
    attrs["config_warnings"] = "\n".join(str(r["message"]) for r in records)
    if not records:
        attrs.pop("config_warnings")
    if "variant_time" in v.variables:
        t = np.asarray(v["variant_time"].values, float)
        v = v.assign_coords(time=("time", t, dict(ds["variant_time"].attrs)))
    if "bridge_length" in v:
        attrs["bridge_length"] = float(v["bridge_length"])
    if "acceleration_cutoff" in v:
        attrs["acceleration_cutoff_hz"] = float(v["acceleration_cutoff"])
    if "variant_config_json" in v:
        attrs["config_json"] = str(v["variant_config_json"].values)
    if "damping_rule" in v and str(v["damping_rule"].values):
        rules = str(v["damping_rule"].values).split(" ; ")
        attrs["damping_rule"] = rules[0]
        if len(rules) > 1:
            attrs["additional_damping_rule"] = rules[1]
    attrs["variant"] = int(k)
    attrs["variant_label"] = variant_label(ds, k)
    if "bridge_description" in attrs:  # the file's is the first variant's bridge
        attrs["bridge_description"] = f"variant {k} ({attrs['variant_label']})"
    v = v.drop_vars([n for n in (*_PER_VARIANT, *varied_coords(ds), "variant") if n in v.variables])
    if "point_position" in v.variables:
        pos = np.asarray(v["point_position"].values, float)
        keep = np.isfinite(pos)
        v = v.isel(point=np.flatnonzero(keep)).drop_vars("point_position")
        v = v.assign_coords(point=("point", pos[keep], _point_attrs(ds)))
    if "frequency" in v:
        f = np.asarray(v["frequency"].values, float)
        v = v.isel(mode=np.flatnonzero(np.isfinite(f)))
    v.attrs = attrs
    return v


def _point_attrs(ds: xr.Dataset) -> dict:
    """Attributes of the variant view's ``point`` (from ``point_position``)."""
    a = dict(ds["point_position"].attrs) if "point_position" in ds else {}
    return {"units": a.get("units", "m"), "long_name": a.get("long_name", "output point")}


def _all_failed(ds: xr.Dataset) -> bool:
    """True when no run of any variant has a deck acceleration (every run failed)."""
    return not bool(np.isfinite(peak_deck_acceleration(ds).values).any())


_ALL_FAILED = ("every run of every variant failed numerically (status != 0, outputs NaN): "
               "there is nothing to check. Fix the run (see the warnings and "
               "docs/reference/troubleshooting.md) and run it again")


def peak_deck_acceleration(ds: xr.Dataset) -> xr.DataArray:
    """Peak deck acceleration per (variant, speed) (m s-2): the maximum over trains,
    realisations and the deck (the whole-deck envelope when the file has it, else the
    output points)."""
    a = ds["max_deck_acceleration"].max(["train", "irregularity", "point"])
    if "max_deck_acceleration_whole_deck" in ds:
        a = np.fmax(a, ds["max_deck_acceleration_whole_deck"].max(["train", "irregularity"]))
    return a


def variant_table(ds: xr.Dataset, q: float = chk.DEFAULT_Q) -> pd.DataFrame:
    """One row per variant: its varied values, the governing deck-acceleration value,
    limit, result, governing train and speed, and phi'_dyn."""
    rows = []
    for k in range(ds.sizes["variant"]):
        v = variant_view(ds, k)
        row = {n: ds[n].values[k] for n in varied_coords(ds)}
        row["f1_hz"] = float(v["frequency"].values[0]) if v.sizes.get("mode") else np.nan
        if "damping_ratio" in ds:
            row["zeta_pct"] = 100 * float(ds["damping_ratio"].values[k, 0])
        if "additional_damping" in ds and float(ds["additional_damping"].values[k]):
            row["dzeta_mf_pct"] = 100 * float(ds["additional_damping"].values[k])
        row["track_type"] = variant_track_type(ds, k)
        try:
            acc = chk.deck_acceleration_check(v, q=q, n_boot=200)
            result = acc.attrs["result"]
            if any(r.get("kind") == "resolution" for r in variant_warnings(ds, k)):
                result = {"pass": NOT_RELIABLE, "FAIL": f"FAIL ({NOT_RELIABLE})"}.get(
                    result, result)
            row.update(deck_acceleration=acc.attrs["value"], limit=acc.attrs["limit"],
                       result=result, governing_train=acc.attrs[
                           "governing_train"], governing_speed_kmh=acc.attrs[
                           "governing_speed_kmh"])
        except chk.ResultsError as exc:  # e.g. every run of the variant failed
            row.update(deck_acceleration=np.nan, limit=np.nan, result=f"n/a ({exc})")
        try:
            dyn = chk.dynamic_amplification(v)
            row["phi_dyn"] = dyn.attrs.get("value", np.nan)
        except (chk.ResultsError, KeyError):
            row["phi_dyn"] = np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def governing_variant(ds: xr.Dataset) -> int:
    """The variant with the highest utilisation of its deck-acceleration limit (peak
    deck acceleration / the variant's limit).

    Raises
    ------
    ResultsError
        When every run of every variant failed (no deck acceleration at all).
    """
    if _all_failed(ds):
        raise ResultsError(_ALL_FAILED)
    a = peak_deck_acceleration(ds).max("speed").values
    return int(np.nanargmax(a / _limits(ds)))


def _determined(ds: xr.Dataset, key: str, by: list[str]) -> bool:
    """Whether the values of ``key`` are a function of the values of ``by`` (e.g. the
    EI of a ``vary_together`` group given its span and label)."""
    seen: dict = {}
    for k in range(ds.sizes["variant"]):
        at = tuple(str(ds[b].values[k]) for b in by)
        if seen.setdefault(at, str(ds[key].values[k])) != str(ds[key].values[k]):
            return False
    return True


def chart_layout(ds: xr.Dataset, x_key: str | None = None):
    """How the design chart shows the variants: ``(x_key, panel_keys, panels)``.

    ``x_key`` is the varied numeric key on the x axis and ``panels`` a list of
    ``(panel values, variant indices)``: one panel per combination of ``panel_keys``, the
    varied keys that are not determined by ``x_key`` and the keys already chosen (a
    ``vary_together`` group contributes one key: its ``label`` when it has one, else its
    first key).  A layout needs at least two distinct x values in every panel and no x
    value twice in a panel; the first numeric key (in the file's order) that gives one is
    taken.  ``x_key`` is None when none does: the chart then draws one line per variant
    over the speed.
    """
    keys = varied_coords(ds)
    numeric = [n for n in keys if ds[n].dtype.kind in "fiu"]
    candidates = [x_key] if x_key else numeric
    order = (["label"] if "label" in keys else []) + [n for n in keys if n != "label"]
    for x in candidates:
        others: list[str] = []
        for k in order:
            if k != x and not _determined(ds, k, [x, *others]):
                others.append(k)
        groups: dict = {}
        for k in range(ds.sizes["variant"]):
            groups.setdefault(tuple(ds[n].values[k] for n in others), []).append(k)
        ok = all(len({float(ds[x].values[k]) for k in ks}) == len(ks) >= 2
                 for ks in groups.values())
        if ok:
            return x, others, list(groups.items())
    return None, [], [((), list(range(ds.sizes["variant"])))]


def design_chart_figure(ds: xr.Dataset, x_key: str | None = None, max_panels: int = 9):
    """The design chart of a study of variants (see :func:`design_charts`).

    Returns
    -------
    (matplotlib.figure.Figure, str)
        The figure (close it when done) and its caption.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    peak = peak_deck_acceleration(ds).transpose("variant", "speed")
    limits = _limits(ds)  # each variant's own (its track type)
    limit = float(limits.max())
    same = bool(np.all(limits == limit))
    speeds = np.asarray(ds["speed_kmh"].values, float)
    x_key, others, groups = chart_layout(ds, x_key)
    panels = groups[:max_panels]

    def name(k):
        return ds[k].attrs.get("key_path", k)

    def show(k, v):
        return f"{name(k)} = {v:.4g}" if isinstance(v, float | np.floating) else \
            f"{name(k)} = {v}"

    if x_key is None:  # no heat map possible: peak acceleration over speed per variant
        fig, ax = plt.subplots(figsize=(8.0, 4.8), constrained_layout=True)
        ks = list(range(ds.sizes["variant"]))
        if len(ks) > 12:  # the envelope and the governing variant
            env = np.nanmax(peak.values, axis=0)
            ax.plot(speeds, env, "k-", lw=1.8, label=f"envelope of {len(ks)} variants")
            gov = governing_variant(ds)
            ax.plot(speeds, peak.values[gov], "C1--", label=f"governing: {variant_label(ds, gov)}")
        else:
            styles = ["-", "--", "-.", ":"]
            for j, k in enumerate(ks):
                text = (str(ds["label"].values[k]) if "label" in ds.coords
                        and len(set(map(str, ds["label"].values))) == len(ks)
                        else variant_label(ds, k))
                ax.plot(speeds, peak.values[k], color=f"C{j % 10}", ls=styles[j // 10 % 4],
                        marker=".", label=text)
        if same:
            ax.axhline(limit, color="red", lw=1.2, ls="--", label=f"limit {limit:g} m/s²")
        else:
            for lim in sorted(set(limits.tolist())):
                ax.axhline(lim, color="red", lw=1.2, ls="--" if lim == limit else ":",
                           label=f"limit {lim:g} m/s² (variant"
                           + ("s " if np.sum(limits == lim) > 1 else " ")
                           + ", ".join(str(k) for k in np.flatnonzero(limits == lim)[:8])
                           + (", ..." if np.sum(limits == lim) > 8 else "") + ")")
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("peak deck acceleration [m/s²]")
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(alpha=0.3)
        caption = ("Design chart: peak deck acceleration (max over trains, realisations and "
                   "the deck) over the speed, one line per variant; red: the limit of each "
                   f"variant, {_limits_text(ds)}.")
        return fig, caption

    n = len(panels)
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.0 * rows), squeeze=False,
                             constrained_layout=True)
    # the colours resolve the range around the limit; above 3x the limit they saturate
    vmax = float(np.nanmax(peak.values)) if np.isfinite(peak.values).any() else 1.0
    vmax = min(vmax, 3.0 * limit)
    mesh = None
    for ax, (other_vals, ks) in zip(axes.flat, panels, strict=False):
        ks = sorted(ks, key=lambda k: float(ds[x_key].values[k]))
        x = np.asarray([ds[x_key].values[k] for k in ks], float)
        z = np.asarray(peak.values[ks], float).T  # (speed, x)
        u = z / limits[ks][None, :]  # utilisation of each variant's own limit
        mesh = ax.pcolormesh(x, speeds, z, shading="nearest", cmap="viridis", vmin=0,
                             vmax=vmax)
        if np.isfinite(u).any() and np.nanmin(u) < 1.0 < np.nanmax(u):
            lims = sorted(set(limits[ks].tolist()))
            cs = ax.contour(x, speeds, u, levels=[1.0], colors="red", linewidths=1.5)
            ax.clabel(cs, fmt={1.0: " / ".join(f"{v:g}" for v in lims) + " m/s²"},
                      fontsize=8)
        if "label" in ds.coords and "label" not in others and "label" != x_key:
            top = ax.secondary_xaxis("top")  # the label of each x (its vary_together group)
            top.set_xticks(x, [str(ds["label"].values[k]) for k in ks], fontsize=7)
        if x.size <= 8:
            ax.set_xticks(x)
        units = ds[x_key].attrs.get("units")
        ax.set_xlabel(name(x_key) + (f" [{units}]" if units else ""))
        ax.set_ylabel("speed [km/h]")
        ax.set_title(", ".join(show(o, v) for o, v in zip(others, other_vals, strict=True))
                     or "peak deck acceleration", fontsize=9)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.colorbar(mesh, ax=axes, label="peak deck acceleration [m/s²]", extend="max")
    caption = (f"Design chart: peak deck acceleration (max over trains, realisations and the "
               f"deck) over {name(x_key)} and speed; red: where each variant reaches its "
               f"own limit ({_limits_text(ds)})"
               + (f"; one panel per {', '.join(name(o) for o in others)}" if others else "")
               + (f" (first {len(panels)} of {len(groups)})" if len(groups) > len(panels)
                  else "") + ".")
    return fig, caption


def design_charts(ds: xr.Dataset, path, x_key: str | None = None):
    """Heat maps of the peak deck acceleration over (a varied key x speed), one panel per
    combination of the other varied keys (:func:`chart_layout`), with the limit's
    contour; without a key that spans a heat map, the peak over the speed per variant.
    Saved to ``path``.

    Returns the figure's caption.
    """
    import matplotlib.pyplot as plt

    fig, caption = design_chart_figure(ds, x_key)
    from vsi_numba.analysis.figure_file import savefig
    from vsi_numba.io.atomic import write_atomic

    try:
        if isinstance(path, str | os.PathLike):  # a file: whole or not at all
            write_atomic(path, lambda tmp: savefig(fig, tmp, dpi=110))
        else:  # a binary file object
            savefig(fig, path, dpi=110)
    finally:
        plt.close(fig)
    return caption
