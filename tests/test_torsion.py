"""Decks in space (vsi_numba.model.deck3d): torsional modes, eccentric tracks and the deck
twist against references written here (closed-form St-Venant torsion, a torsion FE
model assembled in the test), and today's planar model bit for bit without torsion."""

from __future__ import annotations

import numpy as np
import pytest

from vsi_numba.model import bridge as br
from vsi_numba.model import deck3d as d3
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import no_irregularity
from vsi_numba.solver.pack import pack
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import run_batch

# a 20 m box-girder deck carrying two tracks
L, EI, MASS = 20.0, 2.0e10, 15000.0
GJ, IP = 2.0e10, 4.0e4
ECC = 2.2
S = 1.435


def _rotation(x, a, span, gj=GJ):
    """St-Venant rotation (rad per N m) at x of a unit torque at a, fork-supported span
    [0, span] (x, a in the span): piecewise linear, the kink at the torque."""
    x = np.asarray(x, float)
    inside = (x >= 0) & (x <= span)
    return np.where(inside, np.where(x <= a, x * (span - a), a * (span - x)) / (gj * span),
                    0.0)


def test_simply_supported_torsional_frequencies_closed_form():
    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP, 0.02),
                               [{"eccentricity": ECC}], n_modes=4, n_torsion_modes=6)
    tor = deck.torsional_share > 0.5
    j = np.arange(1, 7)
    # closed form omega_j = (j pi / L) sqrt(GJ / I_p); the model evaluates the same
    # formula: agreement to round-off
    np.testing.assert_allclose(deck.frequencies[tor], j * np.pi / L * np.sqrt(GJ / IP)
                               / (2 * np.pi), rtol=1e-12)
    np.testing.assert_allclose(deck.frequencies[~tor], br.simply_supported(
        L, EI, MASS, n_modes=4).frequencies, rtol=1e-12)
    np.testing.assert_array_equal(deck.bending.damping[tor], 0.02)
    # unit modal mass of the torsional modes, int I_p theta_j theta_k dx = delta_jk, by
    # Gauss quadrature of the tabulated shapes (Hermite table of the sines: 2.5e-7 of the
    # amplitude, squared and integrated: 1e-6 is 4x the table's error)
    g, w = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0, L, 41)
    xq = (0.5 * (edges[:-1] + edges[1:])[:, None] + 0.5 * np.diff(edges)[:, None] * g).ravel()
    wq = np.tile(0.5 * np.diff(edges)[0] * w, edges.size - 1)
    th = deck.theta(xq)[:, tor]
    np.testing.assert_allclose(IP * (th * wq[:, None]).T @ th, np.eye(6), atol=1e-6)


def test_track_line_and_rails_are_phi_plus_y_theta():
    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP),
                               [{"eccentricity": ECC}, {"eccentricity": -ECC}], n_modes=3,
                               n_torsion_modes=3)
    x = np.linspace(0.0, L, 57)
    k = np.pi * np.arange(1, 4) / L
    phi = np.sqrt(2 / (MASS * L)) * np.sin(np.outer(x, k))
    theta = np.sqrt(2 / (IP * L)) * np.sin(np.outer(x, k))
    tor = deck.torsional_share > 0.5
    for t, y in ((0, ECC), (1, -ECC)):
        want = np.zeros((x.size, 6))
        want[:, ~tor] = phi
        want[:, tor] = y * theta
        # the kernels' table (Hermite cubics of the sines, 32 intervals per half wave of
        # the highest mode: (k h)^4 / 384 = 2.5e-7 of the amplitude; 1e-6 relative)
        got = deck.track_bridge(t).shapes(x)
        np.testing.assert_allclose(got, want, atol=1e-6 * np.abs(want).max())
        left, right = deck.rail_shapes(t, x)
        np.testing.assert_allclose(left - right, S * deck.theta(x), atol=1e-15)
    with pytest.raises(d3.SpaceModelError, match="train.track = 3"):
        deck.track_bridge(2)


