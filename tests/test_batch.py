"""The batch kernel: envelopes reduced while stepping, several runs per call.

References are computed here, independently of the in-kernel reductions: the envelopes
from the full time histories with numpy (max |.|, argmax, argmin, counts of separated
steps and of separation events), and the moving-force modal load as the direct sum over
the axles on the deck.
"""

from __future__ import annotations

import numpy as np
import pytest

from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.library import get_train
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

#: Envelopes from histories vs in the kernel: the same numbers summed in another order
#: (BLAS matmul vs a loop over modes) -> round-off only.
RTOL = 1e-12


def _envelopes_from_histories(ds, dt):
    """The envelopes of one run from its time histories (numpy, first extreme wins)."""
    t = ds["time"].values
    w = ds["deck_displacement"].values
    a = ds["deck_acceleration"].values
    X = ds["contact_force"].values
    c = ds["in_contact"].values
    b = ds["carbody_acceleration"].values
    q0 = ds["static_wheel_load"].values
    x0 = -ds.attrs.get("approach", 0.0) - ds["wheel_position"].values
    out = {
        "max_deck_displacement": np.abs(w).max(axis=0),
        "time_of_max_deck_displacement": t[np.abs(w).argmax(axis=0)],
        "max_deck_acceleration": np.abs(a).max(axis=0),
        "time_of_max_deck_acceleration": t[np.abs(a).argmax(axis=0)],
        "min_contact_force": X.min(axis=0),
        "max_contact_force": X.max(axis=0),
        "max_wheel_unloading": ((q0 - X) / q0).max(axis=0),
        "position_of_min_contact_force": x0 + ds.attrs["speed"] * t[X.argmin(axis=0)],
        "contact_loss_duration": (c == 0).sum(axis=0) * dt,
    }
    if b.shape[1]:
        out["max_carbody_acceleration"] = np.abs(b).max(axis=0)
        out["time_of_max_carbody_acceleration"] = t[np.abs(b).argmax(axis=0)]
    # separation events: runs of consecutive separated steps
    longest, events, single = [], [], []
    for k in range(c.shape[1]):
        runs, n = [], 0
        for flag in c[:, k]:
            if flag == 0:
                n += 1
            elif n:
                runs.append(n)
                n = 0
        if n:
            runs.append(n)
        longest.append(max(runs, default=0) * dt)
        events.append(len(runs))
        single.append(sum(r == 1 for r in runs))
    out["longest_contact_loss"] = np.array(longest)
    out["contact_loss_events"] = np.array(events, float)
    out["single_step_contact_losses"] = np.array(single, float)
    return out


def _comfort_and_whole_deck(bridge, train, speed, profile, settings, points, t):
    """Car-body envelopes over the comfort points (CG bounce + d x pitch histories) and
    the whole-deck envelope (raw modal accelerations times the band-limited shapes on the
    grid), from the raw histories of the same run; first step, then first point wins."""
    packed = sm.pack(bridge, train, speed, profile, settings)
    res = sm.run_batch(packed, profile, [speed], points, settings, bridge,
                       keep_histories=[True])
    out = {}
    body, d = res.comfort_points()
    if body.size:
        a = np.abs(res.comfort_point_histories(0))
        peak, when, where = [], [], []
        for b in range(packed.vehicles.body_dof.size):
            ab = a[:, body == b]
            n = int(np.argmax(ab.max(axis=1)))
            k = int(np.argmax(ab[n]))
            peak.append(ab[n, k])
            when.append(t[n])
            where.append(d[body == b][k])
        out["max_carbody_acceleration"] = np.array(peak)
        out["time_of_max_carbody_acceleration"] = np.array(when)
        out["position_of_max_carbody_acceleration"] = np.array(where)
    keep = bridge.frequencies <= sm.acceleration_cutoff(bridge.frequencies) + 1e-9
    grid = res.grid_x
    acc = np.abs(res.out.qdd[0][:, keep] @ bridge.output_shapes(grid)[:, keep].T)
    n = int(np.argmax(acc.max(axis=1)))
    k = int(np.argmax(acc[n]))
    out["max_deck_acceleration_whole_deck"] = acc[n, k]
    out["time_of_max_deck_acceleration_whole_deck"] = t[n]
    out["position_of_max_deck_acceleration_whole_deck"] = grid[k]
    return out


def _dip(depth, x0, length):
    def f(x):
        s = (np.asarray(x) - x0) / length
        return np.where((s > 0) & (s < 1), depth * np.sin(np.pi * s) ** 2, 0.0)

    return Profile.from_function(f, -20.0, 60.0, 0.005, "dip")


