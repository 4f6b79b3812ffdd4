"""Imported bridges: modes tables (netCDF/CSV) and FE matrices (Matrix Market).

References are built here, independently of the package: a Hermite-beam FE assembly of
our own (sparse, element matrices written out), analytic sine modes of a simply
supported span, dense ``scipy.linalg.eigh`` modes.  The imported bridges must give the
same frequencies and the same mid-span deflection history under a moving force as the
built-in models (``bridge.simply_supported``, ``bridge.continuous``).

Set NUMBA_CACHE_DIR: the simulate tests compile the kernels once per machine.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.integrate
import scipy.io
import scipy.linalg
import scipy.optimize
import scipy.sparse
import xarray as xr
from userpath import vsi

from vsi_numba.config import ConfigError, load_config
from vsi_numba.model import bridge as br
from vsi_numba.model import imported as im
from vsi_numba.model import vehicle as vh

ROOT = Path(__file__).resolve().parents[1]

# the simply supported span of the quick start, and the two-span deck of the ICE3 example
SS = {"L": 25.0, "EI": 8.323e9, "m": 2303.0}
TWO = {"spans": (20.0, 20.0), "EI": 7.0e10, "m": 15000.0}

#: Interpolation errors measured by test_imported__spline_interpolation_order (filled in
#: at run time; readable with ``pytest -s`` from the assertion messages).
SPLINE_ERRORS: dict[int, float] = {}


# ------------------------------------------------------------------ independent FE code


def hermite_beam(spans, EI, m, ne):
    """Sparse K, M of a continuous beam (Hermite cubics, consistent mass), our own code.

    DOFs per node (w, theta = dw/dx); returns K, M (csr), node x, support DOFs.
    """
    rows, cols, kv, mv = [], [], [], []
    x = [0.0]
    for s, span in enumerate(spans):
        h = span / ne
        k = EI / h**3 * np.array([[12.0, 6 * h, -12, 6 * h],
                                  [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                  [-12, -6 * h, 12, -6 * h],
                                  [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
        mm = m * h / 420.0 * np.array([[156.0, 22 * h, 54, -13 * h],
                                       [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                       [54, 13 * h, 156, -22 * h],
                                       [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
        for e in range(ne):
            n0 = s * ne + e
            dofs = [2 * n0, 2 * n0 + 1, 2 * n0 + 2, 2 * n0 + 3]
            for a in range(4):
                for b in range(4):
                    rows.append(dofs[a])
                    cols.append(dofs[b])
                    kv.append(k[a, b])
                    mv.append(mm[a, b])
            x.append(sum(spans[:s]) + (e + 1) * h)
    n = 2 * len(x)
    K = scipy.sparse.coo_matrix((kv, (rows, cols)), shape=(n, n)).tocsr()
    M = scipy.sparse.coo_matrix((mv, (rows, cols)), shape=(n, n)).tocsr()
    fixed = [2 * s * ne for s in range(len(spans) + 1)]
    return K, M, np.array(x), fixed


def write_matrices(tmp_path, K, M, x, *, rotations=True, symmetric=True):
    sym = "symmetric" if symmetric else "general"
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(K), symmetry=sym)
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(M), symmetry=sym)
    table = {"x": x, "dof": 2 * np.arange(x.size)}
    if rotations:
        table["rotation_dof"] = 2 * np.arange(x.size) + 1
    pd.DataFrame(table).to_csv(tmp_path / "stations.csv", index=False)


def sine_table(x, n_modes, scale=1.0):
    """Analytic SS modes: rows of the long CSV layout, shapes scaled by ``scale``."""
    L, EI, m = SS["L"], SS["EI"], SS["m"]
    rows = []
    for j in range(1, n_modes + 1):
        f = (j * np.pi / L) ** 2 * np.sqrt(EI / m) / (2 * np.pi)
        for xi in x:  # unit-amplitude sine: modal mass m L / 2, times scale^2
            rows.append({"mode": j, "frequency": f, "modal_mass": m * L / 2 * scale**2,
                         "x": xi, "shape": scale * np.sin(j * np.pi * xi / L)})
    return pd.DataFrame(rows)


def base_config(bridge, speed_kmh=100.0):
    return {"title": "imported", "bridge": bridge,
            "train": {"vehicles": [{"kind": "force", "load": 1.0e5}]},
            "solver": {"dt": 2e-3, "approach": 1.0, "free_vibration": 0.2},
            "study": {"speeds_kmh": [speed_kmh]}}


def config_errors(bridge, tmp_path) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(base_config(bridge), base_dir=tmp_path)
    return info.value.errors


def midspan_history(bridge, x_out, speed=30.0):
    """Deflection at ``x_out`` (m, positive down) under a 100 kN moving force."""
    from vsi_numba.solver.settings import SolverSettings
    from vsi_numba.solver.simulate import simulate

    train = vh.Train("P", (vh.moving_force(1.0e5),), (0.0,))
    ds = simulate(bridge, train, speed, settings=SolverSettings(
        dt=2e-3, approach=1.0, free_vibration=0.2), output_points=[x_out])
    assert ds.attrs["status"] == 0
    return ds["deck_displacement"].values[:, 0]


def same_up_to_sign(a, b):
    """Flip the columns of ``a`` to match ``b`` (mode signs are arbitrary)."""
    s = np.sign(np.sum(a * b, axis=0))
    s[s == 0] = 1.0
    return a * s


# ---------------------------------------------------------------------- matrices: SS


def test_imported__matrices_simply_supported_frequencies_and_effective_mass(tmp_path):
    K, M, x, fixed = hermite_beam([SS["L"]], SS["EI"], SS["m"], 20)
    write_matrices(tmp_path, K, M, x)
    res = im.read_matrices(tmp_path / "K.mtx", tmp_path / "M.mtx", tmp_path / "stations.csv",
                           fixed_dofs=fixed, n_modes=4, spans=[SS["L"]])
    j = np.arange(1, 5)
    f_exact = (j * np.pi / SS["L"]) ** 2 * np.sqrt(SS["EI"] / SS["m"]) / (2 * np.pi)
    # 20 cubic elements: FE frequency error O(h^4); mode 4 (5 elements per half wave) is
    # 1.1e-4 too high, mode 1 1e-7
    np.testing.assert_allclose(res.bridge.frequencies, f_exact, rtol=2e-4)
    assert abs(res.bridge.frequencies[0] / f_exact[0] - 1) < 1e-6
    # effective mass of a SS beam: 8 / (j pi)^2 for odd j, 0 for even j (closed form)
    eff_exact = np.where(j % 2 == 1, 8.0 / (j * np.pi) ** 2, 0.0)
    # 2e-5 absolute: FE discretisation error of the modal participation
    np.testing.assert_allclose(res.bridge.effective_mass_fraction, eff_exact, atol=2e-5)
    # unit modal mass: the shapes equal sqrt(2/(mL)) sin(j pi x/L) up to sign, 5e-4 of
    # the amplitude (FE shape error of mode 4 at 20 elements: 2e-4)
    xx = np.linspace(0, SS["L"], 501)
    ref = br.simply_supported(SS["L"], SS["EI"], SS["m"], 4)
    got = same_up_to_sign(res.bridge.shapes(xx), ref.shapes(xx))
    assert np.max(np.abs(got - ref.shapes(xx))) < 5e-4 * ref.values.max()


def test_imported__matrices_simply_supported_response_equals_builtin(tmp_path):
    K, M, x, fixed = hermite_beam([SS["L"]], SS["EI"], SS["m"], 20)
    write_matrices(tmp_path, K, M, x)
    res = im.read_matrices(tmp_path / "K.mtx", tmp_path / "M.mtx", tmp_path / "stations.csv",
                           fixed_dofs=fixed, n_modes=4, spans=[SS["L"]])
    ref = br.simply_supported(SS["L"], SS["EI"], SS["m"], 4)
    w_imp = midspan_history(res.bridge, 12.5)
    w_ref = midspan_history(ref, 12.5)
    # FE (20 elements) vs analytic modes: 1e-4 of the peak deflection
    assert np.max(np.abs(w_imp - w_ref)) < 1e-4 * np.max(np.abs(w_ref))


# ------------------------------------------------------------------ matrices: two span


def test_imported__matrices_two_span_equals_continuous(tmp_path):
    K, M, x, fixed = hermite_beam(TWO["spans"], TWO["EI"], TWO["m"], 40)
    write_matrices(tmp_path, K, M, x)
    cfg = load_config(base_config({
        "kind": "matrices", "stiffness_matrix": "K.mtx", "mass_matrix": "M.mtx",
        "station_map": "stations.csv", "fixed_dofs": fixed, "spans": list(TWO["spans"]),
        "n_modes": 4, "damping_ratio": 0.02}), base_dir=tmp_path)
    got = cfg.build_bridge()
    ref = br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 4, damping_ratio=0.02,
                        elements_per_span=40)
    # same discretisation (the rotation DOFs give the FE slopes): equal to round-off
    np.testing.assert_allclose(got.frequencies, ref.frequencies, rtol=1e-9)
    np.testing.assert_allclose(got.damping, ref.damping)
    np.testing.assert_allclose(got.supports, [0.0, 20.0, 40.0])
    np.testing.assert_allclose(cfg.output_points, [10.0, 30.0])
    xx = np.linspace(0, 40, 777)
    # 1e-9 of the amplitude: round-off of two eigensolvers on the same matrices
    assert np.max(np.abs(same_up_to_sign(got.shapes(xx), ref.shapes(xx)) - ref.shapes(xx))) \
        < 1e-9 * np.abs(ref.values).max()
    w_imp = midspan_history(got, 10.0)
    w_ref = midspan_history(ref, 10.0)
    # same model: 1e-8 of the peak (round-off through the time integration)
    assert np.max(np.abs(w_imp - w_ref)) < 1e-8 * np.max(np.abs(w_ref))


def test_imported__matrices_without_rotations_use_the_spline(tmp_path):
    K, M, x, fixed = hermite_beam(TWO["spans"], TWO["EI"], TWO["m"], 40)
    write_matrices(tmp_path, K, M, x, rotations=False)
    res = im.read_matrices(tmp_path / "K.mtx", tmp_path / "M.mtx", tmp_path / "stations.csv",
                           fixed_dofs=fixed, n_modes=4)
    ref = br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 4, elements_per_span=40)
    xx = np.linspace(0, 40, 777)
    err = np.max(np.abs(same_up_to_sign(res.bridge.shapes(xx), ref.shapes(xx))
                        - ref.shapes(xx)))
    # spline through 0.5 m stations instead of the FE slopes: 1e-4 of the amplitude
    # (the shear jumps at the middle support make the spline locally O(h^3))
    assert err < 1e-4 * np.abs(ref.values).max()


def test_imported__max_frequency_extends_the_eigsh_search(tmp_path):
    K, M, x, fixed = hermite_beam(TWO["spans"], TWO["EI"], TWO["m"], 40)
    write_matrices(tmp_path, K, M, x)
    # 600 Hz needs more than the first eigsh batch of 12 modes: the search doubles
    res = im.read_matrices(tmp_path / "K.mtx", tmp_path / "M.mtx", tmp_path / "stations.csv",
                           fixed_dofs=fixed, n_modes=None, max_frequency=600.0)
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    lam = scipy.linalg.eigh(K.toarray()[np.ix_(free, free)], M.toarray()[np.ix_(free, free)],
                            eigvals_only=True)
    f = np.sqrt(lam) / (2 * np.pi)
    expected = f[f <= 600.0]
    assert expected.size > 12
    np.testing.assert_allclose(res.bridge.frequencies, expected, rtol=1e-9)


def test_imported__one_based_dofs_and_lines(tmp_path):
    K, M, x, fixed = hermite_beam(TWO["spans"], TWO["EI"], TWO["m"], 20)
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(K))
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(M))
    n = x.size
    pd.DataFrame({"x": np.r_[x, x[:3]], "dof": np.r_[2 * np.arange(n), [0, 2, 4]] + 1,
                  "line": ["main"] * n + ["stub"] * 3}).to_csv(tmp_path / "st.csv",
                                                             index=False)
    cfg = load_config(base_config({
        "kind": "matrices", "stiffness_matrix": "K.mtx", "mass_matrix": "M.mtx",
        "station_map": "st.csv", "fixed_dofs": [f + 1 for f in fixed], "dof_base": 1,
        "track_line": "main", "n_modes": 2, "vertical_dofs": {"start": 1, "step": 2}}),
        base_dir=tmp_path)
    b = cfg.build_bridge()
    ref = br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 2, elements_per_span=20)
    np.testing.assert_allclose(b.frequencies, ref.frequencies, rtol=1e-9)
    assert b.effective_mass_fraction[0] < 1e-12  # antisymmetric mode: no net mass
    # symmetric mode of two equal continuous spans = first mode of a propped cantilever
    # (clamped at the middle support): (int phi)^2 / (L int phi^2) from the closed form
    beta = scipy.optimize.brentq(lambda b: np.tan(b) - np.tanh(b), 3.5, 4.2)  # 3.9266
    sig = (np.cosh(beta) - np.cos(beta)) / (np.sinh(beta) - np.sin(beta))
    s = np.linspace(0.0, 1.0, 20001)
    phi = np.cosh(beta * s) - np.cos(beta * s) - sig * (np.sinh(beta * s) - np.sin(beta * s))
    eff = scipy.integrate.trapezoid(phi, s) ** 2 / scipy.integrate.trapezoid(phi**2, s)
    # 1e-6: FE discretisation (20 elements per span) and the quadrature
    assert abs(b.effective_mass_fraction[1] - eff) < 1e-6, (b.effective_mass_fraction, eff)


# ----------------------------------------------------------------------- modes tables


def test_imported__modes_csv_simply_supported_equals_builtin(tmp_path):
    x = np.linspace(0, SS["L"], 51)  # 0.5 m stations
    sine_table(x, 4, scale=0.7).to_csv(tmp_path / "modes.csv", index=False)
    cfg = load_config(base_config({"kind": "modes_file", "file": "modes.csv",
                                   "spans": [SS["L"]], "damping_ratio": 0.01}),
                      base_dir=tmp_path)
    got = cfg.build_bridge()
    ref = br.simply_supported(SS["L"], SS["EI"], SS["m"], 4, damping_ratio=0.01)
    np.testing.assert_allclose(got.frequencies, ref.frequencies, rtol=1e-12)
    np.testing.assert_allclose(got.damping, 0.01)
    xx = np.linspace(0, SS["L"], 1001)
    # spline through 0.5 m stations: 5e-5 of the amplitude up to mode 4 (h^4 error,
    # 3e-5 for mode 4 with 12.5 stations per half wave)
    err = np.max(np.abs(same_up_to_sign(got.shapes(xx), ref.shapes(xx)) - ref.shapes(xx)))
    assert err < 5e-5 * ref.values.max()
    w_imp = midspan_history(got, 12.5)
    w_ref = midspan_history(ref, 12.5)
    # interpolated vs analytic modes: 1e-4 of the peak deflection
    assert np.max(np.abs(w_imp - w_ref)) < 1e-4 * np.max(np.abs(w_ref))


def test_imported__modes_netcdf_two_span_two_lines_equals_continuous(tmp_path):
    """FE modes (dense eigh, our own assembly) on two track lines, modal masses not 1."""
    K, M, x, fixed = hermite_beam(TWO["spans"], TWO["EI"], TWO["m"], 40)
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    lam, vec = scipy.linalg.eigh(K.toarray()[np.ix_(free, free)],
                                 M.toarray()[np.ix_(free, free)])
    n_m = 5
    full = np.zeros((K.shape[0], n_m))
    full[free] = vec[:, :n_m]
    phi = full / np.max(np.abs(full[0::2]), axis=0)  # unit peak, as FE programs export
    modal_mass = np.einsum("ij,ij->j", phi, M @ phi)  # phi^T M phi of the stored shape
    w = phi[0::2]
    stations = x[::2]  # every other FE node: 1 m stations, spline between them
    other = np.linspace(0, 41.0, 30)  # a second line with another length (NaN padded)
    xs = np.full((2, stations.size), np.nan)
    xs[0], xs[1, :other.size] = stations, other
    shp = np.full((2, stations.size, n_m), np.nan)
    shp[0] = w[::2]
    shp[1, :other.size] = np.sin(np.pi * other / 41.0)[:, None] * np.ones(n_m)
    ds = xr.Dataset(
        {"frequency": ("mode", np.sqrt(lam[:n_m]) / (2 * np.pi)),
         "modal_mass": ("mode", modal_mass),
         "x": (("line", "station"), xs),
         "shape": (("mode", "line", "station"), shp.transpose(2, 0, 1))},  # dims any order
        coords={"line": ["up", "down"]})
    ds.to_netcdf(tmp_path / "modes.nc")
    cfg = load_config(base_config({"kind": "modes_file", "file": "modes.nc",
                                   "track_line": "up", "n_modes": 4, "spans": [20.0, 20.0]}),
                      base_dir=tmp_path)
    got = cfg.build_bridge()
    ref = br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 4, elements_per_span=40)
    np.testing.assert_allclose(got.frequencies, ref.frequencies, rtol=1e-9)
    xx = np.linspace(0, 40, 801)
    err = np.max(np.abs(same_up_to_sign(got.shapes(xx), ref.shapes(xx)) - ref.shapes(xx)))
    # spline through 1 m stations, shear jump at the middle support: 1e-3 of the amplitude
    assert err < 1e-3 * np.abs(ref.values).max()
    w_imp = midspan_history(got, 10.0)
    w_ref = midspan_history(ref, 10.0)
    # 1e-3 of the peak: the shape interpolation error above, integrated
    assert np.max(np.abs(w_imp - w_ref)) < 1e-3 * np.max(np.abs(w_ref))
    # the other line is there and different
    down = im.read_modes_table(tmp_path / "modes.nc", track_line="down", mass_normalised=None)
    assert down.bridge.length == pytest.approx(41.0)
    assert down.lines == ("up", "down")


def test_imported__modes_with_slopes_are_hermite(tmp_path):
    """Given slopes: the kernel's Hermite cubic reproduces the FE field exactly."""
    ref = br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 3, elements_per_span=10)
    rows = []
    for j in range(3):
        for xi, v, s in zip(ref.nodes, ref.values[:, j], ref.slopes[:, j], strict=True):
            rows.append({"mode": j + 1, "frequency": ref.frequencies[j], "x": xi,
                         "shape": v, "slope": s})
    pd.DataFrame(rows).to_csv(tmp_path / "m.csv", index=False)
    res = im.read_modes_table(tmp_path / "m.csv", mass_normalised=True)
    xx = np.linspace(0, 40, 333)
    # exact representation: round-off only
    np.testing.assert_allclose(same_up_to_sign(res.bridge.shapes(xx), ref.shapes(xx)),
                               ref.shapes(xx), atol=1e-12)


