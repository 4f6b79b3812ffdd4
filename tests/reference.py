"""Independent reference solutions for validating the vsi_numba engine: those the tests
alone need.

The references ``vsi verify`` also uses (the modes of a simply supported beam, the exact
modal response to a moving force, Frýba's dynamic amplification, ...) are those of the
shipped oracle, :mod:`vsi_numba.verification.reference`, imported here (one definition of
each).  Everything here uses numpy and scipy and that oracle only (which imports numpy
and scipy only) and never the engine: the validation tests compare the engine with these
closed forms, ``solve_ivp`` integrations of the coupled equations and event-driven
solutions, never with the engine's own output.

Conventions (those of docs/manual/theory.md, "Conventions")
--------------------------------------------------
* SI units (m, s, kg, N).
* Vertical displacements, velocities and accelerations are positive **down**; gravity
  acts in the positive direction.
* Irregularity ``r(x) > 0`` means the rail is **lower** (a dip): on a deck with
  deflection ``w(x, t)`` the rail top is at ``w + r``.
* Contact forces are positive in **compression**.
* ``x`` is measured from the left support of the bridge; a vehicle starting at
  ``x_start`` is at ``x(t) = x_start + v t``.

Simply supported beam: mass-normalised modes ``phi_j = sqrt(2/(m L)) sin(j pi x / L)``,
``omega_j = (j pi / L)^2 sqrt(EI/m)``, modal equations
``q_j'' + 2 zeta omega_j q_j' + omega_j^2 q_j = sum_k P_k phi_j(x_k)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.optimize

# the shipped oracle's beam (``vsi verify`` uses it too): one definition of each
from vsi_numba.verification.reference import (  # noqa: F401 - re-exported to the tests
    GRAVITY,
    moving_force_daf,
    moving_force_modal,
    ss_omega,
    ss_shapes,
)

# =============================================================================
# Simply supported beam: static deflection, moving constant force
# =============================================================================


def static_deflection_point_load(P: float, L: float, EI: float, a: float, x) -> np.ndarray:
    """Static deflection (m, down) at ``x`` of a simply supported beam, point load P at a.

    ``w(x) = P b x (L^2 - b^2 - x^2) / (6 EI L)`` for ``x <= a`` (``b = L - a``) and the
    mirror formula for ``x > a``; under the load ``w(a) = P a^2 b^2 / (3 EI L)``.
    Zero when the load is off the span.
    """
    x = np.asarray(x, float)
    if a < 0.0 or a > L:
        return np.zeros_like(x)
    b = L - a
    xr = L - x
    left = P * b * x * (L**2 - b**2 - x**2) / (6.0 * EI * L)
    right = P * a * xr * (L**2 - a**2 - xr**2) / (6.0 * EI * L)
    return np.where(x <= a, left, right)


def moving_force_series(P, L, EI, m, v, x, t, n_modes, zeta=0.0) -> np.ndarray:
    """Frýba's modal series for a constant force crossing a simply supported beam.

    The force ``P`` (N, down) enters at ``x = 0`` at ``t = 0`` and moves at ``v``; the
    beam starts from rest; after ``t = L/v`` the beam vibrates freely.

    Parameters
    ----------
    P, L, EI, m, v : float
        Force (N), span (m), bending stiffness (N m2), mass per length (kg/m), speed (m/s).
    x : array_like, shape (nx,)
        Abscissae (m) where the deflection is wanted.
    t : array_like, shape (nt,)
        Times (s) since the force entered the span.
    n_modes : int
        Number of modes in the series.
    zeta : float
        Modal damping ratio (same for every mode).

    Returns
    -------
    ndarray, shape (nt, nx)
        Deflection w(x, t) (m, positive down).

    Notes
    -----
    Undamped: ``w = sum 2P/(mL) (sin Om_j t - Om_j/w_j sin w_j t)/(w_j^2 - Om_j^2)
    sin(j pi x/L)``, railway notes section 3.1; the damped case is the exact damped
    SDOF solution of each mode.
    """
    q, _, _ = moving_force_modal(P, L, EI, m, v, t, n_modes, zeta)
    return q @ ss_shapes(L, m, n_modes, x).T


# =============================================================================
# Track profiles (with exact derivatives, for the reference integrations)
# =============================================================================


@dataclass(frozen=True)
class FlatTrack:
    """No irregularity."""

    breakpoints: tuple[float, ...] = ()

    def __call__(self, x, derivative: int = 0):
        return np.zeros_like(np.asarray(x, float))


@dataclass(frozen=True)
class CosineDip:
    """Isolated cosine dip ``r = depth/2 (1 - cos(2 pi (x - position)/wavelength))``.

    Nonzero on ``[position, position + wavelength]``; positive depth = rail lower.
    r and r' are continuous, r'' jumps at both ends (listed in ``breakpoints``).
    """

    depth: float
    wavelength: float
    position: float

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return (self.position, self.position + self.wavelength)

    def __call__(self, x, derivative: int = 0):
        x = np.asarray(x, float)
        k = 2.0 * np.pi / self.wavelength
        s = x - self.position
        inside = (s >= 0.0) & (s <= self.wavelength)
        h = 0.5 * self.depth
        if derivative == 0:
            val = h * (1.0 - np.cos(k * s))
        elif derivative == 1:
            val = h * k * np.sin(k * s)
        elif derivative == 2:
            val = h * k**2 * np.cos(k * s)
        else:
            raise ValueError("derivative must be 0, 1 or 2")
        return np.where(inside, val, 0.0)


@dataclass(frozen=True)
class SmoothDip:
    """C2 isolated dip ``r = depth sin^4(pi (x - position)/wavelength)``.

    r, r' and r'' are continuous everywhere (no jump of the rail acceleration at its
    ends), so the first loss of contact happens where the dynamics say, not at an edge.
    """

    depth: float
    wavelength: float
    position: float

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return (self.position, self.position + self.wavelength)

    def __call__(self, x, derivative: int = 0):
        x = np.asarray(x, float)
        k = np.pi / self.wavelength
        s = x - self.position
        inside = (s >= 0.0) & (s <= self.wavelength)
        sn, cs = np.sin(k * s), np.cos(k * s)
        if derivative == 0:
            val = self.depth * sn**4
        elif derivative == 1:
            val = self.depth * 4 * k * sn**3 * cs
        elif derivative == 2:
            val = self.depth * 4 * k**2 * (3 * sn**2 * cs**2 - sn**4)
        else:
            raise ValueError("derivative must be 0, 1 or 2")
        return np.where(inside, val, 0.0)


def _time_breaks(x_marks: Sequence[float], x_start: float, v: float, t_end: float):
    """Times in (0, t_end) at which the vehicle passes the abscissae ``x_marks``."""
    ts = sorted({(xm - x_start) / v for xm in x_marks})
    return [0.0] + [t for t in ts if 0.0 < t < t_end] + [t_end]


class _Piecewise:
    """Dense output stitched from consecutive ``solve_ivp`` segments."""

    def __init__(self):
        self.t0: list[float] = []
        self.t1: list[float] = []
        self.sols: list = []
        self.tags: list = []

    def add(self, t0, t1, sol, tag=None):
        self.t0.append(float(t0))
        self.t1.append(float(t1))
        self.sols.append(sol)
        self.tags.append(tag)

    def index(self, t: float) -> int:
        """Segment holding ``t`` (right-continuous: a boundary belongs to the next)."""
        i = int(np.searchsorted(np.asarray(self.t0), t, side="right")) - 1
        return min(max(i, 0), len(self.sols) - 1)


# =============================================================================
# Quarter car / sprung mass crossing a simply supported beam (contact always kept)
# =============================================================================


@dataclass
class BeamCrossing:
    """Reference solution of a quarter car (or sprung mass) crossing a SS beam.

    Use :meth:`evaluate` to get the response at any times (dense ODE output).
    """

    body_mass: float
    stiffness: float
    damping: float
    wheel_mass: float
    L: float
    EI: float
    m: float
    speed: float
    n_modes: int
    zeta: float
    x_start: float
    profile: Callable
    points: np.ndarray
    omega: np.ndarray = field(init=False)
    pieces: _Piecewise = field(init=False)

    def __post_init__(self):
        self.omega = ss_omega(self.L, self.EI, self.m, self.n_modes)
        self._k = np.pi * np.arange(1, self.n_modes + 1) / self.L
        self._amp = np.sqrt(2.0 / (self.m * self.L))
        self._zeros = np.zeros(self.n_modes)
        self._ampk = self._amp * self._k
        self._k2 = self._k**2
        self._2zw = 2.0 * self.zeta * self.omega
        self._w2 = self.omega**2
        self._flat = isinstance(self.profile, FlatTrack)
        self.points = np.atleast_1d(np.asarray(self.points, float))

    # -- equations ---------------------------------------------------------------
    def _terms(self, t, s):
        """Everything derived from the state s = [z, z', q (n), q' (n)] at time t."""
        n = self.n_modes
        v = self.speed
        z, zd = s[0], s[1]
        q, qd = s[2 : 2 + n], s[2 + n :]
        x = self.x_start + v * t
        if 0.0 <= x <= self.L and n > 0:
            arg = self._k * x
            sn = self._amp * np.sin(arg)
            phi, dphi, ddphi = sn, self._amp * self._k * np.cos(arg), -self._k**2 * sn
        else:
            phi = dphi = ddphi = self._zeros
        if self._flat:
            r0 = r1 = r2 = 0.0
        else:
            r0, r1, r2 = (float(self.profile(x, d)) for d in (0, 1, 2))
        # wheel (= contact point) follows the rail: y = phi.q + r(x), x = x_start + v t
        y = phi @ q + r0
        yd = phi @ qd + v * (dphi @ q) + v * r1
        conv = 2.0 * v * (dphi @ qd) + v * v * (ddphi @ q) + v * v * r2  # y'' - phi.q''
        fs = self.stiffness * (z - y) + self.damping * (zd - yd)  # suspension force
        zdd = GRAVITY - fs / self.body_mass
        mw = self.wheel_mass
        # beam: q'' + 2 zeta w q' + w^2 q = phi P,  P = mw g + fs - mw (phi.q'' + conv)
        # => (I + mw phi phi^T) q'' = rhs  (Sherman-Morrison)
        rhs = -2 * self.zeta * self.omega * qd - self.omega**2 * q + phi * (
            mw * GRAVITY + fs - mw * conv
        )
        qdd = rhs - phi * (mw * (phi @ rhs)) / (1.0 + mw * (phi @ phi))
        ydd = phi @ qdd + conv
        P = mw * GRAVITY + fs - mw * ydd
        return dict(x=x, z=z, zd=zd, zdd=zdd, q=q, qd=qd, qdd=qdd, y=y, yd=yd, ydd=ydd, P=P)

    def _rhs(self, t, s):
        """Lean version of :meth:`_terms` (same equations), for the integrator."""
        n = self.n_modes
        v = self.speed
        q, qd = s[2 : 2 + n], s[2 + n :]
        x = self.x_start + v * t
        out = np.empty_like(s)
        out[0] = s[1]
        out[2 : 2 + n] = qd
        if self._flat:
            r0 = r1 = r2 = 0.0
        else:
            r0, r1, r2 = (float(self.profile(x, d)) for d in (0, 1, 2))
        rhs = -self._2zw * qd - self._w2 * q
        if 0.0 <= x <= self.L and n > 0:
            arg = self._k * x
            phi = self._amp * np.sin(arg)
            dphi = self._ampk * np.cos(arg)
            y = phi.dot(q) + r0
            yd = phi.dot(qd) + v * (dphi.dot(q) + r1)
            conv = 2.0 * v * dphi.dot(qd) - v * v * (self._k2phi(phi).dot(q) - r2)
            fs = self.stiffness * (s[0] - y) + self.damping * (s[1] - yd)
            mw = self.wheel_mass
            rhs += phi * (mw * GRAVITY + fs - mw * conv)
            if mw:
                rhs -= phi * (mw * phi.dot(rhs) / (1.0 + mw * phi.dot(phi)))
        else:
            fs = self.stiffness * (s[0] - r0) + self.damping * (s[1] - v * r1)
        out[1] = GRAVITY - fs / self.body_mass
        out[2 + n :] = rhs
        return out

    def _k2phi(self, phi):
        return self._k2 * phi

    def solve(self, t_end: float, rtol: float = 1e-10, atol: float = 1e-13,
              method: str = "DOP853") -> BeamCrossing:
        """Integrate from static equilibrium on level rigid ground, q = 0 (in place)."""
        n = self.n_modes
        s0 = np.zeros(2 + 2 * n)
        s0[0] = (self.body_mass * GRAVITY) / self.stiffness + float(
            self.profile(self.x_start)
        )
        marks = [0.0, self.L, *getattr(self.profile, "breakpoints", ())]
        breaks = _time_breaks(marks, self.x_start, self.speed, t_end)
        self.pieces = _Piecewise()
        for ta, tb in zip(breaks[:-1], breaks[1:], strict=True):
            sol = scipy.integrate.solve_ivp(
                self._rhs, (ta, tb), s0, method=method, rtol=rtol, atol=atol,
                dense_output=True,
            )
            if sol.status != 0:
                raise RuntimeError(f"solve_ivp failed: {sol.message}")
            self.pieces.add(ta, tb, sol.sol)
            s0 = sol.y[:, -1]
        return self

    def evaluate(self, t) -> dict[str, np.ndarray]:
        """Response at times ``t`` (s, same origin as the integration).

        Keys: ``x`` (vehicle position), ``deck_displacement`` and ``deck_acceleration``
        (nt, n_points), ``body_displacement``, ``body_acceleration``,
        ``wheel_displacement``, ``contact_force``, ``q`` (nt, n_modes).
        """
        t = np.atleast_1d(np.asarray(t, float))
        n = self.n_modes
        shp = ss_shapes(self.L, self.m, n, self.points)
        out = {k: np.zeros(t.size) for k in ("x", "body_displacement", "body_velocity",
                                             "body_acceleration", "wheel_displacement",
                                             "contact_force")}
        q_all = np.zeros((t.size, n))
        qdd_all = np.zeros((t.size, n))
        for i, ti in enumerate(t):
            sol = self.pieces.sols[self.pieces.index(ti)]
            d = self._terms(ti, sol(ti))
            out["x"][i] = d["x"]
            out["body_displacement"][i] = d["z"]
            out["body_velocity"][i] = d["zd"]
            out["body_acceleration"][i] = d["zdd"]
            out["wheel_displacement"][i] = d["y"]
            out["contact_force"][i] = d["P"]
            q_all[i] = d["q"]
            qdd_all[i] = d["qdd"]
        out["q"] = q_all
        out["deck_displacement"] = q_all @ shp.T
        out["deck_acceleration"] = qdd_all @ shp.T
        return out


    def first_loss_of_contact(self, t_grid) -> float:
        """First time (s) at which the bilateral contact force turns negative.

        Sign change located on ``t_grid`` and refined by ``brentq`` on the dense
        solution; ``nan`` if the force stays compressive over the grid.
        """
        t_grid = np.asarray(t_grid, float)
        P = self.evaluate(t_grid)["contact_force"]
        neg = np.flatnonzero(P < 0.0)
        if neg.size == 0:
            return float("nan")
        i = neg[0]
        if i == 0:
            return float(t_grid[0])

        def f(tt):
            return self.evaluate([tt])["contact_force"][0]

        return float(scipy.optimize.brentq(f, t_grid[i - 1], t_grid[i], xtol=1e-12))


def quarter_car_crossing(
    body_mass, stiffness, damping, wheel_mass, L, EI, m, speed, n_modes, t_end,
    x_start=0.0, zeta=0.0, profile=None, points=None, rtol=1e-10, atol=1e-13,
    method="DOP853",
) -> BeamCrossing:
    """Quarter car (body on spring-dashpot on a wheel that stays in contact) on a SS beam.

    Parameters
    ----------
    body_mass, stiffness, damping, wheel_mass : float
        kg, N/m, N s/m, kg.  ``wheel_mass = 0`` is the sprung mass with a massless
        contact point.
    L, EI, m : float
        Span (m), bending stiffness (N m2), mass per length (kg/m).
    speed : float
        m/s.
    n_modes : int
        Sine modes kept.
    t_end : float
        Integration time (s); ``t = 0`` with the wheel at ``x_start`` (m, < 0 on the
        approach).
    zeta : float
        Modal damping ratio of the beam.
    profile : callable ``profile(x, derivative)`` or None
        Rail irregularity (positive = lower) on the beam and on the rigid approach/exit.
    points : array_like
        Deck output abscissae (default: midspan).

    Notes
    -----
    Unknowns: body displacement z and modal coordinates q.  The wheel follows the rail,
    ``y = phi(x) q + r(x)`` with ``x = x_start + v t``, so
    ``y' = phi q' + v phi' q + v r'`` and ``y'' = phi q'' + 2 v phi' q' + v^2 phi'' q
    + v^2 r''``.  With the suspension force ``F_s = k (z - y) + c (z' - y')``:

    * body: ``M z'' = M g - F_s``;
    * wheel: ``m_w y'' = m_w g + F_s - P`` gives the contact force ``P``;
    * beam: ``q'' + 2 zeta w q' + w^2 q = phi(x) P``; substituting P gives
      ``(I + m_w phi phi^T) q'' = -2 zeta w q' - w^2 q
      + phi (m_w g + F_s - m_w (2 v phi' q' + v^2 phi'' q + v^2 r''))``.

    Off the span phi = 0 (rigid level ground).  The start is static equilibrium on the
    rigid approach: ``z = M g / k``, q = 0.  Integration is split where the vehicle
    enters/leaves the span and at profile breakpoints.  At the exit the deck slope makes
    the wheel velocity jump (the contact force has an impulse there when m_w > 0); the
    state (z, z', q, q') stays continuous.
    """
    profile = FlatTrack() if profile is None else profile
    points = [0.5 * L] if points is None else points
    ref = BeamCrossing(
        body_mass=body_mass, stiffness=stiffness, damping=damping, wheel_mass=wheel_mass,
        L=L, EI=EI, m=m, speed=speed, n_modes=n_modes, zeta=zeta, x_start=x_start,
        profile=profile, points=points,
    )
    return ref.solve(t_end, rtol=rtol, atol=atol, method=method)


def sprung_mass_crossing(
    body_mass, stiffness, damping, L, EI, m, speed, n_modes, t_end, x_start=0.0,
    zeta=0.0, profile=None, points=None, rtol=1e-10, atol=1e-13, method="DOP853",
) -> BeamCrossing:
    """Sprung mass with a massless contact point crossing a SS beam (see
    :func:`quarter_car_crossing` with ``wheel_mass = 0``: the contact force is the
    suspension force and acts on the beam)."""
    return quarter_car_crossing(
        body_mass, stiffness, damping, 0.0, L, EI, m, speed, n_modes, t_end,
        x_start=x_start, zeta=zeta, profile=profile, points=points, rtol=rtol, atol=atol,
        method=method,
    )


# =============================================================================
# Quarter car on rigid track over a dip, with loss of contact (event-driven)
# =============================================================================


@dataclass
class ContactEvent:
    """A change of contact state: ``kind`` is ``"detach"`` or ``"attach"``."""

    kind: str
    t: float
    x: float
    wheel_velocity_jump: float = 0.0  # m/s, plastic impact (attach only)


@dataclass
class EventDrivenSolution:
    """Event-driven quarter car on rigid track: contact and free-flight phases."""

    body_mass: float
    stiffness: float
    damping: float
    wheel_mass: float
    speed: float
    profile: Callable
    x_start: float
    events: list[ContactEvent] = field(default_factory=list)
    pieces: _Piecewise = field(default_factory=_Piecewise)

    @property
    def detachment_positions(self) -> np.ndarray:
        return np.array([e.x for e in self.events if e.kind == "detach"])

    @property
    def reattachment_positions(self) -> np.ndarray:
        return np.array([e.x for e in self.events if e.kind == "attach"])

    @property
    def event_times(self) -> np.ndarray:
        return np.array([e.t for e in self.events])

    # -- phase equations -----------------------------------------------------------
    def _rail(self, t):
        x = self.x_start + self.speed * t
        v = self.speed
        return (x, float(self.profile(x)), v * float(self.profile(x, 1)),
                v * v * float(self.profile(x, 2)))

    def _contact(self, t, s):
        """Contact phase, s = [z, z']: (z'', y, y', y'', P)."""
        _, y, yd, ydd = self._rail(t)
        fs = self.stiffness * (s[0] - y) + self.damping * (s[1] - yd)
        zdd = GRAVITY - fs / self.body_mass
        P = self.wheel_mass * GRAVITY + fs - self.wheel_mass * ydd
        return zdd, y, yd, ydd, P

    def _flight(self, t, s):
        """Flight phase, s = [z, z', y, y']: (z'', y'')."""
        fs = self.stiffness * (s[0] - s[2]) + self.damping * (s[1] - s[3])
        return GRAVITY - fs / self.body_mass, GRAVITY + fs / self.wheel_mass

    def evaluate(self, t) -> dict[str, np.ndarray]:
        """Response at times ``t``: x, body displacement/velocity/acceleration,
        wheel displacement/velocity, contact force, in_contact (0/1)."""
        t = np.atleast_1d(np.asarray(t, float))
        keys = ("x", "body_displacement", "body_velocity", "body_acceleration",
                "wheel_displacement", "wheel_velocity", "contact_force", "in_contact")
        out = {k: np.zeros(t.size) for k in keys}
        for i, ti in enumerate(t):
            j = self.pieces.index(ti)
            s = self.pieces.sols[j](ti)
            out["x"][i] = self.x_start + self.speed * ti
            out["body_displacement"][i] = s[0]
            out["body_velocity"][i] = s[1]
            if self.pieces.tags[j] == "contact":
                zdd, y, yd, _, P = self._contact(ti, s)
                out["contact_force"][i] = P
                out["in_contact"][i] = 1.0
            else:
                zdd, _ = self._flight(ti, s)
                y, yd = s[2], s[3]
            out["body_acceleration"][i] = zdd
            out["wheel_displacement"][i] = y
            out["wheel_velocity"][i] = yd
        return out


def quarter_car_rigid_dip_event_driven(
    body_mass, stiffness, damping, wheel_mass, speed, profile, t_end, x_start=0.0,
    rtol=1e-11, atol=1e-14, max_events=200,
) -> EventDrivenSolution:
    """Quarter car on RIGID track over an isolated dip, unilateral contact, event-driven.

    Parameters
    ----------
    body_mass, stiffness, damping, wheel_mass : float
        kg, N/m, N s/m, kg (wheel_mass > 0).
    speed : float
        m/s.
    profile : callable ``profile(x, derivative)`` with ``breakpoints``
        Rail irregularity (positive = rail lower), e.g. :class:`CosineDip`.
    t_end : float
        End time (s); ``t = 0`` with the wheel at ``x_start``, in static equilibrium.

    Notes
    -----
    * Contact phase (state z, z'): the wheel follows the rail, ``y = r(x(t))``,
      ``y' = v r'``, ``y'' = v^2 r''``; body ``M z'' = M g - F_s`` with
      ``F_s = k (z - y) + c (z' - y')``; contact force ``P = m_w g + F_s - m_w y''``.
      Lift-off when P crosses zero downwards (event; also checked at the profile
      breakpoints, where r'' and hence P jump).
    * Flight phase (state z, z', y, y'): ``m_w y'' = m_w g + F_s``, P = 0.  Landing when
      the gap ``r(x) - y`` (wheel above the rail is y < r) returns to zero from above.
    * Landing is a plastic impact: the wheel velocity becomes the rail velocity
      ``v r'(x)``; the body velocity is unchanged (a spring-dashpot transmits no
      impulse).  If the contact force right after the impact is negative the wheel
      leaves again at once (grazing).
    """
    if wheel_mass <= 0:
        raise ValueError("the event-driven reference needs a wheel mass > 0")
    sol = EventDrivenSolution(body_mass, stiffness, damping, wheel_mass, speed, profile,
                              x_start)
    breaks = _time_breaks(getattr(profile, "breakpoints", ()), x_start, speed, t_end)[1:]
    z0 = body_mass * GRAVITY / stiffness + float(profile(x_start))
    state = np.array([z0, 0.0])
    phase = "contact"
    t = 0.0
    n_ev = 0

    def lift(tt, s):
        return sol._contact(tt, s)[4]

    lift.terminal, lift.direction = True, -1

    def land(tt, s):
        return float(profile(x_start + speed * tt)) - s[2]

    land.terminal, land.direction = True, -1

    def rhs_contact(tt, s):
        return [s[1], sol._contact(tt, s)[0]]

    def rhs_flight(tt, s):
        zdd, ydd = sol._flight(tt, s)
        return [s[1], zdd, s[3], ydd]

    while t < t_end - 1e-15:
        tb = next(b for b in breaks if b > t + 1e-15)
        if phase == "contact":
            if lift(t, state) < 0.0:  # e.g. r'' jumps at a breakpoint, or grazing landing
                x = x_start + speed * t
                sol.events.append(ContactEvent("detach", t, x))
                n_ev += 1
                _, y, yd, _, _ = sol._contact(t, state)
                state = np.array([state[0], state[1], y, yd])
                phase = "flight"
                continue
            r = scipy.integrate.solve_ivp(rhs_contact, (t, tb), state, method="DOP853",
                                          rtol=rtol, atol=atol, dense_output=True,
                                          events=lift)
            sol.pieces.add(t, r.t[-1], r.sol, "contact")
            if r.status == 1:
                te = float(r.t_events[0][0])
                se = r.y_events[0][0]
                sol.events.append(ContactEvent("detach", te, x_start + speed * te))
                n_ev += 1
                _, y, yd, _, _ = sol._contact(te, se)
                state = np.array([se[0], se[1], y, yd])
                phase = "flight"
                t = te
            else:
                state, t = r.y[:, -1], tb
        else:
            # a short first step without the landing event: at lift-off the gap is zero
            # and grows like t^2 (or t^3); avoid a spurious root at the start.
            t_skip = min(t + 1e-7, tb)
            r0 = scipy.integrate.solve_ivp(rhs_flight, (t, t_skip), state, method="DOP853",
                                           rtol=rtol, atol=atol, dense_output=True)
            sol.pieces.add(t, t_skip, r0.sol, "flight")
            state, t = r0.y[:, -1], t_skip
            if t >= tb - 1e-15:
                continue
            r = scipy.integrate.solve_ivp(rhs_flight, (t, tb), state, method="DOP853",
                                          rtol=rtol, atol=atol, dense_output=True,
                                          events=land)
            sol.pieces.add(t, r.t[-1], r.sol, "flight")
            if r.status == 1:
                te = float(r.t_events[0][0])
                se = r.y_events[0][0]
                x = x_start + speed * te
                yd_rail = speed * float(profile(x, 1))
                sol.events.append(ContactEvent("attach", te, x, yd_rail - se[3]))
                n_ev += 1
                state = np.array([se[0], se[1]])  # plastic impact: body velocity kept
                phase = "contact"
                t = te
            else:
                state, t = r.y[:, -1], tb
        if n_ev > max_events:
            raise RuntimeError("too many contact events (chattering?)")
    return sol


# =============================================================================
# Two-span continuous beam
# =============================================================================


def _two_span_matrix(beta, L1, L2):
    """Characteristic matrix of the two-span beam, unknowns (A1, B1~, A2, B2~).

    Span i, local coordinate xi from its outer (pinned) end:
    ``W_i = A_i sin(beta xi) + B~_i sinh(beta xi)/cosh(beta L_i)`` (w = w'' = 0 at the
    outer end).  At the middle support: ``W_1 = W_2 = 0``, slope continuity
    ``W_1' = -W_2'`` (span 2's xi runs backwards) and equal bending moments
    ``W_1'' = W_2''``.  The hyperbolic terms are scaled by cosh to stay O(1).
    """
    s1, s2 = np.sin(beta * L1), np.sin(beta * L2)
    c1, c2 = np.cos(beta * L1), np.cos(beta * L2)
    t1, t2 = np.tanh(beta * L1), np.tanh(beta * L2)
    return np.array([
        [s1, t1, 0.0, 0.0],
        [0.0, 0.0, s2, t2],
        [c1, 1.0, c2, 1.0],
        [-s1, t1, s2, -t2],
    ])


def _two_span_betas(L1, L2, n):
    """The first n roots beta of det(_two_span_matrix) = 0 (brentq on sign changes)."""
    Lt = L1 + L2
    det = lambda b: np.linalg.det(_two_span_matrix(b, L1, L2))  # noqa: E731
    step = np.pi / Lt / 64.0
    roots: list[float] = []
    b0 = 1e-6
    f0 = det(b0)
    while len(roots) < n:
        b1 = b0 + step
        f1 = det(b1)
        if f0 == 0.0:
            roots.append(b0)
        elif f0 * f1 < 0.0:
            roots.append(scipy.optimize.brentq(det, b0, b1, xtol=1e-15))
        b0, f0 = b1, f1
    return np.array(roots[:n])


def two_span_continuous_frequencies(L1, L2, EI, m, n) -> np.ndarray:
    """Natural frequencies (Hz) of a two-span continuous Euler-Bernoulli beam.

    Pinned at both ends with an intermediate point support at ``x = L1``; uniform EI
    (N m2) and m (kg/m).  Roots ``beta`` of the 4x4 characteristic determinant (see
    ``_two_span_matrix``) by a sign scan and ``brentq``; ``omega = beta^2 sqrt(EI/m)``.
    """
    beta = _two_span_betas(L1, L2, n)
    return beta**2 * np.sqrt(EI / m) / (2.0 * np.pi)


def two_span_equal_frequencies(L, EI, m, n) -> np.ndarray:
    """Closed form for two equal spans (Hz): the antisymmetric modes are the simply
    supported modes of one span, ``beta L = j pi``; the symmetric ones are the
    clamped-pinned modes of one span, ``tan(beta L) = tanh(beta L)``."""
    ss = np.arange(1, n + 1) * np.pi
    cp = []
    for j in range(1, n + 1):  # one root in (j pi, j pi + pi/2)
        f = lambda b: np.tan(b) - np.tanh(b)  # noqa: E731
        cp.append(scipy.optimize.brentq(f, j * np.pi + 1e-9, j * np.pi + 0.5 * np.pi - 1e-9,
                                        xtol=1e-15))
    beta_l = np.sort(np.concatenate([ss, cp]))[:n]
    return (beta_l / L) ** 2 * np.sqrt(EI / m) / (2.0 * np.pi)


def two_span_continuous_modes(L1, L2, EI, m, n, x, derivative: int = 0):
    """Frequencies (Hz) and mass-normalised mode shapes of the two-span beam.

    Returns ``(freqs, shapes)`` with shapes of shape (len(x), n) (or their
    ``derivative``-th x-derivative, 0..2), each mode with ``int m phi^2 dx = 1`` and its
    largest displacement positive (down).
    """
    x = np.atleast_1d(np.asarray(x, float))
    beta = _two_span_betas(L1, L2, n)
    gx, gw = np.polynomial.legendre.leggauss(200)

    def span_shape(c, b, Li, xi, d):
        a, bt = c
        sc = 1.0 / np.cosh(b * Li)
        if d == 0:
            return a * np.sin(b * xi) + bt * sc * np.sinh(b * xi)
        if d == 1:
            return b * (a * np.cos(b * xi) + bt * sc * np.cosh(b * xi))
        return b * b * (-a * np.sin(b * xi) + bt * sc * np.sinh(b * xi))

    def shape(c, b, xx, d):
        out = np.zeros_like(xx)
        left = xx <= L1
        out[left] = span_shape(c[:2], b, L1, xx[left], d)
        xi = L1 + L2 - xx[~left]
        out[~left] = (-1.0) ** d * span_shape(c[2:], b, L2, xi, d)
        out[(xx < 0) | (xx > L1 + L2)] = 0.0
        return out

    freqs = beta**2 * np.sqrt(EI / m) / (2.0 * np.pi)
    shapes = np.zeros((x.size, n))
    dense = np.linspace(0.0, L1 + L2, 4001)
    for j, b in enumerate(beta):
        _, _, vt = np.linalg.svd(_two_span_matrix(b, L1, L2))
        c = vt[-1]
        norm = 0.0
        for a0, a1 in ((0.0, L1), (L1, L1 + L2)):
            xq = 0.5 * (a1 - a0) * gx + 0.5 * (a1 + a0)
            norm += 0.5 * (a1 - a0) * np.sum(gw * m * shape(c, b, xq, 0) ** 2)
        c = c / np.sqrt(norm)
        wd = shape(c, b, dense, 0)
        c = c * np.sign(wd[np.argmax(np.abs(wd))])
        shapes[:, j] = shape(c, b, x, derivative)
    return freqs, shapes


# =============================================================================
# Vehicles: 10-DOF railway car, lever-rule static loads
# =============================================================================


def lever_rule(weight: float, p_cg: float, p_front: float, p_rear: float):
    """Split ``weight`` (N) between two supports at positions p_front < p_rear (m)."""
    span = p_rear - p_front
    rear = weight * (p_cg - p_front) / span
    return weight - rear, rear


def railway_car_static_axle_loads(body_mass, bogie_mass, wheelset_mass, bogie_spacing,
                                  body_cg_to_front_bogie=None) -> np.ndarray:
    """Static axle loads (N) of the 4-axle car on level rigid track, by the lever rule.

    Body weight split between the bogie centres, each bogie's load split equally
    between its two axles (bogie mass centred), plus the wheelset weight.
    """
    if body_cg_to_front_bogie is None:
        body_cg_to_front_bogie = 0.5 * bogie_spacing
    front, rear = lever_rule(body_mass * GRAVITY, body_cg_to_front_bogie, 0.0, bogie_spacing)
    b = bogie_mass * GRAVITY
    w = wheelset_mass * GRAVITY
    return np.array([0.5 * (front + b) + w] * 2 + [0.5 * (rear + b) + w] * 2)


def railway_car_matrices(body_mass, body_pitch_inertia, bogie_mass, bogie_pitch_inertia,
                         wheelset_mass, bogie_spacing, wheelbase, primary_stiffness,
                         primary_damping, secondary_stiffness, secondary_damping,
                         body_cg_to_front_bogie=None):
    """Mass, damping and stiffness matrices of the planar 10-DOF car.

    DOFs: body bounce z_c, body pitch t_c, bogie 1 bounce/pitch (z_1, t_1), bogie 2
    (z_2, t_2), wheelsets w_1..w_4 (front to rear).  Here pitch is positive when the
    front goes up (a point a distance ``d`` ahead of the centre moves ``z - d t``);
    eigenvalues and static loads do not depend on this choice.

    Returns
    -------
    M, C, K : ndarray (10, 10)
    wheel_dofs : ndarray (4,)
    """
    if body_cg_to_front_bogie is None:
        body_cg_to_front_bogie = 0.5 * bogie_spacing
    d1 = body_cg_to_front_bogie  # front bogie ahead of the body cg
    d2 = bogie_spacing - body_cg_to_front_bogie  # rear bogie behind the body cg
    a = 0.5 * wheelbase
    M = np.diag([body_mass, body_pitch_inertia, bogie_mass, bogie_pitch_inertia, bogie_mass,
                 bogie_pitch_inertia] + [wheelset_mass] * 4)
    K = np.zeros((10, 10))
    C = np.zeros((10, 10))

    def spring(i_up, up_coef, i_lo, lo_coef, k, c):
        # relative displacement = sum(up) - sum(lo)
        e = np.zeros(10)
        for i, cf in zip(i_up, up_coef, strict=True):
            e[i] += cf
        for i, cf in zip(i_lo, lo_coef, strict=True):
            e[i] -= cf
        K[:] += k * np.outer(e, e)
        C[:] += c * np.outer(e, e)

    ks, cs, kp, cp = secondary_stiffness, secondary_damping, primary_stiffness, primary_damping
    # secondary: body point over bogie centre (front: ahead by d1 -> z - d1 t)
    spring([0, 1], [1.0, -d1], [2], [1.0], ks, cs)
    spring([0, 1], [1.0, +d2], [4], [1.0], ks, cs)
    # primary: bogie point over each wheelset (front axle ahead of the bogie centre by a)
    spring([2, 3], [1.0, -a], [6], [1.0], kp, cp)
    spring([2, 3], [1.0, +a], [7], [1.0], kp, cp)
    spring([4, 5], [1.0, -a], [8], [1.0], kp, cp)
    spring([4, 5], [1.0, +a], [9], [1.0], kp, cp)
    return M, C, K, np.array([6, 7, 8, 9])


def fixed_wheel_frequencies(M, K, wheel_dofs) -> np.ndarray:
    """Undamped natural frequencies (Hz) with the wheel DOFs held fixed."""
    keep = np.setdiff1d(np.arange(M.shape[0]), wheel_dofs)
    lam = scipy.linalg.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


# =============================================================================
# Signal utilities (for free-vibration checks)
# =============================================================================


def dominant_frequency(t, y, f_lo=0.0, f_hi=np.inf) -> float:
    """Frequency (Hz) of the largest spectral peak of ``y(t)`` in ``[f_lo, f_hi]``.

    Hann window, 16x zero padding, then the peak of the (continuous) windowed DTFT is
    refined with a bounded scalar search: the estimate is limited by leakage from
    other components, not by the bin width.
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float) - np.mean(y)
    dt = t[1] - t[0]
    w = np.hanning(y.size)
    nfft = 16 * int(2 ** np.ceil(np.log2(y.size)))
    spec = np.abs(np.fft.rfft(w * y, nfft))
    f = np.fft.rfftfreq(nfft, dt)
    band = (f >= f_lo) & (f <= f_hi)
    i = np.flatnonzero(band)[np.argmax(spec[band])]

    def amp(fr):
        return -abs(np.sum(w * y * np.exp(-2j * np.pi * fr * (t - t[0]))))

    res = scipy.optimize.minimize_scalar(amp, bounds=(f[i - 1], f[i + 1]), method="bounded",
                                         options={"xatol": 1e-10})
    return float(res.x)


