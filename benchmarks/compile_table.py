"""Compile time of every jitted function of the kernels, from an empty numba cache.

Each version of the code is measured in a fresh process with its own empty
``NUMBA_CACHE_DIR``: the process compiles both kernel families the way a study does
(``vsi_numba.solver.batch._tiny_batch``, one process) while a
``numba:compile`` listener (``numba.core.event``) records the process's CPU time when the
compilation of each function starts and ends (CPU, not wall: the machine is shared).
A callee compiles inside its caller's compilation, so each
function gets its inclusive time and its own ("self": inclusive minus its callees')
time; the self times add up to the total.  Functions that numba inlines
(``inline="always"``) compile inside their callers and have no row.

    python -m benchmarks.compile_table BEFORE_TREE AFTER_TREE   # a markdown table
    python -m benchmarks.compile_table --json BEFORE.json AFTER.json  # table of saved runs
    ... --write "TITLE"     # into reports/benchmarks.md, section "Compile time per function"
    python -m benchmarks.compile_table --measure > X.json       # the code on sys.path
    python -m benchmarks.compile_table --cold [TREE ...]   # ``vsi compile``, empty cache

``--cold`` runs the whole command a first run pays, ``vsi compile`` (both families, the
moving-force family in its second process on 2 cores), in a fresh process on an empty
``NUMBA_CACHE_DIR`` for each tree (default: this checkout), and prints its CPU seconds
(user + system of the command and its helper process), its wall seconds and the size of
the cache it wrote.

A tree is a checkout of the repository (its root goes first on ``PYTHONPATH``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FAMILIES = ("moving_force", "interaction")
BEGIN = "<!-- compile-table:begin -->"
END = "<!-- compile-table:end -->"
REPORT = Path(__file__).resolve().parents[1] / "reports" / "benchmarks.md"


def _recorder():
    from numba.core import event

    class CpuRecorder(event.Listener):
        """The ``numba:compile`` events with the CPU time of this process when each
        happened (the wall clock would count the other processes of a loaded machine)."""

        def __init__(self):
            self.buffer = []

        def on_start(self, ev):
            self.buffer.append((time.process_time(), ev))

        def on_end(self, ev):
            self.buffer.append((time.process_time(), ev))

    return CpuRecorder()


def measure() -> dict:
    """{family: {"wall": s, "cpu": s, "functions": {name: [calls, inclusive s, self s]}}}
    (CPU seconds of this process) for the code it imports (its numba cache must be
    empty)."""
    from numba.core import event

    from vsi_numba.solver.batch import _tiny_batch
    result = {}
    for family in FAMILIES:
        rec = _recorder()
        event.register("numba:compile", rec)
        try:
            t0 = time.perf_counter()
            c0 = time.process_time()
            _tiny_batch(family)
            wall = time.perf_counter() - t0
            cpu = time.process_time() - c0
        finally:
            event.unregister("numba:compile", rec)
        stack = []  # [name, start, children's inclusive time]
        funcs: dict[str, list] = {}
        for ts, ev in rec.buffer:
            disp = ev.data["dispatcher"]
            name = disp.py_func.__qualname__
            if ev.is_start:
                stack.append([name, ts, 0.0])
                continue
            top, start, inner = stack.pop()
            assert top == name, (top, name)
            incl = ts - start
            row = funcs.setdefault(name, [0, 0.0, 0.0])
            row[0] += 1
            row[1] += incl
            row[2] += incl - inner
            if stack:
                stack[-1][2] += incl
        result[family] = {"wall": wall, "cpu": cpu, "functions": funcs}
    return result


def run_tree(tree: str) -> dict:
    """:func:`measure` in a fresh process on ``tree``'s code and an empty cache."""
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        env = {**os.environ, "PYTHONPATH": tree, "NUMBA_CACHE_DIR": cache}
        out = subprocess.run([sys.executable, __file__, "--measure"], env=env, cwd=tree,
                             check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def cold(tree: str) -> dict:
    """``vsi compile`` on ``tree``'s code from an empty cache: {"cpu": s, "wall": s,
    "cache_mb": MB} (CPU: user + system of the command and of the processes it waited
    for, its compile helper)."""
    import resource

    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        env = {**os.environ, "PYTHONPATH": tree, "NUMBA_CACHE_DIR": cache}
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "vsi_numba.cli", "compile", "--quiet"],
                       env=env, cwd=tree, check=True)
        wall = time.perf_counter() - t0
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        size = sum(p.stat().st_size for p in Path(cache).rglob("*") if p.is_file())
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return {"cpu": cpu, "wall": wall, "cache_mb": size / 1e6}


