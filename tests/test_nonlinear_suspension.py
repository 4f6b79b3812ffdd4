"""Nonlinear suspension elements (bump stops, damper blow-off): Newton on the element
branches with the tangent stiffness in the HHT-alpha step, against ``solve_ivp``.

Reference: ``reference.vehicle_on_rigid_rail`` (the vehicle's free DOFs with the wheels
following the rigid rail, DOP853 at rtol 1e-10, the element laws written out in
``reference.bump_stop_force`` / ``reference.blowoff_damper_force``).  The cases are on
the rigid track (``bridge.rigid``), over an isolated C2 defect (``reference.SmoothDip``,
sampled finely for the engine: its spline adds no error at the scale of the checks),
with massless wheels (the classical moving sprung mass; the trapezoidal rule,
alpha = 0, is then free of the spurious contact-force oscillation of a massive wheel on
a rigid rail), the contact never lost (checked on the reference's wheel forces and the
engine's flags).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import reference as ref

from vsi_numba.config import ConfigError, load_config
from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.profile import Profile
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

APPROACH = 5.0
V = 30.0
DTS = (1e-3, 5e-4, 2.5e-4)  # sprung mass (bump stop closed: ~10 Hz)
DTS_CAR = (4e-3, 2e-3, 1e-3)  # car (body and bogies below ~8 Hz)

# sprung mass over a 12 mm bump (6 m long): the spring compresses up to ~10 mm more than
# its static 35 mm, the stop closes after 5 mm
SM = dict(mass=5750.0, stiffness=1.595e6, damping=1e4, wheel_mass=0.0)
SM_STOP = vh.BumpStop(gap=0.005, stiffness=2e7)
SM_BUMP = dict(depth=-0.012, wavelength=6.0, position=3.0)

# car over a 15 mm dip (8 m long): the secondary dampers blow off at 1.5 kN
CAR = dict(body_mass=40000.0, body_pitch_inertia=2.0e6, bogie_mass=3000.0,
           bogie_pitch_inertia=3000.0, wheelset_mass=0.0, bogie_spacing=17.5,
           wheelbase=2.5, primary_stiffness=1.6e6, primary_damping=2e4,
           secondary_stiffness=6e5, secondary_damping=4e4)
CAR_BLOWOFF = vh.DamperBlowoff(force=1.5e3, post_damping=5e3)
CAR_DIP = dict(depth=0.015, wavelength=8.0, position=3.0)


def _dip(defect):
    return ref.SmoothDip(defect["depth"], defect["wavelength"], defect["position"])


def _engine(vehicle, defect, dt, length, alpha=0.0):
    dip = _dip(defect)
    a, b = defect["position"] - 1.0, defect["position"] + defect["wavelength"] + 1.0
    prof = Profile.from_function(dip, a, b, defect["wavelength"] / 400, "smooth dip")
    # alpha = 0: HHT-alpha's accelerations and forces are those of t_{n+1+alpha}, first
    # order in dt for alpha < 0; the trapezoidal rule (alpha = 0) is second order in all
    ds = sm.simulate(br.rigid(length), vh.Train("t", (vehicle,), (0.0,)), V, prof,
                     settings=SolverSettings(dt=dt, approach=APPROACH, free_vibration=0.2,
                                             hht_alpha=alpha))
    assert ds.attrs["status"] == 0, ds.attrs.get("message")
    assert np.all(ds.in_contact.values == 1)
    return ds


def _reference(vehicle, defect, forces, t):
    """The reference run of ``vehicle`` (its matrices are the plain spring-dashpot ones,
    rebuilt here only through the model's builder for the wheel positions)."""
    return ref.vehicle_on_rigid_rail(
        vehicle.M, vehicle.C, vehicle.K, vehicle.gravity, vehicle.wheel_dofs,
        -APPROACH - vehicle.wheel_positions, V, _dip(defect), forces, t)


def _sprung_mass(stop=SM_STOP):
    return vh.sprung_mass(**SM, bump_stop=stop)


def _sm_reference(t, with_stop=True):
    lin = _sprung_mass(None)
    row = np.array([1.0, -1.0])
    d_on = SM["mass"] * vh.GRAVITY / SM["stiffness"] + SM_STOP.gap  # static + gap
    forces = [(row, lambda d, dd: ref.bump_stop_force(d, d_on, SM_STOP.stiffness))]
    return _reference(lin, SM_BUMP, forces if with_stop else [], t), d_on


def _car(blowoff=CAR_BLOWOFF, **kw):
    return vh.railway_car(**CAR, secondary_damper_blowoff=blowoff, **kw)


def _car_reference(t, with_blowoff=True):
    """Reference car: reference.railway_car_matrices without the secondary dampers,
    which act through their own law on the rows body-over-bogie-centre."""
    c = dict(CAR)
    cs = c.pop("secondary_damping")
    M, C, K, wd = ref.railway_car_matrices(**c, secondary_damping=0.0)
    g = vh.GRAVITY * np.diag(M) * np.array([1, 0, 1, 0, 1, 0, 1, 1, 1, 1])
    d = 0.5 * CAR["bogie_spacing"]
    rows = [np.eye(10)[0] - d * np.eye(10)[1] - np.eye(10)[2],
            np.eye(10)[0] + d * np.eye(10)[1] - np.eye(10)[4]]

    def law(d, rate):
        if with_blowoff:
            return ref.blowoff_damper_force(rate, cs, CAR_BLOWOFF.force,
                                            CAR_BLOWOFF.post_damping)
        return cs * rate
    a = 0.5 * CAR["wheelbase"]
    x_wheels = -APPROACH - np.array([0.0, 2 * a, CAR["bogie_spacing"],
                                     CAR["bogie_spacing"] + 2 * a])
    return ref.vehicle_on_rigid_rail(M, C, K, g, wd, x_wheels, V, _dip(CAR_DIP),
                                     [(r, law) for r in rows], t)


def _errors(ds, run):
    """Largest error of the body acceleration and of the wheel forces over the run,
    each relative to the largest dynamic part of the reference's."""
    a = ds.carbody_acceleration.isel(vehicle=0).values
    x = ds.contact_force.values
    ea = np.max(np.abs(a - run.a[:, 0])) / np.max(np.abs(run.a[:, 0]))
    dyn = run.wheel_force - run.wheel_force[0]
    ex = np.max(np.abs(x - run.wheel_force)) / np.max(np.abs(dyn))
    return ea, ex


def _order(errs, dts):
    """Slope of the log-log fit of the errors against dt."""
    return np.polyfit(np.log(dts), np.log(errs), 1)[0]


def test_nonlinear__sprung_mass_bump_stop_matches_solve_ivp():
    runs = [_engine(_sprung_mass(), SM_BUMP, dt, 15.0) for dt in DTS]
    t = _all_times(runs)
    run, d_on = _sm_reference(t)
    # the case: the stop closes by more than its gap's worth, the wheel stays loaded
    assert run.element[:, 0].max() > d_on + 0.003
    assert run.wheel_force.min() > 0.2 * run.wheel_force[0, 0]
    # ... and matters: the linear run's body acceleration differs by > 20 %
    lin, _ = _sm_reference(t, with_stop=False)
    assert np.max(np.abs(lin.a[:, 0] - run.a[:, 0])) > 0.2 * np.max(np.abs(run.a[:, 0]))
    errs = []
    for ds in runs:
        sub = _reference_on(run, ds.time.values)
        errs.append(_errors(ds, sub))
    ea, ex = np.array(errs).T
    # the trapezoidal rule is second order; the branch changes inside a step (a kink of
    # a continuous force, met by Newton at the step's end) keep it so: fitted order
    # > 1.8 over dt, dt/2, dt/4 (measured 1.87: 1.76 then 1.98)
    assert _order(ea, DTS) > 1.8, ea
    assert _order(ex, DTS) > 1.8, ex
    # at dt = 0.25 ms below 1e-3 of the response (measured 1.3e-4); the stop on a wrong
    # branch for a single step would cost ~ k_s * 1 mm = 20 kN, > 10 % of it
    assert ea[-1] < 1e-3 and ex[-1] < 1e-3, (ea, ex)


def _all_times(runs):
    """Every output time of the runs (the grids of dt, dt/2, dt/4 nest)."""
    return np.unique(np.round(np.concatenate([ds.time.values for ds in runs]), 12))


def _reference_on(run, t):
    """``run`` (computed at :func:`_all_times`) at the grid ``t`` of one run."""
    idx = np.searchsorted(run.t, np.round(t, 12))
    assert np.allclose(run.t[idx], t, rtol=0, atol=1e-12)
    return ref.RigidRailRun(run.t[idx], run.u[idx], run.a[idx], run.wheel_force[idx],
                            run.element[idx], run.element_rate[idx])


def test_nonlinear__car_secondary_damper_blowoff_matches_solve_ivp():
    runs = [_engine(_car(), CAR_DIP, dt, 40.0) for dt in DTS_CAR]
    t = _all_times(runs)
    run = _car_reference(t)
    # the case: the valves open (rate beyond 2x the blow-off rate) on both bogies
    v_b = CAR_BLOWOFF.force / CAR["secondary_damping"]
    assert np.all(np.abs(run.element_rate).max(axis=0) > 2 * v_b)
    lin = _car_reference(t, with_blowoff=False)
    assert np.max(np.abs(lin.a[:, 0] - run.a[:, 0])) > 0.2 * np.max(np.abs(run.a[:, 0]))
    errs = [_errors(ds, _reference_on(run, ds.time.values)) for ds in runs]
    ea, ex = np.array(errs).T
    assert _order(ea, DTS_CAR) > 1.8, ea  # as for the bump stop (measured 2.08)
    assert _order(ex, DTS_CAR) > 1.8, ex  # (measured 2.00)
    # at dt = 1 ms below 1e-3 of the dynamic response (measured 1.0e-4 and 3.3e-4)
    assert ea[-1] < 1e-3 and ex[-1] < 1e-3, (ea, ex)


def test_nonlinear__inactive_elements_give_the_linear_run_bit_for_bit():
    """Elements that never leave their linear branch (a gap and a blow-off force out of
    reach) change nothing: the Newton step is the linear step."""
    far = dict(primary_bump_stop=vh.BumpStop(1.0, 1e7),
               secondary_bump_stop=vh.BumpStop(1.0, 1e7))
    a = _engine(_car(vh.DamperBlowoff(1e9), **far), CAR_DIP, 1e-3, 40.0)
    b = _engine(_car(None), CAR_DIP, 1e-3, 40.0)
    for k in ("carbody_acceleration", "contact_force"):
        np.testing.assert_array_equal(a[k].values, b[k].values)


# ------------------------------------------------------------------------------ config

BASE = {
    "title": "t",
    "bridge": {"kind": "rigid", "spans": [20.0]},
    "train": {"vehicles": [{"kind": "sprung_mass", "mass": 5750.0, "stiffness": 1.595e6,
                            "damping": 1e4}]},
    "solver": {"dt": 1e-3},
    "study": {"speeds_kmh": [100.0], "output": "results/t.nc"},
}


def _cfg(**keys):
    data = copy.deepcopy(BASE)
    data["train"]["vehicles"][0].update(keys)
    return data


def _error(data):
    with pytest.raises(ConfigError) as info:
        load_config(data)
    return str(info.value)


def test_nonlinear__config_builds_the_elements():
    cfg = load_config(_cfg(bump_stop={"gap": 0.04, "stiffness": 5e6},
                           damper_blowoff={"force": 3e3}))
    (veh,) = cfg.trains()[0].vehicles
    kinds = [e.kind for e in veh.nonlinear]
    assert kinds == ["bump_stop", "damper_blowoff"]
    # the stop closes at the static compression m g / k plus the gap
    assert veh.nonlinear[0].params[0] == pytest.approx(5750.0 * 9.81 / 1.595e6 + 0.04)
    assert veh.nonlinear[1].params == (1e4, 3e3, 0.0)


@pytest.mark.parametrize(("keys", "where", "what"), [
    (dict(bump_stop={"gap": -0.01, "stiffness": 5e6}), "train.vehicles[0].bump_stop.gap",
     "a clearance > 0 m"),
    (dict(bump_stop={"gap": 0.01}), "train.vehicles[0].bump_stop.stiffness", "stiffness"),
    (dict(bump_stop=0.04), "train.vehicles[0].bump_stop", "a table (gap = ..."),
    (dict(bump_stop={"gap": 0.01, "stifness": 5e6}), "train.vehicles[0].bump_stop.stifness",
     "did you mean 'stiffness'"),
    (dict(damper_blowoff={"force": 3e3, "post_damping": 2e4}),
     "train.vehicles[0].damper_blowoff.post_damping", "must be > post_damping"),
    (dict(damping=0.0, damper_blowoff={"force": 3e3}), "train.vehicles[0].damper_blowoff",
     "train.vehicles[0].damping = 0.0 N s/m must be > post_damping"),
    (dict(secondary_bump_stop={"gap": 0.01, "stiffness": 5e6}),
     "train.vehicles[0].secondary_bump_stop", "kind = 'car'"),
])
def test_nonlinear__config_errors_name_key_value_and_expectation(keys, where, what):
    msg = _error(_cfg(**keys))
    assert where in msg and what in msg, msg
