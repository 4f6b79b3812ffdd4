"""Studies: speeds x trains x irregularity realisations, resumable, serial or parallel.

``run_study`` (the ``vsi sweep`` command) runs every case of a configuration in batches
(:mod:`.batches`: one kernel call per train, realisation and block of speeds), keeps each
finished batch in ``<output>.cases/`` and writes one CF netCDF file by slices
(:mod:`vsi_numba.io.study_file`); see :mod:`vsi_numba.study.runner` for the flow, the
variants of ``study.vary`` and the exit codes, :mod:`.store` for resume and
:mod:`.backends` for the parallel backends.
"""

__all__ = ["StudySpec", "run_case", "run_study", "study_spec"]


def __getattr__(name):
    """The names of :data:`__all__` from :mod:`.runner`, imported when first used (a
    command that finds its study written imports no engine: :mod:`.unchanged`)."""
    if name in __all__:
        from vsi_numba.study import runner

        return getattr(runner, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
