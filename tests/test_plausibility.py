"""Unit slips and the time-step checks of nonlinear suspensions, through ``vsi check``.

Each slip is a value typed in the wrong unit (t/m for kg/m, m/s for km/h, % for a
ratio, kN for N and back, t for kg): the message names the key, the value and the unit
it looks like; ordinary input stays quiet.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from vsi_numba.cli import app

DECK = """\
title = "plausibility"
[bridge]
kind = "simply_supported"
spans = [25.0]
EI = 7.0e10
mass_per_length = {mass}
damping_ratio = {damping}
n_modes = 3
{train}
[solver]
dt = {dt}
[study]
{speeds}
output = "out.nc"
"""
HSLM = '[train]\npreset = "HSLM-A1"\nmodel = "moving_force"'


def check(tmp_path: Path, *, mass=15000.0, damping=0.01, train=HSLM, dt=1e-3,
          speeds="speeds_kmh = [200.0, 300.0]", files=None):
    """Write the config (and ``files``) in ``tmp_path``, run ``vsi check``: (exit code,
    output on one line per message)."""
    for name, text in (files or {}).items():
        (tmp_path / name).write_text(text)
    cfg = tmp_path / "c.toml"
    cfg.write_text(DECK.format(mass=mass, damping=damping, train=train, dt=dt,
                               speeds=speeds))
    res = CliRunner().invoke(app, ["check", str(cfg)])
    return res.exit_code, res.output


def number(pattern, text):
    m = re.search(pattern, text)
    assert m, (pattern, text)
    return float(m.group(1))


def test_check__ordinary_deck_is_quiet(tmp_path):
    code, out = check(tmp_path)
    assert code == 0, out
    assert "looks like" not in out and "look like" not in out and "warning:" not in out


def test_check__deck_mass_in_t_per_m_is_refused_before_the_time_step(tmp_path):
    code, out = check(tmp_path, mass=22.0)
    assert code == 2, out
    assert "bridge.mass_per_length = 22 kg/m looks like t/m (22 t/m = 22000 kg/m)" in out
    assert "solver.dt" not in out  # the mass is the cause, not the time step
    # the f1 it quotes, against the closed form of a simply supported beam
    f1 = math.pi / (2 * 25.0**2) * math.sqrt(7.0e10 / 22.0)
    assert number(r"it gives f1 = ([\d.]+) Hz", out) == pytest.approx(f1, rel=1e-3)  # 4 digits
    f1_t = math.pi / (2 * 25.0**2) * math.sqrt(7.0e10 / 22000.0)
    assert number(r"with 22000 kg/m: f1 = ([\d.]+) Hz", out) == pytest.approx(f1_t, rel=2e-3)
    assert "solver.allow_implausible" in out


def test_check__damping_ratio_as_a_percentage(tmp_path):
    code, out = check(tmp_path, damping=1.5)
    assert code == 2
    assert "bridge.damping_ratio = 1.5: expected a damping ratio 0 <= zeta < 1" in out
    assert "did you mean 0.015 (1.5 %)?" in out
    code, out = check(tmp_path, damping="[0.01, 2.0, 0.02]")
    assert code == 2 and "bridge.damping_ratio[1] = 2.0:" in out and "did you mean 0.02" in out
    code, out = check(tmp_path, damping=0.5)
    assert code == 0, out
    assert "bridge.damping_ratio = 0.5: 50 % of critical damping" in out
    assert "looks like a percentage? (0.5 % = 0.005)" in out
    code, out = check(tmp_path, damping=0.05)  # a high but ordinary ratio: quiet
    assert code == 0 and "percentage" not in out and "warning:" not in out


def test_check__speeds_in_m_per_s(tmp_path):
    code, out = check(tmp_path, speeds="line_speed_kmh = 88.9")
    assert code == 0, out
    assert "study.line_speed_kmh = 88.9 km/h looks like m/s (88.9 m/s = 320 km/h)" in out
    code, out = check(tmp_path, speeds="speeds_kmh = { start = 40.0, stop = 83.0, step = 1.0 }")
    assert code == 0, out
    assert ("study.speeds_kmh: the fastest speed is 83 km/h, which looks like m/s (83 m/s "
            "= 298.8 km/h)") in out
    for quiet in ("line_speed_kmh = 160.0", "speeds_kmh = [100.0]", "speeds_kmh = [20.0]"):
        code, out = check(tmp_path, speeds=quiet)  # 20 km/h: 72 km/h in m/s, no slip
        assert code == 0 and "looks like" not in out, (quiet, out)


AXLES = "position,load\n0,{q}\n3,{q}\n11,{q}\n14,{q}\n"


def test_check__axle_loads_in_the_wrong_unit(tmp_path):
    train = '[train]\naxles = {{ file = "axles.csv", load_unit = "{unit}" }}'
    code, out = check(tmp_path, train=train.format(unit="N"),
                      files={"axles.csv": AXLES.format(q=170)})
    assert code == 2, out
    assert 'train.axles.load_unit = "N": the mean axle load of train.axles.file is 170 N' in out
    assert "(a 0.68 kN train); looks like kN (170 kN = 170000 N per axle)" in out
    code, out = check(tmp_path, train=train.format(unit="kN"),
                      files={"axles.csv": AXLES.format(q=170000)})
    assert code == 2, out
    assert 'train.axles.load_unit = "kN": the mean axle load of train.axles.file is ' \
        "1.7e+05 kN" in out and "looks like N (170000 N = 170 kN)" in out
    assert "static deflection" not in out  # its consequence is not repeated
    for unit, q in (("kN", 170), ("N", 170000)):
        code, out = check(tmp_path, train=train.format(unit=unit),
                          files={"axles.csv": AXLES.format(q=q)})
        assert code == 0 and "looks like" not in out, out


def test_check__vehicle_masses_in_tonnes_and_loads_in_kN(tmp_path):
    train = ('[[train.vehicles]]\nkind = "sprung_mass"\nmass = 5.75\nstiffness = 1.595e6\n'
             '[[train.vehicles]]\nkind = "force"\noffset = 10.0\nload = 170.0')
    code, out = check(tmp_path, train=train, speeds="speeds_kmh = [100.0]")
    assert code == 2, out
    assert "train.vehicles[0].mass = 5.75 kg looks like tonnes" in out
    assert "(5.75 t = 5750 kg)" in out
    assert "train.vehicles[1].load = 170 N looks like kN (170 kN = 170000 N)" in out
    assert "solver.dt" not in out  # a 5.75 kg body rings at 84 Hz: not the cause


SPRUNG = ('[[train.vehicles]]\nkind = "sprung_mass"\nmass = 5750.0\nstiffness = {k}\n'
          'damping = 1.0e4\n{stop}')


def test_check__bump_stop_enters_the_time_step_check(tmp_path):
    """A closed bump stop is a spring in parallel: the run must resolve it as it
    resolves the same spring given linearly (a 1e12 N/m stop at dt = 0.5 ms)."""
    m, k, ks, dt = 5750.0, 1.595e6, 1.0e12, 5e-4
    stop = f"bump_stop = {{ gap = 0.005, stiffness = {ks:g} }}"
    code, out = check(tmp_path, train=SPRUNG.format(k=k, stop=stop), dt=dt,
                      speeds="speeds_kmh = [100.0]")
    assert code == 2, out
    f_closed = math.sqrt((k + ks) / m) / (2 * math.pi)  # body on both springs, wheel held
    assert number(r"highest vehicle frequency of train 'plausibility' \(([\d.]+) Hz", out) \
        == pytest.approx(f_closed, rel=1e-3)  # printed to 4 digits
    assert "bump stops closed: bump_stop.stiffness up to 1e+12 N/m" in out
    f_open = math.sqrt(k / m) / (2 * math.pi)
    assert number(r"; ([\d.]+) Hz with the stops open", out) == pytest.approx(f_open, rel=1e-3)
    assert f"solver.dt = {dt:g}: expected a time step" in out
    # the same spring given linearly: the same refusal, the same frequency
    code, lin = check(tmp_path, train=SPRUNG.format(k=k + ks, stop=""), dt=dt,
                      speeds="speeds_kmh = [100.0]")
    assert code == 2
    assert number(r"train 'plausibility' \(([\d.]+) Hz", lin) == pytest.approx(f_closed,
                                                                               rel=1e-3)
    # a soft stop (the closed vehicle at 3.5 Hz) leaves the ordinary step quiet
    soft = "bump_stop = { gap = 0.005, stiffness = 1.2e6 }"
    code, out = check(tmp_path, train=SPRUNG.format(k=k, stop=soft), dt=1e-3,
                      speeds="speeds_kmh = [100.0]")
    assert code == 0 and "solver.dt" not in out, out


def test_check__speeds_short_of_the_en_range_of_the_line_speed(tmp_path):
    """EN 1991-2 6.4.6.2 [R]: speeds up to 1.2 x the line speed."""
    code, out = check(tmp_path, speeds="speeds_kmh = [200.0, 300.0]\nline_speed_kmh = 300.0")
    assert code == 0, out
    assert ("study.speeds_kmh: the fastest speed is 300 km/h, below the EN range up to "
            "1.2 x study.line_speed_kmh = 360 km/h") in out
    code, out = check(tmp_path, speeds="speeds_kmh = [200.0, 360.0]\nline_speed_kmh = 300.0")
    assert code == 0 and "EN range" not in out, out


CAR = """[[train.vehicles]]
kind = "car"
body_mass = {body}
body_pitch_inertia = 2.0e6
bogie_mass = 3000.0
bogie_pitch_inertia = 2000.0
wheelset_mass = 1800.0
bogie_spacing = 17.5
wheelbase = 2.5
primary_stiffness = 1.0e6
primary_damping = 1.0e4
secondary_stiffness = 3.0e5
secondary_damping = 2.0e4
"""


def test_check__car_body_mass_in_tonnes(tmp_path):
    code, out = check(tmp_path, train=CAR.format(body=40.0), speeds="speeds_kmh = [200.0]")
    assert code == 2, out
    assert "train.vehicles[0].body_mass = 40 kg looks like tonnes (40 t = 40000 kg)" in out
    code, out = check(tmp_path, train=CAR.format(body=40000.0), speeds="speeds_kmh = [200.0]")
    assert code == 0 and "looks like" not in out, out


def test_check__user_vehicle_masses_in_tonnes(tmp_path):
    train = ('[[train.vehicles]]\nkind = "user"\nM = [[5.75, 0.0], [0.0, 0.1]]\n'
             "C = [[0.0, 0.0], [0.0, 0.0]]\nK = [[1.0e6, -1.0e6], [-1.0e6, 1.0e6]]\n"
             "wheel_dofs = [1]\nwheel_positions = [0.0]")
    code, out = check(tmp_path, train=train, speeds="speeds_kmh = [200.0]")
    assert code == 2, out
    # 5.85 kg x 9.81 m/s^2 on one axle
    assert "train.vehicles[0].M, train.vehicles[0].gravity: a static axle load of " \
        f"{5.85 * 9.81:.4g} N" in out and "looks like tonnes typed as kg" in out
