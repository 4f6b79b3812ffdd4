"""``vsi reliability``: the probability that a check is exceeded, and the reliability
index ``beta = -Phi^-1(P)``.

The check's value is the study's: the peak deck acceleration (whole deck and output
points, band-limited to the EN 1990 A2 cut-off, the largest over the configuration's
trains) or the peak deck displacement at the output points, per speed of
``study.speeds_kmh``, against ``reliability.limit`` or the code profile's limit.  The
random inputs are configuration keys with their distributions
(:mod:`vsi_numba.existing.distributions`); every evaluation is a forward run of the
configuration with the keys set (:mod:`vsi_numba.existing.forward`).

Estimators
    ``subset``: subset simulation (Au & Beck 2001) by OpenTURNS
    (``ot.SubsetSampling``: conditional probability 0.1 per level, modified Metropolis
    chains in the standard normal space, the estimate's coefficient of variation from
    the chains' correlation).  ``monte_carlo``: crude Monte Carlo, the reference, blocks
    of ``block_size`` runs until the coefficient of variation ``sqrt((1 - P) / (N P))``
    is below ``target_cov``.  A subset simulation that misses ``target_cov`` is re-run
    once with the per-level sample grown by ``(cov / target)^2``; both stop at
    ``max_runs``.

Per speed, and over the range (the largest value over the speeds exceeds the limit),
each its own estimate.  With no exceedance at all (crude Monte Carlo) the estimate is 0
and its coefficient of variation not determined: the file says so and gives the 95 %
upper bound ``3 / N`` (rule of three) instead.
"""

from __future__ import annotations

import math
import time as _time

import numpy as np
import scipy.stats

from vsi_numba.existing.distributions import Marginals, describe
from vsi_numba.existing.forward import Forward, Group

#: Conditional probability of a subset level.
LEVEL_PROBABILITY = 0.1


class ReliabilityError(ValueError):
    """An estimate that cannot be made (the message says why)."""


def check_limit(cfg) -> float:
    """The limit of the check: ``reliability.limit``, else the code profile's deck
    acceleration limit of the deck's track type."""
    from vsi_numba.en1990 import deck_acceleration_limits

    r = cfg.resolved()["reliability"]
    if r.get("limit") is not None:
        return float(r["limit"])
    if r["check"] != "deck_acceleration":
        raise ReliabilityError(f"reliability.check = {r['check']!r} has no limit in the code "
                               "profile: give reliability.limit")
    limits = deck_acceleration_limits(cfg.code_profile)
    return float(limits.get(cfg.track_type, limits["ballasted"]))


class Response:
    """The check's value per speed of rows of random inputs (standard normal space)."""

    def __init__(self, cfg, speeds_kmh):
        r = cfg.resolved()["reliability"]
        self.cfg = cfg
        self.check = r["check"]
        self.marginals = Marginals(r["variables"])
        self.keys = [v["key"] for v in r["variables"]]
        names = [t.name for t in cfg.trains()]
        preset = cfg.resolved()["train"].get("preset")
        trains = names if preset is not None else [None]
        pts = tuple(float(x) for x in np.atleast_1d(cfg.output_points))
        self.forwards = [Forward(cfg.resolved(), cfg.base_dir, self.keys,
                                 [Group(t, tuple(float(v) for v in speeds_kmh), pts)
                                  for t in trains], histories=False)]
        self.n_speeds = len(speeds_kmh)
        self.runs = 0
        self.failed: list[str] = []
        self.n_failed = 0
        self.evaluator = None

    def values(self, u) -> np.ndarray:
        """Values (n, n_speeds) of the check at rows ``u`` (n, n_variables) of the
        standard normal space; a row whose model cannot be run is +inf (exceeded, the
        safe side; :meth:`failure` names why).  The evaluation the backends run
        (:mod:`vsi_numba.existing.parallel`)."""
        u = np.atleast_2d(np.asarray(u, float))
        rows = self.marginals.from_u(u)
        out = np.empty((len(rows), self.n_speeds))
        for k, row in enumerate(rows):
            rr = self.forwards[0].run_row(row)
            if any(x.error for x in rr):
                out[k] = np.inf
                continue
            env = [x.envelope_acc if self.check == "deck_acceleration" else
                   x.envelope_disp for x in rr]
            out[k] = np.max(env, axis=0)
        return out

    def failure(self, u) -> str:
        """Why the model of row ``u`` cannot be run ("" when it can)."""
        rr = self.forwards[0].run_row(self.marginals.from_u(np.atleast_2d(u))[0])
        return next((x.error for x in rr if x.error), "")

    def __call__(self, u) -> np.ndarray:
        """:meth:`values` through the evaluator (backend and store) when one is set."""
        u = np.atleast_2d(np.asarray(u, float))
        out = self.evaluator(u) if self.evaluator is not None else self.values(u)
        self.runs += len(u) * self.n_speeds
        bad = ~np.all(np.isfinite(out), axis=1)
        if bad.any():
            self.n_failed += int(bad.sum())
            if len(self.failed) < 5:
                self.failed.append(self.failure(u[np.flatnonzero(bad)[0]]))
        return out


