"""Studies: speeds x trains x irregularity realisations, resumable, serial or parallel.

``run_study`` (the ``vsi sweep`` command) runs every case of a configuration in batches
(:mod:`.batches`: one kernel call per train, realisation and block of speeds), keeps each
finished batch in ``<output>.cases/`` and writes one CF netCDF file by slices
(:mod:`vsi_numba.io.study_file`); see :mod:`vsi_numba.study.runner` for the flow, the
variants of ``study.vary`` and the exit codes, :mod:`.store` for resume and
:mod:`.backends` for the parallel backends.
"""

from vsi_numba.study.runner import StudySpec, run_case, run_study, study_spec

__all__ = ["StudySpec", "run_case", "run_study", "study_spec"]
