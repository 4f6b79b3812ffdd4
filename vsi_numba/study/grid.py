"""The case grid of a study: speeds x trains x irregularity realisations.

Order is deterministic: speed (as listed in the configuration) outermost, then train, then
irregularity realisation.  A case is identified by its three indices; its key
(``s0003_t001_i002``) names its file in the case store.  The indices are only meaningful
for one configuration, which is why a store is tied to the configuration's SHA-256.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from vsi_numba.model.irregularity import (  # noqa: F401  (re-exported)
    SPEED_BOUND_KMH,
    profile_range,
)


class Case(NamedTuple):
    """One analysis of a study (picklable: it travels to worker processes).

    Attributes
    ----------
    index : int
        Position in the grid (deterministic order).
    i_speed, i_train, i_irregularity : int
        Indices along the study dimensions.
    speed_kmh : float
        Train speed (km/h), as the configuration lists it.
    train : str
        Train name.
    irregularity : int
        Irregularity realisation id (the seed; -1 for a deterministic profile).
    histories : bool
        Whether time histories are kept for this case.
    speed_m_s : float or None
        Train speed (m/s), from the configuration
        (:attr:`vsi_numba.config.Config.speeds_m_s`); None for a case that only names a
        store entry (:attr:`key`).
    """

    index: int
    i_speed: int
    i_train: int
    i_irregularity: int
    speed_kmh: float
    train: str
    irregularity: int
    histories: bool
    speed_m_s: float | None = None

    @property
    def key(self) -> str:
        """Name of the case in the store, e.g. ``s0003_t001_i002``."""
        return f"s{self.i_speed:04d}_t{self.i_train:03d}_i{self.i_irregularity:03d}"


@dataclass(frozen=True)
class StudyGrid:
    """Axes and cases of a study."""

    speeds_kmh: np.ndarray
    trains: tuple[str, ...]
    irregularities: tuple[int, ...]
    history_speeds: np.ndarray  # bool per speed
    cases: tuple[Case, ...]
    speeds_m_s: np.ndarray  # the speeds in m/s, from the configuration

    @property
    def shape(self) -> tuple[int, int, int]:
        """(n_speed, n_train, n_irregularity)."""
        return (self.speeds_kmh.size, len(self.trains), len(self.irregularities))


def history_mask(speeds_kmh, save: bool, history_speeds_kmh) -> np.ndarray:
    """Which speeds keep time histories: none, all, or those listed (to 1e-9 km/h)."""
    speeds = np.asarray(speeds_kmh, float)
    if not save:
        return np.zeros(speeds.size, bool)
    if history_speeds_kmh is None:
        return np.ones(speeds.size, bool)
    wanted = np.atleast_1d(np.asarray(history_speeds_kmh, float))
    return np.array([bool(np.any(np.abs(wanted - v) <= 1e-9 * max(1.0, abs(v)))) for v in speeds])


def make_grid(speeds_kmh, trains, irregularity_ids, history_speeds, speeds_m_s) -> StudyGrid:
    """Build the deterministic case grid (speed, then train, then realisation);
    ``speeds_m_s`` are ``speeds_kmh`` in m/s, as the configuration gives them
    (:attr:`vsi_numba.config.Config.speeds_m_s`)."""
    speeds = np.asarray(speeds_kmh, float)
    speeds_si = np.asarray(speeds_m_s, float)
    if speeds_si.shape != speeds.shape:
        raise ValueError(f"{speeds_si.size} speeds in m/s for {speeds.size} in km/h")
    trains = tuple(str(t) for t in trains)
    irr = tuple(int(i) for i in irregularity_ids)
    hist = np.asarray(history_speeds, bool)
    if len(set(trains)) != len(trains):
        raise ValueError(f"train names must be unique in a study, got {list(trains)}")
    if len(set(irr)) != len(irr):
        raise ValueError(f"irregularity ids must be unique in a study, got {list(irr)}")
    cases = []
    for i_s, v in enumerate(speeds):
        for i_t, name in enumerate(trains):
            for i_i, rid in enumerate(irr):
                cases.append(
                    Case(len(cases), i_s, i_t, i_i, float(v), name, rid, bool(hist[i_s]),
                         float(speeds_si[i_s]))
                )
    return StudyGrid(speeds, trains, irr, hist, tuple(cases), speeds_si)
