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

    1. coarse: ``rho`` of the two histories' envelopes (moving RMS over 0.5 s), which
       varies slowly with the speed (the passage's length in time) and has no maximum
       at a sub-multiple of the speed, on a geometric grid of speeds over
       :data:`SPEED_RANGE_KMH`, ratio :data:`COARSE_RATIO`;
    2. fine: ``rho`` of the histories themselves, whose maximum is sharp (the axle
       groups' times: a speed 3 % off puts the last car a period late), on
       :data:`FINE_POINTS` speeds within two coarse steps of the coarse best, and a
       parabola through the maximum and its neighbours;
    3. joint: the first parameter of ``[calibration]`` at quantiles of its prior
       (:data:`JOINT_QUANTILES`) and the speeds within 1.2 % of the fine result: the
       best correlation of all.  Near a resonance the response's shape depends on the
       deck's frequency, which the priors' median may miss (on the synthetic record at
       305 km/h, 1 % off the resonance of the truth: 0.85 % with the median's EI, 0.4 %
       with the joint search).

    The model runs the configuration with the calibration's parameters at their priors'
    medians.  On the shipped synthetic records (truth EI 10 % above the prior median,
    0.3 m s-2 noise) it finds 240 and 280 km/h to 0.03 % and 305 km/h, near the
    resonance, to 0.5 % (tests/test_existing_speed.py).
"""

from __future__ import annotations

import numpy as np

from vsi_numba.existing.forward import ForwardError

#: The speeds searched (km/h).
SPEED_RANGE_KMH = (40.0, 420.0)
#: Ratio of two neighbouring speeds of the coarse grid.
COARSE_RATIO = 1.03
#: Speeds of the fine grid (within one coarse step either side of the coarse best).
FINE_POINTS = 31
#: The joint search: the first parameter at these quantiles of its prior, the speeds
#: within this fraction of the fine search's.
JOINT_QUANTILES = (0.05, 0.2, 0.35, 0.65, 0.8, 0.95)
JOINT_SPAN, JOINT_POINTS = 0.012, 13
#: Window and step of the envelopes of the coarse search (s).
ENVELOPE_WINDOW_S, ENVELOPE_STEP_S = 0.5, 0.05
#: Speeds of one kernel call (their histories are kept: memory).
SPEEDS_PER_CALL = 8


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


def _histories(cfg, rec, speeds_kmh, row=None):
    """The model's histories of the record's quantity at its point, per speed, and the
    cut-off."""
    from vsi_numba.existing.forward import Forward, Group, central_row

    c = cfg.resolved()["calibration"]
    keys = [p["key"] for p in c["parameters"]]
    hist, cutoff = [], None
    for a in range(0, len(speeds_kmh), SPEEDS_PER_CALL):
        part = tuple(float(v) for v in speeds_kmh[a: a + SPEEDS_PER_CALL])
        g = Group(rec["train"], part, (float(rec["point"]),), rec.get("track"))
        fwd = Forward(cfg.resolved(), cfg.base_dir, keys, [g])
        res = fwd.run_row(central_row(c) if row is None else row)[0]
        if res.error:
            raise SpeedError(f"the model at the priors' medians cannot be run: {res.error}")
        hist += [h[:, 0] for h in (res.acceleration if rec["quantity"] ==
                                   "deck_acceleration" else res.displacement)]
        cutoff = res.cutoff
    return hist, cutoff


def envelope(x: np.ndarray, dt: float) -> np.ndarray:
    """The moving RMS of ``x`` over :data:`ENVELOPE_WINDOW_S`, every
    :data:`ENVELOPE_STEP_S`."""
    w = max(1, int(round(ENVELOPE_WINDOW_S / dt)))
    step = max(1, int(round(ENVELOPE_STEP_S / dt)))
    cs = np.concatenate([[0.0], np.cumsum(np.asarray(x, float) ** 2)])
    idx = np.arange(0, max(x.size - w, 0) + 1, step)
    return np.sqrt(np.maximum(cs[idx + w] - cs[idx], 0.0) / w)


def _correlation(m, s, lag0, max_lag) -> float:
    """The normalised correlation of ``m`` and ``s`` at their best alignment."""
    from vsi_numba.existing.signal import best_shift

    lag, _ = best_shift(m, s, lag0, max_lag)
    idx = np.arange(m.size) + int(round(lag))
    inside = (idx >= 0) & (idx < s.size)
    cross = float(m[inside] @ s[idx[inside]])
    return cross / np.sqrt(max(float(m @ m) * float(s @ s), 1e-300))


def _rho(cfg, rec, m, t0, dt, speeds_kmh, coarse: bool, row=None):
    """Normalised correlation of the record with the model at each speed: of their
    envelopes (``coarse``) or of the histories."""
    from vsi_numba.existing.signal import lowpass

    c = cfg.resolved()["calibration"]
    hist, cutoff = _histories(cfg, rec, speeds_kmh, row)
    lag0 = int(round(t0 / dt))
    max_lag = int(round(float(c["max_lag_s"]) / dt))
    out = np.empty(len(speeds_kmh))
    step = max(1, int(round(ENVELOPE_STEP_S / dt)))
    me = envelope(m, dt) if coarse else None
    for j, h in enumerate(hist):
        s = lowpass(h, 1.0 / dt, cutoff)
        if coarse:
            out[j] = _correlation(me, envelope(s, dt), lag0 // step, max_lag // step + 1)
        else:
            out[j] = _correlation(m, s, lag0, max_lag)
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
    rho = _rho(cfg, rec, m, t[0], dt, coarse, True)
    k = int(np.argmax(rho))
    a, b = coarse[max(k - 2, 0)], coarse[min(k + 2, coarse.size - 1)]
    fine = np.linspace(a, b, FINE_POINTS)
    rf = _rho(cfg, rec, m, t[0], dt, fine, False)
    v, best = _peak(fine, rf)
    # 3. the first parameter over its prior too: the response's shape near a resonance
    # depends on the frequency, which the priors' median may miss
    from vsi_numba.existing.distributions import Marginals
    from vsi_numba.existing.forward import central_row

    c = cfg.resolved()["calibration"]
    row0 = central_row(c)
    first = Marginals([dict(c["parameters"][0])])
    joint = np.linspace(v * (1 - JOINT_SPAN), v * (1 + JOINT_SPAN), JOINT_POINTS)
    for q in JOINT_QUANTILES:
        row = row0.copy()
        row[0] = first.from_u(np.array([float(_norm_ppf(q))]))[0]
        vq, rq = _peak(joint, _rho(cfg, rec, m, t[0], dt, joint, False, row))
        if rq > best:
            v, best = vq, rq
    return v, best


def _norm_ppf(q: float) -> float:
    import scipy.stats

    return float(scipy.stats.norm.ppf(q))


def _peak(x, y) -> tuple[float, float]:
    """The maximum of ``y(x)`` on a uniform grid, refined by a parabola."""
    i = int(np.argmax(y))
    v = float(x[i])
    if 0 < i < len(x) - 1:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            v += float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5)) * float(x[1] - x[0])
    return v, float(y[i])


def _cutoff(cfg) -> float:
    """The EN cut-off of the configuration's deck (the records' low-pass)."""
    from vsi_numba.solver.batch import acceleration_cutoff

    settings = cfg.solver_settings()
    if settings.acceleration_cutoff is not None:
        return float(settings.acceleration_cutoff)
    train = cfg.trains()[0]
    return float(acceleration_cutoff(cfg.bridge_for(train).frequencies))
