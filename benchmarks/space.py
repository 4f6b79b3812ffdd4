"""Decks in space: what tracks and torsion cost a whole ``vsi sweep`` command.

Three configs, derived from ``configs/double_track_viaduct.toml`` (25 + 32 + 25 m box,
HSLM-A1..A4 as moving forces, bending modes up to 30 Hz) on the same reduced speed list:

a. planar: the deck without ``bridge.tracks``, ``bridge.torsion`` and ``train.track``;
b. one track at eccentricity 0, no torsion: the project promises results bit for bit
   those of (a) and at most 10 % more time (ratio b / a, bar 1.10);
c. the double-track viaduct with St-Venant torsion (two tracks at +-2.25 m, the
   torsional modes up to the highest bending mode), one train per run: the promise is a
   cost of at most the extra modes' share, i.e. the ratio c / a at most the ratio of the
   mode counts (read from the ``mode`` dimension of the two results files);
d. the bundled config: (c) with the same train on track 2 entering at the far end
   (``train.other_trains``, two trains per run superposed): the ratio d / c against 2,
   the number of trains per run;
e. planar with the modes of (c): (a) with ``n_modes`` = (c)'s mode count instead of
   ``max_frequency``: the promise is the double-track viaduct with trains meeting (d)
   at most 3 x this planar deck with the same number of modes (ratio d / e, bar 3).

Each command is ``python -m vsi_numba.cli sweep CONFIG -o OUT --quiet`` as a subprocess
(:func:`benchmarks.study.run_command`: wall time, CPU time of the command and its
children, peak RSS of its process tree), warm numba cache: every variant first runs
once on a 1-run grid (not in smoke mode, the tests' size, where only (a) runs as a
subprocess and the others by the CLI app in the benchmark's process).  The variants run
in interleaved rounds (a, b, c, then the same on a 1-run grid), so the load of a shared
machine hits them alike; medians over the rounds.  *Compute* is the CPU time on the
full grid minus that of the same command on 1 run (start-up, imports, model, kernels
from the cache, file output): the part that grows with the runs, and less sensitive
than the wall to the other work of a shared machine.  ``--cold`` adds one run of (a)
and (c) each with an empty numba cache of its own (the same moving-force kernels compile
for both).

Usage: ``python -m benchmarks.space [--smoke | --quick] [--rounds N] [--cold]
[--no-write] [--report PATH]``; the section ``Decks in space`` of
``reports/benchmarks.md`` is replaced in place (or appended).
"""

from __future__ import annotations

import argparse
import copy
import datetime as _dt
import functools
import os
import statistics
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.cases import fmt_s, md_table
from benchmarks.study import MB, Measure, one_run, run_command, run_in_process, to_toml
from benchmarks.timing import REPO, load1, machine_info, user_env

DOUBLE_TRACK = REPO / "configs" / "double_track_viaduct.toml"
BEGIN = "<!-- space-benchmark:begin -->"
END = "<!-- space-benchmark:end -->"
VARIANTS = ("a", "b", "c", "d", "e")
LABELS = {"a": "planar (no tracks, no torsion)",
          "b": "one track at eccentricity 0, no torsion",
          "c": "two tracks at +-2.25 m with torsion, one train per run",
          "d": "(c) with the train meeting on track 2 (bundled config)",
          "e": "planar with the mode count of (c)"}
SINGLE_TRACK_BAR = 1.10
#: The double-track viaduct with trains meeting (d) over the planar deck with the same
#: number of modes (e).
SAME_MODES_BAR = 3.0


@dataclass(frozen=True)
class SpacePlan:
    """Sizes of one mode of the benchmark."""

    name: str
    speeds: tuple  # km/h
    rounds: int
    warm_up: bool = True
    fixed: bool = True  # also time each variant on a 1-run grid (the fixed part)
    in_process: bool = False  # every variant but (a) in this process (smoke: no measure)


def make_space_plan(mode: str, rounds: int | None = None) -> SpacePlan:
    """``smoke`` (1 run per variant, for the tests: (a) as a command, the others by the
    CLI app in this process), ``quick`` (48 runs per variant, 3 rounds), ``normal`` (92
    runs, 5 rounds)."""
    if mode == "smoke":
        plan = SpacePlan("smoke", (300.0,), 1, warm_up=False, fixed=False, in_process=True)
    elif mode == "quick":
        plan = SpacePlan("quick", tuple(140.0 + 20.0 * i for i in range(12)), 3)
    elif mode == "normal":
        plan = SpacePlan("normal", tuple(140.0 + 10.0 * i for i in range(23)), 5)
    else:
        raise ValueError(f"unknown mode {mode!r}")
    if rounds is not None:
        import dataclasses

        plan = dataclasses.replace(plan, rounds=max(int(rounds), 1))
    return plan


