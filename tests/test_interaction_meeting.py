"""Interaction trains on two tracks in one run (``[train] other_trains`` with
``model = "interaction"``) through the user's path (config -> ``vsi sweep`` -> netCDF ->
``vsi report``), each against a reference computed here:

- two sprung masses meeting at crawl speed on a two-span continuous deck with torsion:
  the torsional moment and the twist with both loaded (mode-acceleration method, each
  load on its own track) against the test's own static St-Venant finite-element solution
  of both loads (numpy);
- every check of the report with both trains loaded, none NaN, the deck's φ'dyn (which
  such a run cannot give) refused with a message naming the key.

Two ICE3 meeting on the viaduct against each alone: ``tests/test_trains_meeting_space.py``.
"""

from __future__ import annotations

import csv
import json
import re

import numpy as np
from test_other_trains_own_speed_torsion import GJ, Y, _config, _fe_torque, _run, fe_bar_stiffness
from test_space_config import L
from userpath import vsi

SPRUNG = """[[train.vehicles]]
kind = "sprung_mass"
offset = 0.0
mass = 10000.0
stiffness = 2e6
damping = 2e4
wheel_mass = 0.0"""
MEETING = 'other_trains = [{ track = 2, direction = "opposite", offset = 0.0 }]'
GAUGE = 1.435  # m, the default rail spacing
SUP = np.array([0.0, 10.0, 20.0])


