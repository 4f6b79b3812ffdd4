"""The governing case of a check: the train, speed and realisation whose result the check
states (the one its verdict rests on), read in one place from the check's result.

The checks of :mod:`vsi_numba.analysis.checks` name their governing case in the
attributes of their result (``governing_train``, ``governing_speed`` in m/s,
``governing_irregularity``, ``value``); the load-effect checks in the rows of their
verdict table.  The report's time-history figures and its convergence section re-run
these cases; :func:`governing_case` and :func:`governing_cases` are what they read.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsi_numba.analysis.dataset import DETERMINISTIC

#: The checks whose governing case the convergence section re-runs, in its order.
RERUN_CHECKS = ("deck_acceleration", "deck_displacement", "wheel_unloading")


class GoverningCase(NamedTuple):
    """The case a check's result rests on."""

    train: str
    speed: float  # m s-1
    value: float  # the check's governing value
    irregularity: int = DETERMINISTIC


def governing_case(result) -> GoverningCase | None:
    """The governing case of a check's result (an xarray object with the attributes
    above), or None when the check was not made (None, or the text saying why) or names
    no governing case."""
    if result is None or isinstance(result, str):
        return None
    a = result.attrs
    train = str(a.get("governing_train", "") or "")
    speed = float(a.get("governing_speed", np.nan))
    if not train or not np.isfinite(speed):
        return None
    return GoverningCase(train, speed, float(a.get("value", np.nan)),
                         int(a.get("governing_irregularity", DETERMINISTIC)))


def governing_cases(results: dict, le_checks=None) -> dict[str, GoverningCase]:
    """check name -> its governing case, for the checks of :data:`RERUN_CHECKS` in
    ``results`` (:func:`vsi_numba.analysis.checks.run_checks`; the wheel unloading only
    where it applies to a train) and the EN 1991-2 6.4.6.5(3) bending-moment ratio of
    the load-effect checks ``le_checks`` (``"bending_moment"``)."""
    out = {}
    for name in RERUN_CHECKS:
        r = results.get(name)
        if (name == "wheel_unloading" and r is not None and not isinstance(r, str)
                and not bool(np.asarray(r["applicable"]).any())):
            continue
        case = governing_case(r)
        if case is not None:
            out[name] = case
    if le_checks is not None and not isinstance(le_checks, str):
        v = le_checks.verdict[le_checks.verdict["effect"] == "moment"]
        if not v.empty and np.isfinite(float(v["ratio"].iloc[0])):
            out["bending_moment"] = GoverningCase(str(v["train"].iloc[0]),
                                                  float(v["speed_kmh"].iloc[0]) / 3.6,
                                                  float(v["ratio"].iloc[0]))
    return out
