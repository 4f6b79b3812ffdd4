"""``vsi trains``: the train library (:mod:`vsi_numba.model.library`) as tables."""

from __future__ import annotations

from vsi_numba.cli.common import EXIT_USAGE, Printer


def trains_command(name: str | None = None) -> int:
    """Print the library (or one train's axles) with rich; return the exit code.

    Parameters
    ----------
    name : str, optional
        A train name: print its header, data-status warning and axle table.  None:
        print the library table with each train's status.

    Returns
    -------
    int
        0 on success, 2 for an unknown name (after a one-line message on stderr).
    """
    from rich.table import Table

    from vsi_numba.model import library as lib
    from vsi_numba.model.library.data import _WARN_STATUSES, _spec
    from vsi_numba.model.library.tables import _description

    pr = Printer()
    out = pr.out
    from vsi_numba.model.library import extra

    if name is None:
        import pandas as pd

        df = pd.concat([lib.library_table(), pd.DataFrame([extra.hslm_b_row()])],
                       ignore_index=True)
        table = Table(title="vsi_numba train library", box=None, padding=(0, 1, 0, 0),
                      header_style="bold underline", title_justify="left",
                      caption="static whole-axle loads; D = regular coach length; HSLM-A: "
                              "moving forces only, others: interaction or moving forces",
                      caption_justify="left")
        # (no square brackets in headers: rich would read "[m]" as markup); the whole
        # table fits 80 columns, and names never wrap (users copy them)
        for col, just in (("name", "left"), ("status", "left"), ("axles", "right"),
                          ("length\nm", "right"), ("mass\nt", "right"),
                          ("max axle\nkN", "right"), ("D\nm", "right")):
            table.add_column(col, justify=just, no_wrap=True)
        style = {"suspect": "red", "reconstruction": "yellow", "secondary": "yellow"}
        for r in df.itertuples(index=False):
            st = f"[{style[r.status]}]{r.status}[/]" if r.status in style else r.status
            if r.name == extra.HSLM_B_NAME:  # no axle data: N and d from the config
                table.add_row(r.name, r.status, "N", "-", "-", f"{r.max_axle_load_kN:.1f}",
                              "d")
                continue
            table.add_row(
                r.name, st, str(int(r.axles)), f"{r.length_m:.3f}", f"{r.total_mass_t:.1f}",
                f"{r.max_axle_load_kN:.1f}",
                f"{r.regular_length_m:g}" if r.regular_length_m else "-",
            )
        out.print(table)
        flagged = [n for n, s in zip(df["name"], df["status"], strict=True)
                   if s in _WARN_STATUSES]
        if flagged:
            out.print(f"[yellow]Uncertain data (suspect / reconstruction): {', '.join(flagged)}."
                      " `vsi trains NAME` shows the documented doubts.[/]")
        out.print(f"HSLM-B: {extra.HSLM_B_MISSING}.", highlight=False, markup=False)
        return 0
    if name.strip().casefold() == extra.HSLM_B_NAME.casefold():
        out.print(f"[bold]{extra.HSLM_B_NAME}[/] - status: {extra.HSLM_B_STATUS}",
                  highlight=False)
        out.print(f"{extra.HSLM_B_MISSING}.", highlight=False, markup=False)
        return 0
    try:
        canon, kind, spec = _spec(name)
    except lib.UnknownTrainError as exc:
        pr.line(f"error: {exc}", stderr=True)
        return EXIT_USAGE
    df = lib.axle_table(canon)
    t = lib.get_train(canon, "moving_force")
    out.print(f"[bold]{canon}[/] - {_description(kind, spec)}", highlight=False)
    out.print(f"status: {t.status} ({lib.STATUS_MEANING.get(t.status, '')})", highlight=False)
    out.print(f"axles: {len(df)}, first to last axle {t.length:.3f} m, total "
              f"{t.total_mass / 1e3:.1f} t", highlight=False)
    if lib.status_warning(canon):
        out.print(f"[yellow]warning: data status {t.status!r}; do not use this train for "
                  "validation. Documented doubts (docs/manual/trains.md):[/]", highlight=False)
        for d in lib.documented_doubts(canon):
            out.print(f"  - {d}", markup=False, highlight=False)
    table = Table(title=f"{canon}: axles", box=None,
                  padding=(0, 1, 0, 0), header_style="bold underline", title_justify="left")
    for col in ("axle", "position\nm", "static load\nkN", "vehicle"):
        table.add_column(col, justify="left" if col == "vehicle" else "right",
                         no_wrap=col != "vehicle")
    for r in df.itertuples(index=False):
        table.add_row(str(r.axle), f"{r.position_m:.4f}", f"{r.static_load_kN:.2f}", r.vehicle)
    out.print(table)
    return 0


