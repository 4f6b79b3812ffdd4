"""Unilateral impacts: the velocity projection at a landing or at a deck end is an LCP
(impulses only push), so results do not depend on where events fall on the time grid.

References are independent of the engine: ``reference.quarter_car_flexible_event_driven``
(event-driven, plastic impacts, unilateral deck-end crossings, numpy/scipy only).
"""

from __future__ import annotations

import numpy as np
import pytest
import reference as ref

from vsi_numba import kernels as ek
from vsi_numba.kernels.probe import hht_step
from vsi_numba.model import bridge as br
from vsi_numba.model import vehicle as vh
from vsi_numba.model.irregularity import no_irregularity
from vsi_numba.solver import batch as sb
from vsi_numba.solver import driver
from vsi_numba.solver import simulate as sm
from vsi_numba.solver.settings import SolverSettings

# 25 m deck (f1 = 4.8 Hz); a quarter car between two 200 kN moving forces: the leading
# force deflects the deck when the car enters (the rail at x = 0 falls away from the
# wheel), the trailing one when it leaves (the rail at x = L rises under it)
BEAM = dict(L=25.0, EI=8.323e9, m=2303.0)
QC = dict(body_mass=2000.0, stiffness=3e6, damping=1e4, wheel_mass=500.0)
N_MODES, ZETA = 4, 0.01
V, DT = 25.0, 1e-4  # v dt = 2.5 mm: approach 5 m and the span are on the grid
D_CAR, D_TRAIL, P_FORCE = 20.0, 5.0, 2e5


def _train():
    car = vh.sprung_mass(QC["body_mass"], QC["stiffness"], QC["damping"],
                         wheel_mass=QC["wheel_mass"])
    return vh.Train("force-car-force", (vh.moving_force(P_FORCE), car,
                                        vh.moving_force(P_FORCE)),
                    (0.0, D_CAR, D_CAR + D_TRAIL))


def _beam():
    return br.simply_supported(BEAM["L"], BEAM["EI"], BEAM["m"], n_modes=N_MODES,
                               damping_ratio=ZETA)


def _losses(approach, dt=DT):
    """(detachment x, reattachment x) of the car's wheel from the engine's flags."""
    ds = sm.simulate(_beam(), _train(), V, settings=SolverSettings(
        dt=dt, approach=approach, free_vibration=0.05))
    assert ds.attrs["status"] == 0, ds.attrs.get("message")
    t = ds.time.values
    x = -approach - D_CAR + V * t
    f = ds.in_contact.isel(wheel=0).values.astype(int)
    starts = np.flatnonzero(np.diff(f) == -1) + 1
    ends = np.flatnonzero(np.diff(f) == 1) + 1
    out = [(x[s], x[ends[ends > s][0]]) for s in starts]
    return out, ds


@pytest.fixture(scope="module")
def event_driven():
    approach = 5.0
    t_end = (BEAM["L"] + approach + D_CAR) / V + 0.05
    sol = ref.quarter_car_flexible_event_driven(
        **QC, **BEAM, speed=V, n_modes=N_MODES, t_end=t_end, x_start=-approach - D_CAR,
        force_x_start=[-approach, -approach - D_CAR - D_TRAIL], force_p=[P_FORCE] * 2,
        zeta=ZETA)
    x0 = -approach - D_CAR
    return [(x0 + V * a, x0 + V * b) for a, b in sol.losses()]


def test_impact__two_losses_match_event_driven_reference(event_driven):
    # self-check of the case: the wheel leaves the rail at the entry and at the exit
    assert len(event_driven) == 2
    assert event_driven[0][0] == pytest.approx(0.0, abs=1e-9)
    assert event_driven[1][0] == pytest.approx(BEAM["L"], abs=1e-9)
    assert all(b - a > 5 * V * DT for a, b in event_driven)  # each > 5 steps long
    for approach in (5.0, 5.0 + 0.37 * V * DT):
        eng, _ = _losses(approach)
        assert len(eng) == 2, eng
        for (xa, xb), (ra, rb) in zip(eng, event_driven, strict=True):
            # the engine flags the first sample at or after the detachment (<= 1 step of
            # travel late) and reattaches at the first sample after the landing; the
            # landing itself is O(dt) accurate: 2 steps of travel
            assert ra - 1e-9 <= xa <= ra + V * DT + 1e-9
            assert abs(xb - rb) <= 2 * V * DT, (xb, rb)


def test_impact__entering_on_and_off_the_grid_gives_the_same_loss():
    """The issue's case: an axle reaching x = 0 exactly on a time step has gap 0; the
    rail falls away, so it must leave the rail as it does 0.37 steps later."""
    on, _ = _losses(5.0)
    off, _ = _losses(5.0 + 0.37 * V * DT)
    assert len(on) == len(off) == 2
    for (a1, b1), (a2, b2) in zip(on, off, strict=True):
        # same events; the durations differ by the sampling of the flags (1 step) plus
        # the O(dt) landing (1 step)
        assert abs((b1 - a1) - (b2 - a2)) <= 2 * V * DT


