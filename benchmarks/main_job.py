"""The README's main job, whole commands, against a baseline checkout in the same run.

``python -m benchmarks.main_job [--baseline DIR] [--rounds N] [--cold] [--no-write]``

Each round runs, for this checkout and (with ``--baseline``) for another checkout of the
package (e.g. ``git archive COMMIT | tar -x -C DIR``), interleaved so that both see the
same load:

* **sweep** ``vsi sweep study.toml --fresh -q``: the 627 runs computed and written, the
  governing results printed;
* **report** ``vsi report results.nc -o DIR``: the report of that file;
* **main job, re-run** ``vsi sweep study.toml --report DIR -q`` on the written study: the
  README's first command a second time (a checkout that leaves a written study as it is
  computes nothing; one that does not runs the 627 runs again);
* with ``--cold``: **main job, empty cache** ``vsi sweep study.toml --report DIR -q`` on an
  empty ``NUMBA_CACHE_DIR`` (the kernels compiled in the command), once per checkout.

The commands run as subprocesses (``python -m vsi_numba.cli``, the checkout on
``PYTHONPATH``) on a copy of ``studies/hslm_psc_25m/study.toml`` in a temporary
directory, warm numba cache (``NUMBA_CACHE_DIR`` as set, else a temporary one filled by a
first untimed run).  *CPU* is user + system time of the command and its children.
Medians over the rounds; ratios are this checkout's median over the baseline's.  The
section ``Main job`` of ``reports/benchmarks.md`` is replaced (``--no-write``: printed
only).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import shutil
import statistics
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
            ("rerun", "main job re-run (`sweep --report` on the written study)"))


@dataclass
class Result:
    """Walls and CPU times (s) per (checkout label, command key)."""

    trees: dict  # label -> package root
    walls: dict = field(default_factory=dict)
    cpus: dict = field(default_factory=dict)
    cold: dict = field(default_factory=dict)  # label -> (wall, cpu)
    notes: dict = field(default_factory=dict)  # label -> first stderr line of the re-run
    load: tuple = (float("nan"), float("nan"))
    date: str = ""
    rounds: int = 0
    errors: list = field(default_factory=list)

    def add(self, label: str, key: str, wall: float, cpu: float) -> None:
        self.walls.setdefault((label, key), []).append(wall)
        self.cpus.setdefault((label, key), []).append(cpu)

    def median(self, label: str, key: str, cpu: bool = False) -> float:
        values = (self.cpus if cpu else self.walls).get((label, key), [])
        return statistics.median(values) if values else float("nan")


def _env(root: Path, cache: Path | None) -> dict:
    env = user_env()
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
                       study: Path = STUDY, echo=print) -> Result:
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
                 _env(trees[label], cache))
        for r in range(rounds):
            for label, root in trees.items():
                d, env = dirs[label], _env(root, cache)
                _vsi(res, label, "sweep", ["sweep", "study.toml", "--fresh", "-q"], d, env)
                shutil.rmtree(d / "rep", ignore_errors=True)
                _vsi(res, label, "report", ["report", "results.nc", "-o", "rep"], d, env)
                run = _vsi(res, label, "rerun", ["sweep", "study.toml", "--report", "rep2"],
                           d, env)
                res.notes[label] = next((ln.replace(f"{d}{os.sep}", "")
                                         for ln in run.stderr.splitlines()
                                         if ln.startswith("627 runs")), "")
            echo(f"round {r + 1} of {rounds} done")
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
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = run_main_job_bench(a.baseline, max(a.rounds, 1), a.cold)
    section = markdown(res)
    print(section)
    print(f"({time.perf_counter() - t0:.0f} s)")
    if not a.no_write:
        write_section(a.report, section)
    return 1 if res.errors else 0


if __name__ == "__main__":
    sys.exit(main())