def evaluation_of(cfg):
    """The evaluation of a configuration's reliability estimate (built in a worker)."""
    return Response(cfg, np.asarray(cfg.speeds_kmh, float)).values


def _monte_carlo(g, n_var, limit, target, block, max_runs, rng):
    """Crude Monte Carlo of every column of ``g`` and of their maximum."""
    hits, n = None, 0
    while True:
        y = g(rng.standard_normal((block, n_var)))
        y = np.concatenate([y, y.max(axis=1, keepdims=True)], axis=1)
        h = (y > limit).sum(axis=0)
        hits = h if hits is None else hits + h
        n += block
        p = hits / n
        with np.errstate(divide="ignore", invalid="ignore"):
            cov = np.sqrt((1.0 - p) / (n * p))
        if (np.isfinite(cov[-1]) and cov[-1] <= target) or n + block > max_runs:
            return p, cov, np.full(p.size, n)


def _subset(g1, n_var, limit, target, block, max_runs, seed):
    """Subset simulation (OpenTURNS) of the scalar response ``g1``: (P, cov, runs)."""
    import openturns as ot

    calls = [0]
    raised: list[BaseException] = []

    def f(x):
        try:
            y = g1(np.asarray(x, float))
        except BaseException as exc:  # OpenTURNS turns it into a RuntimeError
            raised.append(exc)
            raise
        calls[0] += len(y)
        return [[float(v)] for v in y]

    n_level = block
    for attempt in range(2):
        ot.RandomGenerator.SetSeed(int(seed))
        calls[0] = 0
        model = ot.PythonFunction(n_var, 1, func_sample=f)
        y = ot.CompositeRandomVector(model, ot.RandomVector(ot.Normal(n_var)))
        event = ot.ThresholdEvent(y, ot.Greater(), float(limit))
        algo = ot.SubsetSampling(event)
        algo.setMaximumOuterSampling(1)
        algo.setBlockSize(int(n_level))
        algo.setConditionalProbability(LEVEL_PROBABILITY)
        try:
            algo.run()
        except RuntimeError:
            if raised:  # the evaluation's own exception (an interruption: the store)
                raise raised[0] from None
            raise
        res = algo.getResult()
        p = float(res.getProbabilityEstimate())
        cov = float(res.getCoefficientOfVariation()) if p > 0 else math.inf
        if attempt or cov <= target or not math.isfinite(cov):
            break
        grown = int(math.ceil(n_level * (cov / target) ** 2 * 1.1))
        levels = max(1, round(calls[0] / n_level))
        if grown * levels > max_runs:
            break
        n_level = grown
    return p, cov, calls[0]