def test_crawl_twist_against_st_venant_rotation_of_a_point_torque():
    """A force P crawls along the eccentric track: the deck twist over 3 m from the
    kernels' modal coordinates against s (theta(x) - theta(x + 3)) of the point torque
    P e, closed form."""
    n_t = 60
    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP, 0.05),
                               [{"eccentricity": ECC}], n_modes=4, n_torsion_modes=n_t,
                               damping_ratio=0.05)
    bridge = deck.track_bridge(0)
    P = 200e3
    train = vh.Train("P", (vh.moving_force(P),), (0.0,))
    v = 1.0
    settings = SolverSettings(dt=0.01, approach=0.0, free_vibration=0.0)
    packed = pack(bridge, train, v, None, settings)
    res = run_batch(packed, no_irregularity(), [v], [10.0], settings, bridge,
                    keep_histories=[True])
    n = int(res.n_steps[0]) + 1
    q = res.out.q[0, :n]
    starts = np.array([-1.5, 2.0, 6.0, 8.5, 14.0, 17.0])
    twist = q @ deck.twist_operator(0, starts).T  # (time, window)
    a = np.clip(np.arange(n) * settings.dt * v, 0.0, L)  # the force's abscissa
    ref = S * P * ECC * (_rotation(starts[None, :], a[:, None], L)
                         - _rotation(starts[None, :] + 3.0, a[:, None], L))
    # the same static twist from the first n_t terms of the modal series of the point
    # torque, sum_j theta_j(x) theta_j(a) / w_j^2 (closed-form modes, written here)
    j = np.arange(1, n_t + 1)
    th = lambda x: np.sqrt(2 / (IP * L)) * np.sin(np.multiply.outer(x, j * np.pi / L))  # noqa: E731
    w2 = (j * np.pi / L) ** 2 * GJ / IP
    series = S * P * ECC * np.einsum("tj,twj->tw", th(a) / w2,
                                     th(starts[None, :] + 0 * a[:, None])
                                     * ((starts[None, :] >= 0)[..., None])
                                     - th(starts[None, :] + 3.0 + 0 * a[:, None]))
    peak = np.abs(ref).max()
    # kernels against the truncated series: what is left is the dynamic part of a crawl
    # at 1 m/s (measured 0.11 % of the peak): tolerance 0.3 %
    assert np.abs(twist - series).max() <= 3e-3 * peak
    # and against the closed form: the series converges like 1/n at the torque (the kink
    # of theta): its own truncation error (1.3 % of the peak with 60 modes, computed
    # here) plus the same 0.3 %
    trunc = np.abs(series - ref).max()
    assert trunc <= 0.02 * peak
    assert np.abs(twist - ref).max() <= trunc + 3e-3 * peak
    # sign: a load on the left track (y > 0) turns the deck left side down (theta > 0):
    # a window starting at mid-span of the loaded half twists positive (theta decreases)
    assert twist[np.argmin(np.abs(a - 6.0)), 2] > 0


def _torsion_fe(spans, gj, ip, ne):
    """Torsion of a continuous deck, linear elements, theta = 0 at every support
    (written here, independent of the package)."""
    sup = np.concatenate([[0.0], np.cumsum(spans)])
    x = np.unique(np.concatenate([np.linspace(a, b, ne + 1) for a, b in
                                  zip(sup[:-1], sup[1:], strict=True)]))
    n = x.size
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    for e in range(n - 1):
        h = x[e + 1] - x[e]
        K[e:e + 2, e:e + 2] += gj / h * np.array([[1, -1], [-1, 1]])
        M[e:e + 2, e:e + 2] += ip * h / 6 * np.array([[2, 1], [1, 2]])
    fixed = np.searchsorted(x, sup)
    free = np.setdiff1d(np.arange(n), fixed)
    return x, K, M, free


