"""Several interaction trains in one run (``solver.trains.pack_trains``): the wheels of every
train and the deck in one contact problem per step.

The reference is written here: the coupled ODEs of the deck's bending and torsion modes
and two sprung masses on massless contact points (permanent contact, rigid track),
integrated by ``scipy.integrate.solve_ivp`` piecewise between the deck-end events.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vsi_numba.model import deck3d
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.batch import run_batch
from vsi_numba.solver.pack import ModelError, pack
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.trains import TrainOnTrack, pack_trains

# deck: 25 m simply supported, 3 bending modes (2.8, 11.2, 25.3 Hz) and the torsional
# modes below the highest of them (5, 10, 15, 20, 25 Hz... up to 25.3 Hz)
L, EI, MASS = 25.0, 2.87e9, 2303.0
IP = MASS * 9.0  # polar mass: radius of gyration 3 m
GJ = IP * (2.0 * L * 5.0) ** 2  # first torsional mode at 5 Hz
ZETA_B, ZETA_T = 0.01, 0.02
N_B = 3
E = 2.0  # the tracks at y = +E (track 1) and y = -E (track 2)
# the vehicle: a sprung mass on a massless contact point
MV, KV, CV = 5750.0, 1.595e6, 2.0e4
G = 9.81
V = 30.0  # m/s, both trains
APPROACH = 5.0
OFFSET = 7.0  # m: the second train starts further back (no symmetry between the tracks)


def _model():
    deck = deck3d.simply_supported(
        L, EI, MASS, torsion=deck3d.Torsion(GJ, IP, ZETA_T),
        tracks=[{"eccentricity": E}, {"eccentricity": -E}], n_modes=N_B,
        damping_ratio=ZETA_B)
    car = vh.sprung_mass(MV, KV, CV, 0.0)
    train = Train("sprung mass", (car,), (0.0,))
    return deck, train


def _reference(t_out, n_t):
    """Deck modal coordinates (bending 1..N_B, torsion 1..n_t, the test's own order),
    the two bodies' accelerations (m/s2, down) and the deck at mid-span of each track
    at the times ``t_out``: solve_ivp (DOP853, rtol 1e-11) between the deck-end events."""
    jb = np.arange(1, N_B + 1)
    jt = np.arange(1, n_t + 1)
    k = np.concatenate([jb, jt]) * np.pi / L
    amp_b = np.sqrt(2.0 / (MASS * L))
    amp_t = np.sqrt(2.0 / (IP * L))
    om = np.concatenate([(jb * np.pi / L) ** 2 * np.sqrt(EI / MASS),
                         (jt * np.pi / L) * np.sqrt(GJ / IP)])
    ze = np.concatenate([np.full(N_B, ZETA_B), np.full(n_t, ZETA_T)])
    n_m = om.size

    def shape(x, y):  # w_j(x, y) = phi_j + y theta_j and its x-derivative
        if x < 0.0 or x > L:
            return np.zeros(n_m), np.zeros(n_m)
        a = np.concatenate([np.full(N_B, amp_b), np.full(n_t, y * amp_t)])
        return a * np.sin(k * x), a * k * np.cos(k * x)

    # vehicle A on y = +E in +x from -APPROACH; B on y = -E in -x from L + APPROACH +
    # OFFSET
    cars = ((-APPROACH, V, E), (L + APPROACH + OFFSET, -V, -E))

    def forces(t, y):
        q, qd = y[:n_m], y[n_m:2 * n_m]
        out = []
        for c, (x0, v, ecc) in enumerate(cars):
            z, zd = y[2 * n_m + 2 * c], y[2 * n_m + 2 * c + 1]
            w, dw = shape(x0 + v * t, ecc)
            wc = w @ q
            wcd = v * (dw @ q) + w @ qd
            out.append((w, KV * (z - wc) + CV * (zd - wcd)))
        return out

    def rhs(t, y):
        q, qd = y[:n_m], y[n_m:2 * n_m]
        dy = np.empty_like(y)
        dy[:n_m] = qd
        f = -2.0 * ze * om * qd - om**2 * q
        for c, (w, F) in enumerate(forces(t, y)):
            f = f + w * F
            dy[2 * n_m + 2 * c] = y[2 * n_m + 2 * c + 1]
            dy[2 * n_m + 2 * c + 1] = G - F / MV
        dy[n_m:2 * n_m] = f
        return dy

    y = np.zeros(2 * n_m + 4)
    y[2 * n_m] = y[2 * n_m + 2] = MV * G / KV  # static on the approach
    events = sorted({APPROACH / V, (APPROACH + L) / V, (APPROACH + OFFSET) / V,
                     (APPROACH + OFFSET + L) / V})
    edges = [0.0, *events, t_out[-1] + 1e-12]
    q_out = np.zeros((t_out.size, n_m))
    acc = np.zeros((t_out.size, 2))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-11, atol=1e-13,
                        dense_output=True, max_step=2e-3)
        assert sol.success
        sel = (t_out >= a) & (t_out < b)
        for i in np.flatnonzero(sel):
            yi = sol.sol(t_out[i])
            q_out[i] = yi[:n_m]
            acc[i] = [G - F / MV for _, F in forces(t_out[i], yi)]
        y = sol.y[:, -1]
    mid = [shape(0.5 * L, ecc)[0] for ecc in (E, -E)]
    return q_out, acc, np.stack([q_out @ m for m in mid], axis=1)


def _engine(dt):
    deck, train = _model()
    lines = [deck.track_bridge(0), deck.track_bridge(1)]
    settings = SolverSettings(dt=dt, hht_alpha=0.0, approach=APPROACH, free_vibration=0.2)
    trains = [TrainOnTrack(train, line=0), TrainOnTrack(train, line=1, direction=-1,
                                                           offset=OFFSET)]
    packed = pack_trains(lines, trains, V, None, settings)
    res = run_batch(packed, no_irregularity(), [V], [0.5 * L], settings, lines[0],
                    keep_histories=[True])
    assert res.status[0] == 0, res.message(0)
    n = int(res.n_steps[0]) + 1
    t = np.arange(n) * dt
    q = res.out.q[0, :n]
    mid = np.stack([deck.track_shapes(k, [0.5 * L])[0] @ q.T for k in (0, 1)], axis=1)
    n_t = int(np.sum(deck.torsional_share > 0.5))
    return t, res.out.body_acc[0, :n], mid, n_t, res


@pytest.fixture(scope="module")
def runs():
    out = {}
    for dt in (1e-3, 5e-4):
        t, acc, mid, n_t, res = _engine(dt)
        _, acc_ref, mid_ref = _reference(t, n_t)
        out[dt] = (acc, acc_ref, mid, mid_ref, res)
    return out


def _err(a, ref):
    return float(np.max(np.abs(a - ref)) / np.max(np.abs(ref)))


def test_pack_trains__two_sprung_masses_meeting_on_a_deck_with_torsion(runs):
    """Both bodies' accelerations and the deck at mid-span of both tracks against the
    coupled ODEs: second-order convergence (HHT alpha = 0) and a small error at dt =
    0.5 ms (measured 1.8e-4 of the peak on the accelerations, 2.9e-5 on the deck, the
    HHT discretisation error: tolerances 3x, room for round-off across platforms,
    below the 1 ms errors)."""
    acc1, acc_ref1, mid1, mid_ref1, _ = runs[1e-3]
    acc2, acc_ref2, mid2, mid_ref2, _ = runs[5e-4]
    e_acc = [_err(acc1, acc_ref1), _err(acc2, acc_ref2)]
    e_mid = [_err(mid1, mid_ref1), _err(mid2, mid_ref2)]
    print("relative errors (dt = 1 ms, 0.5 ms): body acc", e_acc, "deck", e_mid)
    assert e_acc[1] < 5.5e-4
    assert e_mid[1] < 9e-5
    # second order: halving dt divides the error by ~4 (3 .. 5: the deck-end kinks)
    assert 3.0 < e_acc[0] / e_acc[1] < 5.0
    assert 3.0 < e_mid[0] / e_mid[1] < 5.0
    # the torsion matters: the two tracks' mid-spans move differently, and the other
    # train is in the response (each body's acceleration is not the one train's)
    assert np.max(np.abs(mid_ref2[:, 0] - mid_ref2[:, 1])) > 0.05 * np.max(np.abs(mid_ref2))


def test_pack_trains__the_second_train_changes_the_first(runs):
    """The first train alone (``pack``) against the same train with the second one on the
    other track: the body acceleration of the first differs by far more than the
    discretisation error (the trains interact through the deck)."""
    acc2, acc_ref2, _, _, _ = runs[5e-4]
    deck, train = _model()
    settings = SolverSettings(dt=5e-4, hht_alpha=0.0, approach=APPROACH, free_vibration=0.2)
    line = deck.track_bridge(0)
    alone = run_batch(pack(line, train, V, None, settings), no_irregularity(), [V],
                      [0.5 * L], settings, line, keep_histories=[True])
    n = int(alone.n_steps[0]) + 1
    a1 = alone.out.body_acc[0, :n, 0]
    assert _err(a1, acc_ref2[:n, 0]) > 10 * _err(acc2, acc_ref2)


def test_pack_trains__one_train_is_pack_itself():
    """One train on line 0 in +x: the single-train packing, unchanged."""
    deck, train = _model()
    settings = SolverSettings(dt=1e-3, approach=APPROACH)
    line = deck.track_bridge(0)
    a = pack(line, train, V, None, settings)
    b = pack_trains([line], [TrainOnTrack(train)], V, None, settings)
    for f in a.vehicles._fields:
        assert np.array_equal(getattr(a.vehicles, f), getattr(b.vehicles, f)), f
    assert a.params == b.params


def test_pack_trains__bad_input_names_the_train():
    deck, train = _model()
    settings = SolverSettings(dt=1e-3, approach=APPROACH)
    line = deck.track_bridge(0)
    with pytest.raises(ModelError, match=r"trains\[1\]\.line = 3"):
        pack_trains([line], [TrainOnTrack(train), TrainOnTrack(train, line=3)], V, None,
                    settings)
    forces = Train("forces", (vh.point_loads([0.0, 3.0], [1e5, 1e5], name="f"),), (0.0,))
    with pytest.raises(ModelError, match="superposed"):
        pack_trains([line], [TrainOnTrack(forces), TrainOnTrack(forces, direction=-1)], V,
                    None, settings)
    with pytest.raises(ModelError, match=r"trains\[1\]\.direction = 0"):
        pack_trains([line], [TrainOnTrack(train), TrainOnTrack(train, direction=0)], V,
                    None, settings)


def test_config__interaction_trains_on_other_tracks_run_together(tmp_path):
    """``[train] other_trains`` with an interaction train through ``vsi sweep``: the file
    holds both trains' wheels and bodies, equal to the Python API's run of the same
    model (:func:`pack_trains` on the config's track lines, to round-off), and its
    ``_all_tracks`` envelopes are the run's own (every train is in the run)."""
    from test_space_config import SPRUNG, TORSION, TRACKS, _text
    from userpath import sweep_file

    from vsi_numba.config import load_config

    others = 'other_trains = [{ track = 2, direction = "opposite", offset = 3.0 }]'
    text = _text(TRACKS, TORSION, "track = 1\n" + others, SPRUNG)
    ds = sweep_file(tmp_path, text, speed=0)
    assert ds.sizes["wheel"] == 2 and ds.sizes["vehicle"] == 2
    cfg = load_config(tmp_path / "deck.toml")
    train = cfg.trains()[0]
    settings = cfg.solver_settings()
    lines = [cfg.bridge_for(train, k) for k in (1, 2)]
    packed = pack_trains(lines, [TrainOnTrack(train, 0),
                                 TrainOnTrack(train, 1, direction=-1, offset=3.0)],
                         1.0, None, settings)
    v = float(ds.speed)
    res = run_batch(packed, no_irregularity(), [v], [10.0], settings, lines[0],
                    keep_histories=[True])
    n = int(res.n_steps[0]) + 1
    assert ds.sizes["time"] == n
    got = ds["carbody_acceleration"].values
    want = res.out.body_acc[0, :n]
    # float32 histories in the file: 1e-6 of the peak
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * np.abs(want).max())
    for k in ("max_deck_displacement", "max_deck_acceleration"):
        np.testing.assert_array_equal(ds[k].values, ds[k + "_all_tracks"].values)
    # the second train is in the run: the first one's body differs from a run alone
    (tmp_path / "alone").mkdir()
    alone = sweep_file(tmp_path / "alone", _text(TRACKS, TORSION, "track = 1", SPRUNG),
                       speed=0)
    a1 = alone["carbody_acceleration"].values[:, 0]
    assert np.max(np.abs(a1 - got[:a1.size, 0])) > 0.05 * np.max(np.abs(a1))


def _car_with_wheel():
    """A sprung mass on a wheel of 1 t: the wheel meets the kinks of the running surface
    at the deck ends (impacts, crossing pieces of the step)."""
    return Train("sprung mass on a wheel", (vh.sprung_mass(MV, KV, CV, 1000.0),), (0.0,))


def test_pack_trains__a_train_in_minus_x_is_the_mirror_of_one_in_plus_x():
    """On a planar simply supported span (symmetric: mode n is (-1)^(n+1) itself
    mirrored), a train in -x from beyond the far end is the +x run mirrored: the same
    body acceleration and contact force histories (to round-off: the shapes are
    evaluated at L - x), the deck-end impacts included."""
    from vsi_numba.model import bridge as br

    deck = br.simply_supported(L, EI, MASS, n_modes=4, damping_ratio=0.02)
    train = _car_with_wheel()
    settings = SolverSettings(dt=1e-3, approach=APPROACH, free_vibration=0.2)
    prof = no_irregularity()
    runs = []
    for d in (1, -1):
        packed = pack_trains([deck], [TrainOnTrack(train, direction=d, offset=1e-9)], V, None,
                             settings)
        res = run_batch(packed, prof, [V], [0.5 * L], settings, deck, keep_histories=[True])
        assert res.status[0] == 0, res.message(0)
        n = int(res.n_steps[0]) + 1
        runs.append((res.out.body_acc[0, :n], res.out.X[0, :n], res.out.q[0, :n]))
    (a1, x1, q1), (a2, x2, q2) = runs
    sign = (-1.0) ** np.arange(4)  # q_n of the mirrored run: (-1)^(n+1) q_n
    # round-off of the mirrored abscissae (1e-15 m) through the impacts: 1e-9 of the peak
    np.testing.assert_allclose(a2, a1, rtol=0, atol=1e-9 * np.abs(a1).max())
    np.testing.assert_allclose(x2, x1, rtol=0, atol=1e-9 * np.abs(x1).max())
    np.testing.assert_allclose(q2 * sign, q1, rtol=0, atol=1e-9 * np.abs(q1).max())


def test_pack_trains__each_line_its_own_profile():
    """One profile per track line: a train alone on line 1 of two (line 0 smooth, line 1
    a cosine dip) is the single-train run on line 1 with the dip, bit for bit; the same
    train on line 0 sees no dip."""
    from vsi_numba.model import irregularity as irr

    deck, _ = _model()
    train = _car_with_wheel()
    settings = SolverSettings(dt=1e-3, approach=APPROACH, free_vibration=0.2)
    lines = [deck.track_bridge(0), deck.track_bridge(1)]
    dip = irr.cosine_defect(0.004, 3.0, 10.0)
    flat = irr.Profile(dip.x0, dip.dx, np.zeros_like(dip.coef), "none")

    def run(packed, prof, line):
        res = run_batch(packed, prof, [V], [0.5 * L], settings, line, keep_histories=[True])
        assert res.status[0] == 0
        n = int(res.n_steps[0]) + 1
        return res.out.body_acc[0, :n], res.out.X[0, :n]

    single = run(pack(lines[1], train, V, dip, settings), dip, lines[1])
    on1 = run(pack_trains(lines, [TrainOnTrack(train, line=1)], V, [flat, dip], settings),
              [flat, dip], lines[1])
    for a, b in zip(single, on1, strict=True):
        np.testing.assert_array_equal(a, b)
    # train 1 on the smooth line 0, train 2 on line 1 far behind (200 m): until train 2
    # reaches the deck, train 1 runs as alone on smooth track (not on line 1's dip)
    smooth = run(pack(lines[0], train, V, None, settings), no_irregularity(), lines[0])
    two = [TrainOnTrack(train, line=0), TrainOnTrack(train, line=1, offset=200.0)]
    on0 = run(pack_trains(lines, two, V, [flat, dip], settings), [flat, dip], lines[0])
    k = min(int((APPROACH + 200.0) / V / 1e-3) - 10, smooth[0].shape[0])
    np.testing.assert_array_equal(on0[0][:k, 0], smooth[0][:k, 0])


def test_config__an_interaction_train_on_track_2_at_its_own_speed_factor(tmp_path):
    """``other_trains = [{ track = 2, speed_factor = 1.4, offset = 3 }]`` with an
    interaction train through ``vsi sweep``: the file's body accelerations equal the
    Python API's run of :func:`pack_trains` with that speed factor (to the float32 of the
    file), the run lasts until the slower train has left, and a factor of 1 gives a
    different second body (the factor reaches the run)."""
    from test_space_config import SPRUNG, TORSION, TRACKS, _text
    from userpath import sweep_file

    from vsi_numba.config import load_config

    def text(factor):
        return _text(TRACKS, TORSION, "track = 1\nother_trains = [{ track = 2, "
                     f"offset = 3.0, speed_factor = {factor} }}]", SPRUNG)

    ds = sweep_file(tmp_path, text(1.4), speed=0)
    cfg = load_config(tmp_path / "deck.toml")
    train = cfg.trains()[0]
    settings = cfg.solver_settings()
    lines = [cfg.bridge_for(train, k) for k in (1, 2)]
    packed = pack_trains(lines, [TrainOnTrack(train, 0),
                                 TrainOnTrack(train, 1, offset=3.0, speed_factor=1.4)],
                         1.0, None, settings)
    v = float(ds.speed)
    res = run_batch(packed, no_irregularity(), [v], [10.0], settings, lines[0],
                    keep_histories=[True])
    n = int(res.n_steps[0]) + 1
    assert ds.sizes["time"] == n
    # the run's train (1.0 v, no offset) is the last to leave: its own run length
    alone = pack(lines[0], train, 1.0, None, settings)
    t_end = alone.run_length / v + settings.free_vibration
    assert (n - 1) * settings.dt == pytest.approx(t_end, abs=settings.dt)
    got = ds["carbody_acceleration"].values
    want = res.out.body_acc[0, :n]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * np.abs(want).max())
    (tmp_path / "one").mkdir()
    same = sweep_file(tmp_path / "one", text(1.0), speed=0)["carbody_acceleration"].values
    m = min(same.shape[0], n)
    assert np.max(np.abs(same[:m, 1] - got[:m, 1])) > 0.05 * np.max(np.abs(got[:, 1]))


