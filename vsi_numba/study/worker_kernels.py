"""The compiled kernels a Dask study's client gives the workers of its cluster.

A worker process on another machine (or with a cache of its own) would compile the
kernels before its first batch: a minute or more of CPU per worker.  The client sends
the files of its own kernel cache instead (:func:`share_kernels`), and each worker,
also one that joins later, writes those it lacks into its cache before its first task
(:class:`KernelFiles`, a Dask worker plugin); numba then loads the kernels from there.
A worker whose CPU differs from the one the kernels were compiled for (numba keys a
cached kernel on it) compiles them as before; kernels compiled for a generic CPU
(``vsi compile --into DIR``, the client run with ``NUMBA_CACHE_DIR=DIR``) load on every
machine of the architecture.
"""

from __future__ import annotations

from distributed import WorkerPlugin


class KernelFiles(WorkerPlugin):
    """Dask worker plugin: the client's kernel cache ``files`` written into the worker's
    (:func:`~vsi_numba.solver.kernel_cache.install_cache_files`) when the worker starts
    or, for the workers already running, when the plugin is registered."""

    name = "vsi-numba-kernels"

    def __init__(self, files: dict[str, bytes], generic: bool):
        self.files = files
        self.generic = generic

    def setup(self, worker=None):
        from vsi_numba.solver.kernel_cache import install_cache_files

        install_cache_files(self.files, self.generic)


def share_kernels(client) -> int:
    """Register :class:`KernelFiles` with this process's compiled kernels on the cluster
    of ``client`` (nothing when this process has none in its cache).  Returns the number
    of files sent."""
    from vsi_numba._jit import targets_generic_cpu
    from vsi_numba.solver import kernel_cache as kc

    if not any(kc.is_cached(f) for f in kc.FAMILIES):
        return 0
    files = kc.cache_files()
    if files:
        client.register_plugin(KernelFiles(files, targets_generic_cpu()),
                               name=KernelFiles.name)
    return len(files)
