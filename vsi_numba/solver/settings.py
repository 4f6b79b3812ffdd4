"""Solver settings (SI units)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SolverSettings:
    """Time integration and contact settings.

    Parameters
    ----------
    dt : float
        Time step (s).
    hht_alpha : float
        HHT-alpha parameter in [-1/3, 0]; 0 is the trapezoidal rule (no numerical
        damping), a small negative value damps spurious high-frequency contact forces.
    approach : float
        Length of track ahead of the bridge (m): the first axle starts at x = -approach.
    free_vibration : float
        Time simulated after the last axle has left the bridge (s).
    max_iterations : int
        Cap on active-set iterations per step (contact detachment/reattachment).
    max_subdivisions : int
        A step whose contact iterations fail is retried with dt/2, dt/4, ... up to this
        many halvings before the case is flagged as failed.
    acceleration_cutoff : float or None
        Highest frequency (Hz) of the modes that enter the deck-acceleration output
        (EN 1990 A2.4.4.2.1: max(30 Hz, 1.5 f1, f3)); None computes that value.
    """

    dt: float = 1e-3
    hht_alpha: float = -0.1
    approach: float = 5.0
    free_vibration: float = 1.0
    max_iterations: int = 50
    max_subdivisions: int = 4
    acceleration_cutoff: float | None = None

    def __post_init__(self):
        if not self.dt > 0:
            raise ValueError(f"solver.dt = {self.dt!r}: expected a time step > 0 s")
        if not -1.0 / 3.0 - 1e-12 <= self.hht_alpha <= 0.0:
            raise ValueError(f"solver.hht_alpha = {self.hht_alpha!r}: expected -1/3 <= alpha <= 0")
        if self.approach < 0:
            raise ValueError(f"solver.approach = {self.approach!r}: expected >= 0 m")
        if self.free_vibration < 0:
            raise ValueError(f"solver.free_vibration = {self.free_vibration!r}: expected >= 0 s")