def free_vibration_fit(t, y, freqs) -> float:
    """Relative residual of the least-squares fit of ``y(t)`` by sinusoids at ``freqs``.

    ``y ~ c + sum_k a_k cos(2 pi f_k t) + b_k sin(2 pi f_k t)``; returns
    ``||y - fit|| / ||y - mean(y)||``.  Small only if the signal's frequencies are
    (very nearly) the given ones: a relative frequency error e over a record of N
    periods leaves a residual of order 2 pi N e.
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    fr = np.unique(np.round(np.asarray(freqs, float), 12))
    cols = [np.ones_like(t)]
    for f in fr:
        cols += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(np.linalg.norm(y - A @ coef) / np.linalg.norm(y - y.mean()))


# =============================================================================
# Quarter car behind moving forces on a flexible SS beam, unilateral contact
# (event-driven, plastic impacts)
# =============================================================================


@dataclass
class FlexibleEventDriven:
    """Event-driven quarter car on a simply supported beam (flat rail), led by moving
    forces, with unilateral contact and plastic impacts.  See
    :func:`quarter_car_flexible_event_driven`."""

    body_mass: float
    stiffness: float
    damping: float
    wheel_mass: float
    L: float
    EI: float
    m: float
    zeta: float
    n_modes: int
    speed: float
    x_start: float
    force_x_start: np.ndarray
    force_p: np.ndarray
    events: list[ContactEvent] = field(default_factory=list)
    pieces: _Piecewise = field(default_factory=_Piecewise)

    def __post_init__(self):
        self.omega = ss_omega(self.L, self.EI, self.m, self.n_modes)
        self._k = np.pi * np.arange(1, self.n_modes + 1) / self.L
        self._amp = np.sqrt(2.0 / (self.m * self.L))

    def shapes(self, x, side=0.0):
        """phi, phi' at x (zero off the span; ``side`` = +-1 picks the limit at an end)."""
        xe = x + side * 1e-12
        if 0.0 <= xe <= self.L:
            return self._amp * np.sin(self._k * x), self._amp * self._k * np.cos(self._k * x)
        z = np.zeros(self.n_modes)
        return z, z

    def _load(self, t):
        f = np.zeros(self.n_modes)
        for x0, p in zip(self.force_x_start, self.force_p, strict=True):
            x = x0 + self.speed * t
            if 0.0 <= x <= self.L:
                f += p * self._amp * np.sin(self._k * x)
        return f

    def _beam_free(self, t, q, qd):
        return -2 * self.zeta * self.omega * qd - self.omega**2 * q + self._load(t)

    def _contact(self, t, s):
        """Contact phase, s = [z, z', q, q']: (derivative, contact force P)."""
        n, v, mw = self.n_modes, self.speed, self.wheel_mass
        q, qd = s[2:2 + n], s[2 + n:]
        phi, dphi = self.shapes(self.x_start + v * t)
        y = phi @ q
        yd = phi @ qd + v * (dphi @ q)
        conv = 2 * v * (dphi @ qd) - v * v * ((self._k**2 * phi) @ q)
        fs = self.stiffness * (s[0] - y) + self.damping * (s[1] - yd)
        rhs = self._beam_free(t, q, qd) + phi * (mw * GRAVITY + fs - mw * conv)
        qdd = rhs - phi * (mw * (phi @ rhs)) / (1.0 + mw * (phi @ phi))
        P = mw * GRAVITY + fs - mw * (phi @ qdd + conv)
        out = np.concatenate([[s[1], GRAVITY - fs / self.body_mass], qd, qdd])
        return out, P

    def _flight(self, t, s):
        """Flight phase, s = [z, z', y, y', q, q']."""
        n = self.n_modes
        q, qd = s[4:4 + n], s[4 + n:]
        fs = self.stiffness * (s[0] - s[2]) + self.damping * (s[1] - s[3])
        return np.concatenate([[s[1], GRAVITY - fs / self.body_mass, s[3],
                                GRAVITY + fs / self.wheel_mass], qd,
                               self._beam_free(t, q, qd)])

    def _rail(self, t, q, qd, side=0.0):
        phi, dphi = self.shapes(self.x_start + self.speed * t, side)
        return phi @ q, phi @ qd + self.speed * (dphi @ q), phi

    def evaluate(self, t) -> dict[str, np.ndarray]:
        """in_contact (0/1), contact_force, wheel_displacement at times ``t``."""
        t = np.atleast_1d(np.asarray(t, float))
        out = {k: np.zeros(t.size) for k in ("in_contact", "contact_force",
                                              "wheel_displacement")}
        n = self.n_modes
        for i, ti in enumerate(t):
            j = self.pieces.index(ti)
            s = self.pieces.sols[j](ti)
            if self.pieces.tags[j] == "contact":
                out["in_contact"][i] = 1.0
                out["contact_force"][i] = self._contact(ti, s)[1]
                out["wheel_displacement"][i] = self._rail(ti, s[2:2 + n], s[2 + n:])[0]
            else:
                out["wheel_displacement"][i] = s[2]
        return out

    def losses(self) -> list[tuple[float, float]]:
        """(detachment time, reattachment time) of every loss of contact (s)."""
        out, t0 = [], None
        for e in self.events:
            if e.kind == "detach":
                t0 = e.t
            elif t0 is not None:
                out.append((t0, e.t))
                t0 = None
        return out