def space_configs(speeds, trains: tuple | None = None) -> dict[str, dict]:
    """The three configs (TOML tables) of the benchmark on the speed list ``speeds``
    (km/h); ``trains`` restricts the bundled config's trains (default: all four)."""
    with open(DOUBLE_TRACK, "rb") as fh:
        base = tomllib.load(fh)
    base["title"] = "benchmark: " + base["title"]
    study = base["study"]
    study.pop("line_speed_kmh", None)
    study["speeds_kmh"] = [round(float(v), 6) for v in speeds]
    study["output"] = "results.nc"
    if trains is not None:
        base["train"]["preset"] = list(trains)
    d = base
    c = copy.deepcopy(base)
    c["train"].pop("other_trains", None)
    a = copy.deepcopy(c)
    for key in ("tracks", "torsion"):
        a["bridge"].pop(key)
    a["train"].pop("track")
    b = copy.deepcopy(a)
    b["bridge"]["tracks"] = [{"eccentricity": 0.0}]
    e = copy.deepcopy(a)
    e["bridge"].pop("max_frequency", None)
    e["bridge"]["n_modes"] = space_mode_count(c)
    return {"a": a, "b": b, "c": c, "d": d, "e": e}


def space_mode_count(cfg: dict) -> int:
    """Retained modes of the deck of ``cfg`` (its study model, built in this process)."""
    import json

    return _mode_count(json.dumps(cfg["bridge"], sort_keys=True))


@functools.lru_cache(maxsize=8)
def _mode_count(bridge_json: str) -> int:
    import json

    from vsi_numba.config import load_config

    cfg = load_config({"title": "modes", "bridge": json.loads(bridge_json),
                       "train": {"preset": "HSLM-A1", "model": "moving_force"},
                       "study": {"speeds_kmh": [200.0]}})
    return int(cfg.build_bridge().n_modes)


def n_runs(cfg: dict) -> int:
    preset = cfg["train"]["preset"]
    return (len(preset) if isinstance(preset, list) else 1) * len(cfg["study"]["speeds_kmh"])


def shared_differences(a: Path, b: Path) -> list[str]:
    """Names of the variables two results files share but whose values differ ([] when
    every shared variable is bit-identical; the attributes are not compared)."""
    import xarray as xr

    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        return [name for name in sorted(set(x.variables) & set(y.variables))
                if not x[name].load().identical(y[name].load())]


