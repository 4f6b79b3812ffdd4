"""Dynamic load effects (bending moment, shear, reactions, rotations): the static
influence lines against textbook closed forms, the mode-acceleration results of the
engine against Fryba's analytic modal series, global equilibrium of an interaction run,
and the refusals for bridges that cannot give them.

Every reference is computed here, independently of vsi_numba.model.influence.
"""

from __future__ import annotations

import numpy as np
import pytest

from vsi_numba.model import bridge as br
from vsi_numba.model import influence as inf
from vsi_numba.model import vehicle as vh
from vsi_numba.model.imported.matrices import modes_from_matrices
from vsi_numba.model.irregularity import no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver import batch as sb
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

# -------------------------------------------------------------------- static: closed forms


def _ss_reference(L, EI, loads, x):
    """Simply supported span, textbook formulas (Roark, case 'concentrated load'),
    superposed over ``loads`` = [(a, P)]: M, V (just right), R_A, R_B, theta_A, theta_B,
    w at ``x``."""
    M = np.zeros_like(x)
    V = np.zeros_like(x)
    w = np.zeros_like(x)
    RA = RB = thA = thB = 0.0
    for a, P in loads:
        b = L - a
        M += np.where(x <= a, P * b * x / L, P * a * (L - x) / L)
        V += np.where(x < a, P * b / L, -P * a / L)
        w += np.where(x <= a, P * b * x * (L**2 - b**2 - x**2),
                      P * a * (L - x) * (L**2 - a**2 - (L - x) ** 2)) / (6 * EI * L)
        RA += P * b / L
        RB += P * a / L
        thA += P * a * b * (L + b) / (6 * EI * L)
        thB -= P * a * b * (L + a) / (6 * EI * L)
    return M, V, w, np.array([RA, RB]), np.array([thA, thB])


def test_influence__simply_supported_matches_textbook():
    L, EI = 20.0, 4e9
    loads = [(3.0, 1.0e5), (7.5, 2.0e5), (15.2, 0.7e5)]
    x = np.array([0.0, 2.0, 3.0, 7.5, 10.0, 15.2, 19.0, 20.0])
    st = inf.beam_deck([L], EI)
    xl = np.array([a for a, _ in loads])
    P = np.array([p for _, p in loads])
    M, V, w, R, th = _ss_reference(L, EI, loads, x)
    # same closed forms, different algebra (three-moment solver path, broadcasting):
    # round-off only
    np.testing.assert_allclose(inf.influence(st, "moment", x, xl) @ P, M, rtol=1e-12,
                               atol=1e-6)
    np.testing.assert_allclose(inf.influence(st, "shear", x, xl) @ P, V, rtol=1e-12,
                               atol=1e-7)
    np.testing.assert_allclose(inf.influence(st, "deflection", x, xl) @ P, w, rtol=1e-12,
                               atol=1e-18)
    np.testing.assert_allclose(inf.influence(st, "reaction", [0, 1], xl) @ P, R, rtol=1e-12)
    np.testing.assert_allclose(inf.influence(st, "rotation", [0, 1], xl) @ P, th, rtol=1e-12)
    # a load off the deck has no effect
    assert not np.any(inf.influence(st, "moment", x, [-0.1, 20.1]))


