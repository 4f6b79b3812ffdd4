"""Interaction trains meeting on a deck in space, through the user's path (config file ->
``vsi sweep`` -> netCDF -> ``vsi report``): the torsional moment and the twist by the
mode-acceleration method with each axle load at its own track's eccentricity, against
the closed-form static torque and twist of the test's own (crawl speed); and two ICE3
trains meeting on the double-track viaduct of ``studies/ice3_meeting_viaduct``: what
the second train changes, against each train alone."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
from test_space_config import ECC, GAUGE, GJ, SPRUNG, TORSION, TRACKS, L, _text
from userpath import sweep_file, vsi

OFFSET = 3.0  # m: the second train starts this much further back
OTHERS = f'other_trains = [{{ track = 2, direction = "opposite", offset = {OFFSET} }}]'


def _static_torque_twist(x, y, t, v, X):
    """Closed-form static torque at ``x`` and twist over [x, x + 3] of track ``y``... of
    the two sprung masses (contact forces ``X`` (n, 2), N) at time ``t`` (s): mass 1 on
    y = +ECC from x = 0 in +x, mass 2 on y = -ECC from x = L + OFFSET in -x (the
    documented starts with solver.approach = 0); fork-supported span."""
    a = np.stack([v * t, L + OFFSET - v * t], axis=1)  # (n, 2)
    e = np.array([ECC, -ECC])
    on = (a >= 0.0) & (a <= L)
    torque = np.where(a > x, 1.0 - a / L, -a / L)  # T per unit torque, just right of x
    T = np.sum(np.where(on, X * e * torque, 0.0), axis=1)

    def theta(s):  # static rotation: e P M_s(s; a) / GJ
        m = np.where(s <= a, s * (L - a), a * (L - s)) / L
        return np.sum(np.where(on, X * e * m, 0.0), axis=1) / GJ

    twist = GAUGE * (theta(x) - theta(x + 3.0))
    return T, twist


def test_sweep__meeting_interaction_trains_torque_and_twist_at_crawl_speed(tmp_path):
    """Two sprung masses meeting at 10 km/h on tracks at +-2.2 m: the file's torque and
    twist histories (every load at its own track's eccentricity) equal the closed-form
    static ones of the file's contact forces within 1e-2 of P e: what the static
    reference leaves out is the deck's dynamic response to the fluctuating part of the
    contact forces (the undamped sprung masses bounce at 2.25 Hz after they enter, the
    first torsional mode is at 6.25 Hz: about 15 % amplification of that part; measured
    5.0e-3 of P e for the torque, the single-train crawl check of moving forces is
    2.7e-4); with one eccentricity for both loads (the second load's sign wrong) the
    torque would be off by more than 0.5 P e, a hundred times the tolerance."""
    text = _text(TRACKS, TORSION, "track = 1\n" + OTHERS, SPRUNG, speed=10.0, free=0.0)
    ds = sweep_file(tmp_path, text, speed=0)
    assert ds.attrs["deck_twist_method"] == "mode-acceleration"
    assert "max_torsional_moment" not in json.loads(ds.attrs["not_computed"])
    v = float(ds.speed)
    t = ds["time"].values
    X = ds["contact_force"].values  # (time, wheel): the two trains' wheels
    ok = np.isfinite(X).all(axis=1)
    t, X = t[ok], X[ok]
    T_ref, tw_ref = _static_torque_twist(10.0, ECC, t, v, X)
    T = ds["torsional_moment"].values[ok, 0]
    pe = float(ds["static_wheel_load"].values[0]) * ECC
    assert np.max(np.abs(T - T_ref)) < 1e-2 * pe
    tw = ds["deck_twist"].values[ok, 0, 0]
    assert np.max(np.abs(tw - tw_ref)) < 1e-2 * np.max(np.abs(tw_ref))
    # the second train's torque has the other sign: the sum is not one eccentricity's
    T_one = _static_torque_twist(10.0, ECC, t, v, X * np.array([1.0, -1.0]))[0]
    assert np.max(np.abs(T_one - T_ref)) > 0.5 * pe
    # the envelope is the history's extreme, and the all-tracks twin repeats it
    np.testing.assert_allclose(float(ds["max_torsional_moment"][0]), np.nanmax(T),
                               rtol=1e-6)
    np.testing.assert_array_equal(ds["max_torsional_moment"].values,
                                  ds["max_torsional_moment_all_tracks"].values)
    # the attributes say what the variables hold
    assert "every train of the run" in ds["max_torsional_moment"].attrs["loading"]
    assert "loaded track" not in ds["max_torsional_moment"].attrs["long_name"]
    assert "same values" in ds["max_deck_twist_all_tracks"].attrs["loading"]
    assert ds.attrs["other_trains_loading"] == "together"


STUDY = Path(__file__).resolve().parents[1] / "studies" / "ice3_meeting_viaduct" / "study.toml"


def _viaduct(tmp_path, name, speeds, dt, together=True):
    text = STUDY.read_text()
    text = text.replace('speeds_kmh = { start = 140.0, stop = 360.0, step = 10.0 }',
                        f"speeds_kmh = {list(speeds)!r}")
    text = text.replace("dt = 1e-3 ", f"dt = {dt!r} ")
    text = text.replace("history_speeds_kmh = [300.0]", f"history_speeds_kmh = {list(speeds)!r}")
    if not together:
        text = text.replace('other_trains = [{ track = 2, direction = "opposite", '
                            'offset = 0.0 }]', "")
    d = tmp_path / name
    d.mkdir()
    assert text.count("\nspeeds_kmh = [") == 1 and (not together or "other_trains" in text)
    return sweep_file(d, text.replace('output = "results.nc"', 'output = "out.nc"'))


def test_sweep__two_ice3_meeting_on_the_viaduct_against_each_alone(tmp_path):
    """Two ICE3 meeting on the double-track viaduct (the study's config, smooth track) at
    250 and 330 km/h, against the ICE3 alone on track 1.  The deck is symmetric (spans
    25 + 32 + 25 m, tracks at +-2.25 m): the second train alone (track 2, -x) is the
    first alone turned by 180 degrees, so at x on the axis it gives the first's deck
    displacement at L - x.  References and tolerances:

    - deck displacement on the axis with both trains = alone(x) + alone(L - x) within
      8 % of the peak: what is left is the trains' interaction through the deck (the
      vehicles are not prescribed forces; measured 4.4 % at 250 km/h, 1.8 % at 330);
    - both trains in the run are mirror images of each other: train 2's wheel unloading
      and comfort equal train 1's within 1e-3 (relative; round-off of the mirrored run);
    - on smooth track the deck is all the trains feel, so the second train changes the
      first's wheel unloading by +5 .. +50 % (measured +31 %, +12 %) and its car-body
      acceleration by +10 .. +80 % (measured +41 %, +48 %), each change more than 20 x
      its numerical error (the change between dt = 1 ms and 0.5 ms of the train alone:
      measured 0.1 % of dQ/Q0 and 0.1 % of the acceleration, 100-500 x below the
      changes).
    """
    speeds = [250.0, 330.0]
    both = _viaduct(tmp_path, "both", speeds, 1e-3)
    alone = _viaduct(tmp_path, "alone", speeds, 1e-3, together=False)
    fine = _viaduct(tmp_path, "fine", speeds, 5e-4, together=False)
    n_w = alone.sizes["wheel"]
    assert both.sizes["wheel"] == 2 * n_w
    for s in range(len(speeds)):
        w_b = both["deck_displacement"].isel(speed=s).values
        w_a = alone["deck_displacement"].isel(speed=s).values
        n = min(w_b.shape[0], w_a.shape[0])
        ok = np.isfinite(w_b[:n]).all(axis=1) & np.isfinite(w_a[:n]).all(axis=1)
        ref = w_a[:n] + w_a[:n, ::-1]  # the points 12.5, 41, 69.5 m are symmetric
        err = np.max(np.abs(w_b[:n][ok] - ref[ok])) / np.max(np.abs(ref[ok]))
        assert err < 0.08, (speeds[s], err)
    dq_b = both["max_wheel_unloading"].values  # (speed, wheel)
    dq_a = alone["max_wheel_unloading"].values
    dq_f = fine["max_wheel_unloading"].values
    # the mirrored train: the same unloading (axle k of train 2 is axle k of train 1)
    np.testing.assert_allclose(np.nanmax(dq_b[:, n_w:], axis=1),
                               np.nanmax(dq_b[:, :n_w], axis=1), rtol=1e-3)
    first = np.nanmax(dq_b[:, :n_w], axis=1)
    own = np.nanmax(dq_a, axis=1)
    noise = np.abs(np.nanmax(dq_f, axis=1) - own)
    change = first - own
    assert np.all(np.abs(change) > 20.0 * noise), (change, noise)
    assert np.all((change > 0.05 * own) & (change < 0.50 * own)), change / own
    n_v = alone.sizes["vehicle"]
    acc = both["max_carbody_acceleration"].values
    np.testing.assert_allclose(np.nanmax(acc[:, n_v:], axis=1),
                               np.nanmax(acc[:, :n_v], axis=1), rtol=1e-3)
    acc_b = np.nanmax(acc[:, :n_v], axis=1)
    acc_a = np.nanmax(alone["max_carbody_acceleration"].values, axis=1)
    acc_f = np.nanmax(fine["max_carbody_acceleration"].values, axis=1)
    assert np.all(np.abs(acc_b - acc_a) > 20.0 * np.abs(acc_f - acc_a))
    assert np.all((acc_b > 1.10 * acc_a) & (acc_b < 1.80 * acc_a)), acc_b / acc_a
    # the report: every check with both trains, nothing NaN
    res = vsi("report", tmp_path / "both" / "out.nc", "-o", tmp_path / "report")
    assert res.returncode == 0, res.stdout + res.stderr
    md = (tmp_path / "report" / "report.md").read_text()
    for section in ("Peak deck acceleration", "Wheel unloading", "Car-body acceleration",
                    "tracks 1, 2 loaded", "Torsional moment |T| (every train",
                    "Deck twist and tracks", "Dynamic: every train of the run",
                    "every train of the run against LM71 on track 1 alone (on the safe side)",
                    "come from one run (interaction trains"):
        assert section.replace("|", "\\|") in md or section in md, section
    # one value per quantity: the twins that repeat the values are not shown again
    assert "every train of a run loaded (train.other_trains)" not in md
    assert "their runs superposed" not in md
    assert md.count("Torsional moment |T|".replace("|", "\\|")) == 2
    assert not re.search(r"\bnan\b", md, re.IGNORECASE)
    names = [str(v) for v in np.ravel(both["vehicle_name"].values)]
    assert sum(n.startswith("train 2: ") for n in names) == n_v  # both trains named
