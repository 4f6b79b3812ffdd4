"""Comfort at the car-body points, deck acceleration over the whole deck, HHT-alpha
accuracy order of the accelerations, and the solver-setting warnings.

References are independent of the engine: a 2-DOF (bounce, pitch) body on two massive
wheelsets on a rigid track, integrated with ``solve_ivp`` from hand-written equations;
the whole-deck envelope from the raw modal accelerations and mode shapes on a dense x
grid with numpy; the moving force on one mode from its closed-form solution.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vsi_numba.analysis import checks
from vsi_numba.analysis.synthetic import synthetic_results
from vsi_numba.config import load_config
from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import Profile
from vsi_numba.model.library import get_train
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

# ----------------------------------------------------------------- comfort points


def test_comfort_points__railway_car_has_centre_and_both_pivots():
    car = vh.railway_car(40e3, 2e6, 3e3, 2e3, 1.8e3, 17.5, 2.5, 1e6, 1e4, 4e5, 2e4,
                         body_cg_to_front_bogie=8.0)
    [pts] = car.comfort_points
    pitch = car.dof_names.index("body_pitch")
    # centre first (ties keep the centre), then the pivots: 8 m ahead, 9.5 m behind
    assert pts == ((pitch, 0.0), (pitch, 8.0), (pitch, -9.5))
    assert vh.sprung_mass(1e3, 1e6).body_comfort_points(0) == ((-1, 0.0),)


def test_comfort_points__articulated_bodies_get_their_own_pivots():
    b = vh.MultibodyBuilder("two bodies")
    b.add_body("b1", 1e4, 5.0, 1e5)
    b.add_body("b2", 1e4, 15.0, 1e5)
    b.add_body("mid", 1e3, 10.0)
    for w, x in (("w0", 0.0), ("w1", 10.0), ("w2", 20.0)):
        b.add_wheel(w, 100.0, x)
    b.connect("b1", "w0", 0.0, 1e6, 0.0)
    b.connect("b1", "mid", 10.0, 1e6, 0.0)
    b.connect("b2", "mid", 10.0, 1e6, 0.0)
    b.connect("b2", "w2", 20.0, 1e6, 0.0)
    b.connect("mid", "w1", 10.0, 1e6, 0.0)
    v = b.build(body=["b1", "b2"])
    assert [d for _, d in v.comfort_points[0]] == [0.0, 5.0, -5.0]
    assert [d for _, d in v.comfort_points[1]] == [0.0, 5.0, -5.0]
    assert v.comfort_points[0][0][0] != v.comfort_points[1][0][0]  # own pitch DOFs


# 4-DOF car: body bounce z and pitch theta (nose down), CG 4 m behind the front wheelset,
# wheelsets 10 m apart, secondary spring-dashpots over the wheelsets
M_B, J_B, K_S, C_S, M_W = 30e3, 1.2e6, 6e5, 2.5e4, 1.5e3
P_CG, SPACING = 4.0, 10.0
DEPTH, X_DIP, L_DIP = 0.006, 8.0, 12.0  # cosine dip r = depth sin^2(pi s), 0 < s < 1


def _four_dof_car():
    b = vh.MultibodyBuilder("4dof")
    b.add_body("body", M_B, P_CG, J_B)
    b.add_wheel("w1", M_W, 0.0)
    b.add_wheel("w2", M_W, SPACING)
    b.connect("body", "w1", 0.0, K_S, C_S)
    b.connect("body", "w2", SPACING, K_S, C_S)
    return b.build(body="body")


def _dip(x):
    s = (np.asarray(x, float) - X_DIP) / L_DIP
    inside = (s > 0) & (s < 1)
    r = np.where(inside, DEPTH * np.sin(np.pi * s) ** 2, 0.0)
    dr = np.where(inside, DEPTH * np.pi / L_DIP * np.sin(2 * np.pi * s), 0.0)
    return r, dr


def test_comfort__pivot_accelerations_of_a_pitching_car_match_solve_ivp():
    """Rigid track, rigid contact: the wheelsets follow the rail, r(x_i(t)); the body
    (z, theta) is a 2-DOF linear system driven through the secondary suspension.
    Reference: solve_ivp of the hand-written equations (deviations from static
    equilibrium, where gravity cancels); a point d metres ahead of the CG accelerates
    by z'' + d theta''."""
    car = _four_dof_car()
    train = vh.Train("car", (car,), (0.0,))
    speed, approach, dt = 160 / 3.6, 5.0, 2e-4
    settings = SolverSettings(dt=dt, hht_alpha=-0.05, approach=approach, free_vibration=0.5)
    profile = Profile.from_function(lambda x: _dip(x)[0], -30.0, 60.0, 0.002, "dip")
    bridge = br.rigid(30.0)
    packed = sm.pack(bridge, train, speed, profile, settings)
    res = sm.run_batch(packed, profile, [speed], [], settings, bridge, keep_histories=[True])
    assert res.status[0] == 0
    env = res.envelopes()
    n = int(res.n_steps[0]) + 1
    t = np.arange(n) * dt
    e = np.array([P_CG - 0.0, P_CG - SPACING])  # wheelsets ahead of the CG, m
    x0 = -approach - np.array([0.0, SPACING])

    def rhs(tt, y):
        z, th, zd, thd = y
        r, dr = _dip(x0 + speed * tt)
        f = K_S * (z + e * th - r) + C_S * (zd + e * thd - speed * dr)
        return [zd, thd, -f.sum() / M_B, -(e * f).sum() / J_B]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, 0.0, 0.0], t_eval=t, rtol=1e-10,
                    atol=1e-13, max_step=1e-3)
    acc = np.array([rhs(tt, y)[2:] for tt, y in zip(sol.t, sol.y.T, strict=True)])
    body, d = res.comfort_points()
    np.testing.assert_allclose(d, [0.0, P_CG, P_CG - SPACING])
    ref = acc[:, :1] + d[None, :] * acc[:, 1:]  # (time, point)
    peak = np.abs(ref).max(axis=0)
    # pitch matters: the rear pivot (6 m behind the CG) moves clearly more than the CG
    assert peak[2] > 1.2 * peak[0]
    # HHT-alpha accelerations are first order: error ~ |alpha| dt |a'| ~ 0.05 * 2e-4 s *
    # 2 pi 3.7 Hz (the dip at 160 km/h) ~ 2.3e-4 of the peak, plus the O(dt^2) part and
    # the 2 mm profile spline; 0.5 % leaves margin without hiding a sign error (which
    # would swap the pivots: tens of %)
    got = res.comfort_point_histories(0)
    np.testing.assert_allclose(got, ref, rtol=0, atol=5e-3 * peak.max())
    np.testing.assert_allclose(env["max_carbody_acceleration"][0], peak.max(), rtol=5e-3)
    assert env["position_of_max_carbody_acceleration"][0] == d[np.argmax(peak)]
    # the CG history stays the CG's
    np.testing.assert_allclose(res.histories(0)["carbody_acceleration"][:, 0], ref[:, 0],
                               rtol=0, atol=5e-3 * peak.max())


# ----------------------------------------------------------------- whole-deck envelope


def _span15():
    """15 m simply supported span, f1 = 8.06 Hz (m = 15 t/m, EI = 2.0e10 N m2), EN 1991-2
    damping 1.5 + 0.07 (20 - 15) = 1.85 %."""
    return br.simply_supported(15.0, 2.0e10, 15e3, damping_ratio=0.0185, n_modes=10)


def test_whole_deck__exceeds_mid_span_and_equals_a_dense_numpy_envelope():
    bridge = _span15()
    assert bridge.frequencies[0] == pytest.approx(8.06, abs=0.01)
    train = get_train("HSLM-A1", model="moving_force")
    speed = 395 / 3.6
    settings = SolverSettings(dt=1e-3, approach=0.0, free_vibration=0.5)
    ds = sm.simulate(bridge, train, speed, settings=settings, save_histories=False)
    mid = float(ds["max_deck_acceleration"].sel(point=7.5))
    whole = float(ds["max_deck_acceleration_whole_deck"])
    x_w = float(ds["position_of_max_deck_acceleration_whole_deck"])
    # the governing point is off mid-span (mode 2 has a node there), and clearly higher
    assert abs(x_w - 7.5) > 1.0
    assert whole > 1.1 * mid
    # reference: raw modal accelerations of the same run, band-limited modes (up to the
    # EN 1990 cut-off max(30, 1.5 f1, f3) = f3) evaluated by numpy on a dense grid that
    # contains the kernel's grid (every 15/32 m) and refines it 50 times
    packed = sm.pack(bridge, train, speed, None, settings)
    status, _, out, _ = sm.run_kernel(packed, sm.no_irregularity())
    assert status == 0
    keep = bridge.frequencies <= sm.acceleration_cutoff(bridge.frequencies) + 1e-9
    assert keep.sum() == 3
    x = np.linspace(0.0, 15.0, 32 * 50 + 1)
    acc = np.abs(out.qdd[:, keep] @ bridge.shapes(x)[:, keep].T)  # (time, x)
    dense = acc.max()
    on_grid = acc[:, ::50].max()
    # on the kernel's own grid: the same numbers summed in another order (round-off)
    assert whole == pytest.approx(on_grid, rel=1e-12)
    # grid vs continuum: the grid maximum is below the dense one by at most (K h)^2 / 8,
    # K = 3 pi / L (three half-waves in the band), h = L / 32: 1.08 %
    bound = (3 * np.pi / 32) ** 2 / 8
    assert dense * (1 - bound) <= whole <= dense * (1 + 1e-12)
    assert x[np.argmax(acc.max(axis=0))] == pytest.approx(x_w, abs=15 / 32)
    # the kernel's time of the maximum is that of the numpy maximum on its grid
    n_max = int(np.argmax(acc[:, ::50].max(axis=1)))
    assert float(ds["time_of_max_deck_acceleration_whole_deck"]) == pytest.approx(
        n_max * settings.dt)


def test_whole_deck__interaction_model_matches_the_moving_force_loop():
    """The general time loop (``record``) reduces the grid like the moving-force loop:
    a sprung mass with a massless wheel and no suspension mass effect is not the same
    load, so compare each with numpy on its own raw histories instead."""
    bridge = _span15()
    train = vh.Train("sm", (vh.sprung_mass(20e3, 5e6, 1e4, 1e3),), (0.0,))
    speed = 250 / 3.6
    settings = SolverSettings(dt=5e-4, approach=1.0, free_vibration=0.2)
    packed = sm.pack(bridge, train, speed, None, settings)
    res = sm.run_batch(packed, sm.no_irregularity(), [speed], [7.5], settings, bridge,
                       keep_histories=[True])
    keep = bridge.frequencies <= sm.acceleration_cutoff(bridge.frequencies) + 1e-9
    acc = np.abs(res.out.qdd[0][:, keep] @ bridge.shapes(res.grid_x)[:, keep].T)
    env = res.envelopes()
    # same numbers, another summation order
    assert env["max_deck_acceleration_whole_deck"][0] == pytest.approx(acc.max(), rel=1e-12)
    assert env["max_deck_acceleration_whole_deck"][0] >= env["max_deck_acceleration"][0, 0]


def test_deck_acceleration_check__uses_the_whole_deck_envelope():
    ds = synthetic_results(speeds_kmh=(200.0, 250.0), n_points=3)
    ds["max_deck_acceleration"][:] = 1.0
    shape = ds["max_deck_acceleration"].isel(point=0).shape
    dims = ds["max_deck_acceleration"].isel(point=0).dims
    ds["max_deck_acceleration_whole_deck"] = (dims, np.full(shape, 1.2))
    ds["position_of_max_deck_acceleration_whole_deck"] = (dims, np.full(shape, 3.0))
    sel = {"train": "HSLM-A4", "speed": ds["speed"].values[1]}
    ds["max_deck_acceleration_whole_deck"].loc[sel] = 3.9
    ds["position_of_max_deck_acceleration_whole_deck"].loc[sel] = 6.25
    out = checks.deck_acceleration_check(ds)
    a = out.attrs
    assert a["whole_deck"] == 1
    assert a["value"] == pytest.approx(3.9)
    assert a["governing_point"] == pytest.approx(6.25)
    assert a["result"] == "FAIL"  # 3.9 > 3.5 although every output point has 1.0
    assert a["value_at_output_points"] == pytest.approx(1.0)
    assert a["governing_output_point"] in ds["point"].values
    # without the whole-deck variables: the output points only
    old = checks.deck_acceleration_check(ds.drop_vars(
        ["max_deck_acceleration_whole_deck", "position_of_max_deck_acceleration_whole_deck"]))
    assert old.attrs["whole_deck"] == 0 and old.attrs["value"] == pytest.approx(1.0)


# ------------------------------------------------------------- HHT-alpha accuracy order


def _moving_force_errors(alpha, dts):
    """Max error of the mid-span acceleration and displacement of one undamped mode under
    a moving force, while the force is on the span, against the closed form
    q'' + w^2 q = P a sin(W t), q(0) = q'(0) = 0, W = pi v / L."""
    length, ei, m, p, v = 20.0, 1e10, 1e4, 1e5, 30.0
    bridge = br.simply_supported(length, ei, m, n_modes=1)
    train = vh.Train("P", (vh.moving_force(p),), (0.0,))
    w = bridge.omega[0]
    big_w = np.pi * v / length
    a = np.sqrt(2 / (m * length))
    errs_a, errs_w = [], []
    for dt in dts:
        s = SolverSettings(dt=dt, hht_alpha=alpha, approach=0.0, free_vibration=0.0)
        ds = sm.simulate(bridge, train, v, settings=s, output_points=[length / 2])
        t = ds["time"].values
        on = t <= length / v
        c = p * a / (w**2 - big_w**2)
        q = c * (np.sin(big_w * t) - big_w / w * np.sin(w * t))
        qdd = c * (-big_w**2 * np.sin(big_w * t) + big_w * w * np.sin(w * t))
        acc = ds["deck_acceleration"].values[:, 0]
        disp = ds["deck_displacement"].values[:, 0]
        errs_a.append(np.abs(acc - a * qdd)[on].max() / np.abs(a * qdd).max())
        errs_w.append(np.abs(disp - a * q)[on].max() / np.abs(a * q).max())
    return np.array(errs_a), np.array(errs_w)