def _step_all(packed, max_sub=4):
    """The engine's time loop in Python (deck-end crossings in 2^max_sub substeps, as
    ``time_loop``), yielding the workspace after each (sub)step."""
    prm = packed.params
    st = sm.initial_state(packed, no_irregularity())
    wk = sb._workspace(packed.bridge.omega.size, packed.n_dof, packed.vehicles.wheel_dof.size)
    driver.reset_work(wk)
    # the on-bridge flags at t = 0 and the steps that take a wheel across an end of the
    # deck, with the comparisons of contact_search and crosses_deck_end (numpy: only
    # hht_step runs from here, compiled for the types a study gives it)
    x0 = packed.vehicles.wheel_x0
    length = packed.bridge.length
    wk.onb[:] = (x0 >= 0.0) & (x0 <= length)
    for n in range(prm.n_steps):
        xa = x0 + prm.speed * (n * prm.dt)
        xb = x0 + prm.speed * ((n + 1) * prm.dt)
        cross = bool((((xa < 0.0) & (0.0 <= xb)) | ((xa <= length) & (length < xb))).any())
        sub = 2**max_sub if cross else 1
        for k in range(sub):
            wk.was_active[:] = wk.active
            h = prm.dt / sub
            status, _ = hht_step(packed.bridge, packed.vehicles, packed.profile, prm, st,
                                    wk, n * prm.dt + (k + 1) * h, h, max_sub if cross else 0)
            assert status == ek.OK
            yield n, wk


def test_impact__deck_end_impulse_never_pulls():
    """Drive the kernel step by step and read the impact impulse diagnostic: at the entry
    (rail falling away) the impulse is zero and the wheel is released, never the tensile
    impulse that a bilateral projection applies."""
    for approach in (5.0, 5.0 + 0.37 * V * DT):
        settings = SolverSettings(dt=DT, approach=approach, free_vibration=0.0)
        packed = sm.pack(_beam(), _train(), V, no_irregularity(), settings)
        packed = sm.Packed(**{**packed.__dict__, "run_length": D_CAR + 1.0})  # entry only
        released = False
        for _, wk in _step_all(packed):
            crossing = (wk.was_active[0] == 1) and (wk.onb[0] != wk.onb_prev[0])
            if crossing:
                # compressive only (tol: round-off of ~1e2 N s impulses)
                assert wk.impulse[0] >= -1e-9
                released |= wk.active[0] == 0
        assert released


ICE3_SPAN = dict(length=25.0, EI=7.16e10, mass_per_length=18000.0, n_modes=3,
                 damping_ratio=0.01)


@pytest.mark.parametrize("speed_kmh", [300.0, 225.0])
def test_impact__ice3_contact_loss_does_not_depend_on_the_time_grid(speed_kmh):
    """ICE3 on the rigid track (the kink at the deck ends), rigid contact, dt = 0.1 ms, the
    first axle on the time grid and 0.36 and 0.9 of a step off it.

    The deck-end kink is an impact; after it some wheels fly for a step or two.  Such a
    flight is at the limit of the time resolution: whether it shows depends on where
    the end falls between two steps (at 225 km/h, 26 to 31 axles lose contact over six
    alignments, every difference a flight of 1-2 steps; at dt = 0.05 ms the same
    picture at half the duration).  The bound: every loss longer than 2 dt is found at
    every alignment; every axle's loss time (0 if none) is the same within 2 dt."""
    from vsi_numba.model.library import get_train

    dt = 1e-4
    beam = br.simply_supported(**ICE3_SPAN)
    v = speed_kmh / 3.6
    rows, unloading = [], []
    for frac in (0.0, 0.36, 0.9):
        ds = sm.simulate(beam, get_train("ICE3"), v, save_histories=False,
                         settings=SolverSettings(dt=dt, approach=5.0 + frac * v * dt,
                                                 free_vibration=0.0))
        assert ds.attrs["status"] == 0
        rows.append(ds.contact_loss_duration.values.ravel())
        unloading.append(float(np.nanmax(ds.max_wheel_unloading)))
    d = np.array(rows)
    eps = 1e-9
    assert (d > 2 * dt + eps).any()
    # every axle's loss of contact (0: none) is the same at every alignment within 2 dt:
    # a landing or a lift-off moves by a step, a flight of 1-2 steps comes and goes
    spread = d.max(0) - d.min(0)
    assert spread.max() <= 2 * dt + eps, spread
    # so every loss longer than 2 dt is found at every alignment
    assert ((d > 2 * dt + eps).any(0) <= (d > 0).all(0)).all()
    assert max(unloading) - min(unloading) <= 1e-6  # a flight is a full unloading
