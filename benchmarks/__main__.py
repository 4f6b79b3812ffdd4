"""``python -m benchmarks [--quick | --full | --smoke] [--[no-]study] [--measure X] ...``

Modes: ``--smoke`` (seconds, used by the tests), ``--quick`` (CI: small grids, few
repetitions, < 2 min once the kernels are compiled, no cold-start compile), default
``normal`` (full HSLM grid, subsets of the interaction grid, cold start, micro-profile),
``--full`` (normal + the whole ICE3 grid on 2 processes).

Study level (``benchmarks/study.py``): whole ``vsi sweep`` commands as subprocesses (wall
time, peak RSS of the process tree) against the numpy/scipy yardstick
(``benchmarks/yardstick.py``).  ``--study`` runs ONLY the study level, at the size of the
mode (``--study --smoke``: one 1-run command; ``--study --quick``: scaling capped at 1,000
runs); without the flag it follows the cases in smoke, normal and full mode (not in quick);
``--no-study`` leaves it out.  Its section of the report is replaced in place, and kept
when only the cases run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_const", dest="mode", const="quick")
    g.add_argument("--full", action="store_const", dest="mode", const="full")
    g.add_argument("--smoke", action="store_const", dest="mode", const="smoke")
    p.add_argument("--no-write", action="store_true", help="do not write the report")
    p.add_argument("--report", type=Path, default=None,
                   help="report path (default reports/benchmarks.md)")
    p.add_argument("--cold", action=argparse.BooleanOptionalAction, default=None,
                   help="time a first run with an empty numba cache (default: normal/full)")
    p.add_argument("--micro", action=argparse.BooleanOptionalAction, default=None,
                   help="kernel micro-profile (default: normal/full)")
    p.add_argument("--study", action=argparse.BooleanOptionalAction, default=None,
                   help="--study: only the study-level benchmark (whole `vsi sweep` "
                        "commands); --no-study: only the cases (default: cases, then the "
                        "study level in smoke/normal/full mode)")
    p.add_argument("--measure", action="append", choices=list("abcdefghij"),
                   help="study level: run only these measures (repeatable; implies --study)")
    p.add_argument("--case", action="append", choices=list("12345"),
                   help="run only these cases (repeatable)")
    p.add_argument("--blas-threads", type=int, default=1,
                   help="OPENBLAS/OMP/MKL threads for this process (default 1: every run is "
                        "serial and OpenBLAS threads fighting for 2 shared cores slow small "
                        "solves down by orders of magnitude); 0 = leave the environment")
    args = p.parse_args(argv)
    if args.blas_threads > 0:
        from benchmarks.timing import limit_blas_threads

        limit_blas_threads(args.blas_threads)
    mode = args.mode or "normal"
    if args.measure and args.study is None:
        args.study = True  # --measure implies --study
    if args.case and args.study is None:
        args.study = False  # --case selects cases only
    echo = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    code = 0
    if args.study is not True:
        from benchmarks.suite import run_suite, text_table

        suite = run_suite(mode, write=not args.no_write, report=args.report,
                          cold=args.cold, micro=args.micro, only=args.case, echo=echo)
        print(text_table(suite))
        code = 1 if any(r.error for r in suite.results) else 0
    if args.study or (args.study is None and mode != "quick"):
        from benchmarks.study import run_study_bench
        from benchmarks.study import text_table as study_table

        res = run_study_bench(mode, write=not args.no_write, report=args.report,
                              only=args.measure, echo=echo)
        print()
        print(study_table(res))
        code = code or (1 if res.errors else 0)
    return code


if __name__ == "__main__":
    sys.exit(main())
