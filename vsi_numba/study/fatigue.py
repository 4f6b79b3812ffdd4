"""The fatigue runs of a study with a ``[fatigue]`` section (:mod:`vsi_numba.config.fatigue`).

Each train of the traffic runs once at its speed over the configuration's bridge (its
own track, solver settings and the first irregularity realisation), with the bending
moment kept at the fatigue sections only.  The run goes on after the last axle has left
the deck until the free vibration has decayed (below): the cycles of the free
vibration are part of the count (EN 1991-2 6.4.6.6 [R]).  The moment history of each
section becomes a stress history sigma = M / W, which is counted by rainflow and
reduced at once to a histogram of ranges and to Miner's damage per passage; the
history itself is dropped, so the memory does not grow with the traffic or the design
life.  The results file gets the histograms (dims ``fatigue_traffic``,
``fatigue_section``, ``stress_range``), the damage per train and the total damage
over the design life (``fatigue_damage``), and the traffic's tonnage (the report computes
the lambda-method value from it, :mod:`vsi_numba.analysis.report.fatigue`).

Studs (``[[fatigue.studs]]``): the same runs give the vertical shear V(t) at the studs'
x (output points after the sections', so the sections' moments are those without them);
the stud shear stress tau = V S s / (I n pi d^2 / 4)
(:func:`~vsi_numba.model.fatigue.stud_stress_per_shear`) is counted and summed on the
stud curve (:class:`~vsi_numba.model.fatigue.StudCurve`) the same way
(``fatigue_stud_*``, dim ``fatigue_stud``).

Variants (``study.vary``): the traffic runs over each variant's bridge (the variant's
own configuration); the results of :data:`PER_VARIANT` get a leading ``variant``
dimension, the rest is the same in every variant (``[fatigue]`` is not varied).

When the free vibration has decayed
    Every mode decays as exp(-zeta_j omega_j t).  The run continues for
    ``t = ln(1 / r) / min_j(zeta_j omega_j)`` after the last axle leaves, with r the
    code profile's ``fatigue_free_vibration_decay`` (1 %): every mode is then below 1 %
    of its amplitude at the exit, and so are the ranges it still adds (far below any
    cut-off limit Delta sigma_L = 0.4 Delta sigma_C).  The time is capped at
    :data:`MAX_FREE_VIBRATION` (an undamped deck never decays; the results record the
    time used).
"""

from __future__ import annotations

import dataclasses
import time as _time

import numpy as np

from vsi_numba.config.limits import MAX_FATIGUE_FREE_VIBRATION
from vsi_numba.model import fatigue as fat

#: Longest free vibration of a fatigue run (s).
MAX_FREE_VIBRATION = MAX_FATIGUE_FREE_VIBRATION
#: Gravity used to turn the trains' loads into tonnes (lambda_2).
G = 9.81


class FatigueError(RuntimeError):
    """The fatigue runs cannot be made (the message says why)."""


def _train(row, base_dir):
    from vsi_numba.config.fatigue import fatigue_train

    return fatigue_train(row, base_dir)


#: Results that depend on the bridge: with ``study.vary`` they get a leading ``variant``
#: dimension (one row per variant); the rest (sections, studs, traffic) is the same in
#: every variant.
PER_VARIANT = ("histogram", "damage_per_passage", "damage_per_train", "damage",
               "max_range", "cycles", "equivalent", "free_vibration", "stud_histogram",
               "stud_damage_per_passage", "stud_damage_per_train", "stud_damage",
               "stud_max_range", "stud_equivalent")


def fatigue_runs(cfg, progress=None) -> dict:
    """Run the traffic of ``cfg``'s ``[fatigue]`` and count the stress cycles; with
    ``study.vary``, over each variant's bridge (its own configuration), stacked along a
    leading variant axis (:data:`PER_VARIANT`).

    Returns
    -------
    dict
        Arrays (see :func:`write`) and ``seconds`` (wall time of the runs);
        ``n_variants`` (0 without variants).
    """
    t0 = _time.perf_counter()
    if not getattr(cfg, "variants", None):
        out = _fatigue_runs(cfg, progress)
        out["n_variants"] = 0
        return out
    runs = [_fatigue_runs(vcfg, progress) for _, vcfg in cfg.variants]
    out = dict(runs[0])
    for k in PER_VARIANT:
        if k in out:
            out[k] = np.stack([r[k] for r in runs])
    out["n_variants"] = len(runs)
    out["seconds"] = _time.perf_counter() - t0
    return out


