"""LM71 and crawl envelopes against hand-derived influence-line maxima, and Phi_2/Phi_3."""

import numpy as np
import pytest

from vsi_numba.analysis.checks.load_effects import crawl_envelope, lm71_envelope
from vsi_numba.en1991 import dynamic_factor
from vsi_numba.model.influence import beam_deck, influence

L = 20.0
Q, q = 250e3, 80e3


def ss_moment_mid(x):
    """Midspan bending-moment influence line of a simply supported span (tent, L/4)."""
    x = np.asarray(x, float)
    return np.where((x >= 0) & (x <= L), np.minimum(x, L - x) / 2.0, 0.0)[None, :]


def ss_shear_left(x):
    """Shear just right of the left support: 1 - x/L for 0 < x <= L, 0 at x = 0."""
    x = np.asarray(x, float)
    return np.where((x > 0) & (x <= L), 1.0 - x / L, 0.0)[None, :]


def test_lm71_simply_supported_midspan_moment():
    # Two axles on each side of midspan keep the axle sum at Q (L - 3.2); the 80 kN/m
    # outside the zone grows as the zone leaves the centre (d/dc = q (I(c-3.2) - I(c+3.2)))
    # until an axle reaches midspan (shift 0.8 m), after which the axle sum falls by
    # Q per m (> q x 0.8 m): max at shift 0.8 m. Zone area at shift d: 1.6 L - (3.2^2+d^2)/2.
    expected = Q * (L - 3.2) + q * (L**2 / 8 - (1.6 * L - (3.2**2 + 0.8**2) / 2))
    env = lm71_envelope(ss_moment_mid, [0.0, L / 2, L], (0.0, L))
    # linear line: exact at crossings; the udl integral is trapezoidal on a grid holding
    # the kink, exact for a piecewise-linear line -> round-off
    assert env.max[0] == pytest.approx(expected, rel=1e-9)
    assert abs(abs(env.at_max[0] - L / 2) - 0.8) < 1e-6
    assert env.min[0] == pytest.approx(0.0, abs=1e-6)  # the line is never negative


def test_lm71_simply_supported_support_shear():
    # First axle just right of the support, the others at 1.6, 3.2, 4.8 m; the zone ends at
    # 5.6 m and the udl covers (5.6, L]; every other placement is lower (hand check: the
    # group off the deck gives q L / 2 = 800 kN < 1295 kN).
    expected = Q * (4 - 9.6 / L) + q * (L - 5.6) ** 2 / (2 * L)
    env = lm71_envelope(ss_shear_left, [0.0, L], (0.0, L))
    assert env.max[0] == pytest.approx(expected, rel=1e-8)  # 1e-9 m crossing offsets


def two_span_support_moment(Ls):
    """Closed form: hogging moment over the middle support of two equal spans,
    M_B = -x (L^2 - x^2) / (4 L^2) for a unit load at x from the outer end of a span."""
    def line(x):
        x = np.asarray(x, float)
        a = np.where(x <= Ls, x, 2 * Ls - x)
        m = -a * (Ls**2 - a**2) / (4 * Ls**2)
        return np.where((x >= 0) & (x <= 2 * Ls), m, 0.0)[None, :]
    return line


def test_lm71_two_span_hogging_brute_force():
    Ls = 15.0
    line = two_span_support_moment(Ls)
    env = lm71_envelope(line, [0.0, Ls, 2 * Ls], (0.0, 2 * Ls), step=0.05)
    # brute force: centre c on a 1 cm grid; udl = q times the integral of the (entirely
    # negative) line outside the zone by a 1 mm midpoint rule
    xm = np.arange(0.0005, 2 * Ls, 0.001)
    il = line(xm)[0]
    best = np.inf
    for c in np.arange(-3.2, 2 * Ls + 3.2, 0.01):
        out = (xm < c - 3.2) | (xm > c + 3.2)
        axles = sum(line(np.array([c + o]))[0, 0] for o in (-2.4, -0.8, 0.8, 2.4))
        best = min(best, Q * axles + q * 0.001 * il[out].sum())
    # |E''| ~ 3e4 N m/m^2 at the optimum: the 0.05 m grid misses < 0.05^2/8 |E''| ~ 10 N m,
    # the 1 cm brute grid < 1 N m, the 1 mm midpoint mask ~ 0.0005 m x |I| x q ~ 50 N m;
    # the optimum is 2.9e6 N m: 1e-5 relative covers them with margin
    assert env.min[0] == pytest.approx(best, rel=1e-5)
    assert env.max[0] == pytest.approx(0.0, abs=1e-6)