def test_hht_alpha__accelerations_first_order_displacements_second_order():
    """Log-log slope of the error over dt = 2, 1, 0.5, 0.25 ms (w dt <= 0.06).
    alpha = -0.3: accelerations order 1, displacements order 2; alpha = 0: both order 2.
    Tolerance +-0.2 on the slope: with alpha = -0.3 the O(dt^2) part of the acceleration
    error still adds ~0.1 to the fitted slope at the coarse end (local slopes 1.15, 1.08,
    1.04 from 4 ms down); 0.2 still separates 1 from 2."""
    dts = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])
    ea, ew = _moving_force_errors(-0.3, dts)
    order_a = np.polyfit(np.log(dts), np.log(ea), 1)[0]
    order_w = np.polyfit(np.log(dts), np.log(ew), 1)[0]
    assert order_a == pytest.approx(1.0, abs=0.2)
    assert order_w == pytest.approx(2.0, abs=0.2)
    ea0, _ = _moving_force_errors(0.0, dts)
    assert np.polyfit(np.log(dts), np.log(ea0), 1)[0] == pytest.approx(2.0, abs=0.2)
    # at dt = 1 ms the alpha = -0.3 acceleration error is well above the alpha = 0 one
    assert ea[1] > 3 * ea0[1]


# ----------------------------------------------------------------------- warnings


