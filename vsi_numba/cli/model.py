"""``vsi modes`` and ``vsi profile``: look at a configuration's bridge modes and track
irregularities before a long sweep (tables here, figures in
:mod:`vsi_numba.analysis.model_plots`)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config


def modes_command(config, output=None) -> int:
    """``vsi modes``: print the retained modes of a config's bridge and plot them.

    Returns the exit code (2 for a config error).
    """
    from rich.markup import escape
    from rich.table import Table

    from vsi_numba.config import ConfigError

    pr = Printer()
    if _bad_figure(pr, output, "-o"):
        return EXIT_USAGE
    cfg = load_config(config, pr)
    if cfg is None:
        return EXIT_USAGE
    try:
        bridge = cfg.build_bridge()
    except ConfigError as exc:
        pr.config_error(config, exc)
        return EXIT_USAGE
    for w in cfg.warnings:
        pr.warning(w)
    console = pr.out
    console.print(f"[bold]{escape(cfg.title)}[/bold]", highlight=False)
    pr.line(bridge.description or "")
    sup = ", ".join(f"{s:g}" for s in bridge.supports)
    console.print(f"length {bridge.length:g} m along the track; supports at x = {sup} m",
                  highlight=False)
    table = Table(title=f"{bridge.n_modes} retained modes")
    table.add_column("mode", justify="right")
    table.add_column("f (Hz)", justify="right")
    table.add_column("zeta (%)", justify="right")
    eff = getattr(bridge, "effective_mass_fraction", None)
    if eff is not None:
        table.add_column("eff. vertical mass (%)", justify="right")
        table.add_column("cumulative (%)", justify="right")
    cum = 0.0
    for j in range(bridge.n_modes):
        row = [str(j + 1), f"{bridge.frequencies[j]:.4f}", f"{100 * bridge.damping[j]:.2f}"]
        if eff is not None:
            cum += float(eff[j])
            row += [f"{100 * eff[j]:.2f}", f"{100 * cum:.2f}"]
        table.add_row(*row)
    console.print(table)
    if output is not None and bridge.n_modes == 0:
        console.print("no modes (rigid track): nothing to plot", highlight=False)
    elif output is not None:
        from vsi_numba.analysis.model_plots import plot_modes

        if _figure_failed(pr, output, lambda: plot_modes(bridge, output, title=cfg.title)):
            return EXIT_USAGE
        console.print(f"mode shapes plotted to {output}", highlight=False)
    return 0


def _bad_figure(pr: Printer, path, option: str) -> bool:
    """Say why a figure cannot be written to ``path`` (None: no figure asked for)."""
    if path is None:
        return False
    from vsi_numba.analysis.figure_file import figure_problem

    problem = figure_problem(path, f"{option} figure")
    if problem is not None:
        pr.error(problem)
    return problem is not None


def _figure_failed(pr: Printer, path, draw) -> bool:
    """Run ``draw()``; on a write failure say so (nothing is left) and return True."""
    from vsi_numba.io.atomic import describe

    try:
        draw()
    except OSError as exc:
        pr.error(f"cannot write {path}: {describe(exc)}; nothing was written")
        return True
    return False


def profile_command(config: Path, plot: Path | None) -> int:
    """``vsi profile``: print each realisation's statistics over the run; draw them when
    ``plot`` is given.

    Returns the exit code (2 for a config error).
    """
    import numpy as np
    from rich.table import Table

    from vsi_numba.model.irregularity import profile_range

    pr = Printer()
    if _bad_figure(pr, plot, "--plot"):
        return EXIT_USAGE
    cfg = load_config(config, pr)
    if cfg is None:
        return EXIT_USAGE
    bridge = cfg.build_bridge()
    trains = cfg.trains()
    settings = cfg.solver_settings()
    x0, x1 = profile_range(bridge.length, [t.length for t in trains], settings.approach,
                           settings.free_vibration)
    profiles = cfg.irregularities(x0, x1)
    x = np.linspace(x0, x1, max(int((x1 - x0) / 0.05), 2))
    table = Table(title=f"track profiles of {config} (x = {x0:.1f} .. {x1:.1f} m; "
                        "r > 0: rail lower)")
    for col in ("realisation", "profile", "std [mm]", "min [mm]", "max [mm]"):
        table.add_column(col)
    for rid, prof in profiles:
        r = prof(x) * 1e3
        table.add_row(str(rid), prof.label, f"{r.std():.3f}", f"{r.min():.3f}", f"{r.max():.3f}")
    pr.out.print(table)
    if plot is not None:
        from vsi_numba.analysis.model_plots import plot_profiles

        if _figure_failed(pr, plot, lambda: plot_profiles(profiles, x, bridge.length,
                                                           cfg.title, plot)):
            return EXIT_USAGE
        pr.out.print(f"wrote {plot}")
    return 0
