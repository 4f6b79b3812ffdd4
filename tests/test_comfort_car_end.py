"""Comfort at the car-body ends (EN 1990 A2.4.4.3: the vertical acceleration inside the
coach): the car-end envelope ``max_carbody_acceleration_car_end`` against an independent
solve_ivp run of the car (``reference.railway_car_matrices`` and
``reference.vehicle_on_rigid_rail``, DOP853 at rtol 1e-10, the wheels following the
rigid rail over an isolated C2 dip), the car-end acceleration being
a_end = a_cg +/- e * pitch_acc at the body's ends, e = body_length / 2 from the bogie
midpoint (the centre of gravity; the reference's own pitch convention, front bogie
attachment at u - d theta)."""

from __future__ import annotations

import numpy as np
import pytest
import reference as ref
import xarray as xr

from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.profile import Profile
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

APPROACH = 5.0
V = 30.0
DT = 1e-3
CAR = dict(body_mass=40000.0, body_pitch_inertia=2.0e6, bogie_mass=3000.0,
           bogie_pitch_inertia=3000.0, wheelset_mass=0.0, bogie_spacing=17.5,
           wheelbase=2.5, primary_stiffness=1.6e6, primary_damping=2e4,
           secondary_stiffness=6e5, secondary_damping=4e4)
BODY_LENGTH = 26.0
DIP = ref.SmoothDip(0.015, 8.0, 3.0)


def _engine():
    prof = Profile.from_function(DIP, DIP.position - 1.0, DIP.position + DIP.wavelength + 1,
                                 DIP.wavelength / 400, "smooth dip")
    car = vh.railway_car(**CAR, body_length=BODY_LENGTH)
    ds = sm.simulate(br.rigid(40.0), vh.Train("t", (car,), (0.0,)), V, prof,
                     settings=SolverSettings(dt=DT, approach=APPROACH, free_vibration=0.2,
                                             hht_alpha=0.0))
    assert ds.attrs["status"] == 0, ds.attrs.get("message")
    return ds


def _reference(t):
    """Body bounce and pitch accelerations of the linear car (massless wheelsets)."""
    M, C, K, wd = ref.railway_car_matrices(**CAR)
    g = vh.GRAVITY * np.diag(M) * np.array([1, 0, 1, 0, 1, 0, 1, 1, 1, 1])
    a = 0.5 * CAR["wheelbase"]
    x_wheels = -APPROACH - np.array([0.0, 2 * a, CAR["bogie_spacing"],
                                     CAR["bogie_spacing"] + 2 * a])
    run = ref.vehicle_on_rigid_rail(M, C, K, g, wd, x_wheels, V, DIP, [], t)
    return run.a[:, 0], run.a[:, 1]


def test_comfort_car_end__envelope_matches_solve_ivp_bounce_plus_pitch():
    ds = _engine()
    t = ds.time.values
    a_cg, a_th = _reference(t)
    e = 0.5 * BODY_LENGTH
    front, rear = a_cg - e * a_th, a_cg + e * a_th  # reference: front at u - d theta
    ends = np.abs(np.stack([front, rear]))
    i_end, i_t = np.unravel_index(np.argmax(ends), ends.shape)
    a_ref = ends[i_end, i_t]
    # the ends matter: they are > 20 % above the centre's peak (measured 3.6 times it)
    assert a_ref > 1.2 * np.abs(a_cg).max()
    got = float(ds["max_carbody_acceleration_car_end"].values.reshape(-1)[0])
    # trapezoidal rule at dt = 1 ms: the car's accelerations within 1e-3 of their peak
    # (measured 3.8e-6 here; 2e-3 leaves room for the reference's and the platform's)
    assert got == pytest.approx(a_ref, rel=2e-3)
    # the time within two steps (the peak's neighbours differ by less than the error)
    t_got = float(ds["time_of_max_carbody_acceleration_car_end"].values.reshape(-1)[0])
    assert abs(t_got - t[i_t]) <= 2 * DT + 1e-12
    # the end: the front (positive, ahead of the centre) or the rear, as the reference's
    pos = float(ds["position_of_max_carbody_acceleration_car_end"].values.reshape(-1)[0])
    assert pos == pytest.approx(e if i_end == 0 else -e, abs=1e-12)
    # the ends lie beyond the pivots: the rigid body's acceleration is linear along it,
    # so the end envelope bounds the centre/pivot envelope, which stays reported apart
    body = float(ds["max_carbody_acceleration"].values.reshape(-1)[0])
    assert got >= body
    pivots = np.abs(np.stack([a_cg, a_cg - 0.5 * CAR["bogie_spacing"] * a_th,
                              a_cg + 0.5 * CAR["bogie_spacing"] * a_th])).max()
    assert body == pytest.approx(pivots, rel=2e-3)


