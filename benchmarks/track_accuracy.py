"""Accuracy of the default damped track on rough track, against a converged damped rail.

The case: the leading end car of the ICE3 (AVE S-103 coach 1, the ``[whole]`` values of
``vsi_numba/data/trains.toml``, 4 wheelsets of 1800 kg) at 250-400 km/h over a 20 m
simply supported span (f1 = 5 Hz, 15 t/m, 1 % damping, 3 modes), German-low track with
wavelengths 1-80 m (seeds 1-3, the profile ramped in over the 4 m after the first axle's
start so the static start is on level track), linearised Hertz contact (G = 2.65e-8
m N^-2/3), the default damped track (k = 8.51e7 N/m^2, c = 1.96e5 N s/m^2) with a
massless rail and with a 120 kg/m rail.

The engine runs through the config path (``load_config`` of a TOML written here, the
profile given as a CSV file, then :func:`vsi_numba.solver.simulate.simulate` on what
the config builds).  The reference is ``tests/reference.py``'s
:func:`vehicle_on_modal_rail`: the continuous rail (sine modes down to 0.4 m wavelength)
on the damped foundation over the deck's modes, BDF2 at dt = 1e-4 s (converged: 0.2 m
and 5e-5 s move its dQ/Q0 by 1e-4 and its peak deck acceleration by 0.02 %).

"before" is the first-order element (k_t = 1 / G(0), c_t = 3/4 (c / k) k_t,
m_t = 3/4 (m' / k) k_t); "after" the fitted element the package uses
(:meth:`vsi_numba.model.track.ElasticTrack.wheel_element`).

Usage: ``python -m benchmarks.track_accuracy [--quick] [--write docs/track_accuracy.md]``
(the full grid, 18 cases, takes a few minutes on one core).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

L_SPAN, M_DECK, F1, ZETA, N_MODES = 20.0, 15000.0, 5.0, 0.01, 3
EI_DECK = (2 * F1 * L_SPAN**2 / np.pi) ** 2 * M_DECK
HERTZ_G = 2.65e-8
APPROACH = 6.0
DT = 2.5e-4
FREE = 0.05
ICE3_C1 = dict(body_mass=47800.0, body_pitch_inertia=1957888.0, bogie_mass=3500.0,
               bogie_pitch_inertia=1715.0, wheelset_mass=1800.0, bogie_spacing=17.375,
               wheelbase=2.5, primary_stiffness=2.4e6, primary_damping=20000.0,
               secondary_stiffness=7.0e5, secondary_damping=40000.0)
OFFSETS = np.array([0.0, 2.5, 17.375, 19.875])


def reference_module():
    """tests/reference.py (numpy/scipy only), loaded from its path."""
    spec = importlib.util.spec_from_file_location("reference", ROOT / "tests" / "reference.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["reference"] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def profile_samples(seed: int):
    """German-low realisation (1-80 m) as samples (x, r), zero up to the first axle's
    start and ramped in over the next 4 m (cosine)."""
    from vsi_numba.model.irregularity import psd_realisation

    x, r, _ = psd_realisation("german_low", 1.0, 80.0, seed, -APPROACH - 30.0,
                              L_SPAN + 60.0, dx=0.05)
    ramp = np.clip((x + APPROACH) / 4.0, 0.0, 1.0)
    return x, r * 0.5 * (1 - np.cos(np.pi * ramp))


def config(profile_csv: Path, speed_kmh: float, rail_mass: float, **solver) -> dict:
    """The case as a config (TOML table)."""
    return {
        "title": "ICE3 end car on a damped track",
        "bridge": {"kind": "simply_supported", "spans": [L_SPAN], "EI": EI_DECK,
                   "mass_per_length": M_DECK, "n_modes": N_MODES, "damping_ratio": ZETA,
                   "output_points": [L_SPAN / 2]},
        "train": {"vehicles": [{"kind": "car", **ICE3_C1}]},
        "track": {"rail_mass": rail_mass},
        "contact": {"model": "hertz_linear", "hertz_coefficient": HERTZ_G},
        "irregularity": {"kind": "file", "path": str(profile_csv)},
        "solver": {"dt": DT, "approach": APPROACH, "free_vibration": FREE, **solver},
        "study": {"speeds_kmh": [speed_kmh], "output": "results/track.nc"},
    }


def toml_text(data: dict) -> str:
    """A minimal TOML writer for :func:`config`'s tables."""
    def val(v):
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(float(v)) if isinstance(v, float) else repr(v)

    lines = [f"title = {val(data['title'])}"]
    for sec, body in data.items():
        if sec == "title":
            continue
        if sec == "train":
            for veh in body["vehicles"]:
                lines.append("[[train.vehicles]]")
                lines += [f"{k} = {val(v)}" for k, v in veh.items()]
            continue
        lines.append(f"[{sec}]")
        lines += [f"{k} = {val(v)}" for k, v in body.items()]
    return "\n".join(lines) + "\n"


