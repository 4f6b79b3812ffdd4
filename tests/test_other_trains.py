"""Several trains in one run through the user's path: ``[train] other_trains`` in a
config file -> ``vsi sweep`` -> netCDF (the ``..._all_tracks`` envelopes), against the
test's own modal integration of every train at once (closed-form bending and torsion
modes, scipy), plus the config's errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from test_space_config import ECC, EI, GJ, IP, MASS, N_B, N_T, TORSION, TRACKS, ZB, ZT, L, _text
from test_space_config import _sweep as _sweep_file

from vsi_numba.config import ConfigError, load_config

S = 1.435  # m, the gauge


def _forces(n, d, p):
    return "\n".join(f'[[train.vehicles]]\nkind = "force"\noffset = {d * i}\nload = {p}'
                     for i in range(n))


def _modal(t, loads):
    """Modal coordinates and accelerations (len(t), N_B + N_T) of the closed-form sine
    modes under moving forces ``loads``: a list of (y, x(t) -> positions, P); solve_ivp
    DOP853 at tight tolerances."""
    from scipy.integrate import solve_ivp

    k = np.pi * np.arange(1, max(N_B, N_T) + 1) / L
    kk = np.concatenate([k[:N_B], k[:N_T]])
    w = np.concatenate([k[:N_B] ** 2 * np.sqrt(EI / MASS), k[:N_T] * np.sqrt(GJ / IP)])
    z = np.concatenate([np.full(N_B, ZB), np.full(N_T, ZT)])

    def amp(y):
        return np.concatenate([np.full(N_B, np.sqrt(2 / (MASS * L))),
                               y * np.full(N_T, np.sqrt(2 / (IP * L)))])

    def force(tt):
        f = np.zeros(w.size)
        for y, where, p in loads:
            x = where(tt)
            x = x[(x >= 0) & (x <= L)]
            f += p * (amp(y) * np.sin(np.outer(x, kk))).sum(axis=0)
        return f

    def rhs(tt, s):
        n = w.size
        return np.concatenate([s[n:], force(tt) - 2 * z * w * s[n:] - w**2 * s[:n]])

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(2 * w.size), method="DOP853", t_eval=t,
                    rtol=1e-10, atol=1e-14, max_step=1e-3)
    qdd = np.array([rhs(tt, s)[w.size:] for tt, s in zip(t, sol.y.T, strict=True)])
    return sol.y[:w.size].T, qdd, kk, w, force


def _moment(x, t, q, kk, w, force, loads):
    """Bending moment at x by the mode-acceleration method written here: the static
    moment of the loads on the deck (closed-form simply supported beam) plus
    sum_j M_j (q_j - F_j / w_j^2) over the bending modes, M_j = EI k_j^2 a sin(k_j x)."""
    out = np.zeros(t.size)
    for i, tt in enumerate(t):
        for _y, where, p in loads:
            a = where(tt)
            a = a[(a >= 0) & (a <= L)]
            out[i] += p * np.where(x <= a, x * (L - a) / L, a * (L - x) / L).sum()
        f = force(tt)
        mj = EI * kk[:N_B] ** 2 * np.sqrt(2 / (MASS * L)) * np.sin(kk[:N_B] * x)
        out[i] += mj @ (q[i, :N_B] - f[:N_B] / w[:N_B] ** 2)
    return out


def _theta(x, t, q, kk, w, force, loads, D):
    """Torsional rotation at the points x (len(t), len(x)) by the mode-acceleration
    method written here: D times the closed-form static St-Venant rotation of the point
    torques P y of the loads on the fork-supported span, minus D sum_j theta_j F_j /
    w_j^2, plus sum_j theta_j q_j over the torsional modes (D = 1 / (1 - (v/c)^2))."""
    x = np.atleast_1d(x)
    tor = np.sqrt(2 / (IP * L)) * np.sin(np.outer(x, kk[N_B:]))  # (len(x), N_T)
    out = np.zeros((t.size, x.size))
    for i, tt in enumerate(t):
        for y, where, p in loads:
            a = where(tt)
            a = a[(a >= 0) & (a <= L)][None, :]
            g = np.where(x[:, None] <= a, x[:, None] * (L - a), a * (L - x[:, None]))
            out[i] += D * p * y * (g / (GJ * L)).sum(axis=1)
        f = force(tt)
        out[i] += tor @ (q[i, N_B:] - D * f[N_B:] / w[N_B:] ** 2)
    return out


def test_trains_meeting_on_a_twisting_deck_against_own_integration(tmp_path):
    """Four 170 kN forces 6 m apart on track 1 (+x) and the same train on track 2
    (y = -2.2 m) entering at the far end 4 m later (-x): the file's envelopes with both
    trains (deck, each track line, twist, bending moment, support reaction) against the
    test's own integration of the eight forces at once; the one-track envelopes stay
    those of the run's train alone."""
    n_f, d, p, off = 4, 6.0, 170e3, 4.0
    v = 90.0 / 3.6
    text = _text(TRACKS, TORSION, "track = 1\nother_trains = [{ track = 2, direction = "
                 f"\"opposite\", offset = {off} }}]", _forces(n_f, d, p), speed=90.0,
                 free=0.2).replace("output_points = [10.0]", "output_points = [5.0, 10.0]")
    ds = _sweep_file(tmp_path, text)
    assert json.loads(ds.attrs["other_trains"]) == [
        {"track": 2, "direction": "opposite", "offset": off}]
    assert ds.attrs["loaded_tracks_all"] == "1 2"
    t = ds["time"].values
    t = t[np.isfinite(ds["deck_displacement"].values[:, 0])]
    offsets = d * np.arange(n_f)
    own = [(ECC, lambda tt: v * tt - offsets, p)]
    both = own + [(-ECC, lambda tt: L - (v * tt - off - offsets), p)]
    pts = np.array([5.0, 10.0])
    for loads, suffix in ((own, ""), (both, "_all_tracks")):
        q, qdd, kk, w, force = _modal(t, loads)
        bend = np.sqrt(2 / (MASS * L)) * np.sin(np.outer(pts, kk[:N_B]))
        axis = np.abs(q[:, :N_B] @ bend.T).max(axis=0)
        D = 1.0 / (1.0 - v * v * IP / GJ)
        th = _theta(pts, t, q, kk, w, force, loads, D)
        th3 = _theta(pts + 3.0, t, q, kk, w, force, loads, D)
        twist = np.abs(S * (th - th3)).max(axis=0)
        # HHT alpha = 0 at dt = 5e-4 s against a converged integration; measured
        # 1e-5 (deck), 8e-5 (track lines), 5e-5 (moment) and 2.5e-3 (twist: a small
        # difference of the torsional modes, up to 25 Hz, whose phase the trapezoidal
        # rule shifts most); tolerances about 2.5x
        np.testing.assert_allclose(ds[f"max_deck_displacement{suffix}"].values, axis,
                                   rtol=3e-5)
        np.testing.assert_allclose(ds[f"max_deck_twist{suffix}"].sel(track=1).values,
                                   twist, rtol=6e-3)
        for k, y in ((1, ECC), (2, -ECC)):
            disp = np.abs(q[:, :N_B] @ bend.T + y * th).max(axis=0)
            np.testing.assert_allclose(
                ds[f"max_track_displacement{suffix}"].sel(track=k).values, disp, rtol=2e-4)
        m = _moment(10.0, t, q, kk, w, force, loads)
        got = ds[f"max_bending_moment{suffix}"].isel(point=1).values
        np.testing.assert_allclose(got, m.max(), rtol=1.5e-4)
    # both trains together load the deck more than the run's train alone
    assert np.all(ds["max_bending_moment_all_tracks"].values
                  > ds["max_bending_moment"].values)


