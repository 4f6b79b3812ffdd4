"""Solver settings (SI units)."""

from __future__ import annotations

from dataclasses import dataclass

CONTACT_MODELS = {"rigid": 0, "hertz": 1, "hertz_linear": 2}

#: Lowest HHT-alpha: -1/3 (the config clamps what it admits below it to this value).
HHT_ALPHA_MIN = -1.0 / 3.0


@dataclass(frozen=True)
class Bounds:
    """An admissible range, ``x > gt``, ``x >= ge``, ``x < lt``, ``x <= le`` (None: no
    limit); ``x in bounds`` tests it (NaN is never in)."""

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None

    def __contains__(self, x) -> bool:
        return ((self.gt is None or x > self.gt) and (self.ge is None or x >= self.ge)
                and (self.lt is None or x < self.lt) and (self.le is None or x <= self.le))


#: The admissible values of the numeric settings: one definition for
#: :class:`SolverSettings` and the ``[solver]`` / ``[contact]`` keys of the configuration.
BOUNDS = {
    "dt": Bounds(gt=0.0),
    "hht_alpha": Bounds(ge=HHT_ALPHA_MIN - 1e-12, le=0.0),  # -1/3 as written in a file
    "approach": Bounds(ge=0.0),
    "free_vibration": Bounds(ge=0.0),
    "max_iterations": Bounds(ge=1, le=10_000),
    "max_subdivisions": Bounds(ge=0, le=30),
    "acceleration_cutoff": Bounds(gt=0.0),
    "hertz_coefficient": Bounds(gt=0.0),
}


def hertz_coefficient(wheel_radius: float, tread: str = "worn",
                      rail_radius: float | None = None, youngs_modulus: float = 2.1e11,
                      poisson: float = 0.3) -> float:
    """Hertz constant G (m N^-2/3) of a wheel on a rail, ``delta = G N^(2/3)``.

    Without ``rail_radius``: the empirical fits quoted by Zhai (Vehicle-Track Coupled
    Dynamics) for a wheel of rolling radius R (m) -- worn tread ``G = 3.86e-8 R^-0.115``,
    conical tread ``G = 4.57e-8 R^-0.149``.  [R] recalled from Zhai's book, not re-read
    against it: give ``contact.hertz_coefficient`` explicitly for design work.

    With ``rail_radius``: two crossed cylinders of equal radius-of-curvature product,
    ``G = (9 (1 - nu^2)^2 / (4 E^2 R_e))^(1/3)``, ``R_e = sqrt(R_wheel R_rail)`` (Johnson,
    Contact Mechanics, 1985, circular-contact approximation of eq. 4.22).
    """
    if wheel_radius <= 0:
        raise ValueError(f"wheel_radius = {wheel_radius!r}: expected > 0 m")
    if rail_radius is None:
        if tread == "worn":
            return 3.86e-8 * wheel_radius ** (-0.115)
        if tread == "conical":
            return 4.57e-8 * wheel_radius ** (-0.149)
        raise ValueError(f"tread = {tread!r}: expected 'worn' or 'conical'")
    r_e = (wheel_radius * rail_radius) ** 0.5
    return (9.0 * (1.0 - poisson**2) ** 2 / (4.0 * youngs_modulus**2 * r_e)) ** (1.0 / 3.0)


