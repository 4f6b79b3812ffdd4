"""The track as a rail on an elastic (Winkler) foundation, over the deck and the approaches.

Why: with a rigid track the wheel runs on the deflected deck and, past its end, on a
rigid approach; the deck's end rotation is then a kink in the running surface, and a
wheel in rigid contact meets it as an impact whose force grows like 1/dt.  Real rails
are continuous beams on a foundation (pads, sleepers, ballast, formation) that carries
them over the joint: the running surface is smooth there and the wheel sits on a
spring of finite stiffness everywhere.

Model (2-D, one track: both rails together, consistent with the whole-axle forces of
the planar vehicles).  The rail is an infinite Euler-Bernoulli beam (``rail_EI``) on a
Winkler foundation of modulus ``k`` (N/m per metre of track) that bears on the deck
where there is deck and on rigid ground elsewhere; for the deck and the coupling between
wheels the rail is massless and the foundation elastic (quasi-static):

    EI w'''' + k (w - u) = sum_i X_i delta(x - x_i),   u = sum_j phi_j q_j on the deck, 0 off it

so w = sum_j phit_j q_j + sum_i G(x - x_i) X_i with the infinite-beam Green function
(Hetenyi 1946)

    G(xi) = beta / (2 k) exp(-beta |xi|) (cos beta xi + sin beta |xi|),  beta = (k / (4 EI))^(1/4)

and the *track-filtered mode shapes* phit_j = k G * phi_j (a convolution: a smoothing
over ~1/beta ~ 1 m that carries each mode shape smoothly across the deck ends, and is
non-zero over a few metres of the approaches).  By reciprocity a wheel force X at x
loads mode j with phit_j(x) X (the foundation spreads it over the deck), so the coupling
stays symmetric.  The wheel thus sees a continuous rail: the deck through phit, and the
local rail deflection under the wheels through the compliance matrix G(x_i - x_k),
constant in time because the wheel spacing is.

What it leaves out (documented choices):
- rail and sleeper inertia: the track's own resonances (the wheelset on the track,
  P2, ~50-100 Hz with the unsprung mass; sleepers on ballast, 100-300 Hz) are above the
  bridge and vehicle-body frequencies of the EN 1990 checks; the wheelset-on-track mode
  is kept (unsprung mass on the compliance G(0)), the track mass is not;
- the rail's bending stiffness added to the deck (EI_rail / EI_deck ~ 1e-3) and its
  restraint of the deck-end rotation: the deck's modes are those of the bare deck
  (:func:`restraint_ratio` measures the neglected term; tests bound it);
- the damping and inertia of the rail's coupling between wheels (the compliance between
  two wheels, G(x_i - x_k) with |G| < 0.04 G(0) at a bogie's axle spacing, stays
  elastic) and the rail's inertia and damping in the deck load (a wheel force loads the
  deck through phit, the quasi-static spreading).

Foundation damping and rail mass (``foundation_damping`` c, N s/m per metre, and
``rail_mass`` m', kg per metre of track).  With a Kelvin-Voigt foundation and a rail
with mass the point receptance of the infinite rail is

    G(w) = beta_w / (2 k_w),  k_w = k + i w c - w^2 m',  beta_w^4 = k_w / (4 EI),
    i.e.  G(w) = G(0) (1 + i w c / k - w^2 m' / k)^(-3/4),

and the rail deflection y_i under wheel i is carried by a Kelvin element with a mass,

    m_t y'' + c_t y' + k_t y = X_i,

(:attr:`ElasticTrack.wheel_element`): the kernel integrates it with the step's HHT-alpha
rule, which makes y_{n+1} an affine function a_n + g X_{n+1} of the wheel's contact
force: the element replaces G(0) on the diagonal of the Schur matrix (the wheels'
compliance holds 1 / k_t there, :meth:`ElasticTrack.wheel_compliance`) and adds a_n to
the predictor gap (no new factorisation).

The element's parameters are FITTED to the receptance (:func:`fit_element`): the
least-squares relative error of k_t + i w c_t - w^2 m_t against 1 / G(w) over
0 .. :data:`FIT_BAND_HZ` = 120 Hz (the wheelset-on-track mode at 40-50 Hz and the
irregularity band, 1 m wavelengths at 400 km/h being 111 Hz), all three >= 0.  The
first-order expansion used before (:attr:`ElasticTrack.first_order_element`:
k_t = 1 / G(0), c_t = (3/4) (c / k) k_t, m_t = (3/4) (m' / k) k_t) is exact only as
w -> 0; at 45 Hz w c / k = 0.65 with the default foundation and the element was 3-4 %
too compliant there: on rough track (German low 1-80 m, 250-400 km/h) it put dQ/Q0 up to
0.057 low and the deck acceleration up to 6.7 % low (massless rail; 0.059 and 9.9 %
with 120 kg/m).  Fitted, default foundation: massless rail (1.054 / G(0), 0.947 c_t of
first order, 0): complex receptance error within 8.7 % over the band, 2.1 % at 45 Hz
(a 3-parameter element with m_t >= 0 cannot follow the w^(-3/4)-like receptance at both
ends: it is 5 % stiff at w -> 0, which no result of these checks feels); 120 kg/m
(0.999 / G(0), 1.02 c_t, 80 kg instead of 159 kg): within 1.4 % over the band.
Measured against a converged continuous damped rail (docs/track_accuracy.md,
benchmarks/track_accuracy.py; ICE3 end car, 20 m span, f1 = 5 Hz): massless rail, dQ/Q0
within -0.017 .. +0.018 and the peak deck acceleration -0.5 .. +3.2 %; 120 kg/m, dQ/Q0
-0.020 .. -0.003 and the deck acceleration -1.6 .. +2.7 % (:data:`TRACK_ACCURACY_NOTE`)
with the rail's inertia in the deck load: a deck motion or a wheel force at 45 Hz passes
the rail on its foundation amplified by about 1 / (1 - w^2 m' / k) = 1.11 for 120 kg/m,
which the quasi-static spreading phit does not carry, so wheel i loads the deck with
X_i - kappa z''_i, kappa = (m' / k) k_t (``VehicleArrays.track_kappa``, z'' of its
element at the start of the step: 1 + w^2 m' / k to first order); without it the deck
acceleration was -6.6 .. -0.2 %, on the unsafe side.  With a heavy participating mass
(500 kg/m: the track's own resonance sqrt(k / m') / 2 pi = 65 Hz in the band) neither
the element nor the quasi-static deck load holds.  tests/test_track_damping.py checks
the whole model against the continuous rail (finite differences and rail modes).
Without damping and mass the element is not used (the compliance G(0), as before).

Default values (``ElasticTrack()``): foundation damping c = 1.96e5 N s/m per metre of
track: the ballast damping 58.8 kN s/m per half sleeper at 0.6 m spacing (per rail
9.8e4 N s/m^2), Zhai, Wang & Cai, "Fundamentals of vehicle-track coupled dynamics",
Vehicle System Dynamics 47 (2009) 1349-1376, Table 3 [R: recalled, not re-read]; it
gives the ~45 Hz wheelset-on-track mode of a high-speed car a damping ratio of ~0.2-0.3.
``rail_mass`` 0 (the massless rail; 120 kg/m for two UIC60 rails, more with the share
of the sleepers that moves with the rail).

Default values (``ElasticTrack()``): UIC60 rails, ``rail_EI`` = 2 x 210 GPa x 3055 cm^4
= 1.283e7 N m^2 (EN 13674-1 section properties); a foundation that gives a static track
stiffness of 75 kN/mm per wheel (150 kN/mm per axle), the middle of the 70-80 kN/mm per
wheel recommended for high-speed ballasted track by Lopez Pita et al., "Integral
approach to railway track stiffness", Proc. IMechE F 218 (2004) [R: recalled, not
re-read].  For one rail, K_wheel = 2 k_r / beta = 2^(3/2) k_r^(3/4) EI_r^(1/4) gives
k_r = 42.5 MN/m^2, i.e. ``foundation_stiffness`` = 85 MN/m^2 per track
(beta = 1.13 /m, the rail spreads an axle load over about +-2.8 m).
"""

