"""Tables of the report: maxima per train and per output point, wheel unloading on the
deck and on the approach track separately, and the speed x train tables exported to CSV
and XLSX (units in every header).

Everything here reads the envelopes (never the time histories) of a prepared results
Dataset (:func:`vsi_numba.analysis.dataset.prepare`) and the check Datasets of
:func:`vsi_numba.analysis.checks.run_checks`.

Wheel unloading is split by where the axle was at its minimum contact force
(``position_of_min_contact_force``, m along the track): on the deck (0 <= x <= L) or on
the approach or exit track (x < 0 or x > L). The file keeps one minimum per run and
axle, so a record whose minimum was on the approach says nothing about the same axle's
unloading on the deck except that it is not larger; the tables count those records.
"""

from __future__ import annotations

import datetime
import io
import re
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from vsi_numba.analysis.checks import applicable_trains, prescribed_wheels
from vsi_numba.analysis.checks.wheels import TRANSITION_ZONE
from vsi_numba.analysis.dataset import nanargmax_case, nanmax
from vsi_numba.analysis.report.atomic import checkpoint
from vsi_numba.analysis.report.safe import sheet_frame, write_csv

#: Tolerance (m) of "on the deck" at the deck ends (a wheel exactly over a support).
END_TOLERANCE = 1e-6


def _bridge_length(ds: xr.Dataset) -> float | None:
    length = ds.attrs.get("bridge_length")
    try:
        length = float(length)
    except (TypeError, ValueError):
        return None
    return length if np.isfinite(length) and length > 0 else None


def wheel_unloading_by_zone(ds: xr.Dataset) -> xr.Dataset | None:
    """dQ/Q0 per (speed, train) on the bridge (the deck and :data:`TRANSITION_ZONE` beyond
    each end, the zone of the wheel-unloading check) and on the approach track beyond,
    separately.

    Parameters
    ----------
    ds : xarray.Dataset
        Prepared results with ``max_wheel_unloading`` and ``position_of_min_contact_force``
        on ``(speed, train, irregularity, wheel)`` and the attribute ``bridge_length`` (m).

    Returns
    -------
    xarray.Dataset or None
        ``deck`` and ``approach`` (speed, train): the largest dQ/Q0 over the axles and
        realisations whose minimum contact force lay there (NaN: none); ``deck_x`` and
        ``approach_x`` (m): the axle's position at that minimum; ``deck_wheel``,
        ``approach_wheel``: the axle; ``n_deck``, ``n_approach``: the records (run x
        axle) whose minimum lay there. Trains with prescribed forces (moving forces) are
        NaN. None when the file lacks a variable, the deck length, or any axle with
        varying contact force.
    """
    length = _bridge_length(ds)
    names = ("max_wheel_unloading", "position_of_min_contact_force")
    if length is None or any(n not in ds for n in names):
        return None
    fixed = prescribed_wheels(ds)
    if not bool(applicable_trains(ds, fixed).any()):
        return None
    dq = ds["max_wheel_unloading"].where(~fixed)
    x = ds["position_of_min_contact_force"].where(dq.notnull())
    # the bridge's zone of the wheel-unloading check: the deck and the transitions
    z = TRANSITION_ZONE + END_TOLERANCE
    on_deck = (x >= -z) & (x <= length + z)
    out = xr.Dataset(coords={"speed": ds["speed"], "train": ds["train"]})
    if "speed_kmh" in ds.coords:
        out = out.assign_coords(speed_kmh=ds["speed_kmh"])
    for zone, mask in (("deck", on_deck), ("approach", x.notnull() & ~on_deck)):
        val = dq.where(mask)
        stacked = val.stack(rec=("irregularity", "wheel")).fillna(-np.inf)
        i = stacked.argmax("rec")
        best = stacked.isel(rec=i)
        found = best > -np.inf
        out[zone] = best.where(found).drop_vars(["rec", "irregularity", "wheel"],
                                                errors="ignore")
        xs = x.stack(rec=("irregularity", "wheel")).isel(rec=i)
        out[f"{zone}_x"] = xs.where(found).drop_vars(["rec", "irregularity", "wheel"],
                                                     errors="ignore")
        wheel = xr.DataArray(stacked["wheel"].values[i.values], dims=i.dims,
                             coords={d: i[d] for d in i.dims})
        out[f"{zone}_wheel"] = wheel.where(found)
        out[f"n_{zone}"] = mask.sum(["irregularity", "wheel"])
    out["deck"].attrs.update(units="1", long_name="wheel unloading dQ/Q0 with the minimum "
                             "contact force on the deck")
    out["approach"].attrs.update(units="1", long_name="wheel unloading dQ/Q0 with the minimum "
                                 "contact force on the approach or exit track")
    out.attrs["bridge_length"] = length
    return out


