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
