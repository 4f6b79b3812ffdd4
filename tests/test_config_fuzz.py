"""Fuzzing the config language: malformed input must give a ConfigError, fast, never a crash.

A seeded mutator turns valid configs into configs that are invalid *by construction*
(deleted required keys, wrong types, out-of-range values, unknown keys, garbage strings,
truncated TOML text, junk files).  Every case goes through ``load_config`` on the mapping,
``load_config`` on a TOML file and the CLI (``vsi run``, exit code 2), under a per-case
time budget.  No simulation runs: validation happens before any computation.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import math
import random
import re
import signal
import string
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vsi_numba.config import Config, ConfigError, load_config
from vsi_numba.config.schema.keys import all_keys, required_paths

SEED = 20261121
N_DICT_CASES = 210  # mutated mappings (each also as a TOML file and through the CLI)
N_TEXT_CASES = 48  # truncated TOML texts
CASE_BUDGET = 5.0  # s per load_config call: validation is ms-scale; 5 s only flags a hang

#: Filled by the tests below (readable without ``-s``; also printed via capsys.disabled).
FUZZ_STATS: dict[str, int] = {}

HAS_CLI_RUN = importlib.util.find_spec("vsi_numba.cli.run") is not None

# Every key name of the config language (the declared keys of vsi_numba.config.schema):
# typos are filtered against it so that a mutated key is surely unknown.
KNOWN_KEYS = all_keys()

# Deleting one of these always invalidates the base configs below: the keys the config
# models declare required (for the kind at hand), and the one-of keys the bases give alone
# (no base carries a key that another one makes optional, e.g. no line_speed_kmh next to
# speeds_kmh).
ONE_OF = {"train.preset", "train.vehicles", "study.speeds_kmh"}


def _required(data) -> set[str]:
    return required_paths(data) | ONE_OF


# must be > 0 (zero, negative, nan and -inf are invalid)
POSITIVE = {
    "spans", "EI", "mass_per_length", "mass", "stiffness", "load", "body_mass",
    "body_pitch_inertia", "bogie_mass", "bogie_pitch_inertia", "wheelset_mass",
    "bogie_spacing", "wheelbase", "primary_stiffness", "secondary_stiffness", "dt",
    "speeds_kmh", "start", "stop", "step", "wavelength", "wavelength_min", "wavelength_max",
    "length", "n_modes", "max_frequency", "elements_per_span", "max_iterations",
    "line_speed_kmh", "history_speeds_kmh",
    # decks in space, trains on other tracks, fatigue, compatibility, code profile
    "gauge", "GJ", "polar_mass", "track", "section_modulus", "detail_category", "gamma_Ff",
    "gamma_Mf", "speed_kmh", "per_day", "design_life_years", "speed_factor",
    "deck_acceleration_limit_ballasted", "wheel_unloading_limit", "value",
}
# must be >= 0 (negative values are invalid)
NON_NEGATIVE = {
    "damping", "wheel_mass", "offset", "approach", "free_vibration", "primary_damping",
    "secondary_damping", "seeds", "damping_ratio", "max_subdivisions", "x",
}
# strings from a closed set (or a file that must exist): garbage is invalid
CHOICE_KEYS = {"kind", "spectrum", "model", "preset", "output", "path", "r_unit", "shape",
               "direction", "train", "line", "file", "deck_type", "track_type"}

#: A modes table of a 20 m span with two tracks, each by its rails ("up/left", ...):
#: three sine modes, the same shape on every line (no torsion).
TRACK_MODES = "mode,frequency,modal_mass,line,x,shape\n" + "".join(
    f"{j},{j * j * 5.6:.3f},{1.2e5:.1f},{t}/{side},{x:g},"
    f"{math.sin(j * math.pi * x / 20):.8f}\n"
    for j in (1, 2, 3) for t in ("up", "down") for side in ("left", "right")
    for x in np.linspace(0.0, 20.0, 41))
PROFILE = "x,r\n" + "\n".join(f"{x:.2f},{1e-3 * math.sin(x):.6e}"
                              for x in np.arange(-40.0, 60.01, 0.25)) + "\n"


def _bases() -> list[tuple[str, dict]]:
    sprung = {
        "title": "sprung",
        "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": 8.323e9,
                   "mass_per_length": 2303.0, "n_modes": 3, "damping_ratio": 0.01,
                   "output_points": [6.25, 12.5]},
        "train": {"vehicles": [{"kind": "sprung_mass", "offset": 0.0, "mass": 5750.0,
                                "stiffness": 1.595e6, "damping": 100.0, "wheel_mass": 10.0}]},
        "irregularity": {"kind": "cosine", "depth": 1e-3, "wavelength": 5.0, "position": 10.0},
        "solver": {"dt": 1e-3, "hht_alpha": -0.1, "approach": 5.0, "free_vibration": 0.5,
                   "max_iterations": 50, "max_subdivisions": 4},
        "contact": {"model": "rigid"},
        "study": {"speeds_kmh": [100.0, 200.0], "output": "results/sprung.nc",
                  "save_time_histories": True, "history_speeds_kmh": [100.0]},
    }
    car = {"kind": "car", "body_mass": 4.0e4, "body_pitch_inertia": 2.0e6, "bogie_mass": 3.0e3,
           "bogie_pitch_inertia": 2.0e3, "wheelset_mass": 1.8e3, "bogie_spacing": 17.5,
           "wheelbase": 2.5, "primary_stiffness": 2.4e6, "primary_damping": 2.0e4,
           "secondary_stiffness": 7.0e5, "secondary_damping": 4.0e4}
    cars = {
        "title": "cars",
        "bridge": {"kind": "continuous", "spans": [15.0, 20.0], "EI": [2e10, 3e10],
                   "mass_per_length": 1.2e4, "max_frequency": 60.0, "elements_per_span": 8},
        "train": {"vehicles": [dict(car, offset=0.0, name="front"),
                               dict(car, offset=25.0, name="rear"),
                               {"kind": "force", "offset": 50.0, "load": 1.5e5}]},
        "irregularity": {"kind": "psd", "spectrum": "german_low", "wavelength_min": 3.0,
                         "wavelength_max": 60.0, "seeds": [1, 2],
                         "defects": [{"kind": "cosine", "depth": 1e-3, "wavelength": 4.0,
                                      "position": 5.0},
                                     {"kind": "step", "height": 5e-4, "length": 3.0,
                                      "position": 20.0, "shape": "quintic"}]},
        "solver": {"dt": 5e-4},
        "study": {"speeds_kmh": {"start": 150.0, "stop": 300.0, "step": 50.0}},
    }
    user = {
        "title": "user",
        "bridge": {"kind": "rigid", "spans": [30.0]},
        "train": {"vehicles": [{"kind": "user", "M": [[1000.0, 0.0], [0.0, 50.0]],
                                "C": [[10.0, -10.0], [-10.0, 10.0]],
                                "K": [[1e6, -1e6], [-1e6, 1e6]], "wheel_dofs": [1],
                                "wheel_positions": [0.0], "body_dof": 0,
                                "gravity": [9810.0, 490.5]}]},
        "irregularity": {"kind": "file", "path": "profile.csv", "r_unit": "m"},
        "study": {"speeds_kmh": [80.0]},
    }
    presets = {
        "title": "presets",
        "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 1.5e10,
                   "mass_per_length": 1.0e4, "n_modes": 3},
        "train": {"preset": ["HSLM-A1", "ICE3"], "model": "moving_force"},
        "study": {"speeds_kmh": [200.0, 250.0], "output": "out/presets.nc"},
    }
    space = {
        "title": "space",
        "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 1.5e10,
                   "mass_per_length": 1.0e4, "n_modes": 3, "damping_ratio": 0.01,
                   "tracks": [{"eccentricity": 2.0, "gauge": 1.435}, {"eccentricity": -2.0}],
                   "torsion": {"GJ": 1.0e10, "polar_mass": 4.0e4, "damping_ratio": 0.01,
                               "n_modes": 2}},
        "train": {"preset": "HSLM-A1", "model": "moving_force", "track": 1,
                  "other_trains": [{"track": 2, "direction": "opposite", "offset": 10.0}]},
        "study": {"speeds_kmh": [200.0, 250.0]},
    }
    checks = {
        "title": "checks",
        "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": 2.2e10,
                   "mass_per_length": 1.1e4, "n_modes": 3, "damping_ratio": "EN1991-2",
                   "deck_type": "steel_composite", "track_type": "ballasted"},
        "train": {"preset": ["HSLM-A1", "ICE3"], "model": "moving_force"},
        "study": {"speeds_kmh": [200.0, 230.0]},
        "code_profile": {"name": "client rule", "overrides": {
            "deck_acceleration_limit_ballasted": 3.0,
            "wheel_unloading_limit": {"value": 0.5, "clause": "R-12"}}},
        "fatigue": {"design_life_years": 100.0,
                    "sections": [{"x": 10.0, "section_modulus": 0.11, "detail_category": 71,
                                  "gamma_Ff": 1.0, "gamma_Mf": 1.35, "name": "flange"}],
                    "traffic": [{"train": "ICE3", "speed_kmh": 200.0, "per_day": 20,
                                 "model": "moving_force"}]},
        "compatibility": {"train": "ICE3", "line_speed_kmh": 200.0, "speed_factor": 1.1},
    }
    imported = {
        "title": "imported",
        "bridge": {"kind": "modes_file", "file": "tracks_modes.csv", "spans": [20.0],
                   "damping_ratio": 0.01,
                   "tracks": [{"line": "up", "eccentricity": 2.0}, {"line": "down"}]},
        "train": {"preset": "HSLM-A1", "model": "moving_force", "track": 2},
        "study": {"speeds_kmh": [200.0]},
    }
    return [("sprung", sprung), ("cars", cars), ("user", user), ("presets", presets),
            ("space", space), ("checks", checks), ("imported", imported)]


# ------------------------------------------------------------------------ TOML writer


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _toml_str(k)


def _toml_str(s: str) -> str:
    out = json.dumps(s, ensure_ascii=False)  # escapes ", \ and C0 controls like TOML does
    return out.replace("\x7f", "\\u007f")


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(type(v))


def to_toml(data: dict) -> str:
    """Write a mapping as TOML: top-level tables as sections, arrays of tables as [[...]]."""
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in data.items()
             if not isinstance(v, dict)]
    for k, v in data.items():
        if not isinstance(v, dict):
            continue
        lines.append(f"\n[{_toml_key(k)}]")
        arrays = []
        for kk, vv in v.items():
            if isinstance(vv, list) and vv and all(isinstance(x, dict) for x in vv):
                arrays.append((kk, vv))
            else:
                lines.append(f"{_toml_key(kk)} = {_toml_value(vv)}")
        for kk, vv in arrays:
            for item in vv:
                lines.append(f"\n[[{_toml_key(k)}.{_toml_key(kk)}]]")
                lines += [f"{_toml_key(a)} = {_toml_value(b)}" for a, b in item.items()]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- mutator


def _leaves(node, path=""):
    """Yield (path, parent, key, value) for every value below ``node`` (tables and items)."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for k, v in items:
        p = (f"{path}.{k}" if path else k) if isinstance(node, dict) else f"{path}[{k}]"
        yield p, node, k, v
        if isinstance(v, dict | list):
            yield from _leaves(v, p)


