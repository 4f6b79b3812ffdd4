"""Write the example files of ``configs/two_span_imported.toml`` and
``configs/two_span_modes_file.toml`` (run from the repository root:
``.venv/bin/python configs/data/make_two_span.py``).

The "other FE program" here is a small skew two-track grillage: two continuous
two-span Euler-Bernoulli beams (one under each track, 2 x 20 m along each track), 20
Hermite elements per span, joined node by node by vertical springs (the deck slab and
cross girders, lumped).  The supports are skew: track 2 starts 3 m further along the
bridge's global axis than track 1, so its supports sit at global X = 3, 23, 43 m
against 0, 20, 40 m for track 1; a node of track 1 at global X is tied to the node of
track 2 at the same X (the 3 m shift is 3 elements).  Along each track line x runs
from that line's first support, so both lines have supports at x = 0, 20, 40 m, but the
modes differ between the lines because of the skew coupling.

Files (formats: :mod:`vsi_numba.model.imported`):

- ``two_span_K.mtx``, ``two_span_M.mtx``: stiffness and consistent mass, symmetric
  Matrix Market, 164 DOFs (node i of track t: w = 2 (41 t + i), theta = w + 1), supports
  NOT applied (``fixed_dofs`` in the config);
- ``two_span_stations.csv``: x, dof, rotation_dof, line for both tracks;
- ``two_span_modes.nc``: the 8 lowest modes of the same model as a modes table
  (frequency, modal_mass, x, shape, slope, support_x per line, damping_ratio), the
  shapes scaled to a unit peak so that the modal masses are not 1 (as most FE programs
  export them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import scipy.io
import scipy.linalg
import scipy.sparse
import xarray as xr

HERE = Path(__file__).resolve().parent
SPANS = (20.0, 20.0)  # m, along each track
NE = 20  # elements per span
EI = 3.5e10  # N m^2 per track beam (half of a 7e10 deck)
MASS = 7500.0  # kg/m per track beam (half of 15 t/m)
K_LINK = 2.0e8  # N/m per node pair: slab + cross girders, lumped at the nodes
SKEW = 3  # elements (1 m each): track 2 starts 3 m further along the bridge
N_MODES_TABLE = 8


def beam(spans, ei, m, ne):
    """K, M (dense) and node x of one Hermite beam; DOFs (w, theta) per node."""
    h = spans[0] / ne
    n = len(spans) * ne + 1
    K = np.zeros((2 * n, 2 * n))
    M = np.zeros((2 * n, 2 * n))
    ke = ei / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h**2, -6 * h, 2 * h**2],
                               [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h**2, -6 * h, 4 * h**2]])
    me = m * h / 420 * np.array([[156, 22 * h, 54, -13 * h],
                                 [22 * h, 4 * h**2, 13 * h, -3 * h**2],
                                 [54, 13 * h, 156, -22 * h],
                                 [-13 * h, -3 * h**2, -22 * h, 4 * h**2]])
    for e in range(n - 1):
        i = slice(2 * e, 2 * e + 4)
        K[i, i] += ke
        M[i, i] += me
    return K, M, np.arange(n) * h


def model():
    K1, M1, x = beam(SPANS, EI, MASS, NE)
    n1 = K1.shape[0]
    K = scipy.linalg.block_diag(K1, K1)
    M = scipy.linalg.block_diag(M1, M1)
    nn = x.size
    for i in range(nn):  # node i of track 1 at global X = x[i]; track 2 node i - SKEW
        j = i - SKEW
        if 0 <= j < nn:
            a, b = 2 * i, n1 + 2 * j
            K[a, a] += K_LINK
            K[b, b] += K_LINK
            K[a, b] -= K_LINK
            K[b, a] -= K_LINK
    supports = [0, NE, 2 * NE]
    fixed = [2 * s for s in supports] + [n1 + 2 * s for s in supports]
    return K, M, x, fixed


def main():
    K, M, x, fixed = model()
    n1 = K.shape[0] // 2
    scipy.io.mmwrite(HERE / "two_span_K.mtx", scipy.sparse.coo_matrix(K), symmetry="symmetric",
                     comment="two-track skew two-span grillage, stiffness (N/m, N, N m)",
                     precision=12)
    scipy.io.mmwrite(HERE / "two_span_M.mtx", scipy.sparse.coo_matrix(M), symmetry="symmetric",
                     comment="two-track skew two-span grillage, consistent mass (kg, kg m^2)",
                     precision=12)
    nn = x.size
    rows = []
    for t, name in enumerate(("track1", "track2")):
        for i in range(nn):
            w = t * n1 + 2 * i
            rows.append({"x": round(float(x[i]), 6), "dof": w, "rotation_dof": w + 1,
                         "line": name})
    pd.DataFrame(rows).to_csv(HERE / "two_span_stations.csv", index=False)

    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    lam, vec = lam[:N_MODES_TABLE], vec[:, :N_MODES_TABLE]
    full = np.zeros((K.shape[0], N_MODES_TABLE))
    full[free] = vec
    w = np.stack([full[0:n1:2], full[n1::2]])  # (line, station, mode)
    th = np.stack([full[1:n1:2], full[n1 + 1::2]])
    peak = np.max(np.abs(w), axis=(0, 1))
    scale = 1.0 / peak  # unit peak, as exported by many programs
    modal_mass = scale**2  # phi^T M phi of the scaled shape (phi itself: unit modal mass)
    freq = np.sqrt(lam) / (2 * np.pi)
    ds = xr.Dataset(
        {
            "frequency": ("mode", freq, {"units": "Hz", "long_name": "natural frequency"}),
            "modal_mass": ("mode", modal_mass, {"units": "kg",
                                                "long_name": "modal mass of the stored shape"}),
            "damping_ratio": ("mode", np.full(N_MODES_TABLE, 0.015),
                              {"units": "1", "long_name": "modal damping ratio"}),
            "x": (("line", "station"), np.stack([x, x]),
                  {"units": "m", "long_name": "station abscissa along the track line"}),
            "shape": (("line", "station", "mode"), w * scale,
                      {"units": "m", "long_name": "vertical mode shape (unit peak)"}),
            "slope": (("line", "station", "mode"), th * scale,
                      {"units": "1", "long_name": "d(shape)/dx"}),
            "support_x": (("line", "support"), np.array([[0.0, 20.0, 40.0]] * 2),
                          {"units": "m", "long_name": "support abscissa along the track line"}),
        },
        coords={"mode": np.arange(1, N_MODES_TABLE + 1), "line": ["track1", "track2"]},
        attrs={"Conventions": "CF-1.8",
               "title": "two-track skew two-span grillage: 8 lowest modes",
               "source": "configs/data/make_two_span.py",
               "mass_normalised": 0},
    )
    ds.to_netcdf(HERE / "two_span_modes.nc")
    print("frequencies (Hz):", np.round(freq, 3))


if __name__ == "__main__":
    main()
