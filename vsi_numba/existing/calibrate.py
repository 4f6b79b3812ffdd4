"""``vsi calibrate``: Bayesian updating of configuration keys from measured records.

The model
    Each record ``m(t)`` (a deck acceleration or displacement at a point, for a train at
    a speed) is compared with the forward run's history ``s(t; theta)`` of the same
    quantity at the same point, both low-passed at the EN cut-off
    (:mod:`vsi_numba.existing.signal`) and sampled at the model's time step.  The
    record's clock is the model's (``t = 0`` when the first axle is ``solver.approach``
    before the deck) up to a shift, found for every forward run by least squares over
    ``+- calibration.max_lag_s`` (an FFT cross-correlation, refined below a step): the
    alignment is a profiled nuisance parameter, not hand-tuned.

The likelihood
    Independent Gaussian residuals with the standard deviation of the filtered noise,
    ``noise_std x g`` (``g``: the filter's gain on white noise at the record's sampling),
    taken every ``1 / (2 f_c)`` seconds: the filtered noise is correlated over about that
    time, so the samples in between carry no new information and counting them would
    make the posterior too narrow.  The samples kept are still slightly correlated
    (the filtered noise's autocorrelation at multiples of the spacing): the spectral
    density of their noise at low frequency, where the parameters' information lies
    (the modes' frequencies and the decay of the free vibration, far below the kept
    rate 2 f_c), is ``kappa`` times that of independent samples,
    ``kappa = sum_k rho(k / (2 f_c))`` (:func:`~vsi_numba.existing.signal.kept_correlation`,
    1.134 at the synthetic case's 500 Hz and 40.8 Hz).  Each record's log-likelihood is
    divided by its ``kappa`` (``n_kept / kappa`` effective samples, the Whittle
    likelihood at low frequency): without it, the estimates of the synthetic case
    scatter over noise realisations 1.06-1.07 times the posterior's standard deviation
    (a linearised Monte Carlo of the estimator through the records' filter and
    resampling, 3000 realisations).  Without ``calibration.noise_std`` the noise of each
    quantity is a parameter too (``calibration.noise_std.<quantity>``, lognormal prior,
    median 10 % of the filtered records' RMS, cov 1).

The sampler
    ``emcee`` (Foreman-Mackey et al. 2013), the affine-invariant ensemble sampler of
    Goodman & Weare (2010): no tuning of a proposal per parameter, which suits parameters
    of very different scales (EI in N m2, damping ratios), and every step evaluates all
    walkers at once (``vectorize=True``), which is the batch the forward runs are made in.
    The moves are emcee's differential evolution
    (:func:`~vsi_numba.existing.sampling.moves`): on a standard normal target it mixes
    as the earlier mixture with 20 % of emcee's snooker moves, which narrowed the
    posterior (standard deviations 0.978 of the target's), and much faster
    than the default stretch move (about 30 steps on the synthetic case).
    It samples in the priors' standard normal space (:mod:`vsi_numba.existing.distributions`).
    The walkers start as draws of the Laplace approximation at the maximum a posteriori
    point (a Nelder-Mead search, scipy, from the best of ``4 x n_walkers`` prior draws):
    a normal law of covariance ``(-H)^-1``, ``H`` the log posterior's Hessian by central
    differences of one standard deviation (``2 n (n + 1) + 1`` evaluations in three
    batches); where ``H`` is not negative definite, a small ball (1e-4 prior standard
    deviations) around the point.  Drawn from about the posterior's width, the walkers
    need a short burn-in only; from the ball they took 60-80 steps to spread to it,
    and a chain kept from step 100 (the coverage chains of the synthetic case) had
    R-hat 1.07-1.23.  The moves' integrated autocorrelation time is about 10-12 steps
    on the synthetic case: a split R-hat at most 1.05 wants about 400 kept steps.

Diagnostics
    The acceptance fraction per walker, the integrated autocorrelation time per
    parameter (emcee's estimator), the effective sample size ``n_samples / tau`` and the
    Gelman-Rubin R-hat over the walkers' chains (of the kept steps, split in halves).
"""

from __future__ import annotations