def test_influence__two_span_continuous_three_moment_equation():
    """Two spans of different length and EI, several loads in both: the support moment
    of the three-moment (Clapeyron) equation, then each span as a simply supported span
    with its end moment."""
    L1, L2, E1, E2 = 12.0, 18.0, 3e9, 5e9
    loads = [(4.0, 1.0e5), (9.0, 0.5e5), (12.0 + 6.0, 2.0e5), (12.0 + 15.0, 1.2e5)]
    f1, f2 = L1 / E1, L2 / E2
    rhs = 0.0
    for x, P in loads:  # -6 x (end slopes of the simply supported spans)
        if x < L1:
            a, b = x, L1 - x
            rhs -= P * a * b * (L1 + a) / (L1 * E1)
        else:
            a, b = x - L1, L1 + L2 - x
            rhs -= P * a * b * (L2 + b) / (L2 * E2)
    MB = rhs / (2 * (f1 + f2))
    l1 = [(x, P) for x, P in loads if x < L1]
    l2 = [(x - L1, P) for x, P in loads if x >= L1]
    xs1 = np.array([0.0, 3.0, 4.0, 9.0, 11.9])
    xs2 = np.array([0.0, 6.0, 10.0, 17.0, 18.0])
    M1, V1, _, R1, th1 = _ss_reference(L1, E1, l1, xs1)
    M2, V2, _, R2, th2 = _ss_reference(L2, E2, l2, xs2)
    M_ref = np.concatenate([M1 + MB * xs1 / L1, M2 + MB * (1 - xs2 / L2)])
    V_ref = np.concatenate([V1 + MB / L1, V2 - MB / L2])
    R_ref = np.array([R1[0] + MB / L1, R1[1] - MB / L1 + R2[0] - MB / L2, R2[1] + MB / L2])
    th_ref = np.array([th1[0] + MB * L1 / (6 * E1), th2[0] + MB * L2 / (3 * E2),
                       th2[1] - MB * L2 / (6 * E2)])
    st = inf.beam_deck([L1, L2], [E1, E2])
    xl = np.array([x for x, _ in loads])
    P = np.array([p for _, p in loads])
    x = np.concatenate([xs1, xs2 + L1])
    # exact both ways: round-off only
    np.testing.assert_allclose(inf.influence(st, "moment", x, xl) @ P, M_ref, rtol=1e-10,
                               atol=1e-5)
    np.testing.assert_allclose(inf.influence(st, "shear", x, xl) @ P, V_ref, rtol=1e-10,
                               atol=1e-6)
    np.testing.assert_allclose(inf.influence(st, "reaction", [0, 1, 2], xl) @ P, R_ref,
                               rtol=1e-10)
    np.testing.assert_allclose(inf.influence(st, "rotation", [0, 1, 2], xl) @ P, th_ref,
                               rtol=1e-10)
    # global equilibrium: the reactions carry the loads
    assert inf.influence(st, "reaction", [0, 1, 2], xl).sum(axis=0) == pytest.approx(1.0)


def test_influence__refusals_say_what_is_available():
    x = np.linspace(0.0, 20.0, 41)
    table = br.from_table(x, np.sin(np.pi * x / 20.0)[:, None] * 0.01, [3.0])
    assert table.static is None
    with pytest.raises(inf.LoadEffectError, match=r"(?s)modes table.*no bending stiffness"
                       r".*Available from the modes: deck deflection and rotation"):
        inf.influence(table.static, "moment", [10.0], [5.0])
    with pytest.raises(inf.LoadEffectError, match="expected one of deflection, moment"):
        inf.influence(inf.beam_deck([20.0], 1e9), "torque", [10.0], [5.0])
    with pytest.raises(inf.LoadEffectError, match="support indices 0 .. 1"):
        inf.influence(inf.beam_deck([20.0], 1e9), "reaction", [2], [5.0])
    # FE matrices: reactions and rotations from K, the moment refused
    spans, EI = [12.0, 18.0], [3e9, 5e9]
    nodes, K, M, fixed, _ = br.beam_matrices(spans, EI, 1000.0, 12)
    res = modes_from_matrices(K, M, nodes, 2 * np.arange(nodes.size),
                              2 * np.arange(nodes.size) + 1, fixed, n_modes=3, spans=spans)
    st = res.bridge.static
    assert st.effects == ("deflection", "reaction", "rotation")
    with pytest.raises(inf.LoadEffectError, match=r"FE matrices.*section forces.*Available: "
                       r"deflection, support reactions"):
        inf.influence(st, "shear", [5.0], [3.0])
    beam = inf.beam_deck(spans, EI)
    xl = nodes[[3, 12, 20]]  # at stations: the linear sharing is exact there
    for effect in ("reaction", "rotation"):
        # Hermite FE is exact at the nodes for nodal loads: round-off of the sparse solve
        np.testing.assert_allclose(inf.influence(st, effect, [0, 1, 2], xl),
                                   inf.influence(beam, effect, [0, 1, 2], xl),
                                   rtol=1e-8, atol=1e-14)
    no_rot = modes_from_matrices(K, M, nodes, 2 * np.arange(nodes.size), None, fixed,
                                 n_modes=3, spans=spans).bridge.static
    with pytest.raises(inf.LoadEffectError, match="no rotation DOFs"):
        inf.influence(no_rot, "rotation", [0], [3.0])


