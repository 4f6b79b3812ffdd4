"""A record's train speed when ``calibration.records[i].speed_kmh`` is not given: the
speed at which the model's history fits the record best, in shape.

The method (a matched filter over the speed, with the model of the priors' medians)
    The train's axles are known (the record's ``train``), so the model predicts the
    record's history at any speed; its pattern in time - the axle groups passing the
    point, the passage's length - scales with ``1 / v`` whatever the deck's stiffness or
    damping, which change the amplitudes and the free vibration.  So the fit measure is
    the normalised cross-correlation ``rho(v) = max_L <m, s_v(. + L)> / (|m| |s_v|)``
    of the low-passed record ``m`` with the model's history ``s_v`` at speed ``v``,
    aligned as the likelihood aligns (:func:`vsi_numba.existing.signal.best_shift`):
    an amplitude that the parameters still have to find does not move the maximum.

    1. ``rho`` on a geometric grid of speeds from :data:`SPEED_RANGE_KMH`, ratio
       :data:`COARSE_RATIO` (all the speeds of one kernel call);
    2. a grid 100 times finer around the best (:data:`FINE_POINTS` speeds within one
       coarse step each side), and a parabola through the maximum and its neighbours.

    The model runs the configuration with the calibration's parameters at their priors'
    medians.  On the shipped synthetic records (truth EI 10 % above the prior median,
    0.3 m s-2 noise) it finds the speeds to within 0.1 % (tests/test_existing_speed.py).
"""

from __future__ import annotations

import numpy as np

from vsi_numba.existing.forward import ForwardError

#: The speeds searched (km/h).
SPEED_RANGE_KMH = (40.0, 420.0)
#: Ratio of two neighbouring speeds of the coarse grid.
COARSE_RATIO = 1.03
#: Speeds of the fine grid (within one coarse step either side of the coarse best).
FINE_POINTS = 41


class SpeedError(ForwardError):
    """A speed that cannot be found from a record."""


def record_speeds(cfg) -> tuple[list[float], list[str]]:
    """Per record of ``[calibration]``: its speed (km/h), given or found; and a note per
    speed found (``records[i]: speed 280.1 km/h from the record ...``)."""
    c = cfg.resolved()["calibration"]
    speeds, notes = [], []
    for i, r in enumerate(c["records"]):
        if r.get("speed_kmh") is not None:
            speeds.append(float(r["speed_kmh"]))
            continue
        v, rho = estimate_speed(cfg, r)
        speeds.append(v)
        notes.append(f"calibration.records[{i}]: speed {v:.5g} km/h from the record (the "
                     f"model's history fits it best in shape at that speed: correlation "
                     f"{rho:.3f})")
    return speeds, notes


def _rho(cfg, rec, m, t0, dt, speeds_kmh):
    """Normalised correlation of the record with the model at each speed."""
    from vsi_numba.existing.forward import Forward, Group, central_row
    from vsi_numba.existing.signal import best_shift, lowpass

    c = cfg.resolved()["calibration"]
    keys = [p["key"] for p in c["parameters"]]
    g = Group(rec["train"], tuple(float(v) for v in speeds_kmh), (float(rec["point"]),),
              rec.get("track"))
    fwd = Forward(cfg.resolved(), cfg.base_dir, keys, [g])
    res = fwd.run_row(central_row(c))[0]
    if res.error:
        raise SpeedError(f"the model at the priors' medians cannot be run: {res.error}")
    hist = res.acceleration if rec["quantity"] == "deck_acceleration" else res.displacement
    lag0 = int(round(t0 / dt))
    max_lag = int(round(float(c["max_lag_s"]) / dt))
    mm = float(m @ m)
    out = np.empty(len(speeds_kmh))
    for j, h in enumerate(hist):
        s = lowpass(h[:, 0], 1.0 / dt, res.cutoff)
        ss = float(s @ s)
        # the least-squares alignment with a free amplitude: the best correlation
        lag, sse = best_shift(m, s, lag0, max_lag)
        lag_i = int(round(lag))
        idx = np.arange(m.size) + lag_i
        inside = (idx >= 0) & (idx < s.size)
        cross = float(m[inside] @ s[idx[inside]])
        out[j] = cross / np.sqrt(max(mm * ss, 1e-300))
    return out


def estimate_speed(cfg, rec) -> tuple[float, float]:
    """The speed (km/h) of one record and the normalised correlation there."""
    from vsi_numba.existing.forward import record_path
    from vsi_numba.existing.signal import lowpass, resample
    from vsi_numba.io.records import read_record

    dt = float(cfg.solver_settings().dt)
    raw = read_record(record_path(rec["file"], cfg.base_dir))
    cutoff = _cutoff(cfg)
    t, m = resample(raw.t, lowpass(raw.value, 1.0 / raw.dt, cutoff), dt)
    lo, hi = SPEED_RANGE_KMH
    coarse = lo * COARSE_RATIO ** np.arange(int(np.log(hi / lo) / np.log(COARSE_RATIO)) + 1)
    rho = _rho(cfg, rec, m, t[0], dt, coarse)
    k = int(np.argmax(rho))
    a, b = coarse[max(k - 1, 0)], coarse[min(k + 1, coarse.size - 1)]
    fine = np.linspace(a, b, FINE_POINTS)
    rf = _rho(cfg, rec, m, t[0], dt, fine)
    i = int(np.argmax(rf))
    v = float(fine[i])
    if 0 < i < fine.size - 1:
        y0, y1, y2 = rf[i - 1], rf[i], rf[i + 1]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            v += float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5)) * (fine[1] - fine[0])
    return v, float(rf[i])


def _cutoff(cfg) -> float:
    """The EN cut-off of the configuration's deck (the records' low-pass)."""
    from vsi_numba.solver.batch import acceleration_cutoff

    settings = cfg.solver_settings()
    if settings.acceleration_cutoff is not None:
        return float(settings.acceleration_cutoff)
    train = cfg.trains()[0]
    return float(acceleration_cutoff(cfg.bridge_for(train).frequencies))
