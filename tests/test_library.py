"""Tests of the train library (vsi_numba.model.library).

References: the check values of the package data file (computed by its compiler with its
own script, independent of this code: lever rule for static loads, a separate 6-DOF
eigen-solve), the HSLM-A table of docs/manual/trains.md typed in here, Karoumi's
recursive HSLM-A spacing, and static solves / matrix assemblies written in this file.
"""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
import pytest
import scipy.linalg

from vsi_numba.cli.trains import trains_command
from vsi_numba.model import library as lib
from vsi_numba.model.library import (
    UnknownTrainError,
    axle_table,
    get_train,
    get_vehicle,
    library_table,
    list_presets,
    load_user_trains,
    status_warning,
)

G = 9.81  # m/s2, the data file's g

DATA = tomllib.loads(
    resources.files("vsi_numba").joinpath("data", "trains.toml").read_text("utf-8")
)
VEHICLES = {v["id"]: v for v in DATA["vehicle"]}
TRAINS = {t["id"]: t for t in DATA["train"]}

# docs/manual/trains.md (HSLM-A table): train, N, D (m), d (m), P (kN)
HSLM_TABLE = [
    ("HSLM-A1", 18, 18.0, 2.0, 170.0),
    ("HSLM-A2", 17, 19.0, 3.5, 200.0),
    ("HSLM-A3", 16, 20.0, 2.0, 180.0),
    ("HSLM-A4", 15, 21.0, 3.0, 190.0),
    ("HSLM-A5", 14, 22.0, 2.0, 170.0),
    ("HSLM-A6", 13, 23.0, 2.0, 180.0),
    ("HSLM-A7", 13, 24.0, 2.0, 190.0),
    ("HSLM-A8", 12, 25.0, 2.5, 190.0),
    ("HSLM-A9", 11, 26.0, 2.0, 210.0),
    ("HSLM-A10", 11, 27.0, 2.0, 210.0),
]

STATIC_TOL = 0.06  # N: the file rounds loads to 0.1 N (error <= 0.05 N) + solve rounding


@pytest.fixture(autouse=True)
def _no_user_trains():
    lib.clear_user_trains()
    yield
    lib.clear_user_trains()


# ------------------------------------------------------------------- independent helpers


def static_loads_constrained(M, K, wheel_dofs, gravity):
    """Wheel loads (N, down) from the saddle-point system K u + B^T X = g, B u = 0."""
    n = K.shape[0]
    B = np.zeros((len(wheel_dofs), n))
    B[np.arange(len(wheel_dofs)), wheel_dofs] = 1.0
    A = np.block([[K, B.T], [B, np.zeros((B.shape[0], B.shape[0]))]])
    sol = np.linalg.solve(A, np.concatenate([gravity, np.zeros(B.shape[0])]))
    # K u = g - B^T X: the rail pushes the wheel up by X, i.e. X is the wheel load (down)
    return sol[n:]


def fixed_wheel_frequencies(M, K, wheel_dofs):
    keep = np.setdiff1d(np.arange(K.shape[0]), wheel_dofs)
    lam = scipy.linalg.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)


def vehicle_mass(v):
    """Sum of translational masses (kg): DOFs named *_bounce."""
    idx = [i for i, nm in enumerate(v.dof_names) if nm.endswith("_bounce")]
    return float(np.diag(v.M)[idx].sum())


def train_static_axles(train):
    """(positions, loads) of a multibody train by the constrained static solve, sorted."""
    pos, load = [], []
    for v, o in zip(train.vehicles, train.offsets, strict=True):
        pos.append(o + v.wheel_positions)
        load.append(static_loads_constrained(v.M, v.K, v.wheel_dofs, v.gravity))
    pos, load = np.concatenate(pos), np.concatenate(load)
    order = np.argsort(pos, kind="stable")
    return pos[order], load[order]