def _fatigue_runs(cfg, progress=None) -> dict:
    """:func:`fatigue_runs` of one bridge (a configuration without variants)."""
    from vsi_numba.code_profile import resolve
    from vsi_numba.config.fatigue import traffic_of
    from vsi_numba.config.physics import train_extent
    from vsi_numba.model.irregularity import profile_range
    from vsi_numba.solver.simulate import simulate

    t0 = _time.perf_counter()
    section = cfg.resolved()["fatigue"]
    profile = resolve(cfg.code_profile)
    traffic = traffic_of(section)
    secs = section["sections"]
    xs = np.array([s["x"] for s in secs], float)
    w = np.array([s["section_modulus"] for s in secs], float)
    curves = [fat.SNCurve.of(s["detail_category"], s["gamma_Mf"], profile) for s in secs]
    gff = np.array([s["gamma_Ff"] for s in secs], float)
    years = float(section["design_life_years"])
    settings = cfg.solver_settings()
    trains = [_train(r, cfg.base_dir) for r in traffic]
    base = cfg.build_bridge()
    if base.static is None:
        raise FatigueError("the bridge gives no bending moments (an imported modes table "
                           "without a deck line): [fatigue] needs a beam deck or matrices")
    frees = [min(fat.decay_time(cfg.bridge_for(t).omega, cfg.bridge_for(t).damping,
                                profile["fatigue_free_vibration_decay"]), MAX_FREE_VIBRATION)
             for t in trains]
    studs = section.get("studs") or []
    xv = np.array([s["x"] for s in studs], float)
    per_v = np.array([fat.stud_stress_per_shear(s["first_moment"], s["second_moment"],
                                                s["row_spacing"], s["per_row"],
                                                s["diameter"]) for s in studs], float)
    stud_curves = [fat.StudCurve.of(s["gamma_Mf"], profile) for s in studs]
    gfv = np.array([s["gamma_Ff"] for s in studs], float)
    n_v = xv.size
    # the studs' shear at points of their own after the sections' (the sections' moments
    # are those of the sections alone)
    points = np.concatenate([xs, xv]) if n_v else xs
    x_range = profile_range(base.length, [train_extent(t) for t in trains],
                            settings.approach, max(frees))
    track = cfg.irregularities(*x_range)[0][1]
    n_t, n_s = len(traffic), xs.size
    hist = np.zeros((n_t, n_s, fat.N_BINS))
    per_pass = np.zeros((n_t, n_s))
    max_range = np.zeros((n_t, n_s))
    cycles = np.zeros((n_t, n_s))
    free = np.zeros(n_t)
    tonnes = np.zeros(n_t)
    v_hist = np.zeros((n_t, n_v, fat.N_BINS))
    v_pass = np.zeros((n_t, n_v))
    v_max = np.zeros((n_t, n_v))
    for i, (row, train) in enumerate(zip(traffic, trains, strict=True)):
        bridge = cfg.bridge_for(train)
        fv = free[i] = frees[i]
        run = dataclasses.replace(settings, free_vibration=fv)
        sim = simulate(bridge, train, row["speed_kmh"] / 3.6, track, run,
                       output_points=points, save_histories=True)
        if int(sim.attrs.get("status", 0)) != 0:
            raise FatigueError(f"fatigue run of {row['train']} at {row['speed_kmh']:g} km/h "
                               f"failed: {sim.attrs.get('message', '')}")
        moment = np.asarray(sim["bending_moment"].values, float)[:, :n_s]  # N m
        shear = np.asarray(sim["shear_force"].values, float)[:, n_s:] if n_v else None
        del sim
        for j in range(n_v):
            tau = shear[:, j] * per_v[j] / 1e6  # MPa
            r, c = fat.rainflow_cycles(tau)
            v_hist[i, j] = fat.histogram(r, c)
            v_pass[i, j] = stud_curves[j].damage(gfv[j] * r, c)
            v_max[i, j] = r.max() if r.size else 0.0
        del shear
        for j in range(n_s):
            stress = moment[:, j] / w[j] / 1e6  # MPa
            r, c = fat.rainflow_cycles(stress)
            hist[i, j] = fat.histogram(r, c)
            per_pass[i, j] = curves[j].damage(gff[j] * r, c)
            max_range[i, j] = r.max() if r.size else 0.0
            cycles[i, j] = c.sum()
        del moment
        loads = sum(float(np.sum(v.loads)) for v in train.vehicles)
        if any(v.n_dof for v in train.vehicles):
            from vsi_numba.model.library import moving_force_train

            loads = sum(float(np.sum(v.loads)) for v in moving_force_train(train).vehicles)
        tonnes[i] = loads / G / 1e3
        if progress is not None:
            progress(i + 1, n_t, row)
    per_day = np.array([r["per_day"] for r in traffic], float)
    passages = per_day * 365.0 * years
    damage_per_train = per_pass * passages[:, None]
    damage = damage_per_train.sum(axis=0)
    equivalent = np.array([curves[j].equivalent_range(damage[j]) / gff[j]
                           for j in range(n_s)])
    studs_out = {}
    if n_v:
        v_train = v_pass * passages[:, None]
        v_damage = v_train.sum(axis=0)
        studs_out = {
            "stud_x": xv, "stud_names": [s.get("name") or f"studs at x = {x:g} m"
                                         for s, x in zip(studs, xv, strict=True)],
            "stud_stress_per_shear": per_v,
            **{f"stud_{k}": np.array([s[k] for s in studs], float)
               for k in ("diameter", "per_row", "row_spacing", "first_moment",
                         "second_moment", "gamma_Ff", "gamma_Mf")},
            "stud_category": np.array([c.category for c in stud_curves], float),
            "stud_slope": np.array([c.m for c in stud_curves], float),
            "stud_histogram": v_hist, "stud_damage_per_passage": v_pass,
            "stud_damage_per_train": v_train, "stud_damage": v_damage,
            "stud_max_range": v_max,
            "stud_equivalent": np.array([stud_curves[j].equivalent_range(v_damage[j])
                                         / gfv[j] for j in range(n_v)]),
        }
    return {
        **studs_out,
        "x": xs, "names": [s.get("name") or f"x = {x:g} m" for s, x in zip(secs, xs,
                                                                           strict=True)],
        "section_modulus": w, "detail_category": np.array([s["detail_category"]
                                                           for s in secs], float),
        "gamma_Ff": gff, "gamma_Mf": np.array([s["gamma_Mf"] for s in secs], float),
        "train": [r["train"] for r in traffic],
        "speed_kmh": np.array([r["speed_kmh"] for r in traffic], float),
        "per_day": per_day, "tonnes": tonnes, "free_vibration": free,
        "histogram": hist, "damage_per_passage": per_pass, "damage_per_train":
        damage_per_train, "damage": damage, "max_range": max_range, "cycles": cycles,
        "equivalent": equivalent, "design_life_years": years,
        "tonnes_per_year": float(np.sum(per_day * tonnes) * 365.0),
        "mix": section.get("mix", ""), "seconds": _time.perf_counter() - t0,
    }


