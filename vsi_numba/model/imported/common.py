"""What both ways in share: the error type and result of an import, the tolerances, and
the checks and steps applied to mode shapes along a track line."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.interpolate

from vsi_numba.model import bridge as _br

NETCDF_SUFFIXES = (".nc", ".nc4", ".cdf", ".netcdf")
SIGMA = -1.0  # rad^2/s^2: shift of the shift-invert eigensolver (just below zero)
SYMMETRY_TOL = 1e-8  # relative to max |A|
NORMALISATION_TOL = 1e-6  # max |Phi^T M Phi - I|
END_TOL = 1e-2  # |phi(end)| / max |phi| above this: the shape does not vanish at an end
COVER_TOL = 1e-4  # relative to the length: stations must reach both ends
RIGID_BODY_HZ = 1e-3  # a mode below this is a rigid-body mode (missing supports)
LOW_FREQUENCY_HZ = 0.5  # a first mode below this: units or K/M swapped? (warning)
MAX_MODES = 1000


class ModelFileError(ValueError):
    """A bridge data file (or a key that refers to it) cannot be used.

    Parameters
    ----------
    problems : list of (key, value, expected)
        ``key`` is the config key under ``[bridge]`` the problem belongs to ("file",
        "stiffness_matrix", "mass_matrix", "station_map", "fixed_dofs", "track_line",
        ...), ``value`` the file name or value (None: the key is missing), ``expected``
        what was expected and what was found.
    """

    def __init__(self, problems):
        self.problems = [(str(k), v, str(e)) for k, v, e in problems]
        super().__init__("\n".join(
            f"{k}: missing; expected {e}" if v is None else f"{k} = {v}: expected {e}"
            for k, v, e in self.problems))


@dataclass(frozen=True)
class ImportResult:
    """An imported bridge with what the config checks need.

    Attributes
    ----------
    bridge : ModalBridge
        The retained modes along the selected track line.
    all_frequencies : ndarray
        Every frequency known (Hz, ascending): the file's, or those computed; used for
        the EN 1990 A2 cut-off check.
    warnings : tuple of str
    lines : tuple of str
        The track lines available in the data.
    line_shapes : dict
        Other lines asked for (``extra_lines`` of
        :func:`~vsi_numba.model.imported.modes_from_matrices`): name -> (x, values,
        slopes), the retained modes with the signs and normalisation of ``bridge``.
    """

    bridge: _br.ModalBridge
    all_frequencies: np.ndarray
    warnings: tuple[str, ...] = ()
    lines: tuple[str, ...] = ()
    line_shapes: dict = field(default_factory=dict)


# ------------------------------------------------------------------------ shared steps


class _Problems:
    def __init__(self):
        self.items: list[tuple[str, object, str]] = []

    def add(self, key, value, expected):
        self.items.append((key, value, expected))

    def raise_if_any(self):
        if self.items:
            raise ModelFileError(self.items)


def _fmt_x(x) -> str:
    return f"{float(x):.6g} m"


def _check_stations(p, key, name, x, line, length):
    """Stations strictly increasing from 0, reaching ``length`` when known."""
    where = f" on line '{line}'" if line else ""
    if x.size < 2:
        p.add(key, name, f"at least 2 stations{where} (found {x.size})")
        return False
    if not np.all(np.isfinite(x)):
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        p.add(key, name, f"finite station abscissae x (m){where} (station {i} is {x[i]})")
        return False
    d = np.diff(x)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        what = "repeated" if d[i] == 0 else "decreasing"
        p.add(key, name, f"station abscissae strictly increasing{where} ({what} at x = "
                         f"{_fmt_x(x[i])} -> {_fmt_x(x[i + 1])})")
        return False
    span = x[-1] - x[0]
    if abs(x[0]) > COVER_TOL * span:
        p.add(key, name, f"stations starting at x = 0 (the left end of the deck along the "
                         f"track line){where}; the first station is at x = {_fmt_x(x[0])}")
        return False
    if length is not None and abs(x[-1] - length) > COVER_TOL * length:
        p.add(key, name, f"a table covering the whole bridge, x = 0 .. {length:g} m (sum of "
                         f"bridge.spans){where}; the stations end at x = {_fmt_x(x[-1])}")
        return False
    return True


def _check_ends(p, key, name, x, shapes, line, labels):
    """Mode shapes vanish at both ends (the train runs onto rigid track there)."""
    where = f" on line '{line}'" if line else ""
    peak = np.max(np.abs(shapes), axis=0)
    peak[peak == 0] = 1.0
    for end, row in (("first", 0), ("last", -1)):
        ratio = np.abs(shapes[row]) / peak
        j = int(np.argmax(ratio))
        if ratio[j] > END_TOL:
            p.add(key, name,
                  f"mode shapes that vanish at both ends of the track line{where} (the train "
                  f"runs onto rigid track there); mode {labels[j]} is {ratio[j]:.3g} x its "
                  f"maximum at the {end} station x = {_fmt_x(x[row])}: does the table cover "
                  "the whole bridge, from support to support?")
            return False
    return True


def _keep(freqs, n_modes, max_frequency):
    n = freqs.size if n_modes is None else min(int(n_modes), freqs.size)
    if max_frequency is not None:
        n = min(n, int(np.count_nonzero(freqs <= max_frequency * (1 + 1e-12))))
    return n


def _damping(p, damping_ratio, from_file, n, warnings):
    if damping_ratio is None:
        return np.zeros(n) if from_file is None else from_file[:n].copy()
    if from_file is not None and np.any(from_file[:n] != 0):
        warnings.append("bridge.damping_ratio overrides the damping ratios of the file")
    z = np.asarray(damping_ratio, float)
    if z.ndim == 0:
        return np.full(n, float(z))
    if z.size < n:
        p.add("damping_ratio", z.tolist(),
              f"a single ratio or at least one per retained mode ({n} modes)")
        return np.zeros(n)
    return z[:n].copy()


def _spline_slopes(x, values):
    return scipy.interpolate.CubicSpline(x, values, axis=0, bc_type="not-a-knot")(x, 1)


def _flip_positive(values, slopes, *others):
    """Flip each mode so that its largest value along the track line is positive."""
    j = np.arange(values.shape[1])
    sign = np.sign(values[np.argmax(np.abs(values), axis=0), j])
    sign[sign == 0] = 1.0
    return (values * sign, slopes * sign, *(o * sign for o in others))


def _supports_from(spans, given, x_end):
    if given is not None and given.size >= 2:
        return given
    if spans is not None:
        return np.concatenate([[0.0], np.cumsum(np.asarray(spans, float))])
    return np.array([0.0, x_end])