def car_matrices(w, spacing, wheelbase, cg_front):
    """10-DOF planar car written out by hand (TTB-2D layout), positions behind axle 1.

    DOFs: 0 body z, 1 body pitch, 2/3 front bogie z/pitch, 4/5 rear bogie z/pitch,
    6..9 wheelsets.  z down, pitch nose-down: point p moves z + (p_cg - p) theta.
    """
    h = 0.5 * wheelbase
    pb = [h, h + spacing]
    pcg = h + cg_front
    M = np.diag([w["body_mass"], w["body_pitch_inertia"], w["bogie_mass"],
                 w["bogie_pitch_inertia"], w["bogie_mass"], w["bogie_pitch_inertia"]]
                + [w["wheelset_mass"]] * 4)
    K = np.zeros((10, 10))
    C = np.zeros((10, 10))
    for b in range(2):
        e = np.zeros(10)
        e[0], e[1] = 1.0, pcg - pb[b]
        e[2 + 2 * b] = -1.0
        K += w["secondary_stiffness"] * np.outer(e, e)
        C += w["secondary_damping"] * np.outer(e, e)
        for s, wheel in ((-h, 6 + 2 * b), (h, 7 + 2 * b)):
            e = np.zeros(10)
            e[2 + 2 * b], e[3 + 2 * b] = 1.0, -s
            e[wheel] = -1.0
            K += w["primary_stiffness"] * np.outer(e, e)
            C += w["primary_damping"] * np.outer(e, e)
    return M, K, C


# ------------------------------------------------------------------------------- HSLM


def karoumi_positions(N, D, d):
    """HSLM-A axles by cumulative spacings (Karoumi's recursion, docs/manual/trains.md)."""
    gap = D - 1.5 * d - 3.525 / 2
    sp = [3.0, 11.0, 3.0, 3.525, d, gap] + [d, D - d] * N + [d, gap, d, 3.525, 3.0, 11.0, 3.0]
    return np.concatenate([[0.0], np.cumsum(sp)])


@pytest.mark.parametrize(("name", "N", "D", "d", "P_kN"), HSLM_TABLE)
def test_hslm__geometry_and_loads(name, N, D, d, P_kN):
    t = get_train(name, "moving_force")
    x = np.sort(t.axle_positions)
    loads = np.concatenate([v.loads for v in t.vehicles])
    assert x.size == 2 * N + 14
    assert loads.size == x.size and np.all(loads == P_kN * 1e3)
    # float sums of decimal inputs: 1e-9 m
    assert x[-1] - x[0] == pytest.approx(37.525 + (N + 2) * D, abs=1e-9)
    np.testing.assert_allclose(x, karoumi_positions(N, D, d), rtol=0, atol=1e-9)
    s = np.diff(x)
    np.testing.assert_allclose(s[:5], [3.0, 11.0, 3.0, 3.525, d], atol=1e-9)
    np.testing.assert_allclose(s[-5:], [d, 3.525, 3.0, 11.0, 3.0], atol=1e-9)
    assert s[5] == pytest.approx(D - 1.5 * d - 1.7625, abs=1e-9)
    # the regular coach spacing: leading axles of consecutive articulated bogies are D apart
    np.testing.assert_allclose(np.diff(x[6 : 6 + 2 * (N + 1) : 2]), D, atol=1e-9)
    assert t.regular_length == D and t.status == "standard" and t.name == name
    assert t.total_mass == pytest.approx(x.size * P_kN * 1e3 / G, rel=1e-12)  # weight / g
    with pytest.raises(ValueError, match="moving_force"):
        get_train(name, "interaction")


@pytest.mark.parametrize("key", ["A1", "A10"])
def test_hslm__exact_check_axle_lists(key):
    chk = DATA["hslm"]["check"][key]
    x = np.sort(get_train(f"HSLM-{key}", "moving_force").axle_positions)
    np.testing.assert_array_equal(x, np.asarray(chk["axle_positions"]))  # exact (rounded 1e-9)
    assert x.size == chk["n_axles"]


# -------------------------------------------------------------------- vehicle entries