import json
import math
import time as _time
from pathlib import Path

import numpy as np

from vsi_numba.existing.distributions import Marginals, describe
from vsi_numba.existing.forward import Forward, Group, record_path
from vsi_numba.existing.sampling import laplace_covariance, laplace_evaluations, moves
from vsi_numba.existing.signal import (
    decimation,
    kept_correlation,
    lowpass,
    lowpass_sections,
    noise_gain,
    resample,
)
from vsi_numba.io.records import read_record

#: Prior of a noise standard deviation that is a parameter: lognormal, this cov, median
#: this fraction of the RMS of the filtered records of its quantity.
NOISE_PRIOR_COV = 1.0
NOISE_PRIOR_FRACTION = 0.1
#: Where the Laplace approximation fails (a Hessian not negative definite), walkers
#: start in a ball of this radius (prior standard deviations) around the maximum a
#: posteriori point: small, since the ensemble's moves widen a ball faster than they
#: shrink one (records pin stiffness to 1e-4 of its value, 5e-4 prior standard
#: deviations of a 20 % prior).
START_BALL = 1e-4
#: Evaluations of the Nelder-Mead search of the maximum a posteriori point.
POLISH_EVALUATIONS = 60
#: Prior draws searched for the start: this many times the number of walkers.
START_DRAWS = 4


class CalibrationError(ValueError):
    """A calibration that cannot be made (the message says why)."""


