"""``vsi run``: one configuration's first train on its first track realisation, at every
speed, through the study engine (:func:`vsi_numba.study.runner.execute_study` with
``first_case=True``): the same batches, kernels and writer as ``vsi sweep``, so the file
has the study layout (dims ``speed``, ``train`` and ``irregularity``, the last two of
length one) and the same variables and attributes.  Nothing is resumed: the finished
batches live in ``<output>.run-cases/`` (never the store of a sweep of that output) while
the run goes and are removed once the file is written."""

from __future__ import annotations

from vsi_numba.study.runner import StudyOutcome, execute_study


def run_config(cfg, output, progress: bool = False, quiet: bool = True,
               command: str | None = None) -> StudyOutcome:
    """Run every speed of ``cfg`` for its first train and first irregularity realisation
    into the netCDF file ``output``; returns what was written (path, runs, failed runs).

    Raises what :func:`~vsi_numba.study.runner.execute_study` raises (``StudyError``,
    ``KeyboardInterrupt`` with the finished batches kept).
    """
    return execute_study(cfg, output, progress=progress, fresh=True, quiet=quiet,
                         command=command, first_case=True)
