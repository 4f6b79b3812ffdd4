"""Records of a calibration: the speed found from a record when ``speed_kmh`` is not
given (against synthetic records of a known speed from an independent integration), and
the ``track`` of a record (the passage on a track of a deck in space; refused on a deck of
one track)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.userpath import vsi
from vsi_numba.config import load_config
from vsi_numba.existing.forward import Forward, Group
from vsi_numba.existing.speed import estimate_speed
from vsi_numba.verification import existing as syn


def _without_speeds(path):
    path.write_text(re.sub(r"(?m)^speed_kmh = [0-9.]+\n", "", path.read_text()))
    return path


@pytest.mark.parametrize(("speed", "tol"), [(240.0, 0.002), (280.0, 0.002),
                                            # 1 % below the resonance of the truth, whose
                                            # frequency the prior's median misses by 5 %
                                            (305.0, 0.006)])
def test_speed_from_the_record_of_a_known_speed(tmp_path, speed, tol):
    cfg = load_config(_without_speeds(syn.write_case(tmp_path, speeds=(speed,),
                                                     n_samples=64)))
    rec = cfg.resolved()["calibration"]["records"][0]
    assert "speed_kmh" not in rec
    v, rho = estimate_speed(cfg, rec)
    assert v == pytest.approx(speed, rel=tol)
    assert rho > 0.9


def test_check_prints_the_speed_found(tmp_path):
    cfg = _without_speeds(syn.write_case(tmp_path, speeds=(280.0,), n_samples=64))
    res = vsi("check", cfg)
    assert res.returncode == 0, res.stdout + res.stderr
    m = re.search(r"calibration\.records\[0\]: speed ([0-9.]+) km/h from the record",
                  res.stdout + res.stderr)
    assert m is not None, res.stdout
    assert float(m.group(1)) == pytest.approx(280.0, rel=0.002)


def test_track_of_a_record_on_a_deck_of_one_track_is_refused(tmp_path):
    cfg = syn.write_case(tmp_path, speeds=(280.0,), n_samples=64)
    cfg.write_text(cfg.read_text().replace('train = "HSLM-A1"\nspeed_kmh',
                                           'train = "HSLM-A1"\ntrack = 2\nspeed_kmh'))
    res = vsi("check", cfg)
    assert res.returncode == 2
    assert ("calibration.records[0].track = 2: expected no track for a deck of one track "
            "(bridge.tracks not given): leave it out") in res.stdout + res.stderr


ECC, GJ, IP = 2.2, 4.0e9, 2.0e4


def _space_case(tmp_path, track: int):
    cfg = syn.write_case(tmp_path, speeds=(280.0,), n_samples=64)
    text = cfg.read_text().replace(
        "output_points = [10.0]",
        f"output_points = [10.0]\ntracks = [{{ eccentricity = {ECC} }}, "
        f"{{ eccentricity = {-ECC} }}]\ntorsion = {{ GJ = {GJ}, polar_mass = {IP}, "
        "damping_ratio = 0.02, n_modes = 2 }")
    text = text.replace('train = "HSLM-A1"\nspeed_kmh',
                        f'train = "HSLM-A1"\ntrack = {track}\nspeed_kmh')
    cfg.write_text(text)
    return cfg


def test_track_of_a_record_beyond_the_decks_tracks_is_refused(tmp_path):
    res = vsi("check", _space_case(tmp_path, 3))
    assert res.returncode == 2
    assert "calibration.records[0].track = 3: expected a track of bridge.tracks, 1 .. 2" \
        in res.stdout + res.stderr


def test_track_of_a_record_runs_the_passage_on_that_track(tmp_path):
    # the forward model's shapes at the record's point are the track line's: the bending
    # modes sqrt(2/(m L)) sin(j pi x/L) and the torsional modes y_k sqrt(2/(Ip L))
    # sin(j pi x/L) at the track's eccentricity y_k (closed form)
    for track, y in ((1, ECC), (2, -ECC)):
        cfg = load_config(_space_case(tmp_path / str(track), track))
        rec = cfg.resolved()["calibration"]["records"][0]
        fwd = Forward(cfg.resolved(), cfg.base_dir, ["bridge.EI"],
                      [Group(rec["train"], (280.0,), (10.0,), rec["track"])])
        assert not fwd._typed  # a deck in space takes the full path
        m, _, deck, freqs = fwd._full_row(0, [2.0e10])
        phi = deck[0][0]
        x, L = 10.0, syn.SPAN
        bend = np.sqrt(2.0 / (syn.MASS * L)) * np.sin(np.arange(1, 4) * np.pi * x / L)
        tors = y * np.sqrt(2.0 / (IP * L)) * np.sin(np.arange(1, 3) * np.pi * x / L)
        expected = np.sort(np.abs(np.concatenate([bend, tors])))
        assert np.sort(np.abs(phi)) == pytest.approx(expected, rel=1e-9, abs=1e-12)
        assert m.cfg.train_track == track
        res = fwd.run_row([2.0e10])[0]
        assert not res.error, res.error