class _Prepared:
    """The records, filtered and on the model's grid, and what the likelihood needs."""

    def __init__(self, cfg):
        from vsi_numba.existing.speed import record_speeds

        self.cfg = cfg
        c = cfg.resolved()["calibration"]
        self.c = c
        self.records = c["records"]
        self.keys = [p["key"] for p in c["parameters"]]
        #: per record: its speed (km/h), as given or from the record (speed.py)
        self.speeds_kmh, self.speed_notes = record_speeds(cfg)
        groups = []  # (train, track) in the records' order
        for r in self.records:
            g = (r["train"], r.get("track"))
            if g not in groups:
                groups.append(g)
        self.groups = []
        self.where = []  # per record: (group, speed index, point index)
        for name, track in groups:
            idx = [i for i, r in enumerate(self.records)
                   if (r["train"], r.get("track")) == (name, track)]
            speeds = sorted({self.speeds_kmh[i] for i in idx})
            points = sorted({float(self.records[i]["point"]) for i in idx})
            self.groups.append(Group(name, tuple(speeds), tuple(points), track))
        for i, r in enumerate(self.records):
            gi = groups.index((r["train"], r.get("track")))
            g = self.groups[gi]
            self.where.append((gi, g.speeds_kmh.index(self.speeds_kmh[i]),
                               g.points.index(float(r["point"]))))
        self.data = cfg.resolved()
        self.forward = Forward(self.data, cfg.base_dir, self.keys, self.groups)
        specs = [dict(p) for p in c["parameters"]]
        centre = np.array([Marginals([p]).from_u(np.zeros(1))[0] for p in specs])
        self.dt = float(cfg.solver_settings().dt)
        probe = self.forward.run_row(centre)
        bad = [r.error for r in probe if r.error]
        if bad:
            raise CalibrationError("the model at the priors' medians cannot be run: "
                                   + bad[0])
        self.cutoff = float(probe[0].cutoff)
        self.frequencies = probe[0].frequencies
        self.max_lag = int(round(float(c["max_lag_s"]) / self.dt))
        self.step = max(1, int(math.floor(1.0 / (2.0 * self.cutoff * self.dt))))
        self.measured = []  # per record: (t on the model grid, filtered values)
        self.raw = []
        self.gain = []
        self.kappa = []
        for r in self.records:
            rec = read_record(_record_path(r["file"], cfg.base_dir))
            fs = 1.0 / rec.dt
            filt = lowpass(rec.value, fs, self.cutoff)
            t, m = resample(rec.t, filt, self.dt)
            self.measured.append((t, m))
            self.raw.append(rec)
            self.gain.append(noise_gain(rec.t.size, fs, self.cutoff))
            self.kappa.append(kept_correlation(fs, self.cutoff, self.step * self.dt))
        # the likelihood's samples, the coarse alignment's thinning, the records' side of
        # the alignment (computed once) and the histories each record reads
        self.kept = [np.arange(0, m.size, self.step) for _, m in self.measured]
        self.dec = decimation(self.dt, self.cutoff)
        from vsi_numba.existing.misfit import RecordFit

        sections = lowpass_sections(1.0 / self.dt, self.cutoff)
        self.fits = [RecordFit(m, int(round(t[0] / self.dt)), self.max_lag, self.dec,
                               self.step, sections) for t, m in self.measured]
        self.wanted = [(gi, si, pi, r["quantity"] == "deck_acceleration")
                       for (gi, si, pi), r in zip(self.where, self.records, strict=True)]
        self.quantities = sorted({r["quantity"] for r in self.records})
        self.noise_keys = []
        self.noise_specs = []
        if c.get("noise_std") is None:
            for q in self.quantities:
                rms = [float(np.sqrt(np.mean(self.measured[i][1] ** 2)))
                       for i, r in enumerate(self.records) if r["quantity"] == q]
                med = NOISE_PRIOR_FRACTION * max(float(np.mean(rms)), 1e-300)
                self.noise_keys.append(f"calibration.noise_std.{q}")
                self.noise_specs.append({"prior": "lognormal", "median": med,
                                         "cov": NOISE_PRIOR_COV})
        self.specs = specs + self.noise_specs
        self.marginals = Marginals(self.specs)
        self.parameters = self.keys + self.noise_keys
        # the likelihood's compiled code loaded (or compiled) here, before the backend
        # fans out to worker processes
        self.evaluate(self.marginals.from_u(np.zeros((1, self.marginals.n))))

    def noise(self, row, i_record: int) -> float:
        """Standard deviation of the raw noise of record ``i_record`` for ``row``."""
        c = self.c
        if c.get("noise_std") is not None:
            return float(c["noise_std"])
        q = self.records[i_record]["quantity"]
        return float(row[len(self.keys) + self.quantities.index(q)])

    def loglikes(self, rows, hist) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihoods (n,) and the records' shifts (n, n_records, s) of rows and
        the histories of their forward runs (:meth:`Forward.point_histories
        <vsi_numba.existing.forward.Forward.point_histories>`), each record's histories
        filtered, aligned and compared at once (:class:`~vsi_numba.existing.misfit.RecordFit`)."""
        n = len(rows)
        ll = np.zeros(n)
        shifts = np.full((n, len(self.records)), np.nan)
        ok = np.array([not e for e in hist.errors], bool)
        ll[~ok] = -np.inf
        idx = np.flatnonzero(ok)
        if not idx.size:
            return ll, shifts
        for i, fit in enumerate(self.fits):
            t, _ = self.measured[i]
            sig = np.array([self.noise(rows[j], i) for j in idx]) * self.gain[i]
            for sel, part, x in _by_length(hist.values[i], hist.lengths[i], idx):
                lags, sse, _ = fit.fit(x, sig[part])
                shifts[sel, i] = lags * self.dt - t[0]
                ll[sel] += (-0.5 * sse - self.kept[i].size * (
                    np.log(sig[part]) + 0.5 * math.log(2 * math.pi))) / self.kappa[i]
        return ll, shifts

    def evaluate(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihoods (n,) and shifts (n, n_records) of parameter rows (n, n_par)."""
        rows = np.atleast_2d(rows)
        hist = self.forward.point_histories(rows[:, : len(self.keys)], self.wanted)
        return self.loglikes(rows, hist)

    def predictive_rows(self, x) -> np.ndarray:
        """The posterior-predictive histories of rows of the keys' values (n, n_keys):
        (n, 1 + sum of the records' lengths), 1 when the row's model ran (else 0 and
        NaN), then each record's filtered model history aligned at its best shift, on
        the record's grid (the evaluation the backends run for :func:`_predictive`)."""
        x = np.atleast_2d(np.asarray(x, float))
        hist = self.forward.point_histories(x, self.wanted)
        sizes = [m.size for _, m in self.measured]
        out = np.full((len(x), 1 + sum(sizes)), np.nan)
        ok = np.array([not e for e in hist.errors], bool)
        out[:, 0] = ok
        idx = np.flatnonzero(ok)
        start = 1
        for i, fit in enumerate(self.fits):
            for sel, _, h in _by_length(hist.values[i], hist.lengths[i], idx):
                out[sel, start: start + sizes[i]] = fit.fit(h, np.ones(sel.size), True)[2]
            start += sizes[i]
        return out

    def evaluate_u(self, u) -> np.ndarray:
        """The outputs of rows ``u`` of the priors' standard normal space: (n, 1 +
        n_records), the log-likelihood then the records' shifts (the evaluation the
        backends run, :mod:`vsi_numba.existing.parallel`)."""
        ll, shifts = self.evaluate(self.marginals.from_u(np.atleast_2d(u)))
        return np.concatenate([ll[:, None], shifts], axis=1)


