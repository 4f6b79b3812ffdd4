"""Trains of their own at speeds of their own on other tracks, and the torsional moment of
a continuous deck, through the user's path (config -> ``vsi sweep`` -> netCDF ->
``vsi report``), each against a reference computed here:

- three trains on three tracks, each its own train and speed (``train``, ``speed_kmh``,
  ``speed_factor``): the every-train envelopes against the sum, formed here with the
  test's own time shift, of the histories of each train alone in a one-track run;
- the torsional moment of a two-span continuous deck restrained in torsion at every
  support at crawl speed, at the output points and on the whole-deck grid, one train and
  two trains, against the test's own static St-Venant finite-element solution (numpy);
- the whole-deck bending moment and shear force with both trains at crawl against the
  sum of each train alone;
- a second train on an imported deck's named track line against the sum of each alone.
"""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest
from test_space_config import TORSION, L
from typer.testing import CliRunner
from userpath import sweep_file

from vsi_numba.cli import app
from vsi_numba.config import ConfigError, load_config

Y = (2.2, -2.2, 4.0)  # m, the three tracks' eccentricities
TRACKS3 = "tracks = [" + ", ".join(f"{{ eccentricity = {y} }}" for y in Y) + "]"
GJ, P = 5e9, 100e3


def _config(train_track: str, vehicles: str, speed: float, free: float, kind: str = "ss",
            dt: float = 5e-4, points: str = "[5.0, 10.0]") -> str:
    bridge = ('kind = "simply_supported"\nspans = [20.0]' if kind == "ss" else
              'kind = "continuous"\nspans = [10.0, 10.0]\nelements_per_span = 40')
    return textwrap.dedent("""
        title = "trains of their own"
        [bridge]
        {bridge}
        EI = 2.0e10
        mass_per_length = 15000.0
        damping_ratio = 0.01
        n_modes = 3
        output_points = {points}
        {tracks}
        {torsion}
        [train]
        {train_track}
        {vehicles}
        [track]
        model = "rigid"
        [solver]
        dt = {dt}
        hht_alpha = 0.0
        approach = 0.0
        free_vibration = {free}
        [study]
        speeds_kmh = [{speed}]
        output = "out.nc"
        save_time_histories = true
        """).format(bridge=bridge, points=points, tracks=TRACKS3, torsion=TORSION,
                    train_track=train_track, vehicles=vehicles, dt=dt, free=free,
                    speed=speed)


def _forces(n, d, p):
    return "\n".join(f'[[train.vehicles]]\nkind = "force"\noffset = {d * i}\nload = {p}'
                     for i in range(n))


def _axles(path, positions, loads_kn):
    path.write_text("position,load\n" + "".join(f"{x},{q}\n" for x, q in
                                                 zip(positions, loads_kn, strict=True)))


def _run(tmp_path, name, text):
    d = tmp_path / name
    d.mkdir()
    for f in (*tmp_path.glob("*.csv"), *tmp_path.glob("*.mtx")):  # the deck's data
        (d / f.name).write_bytes(f.read_bytes())
    return sweep_file(d, text, speed=0), d


