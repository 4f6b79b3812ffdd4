"""Verification of vsi_numba on the user's installation (``vsi verify``).

Each case of :mod:`~vsi_numba.verification.cases` runs a configuration through the
public path (a TOML file, the study runner ``vsi sweep`` calls, the netCDF file it
writes) and compares figures with :mod:`~vsi_numba.verification.reference`, which computes
its references independently of the package (closed forms, ``solve_ivp``, published and
peer figures).  :mod:`~vsi_numba.verification.manual` runs the cases and writes
``verification.csv`` and ``verification.html``.
"""

from __future__ import annotations

__all__ = ["run_verification"]


def run_verification(outdir, quick: bool = False, progress=None):
    """Run the verification cases and write the manual; see
    :func:`vsi_numba.verification.manual.run_verification`."""
    from vsi_numba.verification.manual import run_verification as _run

    return _run(outdir, quick=quick, progress=progress)