def _by_length(values, lengths, idx):
    """The rows ``idx`` of ``values`` (n, n_t) in blocks of one history length:
    (rows, their positions in ``idx``, the block (rows, length))."""
    ln = lengths[idx]
    for n_t in np.unique(ln):
        part = np.flatnonzero(ln == n_t)
        sel = idx[part]
        if sel.size == values.shape[0] and n_t == values.shape[1]:
            yield sel, part, values
        else:
            yield sel, part, values[sel, :n_t]


#: The calibrations prepared in this process (a worker's evaluations share them).
_PREPARED: dict = {}


def _prepared(cfg) -> _Prepared:
    key = (cfg.sha256, str(Path(cfg.base_dir).resolve()))
    prep = _PREPARED.get(key)
    if prep is None:
        prep = _PREPARED[key] = _Prepared(cfg)
    return prep


def evaluation_of(cfg):
    """The evaluation of a configuration's calibration (built in a worker process)."""
    return _prepared(cfg).evaluate_u


def predictive_of(cfg):
    """The posterior-predictive evaluation of a configuration's calibration
    (:meth:`_Prepared.predictive_rows`, built in a worker process)."""
    return _prepared(cfg).predictive_rows


def check_of(cfg):
    """The check's evaluation of a configuration's calibration (:class:`_Check`, built
    in a worker process)."""
    return _Check(_prepared(cfg)).values


def _polish(f, u, n_dim: int) -> np.ndarray:
    """The maximum a posteriori point near ``u`` (Nelder-Mead, scipy, a few dozen
    evaluations per parameter)."""
    import scipy.optimize

    res = scipy.optimize.minimize(lambda x: -f(x), u, method="Nelder-Mead",
                                  options={"maxfev": POLISH_EVALUATIONS * n_dim,
                                           "xatol": 1e-6, "fatol": 1e-3,
                                           "initial_simplex": u + np.vstack(
                                               [np.zeros(n_dim), 0.1 * np.eye(n_dim)])})
    return res.x if np.isfinite(res.fun) and res.fun <= -f(u) else np.asarray(u)


def _r_hat(chain: np.ndarray) -> np.ndarray:
    """Split Gelman-Rubin R-hat per parameter of a chain (steps, walkers, n)."""
    n = chain.shape[0] // 2
    if n < 2:
        return np.full(chain.shape[2], np.nan)
    c = np.concatenate([chain[:n], chain[n: 2 * n]], axis=1)  # (n, 2 walkers, p)
    w = c.var(axis=0, ddof=1).mean(axis=0)
    b = n * c.mean(axis=0).var(axis=0, ddof=1)
    var = (n - 1) / n * w + b / n
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(var / w)


