"""The ``vsi`` command line (entry point ``vsi_numba.cli:main``).

=================  ==========================================================
:mod:`.app`        the typer app (options, help) and :func:`main`
:mod:`.common`     the printer and the config loader every command uses
:mod:`.run`        ``vsi run``
:mod:`.sweep`      ``vsi sweep`` (then ``--report``)
:mod:`.report`     ``vsi report``
:mod:`.trains`     ``vsi trains``
:mod:`.model`      ``vsi modes`` and ``vsi profile``
=================  ==========================================================

Nothing below this package imports it.
"""

from vsi_numba.cli.app import app, main

__all__ = ["app", "main"]
