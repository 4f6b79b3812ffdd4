"""The cases of existing bridges with a known answer: synthetic "measured" records from a
known truth (an independent integration plus noise) that a calibration must recover,
and a probability of exceedance in closed form.

The records come from :func:`~vsi_numba.verification.reference.moving_forces_ivp`
(``solve_ivp`` of the modal equations of the simply supported beam, numpy and scipy
only), sampled at 500 Hz on a clock of their own (``CLOCK_OFFSET`` ahead of the model's),
with white Gaussian noise of a known standard deviation.  The train's axles are the
library's HSLM-A1 (input data, not a result of the engine).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.verification import reference as ref

#: The truth of the synthetic case.
TRUTH = {"bridge.EI": 2.2e10, "bridge.damping_ratio": 0.02}
#: The deck of the synthetic case: span (m), mass (kg/m), modes, output point (m).
SPAN, MASS, N_MODES, POINT = 20.0, 15000.0, 3, 10.0
#: Speeds (km/h) of the three passages; the resonance of HSLM-A1 (D = 18 m) with the
#: truth is at f1 D = 4.76 x 18 m/s = 308 km/h.
SPEEDS_KMH = (240.0, 280.0, 305.0)
#: Sampling of the records (Hz), their noise (m s-2), their clock's offset (s: record
#: time = model time + offset) and the noise's seed.
RECORD_RATE, NOISE_STD, CLOCK_OFFSET, NOISE_SEED = 500.0, 0.3, 0.137, 2026
APPROACH, FREE_VIBRATION, DT = 5.0, 2.0, 5e-4

CONFIG = """\
# Calibration of a 20 m simply supported span on three measured passages of HSLM-A1.
# The records are synthetic: an independent integration (solve_ivp of the modal
# equations, vsi_numba.verification.reference.moving_forces_ivp) with the truth
# EI = 2.2e10 N m2, damping ratio 2 %, plus white noise of 0.3 m s-2 (make_records.py).
title = "Calibration on three HSLM-A1 passages (synthetic records)"

[bridge]
kind = "simply_supported"
spans = [{span!r}]
EI = 2.0e10                      # N m2: the design value
mass_per_length = {mass!r}
damping_ratio = 0.01             # the code's value: EN 1991-2 Table 6.6, prestressed
                                 # concrete, L >= 20 m
n_modes = {n_modes}
output_points = [{point!r}]

[train]
preset = "HSLM-A1"
model = "moving_force"

[track]
model = "rigid"                  # point forces on the deck, as the records' integration

[solver]
dt = {dt!r}
hht_alpha = 0.0                  # no numerical damping: the damping is identified
approach = {approach!r}
free_vibration = {free!r}

[study]
line_speed_kmh = 250.0
output = "results/calibration_synthetic.nc"

[calibration]
parameters = [
  {{ key = "bridge.EI", prior = "lognormal", median = 2.0e10, cov = 0.2 }},
  {{ key = "bridge.damping_ratio", prior = "uniform", lower = 0.005, upper = 0.05 }},
]
n_samples = {n_samples}
{extra}seed = 1
{records}"""

RECORD = """
[[calibration.records]]
file = "{file}"
quantity = "deck_acceleration"
point = {point!r}
train = "HSLM-A1"
speed_kmh = {speed!r}
"""


def hslm_a1_axles() -> tuple[np.ndarray, np.ndarray]:
    """Axle positions behind the first (m) and loads (N) of the library's HSLM-A1."""
    from vsi_numba.model import library

    train = library.get_train("HSLM-A1", model="moving_force")
    pos, loads = [], []
    for v, off in zip(train.vehicles, train.offsets, strict=True):
        pos.extend(np.asarray(v.load_positions, float) + off)
        loads.extend(np.asarray(v.loads, float))
    return np.array(pos), np.array(loads)


