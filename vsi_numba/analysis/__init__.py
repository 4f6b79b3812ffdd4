"""Result analysis: checks, statistics, figures and the ``vsi report`` Markdown report.

EN 1990 A2 / EN 1991-2 checks, statistics over irregularity realisations, figures.

Checks and statistics (xarray in, xarray/pandas out; no matplotlib)::

    from vsi_numba.analysis import deck_acceleration_check, dynamic_amplification
    acc = deck_acceleration_check(xr.open_dataset("results.nc"))
    acc.attrs["result"], acc.attrs["governing_train"], acc["value"]  # (speed, train)

Report (imports matplotlib on first use)::

    from vsi_numba.analysis import write_report
    write_report(ds, "report_dir")
"""

from __future__ import annotations

from vsi_numba.analysis.checks import (
    COMFORT_LEVELS,
    DECK_ACCELERATION_LIMITS,
    WHEEL_UNLOADING_LIMIT,
    DeterminantLength,
    applicable_trains,
    comfort,
    deck_acceleration_check,
    design_value,
    determinant_length,
    dynamic_amplification,
    frequency_cutoff,
    irregularity_allowance,
    prescribed_wheels,
    resonance_speeds,
    run_checks,
    summary_table,
    wheel_unloading,
)
from vsi_numba.analysis.dataset import ResultsError, prepare
from vsi_numba.analysis.statistics import realisation_statistics, wilks_sample_size

__all__ = [
    "COMFORT_LEVELS",
    "DECK_ACCELERATION_LIMITS",
    "WHEEL_UNLOADING_LIMIT",
    "DeterminantLength",
    "ResultsError",
    "applicable_trains",
    "comfort",
    "deck_acceleration_check",
    "design_value",
    "determinant_length",
    "dynamic_amplification",
    "frequency_cutoff",
    "irregularity_allowance",
    "prepare",
    "prescribed_wheels",
    "realisation_statistics",
    "resonance_speeds",
    "run_checks",
    "summary_table",
    "wheel_unloading",
    "wilks_sample_size",
    "write_report",
]


def __getattr__(name):  # lazy: matplotlib is imported only when a report is written
    if name == "write_report":
        from vsi_numba.analysis.report import write_report

        return write_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