def test_continuous_two_span_torsion_frequencies_and_static_twist():
    spans = [20.0, 25.0]
    ne = 40
    deck = d3.continuous(spans, EI, MASS, d3.Torsion(GJ, IP, 0.01),
                         [{"eccentricity": ECC}], n_modes=4, n_torsion_modes=6,
                         elements_per_span=ne)
    tor = deck.torsional_share > 0.5
    assert tor.sum() == 6 and (~tor).sum() == 4
    # torsion restrained at the middle support: each span twists on its own,
    # f = j / (2 L_s) sqrt(GJ / I_p); linear elements with consistent mass overestimate
    # by (k h)^2 / 24 (k = j pi / L_s, h = L_s / 40): tolerance 2x that bound per mode
    fam = sorted((j / (2 * s) * np.sqrt(GJ / IP), j * np.pi / s * (s / ne))
                 for s in spans for j in range(1, 5))[:6]
    closed, kh = np.array(fam).T
    rel = deck.frequencies[tor] / closed - 1
    assert np.all(rel >= 0) and np.all(rel <= 2 * kh**2 / 24), rel
    # bending modes: those of the planar FE deck (the same eigen-solve holds both)
    np.testing.assert_allclose(deck.frequencies[~tor], br.continuous(
        spans, EI, MASS, n_modes=4, elements_per_span=ne).frequencies, rtol=1e-9)
    # static twist of a load on the eccentric track: the package's influence line
    # (closed form) against the test's FE static solve, at nodes (the linear FE is exact
    # at the nodes for point torques at nodes: agreement to round-off)
    x, K, M, free = _torsion_fe(spans, GJ, IP, ne)
    starts = np.array([-2.0, 3.0, 16.5, 19.0, 21.0, 33.0, 43.0])
    line = deck.static_twist_line(0, starts)
    for a in (5.0, 17.5, 20.0, 31.25, 42.5):
        f = np.zeros(x.size)
        f[np.searchsorted(x, a)] = ECC  # the torque of a unit force at y = ECC
        th = np.zeros(x.size)
        th[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
        want = S * (np.interp(starts, x, th, left=0.0, right=0.0)
                    - np.interp(starts + 3.0, x, th, left=0.0, right=0.0))
        np.testing.assert_allclose(line(np.array([a]))[:, 0], want, rtol=1e-9,
                                   atol=1e-12 * np.abs(want).max())
        # and from the package's modes, all torsional modes kept: the static modal sum
        # sum_j T_j w_j(a, e) / w_j^2 is the FE static solution (complete basis)
    full = d3.continuous(spans, EI, MASS, d3.Torsion(GJ, IP), [{"eccentricity": ECC}],
                         n_modes=2, n_torsion_modes=2 * ne - 1, elements_per_span=ne)
    a = 31.25
    modal = (full.twist_operator(0, starts) / full.bending.omega**2) @ \
        full.track_shapes(0, [a])[0]
    np.testing.assert_allclose(modal, line(np.array([a]))[:, 0], rtol=1e-7,
                               atol=1e-9 * np.abs(modal).max())


@pytest.mark.parametrize("kind", ["simply_supported", "continuous"])
@pytest.mark.parametrize("ecc", [0.0, 2.2])
def test_no_torsion_is_todays_model_bit_for_bit(kind, ecc):
    if kind == "simply_supported":
        planar = br.simply_supported(L, EI, MASS, n_modes=6, damping_ratio=0.01)
        deck = d3.simply_supported(L, EI, MASS, None, [{"eccentricity": ecc}], n_modes=6,
                                   damping_ratio=0.01)
    else:
        planar = br.continuous([15.0, 20.0], EI, MASS, n_modes=6, damping_ratio=0.01)
        deck = d3.continuous([15.0, 20.0], EI, MASS, None, [{"eccentricity": ecc}],
                             n_modes=6, damping_ratio=0.01)
    train = vh.Train("P", (vh.moving_force(100e3), vh.moving_force(100e3)), (0.0, 3.0))
    settings = SolverSettings(dt=2e-3)
    a = pack(planar, train, 50.0, None, settings).bridge
    b = pack(deck.track_bridge(0), train, 50.0, None, settings).bridge
    for name, va, vb in zip(a._fields, a, b, strict=True):
        if isinstance(va, np.ndarray):
            assert va.tobytes() == vb.tobytes() and va.shape == vb.shape, name
        else:
            assert va == vb, name


def test_bad_track_and_torsion_inputs_name_the_key():
    with pytest.raises(d3.SpaceModelError, match=r"bridge.torsion.GJ = -1.0.*> 0"):
        d3.Torsion(-1.0, IP)
    with pytest.raises(d3.SpaceModelError, match=r"bridge.torsion.damping_ratio"):
        d3.Torsion(GJ, IP, 1.5)
    with pytest.raises(d3.SpaceModelError, match=r"bridge.tracks\[1\]: unknown key"):
        d3.tracks_from([{"eccentricity": 2.0}, {"eccentricty": -2.0}])
    with pytest.raises(d3.SpaceModelError, match=r"bridge.tracks\[0\]: eccentricity"):
        d3.tracks_from([{"eccentricity": float("nan")}])


def test_static_twist_check_lm71_brute_force_and_limits():
    """EN 1990 A2.4.4.2.2: LM71 x Phi x alpha on one track, placed most unfavourably,
    against a brute-force placement written here (closed-form rotation, axle group
    centre every 2 cm, the 80 kN/m wherever it twists the same way)."""
    from vsi_numba.analysis.checks.twist import static_twist_check, twist_limit

    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP), [{"eccentricity": ECC},
                                                               {"eccentricity": -ECC}],
                               n_modes=2)
    alpha, phi = 1.21, 1.12
    checks = static_twist_check(deck, 250.0, alpha, phi)
    assert [(c.loaded, c.track) for c in checks] == [(1, 1), (1, 2), (2, 1), (2, 2)]
    best = max(checks, key=lambda c: c.utilisation)
    # brute force: window starts and load positions on fine grids
    xs = np.linspace(0.0, L, 8001)  # UDL integration grid (2.5 mm)
    dx = xs[1] - xs[0]
    starts = np.linspace(-3.0, L, 231)
    line = S * ECC * (_rotation(starts[:, None], xs[None, :], L)
                      - _rotation(starts[:, None] + 3.0, xs[None, :], L))  # m/N
    pos = np.clip(line, 0, None)
    neg = np.clip(-line, 0, None)
    cum = [np.concatenate([np.zeros((starts.size, 1)), np.cumsum(0.5 * (p[:, 1:] + p[:, :-1])
                                                                 * dx, axis=1)], axis=1)
           for p in (pos, neg)]
    worst = 0.0
    for c in np.arange(-3.2, L + 3.2, 0.02):
        axles = c + np.array([-2.4, -0.8, 0.8, 2.4])
        on = (axles >= 0) & (axles <= L)
        pts = 250e3 * (S * ECC * (_rotation(starts[:, None], axles[None, on], L)
                                  - _rotation(starts[:, None] + 3.0, axles[None, on], L))
                       ).sum(axis=1)
        i0, i1 = np.searchsorted(xs, [c - 3.2, c + 3.2])
        i0, i1 = min(i0, xs.size - 1), min(i1, xs.size - 1)
        for sign, cu in ((1.0, cum[0]), (-1.0, cum[1])):
            udl = 80e3 * (cu[:, -1] - (cu[:, i1] - cu[:, i0]))
            worst = max(worst, np.max(sign * pts + udl))
    worst *= alpha * phi
    # grids of 2 cm / 2.5 mm against the check's crossings: measured 1.0e-5, tolerance 3x
    assert best.value == pytest.approx(worst, rel=3e-5)
    # a 20 m span, GJ = 2e10, e = 2.2 m: about a millimetre (plausible for a box girder)
    assert 2e-4 < best.value < 5e-3
    assert best.limit == 1.5e-3
    assert [twist_limit(v) for v in (120.0, 120.1, 200.0, 200.1)] == [4.5e-3, 3e-3, 3e-3,
                                                                      1.5e-3]
    # a beam deck twists as a whole: track 2 (same gauge) sees the twist of track 1
    np.testing.assert_allclose(checks[1].twist_max, checks[0].twist_max)


