"""``vsi report`` on foreign or edited netCDF files: a one-line message saying what the
file lacks or holds wrongly, exit 2, never a traceback; long names and paths in ``vsi
init`` and ``vsi report`` get a message too.

Each crafted case starts from a real ``vsi sweep`` file (two HSLM trains, moving forces,
two speeds) and changes one thing."""

from __future__ import annotations

import json
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from vsi_numba.cli import app


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def base_file(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("foreign")
    config = d / "base.toml"
    config.write_text(textwrap.dedent("""
        title = "foreign files base"
        [bridge]
        kind = "simply_supported"
        spans = [15.0]
        EI = 1.0e10
        mass_per_length = 12000.0
        damping_ratio = 0.02
        n_modes = 3
        [train]
        preset = ["HSLM-A1", "HSLM-A2"]
        [solver]
        dt = 2e-3
        approach = 5.0
        free_vibration = 0.1
        [study]
        speeds_kmh = [200.0, 250.0]
        output = "base.nc"
        history_speeds_kmh = [250.0]
        """))
    res = invoke("sweep", config, "-q")
    assert res.exit_code == 0, res.output
    return d / "base.nc"


def _stored_config(d, section, key, value):
    cfg = json.loads(d.attrs["config_json"])
    cfg.setdefault(section, {})[key] = value
    d.attrs["config_json"] = json.dumps(cfg)
    return d


CASES = {
    "no point coordinate": (lambda d: d.drop_vars("point"),
                            "the results have no `point` coordinate (x of the output points, m)"),
    "string-valued envelope": (
        lambda d: d.assign(max_deck_acceleration=d.max_deck_acceleration.astype(str)),
        "`max_deck_acceleration` holds <U"),
    "string-valued status": (lambda d: d.assign(status=d.status.astype(str)),
                             "`status` holds <U"),
    "string speeds": (lambda d: d.assign_coords(speed=[str(v) for v in d.speed.values]),
                      "`speed` holds <U"),
    "NaN speed": (lambda d: d.assign_coords(speed=[np.nan, d.speed.values[1]]),
                  "`speed` has 1 value(s) that are not finite and positive (nan)"),
    "zero speed": (lambda d: d.assign_coords(speed=[0.0, d.speed.values[1]]),
                   "`speed` has 1 value(s) that are not finite and positive (0)"),
    "repeated speed": (lambda d: d.assign_coords(speed=[d.speed.values[1]] * 2),
                       "`speed` repeats the value(s)"),
    "no case": (lambda d: d.isel(speed=slice(0, 0)), "`speed` is empty"),
    "duplicate train names": (lambda d: d.assign_coords(train=["HSLM-A1", "HSLM-A1"]),
                              "`train` repeats 'HSLM-A1'"),
    "envelope on a foreign dim": (
        lambda d: d.assign(max_deck_acceleration=d.max_deck_acceleration.rename(
            point="x")),
        "`max_deck_acceleration` is on the dims ('speed', 'train', 'irregularity', 'x'); "
        "expected the case dims followed by ('point',)"),
    "speed_kmh per train": (
        lambda d: d.assign(speed_kmh=d.speed_kmh.expand_dims(train=d.train)),
        "`speed_kmh` is on the dims ('train', 'speed'); expected (speed)"),
    "no frequency": (lambda d: d.drop_vars("frequency"),
                     "the load-effect checks need the bridge's first natural frequency"),
    "classification_factor = 'abc'": (
        lambda d: _stored_config(d, "study", "classification_factor", "abc"),
        "study.classification_factor = 'abc'; expected a number > 0"),
    "spans = ['x']": (lambda d: _stored_config(d, "bridge", "spans", ["x"]),
                      "bridge.spans = ['x']; expected span lengths > 0 (m)"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_report__crafted_file_gives_its_message(base_file, tmp_path, case):
    change, expected = CASES[case]
    with xr.open_dataset(base_file) as ds:
        crafted = change(ds.load().copy(deep=True))
    for v in crafted.variables.values():
        v.encoding.clear()
    path = tmp_path / "crafted.nc"
    crafted.to_netcdf(path)
    res = invoke("report", path, "-o", tmp_path / "rep")
    out = " ".join(res.output.split())
    assert res.exit_code == 2, (case, out)
    assert f"'{path}' is not a usable results file: " in out, out
    assert expected in out, out
    assert "Traceback" not in out and res.exception is None or isinstance(
        res.exception, SystemExit)
    assert not (tmp_path / "rep").exists()


def test_report__the_untouched_file_passes(base_file, tmp_path):
    """The base of the crafted cases is reported (the checks above are not refusing
    everything)."""
    res = invoke("report", base_file, "-o", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "rep" / "report.md").is_file()


def test_long_names__init_and_report_refuse_with_a_message(tmp_path):
    """A file name over NAME_MAX bytes and a path over PATH_MAX bytes: exit 2 and a
    message naming the limit (was: OSError traceback, exit 1)."""
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    path_max = os.pathconf(tmp_path, "PC_PATH_MAX")
    long_name = tmp_path / ("n" * (name_max + 1) + ".toml")
    long_path = Path(str(tmp_path) + ("/" + "d" * 200) * (path_max // 200 + 1)) / "s.toml"
    for path in (long_name, long_path):
        res = invoke("init", path)
        out = " ".join(res.output.split())
        assert res.exit_code == 2, out
        assert ("file names here are at most" in out or "longest path" in out), out
        res = invoke("report", path.with_suffix(".nc"))
        out = " ".join(res.output.split())
        assert res.exit_code == 2, out
        assert ("file names here are at most" in out or "longest path" in out), out
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("header, expected", [
    ("%%MatrixMarket matrix coordinate real symmetric\n100000000 100000000 500000000\n"
     "1 1 1.0\n", "the header says 500,000,000 entries, but the file has only"),
    ("%%MatrixMarket matrix array real general\n100000 100000\n1.0\n",
     "the header says a dense 100,000 x 100,000 array"),
])
def test_matrix_market__header_sizes_refused_before_allocating(tmp_path, header, expected):
    """An 80-byte Matrix Market file announcing 10^10 values: vsi check names the key and
    the header (exit 2) and the process never grows past 400 MB (it allocated 3.7 GiB
    before its error; 400 MB: the interpreter with numpy, scipy and the package is
    ~250 MB here)."""
    import shutil
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    (tmp_path / "data").mkdir()
    for f in ("two_span_M.mtx", "two_span_stations.csv"):
        shutil.copy(root / "configs" / "data" / f, tmp_path / "data" / f)
    (tmp_path / "data" / "two_span_K.mtx").write_text(header)
    config = tmp_path / "m.toml"
    config.write_text((root / "configs" / "two_span_imported.toml").read_text())
    code = ("import sys\nfrom vsi_numba.cli import app\n"
            "try:\n    app(['check', sys.argv[1]], standalone_mode=False)\n"
            "except SystemExit:\n    pass\n"
            "rc = 0\n"
            "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')]\n"
            "print('HWM', hwm[0], file=sys.stderr)\n")
    proc = subprocess.run([sys.executable, "-c", code, str(config)], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(root)})
    err = " ".join(proc.stderr.split())
    assert "bridge.stiffness_matrix" in err and expected in err, err
    assert "Traceback" not in err
    hwm_kb = int(err.rsplit("HWM ", 1)[1].split()[0])
    assert hwm_kb < 400 * 1024, hwm_kb


def _axle_config(directory: Path, n: int) -> Path:
    (directory / "axles.csv").write_text(
        "position,load\n" + "".join(f"{2.5 * i + 0.3 * (i % 3):.3f},{150 + i % 7}\n"
                                    for i in range(n)))
    path = directory / "axles.toml"
    path.write_text(textwrap.dedent("""
        title = "long axle list"
        [bridge]
        kind = "simply_supported"
        spans = [20.0]
        EI = 3.5e10
        mass_per_length = 15000.0
        damping_ratio = 0.02
        n_modes = 3
        [train]
        axles = { file = "axles.csv", load_unit = "kN" }
        [solver]
        dt = 1e-3
        [study]
        speeds_kmh = [200.0]
        save_time_histories = false
        """))
    return path


def test_long_axle_list__static_envelope_is_the_dense_sum_in_bounded_memory(tmp_path):
    """The static reference of phi'dyn (computed at the final write) of a 300-axle list
    equals the dense sum over every (front, axle) pair written here (to round-off, 1e-12
    relative: same terms, other summation order); a 20,000-axle list (50 km) runs in a
    process that stays under 600 MB (it tried to allocate 29.9 GiB)."""
    import subprocess
    import sys

    from vsi_numba.config import load_config
    from vsi_numba.solver.simulate import static_deck_envelope

    cfg = load_config(_axle_config(tmp_path, 300))
    bridge, train = cfg.build_bridge(), cfg.trains()[0]
    points = np.array([5.0, 10.0, 13.0])
    got = static_deck_envelope(bridge, train, points)
    # dense reference: sin modes of the simply supported beam, every front, every axle
    L, m, EI = 20.0, 15000.0, 3.5e10
    table = np.loadtxt(tmp_path / "axles.csv", delimiter=",", skiprows=1)
    pos, Q = table[:, 0], table[:, 1] * 1e3
    fronts = np.arange(0.0, L + pos.max() + 0.05, 0.05)
    x = fronts[:, None] - pos[None, :]
    on = (x >= 0) & (x <= L)
    w = np.zeros((fronts.size, points.size))
    for j in (1, 2, 3):
        wj2 = (j * np.pi / L) ** 4 * EI / m
        shape = np.where(on, np.sqrt(2 / (m * L)) * np.sin(j * np.pi * x / L), 0.0)
        q = (shape * Q).sum(axis=1) / wj2
        w += q[:, None] * np.sqrt(2 / (m * L)) * np.sin(j * np.pi * points / L)[None, :]
    np.testing.assert_allclose(got, np.abs(w).max(axis=0), rtol=1e-9)
    big = tmp_path / "big"
    big.mkdir()
    code = ("import sys\nfrom vsi_numba.config import load_config\n"
            "from vsi_numba.solver.simulate import static_deck_envelope\n"
            "c = load_config(sys.argv[1])\n"
            "static_deck_envelope(c.build_bridge(), c.trains()[0], [10.0])\n"
            "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')]\n"
            "print(hwm[0])\n")
    proc = subprocess.run([sys.executable, "-c", code, str(_axle_config(big, 20000))],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert int(proc.stdout.split()[-1]) < 600 * 1024, proc.stdout