def _name(path: str) -> str:
    """Key name governing ``path`` (list items take the name of their list)."""
    return re.sub(r"(\[\d+\])+$", "", path).rsplit(".", 1)[-1]


def _garbage(rng: random.Random) -> str:
    special = ["", " ", "\n", "\t", "none ", "NONE!", "a" * 3000, "${HOME}", "__import__('os')",
               "1e3", "null", "../../", "\u00e9\u00e8\u4e2d\u6587", "\x01\x02", "\x7f",
               "rigid;rm -rf /", "=", "[[x]]"]
    if rng.random() < 0.4:
        return rng.choice(special)
    alphabet = string.ascii_letters + string.digits + string.punctuation + " \u00e9\u00df\u03a9"
    return "".join(rng.choice(alphabet) for _ in range(rng.randint(1, 40)))


def _typo(key: str, rng: random.Random) -> str:
    ops = ["drop", "swap", "double", "upper", "plural", "prefix"]
    for _ in range(20):
        op = rng.choice(ops)
        i = rng.randrange(len(key))
        if op == "drop" and len(key) > 1:
            new = key[:i] + key[i + 1:]
        elif op == "swap" and len(key) > 1:
            i = min(i, len(key) - 2)
            new = key[:i] + key[i + 1] + key[i] + key[i + 2:]
        elif op == "double":
            new = key[:i] + key[i] + key[i:]
        elif op == "upper":
            new = key.swapcase()
        elif op == "plural":
            new = key + "s"
        else:
            new = "x_" + key
        if new not in KNOWN_KEYS and new:
            return new
    return "zz_" + key


