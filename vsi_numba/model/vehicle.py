"""Vehicles as linear multibody subsystems, and trains as vehicles at offsets.

Conventions (see docs/manual/theory.md, "Conventions")
--------------------------------------------
* Vertical displacements are positive **down**; gravity acts in the positive direction.
* Positions along a vehicle are measured **backwards** from its leading (first) axle:
  ``p = 0`` at the first axle, ``p > 0`` behind it.  A train places each vehicle's first
  axle at ``offset`` metres behind the train's first axle.
* Pitch rotations are positive **nose down**: a point at position ``p`` on a body whose
  centre of gravity is at ``p_cg`` moves down by ``z + (p_cg - p) * theta``.
* Vehicle DOFs are measured from the configuration with unstretched springs and every
  wheel on the undeformed, level rail; the static state is found by the solver.

A vehicle is the tuple (M, C, K, wheel DOFs, wheel positions, gravity loads).  The only
exception is the moving force, which has no DOFs and is carried as a point load.
Suspensions may add nonlinear elements (:class:`BumpStop`, :class:`DamperBlowoff`) on top
of the linear spring-dashpots; the kernels solve them by Newton with the tangent
stiffness of each element's branch.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

GRAVITY = 9.81  # m s-2, as in the published train data (TTB-2D ``Calc.Cte.grav``)

# car-body length over bogie spacing when a car gives no body length (railway_car)
BODY_LENGTH_PER_BOGIE_SPACING = 1.45


class VehicleMatrixError(ValueError):
    """A vehicle matrix breaks a rule of :class:`Vehicle`; ``index`` is the entry (i, j)
    at fault (the largest asymmetry, the first non-finite entry, the most negative mass)."""

    def __init__(self, message: str, index: tuple[int, int]):
        super().__init__(message)
        self.index = index


def check_matrix(a: np.ndarray, name: str, vehicle: str = "") -> None:
    """Raise :class:`VehicleMatrixError` unless the square matrix ``a`` (M, C or K) is
    symmetric (rtol 1e-12, atol 1e-9 (max |a| + 1)) with finite entries."""
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-9 * (np.abs(a).max(initial=0.0) + 1.0)):
        i, j = np.unravel_index(np.argmax(np.abs(a - a.T)), a.shape)
        raise VehicleMatrixError(f"vehicle {vehicle!r}: {name} is not symmetric",
                                 (int(i), int(j)))
    if not np.all(np.isfinite(a)):
        i, j = np.argwhere(~np.isfinite(a))[0]
        raise VehicleMatrixError(f"vehicle {vehicle!r}: {name} has non-finite entries",
                                 (int(i), int(j)))


def check_masses(M: np.ndarray, vehicle: str = "") -> None:
    """Raise :class:`VehicleMatrixError` if the diagonal of the mass matrix has a negative
    entry (index: the most negative)."""
    diag = np.diag(M)
    if np.any(diag < 0):
        i = int(np.argmin(diag))
        raise VehicleMatrixError(f"vehicle {vehicle!r}: negative mass on the diagonal of M",
                                 (i, i))


def _positive(value, what: str, allow_zero: bool = False) -> float:
    v = float(value)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{what} = {value!r}: expected a finite number "
                         f"{'>=' if allow_zero else '>'} 0")
    return v


@dataclass(frozen=True)
class BumpStop:
    """A bump stop in parallel with a suspension spring.

    Parameters
    ----------
    gap : float
        Clearance (m, > 0) in compression measured from the static position (the
        vehicle standing on a level rail): beyond it the stop acts.
    stiffness : float
        Stiffness (N/m, > 0) the stop adds beyond the gap; the element's force is
        ``stiffness * (compression - static compression - gap)`` there, 0 before.
    """

    gap: float
    stiffness: float

    def __post_init__(self):
        object.__setattr__(self, "gap", _positive(self.gap, "bump stop gap"))
        object.__setattr__(self, "stiffness", _positive(self.stiffness,
                                                        "bump stop stiffness"))


@dataclass(frozen=True)
class DamperBlowoff:
    """A blow-off valve on a suspension damper (linear coefficient ``c``).

    Parameters
    ----------
    force : float
        Blow-off force (N, > 0): the damper force ``c * rate`` is capped at this level
        in compression and in extension (blow-off rate ``force / c``).
    post_damping : float
        Damping (N s/m, 0 <= post_damping < c) beyond the blow-off rate: the force is
        ``force + post_damping * (rate - force / c)`` there (0: saturated).
    """

    force: float
    post_damping: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "force", _positive(self.force, "blow-off force"))
        object.__setattr__(self, "post_damping", _positive(
            self.post_damping, "blow-off post_damping", allow_zero=True))


#: Kernel codes of the nonlinear elements (vsi_numba.kernels.types.NL_*).
NL_KINDS = {"bump_stop": 0, "damper_blowoff": 1}


@dataclass(frozen=True)
class NonlinearElement:
    """A nonlinear suspension element as the kernels take it.

    Parameters
    ----------
    kind : str
        ``"bump_stop"`` or ``"damper_blowoff"``.
    label : str
        Which suspension it belongs to (e.g. ``"primary wheelset1"``).
    row : ndarray, shape (n,)
        Compression of the element (m, positive when the upper body moves down
        relative to the lower) as ``row @ u`` over the vehicle's DOFs.
    params : tuple of 3 float
        Bump stop: (compression at which the stop closes, m, from unstretched springs;
        stiffness N/m; 0).  Blow-off: (linear damping c N s/m; blow-off force N;
        post-blow-off damping N s/m).
    """

    kind: str
    label: str
    row: np.ndarray
    params: tuple[float, float, float]


@dataclass(frozen=True)
class Vehicle:
    """A linear vehicle subsystem.

    Parameters
    ----------
    name : str
        Label used in outputs.
    M, C, K : ndarray, shape (n, n)
        Mass (kg, kg m^2), damping (N s/m) and stiffness (N/m) matrices, symmetric.
    wheel_dofs : ndarray of int, shape (n_w,)
        Index of each contact (wheel) DOF.  Wheel DOFs are vertical translations.
    wheel_positions : ndarray, shape (n_w,)
        Position of each wheel behind the vehicle's first axle (m), ascending.
    gravity : ndarray, shape (n,)
        Static load vector (N), positive down (the weight of each translational DOF).
    body_dof : int
        DOF whose acceleration is reported as the car-body acceleration (-1: none).
    extra_body_dofs : tuple of int
        Further car-body DOFs of a multi-body vehicle (articulated trains): each is
        reported as one more entry of the ``vehicle`` output dimension.
    load_positions, loads : ndarray
        Point loads with no dynamics (moving forces), position behind the first axle (m)
        and magnitude (N, positive down).
    dof_names : tuple of str
        One label per DOF.
    comfort_points : tuple
        Where passenger comfort is evaluated on each reported car body (``body_dofs``
        order): per body a tuple of ``(pitch_dof, d)`` pairs, the point ``d`` metres ahead
        of the body's centre of gravity with vertical acceleration
        ``u''[body] + d * u''[pitch_dof]`` (pitch positive nose down; ``pitch_dof = -1``:
        bounce only).  Empty (the default, e.g. a sprung mass or a user vehicle): the
        centre of gravity only.  :class:`MultibodyBuilder` puts them at the centre and over
        every pivot of the body's suspension (see :meth:`MultibodyBuilder.build`).
    end_points : tuple
        The car-body ends of each reported body, in the form of ``comfort_points``
        (front end first); empty (the default): no end points known, the car-end
        envelope is not evaluated (NaN).  :func:`railway_car` sets them from the body
        length.
    nonlinear : tuple of NonlinearElement
        Bump stops and damper blow-offs acting on top of M, C, K (empty: linear).
    """

    name: str
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    wheel_dofs: np.ndarray
    wheel_positions: np.ndarray
    gravity: np.ndarray
    body_dof: int = -1
    extra_body_dofs: tuple[int, ...] = ()
    load_positions: np.ndarray = field(default_factory=lambda: np.zeros(0))
    loads: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dof_names: tuple[str, ...] = ()
    status: str = ""
    comfort_points: tuple = ()
    nonlinear: tuple[NonlinearElement, ...] = ()
    end_points: tuple = ()

    def __post_init__(self):
        n = np.asarray(self.M).shape[0] if np.asarray(self.M).size else 0
        for name in ("M", "C", "K"):
            a = np.asarray(getattr(self, name), dtype=float).reshape(n, n)
            check_matrix(a, name, self.name)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "wheel_dofs", np.asarray(self.wheel_dofs, dtype=np.int64))
        object.__setattr__(
            self, "wheel_positions", np.asarray(self.wheel_positions, dtype=float)
        )
        object.__setattr__(self, "gravity", np.asarray(self.gravity, dtype=float).reshape(n))
        object.__setattr__(self, "load_positions", np.asarray(self.load_positions, float))
        object.__setattr__(self, "loads", np.asarray(self.loads, float))
        if self.wheel_dofs.shape != self.wheel_positions.shape:
            raise ValueError(f"vehicle {self.name!r}: one position per wheel DOF is needed")
        if np.any((self.wheel_dofs < 0) | (self.wheel_dofs >= n)):
            raise ValueError(f"vehicle {self.name!r}: wheel DOF index out of range")
        if len(set(self.wheel_dofs.tolist())) != self.wheel_dofs.size:
            raise ValueError(f"vehicle {self.name!r}: a DOF is used by two wheels")
        check_masses(self.M, self.name)
        if not self.dof_names:
            object.__setattr__(self, "dof_names", tuple(f"dof{i}" for i in range(n)))
        if self.comfort_points and len(self.comfort_points) != len(self.body_dofs):
            raise ValueError(f"vehicle {self.name!r}: one tuple of comfort points per car "
                             "body is needed")
        if self.end_points and len(self.end_points) != len(self.body_dofs):
            raise ValueError(f"vehicle {self.name!r}: one tuple of end points per car "
                             "body is needed")
        for pts in (*self.comfort_points, *self.end_points):
            for th, d in pts:
                if not -1 <= int(th) < n or not np.isfinite(d):
                    raise ValueError(f"vehicle {self.name!r}: bad comfort point ({th}, {d})")
        for el in self.nonlinear:
            if el.kind not in NL_KINDS or np.shape(el.row) != (n,) or len(el.params) != 3:
                raise ValueError(f"vehicle {self.name!r}: bad nonlinear element {el.label!r}")

    def body_comfort_points(self, k: int) -> tuple[tuple[int, float], ...]:
        """Comfort points ``(pitch_dof, d)`` of reported body ``k`` (default: its centre
        of gravity, ``((-1, 0.0),)``)."""
        if self.comfort_points and self.comfort_points[k]:
            return tuple((int(th), float(d)) for th, d in self.comfort_points[k])
        return ((-1, 0.0),)

    def body_end_points(self, k: int) -> tuple[tuple[int, float], ...]:
        """Car-body end points ``(pitch_dof, d)`` of reported body ``k`` (empty: none)."""
        if self.end_points and k < len(self.end_points):
            return tuple((int(th), float(d)) for th, d in self.end_points[k])
        return ()

    @property
    def body_dofs(self) -> tuple[int, ...]:
        """Every car-body DOF reported as car-body acceleration, in train order."""
        return ((self.body_dof,) if self.body_dof >= 0 else ()) + tuple(self.extra_body_dofs)

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_wheels(self) -> int:
        return self.wheel_dofs.size

    @property
    def axle_positions(self) -> np.ndarray:
        """Every axle (wheel or point load), position behind the first axle (m), sorted."""
        return np.sort(np.concatenate([self.wheel_positions, self.load_positions]))

    @property
    def total_weight(self) -> float:
        """Total static vertical load (N) the vehicle puts on the track."""
        return float(self.gravity.sum() + self.loads.sum())

    def natural_frequencies(self, fixed_wheels: bool = True) -> np.ndarray:
        """Undamped natural frequencies (Hz), wheels fixed (rigid track) or free."""
        import scipy.linalg

        keep = np.ones(self.n_dof, dtype=bool)
        if fixed_wheels:
            keep[self.wheel_dofs] = False
        m = self.M[np.ix_(keep, keep)]
        k = self.K[np.ix_(keep, keep)]
        if m.size == 0:
            return np.zeros(0)
        lam = scipy.linalg.eigh(k, m, eigvals_only=True)
        return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


# ----------------------------------------------------------------------------- builders


class MultibodyBuilder:
    """Assemble a planar multibody vehicle from rigid bodies and spring-dashpots.

    Bodies have a bounce DOF and, optionally, a pitch DOF.  A spring-dashpot joins a
    point of one body to a point of another (positions behind the first axle, m).
    Wheelsets are 1-DOF bodies marked as wheels.
    """

    def __init__(self, name: str):
        self.name = name
        self._masses: list[float] = []
        self._names: list[str] = []
        self._bodies: dict[str, tuple[int, int, float]] = {}  # name -> (z, theta|-1, p_cg)
        self._translational: list[int] = []
        self._springs: list[tuple[tuple[str, str, float], float, float]] = []
        # (upper, lower, position, damping, bump stop, blow-off, label)
        self._nonlinear: list[tuple] = []
        self._wheels: list[tuple[int, float]] = []

    def _new_dof(self, label: str, mass: float) -> int:
        self._masses.append(float(mass))
        self._names.append(label)
        return len(self._masses) - 1

    def add_body(self, name: str, mass: float, position: float, pitch_inertia=None) -> str:
        """Add a rigid body with its centre of gravity at ``position`` (m behind axle 1)."""
        if name in self._bodies:
            raise ValueError(f"body {name!r} defined twice")
        z = self._new_dof(f"{name}_bounce", mass)
        self._translational.append(z)
        th = -1
        if pitch_inertia is not None:
            th = self._new_dof(f"{name}_pitch", pitch_inertia)
        self._bodies[name] = (z, th, float(position))
        return name

    def add_wheel(self, name: str, mass: float, position: float) -> str:
        """Add a wheelset (1 DOF, in contact with the rail) at ``position``."""
        self.add_body(name, mass, position)
        self._wheels.append((self._bodies[name][0], float(position)))
        return name

    def _point(self, body: str, position: float, n: int) -> np.ndarray:
        e = np.zeros(n)
        z, th, pcg = self._bodies[body]
        e[z] = 1.0
        if th >= 0:
            e[th] = pcg - position
        elif abs(position - pcg) > 1e-9:
            raise ValueError(f"body {body!r} has no pitch DOF: attach at its centre")
        return e

    def connect(self, upper: str, lower: str, position: float, stiffness: float, damping: float,
                bump_stop: BumpStop | None = None, blowoff: DamperBlowoff | None = None,
                label: str = ""):
        """Join ``upper`` and ``lower`` by a vertical spring-dashpot at ``position``,
        optionally with a bump stop on the spring and a blow-off on the dashpot."""
        for body in (upper, lower):
            if body not in self._bodies:
                raise ValueError(f"connect: unknown body {body!r}")
        self._springs.append(((upper, lower, float(position)), float(stiffness), float(damping)))
        if blowoff is not None and not blowoff.post_damping < damping:
            raise ValueError(
                f"{label or 'suspension'}: a damper blow-off needs damping > post_damping "
                f"(damping = {damping!r} N s/m, post_damping = {blowoff.post_damping!r})")
        if bump_stop is not None or blowoff is not None:
            self._nonlinear.append((upper, lower, float(position), float(damping), bump_stop,
                                    blowoff, label or f"{upper}-{lower}"))

    def _nonlinear_elements(self, K: np.ndarray, g: np.ndarray) -> tuple:
        """The kernels' elements; bump-stop gaps count from the static compression on a
        level rigid rail (wheels held, K_ff u_f = g_f)."""
        n = K.shape[0]
        if not self._nonlinear:
            return ()
        free = np.ones(n, bool)
        free[[w[0] for w in self._wheels]] = False
        u = np.zeros(n)
        u[free] = np.linalg.solve(K[np.ix_(free, free)], g[free])
        out = []
        for upper, lower, pos, c, stop, blow, label in self._nonlinear:
            e = self._point(upper, pos, n) - self._point(lower, pos, n)
            if stop is not None:
                out.append(NonlinearElement("bump_stop", label, e,
                                            (float(e @ u) + stop.gap, stop.stiffness, 0.0)))
            if blow is not None:
                out.append(NonlinearElement("damper_blowoff", label, e,
                                            (c, blow.force, blow.post_damping)))
        return tuple(out)

    def _comfort_points(self, body: str) -> tuple[tuple[int, float], ...]:
        """Centre, then every point where a spring-dashpot attaches to ``body`` (its
        pivots), front to back, as ``(pitch_dof, metres ahead of the CG)``."""
        _, th, pcg = self._bodies[body]
        if th < 0:
            return ((-1, 0.0),)
        pivots = sorted({round(pos, 9) for (up, low, pos), _k, _c in self._springs
                         if body in (up, low)})
        return ((th, 0.0), *((th, pcg - p) for p in pivots if abs(pcg - p) > 1e-9))

    def build(self, body: str | list[str] | None = None, status: str = "") -> Vehicle:
        """The assembled vehicle; ``body`` names the car body (or bodies) to report.

        Comfort (EN 1990 A2.4.4.3: the vertical acceleration *inside* the coach) is
        evaluated at each reported body's centre of gravity and over every pivot of its
        suspension (the secondary suspension over the bogie centres of a railway car).
        The acceleration of a rigid body, bounce plus pitch, is linear in the position
        along it, so the largest over the length between the pivots is at one of them.
        The car-body ends beyond the pivots (larger still) are a separate envelope, from
        ``Vehicle.end_points`` (set by :func:`railway_car`, not here: the builder does
        not know the body's length).
        """
        n = len(self._masses)
        M = np.diag(self._masses)
        K = np.zeros((n, n))
        C = np.zeros((n, n))
        for (upper, lower, pos), k, c in self._springs:
            e = self._point(upper, pos, n) - self._point(lower, pos, n)
            K += k * np.outer(e, e)
            C += c * np.outer(e, e)
        g = np.zeros(n)
        g[self._translational] = GRAVITY * M[self._translational, self._translational]
        order = sorted(self._wheels, key=lambda w: w[1])
        bodies = [body] if isinstance(body, str) else list(body or [])
        return Vehicle(
            name=self.name,
            M=M,
            C=C,
            K=K,
            wheel_dofs=np.array([w[0] for w in order], dtype=np.int64),
            wheel_positions=np.array([w[1] for w in order]),
            gravity=g,
            body_dof=self._bodies[bodies[0]][0] if bodies else -1,
            extra_body_dofs=tuple(self._bodies[b][0] for b in bodies[1:]),
            dof_names=tuple(self._names),
            status=status,
            comfort_points=tuple(self._comfort_points(b) for b in bodies),
            nonlinear=self._nonlinear_elements(K, g),
        )


def moving_force(load: float, name: str = "force") -> Vehicle:
    """A constant vertical force ``load`` (N, positive down): no dynamics, no contact."""
    return point_loads([0.0], [float(load)], name=name)


def point_loads(positions, loads, name: str = "loads", status: str = "") -> Vehicle:
    """Several moving forces travelling together (an axle-load train, e.g. HSLM-A)."""
    positions = np.asarray(positions, float)
    loads = np.broadcast_to(np.asarray(loads, float), positions.shape).copy()
    return Vehicle(
        name=name,
        M=np.zeros((0, 0)),
        C=np.zeros((0, 0)),
        K=np.zeros((0, 0)),
        wheel_dofs=np.zeros(0, dtype=np.int64),
        wheel_positions=np.zeros(0),
        gravity=np.zeros(0),
        load_positions=positions - positions.min(),
        loads=loads,
        status=status,
    )


def sprung_mass(
    mass: float,
    stiffness: float,
    damping: float = 0.0,
    wheel_mass: float = 0.0,
    name: str = "sprung_mass",
    bump_stop: BumpStop | None = None,
    damper_blowoff: DamperBlowoff | None = None,
) -> Vehicle:
    """Sprung mass on a spring-dashpot over a wheel (quarter car).

    ``wheel_mass = 0`` gives the classical moving sprung mass whose massless contact
    point follows the rail.  DOFs: 0 = sprung mass (the "body"), 1 = wheel.
    ``bump_stop`` and ``damper_blowoff`` make the suspension nonlinear.
    """
    b = MultibodyBuilder(name)
    b.add_body("body", mass, 0.0)
    b.add_wheel("wheel", wheel_mass, 0.0)
    b.connect("body", "wheel", 0.0, stiffness, damping, bump_stop, damper_blowoff,
              "suspension")
    return b.build(body="body")


def railway_car(
    body_mass: float,
    body_pitch_inertia: float,
    bogie_mass: float,
    bogie_pitch_inertia: float,
    wheelset_mass: float,
    bogie_spacing: float,
    wheelbase: float,
    primary_stiffness: float,
    primary_damping: float,
    secondary_stiffness: float,
    secondary_damping: float,
    body_cg_to_front_bogie: float | None = None,
    name: str = "car",
    status: str = "",
    primary_bump_stop: BumpStop | None = None,
    primary_damper_blowoff: DamperBlowoff | None = None,
    secondary_bump_stop: BumpStop | None = None,
    secondary_damper_blowoff: DamperBlowoff | None = None,
    body_length: float | None = None,
    body_overhangs: tuple[float, float] | None = None,
) -> Vehicle:
    """The 10-DOF planar railway car (whole-vehicle values).

    DOFs: body bounce, body pitch, front bogie bounce, pitch, rear bogie bounce, pitch,
    four wheelset bounces.  Primary stiffness/damping per wheelset, secondary per bogie.
    ``bogie_spacing`` is the distance between bogie centres, ``wheelbase`` the axle
    distance within a bogie; the body's centre of gravity is ``body_cg_to_front_bogie``
    behind the front bogie centre (default: midway).  The optional bump stops and
    damper blow-offs apply to every primary (per wheelset) or secondary (per bogie)
    suspension.

    The car-body ends (``Vehicle.end_points``, the car-end comfort envelope) are
    ``body_overhangs = (front, rear)`` metres ahead of the front and behind the rear
    bogie centre when given (the library cars' ``front_overhang``/``rear_overhang``),
    else ``body_length / 2`` ahead of and behind the midpoint of the bogie centres (the
    bogies placed symmetrically in the body); ``body_length`` defaults to
    ``BODY_LENGTH_PER_BOGIE_SPACING`` times ``bogie_spacing`` (the ratio of an ICE3 end
    car, 25.8 m over 17.4 m, and of a UIC-Z coach, 26.4 m over 19.0 m, ~1.4-1.5).
    """
    if body_length is None:
        body_length = BODY_LENGTH_PER_BOGIE_SPACING * bogie_spacing
    if body_cg_to_front_bogie is None:
        body_cg_to_front_bogie = 0.5 * bogie_spacing
    half = 0.5 * wheelbase
    pb1 = half
    pb2 = half + bogie_spacing
    b = MultibodyBuilder(name)
    b.add_body("body", body_mass, pb1 + body_cg_to_front_bogie, body_pitch_inertia)
    for tag, pb in (("bogie1", pb1), ("bogie2", pb2)):
        b.add_body(tag, bogie_mass, pb, bogie_pitch_inertia)
    wheels = [
        ("wheelset1", "bogie1", pb1 - half),
        ("wheelset2", "bogie1", pb1 + half),
        ("wheelset3", "bogie2", pb2 - half),
        ("wheelset4", "bogie2", pb2 + half),
    ]
    for tag, _, pos in wheels:
        b.add_wheel(tag, wheelset_mass, pos)
    for tag, pb in (("bogie1", pb1), ("bogie2", pb2)):
        b.connect("body", tag, pb, secondary_stiffness, secondary_damping,
                  secondary_bump_stop, secondary_damper_blowoff, f"secondary {tag}")
    for tag, bogie, pos in wheels:
        b.connect(bogie, tag, pos, primary_stiffness, primary_damping, primary_bump_stop,
                  primary_damper_blowoff, f"primary {tag}")
    car = b.build(body="body", status=status)
    th, pcg = b._bodies["body"][1], b._bodies["body"][2]
    if body_overhangs is not None:
        front, rear = pb1 - body_overhangs[0], pb2 + body_overhangs[1]
    else:
        mid = pb1 + 0.5 * bogie_spacing
        front, rear = mid - 0.5 * body_length, mid + 0.5 * body_length
    ends = ((th, pcg - front), (th, pcg - rear))
    return dataclasses.replace(car, end_points=(ends,))


def user_vehicle(
    M, C, K, wheel_dofs, wheel_positions, gravity=None, body_dof: int = -1, name="user"
) -> Vehicle:
    """A vehicle from its own matrices.  ``gravity`` defaults to g times the diagonal of M
    on every DOF that is a wheel or has no rotational meaning (give it explicitly when
    some DOFs are rotations)."""
    M = np.atleast_2d(np.asarray(M, float))
    if gravity is None:
        gravity = GRAVITY * np.diag(M)
    return Vehicle(
        name=name,
        M=M,
        C=np.atleast_2d(np.asarray(C, float)),
        K=np.atleast_2d(np.asarray(K, float)),
        wheel_dofs=np.asarray(wheel_dofs, dtype=np.int64),
        wheel_positions=np.asarray(wheel_positions, float),
        gravity=np.asarray(gravity, float),
        body_dof=body_dof,
    )


#: Wavelengths (m) searched for the regular length of a train given by its axles: the
#: axle and bogie spacings and coach lengths of railway vehicles.
REGULAR_WAVELENGTHS = (2.0, 40.0)
#: Coherence |sum P_k exp(2 pi i x_k / lambda)| / sum P_k of the axle loads above which a
#: wavelength is a regular one (1: every axle in phase).
REGULAR_COHERENCE = 0.5
#: Length (m) of the front of a train whose axles give its regular length (a passenger
#: train is at most about 400 m long; a longer list is judged by its first 400 m, so the
#: cost stays bounded: a few thousand wavenumbers times the axles there).
REGULAR_WINDOW = 400.0
#: Most axles of that window taken.
REGULAR_MAX_AXLES = 2000


def regular_length(positions, loads, wavelengths=REGULAR_WAVELENGTHS,
                   coherence: float = REGULAR_COHERENCE) -> float:
    """The regular length D (m) of a train given by its axles: the longest wavelength
    at which the axle loads excite the deck in phase, from their spectrum.

    The load train's excitation at wavelength lambda (speed v, frequency v / lambda) is
    A(lambda) = |sum_k P_k exp(2 pi i x_k / lambda)| / sum_k P_k (1 when every axle is
    in phase).  Its peaks of A >= ``coherence`` between ``wavelengths`` are the regular
    wavelengths; D is the longest of them (the coach length, whose fractions D / i are
    the other resonance wavelengths of EN 1991-2 6.4.6.2, v_i = f D / i).  11 axles
    10 m apart give D = 10 m; coaches of 18 m with bogies of two axles 3.5 m apart,
    D = 18 m (A = cos(pi 3.5 / 18) = 0.82).

    Parameters
    ----------
    positions, loads : array_like
        Axle positions (m, any origin) and loads (N, > 0).
    wavelengths : (float, float)
        Shortest and longest wavelength (m) searched.
    coherence : float
        Lowest A of a regular wavelength.

    Returns
    -------
    float
        D (m), 0.0 when the axles have no regular wavelength (fewer than 4 axles, or no
        peak of A >= ``coherence``). A train longer than :data:`REGULAR_WINDOW` is
        judged by the axles of its first :data:`REGULAR_WINDOW` metres.
    """
    x = np.asarray(positions, float).ravel()
    p = np.abs(np.asarray(loads, float).ravel())
    ok = np.isfinite(x) & np.isfinite(p) & (p > 0)
    x, p = x[ok], p[ok]
    if x.size < 4:
        return 0.0
    x = x - x.min()
    keep = np.argsort(x, kind="stable")[:REGULAR_MAX_AXLES]
    keep = keep[x[keep] <= REGULAR_WINDOW]
    x, p = x[keep], p[keep]
    if x.size < 4:
        return 0.0
    span = max(float(x.max()), 1e-9)
    lo, hi = 1.0 / wavelengths[1], 1.0 / wavelengths[0]
    # wavenumbers 1/lambda: a step of a fraction of the peaks' width 1 / (train length)
    k = np.arange(lo, hi + 1e-12, 1.0 / (40.0 * span))
    a = np.empty(k.size)
    for s in range(0, k.size, 512):  # bounded memory for long trains
        kk = k[s:s + 512]
        a[s:s + 512] = np.abs(np.exp(2j * np.pi * np.outer(kk, x)) @ p) / p.sum()
    peak = np.zeros(k.size, bool)
    peak[1:-1] = (a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:])
    peak &= a >= coherence
    if not peak.any():
        return 0.0
    return float(round(1.0 / k[np.flatnonzero(peak)[0]], 3))


@dataclass(frozen=True)
class Train:
    """Vehicles in order, each with its first axle ``offset`` metres behind the train's.

    ``status`` carries the data status of a library train (cross-checked, transcribed,
    suspect, reconstruction, standard) so it can be shown next to every result.
    """

    name: str
    vehicles: tuple[Vehicle, ...]
    offsets: tuple[float, ...]
    status: str = ""
    regular_length: float = 0.0  # m, regular coach length D (resonance speeds), 0 if none

    def __post_init__(self):
        object.__setattr__(self, "vehicles", tuple(self.vehicles))
        object.__setattr__(self, "offsets", tuple(float(o) for o in self.offsets))
        if len(self.vehicles) != len(self.offsets):
            raise ValueError(f"train {self.name!r}: one offset per vehicle is needed")
        if not self.vehicles:
            raise ValueError(f"train {self.name!r} has no vehicles")

    @property
    def n_wheels(self) -> int:
        return sum(v.n_wheels for v in self.vehicles)

    @property
    def n_loads(self) -> int:
        return sum(v.loads.size for v in self.vehicles)

    @property
    def axle_positions(self) -> np.ndarray:
        """All axles (wheels then point loads, in vehicle order), behind the first axle."""
        w = [o + v.wheel_positions for v, o in zip(self.vehicles, self.offsets, strict=True)]
        p = [o + v.load_positions for v, o in zip(self.vehicles, self.offsets, strict=True)]
        return np.concatenate(w + p)

    @property
    def length(self) -> float:
        """First to last axle (m)."""
        a = self.axle_positions
        return float(a.max() - a.min()) if a.size else 0.0

    @property
    def total_mass(self) -> float:
        """Vehicle mass (kg) of the dynamic vehicles, or weight/g for point loads."""
        return sum(v.total_weight for v in self.vehicles) / GRAVITY