def test_lm71_with_model_influence_matches_closed_form():
    # the same midspan moment through vsi_numba.model.influence (wt beam deck)
    deck = beam_deck([L], 1e10)
    env = lm71_envelope(lambda x: influence(deck, "moment", [L / 2], x), [0.0, L / 2, L],
                        (0.0, L))
    expected = Q * (L - 3.2) + q * (L**2 / 8 - (1.6 * L - (3.2**2 + 0.8**2) / 2))
    assert env.max[0] == pytest.approx(expected, rel=1e-9)


def test_crawl_two_axle_vehicle():
    # two axles P1 (leading) and P2 at spacing a <= L/2 on a simply supported span:
    # max midspan moment = heavier axle at midspan: P1 L/4 + P2 (L/2 - a)/2 for P1 >= P2;
    # max shear right of the left support = max(P1, P2 + P1 (1 - a/L)) (trailing axle at
    # 0+, the leading one a metres in).
    P1, P2, a = 200e3, 120e3, 3.0
    m = crawl_envelope(ss_moment_mid, [0.0, a], [P1, P2], [0.0, L / 2, L], (0.0, L))
    assert m.max[0] == pytest.approx(P1 * L / 4 + P2 * (L / 2 - a) / 2, rel=1e-12)
    assert m.at_max[0] == pytest.approx(L / 2, abs=1e-6)
    v = crawl_envelope(ss_shear_left, [0.0, a], [P1, P2], [0.0, L], (0.0, L))
    assert v.max[0] == pytest.approx(max(P1, P2 + P1 * (1 - a / L)), rel=1e-8)
    assert v.min[0] == pytest.approx(-0.0, abs=1e-3)


def test_crawl_smooth_line_error_bound():
    # continuous deck (cubic line): the 0.05 m grid is within h^2/8 max|E''| of the
    # 1 mm brute force maximum
    Ls = 15.0
    line = two_span_support_moment(Ls)
    env = crawl_envelope(line, [0.0, 2.5], [1.0, 1.0], [0.0, Ls, 2 * Ls], (0.0, 2 * Ls))
    s = np.arange(0.0, 2 * Ls + 2.5, 0.001)
    e = line(s)[0] + line(s - 2.5)[0]
    # |E''| <= 2 x max|I''| = 2 x 6 x/(4 L^2) <= 3/L: bound 0.05^2/8 x 0.2 = 6e-5
    assert env.min[0] == pytest.approx(e.min(), abs=7e-5)


@pytest.mark.parametrize("L_phi", [4.0, 10.0, 25.0, 100.0])
def test_dynamic_factors_formula(L_phi):
    phi2 = 1.44 / (np.sqrt(L_phi) - 0.2) + 0.82
    phi3 = 2.16 / (np.sqrt(L_phi) - 0.2) + 0.73
    assert dynamic_factor(L_phi, "careful") == pytest.approx(np.clip(phi2, 1.0, 1.67))
    assert dynamic_factor(L_phi, "standard") == pytest.approx(np.clip(phi3, 1.0, 2.0))


def test_dynamic_factor_bounds():
    # short L_phi hits the upper bounds, very long ones the lower bound 1.00
    assert dynamic_factor(1.0, "careful") == 1.67
    assert dynamic_factor(1.0, "standard") == 2.0
    assert dynamic_factor(0.01, "standard") == 2.0   # sqrt(L) - 0.2 < 0
    assert dynamic_factor(1e4, "careful") == 1.0
    assert dynamic_factor(1e4, "standard") == 1.0
    # 25 m: Phi_3 = 2.16/4.8 + 0.73 = 1.18
    assert dynamic_factor(25.0) == pytest.approx(1.18, abs=1e-12)
    with pytest.raises(ValueError, match="maintenance"):
        dynamic_factor(10.0, "poor")
    with pytest.raises(ValueError, match="length"):
        dynamic_factor(-1.0)
