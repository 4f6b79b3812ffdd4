"""CPU time per step of the two kernel families, two versions of the code interleaved.

The ICE3 on a 25 m simply supported span with a 2 mm cosine dip (the interaction
kernels, ``time_loop``) and HSLM-A1 on the same span (the moving-force kernel,
``run_batch_mf``), at 300 km/h: each version of the code runs
in a process of its own (its root first on ``PYTHONPATH``, its numba cache warm: compile
first), which times the kernel call that ``run_batch`` makes (``driver.run_batch``,
arguments captured once) ``--repeat`` times and prints the median CPU microseconds per
step; the versions alternate ``--rounds`` times, and the medians of the rounds are
printed with their ratio.

    python -m benchmarks.step_time BEFORE_TREE AFTER_TREE
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time


def measure(repeat: int, families=("interaction", "moving_force")) -> dict:
    """{family: CPU us per step} of the code on ``sys.path``."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model.irregularity import cosine_defect
    from vsi_numba.model.library.builders import get_train
    from vsi_numba.solver import batch as sb
    from vsi_numba.solver import driver
    from vsi_numba.solver.settings import SolverSettings
    from vsi_numba.solver.simulate import pack

    beam = br.simply_supported(25.0, 7.16e10, 18000.0, n_modes=4)
    settings = SolverSettings(dt=1e-3, approach=5.0, free_vibration=0.2)
    v = 300.0 / 3.6
    out = {}
    for family in families:
        model = family
        train = get_train("ICE3" if family == "interaction" else "HSLM-A1", model=model)
        profile = cosine_defect(0.002, 6.0, 12.5)
        packed = pack(beam, train, v, profile, settings)
        captured = []
        sb.run_batch(packed, profile, [v], [12.5], settings, beam,
                     _kernel=lambda *a, c=captured: c.append(a))
        args = captured[0]
        n_steps = int(args[5].sum())
        sb.compile_family(family)
        times = []
        for _ in range(repeat):
            c0 = time.process_time()
            driver.run_batch(*args)
            times.append(time.process_time() - c0)
        out[family] = statistics.median(times) / n_steps * 1e6
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.step_time", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trees", nargs="*", help="BEFORE_TREE AFTER_TREE")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--family", choices=("interaction", "moving_force"), action="append",
                   help="only this family (repeatable; default: both)")
    p.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.measure:
        print(json.dumps(measure(args.repeat, args.family or ("interaction", "moving_force"))))
        return 0
    if len(args.trees) != 2:
        p.error("give BEFORE_TREE AFTER_TREE")
    res: dict = {t: [] for t in args.trees}
    for _ in range(args.rounds):
        for tree in args.trees:
            env = {**os.environ, "PYTHONPATH": tree, "OPENBLAS_NUM_THREADS": "1"}
            fam = [a for f in (args.family or []) for a in ("--family", f)]
            done = subprocess.run([sys.executable, __file__, "--measure", "--repeat",
                                   str(args.repeat), *fam], env=env, cwd=tree, check=True,
                                  capture_output=True, text=True)
            res[tree].append(json.loads(done.stdout.strip().splitlines()[-1]))
    before, after = args.trees
    for family in args.family or ("interaction", "moving_force"):
        b = statistics.median(r[family] for r in res[before])
        a = statistics.median(r[family] for r in res[after])
        print(f"{family}: {b:.3f} -> {a:.3f} us/step CPU (x{a / b:.3f}; medians of "
              f"{args.rounds} rounds x {args.repeat} calls)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
