"""Studies: speeds x trains x irregularity realisations, resumable, serial or parallel.

``run_study`` (the ``vsi sweep`` command) runs every case of a configuration, keeps each
finished case in ``<output>.cases/`` and writes one CF netCDF file; see
:mod:`vsi_numba.study.runner` for the flow and exit codes, :mod:`.store` for resume and
:mod:`.backends` for the parallel backends.
"""

from vsi_numba.study.runner import StudySpec, run_case, run_study, study_spec

__all__ = ["StudySpec", "run_case", "run_study", "study_spec"]