def test_per_track_envelopes_are_rows_of_the_output_operator():
    """Twist and track-line displacement envelopes need no kernel change: stacked under
    the planar output operator, the kernels' envelope is max_t |row @ q| of each row
    (checked against the histories of the same run)."""
    from vsi_numba.solver.simulate import deck_operators

    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP, 0.02),
                               [{"eccentricity": ECC}, {"eccentricity": -ECC}], n_modes=4,
                               damping_ratio=0.02)
    bridge = deck.track_bridge(0)
    points = [5.0, 10.0]
    rows = d3.output_rows(deck, points)
    assert rows.has_twist.all() and rows.twist.shape == (2, rows.starts.size, deck.n_modes)
    settings = SolverSettings(dt=2e-3, free_vibration=0.1)
    phi_d, phi_a, cutoff = deck_operators(bridge, points, settings)[:3]
    extra = np.concatenate([rows.disp.reshape(-1, deck.n_modes),
                            rows.twist.reshape(-1, deck.n_modes)])
    stacked_d = np.ascontiguousarray(np.vstack([phi_d, extra]))
    stacked_a = np.ascontiguousarray(np.vstack([phi_a, np.zeros_like(extra)]))
    train = vh.Train("P", tuple(vh.moving_force(150e3) for _ in range(4)),
                     (0.0, 3.0, 17.0, 20.0))
    v = 60.0
    packed = pack(bridge, train, v, None, settings)
    res = run_batch(packed, no_irregularity(), [v], points, settings, bridge,
                    keep_histories=[True], deck=(stacked_d, stacked_a, cutoff))
    n = int(res.n_steps[0]) + 1
    q = res.out.q[0, :n]
    np.testing.assert_allclose(res.red.disp[0, phi_d.shape[0]:],
                               np.abs(q @ extra.T).max(axis=0), rtol=1e-12)
    # the first rows are today's deck outputs (the axis), untouched
    np.testing.assert_allclose(res.red.disp[0, :2], np.abs(q @ phi_d.T).max(axis=0),
                               rtol=1e-12)
    # track 1 is loaded: its line deflects more than the axis and than track 2
    d1, d2 = res.red.disp[0, 2:4], res.red.disp[0, 4:6]
    assert np.all(d1 > res.red.disp[0, :2]) and np.all(d1 > d2)


