"""Existing bridges: calibration of a model on measured passages (``vsi calibrate``) and
the probability that a check is exceeded (``vsi reliability``).

Modules: :mod:`~.distributions` (priors and random inputs), :mod:`~.signal` (the EN
cut-off low-pass, the records' alignment), :mod:`~.misfit` (the same on the histories of
a chunk of forward runs, compiled), :mod:`~.forward` (forward runs of many parameter
sets), :mod:`~.calibrate`, :mod:`~.reliability`, :mod:`~.report`.
"""
