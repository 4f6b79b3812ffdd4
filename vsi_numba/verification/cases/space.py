"""Decks in space: torsion with an eccentric track (V16), the crawl twist of a point
torque (V17), trains meeting on a twisting deck (V18), the twist of a continuous deck
(V19) and the torsional moment (V20)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsi_numba.verification import reference as ref
from vsi_numba.verification.cases.common import Row, forces_toml, ss_bridge, sweep

# ------------------------------------------------------------------ V16-V18 decks in space
#: The deck in space of V16-V18: a 24 m fork-supported span (f1 = 3.05 Hz in bending,
#: 6.59 Hz in torsion), its tracks at +-2.5 m (V16, V17) or +-2.0 m (V18).
_SPACE = dict(L=24.0, EI=1.5e10, m=1.2e4, zeta=0.01, GJ=6.0e9, Ip=6.0e4, zeta_t=0.01)


def _space_bridge(points, tracks, n_bending, n_torsion):
    p = _SPACE
    tr = ", ".join(f"{{ eccentricity = {y!r} }}" for y in tracks)
    return (ss_bridge(p["L"], p["EI"], p["m"], p["zeta"], n_bending, points)
            + f"        tracks = [{tr}]\n"
            + f"        torsion = {{ GJ = {p['GJ']!r}, polar_mass = {p['Ip']!r}, "
              f"damping_ratio = {p['zeta_t']!r}, n_modes = {n_torsion} }}\n")


def _space_run(dt, speed_kmh, free, approach=0.0):
    return f"""
        [track]
        model = "rigid"
        [solver]
        dt = {dt!r}
        hht_alpha = 0.0
        approach = {approach!r}
        free_vibration = {free!r}
        [study]
        speeds_kmh = [{float(speed_kmh)!r}]
        save_time_histories = false
        """


def _space_reference(forces, n_bending, n_torsion, t_end, dt):
    """The deck's modal response to ``forces`` (rows P, y, x0, u) on a grid dt / 4."""
    p = _SPACE
    t = np.linspace(0.0, t_end, int(round(4 * t_end / dt)) + 1)
    return ref.deck_in_space_forces(forces, p["L"], p["EI"], p["m"], p["zeta"], n_bending,
                                    p["GJ"], p["Ip"], p["zeta_t"], n_torsion, t)


_SPACE_IVP = ("solve_ivp (DOP853, rtol 1e-10) of the closed-form bending and St-Venant "
              "torsion sine modes under the moving forces, "
              "vsi_numba.verification.reference.deck_in_space_forces")


_SPACE_CONVERGED = (_SPACE_IVP + " for the bending; the torsion converged: 400 "
                    "torsional modes' exact responses, the twist and rotation by the "
                    "mode-acceleration formula with the closed-form static rotation, "
                    "vsi_numba.verification.reference.fork_torsion_moving_forces")
_TRUNCATED = ("the torsional modes above those kept: at a torsional resonance every "
              "torsional mode is resonant too (f_j = j f_t1), which no static correction "
              "carries; measured ")
#: V16's tolerances (relative) and measured errors (the plain modal sum: -3.8e-2 and
#: -5.4e-3 against the same reference)
V16_TOL = (8e-2, 1e-2)
V16_MEASURED = ("+5.3e-2 (safe side; the plain modal sum before: +9.5e-2)", "-4.0e-3")