from __future__ import annotations

import functools
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.model import hermite

# filtered_shapes per (track, bridge) object pair: a study packs the same bridge for
# every batch, and the FE filter costs ~0.1-0.2 s
_FILTERED: dict[tuple, tuple[weakref.ref, tuple]] = {}

#: Bending stiffness of two UIC60 rails, N m^2 (E = 210 GPa, I = 3055 cm^4 each).
RAIL_EI_UIC60 = 2 * 210e9 * 3055e-8
#: Static track stiffness per wheel of the default foundation, N/m (Lopez Pita 2004 [R]).
WHEEL_STIFFNESS_DEFAULT = 75e6
#: Foundation damping per track (both rails), N s/m per metre: the ballast damping
#: 58.8 kN s/m per half sleeper at 0.6 m spacing (Zhai, Wang & Cai 2009 [R]).
FOUNDATION_DAMPING_DEFAULT = 2.0 * 58.8e3 / 0.6
#: G(xi) is set to zero beyond REACH / beta (|G| < 1e-5 G(0)): the compliance matrix
#: then couples only neighbouring wheels and the filtered mode shapes end this far
#: beyond the deck.
REACH = 12.0
#: Rail elements per 1/beta in the FE filter of the mode shapes (error ~ (h beta)^4).
ELEMENTS_PER_LENGTH = 6
#: Upper end (Hz) of the band over which the wheel element is fitted to the rail's point
#: receptance: the wheelset-on-track mode (40-50 Hz) and the irregularity band of the
#: EN 1990 A2 dynamic studies up to 400 km/h over 1 m wavelengths (111 Hz).
FIT_BAND_HZ = 120.0
#: Frequencies of the fit, evenly spread over (0, FIT_BAND_HZ].
FIT_POINTS = 240
#: What the report should say about the damped track's accuracy (measured against a
#: converged continuous damped rail: docs/track_accuracy.md).
TRACK_ACCURACY_NOTE = (
    "Damped elastic track: against a converged continuous damped rail on rough track "
    "(German low 1-80 m, 250-400 km/h, ICE3 end car on a 20 m span) dQ/Q0 is within "
    "+/-0.02 and the deck acceleration within -0.5 .. +3.2 % with the massless rail "
    "(the default); with rail mass (120 kg/m, its inertia in the deck load) dQ/Q0 is up "
    "to 0.02 low and the deck acceleration within -1.6 .. +2.7 %."
)
#: The same for results computed before the rail's inertia entered the deck load.
TRACK_ACCURACY_NOTE_BEFORE = (
    "Damped elastic track: against a converged continuous damped rail on rough track "
    "(German low 1-80 m, 250-400 km/h, ICE3 end car on a 20 m span) dQ/Q0 is within "
    "+/-0.02 and the deck acceleration within -0.5 .. +3.2 % with the massless rail "
    "(the default); with rail mass (120 kg/m) dQ/Q0 is up to 0.02 and the deck "
    "acceleration up to 7 % LOW (unsafe side): the rail's inertia in the deck load is "
    "left out (results written before it was included)."
)