def signature_command(name: str | None, damping_pct: float | None = None, plot=None) -> int:
    """``vsi trains NAME --signature``: the train's DER and LIR signatures and their
    comparison with the HSLM-A envelope (EN 1991-2 Annex E [R]); return the exit code.

    Parameters
    ----------
    name : str
        A library train, or an axle-load CSV file (columns position in m, load in kN).
    damping_pct : float, optional
        Damping ratio in % (default: the code profile's ``signature_damping``).
    plot : path, optional
        PNG of the signature against the envelope.
    """
    from pathlib import Path

    import numpy as np

    from vsi_numba.analysis import signature as sg
    from vsi_numba.code_profile import default_profile
    from vsi_numba.model import library as lib
    from vsi_numba.model.library import extra

    pr = Printer()
    if not name:
        pr.line("error: --signature needs a train name or an axle-load CSV file", stderr=True)
        return EXIT_USAGE
    if plot is not None:
        from vsi_numba.analysis.figure_file import figure_problem

        problem = figure_problem(plot, "--plot figure")
        if problem is not None:
            pr.line(f"error: {problem}", stderr=True)
            return EXIT_USAGE
    profile = default_profile()
    zeta = profile["signature_damping"] if damping_pct is None else damping_pct / 100.0
    if not (np.isfinite(zeta) and 0.0 <= zeta < 0.2):
        pr.line(f"error: --damping {damping_pct!r}: expected a damping ratio in % from 0 "
                "to 20", stderr=True)
        return EXIT_USAGE
    try:
        if name.lower().endswith(".csv"):
            train = extra.axle_list_train(Path(name))
        elif name.strip().casefold() == extra.HSLM_B_NAME.casefold():
            pr.line(f"error: {extra.HSLM_B_MISSING}; its signature needs N and d",
                    stderr=True)
            return EXIT_USAGE
        else:
            train = sg.train_by_name(name)
    except (lib.UnknownTrainError, extra.AxleFileError) as exc:
        pr.line(f"error: {exc}", stderr=True)
        return EXIT_USAGE
    cov = sg.compare_with_hslm(train, zeta, profile=profile)
    s = cov.train
    out = pr.out
    out.print(f"{s.name}: dynamic signature, damping {100 * zeta:g} % "
              f"({sg.SIGNATURE_CLAUSE} [R])", highlight=False, markup=False)
    # the peaks of the DER signature: local maxima above half of the largest
    d = s.der
    peaks = [i for i in range(1, d.size - 1) if d[i] >= d[i - 1] and d[i] > d[i + 1]
             and d[i] > 0.5 * d.max()]
    peaks = sorted(peaks, key=lambda i: -d[i])[:8]
    from rich.table import Table

    table = Table(title="largest peaks of the DER signature", box=None, padding=(0, 1, 0, 0),
                  header_style="bold underline", title_justify="left")
    for col in ("lambda\nm", "DER G\nkN", "LIR G_r\nkN", "HSLM-A\nenvelope kN", "ratio",
                "governing\nHSLM"):
        table.add_column(col, justify="right", no_wrap=True)
    for i in sorted(peaks, key=lambda i: s.wavelength[i]):
        table.add_row(f"{s.wavelength[i]:.2f}", f"{d[i] / 1e3:.0f}", f"{s.lir[i] / 1e3:.0f}",
                      f"{cov.envelope[i] / 1e3:.0f}", f"{d[i] / cov.envelope[i]:.2f}",
                      str(cov.governing[i]))
    out.print(table)
    verdict = "covered" if cov.covered else "NOT covered"
    out.print(f"{verdict} by HSLM-A over lambda = {s.wavelength[0]:g} to "
              f"{s.wavelength[-1]:g} m: largest ratio {cov.ratio:.3f} at lambda = "
              f"{cov.wavelength_at_ratio:.2f} m (limit {profile['signature_ratio_limit']:g}; "
              "EN 1991-2 Annex E [R]: a train covered by the HSLM-A envelope is covered by "
              "a design with HSLM-A; otherwise run the dynamic analysis with the train)",
              highlight=False, markup=False)
    if not cov.covered:
        out.print("the comparison is pointwise in lambda: the HSLM-A peaks sit at lambda = "
                  "D / i (coach lengths D = 18 .. 27 m) and the envelope dips between them; "
                  "where the train is above it, the envelope reaches the train's value "
                  + (f"within {100 * cov.shift:.1f} % of the wavelength (of the speed)"
                     if np.isfinite(cov.shift) else "nowhere on the grid")
                  + ": not shown covered by the signature route, not a verdict on the "
                  "bridge", highlight=False, markup=False)
    if plot is not None:
        from vsi_numba.io.atomic import describe

        try:
            sg.plot_signature(cov, plot)
        except OSError as exc:
            pr.line(f"error: cannot write {plot}: {describe(exc)}; nothing was written",
                    stderr=True)
            return EXIT_USAGE
        out.print(f"wrote {plot}", highlight=False, markup=False)
    return 0