def v16_torsion(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.5, 3, 4
    n_f, d, P, dt, free = 8, 12.0, 1.5e5, 2.5e-4, 0.3
    f_t = ref.fork_torsion_frequencies(L, p["GJ"], p["Ip"], n_t)
    v = float(f_t[0] * d)  # the first torsional resonance
    x_twist, x_line = 4.0, 12.0
    text = (_space_bridge([x_twist, x_line], [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + forces_toml([k * d for k in range(n_f)], P) + _space_run(dt, v * 3.6, free))
    ds = sweep(workdir, "v16_torsion", text).isel(speed=0, train=0, irregularity=0)
    freq = np.asarray(ds["frequency"].values, float).ravel()
    forces = [(P, ecc, -k * d, v) for k in range(n_f)]
    res = _space_reference(forces, n_b, n_t, (L + (n_f - 1) * d) / v + free, dt)
    # the converged torsion (400 modes, mode acceleration) with the bending of the ivp
    tor = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, res["t"])
    th, tw, _ = ref.fork_torsion_channels(tor, [x_twist, x_line])
    twist = float(np.abs(tw[:, 0]).max())
    w = ref.deck_in_space_line(res, [x_line], 0.0)[0].ravel() + ecc * th[:, 1]
    a = ref.deck_in_space_line(res, [x_line], ecc)[1]
    title = (f"Torsion of a {L:g} m fork-supported span with a track at {ecc:g} m: "
             f"{n_f} forces of {P / 1e3:g} kN at d = {d:g} m, v = f_t1 d = "
             f"{v * 3.6:.1f} km/h")
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             f"HHT alpha = 0, dt {dt * 1e3:g} ms")
    src_f = ("St-Venant torsion of a fork-supported span, f_j = (j pi / L) sqrt(GJ / I_p) "
             "/ (2 pi), vsi_numba.verification.reference.fork_torsion_frequencies")
    reason_f = ("closed form in the model too: round-off of the file's frequency; "
                "measured 0")
    reason = ("the resonance builds up over 8 cycles: the trapezoidal rule's period error "
              "(w dt)^2/12 a cycle and the peak sampled at dt; measured ")
    rows = []
    for j in range(n_t):
        got = freq[int(np.argmin(abs(freq - f_t[j])))]
        rows.append(Row(f"V16-f{j + 1}", title, src_f, model,
                        f"torsional frequency {j + 1} (nearest of the file's frequency)",
                        "Hz", float(f_t[j]), float(got), 1e-12, reason_f))
    dsel = ds.sel(track=1)
    rows += [
        Row("V16-twist", title, _SPACE_CONVERGED, model, f"max deck twist over 3 m from "
            f"x = {x_twist:g} m", "m", twist,
            float(dsel["max_deck_twist"].sel(point=x_twist).values), V16_TOL[0],
            _TRUNCATED + V16_MEASURED[0]),
        Row("V16-w", title, _SPACE_CONVERGED, model, f"max displacement of the track line "
            f"at x = {x_line:g} m", "m", float(np.abs(w).max()),
            float(dsel["max_track_displacement"].sel(point=x_line).values), V16_TOL[1],
            _TRUNCATED + V16_MEASURED[1]),
        Row("V16-a", title, _SPACE_IVP, model, f"max |acceleration| of the track line at "
            f"x = {x_line:g} m (every mode below the 30 Hz cut-off)", "m/s2",
            float(np.abs(a).max()),
            float(dsel["max_track_acceleration"].sel(point=x_line).values), 2e-4,
            reason + "8.0e-5"),
    ]
    return rows


def v17_crawl_twist(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t, P, approach = p["L"], 2.5, 3, 40, 2.0e5, 1.0
    points = [4.0, 10.5]
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n" + forces_toml([0.0], P)
            + _space_run(1e-3, 3.0, 0.2, approach))
    ds = sweep(workdir, "v17_crawl_twist", text).isel(speed=0, train=0, irregularity=0)
    title = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of a "
             f"{L:g} m fork-supported span: a point torque P e")
    src = ("St-Venant rotation of a point torque on a fork-supported span, theta(x) = "
           "P e x (L - a) / (GJ L) for x <= a, max twist at a = x or x + 3 m, "
           "vsi_numba.verification.reference.point_torque_twist")
    model = (f"moving force on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             "HHT alpha = 0, dt 1 ms")
    src_n = (f"the sine series of the same rotation truncated to the {n_t} torsional "
             "modes kept, the torque moved in 1 mm steps, "
             "vsi_numba.verification.reference.point_torque_twist")
    del src_n
    measured = {4.0: "-7.9e-5", 10.5: "+5.5e-5"}
    rows = []
    for i, x in enumerate(points):
        closed = ref.point_torque_twist(P * ecc, p["GJ"], L, x)
        series = ref.point_torque_twist(P * ecc, p["GJ"], L, x, n_modes=n_t)
        got = float(ds["max_deck_twist"].sel(track=1, point=x).values)
        what = f"max deck twist over 3 m from x = {x:g} m"
        rows.append(
            Row(f"V17-twist-{i + 1}", title, src, model, what, "m", closed, got, 3e-4,
                "mode acceleration: the static rotation is the closed form, the modes "
                "add the dynamic part at 3 km/h, the torque's positions sampled at "
                f"v dt = 0.83 mm (the plain series of the {n_t} modes kept is "
                f"{series / closed - 1:+.1e} off); measured {measured[x]}"))
    return rows


_TRUNCATED_V18 = ("the converged torsion (400 modes) against the 4 kept with the "
                  "static correction: the truncated modes' dynamic part; measured ")


def v18_trains_meeting(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.0, 3, 4
    n_f, d, P, off, kmh, dt, free = 5, 8.0, 1.5e5, 10.0, 160.0, 2.5e-4, 0.3
    v = kmh / 3.6
    x = L / 2
    text = (_space_bridge([x], [ecc, -ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + f'other_trains = [{{ track = 2, direction = "opposite", offset = {off!r} }}]\n'
            + forces_toml([k * d for k in range(n_f)], P) + _space_run(dt, kmh, free))
    ds = sweep(workdir, "v18_trains_meeting", text).isel(speed=0, train=0, irregularity=0)
    forces = ([(P, ecc, -k * d, v) for k in range(n_f)]
              + [(P, -ecc, L + off + k * d, -v) for k in range(n_f)])
    res = _space_reference(forces, n_b, n_t, (L + (n_f - 1) * d + off) / v + free, dt)
    w0, _ = ref.deck_in_space_line(res, [x], 0.0)
    # the converged torsion of each train (the one in -x mirrored: x' = L - x)
    fwd = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, res["t"])
    rev = ref.fork_torsion_moving_forces([off + k * d for k in range(n_f)], P, -ecc, L,
                                         p["GJ"], p["Ip"], p["zeta_t"], v, res["t"])
    th = (ref.fork_torsion_channels(fwd, [x])[0][:, 0]
          + ref.fork_torsion_channels(rev, [L - x])[0][:, 0])
    w1 = w0.ravel() + ecc * th
    w2 = w0.ravel() - ecc * th
    moment = ref.deck_in_space_moment(res, x)
    title = (f"Trains meeting on a twisting {L:g} m deck: {n_f} forces of {P / 1e3:g} kN at "
             f"d = {d:g} m on each track (+-{ecc:g} m), the second in -x {off:g} m behind, "
             f"{kmh:g} km/h")
    model = (f"moving forces on tracks 1 and 2 (other_trains, superposed), {n_b} bending + "
             f"{n_t} torsional modes (1 %), mode acceleration, HHT alpha = 0, "
             f"dt {dt * 1e3:g} ms")
    src = _SPACE_IVP + " (all ten forces at once); the moment by deck_in_space_moment"
    reason = ("HHT alpha = 0 at dt 0.25 ms (no resonance: 5.6 forces a second on each "
              "track, f1 = 3.05 Hz, f_t1 = 6.59 Hz) and the peak sampled at dt; measured ")
    at = dict(point=x)
    return [
        Row("V18-w-axis", title, src, model, f"max deck (axis) displacement at x = {x:g} m, "
            "both trains", "m", float(np.abs(w0).max()),
            float(ds["max_deck_displacement_all_tracks"].sel(**at).values), 3e-5,
            reason + "1.1e-5"),
        Row("V18-w-track1", title, src, model, f"max displacement of track 1 at x = {x:g} m,"
            " both trains", "m", float(np.abs(w1).max()),
            float(ds["max_track_displacement_all_tracks"].sel(track=1, **at).values), 3e-3,
            _TRUNCATED_V18 + "1.3e-3 (the plain modal sum before: 5.6e-3)"),
        Row("V18-w-track2", title, src, model, f"max displacement of track 2 at x = {x:g} m,"
            " both trains", "m", float(np.abs(w2).max()),
            float(ds["max_track_displacement_all_tracks"].sel(track=2, **at).values), 1.5e-3,
            _TRUNCATED_V18 + "5.8e-4 (the plain modal sum before: 1.2e-3)"),
        Row("V18-M", title, src, model, f"max bending moment at x = {x:g} m, both trains",
            "N m", float(moment.max()),
            float(ds["max_bending_moment_all_tracks"].sel(**at).values), 4e-6,
            reason + "1.4e-6"),
    ]


# ------------------------------------------------------------------ V19-V20 mode acceleration
#: V19-V20 measured errors and tolerances (relative), against the converged references.
V19_MEASURED = {"crawl": "3.3e-4 (the plain modal sum before: -1.5e-2 .. -1.0e-1)",
                "res": "+5.3e-2 .. +6.7e-2, safe side (the plain modal sum before: "
                       "-1.2e-1 .. +9.9e-2)"}


def _space_continuous(points, ecc, n_bending, n_torsion, spans):
    p = _SPACE
    torsion = (f"{{ GJ = {p['GJ']!r}, polar_mass = {p['Ip']!r}, "
               f"damping_ratio = {p['zeta_t']!r}, n_modes = {n_torsion} }}")
    return f"""
        [bridge]
        kind = "continuous"
        spans = {list(spans)!r}
        EI = {p['EI']!r}
        mass_per_length = {p['m']!r}
        damping_ratio = {p['zeta']!r}
        n_modes = {n_bending}
        elements_per_span = 40
        output_points = {list(points)!r}
        tracks = [{{ eccentricity = {ecc!r} }}]
        torsion = {torsion}
        """


def v19_continuous_twist(workdir: Path) -> list[Row]:
    p = _SPACE
    spans, ecc, n_b, n_t = (24.0, 24.0), 2.5, 4, 8
    points = [4.0, 10.5, 34.5]
    P = 2.0e5
    title_c = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of a "
               "24 + 24 m continuous deck, torsion restrained at the supports")
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), FE "
             "40 elements a span, mode acceleration, HHT alpha = 0")
    text = (_space_continuous(points, ecc, n_b, n_t, spans) + "[train]\ntrack = 1\n"
            + forces_toml([0.0], P) + _space_run(2e-3, 3.0, 0.0))
    ds = sweep(workdir, "v19_crawl", text).isel(speed=0, train=0, irregularity=0)
    src_c = ("St-Venant rotation of a point torque P e on each fork-supported span, the "
             "force moved in 1 mm steps, "
             "vsi_numba.verification.reference.fork_spans_crawl_twist")
    closed = ref.fork_spans_crawl_twist(spans, P, ecc, p["GJ"], points)
    grid = np.asarray(ds["twist_x"].values, float)
    closed_g = ref.fork_spans_crawl_twist(spans, P, ecc, p["GJ"], grid).max()
    rows = [Row(f"V19-crawl-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"max deck twist over 3 m from x = {x:g} m", "m", float(closed[i]),
                float(ds["max_deck_twist"].sel(track=1, point=x).values), 1e-3,
                "the dynamic part at 3 km/h and the FE torsion field (linear elements) "
                "between nodes; measured " + V19_MEASURED["crawl"])
            for i, x in enumerate(points)]
    rows.append(Row("V19-crawl-whole", title_c, src_c, model + ", dt 2 ms",
                    "max deck twist over 3 m, whole-deck grid", "m", float(closed_g),
                    float(ds["max_deck_twist_whole_deck"].sel(track=1).max().values), 1e-3,
                    "as above; measured " + V19_MEASURED["crawl"]))
    # the first torsional resonance: eight forces d = 12 m apart at v = f_t1 d
    n_f, d, dt, free = 8, 12.0, 2.5e-4, 0.3
    f_t1 = float(ref.fork_torsion_frequencies(spans[0], p["GJ"], p["Ip"], 1)[0])
    v = f_t1 * d
    text = (_space_continuous(points, ecc, n_b, n_t, spans) + "[train]\ntrack = 1\n"
            + forces_toml([k * d for k in range(n_f)], 1.5e5) + _space_run(dt, v * 3.6, free))
    ds = sweep(workdir, "v19_resonance", text).isel(speed=0, train=0, irregularity=0)
    t = np.arange(0.0, (sum(spans) + (n_f - 1) * d) / v + free, dt / 2)
    tw = ref.fork_spans_twist(spans, [k * d for k in range(n_f)], 1.5e5, ecc, p["GJ"],
                              p["Ip"], p["zeta_t"], v, t, points)
    title_r = (f"{n_f} forces of 150 kN at d = {d:g} m at the first torsional resonance "
               f"(v = f_t1 d = {v * 3.6:.1f} km/h) on the continuous deck of V19")
    src_r = ("each span a fork-supported span: 400 torsional modes' exact responses, the "
             "twist by the mode-acceleration formula with the closed-form static rotation, "
             "vsi_numba.verification.reference.fork_spans_twist")
    for i, x in enumerate(points):
        rows.append(Row(f"V19-res-{i + 1}", title_r, src_r, model + f", dt {dt * 1e3:g} ms",
                        f"max deck twist over 3 m from x = {x:g} m", "m",
                        float(np.abs(tw[:, i]).max()),
                        float(ds["max_deck_twist"].sel(track=1, point=x).values),
                        V19_RES_TOL, _TRUNCATED + V19_MEASURED["res"]))
    return rows


