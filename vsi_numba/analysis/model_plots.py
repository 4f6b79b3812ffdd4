"""Figures of the model itself, before any run: the bridge's mode shapes (``vsi modes``)
and a configuration's track irregularity profiles (``vsi profile``).  matplotlib (Agg),
PNG files; the figures of a results file are in :mod:`.plots`."""

from __future__ import annotations

import math
import textwrap

import numpy as np

from vsi_numba.analysis.figure_file import save_figure
from vsi_numba.model import bridge as _br


def plot_modes(bridge: _br.ModalBridge, path, title: str = "", per_panel: int = 4,
               max_modes: int = 12):
    """Plot the mode shapes along the track line to ``path`` (PNG, matplotlib Agg).

    One panel per ``per_panel`` modes, stacked, for the first ``max_modes`` modes;
    deflection positive down plotted downwards; supports marked; the legend gives each
    mode's frequency (and effective mass fraction when known).  With a track layer the
    deck under the rail is drawn dashed.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = min(bridge.n_modes, max_modes)
    n_pan = max(1, math.ceil(n / per_panel))
    fig, axes = plt.subplots(n_pan, 1, figsize=(9.0, 2.4 + 2.2 * n_pan), sharex=True,
                             squeeze=False)
    x = np.linspace(0.0, bridge.length, max(400, 20 * int(bridge.length) + 1))
    phi = bridge.shapes(x)
    deck = bridge.deck.shapes(x) if getattr(bridge, "deck", None) is not None else None
    eff = getattr(bridge, "effective_mass_fraction", None)
    nodes = bridge.nodes if bridge.kind == _br.HERMITE else np.zeros(0)
    for k in range(n_pan):
        ax = axes[k, 0]
        for j in range(k * per_panel, min(n, (k + 1) * per_panel)):
            lab = f"mode {j + 1}: {bridge.frequencies[j]:.3f} Hz"
            if eff is not None and np.isfinite(eff[j]):
                lab += f", {100 * eff[j]:.1f}% mass"
            line, = ax.plot(x, phi[:, j], lw=1.6, label=lab)
            if deck is not None:
                ax.plot(x, deck[:, j], lw=1.0, ls="--", color=line.get_color())
            if 0 < nodes.size <= 400:
                ax.plot(nodes, bridge.shapes(nodes)[:, j], ".", ms=3, color=line.get_color())
        for s in bridge.supports:
            ax.axvline(s, color="0.6", lw=0.8, ls="--", zorder=0)
            ax.plot([s], [0.0], marker="^", color="k", ms=7, clip_on=False)
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.invert_yaxis()  # positive down
        ax.set_ylabel("phi (1/sqrt(kg)),\npositive down")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("x along the track line (m)     [dots: table stations / FE nodes; "
                           "triangles: supports]")
    head = title or "Mode shapes along the track"
    if bridge.n_modes > n:
        head += f" (first {n} of {bridge.n_modes} modes)"
    if deck is not None:
        head += "; solid: rail, dashed: deck"
    desc = "\n".join(textwrap.wrap(bridge.description, 120)) if bridge.description else ""
    fig.suptitle(f"{head}\n{desc}" if desc else head, fontsize=9)
    fig.tight_layout()
    try:
        save_figure(fig, path, dpi=130)
    finally:
        plt.close(fig)


def plot_profiles(profiles, x: np.ndarray, bridge_length: float, title: str, path,
                  max_profiles: int = 6) -> None:
    """Draw the first ``max_profiles`` track profiles ``(realisation, Profile)`` over
    ``x`` (m) to the PNG ``path``, the bridge shaded; r > 0 (rail lower) plotted down."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.0), dpi=150)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for rid, prof in profiles[:max_profiles]:
        label = prof.label if rid < 0 else f"realisation {rid}"
        ax.plot(x, prof(x) * 1e3, lw=0.8, label=label[:60])
    ax.axvspan(0.0, bridge_length, color="0.9", zorder=0, label="bridge")
    ax.set_xlabel("x along the track [m] (0 = start of the bridge)")
    ax.set_ylabel("irregularity r [mm] (+ = rail lower)")
    ax.invert_yaxis()
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