def test_imported__spline_interpolation_order():
    """Spline between stations vs the analytic (refined) mode: O(h^4), error recorded.

    Mode 4 of the SS span (wavelength 12.5 m) tabulated at h = 2.5, 1.25, 0.625, 0.3125 m
    and compared on a 1 cm grid with the exact sine; also a coarse table against a 16x
    refined one (what a user checks by exporting twice).
    """
    L, j = SS["L"], 4
    xx = np.linspace(0, L, 2501)
    exact = np.sin(j * np.pi * xx / L)
    hs, errs = [], []
    for n_el in (10, 20, 40, 80):
        x = np.linspace(0, L, n_el + 1)
        b = br.from_table(x, np.sin(j * np.pi * x / L)[:, None], [1.0])
        errs.append(np.max(np.abs(b.shapes(xx)[:, 0] - exact)))
        hs.append(L / n_el)
        SPLINE_ERRORS[n_el] = errs[-1]
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    # C2 cubic spline interpolation: at least fourth order; here 4.9 (the not-a-knot end
    # error decays faster than the interior h^4 term in this range)
    assert 3.7 < order < 5.5, (order, errs)
    # 10 stations per half wavelength (h = 0.625 m): below 1e-4 of the amplitude
    assert SPLINE_ERRORS[40] < 1e-4, SPLINE_ERRORS
    x_c, x_f = np.linspace(0, L, 21), np.linspace(0, L, 321)
    coarse = br.from_table(x_c, np.sin(j * np.pi * x_c / L)[:, None], [1.0])
    fine = br.from_table(x_f, np.sin(j * np.pi * x_f / L)[:, None], [1.0])
    diff = np.max(np.abs(coarse.shapes(xx) - fine.shapes(xx)))
    # the refined table is exact to ~1e-7: the difference is the coarse error
    assert diff == pytest.approx(SPLINE_ERRORS[20], rel=1e-2)


# ---------------------------------------------------------------------- bad files


def _matrix_files(tmp_path, K=None, M=None, stations=None):
    K0, M0, x, fixed = hermite_beam([SS["L"]], SS["EI"], SS["m"], 10)
    K = K0.toarray() if K is None else K
    M = M0.toarray() if M is None else M
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(K))
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(M))
    st = stations if stations is not None else pd.DataFrame(
        {"x": x, "dof": 2 * np.arange(x.size), "rotation_dof": 2 * np.arange(x.size) + 1})
    st.to_csv(tmp_path / "st.csv", index=False)
    return {"kind": "matrices", "stiffness_matrix": "K.mtx", "mass_matrix": "M.mtx",
            "station_map": "st.csv", "fixed_dofs": fixed, "n_modes": 3}, K, M, x


def test_imported__non_symmetric_stiffness(tmp_path):
    bridge, K, M, x = _matrix_files(tmp_path)
    K = K.copy()
    K[3, 5] *= 1.01
    _matrix_files(tmp_path, K=K)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.stiffness_matrix = "K.mtx": expected a symmetric stiffness '
                          "matrix (max |A - A^T| = "), msg
    assert "at (3, 5)" in msg or "at (5, 3)" in msg


def test_imported__negative_and_nan_masses(tmp_path):
    bridge, K, M, x = _matrix_files(tmp_path)
    M = M.copy()
    M[4, 4] = -10.0
    _matrix_files(tmp_path, M=M)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.mass_matrix = "M.mtx": expected positive masses: no '
                          "negative diagonal entry (DOF 4 has -10 kg"), msg
    M[4, 4] = np.nan
    _matrix_files(tmp_path, M=M)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.mass_matrix = "M.mtx": expected finite entries (entry (4, 4) '
                          "is nan"), msg


def test_imported__bad_station_maps(tmp_path):
    bridge, K, M, x = _matrix_files(tmp_path)
    n = K.shape[0]
    st = pd.DataFrame({"x": x, "dof": 2 * np.arange(x.size)})
    st.loc[3, "dof"] = n + 6  # not a DOF of the matrices
    _matrix_files(tmp_path, stations=st)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith(f'bridge.station_map = "st.csv": expected dof values that are DOFs of '
                          f"the {n}-DOF matrices, 0 .. {n - 1} (station x = 7.5 m has dof "
                          f"{n + 6})"), msg
    _matrix_files(tmp_path, stations=pd.DataFrame({"x": x[:6], "dof": 2 * np.arange(6)}))
    (msg,) = config_errors(dict(bridge, spans=[SS["L"]]), tmp_path)
    assert msg.startswith('bridge.station_map = "st.csv": expected a table covering the whole '
                          "bridge, x = 0 .. 25 m (sum of bridge.spans); the stations end at "
                          "x = 12.5 m"), msg
    _matrix_files(tmp_path, stations=pd.DataFrame({"x": x, "node": np.arange(x.size)}))
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.station_map = "st.csv": expected CSV columns x, dof'), msg
    st = pd.DataFrame({"x": x, "dof": 2 * np.arange(x.size)}).astype({"x": object})
    st.loc[2, "x"] = "nan"
    _matrix_files(tmp_path, stations=st)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.station_map = "st.csv": expected finite numbers (m) in '
                          "column 'x' (row 4 has"), msg


def test_imported__unsupported_structure_and_rotation_sign(tmp_path):
    bridge, K, M, x = _matrix_files(tmp_path)
    (msg,) = config_errors(dict(bridge, fixed_dofs=[]), tmp_path)
    assert msg.startswith("bridge.fixed_dofs = []: expected supports that stop every "
                          "rigid-body motion: 2 mode(s) at f < 0.001 Hz"), msg
    (msg,) = config_errors(dict(bridge, rotation_sign=-1), tmp_path)
    assert msg.startswith("bridge.rotation_sign = -1.0: expected rotation DOFs equal to -dw/dx; "
                          "they correlate -1.00"), msg
    (msg,) = config_errors(dict(bridge, fixed_dofs=[0, 500]), tmp_path)
    assert msg.startswith("bridge.fixed_dofs = [0, 500]: expected DOF numbers 0 <= i < 22"), msg


def test_imported__missing_files(tmp_path):
    errors = config_errors({"kind": "matrices", "stiffness_matrix": "K.mtx",
                            "mass_matrix": "M.mtx", "station_map": "st.csv"}, tmp_path)
    assert [e.split(":")[0] for e in errors] == [
        'bridge.stiffness_matrix = "K.mtx"', 'bridge.mass_matrix = "M.mtx"',
        'bridge.station_map = "st.csv"']
    assert all("expected an existing file" in e for e in errors)
    (msg,) = config_errors({"kind": "modes_file", "file": "modes.nc"}, tmp_path)
    assert msg.startswith('bridge.file = "modes.nc": expected an existing file with the deck '
                          "modes"), msg
    (msg,) = config_errors({"kind": "modes_file"}, tmp_path)
    assert msg.startswith("bridge.file: missing required key; expected the path of the deck "
                          "modes"), msg
    (tmp_path / "K.mtx").write_text("this is not a matrix\n")
    bridge, *_ = _matrix_files(tmp_path)
    (tmp_path / "K.mtx").write_text("this is not a matrix\n")
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.stiffness_matrix = "K.mtx": expected a Matrix Market file '
                          "readable by scipy.io.mmread"), msg


def _modes_csv(tmp_path, df, name="modes.csv"):
    df.to_csv(tmp_path / name, index=False)
    return {"kind": "modes_file", "file": name}


def test_imported__modes_table_missing_station(tmp_path):
    df = sine_table(np.linspace(0, SS["L"], 11), 3)
    df = df.drop(index=df.index[(df["mode"] == 2) & np.isclose(df["x"], 5.0)])
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg == ('bridge.file = "modes.csv": expected every mode at every station (missing '
                   "stations: mode 2 has no row at x = 5 m; 1 value(s) missing)"), msg


def test_imported__modes_table_nan_and_bad_numbers(tmp_path):
    df = sine_table(np.linspace(0, SS["L"], 11), 3)
    df.loc[7, "shape"] = np.nan
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg.startswith('bridge.file = "modes.csv": expected finite numbers in column '
                          "'shape' (row 9 of the file"), msg
    df = sine_table(np.linspace(0, SS["L"], 11), 3)
    df.loc[df["mode"] == 3, "modal_mass"] = -1.0
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg == 'bridge.file = "modes.csv": expected modal masses > 0 kg (mode 3 has -1.0)'
    df = sine_table(np.linspace(0, SS["L"], 11), 3)
    df.loc[5, "frequency"] *= 1.1
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg.startswith('bridge.file = "modes.csv": expected the same frequency on every row '
                          "of a mode (mode 1 has"), msg
    df = sine_table(np.linspace(0, SS["L"], 11), 3).drop(columns="modal_mass")
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg.startswith('bridge.file = "modes.csv": expected a modal_mass per mode (kg) -- '
                          "or the shapes already mass-normalised"), msg
    cfg = base_config(dict(_modes_csv(tmp_path, df), mass_normalised=True))
    # the flag makes the file valid; these shapes are not normalised though, and the
    # static deflection they imply (112 m) is refused unless overridden
    with pytest.raises(ConfigError, match="static deflection"):
        load_config(cfg, base_dir=tmp_path)
    cfg.setdefault("solver", {})["allow_implausible"] = True
    load_config(cfg, base_dir=tmp_path)


def test_imported__modes_table_not_covering_the_bridge(tmp_path):
    x = np.linspace(0, 20.0, 9)  # a 25 m bridge tabulated to 20 m
    bridge = _modes_csv(tmp_path, sine_table(x, 3))
    (msg,) = config_errors(dict(bridge, spans=[25.0]), tmp_path)
    assert msg == ('bridge.file = "modes.csv": expected a table covering the whole bridge, x = '
                   "0 .. 25 m (sum of bridge.spans); the stations end at x = 20 m"), msg
    # without spans: the shapes do not vanish at the last station
    (msg,) = config_errors(bridge, tmp_path)
    assert msg.startswith('bridge.file = "modes.csv": expected mode shapes that vanish at both '
                          "ends of the track line (the train runs onto rigid track there); "
                          "mode 2 is 1 x its maximum at the last station x = 20 m"), msg
    df = sine_table(np.linspace(0, SS["L"], 11), 3)
    df["x"] += 100.0  # global coordinates instead of x from the left end
    (msg,) = config_errors(_modes_csv(tmp_path, df), tmp_path)
    assert msg.startswith('bridge.file = "modes.csv": expected stations starting at x = 0'), msg


def test_imported__modes_file_track_lines_and_formats(tmp_path):
    df = sine_table(np.linspace(0, SS["L"], 11), 2)
    two = pd.concat([df.assign(line="A"), df.assign(line="B")])
    bridge = _modes_csv(tmp_path, two)
    (msg,) = config_errors(bridge, tmp_path)
    assert msg == ("bridge.track_line: missing required key; expected the track line the train "
                   "runs on: one of 'A', 'B' (the file modes.csv has several)"), msg
    (msg,) = config_errors(dict(bridge, track_line="C"), tmp_path)
    assert msg == "bridge.track_line = \"'C'\": expected a track line of modes.csv: 'A', 'B'", msg
    cfg = load_config(base_config(dict(bridge, track_line="B")), base_dir=tmp_path)
    assert cfg.build_bridge().n_modes == 2
    (tmp_path / "empty.nc").write_bytes(b"")
    (msg,) = config_errors({"kind": "modes_file", "file": "empty.nc"}, tmp_path)
    assert msg == 'bridge.file = "empty.nc": expected a netCDF or CSV modes table (the file is ' \
                  'empty)'
    (tmp_path / "junk.nc").write_bytes(b"CDF\x01garbage")
    (msg,) = config_errors({"kind": "modes_file", "file": "junk.nc"}, tmp_path)
    assert msg.startswith('bridge.file = "junk.nc": expected '), msg
    assert "netCDF" in msg or "variables frequency(mode)" in msg, msg
    xr.Dataset({"frequency": ("mode", [1.0])}).to_netcdf(tmp_path / "bad.nc")
    (msg,) = config_errors({"kind": "modes_file", "file": "bad.nc"}, tmp_path)
    assert msg.startswith('bridge.file = "bad.nc": expected variables frequency(mode), '
                          "x(station) and shape(station, mode) (missing: x, shape"), msg


# ------------------------------------------------------------------ bundled examples


def test_imported__bundled_examples_agree():
    """The matrices and the modes table of configs/data describe the same deck."""
    mat = load_config(ROOT / "configs" / "two_span_imported.toml")
    tab = load_config(ROOT / "configs" / "two_span_modes_file.toml")
    assert not mat.warnings and not tab.warnings
    data = mat.resolved()
    data["bridge"]["track_line"] = "track2"
    b_mat = load_config(data, base_dir=mat.base_dir).build_bridge()
    b_tab = tab.build_bridge()
    np.testing.assert_allclose(b_mat.frequencies, b_tab.frequencies, rtol=1e-8)
    xx = np.linspace(0, 40, 401)
    # same FE field (slopes given both ways): round-off of the two eigensolutions
    np.testing.assert_allclose(same_up_to_sign(b_tab.shapes(xx), b_mat.shapes(xx)),
                               b_mat.shapes(xx), atol=1e-9 * np.abs(b_mat.values).max())
    eff = mat.build_bridge().effective_mass_fraction
    assert eff is not None and 0.5 < eff.sum() <= 1.0


def test_imported__vsi_modes_prints_and_plots(tmp_path):
    from typer.testing import CliRunner

    from vsi_numba.cli import app

    png = tmp_path / "modes.png"
    result = CliRunner().invoke(app, ["modes", str(ROOT / "configs" / "two_span_imported.toml"),
                                      "-o", str(png)])
    assert result.exit_code == 0, result.output
    assert "10.88" in result.output and "eff. vertical mass" in result.output
    assert png.stat().st_size > 10_000
    bad = tmp_path / "bad.toml"
    bad.write_text('[bridge]\nkind = "modes_file"\nfile = "none.nc"\n[train]\npreset = "ICE3"\n'
                   "[study]\nspeeds_kmh = [100.0]\n")
    result = CliRunner().invoke(app, ["modes", str(bad)])
    assert result.exit_code == 2


def test_imported__bundled_example_sweeps(tmp_path):
    """``vsi sweep configs/two_span_imported.toml -o X --quiet`` exits 0."""
    out = tmp_path / "x.nc"
    proc = vsi("sweep", ROOT / "configs" / "two_span_imported.toml", "-o", out, "--quiet")
    assert proc.returncode == 0, proc.stderr[-2000:]
    with xr.open_dataset(out) as ds:
        d = ds["max_deck_displacement"].values
        assert np.all(np.isfinite(d)) and np.all(d > 0)


# ------------------------------------------------------------------------ track layer

TRACK = {"rail_EI": 1.28e7, "rail_mass_per_length": 120.6, "pad_stiffness": 2.4e8,
         "pad_damping": 1.0e5, "sleeper_mass": 280.0, "sleeper_spacing": 0.6,
         "ballast_stiffness": 2.0e8, "ballast_damping": 1.2e5}


def test_track__rail_on_rigid_deck_is_a_winkler_beam():
    """Static rail deflection under a unit load vs the Winkler beam P beta / (2 k)."""
    layer = br.TrackLayer(**{**TRACK, "rail_elements_per_bay": 4})
    tm = br.track_matrices([30.0], 1e15, 15000.0, 30, layer)  # practically rigid deck
    free = np.setdiff1d(np.arange(tm.K.shape[0]), tm.fixed)
    k_eff = 1.0 / (1.0 / TRACK["pad_stiffness"] + 1.0 / TRACK["ballast_stiffness"])
    k_w = k_eff / TRACK["sleeper_spacing"]  # smeared foundation modulus, N/m^2
    beta = (k_w / (4 * TRACK["rail_EI"])) ** 0.25
    w_winkler = beta / (2 * k_w)
    s = int(np.argmin(np.abs(tm.sleepers - 15.0)))
    for j in (int(np.searchsorted(tm.rail_nodes, tm.sleepers[s])),  # over a sleeper
              int(np.searchsorted(tm.rail_nodes, tm.sleepers[s])) + 2):  # mid-bay
        dof = tm.rail_dof0 + 2 * j
        f = np.zeros(free.size)
        f[np.searchsorted(free, dof)] = 1.0
        w = np.linalg.solve(tm.K[np.ix_(free, free)], f) @ f
        # discrete pads every 0.6 m vs a continuous foundation: 2 % (0.4 / 0.8 % here)
        assert w == pytest.approx(w_winkler, rel=2e-2)


def test_track__stiff_track_moves_with_the_deck():
    """Very stiff pads and ballast: the deck modes of a beam with the track's mass.

    The rail's EI is made small (1e6 N m^2): the rail is clamped at the deck ends (it
    continues onto the rigid approach track), and the real rail on stiff pads would
    restrain the deck's end rotations (+0.3 % on f1); much smaller, the rail between
    two sleepers resonates near the deck modes (1e4 N m^2: 90 Hz bays).
    """
    stiff = br.TrackLayer(**{**TRACK, "pad_stiffness": 1e13, "ballast_stiffness": 1e13,
                             "rail_EI": 1.0e6})
    b = br.continuous_with_track(TWO["spans"], TWO["EI"], TWO["m"], stiff, n_modes=3,
                                 elements_per_span=40)
    m_tot = TWO["m"] + TRACK["rail_mass_per_length"] + TRACK["sleeper_mass"] / 0.6
    ref = br.continuous(TWO["spans"], TWO["EI"], m_tot, 3, elements_per_span=40)
    # 1e-3 (f1: 5e-4): sleepers as point masses every 0.6 m instead of smeared (4e-4 on
    # mode 3) and the end restraint of the clamped rail (2e-4 on f1); the track mass
    # itself lowers f by 2 %, so this checks the mass and coupling assembly
    np.testing.assert_allclose(b.frequencies, ref.frequencies, rtol=1e-3)
    assert b.frequencies[0] == pytest.approx(ref.frequencies[0], rel=5e-4)
    assert b.deck is not None
    xx = np.linspace(3.0, 37.0, 341)  # away from the clamped rail ends
    # rail and deck move together: 3e-3 of the amplitude (the rail bays between
    # sleepers, ~900 Hz with this EI, follow mode 3 at 33 Hz with (33/900)^2 ~ 0.2 %)
    np.testing.assert_allclose(b.shapes(xx), b.output_shapes(xx),
                               atol=3e-3 * np.abs(b.values).max())


def test_track__flexibility_report_and_modal_damping():
    layer = br.TrackLayer(**TRACK)
    b, rep = br.continuous_with_track(TWO["spans"], TWO["EI"], TWO["m"], layer, n_modes=None,
                                      max_frequency=np.inf, damping_ratio=0.01, report=True)
    # every mode kept: the modal sum is the FE static flexibility (round-off)
    assert rep.flexibility_fraction == pytest.approx(1.0, rel=1e-8)
    assert 80.0 < rep.first_track_frequency < 300.0  # sleepers on pads and ballast
    assert rep.modes_for_95 > 50  # the cost: many track modes for the rail deflection
    few = br.continuous_with_track(TWO["spans"], TWO["EI"], TWO["m"], layer, n_modes=6,
                                   damping_ratio=0.01)
    # deck modes: ~1 % (structural) plus a little from the dashpots; track modes: more
    assert np.all(few.damping >= 0.01) and few.damping[0] < 0.011
    assert b.damping[rep.modes_for_95 - 1] > 0.05


def test_track__config_keys_warning_and_errors(tmp_path):
    bridge = {"kind": "continuous", "spans": [20.0, 20.0], "EI": 7e10,
              "mass_per_length": 15000.0, "n_modes": 10, "track": dict(TRACK)}
    cfg = load_config(base_config(bridge))
    b = cfg.build_bridge()
    assert b.deck is not None and b.n_modes == 10
    assert cfg.resolved()["bridge"]["track"]["rail_elements_per_bay"] == 2
    (warn,) = [w for w in cfg.warnings if w.startswith("bridge.track:")]
    assert "of the static rail deflection under a wheel" in warn and "95% needs" in warn
    errors = config_errors({**bridge, "kind": "simply_supported", "spans": [20.0]}, tmp_path)
    assert any(e.startswith("bridge.track = {") and "no [bridge.track] with kind = "
               "'simply_supported'" in e for e in errors), errors
    errors = config_errors({**bridge, "track": {**TRACK, "sleeper_spacing": 0.0,
                                                "pad_stifness": 1.0}}, tmp_path)
    assert sorted(errors) == sorted([
        "bridge.track.pad_stifness = 1.0: unknown key; did you mean 'pad_stiffness'?",
        "bridge.track.sleeper_spacing = 0.0: expected a sleeper spacing > 0 m"]), errors


def test_track__moving_force_runs_on_the_rail():
    layer = br.TrackLayer(**TRACK)
    b = br.continuous_with_track(TWO["spans"], TWO["EI"], TWO["m"], layer, n_modes=20)
    w = midspan_history(b, 10.0, speed=40.0)
    ref = midspan_history(br.continuous(TWO["spans"], TWO["EI"], TWO["m"], 20), 10.0, 40.0)
    assert np.all(np.isfinite(w))
    # the rail deflects more than the bare deck, by less than the full static track
    # compression under the 100 kN force (Winkler beam, P beta / 2k: 0.38 mm); 10 %:
    # dynamic amplification at 40 m/s
    k_eff = 1.0 / (1.0 / TRACK["pad_stiffness"] + 1.0 / TRACK["ballast_stiffness"])
    k_w = k_eff / TRACK["sleeper_spacing"]
    compression = 1.0e5 * (k_w / (4 * TRACK["rail_EI"])) ** 0.25 / (2 * k_w)
    assert np.max(ref) < np.max(w) < 1.1 * (np.max(ref) + compression)
