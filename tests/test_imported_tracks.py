"""Imported decks in space (vsi_numba.model.imported.lines): a small grillage assembled
here with numpy (two main girders, two rail stringers of one eccentric track,
cross-beams), exported as Matrix Market K and M with rail-line stations, against the
grillage itself (its static solve, and a direct integration of the whole grillage with
moving loads); a modes table's rail lines against the beam model with torsion."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse

from vsi_numba.model import deck3d as d3
from vsi_numba.model import vehicle as vh
from vsi_numba.model.imported.lines import read_matrices_tracks, read_modes_table_tracks
from vsi_numba.model.irregularity import no_irregularity
from vsi_numba.solver.pack import pack
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import run_batch

L = 20.0
NX = 16  # cross-beams every 1.25 m
Y = np.array([-3.5, 2.2 - 0.7175, 2.2 + 0.7175, 3.5])  # girder, right rail, left rail, girder
RAIL_R, RAIL_L = 1, 2


def _beam(h, ei, m):
    k = ei / h**3 * np.array([[12, 6 * h, -12, 6 * h],
                              [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                              [-12, -6 * h, 12, -6 * h],
                              [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    mm = m * h / 420 * np.array([[156, 22 * h, 54, -13 * h],
                                 [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                 [54, 13 * h, 156, -22 * h],
                                 [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    return k, mm


def _bar(h, gj, ip):
    return gj / h * np.array([[1, -1], [-1, 1]]), ip * h / 6 * np.array([[2, 1], [1, 2]])


def grillage():
    """K, M, nodes' DOFs: node (i along x, ln along y) has w, a = dw/dx, b = dw/dy at
    3 (ln (NX + 1) + i) + (0, 1, 2); w positive down."""
    x = np.linspace(0, L, NX + 1)
    n = 3 * Y.size * x.size
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    dof = lambda i, ln, c: 3 * (ln * x.size + i) + c  # noqa: E731
    girder = dict(ei=4e10, m=9000.0, gj=3e9, ip=3000.0)
    stringer = dict(ei=2e8, m=600.0, gj=1e7, ip=10.0)
    cross = dict(ei=3e9, m=1500.0, gj=5e8, ip=300.0)
    for ln in range(Y.size):
        p = girder if ln in (0, 3) else stringer
        for i in range(NX):
            h = x[i + 1] - x[i]
            kb, mb = _beam(h, p["ei"], p["m"])
            idx = [dof(i, ln, 0), dof(i, ln, 1), dof(i + 1, ln, 0), dof(i + 1, ln, 1)]
            K[np.ix_(idx, idx)] += kb
            M[np.ix_(idx, idx)] += mb
            kt, mt = _bar(h, p["gj"], p["ip"])
            idx = [dof(i, ln, 2), dof(i + 1, ln, 2)]  # torsion of a member along x: dw/dy
            K[np.ix_(idx, idx)] += kt
            M[np.ix_(idx, idx)] += mt
    for i in range(x.size):
        for ln in range(Y.size - 1):
            h = Y[ln + 1] - Y[ln]
            kb, mb = _beam(h, cross["ei"], cross["m"])
            idx = [dof(i, ln, 0), dof(i, ln, 2), dof(i, ln + 1, 0), dof(i, ln + 1, 2)]
            K[np.ix_(idx, idx)] += kb
            M[np.ix_(idx, idx)] += mb
            kt, mt = _bar(h, cross["gj"], cross["ip"])
            idx = [dof(i, ln, 1), dof(i, ln + 1, 1)]  # torsion of a member along y: dw/dx
            K[np.ix_(idx, idx)] += kt
            M[np.ix_(idx, idx)] += mt
    fixed = np.array([dof(i, ln, 0) for i in (0, NX) for ln in range(Y.size)])
    return x, K, M, fixed, dof


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    x, K, M, fixed, dof = grillage()
    d = tmp_path_factory.mktemp("grillage")
    scipy.io.mmwrite(str(d / "K.mtx"), scipy.sparse.coo_matrix(K), symmetry="symmetric")
    scipy.io.mmwrite(str(d / "M.mtx"), scipy.sparse.coo_matrix(M), symmetry="symmetric")
    rows = ["x,dof,rotation_dof,line"]
    for name, ln in (("A/left", RAIL_L), ("A/right", RAIL_R)):
        rows += [f"{float(xi)!r},{dof(i, ln, 0)},{dof(i, ln, 1)},{name}" for i, xi in enumerate(x)]
    (d / "stations.csv").write_text("\n".join(rows) + "\n")
    return d, (x, K, M, fixed, dof)


def test_grillage_modes_and_static_twist(exported):
    d, (x, K, M, fixed, dof) = exported
    deck = read_matrices_tracks(d / "K.mtx", d / "M.mtx", d / "stations.csv",
                                [{"line": "A"}], fixed_dofs=fixed.tolist(), n_modes=12,
                                spans=[L])
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    lam = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)],
                            eigvals_only=True)
    # shift-invert Lanczos against the dense solve of the same matrices
    np.testing.assert_allclose(deck.frequencies, np.sqrt(lam[:12]) / (2 * np.pi), rtol=1e-8)
    # the contact line is the mean of the rails, at the stations (the FE nodes)
    b = deck.track_bridge(0)
    left, right = deck.rail_shapes(0, x)
    np.testing.assert_allclose(b.shapes(x), 0.5 * (left + right), atol=1e-14)
    # static twist of the rails under a unit force on the track (half on each rail,
    # shared linearly between nodes): the grillage's own static solve, written here
    starts = np.array([-2.0, 0.0, 4.0, 8.5, 12.0, 17.0])
    line = deck.static_twist_line(0, starts)
    for a in (3.0, 7.4, 10.0, 15.6):
        f = np.zeros(K.shape[0])
        e = min(int(a // (L / NX)), NX - 1)
        t = a / (L / NX) - e
        for ln in (RAIL_L, RAIL_R):
            f[dof(e, ln, 0)] += 0.5 * (1 - t)
            f[dof(e + 1, ln, 0)] += 0.5 * t
        u = np.zeros(K.shape[0])
        u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
        rl, rr = ([u[dof(i, ln, 0)] for i in range(x.size)] for ln in (RAIL_L, RAIL_R))
        want = (np.interp(starts, x, rl) - np.interp(starts, x, rr)) - (
            np.interp(starts + 3, x, rl, right=0.0) - np.interp(starts + 3, x, rr, right=0.0))
        np.testing.assert_allclose(line(np.array([a]))[:, 0], want, rtol=1e-9,
                                   atol=1e-9 * np.abs(want).max())
        assert np.abs(want).max() > 0


def test_grillage_moving_force_against_direct_integration(exported):
    """A force on track A (y = 2.2 m): the kernels on the imported modes against a
    direct integration of the whole grillage (Newmark average acceleration, the force
    shared by the two rails with the stringers' Hermite shape functions)."""
    d, (x, K, M, fixed, dof) = exported
    n_modes = 120
    deck = read_matrices_tracks(d / "K.mtx", d / "M.mtx", d / "stations.csv",
                                [{"line": "A"}], fixed_dofs=fixed.tolist(),
                                n_modes=n_modes, spans=[L])
    bridge = deck.track_bridge(0)
    P, v, dt = 100e3, 25.0, 5e-4
    settings = SolverSettings(dt=dt, approach=0.0, free_vibration=0.2, hht_alpha=0.0)
    train = vh.Train("P", (vh.moving_force(P),), (0.0,))
    packed = pack(bridge, train, v, None, settings)
    res = run_batch(packed, no_irregularity(), [v], [10.0], settings, bridge,
                    keep_histories=[True])
    n = int(res.n_steps[0]) + 1
    q = res.out.q[0, :n]
    starts = np.array([4.0, 8.5, 12.0])
    twist = q @ deck.twist_operator(0, starts).T
    mid = q @ deck.rail_shapes(0, [10.0])[0].T  # left rail at mid-span

    # direct integration of the whole grillage
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    Kf, Mf = K[np.ix_(free, free)], M[np.ix_(free, free)]
    pos = {g: i for i, g in enumerate(free)}
    h = L / NX

    def load(t):
        f = np.zeros(free.size)
        a = v * t
        if not 0.0 <= a <= L:
            return f
        e = min(int(a // h), NX - 1)
        s = a / h - e
        N = (1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3,
             h * (s**3 - s**2))
        for ln in (RAIL_L, RAIL_R):
            for g, c in zip((dof(e, ln, 0), dof(e, ln, 1), dof(e + 1, ln, 0), dof(e + 1, ln, 1)),
                            N, strict=True):
                if g in pos:
                    f[pos[g]] += 0.5 * P * c
        return f

    a0 = 4 / dt**2
    lu = scipy.linalg.lu_factor(Kf + a0 * Mf)
    u = np.zeros(free.size)
    ud = np.zeros(free.size)
    udd = np.zeros(free.size)
    hist = np.zeros((n, free.size))
    for k in range(1, n):
        rhs = load(k * dt) + Mf @ (a0 * u + 4 / dt * ud + udd)
        un = scipy.linalg.lu_solve(lu, rhs)
        uddn = a0 * (un - u) - 4 / dt * ud - udd
        ud = ud + 0.5 * dt * (udd + uddn)
        u, udd = un, uddn
        hist[k] = u
    full = np.zeros((n, K.shape[0]))
    full[:, free] = hist

    def rail(ln, z):
        """The rail's FE field (the stringer's Hermite cubics) at z: (time, len(z))."""
        e = np.clip((z // h).astype(int), 0, NX - 1)
        s = z / h - e
        N = (1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3,
             h * (s**3 - s**2))
        out = sum(c * full[:, [dof(i, ln, comp) for i in e + off]]
                  for c, off, comp in zip(N, (0, 0, 1, 1), (0, 1, 0, 1), strict=True))
        return np.where((z >= 0) & (z <= L), out, 0.0)

    ref_twist = (rail(RAIL_L, starts) - rail(RAIL_R, starts)) - (
        rail(RAIL_L, starts + 3) - rail(RAIL_R, starts + 3))
    ref_mid = full[:, dof(NX // 2, RAIL_L, 0)]
    # same time integrator (HHT alpha = 0 is Newmark average acceleration) and dt: what
    # differs is the modes left out, 120 of 196 (the stringers' local bending between
    # cross-beams converges slowly in the twist): measured 0.03 % of the peak on the rail
    # deflection, 0.56 % on the twist (40 modes: 0.4 % and 3.3 %; 188: 1e-6 and 1.3e-5);
    # tolerance 2-3x
    err_mid = np.abs(mid[:, 0] - ref_mid).max() / np.abs(ref_mid).max()
    err_tw = np.abs(twist - ref_twist).max() / np.abs(ref_twist).max()
    assert err_mid <= 1e-3
    assert err_tw <= 0.012


def test_modes_table_rails_against_the_beam_model(tmp_path):
    """Rail lines of a modes file (written from the closed-form torsion deck) give the
    twist of the beam model, and a centre-line-only track says it has no twist."""
    deck = d3.simply_supported(L, 2e10, 15000.0, d3.Torsion(2e10, 4e4),
                               [{"eccentricity": 2.2}], n_modes=3, n_torsion_modes=3)
    x = np.linspace(0, L, 81)
    left, right = deck.rail_shapes(0, x)
    centre = deck.track_shapes(0, x)
    rows = ["mode,frequency,modal_mass,line,x,shape"]
    for j, f in enumerate(deck.frequencies):
        for name, sh in (("A/left", left), ("A/right", right), ("B", centre)):
            rows += [f"{j + 1},{float(f)!r},1.0,{name},{float(xi)!r},{float(sh[i, j])!r}"
                     for i, xi in enumerate(x)]
    (tmp_path / "modes.csv").write_text("\n".join(rows) + "\n")
    imp = read_modes_table_tracks(tmp_path / "modes.csv", [{"line": "A"}, {"line": "B"}])
    z = np.linspace(-3.0, L, 47)
    # the sign of a mode is arbitrary (the reader makes each largest value positive):
    # compare what does not depend on it, the modal static twist of a force on the
    # track, sum_j T_j(z) w_j(a) / w_j^2.  The file's shapes are the beam model's at 81
    # stations, splined: measured 1.0e-7 of the peak, tolerance 3e-7
    a = np.array([3.3, 9.1, 14.0])
    w2 = (2 * np.pi * deck.frequencies) ** 2
    got = (imp.twist_operator(0, z) / w2) @ imp.track_shapes(0, a).T
    want = (deck.twist_operator(0, z) / w2) @ deck.track_shapes(0, a).T
    assert np.abs(got - want).max() <= 3e-7 * np.abs(want).max()
    # track B is the centre line of the same track: the mean of A's rails
    np.testing.assert_allclose(imp.track_shapes(0, x), imp.track_shapes(1, x),
                               atol=1e-12 * np.abs(centre).max())
    with pytest.raises(d3.SpaceModelError, match="rail lines 'B/left' and 'B/right'"):
        imp.twist_operator(1, z)
    with pytest.raises(d3.SpaceModelError, match="needs its static response"):
        imp.static_twist_line(0, z)


def test_section_forces_by_mode_acceleration_like_the_built_in_deck():
    """An imported deck's bending moment and shear from its modal section forces and
    static influence lines (written here in closed form for a 20 m simply supported
    span) reproduce the built-in deck's mode-acceleration load effects of the same run."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model.imported.effects import from_arrays, mode_acceleration

    EI, m = 2e10, 15000.0
    bridge = br.simply_supported(L, EI, m, n_modes=3, damping_ratio=0.02)
    points = np.array([5.0, 10.0, 13.7])
    train = vh.Train("P", tuple(vh.moving_force(170e3) for _ in range(6)),
                     tuple(17.0 * np.arange(6)))
    f1 = bridge.frequencies[0]
    v = f1 * 17.0  # first resonance of the 17 m spacing
    settings = SolverSettings(dt=1e-3, free_vibration=0.2)
    packed = pack(bridge, train, v, None, settings)
    res = run_batch(packed, no_irregularity(), [v], points, settings, bridge,
                    keep_histories=[True])
    built_in = res.effect_histories(0)
    n = int(res.n_steps[0]) + 1
    t = np.arange(n) * settings.dt
    x_load = packed.vehicles.load_x0[None, :] + v * t[:, None]
    P = np.broadcast_to(packed.vehicles.load_p, x_load.shape)
    # the export: modal section forces of the mass-normalised sine modes and the static
    # influence lines at load stations that hold the kinks (the sections)
    a = np.sqrt(2 / (m * L))
    k = np.pi * np.arange(1, 4) / L
    modal = {"moment": EI * a * k**2 * np.sin(np.outer(points, k)),
             "shear": EI * a * k**3 * np.cos(np.outer(points, k))}
    load_x = np.unique(np.concatenate([np.linspace(0, L, 81), points, points + 1e-9]))
    X, A = points[:, None], load_x[None, :]
    infl = {("moment", "A"): np.where(X <= A, X * (L - A), A * (L - X)) / L,
            ("shear", "A"): np.where(X < A, (L - A) / L, -A / L)}
    sf = from_arrays(points, modal, load_x, infl, np.ones(3), np.ones(3))
    assert sf.effects == ("moment", "shear")
    q, F = res.out.q[0, :n], res.out.fq[0, :n]
    for effect, name in (("moment", "bending_moment"), ("shear", "shear_force")):
        got = mode_acceleration(sf, effect, "A", bridge.omega, q, F, x_load, P)
        ref = built_in[name]
        # the same formula on the same run with exact static lines (piecewise linear,
        # kinks tabulated): measured 3e-16 of the peak; 1e-12 allows for the summation
        # order
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max(), effect


def test_grillage_static_twist_check(exported):
    """The EN 1990 A2.4.4.2.2 check runs on an imported deck from its stiffness: the
    design twist at the governing placement is at least that of the four LM71 axles
    there (the distributed load only adds where unfavourable), from the grillage's own
    static solve."""
    from vsi_numba.analysis.checks.twist import static_twist_check

    d, (x, K, M, fixed, dof) = exported
    deck = read_matrices_tracks(d / "K.mtx", d / "M.mtx", d / "stations.csv",
                                [{"line": "A"}], fixed_dofs=fixed.tolist(), n_modes=6,
                                spans=[L])
    (c,) = static_twist_check(deck, 160.0, 1.0, 1.0, intervals=8, step=0.1)
    assert c.limit == 3.0e-3 and c.value > 0
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    f = np.zeros(K.shape[0])
    h = L / NX
    for a in c.load_at + np.array([-2.4, -0.8, 0.8, 2.4]):
        if 0 <= a <= L:
            e = min(int(a // h), NX - 1)
            t = a / h - e
            for ln in (RAIL_L, RAIL_R):
                f[dof(e, ln, 0)] += 0.5 * 250e3 * (1 - t)
                f[dof(e + 1, ln, 0)] += 0.5 * 250e3 * t
    u = np.zeros(K.shape[0])
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    rl, rr = ([u[dof(i, ln, 0)] for i in range(x.size)] for ln in (RAIL_L, RAIL_R))
    z = np.array([c.at, c.at + 3.0])
    dz = np.interp(z, x, rl, left=0, right=0) - np.interp(z, x, rr, left=0, right=0)
    axles_only = abs(dz[0] - dz[1])
    assert c.value >= axles_only * (1 - 1e-9) and axles_only > 0.3 * c.value


def test_one_track_line_is_todays_import_bit_for_bit(exported):
    """A track named by one line of the station map gives the modes read_matrices gives
    for that line, bit for bit."""
    from vsi_numba.model.imported import read_matrices

    d, (x, K, M, fixed, dof) = exported
    old = read_matrices(d / "K.mtx", d / "M.mtx", d / "stations.csv", track_line="A/left",
                        fixed_dofs=fixed.tolist(), n_modes=8, spans=[L]).bridge
    new = read_matrices_tracks(d / "K.mtx", d / "M.mtx", d / "stations.csv",
                               [{"line": "A/left"}], fixed_dofs=fixed.tolist(), n_modes=8,
                               spans=[L]).track_bridge(0)
    for name in ("frequencies", "damping", "nodes", "values", "slopes", "supports",
                 "effective_mass_fraction"):
        a, b = getattr(old, name), getattr(new, name)
        assert a.tobytes() == b.tobytes(), name