def test_resonance_twist_and_track_acceleration_against_own_modal_integration():
    """Ten forces 15 m apart at the first torsional resonance (v = f_t1 d) on the
    eccentric track: the kernels' twist and the deck acceleration along the track
    against the test's own integration of the modal equations (closed-form bending and
    torsion modes, scipy solve_ivp DOP853 at tight tolerances)."""
    from scipy.integrate import solve_ivp

    gj, ip, zb, zt = 5e9, 8e4, 0.01, 0.01
    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(gj, ip, zt), [{"eccentricity": ECC}],
                               n_modes=3, n_torsion_modes=3, damping_ratio=zb)
    bridge = deck.track_bridge(0)
    d, P, n_f = 15.0, 170e3, 10
    f_t1 = np.sqrt(gj / ip) / (2 * L)
    v = f_t1 * d
    dt = 2.5e-4
    settings = SolverSettings(dt=dt, approach=0.0, free_vibration=0.3, hht_alpha=0.0)
    train = vh.Train("F", tuple(vh.moving_force(P) for _ in range(n_f)),
                     tuple(d * np.arange(n_f)))
    packed = pack(bridge, train, v, None, settings)
    res = run_batch(packed, no_irregularity(), [v], [10.0], settings, bridge,
                    keep_histories=[True])
    n = int(res.n_steps[0]) + 1
    t = np.arange(n) * dt
    q, qdd = res.out.q[0, :n], res.out.qdd[0, :n]
    starts = np.array([2.0, 8.5, 15.0])
    twist = q @ deck.twist_operator(0, starts).T
    acc = qdd @ deck.track_shapes(0, [5.0, 10.0]).T

    # own modal model: bending sin modes (theta = 0), torsion sin modes (phi = 0)
    j = np.arange(1, 4)
    k = j * np.pi / L
    wb = k**2 * np.sqrt(EI / MASS)
    wt = k * np.sqrt(gj / ip)
    w = np.concatenate([wb, wt])
    z = np.concatenate([np.full(3, zb), np.full(3, zt)])
    amp = np.concatenate([np.full(3, np.sqrt(2 / (MASS * L))),
                          ECC * np.full(3, np.sqrt(2 / (ip * L)))])  # shape at y = ECC
    kk = np.concatenate([k, k])
    offsets = d * np.arange(n_f)

    def force(tt):
        x = v * tt - offsets
        on = (x >= 0) & (x <= L)
        return P * (amp * np.sin(np.outer(x[on], kk))).sum(axis=0)

    def rhs(tt, y):
        qq, qd = y[:6], y[6:]
        return np.concatenate([qd, force(tt) - 2 * z * w * qd - w**2 * qq])

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(12), method="DOP853", t_eval=t, rtol=1e-10,
                    atol=1e-14, max_step=2e-3)
    qr = sol.y[:6].T
    qddr = np.array([rhs(tt, y)[6:] for tt, y in zip(t, sol.y.T, strict=True)])
    tw_ref = S * (np.sqrt(2 / (ip * L)) * (np.sin(np.outer(starts, k))
                                           - np.sin(np.outer(np.minimum(starts + 3, L), k)))
                  ) @ qr[:, 3:].T
    acc_ref = qddr @ (amp * np.sin(np.outer([5.0, 10.0], kk))).T
    # HHT alpha = 0 (trapezoidal rule) converges at second order: measured twist / track
    # acceleration errors 0.38 % / 1.06 % of the peak at dt = 5e-4 s, 0.096 % / 0.26 % at
    # 2.5e-4 s, 0.024 % / 0.066 % at 1.25e-4 s (ratio 4); at 2.5e-4 s tolerances 2.5x
    e_tw = np.abs(twist - tw_ref.T).max() / np.abs(tw_ref).max()
    e_acc = np.abs(acc - acc_ref).max() / np.abs(acc_ref).max()
    assert e_tw <= 2.5e-3
    assert e_acc <= 7e-3
    # at resonance the twist is ~0.8 mm (the track acceleration ~9 m/s2)
    assert np.abs(tw_ref).max() > 5e-4