#: The deck acceleration's error with a rail mass on the elastic track, measured against a
#: converged continuous damped rail (rough track, German low 1-80 m, 250-400 km/h, ICE3
#: end car on a 20 m span, docs/track_accuracy.md): with the rail's inertia in the deck
#: load (``VehicleArrays.track_kappa``) -1.6 .. +2.7 % at 120 kg/m; without it (results
#: written before) -0.2 .. -6.6 % (-6.8 % the largest reported), taken in proportion to
#: the rail mass.
RAIL_MASS_ACCELERATION_ERROR = -0.068 / 120.0
#: The range of the error with the rail's inertia in the deck load, at 120 kg/m.
RAIL_MASS_ACCELERATION_RANGE = (-0.016, 0.027)
#: The rail mass at which the errors were measured (kg/m).
RAIL_MASS_MEASURED = 120.0


def rail_mass_acceleration_note(rail_mass: float, inertia_in_deck_load: bool = True) -> str:
    """The sign and size of the deck acceleration's error with ``rail_mass`` (kg per metre
    of track) on the elastic track, for the report beside the verdict ("" for a massless
    rail); ``inertia_in_deck_load``: the results load the deck with the rail's inertia
    (false for results written before it did)."""
    m = float(rail_mass)
    if not m > 0.0:
        return ""
    at = abs(m - RAIL_MASS_MEASURED) < 1e-9
    if inertia_in_deck_load:
        lo, hi = (100.0 * v for v in RAIL_MASS_ACCELERATION_RANGE)
        return (f"the value is within {lo:+.1f} .. {hi:+.1f} % of a converged continuous "
                f"damped rail, measured at {RAIL_MASS_MEASURED:g} kg/m"
                + ("" if at else f"; not measured at {m:g} kg/m"))
    err = 100.0 * RAIL_MASS_ACCELERATION_ERROR * m
    how = ("measured at 120 kg/m" if at else
           f"measured {100 * RAIL_MASS_ACCELERATION_ERROR * RAIL_MASS_MEASURED:.1f} % at "
           f"{RAIL_MASS_MEASURED:g} kg/m, scaled in proportion to the rail mass"
           + (", not measured above it" if m > RAIL_MASS_MEASURED else ""))
    return (f"the value is up to {abs(err):.1f} % LOW (unsafe side): the elastic track's "
            f"rail mass ({m:g} kg/m) is left out of the deck load ({how}, against a "
            "converged continuous damped rail)")