def test_modal_effects__fe_quadrature_matches_analytic_sine_modes():
    """One-span FE deck (quadrature of the modal inertia load) against the analytic sine
    modes (EI phi'', EI phi''' ...): equal up to the FE error of the modes."""
    L, EI, m = 25.0, 8e9, 2300.0
    sine = br.simply_supported(L, EI, m, n_modes=5)
    fe = br.continuous([L], EI, m, n_modes=5, elements_per_span=40)
    x = np.array([0.0, 3.0, 12.5, 21.0, 25.0])
    for effect, at in (("moment", x), ("shear", x), ("reaction", [0, 1]),
                       ("rotation", [0, 1])):
        a = inf.modal_effects(sine, effect, at)
        b = inf.modal_effects(fe, effect, at)
        b = b * np.sign(np.sum(a * b, axis=0))  # mode signs are arbitrary
        # 40 cubic elements: mode-5 shapes to ~1e-4; the shear is as good as the moment
        np.testing.assert_allclose(b, a, rtol=0, atol=5e-4 * np.abs(a).max())


# ----------------------------------------------------------- moving force: convergence


def _fryba(L, EI, m, P, v, x, t, n_modes):
    """Frýba's closed-form modal series (railway notes 3.1), undamped, from rest, while
    the force is on the span: M = EI sum a_j k_j^2 q_j sin(k_j x), V its x-derivative."""
    j = np.arange(1, n_modes + 1)
    k = j * np.pi / L
    w = k**2 * np.sqrt(EI / m)
    W = k * v
    amp = 2 * P / (m * L)
    q = amp * (np.sin(np.outer(t, W)) - W / w * np.sin(np.outer(t, w))) / (w**2 - W**2)
    M = EI * (q * k**2) @ np.sin(np.outer(k, x))
    V = EI * (q * k**3) @ np.cos(np.outer(k, x))
    return M, V


def test_moving_force__mode_acceleration_converges_with_few_modes():
    """A force crossing a simply supported span: the engine's M and V (mode
    acceleration) with 1, 2 and 4 modes against Frýba's series with 3000 modes; plain
    modal superposition with the same modes misses by far (the shear worst)."""
    L, EI, m, P, v = 20.0, 5e9, 5000.0, 2.0e5, 40.0  # f1 = 3.9 Hz, speed parameter 0.25
    dt = 2e-4
    train = Train("F", (vh.moving_force(P),), (0.0,))
    settings = SolverSettings(dt=dt, hht_alpha=0.0, approach=0.0, free_vibration=0.0)
    xs = np.array([2.0, 7.0, 10.0, 15.5])
    errors = {}
    for n_modes in (1, 2, 4):
        bridge = br.simply_supported(L, EI, m, n_modes=n_modes)
        packed = sm.pack(bridge, train, v, no_irregularity(), settings)
        res = sb.run_batch(packed, no_irregularity(), [v], xs, settings, bridge,
                           keep_histories=[True])
        h = res.histories(0)
        n = int(res.n_steps[0]) + 1
        t = np.arange(n) * dt
        on = v * t <= L  # Frýba's formula holds while the force is on the span
        if n_modes == 1:
            M_ref, V_ref = _fryba(L, EI, m, P, v, xs, t[on], 3000)
            M_chk, V_chk = _fryba(L, EI, m, P, v, xs, t[on], 1500)
            # away from the force: the series of V has a Gibbs jump under it
            far = np.abs(v * t[on][:, None] - xs[None, :]) > 0.5
            M_scale, V_scale = np.abs(M_ref).max(), np.abs(V_ref).max()
            # the reference's own truncation (3000 vs 1500 modes)
            assert np.abs(M_ref - M_chk).max() / M_scale < 3e-4  # tail ~ 0.4 / N
            assert np.abs((V_ref - V_chk)[far]).max() / V_scale < 5e-3
        e = res.effects
        q = res.out.q[0, :n][on]
        plain_M = q @ e.E[:, e.point_index]  # sum_j E_j q_j
        plain_V = q @ e.E[:, e.n_sections + e.point_index]
        errors[n_modes] = (
            np.abs(h["bending_moment"][on] - M_ref).max() / M_scale,
            np.abs((h["shear_force"][on] - V_ref)[far]).max() / V_scale,
            np.abs(plain_M - M_ref).max() / M_scale,
            np.abs((plain_V - V_ref)[far]).max() / V_scale)
        # the kernel's envelopes are the extremes of the histories (same formula; the
        # static part by the kernel's sweep vs influence() for the histories): round-off
        env = res.envelopes()
        for name in ("bending_moment", "shear_force"):
            scale = np.abs(h[name]).max()
            np.testing.assert_allclose(env[f"max_{name}"][0], h[name].max(axis=0),
                                       rtol=0, atol=1e-9 * scale)
            np.testing.assert_allclose(env[f"min_{name}"][0], h[name].min(axis=0),
                                       rtol=0, atol=1e-9 * scale)
    ma_M, ma_V, pl_M, pl_V = (np.array([errors[k][i] for k in (1, 2, 4)]) for i in range(4))
    # mode acceleration converges with the modes kept (measured: M 3.0, 0.95, 0.28 %;
    # V 6.4, 3.5, 1.6 %); what remains is the free vibration of the dropped modes set off
    # by the force entering the span at speed (~ sum_{j > n} 1/j^2 of the shear), and the
    # time error of dt = 2e-4 s (< 0.1 %: halving dt changes the errors by < 1 %)
    assert np.all(np.diff(ma_M) < 0) and np.all(np.diff(ma_V) < 0)
    assert ma_M[-1] < 5e-3 and ma_V[-1] < 2.5e-2
    # plain superposition with 4 modes: M 9 %, V 50 % (the static part of modes 5+ is
    # missing, and it converges like 1/j^2 for M, 1/j for V)
    assert pl_M[-1] > 10 * ma_M[-1] and pl_V[-1] > 10 * ma_V[-1]
    assert pl_V[-1] > pl_M[-1]  # the shear converges worst