def run_engine(workdir: Path, seed: int, speed_kmh: float, rail_mass: float,
               element=None, **solver) -> dict:
    """dQ/Q0 (largest over the wheels) and the peak midspan deck acceleration of the
    engine through the config; ``element`` overrides ``ElasticTrack.wheel_element``."""
    from vsi_numba.config import load_config
    from vsi_numba.model.track import ElasticTrack
    from vsi_numba.solver.simulate import simulate

    csv = workdir / f"profile_{seed}.csv"
    if not csv.exists():
        x, r = profile_samples(seed)
        np.savetxt(csv, np.column_stack([x, r]), delimiter=",", header="x,r", comments="")
    toml = workdir / f"case_{seed}_{speed_kmh:g}_{rail_mass:g}.toml"
    toml.write_text(toml_text(config(csv, speed_kmh, rail_mass, **solver)))
    cfg = load_config(toml)
    train = cfg.trains()[0]
    bridge = cfg.bridge_for(train)
    prof = cfg.irregularities(-200.0, 200.0)[0][1]
    patch = (mock.patch.object(ElasticTrack, "wheel_element", property(element))
             if element is not None else contextlib.nullcontext())
    with patch:
        ds = simulate(bridge, train, speed_kmh / 3.6, profile=prof,
                      settings=cfg.solver_settings(), output_points=[L_SPAN / 2])
    assert int(ds.attrs["status"]) == 0
    return {"dq": float(ds["max_wheel_unloading"].values.max()),
            "acc": float(ds["max_deck_acceleration"].values.max())}


def first_order_element(track):
    """The element before the fit: the receptance's first-order expansion."""
    return track.first_order_element


def run_reference(ref, seed: int, speed_kmh: float, rail_mass: float,
                  wavelength_min: float = 0.4, dt: float = 1e-4) -> dict:
    """The same case on the continuous rail (``vehicle_on_modal_rail``)."""
    import scipy.interpolate

    from vsi_numba.model.track import ElasticTrack

    t = ElasticTrack(rail_mass=rail_mass)
    M, C, K, wd = ref.railway_car_matrices(**ICE3_C1)
    g = 9.81 * np.diag(M).copy()
    g[[1, 3, 5]] = 0.0
    q0 = ref.railway_car_static_axle_loads(
        ICE3_C1["body_mass"], ICE3_C1["bogie_mass"], ICE3_C1["wheelset_mass"],
        ICE3_C1["bogie_spacing"])
    x, r = profile_samples(seed)
    spl = scipy.interpolate.CubicSpline(x, r)
    v = speed_kmh / 3.6
    t_end = (L_SPAN + APPROACH + OFFSETS.max()) / v + FREE
    kc = 1.5 * np.cbrt(np.mean(q0)) / HERTZ_G
    res = ref.vehicle_on_modal_rail(
        L_SPAN, EI_DECK, M_DECK, N_MODES, ZETA, t.foundation_stiffness,
        t.foundation_damping, t.rail_EI, rail_mass, M, C, K, g, wd, OFFSETS, kc, spl, v,
        -APPROACH, t_end, points=(L_SPAN / 2,), wavelength_min=wavelength_min, dt=dt)
    return {"dq": float((1 - res.force.min(axis=0) / res.static_force).max()),
            "acc": float(np.abs(res.deck_acceleration[:, 0]).max())}


def grid(quick: bool):
    seeds = (1,) if quick else (1, 2, 3)
    speeds = (400.0,) if quick else (250.0, 325.0, 400.0)
    return [(s, v, m) for m in (0.0, 120.0) for s in seeds for v in speeds]


def table(rows) -> str:
    head = ("| seed | km/h | rail kg/m | dQ/Q0 ref | before | after | error after | "
            "acc ref m/s2 | before | after | error after |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n")
    body = ""
    for r in rows:
        body += (f"| {r['seed']} | {r['speed']:g} | {r['rail_mass']:g} | {r['ref']['dq']:.3f} | "
                 f"{r['before']['dq']:.3f} | {r['after']['dq']:.3f} | "
                 f"{r['after']['dq'] - r['ref']['dq']:+.3f} | {r['ref']['acc']:.3f} | "
                 f"{r['before']['acc']:.3f} | {r['after']['acc']:.3f} | "
                 f"{100 * (r['after']['acc'] / r['ref']['acc'] - 1):+.1f} % |\n")
    return head + body


def summary(rows) -> str:
    out = []
    for m in sorted({r["rail_mass"] for r in rows}):
        sel = [r for r in rows if r["rail_mass"] == m]
        for key in ("before", "after"):
            edq = np.array([r[key]["dq"] - r["ref"]["dq"] for r in sel])
            eac = np.array([r[key]["acc"] / r["ref"]["acc"] - 1 for r in sel])
            out.append(f"- rail {m:g} kg/m, {key}: dQ/Q0 error {edq.min():+.3f} .. "
                       f"{edq.max():+.3f}, deck acceleration {100 * eac.min():+.1f} .. "
                       f"{100 * eac.max():+.1f} %")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="seed 1 at 400 km/h only")
    ap.add_argument("--write", type=Path, help="write the table into this markdown file "
                    "(between the TABLE markers)")
    a = ap.parse_args(argv)
    ref = reference_module()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for seed, speed, mass in grid(a.quick):
            t0 = time.time()
            row = {"seed": seed, "speed": speed, "rail_mass": mass,
                   "ref": run_reference(ref, seed, speed, mass),
                   "before": run_engine(work, seed, speed, mass, first_order_element),
                   "after": run_engine(work, seed, speed, mass)}
            rows.append(row)
            print(f"seed {seed} {speed:g} km/h rail {mass:g}: ref {row['ref']}, before "
                  f"{row['before']}, after {row['after']} ({time.time() - t0:.1f} s)",
                  flush=True)
    text = table(rows) + "\n" + summary(rows) + "\n"
    print(text)
    if a.write:
        doc = a.write.read_text()
        start, end = "<!-- TABLE START -->\n", "<!-- TABLE END -->"
        i, j = doc.index(start) + len(start), doc.index(end)
        a.write.write_text(doc[:i] + text + doc[j:])


if __name__ == "__main__":
    main()