def mode_count(path: Path) -> int:
    """Number of retained modes of a results file (its ``mode`` dimension)."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return int(ds.sizes["mode"])


@dataclass
class SpaceResult:
    mode: str
    rounds: int = 1
    grid: str = ""
    walls: dict = field(default_factory=dict)  # variant -> [s], full grid
    cpus: dict = field(default_factory=dict)
    rss: dict = field(default_factory=dict)  # variant -> [bytes]
    fixed: dict = field(default_factory=dict)  # variant -> [s], wall on a 1-run grid
    fixed_cpu: dict = field(default_factory=dict)  # variant -> [s], CPU on a 1-run grid
    cold: dict = field(default_factory=dict)  # variant -> s, empty numba cache
    modes: dict = field(default_factory=dict)  # variant -> retained modes
    planar_identical: list | None = None  # variables of b differing from a's
    measures: list[Measure] = field(default_factory=list)
    date: str = ""
    load: tuple = (float("nan"), float("nan"))
    seconds: float = 0.0
    errors: list[str] = field(default_factory=list)


def _median(values) -> float:
    return statistics.median(values) if values else float("nan")


def run_space_bench(mode: str = "normal", write: bool = True, report: Path | None = None,
                    rounds: int | None = None, cold: bool = False,
                    echo=print) -> SpaceResult:
    """Run the benchmark of ``mode``; write its section of the report unless told not."""
    import vsi_numba

    plan = make_space_plan(mode, rounds)
    trains = ("HSLM-A1",) if mode == "smoke" else None
    cfgs = space_configs(plan.speeds, trains)
    res = SpaceResult(mode, plan.rounds,
                      date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"))
    runs = n_runs(cfgs["a"])
    n_tr, n_sp = len(cfgs["a"]["train"]["preset"]), len(plan.speeds)
    res.grid = (f"{n_tr} HSLM-A train{'s' * (n_tr > 1)} x {n_sp} speed{'s' * (n_sp > 1)} "
                f"({plan.speeds[0]:g}..{plan.speeds[-1]:g} km/h) = {runs} "
                f"run{'s' * (runs > 1)}")
    load0, t0 = load1(), time.perf_counter()
    env = user_env()
    pkg_root = str(Path(vsi_numba.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(
        [pkg_root] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    with tempfile.TemporaryDirectory(prefix="vsi_space_bench_") as tmp:
        tmp = Path(tmp)
        paths, ones = {}, {}
        for v, cfg in cfgs.items():
            paths[v] = tmp / f"{v}.toml"
            paths[v].write_text(to_toml(cfg))
            ones[v] = tmp / f"{v}_1run.toml"
            ones[v].write_text(to_toml(one_run(cfg)))
        k = 0

        def sweep(config: Path, keep: bool = False, environ: dict | None = None,
                  in_process: bool = False):
            nonlocal k
            k += 1
            out = tmp / f"out{k}.nc"
            cmd = [sys.executable, "-m", "vsi_numba.cli", "sweep", str(config), "-o",
                   str(out), "--quiet"]
            if in_process:
                r = run_in_process(cmd[3:])  # after `python -m vsi_numba.cli`
            else:
                r = run_command(cmd, tmp, environ or env)
            if r.aborted or r.returncode not in (0, 1) or not out.exists():
                raise RuntimeError(f"`vsi sweep {config.name}` failed (exit {r.returncode}"
                                   f"{', ' + r.aborted if r.aborted else ''}):\n{r.stderr}")
            if not keep:
                out.unlink()
            return r, out

        try:
            if plan.warm_up:
                for v in VARIANTS:
                    r, _ = sweep(ones[v])
                    echo(f"[space] warm-up {v} (1 run): {r.wall:.2f} s")
            outs = {}
            for i in range(plan.rounds):
                j = i % len(VARIANTS)
                order = VARIANTS[j:] + VARIANTS[:j]
                for v in order:
                    r, out = sweep(paths[v], keep=i == 0,
                                   in_process=plan.in_process and v != "a")
                    if i == 0:
                        outs[v] = out
                    res.walls.setdefault(v, []).append(r.wall)
                    res.cpus.setdefault(v, []).append(r.cpu)
                    res.rss.setdefault(v, []).append(r.peak_rss)
                    echo(f"[space] round {i + 1} {v}: {r.wall:.2f} s wall, {r.cpu:.2f} s "
                         f"CPU, peak RSS {r.peak_rss / MB:,.0f} MB (load {load1():.2f})")
                if plan.fixed:
                    for v in order:
                        r, _ = sweep(ones[v])
                        res.fixed.setdefault(v, []).append(r.wall)
                        res.fixed_cpu.setdefault(v, []).append(r.cpu)
                        echo(f"[space] round {i + 1} {v} on 1 run: {r.wall:.2f} s wall, "
                             f"{r.cpu:.2f} s CPU")
            res.modes = {v: mode_count(outs[v]) for v in VARIANTS}
            res.planar_identical = shared_differences(outs["a"], outs["b"])
            if cold:
                for v in ("a", "c"):
                    cache = tmp / f"numba_cache_{v}"
                    r, _ = sweep(paths[v], environ={**env, "NUMBA_CACHE_DIR": str(cache)})
                    res.cold[v] = r.wall
                    echo(f"[space] {v} with an empty numba cache: {r.wall:.1f} s")
        except Exception as exc:  # noqa: BLE001 - the report must still say what failed
            res.errors.append(f"{type(exc).__name__}: {exc}")
            echo(f"[space] FAILED: {exc}")
    res.seconds = time.perf_counter() - t0
    res.load = (load0, load1())
    if not res.errors:
        _measures(res)
    if write:
        write_section(Path(report) if report else REPO / "reports" / "benchmarks.md",
                      markdown(res))
        echo("[space] wrote the section 'Decks in space' of the report")
    return res


def _ratio(x: float, y: float) -> float:
    """x / y, NaN (n/a) unless both are positive (a compute part within the noise of the
    fixed part)."""
    return x / y if x > 0 and y > 0 else float("nan")


def _measures(res: SpaceResult) -> None:
    wall = {v: _median(res.walls[v]) for v in VARIANTS}
    cpu = {v: _median(res.cpus[v]) for v in VARIANTS}
    comp = {v: cpu[v] - _median(res.fixed_cpu.get(v, [])) for v in VARIANTS}
    m = res.modes
    mode_ratio = m["c"] / m["a"]
    same = ("results identical to (a)'s in every shared variable"
            if not res.planar_identical else
            f"DIFFERENT from (a)'s in {', '.join(res.planar_identical)}")
    res.measures += [
        Measure("b1", "one track at 0 / planar, wall", res.grid, wall["b"] / wall["a"],
                "ratio", SINGLE_TRACK_BAR, None,
                f"{fmt_s(wall['b'])} / {fmt_s(wall['a'])}; {same}"),
        Measure("b2", "one track at 0 / planar, CPU", res.grid, cpu["b"] / cpu["a"], "ratio",
                SINGLE_TRACK_BAR, None, f"{fmt_s(cpu['b'])} / {fmt_s(cpu['a'])}"),
        Measure("b3", "one track at 0 / planar, compute (CPU - 1-run CPU)", res.grid,
                _ratio(comp["b"], comp["a"]), "ratio", SINGLE_TRACK_BAR, None,
                f"{fmt_s(comp['b'])} / {fmt_s(comp['a'])}"),
        Measure("c1", "two tracks + torsion / planar, wall", res.grid, wall["c"] / wall["a"],
                "ratio", mode_ratio, None,
                f"{fmt_s(wall['c'])} / {fmt_s(wall['a'])}; bar = mode ratio "
                f"{m['c']} / {m['a']}"),
        Measure("c2", "two tracks + torsion / planar, CPU", res.grid, cpu["c"] / cpu["a"],
                "ratio", mode_ratio, None, f"{fmt_s(cpu['c'])} / {fmt_s(cpu['a'])}"),
        Measure("c3", "two tracks + torsion / planar, compute (CPU - 1-run CPU)",
                res.grid, _ratio(comp["c"], comp["a"]), "ratio", mode_ratio, None,
                f"{fmt_s(comp['c'])} / {fmt_s(comp['a'])}"),
        Measure("d1", "trains meeting (two per run) / one train, wall", res.grid,
                wall["d"] / wall["c"], "ratio", 2.0, None,
                f"{fmt_s(wall['d'])} / {fmt_s(wall['c'])}; bar = 2 trains per run"),
        Measure("d3", "trains meeting (two per run) / one train, compute", res.grid,
                _ratio(comp["d"], comp["c"]), "ratio", 2.0, None,
                f"{fmt_s(comp['d'])} / {fmt_s(comp['c'])}"),
        Measure("e1", "trains meeting / planar with the same modes, wall", res.grid,
                wall["d"] / wall["e"], "ratio", SAME_MODES_BAR, None,
                f"{fmt_s(wall['d'])} / {fmt_s(wall['e'])}; modes {m['d']} / {m['e']}"),
        Measure("e2", "trains meeting / planar with the same modes, CPU", res.grid,
                cpu["d"] / cpu["e"], "ratio", SAME_MODES_BAR, None,
                f"{fmt_s(cpu['d'])} / {fmt_s(cpu['e'])}"),
        Measure("e3", "trains meeting / planar with the same modes, compute", res.grid,
                _ratio(comp["d"], comp["e"]), "ratio", SAME_MODES_BAR, None,
                f"{fmt_s(comp['d'])} / {fmt_s(comp['e'])}"),
        Measure("n1", "noise: slowest / fastest repetition of (a), CPU", res.grid,
                max(res.cpus["a"]) / min(res.cpus["a"]), "ratio", None, None,
                f"the same command {len(res.cpus['a'])} times; a ratio of the medians "
                "above closer to 1 than this spread is within the noise of the machine"),
    ]


HEADER = ["#", "measure", "grid", "measured", "bar", "goal", "verdict", "notes"]
VARIANT_HEADER = ["variant", "modes", "wall median (all)", "CPU median",
                  "1 run: wall, CPU medians", "peak RSS median (max)", "empty cache"]


def variant_rows(res: SpaceResult) -> list[list[str]]:
    rows = []
    for v in VARIANTS:
        if v not in res.walls:
            continue
        rss = res.rss[v]
        rows.append([
            f"{v}. {LABELS[v]}", str(res.modes.get(v, "n/a")),
            f"{fmt_s(_median(res.walls[v]))} ({', '.join(f'{w:.2f}' for w in res.walls[v])} s)",
            fmt_s(_median(res.cpus[v])),
            (f"{fmt_s(_median(res.fixed[v]))}, {fmt_s(_median(res.fixed_cpu[v]))}"
             if res.fixed.get(v) else "-"),
            f"{_median(rss) / MB:,.0f} MB ({max(rss) / MB:,.0f} MB)",
            fmt_s(res.cold[v]) if v in res.cold else "-"])
    return rows


def text_table(res: SpaceResult) -> str:
    out = []
    for header, rows in ((VARIANT_HEADER, variant_rows(res)),
                         (HEADER, [mm.cells() for mm in res.measures])):
        if not rows:
            continue
        table = [header] + rows
        widths = [max(len(str(r[i])) for r in table) for i in range(len(header))]
        lines = ["  ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
                 for r in table]
        lines.insert(1, "  ".join("-" * w for w in widths))
        out += lines + [""]
    out += ["ERROR " + e.strip().splitlines()[0] for e in res.errors]
    return "\n".join(out).rstrip() + "\n"


def markdown(res: SpaceResult) -> str:
    m = machine_info()
    flag = ("" if res.mode == "normal" else " --" + res.mode) + (
        "" if res.rounds == make_space_plan(res.mode).rounds else f" --rounds {res.rounds}")
    lines = [
        BEGIN,
        "## Decks in space: tracks and torsion",
        "",
        f"Written by `python -m benchmarks.space{flag}` on {res.date} (mode **{res.mode}**, "
        f"{res.rounds} round{'s' * (res.rounds > 1)}, {res.seconds:.0f} s; "
        f"load {res.load[0]:.2f} at start, {res.load[1]:.2f} at end; "
        f"git {m['git_commit']}; {m['cores']} cores).",
        "",
        "Whole `python -m vsi_numba.cli sweep CONFIG -o OUT --quiet` commands on four "
        "configs derived from `configs/double_track_viaduct.toml` (same deck, trains and "
        f"speeds: {res.grid}): (a) without `bridge.tracks`, `bridge.torsion` and "
        "`train.track`; (b) (a) with `tracks = [{ eccentricity = 0.0 }]`; (c) two tracks "
        "at +-2.25 m with torsion, one train per run; (d) the bundled config, (c) with the "
        "same train on track 2 entering at the far end (`train.other_trains`).  Warm "
        "numba cache (each variant first ran once on a 1-run grid), interleaved rounds, "
        "medians over the rounds; *CPU* is "
        "the user + system time of the command and its children; *compute* is the CPU "
        "time on the full grid minus that of the same command on 1 run (start-up, "
        "imports, model, kernels from the cache, file output), the part that grows with "
        "the runs.  The "
        "bars: (b) at most 10 % over (a); (c) over (a) at most the ratio of the retained "
        "mode counts (the `mode` dimension of the results files).",
        "",
        md_table(VARIANT_HEADER, variant_rows(res)),
        "",
        md_table(HEADER, [mm.cells() for mm in res.measures]),
        "",
    ]
    for e in res.errors:
        lines += ["**Failed:**", "", "```", e.strip(), "```", ""]
    lines.append(END)
    return "\n".join(lines) + "\n"


def write_section(path: Path, section: str) -> None:
    """Replace the section of this benchmark in the report at ``path`` (or append it),
    keeping the rest of the report."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = path.read_text() if path.exists() else "# vsi_numba benchmarks\n"
    i, j = text.find(BEGIN), text.find(END)
    if 0 <= i < j:
        text = text[:i] + section.rstrip("\n") + text[j + len(END):]
    else:
        text = text.rstrip("\n") + "\n\n" + section
    path.write_text(text if text.endswith("\n") else text + "\n")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.space", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_const", dest="mode", const="quick")
    g.add_argument("--smoke", action="store_const", dest="mode", const="smoke")
    p.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default: "
                   "1 smoke, 3 quick, 5 normal)")
    p.add_argument("--cold", action="store_true",
                   help="also time (a) and (c) once each with an empty numba cache")
    p.add_argument("--no-write", action="store_true", help="do not write the report")
    p.add_argument("--report", type=Path, default=None,
                   help="report path (default reports/benchmarks.md)")
    args = p.parse_args(argv)
    echo = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    res = run_space_bench(args.mode or "normal", write=not args.no_write, report=args.report,
                          rounds=args.rounds, cold=args.cold, echo=echo)
    print(text_table(res))
    return 1 if res.errors else 0


if __name__ == "__main__":
    sys.exit(main())
