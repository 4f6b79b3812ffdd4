"""``[track] load_distribution``: moving forces distributed by the rail, the ballast or the
elastic track, checked through ``vsi run`` against references written here (influence
lines of the simply supported span, modal equations integrated with scipy), and the
input echo of the report and of ``vsi check``."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import quad
from scipy.signal import lsim
from typer.testing import CliRunner

from vsi_numba.cli import app
from vsi_numba.config import ConfigError, load_config
from vsi_numba.model.distribution import describe_config

# a short simply supported span: 6 m, f1 = 19.5 Hz, one or eight forces of 170 kN
L, EI, MASS, P, ZETA = 6.0, 2.0e9, 1.0e4, 170e3, 0.02
A, B, H = 0.6, 0.3, 0.35            # sleeper spacing, sleeper width, ballast depth (m)
N_MODES = 5
OMEGA = (np.arange(1, N_MODES + 1) * np.pi / L) ** 2 * np.sqrt(EI / MASS)
F1 = OMEGA[0] / (2 * np.pi)
DIRECT = ("moving forces act on the deck directly (the track model applies to "
          "interaction trains only)")


def write_config(tmp_path, name, track="", vehicles=None, speeds=(5.0,), extra=""):
    vehicles = vehicles if vehicles is not None else [0.0]
    veh = "".join(f'[[train.vehicles]]\nkind = "force"\nload = {P}\noffset = {o}\n\n'
                  for o in vehicles)
    text = f"""title = "{name}"
[bridge]
kind = "simply_supported"
spans = [{L}]
EI = {EI}
mass_per_length = {MASS}
damping_ratio = {ZETA}
n_modes = {N_MODES}

[train]
{veh}
{track}

[solver]
dt = 2e-4
hht_alpha = 0.0