def _config(**solver):
    return {
        "title": "t",
        "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
                   "mass_per_length": 2303.0, "n_modes": 3},
        "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0,
                                "stiffness": 1.595e6, "wheel_mass": 500.0}]},
        "solver": {"dt": 1e-3, **solver},
        "study": {"speeds_kmh": [100.0], "output": "results/t.nc"},
    }


_config_elastic = _config  # the default track: the rail on its foundation


def test_warnings__rigid_contact_with_massive_wheels_needs_numerical_damping():
    def _config(**solver):  # the rigid-track idealisation: rigid contact on rigid rails
        data = _config_elastic(**solver)
        data["track"] = {"model": "rigid"}
        return data

    warned = [w for w in load_config(_config(hht_alpha=0.0)).warnings
              if w.startswith("solver.hht_alpha")]
    assert len(warned) == 1 and "-0.02" in warned[0]
    assert not [w for w in load_config(_config(hht_alpha=-0.02)).warnings
                if w.startswith("solver.hht_alpha")]
    # on the default elastic track the contact is compliant: no constraint ringing
    assert not [w for w in load_config(_config_elastic(hht_alpha=0.0)).warnings
                if w.startswith("solver.hht_alpha")]
    massless = _config(hht_alpha=0.0)
    massless["train"]["vehicles"][0]["wheel_mass"] = 0.0
    assert not [w for w in load_config(massless).warnings if w.startswith("solver.hht_alpha")]


def test_warnings__hertz_time_step_at_twice_the_static_load():
    """Wheel 500 kg under (5750 + 500) kg g, G = 4e-8: k_H(N) = 1.5 N^(1/3) / G, so the
    frequency at 2 Q0 is 2^(1/6) times the one at Q0; a dt between 0.1/f(2 Q0) and
    0.1/f(Q0) warns for "hertz" (not for "hertz_linear": its stiffness is k_H(Q0))."""
    g = 4e-8
    q0 = 6250.0 * 9.81
    f0 = np.sqrt(1.5 * np.cbrt(q0) / g / 500.0) / (2 * np.pi)
    dt = 0.1 / f0 / 1.06  # dt f0 = 0.094, dt f(2 Q0) = 0.106

    def warnings(model):
        data = _config(dt=dt)
        data["contact"] = {"model": model, "hertz_coefficient": g}
        data["track"] = {"model": "rigid"}  # the wheel on the Hertz spring alone
        return [w for w in load_config(data).warnings if "Hertz contact spring" in w]

    [w] = warnings("hertz")
    assert w.startswith("solver.dt") and "2 x the static wheel load" in w
    assert warnings("hertz_linear") == []
