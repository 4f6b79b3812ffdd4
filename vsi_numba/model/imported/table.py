"""Modes tables (``bridge.kind = "modes_file"``): netCDF or CSV files of frequencies,
modal masses and mode shapes at stations along track lines, see :mod:`vsi_numba.model.imported`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.model import bridge as _br
from vsi_numba.model.imported.common import (
    NETCDF_SUFFIXES,
    ImportResult,
    _check_ends,
    _check_stations,
    _damping,
    _flip_positive,
    _fmt_x,
    _keep,
    _Problems,
    _spline_slopes,
    _supports_from,
)

# --------------------------------------------------------------------------- modes table


@dataclass
class _Line:
    x: np.ndarray
    shape: np.ndarray  # (n_station, n_mode)
    slope: np.ndarray | None
    supports: np.ndarray | None


@dataclass
class _Table:
    labels: list  # mode labels, file order
    frequency: np.ndarray
    modal_mass: np.ndarray | None
    damping: np.ndarray | None
    normalised_flag: bool | None
    lines: dict  # name -> _Line
    #: the optional section forces (:mod:`.effects`): "section_x", "load_x" (arrays),
    #: "modal" {effect: (n_sec, n_mode), file order}, "influence" {(effect, line):
    #: (n_sec, n_load)}; None without them
    effects: dict | None = None


def _is_netcdf(path: Path) -> bool:
    if path.suffix.lower() in NETCDF_SUFFIXES:
        return True
    if path.suffix.lower() in (".csv", ".txt"):
        return False
    try:
        head = path.read_bytes()[:4]
    except OSError:
        return False
    return head[:3] == b"CDF" or head == b"\x89HDF"


def _flag(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str):
        v = value.strip().lower()
        if v in ("1", "true", "yes"):
            return True
        if v in ("0", "false", "no"):
            return False
        return None
    try:
        return bool(int(np.asarray(value).ravel()[0]))
    except (TypeError, ValueError, IndexError):
        return None


def _read_netcdf(path: Path, name, p: _Problems) -> _Table | None:
    import xarray as xr

    try:
        with xr.open_dataset(path) as ds:
            ds = ds.load()
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        p.add("file", name, f"a netCDF modes table readable by xarray ({type(exc).__name__}: "
                            f"{' '.join(str(exc).split())[:160]})")
        return None
    missing = [v for v in ("frequency", "x", "shape") if v not in ds.variables]
    if missing:
        p.add("file", name, f"variables frequency(mode), x(station) and shape(station, mode) "
                            f"(missing: {', '.join(missing)}; found: "
                            f"{', '.join(sorted(map(str, ds.variables))) or 'none'})")
        return None
    shape = ds["shape"]
    need = {"mode", "station"}
    if not need <= set(shape.dims) or not set(shape.dims) <= need | {"line"}:
        p.add("file", name, f"shape with dimensions (station, mode) or (line, station, mode) "
                            f"(found {tuple(shape.dims)})")
        return None
    has_line = "line" in shape.dims
    order = ("line", "station", "mode") if has_line else ("station", "mode")
    shape = shape.transpose(*order)
    if ds["frequency"].dims != ("mode",):
        p.add("file", name, f"frequency with dimension (mode) (found {ds['frequency'].dims})")
        return None
    freq = np.asarray(ds["frequency"].values, float)
    n_m = freq.size
    labels = (list(np.asarray(ds["mode"].values).tolist()) if "mode" in ds.coords
              else list(range(1, n_m + 1)))

    def per_mode(var, unit_text):
        if var not in ds.variables:
            return None
        a = ds[var]
        if a.dims != ("mode",):
            p.add("file", name, f"{var}(mode) {unit_text} (found dimensions {a.dims})")
            return None
        return np.asarray(a.values, float)

    mm = per_mode("modal_mass", "in kg")
    zeta = per_mode("damping_ratio", "(-)")
    flag = None
    if "mass_normalised" in ds.attrs:
        flag = _flag(ds.attrs["mass_normalised"])
        if flag is None:
            p.add("file", name, f"a global attribute mass_normalised = 1 or 0 (found "
                                f"{ds.attrs['mass_normalised']!r})")
    x = ds["x"]
    x_dims = ("line", "station") if has_line else ("station",)
    if set(x.dims) != set(x_dims) and not (has_line and x.dims == ("station",)):
        p.add("file", name, f"x with dimensions {x_dims} (found {x.dims})")
        return None
    slope = None
    if "slope" in ds.variables:
        if set(ds["slope"].dims) != set(order):
            p.add("file", name, f"slope with the dimensions of shape {order} (found "
                                f"{ds['slope'].dims})")
            return None
        slope = np.asarray(ds["slope"].transpose(*order).values, float)
    sup = None
    if "support_x" in ds.variables:
        s = ds["support_x"]
        want = {"line", "support"} if has_line else {"support"}
        if set(s.dims) != want and set(s.dims) != {"support"}:
            p.add("file", name, f"support_x with dimensions {tuple(sorted(want))} (found "
                                f"{s.dims})")
            return None
        sup = s.transpose(*[d for d in ("line", "support") if d in s.dims])
    if has_line:
        names = ([str(v) for v in np.asarray(ds["line"].values).tolist()] if "line" in ds.coords
                 else [str(i) for i in range(shape.sizes["line"])])
    else:
        names = [""]
    lines = {}
    sh = np.asarray(shape.values, float)
    for i, ln in enumerate(names):
        xi = np.asarray(x.transpose(*[d for d in x_dims if d in x.dims]).values, float)
        if xi.ndim == 2:
            xi = xi[i]
        valid = np.isfinite(xi)
        shi = sh[i] if has_line else sh
        sli = None if slope is None else (slope[i] if has_line else slope)
        if has_line and not valid.all():  # NaN padding at the end of shorter lines
            n_valid = int(np.argmin(valid)) if not valid.all() else xi.size
            if valid[n_valid:].any():
                p.add("file", name, f"x on line '{ln}' NaN only as padding after its last "
                                    "station (found a NaN between stations)")
                continue
            xi, shi = xi[:n_valid], shi[:n_valid]
            sli = None if sli is None else sli[:n_valid]
        si = None
        if sup is not None:
            sv = np.asarray(sup.values, float)
            sv = sv[i] if sv.ndim == 2 else sv
            si = sv[np.isfinite(sv)]
        lines[ln] = _Line(xi, shi, sli, si)
    return _Table(labels, freq, mm, zeta, flag, lines, _read_effects(ds, name, p, names))


#: The optional variables of the section forces (:mod:`.effects`).
EFFECT_VARIABLES = ("section_x", "section_moment", "section_shear", "load_x",
                    "influence_moment", "influence_shear")


def _read_effects(ds, name, p: _Problems, lines) -> dict | None:
    """The section forces of a netCDF modes table (:mod:`.effects`), None without them;
    problems are recorded in ``p``."""
    given = [v for v in EFFECT_VARIABLES if v in ds.variables]
    if not given:
        return None
    need = ("section_x", "section_moment", "load_x", "influence_moment")
    missing = [v for v in need if v not in ds.variables]
    if missing:
        p.add("file", name, "the section forces complete: section_x(section), "
                            "section_moment(section, mode), load_x(load), influence_moment("
                            f"line, section, load) (+ optional section_shear, influence_shear"
                            f"); missing: {', '.join(missing)}")
        return None
    out = {"modal": {}, "influence": {}}
    for var, dims in (("section_x", ("section",)), ("load_x", ("load",))):
        a = np.asarray(ds[var].values, float)
        if ds[var].dims != dims or not np.all(np.isfinite(a)) or np.any(np.diff(a) < 0):
            p.add("file", name, f"{var}{dims} finite and ascending (m)")
            return None
        out[var] = a
    for effect in ("moment", "shear"):
        var = f"section_{effect}"
        if var in ds.variables:
            da = ds[var]
            if set(da.dims) != {"section", "mode"}:
                p.add("file", name, f"{var} with dimensions (section, mode) (found {da.dims})")
                return None
            a = np.asarray(da.transpose("section", "mode").values, float)
            if not np.all(np.isfinite(a)):
                p.add("file", name, f"finite values of {var}")
                return None
            out["modal"][effect] = a
        var = f"influence_{effect}"
        if var not in ds.variables:
            continue
        da = ds[var]
        if set(da.dims) not in ({"section", "load"}, {"line", "section", "load"}):
            p.add("file", name, f"{var} with dimensions (line, section, load) or (section, "
                                f"load) (found {da.dims})")
            return None
        a = np.asarray(da.transpose(*[d for d in ("line", "section", "load")
                                      if d in da.dims]).values, float)
        if not np.all(np.isfinite(a)):
            p.add("file", name, f"finite values of {var}")
            return None
        for i, ln in enumerate(lines if a.ndim == 3 else [""]):
            out["influence"][(effect, ln if a.ndim == 3 else "")] = a[i] if a.ndim == 3 else a
    if ("shear" in out["modal"]) != any(k[0] == "shear" for k in out["influence"]):
        p.add("file", name, "section_shear and influence_shear together (one is missing)")
        return None
    return out


def _read_csv(path: Path, name, p: _Problems) -> _Table | None:
    import pandas as pd

    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except Exception as exc:  # noqa: BLE001 - any parser failure is a bad file
        p.add("file", name, f"a CSV modes table ({type(exc).__name__}: "
                            f"{' '.join(str(exc).split())[:160]})")
        return None
    df.columns = [str(c).strip().lower() for c in df.columns]
    required = ("mode", "frequency", "x", "shape")
    missing = [c for c in required if c not in df.columns]
    if missing:
        p.add("file", name, f"CSV columns mode, frequency, x, shape (+ optional modal_mass, "
                            f"damping_ratio, line, slope); missing: {', '.join(missing)}; "
                            f"found: {', '.join(df.columns) or 'none'}")
        return None
    if df.empty:
        p.add("file", name, "at least one row of mode shape data (the table is empty)")
        return None
    numeric = [c for c in ("frequency", "modal_mass", "damping_ratio", "x", "shape", "slope")
               if c in df.columns]
    ok = True
    for c in numeric:
        col = pd.to_numeric(df[c], errors="coerce")
        bad = ~np.isfinite(col.to_numpy(float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            p.add("file", name, f"finite numbers in column '{c}' (row {i + 2} of the file has "
                                f"{df[c].iloc[i]!r}; {int(bad.sum())} bad row(s))")
            ok = False
        df[c] = col
    if not ok:
        return None
    if "line" not in df.columns:
        df["line"] = ""
    df["line"] = df["line"].astype(str).str.strip()
    labels = list(pd.unique(df["mode"]))
    per_mode = {}
    for c in ("frequency", "modal_mass", "damping_ratio"):
        if c not in df.columns:
            per_mode[c] = None
            continue
        g = df.groupby("mode", sort=False)[c]
        lo, hi = g.min(), g.max()
        spread = (hi - lo).abs() > 1e-6 * np.maximum(hi.abs(), 1e-300)
        if spread.any():
            m = spread.index[spread.to_numpy()][0]
            p.add("file", name, f"the same {c} on every row of a mode (mode {m} has "
                                f"{lo[m]:.6g} .. {hi[m]:.6g})")
            ok = False
        per_mode[c] = np.array([float(lo[m]) for m in labels])
    dup = df.duplicated(subset=["mode", "line", "x"], keep=False)
    if dup.any():
        r = df[dup].iloc[0]
        p.add("file", name, f"one row per mode, line and station (mode {r['mode']} has x = "
                            f"{_fmt_x(r['x'])}{' on line ' + repr(r['line']) if r['line'] else ''}"
                            " more than once)")
        ok = False
    if not ok:
        return None
    lines = {}
    for ln, sub in df.groupby("line", sort=False):
        x = np.sort(pd.unique(sub["x"]).astype(float))
        wide = sub.pivot(index="x", columns="mode", values="shape").reindex(index=x,
                                                                            columns=labels)
        if wide.isna().to_numpy().any():
            holes = np.argwhere(wide.isna().to_numpy())
            i, j = holes[0]
            where = f" of line '{ln}'" if ln else ""
            p.add("file", name, f"every mode at every station{where} (missing stations: mode "
                                f"{labels[j]} has no row at x = {_fmt_x(x[i])}; "
                                f"{len(holes)} value(s) missing)")
            ok = False
            continue
        slope = None
        if "slope" in df.columns:
            slope = sub.pivot(index="x", columns="mode", values="slope").reindex(
                index=x, columns=labels).to_numpy(float)
        lines[str(ln)] = _Line(x, wide.to_numpy(float), slope, None)
    if not ok:
        return None
    return _Table(labels, per_mode["frequency"], per_mode["modal_mass"],
                  per_mode["damping_ratio"], None, lines)


def open_table(path, name=None):
    """Read a modes table file (netCDF or CSV): ``(table, name, problems)``, ``name`` how
    the messages name the file (default: the path as given).  Raises
    :class:`ModelFileError` when the file is missing, empty or unreadable."""
    path = Path(path)
    name = str(path) if name is None else name
    p = _Problems()
    if not path.is_file():
        p.add("file", name, f"an existing modes table file (looked for {path.resolve()})")
        p.raise_if_any()
    if path.stat().st_size == 0:
        p.add("file", name, "a netCDF or CSV modes table (the file is empty)")
        p.raise_if_any()
    tab = _read_netcdf(path, name, p) if _is_netcdf(path) else _read_csv(path, name, p)
    p.raise_if_any()
    return tab, name, p


def read_modes_table(
    path,
    *,
    track_line: str | None = None,
    n_modes: int | None = None,
    max_frequency: float | None = None,
    damping_ratio=None,
    mass_normalised: bool | None = None,
    spans=None,
    name: str | None = None,
) -> ImportResult:
    """Read a modes table (netCDF or CSV, formats in the module docstring).

    Parameters
    ----------
    path : str or path-like
    track_line : str, optional
        Line the train runs on; required when the file has several.
    n_modes, max_frequency : int, float, optional
        Keep the lowest ``n_modes`` and/or the modes up to ``max_frequency`` (Hz); both
        None keeps every mode of the file.
    damping_ratio : float or sequence, optional
        Modal damping ratio(s); overrides the file's.  Default: the file's, else 0.
    mass_normalised : bool, optional
        True: the shapes are already mass-normalised (no ``modal_mass`` needed).
    spans : sequence of float, optional
        Span lengths (m) along the track line: the table must cover their sum, and the
        supports (plots, default output points) are their ends.
    name : str, optional
        How to name the file in messages (default: the path as given).

    Returns
    -------
    ImportResult

    Raises
    ------
    ModelFileError
        Listing every problem found, each naming the file.
    """
    tab, name, p = open_table(path, name)
    warnings: list[str] = []

    # per-mode data
    f = tab.frequency
    if not np.all(np.isfinite(f)) or np.any(f <= 0):
        j = int(np.flatnonzero(~(np.isfinite(f) & (f > 0)))[0])
        p.add("file", name, f"natural frequencies > 0 Hz (mode {tab.labels[j]} has {f[j]})")
    elif np.unique(f).size != f.size:
        p.add("file", name, "distinct natural frequencies (a mode is listed twice?)")
    norm_flag = mass_normalised if mass_normalised is not None else tab.normalised_flag
    mm = tab.modal_mass
    if mm is not None:
        if not np.all(np.isfinite(mm)) or np.any(mm <= 0):
            j = int(np.flatnonzero(~(np.isfinite(mm) & (mm > 0)))[0])
            p.add("file", name, f"modal masses > 0 kg (mode {tab.labels[j]} has {mm[j]})")
        elif norm_flag and np.max(np.abs(mm - 1.0)) > 1e-3:
            p.add("mass_normalised", True, "modal masses of 1 when the shapes are said to be "
                  f"mass-normalised (the file's modal_mass goes up to {mm.max():.4g} kg); "
                  "remove mass_normalised to normalise by the file's modal masses")
    elif not norm_flag:
        p.add("file", name, "a modal_mass per mode (kg) -- or the shapes already "
                            "mass-normalised: bridge.mass_normalised = true (or the netCDF "
                            "attribute mass_normalised = 1)")
    z = tab.damping
    if z is not None and (not np.all(np.isfinite(z)) or np.any((z < 0) | (z >= 1))):
        j = int(np.flatnonzero(~(np.isfinite(z) & (z >= 0) & (z < 1)))[0])
        p.add("file", name, f"damping ratios 0 <= zeta < 1 (mode {tab.labels[j]} has {z[j]})")

    # the track line
    names = list(tab.lines)
    shown = [n for n in names if n]
    if track_line is None:
        if len(names) > 1:
            p.add("track_line", None, "the track line the train runs on: one of "
                  + ", ".join(repr(n) for n in shown) + f" (the file {name} has several)")
            p.raise_if_any()
        line_name = names[0]
    else:
        line_name = str(track_line)
        if line_name not in tab.lines:
            p.add("track_line", repr(line_name),
                  f"a track line of {name}: "
                  + (", ".join(repr(n) for n in shown) if shown else "the file has no line "
                     "names (one line only: remove bridge.track_line)"))
            p.raise_if_any()
    ln = tab.lines[line_name]
    length = float(np.sum(spans)) if spans is not None else None
    label = f"line '{line_name}' of {name}" if line_name else name
    if not np.all(np.isfinite(ln.shape)):
        i, j = np.argwhere(~np.isfinite(ln.shape))[0]
        p.add("file", name, f"finite mode shape values (mode {tab.labels[j]} at x = "
                            f"{_fmt_x(ln.x[i])} is {ln.shape[i, j]})")
    if ln.slope is not None and not np.all(np.isfinite(ln.slope)):
        i, j = np.argwhere(~np.isfinite(ln.slope))[0]
        p.add("file", name, f"finite slopes (mode {tab.labels[j]} at x = {_fmt_x(ln.x[i])} "
                            f"is {ln.slope[i, j]})")
    p.raise_if_any()
    if _check_stations(p, "file", name, ln.x, line_name, length):
        _check_ends(p, "file", name, ln.x, ln.shape, line_name, tab.labels)
    p.raise_if_any()

    # sort, select, normalise
    order = np.argsort(f, kind="stable")
    f = f[order]
    n = _keep(f, n_modes, max_frequency)
    if n < 1:
        p.add("max_frequency", max_frequency, f"a frequency >= the first mode of {name} "
                                              f"({f[0]:.4g} Hz), else no mode is retained")
        p.raise_if_any()
    if n_modes is not None and n_modes > f.size:
        warnings.append(f"bridge.n_modes = {n_modes}: {name} has only {f.size} modes; all are "
                        "used")
    sel = order[:n]
    scale = 1.0 / np.sqrt(mm[sel]) if mm is not None else np.ones(n)
    values = ln.shape[:, sel] * scale
    slopes = ln.slope[:, sel] * scale if ln.slope is not None else _spline_slopes(ln.x, values)
    sign = np.sign(values[np.argmax(np.abs(values), axis=0), np.arange(n)])
    sign[sign == 0] = 1.0
    values, slopes = _flip_positive(values, slopes)
    zeta = _damping(p, damping_ratio, None if z is None else z[order], n, warnings)
    p.raise_if_any()
    supports = _supports_from(spans, ln.supports, float(ln.x[-1]))
    static = None
    if tab.effects is not None:
        static = _section_forces(tab.effects, sel, scale, sign, line_name, supports)
        if isinstance(static, str):
            warnings.append(f"bridge.file ({name}): its section forces are not used, "
                            f"bending moments and shear forces are not computed: {static}")
            static = None
    x = ln.x.copy()
    x[0] = 0.0
    if length is not None:
        x[-1] = length  # within COVER_TOL: exact ends for the kernel's on-bridge test
    bridge = _br.from_table(
        x, values, f[:n], zeta, slopes=slopes, supports=supports,
        description=(f"modes table {label}: {n} modes, {x.size} stations, "
                     f"{'Hermite with the given slopes' if ln.slope is not None else 'C2 spline'}"
                     " between stations"),
    )
    if static is not None:
        bridge = dataclasses.replace(bridge, static=static)
    return ImportResult(bridge, f.copy(), tuple(warnings), tuple(shown))


def _section_forces(eff, sel, scale, sign, line, supports):
    """The static deck of the file's section forces for the retained modes ``sel``
    (:func:`~vsi_numba.model.imported.effects.beam_statics`) for a train on ``line``, or
    why not (str).  Influence lines without a line dimension serve every line."""
    from vsi_numba.model.imported import effects

    found = {k[1] for k in eff["influence"]}
    if line not in found and "" in found:
        line = ""
    if line not in found:
        return (f"no influence lines for the track line {line!r} (the file has them for "
                f"{', '.join(map(repr, sorted(found)))})")
    sf = effects.from_arrays(eff["section_x"], {k: v[:, sel] for k, v in eff["modal"].items()},
                             eff["load_x"], {k: v for k, v in eff["influence"].items()
                                             if k[1] == line}, scale, sign)
    return effects.beam_statics(sf, line, supports)