def quarter_car_flexible_event_driven(
    body_mass, stiffness, damping, wheel_mass, L, EI, m, speed, n_modes, t_end,
    x_start, force_x_start=(), force_p=(), zeta=0.0, rtol=1e-10, atol=1e-13,
    max_events=100,
) -> FlexibleEventDriven:
    """Quarter car (wheel mass > 0) crossing a simply supported beam behind moving forces,
    with unilateral contact and plastic impacts, event by event.

    Notes
    -----
    * Contact phase: the wheel follows the rail ``y = phi(x) q`` (flat rail), equations
      of :class:`BeamCrossing` plus the modal load of the forces; lift-off when the
      contact force P crosses zero downwards.
    * Flight phase: wheel ``m_w y'' = m_w g + F_s``, beam loaded by the forces only;
      landing when the gap ``phi q - y`` returns to zero.
    * Landing: plastic impact of the wheel on the beam modes (unit modal masses),
      impulse ``P = (y'- - rail'-) / (1/m_w + phi.phi) >= 0``, ``y' -= P/m_w``,
      ``q' += phi P``.
    * Crossing an end of the span in contact: the rail velocity jumps (from 0 to
      ``v phi'(0) q`` at the entry, from ``v phi'(L) q`` to 0 at the exit).  The impulse
      that would keep the wheel on the rail is ``m_w (y'- - rail'+)`` (phi = 0 at the
      supports); if it is tensile the wheel leaves the rail with its velocity
      (unilateral impact: it can only push), else it is applied (plastic).
    """
    if wheel_mass <= 0:
        raise ValueError("the event-driven reference needs a wheel mass > 0")
    sol = FlexibleEventDriven(body_mass, stiffness, damping, wheel_mass, L, EI, m, zeta,
                              n_modes, speed, x_start, np.asarray(force_x_start, float),
                              np.asarray(force_p, float))
    n = n_modes
    marks = [0.0, L]
    ts = {(xm - x_start) / speed for xm in marks}
    for x0 in sol.force_x_start:
        ts |= {(xm - x0) / speed for xm in marks}
    breaks = [tb for tb in sorted(ts) if 0.0 < tb < t_end] + [t_end]
    wheel_breaks = {(xm - x_start) / speed for xm in marks}
    state = np.zeros(2 + 2 * n)
    state[0] = body_mass * GRAVITY / stiffness
    phase, t, n_ev = "contact", 0.0, 0

    def lift(tt, s):
        return sol._contact(tt, s)[1]

    lift.terminal, lift.direction = True, -1

    def land(tt, s):
        return sol._rail(tt, s[4:4 + n], s[4 + n:])[0] - s[2]

    land.terminal, land.direction = True, -1

    def to_flight(tt, s):
        y, yd, _ = sol._rail(tt, s[2:2 + n], s[2 + n:], -1.0)
        return np.concatenate([s[:2], [y, yd], s[2:]])

    while t < t_end - 1e-15:
        tb = next(b for b in breaks if b > t + 1e-15)
        if phase == "contact":
            if lift(t, state) < 0.0:
                sol.events.append(ContactEvent("detach", t, x_start + speed * t))
                n_ev += 1
                state, phase = to_flight(t, state), "flight"
                continue
            r = scipy.integrate.solve_ivp(lambda tt, s: sol._contact(tt, s)[0], (t, tb),
                                          state, method="DOP853", rtol=rtol, atol=atol,
                                          dense_output=True, events=lift)
            sol.pieces.add(t, r.t[-1], r.sol, "contact")
            if r.status == 1:
                te = float(r.t_events[0][0])
                sol.events.append(ContactEvent("detach", te, x_start + speed * te))
                n_ev += 1
                state, phase, t = to_flight(te, r.y_events[0][0]), "flight", te
                continue
            state, t = r.y[:, -1], tb
            if any(abs(t - w) < 1e-12 for w in wheel_breaks):
                q, qd = state[2:2 + n], state[2 + n:]
                _, yd_before, _ = sol._rail(t, q, qd, -1.0)
                _, yd_after, _ = sol._rail(t, q, qd, +1.0)
                if wheel_mass * (yd_before - yd_after) < 0.0:  # tensile: the wheel leaves
                    sol.events.append(ContactEvent("detach", t, x_start + speed * t))
                    n_ev += 1
                    s = np.concatenate([state[:2], [sol._rail(t, q, qd)[0], yd_before],
                                        state[2:]])
                    state, phase = s, "flight"
        else:
            t_skip = min(t + 1e-7, tb)
            r0 = scipy.integrate.solve_ivp(sol._flight, (t, t_skip), state, method="DOP853",
                                           rtol=rtol, atol=atol, dense_output=True)
            sol.pieces.add(t, t_skip, r0.sol, "flight")
            state, t = r0.y[:, -1], t_skip
            if t >= tb - 1e-15:
                continue
            r = scipy.integrate.solve_ivp(sol._flight, (t, tb), state, method="DOP853",
                                          rtol=rtol, atol=atol, dense_output=True,
                                          events=land)
            sol.pieces.add(t, r.t[-1], r.sol, "flight")
            if r.status == 1:
                te = float(r.t_events[0][0])
                se = r.y_events[0][0]
                q, qd = se[4:4 + n], se[4 + n:].copy()
                _, rd, phi = sol._rail(te, q, qd)
                P = (se[3] - rd) / (1.0 / wheel_mass + phi @ phi)
                sol.events.append(ContactEvent("attach", te, x_start + speed * te,
                                               -P / wheel_mass))
                n_ev += 1
                qd += phi * P
                state = np.concatenate([se[:2], q, qd])
                phase, t = "contact", te
            else:
                state, t = r.y[:, -1], tb
        if n_ev > max_events:
            raise RuntimeError("too many contact events (chattering?)")
    return sol


