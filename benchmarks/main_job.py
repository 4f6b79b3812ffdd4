"""The README's main job, whole commands, against a baseline checkout in the same run.

``python -m benchmarks.main_job [--baseline DIR] [--rounds N] [--cold] [--no-write]
[--fresh-runs N]``

Each round runs, for this checkout and (with ``--baseline``) for another checkout of the
package (e.g. ``git archive COMMIT | tar -x -C DIR``), interleaved so that both see the
same load:

* **sweep** ``vsi sweep study.toml --fresh -q``: the 627 runs computed and written, the
  governing results printed;
* **report** ``vsi report results.nc -o DIR``: the report of that file;
* **main job, re-run** ``vsi sweep study.toml --report DIR`` on the written study: the
  README's first command a second time (a checkout that leaves a written study as it is
  computes nothing; one that does not runs the 627 runs again), its report new;
* **main job, warm** the same command once more: the study and its report written (a
  checkout that keeps a report of unchanged inputs, :mod:`vsi_numba.io.kept`, writes
  nothing);
* with ``--cold``: **main job, empty cache** ``vsi sweep study.toml --report DIR -q`` on an
  empty ``NUMBA_CACHE_DIR`` (the kernels compiled in the command), once per checkout.

The commands run as subprocesses (``python -m vsi_numba.cli``, the checkout on
``PYTHONPATH``) on a copy of ``studies/hslm_psc_25m/study.toml`` in a temporary
directory, warm numba cache (``NUMBA_CACHE_DIR`` as set, else a temporary one filled by a
first untimed run).  *CPU* is user + system time of the command and its children.
Medians over the rounds; ratios are this checkout's median over the baseline's.  The
records of kept outputs go to a temporary directory (``VSI_OUTPUT_CACHE``).  After the
rounds, each checkout's fresh sweep and its README command on the written study are
profiled once each in one process (:data:`STAGES`: CPU seconds of the imports, the
sweep's parts or its decision, the governing lines and the parts of the report; the
sweep computed, the report made whole, then warm; the fresh sweep ``--fresh-runs`` times,
interleaved, medians, with the CPU of its batch threads and of its main thread, each on
its own clock, and from them the wall on 2 idle cores, a machine shared with other work
not having them; the CPU of child processes, e.g. the report's second process of
re-runs, :mod:`vsi_numba.analysis.report.background`, on a line of its own: a stage run
there counts in no row of the parent).  The section ``Main job`` of
``reports/benchmarks.md`` is replaced (``--no-write``: printed only).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.study import run_command
from benchmarks.timing import REPO, load1, user_env

STUDY = REPO / "studies" / "hslm_psc_25m" / "study.toml"
REPORT = REPO / "reports" / "benchmarks.md"
BEGIN, END = "<!-- main-job-benchmark:begin -->", "<!-- main-job-benchmark:end -->"

#: (key, label) of the warm commands, in the order of a round.
COMMANDS = (("sweep", "sweep (627 runs computed, `--fresh`)"),
            ("report", "report of the written file"),
            ("rerun", "main job re-run (`sweep --report` on the written study, report new)"),
            ("warm", "main job warm (`sweep --report`, study and report written)"))

#: In-process CPU profile of ``vsi sweep study.toml --report DIR -q`` on a written study
#: (``argv``: DIR, then ``whole``: the report made whole, records off; ``warm``: as the
#: records are), or of ``vsi sweep study.toml --fresh -q`` (``fresh``: the 627 runs
#: computed and written, the governing lines; no report): seconds per stage as JSON on
#: stdout.  Stages are
#: functions of both checkouts, wrapped where they exist; nested ones count inside their
#: parents (``report`` holds the rest).
STAGES = r"""
import importlib, importlib.util, json, os, sys, time
from pathlib import Path
T = time.process_time
acc = {}
def wrap(mod, name, label, clock=None, cls=None):
    try:
        m = importlib.import_module(mod)
        if cls is not None:
            m = getattr(m, cls)
        f = getattr(m, name)
    except (ImportError, AttributeError):
        return
    tick = clock or T
    def g(*a, **k):
        s = tick()
        key = label if label not in acc or not label.startswith("sweep") or cls else (
            "report: its re-runs through the study engine")
        try:
            return f(*a, **k)
        finally:
            acc[key] = acc.get(key, 0.0) + tick() - s
    setattr(m, name, g)
