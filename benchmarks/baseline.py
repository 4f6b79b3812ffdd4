"""A plain numpy/scipy implementation of the direct method, used ONLY as a yardstick.

This is the "straightforward" way to code the method of Neves et al. (Eng. Struct. 69,
2014, Eq. 3), written independently of ``vsi_numba.kernels`` (no numba, no Schur
complement, no pre-factorisation):

* one global DOF vector ``z = [q (n_m modal coordinates), u (n_v vehicle DOFs)]``,
  positive down, with dense global matrices ``M = diag(I, M_v)``,
  ``C = diag(2 zeta omega, C_v)``, ``K = diag(omega^2, K_v)`` (vehicle blocks placed on
  the diagonal with ``scipy.linalg.block_diag``);
* HHT-alpha (beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha) written incrementally in
  ``dz = z_{n+1} - z_n``; the effective stiffness ``K^ = a0 M + (1 + alpha)(a1 C + K)``
  is formed as a dense matrix EVERY step (as a naive code would);
* wheel ``i`` at ``x_i(t)`` with constraint row ``B_i z = u_wheel - sum_j phi_j(x_i) q_j``
  and contact force ``X_i >= 0`` (compression), generalised force ``-B_i^T X_i``; the
  coupled system with the forces of the active wheels as unknowns,

      [ K^        (1+alpha) B_A^T ] [dz ]   [ R0                ]
      [ B_A            0          ] [X_A] = [ r(x_A) - B_A z_n  ]

  is solved with ``scipy.linalg.solve`` per step and per active-set iteration (a wheel
  in tension is released, a free wheel that penetrates is attached, until the set is
  stable; tolerances as in the engine: 1e-12 max(L, 1) m on gaps, 1e-9 x the largest
  gravity load on forces);
* a wheel landing (free -> active), and a wheel in contact crossing an end of the deck
  (where the rail velocity v phi'(x) q jumps to or from the rigid track's), is a plastic
  impact: a velocity-level solve with the mass matrix, then accelerations and forces
  consistent with the HHT equilibrium and the rail acceleration (docs/manual/theory.md,
  "Contact and impacts"), both as dense KKT solves;
* moving point forces enter ``R0`` through ``sum_k P_k phi(x_k(t))``.

Conventions shared with ``vsi_numba.solver.simulate`` (needed to compare histories step
by step, nothing else is shared):

* a wheel/load at ``p`` metres behind the first axle is at ``x = -approach - p + v t``;
* ``n_steps = ceil((t_exit + free_vibration) / dt - 1e-9)`` with
  ``t_exit = (L + approach + last axle position) / v``; step 0 is ``t = 0``;
* start in static equilibrium on the approach track with every wheel in contact,
  velocities and accelerations compatible with the rail, the bridge at rest (written
  here by elimination of the wheel DOFs, see ``start=`` of :func:`run_baseline` for the
  alternatives, one of which reuses the engine's ``initial_state``).

The model layer (``ModalBridge.shapes``, ``Profile.__call__``, the ``Vehicle`` matrices)
is reused as the common input.  Not implemented: the engine's step subdivision after a
non-converged active set (this code raises ``BaselineError`` instead) and the Hertzian
contact models (rigid constraint only).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from vsi_numba.model.bridge import RIGID, ModalBridge
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.settings import SolverSettings


class BaselineError(RuntimeError):
    """The baseline cannot continue (active set not converged, bad start position)."""


@dataclass
class BaselineResult:
    """Histories of one baseline run (rows: steps 0..n_steps)."""

    time: np.ndarray  # (n + 1,) s
    q: np.ndarray  # (n + 1, n_m) modal coordinates
    X: np.ndarray  # (n + 1, n_w) contact forces, N (0 when free)
    active: np.ndarray  # (n + 1, n_w) bool
    wheel_positions: np.ndarray  # (n_w,) m behind the first axle
    load_positions: np.ndarray  # (n_l,)
    loads: np.ndarray  # (n_l,) N
    n_steps: int  # steps actually integrated
    n_steps_full: int  # steps of the complete run (engine convention)
    seconds: float  # wall time of the time loop
    cpu_seconds: float  # CPU time of this process during the time loop
    solves: int  # scipy.linalg.solve calls in the loop
    landings: int  # steps with a plastic impact
    bridge: ModalBridge = field(repr=False)

    def deflection(self, x) -> np.ndarray:
        """Deck displacement (m, positive down) at abscissae ``x``: (n + 1, len(x))."""
        return self.q @ self.bridge.shapes(np.atleast_1d(np.asarray(x, float))).T

    @property
    def seconds_per_step(self) -> float:
        return self.seconds / max(self.n_steps, 1)

    @property
    def cpu_per_step(self) -> float:
        return self.cpu_seconds / max(self.n_steps, 1)


def _kkt_lstsq(A, G, top, bottom):
    n, m = A.shape[0], G.shape[0]
    kkt = np.zeros((n + m, n + m))
    kkt[:n, :n] = A
    kkt[:n, n:] = G.T
    kkt[n:, :n] = G
    sol = scipy.linalg.lstsq(kkt, np.concatenate([top, bottom]))[0]
    return sol[:n], sol[n:]


def static_start(M, C, K, g, wdof, profile, x0, v):
    """Static start with every wheel on the rail, by elimination of the wheel DOFs.

    ``u_w = r(x)``, ``K_ff u_f = g_f - K_fw u_w``; velocities with ``ud_w = v r'`` and
    ``M_ff ud_f = -M_fw ud_w``; accelerations with ``udd_w = v^2 r''`` and
    ``M_ff udd_f = (g - C ud - K u)_f - M_fw udd_w``; contact forces (compression) from
    the wheel rows ``X = (g - C ud - K u - M udd)_w``.
    """
    n = M.shape[0]
    free = np.setdiff1d(np.arange(n), wdof)
    f, w = np.ix_(free, free), np.ix_(free, wdof)
    u = np.zeros(n)
    ud = np.zeros(n)
    udd = np.zeros(n)
    u[wdof] = profile(x0)
    ud[wdof] = v * profile(x0, 1)
    udd[wdof] = v * v * profile(x0, 2)
    if free.size:
        u[free] = scipy.linalg.solve(K[f], g[free] - K[w] @ u[wdof])
        ud[free] = scipy.linalg.lstsq(M[f], -M[w] @ ud[wdof])[0]
        rhs = (g - C @ ud - K @ u)[free] - M[w] @ udd[wdof]
        udd[free] = scipy.linalg.lstsq(M[f], rhs)[0]
    X = (g - C @ ud - K @ u - M @ udd)[wdof]
    return u, ud, udd, X


def _block_diag(mats, n):
    return scipy.linalg.block_diag(*mats) if mats else np.zeros((n, n))


def assemble_train(train: Train):
    """Dense vehicle matrices of a train (dynamic vehicles in train order).

    Returns ``M, C, K, gravity, wheel_dof, wheel_pos, load_pos, loads``: the block-diagonal
    vehicle matrices, the gravity vector, the global DOF and the position behind the
    first axle (m) of every wheel, and the position and magnitude (N) of every point load.
    """
    dyn = [(veh, off) for veh, off in zip(train.vehicles, train.offsets, strict=True)
           if veh.n_dof > 0]
    starts = np.cumsum([0] + [veh.n_dof for veh, _ in dyn])
    Mv = _block_diag([veh.M for veh, _ in dyn], 0)
    Cv = _block_diag([veh.C for veh, _ in dyn], 0)
    Kv = _block_diag([veh.K for veh, _ in dyn], 0)
    grav = np.concatenate([veh.gravity for veh, _ in dyn]) if dyn else np.zeros(0)
    if dyn:
        wdof = np.concatenate([st + veh.wheel_dofs
                               for st, (veh, _) in zip(starts[:-1], dyn, strict=True)])
        wpos = np.concatenate([off + veh.wheel_positions for veh, off in dyn])
    else:
        wdof, wpos = np.zeros(0, int), np.zeros(0)
    lpos = np.concatenate([off + veh.load_positions
                           for veh, off in zip(train.vehicles, train.offsets, strict=True)])
    lp = np.concatenate([veh.loads for veh in train.vehicles])
    return Mv, Cv, Kv, grav, wdof.astype(int), wpos, lpos, lp


def n_steps_for(bridge: ModalBridge, train: Train, speed: float,
                settings: SolverSettings) -> int:
    """Steps of a whole run (the engine's convention, see the module docstring)."""
    pos = train.axle_positions
    last = pos.max() if pos.size else 0.0
    t_exit = (bridge.length + settings.approach + last) / speed
    return int(math.ceil((t_exit + settings.free_vibration) / settings.dt - 1e-9))


def run_baseline(
    bridge: ModalBridge,
    train: Train,
    speed: float,
    profile: Profile | None = None,
    settings: SolverSettings | None = None,
    n_steps: int | None = None,
    start: str = "exact",
) -> BaselineResult:
    """Integrate one passage (``speed`` in m/s) with the dense direct method.

    ``n_steps`` limits the run to its first ``n_steps`` steps (for per-step timing);
    default: the whole run, with the engine's step count.

    ``start`` selects how the static start on the approach track is computed:

    * ``"exact"`` (default): wheel DOFs prescribed on the rail, the other DOFs by
      elimination (``K_ff u_f = g_f - K_fw r``), well conditioned;
    * ``"lstsq"``: least squares on the un-equilibrated KKT system ``[K G^T; G 0]``
      (what the engine's ``initial_state`` did before commit 165eb3a).  Kept to show the
      problem: for multi-wheel vehicles its round-off leaves wheels micrometres to
      millimetres off the rail (error ~ eps cond |X|), i.e. spurious impacts at step 1;
    * ``"engine"``: the engine's own ``initial_state`` (reused, as allowed for the start).
    """
    settings = settings or SolverSettings()
    if getattr(settings, "contact_model", "rigid") != "rigid":
        raise BaselineError("the baseline implements the rigid contact constraint only "
                            f"(settings.contact_model = {settings.contact_model!r})")
    profile = profile if profile is not None else no_irregularity()
    v = float(speed)
    dt = float(settings.dt)
    alpha = float(settings.hht_alpha)
    s = 1.0 + alpha
    beta = 0.25 * (1.0 - alpha) ** 2
    gamma = 0.5 - alpha
    a0 = 1.0 / (beta * dt * dt)
    a1 = gamma / (beta * dt)
    a2 = 1.0 / (beta * dt)
    a3 = 0.5 / beta - 1.0
    cv = s * (1.0 - gamma / beta) - alpha  # weight of v_n in (1+a) C v_{n+1} - a C v_n
    ca = s * dt * (1.0 - 0.5 * gamma / beta)  # weight of a_n in the same

    # ---------------------------------------------------------------- model assembly
    n_m = bridge.n_modes
    Mv, Cv, Kv, grav, wdof, wpos, lpos, lp = assemble_train(train)
    n_v = Mv.shape[0]
    n_w = wdof.size
    N = n_m + n_v
    omega = bridge.omega
    Mg = np.zeros((N, N))
    Cg = np.zeros((N, N))
    Kg = np.zeros((N, N))
    Mg[:n_m, :n_m] = np.eye(n_m)
    Cg[:n_m, :n_m] = np.diag(2.0 * bridge.damping * omega)
    Kg[:n_m, :n_m] = np.diag(omega**2)
    Mg[n_m:, n_m:] = Mv
    Cg[n_m:, n_m:] = Cv
    Kg[n_m:, n_m:] = Kv
    fgrav = np.zeros(N)
    fgrav[n_m:] = grav
    wcol = n_m + wdof  # global column of each wheel DOF
    massive = np.any(Mg != 0.0, axis=1)
    wheel_massless = ~massive[wcol]
    mi = np.flatnonzero(massive)
    Mmm = Mg[np.ix_(mi, mi)]
    Mmm_inv = np.linalg.inv(Mmm) if mi.size else np.zeros((0, 0))

    x_front = -float(settings.approach)
    xw0 = x_front - wpos
    xl0 = x_front - lpos
    if np.any(xw0 > 0.0):
        raise BaselineError("every wheel must start on the approach track (x <= 0)")
    n_full = n_steps_for(bridge, train, v, settings)
    n_run = n_full if n_steps is None else min(int(n_steps), n_full)
    tol_gap = 1e-12 * max(bridge.length, 1.0)
    tol_force = 1e-9 * max(float(np.max(np.abs(grav), initial=0.0)), 1.0)
    max_iter = int(settings.max_iterations)

    # ------------------------------------------------ static start on the approach track
    z = np.zeros(N)
    zd = np.zeros(N)
    zdd = np.zeros(N)
    X = np.zeros(n_w)
    if n_v:
        if start == "exact":
            u, ud, udd, X = static_start(Mv, Cv, Kv, grav, wdof, profile, xw0, v)
        elif start == "lstsq":
            G = np.zeros((n_w, n_v))
            G[np.arange(n_w), wdof] = 1.0
            u, _ = _kkt_lstsq(Kv, G, grav, profile(xw0))
            ud, _ = _kkt_lstsq(Mv, G, np.zeros(n_v), v * profile(xw0, 1))
            udd, X = _kkt_lstsq(Mv, G, grav - Cv @ ud - Kv @ u, v * v * profile(xw0, 2))
        elif start == "engine":
            from vsi_numba.solver.simulate import initial_state, pack

            st0 = initial_state(pack(bridge, train, v, profile, settings), profile)
            u, ud, udd, X = st0.u.copy(), st0.ud.copy(), st0.udd.copy(), st0.X.copy()
        else:
            raise ValueError(f"start = {start!r}: expected 'exact', 'lstsq' or 'engine'")
        z[n_m:], zd[n_m:], zdd[n_m:] = u, ud, udd
    B = np.zeros((n_w, N))
    B[np.arange(n_w), wcol] = 1.0
    B[:, :n_m] = -bridge.shapes(xw0)
    F = fgrav.copy()  # total generalised force at t_n: loads + gravity - B^T X
    F[:n_m] += bridge.shapes(xl0).T @ lp
    F -= B.T @ X
    active = np.ones(n_w, dtype=bool)
    deck = bridge.kind != RIGID and n_m > 0

    def on_deck(x):
        return (x >= 0.0) & (x <= bridge.length) if deck else np.zeros(x.shape, bool)

    onb = on_deck(xw0)

    q_out = np.zeros((n_run + 1, n_m))
    X_out = np.zeros((n_run + 1, n_w))
    act_out = np.zeros((n_run + 1, n_w), dtype=bool)
    X_out[0] = X
    act_out[0] = active
    solves = 0
    landings = 0

    # ----------------------------------------------------------------------- time loop
    t_start = time.perf_counter()
    c_start = time.process_time()
    for n in range(n_run):
        t1 = (n + 1) * dt
        xw = xw0 + v * t1
        phi = bridge.shapes(xw)
        r = profile(xw)
        fext = fgrav.copy()
        if lp.size:
            fext[:n_m] += bridge.shapes(xl0 + v * t1).T @ lp
        Khat = a0 * Mg + s * (a1 * Cg + Kg)
        c_eq = float(np.mean(np.abs(np.diag(Khat)))) if N else 1.0
        R0 = (s * fext - alpha * F + Mg @ (a2 * zd + a3 * zdd)
              - Cg @ (cv * zd + ca * zdd) - Kg @ z)
        B[:, :n_m] = -phi
        was_active = active.copy()
        for _ in range(max_iter):
            A = np.flatnonzero(active)
            m = A.size
            if m == 0:
                dz = scipy.linalg.solve(Khat, R0)
                Xa = np.zeros(0)
            else:
                # constraint rows and force unknowns scaled by c (the size of K^) so
                # that the KKT matrix is equilibrated: X = c * Xs
                kkt = np.zeros((N + m, N + m))
                kkt[:N, :N] = Khat
                kkt[:N, N:] = (s * c_eq) * B[A].T
                kkt[N:, :N] = c_eq * B[A]
                sol = scipy.linalg.solve(kkt, np.concatenate([R0, c_eq * (r[A] - B[A] @ z)]))
                dz, Xa = sol[:N], c_eq * sol[N:]
            solves += 1
            X = np.zeros(n_w)
            X[A] = Xa
            if n_w == 0:
                break
            gap = r - B @ (z + dz)
            release = active & (X < -tol_force)
            attach = ~active & (gap < -tol_gap)
            if not (release.any() or attach.any()):
                break
            active = (active & ~release) | attach
        else:
            raise BaselineError(f"active set not converged in {max_iter} iterations at "
                                f"step {n + 1} (t = {t1:.6g} s)")
        np.maximum(X, 0.0, out=X)
        X_step = X.copy()

        # Newmark updates
        acc = a0 * dz - a2 * zd - a3 * zdd
        zd = zd + dt * ((1.0 - gamma) * zdd + gamma * acc)
        zdd = acc
        z = z + dz

        onb_prev, onb = onb, on_deck(xw)
        if np.any(active & (~was_active | (onb != onb_prev))):
            landings += 1
            zd, zdd, X = _plastic_impact(
                bridge, profile, v, xw, phi, B, X, z, zd, zdd, Mg, Cg, s, n_m, wcol,
                active, wheel_massless, mi, Mmm, Mmm_inv)
            solves += 2
        F = fext - B.T @ X
        q_out[n + 1] = z[:n_m]
        X_out[n + 1] = X_step
        act_out[n + 1] = active
    seconds = time.perf_counter() - t_start
    cpu_seconds = time.process_time() - c_start
    return BaselineResult(
        time=np.arange(n_run + 1) * dt, q=q_out, X=X_out, active=act_out,
        wheel_positions=wpos, load_positions=lpos, loads=lp, n_steps=n_run,
        n_steps_full=n_full, seconds=seconds, cpu_seconds=cpu_seconds, solves=solves,
        landings=landings, bridge=bridge,
    )


def _plastic_impact(bridge, profile, v, xw, phi, B, X, z, zd, zdd, Mg, Cg, s, n_m, wcol,
                    active, wheel_massless, mi, Mmm, Mmm_inv):
    """Velocity jump and consistent accelerations at a landing (dense KKT solves).

    Velocities: ``G M^-1 G^T L = rdot - G zdot``, ``zdot += M^-1 G^T L`` over the DOFs
    with mass, ``rdot_i = v (r'(x_i) + sum_j phi_j'(x_i) q_j)``; a massless wheel follows
    the rail.  Accelerations and forces: ``[M  s G^T; G  0][a; X] = [h; c]`` with
    ``h = M a_step + s B^T X_step - s C (zdot_new - zdot_step)`` (the HHT residual is
    unchanged by the impact) and ``c_i = v^2 (r'' + sum phi'' q) + 2 v sum phi' qdot``.
    """
    q = z[:n_m]
    dphi = bridge.shapes(xw, 1)
    d2phi = bridge.shapes(xw, 2)
    r1 = profile(xw, 1)
    r2 = profile(xw, 2)
    zd_step = zd.copy()
    zdd_step = zdd.copy()
    h = Mg @ zdd + s * B.T @ X
    am = np.flatnonzero(active & ~wheel_massless)
    al = np.flatnonzero(active & wheel_massless)
    zd = zd.copy()
    if am.size:
        G = B[np.ix_(am, mi)]
        rdot = v * (r1[am] + dphi[am] @ q)
        lam = scipy.linalg.solve(G @ Mmm_inv @ G.T, rdot - B[am] @ zd)
        zd[mi] += Mmm_inv @ G.T @ lam
    for i in al:
        zd[wcol[i]] = v * r1[i] + v * dphi[i] @ q + phi[i] @ zd[:n_m]
    h -= s * Cg @ (zd - zd_step)
    Xc = np.zeros(X.size)
    for i in al:  # a massless wheel transmits its residual directly
        Xc[i] = h[wcol[i]] / s
        h[:n_m] += s * phi[i] * Xc[i]
        h[wcol[i]] = 0.0
    qd = zd[:n_m]
    c = v * v * (r2 + d2phi @ q) + 2.0 * v * (dphi @ qd)
    nm, na = mi.size, am.size
    kkt = np.zeros((nm + na, nm + na))
    kkt[:nm, :nm] = Mmm
    c_eq = float(np.mean(np.abs(np.diag(Mmm)))) if nm else 1.0  # equilibration, X = c Xs
    if na:
        G = B[np.ix_(am, mi)]
        kkt[:nm, nm:] = (s * c_eq) * G.T
        kkt[nm:, :nm] = c_eq * G
    sol = scipy.linalg.solve(kkt, np.concatenate([h[mi], c_eq * c[am]]))
    zdd = np.zeros_like(zdd_step)
    zdd[mi] = sol[:nm]
    Xc[am] = c_eq * sol[nm:]
    for i in range(X.size):
        if wheel_massless[i]:
            if active[i]:
                zdd[wcol[i]] = (v * v * r2[i] + v * v * d2phi[i] @ q
                                + 2.0 * v * dphi[i] @ qd + phi[i] @ zdd[:n_m])
            else:
                zdd[wcol[i]] = zdd_step[wcol[i]]
    return zd, zdd, Xc