def _gov(da: xr.DataArray) -> dict | None:
    g = nanargmax_case(da)
    return g


def wheel_unloading_zones_table(zones: xr.Dataset) -> pd.DataFrame:
    """The governing case of dQ/Q0 on the deck and on the approach track (two rows)."""
    rows = []
    t = f"{TRANSITION_ZONE:g} m"
    for zone, what in (("deck", f"on the bridge: the deck and {t} beyond its ends "
                                f"(−{t} ≤ x ≤ L + {t})"),
                       ("approach", f"on the approach / exit track (x < −{t} or "
                                    f"x > L + {t}; information)")):
        g = _gov(zones[zone])
        n = int(zones[f"n_{zone}"].sum())
        if g is None:
            rows.append({"Minimum contact force": what, "ΔQ/Q₀ max": np.nan, "Train": "",
                         "Speed [km/h]": np.nan, "Axle": "", "x of the axle [m]": np.nan,
                         "Records (run × axle)": n})
            continue
        sel = {"speed": g["speed"], "train": g["train"]}
        rows.append({
            "Minimum contact force": what,
            "ΔQ/Q₀ max": float(zones[zone].sel(sel)),
            "Train": str(g["train"]),
            "Speed [km/h]": float(zones["speed_kmh"].sel(speed=g["speed"])),
            "Axle": str(int(zones[f"{zone}_wheel"].sel(sel))),
            "x of the axle [m]": float(zones[f"{zone}_x"].sel(sel)),
            "Records (run × axle)": n,
        })
    return pd.DataFrame(rows)


