"""The benchmark cases: models, grids, and the measurements of each case.

Every case returns a :class:`CaseResult`: summary rows for the main table, a Markdown
section with the details (breakdowns, fits, extrapolations, agreement with the baseline)
and, where a target is missed, the profile and what would close the gap.

Models (SI units)
-----------------
* ``LIGHT_BEAM``: 25 m simply supported span, EI = 8.323e9 N m2, m = 2303 kg/m
  (f1 = 4.78 Hz), the Yang & Wu sprung-mass benchmark beam of
  ``configs/sprung_mass_25m.toml`` and ``configs/hslm_25m.toml``.
* ``HSR_DECK``: 25 m simply supported span, EI = 7.0e10 N m2, m = 15000 kg/m
  (f1 = 5.4 Hz, inside the EN 1991-2 Fig. 6.10 band 3.2-8.3 Hz for L = 25 m): the
  interaction case with the 8-car ICE3 (a 2303 kg/m beam under a 400 t train is not a
  realistic high-speed deck).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.baseline import n_steps_for, run_baseline
from benchmarks.timing import REPO, Timing, load1, measure, median, user_env

SPAN = 25.0
LIGHT_BEAM = {"EI": 8.323e9, "mass_per_length": 2303.0}
HSR_DECK = {"EI": 7.0e10, "mass_per_length": 15000.0}
HSLM_NAMES = [f"HSLM-A{i}" for i in range(1, 11)]
SPEEDS_KMH = np.arange(140.0, 420.0 + 1e-9, 5.0)  # 57 speeds
N_SEEDS = 10


# ----------------------------------------------------------------------------- plans


@dataclass(frozen=True)
class Plan:
    """Sizes of one benchmark mode."""

    name: str
    c1_repeat: int
    c1_baseline_repeat: int
    c2_trains: tuple  # trains run by the engine
    c2_speeds: tuple  # km/h run by the engine
    c2_baseline_speeds: tuple
    c2_baseline_steps: int
    c3_speeds: tuple
    c3_seeds: tuple
    c3_full_parallel: bool
    c3_baseline_steps: int
    c4_modes: tuple
    c4_cars: tuple
    c4_repeat: int
    c4_baseline_steps: int
    c5_run: bool
    c5_cold: bool
    c5_repeat: int


def make_plan(mode: str, cold: bool | None = None) -> Plan:
    """``smoke`` (tests), ``quick`` (CI, < 2 min after JIT), ``normal``, ``full``."""
    every = tuple(float(v) for v in SPEEDS_KMH)
    if mode == "smoke":
        return Plan("smoke", 2, 1, ("HSLM-A1", "HSLM-A10"), (140.0, 420.0), (300.0,), 60,
                    (420.0,), (1,), False, 15, (5, 20), (1, 2), 1, 15,
                    False, False, 1)
    if mode == "quick":
        return Plan("quick", 7, 1, tuple(HSLM_NAMES), every[::8], (140.0, 420.0), 300,
                    (140.0, 280.0, 420.0), (1,), False, 100, (5, 20, 80), (1, 4, 16), 3, 60,
                    True, bool(cold), 2)
    if mode in ("normal", "full"):
        return Plan(mode, 15, 3, tuple(HSLM_NAMES), every, (140.0, 280.0, 420.0), 600,
                    every[::8], (1, 2), mode == "full", 300, (5, 10, 20, 40, 80),
                    (1, 2, 4, 8, 16), 3, 150, True, True if cold is None else cold, 3)
    raise ValueError(f"unknown mode {mode!r}")


# ---------------------------------------------------------------------------- results


@dataclass
class Row:
    """One line of the summary table."""

    case: str
    quantity: str
    engine: str  # formatted wall time of the measured/extrapolated quantity
    kernel_us: float = float("nan")  # engine time loop per step, wall
    kernel_cpu_us: float = float("nan")  # engine time loop per step, CPU
    baseline_us: float = float("nan")  # dense baseline per step, CPU
    target: str = ""
    status: str = ""  # met / MISSED / info
    load: float = float("nan")
    cpu_wall: float = float("nan")  # cpu / wall of the measurement

    @property
    def steps_per_s(self) -> float:
        t = self.kernel_cpu_us if self.kernel_cpu_us == self.kernel_cpu_us else self.kernel_us
        return 1e6 / t if t > 0 else float("nan")

    @property
    def speedup(self) -> float:
        t = self.kernel_cpu_us if self.kernel_cpu_us == self.kernel_cpu_us else self.kernel_us
        if t > 0 and self.baseline_us > 0:
            return self.baseline_us / t
        return float("nan")


@dataclass
class CaseResult:
    key: str
    title: str
    rows: list[Row] = field(default_factory=list)
    details: list[str] = field(default_factory=list)  # Markdown paragraphs / tables
    agreement: dict = field(default_factory=dict)  # name -> max relative difference
    data: dict = field(default_factory=dict)  # raw numbers (scaling curves, ...)
    error: str = ""


def fmt_s(t: float) -> str:
    if not t == t:
        return "n/a"
    if t < 1e-3:
        return f"{t * 1e6:.0f} us"
    if t < 1.0:
        return f"{t * 1e3:.3g} ms"
    return f"{t:.3g} s"


def md_table(header, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


# ----------------------------------------------------------------------------- models


def _engine():
    from vsi_numba.solver import simulate as sim

    return sim


def light_beam(n_modes, damping=0.0):
    from vsi_numba.model.bridge import simply_supported

    return simply_supported(SPAN, LIGHT_BEAM["EI"], LIGHT_BEAM["mass_per_length"],
                            n_modes=n_modes, damping_ratio=damping)


def hsr_deck(n_modes, damping=0.01):
    from vsi_numba.model.bridge import simply_supported

    return simply_supported(SPAN, HSR_DECK["EI"], HSR_DECK["mass_per_length"],
                            n_modes=n_modes, damping_ratio=damping)


def case1_model():
    """Sprung mass (5750 kg, 1.595e6 N/m, massless contact point) at 100 km/h, 20 modes,
    dt = 1 ms, alpha = -0.1; the crossing: first axle from x = -5 m until it leaves the
    span (free_vibration = 0)."""
    from vsi_numba.model import vehicle as vh
    from vsi_numba.solver.settings import SolverSettings

    train = vh.Train("sprung mass", (vh.sprung_mass(5750.0, 1.595e6, 0.0, 0.0),), (0.0,))
    settings = SolverSettings(dt=1e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.0)
    return light_beam(20, 0.0), train, 100.0 / 3.6, settings


def case2_model():
    """HSLM-A1..A10 moving forces on the light beam, 10 modes, zeta = 1 %, dt = 2 ms,
    free_vibration = 0 (as ``configs/hslm_25m.toml`` but with 10 modes)."""
    from vsi_numba.model.library import get_train
    from vsi_numba.solver.settings import SolverSettings

    trains = {n: get_train(n, model="moving_force") for n in HSLM_NAMES}
    settings = SolverSettings(dt=2e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.0)
    return light_beam(10, 0.01), trains, settings


def case3_model():
    """ICE3 8-car multibody train on the HSR deck, 20 modes, zeta = 1 %, dt = 1 ms,
    approach 5 m, free_vibration = 0.5 s (as ``configs/ice3_continuous.toml``)."""
    from vsi_numba.model.library import get_train
    from vsi_numba.solver.settings import SolverSettings

    train = get_train("ICE3")
    settings = SolverSettings(dt=1e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.5)
    return hsr_deck(20), train, settings


def case3_profile(train, settings, seed):
    """German low-interference profile, wavelengths 3-80 m, covering the whole run at
    every speed (approach, bridge, exit and free vibration at 420 km/h)."""
    from vsi_numba.model.irregularity import psd_profile

    x_start = -settings.approach - train.length - 1.0
    x_stop = SPAN + train.length + 420.0 / 3.6 * settings.free_vibration + 1.0
    return psd_profile("german_low", 3.0, 80.0, int(seed), x_start, x_stop)


def repeated_car_train(n_cars: int):
    """``n_cars`` ICE3 cars (cycling through the 8 ICE3 vehicles) at the ICE3 spacing."""
    from vsi_numba.model.library import get_train
    from vsi_numba.model.vehicle import Train

    ice3 = get_train("ICE3")
    spacing = ice3.offsets[1] - ice3.offsets[0]
    vehicles = tuple(ice3.vehicles[k % len(ice3.vehicles)] for k in range(n_cars))
    return Train(f"{n_cars} ICE3 cars", vehicles, tuple(k * spacing for k in range(n_cars)))


# ------------------------------------------------------------------ engine measurements


def _midspans(bridge):
    s = np.asarray(bridge.supports, float)
    return 0.5 * (s[:-1] + s[1:])


@dataclass
class KernelRun:
    wall: float  # s, time loop alone
    cpu: float  # s, CPU time of the time loop
    steps: int
    out: object  # engine Output
    status: int


def kernel_args(packed, profile, speed, points, settings, bridge, **kw):
    """The arguments of the engine's ``run_batch`` as ``solver.batch.run_batch`` builds
    them for one run at ``speed`` (workspace, envelopes with the load effects, history
    slots per ``keep_histories``), the state and workspace set for that run
    (``start_vsi_run``)."""
    from vsi_numba.solver import batch as sim_batch
    from vsi_numba.solver import driver

    grabbed = {}

    def grab(*args):
        grabbed["args"] = args

    real = sim_batch.driver.run_batch
    sim_batch.driver.run_batch = grab
    try:
        sim_batch.run_batch(packed, profile, [speed], points, settings, bridge, **kw)
    finally:
        sim_batch.driver.run_batch = real
    args = grabbed["args"]
    driver.start_vsi_run(args[6], 0, args[7], args[9])  # init row 0 -> st; reset wk
    return args


def engine_window(bridge, train, speed, profile, settings, n_steps=None) -> KernelRun:
    """The engine's time loop alone over the first ``n_steps`` steps (all by default).

    The kernel arguments are those ``solver.batch.run_batch`` builds (workspace,
    envelopes with the load effects, one history slot); the CPU time is the time loop's.
    """
    sim = _engine()
    from vsi_numba.model.irregularity import no_irregularity

    profile = profile if profile is not None else no_irregularity()
    packed = sim.pack(bridge, train, speed, profile, settings)
    if n_steps is not None:
        n = min(int(n_steps), packed.params.n_steps)
        packed = dataclasses.replace(packed, params=packed.params._replace(n_steps=n))
    from vsi_numba import kernels as ek

    # the kernel arguments as run_batch builds them (workspace, envelopes with the
    # load effects, a history slot), then the time loop alone
    (br, veh, pr, prm, _sp, n_all, init, st, bk, wk, red, hist, _sl, _s,
     _r) = kernel_args(packed, profile, speed, _midspans(bridge), settings, bridge,
                       keep_histories=[True])
    n = packed.params.n_steps
    p = ek.Params(prm.dt, prm.alpha, speed, n, prm.max_iter, prm.tol_gap,
                  prm.tol_force, prm.max_sub, prm.contact_model, prm.hertz_g)
    c0, w0 = time.process_time(), time.perf_counter()
    status, _ = ek.time_loop(br, veh, pr, p, st, bk, wk, red, 0, hist, 0)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    m = n + 1
    out = ek.Output(*(a[0, :m] if a.shape[0] else a for a in hist))
    return KernelRun(wall, cpu, packed.params.n_steps, out, int(status))


def kernel_median(bridge, train, speed, profile, settings, n_steps, repeat) -> KernelRun:
    """Median (wall and CPU separately) of ``repeat`` kernel runs; Output of the last."""
    runs = [engine_window(bridge, train, speed, profile, settings, n_steps)
            for _ in range(max(repeat, 1))]
    return KernelRun(median([r.wall for r in runs]), median([r.cpu for r in runs]),
                     runs[-1].steps, runs[-1].out, runs[-1].status)


def breakdown(bridge, train, speed, profile, settings, save_histories, repeat=3):
    """Median seconds of the parts of ``simulate``: pack, initial_state, run_kernel
    (kernel alone, and the rest: initial_state again + output allocation), to_dataset."""
    sim = _engine()
    from vsi_numba.model.irregularity import no_irregularity

    profile = profile if profile is not None else no_irregularity()
    points = _midspans(bridge)
    parts: dict[str, list] = {k: [] for k in
                              ("pack", "initial_state", "kernel", "run_kernel other",
                               "to_dataset", "total")}
    for _ in range(repeat):
        t0 = time.perf_counter()
        packed = sim.pack(bridge, train, speed, profile, settings)
        t1 = time.perf_counter()
        sim.initial_state(packed, profile)
        t2 = time.perf_counter()
        res = sim.run_batch(packed, profile, [speed], points, settings, bridge,
                            keep_histories=[save_histories])
        kern = res.elapsed
        t3 = time.perf_counter()
        sim.to_dataset(bridge, train, res, profile, settings, points, save_histories)
        t4 = time.perf_counter()
        parts["pack"].append(t1 - t0)
        parts["initial_state"].append(t2 - t1)
        parts["kernel"].append(kern)
        parts["run_kernel other"].append(max(t3 - t2 - kern - (t2 - t1), 0.0))
        parts["to_dataset"].append(t4 - t3)
        parts["total"].append(t4 - t0 - (t2 - t1))  # initial_state is counted once
    med = {k: median(v) for k, v in parts.items()}
    med["n_steps"] = packed.params.n_steps
    return med


def breakdown_table(med) -> str:
    total = med["total"]
    rows = []
    for k in ("pack", "initial_state", "kernel", "run_kernel other", "to_dataset"):
        rows.append([k, fmt_s(med[k]), f"{100 * med[k] / total:.0f} %"])
    rows.append(["sum (= simulate)", fmt_s(total), "100 %"])
    return md_table(["part of simulate()", "median", "share"], rows)


def rel_diff(a, b) -> float:
    """max_t |a - b| / max_t |b| per column, maximum over columns (0/0 -> 0)."""
    a = np.atleast_2d(np.asarray(a, float).T).T
    b = np.atleast_2d(np.asarray(b, float).T).T
    scale = np.max(np.abs(b), axis=0)
    diff = np.max(np.abs(a - b), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(scale > 0, diff / np.where(scale > 0, scale, 1.0), diff)
    return float(np.max(r)) if r.size else 0.0


def agreement_full(ds, res) -> dict:
    """Engine dataset vs baseline over every step of a complete run."""
    x = float(ds["point"].values[0])
    n_w = res.X.shape[1]
    out = {"deflection": rel_diff(ds["deck_displacement"].values[:, 0],
                                  res.deflection(x)[:, 0])}
    if n_w:
        out["contact_force"] = rel_diff(ds["contact_force"].values[:, :n_w], res.X)
    return out


def agreement_window(out, res, bridge) -> dict:
    """Engine kernel Output vs baseline over the same first steps."""
    n = res.q.shape[0]
    phi = bridge.shapes(_midspans(bridge)[:1])
    d = {"deflection": rel_diff(out.q[:n] @ phi.T, res.q @ phi.T)}
    if res.X.shape[1]:
        d["contact_force"] = rel_diff(out.X[:n], res.X)
    return d


def fit_linear(x, y):
    """Least-squares ``y = a + b x``; returns (a, b)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 2 or np.ptp(x) == 0:
        return 0.0, float(np.sum(y) / max(np.sum(x), 1.0))
    b, a = np.polyfit(x, y, 1)
    return float(a), float(b)