[study]
speeds_kmh = {[float(v) for v in speeds]}
output = "{name}.nc"
{extra}
"""
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def run(path) -> xr.Dataset:
    res = CliRunner().invoke(app, ["run", str(path), "-q"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(path.with_suffix(".nc")) as ds:
        return ds.load()


def patches(kind):
    """(offset from the axle m, share, patch length m) of each sleeper's load, as EN
    1991-2 6.3.6.1-2 [R] state them: P/4, P/2, P/4 at -a, 0, a; through the ballast at
    4:1 a uniform patch of b + 2 h/4 under each sleeper."""
    if kind == "none":
        return [(0.0, 1.0, 0.0)]
    length = B + 2 * H / 4 if kind == "rail_ballast" else 0.0
    return [(-A, 0.25, length), (0.0, 0.5, length), (A, 0.25, length)]


def moment_line(x):
    """Mid-span bending moment of a unit force at x (N m/N); 0 off the span."""
    return np.where((x >= 0) & (x <= L), np.minimum(x, L - x) / 2, 0.0)


def deflection_line(x):
    """Mid-span deflection of a unit force at x (m/N, down); 0 off the span."""
    u = np.minimum(x, L - x)
    return np.where((x >= 0) & (x <= L), u * (3 * L**2 - 4 * u**2) / (48 * EI), 0.0)


def patch_mean(line, centre, length):
    if length == 0:
        return float(line(np.array(centre)))
    a, b = centre - length / 2, centre + length / 2
    pts = [p for p in (0.0, L / 2, L) if a < p < b]
    return quad(lambda x: float(line(np.array(x))), a, b, points=pts or None,
                epsabs=0, epsrel=1e-12)[0] / length


def static_max(line, kind):
    """Largest mid-span effect of one axle P distributed by ``kind``, over axle positions
    within 0.5 m of mid-span (the effect is concave there, symmetric about mid-span)."""
    s = np.linspace(L / 2 - 0.5, L / 2 + 0.5, 201)
    vals = [sum(w * P * patch_mean(line, x + d, ell) for d, w, ell in patches(kind))
            for x in s]
    return max(vals)


def winkler_static_max(line, sleepers: bool):
    """The same for the rail on the default Winkler foundation, axle at mid-span
    (symmetric, concave): the foundation reaction k G(x) (Hetenyi) on the continuous
    foundation, or taken by the sleepers at spacing a within 7 / beta of the axle (the
    reaction at each sleeper x a, rescaled to carry P)."""
    from vsi_numba.model.track import FOUNDATION_DEFAULT, RAIL_EI_UIC60

    beta = (FOUNDATION_DEFAULT / (4 * RAIL_EI_UIC60)) ** 0.25

    def p(x):
        u = beta * np.abs(x - L / 2)
        return beta / 2 * np.exp(-u) * (np.cos(u) + np.sin(u))   # k G: integrates to 1

    if sleepers:
        x = L / 2 + A * np.arange(-20, 21)
        x = x[beta * np.abs(x - L / 2) <= 7.0]
        return P * float(np.sum(p(x) * line(x)) / np.sum(p(x)))
    return P * quad(lambda x: p(x) * float(line(np.array(x))), 0, L, points=[L / 2],
                    epsabs=0, epsrel=1e-12)[0]


@pytest.mark.parametrize("kind", ["rail", "rail_ballast"])
def test_load_distribution__crawl_matches_the_distributed_static_load(tmp_path, kind):
    """At 5 km/h the mid-span moment and deflection are those of the distributed static
    load; the point force would give 11-14 % more moment."""
    cfg = write_config(tmp_path, kind, f'[track]\nload_distribution = "{kind}"\n'
                       f"sleeper_spacing = {A}\nsleeper_width = {B}\nballast_depth = {H}\n")
    ds = run(cfg)
    m = float(ds["max_bending_moment"].sel(point=L / 2).squeeze())
    w = float(ds["max_deck_displacement"].sel(point=L / 2).squeeze())
    m_ref, w_ref = static_max(moment_line, kind), static_max(deflection_line, kind)
    # 0.25 %: the patch is taken as 5 forces (midpoint rule, +0.09 % at the moment's kink
    # under the middle sleeper, measured) plus the crawl's dynamic part (< 0.01 %)
    assert m == pytest.approx(m_ref, rel=2.5e-3)
    # 0.04 %: five modes (the point force's truncation, -7e-4, is smaller for the
    # distributed loads) and the crawl: measured -0.01 % for rail, +0.005 % for
    # rail_ballast
    assert w == pytest.approx(w_ref, rel=4e-4)
    assert m < 0.91 * P * L / 4         # a point force: P L / 4
    assert w < (1 - 3e-3) * P * L**3 / (48 * EI)
    # the static reference of phi'_dyn is the distributed load as well
    w_stat = float(ds["max_static_deck_displacement"].sel(point=L / 2).squeeze())
    assert w_stat == pytest.approx(w_ref, rel=4e-4)  # measured -0.014 %
    # the outputs stay per axle: one moving force of P
    assert ds.sizes["wheel"] == 1
    assert float(ds["static_wheel_load"].squeeze()) == P


def test_load_distribution__load_effect_checks_crawl_the_distributed_load(tmp_path):
    """The report's EN 1991-2 6.4.6 checks take the static reference of phi'_dyn from the
    moving forces as the runs distributed them: at 5 km/h phi'_dyn is ~0, not the -12 %
    of a distributed dynamic result over a point-force static one."""
    from vsi_numba.analysis.checks.load_effects import load_effect_checks

    ds = run(write_config(tmp_path, "le", '[track]\nload_distribution = "rail_ballast"\n'))
    checks = load_effect_checks(ds)
    env = checks.envelopes.set_index(["effect", "location"])
    # 0.01 %: the crawl envelope is exact at the kinks (its grid holds every force
    # crossing a breakpoint); the reference integrates the patches (quad)
    assert env.loc[("moment", L / 2), "static"] == pytest.approx(
        static_max(moment_line, "rail_ballast"), rel=1e-3)
    phi = checks.phi_dyn.set_index(["effect", "train"])["phi_dyn"]
    # the crawl's dynamic part and the ballast patches as 5 forces in the run (+0.09 %)
    assert abs(phi[("moment", "le")]) < 2.5e-3
    assert abs(phi[("deflection", "le")]) < 1e-3


def test_load_distribution__elastic_track_spreads_like_the_winkler_foundation(tmp_path):
    """The foundation reaction of the rail on the Winkler foundation, sampled at the
    sleepers, against the continuous reaction integrated here."""
    cfg = write_config(tmp_path, "winkler", '[track]\nload_distribution = "elastic_track"\n')
    ds = run(cfg)
    m = float(ds["max_bending_moment"].sel(point=L / 2).squeeze())
    w = float(ds["max_deck_displacement"].sel(point=L / 2).squeeze())
    # the sleepers' reactions: tolerances as for the crawl above
    assert m == pytest.approx(winkler_static_max(moment_line, True), rel=2.5e-3)
    assert w == pytest.approx(winkler_static_max(deflection_line, True), rel=4e-4)
    # 4 %: the sleepers against the continuous foundation (measured +1.5 % in the moment,
    # whose influence line has a kink under the axle; +0.13 % in the deflection)
    assert m == pytest.approx(winkler_static_max(moment_line, False), rel=4e-2)
    assert w == pytest.approx(winkler_static_max(deflection_line, False), rel=4e-3)
    assert m < 0.9 * P * L / 4


def modal_reference(kind, speed, offsets, approach=5.0, t_end=None):
    """Mid-span displacement and band-limited acceleration histories of the modal
    equations q'' + 2 zeta w q' + w^2 q = F(t), F the exact modal load of the uniform
    ballast patches (closed-form integrals of the sine modes), by scipy's lsim: exact
    for F linearly interpolated between samples 2e-5 s apart."""
    amp = np.sqrt(2 / (MASS * L))
    kj = np.arange(1, N_MODES + 1) * np.pi / L
    cut = max(30.0, 1.5 * F1, 9 * F1)      # EN 1990 A2.4.4.2.1: f3 of this span
    keep = OMEGA / (2 * np.pi) <= cut + 1e-9
    pieces = np.array([(o, d, share, ell) for o in offsets
                       for d, share, ell in patches(kind)])
    off, d, share, ell = (pieces[:, i, None] for i in range(4))     # (piece, 1)

    def force(t):
        """Modal forces (N / sqrt(kg)) at the times ``t``, shape (len(t), N_MODES)."""
        c = -approach - off + speed * np.atleast_1d(t)[:, None, None] + d   # (t, piece, 1)
        if kind == "none":
            on = (c >= 0) & (c <= L)
            return np.sum(np.where(on, share * P * amp * np.sin(kj * c), 0.0), axis=1)
        a, b = np.clip(c - ell / 2, 0, L), np.clip(c + ell / 2, 0, L)
        return np.sum(share * P * amp * (np.cos(kj * a) - np.cos(kj * b)) / (kj * ell),
                      axis=1)

    # one state-space system of the uncoupled modes, outputs the mid-span displacement
    # and band-limited acceleration: x = (q, q'), u = F
    phi_mid = amp * np.sin(kj * L / 2)
    eye, zero = np.eye(N_MODES), np.zeros((N_MODES, N_MODES))
    sys_a = np.block([[zero, eye], [-np.diag(OMEGA**2), -np.diag(2 * ZETA * OMEGA)]])
    sys_b = np.vstack([zero, eye])
    sys_c = np.vstack([np.concatenate([phi_mid, np.zeros(N_MODES)]),
                       np.concatenate([-(phi_mid * keep) * OMEGA**2,
                                       -(phi_mid * keep) * 2 * ZETA * OMEGA])])
    sys_d = np.vstack([np.zeros(N_MODES), phi_mid * keep])
    t_end = t_end or (approach + L + max(offsets) + A + B) / speed + 0.3
    t = np.arange(0.0, t_end, 2e-5)
    _, y, _ = lsim((sys_a, sys_b, sys_c, sys_d), force(t), t)
    return y[:, 0], y[:, 1]


def test_load_distribution__resonance_matches_the_modal_integration(tmp_path):
    """Eight forces 3 m apart at v = 3 f1 (first resonance) with the rail-and-ballast
    distribution: the engine's mid-span displacement and acceleration against the modal
    equations of the exact patch loads; the point forces give a clearly different
    answer."""
    offsets = [3.0 * i for i in range(8)]
    v = 3.0 * F1
    track = '[track]\nload_distribution = "rail_ballast"\n'
    ds = run(write_config(tmp_path, "res", track, offsets, speeds=(v * 3.6,)))
    point = run(write_config(tmp_path, "res_point", "", offsets, speeds=(v * 3.6,)))
    w_ref, a_ref = modal_reference("rail_ballast", v, offsets)
    w = float(ds["max_deck_displacement"].sel(point=L / 2).squeeze())
    a = float(ds["max_deck_acceleration"].sel(point=L / 2).squeeze())
    # trapezoidal rule at dt = 2e-4 s (omega dt = 0.025 on the first mode, 0.22 on the
    # third, which resonates too: f3 = 9 f1) and the patches as 5 forces each: measured
    # +0.085 % in the displacement, +0.29 % in the acceleration
    assert w == pytest.approx(np.max(np.abs(w_ref)), rel=2e-3)
    assert a == pytest.approx(np.max(np.abs(a_ref)), rel=7e-3)
    w_point = float(point["max_deck_displacement"].sel(point=L / 2).squeeze())
    # the point forces: +32 % (their entry onto the span excites the higher modes)
    assert w_point > 1.2 * np.max(np.abs(w_ref))


def test_load_distribution__none_is_bit_for_bit_the_run_without_the_key(tmp_path):
    """HSLM-A1 on the 6 m span: ``load_distribution = "none"`` gives the very numbers
    (and the stored configuration) of the run without the key."""
    def cfg(name, track):
        text = write_config(tmp_path, name, track).read_text().replace(
            '[[train.vehicles]]\nkind = "force"\nload = 170000.0\noffset = 0.0\n',
            'preset = "HSLM-A1"\n').replace("speeds_kmh = [5.0]",
                                            "speeds_kmh = [200.0, 300.0]")
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        return path

    a = run(cfg("absent", ""))
    b = run(cfg("none", '[track]\nload_distribution = "none"\n'))
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        x, y = a[name].values, b[name].values
        assert x.dtype == y.dtype, name
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name
    assert a.attrs["config_json"].replace("absent", "none") == b.attrs["config_json"]


def test_load_distribution__input_echo_says_what_moving_forces_act_on(tmp_path):
    """The input echo of ``vsi report`` and ``vsi check``: the deck directly, or the
    distribution."""
    plain = write_config(tmp_path, "plain")
    dist = write_config(tmp_path, "dist", '[track]\nload_distribution = "rail"\n')

    def echo(path):
        run(path)
        out = tmp_path / f"{path.stem}_report"
        res = CliRunner().invoke(app, ["report", str(path.with_suffix(".nc")), "-o",
                                       str(out)])
        assert res.exit_code == 0, res.output
        rows = [line for line in (out / "report.md").read_text().splitlines()
                if line.startswith("| Moving forces |")]
        assert len(rows) == 1
        return rows[0]

    assert f"| Moving forces | {DIRECT} |" == echo(plain)
    text = echo(dist)
    assert "distributed by the rail: P/4, P/2, P/4 on three sleepers at a = 0.6 m" in text
    for path, expected in ((plain, DIRECT), (dist, "moving forces distributed by the rail")):
        res = CliRunner().invoke(app, ["check", str(path)])
        assert res.exit_code == 0, res.output
        assert f"input: {expected}" in " ".join(res.output.split())


BASE = {"bridge": {"kind": "simply_supported", "spans": [L], "EI": EI,
                   "mass_per_length": MASS, "n_modes": 3},
        "train": {"preset": "HSLM-A1"}, "study": {"speeds_kmh": [200.0]}}


@pytest.mark.parametrize("track, message", [
    ({"load_distribution": "ballast"},
     "track.load_distribution = \"ballast\": expected one of 'none', 'rail', "),
    ({"model": "rigid", "load_distribution": "elastic_track"},
     "track.load_distribution = \"elastic_track\": expected 'none', 'rail' or "
     "'rail_ballast' with track.model = 'rigid'"),
    ({"load_distribution": "rail", "sleeper_spacing": -0.6},
     "track.sleeper_spacing = -0.6: expected a sleeper spacing > 0"),
    ({"load_distribution": "rail_ballast", "ballast_depth": 350.0},
     "track.ballast_depth = 350.0: expected a ballast depth"),
])
def test_load_distribution__bad_input_names_the_key(track, message):
    with pytest.raises(ConfigError) as err:
        load_config({**BASE, "track": track})
    assert message in str(err.value)


def test_load_distribution__implausible_or_unused_values_warn():
    cfg = load_config({**BASE, "track": {"load_distribution": "rail_ballast",
                                         "ballast_depth": 0.05}})
    assert any("track.ballast_depth = 0.05 m looks implausible" in w for w in cfg.warnings)
    cfg = load_config({**BASE, "track": {"load_distribution": "rail", "ballast_depth": 0.4}})
    assert any("track.ballast_depth is ignored: not used by track.load_distribution = "
               "'rail'" in w for w in cfg.warnings)
    # the forces ahead of the first axle reach beyond the approach: a sudden load
    cfg = load_config({**BASE, "solver": {"approach": 2.0},
                       "track": {"load_distribution": "elastic_track"}})
    assert any("solver.approach = 2 m is shorter than the reach of track.load_distribution"
               " = 'elastic_track' (6 m ahead of an axle)" in w for w in cfg.warnings)
    # interaction trains only: nothing to distribute
    cfg = load_config({**BASE, "train": {"preset": "ICE3"},
                       "track": {"load_distribution": "rail"}})
    assert any("track.load_distribution = 'rail' is not used: no train of the study has "
               "moving forces" in w for w in cfg.warnings)
    # an FE track layer is the track: its rail spreads the moving forces
    assert describe_config({"bridge": {"track": {"rail_EI": 1.3e7}}}).startswith(
        "moving forces act on the rail of the FE track layer")
    # with the rigid track the rail and the ballast still spread the moving forces
    cfg = load_config({**BASE, "track": {"model": "rigid", "load_distribution": "rail"}})
    assert cfg.build_bridge().load_distribution.kind == "rail"