def foundation_for(wheel_stiffness: float, rail_EI_one: float) -> float:
    """Foundation modulus of ONE rail (N/m^2) with static stiffness ``wheel_stiffness``
    (N/m) under a wheel: K = 2 k / beta = 2^(3/2) k^(3/4) EI^(1/4)."""
    return (wheel_stiffness / (2.0**1.5 * rail_EI_one**0.25)) ** (4.0 / 3.0)


#: Foundation modulus per track (both rails), N/m per metre: 8.51e7.
FOUNDATION_DEFAULT = 2.0 * foundation_for(WHEEL_STIFFNESS_DEFAULT, RAIL_EI_UIC60 / 2.0)


def nnls(A, b):
    """``scipy.optimize.nnls(A, b)`` (x, residual norm): scipy's compiled routine
    (``scipy.optimize._slsqplib.nnls``, what ``scipy.optimize.nnls`` calls with these
    arguments) loaded without importing ``scipy.optimize`` (~0.2 s of CPU: the whole
    optimisation package, for one 480 x 3 problem per track); ``scipy.optimize.nnls``
    itself when that module is not where it is expected (another scipy)."""
    lib = _slsqplib()
    if lib is None:
        import scipy.optimize

        return scipy.optimize.nnls(A, b)
    A = np.asarray_chkfinite(A, dtype=np.float64, order="C")
    b = np.asarray_chkfinite(b, dtype=np.float64)
    if A.ndim != 2 or b.ndim != 1 or A.shape[0] != b.shape[0]:
        raise ValueError(f"nnls: A {A.shape} and b {b.shape} do not match")
    x, rnorm, info = lib.nnls(A, b, 3 * A.shape[1])  # scipy's default maxiter, 3 n
    if info == 3:
        raise RuntimeError("Maximum number of iterations reached.")
    return x, rnorm


@functools.lru_cache(maxsize=1)
def _slsqplib():
    """scipy's ``scipy.optimize._slsqplib`` extension (the one in ``sys.modules`` if
    ``scipy.optimize`` is imported, else loaded from its file for this module alone:
    scipy's import state is left as it is), or None when this scipy has none (its
    version's ``nnls`` is then used)."""
    import importlib.machinery
    import importlib.util
    import sys

    name = "scipy.optimize._slsqplib"
    if name in sys.modules:
        return sys.modules[name] if hasattr(sys.modules[name], "nnls") else None
    try:
        import scipy

        folder = Path(scipy.__file__).parent / "optimize"
        files = [folder / f"_slsqplib{sfx}" for sfx in importlib.machinery.EXTENSION_SUFFIXES]
        path = next((f for f in files if f.is_file()), None)
        if path is None or not (folder / "_nnls.py").is_file():
            return None
        if "_slsqplib import nnls as _nnls" not in (folder / "_nnls.py").read_text():
            return None  # scipy.optimize.nnls calls something else
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        spec = importlib.util.spec_from_file_location(name, str(path), loader=loader)
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except (ImportError, OSError, ValueError):
        return None
    finally:
        if sys.modules.get(name) is not None and "scipy.optimize" not in sys.modules:
            del sys.modules[name]  # (an extension of single-phase init puts itself there)
    return module if callable(getattr(module, "nnls", None)) else None


