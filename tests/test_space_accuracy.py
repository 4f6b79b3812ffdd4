"""Accuracy of the deck-in-space results and the statements beside the verdicts, through
``vsi sweep`` (and ``--report``): the deck acceleration with a rail mass on the elastic
track states the sign and size of its error in the summary's verdict (the massless rail
states none); the twist, the torsional moment against closed forms and a converged
reference; the twist section's statements."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner
from userpath import sweep_file

from vsi_numba.cli import app

RAIL = """title = "rail mass"
[bridge]
kind = "simply_supported"
spans = [15.0]
EI = 2.0e10
mass_per_length = 12000.0
damping_ratio = 0.02
n_modes = 3
[train]
[[train.vehicles]]
kind = "sprung_mass"
offset = 0.0
mass = 5750.0
stiffness = 1.595e6
damping = 1e4
wheel_mass = 500.0
[track]
model = "elastic"
rail_mass = {mass}
[solver]
dt = 1e-3
free_vibration = 0.1
[study]
speeds_kmh = [150.0]
output = "s.nc"
"""


def _summary_row(tmp_path, text: str, check: str) -> str:
    (tmp_path / "s.toml").write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "s.toml"), "-q", "--report",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    rows = [line for line in md.splitlines() if line.startswith(f"| {check} |")]
    assert rows, md[:3000]
    return rows[0]


@pytest.mark.parametrize("mass", [120.0, 0.0])
def test_space_accuracy__rail_mass_error_beside_the_acceleration_verdict(tmp_path, mass):
    row = _summary_row(tmp_path, RAIL.format(mass=mass), "Peak deck acceleration")
    verdict = row.split("|")[6]
    if mass:
        # the measured error with its sign, in the verdict's cell (docs/track_accuracy.md:
        # -1.6 .. +2.7 % at 120 kg/m with the rail's inertia in the deck load,
        # tests/test_track_accuracy.py checks it against the continuous rail)
        assert ("pass (the value is within -1.6 .. +2.7 % of a converged continuous "
                "damped rail, measured at 120 kg/m)") in verdict, row
    else:
        assert verdict.strip() == "pass", row


# a 20 m deck (and a 20 + 25 m continuous one) with two tracks at +-2.2 m, torsionally
# soft (c = sqrt(GJ / I_p) = 250 m/s); six torsional modes on the simply supported span
GJ, IP, ECC, P = 5e9, 8e4, 2.2, 170e3
SPACE = """title = "twist"
[bridge]
kind = "{kind}"
spans = {spans}
EI = 2.0e10
mass_per_length = 15000.0
damping_ratio = 0.01
n_modes = 3
elements_per_span = 40
output_points = {points}
tracks = [{{ eccentricity = 2.2 }}, {{ eccentricity = -2.2 }}]
torsion = {{ GJ = 5e9, polar_mass = 8e4, damping_ratio = 0.01, n_modes = 6 }}
[train]
track = 1
{forces}
[track]
model = "rigid"
[solver]
dt = {dt}
hht_alpha = 0.0
approach = 0.0
free_vibration = {free}
[study]
speeds_kmh = [{kmh}]
line_speed_kmh = 160.0
output = "out.nc"
save_time_histories = false
"""


def _forces(offsets):
    return "\n".join(f'[[train.vehicles]]\nkind = "force"\noffset = {o}\nload = {P}'
                     for o in offsets)


def _static_twist_envelope(spans, x, base=3.0, gauge=1.435):
    """Largest |twist| over ``base`` from each ``x`` of the force P at y = ECC crawling
    over the deck, written here: torsion restrained at every support, each span a
    fork-supported span, theta(X) = P y X (L - a) / (GJ L) for X <= a (the load at a in
    the same span), the load moved in 1 mm steps."""
    sup = np.concatenate([[0.0], np.cumsum(spans)])
    a = np.arange(0.0, sup[-1] + 5e-4, 1e-3)

    def theta(at):
        out = np.zeros((at.size, a.size))
        for s in range(len(spans)):
            L = spans[s]
            X, b = (at - sup[s])[:, None], (a - sup[s])[None, :]
            g = np.where(X <= b, X * (L - b), b * (L - X)) / (GJ * L)
            out += np.where((X >= 0) & (X <= L) & (b >= 0) & (b <= L), g, 0.0)
        return P * ECC * out

    x = np.atleast_1d(x)
    return np.abs(gauge * (theta(x) - theta(x + base))).max(axis=1)


@pytest.mark.parametrize(("kind", "spans"), [("simply_supported", [20.0]),
                                             ("continuous", [20.0, 25.0])])
def test_space_accuracy__crawl_twist_against_the_closed_form(tmp_path, kind, spans):
    """A 170 kN force crawling at 3 km/h on track 1: the file's deck twist over 3 m at
    the output points and on the whole-deck grid against the closed-form static St-Venant
    twist (the plain modal sum of the six torsional modes was 5.7 % low on the grid of
    the simply supported deck and 24 % low at x = 10 m of the continuous one)."""
    points = [5.0, 10.0, 30.0] if len(spans) > 1 else [5.0, 10.0]
    ds = sweep_file(tmp_path, SPACE.format(kind=kind, spans=spans, points=points,
                                           forces=_forces([0.0]), dt=2e-3, free=0.0,
                                           kmh=3.0), speed=0)
    for k in (1, 2):  # the other track's rails twist alike (a beam deck's section)
        got = ds["max_deck_twist"].sel(track=k).values
        # mode acceleration: the static part is the closed form, the modes add the
        # dynamic part at 3 km/h (and the FE torsion between nodes); measured 3.3e-4
        np.testing.assert_allclose(got, _static_twist_envelope(spans, points), rtol=1e-3)
        whole = ds["max_deck_twist_whole_deck"].sel(track=k).values.max()
        ref = _static_twist_envelope(spans, ds["twist_x"].values).max()
        np.testing.assert_allclose(whole, ref, rtol=1e-3)
    assert ds.attrs["deck_twist_method"] == "mode-acceleration"


def test_space_accuracy__twist_and_torque_at_speed_against_a_converged_reference(tmp_path):
    """Ten 170 kN forces 15 m apart at 150 km/h (v/c = 0.17) on the simply supported
    deck: the twist and the torsional moment envelopes against 400 torsional modes'
    exact responses by the mode-acceleration formula (a converged reference: the plain
    modal twist of six modes was -13 .. +10 % off, the torque without the speed factor
    up to 5.2 % low); the report states the twist's accuracy beside its verdicts."""
    from vsi_numba.verification.reference import (
        fork_torsion_channels,
        fork_torsion_moving_forces,
    )

    points, offsets, v = [2.0, 5.0, 10.0], 15.0 * np.arange(10), 150.0 / 3.6
    text = SPACE.format(kind="simply_supported", spans=[20.0], points=points,
                        forces=_forces(offsets), dt=5e-4, free=0.3, kmh=150.0)
    (tmp_path / "s.toml").write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "s.toml"), "-q", "--report",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    import xarray as xr

    with xr.open_dataset(tmp_path / "out.nc") as f:
        ds = f.isel(train=0, irregularity=0, speed=0).load()
    t = np.arange(0.0, (20.0 + offsets[-1]) / v + 0.3, 2.5e-4)
    conv = fork_torsion_moving_forces(offsets, P, ECC, 20.0, GJ, IP, 0.01, v, t)
    _, twist, torque = fork_torsion_channels(conv, points)
    # the truncated torsional modes' dynamic part (the torque fronts a force sends off
    # at c when it enters or leaves the span); measured 2.2e-2 (twist), 1.9e-2 (torque)
    np.testing.assert_allclose(ds["max_deck_twist"].sel(track=1).values,
                               np.abs(twist).max(axis=0), rtol=5e-2)
    np.testing.assert_allclose(ds["max_torsional_moment"].values, torque.max(axis=0),
                               rtol=4e-2)
    np.testing.assert_allclose(ds["min_torsional_moment"].values, torque.min(axis=0),
                               rtol=4e-2)
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    rows = [r for r in md.splitlines() if r.startswith("| 1 |") and "mode acceleration" in r]
    assert rows and "at a torsional resonance -2 .. +7 %" in rows[0], md[-4000:]


