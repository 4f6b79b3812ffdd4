"""Damping ratio of the first mode from the free vibration after a passage (logarithmic
decrement), usable as the prior of a calibration.

The whole record is low-passed at twice the first frequency (:func:`~.signal.lowpass`,
zero phase; the filter runs over the whole record so that its end effects stay out of
the window), the window starts two periods after the last axle has left the deck (the
higher modes have died out by then), and the logarithm of the peaks' magnitudes (maxima
and minima, ``scipy.signal.find_peaks``) is fitted by a straight line in time (least
squares): ``zeta = -slope / (2 pi f1)`` (light damping), ``f1`` from the mean spacing of
the peaks.  The fit's standard error gives the coefficient of variation of a lognormal
prior (:meth:`FreeVibrationFit.prior`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.signal

from vsi_numba.existing.signal import lowpass


class FreeVibrationFit(NamedTuple):
    """The identified first mode: frequency (Hz), damping ratio, its cov, peaks used."""

    frequency: float
    damping_ratio: float
    cov: float
    n_peaks: int

    def prior(self, key: str = "bridge.damping_ratio", min_cov: float = 0.1) -> dict:
        """A ``calibration.parameters`` entry: lognormal at the fit, cov at least
        ``min_cov``."""
        return {"key": key, "prior": "lognormal", "median": float(self.damping_ratio),
                "cov": float(max(self.cov, min_cov))}


def free_vibration_damping(t, value, t_leave: float, f1_guess: float) -> FreeVibrationFit:
    """Fit the decay of the free vibration of ``value(t)`` after ``t_leave`` (s, the last
    axle off the deck, on the record's clock); ``f1_guess`` (Hz) sets the filter and the
    peak spacing.  ``ValueError`` with fewer than six peaks."""
    t = np.asarray(t, float)
    fs = 1.0 / float(np.mean(np.diff(t)))
    y = lowpass(np.asarray(value, float), fs, 2.0 * f1_guess)
    keep = t >= t_leave + 2.0 / f1_guess
    tt, yy = t[keep], y[keep]
    dist = max(1, int(0.35 * fs / f1_guess))
    hi, _ = scipy.signal.find_peaks(yy, distance=dist)
    lo, _ = scipy.signal.find_peaks(-yy, distance=dist)
    idx = np.sort(np.concatenate([hi, lo]))
    if idx.size < 6:
        raise ValueError(f"the free vibration after t = {t_leave:g} s holds {idx.size} "
                         "peaks: at least six are needed")
    tp, ap = tt[idx], np.abs(yy[idx])
    f1 = 0.5 / float(np.mean(np.diff(tp)))
    A = np.vstack([tp - tp.mean(), np.ones_like(tp)]).T
    coef, res, *_ = np.linalg.lstsq(A, np.log(ap), rcond=None)
    slope = float(coef[0])
    s2 = float(res[0]) / max(tp.size - 2, 1) if res.size else 0.0
    se = float(np.sqrt(s2 / np.sum((tp - tp.mean()) ** 2)))
    zeta = -slope / (2.0 * np.pi * f1)
    return FreeVibrationFit(f1, float(zeta), abs(se / slope) if slope else float("inf"),
                            int(idx.size))
