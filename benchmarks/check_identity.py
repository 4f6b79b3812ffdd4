"""Results of the engine, compared between two versions of the code.

A handful of small configurations that cover the interaction path (elastic damped track
with the ICE3, rigid track with impacts and deck ends, steps retried in substeps, no step
split, Hertz contact, a continuous FE deck, a nonlinear suspension, lift-off, a massive
rail) and the moving-force kernel (sine modes with load effects, the first axle on the
deck at t = 0, a continuous deck, no load effects) are run with ``vsi sweep``'s
engine (``run_study``, histories on) into one netCDF file each::

    python -m benchmarks.check_identity write DIR        # with the code on PYTHONPATH
    python -m benchmarks.check_identity compare DIR_A DIR_B

``compare`` checks every variable of every file: equal bit for bit, or within ``--rtol``
(1e-12 by default) of the largest magnitude of the variable (NaN where NaN).  Run
``write`` once with the reference code (its own NUMBA_CACHE_DIR) and once with the new
code, then ``compare``.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path

import numpy as np

_SS = {"kind": "simply_supported", "spans": [20.0], "EI": 2.43e10,
       "mass_per_length": 15000.0, "damping_ratio": 0.01, "n_modes": 4,
       "output_points": [10.0]}
_PSD = {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
        "wavelength_max": 80.0, "seeds": [1]}
_SOLVER = {"dt": 1e-3, "approach": 5.0, "free_vibration": 0.2}
_SPRUNG = {"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6, "damping": 1e4,
           "wheel_mass": 1000.0}


def _case(title, bridge=None, train=None, irregularity=None, solver=None, speeds=(250.0,),
          study_extra=None, **extra):
    cfg = {
        "title": title,
        "bridge": copy.deepcopy(bridge or _SS),
        "train": copy.deepcopy(train or {"preset": "ICE3", "model": "interaction"}),
        "irregularity": copy.deepcopy(irregularity or _PSD),
        "solver": {**_SOLVER, **(solver or {})},
        "study": {"speeds_kmh": list(speeds), "output": "results.nc",
                  "save_time_histories": True, **(study_extra or {})},
    }
    cfg.update(copy.deepcopy(extra))
    return cfg


def cases() -> dict:
    """name -> config dict (small: a few modes, short decks, 0.2 s of free vibration)."""
    dip = {"kind": "cosine", "depth": 0.02, "wavelength": 2.0, "position": 8.0}
    ice3 = {"preset": "ICE3", "model": "interaction"}
    hslm = {"preset": ["HSLM-A1", "HSLM-A4"], "model": "moving_force"}
    smooth = {"kind": "none"}
    return {
        # the default (elastic, damped) track, 8 cars, two speeds
        "ice3_damped": _case("ICE3 on the damped elastic track", speeds=(250.0, 330.0)),
        # rigid track: landings and deck-end crossings are impacts
        "rigid_ice3": _case("ICE3 on the rigid track", train=ice3,
                            irregularity={**_PSD, "spectrum": "german_high"},
                            speeds=(300.0, 380.0), track={"model": "rigid"}),
        # Hertz contact on the rigid track
        "hertz": _case("Hertz contact", train=ice3, speeds=(300.0,),
                       track={"model": "rigid"},
                       contact={"model": "hertz", "hertz_coefficient": 4.57e-8}),
        # continuous FE deck, 2 spans, elastic track
        "continuous": _case("2-span continuous deck", train=ice3, speeds=(280.0,),
                            bridge={"kind": "continuous", "spans": [12.0, 12.0],
                                    "EI": 2e10, "mass_per_length": 12000.0,
                                    "damping_ratio": 0.015, "n_modes": 4,
                                    "elements_per_span": 10, "output_points": [6.0, 18.0]}),
        # a sprung mass with a bump stop over a dip on the damped track
        "bump_stop": _case("bump stop", speeds=(200.0,),
                           train={"vehicles": [{**_SPRUNG, "bump_stop": {
                               "gap": 0.002, "stiffness": 5e6}}]},
                           irregularity={"kind": "cosine", "depth": 0.01, "wavelength": 3.0,
                                         "position": 8.0}),
        # a sprung mass losing contact over a deep short dip on the rigid track
        "lift_off": _case("lift-off", speeds=(200.0,), train={"vehicles": [_SPRUNG]},
                          irregularity=dip, track={"model": "rigid"}),
        # steps retried in 2, 4, ... substeps (one contact iteration allowed: the
        # deck-end crossings on the rigid track fail, then a later step for good)
        "retries": _case("retried steps", train=ice3, speeds=(300.0,),
                         irregularity={**_PSD, "spectrum": "german_high"},
                         track={"model": "rigid"},
                         solver={"max_iterations": 1, "max_subdivisions": 4}),
        # no step split (max_subdivisions = 0): a deck-end crossing is one step
        "no_split": _case("crossings not split", train=ice3, speeds=(300.0,),
                          irregularity={**_PSD, "spectrum": "german_high"},
                          track={"model": "rigid"}, solver={"max_subdivisions": 0}),
        # massive rail (damped and massive track elements)
        "rail_mass": _case("massive rail", train=ice3, speeds=(300.0,),
                           track={"rail_mass": 120.0}),
        # trains of moving forces (their own kernel): load effects on, sine modes ...
        "mf_hslm": _case("HSLM moving forces", train=hslm, irregularity=smooth,
                         speeds=(200.0, 300.0, 390.0), solver={"hht_alpha": -0.05}),
        # ... the first axle on the deck at t = 0 ...
        "mf_approach0": _case("HSLM moving forces from x = 0", train=hslm,
                              irregularity=smooth, speeds=(250.0,),
                              solver={"approach": 0.0, "free_vibration": 0.0}),
        # ... a continuous FE deck (the loads summed one by one), no load effects
        "mf_continuous": _case("moving forces on a 2-span deck", train=hslm,
                               irregularity=smooth, speeds=(280.0,),
                               bridge={"kind": "continuous", "spans": [12.0, 15.0],
                                       "EI": 2e10, "mass_per_length": 12000.0,
                                       "damping_ratio": 0.015, "n_modes": 5,
                                       "elements_per_span": 10,
                                       "output_points": [6.0, 20.0]}),
        "mf_no_load_effects": _case("moving forces, no load effects", train=hslm,
                                    irregularity=smooth, speeds=(300.0,),
                                    study_extra={"load_effects": False}),
    }


def write(out_dir: Path, only=None) -> None:
    from vsi_numba.study.runner import run_study

    out_dir.mkdir(parents=True, exist_ok=True)
    for name, cfg in cases().items():
        if only and name not in only:
            continue
        t0 = time.perf_counter()
        run_study(cfg, out_dir / f"{name}.nc", backend="serial", fresh=True)
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)


def _compare_var(a, b, rtol):
    if a.dtype.kind not in "fc":
        return 0.0 if np.array_equal(a, b) else np.inf
    if a.shape != b.shape:
        return np.inf
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    if not np.array_equal(nan_a, nan_b):
        return np.inf
    if np.array_equal(a[~nan_a], b[~nan_b]):
        return 0.0
    ref = np.nanmax(np.abs(a)) if a.size else 0.0
    d = np.nanmax(np.abs(a - b))
    return d / ref if ref > 0 else np.inf


def compare(dir_a: Path, dir_b: Path, rtol: float) -> int:
    import xarray as xr

    bad = 0
    for name in cases():
        pa, pb = dir_a / f"{name}.nc", dir_b / f"{name}.nc"
        if not (pa.exists() and pb.exists()):
            print(f"{name}: MISSING")
            bad += 1
            continue
        with xr.open_dataset(pa) as da, xr.open_dataset(pb) as db:
            names = sorted(set(da.variables) | set(db.variables))
            worst, n_bits, diffs = 0.0, 0, []
            for v in names:
                if v not in da.variables or v not in db.variables:
                    diffs.append(f"{v} missing")
                    continue
                e = _compare_var(np.asarray(da[v].values), np.asarray(db[v].values), rtol)
                if e == 0.0:
                    n_bits += 1
                worst = max(worst, e)
                if e > rtol:
                    diffs.append(f"{v} {e:.3g}")
            ok = not diffs
            bad += not ok
            print(f"{name}: {len(names)} variables, {n_bits} bit for bit, worst relative "
                  f"{worst:.3g} {'OK' if ok else 'DIFFER: ' + ', '.join(diffs)}")
    return bad


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("dir", type=Path)
    w.add_argument("--only", nargs="*")
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--rtol", type=float, default=1e-12)
    args = p.parse_args(argv)
    if args.cmd == "write":
        write(args.dir, args.only)
        return 0
    return 1 if compare(args.a, args.b, args.rtol) else 0


if __name__ == "__main__":
    sys.exit(main())