def synthetic_record(speed_kmh: float, truth=None, noise_std: float = NOISE_STD,
                     seed: int = NOISE_SEED) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic measured deck acceleration at ``POINT``: (record time, value)."""
    truth = {**TRUTH, **(truth or {})}
    pos, loads = hslm_a1_axles()
    v = speed_kmh / 3.6
    t_end = (APPROACH + SPAN + pos.max()) / v + FREE_VIBRATION
    t = np.arange(0.0, t_end, 1.0 / RECORD_RATE)
    _, a = ref.moving_forces_ivp(pos, loads, SPAN, truth["bridge.EI"], MASS,
                                 truth["bridge.damping_ratio"], N_MODES, v, [POINT], t,
                                 x_start=-APPROACH)
    rng = np.random.default_rng(seed + int(round(speed_kmh * 10)))
    return t + CLOCK_OFFSET, a[:, 0] + noise_std * rng.standard_normal(t.size)


def write_case(directory, speeds=SPEEDS_KMH, n_samples: int = 4000, extra: str = "",
               name: str = "calibration.toml", noise_std: float = NOISE_STD,
               seed: int = NOISE_SEED) -> Path:
    """Write the records (``passage_NN.csv``) and the configuration into
    ``directory``; return the configuration's path."""
    from vsi_numba.io.atomic import write_text_atomic

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    blocks = []
    for i, s in enumerate(speeds, start=1):
        t, a = synthetic_record(s, noise_std=noise_std, seed=seed)
        f = f"passage_{i:02d}.csv"
        lines = [f"# synthetic deck acceleration at x = {POINT:g} m, HSLM-A1 at {s:g} km/h,",
                 f"# m s-2 positive down; truth EI = {TRUTH['bridge.EI']:g} N m2, damping "
                 f"{TRUTH['bridge.damping_ratio']:g}; noise {noise_std:g} m s-2"
                 + ("" if seed == NOISE_SEED else f" (seed {seed})"), "t,value"]
        lines += [f"{ti:.6f},{ai:.6e}" for ti, ai in zip(t, a, strict=True)]
        write_text_atomic(d / f, "\n".join(lines) + "\n")
        blocks.append(RECORD.format(file=f, point=POINT, speed=float(s)))
    text = CONFIG.format(span=SPAN, mass=MASS, n_modes=N_MODES, point=POINT, dt=DT,
                         approach=APPROACH, free=FREE_VIBRATION, n_samples=n_samples,
                         extra=extra, records="".join(blocks))
    write_text_atomic(d / name, text)
    return d / name


# ------------------------------------------------------------------ reliability
#: The monotone case: ten equal forces 18 m apart at the resonance speed of a 20 m span
#: (one mode), the damping ratio lognormal; the peak deck acceleration decreases with the
#: damping, so P(a > limit) = F(zeta*) with a(zeta*) = limit.
REL_FORCES, REL_SPACING, REL_LOAD, REL_EI = 10, 18.0, 170e3, 2.0e10
REL_DAMPING = {"median": 0.015, "cov": 0.3}
REL_DT = 2e-3

REL_CONFIG = """\
# Probability that the deck acceleration of a 20 m span exceeds a limit under ten equal
# forces at resonance, the damping ratio lognormal (a case with a closed-form answer).
title = "Probability of exceedance, damping ratio lognormal (closed form)"

[bridge]
kind = "simply_supported"
spans = [{span!r}]
EI = {ei!r}
mass_per_length = {mass!r}
damping_ratio = 0.015
n_modes = 1
output_points = [{point!r}]
{forces}
[track]
model = "rigid"                  # point forces, as the closed form

[solver]
dt = {dt!r}
hht_alpha = 0.0
approach = 0.0
free_vibration = 0.0

[study]
speeds_kmh = [{speed!r}]

[reliability]
check = "deck_acceleration"
method = "{method}"
target_cov = {target!r}
limit = {limit!r}
block_size = {block}
max_runs = {max_runs}
seed = 3
variables = [
  {{ key = "bridge.damping_ratio", distribution = "lognormal", median = {med!r}, cov = {cov!r} }},
]
"""


def rel_speed_kmh() -> float:
    """The resonance speed f1 D (km/h) of the monotone case."""
    f1 = ref.ss_omega(SPAN, REL_EI, MASS, 1)[0] / (2 * np.pi)
    return float(f1 * REL_SPACING * 3.6)


def rel_response(zeta: float) -> float:
    """Peak deck acceleration at mid-span (closed form, :func:`reference.train_of_forces`,
    the one mode of the model) at the resonance speed."""
    v = rel_speed_kmh() / 3.6
    pos = REL_SPACING * np.arange(REL_FORCES)
    t_end = (SPAN + pos.max()) / v
    _, _, a = ref.train_of_forces(pos, np.full(REL_FORCES, REL_LOAD), SPAN, REL_EI, MASS,
                                  zeta, 1, v, [POINT], t_end, nt=200001)
    return float(np.abs(a).max())