def test_own_trains_and_speeds__against_the_sum_of_each_train_alone(tmp_path):
    """Four 170 kN forces on track 1 at 90 km/h; an axle-CSV train on track 2 at
    speed_kmh = 72, 4 m behind (it enters 4 / 20 = 0.2 s later); another axle-CSV train
    on track 3 at speed_factor = 0.5 (45 km/h): the file's every-train envelopes against
    max |h1(t) + h2(t - 0.2 s) + h3(t)| of the histories of each train alone (its own
    one-track run, free vibration long enough to cover the run of all three)."""
    _axles(tmp_path / "a.csv", [0.0, 2.5, 9.0], [120.0, 120.0, 150.0])
    _axles(tmp_path / "b.csv", [0.0, 3.0], [200.0, 200.0])
    others = ('other_trains = [{ track = 2, train = { file = "a.csv" }, speed_kmh = 72.0, '
              'offset = 4.0 }, { track = 3, train = { file = "b.csv", name = "B" }, '
              'speed_factor = 0.5 }]')
    ds, _ = _run(tmp_path, "all", _config(f"track = 1\n{others}", _forces(4, 6.0, 170e3),
                                          90.0, 0.2))
    got = json.loads(ds.attrs["other_trains"])
    assert got[0]["train"] == {"file": "a.csv", "load_unit": "kN"}
    assert got[0]["speed_kmh"] == 72.0 and got[1]["speed_factor"] == 0.5
    # the run lasts until the slowest train has left: B, (20 + 3) m at 12.5 m/s
    n = int(np.isfinite(ds["deck_displacement"].values[:, 0]).sum())
    assert (n - 1) * 5e-4 >= 23.0 / 12.5 + 0.2 - 1e-9
    alone = [
        _run(tmp_path, "one", _config("track = 1", _forces(4, 6.0, 170e3), 90.0, 3.0))[0],
        _run(tmp_path, "two", _config('track = 2\naxles = { file = "a.csv" }', "", 72.0,
                                      3.0))[0],
        _run(tmp_path, "three", _config('track = 3\naxles = { file = "b.csv" }', "", 45.0,
                                        3.0))[0]]
    shift = [0, 400, 0]  # steps: train 2 enters 4 m / 20 m/s = 0.2 s = 400 dt later

    def summed(name):
        out = 0.0
        for a, k in zip(alone, shift, strict=True):
            h = a[name].values.astype(float)
            h = np.concatenate([np.zeros((k, *h.shape[1:])), h])[:n]
            assert h.shape[0] == n and np.isfinite(h).all(), name
            out = out + h
        return out

    # the alone histories are stored as float32 (relative 6e-8) and summed here:
    # measured up to 2.6e-8 of the envelope; tolerance 7e-8 (2.7x)
    rtol = 7e-8
    np.testing.assert_allclose(ds["max_deck_displacement_all_tracks"].values,
                               np.abs(summed("deck_displacement")).max(axis=0), rtol=rtol)
    m = summed("bending_moment")
    np.testing.assert_allclose(ds["max_bending_moment_all_tracks"].values, m.max(axis=0),
                               rtol=rtol)
    np.testing.assert_allclose(ds["min_bending_moment_all_tracks"].values, m.min(axis=0),
                               rtol=rtol, atol=rtol * np.abs(m).max())
    np.testing.assert_allclose(ds["max_track_displacement_all_tracks"].values,
                               np.abs(summed("track_displacement")).max(axis=0), rtol=rtol)
    np.testing.assert_allclose(ds["max_deck_twist_all_tracks"].values,
                               np.abs(summed("deck_twist")).max(axis=0), rtol=rtol)
    tq = summed("torsional_moment")
    np.testing.assert_allclose(ds["max_torsional_moment_all_tracks"].values, tq.max(axis=0),
                               rtol=rtol, atol=rtol * np.abs(tq).max())
    np.testing.assert_allclose(ds["min_torsional_moment_all_tracks"].values, tq.min(axis=0),
                               rtol=rtol, atol=rtol * np.abs(tq).max())
    # the one-track envelopes stay the run's train's alone, bit for bit
    for name in ("max_deck_displacement", "max_bending_moment", "max_torsional_moment"):
        np.testing.assert_array_equal(ds[name].values, alone[0][name].values)