def _wrong_type(value, rng: random.Random):
    if isinstance(value, bool):
        return rng.choice(["yes", 1, 0.0, [True]])
    if isinstance(value, int | float):
        return rng.choice(["garbage", True, {"x": 1}, [["nested"]], "1e3"])
    if isinstance(value, str):
        return rng.choice([42, 3.5, True, {"k": "v"}, ["a", 1]])
    if isinstance(value, list):
        return rng.choice(["garbage", True, {"zzz": 1}])
    return rng.choice(["garbage", True, ["x"]])  # a table


def _bad_number(name: str, value, rng: random.Random):
    integer = isinstance(value, int) and not isinstance(value, bool)
    if name in POSITIVE:
        return rng.choice([0, -1] if integer else [0.0, -abs(value) - 1.0, float("nan"),
                                                   float("-inf"), -1e-300])
    return rng.choice([-1] if integer else [-abs(value) - 1.0, float("-inf"), float("nan")])


SINGLE_OPS = ("delete", "wrong_type", "bad_number", "unknown_key", "garbage")


def mutate(base: dict, rng: random.Random, ops=SINGLE_OPS + ("special", "several")):
    """Return (operator, mutated copy of ``base``), invalid by construction."""
    data = copy.deepcopy(base)
    op = rng.choice(ops)
    if op == "several":
        for _ in range(rng.randint(2, 4)):
            _, data = mutate(data, rng, SINGLE_OPS)
        return op, data
    if op == "special":
        return _special(data, rng)
    leaves = list(_leaves(data))
    cands = {
        "delete": [x for x in leaves if x[0] in _required(data)],
        "wrong_type": leaves,
        "bad_number": [x for x in leaves if _name(x[0]) in POSITIVE | NON_NEGATIVE
                       and isinstance(x[3], int | float) and not isinstance(x[3], bool)],
        "garbage": [x for x in leaves if _name(x[0]) in CHOICE_KEYS and isinstance(x[3], str)],
    }
    if not cands.get(op, True):
        op = "unknown_key"  # nothing left to mutate that way (after earlier mutations)
    if op == "unknown_key":
        tables = [data] + [x[3] for x in leaves if isinstance(x[3], dict)]
        table = rng.choice(tables)
        if table and rng.random() < 0.6:
            old = rng.choice(list(table))
            table[_typo(old, rng)] = table.pop(old)
        else:
            table["zz" + "".join(rng.choice(string.ascii_lowercase) for _ in range(5))] = (
                rng.choice([1, "x", [1.0], {"a": 1}, True]))
        return op, data
    path, parent, key, v = rng.choice(cands[op])
    if op == "delete":
        del parent[key]
    elif op == "wrong_type":
        parent[key] = _wrong_type(v, rng)
    elif op == "bad_number":
        parent[key] = _bad_number(_name(path), v, rng)
    else:
        g = _garbage(rng)
        parent[key] = g + "x" if g.endswith(".nc") else g
    return op, data


