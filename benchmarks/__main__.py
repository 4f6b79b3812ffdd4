"""``python -m benchmarks [--quick | --full | --smoke] [--no-write] [--cold] ...``

Modes: ``--smoke`` (seconds, used by the tests), ``--quick`` (CI: small grids, few
repetitions, < 2 min once the kernels are compiled, no cold-start compile), default
``normal`` (full HSLM grid, subsets of the interaction grid, cold start, micro-profile),
``--full`` (normal + the whole ICE3 grid on 2 processes).
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
    from benchmarks.suite import run_suite, text_table

    suite = run_suite(args.mode or "normal", write=not args.no_write, report=args.report,
                      cold=args.cold, micro=args.micro, only=args.case,
                      echo=lambda s: print(s, file=sys.stderr, flush=True))
    print(text_table(suite))
    return 1 if any(r.error for r in suite.results) else 0


if __name__ == "__main__":
    sys.exit(main())