def test_space_accuracy__modal_sum_twist_states_its_error(tmp_path):
    """With the load effects off the twist is the plain modal sum: the file says so (no
    ``deck_twist_method``) and the report states the sign and size of its error beside
    the dynamic twist's verdicts; the same run computes the closed-form crawl twist's
    shortfall that the statement covers (5.7 % on the whole-deck grid here, within the
    8 % stated)."""
    text = SPACE.format(kind="simply_supported", spans=[20.0], points=[5.0, 10.0],
                        forces=_forces([0.0]), dt=2e-3, free=0.0, kmh=3.0).replace(
        "save_time_histories = false", "save_time_histories = false\nload_effects = false")
    (tmp_path / "s.toml").write_text(text)
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "s.toml"), "-q", "--report",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    import xarray as xr

    with xr.open_dataset(tmp_path / "out.nc") as f:
        ds = f.isel(train=0, irregularity=0, speed=0).load()
    assert "deck_twist_method" not in ds.attrs
    whole = ds["max_deck_twist_whole_deck"].sel(track=1).values.max()
    short = whole / _static_twist_envelope([20.0], ds["twist_x"].values).max() - 1.0
    assert -0.08 < short < -0.03  # low, within the statement (measured -5.7 %)
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    rows = [r for r in md.splitlines() if r.startswith("| 1 |") and "modal sum" in r]
    assert rows and "up to 8 % LOW, unsafe side" in rows[0], md[-4000:]


def test_space_accuracy__rail_mass_results_written_before_state_their_error(tmp_path):
    """A results file without ``rail_inertia_in_deck_load`` (written before the rail's
    inertia entered the deck load) gets that model's measured error beside the verdict:
    up to 6.8 % low at 120 kg/m (docs/track_accuracy.md, the results before)."""
    import xarray as xr

    (tmp_path / "s.toml").write_text(RAIL.format(mass=120.0))
    res = CliRunner().invoke(app, ["sweep", str(tmp_path / "s.toml"), "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "s.nc") as f:
        ds = f.load()
    assert ds.attrs.pop("rail_inertia_in_deck_load") == 1
    ds.to_netcdf(tmp_path / "old.nc")
    res = CliRunner().invoke(app, ["report", str(tmp_path / "old.nc"), "-o",
                                   str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    row = next(r for r in md.splitlines() if r.startswith("| Peak deck acceleration |"))
    assert "the value is up to 6.8 % LOW (unsafe side)" in row.split("|")[6], row
    assert "up to 7 % LOW (unsafe side)" in md  # the input table says the same