def estimate(cfg, command: str = "vsi reliability", backend=None, workers=None,
             scheduler=None, store=None, fresh=False, notes=None):
    """Estimate the probability of exceedance of the configuration's check
    (:func:`_estimate`) with the BLAS pool at one thread: its threads only spin on the
    small products of the forward runs (1.4 x the CPU time for the same wall time).
    ``backend``, ``workers``, ``scheduler``, ``store``, ``fresh``, ``notes``: as for
    :func:`vsi_numba.existing.calibrate.calibrate`."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return _estimate(cfg, command=command, backend=backend, workers=workers,
                         scheduler=scheduler, store=store, fresh=fresh, notes=notes)


def _estimate(cfg, command: str = "vsi reliability", backend=None, workers=None,
              scheduler=None, store=None, fresh=False, notes=None):
    """Estimate the probability of exceedance of the configuration's check.

    Returns
    -------
    xarray.Dataset
        The reliability file (:func:`reliability_dataset`).
    """
    from pathlib import Path

    from vsi_numba.existing.calibrate import _identity
    from vsi_numba.existing.parallel import Evaluator, Spec, Store

    t0 = _time.perf_counter()
    r = cfg.resolved().get("reliability")
    if not r:
        raise ReliabilityError("the configuration has no [reliability] section")
    speeds = np.asarray(cfg.speeds_kmh, float)
    limit = check_limit(cfg)
    g = Response(cfg, speeds)
    probe = g(np.zeros((1, g.marginals.n)))
    if g.failed:
        raise ReliabilityError("the model at the inputs' medians cannot be run: "
                               + g.failed[0])
    g.runs = 0
    n_var = g.marginals.n
    spec = Spec("reliability", cfg.to_json(), str(Path(cfg.base_dir).resolve()))
    st = Store(store, _identity(cfg, "reliability", n_var, speeds.size), fresh=fresh)
    if notes is not None and st.discarded:
        notes.append(f"the stored evaluations {store} were discarded: {st.discarded}")
    try:
        with Evaluator(spec, g.values, speeds.size, backend=backend, workers=workers,
                       scheduler=scheduler, store=st) as ev:
            g.evaluator = ev
            p, cov, runs = _estimates(g, r, speeds, limit, n_var)
    finally:
        g.evaluator = None
        st.close()
    if notes is not None and st.replayed:
        notes.append(f"{st.replayed} blocks of forward runs replayed from {store}")
    ds = reliability_dataset(cfg, r, speeds, limit, probe[0], p, cov, runs, g,
                             _time.perf_counter() - t0, command)
    ds.attrs["backend"] = ev.describe()
    return ds


def _estimates(g, r, speeds, limit, n_var):
    """(P, cov, runs) per speed and over the range, by the configuration's method."""
    target, block, max_runs = float(r["target_cov"]), int(r["block_size"]), int(
        r["max_runs"])
    if r["method"] == "monte_carlo":
        rng = np.random.default_rng(int(r["seed"]))
        return _monte_carlo(g, n_var, limit, target, block, max_runs, rng)
    p, cov, runs = [], [], []
    for j in range(speeds.size + (speeds.size > 1)):
        col = (lambda u, j=j: g(u)[:, j]) if j < speeds.size else \
            (lambda u: g(u).max(axis=1))
        pj, cj, nj = _subset(col, n_var, limit, target, block, max_runs,
                             int(r["seed"]) + j)
        p.append(pj)
        cov.append(cj)
        runs.append(nj)
    if speeds.size == 1:  # the range is the one speed: the same estimate
        p, cov, runs = p * 2, cov * 2, runs * 2
    return np.array(p), np.array(cov), np.array(runs)


def reliability_dataset(cfg, r, speeds, limit, median_value, p, cov, runs, g, elapsed,
                        command):
    """The reliability file: per speed and over the range (see the module notes)."""
    import json

    import xarray as xr

    from vsi_numba.io.netcdf import CONVENTIONS, history_line, source_string

    p = np.asarray(p, float)
    with np.errstate(divide="ignore"):
        beta = -scipy.stats.norm.ppf(p)
    runs = np.asarray(runs, np.int64)
    upper = np.where(p > 0, p, 3.0 / np.maximum(runs, 1))
    unit = "m s-2" if r["check"] == "deck_acceleration" else "m"
    ds = xr.Dataset(
        {
            "probability_of_exceedance": ("speed", p[:-1], {
                "long_name": f"probability that {r['check']} exceeds the limit",
                "units": "1"}),
            "reliability_index": ("speed", beta[:-1], {"long_name": "beta = -Phi^-1(P)",
                                                      "units": "1"}),
            "cov": ("speed", np.asarray(cov, float)[:-1], {
                "long_name": "coefficient of variation of the estimate (inf: no "
                             "exceedance observed)", "units": "1"}),
            "runs": ("speed", runs[:-1], {"long_name": "forward runs of the estimate",
                                          "units": "1"}),
            "probability_upper_95": ("speed", upper[:-1], {
                "long_name": "the estimate, or 3/N (95 % upper bound) without an "
                             "exceedance", "units": "1"}),
            "probability_of_exceedance_range": ((), p[-1], {
                "long_name": "probability that the largest value over the speeds "
                             "exceeds the limit", "units": "1"}),
            "reliability_index_range": ((), beta[-1], {"units": "1"}),
            "cov_range": ((), float(np.asarray(cov, float)[-1]), {"units": "1"}),
            "runs_range": ((), runs[-1], {"units": "1"}),
            "probability_upper_95_range": ((), upper[-1], {"units": "1"}),
            "value_at_medians": ("speed", np.asarray(median_value, float), {
                "long_name": f"{r['check']} with every input at its median "
                             "(deterministic verdict)", "units": unit}),
            "variable_distribution": ("variable", [describe(v) for v in r["variables"]]),
        },
        coords={"speed": ("speed", speeds / 3.6, {"units": "m s-1",
                                                   "long_name": "train speed"}),
                "speed_kmh": ("speed", speeds, {"units": "km/h"}),
                "variable": ("variable", [v["key"] for v in r["variables"]])},
        attrs={
            "Conventions": CONVENTIONS,
            "title": str(cfg.title or "vsi_numba reliability"),
            "history": history_line(command),
            "source": source_string(),
            "vsi_file": "reliability",
            "config_json": cfg.to_json(),
            "config_sha256": cfg.sha256,
            "check": r["check"], "limit": float(limit), "limit_units": unit,
            "method": ("subset simulation (OpenTURNS SubsetSampling, conditional "
                       f"probability {LEVEL_PROBABILITY:g})" if r["method"] == "subset"
                       else "crude Monte Carlo"),
            "target_cov": float(r["target_cov"]), "seed": int(r["seed"]),
            "n_forward_runs": int(g.runs), "elapsed_s": float(elapsed),
            "failed_runs": int(g.n_failed),
            "failed_examples": json.dumps(sorted(set(g.failed))[:5]),
        },
    )
    return ds