def _fe_theta(at, loads, gj=GJ):
    """Static St-Venant rotation at ``at`` of point torques ``loads`` [(a, M)] on the
    10 + 10 m bar restrained at every support (linear elements with a node at every
    support and load: theta is linear between them, so exact), zero off the deck."""
    nodes = np.unique(np.concatenate([SUP, [a for a, _ in loads]]))
    n = nodes.size
    K = fe_bar_stiffness(nodes, gj)
    f = np.zeros(n)
    for a, m in loads:
        f[np.searchsorted(nodes, a)] += m
    free = ~np.isin(nodes, SUP)
    th = np.zeros(n)
    th[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    return np.interp(at, nodes, th, left=0.0, right=0.0)


def _meeting_reference(sections, starts, p, v, dt, n, ys):
    """max / min torque at ``sections`` and max |twist| over 3 m from ``starts`` over the
    run's steps of the static loads ``p`` of a train at y = ys[0] in +x from x = 0 and
    one at ys[1] in -x from x = L (the test's own FE solution)."""
    hi = np.full(sections.size, -np.inf)
    lo = np.full(sections.size, np.inf)
    tw = np.zeros(starts.size)
    for i in range(n):
        s = v * i * dt
        loads = [(a, p * y) for a, y in ((s, ys[0]), (L - s, ys[1])) if 0.0 <= a <= L]
        if not loads:
            continue
        t = _fe_torque(sections, loads, SUP, GJ)
        hi, lo = np.maximum(hi, t), np.minimum(lo, t)
        tw = np.maximum(tw, np.abs(GAUGE * (_fe_theta(starts, loads)
                                            - _fe_theta(starts + 3.0, loads))))
    return hi, lo, tw


def test_two_sprung_masses_meeting_at_crawl__torque_and_twist_against_static_fe(tmp_path):
    """A 10 t sprung mass on track 1 (y = 2.2 m) in +x and the same on track 2
    (y = -2.2 m) in -x at 1 m/s over 10 + 10 m, torsion restrained at every support: the
    torque envelopes (output points, whole-deck grid) and the twist envelopes with both
    loaded against the static FE solution of both loads; the same reference with both
    loads on track 1 (what a static part with one eccentricity gives) is far off."""
    v, dt = 1.0, 5e-3
    pts = "[2.5, 5.0, 7.5, 12.5, 15.0, 17.5]"
    text = _config("track = 1\n" + MEETING, SPRUNG, 3.6, 0.2, "continuous", dt, pts)
    text = text.replace("save_time_histories = true", "save_time_histories = false")
    ds, _ = _run(tmp_path, "both", text)
    assert ds.attrs["deck_twist_method"] == "mode-acceleration"
    nc = json.loads(ds.attrs["not_computed"])
    assert not any("torsional_moment" in k for k in nc), nc
    p = float(ds["static_wheel_load"].values[0])  # M g
    n = int(round(L / v / dt)) + 1
    x, grid = ds["point"].values, ds["deck_x"].values
    starts = ds["twist_x"].values
    hi, lo, tw = _meeting_reference(np.concatenate([x, grid]), starts, p, v, dt, n, Y[:2])
    scale = p * Y[0]
    # crawl (v/c = 4e-3): the static solution plus the kept torsional modes' ringing when
    # a load enters or leaves a span, and the sprung masses' own small dynamics:
    # measured 2.5e-3 of P e on the whole-deck grid (at the supports), 1.7e-4 at the
    # output points inside the spans; 2.4x and 2.9x
    for ext, ref in (("max", hi), ("min", lo)):
        for sfx in ("", "_all_tracks"):  # every train in the run: the same envelopes
            got = ds[f"{ext}_torsional_moment{sfx}"].values
            np.testing.assert_allclose(got, ref[:x.size], atol=5e-4 * scale)
            got = ds[f"{ext}_torsional_moment_whole_deck{sfx}"].values
            np.testing.assert_allclose(got, ref[x.size:], atol=6e-3 * scale)
    twist = ds["max_deck_twist_whole_deck_all_tracks"].values  # (track, twist_x)
    big = tw.max()
    # measured 5.1e-4 of the largest twist; 2.9x
    for k in range(2):  # the same gauge: the same twist along both tracks
        np.testing.assert_allclose(twist[k], tw, atol=1.5e-3 * big)
    # a static part with every load at y = 2.2 m (one eccentricity) misses it by far
    hi1, lo1, tw1 = _meeting_reference(np.concatenate([x, grid]), starts, p, v, dt, n,
                                       (Y[0], Y[0]))
    assert np.max(np.abs(ds["max_torsional_moment_whole_deck"].values - hi1[x.size:])) > \
        0.2 * scale
    assert np.max(np.abs(twist[0] - tw1)) > 0.2 * big


def test_report_of_two_interaction_trains__every_check_with_both_loaded(tmp_path):
    """``vsi report`` of two sprung masses meeting (interaction) on the continuous deck
    with torsion: every check of the summary is there with both trains loaded and
    finite (deck acceleration, wheel unloading, comfort, the EN 1991-2 6.4.6.5(3)
    verdicts with tracks 1, 2 loaded, the deck-end rotation, the torsional moment);
    the twist section gives the twist by the mode-acceleration method; the deck's φ'dyn
    (every train's displacement over one train's static deflection) is refused with a
    message naming train.other_trains, not given as a number."""
    text = _config("track = 1\n" + MEETING, SPRUNG, 80.0, 0.3, "continuous", 1e-3,
                   "[5.0, 10.0, 15.0]")
    text = text.replace("speeds_kmh = [80.0]", "speeds_kmh = [60.0, 80.0]\n"
                        "line_speed_kmh = 70.0")
    ds, d = _run(tmp_path, "both", text)
    assert ds.attrs["other_trains_loading"] == "together"
    res = vsi("report", d / "out.nc", "-o", d / "rep")
    assert res.returncode == 0, res.stdout + res.stderr
    with open(d / "rep" / "summary.csv", newline="", encoding="utf-8") as f:
        rows = {r["check"]: r for r in csv.DictReader(f)}
    wanted = ["Peak deck acceleration", "Wheel unloading ΔQ/Q₀",
              "Car-body acceleration (comfort)",
              *(f"6.4.6.5(3) {e}, tracks 1, 2 loaded: (1 + φ'dyn + φ''/2) × train / "
                "(Φ3 × α × LM71)" for e in ("deflection w", "bending moment M",
                                            "shear force V", "support reaction R",
                                            "rotation θ")),
              "Torsional moment |T| (every train of the run, output points)",
              "Torsional moment |T| (every train of the run, whole-deck grid)"]
    for name in wanted:
        assert name in rows, (name, list(rows))
        assert np.isfinite(float(rows[name]["value"])), rows[name]
    assert any(k.startswith("Deck-end rotation") for k in rows)
    for r in rows.values():  # no NaN posing as a result
        assert r["value"].lower() != "nan", r
    # the deck's φ'dyn would be both trains' displacement over one train's static
    # deflection: refused, naming the key, not given as a number
    assert "Dynamic increment φ'dyn" not in rows
    assert "Design factor 1 + φ'dyn + φ''/2" not in rows
    text = (d / "rep" / "report.md").read_text()
    assert "the dynamic increment φ'dyn: train.other_trains: the interaction trains" in text
    part = text[text.index("## Deck twist and tracks"):]
    part = part[:part.index("\n## ", 3)]
    assert "mode acceleration" in part and "8 % LOW" not in part
    assert not re.search(r"\bnan\b", part, re.IGNORECASE)
    # the governing cases' convergence is re-run with both trains
    conv = text[text.index("## Convergence of the governing cases"):].split("\n## ")[0]
    assert "Re-run at dt/2" in conv and "cannot be re-run" not in conv
