"""The elastic track (rail on a Winkler foundation) that carries the wheels over the deck
ends: closed forms of the beam on elastic foundation, an independent solve_ivp reference
of a quarter car crossing the joint, and the config keys."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from reference import quarter_car_elastic_joint

from vsi_numba.config import ConfigError, load_config
from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.hermite import table as hermite_table
from vsi_numba.model.track import ElasticTrack
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.settings import SolverSettings
from vsi_numba.solver.simulate import simulate


def test_track__default_is_150_kN_per_mm_per_axle_with_uic60_rails():
    """Hetenyi: static deflection under a point load P on an infinite beam on a Winkler
    foundation is P beta / (2 k); the default foundation is chosen for 75 kN/mm per wheel
    (150 kN/mm per axle, both rails) with two UIC60 rails (EI = 2 x 210 GPa x 3055 cm^4)."""
    t = ElasticTrack()
    assert t.rail_EI == pytest.approx(2 * 210e9 * 3055e-8, rel=1e-12)
    beta = (t.foundation_stiffness / (4 * t.rail_EI)) ** 0.25
    assert 1.0 / t.green(0.0) == pytest.approx(2 * t.foundation_stiffness / beta, rel=1e-12)
    assert 1.0 / t.green(0.0) == pytest.approx(150e6, rel=1e-9)
    # the deflection line: zero crossing at beta x = 3 pi / 4, minimum (uplift) at pi / 2..pi
    assert t.green(0.75 * np.pi / beta) == pytest.approx(0.0, abs=1e-20)
    assert t.green(np.pi / beta) < 0.0
    C = t.compliance([0.0, -2.5, -20.0])
    np.testing.assert_allclose(C, C.T, rtol=0, atol=0)
    assert C[0, 2] == 0.0  # beyond the reach: not coupled
    assert np.all(np.linalg.eigvalsh(C) > 0)


def test_track__filtered_shapes_are_the_closed_form_inside_and_smooth_across_the_ends():
    """A sine u = sin(k x) under an infinite rail on the foundation gives
    w = u / (1 + EI k^4 / k_f) (closed form); near the deck ends the filtered shape
    carries the mode over the joint (non-zero on the approach within a few metres, zero
    beyond the reach)."""
    L, t = 25.0, ElasticTrack()
    bridge = br.simply_supported(L, 7.16e10, 18000.0, n_modes=3)
    nodes, vals, slopes = t.filtered_shapes(bridge)
    # 11 m or more from the ends, whose influence decays like exp(-beta d) = 3.8e-6
    x = np.array([11.0, 12.5, 14.0])
    kj = np.pi * np.arange(1, 4) / L
    expect = bridge.shapes(x) / (1 + t.rail_EI * kj**4 / t.foundation_stiffness)
    np.testing.assert_allclose(hermite_table(nodes, vals, slopes, x), expect, rtol=1e-5,
                               atol=1e-9 * np.abs(expect).max())
    # across the left end: the rail is pulled down on the approach, C1 at x = 0
    left = hermite_table(nodes, vals, slopes, [-0.3, 0.0, 0.3])[:, 0]
    assert left[0] > 0 and left[1] > 0 and left[2] > left[1]
    assert np.all(hermite_table(nodes, vals, slopes, [-t.reach - 0.01, L + t.reach + 0.01])
                  == 0.0)
    # the neglected rail-to-deck stiffness (rail bending + end restraint): < 0.2 %
    assert np.all(t.restraint_ratio(bridge) < 2e-3)


def test_track__wheel_crossing_the_deck_end_converges_to_the_solve_ivp_reference():
    """A quarter car at 120 m/s over a flexible 20 m span (f1 = 2.8 Hz) on the default
    elastic track, in rigid contact with the rail, against an independent reference
    (tests/reference.py: finite-difference rail, deck modes, solve_ivp DOP853 at
    rtol 1e-9).  The largest wheel unloading happens just past the exit end of the deck
    (the deck's end rotation carried over the joint by the rail).

    Tolerances: the whole contact-force history within 0.6 % of Q0 at dt = 1 ms and
    0.15 % at dt = 0.25 ms (measured 0.47 % and 0.064 %): the error must fall with dt
    (HHT-alpha, O(dt^2) for the forces) down to the floor set by the reference's
    finite-difference rail (h = 2.5 cm, O((h beta)^2) ~ 1e-3) and the rail-to-deck
    stiffness the engine neglects (0.1 % of the modal stiffness); dQ/Q0 within 2 % of
    the reference's at dt = 0.25 ms (measured 0.6 %), converging monotonically."""
    L, EI, m, n_modes = 20.0, 5e9, 1e4, 3
    track = ElasticTrack(foundation_damping=0.0)  # the reference's elastic foundation
    M, ks, cs, mw, v, approach = 8000.0, 1.0e6, 2.0e4, 1000.0, 120.0, 10.0
    t_end = (L + approach + 8.0) / v
    ref = quarter_car_elastic_joint(L, EI, m, n_modes, track.foundation_stiffness,
                                    track.rail_EI, M, ks, cs, mw, v, -approach, t_end)
    assert ref.force.min() > 0.5 * ref.static_force  # stays in contact: rigid contact ok
    ref_dq = 1.0 - ref.force.min() / ref.static_force
    assert 0.03 < ref_dq < 0.08  # a real deck-end effect, not numerical noise
    assert L < ref.x[np.argmin(ref.force)] < L + 1.0  # just past the exit joint

    bridge = dataclasses.replace(br.simply_supported(L, EI, m, n_modes=n_modes),
                                 track=track)
    train = Train("quarter car", (vh.sprung_mass(M, ks, cs, mw),), (0.0,))
    errors, dq = [], []
    for dt in (1e-3, 5e-4, 2.5e-4):
        ds = simulate(bridge, train, v, settings=SolverSettings(
            dt=dt, approach=approach, free_vibration=8.0 / v))
        assert int(ds.attrs["status"]) == 0
        X, t = ds["contact_force"].values[:, 0], ds["time"].values
        Q0 = float(ds["static_wheel_load"].values[0])
        assert Q0 == pytest.approx(ref.static_force, rel=1e-12)
        errors.append(np.abs(X - np.interp(t, ref.t, ref.force)).max() / Q0)
        dq.append(float(ds["max_wheel_unloading"].values[0]))
    assert errors[0] < 6e-3 and errors[2] < 1.5e-3 and errors[2] < errors[1] < errors[0]
    assert abs(dq[2] - ref_dq) < 0.02 * ref_dq
    assert abs(dq[2] - dq[1]) < abs(dq[1] - dq[0])  # converging with dt


def test_track__rigid_idealisation_loses_contact_at_the_same_joint():
    """The same case on the rigid-track idealisation (``track=None``): the end rotation is
    a kink that the wheel meets as an impact and leaves the rail (dQ/Q0 = 1 at every dt)
    where the reference above, with a rail over the joint, unloads it by ~5 % (that is
    why the elastic track is the default)."""
    L, EI, m = 20.0, 5e9, 1e4
    bridge = br.simply_supported(L, EI, m, n_modes=3)
    train = Train("quarter car", (vh.sprung_mass(8000.0, 1.0e6, 2.0e4, 1000.0),), (0.0,))
    for dt in (1e-3, 2.5e-4):
        s = SolverSettings(dt=dt, approach=10.0, free_vibration=8.0 / 120.0)
        rigid = simulate(bridge, train, 120.0, settings=s)
        elastic = simulate(dataclasses.replace(bridge, track=ElasticTrack()), train, 120.0,
                           settings=s)
        assert float(rigid["max_wheel_unloading"].values[0]) == 1.0
        assert float(rigid["contact_loss_duration"].values[0]) > 0.0
        assert L - 0.5 < float(rigid["position_of_min_contact_force"].values[0]) < L + 1.0
        assert float(elastic["max_wheel_unloading"].values[0]) < 0.06
        assert float(elastic["contact_loss_duration"].values[0]) == 0.0


def _cfg(**extra):
    data = {
        "title": "t",
        "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 5e9,
                   "mass_per_length": 1e4, "n_modes": 3},
        "train": {"vehicles": [{"kind": "sprung_mass", "mass": 8000.0,
                                "stiffness": 1e6, "wheel_mass": 1000.0}]},
        "study": {"speeds_kmh": [200.0], "output": "results/t.nc"},
    }
    data.update(extra)
    return data