def test_own_train_by_library_name_and_config_errors(tmp_path):
    """A library name builds that train as moving forces; speed_kmh with speed_factor,
    an unknown name and a factor out of bounds are refused naming key and value."""
    def load(other):
        p = tmp_path / "c.toml"
        p.write_text(_config(f"track = 1\nother_trains = [{other}]", _forces(1, 0.0, 1e5),
                             100.0, 0.1))
        return load_config(p)

    cfg = load('{ track = 2, train = "HSLM-A1" }')
    (own,) = cfg.other_train_models()
    assert own.name == "HSLM-A1" and all(v.n_dof == 0 for v in own.vehicles)
    from vsi_numba.model import library

    ref = library.get_train("HSLM-A1", model="moving_force")
    np.testing.assert_array_equal(own.axle_positions, ref.axle_positions)
    assert load("{ track = 2 }").other_train_models() == [None]
    for other, key, words in (
            ("{ track = 2, speed_kmh = 200, speed_factor = 2 }", "speed_factor", "not both"),
            ('{ track = 2, train = "HSLM-A99" }', "train", "library"),
            ("{ track = 2, speed_factor = 20 }", "speed_factor", "0.1 .. 10"),
            ("{ track = 2, speed_kmh = -5 }", "speed_kmh", "> 0 km/h")):
        with pytest.raises(ConfigError) as exc:
            load(other)
        assert f"train.other_trains[0].{key}" in str(exc.value) and words in str(exc.value)


# ------------------------------------------------------- torsion of a continuous deck


def fe_bar_stiffness(nodes, gj):
    """Stiffness matrix (n, n) of the bar of linear elements between ``nodes``: element e
    adds GJ / h_e [[1, -1], [-1, 1]] at rows and columns (e, e + 1).  Assembled as
    arrays, not element by element (the references call it ~10^4 times): node e's
    diagonal is k_(e-1) + k_e, the same sum, in the same floating-point value, as the
    element loop's."""
    k = gj / np.diff(nodes)
    i = np.arange(nodes.size - 1)
    K = np.zeros((nodes.size, nodes.size))
    K[i + 1, i + 1] = k
    K[i, i] += k
    K[i, i + 1] = -k
    K[i + 1, i] = -k
    return K