def calibrate(cfg, progress=None, command: str = "vsi calibrate", backend=None,
              workers=None, scheduler=None, store=None, fresh=False, notes=None):
    """Run the calibration of a configuration with a ``[calibration]`` section
    (:func:`_calibrate`) with the BLAS pool at one thread: its threads only spin on the
    small products of the forward runs (1.4 x the CPU time for the same wall time).

    ``backend``, ``workers``, ``scheduler``: where the forward runs go
    (:mod:`vsi_numba.existing.parallel`); ``store``: the file of the evaluations that
    makes the run resumable (None: none), ``fresh``: discard it first; ``notes``: a list
    that receives what the user should know (a discarded store, replayed blocks).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return _calibrate(cfg, progress=progress, command=command, backend=backend,
                          workers=workers, scheduler=scheduler, store=store, fresh=fresh,
                          notes=notes)


def _calibrate(cfg, progress=None, command: str = "vsi calibrate", backend=None,
               workers=None, scheduler=None, store=None, fresh=False, notes=None):
    """Run the calibration of a configuration with a ``[calibration]`` section.

    Returns
    -------
    xarray.Dataset
        The posterior file's content (:func:`posterior_dataset`).
    """
    from vsi_numba.existing.parallel import Evaluator, Spec, Store

    c = cfg.resolved().get("calibration")
    if not c:
        raise CalibrationError("the configuration has no [calibration] section")
    prep = _Prepared(cfg)
    spec = Spec("calibration", cfg.to_json(), str(Path(cfg.base_dir).resolve()))
    st = Store(store, _identity(cfg, "calibration", prep.marginals.n,
                                1 + len(prep.records)), fresh=fresh)
    if notes is not None and st.discarded:
        notes.append(f"the stored evaluations {store} were discarded: {st.discarded}")
    try:
        with Evaluator(spec, prep.evaluate_u, 1 + len(prep.records), backend=backend,
                       workers=workers, scheduler=scheduler, store=st) as ev:
            # the predictive records and the check on the same workers (not stored: a
            # resumed run computes them again, to the same numbers)
            base = (spec.config_json, spec.base_dir)
            check = _Check(prep)
            predict = ev.other(Spec("calibration_predictive", *base), prep.predictive_rows,
                               1 + sum(m.size for _, m in prep.measured))
            checks = ev.other(Spec("calibration_check", *base), check.values,
                              check.speeds.size)
            ds = _sample(cfg, c, prep, ev, progress, command, predict, (check, checks))
    finally:
        st.close()
    if notes is not None and st.replayed:
        notes.append(f"{st.replayed} blocks of forward runs replayed from {store}")
    ds.attrs["backend"] = ev.describe()
    return ds


def _identity(cfg, kind: str, n_in: int, n_out: int) -> dict:
    """What a store of evaluations belongs to (:class:`~vsi_numba.existing.parallel.Store`)."""
    from vsi_numba import __version__

    return {"kind": kind, "config_sha256": cfg.sha256, "version": __version__,
            "n_in": int(n_in), "n_out": int(n_out)}


def _sample(cfg, c, prep, ev, progress, command, predict, check):
    """The start search, the chains, the predictive records and the check (``predict``,
    ``check``: their evaluations on the backend, :meth:`Evaluator.other
    <vsi_numba.existing.parallel.Evaluator.other>`)."""
    import emcee

    t0 = _time.perf_counter()
    n_dim = prep.marginals.n
    n_walkers = int(c.get("n_walkers") or max(16, 4 * n_dim + (4 * n_dim) % 2))
    n_steps = max(1, int(math.ceil(int(c["n_samples"]) / n_walkers)))
    burn = int(c["burn_in"]) if c.get("burn_in") is not None else n_steps
    rng = np.random.default_rng(int(c["seed"]))
    n_runs = [0]

    def log_prob(u):
        u = np.atleast_2d(np.asarray(u, float))
        out = ev(u)
        ll, shifts = out[:, 0], out[:, 1:]
        n_runs[0] += len(u)
        lp = ll - 0.5 * np.sum(u ** 2, axis=1)
        if progress is not None:
            progress(n_runs[0], n_walkers * (burn + n_steps) + START_DRAWS * n_walkers
                     + POLISH_EVALUATIONS * n_dim + laplace_evaluations(n_dim))
        # emcee (vectorize): one row per walker, the log probability then the blobs
        return np.concatenate([lp[:, None], ll[:, None], shifts], axis=1)

    u0 = rng.standard_normal((START_DRAWS * n_walkers, n_dim))
    lp0 = log_prob(u0)[:, 0]
    if not np.isfinite(lp0).any():
        raise CalibrationError("no prior draw gives a model that runs: check the priors")
    best = _polish(lambda u: float(log_prob(np.atleast_2d(u))[0, 0]),
                   u0[int(np.argmax(lp0))], n_dim)
    cov = laplace_covariance(lambda u: log_prob(u)[:, 0], best)
    if cov is not None:
        start = rng.multivariate_normal(best, cov, n_walkers, method="eigh")
    else:
        start = best + START_BALL * rng.standard_normal((n_walkers, n_dim))
    sampler = emcee.EnsembleSampler(n_walkers, n_dim, log_prob, vectorize=True,
                                    moves=moves())
    # emcee's own generator: seeded from the configuration's seed (reproducible)
    sampler.random_state = np.random.RandomState(int(c["seed"])).get_state()
    sampler.run_mcmc(start, burn + n_steps, progress=False)
    chain_u = sampler.get_chain()[burn:]  # (steps, walkers, n)
    blobs = sampler.get_blobs()[burn:]  # (steps, walkers, 1 + n_records)
    lp = sampler.get_log_prob()[burn:]
    flat_u = chain_u.reshape(-1, n_dim)
    post = prep.marginals.from_u(flat_u)
    # emcee's estimator over the walkers that moved (a walker that stayed put through a
    # short chain has no autocorrelation function)
    moved = np.ptp(chain_u, axis=0).min(axis=1) > 0.0
    tau = (emcee.autocorr.integrated_time(chain_u[:, moved], quiet=True, tol=0)
           if moved.any() else np.full(n_dim, np.nan))
    ess = flat_u.shape[0] / np.maximum(tau, 1.0)
    rhat = _r_hat(chain_u)
    diag = dict(acceptance=np.asarray(sampler.acceptance_fraction, float), tau=tau, ess=ess,
                rhat=rhat, n_walkers=n_walkers, n_steps=n_steps, burn=burn,
                n_runs=n_runs[0])
    pred = _predictive(prep, post, int(c["check_samples"]), predict)
    check = _check(prep, post, int(c["check_samples"]), *check)
    elapsed = _time.perf_counter() - t0
    return posterior_dataset(prep, post, blobs.reshape(-1, blobs.shape[-1]),
                             lp.reshape(-1), diag, pred, check, elapsed, command)


def _draws(post: np.ndarray, n: int) -> np.ndarray:
    """``n`` posterior samples evenly spread over the kept chain (deterministic)."""
    idx = np.unique(np.linspace(0, post.shape[0] - 1, min(n, post.shape[0])).astype(int))
    return post[idx]


def _predictive(prep: _Prepared, post, n: int, predict) -> list[dict]:
    """Posterior-predictive records: the filtered model history of each draw aligned at
    its best shift, on the record's grid (:meth:`_Prepared.predictive_rows`, run by
    ``predict``); 5 / 50 / 95 % per time."""
    rows = _draws(post, n)
    y = predict(rows[:, : len(prep.keys)])
    y = y[y[:, 0] == 1.0]
    out = []
    start = 1
    for t, m in prep.measured:
        sims = y[:, start: start + m.size]
        start += m.size
        q = np.percentile(sims, [5, 50, 95], axis=0) if sims.size else np.full(
            (3, m.size), np.nan)
        out.append({"t": t, "measured": m, "p05": q[0], "p50": q[1], "p95": q[2]})
    return out


def check_speeds(cfg, record_speeds=None) -> np.ndarray:
    """Line speed, +10 % and +20 % (km/h) of the calibrated check (without a line speed:
    the fastest record's, ``record_speeds`` when given)."""
    c = cfg.resolved()["calibration"]
    line = c.get("line_speed_kmh") or cfg.resolved()["study"].get("line_speed_kmh")
    if line is None:
        line = max(record_speeds if record_speeds is not None else
                   [float(r["speed_kmh"]) for r in c["records"]])
    return float(line) * np.array([1.0, 1.1, 1.2])


class _Check:
    """The deck-acceleration check of a calibration's configuration: the whole-deck
    envelope (band-limited) of the train of the configuration at the line speed +10/+20
    % (:func:`check_speeds`), one forward run per train and row of the keys' values."""

    def __init__(self, prep: _Prepared):
        cfg = prep.cfg
        self.speeds = check_speeds(cfg, prep.speeds_kmh)
        self.names = [t.name for t in cfg.trains()]
        preset = cfg.resolved()["train"].get("preset")
        trains = self.names if preset is not None else [None]
        self.groups = [Group(t, tuple(float(v) for v in self.speeds),
                             (float(cfg.output_points[0]),)) for t in trains]
        self.forward = Forward(prep.data, cfg.base_dir, prep.keys, self.groups,
                               histories=False)

    def values(self, x) -> np.ndarray:
        """The check's values (n, speeds) of rows of the keys' values (n, n_keys): the
        largest over the trains, NaN where a row's model does not run."""
        x = np.atleast_2d(np.asarray(x, float))
        val = np.full((len(x), self.speeds.size), np.nan)
        for k, row in enumerate(x):
            r = self.forward.run_row(row)
            if not any(e.error for e in r):
                val[k] = np.max([e.envelope_acc for e in r], axis=0)
        return val


def _check(prep: _Prepared, post, n: int, check: _Check, values) -> dict:
    """The deck-acceleration check (:class:`_Check`) for posterior draws (run by
    ``values``) and for the configuration's own values (the code's, where it takes them
    from the code)."""
    from vsi_numba.en1990 import deck_acceleration_limits

    cfg = prep.cfg
    val = values(_draws(post, n)[:, : len(prep.keys)])
    base = Forward(prep.data, cfg.base_dir, [], check.groups, histories=False).run_row([])
    if any(x.error for x in base):
        raise CalibrationError("the configuration's own model cannot be run: "
                               + next(x.error for x in base if x.error))
    code = np.max([x.envelope_acc for x in base], axis=0)
    limits = deck_acceleration_limits(cfg.code_profile)
    limit = float(limits.get(cfg.track_type, limits["ballasted"]))
    return {"speeds_kmh": check.speeds, "posterior": val[np.all(np.isfinite(val), axis=1)],
            "code": code, "limit": limit, "trains": list(check.names)}


def posterior_dataset(prep: _Prepared, post, blobs, logpost, diag, pred, check, elapsed,
                      command):
    """The posterior file (netCDF layout; see docs/manual/calibration.md)."""
    import xarray as xr

    from vsi_numba.io.netcdf import CONVENTIONS, history_line, source_string

    n_rec = len(prep.records)
    n_t = max(p["t"].size for p in pred)

    def pad(key):
        a = np.full((n_rec, n_t), np.nan)
        for i, p in enumerate(pred):
            a[i, : p[key].size] = p[key]
        return a

    cfg = prep.cfg
    recs = prep.records
    check_v = check["speeds_kmh"] / 3.6
    ds = xr.Dataset(
        {
            "posterior": (("sample", "parameter"), post,
                          {"long_name": "posterior samples of the parameters",
                           "units": "1 (each parameter in the unit of its key)"}),
            "log_likelihood": ("sample", blobs[:, 0],
                               {"long_name": "log-likelihood of the records", "units": "1"}),
            "log_posterior": ("sample", logpost,
                              {"long_name": "log posterior density (standard normal "
                                            "space of the priors), up to a constant",
                               "units": "1"}),
            "record_shift": (("sample", "record"), blobs[:, 1:],
                             {"long_name": "time shift of the record against the model "
                                           "(model time = record time + shift)",
                              "units": "s"}),
            "prior": ("parameter", [describe(s) for s in prep.specs],
                      {"long_name": "prior distribution"}),
            "acceptance_fraction": ("walker", diag["acceptance"],
                                    {"long_name": "acceptance fraction of each walker",
                                     "units": "1"}),
            "autocorrelation_time": ("parameter", diag["tau"],
                                     {"long_name": "integrated autocorrelation time (emcee)",
                                      "units": "steps"}),
            "effective_sample_size": ("parameter", diag["ess"],
                                      {"long_name": "effective sample size "
                                                    "(samples / autocorrelation time)",
                                       "units": "1"}),
            "r_hat": ("parameter", diag["rhat"],
                      {"long_name": "split Gelman-Rubin R-hat over the walkers' chains",
                       "units": "1"}),
            "record_file": ("record", [str(r["file"]) for r in recs]),
            "record_quantity": ("record", [str(r["quantity"]) for r in recs]),
            "record_point": ("record", np.array([float(r["point"]) for r in recs]),
                             {"long_name": "deck abscissa of the record", "units": "m"}),
            "record_train": ("record", [str(r["train"]) for r in recs]),
            "record_speed_kmh": ("record", np.array(prep.speeds_kmh, float),
                                 {"long_name": "train speed of the record",
                                  "units": "km/h"}),
            "record_length": ("record", np.array([p["t"].size for p in pred], np.int64),
                              {"long_name": "samples of the record on the model's grid",
                               "units": "1"}),
            "record_time": (("record", "record_sample"), pad("t"),
                            {"long_name": "record time on the model's grid",
                             "units": "s"}),
            "record_measured": (("record", "record_sample"), pad("measured"),
                                {"long_name": "measured record, low-passed at the EN "
                                              "cut-off", "units": "m s-2 or m (quantity)",
                                 "positive": "down"}),
            "record_predictive_p05": (("record", "record_sample"), pad("p05"),
                                      {"long_name": "posterior-predictive 5 % (aligned)",
                                       "units": "m s-2 or m (quantity)"}),
            "record_predictive_p50": (("record", "record_sample"), pad("p50"),
                                      {"long_name": "posterior-predictive median",
                                       "units": "m s-2 or m (quantity)"}),
            "record_predictive_p95": (("record", "record_sample"), pad("p95"),
                                      {"long_name": "posterior-predictive 95 %",
                                       "units": "m s-2 or m (quantity)"}),
            "check_posterior": (("check_sample", "check_speed"), check["posterior"],
                                {"long_name": "max deck acceleration (whole deck, "
                                              "band-limited), calibrated model",
                                 "units": "m s-2"}),
            "check_code": ("check_speed", check["code"],
                           {"long_name": "max deck acceleration with the configuration's "
                                         "values", "units": "m s-2"}),
        },
        coords={
            "parameter": ("parameter", list(prep.parameters)),
            "sample": ("sample", np.arange(post.shape[0])),
            "walker": ("walker", np.arange(diag["acceptance"].size)),
            "record": ("record", np.arange(n_rec)),
            "check_speed": ("check_speed", check_v, {"units": "m s-1",
                                                     "long_name": "train speed"}),
            "check_speed_kmh": ("check_speed", check["speeds_kmh"], {"units": "km/h"}),
        },
        attrs={
            "Conventions": CONVENTIONS,
            "title": str(cfg.title or "vsi_numba calibration"),
            "history": history_line(command),
            "source": source_string(),
            "vsi_file": "posterior",
            "config_json": cfg.to_json(),
            "config_sha256": cfg.sha256,
            "config_directory": str(cfg.base_dir),
            "sampler": "emcee EnsembleSampler (differential-evolution moves; "
                       "vectorised)",
            "n_walkers": int(diag["n_walkers"]), "n_steps": int(diag["n_steps"]),
            "burn_in": int(diag["burn"]), "n_forward_runs": int(diag["n_runs"]),
            "n_kernel_runs_per_forward_run": int(sum(len(g.speeds_kmh)
                                                     for g in prep.groups)),
            "seed": int(prep.c["seed"]),
            "acceleration_cutoff_hz": prep.cutoff,
            "filter": "Butterworth low-pass order 4, forward and backward (sosfiltfilt), "
                      "at the EN 1990 A2 cut-off of the priors' medians",
            "likelihood_step_s": prep.step * prep.dt,
            "likelihood_kappa": json.dumps([float(k) for k in prep.kappa]),
            "noise_gain": json.dumps([float(g) for g in prep.gain]),
            "check_limit": check["limit"],
            "check_trains": " ".join(check["trains"]),
            "frequencies_hz_at_prior_median": " ".join(f"{f:.6g}" for f in
                                                       prep.frequencies[:6]),
            "elapsed_s": float(elapsed),
        },
    )
    return ds


_record_path = record_path