whole = sys.argv[2] in ("whole", "fresh")
fresh = sys.argv[2] == "fresh"
t0, m0 = T(), time.thread_time()
from vsi_numba.cli import sweep as sw
# the study runner (the engine) where the command imports it: a warm command of a
# checkout that finds its study by its record does not
kept = not whole and importlib.util.find_spec("vsi_numba.study.unchanged") is not None
if not kept:
    from vsi_numba.study import runner
acc["imports: the CLI (and the study runner where used)"] = T() - t0
if "vsi_numba.study.runner" in sys.modules:
    wrap("vsi_numba.study.runner", "execute_study", "sweep: the study found written (or run)")
if fresh:  # the study computed again: its parts
    wrap("vsi_numba.cli.sweep", "load_config_and_output", "sweep: configuration read")
    for name, label in [("_build_model", "sweep: model built"),
                        ("study_plan", "sweep: batches planned"),
                        ("_run_pending", "sweep: batches run (kernels loaded, runs)"),
                        ("write_results", "sweep: results file written")]:
        wrap("vsi_numba.study.runner", name, label)
    # the results file written while the batches run: the main thread's share (its own
    # CPU clock: the batch threads run beside it), then the rest after the last batch
    rf = "vsi_numba.study.results_file"
    wrap(rf, "__init__", "sweep: results file created (main thread, during the batches)",
         time.thread_time, cls="ResultsWriter")
    wrap(rf, "add", "sweep: batches written into it as they finish (main thread, during "
         "the batches)", time.thread_time, cls="ResultsWriter")
    wrap(rf, "finish", "sweep: results file written", cls="ResultsWriter")
    wrap("vsi_numba.study.runner", "_import_results_readers", "sweep: results readers "
         "imported (main thread, during the batches)", time.thread_time)
    wrap("xarray", "open_dataset", "governing: the results file opened (xarray)")
    # the critical path: the CPU of each batch thread and of the main thread (its share
    # during the batches), each on its own clock
    import threading
    per_thread = {}
    rn = importlib.import_module("vsi_numba.study.runner")
    task0 = rn.run_batch_task
    def task(*a, **k):
        s = time.thread_time()
        try:
            return task0(*a, **k)
        finally:
            name = threading.current_thread().name
            per_thread[name] = per_thread.get(name, 0.0) + time.thread_time() - s
    rn.run_batch_task = task
    wrap("vsi_numba.study.runner", "_run_pending", "main thread: CPU during the batches",
         time.thread_time)
wrap("vsi_numba.cli.sweep", "_written", "sweep: the study found by its record (or not)")
wrap("vsi_numba.cli.sweep", "_print_governing", "governing lines")
wrap("vsi_numba.cli.sweep", "_report", "report, whole")
if not kept and not fresh:  # (the warm command with records imports none of the report)
    s = T()
    import vsi_numba.analysis.report as R
    acc["report: imports (matplotlib, openpyxl, ...)"] = T() - s
    for name, label in [("denoised", "report: results to 12 digits"),
                        ("write_tables", "report: CSV and XLSX tables")]:
        wrap("vsi_numba.analysis.report.tables", name, label)
    for name, label in [("_figures", "report: figures, governing cases re-run"),
                        ("convergence_section", "report: convergence re-runs"),
                        ("load_effect_checks", "report: load-effect checks"),
                        ("write_markdown", "report: Markdown + PNG rendering")]:
        wrap("vsi_numba.analysis.report", name, label)
    for name, label in [("envelope_figures", "report: figures of the envelopes"),
                        ("history_figures", "report: time-history figures (re-runs made)")]:
        wrap("vsi_numba.analysis.report", name, label)
    wrap("vsi_numba.analysis.report.document", "savefig",
         "report: the PNGs rendered (savefig, in the rows above or not)")
    wrap("vsi_numba.analysis.checks", "run_checks", "report: checks")
