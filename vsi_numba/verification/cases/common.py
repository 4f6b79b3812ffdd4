"""What every verification case uses: :class:`Row` (a compared figure), :class:`Case`,
:func:`sweep` (a configuration run through the study runner of ``vsi sweep``) and the
TOML pieces of a simply supported bridge and of a train of forces."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Row:
    """One compared figure of a case (a row of verification.csv)."""

    id: str
    title: str
    source: str
    model: str
    quantity: str
    unit: str
    reference: float
    computed: float
    tolerance: float  # on the relative error
    tolerance_reason: str

    @property
    def error(self) -> float:
        """Relative error ``computed / reference - 1``."""
        return float(self.computed / self.reference - 1.0)

    @property
    def passed(self) -> bool:
        """True when the relative error is within the tolerance (NaN fails)."""
        return bool(abs(self.error) <= self.tolerance)


@dataclass(frozen=True)
class Case:
    """A verification case: its id, title, whether ``--quick`` runs it, and its run."""

    id: str
    title: str
    quick: bool
    run: Callable[[Path], list[Row]]


def sweep(workdir: Path, name: str, text: str):
    """Write ``text`` as ``workdir/name.toml``, run it with the study runner of
    ``vsi sweep -q --fresh`` (:func:`vsi_numba.study.runner.execute_study`) and return the
    results file's dataset (loaded; dims speed, train, irregularity kept)."""
    import xarray as xr

    from vsi_numba.study.runner import execute_study

    cfg = workdir / f"{name}.toml"
    out = workdir / f"{name}.nc"
    cfg.write_text(text, encoding="utf-8")
    outcome = execute_study(cfg, out, fresh=True, quiet=True,
                            command=f"vsi verify: vsi sweep {cfg} -o {out} --fresh")
    if outcome.n_failed:
        raise RuntimeError(f"{outcome.n_failed} of {outcome.n_runs} runs of {cfg} failed "
                           f"numerically (see the status and message variables of {out})")
    with xr.open_dataset(out) as ds:
        return ds.load()


def ss_bridge(L, EI, m, zeta, n_modes, points):
    return f"""
        [bridge]
        kind = "simply_supported"
        spans = [{L!r}]
        EI = {EI!r}
        mass_per_length = {m!r}
        damping_ratio = {zeta!r}
        n_modes = {n_modes}
        output_points = {list(points)!r}
        """


def forces_toml(offsets, load):
    return "".join(f'\n[[train.vehicles]]\nkind = "force"\noffset = {o!r}\nload = {load!r}\n'
                   for o in offsets)


def ei_for(f1, L, m):
    """EI (N m2) giving the first frequency ``f1`` (Hz) of a simply supported span."""
    return m * (2.0 * np.pi * f1 / (np.pi / L) ** 2) ** 2