# ------------------------------------------------------- interaction: global equilibrium


@pytest.mark.parametrize("kind", ["sine", "continuous"])
def test_sprung_mass__reactions_balance_contact_force_and_deck_inertia(kind):
    """Sum of the support reactions = contact force on the deck - deck inertia
    (sum_j (int m phi_j dx) q''_j), every step; HHT alpha = 0 and no damping, so the
    modal equations hold at every step and the identity is exact."""
    m = 4000.0
    if kind == "sine":
        bridge = br.simply_supported(20.0, 5e9, m, n_modes=5)
    else:
        bridge = br.continuous([12.0, 16.0], 5e9, m, n_modes=5, elements_per_span=16)
    train = Train("SM", (vh.sprung_mass(8000.0, 2e6, 0.0, 500.0),), (0.0,))
    settings = SolverSettings(dt=1e-3, hht_alpha=0.0, approach=1.0, free_vibration=0.1)
    v = 25.0
    packed = sm.pack(bridge, train, v, no_irregularity(), settings)
    res = sb.run_batch(packed, no_irregularity(), [v], [6.0], settings, bridge,
                       keep_histories=[True])
    assert res.status[0] == 0
    h = res.histories(0)
    n = int(res.n_steps[0]) + 1
    t = np.arange(n) * settings.dt
    x = packed.vehicles.wheel_x0[0] + v * t
    X = np.where((x >= 0) & (x <= bridge.length), h["contact_force"][:, 0], 0.0)
    # int m phi_j dx by Gauss-Legendre on 400 intervals (the modes are smooth cubics)
    g, w = np.polynomial.legendre.leggauss(4)
    e = np.linspace(0.0, bridge.length, 401)
    xq = (0.5 * (e[:-1] + e[1:])[:, None] + 0.5 * np.diff(e)[:, None] * g).ravel()
    wq = (0.5 * np.diff(e)[:, None] * w).ravel()
    gamma = (wq * m) @ bridge.shapes(xq)
    inertia = res.out.qdd[0, :n] @ gamma
    total = h["support_reaction"].sum(axis=1)
    # exact identity: round-off of the sums (forces ~1e5 N)
    np.testing.assert_allclose(total, X - inertia, rtol=0, atol=1e-6 * np.abs(X).max())
    # the kernel's reaction envelopes are the histories' extremes
    np.testing.assert_allclose(res.envelopes()["max_support_reaction"][0],
                               h["support_reaction"].max(axis=0), rtol=1e-9)


# --------------------------------------------------------------- results and switches


