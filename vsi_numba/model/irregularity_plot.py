"""``vsi profile``: the irregularity profiles of a configuration, as a table and a plot,
so a user can look at the track before a long sweep."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def profile_command(config: Path, plot: Path | None) -> int:
    """Print each realisation's statistics over the run; draw them when ``plot`` is given.

    Returns the exit code (2 for a config error).
    """
    from rich.console import Console
    from rich.table import Table

    from vsi_numba.config import load_config_for_cli
    from vsi_numba.study.grid import profile_range

    out, err = Console(), Console(stderr=True)
    cfg = load_config_for_cli(config, err)
    if cfg is None:
        return 2
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
    out.print(table)
    if plot is not None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6.5, 4.0), dpi=150)
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        for rid, prof in profiles[:6]:
            label = prof.label if rid < 0 else f"realisation {rid}"
            ax.plot(x, prof(x) * 1e3, lw=0.8, label=label[:60])
        ax.axvspan(0.0, bridge.length, color="0.9", zorder=0, label="bridge")
        ax.set_xlabel("x along the track [m] (0 = start of the bridge)")
        ax.set_ylabel("irregularity r [mm] (+ = rail lower)")
        ax.invert_yaxis()
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
        ax.set_title(cfg.title, fontsize=9)
        fig.tight_layout()
        Path(plot).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(plot)
        out.print(f"wrote {plot}")
    return 0