def markdown(before: dict, after: dict) -> str:
    """Per-function self time before and after, family by family, with totals."""
    lines = []
    for family in FAMILIES:
        b = before[family]["functions"]
        a = after[family]["functions"]
        names = sorted(set(b) | set(a), key=lambda n: -max(b.get(n, [0, 0, 0])[2],
                                                           a.get(n, [0, 0, 0])[2]))
        lines += [f"**{family}**", "",
                  "| function | before: self CPU s (incl.) | after: self CPU s (incl.) |",
                  "|---|---:|---:|"]

        def cell(row):
            return "-" if row is None else f"{row[2]:.2f} ({row[1]:.2f})"

        for n in names:
            lines.append(f"| `{n}` | {cell(b.get(n))} | {cell(a.get(n))} |")
        tb = sum(r[2] for r in b.values())
        ta = sum(r[2] for r in a.values())
        lines.append(f"| **total compile** | **{tb:.2f}** | **{ta:.2f}** |")
        lines.append(f"| CPU of the warm-up | {before[family]['cpu']:.2f} | "
                     f"{after[family]['cpu']:.2f} |")
        lines.append(f"| wall of the warm-up | {before[family]['wall']:.2f} | "
                     f"{after[family]['wall']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def section(before: dict, after: dict, title: str) -> str:
    """The report's section "Compile time per function" (between its markers)."""
    tot = {k: sum(sum(r[2] for r in d[f]["functions"].values()) for f in FAMILIES)
           for k, d in (("before", before), ("after", after))}
    return "\n".join([
        BEGIN, "## Compile time per function", "",
        f"Written by `python -m benchmarks.compile_table` ({title}).  Each version compiled "
        "both kernel families from an empty numba cache in a process of its own "
        "(`_tiny_batch`, both families in one process); CPU seconds of that "
        "process per jitted function, from `numba:compile` events: *self* is the "
        "function's own compilation, *incl.* with the callees it compiled.  Functions "
        "numba inlines have no row.  Both families: "
        f"**{tot['before']:.1f} s before, {tot['after']:.1f} s after**.", "",
        markdown(before, after), END, ""])


def extract_section(text: str) -> str:
    """This section of a report text ('' if none)."""
    i, j = text.find(BEGIN), text.find(END)
    return text[i:j + len(END)] + "\n" if 0 <= i < j else ""


def write_section(path: Path, text: str) -> None:
    """Replace this section of the report at ``path`` (or append it)."""
    old_text = path.read_text(encoding="utf-8") if path.exists() else "# vsi_numba benchmarks\n"
    old = extract_section(old_text)
    if old:
        new = old_text.replace(old.rstrip("\n"), text.rstrip("\n"))
    else:
        new = old_text.rstrip("\n") + "\n\n" + text
    path.write_text(new if new.endswith("\n") else new + "\n", encoding="utf-8")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.compile_table",
                                description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trees", nargs="*", help="BEFORE_TREE AFTER_TREE")
    p.add_argument("--measure", action="store_true",
                   help="measure the code on sys.path (empty NUMBA_CACHE_DIR) as JSON")
    p.add_argument("--cold", action="store_true",
                   help="CPU and wall seconds of `vsi compile` from an empty cache, for "
                        "each tree given (default: this checkout)")
    p.add_argument("--json", action="store_true",
                   help="the two arguments are JSON files of --measure")
    p.add_argument("--write", metavar="TITLE",
                   help="write the section into reports/benchmarks.md, TITLE saying what "
                        "was compared and under which load")
    args = p.parse_args(argv)
    if args.measure:
        print(json.dumps(measure()))
        return 0
    if args.cold:
        for tree in args.trees or [str(Path(__file__).resolve().parents[1])]:
            r = cold(tree)
            print(f"{tree}: vsi compile from an empty cache: {r['cpu']:.1f} s CPU, "
                  f"{r['wall']:.1f} s wall, cache {r['cache_mb']:.1f} MB")
        return 0
    if len(args.trees) != 2:
        p.error("give BEFORE_TREE AFTER_TREE (or --measure)")
    if args.json:
        before, after = (json.loads(open(f, encoding="utf-8").read()) for f in args.trees)
    else:
        before = run_tree(args.trees[0])
        after = run_tree(args.trees[1])
    if args.write:
        write_section(REPORT, section(before, after, args.write))
        print(f"wrote {REPORT}")
    else:
        print(markdown(before, after))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