def run_cost_model(steps, walls, cpus, kernels, kernel_cpu_step):
    """Per-run cost ``overhead + per_step x steps`` from measured runs.

    Wall: per_step = sum(time loop) / sum(steps), overhead = median(wall - time loop) (the
    wrapper: pack, static start, Dataset).  CPU: per_step = the time loop's CPU time per
    step on whole runs, overhead = median(cpu - per_step x steps), at least 0.  Returns
    (overhead_wall, step_wall, overhead_cpu, step_cpu).
    """
    steps = np.asarray(steps, float)
    kernels = np.asarray(kernels, float)
    w = float(kernels.sum() / steps.sum())
    o = median(list(np.asarray(walls, float) - kernels))
    oc = max(median(list(np.asarray(cpus, float) - kernel_cpu_step * steps)), 0.0)
    return max(o, 0.0), w, oc, float(kernel_cpu_step)


def fit_power(x, y):
    """``y = c x^p`` by least squares in log-log; returns (c, p)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 2:
        return float("nan"), float("nan")
    p, logc = np.polyfit(np.log(x), np.log(y), 1)
    return float(np.exp(logc)), float(p)


def _status(value, target) -> str:
    if not value == value:
        return "n/a"
    return "met" if value <= target else f"MISSED x{value / target:.1f}"


# ------------------------------------------------------------------------------ case 1


def case1(plan: Plan) -> CaseResult:
    sim = _engine()
    res = CaseResult("1", "Sprung mass crossing a 25 m simply supported span (20 modes, "
                          "dt = 1 ms, 100 km/h)")
    bridge, train, speed, settings = case1_model()
    t_sim, ds = measure(lambda: sim.simulate(bridge, train, speed, settings=settings),
                        repeat=plan.c1_repeat, warmup=1)
    n = int(ds.attrs["n_steps"])
    med = breakdown(bridge, train, speed, None, settings, True, repeat=plan.c1_repeat)
    k = kernel_median(bridge, train, speed, None, settings, None, plan.c1_repeat)
    t_b, bres = measure(lambda: run_baseline(bridge, train, speed, settings=settings),
                        repeat=plan.c1_baseline_repeat)
    base_cpu = bres.cpu_per_step
    agree = agreement_full(ds, bres)
    res.agreement.update({f"case 1 {key}": v for key, v in agree.items()})
    target = 0.5e-3
    res.rows.append(Row("1", f"crossing, simulate() ({n} steps)", fmt_s(t_sim.wall_median),
                        k.wall / n * 1e6, k.cpu / n * 1e6, base_cpu * 1e6, "<= 0.5 ms",
                        _status(t_sim.wall_median, target), t_sim.load,
                        t_sim.cpu_median / t_sim.wall_median))
    res.rows.append(Row("1", "crossing, time loop alone", fmt_s(k.wall),
                        k.wall / n * 1e6, k.cpu / n * 1e6, base_cpu * 1e6, "<= 0.5 ms",
                        _status(k.wall, target), load1(), k.cpu / k.wall))
    res.data.update(n_steps=n, simulate=t_sim.wall_median, simulate_cpu=t_sim.cpu_median,
                    kernel=k.wall, kernel_cpu=k.cpu, baseline=t_b.wall_median,
                    breakdown=med)
    res.details.append(
        f"Model: {bridge.description}, {bridge.n_modes} modes, undamped; sprung mass 5750 kg "
        f"on 1.595e6 N/m with a massless contact point; v = 100 km/h; dt = 1 ms, "
        f"alpha = -0.1; the crossing is {n} steps (first axle from x = -5 m until it leaves "
        "the span, no free vibration; the 1 s of free vibration of "
        "`configs/sprung_mass_25m.toml` would add 1000 steps at the same cost per step).\n\n"
        f"simulate(): {t_sim.summary()}.  Time loop alone (median of {plan.c1_repeat}): "
        f"{fmt_s(k.wall)} wall, {fmt_s(k.cpu)} CPU.  Baseline (dense numpy/scipy), whole run: "
        f"{t_b.summary()}; loop {base_cpu * 1e6:.0f} us/step CPU.\n\n"
        "Parts of one simulate() call (medians):\n\n" + breakdown_table(med))
    if t_sim.wall_median > target:
        fixed = med["total"] - med["kernel"]
        res.details.append(
            f"**Target missed** by x{t_sim.wall_median / target:.0f} (x"
            f"{t_sim.cpu_median / target:.0f} on CPU time).  The time loop alone is "
            f"{fmt_s(k.cpu)} CPU ({k.cpu / n * 1e6:.2f} us/step) and the Python wrapper "
            f"(pack, static start, output arrays, xarray Dataset) {fmt_s(fixed)}.  To reach "
            f"0.5 ms both must shrink: the loop to <= {0.4e-3 / n * 1e6:.2f} us/step and the "
            "wrapper to ~0.1 ms (see the profile section).")
    return res


# ------------------------------------------------------------------------------ case 2


def case2(plan: Plan) -> CaseResult:
    sim = _engine()
    res = CaseResult("2", "HSLM-A1..A10 x 57 speeds (140-420 km/h), moving forces, "
                          "10 modes")
    bridge, trains, settings = case2_model()
    grid = [(t, float(v)) for t in HSLM_NAMES for v in SPEEDS_KMH]
    steps_full = {(t, v): n_steps_for(bridge, trains[t], v / 3.6, settings) for t, v in grid}
    total_steps = sum(steps_full.values())
    sim.simulate(bridge, trains[plan.c2_trains[0]], plan.c2_speeds[0] / 3.6,
                 settings=settings, save_histories=False)  # warm
    load0 = load1()
    runs = []
    w0, c0 = time.perf_counter(), time.process_time()
    for t in plan.c2_trains:
        for v in plan.c2_speeds:
            a, ac = time.perf_counter(), time.process_time()
            ds = sim.simulate(bridge, trains[t], v / 3.6, settings=settings,
                              save_histories=False)
            runs.append((steps_full[(t, float(v))], time.perf_counter() - a,
                         time.process_time() - ac, float(ds.attrs["kernel_seconds"])))
    wall = time.perf_counter() - w0
    cpu = time.process_time() - c0
    load = max(load0, load1())
    steps = np.array([r[0] for r in runs])
    # the time loop alone, CPU time per step, on whole runs of the grid
    kfull = [engine_window(bridge, trains[t], v / 3.6, None, settings)
             for t, v in ((plan.c2_trains[0], plan.c2_speeds[0]),
                          (plan.c2_trains[-1], plan.c2_speeds[-1]))]
    kern_cpu_step = sum(x.cpu for x in kfull) / sum(x.steps for x in kfull)
    a, b, ac, bc = run_cost_model(steps, [r[1] for r in runs], [r[2] for r in runs],
                                  [r[3] for r in runs], kern_cpu_step)
    kern_step = b
    full = len(runs) == len(grid)
    if full:
        total, total_cpu = wall, cpu
        label = f"measured, all {len(grid)} runs serial"
    else:
        total = a * len(grid) + b * total_steps
        total_cpu = ac * len(grid) + bc * total_steps
        label = (f"EXTRAPOLATED from {len(runs)} of {len(grid)} runs: overhead per run + "
                 "time loop per step x steps")
    # baseline vs engine time loop over the same first steps
    bsteps, ksteps, kwall, agree = [], [], [], {}
    tr = trains["HSLM-A1"]
    for v in plan.c2_baseline_speeds:
        bres = run_baseline(bridge, tr, v / 3.6, settings=settings,
                            n_steps=plan.c2_baseline_steps)
        k = kernel_median(bridge, tr, v / 3.6, None, settings, plan.c2_baseline_steps, 3)
        bsteps.append(bres.cpu_per_step)
        ksteps.append(k.cpu / k.steps)
        kwall.append(k.wall / k.steps)
        for key, d in agreement_window(k.out, bres, bridge).items():
            agree[key] = max(agree.get(key, 0.0), d)
    res.agreement.update({f"case 2 {key} (HSLM-A1, first {plan.c2_baseline_steps} steps)": d
                          for key, d in agree.items()})
    base_step, win_step = median(bsteps), median(ksteps)
    target = 1.0
    res.rows.append(Row("2", f"570 runs serial, {'measured' if full else 'EXTRAPOLATED'}",
                        fmt_s(total), kern_step * 1e6, kern_cpu_step * 1e6, base_step * 1e6,
                        "<= 1 s", _status(total, target), load, cpu / wall))
    res.rows.append(Row("2", "570 runs, ideal 2 cores (serial / 2), estimate",
                        fmt_s(total / 2), kern_step * 1e6, kern_cpu_step * 1e6,
                        base_step * 1e6, "<= 1 s", _status(total / 2, target), load))
    kernel_total = kern_cpu_step * total_steps
    bspeeds = ", ".join(f"{v:g}" for v in plan.c2_baseline_speeds)
    res.data.update(total=total, total_cpu=total_cpu, a=a, b=b, ac=ac, bc=bc,
                    total_steps=total_steps, kernel_total=kernel_total, runs=len(runs),
                    kernel_step=kern_step, kernel_cpu_step=kern_cpu_step,
                    window_engine_step=win_step, baseline_step=base_step)
    res.details.append(
        f"Model: {bridge.description}, 10 modes, zeta = 1 %; HSLM-A1..A10 as moving forces "
        f"(`get_train(name, model='moving_force')`); dt = 2 ms (as `configs/hslm_25m.toml`), "
        f"no free vibration; `simulate(..., save_histories=False)` per run, serial.\n\n"
        f"Grid: {len(grid)} runs, {total_steps:,} steps in all.  Measured {len(runs)} runs "
        f"({int(steps.sum()):,} steps) in {wall:.3g} s wall / {cpu:.3g} s CPU (load "
        f"{load:.2f}); per run: wall = {a * 1e3:.2f} ms + {b * 1e6:.2f} us x steps, CPU = "
        f"{ac * 1e3:.2f} ms + {bc * 1e6:.2f} us x steps (overhead = median of run minus "
        "time loop; per step = time loop).  Whole grid: "
        f"**{total:.3g} s wall, {total_cpu:.3g} s CPU** ({label}).  Time loop alone: "
        f"{kern_step * 1e6:.2f} us/step wall ({kern_cpu_step * 1e6:.2f} us/step CPU on whole "
        f"runs) -> {kernel_total:.3g} s CPU for the grid; the rest is the per-run "
        f"wrapper ({ac * 1e3:.1f} ms CPU x 570 = {ac * len(grid):.3g} s).\n\n"
        f"Baseline vs engine time loop, HSLM-A1 at {bspeeds} km/h over the first "
        f"{plan.c2_baseline_steps} steps (CPU): baseline {base_step * 1e6:.0f} us/step, engine "
        f"{win_step * 1e6:.2f} us/step (x{base_step / win_step:.0f}); the baseline would "
        f"need ~{base_step * total_steps:.3g} s for the grid.")
    if total > target:
        need = target / total_steps
        res.details.append(
            f"**Target missed** by x{total / target:.0f} serial wall (x{total_cpu / target:.0f} "
            f"CPU; x{total_cpu / 2 / target:.0f} with 2 ideal cores).  Per-run wrapper "
            f"~{ac * len(grid):.3g} s CPU, time loop ~{kernel_total:.3g} s CPU; 1 s for "
            f"{total_steps:,} steps is {need * 1e9:.0f} ns/step with everything included "
            "(see the profile section).")
    return res


# ------------------------------------------------------------------------------ case 3


def _case3_run(bridge, train, settings, profile, v_kmh):
    sim = _engine()
    c0, w0 = time.process_time(), time.perf_counter()
    ds = sim.simulate(bridge, train, v_kmh / 3.6, profile=profile, settings=settings,
                      save_histories=False)
    return {"speed": v_kmh, "wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
            "kernel": float(ds.attrs["kernel_seconds"]), "n_steps": int(ds.attrs["n_steps"]),
            "status": int(ds.attrs["status"]),
            "loss": float(ds["contact_loss_duration"].max()),
            "iters": int(ds["max_iterations"])}


_WORKER_CACHE: dict = {}


def case3_worker(task):
    """One (seed, speeds) chunk of the full grid, in a spawned process."""
    seed, speeds = task
    if "model" not in _WORKER_CACHE:
        _WORKER_CACHE["model"] = case3_model()
    bridge, train, settings = _WORKER_CACHE["model"]
    profile = case3_profile(train, settings, seed)
    return [dict(_case3_run(bridge, train, settings, profile, v), seed=seed) for v in speeds]


def _case3_parallel(workers=2):
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    tasks = [(seed, tuple(float(v) for v in SPEEDS_KMH[k::2]))
             for seed in range(1, N_SEEDS + 1) for k in range(2)]
    env_before = os.environ.get("NUMBA_NUM_THREADS")
    os.environ["NUMBA_NUM_THREADS"] = "1"
    try:
        w0 = time.perf_counter()
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as ex:
            out = [r for chunk in ex.map(case3_worker, tasks) for r in chunk]
        return time.perf_counter() - w0, out
    finally:
        if env_before is None:
            os.environ.pop("NUMBA_NUM_THREADS", None)
        else:
            os.environ["NUMBA_NUM_THREADS"] = env_before


_BLAS_PROBE = """
import time
from benchmarks import cases as C
from vsi_numba.solver import simulate as sim
sim.warm_up()
bridge, train, settings = C.case3_model()
prof = C.case3_profile(train, settings, 1)
packed = sim.pack(bridge, train, 300 / 3.6, prof, settings)
ini, tot = [], []
for _ in range(5):
    t0 = time.perf_counter()
    sim.initial_state(packed, prof)
    t1 = time.perf_counter()
    sim.simulate(bridge, train, 300 / 3.6, profile=prof, settings=settings,
                 save_histories=False)
    ini.append(t1 - t0)
    tot.append(time.perf_counter() - t1)