def test_comfort_car_end__default_length_and_no_ends_give_nan():
    car = vh.railway_car(**CAR)
    (pts,) = car.end_points
    e = 0.5 * vh.BODY_LENGTH_PER_BOGIE_SPACING * CAR["bogie_spacing"]
    assert [d for _, d in pts] == pytest.approx([e, -e])
    # a library car: its ends from the data's overhangs about the bogie centres (ICE3
    # end car: 4.76 m ahead of the front, 3.7 m behind the rear bogie, CG midway)
    from vsi_numba.model.library import get_vehicle
    (lib,) = get_vehicle("ave_s103_c1").end_points
    half = 0.5 * 17.375
    assert [d for _, d in lib] == pytest.approx([half + 4.76, -(half + 3.7)], abs=1e-12)
    sm_car = vh.sprung_mass(5750.0, 1.595e6, 1e4)
    assert sm_car.body_end_points(0) == ()
    ds = sm.simulate(br.rigid(5.0), vh.Train("t", (sm_car,), (0.0,)), V, None,
                     settings=SolverSettings(dt=DT, approach=1.0, free_vibration=0.0))
    assert np.isnan(ds["max_carbody_acceleration_car_end"].values).all()


def test_comfort_car_end__check_and_report_state_it_apart_from_the_centre_value():
    """The comfort check's value stays the centre/pivot one; the car-end peak (largest
    over every case, found here by a brute-force numpy search) is reported apart."""
    from vsi_numba.analysis import checks as chk
    from vsi_numba.analysis.report import text
    from vsi_numba.analysis.synthetic import synthetic_results

    ds = synthetic_results()
    body = ds["max_carbody_acceleration"]
    rng = np.random.default_rng(3)
    ends = body * (1.5 + rng.random(body.shape))
    ds["max_carbody_acceleration_car_end"] = ends
    ds["position_of_max_carbody_acceleration_car_end"] = xr.full_like(ends, -13.0)
    base = chk.comfort(synthetic_results(), n_boot=50)
    cf = chk.comfort(ds, n_boot=50)
    assert cf.attrs["value"] == base.attrs["value"]  # the centre/pivot verdict unchanged
    arr = ends.transpose("speed", "train", "irregularity", "vehicle").values
    i = np.unravel_index(np.nanargmax(arr), arr.shape)
    assert cf.attrs["car_end_value"] == arr[i]
    assert cf.attrs["car_end_speed"] == float(ds.speed.values[i[0]])
    assert cf.attrs["car_end_train"] == str(ds.train.values[i[1]])
    assert cf.attrs["car_end_position"] == -13.0
    table = chk.summary_table({"comfort": cf})
    lines = " ".join(text._summary({"comfort": cf}, table, np.zeros(0)))
    assert "Comfort at the car-body ends" in lines and "rear end" in lines, lines
    assert f"{cf.attrs['car_end_speed'] * 3.6:.0f} km/h" in lines, lines
    assert "car_end_value" not in chk.comfort(synthetic_results(), n_boot=50).attrs