def test_simulate__load_effect_variables_and_signs():
    bridge = br.continuous([10.0, 10.0], 3e9, 3000.0, n_modes=4, elements_per_span=10)
    train = Train("F", (vh.moving_force(1e5),), (0.0,))
    settings = SolverSettings(dt=2e-3, approach=0.0, free_vibration=0.0)
    ds = sm.simulate(bridge, train, 5.0, settings=settings, output_points=[5.0])
    assert list(ds["support"].values) == [0.0, 10.0, 20.0]
    assert ds["max_support_reaction"].dims == ("support",)
    assert ds["max_bending_moment_whole_deck"].dims == ("deck_x",)
    assert ds["bending_moment"].dims == ("time", "point")
    assert ds["max_support_reaction"].attrs["positive"] == "up"
    assert ds["min_bending_moment"].attrs["units"] == "N m"
    # a slow force: close to static.  Mid-span of span 1 sagging, the middle support
    # hogging (minimum moment there), uplift at the far end support while the force is
    # on span 1 (reaction minimum < 0), the middle support carries most
    assert ds["max_bending_moment"].sel(point=5.0) > 0
    i_mid = int(np.argmin(np.abs(ds["deck_x"].values - 10.0)))
    assert ds["min_bending_moment_whole_deck"].values[i_mid] < 0
    assert ds["min_support_reaction"].values[2] < 0
    assert ds["max_support_reaction"].values[1] > 0.9 * 1e5
    # static limit of the middle support reaction at its peak: 1.0 x P (load over it)
    assert ds["max_support_reaction"].values[1] == pytest.approx(1e5, rel=0.02)
    off = sm.to_dataset(bridge, train, sb.run_batch(
        sm.pack(bridge, train, 5.0, no_irregularity(), settings), no_irregularity(), [5.0],
        [5.0], settings, bridge, deck=sb.deck_operators(bridge, [5.0], settings,
                                                        load_effects=False)),
        no_irregularity(), settings, [5.0], False)
    assert "max_bending_moment" not in off and "max_deck_displacement" in off


def test_study__load_effects_in_the_file_and_the_switch(tmp_path):
    """A small sweep (two interaction trains, PSD profiles): the load effects on their
    dims with their coordinates; ``[study] load_effects = false`` leaves them out of the
    file (named, with the reason, in ``not_computed``) and every other variable bit for
    bit the same; a bad value is refused by key path."""
    from study_trains import TRAINS_TOML  # noqa: F401  (write_study needs it)
    from test_study import write_study

    from vsi_numba.config import ConfigError, load_config
    from vsi_numba.io.schema import ENVELOPES, LOAD_EFFECTS
    from vsi_numba.study.runner import run_study

    on_cfg = write_study(tmp_path / "on", speeds=(100.0, 150.0), history=(150.0,),
                         seeds=(1,))
    on = run_study(on_cfg, tmp_path / "on.nc", backend="serial")
    assert list(on["support"].values) == [0.0, 10.0]
    assert on["deck_x"].size == 33
    assert on["max_bending_moment_whole_deck"].dims[-1] == "deck_x"
    assert on["support_reaction"].dims[-2:] == ("time", "support")
    assert np.all(np.isfinite(on["max_support_reaction"].values))
    # the stored histories (float32) reach the kernel's envelopes
    h = on["bending_moment"].sel(speed=150 / 3.6, method="nearest")
    env = on["max_bending_moment"].sel(speed=150 / 3.6, method="nearest")
    np.testing.assert_allclose(h.max("time").values, env.values, rtol=1e-6)
    text = on_cfg.read_text().replace("save_time_histories = true",
                                      "save_time_histories = true\nload_effects = false")
    off_dir = tmp_path / "off"
    off_dir.mkdir()
    (off_dir / "trains.toml").write_text((on_cfg.parent / "trains.toml").read_text())
    (off_dir / "study.toml").write_text(text)
    off = run_study(off_dir / "study.toml", tmp_path / "off.nc", backend="serial")
    effect_names = {n for n in ENVELOPES if any(n.endswith(k) for k in LOAD_EFFECTS)}
    import json

    not_computed = json.loads(off.attrs["not_computed"])
    for name in ENVELOPES:
        if name in effect_names:
            assert name not in off.variables, name
            assert "load_effects = false" in not_computed[name]
        else:
            np.testing.assert_array_equal(off[name].values, on[name].values)
    (off_dir / "study.toml").write_text(text.replace("load_effects = false",
                                                     'load_effects = "yes"'))
    with pytest.raises(ConfigError, match=r"study\.load_effects.*true or false"):
        load_config(off_dir / "study.toml")


def test_modal_effects__track_layer_path_differentiates_the_cubics():
    """Decks loaded in their modes by other parts (a track layer) take M = -EI phi'' and
    V = -EI phi''' of the deck's cubics: on a bare two-span FE deck they agree with the
    exact quadrature of the modal inertia load to the FE error (O(h) for V)."""
    import dataclasses

    fe = br.continuous([12.0, 16.0], 5e9, 4000.0, n_modes=3, elements_per_span=40)
    cubic = dataclasses.replace(fe, static=dataclasses.replace(fe.static,
                                                               mass_per_length=None))
    x = np.array([3.0, 6.1, 14.3, 20.2])
    for effect, at, tol in (("moment", x, 2e-3), ("shear", x, 3e-2),
                            ("reaction", [0, 1, 2], 3e-2), ("rotation", [0, 1, 2], 1e-6)):
        a = inf.modal_effects(fe, effect, at)
        b = inf.modal_effects(cubic, effect, at)
        # h = 0.3-0.4 m: M linear and V constant per element, errors ~ (k h)^2, k h
        np.testing.assert_allclose(b, a, rtol=0, atol=tol * np.abs(a).max())