print(sorted(ini)[2], sorted(tot)[2])
"""


def blas_threads_effect() -> dict:
    """Median initial_state() and simulate() of one ICE3 run in fresh processes with the
    BLAS threads left at the OpenBLAS default and with OPENBLAS_NUM_THREADS=1."""
    out = {}
    for label, n in (("default", None), ("1", "1")):
        env = dict(os.environ)
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            env.pop(var, None)
            if n is not None:
                env[var] = n
        p = subprocess.run([sys.executable, "-c", _BLAS_PROBE], env=env, cwd=REPO,
                           capture_output=True, text=True, timeout=900)
        try:
            ini, tot = (float(x) for x in p.stdout.split()[-2:])
        except ValueError:
            ini = tot = float("nan")
        out[label] = (ini, tot, load1())
    return out


def case3(plan: Plan) -> CaseResult:
    sim = _engine()
    res = CaseResult("3", "ICE3 (8 x 10-DOF cars, 32 wheels) interaction, German-low track, "
                          "57 speeds x 10 realisations, 20 modes, dt = 1 ms")
    bridge, train, settings = case3_model()
    t_prof, _ = measure(lambda: case3_profile(train, settings, 1), repeat=3)
    profiles = {s: case3_profile(train, settings, s) for s in plan.c3_seeds}
    # the static start must put every wheel on the rail (a regression check)
    p0 = profiles[plan.c3_seeds[0]]
    packed = sim.pack(bridge, train, plan.c3_speeds[0] / 3.6, p0, settings)
    st0 = sim.initial_state(packed, p0)
    misfit = float(np.max(np.abs(st0.u[packed.vehicles.wheel_dof]
                                 - p0(packed.vehicles.wheel_x0))))
    _case3_run(bridge, train, settings, p0, plan.c3_speeds[0])  # warm
    load0 = load1()
    w0, c0 = time.perf_counter(), time.process_time()
    runs = [dict(_case3_run(bridge, train, settings, profiles[s], v), seed=s)
            for s in plan.c3_seeds for v in plan.c3_speeds]
    wall = time.perf_counter() - w0
    cpu = time.process_time() - c0
    load = max(load0, load1())
    steps = np.array([r["n_steps"] for r in runs])
    v = 300.0
    kf = engine_window(bridge, train, v / 3.6, p0, settings)  # time loop alone, CPU
    kern_cpu_step = kf.cpu / kf.steps
    a, b, ac, bc = run_cost_model(steps, [r["wall"] for r in runs], [r["cpu"] for r in runs],
                                  [r["kernel"] for r in runs], kern_cpu_step)
    grid_steps = N_SEEDS * sum(n_steps_for(bridge, train, v / 3.6, settings) for v in SPEEDS_KMH)
    n_runs = N_SEEDS * SPEEDS_KMH.size
    serial = a * n_runs + b * grid_steps + N_SEEDS * t_prof.wall_median
    serial_cpu = ac * n_runs + bc * grid_steps + N_SEEDS * t_prof.cpu_median
    kern_step = sum(r["kernel"] for r in runs) / steps.sum()
    target = 30.0
    # baseline vs engine over the same first steps
    bres = run_baseline(bridge, train, v / 3.6, p0, settings, n_steps=plan.c3_baseline_steps)
    k = kernel_median(bridge, train, v / 3.6, p0, settings, plan.c3_baseline_steps, 3)
    base_step = bres.cpu_per_step
    win_step = k.cpu / k.steps
    agree = agreement_window(k.out, bres, bridge)
    res.agreement.update({f"case 3 {key} (300 km/h, seed {plan.c3_seeds[0]}, first "
                          f"{plan.c3_baseline_steps} steps; informative)": d
                          for key, d in agree.items()})
    res.rows.append(Row("3", f"570 runs serial, EXTRAPOLATED from {len(runs)}",
                        fmt_s(serial), kern_step * 1e6, kern_cpu_step * 1e6, base_step * 1e6,
                        "(30 s on 2 cores)", "info", load, cpu / wall))
    res.rows.append(Row("3", "570 runs, ideal 2 cores (serial / 2), EXTRAPOLATED",
                        fmt_s(serial / 2), kern_step * 1e6, kern_cpu_step * 1e6,
                        base_step * 1e6, "<= 30 s", _status(serial / 2, target), load))
    par = None
    if plan.c3_full_parallel:
        load_p = load1()
        par = _case3_parallel(2)
        res.rows.append(Row("3", "570 runs, 2 spawned processes, MEASURED", fmt_s(par[0]),
                            target="<= 30 s", status=_status(par[0], target),
                            load=max(load_p, load1())))
    res.data.update(serial=serial, serial_cpu=serial_cpu, a=a, b=b, ac=ac, bc=bc,
                    grid_steps=grid_steps, kernel_step=kern_step,
                    kernel_cpu_step=kern_cpu_step, window_engine_step=win_step,
                    baseline_step=base_step, misfit=misfit, runs=runs,
                    parallel=par[0] if par else None)
    tab = md_table(["speed km/h", "seed", "steps", "wall", "cpu", "time loop (wall)",
                    "us/step (wall)", "max iters", "contact loss s", "status"],
                   [[f"{r['speed']:g}", r["seed"], r["n_steps"], fmt_s(r["wall"]),
                     fmt_s(r["cpu"]), fmt_s(r["kernel"]),
                     f"{r['kernel'] / r['n_steps'] * 1e6:.1f}", r["iters"],
                     f"{r['loss']:.3g}", r["status"]] for r in runs])
    res.details.append(
        f"Model: {bridge.description}, 20 modes, zeta = 1 %; `get_train('ICE3')` "
        f"({len(train.vehicles)} cars, {train.n_wheels} wheels, "
        f"{sum(x.n_dof for x in train.vehicles)} DOFs); German low, 3-80 m, one profile per "
        f"seed over the whole run; dt = 1 ms, approach 5 m, 0.5 s free vibration; "
        f"`simulate(..., save_histories=False)`.\n\n"
        f"Measured {len(runs)} runs in {wall:.3g} s wall / {cpu:.3g} s CPU (load "
        f"{load:.2f}):\n\n" + tab + "\n\n"
        f"Cost model per run: wall = {a * 1e3:.1f} ms + {b * 1e6:.2f} us x steps "
        f"(CPU: {ac * 1e3:.1f} ms + {bc * 1e6:.2f} us x steps; overhead = median of run "
        f"minus time loop, per step = time loop).  The grid has {n_runs} runs and "
        f"{grid_steps:,} steps; one profile per seed costs {fmt_s(t_prof.wall_median)}.  "
        f"**EXTRAPOLATED serial: {serial:.3g} s wall ({serial_cpu:.3g} s CPU); ideal 2 cores: "
        f"{serial / 2:.3g} s wall ({serial_cpu / 2:.3g} s on CPU time).**  "
        + (f"Measured with 2 spawned processes: **{par[0]:.3g} s**.  " if par else
           "(`python -m benchmarks --full` runs the whole grid on 2 processes.)  ")
        + f"Time loop alone on a whole run at 300 km/h: {kern_cpu_step * 1e6:.1f} us/step CPU."
        f"\n\nStatic start: max |u_wheel - r| = {misfit:.2e} m.  Baseline over the first "
        f"{plan.c3_baseline_steps} steps at 300 km/h (CPU): {base_step * 1e6:.0f} us/step vs "
        f"engine time loop {win_step * 1e6:.1f} us/step (x{base_step / win_step:.0f}).")
    if plan.name in ("normal", "full"):
        be = blas_threads_effect()
        res.data["blas"] = be
        res.details.append(
            "**BLAS threads and the wrapper**: the static start (`initial_state`, dense KKT "
            f"solves of {train.n_wheels + sum(x.n_dof for x in train.vehicles)} unknowns with "
            "`np.linalg`) in a fresh process, median of 5, ICE3 at 300 km/h:\n\n"
            + md_table(["OPENBLAS_NUM_THREADS", "initial_state", "whole simulate()", "load"],
                       [[k, fmt_s(v[0]), fmt_s(v[1]), f"{v[2]:.2f}"] for k, v in be.items()])
            + "\n\nWith the OpenBLAS default (one thread per core) on a shared machine its "
            "threads can wait for each other while other jobs hold the cores; the runner "
            "itself uses 1 BLAS thread (`--blas-threads`).")
    cmp_wall = par[0] if par else serial / 2
    if cmp_wall > target:
        res.details.append(
            f"**Target missed** on wall time by x{cmp_wall / target:.1f} "
            + ("(measured on 2 processes)" if par else "(extrapolated, ideal 2 cores)")
            + "; on CPU time (what an idle 2-core machine would give) the ideal 2-core "
            f"estimate is {serial_cpu / 2:.3g} s, "
            + ("within the target" if serial_cpu / 2 <= target else
               f"x{serial_cpu / 2 / target:.1f} over it")
            + f".  {kern_cpu_step * 1e6:.1f} us/step x {grid_steps:,} steps is "
            f"{kern_cpu_step * grid_steps:.3g} s of time loop alone; 30 s on 2 cores needs "
            f"<= {60 / grid_steps * 1e6:.1f} us/step overall.")
    return res


# ------------------------------------------------------------------------------ case 4


def _scaling_point(bridge, train, settings, repeat, base_steps):
    v = 300.0 / 3.6
    full = kernel_median(bridge, train, v, None, settings, None, repeat)
    win = kernel_median(bridge, train, v, None, settings, base_steps, repeat)
    bres = run_baseline(bridge, train, v, None, settings, n_steps=base_steps)
    return {"engine": full.cpu / full.steps, "engine_wall": full.wall / full.steps,
            "window": win.cpu / win.steps, "baseline": bres.cpu_per_step,
            "steps": full.steps}


def case4(plan: Plan) -> CaseResult:
    from vsi_numba.model.library import get_train
    from vsi_numba.solver.settings import SolverSettings

    res = CaseResult("4", "Scaling: time per step vs modes and vs train length")
    settings = SolverSettings(dt=1e-3, hht_alpha=-0.1, approach=5.0, free_vibration=0.0)
    ice3 = get_train("ICE3")
    curves = {}
    load0 = load1()
    for axis, values in (("modes", plan.c4_modes), ("cars", plan.c4_cars)):
        pts = []
        for n in values:
            if axis == "modes":
                bridge, train = hsr_deck(n), ice3
            else:
                bridge, train = hsr_deck(20), repeated_car_train(n)
            pt = _scaling_point(bridge, train, settings, plan.c4_repeat,
                                plan.c4_baseline_steps)
            pt.update(n=n, wheels=train.n_wheels,
                      dofs=bridge.n_modes + sum(x.n_dof for x in train.vehicles))
            pts.append(pt)
        curves[axis] = pts
    res.data["curves"] = curves
    load = max(load0, load1())
    for axis, pts in curves.items():
        ns = [q["n"] for q in pts]
        c, p = fit_power(ns, [q["engine"] for q in pts])
        a, b = fit_linear(ns, [q["engine"] for q in pts])
        cb, pb = fit_power(ns, [q["baseline"] for q in pts])
        res.data[f"fit_{axis}"] = {"power": p, "a": a, "b": b, "baseline_power": pb}
        what = "modes (ICE3, 8 cars)" if axis == "modes" else "cars (20 modes)"
        res.rows.append(Row(
            "4", f"per step vs {what}: {ns[0]}..{ns[-1]}",
            f"{pts[0]['engine'] * 1e6:.1f}..{pts[-1]['engine'] * 1e6:.1f} us CPU",
            pts[-1]["engine_wall"] * 1e6, pts[-1]["engine"] * 1e6, pts[-1]["baseline"] * 1e6,
            "report", f"~ n^{p:.2f}", load))
        tab = md_table(
            [axis, "wheels", "DOFs", "steps", "engine us/step CPU (wall)",
             f"engine us/step, first {plan.c4_baseline_steps}",
             f"baseline us/step, first {plan.c4_baseline_steps}", "speed-up"],
            [[q["n"], q["wheels"], q["dofs"], q["steps"],
              f"{q['engine'] * 1e6:.2f} ({q['engine_wall'] * 1e6:.2f})",
              f"{q['window'] * 1e6:.2f}", f"{q['baseline'] * 1e6:.0f}",
              f"x{q['baseline'] / q['window']:.0f}"] for q in pts])
        res.details.append(
            f"**Per step vs {what}** (300 km/h, smooth track, no free vibration; time loop "
            f"alone, CPU time, median of {plan.c4_repeat}; load {load:.2f}):\n\n{tab}\n\n"
            f"Fitted growth (whole runs), engine: t ~ n^{p:.2f} (linear fit "
            f"{a * 1e6:.2f} us + {b * 1e6:.3f} us x n); baseline: t ~ n^{pb:.2f}.")
    res.details.append(
        "The whole-run figure averages over the steps where part of the train is still on "
        "the approach or exit track; the first-steps window (train entering) is what the "
        "baseline was run on, so the speed-up compares like with like.")
    return res


def plot_scaling(res: CaseResult, path: Path) -> bool:
    """Log-log plot of the scaling curves (matplotlib, Agg); False if unavailable."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker
    except ImportError:
        return False
    curves = res.data.get("curves")
    if not curves:
        return False
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, (axis, pts) in zip(axes, curves.items(), strict=True):
        ns = [p["n"] for p in pts]
        ax.loglog(ns, [p["engine"] * 1e6 for p in pts], "o-", label="engine (whole run)")
        ax.loglog(ns, [p["window"] * 1e6 for p in pts], "s--", label="engine (first steps)")
        ax.loglog(ns, [p["baseline"] * 1e6 for p in pts], "^-", label="dense baseline")
        ax.set_xticks(ns)
        ax.set_xticklabels([str(n) for n in ns])
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_xlabel("number of modes" if axis == "modes" else "number of cars")
        ax.set_ylabel("CPU time per step (us)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    axes[0].set_title("ICE3 (8 cars), 25 m span")
    axes[1].set_title("ICE3 cars, 25 m span, 20 modes")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


# ------------------------------------------------------------------------------ case 5


def _vsi_command():
    exe = Path(sys.executable).parent / "vsi"
    if exe.exists():
        return [str(exe)]
    return [sys.executable, "-c", "from vsi_numba.cli import app; app()"]


def _timed_subprocess(cmd, env, cwd) -> tuple[float, subprocess.CompletedProcess]:
    w0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True, timeout=1800)
    return time.perf_counter() - w0, p