def split_per_train(frame: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    """The table of :func:`maxima_per_train` as two printable tables: the deck (a, δ,
    φ'dyn) and the vehicles (ΔQ/Q₀ by zone, b_v; only trains that have them; None when
    none has)."""
    deck_cols = [c for c in frame.columns if c == "Train" or c.startswith(("a", "δ", "φ"))]
    veh_cols = ["Train", *[c for c in frame.columns if c.startswith(("ΔQ", "b_v"))]]
    deck = frame[deck_cols]
    if len(veh_cols) == 1:
        return deck, None
    veh = frame[veh_cols]
    veh = veh[veh.drop(columns="Train").notna().any(axis=1)]
    return deck, (veh if len(veh) else None)


def maxima_per_train(ds: xr.Dataset, results: dict, zones: xr.Dataset | None) -> pd.DataFrame:
    """One row per train: the largest value over speeds of each check with where it
    occurred (speed, deck x or axle position)."""
    rows = []
    acc = results.get("deck_acceleration")
    dyn = results.get("dynamic_amplification")
    cf = results.get("comfort")
    kmh = ds["speed_kmh"]
    for train in ds["train"].values:
        row = {"Train": str(train)}
        if isinstance(acc, xr.Dataset):
            v = acc["value"].sel(train=train)
            g = nanargmax_case(v)
            row["a max [m/s²]"] = np.nan if g is None else float(v.sel(speed=g["speed"]))
            row["a: speed [km/h]"] = np.nan if g is None else float(kmh.sel(speed=g["speed"]))
            row["a: x [m]"] = (np.nan if g is None else
                               float(acc["point_of_max"].sel(train=train, speed=g["speed"])))
        if "max_deck_displacement" in ds:
            d = nanmax(ds["max_deck_displacement"].sel(train=train), "irregularity")
            g = nanargmax_case(d)
            row["δ max [mm]"] = np.nan if g is None else 1e3 * float(d.sel(g))
            row["δ: speed [km/h]"] = (np.nan if g is None else
                                      float(kmh.sel(speed=g["speed"])))
            row["δ: x [m]"] = np.nan if g is None else float(g["point"])
        if isinstance(dyn, xr.Dataset):
            v = dyn["value"].sel(train=train)
            g = nanargmax_case(v)
            row["φ'dyn max [–]"] = np.nan if g is None else float(v.sel(speed=g["speed"]))
            row["φ': speed [km/h]"] = (np.nan if g is None else
                                       float(kmh.sel(speed=g["speed"])))
        if zones is not None:
            for zone, short in (("deck", "deck"), ("approach", "appr.")):
                v = zones[zone].sel(train=train)
                g = nanargmax_case(v)
                row[f"ΔQ/Q₀ {short} [–]"] = (np.nan if g is None else
                                             float(v.sel(speed=g["speed"])))
                row[f"ΔQ/Q₀ {short}: speed [km/h]"] = (
                    np.nan if g is None else float(kmh.sel(speed=g["speed"])))
                row[f"ΔQ/Q₀ {short}: x [m]"] = (
                    np.nan if g is None else
                    float(zones[f"{zone}_x"].sel(train=train, speed=g["speed"])))
        if isinstance(cf, xr.Dataset) and bool(cf["value"].notnull().any()):
            v = cf["value"].sel(train=train)
            g = nanargmax_case(v)
            row["b_v max [m/s²]"] = np.nan if g is None else float(v.sel(speed=g["speed"]))
            row["b_v: speed [km/h]"] = (np.nan if g is None else
                                        float(kmh.sel(speed=g["speed"])))
        rows.append(row)
    return pd.DataFrame(rows)


def maxima_per_point(ds: xr.Dataset) -> pd.DataFrame:
    """One row per output point: the largest deck acceleration and displacement there
    over every speed, train and realisation, with the case."""
    rows = []
    kmh = ds["speed_kmh"]
    for x in ds["point"].values:
        row = {"x [m]": float(x)}
        for name, label, scale, unit in (("max_deck_acceleration", "a", 1.0, "m/s²"),
                                         ("max_deck_displacement", "δ", 1e3, "mm")):
            if name not in ds:
                continue
            v = ds[name].sel(point=x)
            g = nanargmax_case(v)
            row[f"{label} max [{unit}]"] = np.nan if g is None else scale * float(v.sel(g))
            row[f"{label}: train"] = "" if g is None else str(g["train"])
            row[f"{label}: speed [km/h]"] = (np.nan if g is None else
                                             float(kmh.sel(speed=g["speed"])))
        rows.append(row)
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------------------
# Speed x train tables (CSV / XLSX)
# --------------------------------------------------------------------------------------


def speed_train_tables(ds: xr.Dataset, results: dict,
                       zones: xr.Dataset | None) -> dict[str, tuple[pd.DataFrame, str]]:
    """The speed x train tables: name -> (table, description).

    Each table has a column ``speed [km/h]`` and one column per train named
    ``<train> [<unit>]`` (ASCII units so any spreadsheet reads them).
    """
    out: dict[str, tuple[pd.DataFrame, str]] = {}
    kmh = np.asarray(ds["speed_kmh"].values, float)
    trains = [str(t) for t in ds["train"].values]

    def put(name, da, unit, description, scale=1.0):
        if da is None or not bool(da.notnull().any()):
            return
        da = da.transpose("speed", "train")
        frame = pd.DataFrame(np.asarray(da.values, float) * scale,
                             columns=[f"{t} [{unit}]" for t in trains])
        frame.insert(0, "speed [km/h]", kmh)
        out[name] = (frame, description)

    acc = results.get("deck_acceleration")
    if isinstance(acc, xr.Dataset):
        put("deck_acceleration", acc["value"], "m/s2",
            "peak vertical deck acceleration, max over the deck (design value over "
            "realisations)")
    if "max_deck_displacement" in ds:
        put("deck_displacement", nanmax(nanmax(ds["max_deck_displacement"], "point"),
                                        "irregularity"), "mm",
            "maximum deck displacement (total, positive down), max over the output points "
            "and realisations", 1e3)
    dyn = results.get("dynamic_amplification")
    if isinstance(dyn, xr.Dataset):
        put("dynamic_increment", dyn["value"], "-",
            "dynamic increment phi'_dyn = max|y_dyn| / max|y_stat| - 1")
    if zones is not None:
        put("wheel_unloading_deck", zones["deck"], "-",
            "wheel unloading dQ/Q0, axles whose minimum contact force was on the deck")
        put("wheel_unloading_approach", zones["approach"], "-",
            "wheel unloading dQ/Q0, axles whose minimum contact force was on the approach "
            "or exit track")
    wu = results.get("wheel_unloading")
    if isinstance(wu, xr.Dataset) and "min_contact_force" in wu:
        put("min_contact_force", wu["min_contact_force"], "kN",
            "minimum wheel-rail contact force per axle (design value)", 1e-3)
    cf = results.get("comfort")
    if isinstance(cf, xr.Dataset):
        put("carbody_acceleration", cf["value"], "m/s2",
            "vertical car-body acceleration (comfort), max over the vehicles")
    return out


#: Significant digits of the numbers in the CSV and XLSX files: the results carry more,
#: but the last ones are noise of the arithmetic (another machine, another order of
#: the sums changes the 13th-15th digit); written to 7, the same results give the same
#: files.
SIGNIFICANT = 7
#: ``float_format`` of the CSV files (:data:`SIGNIFICANT` digits).
CSV_FLOAT_FORMAT = f"%.{SIGNIFICANT}g"
#: Significant digits the report keeps of the results it reads (:func:`denoised`).
RESULT_DIGITS = 12


def _text_rounded(values, digits: int) -> list[float]:
    return [float(f"{x:.{digits}g}") for x in values]


def rounded(a, digits: int) -> np.ndarray:
    """``float(f"{x:.{digits}g}")`` of every element of ``a`` (float64, same shape), bit
    for bit, computed on whole arrays.

    For a finite non-zero x with decimal exponent e, the text holds the integer m =
    x 10^k (k = digits - 1 - e) rounded half-even, read back as m / 10^k (m 10^-k for
    k < 0): with 10^|k| a float64 (|k| <= 22) and |m| < 2^53 that is one correctly rounded
    operation, as the reading of the text.  The product x 10^k is itself rounded (by half
    an ulp of a number below 10^digits, far less than 1e-3 for digits <= 15), so m is
    right wherever the product lies more than 1e-3 from a half-integer and has exactly
    ``digits`` digits; NaN reads back as the positive NaN, infinities and zeros as
    themselves; the other elements (near-ties, a wrong e, |k| beyond 22) are formatted
    as text."""
    a = np.asarray(a, dtype=np.float64)
    flat = a.ravel()
    out = np.empty_like(flat)
    if digits > 15:
        out[:] = _text_rounded(flat.tolist(), digits)
        return out.reshape(a.shape)
    finite = np.isfinite(flat) & (flat != 0.0)
    mag = np.abs(np.where(finite, flat, 1.0))
    with np.errstate(all="ignore"):
        e = np.floor(np.log10(mag)).astype(np.int64)
        k = digits - 1 - e
        ok = finite & (np.abs(k) <= 22)
        kk = np.where(ok, k, 0)
        p10 = 10.0 ** np.abs(kk)  # exact: integer powers of ten up to 1e22
        y = np.where(kk >= 0, flat * p10, flat / p10)
        m = np.rint(y)
        frac = np.abs(y - np.trunc(y))
        am = np.abs(m)
        ok &= (np.abs(frac - 0.5) > 1e-3) & (am >= 10.0 ** (digits - 1)) & (
            am < 10.0 ** digits)
        out[:] = np.where(kk >= 0, m / p10, m * p10)
    # the text of NaN reads back as the positive quiet NaN, of +-inf and +-0 as themselves
    nan = np.isnan(flat)
    out[nan] = np.nan
    same = np.isinf(flat) | (flat == 0.0)
    out[same] = flat[same]
    slow = ~(ok | nan | same)
    if slow.any():
        out[slow] = _text_rounded(flat[slow].tolist(), digits)
    return out.reshape(a.shape)


def significant(frame: pd.DataFrame, digits: int = SIGNIFICANT) -> pd.DataFrame:
    """``frame`` with every float cell rounded to ``digits`` significant digits (the
    decimal text of the value read back: what the CSV files hold)."""
    out = frame.copy()
    for j in range(out.shape[1]):
        col = out.iloc[:, j]
        if pd.api.types.is_float_dtype(col.dtype):
            vals = col.to_numpy(dtype=float)
            out.isetitem(j, np.where(np.isfinite(vals), rounded(vals, digits), vals))
    return out


def denoised(ds: xr.Dataset, digits: int = RESULT_DIGITS) -> xr.Dataset:
    """``ds`` with every float64 data variable rounded to ``digits`` significant digits
    (its decimal text read back, the same on every machine).

    The results of the same study differ between machines in the last digits (the order
    of the floating-point sums); a value that lies on a rounding boundary of the report
    (an axle position of 25.125 m, shown to 4 digits) would then print differently.
    Rounded to 12 digits first, both read the same, and every table, sentence and figure
    of the report follows.  Coordinates are left as they are (they select the time
    histories in the file).
    """
    out = ds.copy()
    for name, v in ds.data_vars.items():
        if v.dtype != np.float64:
            continue
        out[name] = v.copy(data=rounded(v.values, digits))
    return out


def write_tables(tables: dict[str, tuple[pd.DataFrame, str]], extra: dict[str, pd.DataFrame],
                 outdir: Path) -> list[Path]:
    """Write every speed x train table as ``tables/<name>.csv`` and all of them (plus
    ``extra`` sheets) into ``tables.xlsx``; return the files written."""
    outdir = Path(outdir)
    folder = outdir / "tables"
    folder.mkdir(exist_ok=True)
    for old in folder.glob("*.csv"):  # no stale table of an earlier report
        old.unlink()
    written = []
    for name, (frame, _) in tables.items():
        path = folder / f"{name}.csv"
        write_csv(frame, path, float_format=CSV_FLOAT_FORMAT)
        checkpoint()
        written.append(path)
    xlsx = outdir / "tables.xlsx"
    index = pd.DataFrame({"sheet": list(extra) + list(tables),
                          "content": [""] * len(extra) + [d for _, d in tables.values()]})
    # text cells through the CSV/XLSX sanitiser: no formula, no control character
    # and the numbers to SIGNIFICANT digits, as in the CSV files
    sheets = [("contents", sheet_frame(index))]
    sheets += [(name[:31], sheet_frame(significant(frame))) for name, frame in extra.items()]
    sheets += [(name[:31], sheet_frame(significant(frame)))
               for name, (frame, _) in tables.items()]
    write_xlsx(xlsx, sheets)
    checkpoint()
    written.append(xlsx)
    return written


#: Longest text of a cell (Excel's limit; pandas cuts longer ones to it).
MAX_CELL_TEXT = 32767


def _xlsx_value(v):
    """A cell's value as ``DataFrame.to_excel`` writes it through openpyxl: NaN and
    None as an empty cell, +-inf as the text ``inf`` / ``-inf``, numpy numbers as
    Python numbers, anything else as its text."""
    if pd.api.types.is_scalar(v) and pd.isna(v):
        return ""
    if pd.api.types.is_bool(v):
        return bool(v)
    if pd.api.types.is_integer(v):
        return int(v)
    if pd.api.types.is_float(v):
        v = float(v)
        return "inf" if v == np.inf else "-inf" if v == -np.inf else v
    return str(v)[:MAX_CELL_TEXT]


def write_xlsx(path, sheets: list[tuple[str, pd.DataFrame]]) -> Path:
    """Write ``sheets`` (name, frame: its columns the header row, no index) into the
    workbook ``path``: the cells ``DataFrame.to_excel`` would write, each column as wide
    as its longest text (8 to 48 characters), the first row and column frozen, fixed
    dates (:data:`XLSX_DATE`).  openpyxl's write-only mode: no cell object is kept; its
    zip is made uncompressed in memory, the file compressed once
    (:func:`reproducible_zip`: the same bytes as openpyxl's file re-packed)."""
    from openpyxl import Workbook
    from openpyxl.utils import get_column_letter
    from openpyxl.writer.excel import ExcelWriter

    book = Workbook(write_only=True)
    for name, frame in sheets:
        sheet = book.create_sheet(name)
        rows = [[_xlsx_value(c) for c in frame.columns]]
        rows += [[_xlsx_value(v) for v in row]
                 for row in frame.itertuples(index=False, name=None)]
        for j in range(len(rows[0])):
            width = max(len(str(r[j])) for r in rows)
            sheet.column_dimensions[get_column_letter(j + 1)].width = min(max(width, 8), 48)
        sheet.freeze_panes = "B2"
        for row in rows:
            sheet.append(row)
    book.properties.created = book.properties.modified = XLSX_DATE
    # what Workbook.save does (openpyxl.writer.excel.save_workbook) but into an
    # uncompressed zip in memory: its entries are compressed once, into the file
    raw = io.BytesIO()
    ExcelWriter(book, zipfile.ZipFile(raw, "w", zipfile.ZIP_STORED, allowZip64=True)).save()
    reproducible_zip(path, raw)
    return Path(path)


#: The date written into the spreadsheets' properties and zip entries: a report of the
#: same results is the same file (the run's time is in the results file's history).
XLSX_DATE = datetime.datetime(2000, 1, 1)


def fix_xlsx_dates(writer) -> None:
    """Give the workbook of an open ``pd.ExcelWriter`` fixed creation/modification dates."""
    props = writer.book.properties
    props.created = props.modified = XLSX_DATE


def reproducible_zip(path, source=None) -> None:
    """Rewrite the zip file ``path`` (an XLSX) with fixed entry times, in place; or write
    it so from the zip ``source`` (a binary file object)."""
    path = Path(path)
    with zipfile.ZipFile(path if source is None else source) as src:
        entries = [(info, src.read(info)) for info in src.infolist()]
    tmp = path.with_name(path.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for info, data in entries:
            if info.filename == "docProps/core.xml":  # openpyxl stamps the save time
                data = re.sub(rb"(<dcterms:(?:created|modified)[^>]*>)[^<]*(<)",
                              rb"\g<1>" + XLSX_DATE.strftime("%Y-%m-%dT%H:%M:%SZ").encode()
                              + rb"\g<2>", data)
            fixed = zipfile.ZipInfo(info.filename, date_time=XLSX_DATE.timetuple()[:6])
            fixed.compress_type = zipfile.ZIP_DEFLATED
            fixed.external_attr = info.external_attr
            dst.writestr(fixed, data)
    tmp.replace(path)


def ascii_units(frame: pd.DataFrame) -> pd.DataFrame:
    """The same table with ASCII headers for CSV/XLSX (m/s² -> m/s2, – -> -)."""
    repl = {"²": "2", "–": "-", "₀": "0", "Δ": "d", "φ": "phi", "δ": "delta", "≤": "<=",
            "×": "x"}

    def clean(text: str) -> str:
        for a, b in repl.items():
            text = text.replace(a, b)
        return text

    return frame.rename(columns=lambda c: clean(str(c)))