def reliability_markdown(ds) -> str:
    """The Markdown of a reliability file."""
    from vsi_numba.existing.text import md as _md

    a = ds.attrs
    lim = float(a["limit"])
    lines = [f"# {_md(a.get('title', 'Reliability'))}", "",
             f"Probability that **{_md(a['check'])}** exceeds {lim:g} {_md(a['limit_units'])}"
             f" ({_md(a['method'])}, target coefficient of variation {a['target_cov']:g}, "
             f"seed {a['seed']}; {a['n_forward_runs']} forward runs in "
             f"{float(a['elapsed_s']):.1f} s).", "",
             "| variable | distribution |", "|---|---|"]
    for k, d in zip(ds["variable"].values, ds["variable_distribution"].values, strict=True):
        lines.append(f"| {_md(k)} | {_md(d)} |")
    lines += ["", "| speed (km/h) | value at the medians | deterministic verdict | P "
              "(exceeded) | beta | cov | runs |", "|---:|---:|---|---:|---:|---:|---:|"]

    def row(label, med, p, beta, cov, runs, upper):
        if med is None:
            verdict, medt = "", ""
        else:
            verdict, medt = ("pass" if med <= lim else "FAIL"), f"{med:.4g}"
        if p > 0:
            pt, bt, ct = f"{p:.3g}", f"{beta:.3f}", f"{cov:.3f}"
        else:
            pt, bt, ct = (f"none observed: < {upper:.2g} (95 %)",
                          f"> {-scipy.stats.norm.ppf(upper):.2f}", "not determined")
        return f"| {label} | {medt} | {verdict} | {pt} | {bt} | {ct} | {runs} |"

    for j, v in enumerate(ds["speed_kmh"].values):
        lines.append(row(f"{float(v):g}", float(ds["value_at_medians"].values[j]),
                         float(ds["probability_of_exceedance"].values[j]),
                         float(ds["reliability_index"].values[j]),
                         float(ds["cov"].values[j]), int(ds["runs"].values[j]),
                         float(ds["probability_upper_95"].values[j])))
    med = float(np.max(ds["value_at_medians"].values))
    lines.append(row("all speeds", med, float(ds["probability_of_exceedance_range"]),
                     float(ds["reliability_index_range"]), float(ds["cov_range"]),
                     int(ds["runs_range"]), float(ds["probability_upper_95_range"])))
    if int(a.get("failed_runs", 0)):
        lines += ["", f"{a['failed_runs']} runs could not be made (counted as exceeded, "
                  f"the safe side): e.g. {_md(a.get('failed_examples', ''))}."]
    lines += ["", "The deterministic verdict is that of every input at its median."]
    return "\n".join(lines) + "\n"
