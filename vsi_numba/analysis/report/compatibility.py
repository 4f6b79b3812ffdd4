"""The report's answer to ``[compatibility]`` (:mod:`vsi_numba.config.compatibility`): is
the train compatible with the bridge?  From the checks of the report (summary table):
compatible when no check fails; the governing check is the one of largest utilisation,
its margin 1 - utilisation.  Beside it, the train's DER signature against the HSLM-A
envelope over the wavelengths v / f0 of the study's speeds (EN 1991-2 Annex E [R],
ERRI D214): information on whether an HSLM-A design covers the train, not the verdict,
which is the dynamic analysis with the train itself."""

from __future__ import annotations

import numpy as np
import pandas as pd

from vsi_numba.analysis.report.document import Figure, Section, Table
from vsi_numba.analysis.report.safe import md


def compatibility_of(ds) -> dict | None:
    """The stored ``[compatibility]`` section, or None."""
    from vsi_numba.analysis.checks.determinant import results_config

    c = results_config(ds).get("compatibility")
    return c if isinstance(c, dict) else None


def _damping(ds) -> float:
    """First-mode damping ratio of the stored bridge (the Table 6.6 rule evaluated)."""
    from vsi_numba.analysis.checks.determinant import results_config
    from vsi_numba.en1991 import damping_lower_bound

    b = results_config(ds).get("bridge", {})
    z = b.get("damping_ratio", 0.01)
    if isinstance(z, list) and z:
        z = z[0]
    if isinstance(z, str):
        spans = b.get("spans") or [20.0]
        try:
            return damping_lower_bound(b.get("deck_type", "prestressed_concrete"),
                                       float(min(spans)))
        except ValueError:
            return 0.01
    return float(z) if isinstance(z, int | float) and z > 0 else 0.01


def verdict(table: pd.DataFrame) -> dict:
    """Compatible?, the governing check (largest utilisation) and its margin, from the
    report's summary table (rows with a pass / FAIL result)."""
    t = table[table["result"].isin(["pass", "FAIL"])].copy()
    t["utilisation"] = pd.to_numeric(t["utilisation"], errors="coerce")
    t = t[np.isfinite(t["utilisation"])]
    if t.empty:
        return {"compatible": None, "check": "", "utilisation": np.nan, "margin": np.nan,
                "train": "", "speed_kmh": np.nan, "failed": []}
    g = t.loc[t["utilisation"].idxmax()]
    failed = [str(c) for c in t.loc[t["result"] == "FAIL", "check"]]
    return {"compatible": not failed, "check": str(g["check"]),
            "utilisation": float(g["utilisation"]), "margin": 1.0 - float(g["utilisation"]),
            "train": str(g.get("governing_train", "")),
            "speed_kmh": float(g.get("governing_speed_kmh", np.nan)), "failed": failed,
            "value": g.get("value"), "limit": g.get("limit"), "units": g.get("units", ""),
            "clause": str(g.get("clause", ""))}


