"""The default damped track on rough track against a converged continuous damped rail
(docs/track_accuracy.md): an ICE3 end car through ``vsi run`` (config, CSV profile,
results file) against :func:`reference.vehicle_on_modal_rail` (the rail by its modes on
a Kelvin-Voigt foundation over the deck's modes; numpy/scipy only)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.interpolate
import xarray as xr
from reference import railway_car_matrices, railway_car_static_axle_loads, vehicle_on_modal_rail
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.model.irregularity import psd_realisation
from vsi_numba.model.track import TRACK_ACCURACY_NOTE, ElasticTrack

L_SPAN, M_DECK, F1, ZETA, N_MODES = 20.0, 15000.0, 5.0, 0.01, 3
EI_DECK = (2 * F1 * L_SPAN**2 / np.pi) ** 2 * M_DECK  # f1 = 5 Hz
HERTZ_G = 2.65e-8  # m N^-2/3
APPROACH, FREE = 6.0, 0.05
CAR = dict(body_mass=47800.0, body_pitch_inertia=1957888.0, bogie_mass=3500.0,
           bogie_pitch_inertia=1715.0, wheelset_mass=1800.0, bogie_spacing=17.375,
           wheelbase=2.5, primary_stiffness=2.4e6, primary_damping=20000.0,
           secondary_stiffness=7.0e5, secondary_damping=40000.0)  # trains.toml ave_s103_c1
OFFSETS = np.array([0.0, 2.5, 17.375, 19.875])


def _profile(seed):
    """German low 1-80 m, zero up to the first axle's start, ramped in over 4 m."""
    x, r, _ = psd_realisation("german_low", 1.0, 80.0, seed, -APPROACH - 30.0,
                              L_SPAN + 60.0, dx=0.05)
    return x, r * 0.5 * (1 - np.cos(np.pi * np.clip((x + APPROACH) / 4.0, 0.0, 1.0)))


def _vsi(tmp_path, monkeypatch, x, r, speed_kmh, rail_mass):
    monkeypatch.chdir(tmp_path)
    np.savetxt(tmp_path / "profile.csv", np.column_stack([x, r]), delimiter=",",
               header="x,r", comments="")
    car = "\n".join(f"{k} = {v!r}" for k, v in CAR.items())
    (tmp_path / "c.toml").write_text(f"""title = "ICE3 end car on a damped track"
[bridge]
kind = "simply_supported"
spans = [{L_SPAN}]
EI = {EI_DECK!r}
mass_per_length = {M_DECK}
n_modes = {N_MODES}
damping_ratio = {ZETA}
output_points = [{L_SPAN / 2}]
[[train.vehicles]]
kind = "car"
{car}
[track]
rail_mass = {rail_mass}
[contact]
model = "hertz_linear"
hertz_coefficient = {HERTZ_G}
[irregularity]
kind = "file"
path = "profile.csv"
[solver]
dt = 2.5e-4
approach = {APPROACH}
free_vibration = {FREE}
[study]
speeds_kmh = [{speed_kmh}]
output = "run.nc"
""")
    res = CliRunner().invoke(app, ["run", "c.toml", "-o", "run.nc", "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        return (float(ds["max_wheel_unloading"].values.max()),
                float(ds["max_deck_acceleration"].values.max()))


def _reference(x, r, speed_kmh, rail_mass):
    t = ElasticTrack(rail_mass=rail_mass)
    M, C, K, wd = railway_car_matrices(**CAR)
    g = 9.81 * np.diag(M).copy()
    g[[1, 3, 5]] = 0.0  # pitch DOFs
    q0 = railway_car_static_axle_loads(CAR["body_mass"], CAR["bogie_mass"],
                                       CAR["wheelset_mass"], CAR["bogie_spacing"])
    v = speed_kmh / 3.6
    res = vehicle_on_modal_rail(
        L_SPAN, EI_DECK, M_DECK, N_MODES, ZETA, t.foundation_stiffness,
        t.foundation_damping, t.rail_EI, rail_mass, M, C, K, g, wd, OFFSETS,
        1.5 * np.cbrt(q0.mean()) / HERTZ_G, scipy.interpolate.CubicSpline(x, r), v,
        -APPROACH, (L_SPAN + APPROACH + OFFSETS.max()) / v + FREE,
        points=(L_SPAN / 2,), wavelength_min=0.4, dt=2e-4)
    np.testing.assert_allclose(res.static_force, q0, rtol=1e-6)  # a static start
    return (float((1 - res.force.min(axis=0) / res.static_force).max()),
            float(np.abs(res.deck_acceleration[:, 0]).max()))


@pytest.mark.parametrize("seed, speed_kmh, rail_mass", [
    (2, 400.0, 0.0), (3, 400.0, 120.0), pytest.param(1, 250.0, 120.0, marks=pytest.mark.slow)])
def test_track_accuracy__ice3_car_on_rough_track_against_the_continuous_rail(
        tmp_path, monkeypatch, seed, speed_kmh, rail_mass):
    """Massless rail (the default), seed 2 at 400 km/h, the worst dQ/Q0 of the grid in
    docs/track_accuracy.md: measured dQ/Q0 -0.017 and the deck acceleration +0.8 % (the
    first-order element: -0.057, -3.5 %); bounds 0.035 and 3 % (2x the measured dQ error,
    and the accuracy aimed at; the first-order element fails both).  120 kg/m, seed 3 at
    400 km/h, the lowest deck acceleration of the grid, and seed 1 at 250 km/h, the
    highest: measured -1.6 % and +2.7 % with the rail's inertia in the deck load (-6.6 %
    and -2.3 % without it), dQ/Q0 -0.007 and -0.005; bounds +-3 % (the accuracy aimed at)
    and 0.035.  The reference at dt = 0.2 ms and 0.4 m
    rail wavelengths: 0.1 ms and 0.2 m move its dQ/Q0 by ~1e-3 and its acceleration by
    < 0.1 % (measured), well inside the bounds."""
    x, r = _profile(seed)
    dq_ref, acc_ref = _reference(x, r, speed_kmh, rail_mass)
    assert dq_ref > 0.2 and acc_ref > 2.0  # rough track: a real excitation
    dq, acc = _vsi(tmp_path, monkeypatch, x, r, speed_kmh, rail_mass)
    assert abs(dq - dq_ref) < 0.035
    if rail_mass == 0.0:
        assert abs(acc / acc_ref - 1) < 0.03
    else:
        assert abs(acc / acc_ref - 1) < 0.03
        assert "-1.6 .. +2.7 %" in TRACK_ACCURACY_NOTE
