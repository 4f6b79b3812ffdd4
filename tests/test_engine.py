"""Kernel units against slow, obvious oracles, and engine-level invariants.

Each kernel is compared with a dense numpy/itertools computation written here; the
physical validation against closed forms and ODE integrations is in test_validation.py.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from vsi_numba import kernels as ek
from vsi_numba.kernels.probe import (
    eval_modes,
    eval_profile,
    skyline_cholesky_solve,
    solve_active_set,
)
from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import Profile, cosine_defect, no_irregularity
from vsi_numba.solver import batch as sb
from vsi_numba.solver import driver, kernel_cache
from vsi_numba.solver import pack as sp
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

ICE_CAR = dict(
    body_mass=47800.0, body_pitch_inertia=1957888.0, bogie_mass=3500.0,
    bogie_pitch_inertia=1715.0, wheelset_mass=1800.0, bogie_spacing=17.375, wheelbase=2.5,
    primary_stiffness=2.4e6, primary_damping=2e4, secondary_stiffness=7e5,
    secondary_damping=4e4,
)


def _pack(bridge, train, speed=30.0, profile=None, **kw):
    settings = SolverSettings(**{"dt": 1e-3, "free_vibration": 0.0, **kw})
    return sm.pack(bridge, train, speed, profile or no_irregularity(), settings)


def _study_kernel_args(packed, v, points, settings, bridge):
    """The arguments ``run_batch`` gives the interaction kernels for one run at ``v``, the
    kernels compiled (or loaded from the cache, or waited for) as a study's batch would
    have them, so that calling ``kernels.time_loop`` from here compiles nothing."""
    captured = []
    sb.run_batch(packed, no_irregularity(), [v], points, settings, bridge,
                 _kernel=lambda *args: captured.append(args))
    sb.compile_family(kernel_cache.family_of(packed))
    return captured[0]


# ------------------------------------------------------------------------- evaluation


@pytest.mark.parametrize("kind", ["sine", "hermite"])
def test_eval_modes__matches_numpy_evaluation(kind):
    if kind == "sine":
        bridge = br.simply_supported(20.0, 5e9, 1e4, n_modes=6)
    else:
        bridge = br.continuous([12.0, 17.0], 5e9, 1e4, n_modes=6, elements_per_span=8)
    arr = sp._pack_bridge(bridge)
    x = np.linspace(-1.0, bridge.length + 1.0, 57)
    n = bridge.n_modes
    for xi in x:
        out, d1, d2 = np.zeros(n), np.zeros(n), np.zeros(n)
        onb = eval_modes(arr, xi, out, d1, d2)
        assert onb == int(0.0 <= xi <= bridge.length)
        # same cubic, two implementations (loops vs vectorised numpy): round-off only
        np.testing.assert_allclose(out, bridge.shapes([xi])[0], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(d1, bridge.shapes([xi], 1)[0], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(d2, bridge.shapes([xi], 2)[0], rtol=1e-9, atol=1e-9)


def test_eval_modes__sine_is_the_analytic_mode():
    L, EI, m = 20.0, 5e9, 1e4
    arr = sp._pack_bridge(br.simply_supported(L, EI, m, n_modes=3))
    out, d1, d2 = np.zeros(3), np.zeros(3), np.zeros(3)
    eval_modes(arr, 7.3, out, d1, d2)
    j = np.arange(1, 4)
    expected = np.sqrt(2 / (m * L)) * np.sin(j * np.pi * 7.3 / L)
    np.testing.assert_allclose(out, expected, rtol=1e-13)  # closed form, round-off only


def test_eval_profile__matches_spline_evaluation():
    x = np.linspace(0.0, 10.0, 41)
    prof = Profile.from_samples(x, 1e-3 * np.sin(x) + 2e-4 * x)
    arr = ek.ProfileArrays(prof.x0, prof.dx, prof.coef)
    out = np.zeros(3)
    for xi in np.linspace(-0.5, 10.5, 101):
        eval_profile(arr, xi, out)
        expected = [prof(xi), prof(xi, 1), prof(xi, 2)]
        np.testing.assert_allclose(out, np.ravel(expected), atol=1e-14)  # same cubic


def test_profile__spline_is_c2():
    prof = cosine_defect(0.01, 3.0, 5.0)
    knots = prof.x0 + prof.dx * np.arange(1, prof.coef.shape[0])
    eps = 1e-9
    for d in (0, 1, 2):
        left, right = prof(knots - eps, d), prof(knots + eps, d)
        scale = np.abs(prof(knots, d)).max()
        # continuity across every knot, up to the eps-shift of a smooth function
        assert np.max(np.abs(left - right)) < 1e-6 * scale


# ------------------------------------------------------------------------ Schur solve


def test_cholesky_solve__dense_envelope_matches_numpy():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(7, 7))
    A = A @ A.T + 7 * np.eye(7)
    idx = np.array([5, 1, 3, 0, 0, 0, 0])
    first = np.zeros(7, np.int64)  # the full envelope: a dense factorisation
    b = rng.normal(size=7)
    x = np.zeros(7)
    assert skyline_cholesky_solve(A, idx, 3, first, np.zeros((7, 7)), b, x) == 0
    sub = A[np.ix_(idx[:3], idx[:3])]
    np.testing.assert_allclose(x[:3], np.linalg.solve(sub, b[:3]), rtol=1e-12)
    assert skyline_cholesky_solve(-A, idx, 3, first, np.zeros((7, 7)), b, x) == 1  # not SPD


def _brute_force_lcp(S, gstar, scale):
    """All 2^n active sets: the one with X >= 0 on it and gap >= 0 off it."""
    n = len(gstar)
    for bits in itertools.product([0, 1], repeat=n):
        act = np.array(bits, bool)
        X = np.zeros(n)
        if act.any():
            X[act] = np.linalg.solve(S[np.ix_(act, act)], -gstar[act] / scale)
        gap = gstar + scale * S @ X
        if np.all(X[act] >= -1e-12) and np.all(gap[~act] >= -1e-12):
            return X
    raise AssertionError("no complementary solution")


@pytest.mark.parametrize("seed", range(6))
def test_solve_active_set__is_the_lcp_solution(seed):
    rng = np.random.default_rng(seed)
    n = 5
    A = rng.normal(size=(n, n))
    S = A @ A.T * 1e-9 + np.eye(n) * 1e-9
    gstar = rng.normal(size=n) * 1e-4
    scale = 0.9
    # a packed train of n wheels (the types a study gives the kernel), all on the bridge:
    # the whole S block is coupled
    cars = tuple(vh.sprung_mass(5e3, 1e6, 1e3, 400.0) for _ in range(n))
    veh = _pack(br.simply_supported(20.0, 5e9, 1e4, n_modes=1),
                vh.Train("masses", cars, tuple(3.0 * k for k in range(n)))).vehicles
    wk = sb._workspace(1, 2 * n, n, veh)
    wk.onb[:] = 1
    wk.S[:] = S
    wk.gstar[:] = gstar
    wk.active[:] = rng.integers(0, 2, n)
    status, _ = solve_active_set(driver.contact_view(veh, wk), scale, 50, 1e-15, 1e-9)
    assert status == ek.OK
    # the LCP with an SPD matrix has one solution: the two must agree to round-off
    np.testing.assert_allclose(wk.X, _brute_force_lcp(S, gstar, scale), rtol=1e-8, atol=1e-6)


def test_solve_active_set__envelope_follows_the_on_bridge_flags():
    """The envelope of the Schur block is kept from one solve to the next while the same
    wheels are active with the same on-bridge flags, and rebuilt when a flag changes:
    wheels of separate vehicles off the bridge (S diagonal), then on it (S dense: a kept
    diagonal envelope would drop the coupling), then off again; each solve equals the
    brute-force LCP solution (an SPD matrix: one solution, so the two agree to the
    round-off of two factorisations, far inside rtol 1e-8; the kept diagonal envelope
    on the dense S moves the forces by ~15 % of the largest, measured)."""
    rng = np.random.default_rng(7)
    n = 5
    A = rng.normal(size=(n, n))
    dense = A @ A.T * 1e-9 + np.eye(n) * 1e-9
    gstar = -np.abs(rng.normal(size=n)) * 1e-4
    scale = 0.9
    cars = tuple(vh.sprung_mass(5e3, 1e6, 1e3, 400.0) for _ in range(n))
    veh = _pack(br.simply_supported(20.0, 5e9, 1e4, n_modes=1),
                vh.Train("masses", cars, tuple(3.0 * k for k in range(n)))).vehicles
    wk = sb._workspace(1, 2 * n, n, veh)
    for on in (0, 1, 0, 1):
        S = dense if on else np.diag(np.diag(dense))  # coupled only on the bridge
        wk.onb[:] = on
        wk.S[:] = S
        wk.gstar[:] = gstar
        wk.active[:] = 1
        status, _ = solve_active_set(driver.contact_view(veh, wk), scale, 50, 1e-15, 1e-9)
        assert status == ek.OK
        np.testing.assert_allclose(wk.X, _brute_force_lcp(S, gstar, scale), rtol=1e-8,
                                   atol=1e-6)


def test_build_schur__equals_dense_b_khat_inv_bt():
    """The Schur matrix of a step (the study's kernel, ``time_loop`` with ``run_batch``'s
    arguments, stopped after a step with the car partly on the deck) equals
    B K^-1 B^T formed densely: B = [-phi(x_i) | e_wheel], K^ = blockdiag(modal
    a0 + (1 + alpha)(a1 c_j + w_j^2), the vehicle blocks' effective stiffness).  Then the
    envelope solve of the active block equals a dense solve."""
    beam = br.simply_supported(20.0, 5e9, 1e4, n_modes=5)
    car = vh.railway_car(**ICE_CAR)
    train = vh.Train("two", (car, vh.sprung_mass(5e3, 1e6, 1e3, 400.0)), (0.0, 25.0))
    settings = SolverSettings(dt=1e-3, free_vibration=0.0)
    v = 30.0
    p = sm.pack(beam, train, v, no_irregularity(), settings)
    (brg, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, _, _, _) = \
        _study_kernel_args(p, v, [10.0], settings, beam)
    n_w = veh.wheel_dof.size
    n = int(round(35.0 / v / prm.dt))  # some wheels on the bridge, some off it
    t = n * prm.dt
    xa = veh.wheel_x0 + v * ((n - 1) * prm.dt)
    x = veh.wheel_x0 + v * t
    assert not (((xa < 0) & (x >= 0)) | ((xa <= beam.length) & (x > beam.length))).any()
    driver.start_vsi_run(init, 0, st, wk)
    p_n = prm._replace(speed=v, n_steps=n)
    assert ek.time_loop(brg, veh, pr, p_n, st, bk, wk, red, 0, out, -1) == (ek.OK, n)
    # dense oracle, with the HHT constants of the step computed here
    alpha, dt = settings.hht_alpha, prm.dt
    beta, gamma = 0.25 * (1 - alpha) ** 2, 0.5 - alpha
    w = beam.omega
    khat_q = 1 / (beta * dt**2) + (1 + alpha) * (gamma / (beta * dt) * 2 * beam.damping * w
                                                 + w**2)
    n_m = beam.n_modes
    Kinv = np.zeros((n_m + p.n_dof,) * 2)
    Kinv[:n_m, :n_m] = np.diag(1 / khat_q)
    Kinv[n_m:, n_m:] = sp._dense(veh, veh.Khat_inv[0])
    B = np.zeros((n_w, n_m + p.n_dof))
    B[:, :n_m] = -beam.shapes(x)
    B[np.arange(n_w), n_m + veh.wheel_dof] = 1.0
    assert 0 < wk.onb.sum() < n_w
    np.testing.assert_allclose(wk.S, B @ Kinv @ B.T, rtol=1e-12, atol=1e-20)

    # the envelope solve of the active block (the step's: wk.idx, wk.first) equals a
    # dense solve
    m = int(wk.active.sum())
    active = wk.idx[:m].copy()
    np.testing.assert_array_equal(active, np.flatnonzero(wk.active))
    assert np.any(wk.first[:m] > 0)  # the envelope really is narrower than dense
    rhs = np.linspace(1.0, 2.0, n_w)
    x = np.zeros(n_w)
    assert skyline_cholesky_solve(wk.S, wk.idx, m, wk.first, wk.L, rhs, x) == 0
    # same factorisation restricted to structural non-zeros: round-off only
    np.testing.assert_allclose(x[:m], np.linalg.solve(wk.S[np.ix_(active, active)], rhs[:m]),
                               rtol=1e-9)


# ------------------------------------------------------------------- engine invariants


def test_static_start__kept_on_level_rigid_track_for_every_library_train():
    from vsi_numba.model.library import get_train, list_presets

    names = [n for n in list_presets() if not n.upper().startswith("HSLM")]
    assert len(names) >= 2
    for name in names:
        train = get_train(name)
        ds = sm.simulate(br.rigid(5.0), train, 50.0,
                         settings=SolverSettings(dt=2e-3, approach=1.0, free_vibration=0.0))
        assert ds.attrs["status"] == 0, name
        q0 = ds.static_wheel_load
        # equilibrium is exact up to round-off of ~1e5 N forces: 1e-8 relative
        assert float(np.abs(ds.contact_force - q0).max()) < 1e-8 * float(q0.max()), name
        assert float(np.abs(ds.carbody_acceleration).max()) < 1e-9, name


def test_static_wheel_loads__sum_to_the_weight():
    car = vh.railway_car(**ICE_CAR)
    p = _pack(br.rigid(10.0), vh.Train("c", (car,), (0.0,)))
    Q = sm.static_wheel_loads(p)
    total = 9.81 * (47800 + 2 * 3500 + 4 * 1800)
    np.testing.assert_allclose(Q.sum(), total, rtol=1e-12)  # statics, round-off only


def test_kkt__a_kept_solution_is_the_solve_bit_for_bit_and_the_callers_own():
    """The static solves are kept by a digest of their inputs: a repeated system gives
    the solve's own bits (checked against numpy's solve of the same scaled system, which
    the kept entry never saw), the caller may change what it got, and a changed input
    is solved anew."""
    rng = np.random.default_rng(7)
    n, m = 30, 4
    a = rng.standard_normal((n, n))
    A = a @ a.T + n * np.eye(n)  # symmetric positive definite, like a vehicle's K
    G = np.zeros((m, n))
    G[np.arange(m), [3, 9, 17, 25]] = 1.0
    top, bottom = rng.standard_normal(n), rng.standard_normal(m)
    s = float(np.max(np.abs(A)))
    kkt = np.block([[A, s * G.T], [s * G, np.zeros((m, m))]])
    ref = np.linalg.solve(kkt, np.concatenate([top, s * bottom]))
    for _ in range(2):  # solved, then kept
        x, y = sp._kkt(A, G, top, bottom)
        assert np.array_equal(x, ref[:n]) and np.array_equal(y, s * ref[n:])
        x[:] = np.nan  # the caller's own arrays: the kept solution is not touched
        y[:] = np.nan
    bottom2 = bottom.copy()
    bottom2[0] += 1e-3
    x2, _ = sp._kkt(A, G, top, bottom2)
    ref2 = np.linalg.solve(kkt, np.concatenate([top, s * bottom2]))
    assert np.array_equal(x2, ref2[:n])


def test_simulate__moving_force_train_has_loads_as_contact_forces():
    train = vh.Train("f", (vh.point_loads([0.0, 3.0], [1e5, 2e5]),), (0.0,))
    ds = sm.simulate(br.simply_supported(10.0, 1e9, 5e3, n_modes=2), train, 20.0,
                     settings=SolverSettings(dt=2e-3, free_vibration=0.1))
    np.testing.assert_array_equal(ds.contact_force.isel(time=5).values, [1e5, 2e5])
    assert ds.sizes["vehicle"] == 0


# --------------------------------------------------------------------- failure paths


def test_failure__contact_not_converged_is_flagged_and_masked():
    car = vh.sprung_mass(5000.0, 5e5, 2e3, 500.0)
    train = vh.Train("q", (car,), (0.0,))
    # a landing needs two active-set iterations; allow one, and no step subdivision
    ds = sm.simulate(br.rigid(20.0), train, 30.0, profile=cosine_defect(0.03, 2.0, 5.0),
                     settings=SolverSettings(dt=1e-3, max_iterations=1, max_subdivisions=0,
                                             free_vibration=0.0))
    assert ds.attrs["status"] == ek.NOT_CONVERGED
    assert "did not converge" in ds.attrs["message"]
    assert np.all(np.isnan(ds.max_contact_force))


def test_failure__same_case_converges_with_default_settings():
    car = vh.sprung_mass(5000.0, 5e5, 2e3, 500.0)
    train = vh.Train("q", (car,), (0.0,))
    ds = sm.simulate(br.rigid(20.0), train, 30.0, profile=cosine_defect(0.03, 2.0, 5.0),
                     settings=SolverSettings(dt=1e-3, free_vibration=0.0))
    assert ds.attrs["status"] == 0
    assert int(ds.max_iterations) == 2  # the landing: one attach, one confirmation
    assert float(ds.contact_loss_duration[0]) > 0.0


def test_failure__diverging_vehicle_is_caught_as_non_finite():
    # a negative stiffness makes the vehicle statically unstable: exponential growth
    bad = vh.user_vehicle(M=[[1000.0, 0.0], [0.0, 100.0]],
                          C=np.zeros((2, 2)),
                          K=[[-1e9, 1e9], [1e9, -1e9]],
                          wheel_dofs=[1], wheel_positions=[0.0])
    ds = sm.simulate(br.rigid(300.0), vh.Train("bad", (bad,), (0.0,)), 30.0,
                     settings=SolverSettings(dt=1e-3, free_vibration=0.0))
    assert ds.attrs["status"] == ek.NON_FINITE
    assert np.all(np.isnan(ds.max_carbody_acceleration))


def test_failure__singular_vehicle_is_a_clear_model_error():
    # a DOF with neither mass nor stiffness cannot be integrated
    bad = vh.user_vehicle(M=[[1000.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 0.0]],
                          C=np.zeros((3, 3)),
                          K=[[1e6, -1e6, 0.0], [-1e6, 1e6, 0.0], [0.0, 0.0, 0.0]],
                          wheel_dofs=[1], wheel_positions=[0.0])
    with pytest.raises(sm.ModelError, match="singular effective stiffness"):
        sm.simulate(br.rigid(10.0), vh.Train("bad", (bad,), (0.0,)), 30.0)


def test_hht__algorithmic_damping_of_bridge_modes_is_negligible():
    """The default alpha must not damp the modes that govern EN 1990 A2 checks."""
    beam = br.simply_supported(20.0, 2e10, 1e4, n_modes=1)  # f1 = 5.5 Hz
    train = vh.Train("f", (vh.moving_force(1e5),), (0.0,))
    ds = sm.simulate(beam, train, 50.0, settings=SolverSettings(dt=1e-3, approach=0.0,
                                                                free_vibration=3.0))
    assert SolverSettings().hht_alpha == -0.3
    t = ds.time.values
    w = ds.deck_displacement[:, 0].values
    free = t > 20.0 / 50.0 + 0.01
    first = np.abs(w[free & (t < t[free][0] + 0.2)]).max()
    last = np.abs(w[t > t[-1] - 0.2]).max()
    # 16 cycles of free vibration, undamped structure: amplitude kept to 0.1 %
    # (an algorithmic damping ratio of 1e-5 would lose 0.1 %; sampling the peaks at
    # dt = 1 ms adds at most (2 pi f dt)^2 / 2 = 0.06 %)
    assert abs(last / first - 1.0) < 1e-3


def test_failure__huge_profile_step_is_survived_or_flagged():
    from vsi_numba.model.irregularity import step_defect

    car = vh.railway_car(**ICE_CAR)
    # a 10 cm drop of the rail over 5 cm of track: every wheel flies and lands hard
    prof = step_defect(0.10, 0.05, 3.0, x_stop=60.0)
    ds = sm.simulate(br.simply_supported(20.0, 5e10, 1.5e4, n_modes=3),
                     vh.Train("car", (car,), (0.0,)), 40.0, profile=prof,
                     settings=SolverSettings(dt=1e-3, free_vibration=0.2))
    if ds.attrs["status"] == 0:
        assert np.all(np.isfinite(ds.contact_force))
        assert float(ds.contact_loss_duration.max()) > 0.0  # the wheels did lift off
        assert np.all(ds.contact_force >= 0.0)  # unilateral: never a pulling wheel
    else:  # flagged: then masked, with a message
        assert np.all(np.isnan(ds.max_contact_force))
        assert ds.attrs["message"] != "ok"


def test_failure__absurd_dt_refused_or_warned_with_the_ratio():
    """dt = 0.2 s on a 43 Hz mode: refused (naming solver.dt and the ratio) unless the
    user overrides it; then a warning with the ratio."""
    from vsi_numba.config import ConfigError, load_config

    data = {
        "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
                   "mass_per_length": 2303.0, "n_modes": 3},
        "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0,
                                "stiffness": 1.595e6}]},
        "solver": {"dt": 0.2},
        "study": {"speeds_kmh": [100.0]},
    }
    with pytest.raises(ConfigError, match=r"solver.dt = 0.2.*8\.6"):
        load_config(data)
    data["solver"]["allow_coarse_dt"] = True
    cfg = load_config(data)
    [w] = [w for w in cfg.warnings if "bridge mode" in w]
    assert "solver.dt" in w and "8.6" in w  # dt x f3 = 0.2 s x 43 Hz = 8.6


def test_start_vsi_run__state_from_its_row_and_the_workspace_as_allocated():
    """Between two interaction runs: the state is row ``r`` of the initial states and
    every workspace array is back to its value in a freshly allocated workspace
    (``batch._workspace``), whatever the previous run left in it."""
    beam = br.simply_supported(20.0, 5e9, 1e4, n_modes=5)
    car = vh.railway_car(**ICE_CAR)
    train = vh.Train("two", (car, vh.sprung_mass(5e3, 1e6, 1e3, 400.0)), (0.0, 25.0))
    p = _pack(beam, train)
    veh = p.vehicles
    fresh = sb._workspace(beam.n_modes, p.n_dof, veh.wheel_dof.size, veh)
    wk = sb._workspace(beam.n_modes, p.n_dof, veh.wheel_dof.size, veh)
    rng = np.random.default_rng(3)
    for a in wk:  # what a run leaves behind
        a[...] = rng.integers(-5, 6, a.shape)
    st0 = sm.initial_state(p, no_irregularity())
    init = ek.State(*(rng.normal(size=(3, *a.shape)) for a in st0))
    st = ek.State(*(np.full_like(a, np.nan) for a in st0))
    driver.start_vsi_run(init, 1, st, wk)
    for name, a, b in zip(ek.State._fields, st, init, strict=True):
        np.testing.assert_array_equal(a, b[1], err_msg=name)
    for name, a, b in zip(ek.Work._fields, wk, fresh, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert wk.active.size > 0 and np.all(wk.active == 1) and np.all(wk.ones == 1.0)


def test_with_patterns__every_nonzero_and_only_those():
    """The patterns the step's sums run over (``solver.driver.with_patterns``, set by ``pack``):
    each row of each block of M, C and K lists exactly its nonzero columns, ascending;
    each block lists its wheel DOFs; each compliance row its nonzeros and its diagonal."""
    import dataclasses

    from vsi_numba.model.track import ElasticTrack

    beam = dataclasses.replace(br.simply_supported(20.0, 5e9, 1e4, n_modes=5),
                               track=ElasticTrack())
    car = vh.railway_car(**ICE_CAR)
    train = vh.Train("two", (car, vh.sprung_mass(5e3, 1e6, 1e3, 400.0)), (0.0, 25.0))
    veh = _pack(beam, train, contact_model="hertz_linear", hertz_coefficient=4e-8).vehicles
    n_veh = veh.start.size - 1
    assert n_veh == 2 and veh.compliance.shape == (5, 5)
    for m, A in enumerate((veh.M, veh.C, veh.K)):
        for b in range(n_veh):
            n = veh.start[b + 1] - veh.start[b]
            for r in range(n):
                cols = veh.blk_col[m, b, veh.blk_ptr[m, b, r]:veh.blk_ptr[m, b, r + 1]]
                np.testing.assert_array_equal(cols, np.flatnonzero(A[b, r, :n]))
    assert veh.blk_ptr[0, 0, 10] == 10  # the car's mass matrix is diagonal
    assert veh.blk_ptr[2, 0, 10] < 60  # and its stiffness sparse
    for b in range(n_veh):
        for r in range(veh.start[b + 1] - veh.start[b]):
            local = veh.blk_col[3, b, veh.blk_ptr[3, b, r]:veh.blk_ptr[3, b, r + 1]]
            np.testing.assert_array_equal(
                local, np.sort(veh.wheel_dof[veh.wheel_veh == b] - veh.start[b]))
    nz = (veh.compliance != 0.0) | np.eye(5, dtype=bool)
    assert not nz.all()  # the rail's compliance is not dense here
    for i in range(5):
        np.testing.assert_array_equal(veh.comp_col[veh.comp_ptr[i]:veh.comp_ptr[i + 1]],
                                      np.flatnonzero(nz[i]))


@pytest.mark.parametrize("elastic", [False, True])
def test_contact_search__rows_of_wheels_off_the_deck_are_zero_along_a_passage(elastic):
    """``contact_search`` zeroes the mode-shape rows of a wheel once, when it leaves the
    deck (the elastic track's table), and skips rows that are zero already: stopped at
    steps along a passage (the study's kernel with ``run_batch``'s arguments), the rows
    of every wheel off the deck are zero - also of the wheels that have crossed it - and
    on the rigid track the rows of the wheels on it are the mode shapes there."""
    import dataclasses

    from vsi_numba.model.track import ElasticTrack

    beam = br.simply_supported(20.0, 5e9, 1e4, n_modes=5)
    if elastic:
        beam = dataclasses.replace(beam, track=ElasticTrack())
    train = vh.Train("car", (vh.railway_car(**ICE_CAR),), (0.0,))
    settings = SolverSettings(dt=1e-3, approach=5.0, free_vibration=0.05)
    v = 40.0
    packed = sm.pack(beam, train, v, no_irregularity(), settings)
    (brg, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, _, _, _) = \
        _study_kernel_args(packed, v, [10.0], settings, beam)
    lo, hi = (brg.t_nodes[0], brg.t_nodes[-1]) if elastic else (0.0, beam.length)
    seen = set()
    for n in np.linspace(1, int(n_steps[0]), 25).astype(int):
        driver.start_vsi_run(init, 0, st, wk)
        p = prm._replace(speed=float(speeds[0]), n_steps=int(n))
        assert ek.time_loop(brg, veh, pr, p, st, bk, wk, red, 0, out, -1) == (ek.OK, n)
        x = veh.wheel_x0 + v * n * prm.dt
        on = (x >= lo) & (x <= hi)
        np.testing.assert_array_equal(wk.onb, on)
        for a in (wk.phi, wk.dphi, wk.d2phi):
            assert np.all(a[~on] == 0.0)
        if not elastic and on.any():
            np.testing.assert_allclose(wk.phi[on], beam.shapes(x[on]), rtol=1e-9,
                                       atol=1e-12)
        seen.update(("on" if o else "left" if xi > hi else "ahead")
                    for o, xi in zip(on, x, strict=True))
    assert seen == {"on", "left", "ahead"}  # every case met, rows that were set included
