"""Run the benchmark cases, print the table, write ``reports/benchmarks.md``."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks import cases as C
from benchmarks.timing import REPO, load1, machine_info

REPORT = REPO / "reports" / "benchmarks.md"
PLOT = REPO / "reports" / "benchmarks_scaling.png"

HEADER = ["case", "measured", "engine (wall)", "loop us/step wall", "loop us/step CPU",
          "steps/s (CPU)", "baseline us/step CPU", "speed-up", "target", "status",
          "load(1m)", "cpu/wall"]


@dataclass
class SuiteResult:
    mode: str
    machine: dict
    results: list = field(default_factory=list)
    warm_up_s: float = float("nan")
    micro: tuple | None = None
    micro_error: str = ""
    seconds: float = 0.0
    load_end: float = float("nan")
    plot: Path | None = None

    @property
    def rows(self):
        return [r for res in self.results for r in res.rows]

    @property
    def agreement(self) -> dict:
        out = {}
        for res in self.results:
            out.update(res.agreement)
        return out

    def case(self, key):
        for r in self.results:
            if r.key == key:
                return r
        return None


def _cells(r: C.Row):
    def num(x, f):
        return "n/a" if not x == x else f.format(x)

    return [r.case, r.quantity, r.engine, num(r.kernel_us, "{:.2f}"),
            num(r.kernel_cpu_us, "{:.2f}"), num(r.steps_per_s, "{:,.0f}"),
            num(r.baseline_us, "{:.0f}"), num(r.speedup, "x{:.0f}"), r.target, r.status,
            num(r.load, "{:.2f}"), num(r.cpu_wall, "{:.2f}")]


def text_table(suite: SuiteResult) -> str:
    """The summary table as aligned plain text."""
    rows = [HEADER] + [_cells(r) for r in suite.rows]
    widths = [max(len(str(row[i])) for row in rows) for i in range(len(HEADER))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(row, widths, strict=True))
             for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    for res in suite.results:
        if res.error:
            lines.append(f"case {res.key}: ERROR {res.error.strip().splitlines()[-1]}")
    if suite.agreement:
        lines.append("")
        lines.append("baseline vs engine, max relative difference (max_t|a-b| / max_t|b|):")
        for k, v in suite.agreement.items():
            lines.append(f"  {k}: {v:.2e}")
    return "\n".join(lines)


def _micro_models():
    from vsi_numba.model.library import get_train
    from vsi_numba.solver.settings import SolverSettings

    b1, t1, v1, s1 = C.case1_model()
    b2, trains, s2 = C.case2_model()
    b3, t3, s3 = C.case3_model()
    s3 = SolverSettings(dt=s3.dt, hht_alpha=s3.hht_alpha, approach=s3.approach,
                        free_vibration=0.0)
    return [("case 1: sprung mass, 20 modes, 1 wheel", b1, t1, v1, s1),
            ("case 2: HSLM-A1, 10 modes, 50 loads", b2, trains["HSLM-A1"], 300 / 3.6, s2),
            ("case 3: ICE3, 20 modes, 32 wheels", b3, get_train("ICE3"), 300 / 3.6, s3)]


def run_suite(mode: str = "quick", write: bool = True, report: Path | None = None,
              cold: bool | None = None, micro: bool | None = None, only=None,
              echo=print) -> SuiteResult:
    """Run the cases of ``mode`` (``smoke``, ``quick``, ``normal``, ``full``).

    ``only``: iterable of case keys ("1".."5") to run; ``micro``: run the kernel
    micro-profile (default: in normal/full mode).
    """
    from vsi_numba.solver.simulate import warm_up

    plan = C.make_plan(mode, cold)
    suite = SuiteResult(mode, machine_info())
    t0 = time.perf_counter()
    echo(f"[benchmarks] mode={mode}, load {suite.machine['loadavg']}; warming up the kernels")
    suite.warm_up_s = warm_up()
    echo(f"[benchmarks] warm_up() {suite.warm_up_s:.1f} s")
    for fn in C.ALL_CASES:
        key = fn.__name__.replace("case", "")
        if only and key not in only:
            continue
        echo(f"[benchmarks] case {key} ... (load {load1():.2f})")
        c = time.perf_counter()
        res = C.run_case(fn, plan)
        echo(f"[benchmarks] case {key} done in {time.perf_counter() - c:.1f} s"
             + (" -- ERROR" if res.error else ""))
        suite.results.append(res)
    if micro is None:
        micro = mode in ("normal", "full")
    if micro:
        echo("[benchmarks] kernel micro-profile (compiles its drivers, no cache) ...")
        try:
            from benchmarks.microprofile import microprofile

            suite.micro = microprofile(_micro_models())
        except Exception as exc:  # noqa: BLE001 - engine internals may change
            suite.micro_error = f"{type(exc).__name__}: {exc}"
    suite.seconds = time.perf_counter() - t0
    suite.load_end = load1()
    if write:
        report = Path(report) if report else REPORT
        c4 = suite.case("4")
        if c4 is not None and c4.data.get("curves"):
            plot = report.parent / PLOT.name
            if C.plot_scaling(c4, plot):
                suite.plot = plot
        report.parent.mkdir(parents=True, exist_ok=True)
        from benchmarks import compile_table
        from benchmarks.study import extract_section

        old = report.read_text() if report.exists() else ""
        kept = extract_section(old) + compile_table.extract_section(old)
        report.write_text(markdown(suite) + ("\n" + kept if kept else ""))
        echo(f"[benchmarks] wrote {report}")
    return suite


# ---------------------------------------------------------------------------- report


#: The parts of ``hht_step`` in the micro-profile (``step``, ``hht_step``, ``record``,
#: ``load_effects``, ``copy_state`` and ``save_restore`` are reported on their own).
_HHT_PARTS = ("contact_search", "assemble_loads", "predictor", "track_predict",
              "build_schur", "compliance_add", "solve_active_set", "skyline_cholesky",
              "corrector", "gaps", "block_matvec", "contact_profile")


def _findings(suite: SuiteResult) -> list[str]:
    """Where the time goes and what would close each missed target (from the numbers)."""
    out = []
    c1, c2, c3 = suite.case("1"), suite.case("2"), suite.case("3")
    c4, c5 = suite.case("4"), suite.case("5")
    parts = {}
    if suite.micro:
        comp, parts = suite.micro
        names = sorted({k for row in parts.values() for k in row})
        tab = C.md_table(["model (mid-passage state)"] + [f"{n} (us/call)" for n in names],
                         [[label] + [f"{row[n]:.2f}" if n in row else "-" for n in names]
                          for label, row in parts.items()])
        out.append(
            "**Inside the kernel** (CPU time per call of each engine function, called "
            "20000 times in a jitted loop from the state in the middle of the passage; "
            "`hht_step` is one whole step; the moving-force model runs its own loop, "
            "`mf_time_loop`, so only the functions it shares are timed on it; "
            f"drivers compiled in {comp:.0f} s):\n\n" + tab)
        rows = list(parts.values())
        ice = rows[2] if len(rows) > 2 else {}
        if "hht_step" in ice and "step" in ice:
            inner = sorted(((k, v) for k, v in ice.items() if k in _HHT_PARTS),
                           key=lambda kv: -kv[1])
            out.append(
                f"Reading (ICE3, the model of c1): a whole step of the time loop (`step`: "
                f"copy_state + hht_step + finite check + record) costs {ice['step']:.2f} us, "
                f"`hht_step` {ice['hht_step']:.2f} us and `record` (the envelopes) "
                f"{ice.get('record', float('nan')):.2f} us, of which the load effects "
                f"(`load_effects`) {ice.get('load_effects', float('nan')):.2f} us.  Inside "
                "`hht_step`, timed alone (they overlap - the predictor and the corrector "
                "call `block_matvec`, the active-set solve the Cholesky - so they do not add "
                "up exactly): " + ", ".join(f"{k} {v:.2f} us" for k, v in inner) + ".  No "
                "part dominates: a step twice as fast needs the runs of a batch advanced in "
                "lockstep (the arithmetic vectorised across the speeds) or the Schur block "
                "updated instead of rebuilt while the active set is unchanged; neither is "
                "done.")
    elif suite.micro_error:
        out.append(f"Micro-profile failed: {suite.micro_error}")
    if c1 and c1.data:
        d = c1.data
        med = d["breakdown"]
        n = d["n_steps"]
        out.append(
            "**Case 1 (target 0.5 ms per crossing), "
            + (f"missed by x{d['simulate'] / 0.5e-3:.0f}" if d["simulate"] > 0.5e-3 else "met")
            + f"**: simulate() takes {C.fmt_s(d['simulate'])} "
            f"wall ({C.fmt_s(d['simulate_cpu'])} CPU); the time loop {C.fmt_s(d['kernel_cpu'])} "
            f"CPU for {n} steps ({d['kernel_cpu'] / n * 1e6:.2f} us/step) and the wrapper "
            f"(medians, wall): pack {C.fmt_s(med['pack'])}, initial_state "
            f"{C.fmt_s(med['initial_state'])}, output allocation "
            f"{C.fmt_s(med['run_kernel other'])}, to_dataset {C.fmt_s(med['to_dataset'])}."
            + "  A single short run is mostly the wrapper (the Python side of "
            "`simulate()`: pack, static start, output arrays, the xarray Dataset); a study "
            "runs its batches through `run_batch` without a Dataset per run.")
    if c2 and c2.data:
        d = c2.data
        out.append(
            "**Case 2 (target 1 s for 570 HSLM runs), "
            + (f"missed by x{d['total']:.0f} serial" if d["total"] > 1.0 else "met")
            + f"**: {d['total']:.3g} s wall, {d['total_cpu']:.3g} s CPU, of which "
            f"~{d['ac'] * 570:.3g} s CPU is the per-run wrapper ({d['ac'] * 1e3:.1f} ms x 570) "
            f"and ~{d['kernel_total']:.3g} s CPU the time loop ({d['total_steps']:,} steps at "
            f"{d['kernel_cpu_step'] * 1e6:.1f} us/step).  1 s for the grid means "
            f"{1e9 / d['total_steps']:.0f} ns per step with everything included.  The "
            "moving-force loop (`mf_time_loop`) already has no contact machinery, builds "
            "the modal loads from phasor sums (O(modes) per step, whatever the number of "
            "loads) and runs every speed of a batch in one kernel call; what is left per "
            "step is the HHT update of the modes, the envelopes at the output points and "
            "on the whole-deck grid, and the load effects (M and V on the grid, reactions "
            "and end rotations; measure a3 gives their cost on the whole command).")
    if c3 and c3.data:
        d = c3.data
        two = d["parallel"] if d.get("parallel") else d["serial"] / 2
        how = "measured on 2 processes" if d.get("parallel") else "extrapolated, ideal 2 cores"
        verdict = (f"met ({how}: {two:.3g} s, margin x{30 / two:.2f})" if two <= 30 else
                   f"missed by x{two / 30:.1f} ({how})")
        out.append(
            f"**Case 3 (target 30 s on 2 cores), {verdict}**: extrapolated "
            f"{d['serial'] / 2:.3g} s on 2 ideal cores ({d['serial']:.3g} s serial wall, "
            f"{d['serial_cpu']:.3g} s CPU); the time loop runs at "
            f"{d['kernel_cpu_step'] * 1e6:.1f} us/step CPU for 32 wheels and 20 modes and "
            f"the grid has {d['grid_steps']:,} steps, so the loop alone is "
            f"{d['kernel_cpu_step'] * d['grid_steps']:.0f} s CPU.  Where a step's time goes: "
            "the micro-profile above.  The study runner runs the cases on the 2 cores "
            "(measure c1 of the study level: the whole command).")
    if c3 and c3.data.get("blas"):
        be = c3.data["blas"]
        d0, d1 = be.get("default"), be.get("1")
        if d0 and d1 and d0[0] == d0[0] and d1[0] == d1[0]:
            ratio = d0[0] / max(d1[0], 1e-12)
            out.append(
                f"**BLAS threading (all cases that run `simulate`)**: in this run, in a fresh "
                f"process with the OpenBLAS default threads, `initial_state` of the ICE3 took "
                f"{C.fmt_s(d0[0])} and a whole simulate() {C.fmt_s(d0[1])}; with "
                f"OPENBLAS_NUM_THREADS=1 {C.fmt_s(d1[0])} and {C.fmt_s(d1[1])} "
                f"(x{ratio:.1f} on the static start, load {d0[2]:.1f}).  The effect depends "
                "on what else runs: while this suite was developed (2026-11-21, load 3-7 on "
                "the 2 cores) the same probe gave 500-550 ms against 0.9 ms (x540) and a "
                "whole ICE3 simulate() of 0.8-1.1 s against 0.08-0.16 s; the dense baseline "
                "went from ~1 ms to 55-77 ms per step at 40-80 modes.  The dense "
                "`np.linalg` solves of the wrapper (`initial_state`, `static_wheel_loads`: "
                "global KKT systems of ~110 unknowns) hit OpenBLAS's threading, whose "
                "threads spin and wait for each other when the cores are shared.  The "
                "study runner (`vsi sweep`) runs its batches with 1 BLAS thread (threadpoolctl "
                "in its own process, OPENBLAS_NUM_THREADS=1 in worker processes): on an idle "
                "2-core machine the busy-waiting OpenBLAS threads had taken the batch "
                "threads' cores (570 ICE3 runs: 14.6 s with the default, 11.1 s with 1 "
                "thread).  A single `simulate()` keeps the default.  The numbers above were "
                "taken with 1 BLAS thread.")
    if c4 and c4.data.get("fit_modes"):
        fm, fc = c4.data["fit_modes"], c4.data["fit_cars"]
        out.append(
            f"**Scaling (case 4)**: engine time per step grows like n_modes^{fm['power']:.2f} "
            f"and n_cars^{fc['power']:.2f} (dense baseline: ^{fm['baseline_power']:.2f} and "
            f"^{fc['baseline_power']:.2f}).  The small exponent in the modes says the step "
            "is dominated by per-wheel and per-call costs, not by modal arithmetic (each mode "
            "adds a few multiply-adds per wheel on the span); the growth with the cars is the "
            "per-wheel work (contact search of the wheels, the n_wheels^2 Schur matrix and "
            "its factorisation) - sub-linear over this range because most wheels are off the "
            "span, where the bridge terms are skipped.")
    if c5 and c5.data:
        d = c5.data
        out.append(
            "**Case 5 (target 5 s warm), "
            + (f"missed by x{d['warm'] / 5:.1f}" if d["warm"] > 5 else "met")
            + f"**: warm `vsi run` {C.fmt_s(d['warm'])} wall: the "
            f"imports alone (`import vsi_numba.solver.simulate, vsi_numba.config`) take "
            f"{C.fmt_s(d['imports'])}, `vsi --help` {C.fmt_s(d['cli_help'])}, loading the "
            f"kernels from the cache + a tiny run {C.fmt_s(d['warm_up'])}.  Cold (empty "
            f"cache): {C.fmt_s(d['cold'])}, nearly all JIT compilation.  `python -X "
            "importtime` shows xarray (+ pandas), scipy.interpolate (imported at module "
            "level by `model.irregularity`) and numba as the big imports; deferring "
            "scipy.interpolate/scipy.optimize and xarray to the functions that need them "
            "shortens the warm start; the cold "
            "time is governed by the size of the inlined `time_loop` - shipping a pre-warmed "
            "cache (or AOT compilation) removes it from the user's first run.  These runs "
            "use the user's BLAS settings (not the runner's single thread).")
    return out


def markdown(suite: SuiteResult) -> str:
    m = suite.machine
    la = m["loadavg"]
    lines = [
        "# vsi_numba benchmarks",
        "",
        f"Written by `python -m benchmarks{'' if suite.mode == 'normal' else ' --' + suite.mode}`"
        f" on {m['date']} (mode **{suite.mode}**, {suite.seconds:.0f} s in all).",
        "",
        "## Machine",
        "",
        C.md_table(["", ""], [
            ["CPU", m["host_cpu"]],
            ["cores (usable)", f"{m['cores']} ({m['cores_usable']})"],
            ["load average at start (1, 5, 15 min)", f"{la[0]:.2f}, {la[1]:.2f}, {la[2]:.2f}"],
            ["load average at end (1 min)", f"{suite.load_end:.2f}"],
            ["python / numpy / scipy / numba / xarray",
             f"{m['python']} / {m['numpy']} / {m['scipy']} / {m['numba']} / {m['xarray']}"],
            ["NUMBA_NUM_THREADS / NUMBA_CACHE_DIR",
             f"{m['numba_threads']} / `{m['numba_cache_dir']}`"],
            ["BLAS threads (OPENBLAS_NUM_THREADS)", m["blas_threads"]],
            ["git commit", m["git_commit"]],
            ["warm_up() in the runner (cache load or JIT)", f"{suite.warm_up_s:.1f} s"],
        ]),
        "",
        "The machine is shared with other jobs: a load above the core count means the wall "
        "times below are inflated.  Each timing is the median of several runs (counts in "
        "the details); CPU time of the process (`time.process_time`) is reported next to "
        "the wall time where it matters - cpu/wall well below 1 for a serial run means "
        "the run waited for a core.",
        "",
        "## Summary",
        "",
        C.md_table(HEADER, [_cells(r) for r in suite.rows]),
        "",
        "*loop us/step*: the numba time loop alone (`ek.time_loop`, as timed by "
        "`run_kernel`), wall and CPU time per step; *steps/s* from the CPU figure.  "
        "*baseline us/step*: CPU time per step of the dense numpy/scipy implementation "
        "(`benchmarks/baseline.py`) on the same model, over a window of the first steps "
        "or the whole run (see the details); *speed-up* = baseline / engine, CPU time per "
        "step.  *cpu/wall*: CPU time / wall time of the measurement (< 1: the process "
        "waited for a core).  EXTRAPOLATED rows are predictions "
        "from a subset (per-run cost = overhead + time loop per step x steps, the overhead "
        "being the median of (run - time loop) over the measured runs, applied to the "
        "step count of every run of the grid); '2 cores' rows are the "
        "serial figure divided by 2 (ideal) unless marked MEASURED.",
        "",
    ]
    errors = [r for r in suite.results if r.error]
    for r in errors:
        lines += [f"**Case {r.key} failed:**", "", "```", r.error.strip(), "```", ""]
    lines += [
        "## Baseline vs engine (correctness of the yardstick)",
        "",
        "The baseline is written independently (global dense matrices, K^ formed every step,"
        " the coupled system [K^, (1+a)B^T; B, 0] solved with `scipy.linalg.solve` per step "
        "and active-set iteration, its own static start by elimination of the wheel DOFs, "
        "plastic impacts by dense KKT solves).  Measure: for each channel (midspan "
        "deflection; contact force of each wheel) max over time of |engine - baseline| "
        "divided by max over time of |baseline|, then the maximum over channels.  "
        "Required: <= 1e-6 on cases 1 and 2.",
        "",
        C.md_table(["comparison", "max relative difference", "<= 1e-6"],
                   [[k, f"{v:.2e}", "yes" if v <= 1e-6 else "NO"]
                    for k, v in suite.agreement.items()]),
        "",
    ]
    for res in suite.results:
        lines += [f"## Case {res.key}: {res.title}", ""]
        for d in res.details:
            lines += [d, ""]
        if res.key == "4" and suite.plot is not None:
            lines += [f"![scaling]({suite.plot.name})", ""]
    lines += ["## Profile: where the time goes, and what would close the gaps", ""]
    for f in _findings(suite):
        lines += [f, ""]
    return "\n".join(lines).rstrip() + "\n"
