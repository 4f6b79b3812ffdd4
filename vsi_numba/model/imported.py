"""Bring your own bridge: deck modes or FE matrices exported from another program.

Both ways in end in a :class:`~vsi_numba.model.bridge.ModalBridge` of kind ``HERMITE``
along the track line the train runs on: x in metres from the left end of that line (the
first support it crosses), vertical deflection positive down, modes normalised to unit
modal mass (``phi^T M phi = 1``, so ``phi`` is in 1/sqrt(kg)).  Between stations the
mode shapes are a C2 cubic spline through the station values (not-a-knot ends), or the
Hermite cubic of the given values and slopes; the kernels evaluate exactly that cubic.

The sign of a whole mode is arbitrary (it cancels in every response), so "z up" exports
can be read as they are; each mode is flipped so that its largest value along the track
line is positive.  Only the *relative* sign of rotations and displacements matters
(``rotation_sign`` below).

1. Modes table (``bridge.kind = "modes_file"``, :func:`read_modes_table`)
--------------------------------------------------------------------------
Per retained mode: the natural frequency (Hz), the modal mass (kg) of the shape as
tabulated -- or a flag saying the shapes are already mass-normalised -- and the vertical
mode shape at stations along one or more track lines; optionally a damping ratio per
mode and slopes d(phi)/dx at the stations.  Shapes are divided by sqrt(modal mass).

*netCDF* (``.nc``; read with xarray; dimension order free)::

    dimensions:  mode, station, line (optional), support (optional)
    frequency(mode)             Hz     natural frequency, > 0
    modal_mass(mode)            kg     phi^T M phi of the shape as stored  [or the global
                                       attribute mass_normalised = 1]
    damping_ratio(mode)         1      optional (bridge.damping_ratio wins when given)
    x(station) or x(line, station)           m   station abscissa along the line, from
                                                 0 (NaN-padded when lines differ in length)
    shape(station, mode) or shape(line, station, mode)   vertical mode shape (any
                                                 consistent scale; m per unit coordinate)
    slope(...)                  1/m    optional, same dims as shape: d(shape)/dx
    line(line)                  str    track-line names (bridge.track_line picks one)
    support_x(support) or support_x(line, support)   m   optional support abscissae
                                                 along each line (NaN-padded): for plots,
                                                 default output points and reports

*CSV* (``.csv``; one row per station and mode, "long" layout as FE post-processors
export it; ``#`` starts a comment; header names are case-insensitive)::

    mode,frequency,modal_mass,damping_ratio,line,x,shape,slope
    1,3.52,1.15e5,0.01,up,0.0,0.0,0.0123
    1,3.52,1.15e5,0.01,up,0.5,0.0061,0.0122
    ...

``mode`` (label), ``frequency`` (Hz), ``x`` (m) and ``shape`` are required;
``modal_mass`` (kg; else the config key ``bridge.mass_normalised = true``),
``damping_ratio``, ``line`` and ``slope`` (1/m) are optional.  Per-mode columns must
repeat the same value on every row of a mode; every mode must have a value at every
station of a line (same x set per line).

Checks (each a :class:`ModelFileError` naming the file and the problem): readable file,
required variables/columns, finite numbers (no NaN), frequencies > 0 and distinct,
modal masses > 0, stations strictly increasing from x = 0, a complete table (every mode
at every station), a table covering the whole bridge (last station at the sum of
``bridge.spans`` when given) and shapes that vanish at both ends of the line (the train
runs onto rigid track there: a non-zero end value would be a step in the rail).  Modes
are sorted by frequency.

2. Matrices (``bridge.kind = "matrices"``, :func:`read_matrices`)
------------------------------------------------------------------
Stiffness ``K`` and mass ``M`` of the structure in Matrix Market format
(``scipy.io.mmread``; coordinate or array, general or symmetric), same square size, SI
units (N/m, N, N m and kg, kg m^2 for rotational DOFs).  A station map (CSV) ties the
track line to the matrix DOFs::

    x,dof,rotation_dof,line
    0.0,0,1,up
    0.5,2,3,up

``x`` (m, strictly increasing from 0 along a line), ``dof`` (the vertical translation
DOF of the track node) are required; ``rotation_dof`` (the rotation about the
transverse axis, d(w)/dx times ``rotation_sign``) and ``line`` optional.  DOF numbers
are 0-based (``dof_base = 1`` for 1-based numbering, e.g. from a Fortran code); the
same base applies to ``fixed_dofs`` and ``vertical_dofs``.

Boundary conditions: ``fixed_dofs`` lists the DOFs held at zero (supports); omit it
when the exported matrices already have them removed/applied.  Modes: the lowest
``n_modes`` (or all up to ``max_frequency``) of ``K phi = w^2 M phi`` by
``scipy.sparse.linalg.eigsh`` in shift-invert mode around ``sigma = -1 rad^2/s^2``
(slightly below 0, so that an unsupported structure shows its rigid-body modes instead
of failing to factorise).  Checked: symmetry of K and M (relative 1e-8), finite entries,
no negative diagonal mass, K positive semi-definite, no rigid-body mode, and the
mass-normalisation ``|Phi^T M Phi - I| < 1e-6`` of the result.  Slopes along the track
come from the rotation DOFs when the map gives them (then the interpolation is the
exact Hermite FE field of a beam model), else from the spline.

Effective (participating) vertical mass of mode j: ``Gamma_j^2`` with
``Gamma_j = phi_j^T M r``, ``r`` = 1 on the vertical DOFs (``vertical_dofs``; default:
the station DOFs of every track line) and 0 elsewhere, divided by the total vertical
mass ``r^T M r`` (support DOFs included: for a consistent-mass beam these are exactly
``int m phi dx`` and ``int m dx``, so a simply supported span gives 8/pi^2 = 81.1% for
mode 1; the mass sitting on the supports never participates, so the sum over all modes
stays a little below 100%).  Stored per mode in
``ModalBridge.effective_mass_fraction`` and printed by ``vsi modes``.  For a 3-D model
give ``vertical_dofs`` (a list, or ``{start = 2, step = 6}`` for every 6th DOF from 2)
so that r is the whole vertical translation.

Notes
-----
Interpolation error of the spline between stations: O(h^4) for smooth modes (checked in
``tests/test_imported.py`` against a refined table); at 10 stations per half wavelength
the shape error is about 1e-4 of the amplitude.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.interpolate
import scipy.io
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from vsi_numba.model import bridge as _br

__all__ = [
    "ImportResult",
    "ModelFileError",
    "modes_from_matrices",
    "read_matrices",
    "read_modes_table",
]

NETCDF_SUFFIXES = (".nc", ".nc4", ".cdf", ".netcdf")
SIGMA = -1.0  # rad^2/s^2: shift of the shift-invert eigensolver (just below zero)
SYMMETRY_TOL = 1e-8  # relative to max |A|
NORMALISATION_TOL = 1e-6  # max |Phi^T M Phi - I|
END_TOL = 1e-2  # |phi(end)| / max |phi| above this: the shape does not vanish at an end
COVER_TOL = 1e-4  # relative to the length: stations must reach both ends
RIGID_BODY_HZ = 1e-3  # a mode below this is a rigid-body mode (missing supports)
LOW_FREQUENCY_HZ = 0.5  # a first mode below this: units or K/M swapped? (warning)
MAX_MODES = 1000


class ModelFileError(ValueError):
    """A bridge data file (or a key that refers to it) cannot be used.

    Parameters
    ----------
    problems : list of (key, value, expected)
        ``key`` is the config key under ``[bridge]`` the problem belongs to ("file",
        "stiffness_matrix", "mass_matrix", "station_map", "fixed_dofs", "track_line",
        ...), ``value`` the file name or value (None: the key is missing), ``expected``
        what was expected and what was found.
    """

    def __init__(self, problems):
        self.problems = [(str(k), v, str(e)) for k, v, e in problems]
        super().__init__("\n".join(
            f"{k}: missing; expected {e}" if v is None else f"{k} = {v}: expected {e}"
            for k, v, e in self.problems))


@dataclass(frozen=True)
class ImportResult:
    """An imported bridge with what the config checks need.

    Attributes
    ----------
    bridge : ModalBridge
        The retained modes along the selected track line.
    all_frequencies : ndarray
        Every frequency known (Hz, ascending): the file's, or those computed; used for
        the EN 1990 A2 cut-off check.
    warnings : tuple of str
    lines : tuple of str
        The track lines available in the data.
    """

    bridge: _br.ModalBridge
    all_frequencies: np.ndarray
    warnings: tuple[str, ...] = ()
    lines: tuple[str, ...] = ()


# ------------------------------------------------------------------------ shared steps


class _Problems:
    def __init__(self):
        self.items: list[tuple[str, object, str]] = []

    def add(self, key, value, expected):
        self.items.append((key, value, expected))

    def raise_if_any(self):
        if self.items:
            raise ModelFileError(self.items)


def _fmt_x(x) -> str:
    return f"{float(x):.6g} m"


def _check_stations(p, key, name, x, line, length):
    """Stations strictly increasing from 0, reaching ``length`` when known."""
    where = f" on line '{line}'" if line else ""
    if x.size < 2:
        p.add(key, name, f"at least 2 stations{where} (found {x.size})")
        return False
    if not np.all(np.isfinite(x)):
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        p.add(key, name, f"finite station abscissae x (m){where} (station {i} is {x[i]})")
        return False
    d = np.diff(x)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        what = "repeated" if d[i] == 0 else "decreasing"
        p.add(key, name, f"station abscissae strictly increasing{where} ({what} at x = "
                         f"{_fmt_x(x[i])} -> {_fmt_x(x[i + 1])})")
        return False
    span = x[-1] - x[0]
    if abs(x[0]) > COVER_TOL * span:
        p.add(key, name, f"stations starting at x = 0 (the left end of the deck along the "
                         f"track line){where}; the first station is at x = {_fmt_x(x[0])}")
        return False
    if length is not None and abs(x[-1] - length) > COVER_TOL * length:
        p.add(key, name, f"a table covering the whole bridge, x = 0 .. {length:g} m (sum of "
                         f"bridge.spans){where}; the stations end at x = {_fmt_x(x[-1])}")
        return False
    return True


def _check_ends(p, key, name, x, shapes, line, labels):
    """Mode shapes vanish at both ends (the train runs onto rigid track there)."""
    where = f" on line '{line}'" if line else ""
    peak = np.max(np.abs(shapes), axis=0)
    peak[peak == 0] = 1.0
    for end, row in (("first", 0), ("last", -1)):
        ratio = np.abs(shapes[row]) / peak
        j = int(np.argmax(ratio))
        if ratio[j] > END_TOL:
            p.add(key, name,
                  f"mode shapes that vanish at both ends of the track line{where} (the train "
                  f"runs onto rigid track there); mode {labels[j]} is {ratio[j]:.3g} x its "
                  f"maximum at the {end} station x = {_fmt_x(x[row])}: does the table cover "
                  "the whole bridge, from support to support?")
            return False
    return True


def _keep(freqs, n_modes, max_frequency):
    n = freqs.size if n_modes is None else min(int(n_modes), freqs.size)
    if max_frequency is not None:
        n = min(n, int(np.count_nonzero(freqs <= max_frequency * (1 + 1e-12))))
    return n


def _damping(p, damping_ratio, from_file, n, warnings):
    if damping_ratio is None:
        return np.zeros(n) if from_file is None else from_file[:n].copy()
    if from_file is not None and np.any(from_file[:n] != 0):
        warnings.append("bridge.damping_ratio overrides the damping ratios of the file")
    z = np.asarray(damping_ratio, float)
    if z.ndim == 0:
        return np.full(n, float(z))
    if z.size < n:
        p.add("damping_ratio", z.tolist(),
              f"a single ratio or at least one per retained mode ({n} modes)")
        return np.zeros(n)
    return z[:n].copy()


def _spline_slopes(x, values):
    return scipy.interpolate.CubicSpline(x, values, axis=0, bc_type="not-a-knot")(x, 1)


def _flip_positive(values, slopes, *others):
    """Flip each mode so that its largest value along the track line is positive."""
    j = np.arange(values.shape[1])
    sign = np.sign(values[np.argmax(np.abs(values), axis=0), j])
    sign[sign == 0] = 1.0
    return (values * sign, slopes * sign, *(o * sign for o in others))


def _supports_from(spans, given, x_end):
    if given is not None and given.size >= 2:
        return given
    if spans is not None:
        return np.concatenate([[0.0], np.cumsum(np.asarray(spans, float))])
    return np.array([0.0, x_end])


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
    return _Table(labels, freq, mm, zeta, flag, lines)


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
    values, slopes = _flip_positive(values, slopes)
    zeta = _damping(p, damping_ratio, None if z is None else z[order], n, warnings)
    p.raise_if_any()
    supports = _supports_from(spans, ln.supports, float(ln.x[-1]))
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
    return ImportResult(bridge, f.copy(), tuple(warnings), tuple(shown))


# ------------------------------------------------------------------------------ matrices


def _read_mtx(path: Path, key, name, p: _Problems):
    if not path.is_file():
        p.add(key, name, f"an existing Matrix Market file (looked for {path.resolve()})")
        return None
    try:
        a = scipy.io.mmread(str(path))
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        p.add(key, name, f"a Matrix Market file readable by scipy.io.mmread "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())[:160]})")
        return None
    a = scipy.sparse.csr_matrix(a, dtype=float) if not scipy.sparse.issparse(a) else a.tocsr()
    return a.astype(float)


def _check_matrix(p, key, name, a, what):
    if a.shape[0] != a.shape[1] or a.shape[0] == 0:
        p.add(key, name, f"a square {what} matrix (found {a.shape[0]} x {a.shape[1]})")
        return False
    if not np.all(np.isfinite(a.data)):
        k = int(np.flatnonzero(~np.isfinite(a.data))[0])
        coo = a.tocoo()
        bad = ~np.isfinite(coo.data)
        i, j = int(coo.row[bad][0]), int(coo.col[bad][0])
        del k
        p.add(key, name, f"finite entries (entry ({i}, {j}) is {coo.data[bad][0]}; "
                         f"{int(bad.sum())} non-finite)")
        return False
    big = float(np.max(np.abs(a.data), initial=0.0))
    if big == 0.0:
        p.add(key, name, f"a non-zero {what} matrix")
        return False
    d = (a - a.T).tocoo()
    if d.nnz:
        k = int(np.argmax(np.abs(d.data)))
        worst = abs(float(d.data[k]))
        if worst > SYMMETRY_TOL * big:
            p.add(key, name, f"a symmetric {what} matrix (max |A - A^T| = {worst:.3g} at "
                             f"({int(d.row[k])}, {int(d.col[k])}), {worst / big:.3g} of max |A|; "
                             f"tolerance {SYMMETRY_TOL:g})")
            return False
    return True


def _lowest_modes(K, M, n_modes, max_frequency):
    """Lowest modes of ``K phi = lam M phi`` by shift-invert Lanczos (eigsh).

    Returns at least ``n_modes`` modes (when given) and every mode up to
    ``max_frequency`` (Hz, when given; at most ``MAX_MODES``), ascending.  ``K - sigma M``
    is factorised once (``splu``) and reused when more modes are needed.
    """
    n = K.shape[0]
    lam_max = None if max_frequency is None else (2 * np.pi * max_frequency) ** 2
    k = max(1, min(int(n_modes) if n_modes is not None else 12, MAX_MODES))
    op = None
    while True:
        if k >= n - 1:  # eigsh needs k < n - 1: tiny problem, dense solver
            return scipy.linalg.eigh(K.toarray(), M.toarray())
        if op is None:
            lu = scipy.sparse.linalg.splu((K - SIGMA * M).tocsc())
            op = scipy.sparse.linalg.LinearOperator((n, n), matvec=lu.solve, dtype=float)
        lam, vec = scipy.sparse.linalg.eigsh(K, k=k, M=M, sigma=SIGMA, which="LM", OPinv=op)
        o = np.argsort(lam)
        lam, vec = lam[o], vec[:, o]
        if lam_max is None or lam[-1] > lam_max or k >= MAX_MODES:
            return lam, vec
        k = min(2 * k, MAX_MODES, n - 1)


def modes_from_matrices(
    K,
    M,
    x,
    dofs,
    rotation_dofs=None,
    fixed_dofs=(),
    *,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    rotation_sign: float = 1.0,
    vertical_dofs=None,
    spans=None,
    all_up_to: float | None = None,
    names: dict | None = None,
    line: str = "",
    dof_base: int = 0,
) -> ImportResult:
    """Modes of FE matrices, tabulated along a track line.

    Parameters
    ----------
    K, M : (n, n) array or sparse matrix
        Stiffness and mass (SI), symmetric, boundary conditions not yet applied for the
        ``fixed_dofs``.
    x : (n_station,) array
        Station abscissae along the track line (m), strictly increasing from 0.
    dofs : (n_station,) int array
        0-based vertical DOF of each station.
    rotation_dofs : (n_station,) int array, optional
        0-based rotation DOF (``rotation_sign * d(w)/dx``) of each station.
    fixed_dofs : sequence of int
        DOFs held at zero (supports).
    n_modes, max_frequency
        Keep the lowest ``n_modes`` and/or the modes up to ``max_frequency`` (Hz).
    damping_ratio : float or sequence
    rotation_sign : {1, -1}
        ``-1`` when the rotation DOF is ``-dw/dx`` in the sign of the vertical DOF.
    vertical_dofs : sequence of int, optional
        The vertical translation DOFs for the effective mass (default: ``dofs``).
    spans : sequence of float, optional
        Span lengths along the track line (coverage check, supports).
    all_up_to : float, optional
        Also compute the modes up to this frequency (Hz) for ``all_frequencies`` (cut-off
        checks); the bridge keeps only the requested ones.
    names : dict, optional
        File names for messages: keys "stiffness", "mass", "stations".
    line : str
        Name of the track line (messages, description).
    dof_base : int
        Numbering base of the DOFs in messages (the arrays are 0-based).

    Returns
    -------
    ImportResult
        ``bridge.effective_mass_fraction`` holds the effective vertical mass fraction of
        every retained mode.
    """
    names = {"stiffness": "K", "mass": "M", "stations": "stations", **(names or {})}
    p = _Problems()
    K = scipy.sparse.csr_matrix(K, dtype=float)
    M = scipy.sparse.csr_matrix(M, dtype=float)
    okk = _check_matrix(p, "stiffness_matrix", names["stiffness"], K, "stiffness")
    okm = _check_matrix(p, "mass_matrix", names["mass"], M, "mass")
    if okk and okm and K.shape != M.shape:
        p.add("mass_matrix", names["mass"],
              f"a mass matrix of the size of the stiffness matrix ({K.shape[0]} x "
              f"{K.shape[0]}; found {M.shape[0]} x {M.shape[1]})")
    p.raise_if_any()
    n = K.shape[0]
    diag = M.diagonal()
    if np.any(diag < 0):
        i = int(np.argmin(diag))
        p.add("mass_matrix", names["mass"],
              f"positive masses: no negative diagonal entry (DOF {i + dof_base} has "
              f"{diag[i]:.4g} kg; "
              f"{int(np.sum(diag < 0))} negative)")
    fixed = np.unique(np.asarray(list(fixed_dofs), dtype=np.int64))
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        p.add("fixed_dofs", (fixed + dof_base).tolist(),
              f"DOF numbers {dof_base} <= i < {n + dof_base} (the matrices have {n} DOFs)")
    x = np.asarray(x, float)
    dofs = np.asarray(dofs, dtype=np.int64)
    rot = None if rotation_dofs is None else np.asarray(rotation_dofs, dtype=np.int64)
    for what, d in (("dof", dofs), ("rotation_dof", rot)):
        if d is not None and d.size and (d.min() < 0 or d.max() >= n):
            i = int(np.flatnonzero((d < 0) | (d >= n))[0])
            p.add("station_map", names["stations"],
                  f"{what} values that are DOFs of the {n}-DOF matrices, {dof_base} .. "
                  f"{n - 1 + dof_base} (station x = {_fmt_x(x[i])} has {what} "
                  f"{d[i] + dof_base})")
    length = float(np.sum(spans)) if spans is not None else None
    _check_stations(p, "station_map", names["stations"], x, line, length)
    p.raise_if_any()

    free = np.setdiff1d(np.arange(n), fixed)
    Kf = K[free][:, free].tocsc()
    Mf = M[free][:, free].tocsc()
    up_to = [f for f in (max_frequency, all_up_to) if f is not None]
    try:
        lam, vec = _lowest_modes(Kf, Mf, n_modes, max(up_to) if up_to else None)
    except (RuntimeError, ValueError, np.linalg.LinAlgError,
            scipy.sparse.linalg.ArpackError) as exc:
        p.add("stiffness_matrix", names["stiffness"],
              "a stiffness matrix that, with the mass matrix and bridge.fixed_dofs, gives a "
              f"solvable eigenproblem (eigsh: {' '.join(str(exc).split())[:160]})")
        p.raise_if_any()
    lam_scale = max(abs(float(lam[-1])), 1.0)
    if lam[0] < -1e-8 * lam_scale:
        p.add("stiffness_matrix", names["stiffness"],
              f"a positive semi-definite stiffness (eigenvalue {lam[0]:.4g} rad^2/s^2 < 0: "
              "negative stiffness, or a mass matrix that is not positive definite)")
        p.raise_if_any()
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    if freqs[0] < RIGID_BODY_HZ:
        nr = int(np.count_nonzero(freqs < RIGID_BODY_HZ))
        p.add("fixed_dofs", (fixed + dof_base).tolist(),
              f"supports that stop every rigid-body motion: {nr} mode(s) at f < "
              f"{RIGID_BODY_HZ:g} Hz (the structure moves freely; list the support DOFs in "
              "bridge.fixed_dofs, or export K with the supports applied)")
        p.raise_if_any()
    # mass-normalise (eigsh already does up to round-off) and check
    gm = np.einsum("ij,ij->j", vec, Mf @ vec)
    if np.any(gm <= 0):
        p.add("mass_matrix", names["mass"],
              "a mass matrix positive definite on the vibrating DOFs (a mode has zero or "
              "negative generalised mass)")
        p.raise_if_any()
    vec = vec / np.sqrt(gm)
    err = float(np.max(np.abs(vec.T @ (Mf @ vec) - np.eye(vec.shape[1]))))
    if err > NORMALISATION_TOL:
        p.add("mass_matrix", names["mass"],
              f"mass-normalised modes, |Phi^T M Phi - I| < {NORMALISATION_TOL:g} (found "
              f"{err:.3g}: is M symmetric positive definite on the free DOFs?)")
        p.raise_if_any()
    n_keep = _keep(freqs, n_modes, max_frequency)
    if n_keep < 1:
        p.add("max_frequency", max_frequency,
              f"a frequency >= the first mode ({freqs[0]:.4g} Hz), else no mode is retained")
        p.raise_if_any()
    full = np.zeros((n, vec.shape[1]))
    full[free] = vec
    phi = full[:, :n_keep]

    # effective vertical mass (over the free DOFs)
    vdofs = dofs if vertical_dofs is None else np.asarray(vertical_dofs, dtype=np.int64)
    if vdofs.size and (vdofs.min() < 0 or vdofs.max() >= n):
        p.add("vertical_dofs", (vdofs[:8] + dof_base).tolist(),
              f"DOF numbers {dof_base} <= i < {n + dof_base} (the matrices have {n} DOFs)")
        p.raise_if_any()
    # r: unit vertical translation of the whole structure (support DOFs included), so
    # that phi^T M r = int m phi dx and r^T M r = the total vertical mass exactly for a
    # consistent-mass beam; phi is zero on the fixed DOFs
    r = np.zeros(n)
    r[np.unique(vdofs)] = 1.0
    m_tot = float(r @ (M @ r))
    gamma = phi.T @ (M @ r)
    eff = gamma**2 / m_tot if m_tot > 0 else np.full(n_keep, np.nan)

    warnings: list[str] = []
    if freqs[0] < LOW_FREQUENCY_HZ:
        warnings.append(f"bridge.stiffness_matrix: the first natural frequency is "
                        f"{freqs[0]:.3g} Hz, implausibly low for a railway bridge: check the "
                        f"units (N/m and kg) and that {names['stiffness']} and {names['mass']} "
                        "are not swapped")
    values = phi[dofs]
    if rot is not None:
        slopes = rotation_sign * phi[rot]
        spl = _spline_slopes(x, values)
        c = float(np.sum(slopes * spl) / max(np.linalg.norm(slopes) * np.linalg.norm(spl),
                                             1e-300))
        if c < -0.5:
            p.add("rotation_sign", rotation_sign,
                  f"rotation DOFs equal to {'+' if rotation_sign > 0 else '-'}dw/dx; they "
                  f"correlate {c:.2f} with the slope of the vertical station DOFs: set "
                  f"bridge.rotation_sign = {-int(rotation_sign)}")
            p.raise_if_any()
        if c < 0.9:
            warnings.append(f"bridge.station_map ({names['stations']}): the rotation DOFs "
                            f"correlate only {c:.2f} with the slope of the vertical station "
                            "DOFs (wrong rotation_dof column, or too few stations per mode?)")
    else:
        slopes = _spline_slopes(x, values)
    values, slopes = _flip_positive(values, slopes)
    zeta = _damping(p, damping_ratio, None, n_keep, warnings)
    p.raise_if_any()
    xs = x.copy()
    xs[0] = 0.0
    if length is not None:
        xs[-1] = length
    supports = _supports_from(spans, None, float(xs[-1]))
    if supports.size == 2:  # supports from the fixed station DOFs
        at = np.isin(dofs, fixed)
        if at.sum() >= 2:
            supports = xs[at]
    total = float(np.sum(eff))
    desc = (f"matrices {names['stiffness']} / {names['mass']} ({n} DOFs, {fixed.size} fixed): "
            f"{n_keep} modes, {x.size} stations{' on line ' + repr(line) if line else ''}, "
            f"effective vertical mass {100 * total:.1f}%")
    bridge = _br.ModalBridge(
        kind=_br.HERMITE, length=float(xs[-1]), frequencies=freqs[:n_keep].copy(),
        damping=zeta, nodes=xs, values=np.ascontiguousarray(values),
        slopes=np.ascontiguousarray(slopes), supports=np.asarray(supports, float),
        description=desc, effective_mass_fraction=eff,
    )
    return ImportResult(bridge, freqs.copy(), tuple(warnings), (line,) if line else ())


def _read_station_map(path: Path, name, p: _Problems, dof_base: int):
    import pandas as pd

    if not path.is_file():
        p.add("station_map", name, f"an existing station map CSV (looked for {path.resolve()})")
        return None
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except Exception as exc:  # noqa: BLE001
        p.add("station_map", name, f"a CSV station map ({type(exc).__name__}: "
                                f"{' '.join(str(exc).split())[:160]})")
        return None
    df.columns = [str(c).strip().lower() for c in df.columns]
    missing = [c for c in ("x", "dof") if c not in df.columns]
    if missing:
        p.add("station_map", name, f"CSV columns x, dof (+ optional rotation_dof, line); "
                                f"missing: {', '.join(missing)}; found: "
                                f"{', '.join(df.columns) or 'none'}")
        return None
    if df.empty:
        p.add("station_map", name, "at least 2 stations (the map is empty)")
        return None
    cols = [c for c in ("x", "dof", "rotation_dof") if c in df.columns]
    for c in cols:
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(float)
        bad = ~np.isfinite(v)
        if c != "x":
            bad |= np.isfinite(v) & (v != np.round(v))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            kind = "finite numbers (m)" if c == "x" else "integer DOF numbers"
            p.add("station_map", name, f"{kind} in column '{c}' (row {i + 2} has "
                                    f"{df[c].iloc[i]!r})")
            return None
        df[c] = v
    df["dof"] = df["dof"].astype(np.int64) - dof_base
    if "rotation_dof" in df.columns:
        df["rotation_dof"] = df["rotation_dof"].astype(np.int64) - dof_base
    if "line" not in df.columns:
        df["line"] = ""
    df["line"] = df["line"].astype(str).str.strip()
    return df


def _dof_list(p, key, value, dof_base, n_hint=None):
    if value is None:
        return None
    if isinstance(value, dict):
        start, step = int(value.get("start", dof_base)), int(value.get("step", 1))
        if n_hint is None:
            return None
        return np.arange(start - dof_base, n_hint, step, dtype=np.int64)
    return np.asarray(list(value), dtype=np.int64) - dof_base


def read_matrices(
    stiffness,
    mass,
    stations,
    *,
    fixed_dofs=None,
    dof_base: int = 0,
    track_line: str | None = None,
    n_modes: int | None = 10,
    max_frequency: float | None = None,
    damping_ratio=0.0,
    rotation_sign: float = 1.0,
    vertical_dofs=None,
    spans=None,
    all_up_to: float | None = None,
    names: dict | None = None,
) -> ImportResult:
    """Read K and M (Matrix Market) and a station map (CSV); compute the modes.

    Parameters
    ----------
    stiffness, mass, stations : str or path-like
        The files (formats in the module docstring).
    fixed_dofs : sequence of int, optional
        Support DOFs (in ``dof_base`` numbering); None/empty when already applied.
    dof_base : {0, 1}
        Numbering base of the DOFs in the station map, ``fixed_dofs`` and
        ``vertical_dofs``.
    vertical_dofs : sequence of int or {"start": i, "step": s}, optional
        Vertical translation DOFs for the effective mass (default: station DOFs).
    track_line, n_modes, max_frequency, damping_ratio, rotation_sign, spans, all_up_to
        As in :func:`modes_from_matrices`.
    names : dict, optional
        Names of the files in messages (keys "stiffness", "mass", "stations").

    Returns
    -------
    ImportResult
    """
    paths = {"stiffness": Path(stiffness), "mass": Path(mass), "stations": Path(stations)}
    names = {k: str(v) for k, v in paths.items()} | (names or {})
    p = _Problems()
    K = _read_mtx(paths["stiffness"], "stiffness_matrix", names["stiffness"], p)
    M = _read_mtx(paths["mass"], "mass_matrix", names["mass"], p)
    df = _read_station_map(paths["stations"], names["stations"], p, dof_base)
    p.raise_if_any()
    lines = [str(v) for v in dict.fromkeys(df["line"])]
    shown = [ln for ln in lines if ln]
    if track_line is None:
        if len(lines) > 1:
            p.add("track_line", None, "the track line the train runs on: one of "
                  + ", ".join(repr(n) for n in shown) + f" (the station map {names['stations']}"
                  " has several)")
            p.raise_if_any()
        line = lines[0]
    else:
        line = str(track_line)
        if line not in lines:
            p.add("track_line", repr(line), f"a track line of {names['stations']}: "
                  + (", ".join(repr(n) for n in shown) if shown else
                     "the map has no line column (one line only: remove bridge.track_line)"))
            p.raise_if_any()
    sub = df[df["line"] == line].sort_values("x", kind="stable")
    rot = sub["rotation_dof"].to_numpy() if "rotation_dof" in sub.columns else None
    fixed = _dof_list(p, "fixed_dofs", [] if fixed_dofs is None else fixed_dofs, dof_base)
    vd = _dof_list(p, "vertical_dofs", vertical_dofs, dof_base, K.shape[0])
    if vd is None and vertical_dofs is None:
        vd = df["dof"].to_numpy()  # every line's station DOFs
    res = modes_from_matrices(
        K, M, sub["x"].to_numpy(float), sub["dof"].to_numpy(), rot, fixed,
        n_modes=n_modes, max_frequency=max_frequency, damping_ratio=damping_ratio,
        rotation_sign=rotation_sign, vertical_dofs=vd, spans=spans, all_up_to=all_up_to,
        names=names, line=line, dof_base=dof_base,
    )
    return ImportResult(res.bridge, res.all_frequencies, res.warnings, tuple(shown))
