"""Existing bridges: the cost of ``vsi calibrate`` and ``vsi reliability`` (prints numbers).

    python -m benchmarks.existing [--threads N] [--backend B] [--only calibration|stages|subset]

1. Calibration of two parameters (EI, damping ratio; the noise is a third) from three
   synthetic passages (``configs/calibration_synthetic``) with about 10^4 forward runs,
   the whole ``vsi calibrate`` command at the case's dt = 0.5 ms and at 1 ms (the
   default time step of this deck): wall and CPU time, the posterior against the truth.
2. ``stages``: where the CPU time of a smaller calibration (``n_samples`` 800, ~1,850
   forward runs, in this process on the serial backend) goes: the kernels, the set-up
   of the runs, the filter, the alignment and misfit, the sampler, the predictive
   records and the check, the file; and the share of a chunk's evaluation that holds
   the GIL (what bounds the threads backend: two threads run at most 1 / share times
   one thread's rate).
3. Subset simulation at P ~ 1e-4 (the monotone case of
   ``vsi_numba.verification.existing``): runs, estimate and its coefficient of
   variation against the closed form.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np


def calibration(workdir: Path, dt: float | None = None, backend: str | None = None) -> None:
    """The whole command ``vsi calibrate`` (a child process: imports, the kernels'
    loading, the start search, the chains, the predictive records and the check), wall
    and CPU (user + sys of the child, from ``resource.getrusage``: the figure to compare
    on a shared machine).  ``dt``: the model's time step instead of the case's 0.5 ms."""
    import resource
    import subprocess
    import sys

    import xarray as xr

    from vsi_numba.verification import existing as syn

    d = workdir / f"calibration_{dt or syn.DT:g}"
    cfg_path = syn.write_case(d, n_samples=4600)
    if dt is not None:
        cfg_path.write_text(cfg_path.read_text().replace(f"dt = {syn.DT!r}", f"dt = {dt!r}"))
    out = d / "posterior.nc"
    cmd = [sys.executable, "-m", "vsi_numba.cli", "calibrate", str(cfg_path), "-o", str(out),
           "-q"] + (["--backend", backend] if backend else [])
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    with xr.open_dataset(out) as ds:
        ds = ds.load()
    n = int(ds.attrs["n_forward_runs"])
    print(f"calibration (dt {dt or syn.DT:g} s, {ds.attrs.get('backend', 'threads')}): {n} "
          f"forward runs x 3 passages, whole command wall {wall:.1f} s, CPU {cpu:.1f} s "
          f"({cpu / n * 1e3:.2f} ms CPU a forward run)")
    for key, truth in syn.TRUTH.items():
        x = ds["posterior"].sel(parameter=key).values
        q = np.percentile(x, [5, 50, 95])
        print(f"  {key}: truth {truth:.5g}, median {q[1]:.5g} ({q[1] / truth - 1:+.2%}), "
              f"90 % interval {q[0]:.5g} .. {q[2]:.5g}, truth at quantile "
              f"{np.mean(x < truth):.2f}, R-hat {float(ds['r_hat'].sel(parameter=key)):.3f}"
              f", ESS {float(ds['effective_sample_size'].sel(parameter=key)):.0f}")
    print(f"  acceptance {ds['acceptance_fraction'].values.mean():.2f}")


#: The stages of :func:`stages`: (module, attribute, stage); the innermost wrapped call is
#: charged, so a stage's time excludes the stages it calls (the names of this code and of
#: the numpy likelihood before it: an absent one is skipped).
STAGES = (
    ("vsi_numba.solver.driver", "run_batch", "kernels (and their dispatch)"),
    ("vsi_numba.existing.forward", "Forward.run_row", "set-up of the runs"),
    ("vsi_numba.existing.forward", "Forward.point_histories", "set-up of the runs"),
    ("vsi_numba.existing.misfit", "point_history", "points' histories, output check"),
    ("vsi_numba.existing.misfit", "first_unstorable", "points' histories, output check"),
    ("vsi_numba.solver.batch", "_flag_non_finite", "points' histories, output check"),
    ("vsi_numba.existing.misfit", "filtfilt_rows", "filter"),
    ("vsi_numba.existing.calibrate", "lowpass", "filter"),
    ("vsi_numba.existing.calibrate", "best_shifts", "alignment (numpy: coarse and fine)"),
    ("vsi_numba.existing.calibrate", "best_shift", "alignment (numpy: coarse and fine)"),
    ("vsi_numba.existing.misfit", "RecordFit.fit", "alignment: coarse (FFT)"),
    ("vsi_numba.existing.misfit", "align_rows", "alignment: fine, and misfit"),
    ("vsi_numba.existing.calibrate", "_Prepared.loglikes", "likelihood (the rest)"),
    ("vsi_numba.existing.calibrate", "_Prepared.evaluate_u", "likelihood (the rest)"),
    ("vsi_numba.existing.distributions", "Marginals.from_u", "priors' transform"),
    ("vsi_numba.existing.parallel", "Evaluator.__call__", "evaluator (store, chunks)"),
    ("vsi_numba.existing.calibrate", "_polish", "sampler: start search (Nelder-Mead)"),
    ("emcee", "EnsembleSampler.run_mcmc", "sampler: emcee's own"),
    ("vsi_numba.existing.calibrate", "_Prepared.__init__", "records, probe run"),
    ("vsi_numba.existing.calibrate", "_predictive", "predictive records (percentiles)"),
    ("vsi_numba.existing.calibrate", "_check", "check (the rest)"),
    ("vsi_numba.existing.calibrate", "posterior_dataset", "posterior dataset"),
)
#: Compiled calls that release the GIL (:func:`gil_share`).
GIL_FREE = (("vsi_numba.solver.driver", "run_batch_mf"),
            ("vsi_numba.existing.misfit", "point_history"),
            ("vsi_numba.existing.misfit", "first_unstorable"),
            ("vsi_numba.existing.misfit", "filtfilt_rows"),
            ("vsi_numba.existing.misfit", "align_rows"),
            ("scipy.fft", "rfft"), ("scipy.fft", "irfft"))


def _wrapped(table, charge):
    """Replace each ``(module, attribute, ...)`` of ``table`` by a wrapper that calls
    ``charge(entry, thread seconds, seconds of the wrapped calls inside)``; returns the
    undo list."""
    import functools
    import importlib

    stack, undo = [], []
    for entry in table:
        owner = importlib.import_module(entry[0])
        *path, name = entry[1].split(".")
        for part in path:
            owner = getattr(owner, part)
        f = getattr(owner, name)

        def w(*a, _f=f, _e=entry, **k):
            stack.append(0.0)
            t = time.thread_time()
            try:
                return _f(*a, **k)
            finally:
                el = time.thread_time() - t
                inner = stack.pop()
                if stack:
                    stack[-1] += el
                charge(_e, el, inner)

        setattr(owner, name, functools.wraps(f)(w))
        undo.append((owner, name, f))
    return undo


def stages(workdir: Path, n_samples: int = 800) -> None:
    """CPU seconds per stage of one calibration in this process (serial backend, one
    thread: the stage times add up to the CPU time), then :func:`gil_share`."""
    from vsi_numba.config import load_config
    from vsi_numba.existing.calibrate import calibrate
    from vsi_numba.io.netcdf import encoding_for, write_atomic
    from vsi_numba.solver.batch import compile_family
    from vsi_numba.verification import existing as syn

    os.environ["VSI_THREADS"] = "1"
    cfg = load_config(syn.write_case(workdir / "stages", n_samples=n_samples))
    compile_family("moving_force")
    with warnings.catch_warnings():  # emcee's autocorrelation of a 2-step chain
        warnings.simplefilter("ignore", RuntimeWarning)
        calibrate(load_config(syn.write_case(workdir / "warm", speeds=(305.0,),
                                             n_samples=16,
                                             extra="n_walkers = 8\ncheck_samples = 10\n")),
                  backend="serial")  # the imports made, the compiled likelihood loaded
    spent: dict = {}

    def charge(entry, el, inner):
        spent[entry[2]] = spent.get(entry[2], 0.0) + el - inner

    undo = _wrapped([e for e in STAGES if _has(*e[:2])], charge)
    try:
        t0 = time.process_time()
        ds = calibrate(cfg, backend="serial")
        t1 = time.process_time()
        write_atomic(workdir / "stages.nc",
                     lambda tmp: ds.to_netcdf(tmp, encoding=encoding_for(ds)))
        spent["netCDF write"] = time.process_time() - t1
    finally:
        for owner, name, f in undo:
            setattr(owner, name, f)
    total = t1 - t0 + spent["netCDF write"]
    spent["other"] = total - sum(spent.values())
    n = int(ds.attrs["n_forward_runs"])
    print(f"stages of a calibration (n_samples {n_samples}, dt {syn.DT:g} s, serial, one "
          f"thread): {n} forward runs, CPU {total:.1f} s ({total / n * 1e3:.2f} ms a run)")
    for k, v in sorted(spent.items(), key=lambda kv: -kv[1]):
        print(f"  {k:40s} {v:6.2f} s  {v / total:5.1%}")
    gil_share(cfg)


def gil_share(cfg, n_chunks: int = 40) -> None:
    """CPU time of a chunk's evaluation (4 rows) inside the compiled calls that release
    the GIL (:data:`GIL_FREE`; their dispatch counted in), the rest holding it."""
    from vsi_numba.existing.calibrate import _Prepared
    from vsi_numba.existing.parallel import Spec, evaluate_chunk, register, unregister

    prep = _Prepared(cfg)
    spec = Spec("calibration", cfg.to_json(), str(cfg.base_dir))
    register(spec, prep.evaluate_u)
    rng = np.random.default_rng(0)
    u = [0.3 * rng.standard_normal((4, prep.marginals.n)) for _ in range(n_chunks)]
    free = [0.0]

    def charge(entry, el, inner):
        free[0] += el - inner

    undo = _wrapped([e for e in GIL_FREE if _has(*e)], charge)
    try:
        t0 = time.thread_time()
        for x in u:
            evaluate_chunk(spec, x)
        total = time.thread_time() - t0
    finally:
        for owner, name, f in undo:
            setattr(owner, name, f)
        unregister(spec)
    rows = 4 * n_chunks
    held = total - free[0]
    print(f"  a forward run with its likelihood: CPU {total / rows * 1e3:.2f} ms, "
          f"{held / rows * 1e3:.2f} ms of it holding the GIL ({held / total:.0%}): two "
          f"threads at most {min(2.0, total / max(held, 1e-12)):.2f} x one")


def _has(module: str, attr: str) -> bool:
    import importlib

    try:
        owner = importlib.import_module(module)
    except ImportError:
        return False
    for part in attr.split("."):
        if not hasattr(owner, part):
            return False
        owner = getattr(owner, part)
    return True


def subset(workdir: Path, p_target: float = 1e-4) -> None:
    from vsi_numba.config import load_config
    from vsi_numba.existing.reliability import estimate
    from vsi_numba.verification import existing as syn

    limit, _ = syn.rel_limit(p_target)
    cfg = syn.write_reliability_case(workdir / "subset", limit, method="subset",
                                     target=0.3, block=2000, max_runs=10000)
    t0, c0 = time.perf_counter(), time.process_time()
    ds = estimate(load_config(cfg))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    p, cov = float(ds["probability_of_exceedance"][0]), float(ds["cov"][0])
    exact = syn.rel_probability(limit)
    print(f"subset simulation: P = {p:.3g} (closed form {exact:.3g}, {p / exact - 1:+.1%}), "
          f"stated cov {cov:.3f}, beta {float(ds['reliability_index'][0]):.3f}, "
          f"{int(ds['runs'][0])} runs, wall {wall:.1f} s, CPU {cpu:.1f} s (this process)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--backend", default=None,
                    help="the calibration's --backend (default: the command's, threads)")
    ap.add_argument("--only", choices=("calibration", "stages", "subset"), default=None)
    a = ap.parse_args()
    if a.threads:
        os.environ["VSI_THREADS"] = str(a.threads)
    with tempfile.TemporaryDirectory() as d:
        if a.only in (None, "calibration"):
            calibration(Path(d), backend=a.backend)
            calibration(Path(d), dt=1e-3, backend=a.backend)  # this deck's default step
        if a.only in (None, "subset"):
            subset(Path(d))
        if a.only in (None, "stages"):
            stages(Path(d))  # last: it sets VSI_THREADS for this process


if __name__ == "__main__":
    main()
