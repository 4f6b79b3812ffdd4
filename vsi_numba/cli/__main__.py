"""``python -m vsi_numba.cli``: the ``vsi`` command."""

from vsi_numba.cli.app import main

main()
