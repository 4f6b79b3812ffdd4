"""Existing bridges: the cost of ``vsi calibrate`` and ``vsi reliability`` (prints numbers).

    python -m benchmarks.existing [--threads N]

1. Calibration of two parameters (EI, damping ratio; the noise is a third) from three
   synthetic passages (``configs/calibration_synthetic``) with about 10^4 forward runs:
   wall time, forward runs, the posterior against the truth.
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


def calibration(workdir: Path) -> None:
    from vsi_numba.config import load_config
    from vsi_numba.existing.calibrate import calibrate
    from vsi_numba.verification import existing as syn

    cfg_path = syn.write_case(workdir / "calibration", n_samples=4600)
    cfg = load_config(cfg_path)
    t0, c0 = time.perf_counter(), time.process_time()
    ds = calibrate(cfg)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"calibration: {ds.attrs['n_forward_runs']} forward runs x 3 passages, wall "
          f"{wall:.1f} s, CPU {cpu:.1f} s, {wall / ds.attrs['n_forward_runs'] * 1e3:.2f} ms "
          "a forward run (wall)")
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
        if a.only in (None, "subset"):
            subset(Path(d))


if __name__ == "__main__":
    main()