# --------------------------------------------------- quarter car over an elastic-track joint


@dataclass
class JointResult:
    """Output of :func:`quarter_car_elastic_joint`."""

    t: np.ndarray  # s
    force: np.ndarray  # N, wheel-rail contact force (compression)
    x: np.ndarray  # m, wheel abscissa
    static_force: float  # N


def quarter_car_elastic_joint(
    length: float, EI: float, mass_per_length: float, n_modes: int,
    foundation: float, rail_EI: float,
    mass: float, stiffness: float, damping: float, wheel_mass: float,
    speed: float, x_start: float, t_end: float,
    margin: float = 25.0, h: float = 0.025, rtol: float = 1e-9,
) -> JointResult:
    """A quarter car (sprung ``mass`` on a spring-dashpot over ``wheel_mass``) running
    over an undamped simply supported beam whose track is a rail (``rail_EI``) on a
    Winkler foundation (``foundation``, N/m per m) bearing on the deck where there is
    deck and on rigid ground over the approaches; the wheel is in rigid contact with the
    rail (the test checks that it stays in contact).

    The rail is quasi-static and discretised by central finite differences on a uniform
    grid of spacing ``h`` over ``[-margin, length + margin]`` (clamped ends, far from the
    wheel): EI w'''' + k w = k u + P delta(x - x_w) with u = sum_j phi_j q_j on the deck;
    the point load and the rail deflection under the wheel use linear-interpolation
    weights between the two nearest nodes.  The deck's modal force is the foundation
    force integrated over the deck, sum_i h phi_j(x_i) k (w_i - u_i) (trapezoid rule),
    which holds both the spread wheel load and the rail's restraint of the deck.  The
    contact force follows from the rail's compliance under the wheel,
    P = (u_w - w_q(x_w)) / g(x_w).  States: q, q', u_s, u_s', u_w, u_w'; ``solve_ivp``
    (DOP853) with steps below h / speed so the piecewise-linear load path is followed.
    """
    g0 = 9.81
    n = int(round((length + 2 * margin) / h))
    xs = -margin + h * np.arange(n + 1)
    N = xs.size
    # banded FD matrix EI D4 / h^4 + k I; clamped ends (w = 0 at a ghost node beyond the
    # last one and mirrored slope: w_{-1} = w_1)
    c = rail_EI / h**4
    ab = np.zeros((5, N))
    ab[0, 2:] = c
    ab[1, 1:] = -4 * c
    ab[2, :] = 6 * c + foundation
    ab[3, :-1] = -4 * c
    ab[4, :-2] = c
    ab[2, [0, -1]] += c
    omega = ss_omega(length, EI, mass_per_length, n_modes)
    on = (xs >= 0.0) & (xs <= length)
    phi = ss_shapes(length, mass_per_length, n_modes, xs)
    wq = scipy.linalg.solve_banded((2, 2), ab, foundation * phi)  # per unit q_j
    trap = np.where(on, h, 0.0)
    trap[np.flatnonzero(on)[[0, -1]]] *= 0.5
    # rail deflection under unit loads at the nodes the wheel passes (columns)
    x_end = x_start + speed * t_end
    i0 = int(np.floor((x_start - xs[0]) / h)) - 1
    i1 = int(np.floor((x_end - xs[0]) / h)) + 2
    E = np.zeros((N, i1 - i0 + 1))
    E[np.arange(i0, i1 + 1), np.arange(i1 - i0 + 1)] = 1.0 / h
    cols = scipy.linalg.solve_banded((2, 2), ab, E)

    def under_wheel(t, q):
        x = x_start + speed * t
        i = int(np.floor((x - xs[0]) / h))
        s = (x - xs[i]) / h
        wts = np.array([1.0 - s, s])
        col = cols[:, i - i0: i - i0 + 2] @ wts  # rail deflection of a unit wheel load
        g = wts @ col[i:i + 2]
        return wts @ (wq[i:i + 2] @ q), g, col

    def rhs(t, y):
        q, qd = y[:n_modes], y[n_modes:2 * n_modes]
        us, usd, uw, uwd = y[2 * n_modes:]
        wq_x, g, col = under_wheel(t, q)
        P = (uw - wq_x) / g
        w = wq @ q + col * P
        f = (trap * foundation * (w - phi @ q)) @ phi
        fs = stiffness * (us - uw) + damping * (usd - uwd)
        return np.concatenate([qd, f - omega**2 * q,
                               [usd, g0 - fs / mass, uwd, g0 + (fs - P) / wheel_mass]])

    # static equilibrium far from the deck (q = 0)
    _, g, _ = under_wheel(0.0, np.zeros(n_modes))
    P0 = (mass + wheel_mass) * g0
    y0 = np.concatenate([np.zeros(2 * n_modes),
                         [g * P0 + mass * g0 / stiffness, 0.0, g * P0, 0.0]])
    t_eval = np.linspace(0.0, t_end, int(round(t_end / 1e-5)) + 1)
    sol = scipy.integrate.solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol,
                                    atol=1e-12, max_step=0.5 * h / speed, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(sol.message)
    force = np.empty(sol.t.size)
    for k, (t, y) in enumerate(zip(sol.t, sol.y.T, strict=True)):
        wq_x, g, _ = under_wheel(t, y[:n_modes])
        force[k] = (y[2 * n_modes + 2] - wq_x) / g
    return JointResult(t=sol.t, force=force, x=x_start + speed * sol.t, static_force=P0)