def test_track__config_default_keys_and_errors():
    cfg = load_config(_cfg())
    assert cfg.track_model == "elastic"
    assert cfg.build_bridge().track == ElasticTrack()
    assert cfg.build_bridge() is cfg.build_bridge()  # built once (filtered shapes cached)
    soft = load_config(_cfg(track={"foundation_stiffness": 4e7, "rail_EI": 1.0e7}))
    assert soft.build_bridge().track == ElasticTrack(4e7, 1.0e7)
    rigid = load_config(_cfg(track={"model": "rigid"}))
    assert rigid.track_model == "rigid" and rigid.build_bridge().track is None
    with pytest.raises(ConfigError) as e:
        load_config(_cfg(track={"foundation_stiffness": -1.0}))
    assert "track.foundation_stiffness = -1.0: expected a foundation modulus > 0" in str(e.value)
    with pytest.raises(ConfigError) as e:
        load_config(_cfg(track={"model": "ballast"}))
    assert 'track.model = "ballast": expected one of' in str(e.value)
    with pytest.raises(ConfigError) as e:
        load_config(_cfg(track={"stiffness": 1e8}))
    assert "track.stiffness" in str(e.value)
    # the resolved config carries the track and loads again to the same model
    again = load_config(soft.resolved())
    assert again.build_bridge().track == ElasticTrack(4e7, 1.0e7)