def rel_limit(probability: float) -> tuple[float, float]:
    """The limit whose probability of exceedance is ``probability`` (closed form) and
    the damping ratio zeta* where the response equals it."""
    import scipy.stats

    s = np.sqrt(np.log1p(REL_DAMPING["cov"] ** 2))
    zeta = float(scipy.stats.lognorm(s=s, scale=REL_DAMPING["median"]).ppf(probability))
    return rel_response(zeta), zeta


def rel_probability(limit: float) -> float:
    """P(a > limit) = F(zeta*), zeta* by a root solve of a(zeta) = limit (brentq)."""
    import scipy.optimize
    import scipy.stats

    z = scipy.optimize.brentq(lambda x: rel_response(x) - limit, 1e-4, 0.2, xtol=1e-10)
    s = np.sqrt(np.log1p(REL_DAMPING["cov"] ** 2))
    return float(scipy.stats.lognorm(s=s, scale=REL_DAMPING["median"]).cdf(z))


def write_reliability_case(directory, limit: float, method: str = "subset",
                           target: float = 0.1, block: int = 1000,
                           max_runs: int = 100000, name: str = "reliability.toml") -> Path:
    """Write the monotone case's configuration; return its path."""
    from vsi_numba.io.atomic import write_text_atomic

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    forces = "".join(f'\n[[train.vehicles]]\nkind = "force"\noffset = {REL_SPACING * k!r}\n'
                     f"load = {REL_LOAD!r}\n" for k in range(REL_FORCES))
    text = REL_CONFIG.format(span=SPAN, ei=REL_EI, mass=MASS, point=POINT, forces=forces,
                             dt=REL_DT, speed=round(rel_speed_kmh(), 6), method=method,
                             target=target, limit=float(limit), block=block,
                             max_runs=max_runs, med=REL_DAMPING["median"],
                             cov=REL_DAMPING["cov"])
    write_text_atomic(d / name, text)
    return d / name


# ------------------------------------------------------------------ the vsi verify cases
def _calibrate_file(cfg_path: Path, out: Path):
    """Run the calibration of ``vsi calibrate`` and read back its posterior file."""
    import xarray as xr

    from vsi_numba.config import load_config
    from vsi_numba.existing.calibrate import calibrate
    from vsi_numba.io.netcdf import encoding_for, write_atomic

    ds = calibrate(load_config(cfg_path), command=f"vsi verify: vsi calibrate {cfg_path}")
    write_atomic(out, lambda tmp: ds.to_netcdf(tmp, encoding=encoding_for(ds)))
    with xr.open_dataset(out) as back:
        return back.load()


def _reliability_file(cfg_path: Path, out: Path):
    import xarray as xr

    from vsi_numba.config import load_config
    from vsi_numba.existing.reliability import estimate
    from vsi_numba.io.netcdf import encoding_for, write_atomic

    ds = estimate(load_config(cfg_path), command=f"vsi verify: vsi reliability {cfg_path}")
    write_atomic(out, lambda tmp: ds.to_netcdf(tmp, encoding=encoding_for(ds)))
    with xr.open_dataset(out) as back:
        return back.load()


#: The coverage of the 90 % intervals: the noise's seeds of the realisations (the first
#: is the seed of the median rows, its chain reused), the chain of every realisation
#: (samples and burn-in: 16 walkers x 500 kept steps, about 40 autocorrelation times, for
#: a split R-hat of 1.02-1.04), the least count of intervals holding the truth
#: (P(count <= 6 | binomial(10, 0.9)) = 1.3 %) and the largest RMS of the standardized
#: errors (sqrt of the 99.5 % quantile of chi-square(10) / 10 = 1.59).
COVERAGE_SEEDS = (NOISE_SEED,) + tuple(100000 + 10000 * k for k in range(1, 10))
COVERAGE_SAMPLES, COVERAGE_BURN_IN = 8000, 40
COVERAGE_MIN, COVERAGE_RMS_MAX = 7, 1.59
#: The largest split R-hat of a chain the coverage rows accept.
RHAT_MAX = 1.05
#: The noise of the model-bias check (m s-2), its tolerance on the medians and its
#: chain's samples (medians only: 100 steps).
BIAS_NOISE, BIAS_TOL, BIAS_SAMPLES = 0.003, 1e-3, 1600