@pytest.mark.parametrize("case", ["sprung_lift_off", "car_on_two_spans", "moving_forces"])
def test_batch__kernel_envelopes_equal_the_histories(case):
    """Every envelope the kernel reduces equals the one computed from the histories."""
    approach = 2.0
    if case == "sprung_lift_off":  # a deep dip: the wheel leaves the rail and lands again
        bridge = br.simply_supported(10.0, 2e9, 1e4, n_modes=4)
        train = vh.Train("sm", (vh.sprung_mass(5000.0, 1e7, 1e4, 500.0),), (0.0,))
        profile, speed, dt = _dip(0.004, 4.0, 0.5), 300 / 3.6, 5e-4
    elif case == "car_on_two_spans":
        bridge = br.continuous([12.0, 12.0], 5e9, 1.2e4, n_modes=6, elements_per_span=12)
        car = get_train("ICE3").vehicles[0]
        train = vh.Train("car", (car,), (0.0,))
        profile, speed, dt = _dip(0.002, 6.0, 1.0), 250 / 3.6, 1e-3
    else:
        bridge = br.simply_supported(25.0, 8.323e9, 2303.0, n_modes=10)
        train = get_train("HSLM-A3", model="moving_force")
        profile, speed, dt = no_irregularity(), 320 / 3.6, 1e-3
    settings = SolverSettings(dt=dt, approach=approach, free_vibration=0.1)
    points = [2.5, 5.0, 7.5] if bridge.length < 20 else [6.0, 12.0, 18.0]
    ds = sm.simulate(bridge, train, speed, profile, settings, output_points=points)
    assert ds.attrs["status"] == 0
    ds.attrs["approach"] = approach
    ref = _envelopes_from_histories(ds, dt)
    ref.update(_comfort_and_whole_deck(bridge, train, speed, profile, settings, points,
                                       ds["time"].values))
    if case == "sprung_lift_off":
        assert ref["contact_loss_events"].sum() >= 1  # the case really separates
    for name, value in ref.items():
        np.testing.assert_allclose(ds[name].values, value, rtol=RTOL, atol=0, err_msg=name)


def test_batch__many_speeds_in_one_call_equal_single_runs():
    """A batch of runs equals the same runs one by one, bit for bit (the workspace is
    reset between runs; nothing leaks from one run into the next)."""
    bridge = br.simply_supported(10.0, 2e9, 1e4, n_modes=4)
    train = vh.Train("sm", (vh.sprung_mass(5000.0, 1e7, 1e4, 500.0),), (0.0,))
    profile = _dip(0.004, 4.0, 0.5)
    settings = SolverSettings(dt=5e-4, approach=2.0, free_vibration=0.05)
    speeds = np.array([120.0, 300.0, 200.0]) / 3.6
    packed = sm.pack(bridge, train, speeds[0], profile, settings)
    batch = sm.run_batch(packed, profile, speeds, [5.0], settings, bridge,
                         keep_histories=[False, True, True])
    env = batch.envelopes()
    for r, v in enumerate(speeds):
        one = sm.simulate(bridge, train, v, profile, settings, output_points=[5.0])
        for name in env:
            np.testing.assert_array_equal(env[name][r], one[name].values, err_msg=name)
        if r:
            np.testing.assert_array_equal(batch.histories(r)["contact_force"],
                                          one["contact_force"].values)


def test_batch__moving_force_phasor_sum_equals_direct_sum():
    """Sine modes take the phasor form of the modal load (sums over the axles on the deck
    rebuilt when an axle enters or leaves, rotated each step); the reference sums the
    axles directly every step and integrates each mode with the trapezoidal rule
    (HHT-alpha with alpha = 0), written here."""
    train = get_train("HSLM-A1", model="moving_force")
    settings = SolverSettings(dt=1e-3, approach=5.0, free_vibration=0.0, hht_alpha=0.0)
    sine = br.simply_supported(25.0, 8.323e9, 2303.0, n_modes=5)
    speed = 300 / 3.6
    ds = sm.simulate(sine, train, speed, settings=settings, output_points=[12.5])
    # reference: the same HHT recursion (alpha = 0: trapezoidal) per mode, written here,
    # with the modal load summed directly over the axles on the span
    packed = sm.pack(sine, train, speed, no_irregularity(), settings)
    x0, p = packed.vehicles.load_x0, packed.vehicles.load_p
    dt, n = settings.dt, packed.params.n_steps
    w, z = sine.omega, sine.damping
    t = np.arange(n + 1) * dt
    x = x0[None, :] + speed * t[:, None]
    on = (x >= 0) & (x <= sine.length)
    phi = sine.shapes(x.ravel()).reshape(x.shape + (sine.n_modes,))
    f = np.einsum("tk,tkj->tj", np.where(on, p, 0.0), phi)
    q, v, a = np.zeros(sine.n_modes), np.zeros(sine.n_modes), np.zeros(sine.n_modes)
    qs = [q.copy()]
    k_eff = 4 / dt**2 + 2 * z * w * 2 / dt + w**2
    for i in range(n):
        rhs = f[i + 1] + (4 / dt**2) * q + (4 / dt) * v + a + 2 * z * w * ((2 / dt) * q + v)
        q_new = rhs / k_eff
        v_new = 2 / dt * (q_new - q) - v
        a = 4 / dt**2 * (q_new - q) - 4 / dt * v - a
        q, v = q_new, v_new
        qs.append(q.copy())
    w_mid = np.array(qs) @ sine.output_shapes([12.5]).T
    # the phasor sum differs from the direct one by round-off of ~1e3-rad phases
    np.testing.assert_allclose(ds["deck_displacement"].values, w_mid, rtol=0,
                               atol=1e-11 * np.abs(w_mid).max())