# ------------------------------------ deck-end crossings of the event-driven quarter car


@dataclass
class DeckEndCrossing:
    """The wheel of a :class:`FlexibleEventDriven` solution passing an end of the span."""

    t: float  # s
    x: float  # m (0 or L)
    in_contact: bool  # on the rail just before the end
    rail_velocity_before: float  # m/s, down, on the side the wheel comes from
    rail_velocity_after: float  # m/s, down, on the side it goes to
    impulse: float  # N s: m_w (before - after); > 0 a plastic impact, <= 0 a lift-off


def deck_end_crossings(sol: FlexibleEventDriven) -> list[DeckEndCrossing]:
    """Both ends of the span as the wheel of ``sol`` passes them, from its dense output.

    Phi = 0 at the supports, so the rail's down velocity there is v phi'(x) q on the
    deck and 0 on the rigid approach; a wheel on the rail keeps the velocity of the side
    it comes from until the end, and the impulse that keeps it on the other side is
    m_w (before - after) (the deck takes none: phi = 0).  ``sol`` applied it where it is
    compressive (an upward kink of the running surface) and let the wheel fly where not.
    """
    out = []
    n = sol.n_modes
    for xm in (0.0, sol.L):
        t = (xm - sol.x_start) / sol.speed
        j = sol.pieces.index(t)
        if sol.pieces.t0[j] >= t:  # the segment before the end
            j -= 1
        s = sol.pieces.sols[j](t)
        contact = sol.pieces.tags[j] == "contact"
        q, qd = (s[2:2 + n], s[2 + n:]) if contact else (s[4:4 + n], s[4 + n:])
        _, before, _ = sol._rail(t, q, qd, -1.0)
        _, after, _ = sol._rail(t, q, qd, +1.0)
        out.append(DeckEndCrossing(t, xm, contact, float(before), float(after),
                                   float(sol.wheel_mass * (before - after))))
    return out


