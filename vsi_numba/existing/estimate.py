"""What ``vsi check`` says about ``[calibration]`` and ``[reliability]``: the forward runs
they will make, the time (three forward runs timed here) and the memory."""

from __future__ import annotations

import math
import time as _time

import numpy as np


def _per_run_seconds(cfg, keys, specs, groups, histories) -> float:
    from vsi_numba.existing.distributions import Marginals
    from vsi_numba.existing.forward import Forward

    fwd = Forward(cfg.resolved(), cfg.base_dir, keys, groups, histories=histories)
    row = Marginals(specs).from_u(np.zeros(len(specs)))
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):  # as the runs have it
        fwd.run_row(row)  # the first builds caches
        t0 = _time.process_time()  # CPU time: not inflated by a shared machine's load
        for _ in range(3):
            fwd.run_row(row)
        return (_time.process_time() - t0) / 3


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}"
        n /= 1000
    return ""


def lines(cfg) -> list[str]:
    """The estimate lines of the configuration's own sections (none without them)."""
    from vsi_numba.existing import calibrate as cal
    from vsi_numba.existing.forward import Group, threads

    out = []
    res = cfg.resolved()
    n_thr = threads()
    if res.get("calibration"):
        c = res["calibration"]
        n_dim = len(c["parameters"]) + (0 if c.get("noise_std") is not None else len(
            {r["quantity"] for r in c["records"]}))
        w = int(c.get("n_walkers") or max(16, 4 * n_dim + (4 * n_dim) % 2))
        steps = math.ceil(int(c["n_samples"]) / w)
        burn = int(c["burn_in"]) if c.get("burn_in") is not None else steps
        n = (cal.START_DRAWS * w + cal.POLISH_EVALUATIONS * n_dim
             + cal.laplace_evaluations(n_dim) + w * (burn + steps)
             + 2 * int(c["check_samples"]))
        from vsi_numba.existing.forward import CHUNK_ROWS

        prep = cal._Prepared(cfg)  # the records read, filtered, the speeds found
        out.extend(prep.speed_notes)
        from threadpoolctl import threadpool_limits

        u = np.zeros((CHUNK_ROWS, prep.marginals.n))
        with threadpool_limits(limits=1, user_api="blas"):  # as the runs have it
            prep.evaluate_u(u)  # the first builds caches
            cpu = []
            for _ in range(2):  # CPU time: what a shared machine's load does not inflate
                t0 = _time.process_time()
                prep.evaluate_u(u)
                cpu.append(_time.process_time() - t0)
        per = min(cpu) / CHUNK_ROWS
        if not prep.forward._typed:
            out.append(f"calibration: the forward runs validate the configuration for "
                       f"every sample ({prep.forward.typed_reason})")
        mem = 8.0 * int(c["n_samples"]) * (n_dim + 2 + len(c["records"]))
        out.append(f"calibration: {n:,} forward runs ({w} walkers x {burn} burn-in + "
                   f"{steps} kept steps, start search, {c['check_samples']} x 2 for the "
                   f"check and the predictive records), {len(c['records'])} records each; "
                   f"~{per * 1e3:.1f} ms a forward run with its likelihood (CPU, measured "
                   "here) -> time "
                   f"~{n * per / max(1, min(n_thr, 2)) / 60:.1f} min on {n_thr} thread(s); "
                   f"posterior ~{_size(mem)}")
    if res.get("reliability"):
        r = res["reliability"]
        n_s = len(cfg.speeds_kmh)
        names = [t.name for t in cfg.trains()]
        preset = res["train"].get("preset")
        groups = [Group(t, tuple(float(v) for v in cfg.speeds_kmh),
                        tuple(float(x) for x in np.atleast_1d(cfg.output_points)))
                  for t in (names if preset is not None else [None])]
        per = _per_run_seconds(cfg, [v["key"] for v in r["variables"]], r["variables"],
                               groups, False)
        if r["method"] == "subset":
            est = f"{r['block_size']:,} runs per level, about 1 + log10(1/P) levels"
            n_est = (n_s + (n_s > 1)) * int(r["block_size"]) * 4  # P ~ 1e-4: 4 levels
            what = f"{n_s + (n_s > 1)} estimate(s) (per speed and over the range)"
        else:
            est = (f"(1 - P) / (P x {r['target_cov']:g}^2) runs in blocks of "
                   f"{r['block_size']:,}")
            n_est = int(r["max_runs"])
            what = "one sample for every speed"
        minutes = n_est * per / max(1, min(n_thr, 2)) / 60
        memory = _size(8.0 * int(r["block_size"]) * (n_s + 1) * 4)
        out.append(f"reliability: {r['method']}, {what}, {est}, at most "
                   f"{int(r['max_runs']):,} runs each; ~{per * 1e3:.0f} ms a forward run "
                   f"at {n_s} speed(s) (measured here) -> ~{minutes:.1f} min for "
                   f"{n_est:,} runs; memory ~{memory} of samples")
    return out