def case5(plan: Plan) -> CaseResult:
    res = CaseResult("5", "Cold start: first `vsi run configs/quickstart.toml` "
                          "(subprocess)")
    if not plan.c5_run:
        res.details.append("Skipped in this mode.")
        return res
    config = REPO / "configs" / "quickstart.toml"
    cmd = _vsi_command()
    with tempfile.TemporaryDirectory(prefix="vsi_bench_") as tmp:
        tmp = Path(tmp)
        out = tmp / "quickstart.nc"
        env = user_env()  # the user's BLAS settings: this is the user's command
        if plan.c5_cold:
            env["NUMBA_CACHE_DIR"] = str(tmp / "numba_cache")  # empty: JIT compile
        run = [*cmd, "run", str(config), "-o", str(out), "-q"]
        cold = float("nan")
        load_c = float("nan")
        if plan.c5_cold:
            load_c = load1()
            cold, p = _timed_subprocess(run, env, tmp)
            if p.returncode != 0:
                res.error = f"cold run failed ({p.returncode}): {p.stderr[-2000:]}"
                return res
            load_c = max(load_c, load1())
        t = Timing(load_before=load1())
        for _ in range(plan.c5_repeat):
            w, p = _timed_subprocess(run, env, tmp)
            if p.returncode != 0:
                res.error = f"warm run failed ({p.returncode}): {p.stderr[-2000:]}"
                return res
            t.wall.append(w)
        t.load_after = load1()
        # where the warm time goes: interpreter + imports, kernel load from cache
        imp, _ = _timed_subprocess([sys.executable, "-c",
                                    "import vsi_numba.solver.simulate, vsi_numba.config"],
                                   env, tmp)
        cli, _ = _timed_subprocess([*cmd, "--help"], env, tmp)
        _, pw = _timed_subprocess([sys.executable, "-c",
                                   "from vsi_numba.solver.simulate import warm_up;"
                                   "print(warm_up())"], env, tmp)
        try:
            warm_up_s = float(pw.stdout.strip().splitlines()[-1])
        except (ValueError, IndexError):
            warm_up_s = float("nan")
    target = 5.0
    if plan.c5_cold:
        res.rows.append(Row("5", "first run, EMPTY NUMBA_CACHE_DIR (JIT)", fmt_s(cold),
                            target="(report)", status="info", load=load_c))
    res.rows.append(Row("5", f"run with a warm cache (median of {t.n})",
                        fmt_s(t.wall_median), target="<= 5 s",
                        status=_status(t.wall_median, target), load=t.load))
    res.data.update(cold=cold, warm=t.wall_median, imports=imp, cli_help=cli,
                    warm_up=warm_up_s)
    res.details.append(
        f"`{' '.join(Path(c).name if i == 0 else c for i, c in enumerate(run))}` "
        f"(2 speeds, 3 modes, sprung mass) as a subprocess"
        + (" with `NUMBA_CACHE_DIR` set to an empty directory (every kernel JIT-compiled), "
           "then again with that directory warm" if plan.c5_cold else
           " with the runner's (warm) numba cache; the cold run is skipped in this mode "
           "(`--cold` adds it)") + ".\n\n"
        + md_table(["measurement", "wall"],
                   ([["cold (JIT compile + run)", fmt_s(cold)]] if plan.c5_cold else [])
                   + [["warm cache, median", fmt_s(t.wall_median)],
                      ["  of which: `python -c 'import vsi_numba.solver.simulate, "
                       "vsi_numba.config'`", fmt_s(imp)],
                      ["  `vsi --help` (interpreter + CLI import)", fmt_s(cli)],
                      ["  `warm_up()` in a fresh process (kernels loaded from the cache "
                       "+ one tiny run)", fmt_s(warm_up_s)]]))
    return res


def run_case(fn, plan) -> CaseResult:
    """Run one case; an exception becomes an error entry instead of killing the suite."""
    try:
        return fn(plan)
    except Exception as exc:  # noqa: BLE001 - the report must still be written
        import traceback

        key = fn.__name__.replace("case", "")
        r = CaseResult(key, fn.__name__)
        r.error = "".join(traceback.format_exception(exc))[-3000:]
        return r


ALL_CASES = (case1, case2, case3, case4, case5)

__all__ = ["ALL_CASES", "CaseResult", "Plan", "Row", "make_plan", "run_case"]