@functools.lru_cache(maxsize=64)
def fit_element(foundation_stiffness: float, rail_EI: float, foundation_damping: float,
                rail_mass: float, band_hz: float | None = None) -> tuple[float, float, float]:
    """(k_t, c_t, m_t) >= 0 that fit the element's dynamic stiffness
    k_t + i w c_t - w^2 m_t to the continuous rail's 1 / G(w) over ``band_hz``
    (default :data:`FIT_BAND_HZ`): least squares of the relative error
    (k_t + i w c_t - w^2 m_t) G(w) - 1 at :data:`FIT_POINTS` frequencies spread evenly
    over (0, band], non-negative (a negative mass would make the kernel's element
    unstable), solved as an NNLS problem in the scaled unknowns
    (k_t / K0, c_t w_b / K0, m_t w_b^2 / K0), K0 = 1 / G(0), w_b = 2 pi band
    (:func:`nnls`)."""
    band = FIT_BAND_HZ if band_hz is None else float(band_hz)
    k, ei, c, m = foundation_stiffness, rail_EI, foundation_damping, rail_mass
    w = 2.0 * np.pi * band * np.arange(1, FIT_POINTS + 1) / FIT_POINTS
    kw = k + 1j * w * c - w**2 * m
    G = (kw / (4.0 * ei)) ** 0.25 / (2.0 * kw)
    K0 = 2.0 * k / (k / (4.0 * ei)) ** 0.25
    wb = 2.0 * np.pi * band
    A = np.column_stack([np.ones_like(w), 1j * w / wb, -((w / wb) ** 2)]) * (K0 * G)[:, None]
    p, _ = nnls(np.vstack([A.real, A.imag]),
                np.concatenate([np.ones_like(w), np.zeros_like(w)]))
    return float(p[0] * K0), float(p[1] * K0 / wb), float(p[2] * K0 / wb**2)


