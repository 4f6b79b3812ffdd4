"""Independent numpy/scipy yardstick for the moving-force HSLM sweep.

Simply supported span, sine modes phi_j(x) = sqrt(2/(mL)) sin(j pi x/L),
omega_j = (j pi/L)^2 sqrt(EI/m), modal damping zeta.  Each mode is the average-acceleration
Newmark recursion written as a digital filter: q'' + 2 zeta w q' + w^2 q = f(t) discretised
with ``scipy.signal.bilinear`` (s = 2/dt (z-1)/(z+1), the trapezoidal rule) and run with
``scipy.signal.lfilter`` over the whole modal load history f_j(t_n) = sum_k P_k phi_j(x_k(t_n))
(zero off the span).  Newmark beta = 1/4, gamma = 1/2 is the trapezoidal rule on u, u' and
u'', and both start from rest with f(0) = 0 (the first axle starts on the approach track),
so the engine (HHT alpha = 0, decoupled modes, no contact constraints) and this code run the
same recursion: the envelopes agree to round-off, and ``check_agreement`` asks for 1e-9.

The train's axle positions and loads are the only input taken from the package
(``vsi_numba.model.library.get_train``); time grid, loads, modes, filters and envelopes are
computed here.  Deck acceleration keeps the modes up to max(30 Hz, 1.5 f1, f3) (EN 1990
A2.4.4.2.1), as ``vsi sweep`` reports it.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.signal import bilinear, lfilter

SPAN, EI, MASS, N_MODES, ZETA = 25.0, 8.323e9, 2303.0, 10, 0.01
DT, APPROACH = 1e-3, 5.0
TRAINS = tuple(f"HSLM-A{i}" for i in range(1, 11))
SPEEDS_KMH = tuple(140.0 + 5.0 * i for i in range(57))  # 140 .. 420 km/h


def axles(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(positions behind the first axle (m), loads (N)) of a library train's point loads."""
    from vsi_numba.model.library import get_train

    tr = get_train(name, model="moving_force")
    pos = np.concatenate([o + v.load_positions for v, o in zip(tr.vehicles, tr.offsets,
                                                               strict=True)])
    return pos, np.concatenate([v.loads for v in tr.vehicles])


def sweep(train_axles: dict, speeds_kmh, L=SPAN, ei=EI, m=MASS, n_modes=N_MODES, zeta=ZETA,
          dt=DT, approach=APPROACH, x_out=None):
    """Envelopes (max |displacement| m, max |acceleration| m/s2) at ``x_out`` (default
    mid-span), arrays of shape (n_trains, n_speeds) in the order of ``train_axles``."""
    x_out = 0.5 * L if x_out is None else x_out
    j = np.arange(1, n_modes + 1)
    w = (j * np.pi / L) ** 2 * math.sqrt(ei / m)
    f = w / (2 * np.pi)
    cut = max(30.0, 1.5 * f[0], f[2] if n_modes >= 3 else 0.0)  # EN 1990 A2.4.4.2.1
    scale = math.sqrt(2.0 / (m * L))
    phi_out = scale * np.sin(j * np.pi * x_out / L)
    filt = [(bilinear([1.0], [1.0, 2 * zeta * wj, wj * wj], fs=1 / dt),
             bilinear([1.0, 0.0, 0.0], [1.0, 2 * zeta * wj, wj * wj], fs=1 / dt))
            for wj in w]
    disp = np.empty((len(train_axles), len(speeds_kmh)))
    acc = np.empty_like(disp)
    for a, (pos, P) in enumerate(train_axles.values()):
        for b, v_kmh in enumerate(speeds_kmh):
            v = v_kmh / 3.6
            n = math.ceil((L + approach + pos.max()) / v / dt - 1e-9)  # last axle leaves
            x = (v * dt * np.arange(n + 1) - approach)[:, None] - pos[None, :]
            it, k = np.nonzero((x > 0.0) & (x < L))  # (step, axle) pairs on the span
            th = (np.pi / L) * x[it, k]
            s_prev, s, c2 = np.zeros_like(th), np.sin(th), 2.0 * np.cos(th)
            pk = scale * P[k]
            u = np.zeros(n + 1)
            ud = np.zeros(n + 1)
            for jj in range(n_modes):  # sin((j+1)t) = 2 cos t sin(jt) - sin((j-1)t)
                fj = np.bincount(it, weights=pk * s, minlength=n + 1)
                (bd, ad), (ba, aa) = filt[jj]
                u += phi_out[jj] * lfilter(bd, ad, fj)
                if f[jj] <= cut + 1e-9:
                    ud += phi_out[jj] * lfilter(ba, aa, fj)
                s_prev, s = s, c2 * s - s_prev
            disp[a, b], acc[a, b] = np.abs(u).max(), np.abs(ud).max()
    return disp, acc


def timed_sweep(trains=TRAINS, speeds_kmh=SPEEDS_KMH, repeat: int = 3):
    """Median wall and CPU time (s) of ``sweep`` (axle tables read before the clock starts,
    imports excluded, one untimed call first) and its envelopes."""
    tab = {name: axles(name) for name in trains}
    sweep(tab, speeds_kmh[:1])  # first-call effects (allocator, scipy dispatch)
    walls, cpus = [], []
    for _ in range(max(repeat, 1)):
        c0, w0 = time.process_time(), time.perf_counter()
        out = sweep(tab, speeds_kmh)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return float(np.median(walls)), float(np.median(cpus)), out


def engine_envelopes(trains, speeds_kmh, n_modes=N_MODES):
    """The same grid through ``vsi_numba.solver.simulate.simulate`` (HHT alpha = 0)."""
    from vsi_numba.model.bridge import simply_supported
    from vsi_numba.model.library import get_train
    from vsi_numba.solver.settings import SolverSettings
    from vsi_numba.solver.simulate import simulate

    bridge = simply_supported(SPAN, EI, MASS, n_modes=n_modes, damping_ratio=ZETA)
    st = SolverSettings(dt=DT, hht_alpha=0.0, approach=APPROACH, free_vibration=0.0)
    disp = np.empty((len(trains), len(speeds_kmh)))
    acc = np.empty_like(disp)
    for a, name in enumerate(trains):
        tr = get_train(name, model="moving_force")
        for b, v in enumerate(speeds_kmh):
            ds = simulate(bridge, tr, v / 3.6, settings=st, output_points=[SPAN / 2],
                          save_histories=False)
            disp[a, b] = float(ds["max_deck_displacement"].values[0])
            acc[a, b] = float(ds["max_deck_acceleration"].values[0])
    return disp, acc


def check_agreement(trains=("HSLM-A1", "HSLM-A10"), speeds_kmh=(140.0, 300.0, 420.0)):
    """Max relative difference (yardstick vs engine) of the two envelopes over the grid:
    {"displacement": d, "acceleration": a}.  Expected <= 1e-9 (round-off only)."""
    yd, ya = sweep({n: axles(n) for n in trains}, speeds_kmh)
    ed, ea = engine_envelopes(trains, speeds_kmh)
    return {"displacement": float(np.max(np.abs(yd - ed) / np.abs(ed))),
            "acceleration": float(np.max(np.abs(ya - ea) / np.abs(ea)))}
