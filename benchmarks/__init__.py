"""Performance benchmarks of vsi_numba against a dense numpy/scipy baseline.

``python -m benchmarks [--smoke | --quick | --full] [--no-write] [--cold] [--micro]``
runs the five cases of ``benchmarks.cases`` (sprung mass crossing; HSLM-A sweep; ICE3
interaction study; scaling with modes and cars; cold/warm start of ``vsi run``), prints a
summary table and writes ``reports/benchmarks.md`` (+ ``reports/benchmarks_scaling.png``);
then (``--study`` alone, or by default in smoke/normal/full mode) the study level: whole
``vsi sweep`` commands timed as subprocesses with the peak RSS of their process tree.

Modules
-------
baseline      independent dense implementation of the direct method (the yardstick)
cases         models, grids and the measurement of each case
suite         orchestration, text table and Markdown report
timing        medians of wall/CPU time, load average, machine information
microprofile  per-function cost of the engine's step (jitted drivers, no cache)
yardstick     independent numpy/scipy moving-force HSLM sweep (bilinear/lfilter per mode)
study         whole `vsi sweep` commands: wall time, process-tree peak RSS, verdicts
"""