def _burn() -> str:
    """The ``[calibration]`` line of the burn-in of V21's chains."""
    return f"burn_in = {COVERAGE_BURN_IN}\n"


def v21_calibration(workdir: Path, Row, quick: bool = False) -> list:  # noqa: N803
    """Calibration on synthetic records: the truth recovered (medians of one noise
    realisation; the coverage of the 90 % intervals and the standardized errors over
    ``COVERAGE_SEEDS``; the model's bias on nearly noise-free records); ``Row``: the row
    class of :mod:`vsi_numba.verification.cases`."""
    if quick:
        cfg = write_case(workdir, speeds=(305.0,), n_samples=320,
                         extra="n_walkers = 8\nburn_in = 40\ncheck_samples = 10\n")
    else:
        cfg = write_case(workdir, n_samples=COVERAGE_SAMPLES, extra=_burn())
    ds = _calibrate_file(cfg, workdir / "posterior.nc")
    title = ("Calibration of EI and damping on synthetic HSLM-A1 records "
             f"({'one passage, short chain' if quick else 'three passages'})")
    src = ("truth of the records: moving_forces_ivp (solve_ivp of the modal equations) "
           "+ white noise 0.3 m s-2")
    model = "vsi calibrate (emcee), moving forces, rigid track, dt 0.5 ms, HHT alpha = 0"
    keys = (("bridge.EI", 0.03, "the required accuracy of a stiffness"),
            ("bridge.damping_ratio", 0.15, "the required accuracy of a damping ratio"))
    rows = []
    for key, tol, why in keys:
        x = ds["posterior"].sel(parameter=key).values
        lo, hi = np.percentile(x, [5, 95])
        qt = float(np.mean(x < TRUTH[key]))
        rows.append(Row(f"V21-{key.split('.')[1]}-median", title, src, model,
                        f"posterior median of {key} (noise seed {NOISE_SEED}; 90 % "
                        f"interval {lo:.6g} - {hi:.6g}, the truth at its quantile {qt:.3f}: "
                        f"{'inside' if 0.05 <= qt <= 0.95 else 'outside'}; R-hat "
                        f"{float(np.nanmax(ds['r_hat'].values)):.3f}"
                        + (": a short chain, the interval indicative" if quick else "")
                        + ")", "1",
                        TRUTH[key], float(np.median(x)), tol, why))
    if quick:
        return rows
    # the coverage over independent noise realisations
    sets = [ds]
    for seed in COVERAGE_SEEDS[1:]:
        d = workdir / f"coverage_{seed}"
        c = write_case(d, n_samples=COVERAGE_SAMPLES, seed=seed, extra=_burn())
        sets.append(_calibrate_file(c, d / "posterior.nc"))
    posts = [p["posterior"] for p in sets]
    n = len(posts)
    rhat = max(float(np.nanmax(p["r_hat"].values)) for p in sets)
    ess = min(float(np.nanmin(p["effective_sample_size"].values)) for p in sets)
    converged = rhat <= RHAT_MAX
    chains = (f"{n} chains of {int(sets[0].attrs['n_walkers'])} walkers x "
              f"{int(sets[0].attrs['n_steps'])} steps: max R-hat {rhat:.3f}, min ESS "
              f"{ess:.0f}" + ("" if converged else f"; R-hat above {RHAT_MAX}: not "
                              "converged, the row fails"))
    rows.append(Row(
        "V21-convergence", title, "a converged chain: split R-hat 1", model,
        f"largest split R-hat over the parameters of the {n} chains ({chains})", "1",
        1.0, rhat, RHAT_MAX - 1.0,
        f"R-hat <= {RHAT_MAX}: the chains' halves agree (the coverage rows count only "
        "then)"))
    for key, _, _ in keys:
        truth = TRUTH[key]
        name = key.split(".")[1]
        q = np.array([float(np.mean(p.sel(parameter=key).values < truth)) for p in posts])
        z = np.array([(float(np.median(p.sel(parameter=key).values)) - truth)
                      / float(np.std(p.sel(parameter=key).values)) for p in posts])
        inside = int(np.sum((q >= 0.05) & (q <= 0.95)))
        quantiles = ", ".join(f"{v:.3f}" for v in q)
        rows.append(Row(
            f"V21-{name}-coverage", title,
            f"binomial({n}, 0.9): the share of {n} noise realisations whose 90 % "
            f"interval holds the truth", model,
            f"share of the 90 % intervals of {key} holding the truth over the noise "
            f"seeds {', '.join(map(str, COVERAGE_SEEDS))} (the truth's quantiles: "
            f"{quantiles}; {chains})", "1", 0.9,
            inside / n if converged else float("nan"),
            1.0 - (COVERAGE_MIN - 0.5) / (0.9 * n),
            f"at least {COVERAGE_MIN} of {n}: P(<= {COVERAGE_MIN - 1} | p = 0.9) = "
            f"{_binom_cdf(COVERAGE_MIN - 1, n, 0.9):.1%}"))
        rows.append(Row(
            f"V21-{name}-standardized", title,
            f"chi-square({n}): (median - truth) / posterior std of a calibrated posterior "
            "is standard normal", model,
            f"RMS over the {n} noise realisations of (median - truth) / posterior std of "
            f"{key} (values: {', '.join(f'{v:+.2f}' for v in z)}; {chains})", "1", 1.0,
            float(np.sqrt(np.mean(z ** 2))) if converged else float("nan"),
            COVERAGE_RMS_MAX - 1.0,
            f"RMS <= {COVERAGE_RMS_MAX}: sqrt of the 99.5 % quantile of chi-square({n}) "
            f"/ {n}"))
    # the model's bias: nearly noise-free records
    d = workdir / "noise_free"
    c = write_case(d, n_samples=BIAS_SAMPLES, noise_std=BIAS_NOISE, extra=_burn())
    post = _calibrate_file(c, d / "posterior.nc")["posterior"]
    for key, _, _ in keys:
        rows.append(Row(
            f"V21-{key.split('.')[1]}-bias", title,
            f"truth of the records: moving_forces_ivp + white noise {BIAS_NOISE:g} m s-2",
            model, f"posterior median of {key}, records of noise {BIAS_NOISE:g} m s-2",
            "1", TRUTH[key], float(np.median(post.sel(parameter=key).values)), BIAS_TOL,
            "the model's own bias (the noise's share is ~1e-4): a drift of the forward "
            "model or of the likelihood"))
    return rows