@pytest.mark.parametrize("entry, message", [
    ('{ track = 2, train = "HSLM-A1" }',
     'train.other_trains[0].train = "HSLM-A1": expected no train of its own with '
     'interaction trains'),
    ("{ track = 2, speed_kmh = 90.0 }",
     "train.other_trains[0].speed_kmh = 90"),
])
def test_config__an_interaction_runs_other_train_of_its_own_is_refused(tmp_path, entry,
                                                                       message):
    """An interaction run's other train with a train or a speed in km/h of its own: a
    message naming the key and what is offered (speed_factor, moving-force trains)."""
    from test_space_config import SPRUNG, TORSION, TRACKS, _text

    from vsi_numba.config import ConfigError, load_config

    path = tmp_path / "deck.toml"
    path.write_text(_text(TRACKS, TORSION, f"track = 1\nother_trains = [{entry}]", SPRUNG))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = str(err.value)
    assert message in text, text
    assert ("speed_factor" in text) if "speed_kmh" in entry else ("moving_force" in text)


def test_config__interaction_trains_on_an_imported_decks_lines_are_refused(tmp_path):
    """An imported deck with two named track lines takes moving-force trains on its other
    line (superposed); an interaction train there is refused with a message naming the
    key, the deck's kind and what is offered."""
    import test_imported_space_config as imp

    from vsi_numba.config import ConfigError, load_config

    fixed = imp._write_matrices(tmp_path, (("T/left", imp.LEFT_RAIL),
                                           ("T/right", imp.RIGHT_RAIL),
                                           ("G", imp.LEFT_GIRDER)))
    forces = imp._text(imp._matrices_bridge(fixed, 'tracks = [{ line = "T" }, '
                                                   '{ line = "G" }]'), [100.0])
    forces = forces.replace("[train]", "[train]\ntrack = 1\nother_trains = [{ track = 2 }]")
    path = tmp_path / "deck.toml"
    path.write_text(forces)
    assert load_config(path).other_trains == [{"track": 2, "direction": "same",
                                               "offset": 0.0}]
    head, _, rest = forces.partition('name = "axles"')
    sprung = "\n" + textwrap.dedent("""
        [[train.vehicles]]
        kind = "sprung_mass"
        offset = 0.0
        mass = 20000.0
        stiffness = 4e6""")
    path.write_text(head + sprung + "\n[track]" + rest.partition("[track]")[2])
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = str(err.value)
    assert "train.other_trains = " in text and "bridge.kind = \"matrices\"" in text, text
    assert "not offered on imported decks" in text and "moving_force" in text, text