def _special(data: dict, rng: random.Random) -> tuple[str, dict]:
    """Cross-key errors: values valid alone, invalid together."""
    b, study = data["bridge"], data["study"]
    choices = ["alpha", "points", "history", "empty_table"]
    if len(data["train"].get("vehicles", [])) > 1:
        choices.append("overlap")
    if b["kind"] != "rigid":
        choices.append("fmax")
    if isinstance(study["speeds_kmh"], dict):
        choices.append("reversed_grid")
    if data.get("irregularity", {}).get("kind") == "psd":
        choices += ["band", "seeds"]
    what = rng.choice(choices)
    if what == "alpha":
        data["solver"] = dict(data.get("solver", {}), hht_alpha=rng.choice([0.1, -0.34, -1.0, 5]))
    elif what == "points":
        end = sum(b["spans"])
        b["output_points"] = [end / 2, rng.choice([end + 0.5, -0.5, 1e9])]
    elif what == "history":
        study["history_speeds_kmh"] = [123.456]
    elif what == "empty_table":
        data[rng.choice(["bridge", "train", "study"])] = {}
    elif what == "overlap":
        vs = data["train"]["vehicles"]
        vs[1]["offset"] = vs[0].get("offset", 0.0) + rng.choice([0.0, 1.0, 10.0])
    elif what == "fmax":
        b.pop("n_modes", None)
        b["max_frequency"] = 0.5
    elif what == "reversed_grid":
        s = study["speeds_kmh"]
        s["start"], s["stop"] = s["stop"] + 10.0, s["start"]
    elif what == "band":
        irr = data["irregularity"]
        irr["wavelength_min"], irr["wavelength_max"] = irr["wavelength_max"], irr["wavelength_min"]
    else:
        data["irregularity"]["seeds"] = [3, 3]
    return f"special:{what}", data