V19_RES_TOL = 0.1


def v20_torque(workdir: Path) -> list[Row]:
    p = _SPACE
    L, ecc, n_b, n_t = p["L"], 2.5, 3, 6
    points = [3.0, 6.0, 12.0]
    P = 2.0e5
    model = (f"moving forces on track 1, {n_b} bending + {n_t} torsional modes (1 %), "
             "mode acceleration with the speed factor 1 / (1 - (v/c)^2), HHT alpha = 0")
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + forces_toml([0.0], P) + _space_run(2e-3, 3.0, 0.0))
    ds = sweep(workdir, "v20_crawl", text).isel(speed=0, train=0, irregularity=0)
    title_c = (f"A {P / 1e3:g} kN force crawling (3 km/h) on a track at {ecc:g} m of the "
               f"{L:g} m fork-supported span of V16: the St-Venant torsional moment")
    src_c = ("static St-Venant torque of a point torque P e on a fork-supported span: "
             "P e (1 - a/L) left of it, -P e a/L right of it; largest P e (1 - x/L), "
             "smallest -P e x/L")
    Pe = P * ecc
    rows = []
    for i, x in enumerate(points):
        rows += [
            Row(f"V20-crawl-max-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"max torsional moment at x = {x:g} m", "N m", Pe * (1 - x / L),
                float(ds["max_torsional_moment"].sel(point=x).values), 1e-3,
                "the dynamic part at 3 km/h and the load's positions sampled at v dt; "
                "measured " + V20_MEASURED["crawl"]),
            Row(f"V20-crawl-min-{i + 1}", title_c, src_c, model + ", dt 2 ms",
                f"min torsional moment at x = {x:g} m", "N m", -Pe * x / L,
                float(ds["min_torsional_moment"].sel(point=x).values), 5e-3,
                "as above; measured " + V20_MEASURED["crawl"])]
    # at speed: eight forces d = 12 m apart at 200 km/h (v/c = 0.18)
    n_f, d, dt, free, kmh = 8, 12.0, 2.5e-4, 0.3, 200.0
    v = kmh / 3.6
    text = (_space_bridge(points, [ecc], n_b, n_t) + "[train]\ntrack = 1\n"
            + forces_toml([k * d for k in range(n_f)], P) + _space_run(dt, kmh, free))
    ds = sweep(workdir, "v20_speed", text).isel(speed=0, train=0, irregularity=0)
    t = np.arange(0.0, (L + (n_f - 1) * d) / v + free, dt / 2)
    res = ref.fork_torsion_moving_forces([k * d for k in range(n_f)], P, ecc, L, p["GJ"],
                                         p["Ip"], p["zeta_t"], v, t)
    tq = ref.fork_torsion_channels(res, points)[2]
    title_s = (f"{n_f} forces of {P / 1e3:g} kN at d = {d:g} m at {kmh:g} km/h on the span "
               "of V16: the St-Venant torsional moment")
    src_s = ("400 torsional modes' exact responses, the torque by the mode-acceleration "
             "formula with the closed-form static torque, "
             "vsi_numba.verification.reference.fork_torsion_moving_forces")
    for i, x in enumerate(points):
        for ext, fn in (("max", np.max), ("min", np.min)):
            rows.append(Row(f"V20-speed-{ext}-{i + 1}", title_s, src_s,
                            model + f", dt {dt * 1e3:g} ms",
                            f"{ext} torsional moment at x = {x:g} m", "N m",
                            float(fn(tq[:, i])),
                            float(ds[f"{ext}_torsional_moment"].sel(point=x).values),
                            V20_SPEED_TOL, "the torque fronts a force sends off along the "
                            "span when it enters or leaves it, carried by the kept modes "
                            "only; measured " + V20_MEASURED["speed"]))
    return rows


V20_MEASURED = {"crawl": "2.4e-4 (max), 2.1e-3 (min at x = 3 m: 2.6e-4 of P e)",
                "speed": "-6.5e-2 .. +2.2e-2, at most 1.4e-2 of P e (without the speed "
                         "factor before: -8.9e-2 .. +1.7e-2)"}
V20_SPEED_TOL = 0.1
