"""Checks, statistics and layout handling of vsi_numba.analysis on datasets whose answers
are set by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats
import xarray as xr

from vsi_numba.analysis import checks
from vsi_numba.analysis.dataset import ResultsError, nanmax, prepare
from vsi_numba.analysis.statistics import realisation_statistics, wilks_sample_size
from vsi_numba.analysis.synthetic import synthetic_results

TRAINS = (("A", 18.0, 6, "standard"), ("B", 21.0, 4, "suspect"))


def _ds(**kw) -> xr.Dataset:
    kw.setdefault("speeds_kmh", (200.0, 250.0, 300.0))
    kw.setdefault("trains", TRAINS)
    kw.setdefault("n_vehicles", 2)
    return synthetic_results(**kw)


def _set(ds, name, value, **where):
    """ds[name].loc[where] = value, with speeds given in km/h as ``kmh``."""
    if "kmh" in where:
        where["speed"] = ds["speed"].values[np.isclose(ds["speed_kmh"].values,
                                                       where.pop("kmh"))][0]
    ds[name].loc[where] = value


# --- deck acceleration ------------------------------------------------------------------


def test_deck_acceleration_check__governing_case_and_margin_by_construction():
    ds = _ds()
    ds["max_deck_acceleration"][:] = 1.0
    _set(ds, "max_deck_acceleration", 4.2, kmh=250.0, train="B", point=10.0)
    _set(ds, "max_deck_acceleration", 3.0, kmh=300.0, train="A", point=5.0)
    out = checks.deck_acceleration_check(ds)
    a = out.attrs
    assert a["limit"] == 3.5  # ballasted, EN 1990 A2.4.4.2.1
    assert a["governing_train"] == "B"
    assert a["governing_speed_kmh"] == pytest.approx(250.0)
    assert a["governing_point"] == 10.0
    assert a["value"] == pytest.approx(4.2)
    assert a["margin"] == pytest.approx(-0.7)
    assert a["utilisation"] == pytest.approx(1.2)
    assert a["result"] == "FAIL"
    # per speed and train: max over points
    assert float(out["value"].sel(train="A").isel(speed=2)) == pytest.approx(3.0)
    assert float(out["margin"].sel(train="A").isel(speed=2)) == pytest.approx(0.5)
    assert bool(out["passed"].sel(train="A").isel(speed=2))
    assert not bool(out["passed"].sel(train="B").isel(speed=1))


def test_deck_acceleration_check__direct_fastening_limit_and_explicit_limit():
    ds = _ds(track_type="direct_fastening")
    ds["max_deck_acceleration"][:] = 1.0
    _set(ds, "max_deck_acceleration", 4.2, kmh=250.0, train="B", point=10.0)
    a = checks.deck_acceleration_check(ds).attrs
    assert a["limit"] == 5.0 and a["result"] == "pass"
    assert a["margin"] == pytest.approx(0.8)
    assert checks.deck_acceleration_check(ds, limit=4.0).attrs["result"] == "FAIL"


def test_deck_acceleration_check__missing_track_type_defaults_to_ballasted():
    ds = _ds()
    assert checks.deck_acceleration_check(ds).attrs["track_type_assumed"] == 0
    del ds.attrs["track_type"]
    a = checks.deck_acceleration_check(ds).attrs
    assert a["limit"] == 3.5 and a["track_type_assumed"] == 1
    ds.attrs["track_type"] = "unspecified"  # what the study runner writes when not given
    assert checks.deck_acceleration_check(ds).attrs["limit"] == 3.5


@pytest.mark.parametrize(("attr", "limit"), [("Ballasted", 3.5), ("ballastless", 5.0),
                                             ("slab", 5.0), ("direct_fastened", 5.0)])
def test_deck_acceleration_check__track_type_aliases(attr, limit):
    assert checks.deck_acceleration_check(_ds(track_type=attr)).attrs["limit"] == limit


def test_deck_acceleration_check__unknown_track_type_is_a_results_error():
    with pytest.raises(ResultsError, match="track_type"):
        checks.deck_acceleration_check(_ds(track_type="timber trestle"))


def test_deck_acceleration_check__characteristic_value_over_realisations():
    ds = _ds(seeds=(1, 2, 3, 4, 5))
    ds["max_deck_acceleration"][:] = 0.5
    for k, seed in enumerate((1, 2, 3, 4, 5)):
        _set(ds, "max_deck_acceleration", float(k + 1), kmh=300.0, train="A",
             irregularity=seed, point=10.0)
    out = checks.deck_acceleration_check(ds, n_boot=200)
    # numpy 'linear' 95 % fractile of 1..5: 1 + 0.95 * 4 = 4.8
    assert out.attrs["value"] == pytest.approx(4.8)
    assert out.attrs["governing_irregularity"] == 5
    case = out.sel(train="A").isel(speed=2)
    assert int(case["n"]) == 5
    assert float(case["mean"]) == pytest.approx(3.0)
    assert float(case["exceedance_probability"]) == pytest.approx(0.4)  # 4 and 5 > 3.5


def test_deck_acceleration_check__deterministic_and_random_takes_the_worse():
    ds = _ds(seeds=(-1, 1, 2))
    ds["max_deck_acceleration"][:] = 1.0
    _set(ds, "max_deck_acceleration", 2.0, irregularity=-1)
    out = checks.deck_acceleration_check(ds, n_boot=50)
    assert out.attrs["value"] == pytest.approx(2.0)
    assert "deterministic" in out.attrs["basis"]


def test_deck_acceleration_check__failed_cases_are_ignored():
    ds = _ds()
    ds["max_deck_acceleration"][:] = 1.0
    _set(ds, "max_deck_acceleration", 9.0, kmh=200.0, train="A")  # garbage of a failed case
    _set(ds, "status", 3, kmh=200.0, train="A")
    out = checks.deck_acceleration_check(ds)
    assert out.attrs["value"] == pytest.approx(1.0)
    assert np.isnan(float(out["value"].sel(train="A").isel(speed=0)))


@pytest.mark.parametrize(
    ("freqs", "expected"),
    [
        ((5.0, 20.0, 45.0), 45.0),  # f3 governs
        ((25.0, 60.0, 100.0, 160.0), 100.0),
        ((30.0, 35.0, 40.0), 45.0),  # 1.5 f1 governs
        ((3.0, 12.0, 27.0), 30.0),  # the 30 Hz floor governs
        ((45.0, 5.0, 20.0), 45.0),  # any order
        ((2.0,), 30.0),  # f3 unknown
        ((), 30.0),
    ],
)
def test_frequency_cutoff__max_of_30hz_1p5f1_f3(freqs, expected):
    assert checks.frequency_cutoff(freqs) == pytest.approx(expected)


def test_deck_acceleration_check__reports_cutoff_from_frequencies():
    a = checks.deck_acceleration_check(_ds(frequencies=(4.0, 16.0, 36.0, 64.0))).attrs
    assert a["frequency_cutoff"] == pytest.approx(36.0)
    assert a["highest_frequency"] == pytest.approx(64.0)


# --- dynamic amplification --------------------------------------------------------------


def test_dynamic_amplification__phi_dyn_from_known_static_and_dynamic_values():
    ds = _ds(n_points=3, bridge_length=20.0, frequencies=(5.0, 20.0, 45.0))
    ds["max_static_deck_displacement"][:] = [1.0e-3, 2.0e-3, 1.0e-3]  # both trains
    ds["max_deck_displacement"][:] = 1.5e-3  # phi = 0.5 at the quarter points, -0.25 mid
    _set(ds, "max_deck_displacement", 3.0e-3, kmh=250.0, train="B", point=10.0)
    out = checks.dynamic_amplification(ds)
    phi = out["phi_dyn"].sel(train="B")
    assert float(phi.isel(speed=1).sel(point=10.0)) == pytest.approx(0.5)
    assert float(phi.isel(speed=0).sel(point=5.0)) == pytest.approx(0.5)
    assert float(phi.isel(speed=0).sel(point=10.0)) == pytest.approx(-0.25)
    # deck value: max dyn / max static - 1
    assert float(out["value"].sel(train="B").isel(speed=1)) == pytest.approx(0.5)
    assert float(out["value"].sel(train="A").isel(speed=1)) == pytest.approx(-0.25)
    assert float(out["phi_dyn_max"].sel(train="B", point=10.0)) == pytest.approx(0.5)
    assert out.attrs["governing_train"] == "B"
    assert out.attrs["value"] == pytest.approx(0.5)
    assert out.attrs["result"] == "info"
    # phi'' with L = 20 m, n0 = 5 Hz; 200 km/h > 22 m/s so a = 1
    phi2 = 0.56 * math.exp(-4.0) + 0.50 * (5.0 * 20.0 / 80.0 - 1.0) * math.exp(-1.0)
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(phi2)
    assert float(out["design_factor"].sel(train="B").isel(speed=1)) == pytest.approx(
        1.0 + 0.5 + phi2 / 2)
    assert "deterministic" in out.attrs["basis"]


def test_irregularity_allowance__speed_factor_and_non_negative():
    L, n0 = 10.0, 8.0
    full = 0.56 * math.exp(-1.0) + 0.50 * (n0 * L / 80.0 - 1.0) * math.exp(-0.25)
    v = np.array([11.0, 22.0, 80.0])
    np.testing.assert_allclose(checks.irregularity_allowance(v, L, n0),
                               [0.5 * full, full, full], rtol=1e-12)  # a = min(v/22, 1)
    # long span, low frequency: the bracket is negative, phi'' = 0
    assert checks.irregularity_allowance(50.0, 40.0, 1.0) == 0.0


def test_dynamic_amplification__missing_static_response_is_a_results_error():
    ds = _ds().drop_vars("max_static_deck_displacement")
    with pytest.raises(ResultsError, match="max_static_deck_displacement"):
        checks.dynamic_amplification(ds)


# --- wheel unloading --------------------------------------------------------------------


def test_wheel_unloading__governing_wheel_limit_and_padding():
    ds = _ds()
    assert np.isnan(ds["max_wheel_unloading"].sel(train="B", wheel=5)).all()  # 4 wheels
    ds["max_wheel_unloading"] = ds["max_wheel_unloading"].where(
        ds["max_wheel_unloading"].isnull(), 0.1)
    _set(ds, "max_wheel_unloading", 0.72, kmh=300.0, train="A", wheel=3)
    _set(ds, "min_contact_force", 10e3, kmh=300.0, train="A", wheel=3)
    _set(ds, "contact_loss_duration", 0.02, kmh=300.0, train="A", wheel=3)
    _set(ds, "contact_loss_count", 2.0, kmh=300.0, train="A", wheel=3)
    out = checks.wheel_unloading(ds)
    a = out.attrs
    assert a["limit"] == 0.6
    assert (a["governing_train"], a["governing_wheel"]) == ("A", 3)
    assert a["governing_speed_kmh"] == pytest.approx(300.0)
    assert a["value"] == pytest.approx(0.72)
    assert a["margin"] == pytest.approx(-0.12)
    assert a["result"] == "FAIL"
    assert a["min_contact_force"] == pytest.approx(10e3)
    assert a["max_contact_loss_duration"] == pytest.approx(0.02)
    assert a["max_contact_loss_count"] == pytest.approx(2.0)
    assert float(out["wheels_losing_contact"].sel(train="A").isel(speed=2)) == 1.0
    assert float(out["value"].sel(train="B").isel(speed=0)) == pytest.approx(0.1)


# --- comfort ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("bv", "level"),
    [(0.4, "very good"), (1.0, "very good"), (1.2, "good"), (1.9, "acceptable"),
     (2.5, "not acceptable"), (np.nan, "n/a")],
)
def test_comfort_level__en1990_table_a29_levels(bv, level):
    assert checks.comfort_level(bv) == level


def test_comfort__required_level_and_governing_case():
    ds = _ds()
    ds["max_carbody_acceleration"][:] = 0.5
    _set(ds, "max_carbody_acceleration", 1.2, kmh=200.0, train="A", vehicle=1)
    out = checks.comfort(ds)
    assert out.attrs["result"] == "FAIL" and out.attrs["level"] == "good"
    assert out.attrs["governing_train"] == "A"
    assert out["level"].sel(train="B").isel(speed=0).item() == "very good"
    good = checks.comfort(ds, required="good")
    assert good.attrs["result"] == "pass"
    assert good.attrs["margin"] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="required comfort level"):
        checks.comfort(ds, required="excellent")


def test_comfort__moving_force_model_without_car_bodies_is_not_applicable():
    ds = _ds(n_vehicles=0)
    out = checks.comfort(ds)
    assert out.attrs["result"] == "n/a"
    assert out["value"].isnull().all()


# --- resonance speeds -------------------------------------------------------------------


def test_resonance_speeds__f_D_over_i():
    res = checks.resonance_speeds(5.0, 18.0, k_max=4)
    np.testing.assert_allclose(res["speed"], [90.0, 45.0, 30.0, 22.5])
    np.testing.assert_allclose(res["speed_kmh"], [324.0, 162.0, 108.0, 81.0])
    assert list(res["i"]) == [1, 2, 3, 4]
    assert checks.resonance_speeds(5.0, 0.0).empty
    assert checks.resonance_speeds(np.nan, 18.0).empty


# --- statistics -------------------------------------------------------------------------


def test_realisation_statistics__bootstrap_ci_covers_the_true_fractile():
    # 100 independent normal samples of n = 400: the 95 % CI of the 95 % fractile should
    # cover mu + 1.645 sigma in about 95 % of them. Binomial sd of the coverage over 100
    # cells is 2.2 %; accept 85-100 % (4.5 sd below, allowing the bootstrap's small-sample
    # undercoverage).
    rng = np.random.default_rng(42)
    mu, sigma = 2.0, 0.5
    da = xr.DataArray(rng.normal(mu, sigma, (100, 400)), dims=("cell", "irregularity"))
    st = realisation_statistics(da, q=0.95, n_boot=1000, seed=1)
    true = mu + sigma * scipy.stats.norm.ppf(0.95)
    covered = ((st["ci_low"] <= true) & (true <= st["ci_high"])).mean().item()
    assert 0.85 <= covered <= 1.0
    assert (st["n"] == 400).all()
    # the sample fractile is within a few standard errors of the truth on average
    assert abs(float(st["characteristic"].mean()) - true) < 0.02  # se of the mean ~ 0.004


def test_realisation_statistics__single_large_sample_ci_contains_true_fractile():
    rng = np.random.default_rng(7)
    da = xr.DataArray(rng.normal(0.0, 1.0, 5000), dims="irregularity")
    st = realisation_statistics(da, q=0.95, n_boot=2000, seed=0, limit=1.0)
    true = scipy.stats.norm.ppf(0.95)
    assert float(st["ci_low"]) <= true <= float(st["ci_high"])
    assert float(st["ci_high"] - st["ci_low"]) < 0.2  # se ~ 0.03 for n = 5000
    # P(X > 1) = 0.1587: empirical se ~ 0.005, normal fit closer
    assert float(st["exceedance_probability"]) == pytest.approx(0.1587, abs=0.02)
    assert float(st["exceedance_probability_normal"]) == pytest.approx(0.1587, abs=0.01)


def test_realisation_statistics__n1_degrades_gracefully():
    da = xr.DataArray([[3.0], [4.0]], dims=("speed", "irregularity"))
    st = realisation_statistics(da, limit=3.5)
    np.testing.assert_array_equal(st["characteristic"], [3.0, 4.0])
    np.testing.assert_array_equal(st["mean"], [3.0, 4.0])
    np.testing.assert_array_equal(st["n"], [1, 1])
    assert st["std"].isnull().all() and st["ci_low"].isnull().all()
    assert st["ci_high"].isnull().all() and st["exceedance_probability_normal"].isnull().all()
    np.testing.assert_array_equal(st["exceedance_probability"], [0.0, 1.0])
    # no realisation dim at all: one realisation
    st = realisation_statistics(xr.DataArray([1.0, 2.0], dims="speed"))
    np.testing.assert_array_equal(st["characteristic"], [1.0, 2.0])


def test_realisation_statistics__nan_realisations_left_out_per_cell():
    da = xr.DataArray([[1.0, 2.0, np.nan, 4.0], [np.nan] * 4], dims=("speed", "irregularity"))
    st = realisation_statistics(da, q=0.5, n_boot=100)
    assert int(st["n"][0]) == 3 and int(st["n"][1]) == 0
    assert float(st["characteristic"][0]) == 2.0  # median of 1, 2, 4
    assert float(st["std"][0]) == pytest.approx(np.std([1, 2, 4], ddof=1))
    assert st.isel(speed=1)["characteristic"].isnull()


def test_realisation_statistics__reproducible_and_validated():
    da = xr.DataArray(np.random.default_rng(0).normal(size=(3, 20)),
                      dims=("speed", "irregularity"))
    a = realisation_statistics(da, seed=5, n_boot=300)
    b = realisation_statistics(da, seed=5, n_boot=300)
    xr.testing.assert_identical(a, b)
    assert realisation_statistics(da, n_boot=0)["ci_low"].isnull().all()
    with pytest.raises(ValueError, match="q must"):
        realisation_statistics(da, q=1.0)


def test_wilks_sample_size__59_for_95_95():
    assert wilks_sample_size(0.95, 0.95) == 59  # 1 - 0.95**59 = 0.952 >= 0.95 > 1 - 0.95**58
    assert 1 - 0.95**58 < 0.95 <= 1 - 0.95**59


# --- layout -----------------------------------------------------------------------------


def _single_run(ds: xr.Dataset) -> xr.Dataset:
    """A `vsi run` style file: no train/irregularity dims, train vars on their own dims."""
    one = ds.isel(train=0, irregularity=0)
    return one.drop_vars(["train", "irregularity"])


def test_prepare__single_run_file_gets_train_and_irregularity_dims():
    one = _single_run(_ds(histories=True, n_time=50))
    assert "train" not in one.dims and "irregularity" not in one.dims
    ds = prepare(one)
    assert ds["max_deck_acceleration"].dims == ("speed", "train", "irregularity", "point")
    assert ds["deck_acceleration"].dims[:3] == ("speed", "train", "irregularity")
    assert ds["static_wheel_load"].dims == ("train", "wheel")
    assert ds["frequency"].dims == ("mode",)
    assert ds["irregularity"].values.tolist() == [-1]
    assert prepare(ds) is ds  # idempotent
    a = checks.deck_acceleration_check(one).attrs
    assert a["governing_train"] == "train" and np.isfinite(a["value"])


def test_prepare__vsi_run_layout_names_in_attrs_and_train_props_as_coords():
    # `vsi run` writes the train name, data status and realisation as global attrs and
    # static_wheel_load as a coordinate on (wheel)
    one = _single_run(_ds()).drop_vars(["train_status", "train_regular_length",
                                        "max_static_deck_displacement"])
    one = one.set_coords("static_wheel_load")
    one.attrs.update(train="ICE 3", train_status="reconstruction", irregularity=-1)
    ds = prepare(one)
    assert ds["train"].values.tolist() == ["ICE 3"]
    assert ds["train_status"].dims == ("train",)
    assert ds["train_status"].values.tolist() == ["reconstruction"]
    assert ds["static_wheel_load"].dims == ("train", "wheel")
    assert ds["status"].dims == ("speed", "train", "irregularity")
    assert "dynamic_amplification" in checks.run_checks(ds, n_boot=0)


def test_wheel_unloading__moving_force_model_is_not_applicable():
    ds = _ds()
    ds["max_wheel_unloading"] = ds["max_wheel_unloading"] * 0.0
    q0 = ds["static_wheel_load"].broadcast_like(ds["min_contact_force"])
    ds["min_contact_force"] = q0.transpose(*ds["min_contact_force"].dims)
    ds["max_contact_force"] = ds["min_contact_force"].copy()
    a = checks.wheel_unloading(ds).attrs
    assert a["result"] == "n/a" and "moving-force" in a["note"]
    assert a["governing_train"] == "" and np.isnan(a["value"])
    assert checks.wheel_unloading(_ds()).attrs["result"] in ("pass", "FAIL")


def test_prepare__scalar_train_coordinate_and_unsorted_speeds():
    one = _ds().isel(train=1, irregularity=0).isel(speed=[2, 0, 1])
    ds = prepare(one)
    assert ds["train"].values.tolist() == ["B"]
    assert np.all(np.diff(ds["speed"].values) > 0)
    np.testing.assert_allclose(ds["speed_kmh"], [200.0, 250.0, 300.0])


def test_prepare__adds_speed_kmh_and_requires_speed():
    ds = _ds().drop_vars("speed_kmh")
    np.testing.assert_allclose(prepare(ds)["speed_kmh"], [200.0, 250.0, 300.0])
    with pytest.raises(ResultsError, match="speed"):
        prepare(xr.Dataset({"x": ("point", [1.0])}))


def test_nanmax__all_nan_and_empty_without_warnings():
    da = xr.DataArray([[np.nan, np.nan], [1.0, np.nan]], dims=("a", "b"))
    out = nanmax(da, "b")
    assert np.isnan(out[0]) and out[1] == 1.0
    empty = xr.DataArray(np.zeros((2, 0)), dims=("a", "b"))
    assert nanmax(empty, "b").isnull().all()


def test_summary_table__one_row_per_check():
    ds = _ds()
    table = checks.summary_table(checks.run_checks(ds, n_boot=50))
    assert list(table.columns) == checks.SUMMARY_COLUMNS
    assert table["check"].tolist() == [
        "Peak deck acceleration", "Max deck displacement", "Dynamic increment φ'dyn",
        "Design factor 1 + φ'dyn + φ''/2", "Wheel unloading ΔQ/Q₀",
        "Car-body acceleration (comfort)",
    ]
    assert set(table["result"]) <= {"pass", "FAIL", "info", "n/a"}


# --- determinant length L_phi (EN 1991-2 Table 6.2 [R]) ---------------------------------
# Expected values are worked out here from the table: simply supported L_phi = L;
# continuous n spans L_phi = k * mean(spans), k = 1.2 / 1.3 / 1.4 / 1.5 (n = 2 / 3 / 4 / >= 5),
# not less than the largest span. phi'' is then recomputed from the Annex C formula.
# Tolerance rel 1e-12: the same closed forms evaluated twice, only rounding differs.


def _phi2(L, n0):
    """phi'' of EN 1991-2 Annex C [R] for v >= 22 m/s (a = 1), written out independently."""
    return max(0.56 * math.exp(-((L / 10.0) ** 2))
               + 0.50 * (n0 * L / 80.0 - 1.0) * math.exp(-((L / 20.0) ** 2)), 0.0)


def _lphi_case(kind, spans, **kw):
    ds = _ds(bridge_kind=kind, spans=spans, bridge_length=float(sum(spans)),
             frequencies=(5.0, 20.0, 45.0), **kw)
    return ds, checks.dynamic_amplification(ds)


def test_determinant_length__simply_supported_span_is_the_span():
    ds, out = _lphi_case("simply_supported", [25.0])
    expected = 25.0  # Table 6.2: L_phi = L
    assert out.attrs["length"] == pytest.approx(expected, rel=1e-12)
    assert out.attrs["length_assumed"] == 0 and "simply supported" in out.attrs["length_rule"]
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(_phi2(expected, 5.0), rel=1e-12)


@pytest.mark.parametrize("spans", [[20.0, 25.0], [10.0, 40.0]])
def test_determinant_length__two_span_continuous_deck(spans):
    _, out = _lphi_case("continuous", spans)
    expected = max(1.2 * (spans[0] + spans[1]) / 2.0, max(spans))  # 27 m; 40 m (max span)
    assert out.attrs["length"] == pytest.approx(expected, rel=1e-12)
    assert out.attrs["length_assumed"] == 0
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(_phi2(expected, 5.0), rel=1e-12)


def test_determinant_length__three_span_continuous_deck():
    spans = [15.0, 20.0, 15.0]
    _, out = _lphi_case("continuous", spans)
    expected = 1.3 * 50.0 / 3.0  # 21.67 m > largest span 20 m
    assert expected > 20.0
    assert out.attrs["length"] == pytest.approx(expected, rel=1e-12)
    assert "1.3" in out.attrs["length_rule"]
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(_phi2(expected, 5.0), rel=1e-12)


@pytest.mark.parametrize("spans", [[20.0] * 5, [20.0, 25.0, 25.0, 25.0, 25.0, 20.0]])
def test_determinant_length__five_or_more_span_continuous_deck(spans):
    _, out = _lphi_case("continuous", spans)
    expected = 1.5 * sum(spans) / len(spans)  # k = 1.5 for n >= 5: 30 m; 34.5 m
    assert out.attrs["length"] == pytest.approx(expected, rel=1e-12)
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(_phi2(expected, 5.0), rel=1e-12)


def test_determinant_length__override_wins_over_attribute_and_config():
    ds = _ds(bridge_kind="continuous", spans=[20.0, 20.0, 20.0], bridge_length=60.0,
             frequencies=(5.0, 20.0, 45.0))
    assert checks.determinant_length(ds).value == pytest.approx(1.3 * 20.0, rel=1e-12)
    ds.attrs["determinant_length"] = 18.0  # what the config may provide later
    lphi = checks.determinant_length(ds)
    assert lphi.value == 18.0 and "determinant_length" in lphi.rule and not lphi.assumed
    out = checks.dynamic_amplification(ds, length=12.5)  # the explicit argument wins
    assert out.attrs["length"] == 12.5 and "given explicitly" in out.attrs["length_rule"]
    assert float(out["phi2"].isel(speed=0)) == pytest.approx(_phi2(12.5, 5.0), rel=1e-12)
    with pytest.raises(ValueError, match="determinant length"):
        checks.determinant_length(ds, -1.0)


def test_determinant_length__rigid_track_imported_and_no_config():
    ds = _ds(bridge_kind="rigid", spans=[50.0])
    lphi = checks.determinant_length(ds)
    assert np.isnan(lphi.value) and "not applicable" in lphi.rule
    assert checks.dynamic_amplification(ds)["phi2"].isnull().all()
    lphi = checks.determinant_length(_ds(bridge_kind="modes_file", spans=[20.0, 20.0]))
    assert lphi.value == pytest.approx(1.2 * 20.0, rel=1e-12)
    assert lphi.assumed and "ASSUMPTION" in lphi.rule
    ds = _ds(bridge_length=33.0)
    ds.attrs["config_json"] = '{"bridge": {"kind": "matrices"}}'  # no spans
    lphi = checks.determinant_length(ds)
    assert lphi.value == 33.0 and lphi.assumed and "bridge length" in lphi.rule
    del ds.attrs["config_json"]
    assert checks.determinant_length(ds).assumed


# --- wheel unloading per train: moving forces vs interaction ----------------------------


def _mixed(**kw):
    """HSLM-A1 with prescribed forces (min = max = Q0, dQ/Q0 = 0) and ICE3 with varying ones."""
    kw.setdefault("trains", (("HSLM-A1", 18.0, 6, "standard"), ("ICE3", 0.0, 4, "suspect")))
    ds = _ds(**kw)
    q0 = ds["static_wheel_load"].copy()
    q0.loc[{"train": "HSLM-A1"}] = q0.sel(train="HSLM-A1").where(q0.sel(train="HSLM-A1")
                                                                 .isnull(), 50e3)
    ds["static_wheel_load"] = q0
    hslm = {"train": "HSLM-A1"}
    fixed = q0.sel(train="HSLM-A1").broadcast_like(ds["min_contact_force"].sel(hslm))
    for name in ("min_contact_force", "max_contact_force"):
        ds[name].loc[hslm] = fixed.transpose(*ds[name].sel(hslm).dims)
    ds["max_wheel_unloading"].loc[hslm] = ds["max_wheel_unloading"].sel(hslm) * 0.0
    ds["contact_loss_duration"].loc[hslm] = ds["contact_loss_duration"].sel(hslm) * 0.0
    return ds


def test_prescribed_wheels__per_train_and_wheel():
    ds = _mixed()
    fixed = checks.prescribed_wheels(ds)
    assert fixed.dims == ("train", "wheel")
    assert fixed.sel(train="HSLM-A1").values.tolist() == [True] * 6
    assert fixed.sel(train="ICE3").values.tolist() == [False] * 6  # 4 wheels + NaN padding
    assert checks.applicable_trains(ds).values.tolist() == [False, True]


def test_wheel_unloading__mixed_study_checks_the_interaction_train_only():
    ds = _mixed()
    out = checks.wheel_unloading(ds)
    a = out.attrs
    assert a["applicable_trains"] == "ICE3" and a["not_applicable_trains"] == "HSLM-A1"
    assert a["governing_train"] == "ICE3" and a["result"] in ("pass", "FAIL")
    assert out["value"].sel(train="HSLM-A1").isnull().all()
    assert out["min_contact_force"].sel(train="HSLM-A1").isnull().all()
    assert out["contact_loss_duration"].sel(train="HSLM-A1").isnull().all()
    # the HSLM forces (50 kN) are below every ICE3 force: unmasked they would govern
    ice3_min = float(ds["min_contact_force"].sel(train="ICE3").min())
    assert ice3_min > 50e3
    assert a["min_contact_force"] == pytest.approx(ice3_min, rel=1e-12)  # a pick, not a sum
    expected = float(ds["max_wheel_unloading"].sel(train="ICE3").max())
    assert a["value"] == pytest.approx(expected, rel=1e-12)


# --- contact loss: total, longest single loss, one-step losses --------------------------


def test_wheel_unloading__total_longest_and_one_step_losses_named_apart():
    ds = _ds(seeds=(1, 2), contact_loss_events=True)
    where = {"kmh": 300.0, "train": "A"}
    _set(ds, "contact_loss_duration", 0.05, irregularity=1, wheel=2, **where)
    _set(ds, "longest_contact_loss", 0.02, irregularity=1, wheel=2, **where)
    _set(ds, "contact_loss_duration", 0.03, irregularity=2, wheel=1, **where)
    _set(ds, "longest_contact_loss", 0.03, irregularity=2, wheel=1, **where)
    _set(ds, "single_step_contact_losses", 3.0, irregularity=1, wheel=2, **where)
    _set(ds, "single_step_contact_losses", 2.0, irregularity=1, wheel=4, **where)
    _set(ds, "single_step_contact_losses", 4.0, irregularity=2, wheel=0, **where)
    out = checks.wheel_unloading(ds, n_boot=0)
    a = out.attrs
    assert a["max_time_separated"] == pytest.approx(0.05)  # total, realisation 1
    assert a["max_contact_loss_duration"] == a["max_time_separated"]  # former name kept
    assert a["max_longest_contact_loss"] == pytest.approx(0.03)  # single event, realisation 2
    assert a["longest_contact_loss_source"] == "longest_contact_loss"
    # one-step losses: summed over wheels per realisation (3 + 2 = 5; 4), worst = 5
    case = out["single_step_contact_losses"].sel(train="A").isel(speed=2)
    assert float(case) == 5.0 and a["max_single_step_contact_losses"] == 5.0
    assert "total time separated" in out["contact_loss_duration"].attrs["long_name"]
    assert "longest single" in out["longest_contact_loss"].attrs["long_name"]


def test_wheel_unloading__without_longest_loss_falls_back_to_total_with_a_label():
    ds = _ds()
    _set(ds, "contact_loss_duration", 0.04, kmh=250.0, train="B", wheel=1)
    out = checks.wheel_unloading(ds, n_boot=0)
    a = out.attrs
    assert a["max_longest_contact_loss"] == pytest.approx(0.04)
    assert "upper bound" in a["longest_contact_loss_source"]
    assert "upper bound" in out["longest_contact_loss"].attrs["long_name"]
    assert "max_single_step_contact_losses" not in a