code = sw.sweep_command(Path("study.toml"), None, None, None, True, fresh,
                        None if fresh else Path(sys.argv[1]))
acc["total (in process)"] = T() - t0
if fresh and per_thread:
    main = time.thread_time() - m0
    during = acc.get("main thread: CPU during the batches", 0.0)
    acc["main thread: CPU outside the batches"] = main - during
    acc["batch threads: CPU, all"] = sum(per_thread.values())
    acc["batch threads: CPU, the busiest"] = max(per_thread.values())
    # on 2 idle cores: the main thread alone before and after the batches; during them
    # the busiest batch thread, or the batch threads and the main thread on 2 cores
    acc["estimate: wall on 2 idle cores (critical path, without the interpreter's "
        "start)"] = (main - during) + max(max(per_thread.values()),
                                          (sum(per_thread.values()) + during) / 2)
import resource
ch = resource.getrusage(resource.RUSAGE_CHILDREN)
if ch.ru_utime + ch.ru_stime > 0:
    acc["child processes (the report's second process: load-effect and deflection "
        "checks, re-runs)"] = ch.ru_utime + ch.ru_stime
    acc["total, with the child processes"] = acc["total (in process)"] + (
        ch.ru_utime + ch.ru_stime)
print(json.dumps(acc))
"""


@dataclass
class Result:
    """Walls and CPU times (s) per (checkout label, command key)."""

    trees: dict  # label -> package root
    walls: dict = field(default_factory=dict)
    cpus: dict = field(default_factory=dict)
    cold: dict = field(default_factory=dict)  # label -> (wall, cpu)
    stages: dict = field(default_factory=dict)  # "label, mode" -> {stage: CPU s}
    notes: dict = field(default_factory=dict)  # label -> first stderr line of the re-run
    load: tuple = (float("nan"), float("nan"))
    date: str = ""
    rounds: int = 0
    errors: list = field(default_factory=list)
    fresh_runs: int = 1  # profiles of the fresh sweep per checkout (medians)

    def add(self, label: str, key: str, wall: float, cpu: float) -> None:
        self.walls.setdefault((label, key), []).append(wall)
        self.cpus.setdefault((label, key), []).append(cpu)

    def median(self, label: str, key: str, cpu: bool = False) -> float:
        values = (self.cpus if cpu else self.walls).get((label, key), [])
        return statistics.median(values) if values else float("nan")


def _env(root: Path, cache: Path | None, outputs: Path | None = None) -> dict:
    env = user_env()
    if outputs is not None:
        env["VSI_OUTPUT_CACHE"] = str(outputs)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(root)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    return env


def _vsi(res: Result, label: str, key: str | None, args: list, cwd: Path, env: dict):
    """Run ``vsi ARGS`` with the checkout ``label``; record it under ``key``."""
    run = run_command([sys.executable, "-m", "vsi_numba.cli", *map(str, args)], cwd, env)
    if run.returncode not in (0, 1):
        res.errors.append(f"{label} {' '.join(map(str, args))}: exit {run.returncode}\n"
                          f"{run.stderr}")
    elif key is not None:
        res.add(label, key, run.wall, run.cpu)
    return run


def run_main_job_bench(baseline: Path | None = None, rounds: int = 3, cold: bool = False,
                       study: Path = STUDY, echo=print, fresh_runs: int = 1) -> Result:
    """Measure the commands of the module docstring; returns the :class:`Result`."""
    trees = {"this checkout": REPO}
    if baseline is not None:
        trees["baseline"] = Path(baseline).resolve()
    res = Result(trees, rounds=rounds,
                 date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"))
    load0 = load1()
    with tempfile.TemporaryDirectory(prefix="vsi_main_job_") as tmp:
        tmp = Path(tmp)
        cache = None if os.environ.get("NUMBA_CACHE_DIR") else tmp / "numba_cache"
        dirs = {}
        for k, label in enumerate(trees):
            d = tmp / f"tree{k}"
            d.mkdir()
            shutil.copy(study, d / "study.toml")
            dirs[label] = d
            # untimed: the kernels into the cache, the results file written
            _vsi(res, label, None, ["sweep", "study.toml", "--fresh", "-q"], d,
                 _env(trees[label], cache, tmp / "outputs"))
        for r in range(rounds):
            for label, root in trees.items():
                d, env = dirs[label], _env(root, cache, tmp / "outputs")
                _vsi(res, label, "sweep", ["sweep", "study.toml", "--fresh", "-q"], d, env)
                shutil.rmtree(d / "rep", ignore_errors=True)
                _vsi(res, label, "report", ["report", "results.nc", "-o", "rep"], d, env)
                run = _vsi(res, label, "rerun", ["sweep", "study.toml", "--report", "rep2"],
                           d, env)
                res.notes[label] = next((ln.replace(f"{d}{os.sep}", "")
                                         for ln in run.stderr.splitlines()
                                         if ln.startswith("627 runs")), "")
                _vsi(res, label, "warm", ["sweep", "study.toml", "--report", "rep2"], d, env)
            echo(f"round {r + 1} of {rounds} done")
        # whole: records off, a new report directory; warm: the rounds' records and
        # report directory (rep2), as the README command finds them the next time
        # (fresh last: it writes the results file again, a new file for the records)
        # (the fresh profile ``fresh_runs`` times, the checkouts interleaved: medians)
        runs: dict = {}
        for mode, outputs, rep in (("whole", "off", "rep4"), ("warm", None, "rep2"),
                                   *[("fresh", "off", "-")] * max(fresh_runs, 1)):
            for label, root in trees.items():
                d = dirs[label]
                env = _env(root, cache, tmp / "outputs")
                if outputs is not None:
                    env["VSI_OUTPUT_CACHE"] = outputs
                    if rep != "-":
                        shutil.rmtree(d / rep, ignore_errors=True)
                done = subprocess.run([sys.executable, "-c", STAGES, rep, mode], cwd=d, env=env,
                                      capture_output=True, text=True, timeout=3600)
                try:
                    runs.setdefault(f"{label}, {mode}", []).append(json.loads(
                        done.stdout.strip().splitlines()[-1]))
                except (ValueError, IndexError):
                    res.errors.append(f"{label} stages ({mode}): exit {done.returncode}\n"
                                      f"{done.stderr[-2000:]}")
        for col, found in runs.items():
            keys = dict.fromkeys(k for f in found for k in f)
            res.stages[col] = {k: statistics.median(f[k] for f in found if k in f)
                               for k in keys}
        res.fresh_runs = max(fresh_runs, 1)
        if cold:
            for label, root in trees.items():
                d = dirs[label]
                empty = tmp / f"cold_{label.replace(' ', '_')}"
                run = _vsi(res, label, None,
                           ["sweep", "study.toml", "--fresh", "--report", "rep3", "-q"], d,
                           _env(root, empty))
                res.cold[label] = (run.wall, run.cpu)
    res.load = (load0, load1())
    return res


def _s(x: float) -> str:
    return "-" if x != x else f"{x:.2f} s"


def markdown(res: Result) -> str:
    """The report section."""
    labels = list(res.trees)
    base = "baseline" in res.trees
    lines = [BEGIN, "## Main job: whole commands", "",
             f"Written by `python -m benchmarks.main_job` on {res.date} ({res.rounds} "
             f"rounds; load {res.load[0]:.2f} at start, {res.load[1]:.2f} at end; "
             f"{os.cpu_count()} cores).  Each command is `python -m vsi_numba.cli ...` "
             "as a subprocess on a copy of `studies/hslm_psc_25m/study.toml` (627 runs), "
             "warm numba cache, the checkouts interleaved in every round; medians of the "
             "rounds; CPU is user + system time of the command and its children"
             + (f"; the baseline is the package at `{res.trees['baseline']}`" if base else "")
             + ".", ""]
    head = "| command | " + " | ".join(f"{lab}: wall | {lab}: CPU" for lab in labels)
    if base:
        head += " | wall ratio | CPU ratio"
    lines += [head + " |", "|---" * (1 + 2 * len(labels) + 2 * base) + "|"]
    for key, label in COMMANDS:
        row = f"| {label} | " + " | ".join(
            f"{_s(res.median(lab, key))} | {_s(res.median(lab, key, True))}" for lab in labels)
        if base:
            w = res.median(labels[0], key) / res.median("baseline", key)
            c = res.median(labels[0], key, True) / res.median("baseline", key, True)
            row += f" | {w:.2f} | {c:.2f}"
        lines.append(row + " |")
    if res.cold:
        row = "| main job, empty numba cache (once) | " + " | ".join(
            f"{_s(res.cold[lab][0])} | {_s(res.cold[lab][1])}" if lab in res.cold else "- | -"
            for lab in labels)
        if base and all(lab in res.cold for lab in labels):
            w = res.cold[labels[0]][0] / res.cold["baseline"][0]
            c = res.cold[labels[0]][1] / res.cold["baseline"][1]
            row += f" | {w:.2f} | {c:.2f}"
        elif base:
            row += " | - | -"
        lines.append(row + " |")
    lines.append("")
    if res.stages:
        cols = list(res.stages)
        names = list(dict.fromkeys(k for c in cols for k in res.stages[c]))
        lines += ["CPU seconds by stage, one run per checkout in one process (`STAGES` "
                  "of `benchmarks/main_job.py`; a stage nested in another counts in both; "
                  "'-': not reached): *fresh*, `vsi sweep study.toml --fresh -q` (the 627 "
                  "runs computed and written, the governing lines, no report"
                  + (f"; medians of {res.fresh_runs} runs per checkout, interleaved"
                     if res.fresh_runs > 1 else "") + "); and the "
                  "README command on the written study: *whole*, "
                  "the report made whole (records of kept outputs off, a new directory); "
                  "*warm*, the study and its report as the rounds left them (a checkout "
                  "without records makes the report again):", "",
                  "| stage | " + " | ".join(f"{c}: CPU" for c in cols) + " |",
                  "|---" * (1 + len(cols)) + "|"]
        for n in names:
            cells = [res.stages[c].get(n) for c in cols]
            lines.append(f"| {n} | " + " | ".join("-" if c is None else f"{c:.2f} s"
                                                  for c in cells) + " |")
        lines.append("")
    for lab in labels:
        if res.notes.get(lab):
            lines.append(f"The re-run of {lab} said: `{res.notes[lab]}`.  ")
    if res.errors:
        lines += ["", "**Failed:**", "", "```", *[e.strip() for e in res.errors], "```"]
    lines.append(END)
    return "\n".join(lines) + "\n"


def write_section(path: Path, section: str) -> None:
    """Replace the section of the report at ``path`` (or append it)."""
    text = path.read_text() if path.exists() else "# vsi_numba benchmarks\n"
    i, j = text.find(BEGIN), text.find(END)
    if 0 <= i < j:
        text = text[:i] + section.rstrip("\n") + text[j + len(END):]
    else:
        text = text.rstrip("\n") + "\n\n" + section
    path.write_text(text if text.endswith("\n") else text + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.main_job",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, help="another checkout of the package")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cold", action="store_true", help="also a run on an empty numba cache")
    ap.add_argument("--report", type=Path, default=REPORT)
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--fresh-runs", type=int, default=1,
                    help="profiles of the fresh sweep per checkout (medians)")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = run_main_job_bench(a.baseline, max(a.rounds, 1), a.cold,
                             fresh_runs=a.fresh_runs)
    section = markdown(res)
    print(section)
    print(f"({time.perf_counter() - t0:.0f} s)")
    if not a.no_write:
        write_section(a.report, section)
    return 1 if res.errors else 0


if __name__ == "__main__":
    sys.exit(main())