def write(path, res: dict) -> None:
    """Add the fatigue results to a results file (netCDF, opened for append)."""
    import netCDF4

    from vsi_numba.io.schema import FATIGUE

    data = {
        "fatigue_damage": res["damage"],
        "fatigue_damage_per_train": res["damage_per_train"],
        "fatigue_damage_per_passage": res["damage_per_passage"],
        "fatigue_cycles": res["histogram"],
        "fatigue_max_stress_range": res["max_range"],
        "fatigue_equivalent_stress_range": res["equivalent"],
        "fatigue_section_modulus": res["section_modulus"],
        "fatigue_detail_category": res["detail_category"],
        "fatigue_gamma_Ff": res["gamma_Ff"],
        "fatigue_gamma_Mf": res["gamma_Mf"],
        "fatigue_speed_kmh": res["speed_kmh"],
        "fatigue_trains_per_day": res["per_day"],
        "fatigue_train_mass": res["tonnes"],
        "fatigue_free_vibration": res["free_vibration"],
    }
    studs = {
        "fatigue_stud_damage": "stud_damage",
        "fatigue_stud_damage_per_train": "stud_damage_per_train",
        "fatigue_stud_damage_per_passage": "stud_damage_per_passage",
        "fatigue_stud_cycles": "stud_histogram",
        "fatigue_stud_max_shear_stress_range": "stud_max_range",
        "fatigue_stud_equivalent_shear_stress_range": "stud_equivalent",
        "fatigue_stud_shear_stress_per_shear_force": "stud_stress_per_shear",
        "fatigue_stud_diameter": "stud_diameter",
        "fatigue_stud_per_row": "stud_per_row",
        "fatigue_stud_row_spacing": "stud_row_spacing",
        "fatigue_stud_first_moment": "stud_first_moment",
        "fatigue_stud_second_moment": "stud_second_moment",
        "fatigue_stud_category": "stud_category",
        "fatigue_stud_slope": "stud_slope",
        "fatigue_stud_gamma_Ff": "stud_gamma_Ff",
        "fatigue_stud_gamma_Mf": "stud_gamma_Mf",
    }
    if "stud_x" in res:
        data.update({name: res[k] for name, k in studs.items()})
    varied = {"fatigue_damage", "fatigue_damage_per_train", "fatigue_damage_per_passage",
              "fatigue_cycles", "fatigue_max_stress_range", "fatigue_equivalent_stress_range",
              "fatigue_free_vibration", *(n for n, k in studs.items() if k in PER_VARIANT)}
    lead = ("variant",) if res.get("n_variants") else ()
    with netCDF4.Dataset(path, "a") as nc:
        if lead and "variant" not in nc.dimensions:
            raise FatigueError("the results file has no variant dimension for the fatigue "
                               "results of a study of variants")
        nc.createDimension("fatigue_section", res["x"].size)
        nc.createDimension("fatigue_traffic", len(res["train"]))
        nc.createDimension("stress_range", fat.N_BINS)
        v = nc.createVariable("fatigue_section", "f8", ("fatigue_section",))
        v[:] = res["x"]
        v.setncatts({"units": "m", "long_name": "fatigue section: distance from the left "
                     "end of the bridge"})
        v = nc.createVariable("fatigue_traffic", str, ("fatigue_traffic",))
        for k, name in enumerate(res["train"]):
            v[k] = name
        v.setncatts({"units": "1", "long_name": "train of the fatigue traffic"})
        v = nc.createVariable("stress_range", "f8", ("stress_range",))
        v[:] = fat.bin_centres()
        v.setncatts({"units": "MPa", "long_name": "centre of the stress-range bin (width "
                     f"{fat.BIN_WIDTH:g} MPa; the last bin holds every larger range)"})
        v = nc.createVariable("fatigue_section_name", str, ("fatigue_section",))
        for k, name in enumerate(res["names"]):
            v[k] = str(name)
        v.setncatts({"units": "1", "long_name": "name of the fatigue section"})
        if "stud_x" in res:
            nc.createDimension("fatigue_stud", res["stud_x"].size)
            v = nc.createVariable("fatigue_stud", "f8", ("fatigue_stud",))
            v[:] = res["stud_x"]
            v.setncatts({"units": "m", "long_name": "stud shear connectors (fatigue): "
                         "distance from the left end of the bridge"})
            v = nc.createVariable("fatigue_stud_name", str, ("fatigue_stud",))
            for k, name in enumerate(res["stud_names"]):
                v[k] = str(name)
            v.setncatts({"units": "1", "long_name": "name of the stud layout"})
        for name, values in data.items():
            dims, units, long_name, extra = FATIGUE[name]
            if name in varied:
                dims = (*lead, *dims)
            var = nc.createVariable(name, "f8", dims)
            var[:] = np.asarray(values, float)
            var.setncatts({"units": units, "long_name": long_name, **extra})
        nc.setncatts({
            "fatigue_design_life_years": float(res["design_life_years"]),
            "fatigue_mix": str(res["mix"] or ""),
            "fatigue_tonnes_per_year": float(res["tonnes_per_year"]),
            "fatigue_seconds": float(res["seconds"]),
        })