def test_elastic_track__point_load_static_part_bounded_by_the_rail_spreading():
    """On an elastic track the rail spreads a wheel force over the deck (foundation
    pressure p = k G(xi) P, Hetenyi), while the static part of the load effects takes it
    as a point load at the wheel.  A slow sprung mass (quasi-static): the engine's
    midspan moment envelope lies within the point-load / spread-load bracket, and the
    difference is a small fraction of the moment."""
    import dataclasses

    from vsi_numba.model.track import ElasticTrack

    L, EI, m = 20.0, 5e9, 5000.0
    bridge = dataclasses.replace(br.simply_supported(L, EI, m, n_modes=6),
                                 track=ElasticTrack())
    W = 1.0e5  # static wheel load (N): the sprung mass's weight
    train = Train("SM", (vh.sprung_mass(W / 9.81, 5e6, 2e5, 0.0),), (0.0,))
    settings = SolverSettings(dt=2e-3, approach=5.0, free_vibration=0.0)
    v = 2.0  # m/s: f1 = 3.9 Hz, a 20 m crossing takes 10 s: quasi-static
    packed = sm.pack(bridge, train, v, no_irregularity(), settings)
    res = sb.run_batch(packed, no_irregularity(), [v], [L / 2], settings, bridge)
    assert res.status[0] == 0
    m_engine = res.envelopes()["max_bending_moment"][0, 0]
    m_point = W * L / 4  # point load at midspan
    # spread: p(xi) = k G(xi) W with the infinite-beam Green function, on the deck only,
    # the load centred at midspan (the maximum of the bracket's lower end)
    track = bridge.track
    xi = np.linspace(-track.reach, track.reach, 4001)
    p = track.foundation_stiffness * track.green(xi) * W
    x = L / 2 + xi
    on = (x >= 0) & (x <= L)
    M_unit = np.where(x <= L / 2, x / 2, (L - x) / 2)  # influence line of M(L/2)
    m_spread = np.trapezoid(p[on] * M_unit[on], x[on])
    assert m_spread < m_point
    # the engine between the two (the dynamic part at 2 m/s is < 0.5 %), and the
    # spreading changes the peak moment by a few per cent only
    assert m_spread * 0.995 <= m_engine <= m_point * 1.005, (m_spread, m_engine, m_point)
    assert (m_point - m_spread) / m_point < 0.05


def test_kernel__three_span_envelopes_equal_the_influence_histories():
    """Three unequal spans, five moving loads: the kernel's static sweep (support
    moments from their cubic influence coefficients) and the histories' static part
    (influence(): three-moment solve per load position) give the same envelopes to
    round-off."""
    bridge = br.continuous([12.0, 16.0, 10.0], [4e9, 6e9, 4e9], 4000.0, n_modes=5,
                           elements_per_span=12)
    train = Train("L", (vh.point_loads([0, 3, 14, 17, 30],
                                       [1e5, 1.5e5, 1.2e5, 1e5, 2e5]),), (0.0,))
    settings = SolverSettings(dt=2e-3, approach=2.0, free_vibration=0.3)
    packed = sm.pack(bridge, train, 20.0, no_irregularity(), settings)
    res = sb.run_batch(packed, no_irregularity(), [20.0], [5.0, 12.0, 20.3, 33.0], settings,
                       bridge, keep_histories=[True])
    h, env = res.histories(0), res.envelopes()
    for name, key in (("bending_moment", "bending_moment"), ("shear_force", "shear_force"),
                      ("support_reaction", "support_reaction"), ("rotation", "end_rotation")):
        scale = np.abs(h[name]).max()
        # two exact evaluations of the same formula: round-off (measured ~3e-16)
        np.testing.assert_allclose(env[f"max_{key}"][0], h[name].max(axis=0), rtol=0,
                                   atol=1e-12 * scale)
        np.testing.assert_allclose(env[f"min_{key}"][0], h[name].min(axis=0), rtol=0,
                                   atol=1e-12 * scale)