@dataclass(frozen=True)
class ElasticTrack:
    """Rail (both rails) on a Winkler foundation, quasi-static; see the module notes.

    Parameters
    ----------
    foundation_stiffness : float
        k, N/m per metre of track (both rails), > 0.
    rail_EI : float
        Bending stiffness of both rails, N m^2, > 0.
    foundation_damping : float
        c, N s/m per metre of track (both rails), >= 0 (0: elastic foundation).
    rail_mass : float
        m', kg per metre of track moving with the rail (both rails), >= 0 (0: massless).
    """

    foundation_stiffness: float = FOUNDATION_DEFAULT
    rail_EI: float = RAIL_EI_UIC60
    foundation_damping: float = FOUNDATION_DAMPING_DEFAULT
    rail_mass: float = 0.0

    def __post_init__(self):
        for name in ("foundation_stiffness", "rail_EI", "foundation_damping", "rail_mass"):
            v = getattr(self, name)
            positive = name in ("foundation_stiffness", "rail_EI")
            if not (isinstance(v, (int, float)) and np.isfinite(v)
                    and (v > 0 if positive else v >= 0)):
                raise ValueError(f"track.{name} = {v!r}: expected a finite value "
                                 f"{'> 0' if positive else '>= 0'}")

    @property
    def beta(self) -> float:
        """Inverse characteristic length (k / (4 EI))^(1/4), 1/m."""
        return (self.foundation_stiffness / (4.0 * self.rail_EI)) ** 0.25

    @property
    def reach(self) -> float:
        """Distance (m) beyond which the rail deflection of a point load is neglected."""
        return REACH / self.beta

    @property
    def axle_stiffness(self) -> float:
        """Static stiffness under one isolated axle, 1 / G(0) = 2 k / beta (N/m)."""
        return 2.0 * self.foundation_stiffness / self.beta

    @property
    def first_order_element(self) -> tuple[float, float, float]:
        """(k_t, c_t, m_t) of the receptance's first-order expansion: k_t = 1 / G(0),
        c_t = (3/4) (c / k) k_t, m_t = (3/4) (m' / k) k_t (N/m, N s/m, kg).  Exact as
        w -> 0 only: at the wheelset-on-track mode (~45 Hz, w c / k ~ 0.65) it is 3-4 %
        too compliant (module notes)."""
        k_t = self.axle_stiffness
        r = 0.75 * k_t / self.foundation_stiffness
        return k_t, r * self.foundation_damping, r * self.rail_mass

    @property
    def wheel_element(self) -> tuple[float, float, float]:
        """(k_t, c_t, m_t): the Kelvin element with a mass that carries the rail deflection
        under a wheel, m_t y'' + c_t y' + k_t y = X (N/m, N s/m, kg), fitted to the
        continuous rail's point receptance over 0 .. :data:`FIT_BAND_HZ` (module notes;
        :func:`fit_element`).  Without damping and rail mass: (1 / G(0), 0, 0), no
        element."""
        if self.foundation_damping == 0.0 and self.rail_mass == 0.0:
            return self.axle_stiffness, 0.0, 0.0
        return fit_element(self.foundation_stiffness, self.rail_EI,
                           self.foundation_damping, self.rail_mass)

    def wheel_compliance(self, positions) -> np.ndarray:
        """Compliance matrix the wheels see (m/N): :meth:`compliance` with, where the
        element is used (damping or rail mass), the element's static compliance
        1 / k_t on the diagonal (the kernel's element carries the rail deflection under
        each wheel; the static state and the element then agree)."""
        C = self.compliance(positions)
        k_t, c_t, m_t = self.wheel_element
        if c_t > 0.0 or m_t > 0.0:
            C[np.diag_indices(C.shape[0])] = 1.0 / k_t
        return C

    def receptance(self, omega) -> np.ndarray:
        """Point receptance (m/N, complex) of the infinite rail at circular frequency
        ``omega`` (rad/s): beta_w / (2 k_w) with k_w = k + i w c - w^2 m' and
        beta_w = (k_w / (4 EI))^(1/4) (principal root)."""
        w = np.asarray(omega, float)
        kw = self.foundation_stiffness + 1j * w * self.foundation_damping \
            - w**2 * self.rail_mass
        return (kw / (4.0 * self.rail_EI)) ** 0.25 / (2.0 * kw)

    def green(self, xi) -> np.ndarray:
        """Rail deflection (m, down) at distance ``xi`` from a unit load (1 N); zero
        beyond :attr:`reach`."""
        b = self.beta
        a = b * np.abs(np.asarray(xi, float))
        g = b / (2.0 * self.foundation_stiffness) * np.exp(-a) * (np.cos(a) + np.sin(a))
        return np.where(a <= REACH, g, 0.0)

    def compliance(self, positions) -> np.ndarray:
        """Compliance matrix G(x_i - x_k) (m/N) of wheels at ``positions`` (m)."""
        x = np.asarray(positions, float)
        return np.ascontiguousarray(self.green(x[:, None] - x[None, :]))

    def filtered_shapes(self, bridge):
        """Track-filtered mode shapes phit = k G * phi on the track line, as a Hermite
        table ``(nodes, values, slopes)`` over ``[-reach, L + reach]``.

        The rail's static problem EI w'''' + k w = k u is solved by Hermite beam
        elements with the consistent Winkler matrix, u = phi_j on the deck (6-point
        Gauss per element, nodes at the deck ends and the supports), one right-hand side
        per mode; the table holds the FE nodal values and slopes, evaluated in between
        with the same Hermite shape functions.
        """
        key = (self.foundation_stiffness, self.rail_EI, id(bridge))
        hit = _FILTERED.get(key)
        if hit is not None and hit[0]() is bridge:
            return hit[1]
        for k in [k for k, (ref, _) in _FILTERED.items() if ref() is None]:
            del _FILTERED[k]
        table = self._filter(bridge)
        _FILTERED[key] = (weakref.ref(bridge), table)
        return table

    def _filter(self, bridge):
        import scipy.linalg

        L = float(bridge.length)
        h_max = 1.0 / (ELEMENTS_PER_LENGTH * self.beta)
        breaks = np.unique(np.concatenate([[-self.reach, 0.0, L, L + self.reach],
                                           np.asarray(bridge.supports, float)]))
        breaks = breaks[(breaks >= -self.reach) & (breaks <= L + self.reach)]
        nodes = [breaks[:1]]
        for a, b in zip(breaks[:-1], breaks[1:], strict=True):
            n = max(1, int(np.ceil((b - a) / h_max)))
            nodes.append(np.linspace(a, b, n + 1)[1:])
        nodes = np.concatenate(nodes)
        n_n, n_m = nodes.size, bridge.n_modes
        k, ei = self.foundation_stiffness, self.rail_EI
        # banded upper storage of the symmetric matrix (2 DOFs per node: w, w')
        ab = np.zeros((4, 2 * n_n))
        rhs = np.zeros((2 * n_n, n_m))
        gp, gw = np.polynomial.legendre.leggauss(6)
        s = 0.5 * (gp + 1.0)
        lengths = np.diff(nodes)
        # the deck's mode shapes at the Gauss points of every element (one call)
        phi_g = bridge.shapes((nodes[:-1, None] + s * lengths[:, None]).ravel()).reshape(
            n_n - 1, s.size, n_m)
        # the element matrices of all elements at once (cubic Hermite bending + the
        # consistent Winkler foundation), added into the band: element e's DOFs are
        # 2e .. 2e + 3, so within one (r, c) pass no two elements share a band entry
        h = lengths
        # ei / h^3 element by element: numpy's vectorised power differs from the scalar
        # one in the last bit for a few % of the lengths, and the table stays bit for
        # bit the one of the element-by-element assembly
        kb = np.array([ei / x**3 for x in h])
        kf = k * h / 420.0
        ke = np.empty((h.size, 4, 4))
        ke[:, 0, 0] = ke[:, 2, 2] = 12 * kb + 156 * kf
        ke[:, 0, 1] = 6 * h * kb + 22 * h * kf
        ke[:, 0, 2] = -12 * kb + 54 * kf
        ke[:, 0, 3] = 6 * h * kb - 13 * h * kf
        ke[:, 1, 1] = ke[:, 3, 3] = 4 * h * h * kb + 4 * h * h * kf
        ke[:, 1, 2] = -6 * h * kb + 13 * h * kf
        ke[:, 1, 3] = 2 * h * h * kb - 3 * h * h * kf
        ke[:, 2, 3] = -6 * h * kb - 22 * h * kf
        d = 2 * np.arange(h.size)
        for r in range(4):
            for c in range(r, 4):
                ab[3 + r - c, d + c] += ke[:, r, c]
        on_deck = (nodes[:-1] + 0.5 * h >= 0.0) & (nodes[:-1] + 0.5 * h <= L)
        if n_m and on_deck.any():  # the foundation bears on the deck
            e = np.flatnonzero(on_deck)
            # (k N h/2 w_gauss) @ phi per element, as one stacked matmul (the same
            # products and sums as element by element: the table is bit for bit the same)
            N = np.stack(np.broadcast_arrays(
                *hermite.shape_functions(s[None, :], h[e, None])), axis=1)  # (e, 4, gauss)
            load = np.matmul(k * (N * (0.5 * h[e, None] * gw)[:, None, :]), phi_g[e])
            for i in range(4):
                rhs[2 * e + i] += load[:, i]
        sol = scipy.linalg.solveh_banded(ab, rhs) if n_m else rhs
        return (np.ascontiguousarray(nodes), np.ascontiguousarray(sol[0::2]),
                np.ascontiguousarray(sol[1::2]))

    def restraint_ratio(self, bridge) -> np.ndarray:
        """Neglected rail-to-deck stiffness relative to the modal stiffness: for each
        mode, int k phi_j (phi_j - phit_j) dx / omega_j^2 over the deck (mass-normalised
        modes).  It holds the rail's bending stiffness added to the deck and its
        restraint of the deck-end rotations."""
        nodes, vals, slopes = self.filtered_shapes(bridge)
        x = np.linspace(0.0, bridge.length, 20001)
        phi = bridge.shapes(x)
        phit = hermite.table(nodes, vals, slopes, x)
        k_t = np.trapezoid(self.foundation_stiffness * phi * (phi - phit), x, axis=0)
        return k_t / bridge.omega**2