def _fe_torque(sections, loads, supports, gj):
    """Static St-Venant torque T = GJ dtheta/dx at ``sections`` (the value just right of
    a section; just left at the deck's right end) of point torques ``loads`` [(a, M)] on
    a bar restrained in rotation at ``supports``: linear finite elements with a node at
    every support, section and load (nodally exact for point torques), solved here."""
    nodes = np.unique(np.concatenate([supports, sections, [a for a, _ in loads]]))
    h = np.diff(nodes)
    n = nodes.size
    K = fe_bar_stiffness(nodes, gj)
    f = np.zeros(n)
    for a, m in loads:
        f[np.searchsorted(nodes, a)] += m
    free = ~np.isin(nodes, supports)
    th = np.zeros(n)
    th[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    te = gj * np.diff(th) / h  # per element
    e = np.clip(np.searchsorted(nodes, sections, side="right") - 1, 0, n - 2)
    return te[e]


def _crawl_reference(sections, trains, v, dt, n):
    """max / min over the run's steps of the FE torque of every train's loads on the deck
    (each train: eccentricity, axle offsets, load, start delay in steps)."""
    sup = np.array([0.0, 10.0, 20.0])
    hi = np.full(sections.size, -np.inf)
    lo = np.full(sections.size, np.inf)
    for i in range(n):
        loads = []
        for y, offsets, p, delay in trains:
            a = v * (i - delay) * dt - np.asarray(offsets)
            loads += [(float(x), p * y) for x in a if 0.0 <= x <= L]
        t = _fe_torque(sections, loads, sup, GJ) if loads else np.zeros(sections.size)
        hi, lo = np.maximum(hi, t), np.minimum(lo, t)
    return hi, lo


def test_torsional_moment_of_a_continuous_deck_at_crawl__against_static_fe(tmp_path):
    """One 100 kN force on track 1 (y = 2.2 m) at 1 m/s over 10 + 10 m, torsion
    restrained at both ends and the interior support: the torque envelopes at the output
    points and on the whole-deck grid against the test's own static FE torque (numpy);
    the same with a second train on track 2 (y = -2.2 m) 3 m behind, the every-train
    torque envelopes against the FE torque of both loads; the whole-deck bending moment
    and shear force with both trains against the sum of each train alone (their own
    one-track runs' histories at the output points, on the grid); the report names the
    torque's sections."""
    v, dt, off = 1.0, 5e-3, 3.0
    pts = "[2.5, 5.0, 7.5, 10.0, 12.5, 15.0]"
    # free vibration long enough for the run to cover the run of both trains below
    one = _config("track = 1", _forces(1, 0.0, P), 3.6, 3.5, "continuous", dt, pts)
    ds, d1 = _run(tmp_path, "one", one)
    n = ds["time"].size
    x = ds["point"].values
    grid = ds["deck_x"].values
    assert "max_torsional_moment" in ds and "max_torsional_moment_whole_deck" in ds
    assert "torsional_moment" not in json.loads(ds.attrs["not_computed"])
    hi, lo = _crawl_reference(np.concatenate([x, grid]), [(Y[0], [0.0], P, 0)], v, dt, n)
    scale = P * Y[0]
    # crawl (v/c = 4e-3): the static torque plus the kept torsional modes' free
    # vibration, which a load entering or leaving a span starts (ringing at 12.5 Hz):
    # measured 2e-4 of P e at the output points inside the spans, 3.9e-3 over the
    # whole-deck grid (largest at the supports, where the modes' slopes are); 2.5x
    inside = ~np.isin(x, [0.0, 10.0, 20.0])
    tol, tol_all = 5e-4 * scale, 1e-2 * scale
    for ext, ref in (("max", hi), ("min", lo)):
        np.testing.assert_allclose(ds[f"{ext}_torsional_moment"].values[inside],
                                   ref[:x.size][inside], atol=tol)
        np.testing.assert_allclose(ds[f"{ext}_torsional_moment"].values, ref[:x.size],
                                   atol=tol_all)
        np.testing.assert_allclose(ds[f"{ext}_torsional_moment_whole_deck"].values,
                                   ref[x.size:], atol=tol_all)
    # each span carries its own loads only: no torque in span 2 while the load is in
    # span 1 (the interior support restrains the torsion)
    assert ds["max_torsional_moment"].attrs["units"] == "N m"
    both = one.replace("track = 1\n", "track = 1\nother_trains = [{ track = 2, offset = "
                       f"{off} }}]\n", 1).replace("free_vibration = 3.5",
                                                  "free_vibration = 0.2")
    ds2, d2 = _run(tmp_path, "both", both)
    n2 = ds2["time"].size
    delay = int(round(off / v / dt))
    hi2, lo2 = _crawl_reference(np.concatenate([x, grid]), [
        (Y[0], [0.0], P, 0), (Y[1], [0.0], P, delay)], v, dt, n2)
    # two loads ring together: measured 2.1e-3 of P e inside the spans, 3.9e-3 at most
    for ext, ref in (("max", hi2), ("min", lo2)):
        np.testing.assert_allclose(ds2[f"{ext}_torsional_moment_all_tracks"].values,
                                   ref[:x.size], atol=tol_all)
        np.testing.assert_allclose(
            ds2[f"{ext}_torsional_moment_whole_deck_all_tracks"].values, ref[x.size:],
            atol=tol_all)
    # whole-deck M and V with both trains against the sum of each alone: the second
    # train alone on track 2 is the first's run delayed (same force), its M and V the
    # same on the deck's axis; the alone histories at the output points (on the grid)
    m1 = ds["bending_moment"].values.astype(float)
    v1 = ds["shear_force"].values.astype(float)
    pad = np.zeros((delay, x.size))
    msum = m1[:n2] + np.concatenate([pad, m1])[:n2]
    vsum = v1[:n2] + np.concatenate([pad, v1])[:n2]
    at = [int(np.flatnonzero(np.isclose(grid, p))[0]) for p in x]
    # float32 histories summed here: measured 2.9e-8 of the largest value; 7e-8 (2.4x)
    for name, s in (("bending_moment", msum), ("shear_force", vsum)):
        big = np.abs(s).max()
        for ext, f in (("max", np.max), ("min", np.min)):
            np.testing.assert_allclose(
                ds2[f"{ext}_{name}_whole_deck_all_tracks"].values[at], f(s, axis=0),
                atol=7e-8 * big, err_msg=f"{ext}_{name}")
    # the report has the torsional moment's sections and the every-train grid
    res = CliRunner().invoke(app, ["report", str(d2 / "out.nc"), "-o", str(d2 / "rep")])
    assert res.exit_code == 0, res.output
    text = (d2 / "rep" / "report.md").read_text()
    part = text[text.index("### Torsional moment"):]
    assert "every train" in part and "whole-deck grid" in part
    hi_all = ds2["max_torsional_moment_whole_deck_all_tracks"].values
    x_hi = grid[int(np.argmax(hi_all))]
    assert f"{hi_all.max() * 1e-3:.4g} kN m" in part and f"x = {x_hi:g} m" in part
    summary = (d2 / "rep" / "summary.csv").read_text()
    assert "torsional moment" in summary.lower()
    # one value per quantity: the summary shows it as the torque table does, in kN m
    lines = [ln for ln in text.splitlines() if ln.startswith("| Torsional moment \\|T\\|")]
    assert lines and all(" kN m |" in ln for ln in lines), lines
    assert f"| {hi_all.max() * 1e-3:.4g} kN m |" in "\n".join(lines)


# ------------------------------------------------------------ imported decks (lines)


def test_other_trains_on_an_imported_decks_track_lines__against_each_alone(tmp_path):
    """A grillage imported as matrices with two named track lines ('T' with its rails,
    the left girder 'G'): the run's six forces on T at 100 km/h and the same train on G
    at speed_factor = 0.8 (80 km/h), 4 m behind (0.18 s = 180 dt later): the
    every-train envelopes against the sum, with the test's own shift, of each train
    alone on its line; a deck without track lines is refused naming the key."""
    import test_imported_space_config as imp

    def text(train, free):
        fixed = imp._write_matrices(tmp_path, (("T/left", imp.LEFT_RAIL),
                                               ("T/right", imp.RIGHT_RAIL),
                                               ("G", imp.LEFT_GIRDER)))
        t = imp._text(imp._matrices_bridge(fixed, 'tracks = [{ line = "T" }, '
                                                  '{ line = "G" }]'), [100.0],
                      extra="save_time_histories = true")
        return t.replace("[train]", f"[train]\n{train}").replace(
            f"free_vibration = {imp.FREE}", f"free_vibration = {free}")

    ds, _ = _run(tmp_path, "all", text("track = 1\nother_trains = [{ track = 2, "
                                       "speed_factor = 0.8, offset = 4.0 }]", 0.3))
    n = int(np.isfinite(ds["deck_displacement"].values[:, 0]).sum())
    alone = [_run(tmp_path, f"alone{k}", text(f"track = {k}", 2.0))[0] for k in (1, 2)]
    alone[1] = _run(tmp_path, "slow", text("track = 2", 2.0).replace(
        "speeds_kmh = [100.0]", "speeds_kmh = [80.0]"))[0]
    shift = [0, 180]  # 4 m at 80 km/h = 0.18 s, dt = 1e-3 s

    def summed(name):
        out = 0.0
        for a, k in zip(alone, shift, strict=True):
            h = a[name].values.astype(float)
            out = out + np.concatenate([np.zeros((k, *h.shape[1:])), h])[:n]
        return out

    # float32 histories summed here (relative 6e-8 each): measured 1.5e-8 of the
    # envelope, tolerance 4e-8 (2.7x);
    # the deck line of an imported deck is the loaded track's (T for the run's train):
    # the per-track lines are the ones every run shares
    track = summed("track_displacement")
    np.testing.assert_allclose(ds["max_track_displacement_all_tracks"].values,
                               np.abs(track).max(axis=0), rtol=4e-8)
    np.testing.assert_allclose(ds["max_deck_displacement_all_tracks"].values,
                               np.abs(track[:, 0]).max(axis=0), rtol=4e-8)
    assert np.all(ds["max_track_displacement_all_tracks"].values
                  > ds["max_track_displacement"].values)