def truncate(text: str, rng: random.Random) -> str:
    """Cut a TOML text inside a key or right after ``=`` / inside a header: a syntax error."""
    lines = text.splitlines()
    idx = [i for i, line in enumerate(lines) if line.strip() and not line.startswith("#")]
    i = rng.choice(idx)
    line = lines[i]
    if line.startswith("["):
        cut = rng.randint(1, len(line.rstrip("]")) - 1 if line.startswith("[[") else len(line) - 1)
        cut = min(cut, len(line) - 1)
    else:
        eq = line.index("=")
        cut = rng.randint(1, eq + 1)
    return "\n".join(lines[:i] + [line[:cut]])


def junk_files() -> list[tuple[str, bytes]]:
    """Files that are not TOML configs at all."""
    good = to_toml(_bases()[0][1]).encode()
    return [
        ("binary", bytes(range(256)) * 4),
        ("netcdf-like", b"\x89HDF\r\n\x1a\n" + b"\x00" * 64),
        ("latin-1", "title = \"caf\xe9\"\n".encode("latin-1")),
        ("json", json.dumps(_bases()[0][1]).encode()),
        ("empty", b""),
        ("comment-only", b"# nothing here\n"),
        ("bom", b"\xef\xbb\xbf" + good),
        ("duplicate-key", good + b"\n[solver]\ndt = 1e-3\n"),
        ("duplicate-table", good.replace(b"[study]", b"[bridge]\n[study]", 1)),
        ("csv", b"x,r\n0,0\n1,0\n"),
        ("yaml", b"bridge:\n  kind: rigid\n"),
        ("nul", b"title = \"a\x00b\"\n"),
    ]


# ------------------------------------------------------------------------ harness


class _Timeout(Exception):
    pass


@contextmanager
def budget(seconds: float):
    """Fail a case that runs longer than ``seconds`` (SIGALRM; main thread, POSIX)."""
    def handler(signum, frame):
        raise _Timeout(f"case exceeded {seconds} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


def expect_config_error(arg, label: str, **kw) -> tuple[list[str], float]:
    """Run load_config; return the errors and the elapsed time.  Anything else fails."""
    t0 = time.perf_counter()
    try:
        with budget(CASE_BUDGET):
            cfg = load_config(arg, **kw)
    except ConfigError as exc:
        assert exc.errors, label
        for e in exc.errors:
            assert "\n" not in e and e.strip(), (label, e)
        return exc.errors, time.perf_counter() - t0
    assert not isinstance(cfg, Config), f"{label}: a malformed config was accepted"
    raise AssertionError(label)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "profile.csv").write_text(PROFILE)
    (d / "tracks_modes.csv").write_text(TRACK_MODES)
    return d


def test_config_fuzz__bases_are_valid(workdir):
    for name, data in _bases():
        cfg = load_config(data, base_dir=workdir)
        assert cfg.title == name
        import tomllib

        assert tomllib.loads(to_toml(data)) == data  # the writer round-trips
        p = workdir / f"{name}.toml"
        p.write_text(to_toml(data), encoding="utf-8")
        from_file = load_config(p).resolved()
        expected = cfg.resolved()
        if "output" not in data["study"]:  # default output: results/<file stem>.nc
            assert from_file["study"].pop("output") == f"results/{name}.nc"
            expected["study"].pop("output")
        assert from_file == expected


def _cli_check(runner, app, path: Path, first_error: str, label: str) -> None:
    with budget(CASE_BUDGET):
        result = runner.invoke(app, ["run", str(path)])
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        label, repr(result.exception))
    assert result.exit_code == 2, (label, result.exit_code, result.output[-2000:])
    head = first_error.split(" ")[0][:30]
    assert head in result.output.replace("\n", ""), (label, head, result.output[-2000:])