def test_bending_load_effects_of_the_track_bridge_are_the_beams():
    """The track bridge's modal load effects (what the mode-acceleration load effects
    use) are the bending beam's: EI a k^2 sin(k x) and EI a k^3 cos(k x) for the bending
    modes, zero for the torsional ones (a torque does not bend the beam)."""
    from vsi_numba.model.influence import modal_effects

    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP), [{"eccentricity": ECC}],
                               n_modes=3, n_torsion_modes=3)
    b = deck.track_bridge(0)
    x = np.array([2.5, 7.0, 10.0, 16.3])
    tor = deck.torsional_share > 0.5
    k = np.pi * np.arange(1, 4) / L
    a = np.sqrt(2 / (MASS * L))
    for effect, want in (("moment", EI * a * k**2 * np.sin(np.outer(x, k))),
                         ("shear", EI * a * k**3 * np.cos(np.outer(x, k)))):
        got = modal_effects(b, effect, x)
        # Gauss quadrature of the inertia load on the tabulated sines (2.5e-7 of the
        # amplitude): measured 1.3e-7 of the largest value; tolerance 3e-7
        np.testing.assert_allclose(got[:, ~tor], want, atol=3e-7 * np.abs(want).max())
        assert np.all(got[:, tor] == 0.0)


def test_torsional_moment_sections_leave_the_bending_load_effects_bit_for_bit():
    """The deck-in-space channels (``space_operators``: twist, track displacements and
    torsional moment by mode acceleration) change no other envelope: the bending
    moments, shears, reactions, rotations, the deck outputs and the track accelerations
    are bit for bit those of the same run without them (the load-effect tables are the
    planar ones)."""
    import dataclasses

    from vsi_numba.solver.batch import deck_operators, space_operators

    deck = d3.simply_supported(L, EI, MASS, d3.Torsion(GJ, IP, 0.01),
                               [{"eccentricity": ECC}, {"eccentricity": -ECC}], n_modes=3,
                               damping_ratio=0.01, n_torsion_modes=6)
    bridge = deck.track_bridge(0)
    settings = SolverSettings(dt=1e-3, approach=0.0, free_vibration=0.2)
    pts = np.array([5.0, 10.0, 15.0])
    planar = deck_operators(bridge, pts, settings)
    with_torque = space_operators(deck, pts, planar, 0)
    without = (*with_torque[:5], planar[5],
               dataclasses.replace(with_torque[6], channels=None, torque_channel=None))
    assert with_torque[5] is planar[5]
    train = vh.Train("t", (vh.point_loads([0.0, 3.0, 15.0], [1e5, 1e5, 1.2e5], name="x"),),
                     (0.0,))
    packed = pack(bridge, train, 40.0, no_irregularity(), settings)
    a, b = (run_batch(packed, no_irregularity(), [40.0, 60.0], pts, settings, bridge,
                      deck=d).envelopes() for d in (with_torque, without))
    assert set(a) - set(b) == {f"{p}{e}_torsional_moment{w}" for e in ("max", "min")
                               for p in ("", "time_of_") for w in ("", "_whole_deck")}
    moved = ("max_track_displacement", "time_of_max_track_displacement", "max_deck_twist",
             "time_of_max_deck_twist")  # the channels' (tests/test_space_config.py)
    for name, value in b.items():
        if not name.startswith(moved):
            np.testing.assert_array_equal(a[name], value, err_msg=name)