def test_track__coarse_dt_for_the_wheel_on_the_track_spring_warns():
    """Wheel 1000 kg on 150 kN/mm: 61.6 Hz; dt = 2 ms gives dt f = 0.12 > 0.1."""
    f = np.sqrt(150e6 / 1000.0) / (2 * np.pi)
    recs = load_config(_cfg(solver={"dt": 2e-3})).warning_records
    hits = [r for r in recs if "wheel on the track springs" in r["message"]]
    assert len(hits) == 1 and hits[0]["kind"] == "resolution"
    assert f"{f:.4g} Hz" in hits[0]["message"]
    assert not [r for r in load_config(_cfg(solver={"dt": 1e-3})).warning_records
                if "wheel on the track" in r["message"]]


def test_track__report_states_the_track_model_and_the_deck_end_note_follows_it():
    """The report's Bridge section says how the wheels see the track; the note on minima
    at the deck ends blames the kink only for the rigid-track idealisation."""
    import json

    from vsi_numba.analysis import report
    from vsi_numba.analysis.synthetic import synthetic_results

    ds = synthetic_results(bridge_length=20.0)
    ds["position_of_min_contact_force"][:] = 20.2  # every minimum just past the exit end
    ds["max_wheel_unloading"][:] = 0.5
    ds["min_contact_force"][:] = 0.5 * ds["static_wheel_load"]
    config = json.loads(ds.attrs["config_json"])
    notes, lines = {}, {}
    for model in ("rigid", "elastic"):
        config["track"] = ({"model": "rigid"} if model == "rigid" else
                           {"model": "elastic", "foundation_stiffness": 8.51e7,
                            "rail_EI": 1.283e7})
        ds.attrs["config_json"] = json.dumps(config)
        notes[model] = " ".join(report._deck_end_note(ds))
        lines[model] = report._track_model(ds)
    assert "kink" in notes["rigid"] and "rigid approach track" in notes["rigid"]
    assert "not a kink" in notes["elastic"] and "foundation_stiffness" in notes["elastic"]
    assert "rigid-track idealisation" in lines["rigid"]
    assert "85.1 MN/m per metre" in lines["elastic"] and "kN/mm under one axle" in lines["elastic"]
    assert "damping and rail mass not recorded" in lines["elastic"]
    # the damped, massive track states its damping and rail mass with their units
    config["track"].update(foundation_damping=1.96e5, rail_mass=120.0)
    ds.attrs["config_json"] = json.dumps(config)
    line = report._track_model(ds)
    beta = (8.51e7 / (4 * 1.283e7)) ** 0.25
    assert "foundation damping 196 kN s/m per metre of track" in line, line
    assert f"({1.5 * 1.96e5 / beta / 1e3:.4g} kN s/m under one axle)" in line, line
    assert "rail mass 120 kg per metre of track" in line, line
    assert f"({1.5 * 120.0 / beta:.4g} kg under one axle)" in line, line


def test_track__implausible_stiffness_is_refused_naming_the_keys():
    """A foundation modulus given in MN/m^2 instead of N/m^2 (85 instead of 8.5e7) would
    put the rail metres under the axle: refused, naming the keys and the override."""
    with pytest.raises(ConfigError) as e:
        load_config(_cfg(track={"foundation_stiffness": 85.0}))
    msg = str(e.value)
    assert "track.foundation_stiffness, track.rail_EI" in msg and "mm under" in msg
    assert "solver.allow_implausible" in msg
    with pytest.raises(ConfigError) as e:
        load_config(_cfg(track={"foundation_stiffness": 1e12}))
    assert "stiffer than any railway track" in str(e.value)
    ok = load_config(_cfg(track={"foundation_stiffness": 85.0},
                          solver={"allow_implausible": True}))
    assert any("accepted: solver.allow_implausible" in w for w in ok.warnings)