def test_side_by_side_without_torsion_is_twice_the_one_track_envelopes(tmp_path):
    """The same train side by side on both tracks (same direction, offset 0): on a deck
    without torsion the axis sees twice the train, so every deck envelope with both
    trains is twice the one-track envelope (the deck is linear), to round-off."""
    text = _text(TRACKS, "", "track = 1\nother_trains = [{ track = 2 }]",
                 _forces(3, 5.0, 100e3), speed=120.0, free=0.1)
    ds = _sweep_file(tmp_path, text)
    for name in ("max_deck_displacement", "max_bending_moment", "max_support_reaction",
                 "max_shear_force", "max_deck_acceleration"):
        np.testing.assert_allclose(ds[f"{name}_all_tracks"].values, 2 * ds[name].values,
                                   rtol=1e-9, err_msg=name)
    for name in ("time_of_max_deck_displacement", "time_of_max_bending_moment"):
        np.testing.assert_array_equal(ds[f"{name}_all_tracks"].values, ds[name].values)
    # without torsion each track line is the axis: its whole-deck acceleration is the
    # deck's (taken from the deck's envelope, with no rows of its own)
    for sfx in ("", "_all_tracks"):
        for k in (1, 2):
            for pre in ("", "time_of_", "position_of_"):
                np.testing.assert_array_equal(
                    ds[f"{pre}max_track_acceleration_whole_deck{sfx}"].sel(track=k).values,
                    ds[f"{pre}max_deck_acceleration_whole_deck{sfx}"].values)