def compatibility_section(ds, table: pd.DataFrame) -> Section | None:
    """The section (first of the report's body), or None without ``[compatibility]``."""
    c = compatibility_of(ds)
    if c is None:
        return None
    from vsi_numba.analysis import signature as sg
    from vsi_numba.analysis.dataset import bridge_frequencies

    name = str(c["train"])
    line = float(c["line_speed_kmh"])
    factor = float(c["speed_factor"])
    v = verdict(table)
    blocks: list = []
    if v["compatible"] is None:
        head = "**Not decided**: the results allow no pass/fail check."
    else:
        word = "COMPATIBLE" if v["compatible"] else "NOT COMPATIBLE"
        head = (f"**{word}**: train {md(name)} on this bridge at speeds up to "
                f"{factor:g} × {line:g} = {factor * line:g} km/h (line speed "
                f"{line:g} km/h + {100 * (factor - 1):.0f} %; TSI INF 4.2.8.1.3 / IG02042 "
                "practice [R], code profile `compatibility_speed_factor`). Governing check: "
                f"**{md(v['check'])}**, utilisation {v['utilisation']:.3f}, margin "
                f"**{100 * v['margin']:+.1f} %** ({md(v['train'])}"
                + (f", {v['speed_kmh']:.0f} km/h" if np.isfinite(v['speed_kmh']) else "")
                + f"; {md(v['clause'])}).")
        if v["failed"]:
            head += " Failed: " + "; ".join(md(f) for f in v["failed"]) + "."
    blocks.append(head)
    # the signature on the bridge's wavelengths
    f = bridge_frequencies(ds)
    speeds = np.asarray(ds["speed"].values, float)
    if f.size and name in [str(t) for t in ds["train"].values]:
        f0 = float(f[0])
        lam = np.linspace(speeds.min() / f0, speeds.max() / f0, 1500)
        wp = np.asarray(ds["wheel_position"].sel(train=name).values, float)
        wl = np.asarray(ds["static_wheel_load"].sel(train=name).values, float)
        ok = np.isfinite(wp) & np.isfinite(wl) & (wl > 0)
        x = wp[ok] - wp[ok].min()
        order = np.argsort(x, kind="stable")
        x, q = x[order], wl[ok][order]
        keys, inv = np.unique(np.round(x, 9), return_inverse=True)
        q = np.bincount(inv, weights=q)
        zeta = _damping(ds)
        from vsi_numba.model.vehicle import Train, point_loads

        train = Train(name, (point_loads(keys, q, name=name),), (0.0,))
        cov = sg.compare_with_hslm(train, zeta, lam)
        word = "within" if cov.covered else "above"
        blocks.append(
            f"Dynamic signature (DER, ERRI D214; EN 1991-2 Annex E [R]) of {md(name)} with "
            f"the bridge's damping {100 * zeta:.2g} % on the wavelengths λ = v / f₀ of the "
            f"study's speeds (f₀ = {f0:.3g} Hz, λ = {lam[0]:.3g} to {lam[-1]:.3g} m): "
            f"**{word}** the HSLM-A envelope (largest ratio {cov.ratio:.2f} at λ = "
            f"{cov.wavelength_at_ratio:.2f} m, i.e. {cov.wavelength_at_ratio * f0 * 3.6:.0f} "
            "km/h). A train within the envelope is covered by an HSLM-A design of the "
            "bridge. The comparison is pointwise in λ: the HSLM-A peaks sit at λ = D / i "
            "(coach lengths D = 18 to 27 m) and the envelope dips between them"
            + (f"; here it reaches the train's signature within {100 * cov.shift:.1f} % of "
               "the wavelength (of the speed)" if not cov.covered and np.isfinite(cov.shift)
               else "")
            + ". Above the envelope means not shown covered by the signature route; the "
            "dynamic analysis with the train (the verdict above) decides.")
        frame = pd.DataFrame({"λ [m]": [cov.wavelength_at_ratio],
                              "speed [km/h]": [cov.wavelength_at_ratio * f0 * 3.6],
                              "train DER [kN]": [cov.train.der.max() / 1e3],
                              "ratio to HSLM-A": [cov.ratio]})
        blocks.append(Table(frame, "Largest ratio of the train's signature to the HSLM-A "
                                   "envelope on the bridge's wavelengths"))
        fig = _figure(cov, f0)
        blocks.append(Figure(fig, "signature.png", f"DER signature of {md(name)} and the "
                                                   "HSLM-A1..A10 envelope"))
    return Section("Compatibility", blocks)


def _figure(cov, f0):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = cov.train
    fig, ax = plt.subplots(figsize=(7.5, 3.8), layout="constrained")
    ax.fill_between(s.wavelength, 0, cov.envelope / 1e3, color="0.85",
                    label="HSLM-A1..A10 envelope (DER)")
    ax.plot(s.wavelength, s.der / 1e3, color="C0", label=f"{s.name}: DER")
    ax.plot(s.wavelength, s.lir / 1e3, color="C1", ls="--", lw=0.9, label=f"{s.name}: LIR")
    ax.set_xlabel("wavelength λ = v / f₀ (m)")
    ax.set_ylabel("signature (kN)")
    top = ax.secondary_xaxis("top", functions=(lambda lam: lam * f0 * 3.6,
                                               lambda v: v / (f0 * 3.6)))
    top.set_xlabel("speed (km/h)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig
