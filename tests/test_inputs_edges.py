"""Inputs that must be refused with a clear message (key path, value, expectation) before
anything runs or allocates, and a random track that is the same function of x whatever
range a study asks for.

References: dense ``scipy.linalg.eigvalsh`` of the free-DOF pencil (is K indefinite?),
the closed-form first frequency of a simply supported beam, scipy's periodic
``CubicSpline`` through the same samples, and the published ranges of track values.
"""

from __future__ import annotations

import json
import math
import os
import textwrap

import numpy as np
import pytest
import scipy.interpolate
import scipy.io
import scipy.linalg
import scipy.sparse
import xarray as xr

from vsi_numba.config import ConfigError, load_config
from vsi_numba.config.limits import MAX_CONFIG_BYTES, MAX_OUTPUT_POINTS
from vsi_numba.model.psd import PSD_PERIOD, psd_profile, psd_realisation

BASE = """
title = "B"
[bridge]
kind = "simply_supported"
spans = [25.0]
EI = 8.323e9
mass_per_length = 2303.0
damping_ratio = 0.01
n_modes = 3
[[train.vehicles]]
kind = "sprung_mass"
mass = 5750.0
stiffness = 1.595e6
damping = 0.0
[solver]
dt = 1e-3
free_vibration = 0.5
[study]
speeds_kmh = [150.0, 200.0]
"""


def _cfg(tmp_path, extra="", name="c.toml", base=BASE):
    p = tmp_path / name
    p.write_text(textwrap.dedent(base) + textwrap.dedent(extra))
    return p


def _errors(path) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(path)
    return info.value.errors


# ------------------------------------------------------------------ imported K and M


L, EI, M_PER_L = 25.0, 8.323e9, 2303.0


def _beam(ne=10):
    """K, M of a simply supported Hermite beam (our own element matrices), supports."""
    n = 2 * (ne + 1)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    h = L / ne
    k = EI / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                              [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    m = M_PER_L * h / 420 * np.array([[156, 22 * h, 54, -13 * h],
                                      [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                      [54, 13 * h, 156, -22 * h],
                                      [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    for e in range(ne):
        d = slice(2 * e, 2 * e + 4)
        K[d, d] += k
        M[d, d] += m
    return K, M, np.linspace(0.0, L, ne + 1), [0, 2 * ne]


def _matrices(tmp_path, K, M, x, fixed):
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(K))
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(M))
    (tmp_path / "st.csv").write_text("x,dof,rotation_dof\n" + "".join(
        f"{float(xi)!r},{2 * i},{2 * i + 1}\n" for i, xi in enumerate(x)))
    return {"title": "m", "bridge": {"kind": "matrices", "stiffness_matrix": "K.mtx",
                                     "mass_matrix": "M.mtx", "station_map": "st.csv",
                                     "fixed_dofs": fixed, "n_modes": 3},
            "train": {"vehicles": [{"kind": "force", "load": 1e5}]},
            "solver": {"dt": 2e-3, "free_vibration": 0.2},
            "study": {"speeds_kmh": [100.0]}}


def _matrix_errors(tmp_path, K, M, x, fixed):
    with pytest.raises(ConfigError) as info:
        load_config(_matrices(tmp_path, K, M, x, fixed), base_dir=tmp_path)
    return info.value.errors


def _free_pencil_min(K, M, fixed):
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    return scipy.linalg.eigvalsh(K[np.ix_(free, free)], M[np.ix_(free, free)])[0]


def test_matrices__good_beam_is_accepted_with_the_closed_form_f1(tmp_path):
    """The unmodified beam loads; f1 within 1e-4 of pi/(2 L^2) sqrt(EI/m) = 4.778 Hz
    (10 Hermite elements: discretisation error 6.7e-6 measured, O(h^4))."""
    K, M, x, fixed = _beam()
    cfg = load_config(_matrices(tmp_path, K, M, x, fixed), base_dir=tmp_path)
    f1 = math.pi / (2 * L**2) * math.sqrt(EI / M_PER_L)
    assert cfg.build_bridge().frequencies[0] == pytest.approx(f1, rel=1e-4)


@pytest.mark.parametrize("how", ["negated_diagonal", "raised_pair", "mildly_raised_pair"])
def test_matrices__indefinite_stiffness_is_refused(tmp_path, how):
    """A K that is not positive semi-definite on the free DOFs (proved here by a negative
    eigenvalue of the dense free-DOF pencil) is refused naming bridge.stiffness_matrix,
    whether the eigensolver near 0 would see the negative mode or not (it gave a plausible
    but wrong f1 before)."""
    K, M, x, fixed = _beam()
    K = K.copy()
    if how == "negated_diagonal":
        K[6, 6] = -K[6, 6]
    else:
        f = 3.0 if how == "raised_pair" else 1.3
        K[6, 8] *= f
        K[8, 6] *= f
    assert _free_pencil_min(K, M, fixed) < 0  # the reference: indefinite indeed
    (msg,) = _matrix_errors(tmp_path, K, M, x, fixed)
    assert msg.startswith('bridge.stiffness_matrix = "K.mtx": expected a positive '
                          "semi-definite stiffness matrix on the free DOFs"), msg


def test_matrices__complex_matrix_is_refused(tmp_path):
    K, M, x, fixed = _beam()
    cfg = _matrices(tmp_path, K, M, x, fixed)
    Kc = K.astype(complex)
    Kc[2, 2] += 1e3j
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(Kc))
    with pytest.raises(ConfigError) as info:
        load_config(cfg, base_dir=tmp_path)
    (msg,) = info.value.errors
    assert msg.startswith('bridge.stiffness_matrix = "K.mtx": expected a real matrix (the '
                          "file holds complex entries, e.g. (2, 2)"), msg


@pytest.mark.parametrize("how", ["scaled", "swapped"])
def test_matrices__units_or_swap_not_blamed_on_the_supports(tmp_path, how):
    """K scaled by 1e-12 (f1 = 4.8e-6 Hz) or K and M swapped: every mode is low and none
    is a rigid-body mode, so the message names the stiffness matrix, the mass matrix and
    the units/swap, not bridge.fixed_dofs (supports are there: the same beam loads)."""
    K, M, x, fixed = _beam()
    K2, M2 = (K * 1e-12, M) if how == "scaled" else (M, K)
    (msg,) = _matrix_errors(tmp_path, K2, M2, x, fixed)
    assert msg.startswith('bridge.stiffness_matrix = "K.mtx": expected a stiffness matrix in '
                          "SI units that, with the mass matrix M.mtx"), msg
    assert "fixed_dofs" not in msg and "no rigid-body gap" in msg
    if how == "swapped":
        assert "not swapped" in msg


def test_matrices__missing_supports_still_blamed_on_fixed_dofs(tmp_path):
    """A real mechanism (no supports: two rigid-body modes at round-off) keeps the
    fixed_dofs message."""
    K, M, x, _ = _beam()
    (msg,) = _matrix_errors(tmp_path, K, M, x, [])
    assert msg.startswith("bridge.fixed_dofs = []: expected supports that stop every "
                          "rigid-body motion: 2 mode(s)"), msg


# ------------------------------------------------------------------ random track


def test_psd__same_seed_same_track_bit_for_bit_whatever_the_range():
    """Three ranges, one past the 8192 m period (a long train): the same seed gives the
    same r, r', r'' bit for bit on the common x (before: another period past 8192 m, and
    ~1e-14 differences from the spline ends within it)."""
    args = ("german_low", 2.0, 60.0, 11)
    ranges = [(-250.0, 400.0), (-655.0, 1200.0), (-9000.0, 3000.0)]
    profiles = [psd_profile(*args, a, b) for a, b in ranges]
    x = np.linspace(-200.0, 350.0, 20001)
    for k in range(3):
        ref = profiles[0](x, k)
        for p in profiles[1:]:
            np.testing.assert_array_equal(p(x, k), ref)
    assert np.abs(profiles[0](x)).max() > 1e-4
    # beyond one period the track repeats: the same spline coefficients one period on
    p = profiles[2]
    n = round(PSD_PERIOD / p.dx)
    np.testing.assert_array_equal(p.coef[:100], p.coef[n:n + 100])


def test_psd__profile_is_the_periodic_spline_through_the_samples():
    """The Fourier-domain spline equals scipy's periodic CubicSpline through one period
    of the same samples: 1e-12 of the peak in r and 1e-9 in r'' (two solvers of the same
    cyclic system; round-off of ~1e5 unknowns)."""
    x, r, period = psd_realisation("german_low", 3.0, 60.0, 4, 0.0, 8192.0)
    assert period == PSD_PERIOD and x[-1] == period
    spl = scipy.interpolate.CubicSpline(x, np.append(r[:-1], r[0]), bc_type="periodic")
    prof = psd_profile("german_low", 3.0, 60.0, 4, 0.0, 8192.0)
    xs = np.linspace(10.0, 8180.0, 50001)
    for k, tol in ((0, 1e-12), (1, 1e-10), (2, 1e-9)):
        ref = spl(xs, k)
        np.testing.assert_allclose(prof(xs, k), ref, rtol=0, atol=tol * np.abs(ref).max())


def test_psd__study_long_range_warns_that_the_track_repeats(tmp_path):
    """A track range longer than the period (free vibration of 40 s at the 1000 km/h
    bound: 11 km) is legal but said: the track repeats every 8192 m."""
    cfg = load_config(_cfg(tmp_path, base=BASE.replace("free_vibration = 0.5",
                                                       "free_vibration = 40.0"), extra="""
        [irregularity]
        kind = "psd"
        spectrum = "german_low"
        wavelength_min = 3.0
        wavelength_max = 60.0
        seeds = [1]
    """))
    assert any("the track repeats every 8192 m" in w for w in cfg.warnings), cfg.warnings


# ------------------------------------------------------------------ track ranges


@pytest.mark.parametrize("key, value", [("foundation_stiffness", 7500.0),
                                        ("rail_EI", 1.9e19),
                                        ("foundation_stiffness", 7.5e13),
                                        ("rail_EI", 1.9e-11)])
def test_track__values_outside_physical_ranges_are_refused(tmp_path, key, value):
    """Each [track] value is judged by its own physical range (the axle stiffness of
    foundation 7500 with rail_EI 1.9e19 is plausible, but no track has either)."""
    errs = _errors(_cfg(tmp_path, f"[track]\n{key} = {value!r}\n"))
    assert any(e.startswith(f"track.{key} = {value:g}: expected ") and "allow_implausible"
               in e for e in errs), errs


def test_track__review_pair_and_extremes(tmp_path):
    """foundation 7500 + rail_EI 1.9e19 (deck acceleration 0 before) is refused; the
    extremes 7.5e13 / 1.9e-11 are refused even with allow_implausible, by the size of the
    rail filter (1.5e8 nodes: it allocated 9 GB before)."""
    errs = _errors(_cfg(tmp_path, "[track]\nfoundation_stiffness = 7500\nrail_EI = 1.9e19\n"))
    assert len(errs) == 2
    errs = _errors(_cfg(tmp_path, base=BASE.replace("[solver]", "[solver]\n"
                                                    "allow_implausible = true"),
                        extra="[track]\nfoundation_stiffness = 7.5e13\nrail_EI = 1.9e-11\n"))
    (msg,) = errs
    assert "the rail filter of the mode shapes needs 1.5e+08 rail nodes" in msg


def test_track__default_and_realistic_values_accepted(tmp_path):
    for k, ei in ((8.511e7, 1.283e7), (3e7, 7.6e6), (6e8, 1.283e7)):
        load_config(_cfg(tmp_path, f"[track]\nfoundation_stiffness = {k}\nrail_EI = {ei}\n"))


# ------------------------------------------------------------------ sizes


def test_vary__product_counted_in_python_integers(tmp_path):
    """64 varied keys of 2 values: 2^64 variants wrapped to 0 in np.prod and passed the
    cap; now refused by name with the exact count."""
    keys = "\n".join(f'"bridge.damping_ratio_{i}" = [0.01, 0.02]' for i in range(64))
    errs = _errors(_cfg(tmp_path, "[study.vary]\n" + keys + "\n"))
    assert any(e.startswith(f'study.vary = "{2**64} variants": expected at most') for e in
               errs), errs


def test_runs__total_count_refused_before_building(tmp_path):
    """4000 variants x 2 speeds x 300 seeds = 2.4e6 runs: refused with the product."""
    errs = _errors(_cfg(tmp_path, f"""
        [irregularity]
        kind = "psd"
        spectrum = "german_low"
        wavelength_min = 3.0
        wavelength_max = 60.0
        seeds = {list(range(300))}
        [study.vary]
        "bridge.damping_ratio" = {[0.01 + 1e-6 * i for i in range(4000)]}
    """))
    (msg,) = errs
    assert msg.startswith("study: 2400000 runs (4000 variants x 2 speeds x 1 trains x 300 "
                          "irregularity realisations): expected at most"), msg


def test_config__fifo_device_and_huge_files_are_refused(tmp_path):
    """A FIFO (hung before), a character device (/dev/zero: 23.7 GB before) and a file
    over the size budget: one clear line each, nothing read beyond the budget."""
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    (msg,) = _errors(fifo)
    assert msg == f"{fifo}: is a FIFO (named pipe), not a regular file; expected a TOML " \
                  "configuration file"
    (msg,) = _errors("/dev/zero")
    assert msg.startswith("/dev/zero: is a character device, not a regular file")
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(MAX_CONFIG_BYTES + 1)
    (msg,) = _errors(big)
    assert msg.startswith(f"{big}: is {MAX_CONFIG_BYTES + 1} bytes, more than the "
                          f"{MAX_CONFIG_BYTES} bytes")


def test_output_points__count_budget(tmp_path):
    pts = ", ".join(f"{25.0 * i / 200_000!r}" for i in range(200_000))
    base = BASE.replace("n_modes = 3", f"n_modes = 3\noutput_points = [{pts}]")
    (msg,) = _errors(_cfg(tmp_path, base=base))
    assert msg.startswith("bridge.output_points = [0.0, ") and \
        f"expected a list of at most {MAX_OUTPUT_POINTS} positions" in msg


@pytest.mark.parametrize("extra", ["", "allow_large_problem = true\n"])
def test_offsets__first_vehicle_far_behind_is_in_the_budget(tmp_path, extra):
    """A single vehicle at offset 1e12 m (train length 0 but its axle 1e12 m behind):
    2.4e13 time steps, refused by the hard budget even with allow_large_problem (a
    MemoryError traceback before)."""
    base = BASE.replace("damping = 0.0", "damping = 0.0\noffset = 1e12").replace(
        "[solver]", "[solver]\n" + extra)
    (msg,) = _errors(_cfg(tmp_path, base=base))
    assert msg.startswith("the slowest run needs 2.4e+13 time steps, more than the hard "
                          "budget"), msg


# ------------------------------------------------------------------ variants


def test_vary__trains_and_seeds_are_not_variants(tmp_path):
    """Varying train.preset or irregularity.seeds: exit-2 configuration errors naming the
    key and what to do (exit 1 with a dict repr before)."""
    (msg,) = _errors(_cfg(tmp_path, '[study.vary]\n"train.preset" = ["HSLM-A1", "HSLM-A2"]\n'))
    assert msg.startswith('study.vary["train.preset"] = "train.preset": expected a key path '
                          "that is not an axis of the study: list several trains"), msg
    (msg,) = _errors(_cfg(tmp_path, '[study.vary]\n"irregularity.seeds" = [[1], [2]]\n'))
    assert "list several seeds in irregularity.seeds" in msg, msg
    (msg,) = _errors(_cfg(tmp_path, '[study.vary]\n"train.name" = ["a", "b"]\n'))
    assert msg.startswith('study.vary (variant 1: train.name = "b"): changes the trains (b '
                          "instead of a)"), msg


def test_report__rerun_applies_the_run_budgets(tmp_path):
    """A results file whose config_json asks for a run beyond the budgets with
    allow_large_problem: the report's re-run is refused (it hung before), by the same
    budget as `vsi run`."""
    from vsi_numba.analysis.recompute import CaseRunner, RecomputeError

    cfg = load_config(_cfg(tmp_path))
    data = cfg.resolved()
    data["solver"].update(dt=1e-6, free_vibration=100.0, allow_large_problem=True)
    ds = xr.Dataset(coords={"point": [12.5]}, attrs={"config_json": json.dumps(data)})
    with pytest.raises(RecomputeError, match="budget"):
        CaseRunner(ds, base_dir=tmp_path).run("B", 150 / 3.6)


def test_train_file__size_budget(tmp_path):
    """A user train file over the configuration size budget is refused unread."""
    big = tmp_path / "trains.toml"
    with open(big, "wb") as fh:
        fh.truncate(MAX_CONFIG_BYTES + 1)
    base = BASE.replace('[[train.vehicles]]\nkind = "sprung_mass"\nmass = 5750.0\n'
                        'stiffness = 1.595e6\ndamping = 0.0\n', '[train]\nfile = "trains.toml"\n')
    (msg,) = _errors(_cfg(tmp_path, base=base))
    assert msg == (f'train.file = "trains.toml": expected a user train file of at most '
                   f"{MAX_CONFIG_BYTES} bytes (it has {MAX_CONFIG_BYTES + 1})")
