"""Existing bridges: the cost of ``vsi calibrate`` and ``vsi reliability`` (prints numbers).

    python -m benchmarks.existing [--threads N]

1. Calibration of two parameters (EI, damping ratio; the noise is a third) from three
   synthetic passages (``configs/calibration_synthetic``) with about 10^4 forward runs,
   the whole ``vsi calibrate`` command at the case's dt = 0.5 ms and at 1 ms (the
   default time step of this deck): wall and CPU time, the posterior against the truth.
2. Subset simulation at P ~ 1e-4 (the monotone case of
   ``vsi_numba.verification.existing``): runs, estimate and its coefficient of
   variation against the closed form.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
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


def subset(workdir: Path, p_target: float = 1e-4) -> None:
    from vsi_numba.config import load_config
    from vsi_numba.existing.reliability import estimate
    from vsi_numba.verification import existing as syn

    limit, _ = syn.rel_limit(p_target)
    cfg = syn.write_reliability_case(workdir / "subset", limit, method="subset",
                                     target=0.3, block=2000, max_runs=10000)
    t0 = time.perf_counter()
    ds = estimate(load_config(cfg))
    wall = time.perf_counter() - t0
    p, cov = float(ds["probability_of_exceedance"][0]), float(ds["cov"][0])
    exact = syn.rel_probability(limit)
    print(f"subset simulation: P = {p:.3g} (closed form {exact:.3g}, {p / exact - 1:+.1%}), "
          f"stated cov {cov:.3f}, beta {float(ds['reliability_index'][0]):.3f}, "
          f"{int(ds['runs'][0])} runs, wall {wall:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--only", choices=("calibration", "subset"), default=None)
    a = ap.parse_args()
    if a.threads:
        os.environ["VSI_THREADS"] = str(a.threads)
    with tempfile.TemporaryDirectory() as d:
        if a.only in (None, "calibration"):
            calibration(Path(d))
            calibration(Path(d), dt=1e-3)  # the default time step of this deck
        if a.only in (None, "subset"):
            subset(Path(d))


if __name__ == "__main__":
    main()