@dataclass(frozen=True)
class SolverSettings:
    """Time integration and contact settings.

    Parameters
    ----------
    dt : float
        Time step (s).
    hht_alpha : float
        HHT-alpha parameter in [-1/3, 0]; 0 is the trapezoidal rule (no numerical
        damping).  The default -0.3 damps the step-to-step ringing of the rigid contact
        forces after abrupt changes of rail curvature (spectral radius at infinity
        (1 + alpha)/(1 - alpha) = 0.54, against 0.82 for -0.1, so a spurious one-step
        lift-off is much less likely) while its algorithmic damping of the bridge and
        vehicle modes is negligible (O((w dt)^3): about 0.01 % of critical for 30 Hz at
        dt = 1 ms; see tests/test_engine.py).

        Accuracy order: displacements, velocities and contact forces converge with
        O(dt^2) for every alpha, but with alpha != 0 the accelerations (deck and
        car-body accelerations, hence the EN 1990 checks) are only O(dt): the step
        enforces equilibrium at the alpha-weighted mean of t_n and t_n+1 while the
        acceleration is reported at t_n+1, an error of about -alpha dt times the rate of
        change of the acceleration (Hilber, Hughes & Taylor 1977; Erlicher, Bonaventura
        & Bursi 2002).  At dt = 1 ms a resonance peak is off by about 0.6 %; halve dt to
        check an acceleration that governs.  tests/test_comfort_deck.py fits the
        orders.  Rigid contact with wheels that have mass needs alpha <= -0.02 (with
        alpha = 0 the trapezoidal rule is weakly unstable on the position constraint and
        the contact forces ring); the config layer warns.
    approach : float
        Length of track ahead of the bridge (m): the first axle starts at x = -approach.
    free_vibration : float
        Time simulated after the last axle has left the bridge (s).
    max_iterations : int
        Cap on active-set iterations per step (contact detachment/reattachment).
    max_subdivisions : int
        A step whose contact iterations fail is retried with dt/2, dt/4, ... up to this
        many halvings before the case is flagged as failed.
    acceleration_cutoff : float or None
        Highest frequency (Hz) of the modes that enter the deck-acceleration output
        (EN 1990 A2.4.4.2.1: max(30 Hz, 1.5 f1, f3)); None computes that value.
    contact_model : {"rigid", "hertz", "hertz_linear"}
        Wheel-rail contact: rigid node-to-segment constraint; Hertzian spring with
        penetration ``delta = G N^(2/3)`` (unilateral, solved by Newton inside the
        Schur system); or its linearisation at each wheel's static load,
        ``k_H = 3 N0^(1/3) / (2 G)`` (valid while N stays near N0).
    hertz_coefficient : float
        Hertz constant G (m N^-2/3) of ``contact_model = "hertz"``, applied to the contact
        force as the vehicle model carries it.  The planar railway cars carry whole-axle
        forces (two wheels), so use ``G_axle = G_wheel / 2^(2/3)``.
    """

    dt: float = 1e-3
    hht_alpha: float = -0.3
    approach: float = 5.0
    free_vibration: float = 1.0
    max_iterations: int = 50
    max_subdivisions: int = 4
    acceleration_cutoff: float | None = None
    contact_model: str = "rigid"
    hertz_coefficient: float = 0.0

    def __post_init__(self):
        if self.dt not in BOUNDS["dt"]:
            raise ValueError(f"solver.dt = {self.dt!r}: expected a time step > 0 s")
        if self.hht_alpha not in BOUNDS["hht_alpha"]:
            raise ValueError(f"solver.hht_alpha = {self.hht_alpha!r}: expected -1/3 <= alpha <= 0")
        if self.approach not in BOUNDS["approach"]:
            raise ValueError(f"solver.approach = {self.approach!r}: expected >= 0 m")
        if self.contact_model not in tuple(CONTACT_MODELS):
            raise ValueError(
                f"contact.model = {self.contact_model!r}: expected 'rigid', 'hertz' or "
                "'hertz_linear'"
            )
        if self.contact_model != "rigid" and (
                self.hertz_coefficient not in BOUNDS["hertz_coefficient"]):
            raise ValueError(
                f"contact.hertz_coefficient = {self.hertz_coefficient!r}: expected G > 0 "
                "(m N^-2/3)"
            )
        if self.free_vibration not in BOUNDS["free_vibration"]:
            raise ValueError(f"solver.free_vibration = {self.free_vibration!r}: expected >= 0 s")