def _binom_cdf(k: int, n: int, p: float) -> float:
    """P(X <= k) of a binomial(n, p)."""
    from math import comb

    return float(sum(comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k + 1)))


def v22_reliability(workdir: Path, Row, quick: bool = False) -> list:  # noqa: N803
    """Probability of exceedance of a response monotone in the damping (closed form);
    ``Row``: the row class of :mod:`vsi_numba.verification.cases`."""
    title = "Probability of exceedance of the resonant deck acceleration (damping lognormal)"
    src = ("F(zeta*), zeta* a root of a(zeta) = limit on the closed-form modal response "
           "(train_of_forces)")
    rows = []
    runs = ([("monte_carlo", 0.03, 0.2, 200, 4000)] if quick else
            [("subset", 1e-3, 0.1, 2000, 40000), ("monte_carlo", 1e-3, 0.2, 5000, 40000)])
    for method, p_exact, target, block, max_runs in runs:
        limit, _ = rel_limit(p_exact)
        cfg = write_reliability_case(workdir, limit, method=method, target=target,
                                     block=block, max_runs=max_runs,
                                     name=f"reliability_{method}.toml")
        ds = _reliability_file(cfg, workdir / f"reliability_{method}.nc")
        p = float(ds["probability_of_exceedance"].values[0])
        cov = float(ds["cov"].values[0])
        tol = 3.0 * cov + 0.05 if np.isfinite(cov) else 1.0
        rows.append(Row(f"V22-{method}", title, src,
                        f"vsi reliability ({method}, {int(ds['runs'].values[0])} runs), "
                        "one mode, dt 2 ms", f"P(deck acceleration > {limit:.4g} m s-2)",
                        "1", rel_probability(limit), p, tol,
                        f"3 x the estimate's stated cov {cov:.3f}, plus 5 % for the "
                        "engine's 1 % on the resonant response"))
    return rows