def test_files_without_other_trains_name_the_all_tracks_outputs(tmp_path):
    ds = _sweep_file(tmp_path, _text(TRACKS, TORSION, "track = 2"))
    why = json.loads(ds.attrs["not_computed"])
    assert not [v for v in ds.data_vars if v.endswith("_all_tracks")]
    assert "no train.other_trains" in why["max_bending_moment_all_tracks"]
    assert "other_trains" not in ds.attrs


def _toml(tmp_path, text):
    path = tmp_path / "deck.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("tracks, others, vehicle, message", [
    (TRACKS, "[{ track = 3 }]", "", "train.other_trains[0].track = 3: expected a track of "
                                    "bridge.tracks, 1 .. 2"),
    (TRACKS, "[{ track = 1 }]", "", "train.other_trains[0].track = 1: expected a track not "
                                    "loaded yet (train.track = 1)"),
    (TRACKS, "[{ track = 2, direction = \"back\" }]", "", "train.other_trains[0].direction"),
    (TRACKS, "[{ track = 2, offset = -3.0 }]", "", "train.other_trains[0].offset = -3"),
    (TRACKS, "[{ track = 2, speed = 3.0 }]", "", "train.other_trains[0]"),
    (TRACKS, "{ track = 2 }", "", "train.other_trains"),
    ("", "[{ track = 2 }]", "", "the bridge has 1 track"),
])
def test_bad_other_trains_name_the_key(tmp_path, tracks, others, vehicle, message):
    text = _text(tracks, TORSION if tracks else "", f"other_trains = {others}", vehicle)
    with pytest.raises(ConfigError) as err:
        load_config(_toml(tmp_path, text))
    assert message in str(err.value), str(err.value)


def test_other_trains_keep_the_run_going_until_the_last_has_left(tmp_path):
    """An offset makes every run of the study longer by offset / v: the file's time
    axis holds the later train's exit and the free vibration after it."""
    base = _text(TRACKS, TORSION, "track = 1", _forces(2, 5.0, 100e3), speed=72.0, free=0.1)
    later = base.replace("track = 1", "track = 1\nother_trains = [{ track = 2, "
                                      "offset = 30.0 }]")
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    one = _sweep_file(tmp_path / "a", base)
    two = _sweep_file(tmp_path / "b", later)
    n1 = np.isfinite(one["deck_displacement"].values[:, 0]).sum()
    n2 = np.isfinite(two["deck_displacement"].values[:, 0]).sum()
    assert n2 - n1 == pytest.approx(30.0 / 20.0 / 5e-4, abs=1)
    with xr.set_options(keep_attrs=True):
        assert float(two["max_deck_displacement_all_tracks"].max()) > 0