def test_config_fuzz__malformed_configs(workdir, capsys):
    rng = random.Random(SEED)
    bases = _bases()
    runner = app = None
    if HAS_CLI_RUN:
        from typer.testing import CliRunner

        from vsi_numba.cli import app

        runner = CliRunner()
        import vsi_numba.cli.run  # noqa: F401 - warm-up: imports are not part of a case
    for _bname, data in bases:  # warm-up: library and profile readers load once
        load_config(data, base_dir=workdir)
    t_loop = time.perf_counter()
    messages: set[str] = set()
    ops: dict[str, int] = {}
    slowest = 0.0
    n_cases = n_cli = 0
    for k in range(N_DICT_CASES):
        bname, base = bases[k % len(bases)]
        op, data = mutate(base, rng)
        label = f"case {k} ({bname}, {op})"
        ops[op.split(":")[0]] = ops.get(op.split(":")[0], 0) + 1
        errs, dt = expect_config_error(data, label, base_dir=workdir)
        slowest = max(slowest, dt)
        messages.update(errs)
        # the same mapping written as a TOML file: the same errors (file-level ones aside)
        path = workdir / f"case{k}.toml"
        try:
            text = to_toml(data)
        except TypeError:
            text = None
        if text is not None:
            path.write_text(text, encoding="utf-8")
            ferrs, dt = expect_config_error(path, label + " [file]")
            slowest = max(slowest, dt)
            if not any("TOML syntax error" in e for e in ferrs):
                assert sorted(ferrs) == sorted(errs), label  # order: the file's sections
            if runner is not None:
                _cli_check(runner, app, path, ferrs[0], label + " [cli]")
                n_cli += 1
        n_cases += 1
    for k in range(N_TEXT_CASES):
        bname, base = bases[k % len(bases)]
        text = truncate(to_toml(base), rng)
        path = workdir / f"trunc{k}.toml"
        path.write_text(text, encoding="utf-8")
        label = f"truncated {k} ({bname}): {text.splitlines()[-1]!r}"
        errs, dt = expect_config_error(path, label)
        assert len(errs) == 1 and "TOML syntax error" in errs[0], (label, errs)
        assert re.search(r"line \d+, column \d+", errs[0]), (label, errs)
        slowest = max(slowest, dt)
        messages.update(e.replace(str(path), "<file>") for e in errs)
        if runner is not None and k % 4 == 0:
            _cli_check(runner, app, path, errs[0], label + " [cli]")
            n_cli += 1
        n_cases += 1
    for name, blob in junk_files():
        path = workdir / f"junk-{name}.toml"
        path.write_bytes(blob)
        errs, dt = expect_config_error(path, f"junk {name}")
        messages.update(e.replace(str(path), "<file>") for e in errs)
        if runner is not None:
            _cli_check(runner, app, path, errs[0], f"junk {name} [cli]")
            n_cli += 1
        n_cases += 1
    FUZZ_STATS.update(cases=n_cases, cli_cases=n_cli, distinct_messages=len(messages),
                      slowest_ms=round(1000 * slowest),
                      loop_s=round(time.perf_counter() - t_loop, 1),
                      **{f"op_{k}": v for k, v in ops.items()})
    with capsys.disabled():
        print(f"\nconfig fuzz: {FUZZ_STATS}")
    assert n_cases >= 200
    assert len(messages) >= 200, FUZZ_STATS  # the messages are specific, not one generic text
    assert set(ops) >= {"delete", "wrong_type", "bad_number", "unknown_key", "garbage",
                        "special", "several"}
    assert slowest < CASE_BUDGET


# ---------------------------------------------------- hypothesis: never another exception

_garbage_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=4),
    max_leaves=8,
)


@settings(max_examples=100, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_config_fuzz__arbitrary_values_never_crash(data):
    """Any value at any key path: a Config or a ConfigError, nothing else, no warning."""
    name, base = data.draw(st.sampled_from(_bases()[:2] + _bases()[3:]), label="base")
    mutated = copy.deepcopy(base)
    leaves = list(_leaves(mutated))
    _p, parent, key, _v = data.draw(st.sampled_from(leaves), label="where")
    parent[key] = data.draw(_garbage_values, label="value")
    try:
        with budget(CASE_BUDGET):
            load_config(mutated)
    except ConfigError as exc:
        assert all("\n" not in e for e in exc.errors)
