"""Study-level benchmark: whole ``vsi sweep`` commands, as a user types them.

Each measured command runs as a subprocess
(``python -m vsi_numba.cli sweep CONFIG -o OUT [--workers N] --quiet``) on a config
generated in a temporary directory.  Measured: the wall time of the whole command
(interpreter start, imports, numba cache load, workers, netCDF output), and the PEAK RSS
OF THE PROCESS TREE: every ~20 ms the runner walks ``/proc/*/stat`` for the descendants of
the command (spawned workers, Dask scheduler, nannies and workers) and sums their
``VmRSS``.  The sum counts pages shared between processes (libraries, copy-on-write) once
per process, as ``ps``/``top`` would; it is what the processes hold, an upper bound of the
physical memory they use together.

Measures (the bars and goals come with the benchmark; the verdict is computed from the
numbers of the same run):

a. the HSLM sweep of :mod:`benchmarks.yardstick` (10 trains x 57 speeds, 10 modes, dt 1 ms,
   envelopes only): ``vsi sweep`` wall (load effects on, the default) / yardstick compute
   time, load effects on / off in interleaved pairs (wall and CPU time of the command and
   its children), and ``--workers 2`` (Dask LocalCluster) / local default;
b. study 1, ``vsi sweep studies/hslm_psc_25m/study.toml`` (wall, peak RSS);
c. ICE3 interaction on the study-1 span, 20 modes, German-low PSD irregularity, 10 seeds x
   57 speeds, envelopes only (wall);
d. a 1,140-run moving-force sweep keeping every time history (peak RSS, file size); when a
   pilot on a tenth of the grid predicts more memory or disk than the machine can spare,
   the full grid is NOT run and the numbers are extrapolated (marked);
e. scaling: 100 .. 10,000 moving-force runs (envelopes only) against wall time and peak RSS;
f. local parallelism: process pool / threads;
g. the bundled design catalogue (51,870 runs);
h. the first run on a fresh machine, with an empty numba cache: h1 the main job (study 1,
   moving forces and ICE3 interaction), h2 the moving-force sweep of a (normal and full
   mode, or ``--measure h``);
i. the README's test command (ruff + pytest) with an empty numba cache, as on CI (timed
   only with ``--measure i``, which records it in ``reports/test_command.json``; else the
   recorded figure, dated);
j. the catalogue on a loopback Dask cluster of separate processes (``dask scheduler`` + 2 x
   ``dask worker --nthreads 1``, all on 127.0.0.1, ``vsi sweep --scheduler``) / the local
   threaded default, in interleaved rounds with 1 worker and ``--workers 2`` (wall and CPU
   time of every process; the files must be bit-identical), and a 16-worker estimate by
   the batch plan (normal and full mode, or ``--measure j``; it writes
   ``reports/dask_cluster.json``, which smoke and quick mode report, dated, instead).

The targets: a1 (load effects on) <= 0.8 x the yardstick; a3 load effects on / off
<= 1.30 (goal 1.15); c1 ICE3 570 runs <= 5 s (goal 2 s); h1 <= 20 s; i1 <= 2 min;
j1 <= 1.1.  A missed one shows by how much (``MISSED xR over the bar``).

Every command is first run once on a 1-run grid with the same keys (warm numba cache,
warm file cache); medians over the repetitions of the plan.
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks import yardstick as Y
from benchmarks.cases import fmt_s, md_table
from benchmarks.timing import REPO, load1, machine_info, user_env
from vsi_numba._process import available_cores

STUDY3 = REPO / "studies" / "hslm_catalogue" / "study.toml"
STUDY1 = REPO / "studies" / "hslm_psc_25m" / "study.toml"
BEGIN = "<!-- study-benchmark:begin -->"
END = "<!-- study-benchmark:end -->"
MB = 1024.0**2
HIST_SPEEDS = tuple(140.0 + 2.5 * i for i in range(114))  # 140 .. 422.5 km/h
HIST_RUNS = 10 * len(HIST_SPEEDS)  # 1,140


# ------------------------------------------------------------------------------ plans


@dataclass(frozen=True)
class StudyPlan:
    """Sizes of one mode of the study benchmark."""

    name: str
    trains: tuple = Y.TRAINS  # a, d, e
    speeds: tuple = Y.SPEEDS_KMH  # a
    repeat: int = 2  # repetitions of every measured command of a
    repeat_other: int = 1  # ... of b, c, d (full grid)
    dask: bool = True
    study1: bool = True
    ice3_seeds: tuple = tuple(range(1, 11))
    ice3_speeds: tuple = Y.SPEEDS_KMH
    hist_pilots: tuple = (60, 120)  # runs of the pilot grids of d (0: skip d)
    hist_full: bool = True  # run the 1,140-run grid when the pilots say it fits
    scaling: tuple = (100, 300, 1000, 3000, 10000)
    scaling_budget_s: float = 1800.0  # skip a scaling point predicted to take longer
    yardstick_repeat: int = 3
    warm_up: bool = True  # a 1-run warm-up before each measured command
    cold: bool = True  # h: the first run with an empty numba cache
    tests: bool = False  # i: time the README's test command (else the last figure)
    cluster: bool = False  # j: the catalogue on a loopback Dask cluster (else the last figure)
    in_process: bool = False  # a3: the on/off pair in this process (smoke: no measure)


def make_study_plan(mode: str) -> StudyPlan:
    """``smoke`` (one 1-run command as a subprocess, the load-effects pair in this
    process, for the tests), ``quick`` (scaling capped at 1,000 runs), ``normal``,
    ``full`` (3 repetitions)."""
    if mode == "smoke":
        return StudyPlan("smoke", trains=("HSLM-A1",), speeds=(420.0,), repeat=1, dask=False,
                         study1=False, ice3_seeds=(), hist_pilots=(), hist_full=False,
                         scaling=(), yardstick_repeat=1,
                         warm_up=False, cold=False, in_process=True)
    if mode == "quick":
        return StudyPlan("quick", scaling=(100, 300, 1000), scaling_budget_s=600.0,
                         cold=False)
    if mode == "normal":
        return StudyPlan("normal", repeat_other=2, cluster=True)
    if mode == "full":
        return StudyPlan("full", repeat=3, repeat_other=3, cluster=True)
    raise ValueError(f"unknown mode {mode!r}")


# ------------------------------------------------------------- process-tree memory


def _children() -> dict[int, list[int]]:
    """ppid -> child pids, from /proc/*/stat."""
    kids: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as fh:
                s = fh.read()
        except OSError:
            continue
        ppid = int(s[s.rfind(b")") + 2:].split(None, 2)[1])
        kids.setdefault(ppid, []).append(int(name))
    return kids


def tree_pids(root: int) -> list[int]:
    """``root`` and all its descendants."""
    kids = _children()
    out = [root]
    i = 0
    while i < len(out):
        out.extend(kids.get(out[i], ()))
        i += 1
    return out


def rss_bytes(pid: int) -> int:
    """VmRSS of one process (0 if gone or a zombie)."""
    try:
        with open(f"/proc/{pid}/status", "rb") as fh:
            for line in fh:
                if line.startswith(b"VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def tree_rss(root: int) -> tuple[int, int]:
    """(sum of VmRSS in bytes, number of processes) of ``root``'s process tree."""
    pids = tree_pids(root)
    return sum(rss_bytes(p) for p in pids), len(pids)


class TreeSampler(threading.Thread):
    """Samples the RSS of a process tree every ``interval`` s; kills the tree's process
    group if the sum exceeds ``limit`` bytes (a guard for the shared machine)."""

    def __init__(self, pid: int, interval: float = 0.02, limit: float | None = None):
        super().__init__(daemon=True)
        self.pid, self.interval, self.limit = pid, interval, limit
        self.peak = 0
        self.max_procs = 0
        self.samples = 0
        self.cpu = 0.0  # CPU time (s) spent sampling
        self.exceeded = 0
        self._halt = threading.Event()

    def run(self):
        c0 = time.thread_time()
        while not self._halt.is_set():
            rss, n = tree_rss(self.pid)
            self.samples += 1
            self.peak = max(self.peak, rss)
            self.max_procs = max(self.max_procs, n)
            if self.limit and rss > self.limit and not self.exceeded:
                self.exceeded = rss
                try:
                    os.killpg(self.pid, signal.SIGKILL)  # the command's own session
                except OSError:
                    pass
            self._halt.wait(self.interval)
        self.cpu = time.thread_time() - c0

    def stop(self):
        self._halt.set()
        self.join()


@dataclass
class CommandRun:
    wall: float
    peak_rss: float  # bytes
    max_procs: int
    returncode: int
    samples: int
    sampler_cpu: float
    stderr: str = ""
    aborted: str = ""
    cpu: float = float("nan")  # s, user + system of the command and its reaped children


def mem_total() -> float:
    """MemTotal and MemAvailable (bytes)."""
    vals = {}
    for line in Path("/proc/meminfo").read_text().splitlines():
        k, v = line.split(":", 1)
        vals[k] = float(v.split()[0]) * 1024
    return vals.get("MemTotal", 0.0), vals.get("MemAvailable", 0.0)


def run_command(cmd: list[str], cwd: Path, env: dict, timeout: float = 3600.0,
                rss_limit: float | None = None, interval: float = 0.02) -> CommandRun:
    """Run ``cmd`` in its own session; wall time and peak RSS of its process tree."""
    err_path = Path(cwd) / f".stderr-{time.monotonic_ns()}"
    import resource

    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(err_path, "wb") as err:
        w0 = time.perf_counter()
        p = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=err,
                             start_new_session=True)
        sampler = TreeSampler(p.pid, interval, rss_limit)
        sampler.start()
        aborted = ""
        try:
            rc = p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            rc = p.wait()
            aborted = f"killed after the {timeout:.0f} s timeout"
        wall = time.perf_counter() - w0
        sampler.stop()
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    # the session may leave orphans (e.g. a Dask worker being torn down): end them
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except OSError:
        pass
    stderr = err_path.read_text(errors="replace")[-3000:]
    err_path.unlink()
    if sampler.exceeded:
        aborted = (f"killed at {sampler.exceeded / MB:,.0f} MB (limit "
                   f"{rss_limit / MB:,.0f} MB of process-tree RSS)")
    return CommandRun(wall, float(sampler.peak), sampler.max_procs, rc, sampler.samples,
                      sampler.cpu, stderr, aborted, cpu)


def run_in_process(args: list[str]) -> CommandRun:
    """``vsi ARGS`` in this process (the CLI app itself, no interpreter start): the smoke
    modes' runner, whose numbers are not measures.  Wall and CPU time of the command; as
    peak RSS the process's own high-water mark (``ru_maxrss``), one process."""
    import contextlib
    import io
    import resource

    from vsi_numba.cli.app import app

    err = io.StringIO()
    w0, c0 = time.perf_counter(), time.process_time()
    rc = 0
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            app(args=list(args), prog_name="vsi")
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
    return CommandRun(wall, rss, 1, rc, 0, 0.0, err.getvalue()[-3000:], "", cpu)


# --------------------------------------------------------------------------- configs


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(cfg: dict) -> str:
    """TOML text of a config: top-level keys, then one table per dict value."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in cfg.items() if not isinstance(v, dict)]
    for k, v in cfg.items():
        if isinstance(v, dict):
            lines += ["", f"[{k}]"] + [f"{kk} = {_toml_value(x)}" for kk, x in v.items()]
    return "\n".join(lines) + "\n"


def _speeds(values) -> list[float]:
    return [round(float(v), 6) for v in values]


def hslm_config(trains, speeds, histories: bool = False, title: str = "HSLM sweep") -> dict:
    """The yardstick's model as a ``vsi sweep`` config (HHT alpha = 0 = Newmark, as the
    yardstick, so the command's envelopes can be checked against it)."""
    return {
        "title": f"benchmark: {title}",
        "bridge": {"kind": "simply_supported", "spans": [Y.SPAN], "EI": Y.EI,
                   "mass_per_length": Y.MASS, "damping_ratio": Y.ZETA,
                   "n_modes": Y.N_MODES, "output_points": [Y.SPAN / 2]},
        "train": {"preset": list(trains), "model": "moving_force"},
        "solver": {"dt": Y.DT, "hht_alpha": 0.0, "approach": Y.APPROACH,
                   "free_vibration": 0.0},
        "study": {"speeds_kmh": _speeds(speeds), "output": "results.nc",
                  "save_time_histories": bool(histories)},
    }


def study1_config() -> dict:
    with open(STUDY1, "rb") as fh:
        return tomllib.load(fh)


def ice3_config(seeds, speeds) -> dict:
    """ICE3 (interaction) on the study-1 span with 20 modes, German-low PSD track."""
    s1 = study1_config()
    return {
        "title": "benchmark: ICE3 interaction, German low, 25 m PSC span",
        "bridge": {**s1["bridge"], "n_modes": 20},
        "train": {"preset": "ICE3", "model": "interaction"},
        "irregularity": {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
                         "wavelength_max": 80.0, "seeds": [int(s) for s in seeds]},
        "solver": {"dt": 1e-3, "approach": s1["solver"]["approach"], "free_vibration": 0.0},
        "study": {"speeds_kmh": _speeds(speeds), "output": "results.nc",
                  "save_time_histories": False},
    }


def one_run(cfg: dict) -> dict:
    """The same config on a 1-run grid (the warm-up of a measured command)."""
    cfg = {k: (dict(v) if isinstance(v, dict) else v) for k, v in cfg.items()}
    tr = cfg["train"]
    if isinstance(tr.get("preset"), list):
        tr["preset"] = tr["preset"][:1]
    st = cfg["study"]
    sp = st["speeds_kmh"]
    st["speeds_kmh"] = [float(sp["start"])] if isinstance(sp, dict) else list(sp[:1])
    if "history_speeds_kmh" in st:
        st["history_speeds_kmh"] = list(st["speeds_kmh"])
    irr = cfg.get("irregularity")
    if irr and "seeds" in irr:
        irr["seeds"] = irr["seeds"][:1]
    return cfg


def n_runs(cfg: dict) -> int:
    tr = cfg["train"].get("preset", [])
    n_tr = len(tr) if isinstance(tr, list) else 1
    sp = cfg["study"]["speeds_kmh"]
    n_sp = (int(round((sp["stop"] - sp["start"]) / sp["step"])) + 1 if isinstance(sp, dict)
            else len(sp))
    seeds = cfg.get("irregularity", {}).get("seeds", [None])
    return n_tr * n_sp * len(seeds)


# -------------------------------------------------------------------------- results


@dataclass
class Measure:
    """One line of the study table."""

    key: str
    name: str
    grid: str
    value: float
    unit: str  # "ratio", "s", "bytes"
    bar: float | None = None
    goal: float | None = None
    note: str = ""
    extrapolated: bool = False

    @property
    def verdict(self) -> str:
        if not self.value == self.value:
            return "n/a"
        if self.bar is None:
            return "info"
        tag = " (EXTRAPOLATED)" if self.extrapolated else ""
        if self.goal is not None and self.value <= self.goal:
            return "goal met" + tag
        if self.value <= self.bar:
            return ("bar met, goal missed" if self.goal is not None else "met") + tag
        return f"MISSED x{self.value / self.bar:.1f} over the bar" + tag

    def fmt(self, v) -> str:
        if v is None:
            return "-"
        if not v == v:
            return "n/a"
        if self.unit == "ratio":
            return f"{v:.2f}"
        if self.unit == "bytes":
            return f"{v / MB / 1024:.2f} GB" if v >= 1024**3 else f"{v / MB:,.0f} MB"
        return fmt_s(v)

    def cells(self) -> list[str]:
        return [self.key, self.name, self.grid,
                self.fmt(self.value) + (" (extrap.)" if self.extrapolated else ""),
                self.fmt(self.bar), self.fmt(self.goal), self.verdict, self.note]


HEADER = ["#", "measure", "grid", "measured", "bar", "goal", "verdict", "notes"]


@dataclass
class StudyResult:
    mode: str
    measures: list[Measure] = field(default_factory=list)
    commands: list[list[str]] = field(default_factory=list)  # details table rows
    details: list[str] = field(default_factory=list)
    scaling: list[list[str]] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    yardstick: dict = field(default_factory=dict)
    date: str = ""
    load_start: float = float("nan")
    load_end: float = float("nan")
    seconds: float = 0.0

    def measure(self, key):
        return next((m for m in self.measures if m.key == key), None)


def text_table(res: StudyResult) -> str:
    rows = [HEADER] + [m.cells() for m in res.measures]
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(HEADER))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
             for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    if res.scaling:
        lines += ["", "scaling (moving-force HSLM sweeps, envelopes only):"]
        lines += ["  " + " | ".join(r) for r in [SCALING_HEADER] + res.scaling]
    for e in res.errors:
        lines.append("ERROR " + e.strip().splitlines()[-1])
    return "\n".join(lines)


SCALING_HEADER = ["runs", "grid", "wall", "per run", "peak RSS (tree)", "processes"]
COMMAND_HEADER = ["command", "grid (runs)", "wall median (all)", "peak RSS median (max)",
                  "processes", "load(1m)"]


# ---------------------------------------------------------------------------- runner


class Bench:
    """Runs the measured commands of one plan in a temporary directory."""

    def __init__(self, plan: StudyPlan, tmp: Path, echo=print):
        import vsi_numba

        self.plan, self.tmp, self.echo = plan, Path(tmp), echo
        pkg_root = str(Path(vsi_numba.__file__).resolve().parents[1])
        self.env = user_env()  # the user's BLAS settings: these are the user's commands
        self.env["PYTHONPATH"] = os.pathsep.join(
            [pkg_root] + [p for p in self.env.get("PYTHONPATH", "").split(os.pathsep) if p])
        total, _ = mem_total()
        self.rss_limit = 0.6 * total if total else None
        self.k = 0
        self.rows: list[list[str]] = []  # details of the measured commands
        self.sampler_cpu: list[float] = []  # sampler CPU / wall per measured command

    def command(self, config: Path, out: Path, workers: int | None = None,
                backend: str | None = None) -> list[str]:
        if backend is not None:  # the Python API (the CLI has no backend option)
            code = ("from vsi_numba.study.runner import execute_study; "
                    f"execute_study({str(config)!r}, {str(out)!r}, workers={workers!r}, "
                    f"backend={backend!r}, quiet=True)")
            return [sys.executable, "-c", code]
        cmd = [sys.executable, "-m", "vsi_numba.cli", "sweep", str(config), "-o", str(out)]
        if workers:
            cmd += ["--workers", str(workers)]
        return cmd + ["--quiet"]

    def write(self, cfg: dict, name: str) -> Path:
        path = self.tmp / f"{name}.toml"
        path.write_text(to_toml(cfg))
        return path

    def run(self, config: Path, workers: int | None = None, keep: bool = False,
            backend: str | None = None,
            in_process: bool = False) -> tuple[CommandRun, Path, float]:
        """One command (``in_process``: the CLI app in this process, see
        :func:`run_in_process`); returns the run, the output path and its size (bytes).
        The output is deleted unless ``keep``."""
        self.k += 1
        out = self.tmp / f"out{self.k}" / "results.nc"
        out.parent.mkdir()
        cmd = self.command(config, out, workers, backend)
        if in_process and backend is None:
            r = run_in_process(cmd[3:])  # after `python -m vsi_numba.cli`
        else:
            r = run_command(cmd, self.tmp, self.env, rss_limit=self.rss_limit)
        if r.aborted or r.returncode not in (0, 1) or not out.exists():
            raise RuntimeError(f"`vsi sweep {config.name}` failed (exit {r.returncode}"
                               f"{', ' + r.aborted if r.aborted else ''}):\n{r.stderr}")
        size = float(out.stat().st_size)
        if not keep:
            out.unlink()
        return r, out, size

    def repeated(self, label: str, config: Path, grid: str, repeat: int,
                 workers: int | None = None, warm: Path | None = None, keep: bool = False,
                 backend: str | None = None):
        """Warm-up on ``warm`` (a 1-run config), then ``repeat`` runs of ``config``;
        returns (median wall, median peak RSS, runs, last output, size) and records the
        details row."""
        if warm is not None and self.plan.warm_up:
            w, _, _ = self.run(warm, workers, backend=backend)
            self.echo(f"[study]   warm-up ({label}, 1 run) {w.wall:.1f} s")
        runs, out, size = [], None, float("nan")
        load0 = load1()
        for i in range(max(repeat, 1)):
            r, out, size = self.run(config, workers, keep=keep and i == repeat - 1,
                                    backend=backend)
            runs.append(r)
            self.echo(f"[study]   {label}: {r.wall:.2f} s, peak RSS {r.peak_rss / MB:,.0f} MB "
                      f"({r.max_procs} processes, {r.samples} samples)")
        wall = statistics.median(r.wall for r in runs)
        rss = statistics.median(r.peak_rss for r in runs)
        self.rows.append([label, grid, f"{fmt_s(wall)} ({', '.join(f'{r.wall:.2f}' for r in runs)}"
                          " s)", f"{rss / MB:,.0f} MB ({max(r.peak_rss for r in runs) / MB:,.0f}"
                          " MB)", str(max(r.max_procs for r in runs)),
                          f"{max(load0, load1()):.2f}"])
        self.sampler_cpu.append(sum(r.sampler_cpu for r in runs) / sum(r.wall for r in runs))
        return wall, rss, runs, out, size


def _grid(trains, speeds, seeds=None) -> str:
    sp = list(speeds)
    step = f" step {sp[1] - sp[0]:.3g}" if len(sp) > 2 and np.allclose(np.diff(sp), sp[1] - sp[0]) \
        else ""
    s = (f"{len(trains)} train{'s' if len(trains) > 1 else ''} x {len(sp)} speed"
         f"{'s' if len(sp) > 1 else ''} ({sp[0]:g}..{sp[-1]:g} km/h{step})")
    if seeds:
        s += f" x {len(seeds)} seeds"
    n = len(trains) * len(sp) * (len(seeds) if seeds else 1)
    return s + f" = {n:,} run{'s' if n > 1 else ''}"


def _measure_a(b: Bench, res: StudyResult):
    p = b.plan
    b.echo(f"[study] a. yardstick (numpy/scipy) on {len(p.trains)} x {len(p.speeds)} ...")
    yw, yc, (yd, ya) = Y.timed_sweep(p.trains, p.speeds, repeat=p.yardstick_repeat)
    res.yardstick = {"wall": yw, "cpu": yc, "runs": len(p.trains) * len(p.speeds)}
    b.echo(f"[study]   yardstick compute {yw:.3f} s wall, {yc:.3f} s CPU")
    cfg = hslm_config(p.trains, p.speeds)
    grid = _grid(p.trains, p.speeds)
    path, warm = b.write(cfg, "hslm"), b.write(one_run(cfg), "hslm_1run")
    local, _, _, out, _ = b.repeated("a. vsi sweep (local default)", path, grid, p.repeat,
                                     warm=warm, keep=True)
    # the timed command computed the yardstick's numbers
    import xarray as xr

    with xr.open_dataset(out) as ds:
        sel = {d: 0 for d in ds["max_deck_displacement"].dims if d not in ("train", "speed")}
        ed = ds["max_deck_displacement"].isel(sel).transpose("train", "speed")
        ea = ds["max_deck_acceleration"].isel(sel).transpose("train", "speed")
        ed = ed.sel(train=list(p.trains)).values
        ea = ea.sel(train=list(p.trains)).values
    out.unlink()
    agree = max(float(np.max(np.abs(ed - yd) / np.abs(yd))),
                float(np.max(np.abs(ea - ya) / np.abs(ya))))
    res.yardstick["agreement_sweep"] = agree
    res.yardstick["local"] = local
    note = f"{fmt_s(local)} / {fmt_s(yw)}; envelopes = yardstick's to {agree:.1e}"
    if p.warm_up:
        fixed = _fixed_cost(b, "a. vsi sweep, HSLM config on 1 run (the fixed cost)", warm,
                            p.repeat)
        res.yardstick["fixed"] = fixed
        note += (f"; the same command on 1 run {fmt_s(fixed)} = {fixed / yw:.2f} x the "
                 "yardstick (start-up, kernels from the cache, results file, governing "
                 "summary)")
    res.measures.append(Measure("a1", "HSLM sweep, load effects on: `vsi sweep` wall / "
                                "yardstick compute", grid, local / yw, "ratio", 0.8, None,
                                note))
    # the dynamic load effects (on by default): the same sweep without them, in
    # interleaved on/off pairs (a load change on the shared machine hits both alike)
    off_cfg = {**cfg, "study": {**cfg["study"], "load_effects": False}}
    off_path = b.write(off_cfg, "hslm_no_load_effects")
    on_runs, off_runs = [], []
    for _ in range(max(p.repeat, 1)):
        on_runs.append(b.run(path, in_process=p.in_process)[0])
        off_runs.append(b.run(off_path, in_process=p.in_process)[0])
        b.echo(f"[study]   a. load effects on / off: {on_runs[-1].wall:.2f} / "
               f"{off_runs[-1].wall:.2f} s wall, {on_runs[-1].cpu:.2f} / "
               f"{off_runs[-1].cpu:.2f} s CPU")
    med = statistics.median
    w_on, w_off = med(r.wall for r in on_runs), med(r.wall for r in off_runs)
    c_on, c_off = med(r.cpu for r in on_runs), med(r.cpu for r in off_runs)
    res.measures.append(Measure(
        "a3", "HSLM sweep: load effects on / off (whole command, wall)", grid,
        w_on / w_off, "ratio", 1.3, 1.15,
        f"{fmt_s(w_on)} / {fmt_s(w_off)}; CPU {fmt_s(c_on)} / {fmt_s(c_off)} = "
        f"{c_on / c_off:.2f}; medians of {len(on_runs)} interleaved pairs"
        + ("; in the benchmark's process (smoke: not a measure)" if p.in_process else "")))
    if p.dask:
        dask, *_ = b.repeated("a. vsi sweep --workers 2 (Dask)", path, grid, p.repeat,
                              workers=2, warm=warm)
        res.measures.append(Measure("a2", "HSLM sweep: `--workers 2` (Dask) / local default",
                                    grid, dask / local, "ratio", 1.3, 1.1,
                                    f"{fmt_s(dask)} / {fmt_s(local)}"))


def _measure_b(b: Bench, res: StudyResult):
    cfg = study1_config()
    warm = b.write(one_run(cfg), "study1_1run")
    grid = f"{n_runs(cfg)} runs (HSLM-A1..A10 + ICE3 x 57 speeds), histories at 300 km/h"
    wall, rss, *_ = b.repeated("b. vsi sweep studies/hslm_psc_25m/study.toml", STUDY1, grid,
                               b.plan.repeat_other, warm=warm)
    res.measures.append(Measure("b1", "study 1 (`vsi sweep studies/hslm_psc_25m/study.toml`)"
                                ": wall", grid, wall, "s", 10.0, 5.0))
    res.measures.append(Measure("b2", "study 1: peak RSS (process tree)", grid, rss, "bytes",
                                500 * MB, 300 * MB))


def _measure_c(b: Bench, res: StudyResult):
    p = b.plan
    cfg = ice3_config(p.ice3_seeds, p.ice3_speeds)
    grid = _grid(("ICE3",), p.ice3_speeds, p.ice3_seeds) + ", 20 modes, envelopes only"
    path, warm = b.write(cfg, "ice3"), b.write(one_run(cfg), "ice3_1run")
    wall, rss, *_ = b.repeated("c. ICE3 interaction, German low", path, grid,
                               p.repeat_other, warm=warm)
    note = f"peak RSS {rss / MB:,.0f} MB; {wall / n_runs(cfg):.3f} s per run"
    if p.warm_up:
        fixed = _fixed_cost(b, "c. ICE3 interaction on 1 run (the fixed cost)", warm,
                            max(p.repeat_other, 2))
        note += (f"; the same command on 1 run {fmt_s(fixed)}: the {n_runs(cfg)} runs take "
                 f"~{fmt_s(wall - fixed)} on {available_cores()} cores")
    res.measures.append(Measure("c1", "ICE3 interaction sweep: wall", grid, wall, "s",
                                5.0, 2.0, note))


def _fixed_cost(b: Bench, label: str, one: Path, repeat: int) -> float:
    """Median wall of the 1-run config ``one`` (warm): what a command costs whatever its
    grid - interpreter and imports, the kernels loaded from the cache, the results file
    and the governing summary."""
    wall, *_ = b.repeated(label, one, "1 run", repeat)
    return wall


def _fit(xs, ys, x):
    """Value at ``x`` of the straight line through (xs, ys) (least squares)."""
    if len(xs) == 1:
        return ys[0] * x / xs[0]
    k, c = np.polyfit(np.asarray(xs, float), np.asarray(ys, float), 1)
    return float(c + k * x)


def _measure_d(b: Bench, res: StudyResult):
    p = b.plan
    trains, full_grid = p.trains, _grid(p.trains, HIST_SPEEDS) + ", all time histories"
    pts = []  # (runs, peak RSS, file size, wall)
    warm = b.write(one_run(hslm_config(trains, HIST_SPEEDS, True)), "hist_1run")
    for i, n in enumerate(p.hist_pilots):
        k = max(1, round(n / len(trains)))
        idx = np.unique(np.linspace(0, len(HIST_SPEEDS) - 1, k).round().astype(int))
        speeds = [HIST_SPEEDS[j] for j in idx]  # spread over the range like the full grid
        path = b.write(hslm_config(trains, speeds, True, "history pilot"), f"hist_pilot{n}")
        wall, rss, _, _, size = b.repeated(f"d. history sweep, pilot {i + 1}", path,
                                           _grid(trains, speeds) + ", histories", 1,
                                           warm=warm if i == 0 else None)
        pts.append((len(trains) * len(speeds), rss, size, wall))
    if not pts and not p.hist_full:
        return
    runs = [q[0] for q in pts]
    pred_rss = _fit(runs, [q[1] for q in pts], HIST_RUNS) if pts else 0.0
    pred_size = _fit(runs, [q[2] for q in pts], HIST_RUNS) if pts else 0.0
    _, avail = mem_total()
    free_disk = float(os.statvfs(b.tmp).f_bavail * os.statvfs(b.tmp).f_frsize)
    fits = pred_rss < 0.4 * avail and pred_size < 0.4 * free_disk
    if p.hist_full and fits:
        path = b.write(hslm_config(trains, HIST_SPEEDS, True, "1,140 runs with histories"),
                       "hist_full")
        _, rss, _, _, size = b.repeated("d. history sweep, 1,140 runs", path, full_grid,
                                        p.repeat_other, warm=warm if not pts else None)
        extrap, note = False, f"file {size / MB:,.0f} MB"
    else:
        rss, size, extrap = pred_rss, pred_size, True
        why = (f"not run: the pilots predict {pred_rss / MB:,.0f} MB RSS and a "
               f"{pred_size / MB:,.0f} MB file (MemAvailable {avail / MB:,.0f} MB, free disk "
               f"{free_disk / MB:,.0f} MB)" if p.hist_full else "not run in this mode")
        note = (f"{why}; straight line through the pilots ({', '.join(str(r) for r in runs)} "
                f"runs) extrapolated to {HIST_RUNS:,} runs")
        b.echo(f"[study]   d. full grid {why}")
    res.measures.append(Measure("d1", "1,140-run sweep with histories: peak RSS", full_grid,
                                rss, "bytes", 1024 * MB, 500 * MB, note, extrap))
    res.measures.append(Measure("d2", "1,140-run sweep with histories: file size", full_grid,
                                size, "bytes", note="" if not extrap else "extrapolated",
                                extrapolated=extrap))


def _measure_e(b: Bench, res: StudyResult):
    p = b.plan
    pts = []  # (runs, wall)
    warm = b.write(one_run(hslm_config(p.trains, p.speeds)), "scale_1run")
    for i, n in enumerate(p.scaling):
        n_sp = max(1, round(n / len(p.trains)))
        speeds = np.linspace(140.0, 420.0, n_sp)
        runs = len(p.trains) * n_sp
        grid = _grid(p.trains, speeds)
        if pts:
            pred = _fit([q[0] for q in pts], [q[1] for q in pts], runs)
            if pred > p.scaling_budget_s:
                res.scaling.append([f"{runs:,}", grid, f"skipped (predicted {fmt_s(pred)} > "
                                    f"budget {fmt_s(p.scaling_budget_s)})", "", "", ""])
                continue
        path = b.write(hslm_config(p.trains, speeds, title=f"scaling {runs}"), f"scale{runs}")
        wall, rss, r, _, _ = b.repeated(f"e. scaling, {runs:,} runs", path, grid, 1,
                                        warm=warm if i == 0 else None)
        pts.append((runs, wall))
        res.scaling.append([f"{runs:,}", grid, fmt_s(wall), fmt_s(wall / runs),
                            f"{rss / MB:,.0f} MB", str(r[0].max_procs)])
    if len(pts) >= 2:
        k = np.polyfit([q[0] for q in pts], [q[1] for q in pts], 1)
        res.details.append(f"Scaling fit (least squares): wall = {k[1]:.2f} s + "
                           f"{k[0] * 1e3:.2f} ms x runs.")


def _measure_f(b: Bench, res: StudyResult):
    """Local parallelism: threads of one process (the default) vs a process pool fed with
    the same batches, 2 workers each, on study 1 and the HSLM sweep."""
    p = b.plan
    cases = [("study 1", STUDY1, one_run(study1_config()),
              f"{n_runs(study1_config())} runs (study 1)")]
    cfg = hslm_config(p.trains, p.speeds)
    cases.append(("HSLM sweep", b.write(cfg, "hslm_f"), one_run(cfg),
                  _grid(p.trains, p.speeds)))
    for k, (name, path, warm_cfg, grid) in enumerate(cases, start=1):
        warm = b.write(warm_cfg, f"f_{name.replace(' ', '_')}_1run")
        walls = {}
        for backend in ("threads", "processes"):
            walls[backend], rss, *_ = b.repeated(f"f. {name}, {backend} (2)", path, grid,
                                                 b.plan.repeat_other, workers=2, warm=warm,
                                                 backend=backend)
        ratio = walls["processes"] / walls["threads"]
        res.measures.append(Measure(
            f"f{k}", f"{name}: process pool / threads (2 workers each)", grid,
            ratio, "ratio", None, None,
            f"{fmt_s(walls['processes'])} / {fmt_s(walls['threads'])}; the faster is the "
            "default" + (" (threads)" if ratio >= 1 else " (processes: change the default!)")))


def _measure_g(b: Bench, res: StudyResult):
    """The bundled design catalogue (studies/hslm_catalogue): 91 bridge variants x 10 HSLM
    trains x 57 speeds = 51,870 runs, whole command."""
    warm = b.write(one_run(hslm_config(("HSLM-A1",), (420.0,))), "g_1run")
    grid = "91 variants (13 spans x 7 f1) x 10 HSLM x 57 speeds = 51,870 runs"
    wall, rss, *_ = b.repeated("g. vsi sweep studies/hslm_catalogue/study.toml", STUDY3, grid,
                               1, warm=warm)
    res.measures.append(Measure("g1", "catalogue study (`vsi sweep studies/hslm_catalogue/"
                                "study.toml`): wall", grid, wall, "s", 600.0, None))
    res.measures.append(Measure("g2", "catalogue study: peak RSS (process tree)", grid, rss,
                                "bytes", 1024 * MB, None))


def _cold_run(b: Bench, config: Path, name: str):
    """``vsi sweep config`` with an EMPTY numba cache: every kernel it uses is compiled in
    the command (a first run on a fresh machine)."""
    cache = b.tmp / f"empty_numba_cache_{name}"
    out = b.tmp / f"cold_{name}" / "results.nc"
    out.parent.mkdir()
    env = {**b.env, "NUMBA_CACHE_DIR": str(cache)}
    load0 = load1()
    r = run_command(b.command(config, out), b.tmp, env, rss_limit=b.rss_limit)
    if r.aborted or r.returncode not in (0, 1) or not out.exists():
        raise RuntimeError(f"cold `vsi sweep` failed (exit {r.returncode}):\n{r.stderr}")
    return r, max(load0, load1())


def _measure_h(b: Bench, res: StudyResult):
    """The first run on a fresh machine, empty numba cache: h1 the main job (the README's
    first command's sweep: study 1, moving forces and ICE3 interaction), h2 a
    moving-force-only sweep (the HSLM sweep of a: only the moving-force kernels compile)."""
    p = b.plan
    grid = f"{n_runs(study1_config())} runs (study 1), empty NUMBA_CACHE_DIR"
    r, load = _cold_run(b, STUDY1, "study1")
    b.rows.append(["h. vsi sweep studies/hslm_psc_25m/study.toml, first run (empty numba "
                   "cache)", grid, fmt_s(r.wall), f"{r.peak_rss / MB:,.0f} MB",
                   str(r.max_procs), f"{load:.2f}"])
    warm = res.measure("b1")
    cores = available_cores()
    # the compiling processes keep every core busy: no schedule of this work beats CPU/cores
    note = (f"CPU {fmt_s(r.cpu)} (all processes): at least {fmt_s(r.cpu / cores)} on "
            f"{cores} cores whatever the schedule")
    if warm is not None:
        note += (f"; the same command warm {fmt_s(warm.value)} (b1): "
                 f"~{fmt_s(r.wall - warm.value)} is JIT compilation")
    res.measures.append(Measure("h1", "first run of the main job (study 1), empty numba "
                                "cache: wall", grid, r.wall, "s", 20.0, None, note))
    cfg = hslm_config(p.trains, p.speeds, title="first run, empty numba cache")
    path = b.write(cfg, "hslm_cold")
    grid = _grid(p.trains, p.speeds) + ", empty NUMBA_CACHE_DIR"
    r, load = _cold_run(b, path, "hslm")
    b.rows.append(["h. vsi sweep (HSLM, moving forces), first run (empty numba cache)", grid,
                   fmt_s(r.wall), f"{r.peak_rss / MB:,.0f} MB", str(r.max_procs),
                   f"{load:.2f}"])
    note = f"CPU {fmt_s(r.cpu)}"
    if "local" in res.yardstick:
        note += (f"; the same command warm {fmt_s(res.yardstick['local'])}: "
                 f"~{fmt_s(r.wall - res.yardstick['local'])} is JIT compilation")
    res.measures.append(Measure("h2", "first run, empty numba cache, moving forces only "
                                "(HSLM sweep): wall", grid, r.wall, "s", 20.0, None, note))


# The README's test command (ruff + the whole pytest suite) is minutes long and loads the
# machine: it is timed only when asked for (``--measure i``), which records the figure
# here; otherwise the recorded figure is reported with its date.
TEST_COMMAND = REPO / "reports" / "test_command.json"


def readme_pytest_options() -> str:
    """The options of ``pytest`` in the README's test command (e.g. ``-q -n 2``)."""
    for line in (REPO / "README.md").read_text(encoding="utf-8").splitlines():
        head, sep, tail = line.partition("-m pytest")
        if sep and "NUMBA_CACHE_DIR" in head:
            return tail.strip()
    raise RuntimeError("README.md has no test command (`... -m pytest ...`)")


def _measure_i(b: Bench, res: StudyResult):
    import datetime
    import json

    name = "README test command (ruff + vsi compile + pytest -q), empty numba cache: wall"
    if not b.plan.tests:
        if not TEST_COMMAND.exists():
            res.measures.append(Measure("i1", name, "whole suite", float("nan"), "s", 120.0,
                                        None, "not measured: `python -m benchmarks "
                                        "--measure i` times it"))
            return
        d = json.loads(TEST_COMMAND.read_text())
        res.measures.append(Measure(
            "i1", name, d["grid"], float(d["wall_s"]), "s", 120.0, None,
            f"CPU {fmt_s(d['cpu_s'])}; {d['note']}; not re-run: recorded "
            f"{d['date']} (load {d['load']:.2f}) in {TEST_COMMAND.relative_to(REPO)}"))
        return
    venv = Path(sys.executable).parent
    cache = b.tmp / "empty_numba_cache_tests"
    # pytest's summary goes to stderr, whose tail run_command keeps; pytest's options are
    # the README's (the test command's last words)
    cmd = ["bash", "-c", f"{venv / 'ruff'} check vsi_numba tests benchmarks 1>&2 && "
           f"{sys.executable} -m vsi_numba.cli compile 1>&2 && "
           f"{sys.executable} -m pytest {readme_pytest_options()} -p no:cacheprovider 1>&2"]
    env = {**b.env, "NUMBA_CACHE_DIR": str(cache)}
    load0 = load1()
    r = run_command(cmd, REPO, env)
    if r.returncode != 0:
        raise RuntimeError(f"the test command failed (exit {r.returncode}):\n{r.stderr}")
    tail = [ln for ln in r.stderr.splitlines() if " passed" in ln]
    grid = "whole suite, empty numba cache (as on CI; venv and pip install not counted)"
    d = {"wall_s": round(r.wall, 1), "cpu_s": round(r.cpu, 1),
         "load": round(max(load0, load1()), 2), "grid": grid,
         "note": tail[-1].strip("= ") if tail else "",
         "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d")}
    TEST_COMMAND.write_text(json.dumps(d, indent=1) + "\n")
    res.measures.append(Measure("i1", name, grid, r.wall, "s", 120.0, None,
                                f"CPU {fmt_s(r.cpu)}; {d['note']}"))


def list_schedule(times, n_workers: int, overhead: float = 0.0) -> float:
    """Makespan of tasks of ``times`` seconds handed out in the given order, each to the
    worker free first (Dask's order with one thread per worker), each costing
    ``overhead`` seconds more (scheduler, transport)."""
    import heapq

    free = [0.0] * max(int(n_workers), 1)
    for t in times:
        heapq.heappush(free, heapq.heappop(free) + float(t) + overhead)
    return max(free)


def plan_of(kernel_seconds: dict) -> list:
    """The batch plan of stored batches, rebuilt from their keys (plan order is the keys'
    order: variant, train, realisation, speeds) with their measured kernel seconds as
    costs."""
    import re

    from vsi_numba.study.batches import Batch

    plan = []
    for i, key in enumerate(sorted(kernel_seconds)):
        m = re.fullmatch(r"(?:v(\d+)_)?t(\d+)_i(\d+)_s(\d+)-(\d+)", key)
        s0, s1 = int(m.group(4)), int(m.group(5))
        plan.append(Batch(i, int(m.group(2)), int(m.group(3)), tuple(range(s0, s1 + 1)),
                          (False,) * (s1 - s0 + 1), kernel_seconds[key],
                          None if m.group(1) is None else int(m.group(1))))
    return plan


def cluster_estimate(plan, kernel_seconds: dict, compute_1: float, fixed: float,
                     n_workers: int) -> tuple[float, int]:
    """Wall of the study on ``n_workers`` one-thread workers by the batch plan.

    The measured kernel seconds of every batch are scaled by one factor so that they
    add up to the measured compute time of a 1-worker cluster (``compute_1``: its wall
    less ``fixed``, the part that does not parallelise: start-up, planning, the final
    write - measured as the wall of the same command with every batch already stored);
    the batches are grouped into the tasks the backend would submit for that many
    workers (:func:`~vsi_numba.study.cluster.dask_chunks`), and the tasks are list-
    scheduled largest first.  Returns (wall, number of tasks).
    """
    from vsi_numba.study.cluster import chunk_seconds, dask_chunks

    total = sum(kernel_seconds[b.key] for b in plan)
    scale = compute_1 / total
    chunks = dask_chunks(plan, chunk_seconds(plan, n_workers), n_workers)
    times = [scale * sum(kernel_seconds[b.key] for b in c) for c in chunks]
    return fixed + list_schedule(times, n_workers), len(chunks)


def tree_cpu(pids) -> float:
    """User + system CPU seconds so far of the running processes ``pids`` and all their
    descendants (a Dask cluster: scheduler, nannies, workers)."""
    import psutil

    seen, total = set(), 0.0
    for pid in pids:
        try:
            root = psutil.Process(pid)
            procs = [root, *root.children(recursive=True)]
        except psutil.Error:
            continue
        for p in procs:
            if p.pid in seen:
                continue
            seen.add(p.pid)
            try:
                t = p.cpu_times()
            except psutil.Error:
                continue
            total += t.user + t.system
    return total


def same_files(a: Path, b: Path) -> list[str]:
    """Names of the variables (and ``attrs`` for the global attributes but the history
    line) in which two result files differ: [] when bit-identical."""
    import xarray as xr

    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        x, y = x.load(), y.load()
    bad = sorted(set(x.variables) ^ set(y.variables))
    for name in sorted(set(x.variables) & set(y.variables)):
        if not x[name].identical(y[name]):
            bad.append(name)
    ax, ay = dict(x.attrs), dict(y.attrs)
    ax.pop("history", None), ay.pop("history", None)
    if ax != ay:
        bad.append("attrs")
    return bad


# the last measure j written here by ``_measure_j`` (``{"cluster_s": ..., "local_s": ...,
# "grid": ..., "date": ..., ...}``); a run that does not measure j reports it, dated
DASK_CLUSTER = REPO / "reports" / "dask_cluster.json"
J_NAME = ("catalogue: loopback Dask cluster of separate processes (`dask scheduler` + 2 x "
          "`dask worker --nthreads 1`) / local threaded")


def _last_j(res: StudyResult) -> None:
    if not DASK_CLUSTER.exists():
        res.measures.append(Measure(
            "j1", J_NAME, "catalogue", float("nan"), "ratio", 1.1, None,
            f"not measured (no {DASK_CLUSTER.relative_to(REPO)}; `python -m benchmarks "
            "--study --measure j` measures it)"))
        return
    import json

    d = json.loads(DASK_CLUSTER.read_text())
    cl, lo = float(d["cluster_s"]), float(d["local_s"])
    res.measures.append(Measure(
        "j1", J_NAME, str(d.get("grid", "catalogue")), cl / lo, "ratio", 1.1, None,
        f"{fmt_s(cl)} / {fmt_s(lo)}, not re-run: last measured {d.get('date', 'undated')} "
        f"(load {d.get('load', 'n/a')}), read from {DASK_CLUSTER.relative_to(REPO)}"))


def _measure_j(b: Bench | None, res: StudyResult, config: Path = STUDY3,
               grid: str = "catalogue, 51,870 runs"):
    """The catalogue on a loopback cluster of separate processes (``dask scheduler`` + 1 or
    2 ``dask worker --nthreads 1``, ``vsi sweep --scheduler``) and on ``--workers 2``,
    against the local default, in interleaved rounds (wall and CPU of every process);
    the files must be bit-identical; 1 -> 2 worker scaling; 16 workers by the batch plan.

    Measured in normal and full mode and with ``--measure j`` (written to
    :data:`DASK_CLUSTER`); otherwise the last measure is reported from that file.
    """
    if b is None or not b.plan.cluster:
        _last_j(res)
        return
    import datetime as _dt
    import json

    from vsi_numba.study.cluster import LoopbackCluster
    from vsi_numba.study.store import store_path

    warm = b.write(one_run(hslm_config(("HSLM-A1",), (420.0,))), "j_1run")
    n = max(b.plan.repeat_other, 1)

    def sweep(out: Path, scheduler=None, workers=None, keep=False, cluster=None):
        code = ("from vsi_numba.study.runner import execute_study; "
                f"execute_study({str(config)!r}, {str(out)!r}, scheduler={scheduler!r}, "
                f"workers={workers!r}, keep_cases={keep!r}, quiet=True)")
        cmd = [sys.executable, "-c", code]
        if not keep:
            cmd = b.command(config, out, workers)
            if scheduler:
                cmd[-1:-1] = ["--scheduler", scheduler]
        pids = [p.pid for p in cluster._procs] if cluster else []
        c0 = tree_cpu(pids)
        r = run_command(cmd, b.tmp, b.env, rss_limit=b.rss_limit)
        if r.aborted or r.returncode != 0 or not out.exists():
            raise RuntimeError(f"catalogue sweep failed (exit {r.returncode}):\n{r.stderr}")
        return r.wall, r.cpu + tree_cpu(pids) - c0

    names = ("local", "cluster 2", "cluster 1", "workers 2")
    walls: dict = {k: [] for k in names}
    cpus: dict = {k: [] for k in names}
    loads: list = []
    kernel: dict = {}
    fixed = []
    outs: dict = {}
    for i in range(n):  # interleaved: the load of a shared machine hits every variant alike
        b.k += 1
        d = b.tmp / f"j{b.k}"
        d.mkdir()
        if i == 0:
            b.run(warm)
        loads.append(load1())
        for k in names:
            out = d / f"{k.replace(' ', '_')}.nc"
            if k.startswith("cluster"):
                nw = int(k[-1])
                with LoopbackCluster(nw, d / f"cluster{nw}", env=None) as cl:
                    keep = nw == 2 and i == 0
                    w, c = sweep(out, scheduler=cl.address, keep=keep, cluster=cl)
                    if keep:  # per-batch kernel seconds, then the wall with nothing to run
                        for f in store_path(out).glob("batch_*.npz"):
                            with np.load(f) as z:
                                kernel[str(z["batch_key"])] = float(z["kernel_seconds"])
                        fixed.append(sweep(out, scheduler=cl.address, cluster=cl)[0])
            else:
                w, c = sweep(out, workers=2 if k == "workers 2" else None)
            walls[k].append(w)
            cpus[k].append(c)
            if i == 0:
                outs[k] = out
            else:
                out.unlink()
            b.echo(f"[study]   j. {k}: {w:.2f} s wall, {c:.2f} s CPU (load {load1():.2f})")
        loads.append(load1())
        if i == 0:  # bit-identical files, or the ratio is not worth having
            for k in names[1:]:
                bad = same_files(outs["local"], outs[k])
                if bad:
                    raise RuntimeError(f"the {k} file differs from the local one in {bad}")
                outs[k].unlink()
            b.echo("[study]   j. every variable of the Dask files equals the local file's")
    med = {k: statistics.median(v) for k, v in walls.items()}
    cmed = {k: statistics.median(v) for k, v in cpus.items()}
    load = f"{min(loads):.2f}-{max(loads):.2f}"
    for k in names:
        b.rows.append([f"j. catalogue, {k}", grid, f"{fmt_s(med[k])} "
                       f"({', '.join(f'{x:.2f}' for x in walls[k])} s); CPU {fmt_s(cmed[k])}",
                       "", "", load])
    r2, rw = med["cluster 2"] / med["local"], med["workers 2"] / med["local"]
    res.measures.append(Measure(
        "j1", J_NAME, grid, r2, "ratio", 1.1, None,
        f"{fmt_s(med['cluster 2'])} / {fmt_s(med['local'])}; CPU {fmt_s(cmed['cluster 2'])} "
        f"/ {fmt_s(cmed['local'])}; medians of {n} interleaved rounds, load {load}; "
        "files bit-identical"))
    res.measures.append(Measure(
        "j2", "catalogue: `--workers 2` (LocalCluster) / local default", grid, rw, "ratio",
        1.1, None, f"{fmt_s(med['workers 2'])} / {fmt_s(med['local'])}; CPU "
        f"{fmt_s(cmed['workers 2'])}"))
    speedup = med["cluster 1"] / med["cluster 2"]
    res.measures.append(Measure(
        "j3", "catalogue: cluster speed-up 1 -> 2 workers (wall 1 / wall 2)", grid, speedup,
        "ratio", None, None, f"{fmt_s(med['cluster 1'])} / {fmt_s(med['cluster 2'])}"))
    spec_plan = plan_of(kernel)
    f0 = statistics.median(fixed)
    est = {nw: cluster_estimate(spec_plan, kernel, med["cluster 1"] - f0, f0, nw)
           for nw in (2, 16)}
    res.measures.append(Measure(
        "j4", "catalogue: 16-worker cluster by the batch plan (simulated wall)", grid,
        est[16][0], "s", None, None,
        f"{est[16][1]} tasks list-scheduled; speed-up {med['cluster 1'] / est[16][0]:.1f} "
        f"over 1 worker; the same model gives {fmt_s(est[2][0])} for 2 workers "
        f"(measured {fmt_s(med['cluster 2'])})"))
    res.details.append(
        f"Catalogue on Dask (j): fixed part (start-up, planning of the variants, final "
        f"write; the wall with every batch stored) {fmt_s(f0)}; the batches' kernel time "
        f"{fmt_s(sum(kernel.values()))} of the 1-worker compute time "
        f"{fmt_s(med['cluster 1'] - f0)}.  16 workers: the measured per-batch times, "
        f"scaled to that compute time, grouped into the backend's tasks and list-scheduled "
        f"largest first onto 16 workers, plus the fixed part.")
    DASK_CLUSTER.parent.mkdir(parents=True, exist_ok=True)
    DASK_CLUSTER.write_text(json.dumps({
        "cluster_s": med["cluster 2"], "local_s": med["local"], "grid": grid,
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"), "load": load,
        "walls": walls, "cpu": cpus, "fixed_s": f0, "estimate_16_s": est[16][0]},
        indent=1) + "\n")


MEASURES = (("a", _measure_a), ("b", _measure_b), ("c", _measure_c), ("d", _measure_d),
            ("e", _measure_e), ("f", _measure_f), ("g", _measure_g), ("h", _measure_h),
            ("i", _measure_i), ("j", _measure_j))


def run_study_bench(mode: str = "quick", write: bool = True, report: Path | None = None,
                    only=None, echo=print) -> StudyResult:
    """Run the study-level benchmark of ``mode``; write its section of the report."""
    import datetime as _dt

    plan = make_study_plan(mode)
    if only:  # asked for by name: the cold run and the test command run in any mode
        import dataclasses

        plan = dataclasses.replace(plan, cold=plan.cold or "h" in only, tests="i" in only,
                                   cluster=plan.cluster or "j" in only)
    res = StudyResult(mode, date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
                      load_start=load1())
    t0 = time.perf_counter()
    skip = {"a": False, "b": not plan.study1, "c": not plan.ice3_seeds,
            "d": not plan.hist_pilots and not plan.hist_full, "e": not plan.scaling,
            "f": not plan.study1, "g": not plan.study1, "h": not plan.cold,
            "i": False, "j": False}
    with tempfile.TemporaryDirectory(prefix="vsi_study_bench_") as tmp:
        bench = Bench(plan, Path(tmp), echo)
        bench.rows = res.commands
        for key, fn in MEASURES:
            if (only and key not in only) or skip[key]:
                continue
            echo(f"[study] measure {key} ... (load {load1():.2f})")
            try:
                fn(bench, res)
            except Exception as exc:  # noqa: BLE001 - the report must still be written
                import traceback

                res.errors.append(f"measure {key}: "
                                  + "".join(traceback.format_exception(exc))[-3000:])
                echo(f"[study] measure {key} FAILED: {exc}")
        overhead = max(bench.sampler_cpu, default=float("nan"))
    res.seconds = time.perf_counter() - t0
    res.load_end = load1()
    res.details.insert(0, f"RSS sampler cost: at most {100 * overhead:.1f} % of one core "
                          "during a measured command (CPU time of the sampling thread / wall).")
    if write and only and report is None:
        # a partial run must not replace the complete section of the shared report
        echo("[study] partial run (--measure): reports/benchmarks.md left as it is; give "
             "--report PATH to write this section elsewhere")
    elif write:
        write_section(Path(report) if report else REPO / "reports" / "benchmarks.md",
                      markdown(res))
        echo("[study] wrote the study section of the report")
    return res


# ---------------------------------------------------------------------------- report


def markdown(res: StudyResult) -> str:
    m = machine_info()
    y = res.yardstick
    flag = "" if res.mode == "normal" else " --" + res.mode
    lines = [
        BEGIN,
        "## Study level: whole `vsi sweep` commands",
        "",
        f"Written by `python -m benchmarks --study{flag}`"
        f" on {res.date} (mode **{res.mode}**, {res.seconds:.0f} s; load {res.load_start:.2f} at"
        f" start, {res.load_end:.2f} at end; git {m['git_commit']}; {m['cores']} cores).",
        "",
        "Each command is `python -m vsi_numba.cli sweep CONFIG -o OUT [--workers 2] --quiet`, "
        "run as a subprocess on a config written to a temporary directory, after a warm-up "
        "run of the same config on a 1-run grid (not in smoke mode).  *wall*: the whole "
        "command.  *peak RSS*: maximum over samples every 20 ms of the summed `VmRSS` of "
        "the command and all its descendants (local workers, Dask scheduler/nannies/"
        "workers; pages shared between processes count once per process).  Medians over "
        "the repetitions listed below.  Verdicts are computed from these numbers; ratios "
        "come from measurements of this run.",
        "",
        md_table(HEADER, [mm.cells() for mm in res.measures]),
        "",
    ]
    if y:
        lines += [
            f"**Yardstick** (`benchmarks/yardstick.py`, numpy/scipy, one process): "
            f"{y['runs']} runs in {fmt_s(y['wall'])} wall ({fmt_s(y['cpu'])} CPU), "
            "compute only (imports and the axle tables excluded; median of "
            "repetitions after an untimed call).  Each mode is the Newmark average-"
            "acceleration recursion as a `scipy.signal.bilinear` + `lfilter` filter over the "
            "modal load history; the engine (HHT alpha = 0) runs the same recursion, so the "
            "envelopes agree to round-off (`tests/test_benchmarks.py` requires 1e-9 against "
            "`simulate`)"
            + (f"; the timed `vsi sweep` output agrees with the yardstick to "
               f"{y['agreement_sweep']:.1e}" if "agreement_sweep" in y else "") + ".",
            "",
        ]
    if res.commands:
        lines += ["**Commands measured**", "", md_table(COMMAND_HEADER, res.commands), ""]
    if res.scaling:
        lines += ["**Scaling** (moving-force HSLM sweeps on the yardstick's beam, 10 modes, "
                  "dt 1 ms, mid-span output, envelopes only; finer speed steps between 140 "
                  "and 420 km/h; one run each)", "", md_table(SCALING_HEADER, res.scaling), ""]
    for d in res.details:
        lines += [d, ""]
    for e in res.errors:
        lines += ["**Failed:**", "", "```", e.strip(), "```", ""]
    lines.append(END)
    return "\n".join(lines) + "\n"


def extract_section(text: str) -> str:
    """The study section of a report text ('' if none)."""
    i, j = text.find(BEGIN), text.find(END)
    return text[i:j + len(END)] + "\n" if 0 <= i < j else ""


def write_section(path: Path, section: str) -> None:
    """Replace the study section of the report at ``path`` (or append it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = path.read_text() if path.exists() else "# vsi_numba benchmarks\n"
    old = extract_section(text)
    if old:
        text = text.replace(old.rstrip("\n"), section.rstrip("\n"))
    else:
        text = text.rstrip("\n") + "\n\n" + section
    path.write_text(text if text.endswith("\n") else text + "\n")


__all__ = ["StudyPlan", "StudyResult", "make_study_plan", "run_study_bench", "text_table",
           "tree_rss", "run_command", "markdown", "write_section", "extract_section"]