def test_trains_meeting_on_a_symmetric_continuous_deck_load_it_symmetrically(tmp_path):
    """Two equal spans, the same train on each track entering at either end at the same
    time: the deck's response with both trains is symmetric about mid-length (the
    reversed run is the mirror image of the run's train), so every envelope with both
    trains at x equals the one at L - x, and the reactions at the two ends are equal;
    the run's train alone is not symmetric."""
    text = f"""
        title = "meeting"
        [bridge]
        kind = "continuous"
        spans = [20.0, 20.0]
        EI = 2.0e10
        mass_per_length = 15000.0
        damping_ratio = 0.01
        n_modes = 6
        elements_per_span = 10
        output_points = [7.0, 33.0]
        tracks = [{{ eccentricity = 2.0 }}, {{ eccentricity = -2.0 }}]
        [train]
        track = 1
        other_trains = [{{ track = 2, direction = "opposite" }}]
        {_forces(3, 6.0, 150e3)}
        [track]
        model = "rigid"
        [solver]
        dt = 1e-3
        approach = 0.0
        free_vibration = 0.1
        [study]
        speeds_kmh = [140.0]
        output = "out.nc"
        """
    import textwrap
    ds = _sweep_file(tmp_path, textwrap.dedent(text))
    for name in ("max_deck_displacement", "max_bending_moment", "min_bending_moment",
                 "max_deck_acceleration"):
        both = ds[f"{name}_all_tracks"].values
        # mirror images to round-off (the sums of the same numbers in another order)
        np.testing.assert_allclose(both[0], both[1], rtol=1e-9, err_msg=name)
        one = ds[name].values
        assert abs(one[0] / one[1] - 1) > 1e-3, name
    r = ds["max_support_reaction_all_tracks"].values
    np.testing.assert_allclose(r[0], r[2], rtol=1e-9)


def test_other_trains_on_an_imported_deck_take_its_track_lines(tmp_path):
    """A grillage exported as matrices with two tracks (one by its rails, one by a
    centre line): the other train goes on the second track line (the results against
    each train alone: tests/test_other_trains_own_speed_torsion.py); a rigid deck has no
    track lines and is refused, naming the key."""
    from test_imported_space_config import LEFT_RAIL, RIGHT_RAIL, _matrices_bridge, _write_matrices
    from test_imported_space_config import _text as _imported_text

    fixed = _write_matrices(tmp_path, (("T/left", LEFT_RAIL), ("T/right", RIGHT_RAIL),
                                       ("U", LEFT_RAIL)))
    text = _imported_text(_matrices_bridge(
        fixed, 'tracks = [{ line = "T" }, { line = "U" }]'), [60.0]).replace(
        'name = "axles"', 'name = "axles"\nother_trains = [{ track = 2 }]')
    assert load_config(_toml(tmp_path, text)).other_trains == [
        {"track": 2, "direction": "same", "offset": 0.0}]
    rigid = _text(TRACKS, "", "other_trains = [{ track = 2 }]").replace(
        'kind = "simply_supported"', 'kind = "rigid"')
    with pytest.raises(ConfigError) as err:
        load_config(_toml(tmp_path, rigid))
    assert "train.other_trains" in str(err.value)
    assert "bridge.kind = \"rigid\" has no track lines" in str(err.value), str(err.value)


def test_trains_meeting_on_sine_modes_load_the_span_symmetrically(tmp_path):
    """A simply supported span without torsion (its analytic sine modes, each read
    backwards for the train in -x with the sign (-1)^(n+1)): two equal trains entering
    at either end at the same time load it symmetrically about mid-span."""
    text = _text(TRACKS, "", "track = 1\nother_trains = [{ track = 2, direction = "
                 "\"opposite\" }]", _forces(3, 4.0, 120e3), speed=110.0,
                 free=0.1).replace("output_points = [10.0]", "output_points = [6.0, 14.0]")
    ds = _sweep_file(tmp_path, text)
    for name in ("max_deck_displacement", "max_bending_moment", "max_deck_acceleration"):
        both = ds[f"{name}_all_tracks"].values
        np.testing.assert_allclose(both[0], both[1], rtol=1e-9, err_msg=name)
        one = ds[name].values
        assert abs(one[0] / one[1] - 1) > 1e-3, name