# -------------------------------------- vehicles with nonlinear suspensions on a rigid rail


def bump_stop_force(d, d_on, k_stop):
    """Force (N) of a bump stop closing at compression ``d_on`` (m): k (d - d_on)+."""
    return k_stop * np.maximum(d - d_on, 0.0)


def blowoff_damper_force(dd, c, f_blow, c_post):
    """Force (N) of a damper with a blow-off valve: c dd up to |f| = f_blow, then
    f_blow + c_post (|dd| - f_blow / c), odd in the rate dd (m/s)."""
    v_b = f_blow / c
    a = np.abs(dd)
    return np.sign(dd) * np.where(a <= v_b, c * a, f_blow + c_post * (a - v_b))


@dataclass
class RigidRailRun:
    """Output of :func:`vehicle_on_rigid_rail` at the times ``t``."""

    t: np.ndarray  # (n_t,) s
    u: np.ndarray  # (n_t, n) displacements (m, rad), positive down
    a: np.ndarray  # (n_t, n) accelerations
    wheel_force: np.ndarray  # (n_t, n_w) N, compression
    element: np.ndarray  # (n_t, n_e) compression of each nonlinear element, m
    element_rate: np.ndarray  # (n_t, n_e) m/s


def vehicle_on_rigid_rail(M, C, K, gravity, wheel_dofs, wheel_x0, speed, profile, forces,
                          t_eval, rtol=1e-10, atol=1e-13) -> RigidRailRun:
    """A vehicle whose wheels follow a rigid rail (bilateral contact), with nonlinear
    suspension elements, integrated by ``solve_ivp`` (DOP853).

    Parameters
    ----------
    M, C, K, gravity : the linear vehicle (positive down).
    wheel_dofs : wheel DOFs; wheel ``i`` is at ``wheel_x0[i] + speed t`` and its
        displacement is the rail's, ``profile(x)`` (derivatives by ``derivative=``).
    forces : list of (row, f) with ``f(d, dd)`` the element force (N) beyond the linear
        K, C at compression ``d = row @ u`` and rate ``dd = row @ v``; it acts as
        ``row^T f``.
    t_eval : output times, starting at 0 with the free DOFs in static equilibrium on a
        level rail (the elements must be inactive there).

    Notes
    -----
    The free DOFs obey M_ff a_f = g_f - (K u + C v + sum row f)_f - M_fw a_w with the
    wheel motions prescribed; the wheel forces are
    X_w = g_w - (M a + K u + C v + sum row f)_w.  The element forces are continuous
    with kinks (the bump stop closing, the valve opening): DOP853 at rtol 1e-10 meets
    them by step rejection.
    """
    n = M.shape[0]
    wheel_dofs = np.asarray(wheel_dofs)
    wheel_x0 = np.asarray(wheel_x0, float)
    free = np.setdiff1d(np.arange(n), wheel_dofs)
    Mff = M[np.ix_(free, free)]

    def rail(t):
        x = wheel_x0 + speed * t
        return (profile(x), speed * profile(x, 1), speed**2 * profile(x, 2))

    def full(t, y):
        u = np.zeros(n)
        v = np.zeros(n)
        a = np.zeros(n)
        r, rd, rdd = rail(t)
        u[free], v[free] = y[:free.size], y[free.size:]
        u[wheel_dofs], v[wheel_dofs], a[wheel_dofs] = r, rd, rdd
        f = K @ u + C @ v
        for row, law in forces:
            f = f + row * law(row @ u, row @ v)
        a[free] = np.linalg.solve(Mff, gravity[free] - f[free] - M[free][:, wheel_dofs]
                                  @ a[wheel_dofs])
        return u, v, a, f

    def rhs(t, y):
        _, v, a, _ = full(t, y)
        return np.concatenate([v[free], a[free]])

    u0 = np.zeros(n)
    u0[free] = np.linalg.solve(K[np.ix_(free, free)], gravity[free])
    y0 = np.concatenate([u0[free], np.zeros(free.size)])
    t_eval = np.asarray(t_eval, float)
    sol = scipy.integrate.solve_ivp(rhs, (t_eval[0], t_eval[-1]), y0, method="DOP853",
                                    rtol=rtol, atol=atol, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(sol.message)
    U, A, X = [], [], []
    E, ED = [], []
    for t, y in zip(sol.t, sol.y.T, strict=True):
        u, v, a, f = full(t, y)
        U.append(u)
        A.append(a)
        X.append((gravity - M @ a - f)[wheel_dofs])
        E.append([row @ u for row, _ in forces])
        ED.append([row @ v for row, _ in forces])
    return RigidRailRun(sol.t, np.array(U), np.array(A), np.array(X),
                        np.array(E).reshape(len(U), -1), np.array(ED).reshape(len(U), -1))


# ------------------------------------------- vehicle on a damped (massive) track over a span


@dataclass
class DampedTrackResult:
    """Output of :func:`vehicle_on_damped_track`."""

    t: np.ndarray  # s
    force: np.ndarray  # (n_t, n_w) N, wheel-rail contact forces (compression, 0 when off)
    deck_acceleration: np.ndarray  # (n_t, n_p) m/s2 at ``points``, modes summed
    static_force: np.ndarray  # (n_w,) N, contact forces of the static start


def vehicle_on_damped_track(
    length: float, EI: float, mass_per_length: float, n_modes: int, zeta: float,
    foundation: float, foundation_damping: float, rail_EI: float, rail_mass: float,
    M: np.ndarray, C: np.ndarray, K: np.ndarray, gravity: np.ndarray, wheel_dofs,
    wheel_offsets, contact_stiffness: float, profile: Callable, speed: float,
    x_start: float, t_end: float, points=(), h: float = 0.1, margin: float = 12.0,
    rtol: float = 1e-6, n_out: int = 4001,
) -> DampedTrackResult:
    """A vehicle (matrices ``M``, ``C``, ``K``, load ``gravity``) on a rail (``rail_EI``,
    ``rail_mass`` kg/m) on a Kelvin-Voigt foundation (``foundation`` N/m per m,
    ``foundation_damping`` N s/m per m) bearing on a simply supported beam (modes,
    damping ratio ``zeta``) where there is deck and on rigid ground elsewhere.

    The rail is discretised by central finite differences on a uniform grid of spacing
    ``h`` over the wheels' path extended by ``margin`` (clamped ends):

        m' w'' + c (w' - u') + EI w'''' + k (w - u) = sum_i P_i delta(x - x_i),
        u = sum_j phi_j q_j on the deck, 0 off it,

    the deck's modal force is the foundation force over the deck,
    sum_n h_n phi_j(x_n) [k (w_n - u_n) + c (w'_n - u'_n)] (trapezoid weights); with a
    massless rail (``rail_mass = 0``, then ``foundation_damping > 0``) the rail equation
    is first order in w.  The contact is a unilateral linear spring,
    P_i = k_c max(0, u_wheel_i - w(x_i) - r(x_i)), with the point load and the rail
    deflection under the wheel taken with linear-interpolation weights between the two
    nearest nodes; wheel i is ``wheel_offsets[i]`` behind the first axle, at
    ``x_start + v t - offset``.  Starts from the static equilibrium (all wheels in
    contact, at rest); ``profile`` (callable r(x)) must be zero under the wheels at
    t = 0.  Integrated by ``solve_ivp`` (Radau, the exact sparse Jacobian of the
    piecewise-linear system, steps below h / v).
    """
    import scipy.sparse as sps

    wheel_dofs = np.asarray(wheel_dofs)
    offs = np.asarray(wheel_offsets, float)
    n_w, n_v, n_m = wheel_dofs.size, M.shape[0], n_modes
    x_lo = x_start - offs.max() - margin
    x_hi = x_start + speed * t_end + margin
    n = int(np.ceil((x_hi - x_lo) / h))
    xs = x_lo + h * np.arange(n + 1)
    N = xs.size
    c4 = rail_EI / h**4
    D4 = sps.diags([c4, -4 * c4, 6 * c4, -4 * c4, c4], [-2, -1, 0, 1, 2], shape=(N, N),
                   format="lil")
    D4[0, 0] += c4  # clamped: ghost w_{-1} = w_1
    D4[N - 1, N - 1] += c4
    D4 = D4.tocsr()
    Kr = (D4 + foundation * sps.identity(N)).tocsr()
    omega = ss_omega(length, EI, mass_per_length, n_modes)
    on = (xs >= 0.0) & (xs <= length)
    Phi = ss_shapes(length, mass_per_length, n_modes, xs) * on[:, None]  # (N, n_m)
    trap = np.where(on, h, 0.0)
    trap[np.flatnonzero(on)[[0, -1]]] *= 0.5
    PhiT = (Phi * trap[:, None]).T  # (n_m, N): modal force of nodal foundation forces
    phi_p = ss_shapes(length, mass_per_length, n_modes, np.asarray(points, float))
    Minv = np.linalg.inv(M)
    Ew = np.zeros((n_w, n_v))
    Ew[np.arange(n_w), wheel_dofs] = 1.0
    massive = rail_mass > 0.0
    if not massive and foundation_damping <= 0.0:
        raise ValueError("a massless rail needs foundation damping (first-order rail)")
    # state layout
    iw = slice(0, N)
    iwd = slice(N, 2 * N) if massive else None
    o = 2 * N if massive else N
    iq, iqd = slice(o, o + n_m), slice(o + n_m, o + 2 * n_m)
    iu, iud = slice(o + 2 * n_m, o + 2 * n_m + n_v), slice(o + 2 * n_m + n_v,
                                                           o + 2 * n_m + 2 * n_v)
    n_y = o + 2 * n_m + 2 * n_v

    def weights(t):
        """(W (n_w, N) interpolation of the rail under the wheels, x_i)."""
        x = x_start + speed * t - offs
        i = np.floor((x - xs[0]) / h).astype(int)
        s = (x - xs[i]) / h
        rows = np.repeat(np.arange(n_w), 2)
        cols = np.stack([i, i + 1], 1).ravel()
        vals = np.stack([1.0 - s, s], 1).ravel()
        return sps.csr_matrix((vals, (rows, cols)), shape=(n_w, N)), x

    def contact(t, y):
        W, x = weights(t)
        pen = y[iu][wheel_dofs] - W @ y[iw] - profile(x)
        act = pen > 0.0
        return W, np.where(act, contact_stiffness * pen, 0.0), act

    kc = foundation
    cc = foundation_damping
    om2 = omega**2
    c_m = 2 * zeta * omega

    def rhs(t, y):
        # the contact of contact() without building W (the Jacobian's sparse matrix):
        # the rail under wheel i is (1 - s_i) w[j_i] + s_i w[j_i + 1]
        x = x_start + speed * t - offs
        j = np.floor((x - xs[0]) / h).astype(int)
        s = (x - xs[j]) / h
        w, q, qd, u, ud = y[iw], y[iq], y[iqd], y[iu], y[iud]
        pen = u[wheel_dofs] - ((1.0 - s) * w[j] + s * w[j + 1]) - profile(x)
        P = np.where(pen > 0.0, contact_stiffness * pen, 0.0)
        load = np.zeros(N)  # nodal line load of the wheel forces
        np.add.at(load, j, (1.0 - s) * P / h)
        np.add.at(load, j + 1, s * P / h)
        dy = np.empty(n_y)
        uq, uqd = Phi @ q, Phi @ qd
        if massive:
            wd = y[iwd]
            dy[iw] = wd
            dy[iwd] = (load - Kr @ w + kc * uq - cc * (wd - uqd)) / rail_mass
        else:
            wd = (load - Kr @ w + kc * uq + cc * uqd) / cc
            dy[iw] = wd
        f_found = kc * (w - uq) + cc * (wd - uqd)
        dy[iq] = qd
        dy[iqd] = PhiT @ f_found - om2 * q - c_m * qd
        dy[iu] = ud
        dy[iud] = Minv @ (gravity - C @ ud - K @ u - Ew.T @ P)
        return dy

    # Jacobian: a constant part and the contact's (sparse, rank <= 2 n_w) part
    def block(A, rows, cols):
        A = sps.coo_matrix(A)
        return sps.coo_matrix((A.data, (A.row + rows.start, A.col + cols.start)),
                              shape=(n_y, n_y))

    eye_n = sps.identity(N, format="csr")
    sPhiT = sps.csr_matrix(PhiT)
    parts = [block(np.eye(n_m), iq, iqd), block(np.eye(n_v), iu, iud),
             block(-Minv @ K, iud, iu), block(-Minv @ C, iud, iud)]
    if massive:
        parts += [block(eye_n, iw, iwd), block(-Kr / rail_mass, iwd, iw),
                  block(-cc / rail_mass * eye_n, iwd, iwd),
                  block(kc * Phi / rail_mass, iwd, iq), block(cc * Phi / rail_mass, iwd, iqd),
                  block(kc * sPhiT, iqd, iw), block(cc * sPhiT, iqd, iwd),
                  block(-PhiT @ (kc * Phi) - np.diag(om2), iqd, iq),
                  block(-PhiT @ (cc * Phi) - np.diag(c_m), iqd, iqd)]
        r_load = iwd
        s_load = 1.0 / rail_mass
    else:
        # foundation force = k w + c w' - k Phi q - c Phi q' = load - D4 w
        parts += [block(-Kr / cc, iw, iw), block(kc / cc * Phi, iw, iq), block(Phi, iw, iqd),
                  block(-(sPhiT @ D4), iqd, iw), block(-np.diag(om2), iqd, iq),
                  block(-np.diag(c_m), iqd, iqd)]
        r_load = iw
        s_load = 1.0 / cc
    J0 = sum(parts[1:], parts[0]).tocsr()
    MiEt = Minv @ Ew.T

    def jac(t, y):
        W, _, act = contact(t, y)
        ka = sps.diags(act * contact_stiffness)
        Wa = ka @ W  # -dP/dw
        Ua = ka @ sps.csr_matrix(Ew)  # dP/du
        Lw = -(W.T @ Wa) / h  # d load / dw
        Lu = (W.T @ Ua) / h  # d load / du
        extra = [block(s_load * Lw, r_load, iw), block(s_load * Lu, r_load, iu),
                 block(-MiEt @ Ua.toarray(), iud, iu), block(sps.csr_matrix(MiEt) @ Wa, iud, iw)]
        if not massive:
            extra += [block(sPhiT @ Lw, iqd, iw), block(sPhiT @ Lu, iqd, iu)]
        return (J0 + sum(extra[1:], extra[0])).tocsc()

    # static start: all wheels in contact, r = 0 under them, at rest
    W0, _ = weights(0.0)
    W0 = W0.toarray()
    n_s = N + n_m + n_v
    A = np.zeros((n_s, n_s))
    b = np.zeros(n_s)
    kcW = contact_stiffness * W0
    # rail: Kr w - k Phi q - load = 0, load = W^T P / h, P = k_c (Ew u - W w)
    A[:N, :N] = Kr.toarray() + W0.T @ kcW / h
    A[:N, N:N + n_m] = -kc * Phi
    A[:N, N + n_m:] = -W0.T @ (contact_stiffness * Ew) / h
    # deck: omega^2 q - PhiT k (w - Phi q) = 0
    A[N:N + n_m, :N] = -kc * PhiT
    A[N:N + n_m, N:N + n_m] = np.diag(om2) + kc * PhiT @ Phi
    # vehicle: K u + Ew^T P = g
    A[N + n_m:, :N] = -Ew.T @ kcW
    A[N + n_m:, N + n_m:] = K + contact_stiffness * Ew.T @ Ew
    b[N + n_m:] = gravity
    z = np.linalg.solve(A, b)
    y0 = np.zeros(n_y)
    y0[iw] = z[:N]
    y0[iq] = z[N:N + n_m]
    y0[iu] = z[N + n_m:]
    P0 = contact(0.0, y0)[1]
    t_eval = np.linspace(0.0, t_end, n_out)
    sol = scipy.integrate.solve_ivp(rhs, (0.0, t_end), y0, method="Radau", rtol=rtol,
                                    atol=1e-10, max_step=h / speed, jac=jac,
                                    t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(sol.message)
    force = np.empty((sol.t.size, n_w))
    acc = np.empty((sol.t.size, phi_p.shape[0]))
    for k, (t, y) in enumerate(zip(sol.t, sol.y.T, strict=True)):
        force[k] = contact(t, y)[1]
        acc[k] = phi_p @ rhs(t, y)[iqd]
    return DampedTrackResult(t=sol.t, force=force, deck_acceleration=acc, static_force=P0)


# ---------------------------- vehicle on a damped rail with mass: rail modes, fixed-step BDF2


@dataclass
class ModalRailResult:
    """Output of :func:`vehicle_on_modal_rail`."""

    t: np.ndarray  # s
    force: np.ndarray  # (n_t, n_w) N, wheel-rail contact forces (compression, 0 when off)
    deck_acceleration: np.ndarray  # (n_t, n_p) m/s2 at ``points``, modes summed
    static_force: np.ndarray  # (n_w,) N, contact forces of the static start
    n_rail_modes: int


def vehicle_on_modal_rail(
    length: float, EI: float, mass_per_length: float, n_modes: int, zeta: float,
    foundation: float, foundation_damping: float, rail_EI: float, rail_mass: float,
    M: np.ndarray, C: np.ndarray, K: np.ndarray, gravity: np.ndarray, wheel_dofs,
    wheel_offsets, contact_stiffness: float, profile: Callable, speed: float,
    x_start: float, t_end: float, points=(), wavelength_min: float = 0.2,
    margin: float = 15.0, dt: float = 5e-5, out_every: int = 1,
) -> ModalRailResult:
    """A vehicle on a rail (``rail_EI``, ``rail_mass`` kg/m) on a Kelvin-Voigt foundation
    (``foundation`` k N/m per m, ``foundation_damping`` c N s/m per m) that bears on a
    simply supported beam (``n_modes`` modes, damping ratio ``zeta``) where there is deck
    and on rigid ground elsewhere -- the same continuous model as
    :func:`vehicle_on_damped_track`, discretised differently: the rail over
    [x_lo, x_hi] (the wheels' path and ``margin`` m each side, simply supported ends) by
    its sine modes psi_n = sin(n pi (x - x_lo) / L_r) down to ``wavelength_min``
    (kappa_n = n pi / L_r <= 2 pi / wavelength_min), so a wheel load is an exact point
    load on the modes (no grid, no interpolation of the load):

        (L_r / 2) (m' a_n'' + c a_n' + (k + EI_r kappa_n^4) a_n)
            = sum_j B_nj (k q_j + c q_j') + sum_i psi_n(x_i) P_i,
        q_j'' + 2 zeta w_j q_j' + w_j^2 q_j = sum_n B_nj (k a_n + c a_n') - (k q_j + c q_j') / m,

    B_nj = int_0^L psi_n phi_j dx (Gauss quadrature), phi_j the mass-normalised deck modes
    (int phi_j phi_l = delta_jl / m).  With ``rail_mass`` = 0 the rail equations are
    first order.  Contact: a unilateral linear spring P_i = k_c max(0, u_i - w(x_i) -
    r(x_i)).  Time: BDF2 (L-stable, second order) at the fixed step ``dt`` on the whole
    first-order system, the constant part factored once and the active contacts added
    by the Woodbury identity each step, the active set iterated to a fixed point (the
    rail block is diagonal per mode: the linear solves go through the small
    deck-and-vehicle Schur complement).  Starts from the static equilibrium at t = -dt
    and 0 (``profile`` zero under the wheels).
    """
    wheel_dofs = np.asarray(wheel_dofs)
    offs = np.asarray(wheel_offsets, float)
    n_w, n_v, n_m = wheel_dofs.size, M.shape[0], n_modes
    x_lo = x_start - offs.max() - margin
    x_hi = x_start + speed * t_end + margin
    Lr = x_hi - x_lo
    n_r = int(np.ceil(2.0 * Lr / wavelength_min))
    kap = np.pi * np.arange(1, n_r + 1) / Lr
    k, c, mr = foundation, foundation_damping, rail_mass
    massive = mr > 0.0
    if not massive and c <= 0.0:
        raise ValueError("a massless rail needs foundation damping (first-order rail)")
    omega = ss_omega(length, EI, mass_per_length, n_m)
    # B_nj by Gauss-Legendre quadrature, 8 points on each 5 cm cell of the deck
    gp, gw = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0.0, length, int(np.ceil(length / 0.05)) + 1)
    hx = np.diff(edges)
    xq = (edges[:-1, None] + 0.5 * hx[:, None] * (gp + 1.0)).ravel()
    wq = (0.5 * hx[:, None] * gw).ravel()
    phq = ss_shapes(length, mass_per_length, n_m, xq)  # (n_q, n_m)
    B = np.zeros((n_r, n_m))
    for s0 in range(0, n_r, 200):
        sl = slice(s0, min(n_r, s0 + 200))
        B[sl] = (np.sin(np.outer(kap[sl], xq - x_lo)) * wq) @ phq
    half = 0.5 * Lr
    stiff = k + rail_EI * kap**4  # (n_r,)
    # state layout
    ia = slice(0, n_r)
    o = 2 * n_r if massive else n_r
    iad = slice(n_r, 2 * n_r) if massive else None
    iq, iqd = slice(o, o + n_m), slice(o + n_m, o + 2 * n_m)
    iu, iud = slice(o + 2 * n_m, o + 2 * n_m + n_v), slice(o + 2 * n_m + n_v,
                                                           o + 2 * n_m + 2 * n_v)
    n_y = o + 2 * n_m + 2 * n_v
    Minv = np.linalg.inv(M)
    A = np.zeros((n_y, n_y))
    b = np.zeros(n_y)
    A[iq, iqd] = np.eye(n_m)
    A[iu, iud] = np.eye(n_v)
    A[iud, iu] = -Minv @ K
    A[iud, iud] = -Minv @ C
    b[iud] = Minv @ gravity
    A[iqd, iq] = -np.diag(omega**2) - k / mass_per_length * np.eye(n_m)
    A[iqd, iqd] = -np.diag(2 * zeta * omega) - c / mass_per_length * np.eye(n_m)
    # the rows a rail load P psi enters (per unit P, times psi_n(x_i)) and the deck rows
    if massive:
        A[ia, iad] = np.eye(n_r)
        A[iad, ia] = -np.diag(stiff / mr)
        A[iad, iad] = -c / mr * np.eye(n_r)
        A[iad, iq] = k * B / (mr * half)
        A[iad, iqd] = c * B / (mr * half)
        A[iqd, ia] += k * B.T
        A[iqd, iad] += c * B.T
        rail_rows, rail_scale = iad, 1.0 / (mr * half)
        deck_load = np.zeros((n_m, n_r))  # the deck feels P only through the rail
    else:
        # c a' = -stiff a + (B (k q + c q') + psi P) / half
        A[ia, ia] = -np.diag(stiff / c)
        A[ia, iq] = k * B / (c * half)
        A[ia, iqd] = B / half
        # k a + c a' = -EI kappa^4 a + (B (k q + c q') + psi P) / half
        A[iqd, ia] += B.T * (-rail_EI * kap**4)
        A[iqd, iq] += k * (B.T @ B) / half
        A[iqd, iqd] += c * (B.T @ B) / half
        rail_rows, rail_scale = ia, 1.0 / (c * half)
        deck_load = B.T / half  # (n_m, n_r): deck rows per unit psi P
    phi_p = ss_shapes(length, mass_per_length, n_m, np.asarray(points, float))
    wheel_rows = np.arange(n_w)

    def gh(t):
        """(G (n_y, n_w): d y'/d P_i, H (n_w, n_y): d pen_i / d y, x_i)."""
        x = x_start + speed * t - offs
        psi = np.sin(np.outer(kap, x - x_lo))  # (n_r, n_w)
        G = np.zeros((n_y, n_w))
        G[rail_rows] = psi * rail_scale
        G[iqd] = deck_load @ psi
        G[iud] = -Minv[:, wheel_dofs]
        H = np.zeros((n_w, n_y))
        H[:, ia] = -psi.T
        H[wheel_rows, iu.start + wheel_dofs] = 1.0
        return G, H, x

    def static(t):
        G, H, x = gh(t)
        Af = A + contact_stiffness * G @ H
        return np.linalg.solve(Af, -b)

    y_prev, y = static(-dt), static(0.0)
    gam = 2.0 * dt / 3.0
    # I - gam A by blocks: the rail block R is diagonal per mode (a 2 x 2 block per mode
    # with mass), the rest S (deck and vehicle, small) couples to it through q, q'
    R = slice(0, o)
    Ss = slice(o, n_y)
    Ah = np.eye(n_y) - gam * A
    if massive:
        # [[1, -gam], [gam s / m', 1 + gam c / m']] per mode
        d11, d12 = np.ones(n_r), -gam * np.ones(n_r)
        d21, d22 = gam * stiff / mr, (1.0 + gam * c / mr) * np.ones(n_r)
        det = d11 * d22 - d12 * d21

        def dsolve(v):
            v1, v2 = v[:n_r], v[n_r:]
            return np.concatenate([((d22 * v1.T - d12 * v2.T) / det).T,
                                   ((d11 * v2.T - d21 * v1.T) / det).T])
    else:
        dg = 1.0 + gam * stiff / c

        def dsolve(v):
            return (v.T / dg).T
    E, F = Ah[R, Ss], Ah[Ss, R]
    DinvE = dsolve(E)
    # the Schur complement is small (2 n_m + 2 n_v): its inverse, once (a LAPACK solve
    # per step costs more than the product here)
    S_inv = np.linalg.inv(Ah[Ss, Ss] - F @ DinvE)

    def solve(v):
        yr = dsolve(v[R])
        xs = S_inv @ (v[Ss] - F @ yr)
        return np.concatenate([yr - DinvE @ xs, xs])

    n_steps = int(np.ceil(t_end / dt - 1e-9))
    n_out = n_steps // out_every + 1
    ts = np.empty(n_out)
    force = np.empty((n_out, n_w))
    acc = np.empty((n_out, phi_p.shape[0]))
    G, H, x = gh(0.0)
    P0 = contact_stiffness * np.maximum(H @ y - profile(x), 0.0)

    def record(j, t, y, G, P):
        ts[j] = t
        force[j] = P
        acc[j] = phi_p @ (A[iqd] @ y + G[iqd] @ P)

    record(0, 0.0, y, G, P0)
    act = P0 > 0.0
    for n in range(1, n_steps + 1):
        t = n * dt
        G, H, x = gh(t)
        r = profile(x)
        rhs = (4.0 * y - y_prev) / 3.0 + gam * b
        sol = solve(np.column_stack([rhs, G]))
        z, Z = sol[:, 0], sol[:, 1:]
        for _ in range(50):
            ia_ = np.flatnonzero(act)
            if ia_.size:
                # (I - gam A - gam k_c G_a H_a) y = rhs - gam k_c G_a r_a
                Ga = gam * contact_stiffness * Z[:, ia_]
                z1 = z - Ga @ r[ia_]
                S = np.eye(ia_.size) - H[ia_] @ Ga
                y_new = z1 + Ga @ np.linalg.solve(S, H[ia_] @ z1)
            else:
                y_new = z
            pen = H @ y_new - r
            new = pen > 0.0
            if np.array_equal(new, act):
                break
            act = new
        else:
            raise RuntimeError(f"contact active set did not settle at t = {t}")
        y_prev, y = y, y_new
        if n % out_every == 0:
            record(n // out_every, t, y, G, contact_stiffness * np.where(act, pen, 0.0))
    return ModalRailResult(t=ts, force=force, deck_acceleration=acc, static_force=P0,
                           n_rail_modes=n_r)


# =============================================================================
# Fatigue: rainflow counting (ASTM E1049-85, 5.4.4) and the EN 1993-1-9 S-N curve
# =============================================================================


def rainflow_astm(x) -> list[tuple[float, float]]:
    """Rainflow (range, count) pairs of a history, ASTM E1049-85 5.4.4 (three-point rule;
    a range holding the starting point counts half), written from the standard's text."""
    x = np.asarray(x, float)
    d = np.diff(x)
    d = d[d != 0]
    if d.size == 0:
        return []
    # turning points: the first value, every sign change of the slope, the last value
    pts = [x[0]]
    prev = 0.0
    for i in range(1, x.size):
        step = x[i] - x[i - 1]
        if step == 0:
            continue
        if prev != 0 and np.sign(step) != np.sign(prev):
            pts.append(x[i - 1])
        prev = step
    pts.append(x[-1])
    stack: list[float] = []
    out: list[tuple[float, float]] = []
    for p in pts:
        stack.append(p)
        while len(stack) >= 3:
            X = abs(stack[-1] - stack[-2])
            Y = abs(stack[-2] - stack[-3])
            if X < Y:
                break
            if len(stack) == 3:
                out.append((Y, 0.5))
                stack.pop(0)
            else:
                out.append((Y, 1.0))
                last = stack.pop()
                stack.pop()
                stack.pop()
                stack.append(last)
    out += [(abs(b - a), 0.5) for a, b in zip(stack[:-1], stack[1:], strict=True)]
    return out


def sn_damage(ranges, counts, category, gamma_Mf=1.0):
    """Miner's sum on the EN 1993-1-9 curve: slope 3 to 5e6 cycles, 5 to 1e8, cut off
    below (ranges already multiplied by gamma_Ff)."""
    c = category / gamma_Mf
    sd = c * (2.0 / 5.0) ** (1.0 / 3.0)
    sl = sd * (5.0 / 100.0) ** 0.2
    total = 0.0
    for s, n in zip(ranges, counts, strict=True):
        if s >= sd:
            total += n / (2e6 * (c / s) ** 3)
        elif s >= sl:
            total += n / (5e6 * (sd / s) ** 5)
    return total