@pytest.mark.parametrize("vid", list(VEHICLES))
def test_vehicle__mass_static_loads_frequencies(vid):
    entry = VEHICLES[vid]
    v = get_vehicle(vid)
    chk = entry["check"]
    assert vehicle_mass(v) == pytest.approx(chk["total_mass"], abs=0.06)  # file: 0.1 kg
    loads = static_loads_constrained(v.M, v.K, v.wheel_dofs, v.gravity)
    np.testing.assert_allclose(loads, chk["static_axle_loads"], rtol=0, atol=STATIC_TOL)
    np.testing.assert_allclose(v.wheel_positions, entry["axle_offsets"], atol=1e-12)
    # the file rounds frequencies to 4 decimals: 1e-3 relative is >= 3 rounding units
    f = fixed_wheel_frequencies(v.M, v.K, v.wheel_dofs)
    np.testing.assert_allclose(f, chk["natural_frequencies_fixed_wheels"], rtol=1e-3)
    assert v.status == entry["status"]


def test_vehicle__library_assembly_equals_hand_written_car():
    e = VEHICLES["eurostar_ec1"]
    v = get_vehicle("eurostar_ec1")
    M, K, C = car_matrices(e["whole"], e["bogie_spacing"], e["wheelbase"],
                           e["body_cg_to_front_bogie"])
    # same DOF order as railway_car; assembly differs only by rounding
    np.testing.assert_allclose(v.M, M, rtol=1e-13, atol=0)
    np.testing.assert_allclose(v.K, K, rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(v.C, C, rtol=1e-12, atol=1e-6)


# ---------------------------------------------------------------------- train entries


def _check_axles(tid):
    chk = TRAINS[tid]["check"]
    if "merged_axle_positions" in chk:
        return np.asarray(chk["merged_axle_positions"]), np.asarray(chk["merged_static_axle_loads"])
    return np.asarray(chk["axle_positions"]), np.asarray(chk["static_axle_loads"])


@pytest.mark.parametrize("tid", list(TRAINS))
def test_train__static_axle_loads_and_positions_match_file(tid):
    t = get_train(tid, "interaction")
    entry = TRAINS[tid]
    x_ref, q_ref = _check_axles(tid)
    x, q = train_static_axles(t)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-9)  # decimal sums of offsets
    np.testing.assert_allclose(q, q_ref, rtol=0, atol=STATIC_TOL)
    assert sum(vehicle_mass(v) for v in t.vehicles) == pytest.approx(entry["total_mass"],
                                                                      abs=0.5)  # 0.1 kg x n
    assert t.status == entry["status"]
    # moving-force model: the same axles and loads as point forces
    mf = get_train(tid, "moving_force")
    xm = np.concatenate([o + v.load_positions for v, o in zip(mf.vehicles, mf.offsets,
                                                               strict=True)])
    qm = np.concatenate([v.loads for v in mf.vehicles])
    order = np.argsort(xm, kind="stable")
    np.testing.assert_allclose(xm[order], x_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(qm[order], q_ref, rtol=0, atol=STATIC_TOL)
    assert mf.n_wheels == 0 and mf.status == entry["status"]


def test_train__ice3_is_eight_coupled_cars():
    t = get_train("ICE3")
    assert t.name == "ICE3" and len(t.vehicles) == 8
    np.testing.assert_allclose(t.offsets, TRAINS["ave_s103_8car"]["vehicle_offsets"], atol=0)
    assert all(v.n_dof == 10 for v in t.vehicles)
    assert t.regular_length == pytest.approx(24.775, abs=1e-9)  # rounded pitch


def test_train__eurostar_articulated_part_is_one_vehicle_with_shared_bogies():
    t = get_train("Eurostar")
    assert t.status == "reconstruction"
    assert [v.n_wheels for v in t.vehicles] == [4, 20, 4]  # 10 bogie positions x 2 axles
    art = t.vehicles[1]
    assert art.n_dof == 9 * 2 + 10 * 2 + 20
    names = art.dof_names
    mass = dict(zip(names, np.diag(art.M), strict=True))
    w = {k: VEHICLES[k]["whole"] for k in ("eurostar_ec1_recon", "eurostar_ec2_ec8")}
    # EC1 front bogie alone; EC1/EC2 and EC2/EC3 Jacobs bogies: sums of the half-bogies
    assert mass["bogie1_bounce"] == w["eurostar_ec1_recon"]["bogie_mass"]
    assert mass["bogie2_bounce"] == (w["eurostar_ec1_recon"]["bogie_mass"]
                                     + w["eurostar_ec2_ec8"]["bogie_mass"])
    assert mass["bogie3_bounce"] == 2 * w["eurostar_ec2_ec8"]["bogie_mass"]
    assert mass["bogie3_pitch"] == 2 * w["eurostar_ec2_ec8"]["bogie_pitch_inertia"]
    assert mass["wheelset3a_bounce"] == 2 * w["eurostar_ec2_ec8"]["wheelset_mass"]
    as_coded = get_train("eurostar_ttb2d_as_coded")
    assert as_coded.status == "suspect"
    assert [v.n_wheels for v in as_coded.vehicles] == [4, 4, 16, 4, 4]  # EC1, EC9 coupled
    assert get_train("eurostar_halfset_reconstructed").name == "eurostar_halfset_reconstructed"


def test_train__shared_bogie_model_is_ttb2d_model_with_halves_tied():
    """The articulated vehicle equals TTB-2D's coincident half-bogie cars, constrained.

    Reference: the cars assembled by hand (car_matrices), block-diagonal, then the
    coincident half-bogies (bounce, pitch) and coincident wheelsets tied by a Boolean
    transformation T: K_tied = T^T K T.  Compare the wheels-fixed frequencies.
    """
    tid = "eurostar_halfset_reconstructed"
    ids = TRAINS[tid]["vehicles"][1:-1]
    n = len(ids)
    Ms, Ks, Cs = zip(*(car_matrices(VEHICLES[i]["whole"], VEHICLES[i]["bogie_spacing"],
                                    VEHICLES[i]["wheelbase"],
                                    VEHICLES[i]["body_cg_to_front_bogie"]) for i in ids),
                     strict=True)
    M, K = scipy.linalg.block_diag(*Ms), scipy.linalg.block_diag(*Ks)
    # reduced DOFs: bodies (2 per car), bogie positions (2 each, n+1), wheelsets (2 each)
    nb = n + 1
    n_red = 2 * n + 2 * nb + 2 * nb
    T = np.zeros((10 * n, n_red))
    for j in range(n):
        base = 10 * j
        T[base + 0, 2 * j] = T[base + 1, 2 * j + 1] = 1.0
        for b, k in ((0, j), (1, j + 1)):  # front bogie -> position j, rear -> j + 1
            T[base + 2 + 2 * b, 2 * n + 2 * k] = 1.0
            T[base + 3 + 2 * b, 2 * n + 2 * k + 1] = 1.0
            for a in range(2):
                T[base + 6 + 2 * b + a, 2 * n + 2 * nb + 2 * k + a] = 1.0
    Mt, Kt = T.T @ M @ T, T.T @ K @ T
    wheels = np.arange(2 * n + 2 * nb, n_red)
    f_ref = fixed_wheel_frequencies(Mt, Kt, wheels)
    art = get_train(tid).vehicles[1]
    f = fixed_wheel_frequencies(art.M, art.K, art.wheel_dofs)
    np.testing.assert_allclose(f, f_ref, rtol=1e-9)  # same model, different assembly order
    q_ref = static_loads_constrained(Mt, Kt, wheels, G * np.where(
        np.isin(np.arange(n_red), np.r_[0:2 * n:2, 2 * n:2 * n + 2 * nb:2, wheels]),
        np.diag(Mt), 0.0))
    q = static_loads_constrained(art.M, art.K, art.wheel_dofs, art.gravity)
    np.testing.assert_allclose(np.sort(q), np.sort(q_ref), rtol=1e-10)  # solve rounding


# ------------------------------------------------------------------- names and tables


def test_presets__names_aliases_and_status():
    names = list_presets()
    expected = [f"HSLM-A{i}" for i in range(1, 11)] + ["ICE3", "Eurostar"]
    assert names[:12] == expected
    for tid in TRAINS:
        if tid not in ("ave_s103_8car", "eurostar_halfset_reconstructed"):
            assert tid in names
    assert get_train("ICE3").status == "transcribed"
    assert get_train("hslm-a3", "moving_force").name == "HSLM-A3"  # case-insensitive
    assert get_train("ave_s103_8car").status == "transcribed"


def test_presets__unknown_name_suggests():
    with pytest.raises(UnknownTrainError, match="did you mean 'ICE3'") as exc:
        get_train("ICE4")
    assert isinstance(exc.value, KeyError) and isinstance(exc.value, ValueError)
    with pytest.raises(KeyError, match="HSLM-A1"):
        get_train("HSLM_A1", "moving_force")
    with pytest.raises(ValueError, match="model must be"):
        get_train("ICE3", "sprung")


def test_status_warning__only_for_uncertain_data():
    assert status_warning("HSLM-A1") == ""
    assert status_warning("manchester_benchmark_single") == ""
    assert status_warning("ICE3") == ""
    w = status_warning("eurostar_ttb2d_as_coded")
    assert "suspect" in w and "0.8 m" in w
    assert "reconstruction" in status_warning("Eurostar")
    assert "suspect" in status_warning("pioneer_m_single")


def test_library_table__rows_and_values():
    df = library_table()
    assert list(df.columns[:7]) == ["name", "status", "axles", "length_m", "total_mass_t",
                                    "max_axle_load_kN", "regular_length_m"]
    assert list(df["name"]) == list_presets()
    ice = df.set_index("name").loc["ICE3"]
    chk = TRAINS["ave_s103_8car"]
    assert ice["axles"] == chk["n_axles"]
    assert ice["length_m"] == pytest.approx(chk["first_to_last_axle"], abs=1e-9)
    assert ice["total_mass_t"] == pytest.approx(chk["total_mass"] / 1e3, rel=1e-9)
    assert ice["max_axle_load_kN"] == pytest.approx(
        chk["check"]["max_static_axle_load"] / 1e3, abs=STATIC_TOL / 1e3)
    a1 = df.set_index("name").loc["HSLM-A1"]
    assert a1["axles"] == 50 and a1["regular_length_m"] == 18.0 and a1["status"] == "standard"
    eu = df.set_index("name").loc["Eurostar"]
    assert eu["axles"] == TRAINS["eurostar_halfset_reconstructed"]["n_axle_positions"]


def test_axle_table__ice3():
    df = axle_table("ICE3")
    chk = TRAINS["ave_s103_8car"]["check"]
    assert list(df.columns) == ["axle", "position_m", "static_load_kN", "vehicle"]
    np.testing.assert_array_equal(df["axle"], np.arange(1, 33))
    np.testing.assert_allclose(df["position_m"], chk["axle_positions"], atol=1e-9)
    np.testing.assert_allclose(df["static_load_kN"], np.asarray(chk["static_axle_loads"]) / 1e3,
                               atol=STATIC_TOL / 1e3)


def test_trains_command__prints_and_exit_codes(capsys):
    assert trains_command(None) == 0
    out = capsys.readouterr().out
    assert "HSLM-A10" in out and "suspect" in out and "Eurostar" in out
    assert trains_command("eurostar_ttb2d_as_coded") == 0
    out = capsys.readouterr().out
    assert "warning" in out and "225.9800" in out
    assert trains_command("Eurostra") == 2
    cap = capsys.readouterr()
    assert cap.err.strip().count("\n") == 0 and "did you mean" in cap.err
    assert "'Eurostar'" in cap.err


# ------------------------------------------------------------------------ user trains

USER_TOML = """
[[vehicle]]
id = "my_car"
name = "test car"
bogie_spacing = 19.0
wheelbase = 2.5
body_cg_to_front_bogie = 9.0
front_overhang = 3.0
rear_overhang = 3.0
[vehicle.whole]
body_mass = 40000.0
body_pitch_inertia = 2.0e6
bogie_mass = 3000.0
bogie_pitch_inertia = 2000.0
wheelset_mass = 1500.0
primary_stiffness = 2.0e6
primary_damping = 2.0e4
secondary_stiffness = 6.0e5
secondary_damping = 4.0e4

[[vehicle]]
id = "my_art"
bogie_spacing = 18.0
wheelbase = 2.5
front_overhang = 0.0
rear_overhang = 0.0
[vehicle.whole]
body_mass = 25000.0
body_pitch_inertia = 1.0e6
bogie_mass = 1500.0
bogie_pitch_inertia = 1000.0
wheelset_mass = 1000.0
primary_stiffness = 1.0e6
primary_damping = 1.0e4
secondary_stiffness = 3.0e5
secondary_damping = 2.0e4

[[train]]
id = "my_train"
status = "user"
vehicles = ["my_car", "ave_s103_c2367", "my_car"]
vehicle_offsets = [0.0, 30.0, 60.0]

[[train]]
id = "my_articulated"
vehicles = ["my_art", "my_art", "my_art"]
"""


def test_user_trains__load_register_and_build(tmp_path):
    f = tmp_path / "mine.toml"
    f.write_text(USER_TOML)
    built = load_user_trains(f)
    assert set(built) == {"my_train", "my_articulated"}
    assert "my_train" in list_presets() and "my_articulated" in list_presets()
    t = get_train("my_train")
    assert t.status == "user" and len(t.vehicles) == 3
    np.testing.assert_allclose(t.offsets, [0.0, 30.0, 60.0])
    # lever rule by hand: body weight at the CG 9.0 m behind the front bogie of 19.0 m
    W = 40000.0 * G
    front = (W * 10.0 / 19.0 + 3000.0 * G) / 2 + 1500.0 * G
    rear = (W * 9.0 / 19.0 + 3000.0 * G) / 2 + 1500.0 * G
    x, q = train_static_axles(t)
    np.testing.assert_allclose(q[:4], [front, front, rear, rear], rtol=1e-12)  # rounding
    a = get_train("my_articulated")  # articulation derived from zero overhangs
    assert len(a.vehicles) == 1 and a.vehicles[0].n_wheels == 8
    np.testing.assert_allclose(a.axle_positions, [0, 2.5, 18, 20.5, 36, 38.5, 54, 56.5])
    mf = get_train("my_articulated", "moving_force")
    # 3 bodies on 4 bogie positions: outer bogies carry half a body, inner ones a whole one
    b = 25000.0 * G
    outer = (b / 2 + 1500.0 * G) / 2 + 1000.0 * G
    inner = (b + 3000.0 * G) / 2 + 2000.0 * G
    np.testing.assert_allclose(mf.vehicles[0].loads, [outer] * 2 + [inner] * 4 + [outer] * 2,
                               rtol=1e-12)  # rounding
    assert "my_train" in set(library_table()["name"])
    assert load_user_trains(f).keys() == built.keys()  # reloading the same file is allowed


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (("body_mass = 40000.0", "body_mass = -1.0"), r"vehicle\[0\]\.whole\.body_mass"),
        (("body_mass = 40000.0", ""), r"vehicle\[0\]\.whole\.body_mass: missing"),
        (('"ave_s103_c2367"', '"ave_s103_c236"'), r"train\[0\]\.vehicles\[1\].*did you mean"),
        (('id = "my_train"', 'id = "ICE3"'), r"train\[0\]\.id.*library train"),
        (("[0.0, 30.0, 60.0]", "[0.0, 10.0, 60.0]"), r"train\[0\]\.vehicle_offsets\[1\].*overlap"),
        (('id = "my_articulated"', 'id = "my_articulated"\nvehicle_offsets = [0.0, 18.5, 36.0]'),
         r"train\[1\]\.vehicle_offsets\[1\].*coincident"),
    ],
)
def test_user_trains__clear_errors(tmp_path, edit, match):
    f = tmp_path / "bad_trains.toml"
    f.write_text(USER_TOML.replace(*edit, 1))
    with pytest.raises(ValueError, match=match) as exc:
        load_user_trains(f)
    assert "bad_trains.toml" in str(exc.value)
    assert "my_train" not in list_presets()  # nothing registered from a bad file


def test_user_trains__missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="absent.toml"):
        load_user_trains(tmp_path / "absent.toml")
