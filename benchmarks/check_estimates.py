"""``vsi check``'s estimates against measured ``vsi sweep`` runs: time (CPU and wall),
peak RSS, results file size and peak disk (output + case store, sampled every 20 ms).

Run::

    NUMBA_CACHE_DIR=.numba_cache .venv/bin/python -m benchmarks.check_estimates [NAME ...]

Prints a Markdown table (study, quantity, estimated, measured, estimated/measured), the
table of ``docs/check_estimates.md``.  Each study is swept once to warm the numba cache
(not measured), then measured in a fresh interpreter.  The studies are the bundled ones
(``studies/*/study.toml``, ``configs/*.toml``) whose estimated CPU time is below
``--max-seconds`` (default 60 s), and long axle lists (moving forces, histories off:
2,000 axles; 20,000 with ``--long``).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_MEASURE = """\
import resource, sys, time
t0 = time.perf_counter()
from vsi_numba.cli import app
rc = app(['sweep', sys.argv[1], '-o', sys.argv[2], '-q', '--fresh'], standalone_mode=False)
r = resource.getrusage(resource.RUSAGE_SELF)
hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')]
print('MEASURED', int(hwm[0]) * 1024, r.ru_utime + r.ru_stime, time.perf_counter() - t0,
      file=sys.stderr)
"""


def axle_list_config(directory: Path, n_axles: int) -> Path:
    """A moving-force axle list of ``n_axles`` 150 kN axles every 2.5 m on a 20 m span,
    two speeds, time histories off."""
    csv = directory / f"axles_{n_axles}.csv"
    csv.write_text("position,load\n" + "".join(f"{2.5 * i:.3f},150\n"
                                               for i in range(n_axles)))
    path = directory / f"axles_{n_axles}.toml"
    path.write_text(f"""title = "{n_axles} axles"
[bridge]
kind = "simply_supported"
spans = [20.0]
EI = 3.5e10
mass_per_length = 15000.0
damping_ratio = 0.02
n_modes = 3
[train]
axles = {{ file = "{csv.name}", load_unit = "kN" }}
[solver]
dt = 1e-3
approach = 5.0
free_vibration = 0.1
[study]
speeds_kmh = [200.0, 300.0]
output = "axles.nc"
save_time_histories = false
""")
    return path


def _tree_bytes(paths) -> int:
    total = 0
    for p in paths:
        try:
            if p.is_dir():
                for q in p.rglob("*"):
                    try:
                        total += q.stat().st_size if q.is_file() else 0
                    except OSError:
                        pass
            elif p.is_file():
                total += p.stat().st_size
        except OSError:
            pass
    return total


def measure(config: Path, out: Path) -> dict:
    """Sweep ``config`` into ``out`` in a fresh interpreter: peak RSS (bytes), CPU and
    wall time (s), results file and peak disk (bytes) of the output's directory."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    before = {p.name for p in out.parent.iterdir()}
    peak = [0]
    done = threading.Event()

    def sample():
        while not done.is_set():
            new = [p for p in out.parent.iterdir() if p.name not in before]
            peak[0] = max(peak[0], _tree_bytes(new))
            time.sleep(0.02)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    proc = subprocess.run([sys.executable, "-c", _MEASURE, str(config), str(out)],
                          capture_output=True, text=True, env=env, check=False)
    done.set()
    th.join()
    m = re.search(r"MEASURED (\d+) ([\d.]+) ([\d.]+)", proc.stderr)
    if m is None:
        raise RuntimeError(f"{config}: {proc.stderr[-2000:]}")
    return {"memory": float(m.group(1)), "cpu": float(m.group(2)),
            "wall": float(m.group(3)), "file": float(out.stat().st_size),
            "peak_disk": float(peak[0])}


def main(argv=None) -> int:
    """Print the table; return 0."""
    from vsi_numba.cli.check import estimate_study
    from vsi_numba.config import load_config

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="only these studies (substring of the path)")
    ap.add_argument("--max-seconds", type=float, default=60.0)
    ap.add_argument("--long", action="store_true", help="also the 20,000-axle list")
    args = ap.parse_args(argv)
    scratch = Path(tempfile.mkdtemp(prefix="vsi_check_estimates_"))
    configs = sorted(ROOT.glob("studies/*/study.toml")) + sorted(ROOT.glob("configs/*.toml"))
    configs += [axle_list_config(scratch, n) for n in ((2000, 20000) if args.long
                                                       else (2000,))]
    rows = []
    print("| study | quantity | estimated | measured | ratio |")
    print("|---|---|---|---|---|")
    for config in configs:
        label = (config.parent.name if config.name == "study.toml" else config.stem)
        if args.names and not any(n in str(config) for n in args.names):
            continue
        cfg = load_config(config)
        est = estimate_study(cfg)
        if est.cpu_seconds > args.max_seconds:
            print(f"| {label} | (skipped: estimated {est.cpu_seconds:.0f} s CPU) | | | |")
            continue
        d = scratch / label
        d.mkdir(exist_ok=True)
        measure(config, d / "warm.nc")  # fills the numba cache; not measured
        (d / "warm.nc").unlink()
        got = measure(config, d / "out.nc")
        for what, e, unit in (("CPU time", est.cpu_seconds, "s"),
                              ("wall time", est.seconds, "s"),
                              ("peak RSS", est.memory_bytes, "MB"),
                              ("results file", est.disk_bytes, "MB"),
                              ("peak disk", est.peak_disk_bytes, "MB")):
            m = got[{"CPU time": "cpu", "wall time": "wall", "peak RSS": "memory",
                     "results file": "file", "peak disk": "peak_disk"}[what]]
            f = 2.0**20 if unit == "MB" else 1.0
            print(f"| {label} | {what} | {e / f:.3g} {unit} | {m / f:.3g} {unit} | "
                  f"{e / m:.2f} |", flush=True)
            rows.append((label, what, e, m))
        (d / "out.nc").unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
