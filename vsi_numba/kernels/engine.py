"""numba kernels of the direct method: contact search, moving-load assembly, Schur solve,
impact projection and the HHT-alpha time loop.

Every jitted function of the time-loop call graph lives in this one module: numba's
cache is keyed on the defining file only, so a callee in another module could be loaded
stale (docs/manual/developer.md, "The numba cache").

Legend (Neves et al., Eng. Struct. 69 (2014), Eqs. (3)-(12))
-------------------------------------------------------------
q, u        modal coordinates of the bridge (n_m) and vehicle DOFs (n_v), positive down
phi_j(x)    mass-normalised mode shapes along the track
r(x)        irregularity, positive = rail lower; the rail top is at sum_j phi_j q_j + r
B_i         constraint row of wheel i: B_i u = u_wheel - sum_j phi_j(x_i) q_j
gap_i       r(x_i) - B_i u  (>= 0; 0 in contact); on an elastic track phi_j are the
            track-filtered shapes (vsi_numba.model.track); the constant compliance C
            in series with the contact (the elastic rail's deflection under the
            wheels, linearised Hertz springs) adds sum_k C[i, k] X_k to the gap
X_i         contact force of wheel i (>= 0, compression), generalised force -B_i^T X_i
K^          effective stiffness a0 M + (1 + alpha)(a1 C + K): diagonal for the modes,
            a dense block per vehicle, inverted once per analysis
S           Schur complement B K^-1 B^T on the contact forces
a_e         row of nonlinear suspension element e over its vehicle's DOFs: the element's
            compression delta_e = a_e u (velocity a_e udot); its force beyond the linear
            spring-dashpot (already in K, C) is f_e(delta_e, deltadot_e), piecewise linear
            (bump stop: k_s (delta - delta_on) above delta_on; damper blow-off: the
            damper force saturated at F_b plus c2 beyond); on branch b of each element
            f_e = k_t delta + c_t deltadot + f_0 (Eq. (3) of the 2014 paper: R(u) solved by
            Newton with the tangent K_t = K + sum_e k_t a_e^T a_e, C_t likewise)

Status codes returned by the kernels (translated to messages by the solver wrapper)
0 ok, 1 contact iterations not converged, 2 singular contact (Schur) system,
3 non-finite state, 4 singular impact system.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsi_numba._jit import compile_for, njit

OK, NOT_CONVERGED, SINGULAR_SCHUR, NON_FINITE, SINGULAR_IMPACT = 0, 1, 2, 3, 4


class BridgeArrays(NamedTuple):
    """Bridge data for the kernels (see ``vsi_numba.model.bridge.ModalBridge``)."""

    kind: int  # 0 rigid, 1 sine, 2 hermite
    length: float  # m
    omega: np.ndarray  # (n_m,) rad/s
    zeta: np.ndarray  # (n_m,)
    sine_amp: np.ndarray  # (n_m,) sqrt(2/(m L))
    sine_k: np.ndarray  # (n_m,) j pi / L, 1/m
    nodes: np.ndarray  # (n_nodes,) m
    values: np.ndarray  # (n_nodes, n_m)
    slopes: np.ndarray  # (n_nodes, n_m)
    # elastic track (vsi_numba.model.track): the wheels see the track-filtered mode shapes
    # of this Hermite table over [t_nodes[0], t_nodes[-1]] (the deck and a few metres of
    # each approach) and the rail's compliance (in VehicleArrays.compliance); contact is
    # then compliant (no impacts).  track = 0: rigid track, the wheels see the shapes above.
    track: int = 0
    t_nodes: np.ndarray = np.zeros(2)
    t_values: np.ndarray = np.zeros((2, 0))
    t_slopes: np.ndarray = np.zeros((2, 0))


class VehicleArrays(NamedTuple):
    """All vehicles of a train, block-diagonal, padded to ``nb`` DOFs per block."""

    start: np.ndarray  # (n_veh + 1,) first global DOF of each vehicle
    M: np.ndarray  # (n_veh, nb, nb)
    C: np.ndarray  # (n_veh, nb, nb)
    K: np.ndarray  # (n_veh, nb, nb)
    Khat_inv: np.ndarray  # (n_levels, n_veh, nb, nb) inverse effective stiffness per dt/2^k
    M_inv: np.ndarray  # (n_veh, nb, nb) inverse mass on DOFs with mass, zero elsewhere
    gravity: np.ndarray  # (n_v,) N
    wheel_dof: np.ndarray  # (n_w,) global DOF
    wheel_veh: np.ndarray  # (n_w,) vehicle index
    wheel_x0: np.ndarray  # (n_w,) wheel abscissa at t = 0, m
    wheel_massless: np.ndarray  # (n_w,) 1 if the wheel DOF has no mass
    # constant compliance in series with the contact, m/N: the elastic rail's G(x_i - x_k)
    # (constant: the wheel spacing is) plus the linearised Hertz springs 1/k_H on the
    # diagonal (model 2); (n_w, n_w), or (0, 0) when the contact has none
    compliance: np.ndarray
    body_dof: np.ndarray  # (n_b,) global DOF of each reported car body's bounce (-1: none)
    load_x0: np.ndarray  # (n_l,) point-load abscissa at t = 0, m
    load_p: np.ndarray  # (n_l,) N
    # comfort points of the car bodies (CSR): body b has the points
    # body_pt_start[b] .. body_pt_start[b + 1] - 1, each at body_pt_d (m ahead of the centre
    # of gravity) with acceleration udd[body_dof[b]] + body_pt_d * udd[body_pt_pitch]
    # (pitch positive nose down; body_pt_pitch = -1: bounce only)
    body_pt_start: np.ndarray = np.zeros(1, np.int64)  # (n_b + 1,)
    body_pt_pitch: np.ndarray = np.zeros(0, np.int64)  # (n_pt,) global pitch DOF or -1
    body_pt_d: np.ndarray = np.zeros(0)  # (n_pt,) m ahead of the centre of gravity
    # car-body end points of body b (car-end comfort envelope), the same way:
    # body_end_start[b] .. body_end_start[b + 1] - 1 (none: the envelope stays NaN)
    body_end_start: np.ndarray = np.zeros(1, np.int64)  # (n_b + 1,)
    body_end_pitch: np.ndarray = np.zeros(0, np.int64)  # (n_end,) global pitch DOF or -1
    body_end_d: np.ndarray = np.zeros(0)  # (n_end,) m ahead of the centre of gravity
    # nonlinear suspension elements (see the legend), grouped by vehicle: vehicle b has
    # the elements nl_start[b] .. nl_start[b + 1] - 1; none: every vehicle is linear and
    # the step is the linear one, bit for bit
    nl_veh: np.ndarray = np.zeros(0, np.int64)  # (n_e,) vehicle index
    nl_start: np.ndarray = np.zeros(1, np.int64)  # (n_veh + 1,)
    nl_kind: np.ndarray = np.zeros(0, np.int64)  # (n_e,) NL_BUMP_STOP | NL_BLOWOFF
    nl_a: np.ndarray = np.zeros((0, 1))  # (n_e, nb) a_e over the vehicle's local DOFs
    # bump stop: (delta_on m, k_s N/m, 0); blow-off: (c N s/m, F_b N, c2 N s/m)
    nl_p: np.ndarray = np.zeros((0, 3))  # (n_e, 3)
    # damped (or massive) elastic track: each wheel drives an element
    # track_mt z'' + track_ct z' + track_kt z = X_i (vsi_numba.model.track,
    # ElasticTrack.wheel_element) and the rail deflects by track_kt G z instead of G X
    # (G: the rail part of ``compliance``); track_ct = track_mt = 0: no element
    # (N/m, N s/m, kg)
    track_kt: float = 0.0
    track_ct: float = 0.0
    track_mt: float = 0.0
    # (n_w,) the elements' static state z = X_static / track_kt, m (the static contact
    # forces of the start; the start's X holds the forces with the rail's accelerations)
    track_z0: np.ndarray = np.zeros(0)
    # nonzero patterns (set by :func:`with_patterns`; the step's products skip exact
    # zeros only, so its sums are the dense sums bit for bit): blk_col[m, b, p] for p in
    # blk_ptr[m, b, r] .. blk_ptr[m, b, r + 1] - 1 are the columns (ascending) row r of
    # block b sums over: the nonzeros of M (m = 0), C (1) and K (2), and for every row the
    # local DOFs that carry a wheel (3: the only nonzeros of a vector B^T X);
    # comp_col[comp_ptr[i]:comp_ptr[i + 1]] the nonzero columns of row i of
    # ``compliance`` and i itself (ascending)
    blk_ptr: np.ndarray = np.zeros((4, 0, 1), np.int64)  # (4, n_veh, nb + 1)
    blk_col: np.ndarray = np.zeros((4, 0, 1), np.int64)  # (4, n_veh, nb^2)
    comp_ptr: np.ndarray = np.zeros(1, np.int64)  # (n_w + 1,), or (1,) without compliance
    comp_col: np.ndarray = np.zeros(0, np.int64)  # (nnz,)


def with_patterns(veh: VehicleArrays) -> VehicleArrays:
    """``veh`` with the nonzero patterns of its blocks, wheel DOFs and compliance (the
    ``blk_*`` and ``comp_*`` fields), from its current arrays: call it last."""
    n_veh = veh.start.shape[0] - 1
    nb = veh.M.shape[1]
    ptr = np.zeros((4, n_veh, nb + 1), np.int64)
    col = np.zeros((4, n_veh, max(nb * nb, 1)), np.int64)
    for b in range(n_veh):
        n = int(veh.start[b + 1] - veh.start[b])
        wheels = np.zeros((n, n), bool)
        wheels[:, veh.wheel_dof[veh.wheel_veh == b] - veh.start[b]] = True
        for m, A in enumerate((veh.M, veh.C, veh.K, None)):
            nz = wheels if A is None else A[b, :n, :n] != 0.0
            ptr[m, b, 1:n + 1] = np.cumsum(nz.sum(axis=1))
            ptr[m, b, n + 1:] = ptr[m, b, n]
            cols = np.nonzero(nz)[1]  # row by row, columns ascending
            col[m, b, :cols.size] = cols
    comp_ptr = np.zeros(1, np.int64)
    comp_col = np.zeros(0, np.int64)
    if veh.compliance.shape[0] > 0:
        nz = (veh.compliance != 0.0) | np.eye(veh.compliance.shape[0], dtype=bool)
        comp_ptr = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int64)
        comp_col = np.nonzero(nz)[1].astype(np.int64)
    return veh._replace(blk_ptr=ptr, blk_col=col, comp_ptr=comp_ptr, comp_col=comp_col)


class ProfileArrays(NamedTuple):
    """Irregularity as a uniform-grid cubic spline."""

    x0: float
    dx: float
    coef: np.ndarray  # (n_int, 4) ascending powers


class Params(NamedTuple):
    dt: float
    alpha: float
    speed: float  # m/s
    n_steps: int
    max_iter: int
    tol_gap: float  # m
    tol_force: float  # N
    max_sub: int  # step halvings allowed on contact failure
    contact_model: int  # 0 rigid, 1 Hertz, 2 linearised Hertz
    hertz_g: float  # Hertz constant G, m N^-2/3: penetration = G X^(2/3)


class Work(NamedTuple):
    """Workspaces allocated once per run."""

    phi: np.ndarray  # (n_w, n_m) mode values at the wheels
    dphi: np.ndarray  # (n_w, n_m)
    d2phi: np.ndarray  # (n_w, n_m)
    onb: np.ndarray  # (n_w,) int: wheel on the bridge
    rr: np.ndarray  # (n_w, 3) r, r', r'' at the wheels
    S: np.ndarray  # (n_w, n_w)
    L: np.ndarray  # (n_w, n_w) Cholesky factor of the active block
    idx: np.ndarray  # (n_w,) active indices
    rhs: np.ndarray  # (n_w,)
    sol: np.ndarray  # (n_w,)
    gstar: np.ndarray  # (n_w,)
    X: np.ndarray  # (n_w,)
    active: np.ndarray  # (n_w,) int
    was_active: np.ndarray  # (n_w,) int
    yq: np.ndarray  # (n_m,)
    yv: np.ndarray  # (n_v,)
    rq: np.ndarray  # (n_m,)
    rv: np.ndarray  # (n_v,)
    fq: np.ndarray  # (n_m,) external modal load at t_{n+1}
    phil: np.ndarray  # (n_m,) scratch row
    hq: np.ndarray  # (n_m,)
    hv: np.ndarray  # (n_v,)
    ones: np.ndarray  # (n_m,) unit modal masses
    khat: np.ndarray  # (n_m,) modal effective stiffness
    xout: np.ndarray  # (n_w,) contact forces of the step (impact forces at landings)
    vq: np.ndarray  # (n_m,) scratch: modal velocities before an impact
    vv: np.ndarray  # (n_v,) scratch: vehicle velocities before an impact
    av: np.ndarray  # (n_v,) scratch: vehicle accelerations before an impact
    act0: np.ndarray  # (n_w,) int: contact set at t_n, kept for step retries
    J: np.ndarray  # (n_w, n_w) Newton matrix of the Hertz contact
    first: np.ndarray  # (n_w,) int: envelope of the active Schur block
    onb_prev: np.ndarray  # (n_w,) int: on-bridge flags at the start of the step
    onb0: np.ndarray  # (n_w,) int: on-bridge flags at t_n, kept for step retries
    cand: np.ndarray  # (n_w,) int: wheels of the impact / acceleration LCP
    lq: np.ndarray  # (n_w,) LCP vector q, per wheel
    lz: np.ndarray  # (n_w,) LCP unknown z (impulse, N s, or contact force, N)
    lw: np.ndarray  # (n_w,) LCP complement w (separation velocity or acceleration)
    lin: np.ndarray  # (n_w,) int: LCP set (1: z free, w = 0)
    impulse: np.ndarray  # (n_w,) compressive impact impulse of the step, N s (diagnostic)
    # track element of each wheel (VehicleArrays.track_*): z, z', z'' at t_n and the
    # step's known part r_n of the HHT residual; trk0: z, z', z'' kept for step retries
    trk: np.ndarray  # (n_w, 4)
    trk0: np.ndarray  # (n_w, 3)
    # effective-stiffness inverses of the vehicle blocks for steps that are not dt/2^k
    # (deck-end events) or whose nonlinear elements are off their linear branch
    # (:func:`prepare_khat`); empty: deck-end crossings fall back to uniform substeps
    khv: np.ndarray = np.zeros((0, 0, 0))  # (n_veh, nb, nb)
    kh_dt: np.ndarray = np.zeros(0)  # (n_veh,) step size of the stored block (0: none)
    kh_sig: np.ndarray = np.zeros(0, np.int64)  # (n_veh,) branch signature of the block
    kscr: np.ndarray = np.zeros((0, 0))  # (nb, nb) scratch of the inversion
    nlb: np.ndarray = np.zeros(0, np.int64)  # (n_e,) branch of each nonlinear element
    nbk: np.ndarray = np.zeros(0)  # (4 n_m + 4 n_v + n_w,) state at the start of a step
    imp: np.ndarray = np.zeros(0)  # (n_w,) impulses summed over the pieces of a step, N s
    # (n_w,) int: 1 while rows i of phi, dphi, d2phi may hold nonzeros (contact_search
    # zeroes a row once, when its wheel leaves the deck or the elastic track's table)
    phz: np.ndarray = np.zeros(0, np.int64)
    # (1 + 2 n_w,) int: the active wheels and on-bridge flags of wk.first
    # (:func:`contact_profile`)
    pf: np.ndarray = np.zeros(0, np.int64)


class State(NamedTuple):
    """Dynamic state (arrays updated in place)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    u: np.ndarray
    ud: np.ndarray
    udd: np.ndarray
    fq_tot: np.ndarray  # (n_m,) total modal force at t_n (loads + contact)
    fv_tot: np.ndarray  # (n_v,) total vehicle force at t_n (gravity + contact)
    X: np.ndarray  # (n_w,) contact forces at t_n (consistent with the state)


class Output(NamedTuple):
    """Raw per-step histories of the runs that keep them (one slot per such run)."""

    q: np.ndarray  # (n_slots, n_steps + 1, n_m)
    qdd: np.ndarray  # (n_slots, n_steps + 1, n_m)
    X: np.ndarray  # (n_slots, n_steps + 1, n_w)
    contact: np.ndarray  # (n_slots, n_steps + 1, n_w) int8
    body_acc: np.ndarray  # (n_slots, n_steps + 1, n_veh)
    iters: np.ndarray  # (n_slots, n_steps + 1) int16
    # pitch acceleration of each reported body (0 without a pitch DOF), rad/s2
    body_pitch: np.ndarray = np.zeros((0, 0, 0))  # (n_slots, n_steps + 1, n_veh)
    # total modal force of the step (the F of the mode-acceleration load effects), N
    # per unit mode; (0, 0, 0) when the load effects are off
    fq: np.ndarray = np.zeros((0, 0, 0))  # (n_slots, n_steps + 1, n_m)


class Reduce(NamedTuple):
    """Envelopes reduced while the time loop steps, one row per run of a batch.

    Deck quantities at ``n_p`` points: w = phi_d q (displacement), a = phi_a qdd
    (acceleration; ``phi_a`` has zero columns for the modes above the EN 1990 cut-off).
    The whole-deck acceleration is a = phi_g^T qdd[:n_ka] on a grid of ``n_g`` points
    (``phi_g`` holds the first ``n_ka`` modes, transposed, band-limited like ``phi_a``),
    reduced to one maximum per run.  Car bodies: the largest |acceleration| over the
    comfort points of each body (``VehicleArrays.body_pt_*``).
    Extremes keep the first step (and the first point) that reaches them (strict
    comparisons).
    """

    phi_d: np.ndarray  # (n_p, n_m)
    phi_a: np.ndarray  # (n_p, n_m)
    disp: np.ndarray  # (n_runs, n_p) max |w|, m
    disp_t: np.ndarray  # (n_runs, n_p) s
    acc: np.ndarray  # (n_runs, n_p) max |a|, m/s2
    acc_t: np.ndarray  # (n_runs, n_p) s
    xmin: np.ndarray  # (n_runs, n_w) N
    xmin_x: np.ndarray  # (n_runs, n_w) wheel abscissa at the minimum, m
    xmax: np.ndarray  # (n_runs, n_w) N
    body: np.ndarray  # (n_runs, n_veh) max |body acceleration|
    body_t: np.ndarray  # (n_runs, n_veh) s
    body_x: np.ndarray  # (n_runs, n_veh) comfort point of the maximum, m ahead of the CG
    body_end: np.ndarray  # (n_runs, n_veh) max |acceleration| over the body's ends (NaN)
    body_end_t: np.ndarray  # (n_runs, n_veh) s
    body_end_x: np.ndarray  # (n_runs, n_veh) end of the maximum, m ahead of the CG
    lost: np.ndarray  # (n_runs, n_w) int64: steps separated (total)
    longest: np.ndarray  # (n_runs, n_w) int64: steps of the longest single separation
    events: np.ndarray  # (n_runs, n_w) int64: separation events
    single: np.ndarray  # (n_runs, n_w) int64: separation events one step long
    run_len: np.ndarray  # (n_w,) int64 scratch: length of the current separation
    iters: np.ndarray  # (n_runs,) int64: most contact iterations in one step
    phi_g: np.ndarray  # (n_ka, n_g) band-limited mode shapes on the deck grid, transposed
    phi_gmax: np.ndarray  # (n_ka,) max_p |phi_g[j, p]| (1 + 1e-12): a step whose bound
    #                       sum_j phi_gmax_j |qdd_j| <= the envelope cannot raise it
    gacc: np.ndarray  # (n_runs,) max over the grid and time of |a|, m/s2
    gacc_t: np.ndarray  # (n_runs,) s
    gacc_i: np.ndarray  # (n_runs,) int64: grid point of the maximum
    gwork: np.ndarray  # (n_g,) scratch: accelerations on the grid
    # Load effects by the mode-acceleration method (le_static, le_finish), on n_c
    # channels: bending moment at the n_s sections (ascending x), shear force at the
    # sections, reactions and rotations at the n_sup supports.  n_c = 0: off.
    # effect = sum_k P_k G(x_k) (exact static beam) + sum_j E[j, c] (q_j - F_j / w_j^2)
    le_sup: np.ndarray = np.zeros(0)  # (n_sup,) support abscissae, m
    le_L: np.ndarray = np.zeros(0)  # (n_span,) span lengths, m
    le_Linv: np.ndarray = np.zeros(0)  # (n_span,) 1 / L, 1/m
    le_c6: np.ndarray = np.zeros(0)  # (n_span,) 1 / (6 EI L), 1/(N m3)
    le_xi: np.ndarray = np.zeros(0)  # (n_s,) section abscissa / its span length
    le_A: np.ndarray = np.zeros((0, 0))  # (n_span, n_sup) support-moment influence
    le_B: np.ndarray = np.zeros((0, 0))  # (n_span, n_sup)  xi (1 - xi) (A + B xi)
    le_X: np.ndarray = np.zeros(0)  # (n_s,) section abscissa in its span, m
    le_sec0: np.ndarray = np.zeros(1, np.int64)  # (n_span + 1,) first section of a span
    le_E: np.ndarray = np.zeros((0, 0))  # (n_m, n_c) effect of q_j = 1
    le_w2inv: np.ndarray = np.zeros(0)  # (n_m,) 1 / w_j^2
    le_order: np.ndarray = np.zeros(0, np.int64)  # (n_l,) moving loads by x0 ascending
    le_val: np.ndarray = np.zeros(0)  # (n_c,) scratch: effects of the step
    le_Ms: np.ndarray = np.zeros(0)  # (n_sup,) scratch: support moments, N m
    le_acc: np.ndarray = np.zeros((4, 0))  # (4, n_span) scratch: span reactions, slopes
    le_lx: np.ndarray = np.zeros(0)  # (n_l + n_w,) scratch: loads on the deck, m
    le_lp: np.ndarray = np.zeros(0)  # (n_l + n_w,) scratch: their forces, N (down)
    le_ls: np.ndarray = np.zeros(0, np.int64)  # (n_l + n_w,) scratch: their spans
    le_max: np.ndarray = np.zeros((0, 0))  # (n_runs, n_c) maximum over time (from -inf)
    le_max_t: np.ndarray = np.zeros((0, 0))  # (n_runs, n_c) s
    le_min: np.ndarray = np.zeros((0, 0))  # (n_runs, n_c) minimum over time (from +inf)
    le_min_t: np.ndarray = np.zeros((0, 0))  # (n_runs, n_c) s


class Initial(NamedTuple):
    """Initial states of the runs of a batch (one row per run, fields as ``State``)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    u: np.ndarray
    ud: np.ndarray
    udd: np.ndarray
    fq_tot: np.ndarray
    fv_tot: np.ndarray
    X: np.ndarray


# ------------------------------------------------------------------- evaluation kernels


@njit(inline="always")
def off_modes(br, x):
    """True where the mode shapes are zero: ``x`` off the bridge (x < 0 or x > length),
    no bridge, or no modes (:func:`eval_modes` and :func:`contact_search`)."""
    return br.kind == 0 or x < 0.0 or x > br.length or br.omega.shape[0] == 0


@njit
def eval_modes(br, x, out, dout, d2out):
    """Mode shapes and their first two x-derivatives at ``x`` (zero off the bridge).

    Returns 1 if ``x`` is on the bridge (0 <= x <= length), else 0.
    """
    n_m = br.omega.shape[0]
    if off_modes(br, x):
        for j in range(n_m):
            out[j] = 0.0
            dout[j] = 0.0
            d2out[j] = 0.0
        return 0
    if br.kind == 1:
        # sin(j k1 x), cos(j k1 x) by the angle-addition recurrence: two
        # transcendentals per call instead of two per mode (sine_k[j] = (j+1) k1)
        k1 = br.sine_k[0]
        s1 = np.sin(k1 * x)
        c1 = np.cos(k1 * x)
        s = s1
        c = c1
        for j in range(n_m):
            k = br.sine_k[j]
            a = br.sine_amp[j]
            out[j] = a * s
            dout[j] = a * k * c
            d2out[j] = -a * k * k * s
            s, c = s * c1 + c * s1, c * c1 - s * s1
        return 1
    eval_hermite(br.nodes, br.values, br.slopes, x, out, dout, d2out)
    return 1


@njit(inline="always")
def eval_hermite(nodes, values, slopes, x, out, dout, d2out):
    """Values and two x-derivatives at ``x`` of a Hermite table (values and slopes at
    ``nodes``), with the cubic Hermite shape functions of the element holding ``x``."""
    e = np.searchsorted(nodes, x, side="right") - 1
    if e < 0:
        e = 0
    if e > nodes.shape[0] - 2:
        e = nodes.shape[0] - 2
    h = nodes[e + 1] - nodes[e]
    s = (x - nodes[e]) / h
    s2 = s * s
    s3 = s2 * s
    n1 = 1.0 - 3.0 * s2 + 2.0 * s3
    n2 = h * (s - 2.0 * s2 + s3)
    n3 = 3.0 * s2 - 2.0 * s3
    n4 = h * (s3 - s2)
    d1 = (-6.0 * s + 6.0 * s2) / h
    d2 = 1.0 - 4.0 * s + 3.0 * s2
    d3 = -d1
    d4 = -2.0 * s + 3.0 * s2
    e1 = (-6.0 + 12.0 * s) / (h * h)
    e2 = (-4.0 + 6.0 * s) / h
    e3 = -e1
    e4 = (-2.0 + 6.0 * s) / h
    for j in range(values.shape[1]):
        w1 = values[e, j]
        t1 = slopes[e, j]
        w2 = values[e + 1, j]
        t2 = slopes[e + 1, j]
        out[j] = n1 * w1 + n2 * t1 + n3 * w2 + n4 * t2
        dout[j] = d1 * w1 + d2 * t1 + d3 * w2 + d4 * t2
        d2out[j] = e1 * w1 + e2 * t1 + e3 * w2 + e4 * t2


@njit
def eval_profile(pr, x, out):
    """Irregularity r, r', r'' at ``x`` into ``out[0:3]`` (zero outside the profile)."""
    n = pr.coef.shape[0]
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    if n == 0:
        return
    t = (x - pr.x0) / pr.dx
    if t < 0.0 or t > n:
        return
    k = int(np.floor(t))
    if k > n - 1:
        k = n - 1
    s = x - (pr.x0 + k * pr.dx)
    c0 = pr.coef[k, 0]
    c1 = pr.coef[k, 1]
    c2 = pr.coef[k, 2]
    c3 = pr.coef[k, 3]
    out[0] = c0 + s * (c1 + s * (c2 + s * c3))
    out[1] = c1 + s * (2.0 * c2 + 3.0 * s * c3)
    out[2] = 2.0 * c2 + 6.0 * s * c3


@njit(inline="always")
def contact_search(br, veh, pr, t, speed, wk):
    """Position every wheel at time ``t``: coupled to the deck or not, mode values (the
    track-filtered ones on an elastic track), irregularity."""
    n_w = veh.wheel_dof.shape[0]
    n_m = br.omega.shape[0]
    for i in range(n_w):
        x = veh.wheel_x0[i] + speed * t
        if br.track == 0:
            off = off_modes(br, x)
        else:
            off = n_m == 0 or x < br.t_nodes[0] or x > br.t_nodes[br.t_nodes.shape[0] - 1]
        if off:
            wk.onb[i] = 0
            if wk.phz[i] == 1:  # the rows are zero from an earlier call otherwise
                for j in range(n_m):
                    wk.phi[i, j] = 0.0
                    wk.dphi[i, j] = 0.0
                    wk.d2phi[i, j] = 0.0
                wk.phz[i] = 0
        elif br.track == 0:
            wk.onb[i] = eval_modes(br, x, wk.phi[i], wk.dphi[i], wk.d2phi[i])
            wk.phz[i] = 1
        else:
            wk.onb[i] = 1
            eval_hermite(br.t_nodes, br.t_values, br.t_slopes, x, wk.phi[i], wk.dphi[i],
                         wk.d2phi[i])
            wk.phz[i] = 1
        eval_profile(pr, x, wk.rr[i])


@njit(inline="always")
def assemble_loads(br, veh, t, speed, fq, scratch, scratch2, scratch3):
    """Modal load vector of the point loads (moving forces) at time ``t``."""
    n_m = fq.shape[0]
    for j in range(n_m):
        fq[j] = 0.0
    if br.kind == 0 or n_m == 0:
        return
    for k in range(veh.load_x0.shape[0]):
        x = veh.load_x0[k] + speed * t
        if x < 0.0 or x > br.length:
            continue  # off the bridge: no modal load
        eval_modes(br, x, scratch, scratch2, scratch3)
        p = veh.load_p[k]
        for j in range(n_m):
            fq[j] += p * scratch[j]


@njit(inline="always")
def block_matvec(veh, A, x, y, accumulate, scale):
    """y (+)= scale * blockdiag(A) x over the vehicle DOFs."""
    n_veh = veh.start.shape[0] - 1
    for b in range(n_veh):
        s = veh.start[b]
        n = veh.start[b + 1] - s
        # four rows at a time: four independent sums (each in the order of one row's),
        # so the adds overlap instead of waiting for each other (same bits as row by row)
        r = 0
        while r + 4 <= n:
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            a3 = 0.0
            for c in range(n):
                xc = x[s + c]
                a0 += A[b, r, c] * xc
                a1 += A[b, r + 1, c] * xc
                a2 += A[b, r + 2, c] * xc
                a3 += A[b, r + 3, c] * xc
            if accumulate:
                y[s + r] += scale * a0
                y[s + r + 1] += scale * a1
                y[s + r + 2] += scale * a2
                y[s + r + 3] += scale * a3
            else:
                y[s + r] = scale * a0
                y[s + r + 1] = scale * a1
                y[s + r + 2] = scale * a2
                y[s + r + 3] = scale * a3
            r += 4
        while r < n:
            acc = 0.0
            for c in range(n):
                acc += A[b, r, c] * x[s + c]
            if accumulate:
                y[s + r] += scale * acc
            else:
                y[s + r] = scale * acc
            r += 1


@njit(inline="always")
def block_matvec_nz(veh, A, m, x, y, scale):
    """y += scale * blockdiag(A) x over the columns of pattern ``m`` (``veh.blk_*``): the
    nonzeros of A = M, C or K (``m`` = 0, 1, 2; x finite), or the wheel DOFs (3; x = B^T X,
    zero elsewhere, A finite).  The sums of :func:`block_matvec` bit for bit: the skipped
    terms are zeros."""
    n_veh = veh.start.shape[0] - 1
    for b in range(n_veh):
        s = veh.start[b]
        n = veh.start[b + 1] - s
        for r in range(n):
            acc = 0.0
            for p in range(veh.blk_ptr[m, b, r], veh.blk_ptr[m, b, r + 1]):
                c = veh.blk_col[m, b, p]
                acc += A[b, r, c] * x[s + c]
            y[s + r] += scale * acc


# ------------------------------------------------------------------------ Schur solve


@njit(inline="always")
def contact_profile(veh, wk, m):
    """Envelope of the active Schur block: ``wk.first[a]`` is the first active position
    coupled to active position ``a`` (same vehicle, both wheels on the bridge, or close
    enough to share the deflection of an elastic rail).

    Wheels are numbered vehicle by vehicle along the train, so the block is a narrow
    skyline (a vehicle's wheels, plus the wheels on the bridge) and Cholesky costs
    O(m b^2) instead of O(m^3).

    The envelope depends only on the active wheels and their on-bridge flags (the
    vehicles and the rail's coupling are fixed over a run): when those are the ones of
    the previous call (``wk.pf``: m + 1, then the wheels, then their flags; 0 after
    :func:`reset_work`), ``wk.first`` is kept - most steps change neither.
    """
    n_w = veh.wheel_dof.shape[0]
    same = wk.pf[0] == m + 1
    a = 0
    while same and a < m:
        i = wk.idx[a]
        same = wk.pf[1 + a] == i and wk.pf[1 + n_w + a] == wk.onb[i]
        a += 1
    if same:
        return
    wk.pf[0] = m + 1
    for a in range(m):
        i = wk.idx[a]
        wk.pf[1 + a] = i
        wk.pf[1 + n_w + a] = wk.onb[i]
        f = a
        for b in range(a):
            k = wk.idx[b]
            if (veh.wheel_veh[k] == veh.wheel_veh[i] or (wk.onb[i] == 1 and wk.onb[k] == 1)
                    or (veh.compliance.shape[0] > 0 and veh.compliance[i, k] != 0.0)):
                f = b
                break
        wk.first[a] = f


@njit
def skyline_cholesky_solve(A, idx, m, first, Lw, b, x):
    """Solve A[idx, idx] x = b for the ``m`` indices in ``idx`` by Cholesky, within the
    envelope ``first`` (see contact_profile; ``first = 0`` is the dense factorisation).

    Cholesky keeps the envelope of a symmetric matrix, so entries left of ``first`` are
    zero in the factor too and are never touched.  ``b`` and ``x`` are indexed 0..m-1.
    Returns 0, or 1 if the block is not positive definite.
    """
    for i in range(m):
        ii = idx[i]
        fi = first[i]
        for j in range(fi, i + 1):
            jj = idx[j]
            s = A[ii, jj]
            k0 = fi if fi > first[j] else first[j]
            for k in range(k0, j):
                s -= Lw[i, k] * Lw[j, k]
            if i == j:
                if s <= 0.0:
                    return 1
                Lw[i, i] = np.sqrt(s)
            else:
                Lw[i, j] = s / Lw[j, j]
    for i in range(m):
        s = b[i]
        for k in range(first[i], i):
            s -= Lw[i, k] * x[k]
        x[i] = s / Lw[i, i]
    for i in range(m - 1, -1, -1):
        x[i] = x[i] / Lw[i, i]
        xi = x[i]
        for k in range(first[i], i):
            x[k] -= Lw[i, k] * xi
    return 0


@njit(inline="always")
def build_schur(veh, wk, khat_q, A):
    """S_ik = B_i K^-1 B_k^T for all wheel pairs (or B_i M^-1 B_k^T with ``A = M_inv``
    and unit modal masses in ``khat_q``).

    The bridge part couples every pair of wheels on the bridge through the modes; the
    vehicle part couples the wheels of one vehicle.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = khat_q.shape[0]
    for i in range(n_w):
        # row i's flags in locals: the stores to S below could alias them for the compiler
        on_i = wk.onb[i] == 1
        b = veh.wheel_veh[i]
        st = veh.start[b]
        d_i = veh.wheel_dof[i] - st
        for k in range(i + 1):
            s = 0.0
            if on_i and wk.onb[k] == 1:
                for j in range(n_m):
                    s += wk.phi[i, j] * wk.phi[k, j] / khat_q[j]
            if veh.wheel_veh[k] == b:
                s += A[b, d_i, veh.wheel_dof[k] - st]
            wk.S[i, k] = s
            wk.S[k, i] = s


@njit
def solve_active_set(veh, wk, scale, max_iter, tol_gap, tol_force):
    """Unilateral contact by the active-set method on S X = -gap* / scale.

    On entry ``wk.active`` holds the initial guess and ``wk.gstar`` the gaps of the
    predictor (all X = 0).  A wheel in tension is released, a free wheel that
    penetrates is attached, until both sets are stable (Neves et al. 2014, Sec. 3).
    Returns (status, iterations); ``wk.X`` holds the contact forces.
    """
    n_w = veh.wheel_dof.shape[0]
    for it in range(1, max_iter + 1):
        m = 0
        for i in range(n_w):
            wk.X[i] = 0.0
            if wk.active[i] == 1:
                wk.idx[m] = i
                wk.rhs[m] = -wk.gstar[i] / scale
                m += 1
        if m > 0:
            contact_profile(veh, wk, m)
            if skyline_cholesky_solve(wk.S, wk.idx, m, wk.first, wk.L, wk.rhs, wk.sol) != 0:
                return SINGULAR_SCHUR, it
            for a in range(m):
                wk.X[wk.idx[a]] = wk.sol[a]
        changed = False
        for i in range(n_w):
            if wk.active[i] == 1:
                if wk.X[i] < -tol_force:
                    wk.active[i] = 0
                    changed = True
            else:
                g = wk.gstar[i]
                for a in range(m):
                    g += scale * wk.S[i, wk.idx[a]] * wk.sol[a]
                if g < -tol_gap:
                    wk.active[i] = 1
                    changed = True
        if not changed:
            for i in range(n_w):
                if wk.X[i] < 0.0:
                    wk.X[i] = 0.0
            return OK, it
    return NOT_CONVERGED, max_iter


@njit(kernel_only=True)
def solve_hertz(veh, wk, scale, g_hertz, max_iter, tol_force):
    """Hertzian contact: X_i = (delta_i / G)^(3/2) with the penetration
    delta_i = -gap_i = -(g*_i + scale (S X)_i), X_i = 0 where the wheel is separated.

    Newton on the active wheels with the tangent compliance d(delta)/dX on the diagonal
    of S; the active set follows the sign of each wheel's gap with its own force
    removed.  ``wk.X`` holds the starting guess (the forces at t_n) and the result.
    Returns (status, iterations).
    """
    n_w = veh.wheel_dof.shape[0]
    for it in range(1, max_iter + 1):
        m = 0
        changed = False
        for i in range(n_w):
            gf = wk.gstar[i]
            for k in range(n_w):
                if k != i:
                    gf += scale * wk.S[i, k] * wk.X[k]
            if gf < 0.0:
                if wk.X[i] <= 0.0:
                    # below both the rigid and the bare-Hertz single-wheel solutions
                    x_rigid = -gf / (scale * wk.S[i, i])
                    x_hertz = (-gf / g_hertz) ** 1.5
                    wk.X[i] = 0.5 * min(x_rigid, x_hertz)
                    changed = True
                wk.idx[m] = i
                m += 1
                wk.active[i] = 1
            else:
                if wk.X[i] != 0.0:
                    changed = True
                wk.X[i] = 0.0
                wk.active[i] = 0
        if m == 0:
            return OK, it
        xmax = 0.0
        for a in range(m):
            i = wk.idx[a]
            xi = wk.X[i]
            if xi > xmax:
                xmax = xi
            r = (wk.gstar[i] + g_hertz * xi ** (2.0 / 3.0)) / scale
            for b in range(m):
                k = wk.idx[b]
                r += wk.S[i, k] * wk.X[k]
                wk.J[i, k] = wk.S[i, k]
            wk.J[i, i] += (2.0 / 3.0) * g_hertz * xi ** (-1.0 / 3.0) / scale
            wk.rhs[a] = -r
        contact_profile(veh, wk, m)
        if skyline_cholesky_solve(wk.J, wk.idx, m, wk.first, wk.L, wk.rhs, wk.sol) != 0:
            return SINGULAR_SCHUR, it
        dmax = 0.0
        for a in range(m):
            i = wk.idx[a]
            d = wk.sol[a]
            xn = wk.X[i] + d
            if xn <= 0.0:
                xn = 0.1 * wk.X[i]  # stay in the domain of X^(2/3)
            dd = abs(xn - wk.X[i])
            if dd > dmax:
                dmax = dd
            wk.X[i] = xn
        if not changed and dmax <= tol_force + 1e-12 * xmax:
            return OK, it
    return NOT_CONVERGED, max_iter


# ---------------------------------------------------------------------------- impacts

# Halvings of a step in which a wheel crosses an end of the deck (16 substeps); never more
# than ``max_subdivisions``.  Retries of a failed substep may still go finer.
CROSSING_LEVELS = 4
# Murty's least-index rule after this many block-pivoting sweeps of :func:`solve_lcp`
# (block pivoting is fast but may cycle; the least-index rule terminates for any
# P-matrix, and S = G M^-1 G^T is symmetric positive definite).
LCP_BLOCK_SWEEPS = 4
# Share of the step's contact impulse dt X_i that an impact may take back from a wheel
# in contact through the step (see :func:`impact_allowance`).
IMPULSE_ALLOWANCE = 1.0


@njit(kernel_only=True)
def solve_lcp(veh, wk, m, max_iter, tol_z, tol_w):
    """The small LCP of the wheels ``wk.cand[0:m]`` (ascending) on the matrix ``wk.S``.

    Finds z >= 0 with w = S z + q >= 0 and z_i w_i = 0 (q in ``wk.lq``, per wheel), by
    principal pivoting: solve S_AA z_A = -q_A on the set A (skyline Cholesky, see
    :func:`skyline_cholesky_solve`), move a wheel with z_i < -tol_z out of A and one with
    w_i < -tol_w into it; block sweeps first, then Murty's least-index rule (finite for
    a positive definite S).  ``wk.lin`` holds the initial set (1 = in A) and the final
    one; ``wk.lz`` receives z (0 off A), ``wk.lw`` w (0 on A).
    Returns (status, iterations): OK, SINGULAR_IMPACT or NOT_CONVERGED.
    """
    for it in range(1, max_iter + 1):
        na = 0
        for a in range(m):
            i = wk.cand[a]
            wk.lz[i] = 0.0
            if wk.lin[i] == 1:
                wk.idx[na] = i
                wk.rhs[na] = -wk.lq[i]
                na += 1
        if na > 0:
            contact_profile(veh, wk, na)
            if skyline_cholesky_solve(wk.S, wk.idx, na, wk.first, wk.L, wk.rhs,
                                      wk.sol) != 0:
                return SINGULAR_IMPACT, it
            for a in range(na):
                wk.lz[wk.idx[a]] = wk.sol[a]
        n_bad = 0
        for a in range(m):
            i = wk.cand[a]
            if wk.lin[i] == 1:
                wk.lw[i] = 0.0
                bad = wk.lz[i] < -tol_z
            else:
                w = wk.lq[i]
                for b in range(na):
                    w += wk.S[i, wk.idx[b]] * wk.sol[b]
                wk.lw[i] = w
                bad = w < -tol_w
            if bad:
                n_bad += 1
                if it <= LCP_BLOCK_SWEEPS or n_bad == 1:
                    wk.lin[i] = 1 - wk.lin[i]  # block sweep: flip all; Murty: the first
        if n_bad == 0:
            for a in range(m):
                i = wk.cand[a]
                if wk.lz[i] < 0.0:
                    wk.lz[i] = 0.0
            return OK, it
    return NOT_CONVERGED, max_iter


@njit(inline="always")
def crosses_deck_end(br, veh, t0, t1, speed):
    """True if a wheel passes an end of the deck in (t0, t1]: on the bridge (0 <= x <= L,
    as :func:`eval_modes`) at one of the two times and not at the other."""
    if br.kind == 0:
        return False
    for i in range(veh.wheel_dof.shape[0]):
        x0 = veh.wheel_x0[i] + speed * t0
        x1 = veh.wheel_x0[i] + speed * t1
        if (x0 < 0.0 <= x1) or (x0 <= br.length < x1):
            return True
    return False


@njit(inline="always")
def impact_allowance(wk, st, i, dt, alpha):
    """Tensile impulse (N s) the impact may apply to wheel ``i``: the compressive impulse
    that its contact force transmitted in the step, dt ((1 + alpha) X_{n+1} - alpha X_n),
    so that the wheel's net contact impulse over the step stays compressive (Moreau's
    impulse form of the unilateral law).  That covers a wheel that stayed on the same
    rail (an impact elsewhere must not tear it off for less than a step) and a landing
    wheel (the displacement constraint of the landing step overshoots the velocity:
    the projection takes the overshoot back).  0 for a wheel in contact that crosses a
    deck end: the rail's velocity jumps at the end of the step, after the step's force
    was spent on the other rail, and the impact may only push."""
    if wk.was_active[i] == 1 and wk.onb[i] != wk.onb_prev[i]:
        return 0.0
    p = dt * ((1.0 + alpha) * wk.xout[i] - alpha * st.X[i])
    return IMPULSE_ALLOWANCE * p if p > 0.0 else 0.0


@njit(kernel_only=True)
def project_velocities(br, veh, wk, st, speed, dt, alpha, max_iter, tol_force, tol_gap):
    """Plastic unilateral impact: make the velocities of the wheels in contact compatible
    with the rail, with compressive impulses only.

    Design note 1.4: with the pre-impact separation velocity q = rdot_rel - G udot
    (rdot_rel = v (r' + sum_j phi_j' q_j) the convective rail velocity) and the
    compressive impulses P (udot += -M^-1 G^T P), the post-impact separation velocity is
    w = q + G M^-1 G^T P.  The LCP  P_i + b_i >= 0, w_i >= 0, (P_i + b_i) w_i = 0  over
    the active massive wheels (:func:`solve_lcp`, shifted by the allowance b of
    :func:`impact_allowance`) gives P; a wheel left separating (w_i > tol) is released
    (``wk.active[i] = 0``), whatever its gap.  ``wk.impulse`` receives P (N s).
    Massless wheels take no impulse: their velocity is set to the rail's afterwards.
    Returns a status code.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = st.q.shape[0]
    tol_z = tol_force * dt
    tol_w = tol_gap / dt
    build_schur(veh, wk, wk.ones, veh.M_inv)
    m = 0
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 0:
            g = st.ud[veh.wheel_dof[i]]
            rd = speed * wk.rr[i, 1]
            for j in range(n_m):
                g -= wk.phi[i, j] * st.qd[j]
                rd += speed * wk.dphi[i, j] * st.q[j]
            wk.cand[m] = i
            wk.lq[i] = rd - g
            wk.lin[i] = 1
            m += 1
    if m > 0:
        # shift P = z - b: w = S z + (q - S b)
        for a in range(m):
            i = wk.cand[a]
            s = wk.lq[i]
            for c in range(m):
                k = wk.cand[c]
                bk = impact_allowance(wk, st, k, dt, alpha)
                if bk != 0.0:
                    s -= wk.S[i, k] * bk
            wk.lq[i] = s
        status, _ = solve_lcp(veh, wk, m, max_iter, tol_z, tol_w)
        if status != OK:
            return status
        for a in range(m):
            i = wk.cand[a]
            p = wk.lz[i] - impact_allowance(wk, st, i, dt, alpha)
            wk.impulse[i] = p
            b = veh.wheel_veh[i]
            s0 = veh.start[b]
            n = veh.start[b + 1] - s0
            c = veh.wheel_dof[i] - s0
            if p != 0.0:
                for r in range(n):
                    st.ud[s0 + r] -= veh.M_inv[b, r, c] * p
                for j in range(n_m):
                    st.qd[j] += wk.phi[i, j] * p
        for a in range(m):
            i = wk.cand[a]
            if wk.lin[i] == 0 and wk.lw[i] > tol_w:
                wk.active[i] = 0  # separating: released
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            rd = speed * wk.rr[i, 1]
            for j in range(n_m):
                rd += speed * wk.dphi[i, j] * st.q[j] + wk.phi[i, j] * st.qd[j]
            st.ud[veh.wheel_dof[i]] = rd
    return OK


@njit(kernel_only=True)
def consistent_accelerations(br, veh, wk, st, speed, scale, dt, max_iter, tol_force,
                             tol_gap):
    """Accelerations and contact forces consistent with equilibrium and the unilateral
    constraints.

    Solves M a = h - scale B^T X with, for the active wheels, the relative acceleration
    w = c - G a >= 0, X >= 0, X_i w_i = 0 (an LCP, :func:`solve_lcp`), where
    ``wk.hq``/``wk.hv`` hold h (the HHT-weighted residual without contact forces) and
    c_i = v^2 (r'' + sum phi'' q) + 2 v sum phi' qdot is the rail acceleration that is
    not carried by qddot; G a = G a0 - scale S X with a0 = M^-1 h, so
    w / scale = S X + (c - G a0) / scale.  A wheel whose force would be tensile is
    released (``wk.active[i] = 0``).  Massless active wheels carry X_i = h_i / scale,
    or are released if that is tensile.  Returns a status code.
    """
    n_w = veh.wheel_dof.shape[0]
    n_m = st.q.shape[0]
    tol_w = tol_gap / (dt * dt * scale)
    for i in range(n_w):
        wk.X[i] = 0.0
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            xi = wk.hv[veh.wheel_dof[i]] / scale
            if xi < -tol_force:
                wk.active[i] = 0  # the suspension pulls the contact point off the rail
                continue
            wk.X[i] = xi
            for j in range(n_m):
                wk.hq[j] += scale * wk.phi[i, j] * xi
            wk.hv[veh.wheel_dof[i]] = 0.0
    # unconstrained accelerations a0 = M^-1 h
    for j in range(n_m):
        st.qdd[j] = wk.hq[j]
    block_matvec(veh, veh.M_inv, wk.hv, st.udd, False, 1.0)
    build_schur(veh, wk, wk.ones, veh.M_inv)
    m = 0
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 0:
            ga = st.udd[veh.wheel_dof[i]]
            c = speed * speed * wk.rr[i, 2]
            for j in range(n_m):
                ga -= wk.phi[i, j] * st.qdd[j]
                c += (speed * speed * wk.d2phi[i, j] * st.q[j]
                      + 2.0 * speed * wk.dphi[i, j] * st.qd[j])
            wk.cand[m] = i
            wk.lq[i] = (c - ga) / scale
            wk.lin[i] = 1
            m += 1
    if m > 0:
        status, _ = solve_lcp(veh, wk, m, max_iter, tol_force, tol_w)
        if status != OK:
            return status
        for a in range(m):
            i = wk.cand[a]
            xi = wk.lz[i]
            if xi == 0.0:
                if wk.lin[i] == 0 and wk.lw[i] > tol_w:
                    wk.active[i] = 0  # accelerating away from the rail: released
                continue
            wk.X[i] = xi
            b = veh.wheel_veh[i]
            s0 = veh.start[b]
            n = veh.start[b + 1] - s0
            c0 = veh.wheel_dof[i] - s0
            for r in range(n):
                st.udd[s0 + r] -= scale * veh.M_inv[b, r, c0] * xi
            for j in range(n_m):
                st.qdd[j] += scale * wk.phi[i, j] * xi
    for i in range(n_w):
        if wk.active[i] == 1 and veh.wheel_massless[i] == 1:
            a = speed * speed * wk.rr[i, 2]
            for j in range(n_m):
                a += (speed * speed * wk.d2phi[i, j] * st.q[j]
                      + 2.0 * speed * wk.dphi[i, j] * st.qd[j] + wk.phi[i, j] * st.qdd[j])
            st.udd[veh.wheel_dof[i]] = a
    return OK


# ----------------------------------------------- variable steps and nonlinear elements

# Deck-end events closer than this share of dt to the start or the end of a step piece
# are taken at that end: a piece of ~1e-4 dt still resolves its accelerations (round-off
# of the gap constraint, ~1e-18 m, over (1e-4 dt)^2), and the event moves by <= 1e-4 dt.
CROSSING_MIN_FRACTION = 1e-4
# The kinds of piece of a step in :func:`time_loop`.
WHOLE, CROSS, TAIL, RETRY = 0, 1, 2, 3
# hht_step's level for the impact of a deck-end crossing without a step.
CROSSING_IMPACT = -2
NL_BUMP_STOP, NL_BLOWOFF = 0, 1


@njit(kernel_only=True)
def invert_small(A, n, out):
    """Inverse of ``A[:n, :n]`` into ``out[:n, :n]`` by Gauss-Jordan elimination with
    partial pivoting (``A`` is destroyed).  Returns 0, or 1 if ``A`` is singular."""
    for i in range(n):
        for j in range(n):
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        p = c
        big = abs(A[c, c])
        for r in range(c + 1, n):
            if abs(A[r, c]) > big:
                big = abs(A[r, c])
                p = r
        if not big > 0.0 or not np.isfinite(big):
            return 1
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
                out[c, j], out[p, j] = out[p, j], out[c, j]
        piv = A[c, c]
        for j in range(n):
            A[c, j] /= piv
            out[c, j] /= piv
        for r in range(n):
            if r != c:
                f = A[r, c]
                if f != 0.0:
                    for j in range(n):
                        A[r, j] -= f * A[c, j]
                        out[r, j] -= f * out[c, j]
    return 0


@njit(inline="always")
def nl_law(kind, p, branch):
    """(k_t, c_t, f_0) of a nonlinear element on ``branch``: its force beyond the linear
    spring-dashpot is k_t delta + c_t deltadot + f_0 (N; see the legend)."""
    if branch == 0:
        return 0.0, 0.0, 0.0
    if kind == NL_BUMP_STOP:  # p = (delta_on, k_s, -)
        return p[1], 0.0, -p[1] * p[0]
    # blow-off, p = (c, F_b, c2): F_b + c2 (deldot - F_b / c) beyond +F_b / c, minus c deldot
    return 0.0, p[2] - p[0], branch * (p[1] - p[2] * p[1] / p[0])


@njit(inline="always")
def nl_branch(kind, p, d, dd):
    """Branch of a nonlinear element at compression ``d`` and its rate ``dd``: bump stop
    0 open, 1 closed; blow-off 0 linear, +1 / -1 blown off in compression / extension."""
    if kind == NL_BUMP_STOP:
        return 1 if d > p[0] else 0
    f = p[0] * dd
    if f > p[1]:
        return 1
    if f < -p[1]:
        return -1
    return 0


@njit(inline="always")
def nl_strain(veh, e, x):
    """a_e x: the compression (or its rate, its acceleration) of element ``e``."""
    b = veh.nl_veh[e]
    s0 = veh.start[b]
    s = 0.0
    for c in range(veh.start[b + 1] - s0):
        s += veh.nl_a[e, c] * x[s0 + c]
    return s


@njit(inline="always")
def nl_signature(veh, wk, b):
    """Branch set of vehicle ``b`` as one integer (0: every element on its linear
    branch)."""
    sig = 0
    w = 1
    for e in range(veh.nl_start[b], veh.nl_start[b + 1]):
        k = wk.nlb[e]
        sig += (k if k >= 0 else 2) * w
        w *= 3
    return sig


@njit(kernel_only=True)
def prepare_khat(veh, wk, level, dt, alpha):
    """Fill ``wk.khv`` with the effective-stiffness inverse of every vehicle block for
    the step size ``dt`` and the elements' branches ``wk.nlb``: the packed
    ``Khat_inv[level]`` where that is the one (``level >= 0``, linear branches), else
    a0 M + (1 + alpha)(a1 (C + C_t) + K + K_t) inverted here.  A block is refactored
    only when its step size or branch set changed.  Returns 0, or 1 if one is singular.
    """
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    has_nl = veh.nl_veh.shape[0] > 0
    for b in range(veh.start.shape[0] - 1):
        sig = nl_signature(veh, wk, b) if has_nl else 0
        if wk.kh_dt[b] == dt and wk.kh_sig[b] == sig:
            continue
        n = veh.start[b + 1] - veh.start[b]
        if sig == 0 and level >= 0:
            for r in range(n):
                for c in range(n):
                    wk.khv[b, r, c] = veh.Khat_inv[level, b, r, c]
        else:
            A = wk.kscr
            for r in range(n):
                for c in range(n):
                    A[r, c] = a0 * veh.M[b, r, c] + scale * (a1 * veh.C[b, r, c]
                                                             + veh.K[b, r, c])
            if has_nl:
                for e in range(veh.nl_start[b], veh.nl_start[b + 1]):
                    kt, ct, f0 = nl_law(veh.nl_kind[e], veh.nl_p[e], wk.nlb[e])
                    w = scale * (kt + a1 * ct)
                    if w != 0.0:
                        for r in range(n):
                            for c in range(n):
                                A[r, c] += w * veh.nl_a[e, r] * veh.nl_a[e, c]
            if invert_small(A, n, wk.khv[b]) != 0:
                return 1
        wk.kh_dt[b] = dt
        wk.kh_sig[b] = sig
    return 0


@njit(kernel_only=True)
def nl_residual(veh, wk, st, dt, alpha):
    """Add the nonlinear elements to the HHT residual of the vehicles (``wk.rv``):
    -(1 + alpha) a_e (k_t delta_n + c_t a_e v* + f_0) + alpha a_e f_e(delta_n, deltadot_n)
    on the branches ``wk.nlb`` (v* = udot_{n+1} - a1 Delta u, the part of the new
    velocity known at t_n); the rest, (1 + alpha)(k_t + a1 c_t) a_e^T a_e Delta u, is in
    the block of :func:`prepare_khat`."""
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    beta = 0.25 * (1.0 - alpha) ** 2
    wv = 1.0 - gamma / beta
    wa = dt * (1.0 - 0.5 * gamma / beta)
    for e in range(veh.nl_veh.shape[0]):
        kind = veh.nl_kind[e]
        p = veh.nl_p[e]
        d = nl_strain(veh, e, st.u)
        dd = nl_strain(veh, e, st.ud)
        vs = wv * dd + wa * nl_strain(veh, e, st.udd)
        k0, c0, f00 = nl_law(kind, p, nl_branch(kind, p, d, dd))
        kt, ct, f0 = nl_law(kind, p, wk.nlb[e])
        g = alpha * (k0 * d + c0 * dd + f00) - scale * (kt * d + ct * vs + f0)
        b = veh.nl_veh[e]
        s0 = veh.start[b]
        for c in range(veh.start[b + 1] - s0):
            wk.rv[s0 + c] += veh.nl_a[e, c] * g


@njit(kernel_only=True)
def nl_update_branches(veh, wk, st, tol):
    """Newton update of the branches from the state just computed: an element whose
    assumed branch gives a force more than ``tol`` (N) off its law moves to the branch
    of its new compression and rate.  Returns True if any moved."""
    changed = False
    for e in range(veh.nl_veh.shape[0]):
        kind = veh.nl_kind[e]
        p = veh.nl_p[e]
        d = nl_strain(veh, e, st.u)
        dd = nl_strain(veh, e, st.ud)
        bn = nl_branch(kind, p, d, dd)
        if bn != wk.nlb[e]:
            kt, ct, f0 = nl_law(kind, p, wk.nlb[e])
            kn, cn, fn = nl_law(kind, p, bn)
            if abs((kt - kn) * d + (ct - cn) * dd + f0 - fn) > tol:
                wk.nlb[e] = bn
                changed = True
    return changed


@njit(kernel_only=True)
def save_state(st, buf):
    """State at the start of a step into the flat buffer ``buf``."""
    k = 0
    for a in (st.q, st.qd, st.qdd, st.fq_tot):
        for j in range(a.shape[0]):
            buf[k] = a[j]
            k += 1
    for a in (st.u, st.ud, st.udd, st.fv_tot):
        for j in range(a.shape[0]):
            buf[k] = a[j]
            k += 1
    for j in range(st.X.shape[0]):
        buf[k] = st.X[j]
        k += 1


@njit(kernel_only=True)
def restore_state(buf, st):
    """Inverse of :func:`save_state`."""
    k = 0
    for a in (st.q, st.qd, st.qdd, st.fq_tot):
        for j in range(a.shape[0]):
            a[j] = buf[k]
            k += 1
    for a in (st.u, st.ud, st.udd, st.fv_tot):
        for j in range(a.shape[0]):
            a[j] = buf[k]
            k += 1
    for j in range(st.X.shape[0]):
        st.X[j] = buf[k]
        k += 1


@njit(inline="always")
def vsi_step(br, veh, pr, prm, st, wk, t1, dt, level):
    """One step of the coupled system: :func:`hht_step` when every vehicle is linear
    (bit for bit); with nonlinear elements, Newton on their branches (Eq. (3) of the 2014
    paper with the tangent stiffness and damping of each branch): solve the step with
    the assumed branches, move the elements whose law the result violates, and solve it
    again from the saved state until no element moves (a piecewise-linear law: the
    iteration ends when the branch set is consistent; the vehicle blocks whose branch
    set changed are refactored).  Returns (status, contact iterations summed)."""
    # one call site of hht_step (this function is inlined where it is called)
    nl = veh.nl_veh.shape[0] > 0
    n_w = veh.wheel_dof.shape[0]
    track = track_element(veh)
    off = wk.nbk.shape[0] - 3 * n_w
    if nl:
        save_state(st, wk.nbk)
        # the track elements under the wheels (damped/massive track) are state too: kept
        # at the end of the buffer (its last 3 n_w entries)
        if track:
            for i in range(n_w):
                for c in range(3):
                    wk.nbk[off + 3 * i + c] = wk.trk[i, c]
    total = 0
    for _ in range(prm.max_iter if nl else 1):
        status, iters = hht_step(br, veh, pr, prm, st, wk, t1, dt, level)
        total += iters
        if status != OK or not nl:
            return status, total
        if not nl_update_branches(veh, wk, st, prm.tol_force):
            return OK, total
        restore_state(wk.nbk, st)
        if track:
            for i in range(n_w):
                for c in range(3):
                    wk.trk[i, c] = wk.nbk[off + 3 * i + c]
        for i in range(n_w):
            wk.onb[i] = wk.onb_prev[i]
    return NOT_CONVERGED, total


@njit(kernel_only=True)
def next_deck_end(br, veh, t, t1, speed):
    """Earliest time in (t, t1] at which a wheel is on the other side of an end of the
    deck than at ``t`` (the first float time whose abscissa x0 + v t the on-bridge test
    of :func:`eval_modes` puts there); > t1 if none."""
    best = t1 + 1.0
    length = br.length
    for i in range(veh.wheel_dof.shape[0]):
        x0 = veh.wheel_x0[i]
        xa = x0 + speed * t
        xb = x0 + speed * t1
        if xa < 0.0 <= xb:
            tc = (0.0 - x0) / speed
            while x0 + speed * tc < 0.0:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + speed * np.nextafter(tc, -np.inf) >= 0.0:
                tc = np.nextafter(tc, -np.inf)
        elif xa <= length < xb:
            tc = (length - x0) / speed
            while not x0 + speed * tc > length:
                tc = np.nextafter(tc, np.inf)
            while tc > t and x0 + speed * np.nextafter(tc, -np.inf) > length:
                tc = np.nextafter(tc, -np.inf)
        else:
            continue
        if tc < best:
            best = tc
    return best


@njit(inline="always")
def crossing_impact(br, veh, pr, prm, st, wk, tc):
    """The impact of wheels that crossed an end of the deck within
    ``CROSSING_MIN_FRACTION`` dt of the state's time: taken on the state as it is, at the
    crossing time ``tc`` (a piece that short is not integrated; see :func:`time_loop`).
    Adds the impulses to ``wk.imp``; returns the status."""
    n_w = veh.wheel_dof.shape[0]
    for i in range(n_w):
        wk.onb_prev[i] = wk.onb[i]
        wk.X[i] = st.X[i]
        wk.xout[i] = st.X[i]
        wk.impulse[i] = 0.0
    contact_search(br, veh, pr, tc, prm.speed, wk)
    landing = False
    for i in range(n_w):
        if wk.active[i] == 1 and wk.onb[i] != wk.onb_prev[i]:
            landing = True
    if landing:
        status = impact_update(br, veh, prm, st, wk, prm.dt)
        if status != OK:
            return status
        update_force_totals(br, veh, wk, st)
        for i in range(n_w):
            wk.imp[i] += wk.impulse[i]
    return OK


# --------------------------------------------------------------------------- time loop


@njit(inline="always")
def update_force_totals(br, veh, wk, st):
    """Total modal and vehicle forces at the new time (external loads + contact)."""
    n_m = st.q.shape[0]
    for j in range(n_m):
        st.fq_tot[j] = wk.fq[j]
    for k in range(st.u.shape[0]):
        st.fv_tot[k] = veh.gravity[k]
    for i in range(veh.wheel_dof.shape[0]):
        xi = wk.X[i]
        st.X[i] = xi
        if xi != 0.0:
            st.fv_tot[veh.wheel_dof[i]] -= xi
            if wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
                for j in range(n_m):
                    st.fq_tot[j] += wk.phi[i, j] * xi


@njit(inline="always")
def hht_coefficients(alpha, dt):
    """Newmark/HHT-alpha constants of a step ``dt``: beta = (1 - alpha)^2 / 4,
    gamma = 1/2 - alpha; a0 = 1/(beta dt^2), a1 = gamma/(beta dt), a2 = 1/(beta dt),
    a3 = 1/(2 beta) - 1; cv, ca = weights of v_n, a_n in (1+alpha) C v_{n+1} - alpha C v_n;
    scale = 1 + alpha.  Returns (a0, a1, a2, a3, cv, ca, gamma, scale)."""
    beta = 0.25 * (1.0 - alpha) ** 2
    gamma = 0.5 - alpha
    a0 = 1.0 / (beta * dt * dt)
    a1 = gamma / (beta * dt)
    a2 = 1.0 / (beta * dt)
    a3 = 0.5 / beta - 1.0
    cv = (1.0 + alpha) * (1.0 - gamma / beta) - alpha
    ca = (1.0 + alpha) * dt * (1.0 - 0.5 * gamma / beta)
    return a0, a1, a2, a3, cv, ca, gamma, 1.0 + alpha


@njit(inline="always")
def track_predict(veh, wk, st, alpha, a0, a1, a2, a3, cv, ca, scale):
    """Damped/massive track.  Each wheel drives an element m z'' + c z' + k z = X_i
    (k = 1 / G(0)); the rail deflection under wheel i is y_i = k sum_k G_ik z_k (the
    static deflection basins, each delayed by its wheel's element: the compliance
    matrix times one passive transfer function, so the coupling between wheels stays
    passive at every frequency).  By the step's HHT-alpha rule
    z_{n+1} = z_n + (r_n + (1 + alpha) X_{n+1}) / khat, khat = a0 m + (1 + alpha)
    (a1 c + k), r_n = -alpha X_n + m (a2 z'_n + a3 z''_n) - c (cv z'_n + ca z''_n) - k z_n:
    the known part goes into the predictor gaps and the rail block of S (which holds
    C / (1 + alpha)) becomes G k / khat.  ``wk.trk[:, 3]`` receives r_n."""
    k = veh.track_kt
    c = veh.track_ct
    m = veh.track_mt
    n_w = veh.wheel_dof.shape[0]
    khat = a0 * m + scale * (a1 * c + k)
    change = k / khat - 1.0 / scale
    for i in range(n_w):
        z = wk.trk[i, 0]
        zd = wk.trk[i, 1]
        zdd = wk.trk[i, 2]
        wk.trk[i, 3] = (-alpha * st.X[i] + m * (a2 * zd + a3 * zdd)
                        - c * (cv * zd + ca * zdd) - k * z)
    for i in range(n_w):
        acc = 0.0
        for p in range(veh.comp_ptr[i], veh.comp_ptr[i + 1]):  # the nonzero G_ij
            j = veh.comp_col[p]
            g = 1.0 / k if j == i else veh.compliance[i, j]  # the rail's G_ij
            if g != 0.0:
                acc += g * (wk.trk[j, 0] + wk.trk[j, 3] / khat)
                wk.S[i, j] += g * change
        wk.gstar[i] += k * acc


@njit(inline="always")
def newmark(d, v, a, a0, a2, a3, gamma, dt):
    """Newmark update of one DOF whose displacement grew by ``d`` over the step, from its
    velocity ``v`` and acceleration ``a`` at the step's start: (velocity, acceleration)
    at its end."""
    acc = a0 * d - a2 * v - a3 * a
    return v + dt * ((1.0 - gamma) * a + gamma * acc), acc


@njit(inline="always")
def track_update(veh, wk, dt, a0, a1, a2, a3, gamma, scale):
    """Newmark update of the track elements with the step's contact forces ``wk.X``."""
    khat = a0 * veh.track_mt + scale * (a1 * veh.track_ct + veh.track_kt)
    for i in range(veh.wheel_dof.shape[0]):
        dy = (wk.trk[i, 3] + scale * wk.X[i]) / khat
        wk.trk[i, 1], wk.trk[i, 2] = newmark(dy, wk.trk[i, 1], wk.trk[i, 2], a0, a2, a3,
                                             gamma, dt)
        wk.trk[i, 0] += dy


@njit(inline="always")
def track_element(veh):
    """True if the track under the wheels has damping or mass (the element is used)."""
    return veh.track_kt > 0.0 and (veh.track_ct > 0.0 or veh.track_mt > 0.0)


@njit(inline="always")
def hht_correct(veh, st, wk, khat_v, a0, a2, a3, gamma, scale, dt):
    """The corrector of :func:`hht_step` with the contact forces ``wk.X`` of the step:
    Delta u = y - (1 + alpha) K^-1 B^T X (modes and vehicle DOFs), then the Newmark
    updates of the state."""
    n_m = st.q.shape[0]
    n_v = st.u.shape[0]
    n_w = veh.wheel_dof.shape[0]
    for k in range(n_v):
        wk.rv[k] = 0.0
    for i in range(n_w):
        xi = wk.X[i]
        wk.xout[i] = xi
        wk.rv[veh.wheel_dof[i]] = xi
        if xi != 0.0 and wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
            for j in range(n_m):
                wk.yq[j] += scale * wk.phi[i, j] * xi / wk.khat[j]
    block_matvec_nz(veh, khat_v, 3, wk.rv, wk.yv, -scale)
    for j in range(n_m):
        dq = wk.yq[j]
        st.qd[j], st.qdd[j] = newmark(dq, st.qd[j], st.qdd[j], a0, a2, a3, gamma, dt)
        st.q[j] += dq
    for k in range(n_v):
        du = wk.yv[k]
        st.ud[k], st.udd[k] = newmark(du, st.ud[k], st.udd[k], a0, a2, a3, gamma, dt)
        st.u[k] += du


@njit
def hht_step(br, veh, pr, prm, st, wk, t1, dt, level):
    """Advance the state by one HHT-alpha step of size ``dt`` to time ``t1``.

    ``wk.was_active`` holds the contact set at the start of the step; on return
    ``wk.active`` holds the new one and ``wk.xout`` the step's contact forces.
    Returns (status, iterations); the state is garbage when status != 0.
    ``level`` = ``CROSSING_IMPACT``: no step, the impact of wheels that crossed an end of
    the deck at ``t1`` (:func:`crossing_impact`; ``dt`` unused).
    """
    if level != CROSSING_IMPACT:
        # the step (the crossing impact's code comes after it: numba types the step's
        # callees first, while the leaves process compiles impact_update)
        alpha = prm.alpha
        a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
        n_m = st.q.shape[0]
        n_v = st.u.shape[0]
        n_w = veh.wheel_dof.shape[0]
        speed = prm.speed
        if level < 0 or veh.nl_veh.shape[0] > 0:
            # a step that is not dt/2^level, or nonlinear elements: the blocks of this step
            # size and branch set (refactored only where they changed)
            if prepare_khat(veh, wk, level, dt, alpha) != 0:
                return SINGULAR_SCHUR, 0
            khat_v = wk.khv
        else:
            khat_v = veh.Khat_inv[level]

        for i in range(n_w):
            wk.onb_prev[i] = wk.onb[i]
        contact_search(br, veh, pr, t1, speed, wk)
        assemble_loads(br, veh, t1, speed, wk.fq, wk.phil, wk.hq, wk.rq)

        # predictor y = K^-1 R0: the increment with all contact forces at t_{n+1} zero
        for j in range(n_m):
            cq = 2.0 * br.zeta[j] * br.omega[j]
            wk.khat[j] = a0 + scale * (a1 * cq + br.omega[j] ** 2)
            r = (scale * wk.fq[j] - alpha * st.fq_tot[j] + a2 * st.qd[j] + a3 * st.qdd[j]
                 - cq * (cv * st.qd[j] + ca * st.qdd[j]) - br.omega[j] ** 2 * st.q[j])
            wk.yq[j] = r / wk.khat[j]
        for k in range(n_v):
            wk.rv[k] = scale * veh.gravity[k] - alpha * st.fv_tot[k]
            wk.hv[k] = a2 * st.ud[k] + a3 * st.udd[k]
            wk.vv[k] = cv * st.ud[k] + ca * st.udd[k]
        block_matvec_nz(veh, veh.M, 0, wk.hv, wk.rv, 1.0)
        block_matvec_nz(veh, veh.C, 1, wk.vv, wk.rv, -1.0)
        block_matvec_nz(veh, veh.K, 2, st.u, wk.rv, -1.0)
        if veh.nl_veh.shape[0] > 0:
            nl_residual(veh, wk, st, dt, alpha)
        block_matvec(veh, khat_v, wk.rv, wk.yv, False, 1.0)

        # predictor gaps, Schur matrix, active set
        for i in range(n_w):
            d = veh.wheel_dof[i]
            g = wk.rr[i, 0] - (st.u[d] + wk.yv[d])
            if wk.onb[i] == 1:  # phi is zero off the deck (contact_search)
                for j in range(n_m):
                    g += wk.phi[i, j] * (st.q[j] + wk.yq[j])
            wk.gstar[i] = g
            wk.active[i] = wk.was_active[i]
        build_schur(veh, wk, wk.khat, khat_v)
        if veh.compliance.shape[0] > 0:
            # compliance in series with the contact: gap = g* + (1 + alpha) S X + C X
            inv = 1.0 / scale
            for i in range(n_w):
                for p in range(veh.comp_ptr[i], veh.comp_ptr[i + 1]):
                    k = veh.comp_col[p]
                    wk.S[i, k] += veh.compliance[i, k] * inv
        if track_element(veh):
            track_predict(veh, wk, st, alpha, a0, a1, a2, a3, cv, ca, scale)
        if prm.contact_model == 1:
            for i in range(n_w):
                wk.X[i] = st.X[i]
            status, iters = solve_hertz(veh, wk, scale, prm.hertz_g, prm.max_iter, prm.tol_force)
        else:
            status, iters = solve_active_set(veh, wk, scale, prm.max_iter, prm.tol_gap,
                                             prm.tol_force)
        if status != OK:
            return status, iters

        hht_correct(veh, st, wk, khat_v, a0, a2, a3, gamma, scale, dt)
        if track_element(veh):
            track_update(veh, wk, dt, a0, a1, a2, a3, gamma, scale)

        # Velocity jumps of the rail under a wheel in contact are impacts: a landing, and
        # a wheel crossing an end of the deck, where the rail velocity v phi'(x) q jumps
        # to or from the rigid track's (the slope of the deflected deck at its ends).
        landing = False
        if prm.contact_model == 0 and br.track == 0:  # compliant contact: no impulse
            for i in range(n_w):
                wk.impulse[i] = 0.0
                if wk.active[i] == 1 and (wk.was_active[i] == 0 or wk.onb[i] != wk.onb_prev[i]):
                    landing = True
        if landing:
            s = impact_update(br, veh, prm, st, wk, dt)
            if s != OK:
                return s, iters
        update_force_totals(br, veh, wk, st)
        return OK, iters
    # no step: the impact of wheels that crossed an end of the deck at t1
    return crossing_impact(br, veh, pr, prm, st, wk, t1), 0


@njit(kernel_only=True)
def impact_update(br, veh, prm, st, wk, dt):
    """The plastic unilateral impact of the wheels that land or cross a deck end in a
    step of size ``dt`` just completed (``st`` at its end, ``wk.X`` its contact forces,
    ``wk.onb_prev``/``wk.was_active`` the flags at its start).  Returns a status code."""
    alpha = prm.alpha
    scale = 1.0 + alpha
    speed = prm.speed
    n_m = st.q.shape[0]
    n_v = st.u.shape[0]
    n_w = veh.wheel_dof.shape[0]
    # A landing is a plastic, unilateral impact (docs/manual/theory.md, "Contact and
    # impacts"): make the velocities compatible with the rail with compressive
    # impulses only (an LCP: a wheel whose rail moves away is released, whatever its
    # gap), then the
    # accelerations consistent with the HHT equilibrium  M a1 + (1+alpha) B^T X1 = h
    # and X1 >= 0 (a wheel whose force would be tensile is released too).  h of
    # the completed step is h_step = M a1 + (1+alpha) B^T X_step; the velocity jump
    # dv changes it by -(1+alpha) C dv.
    for j in range(n_m):
        wk.vq[j] = st.qd[j]
        wk.hq[j] = st.qdd[j]
    for k in range(n_v):
        wk.vv[k] = st.ud[k]
        wk.av[k] = st.udd[k]
    block_matvec(veh, veh.M, st.udd, wk.hv, False, 1.0)
    for i in range(n_w):
        xi = wk.X[i]
        wk.hv[veh.wheel_dof[i]] += scale * xi
        for j in range(n_m):
            wk.hq[j] -= scale * wk.phi[i, j] * xi
    s = project_velocities(br, veh, wk, st, speed, dt, alpha, prm.max_iter,
                           prm.tol_force, prm.tol_gap)
    if s != OK:
        return s
    for j in range(n_m):
        cq = 2.0 * br.zeta[j] * br.omega[j]
        wk.hq[j] -= scale * cq * (st.qd[j] - wk.vq[j])
    for k in range(n_v):
        wk.vv[k] = st.ud[k] - wk.vv[k]
    block_matvec(veh, veh.C, wk.vv, wk.hv, True, -scale)
    s = consistent_accelerations(br, veh, wk, st, speed, scale, dt, prm.max_iter,
                                 prm.tol_force, prm.tol_gap)
    if s != OK:
        return s
    for i in range(n_w):
        if wk.active[i] == 0:
            wk.xout[i] = 0.0  # released in the impact: separated at t_{n+1}
            if veh.wheel_massless[i] == 1:
                d = veh.wheel_dof[i]
                st.udd[d] = wk.av[d]
    return OK


@njit(inline="always")
def copy_into(src, dst):
    """``dst[:] = src`` for two distinct 1-D arrays of one length, as a plain loop (a slice
    assignment may allocate a temporary, and the kernels run without NRT)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(inline="always")
def copy_state(src, dst):
    copy_into(src.q, dst.q)
    copy_into(src.qd, dst.qd)
    copy_into(src.qdd, dst.qdd)
    copy_into(src.u, dst.u)
    copy_into(src.ud, dst.ud)
    copy_into(src.udd, dst.udd)
    copy_into(src.fq_tot, dst.fq_tot)
    copy_into(src.fv_tot, dst.fv_tot)
    copy_into(src.X, dst.X)


@njit(inline="always")
def state_is_finite(st):
    s = 0.0
    for j in range(st.q.shape[0]):
        s += st.q[j] + st.qd[j] + st.qdd[j]
    for k in range(st.u.shape[0]):
        s += st.u[k] + st.ud[k] + st.udd[k]
    return np.isfinite(s)


@njit(kernel_only=True)
def record(veh, st, wk, red, r, n, t, speed, out, h, iters):
    """Fold step ``n`` (time ``t``) into the envelopes of run ``r`` and, when ``h >= 0``,
    store it in history slot ``h``.

    A kernel of its own, not inlined: :func:`time_loop` calls it once per step (the call
    is nothing next to the step), and a second process compiles it while the first
    compiles :func:`time_loop` (:func:`compile_leaves`)."""
    n_m = st.q.shape[0]
    for p in range(red.phi_d.shape[0]):
        w = 0.0
        a = 0.0
        for j in range(n_m):
            w += red.phi_d[p, j] * st.q[j]
            a += red.phi_a[p, j] * st.qdd[j]
        w = abs(w)
        a = abs(a)
        if n == 0 or w > red.disp[r, p]:
            red.disp[r, p] = w
            red.disp_t[r, p] = t
        if n == 0 or a > red.acc[r, p]:
            red.acc[r, p] = a
            red.acc_t[r, p] = t
    for i in range(veh.wheel_dof.shape[0]):
        x = wk.xout[i]
        if n == 0 or x < red.xmin[r, i]:
            red.xmin[r, i] = x
            red.xmin_x[r, i] = veh.wheel_x0[i] + speed * t
        if n == 0 or x > red.xmax[r, i]:
            red.xmax[r, i] = x
        if wk.active[i] == 0:
            red.lost[r, i] += 1
            red.run_len[i] += 1
            if red.run_len[i] > red.longest[r, i]:
                red.longest[r, i] = red.run_len[i]
        elif red.run_len[i] > 0:
            close_separation(red, r, i)
    n_g = red.gwork.shape[0]
    bound = 0.0
    for j in range(red.phi_g.shape[0]):
        bound += red.phi_gmax[j] * abs(st.qdd[j])
    if n_g > 0 and (n == 0 or bound > red.gacc[r]):
        g = red.gwork
        for p in range(n_g):
            g[p] = 0.0
        for j in range(red.phi_g.shape[0]):
            aj = st.qdd[j]
            for p in range(n_g):
                g[p] += red.phi_g[j, p] * aj
        for p in range(n_g):
            a = abs(g[p])
            if (n == 0 and p == 0) or a > red.gacc[r]:
                red.gacc[r] = a
                red.gacc_t[r] = t
                red.gacc_i[r] = p
    for b in range(veh.body_dof.shape[0]):
        d = veh.body_dof[b]
        a0 = st.udd[d] if d >= 0 else 0.0
        k0 = veh.body_pt_start[b]
        for k in range(k0, veh.body_pt_start[b + 1]):
            th = veh.body_pt_pitch[k]
            a = abs(a0 + veh.body_pt_d[k] * st.udd[th]) if th >= 0 else abs(a0)
            if (n == 0 and k == k0) or a > red.body[r, b]:
                red.body[r, b] = a
                red.body_t[r, b] = t
                red.body_x[r, b] = veh.body_pt_d[k]
        k0 = veh.body_end_start[b]
        for k in range(k0, veh.body_end_start[b + 1]):
            th = veh.body_end_pitch[k]
            a = abs(a0 + veh.body_end_d[k] * st.udd[th]) if th >= 0 else abs(a0)
            if (n == 0 and k == k0) or a > red.body_end[r, b]:
                red.body_end[r, b] = a
                red.body_end_t[r, b] = t
                red.body_end_x[r, b] = veh.body_end_d[k]
    if iters > red.iters[r]:
        red.iters[r] = iters
    if red.le_E.shape[1] > 0:
        le_record(red, veh.wheel_x0, st.X, veh.load_x0, veh.load_p, st.q, st.fq_tot, r, n,
                  t, speed)
    if h >= 0:
        for j in range(n_m):
            out.q[h, n, j] = st.q[j]
            out.qdd[h, n, j] = st.qdd[j]
        if out.fq.shape[0] > 0:
            for j in range(n_m):
                out.fq[h, n, j] = st.fq_tot[j]
        for i in range(veh.wheel_dof.shape[0]):
            out.X[h, n, i] = wk.xout[i]
            out.contact[h, n, i] = wk.active[i]
        for b in range(veh.body_dof.shape[0]):
            d = veh.body_dof[b]
            out.body_acc[h, n, b] = st.udd[d] if d >= 0 else 0.0
            pa = 0.0
            for k in range(veh.body_pt_start[b], veh.body_pt_start[b + 1]):
                if veh.body_pt_pitch[k] >= 0:
                    pa = st.udd[veh.body_pt_pitch[k]]
            out.body_pitch[h, n, b] = pa
        out.iters[h, n] = iters


@njit(inline="always")
def le_static(sup, L, Linv, c6, A, B, X, xi_s, sec0, val, Ms, acc, lx, lp, ls, nl):
    """Static load effects of the ``nl`` point loads ``lx`` (m, ascending, on the deck)
    of forces ``lp`` (N, down) into ``val`` (the channels of ``Reduce.le_*``): exact
    Euler-Bernoulli beam on point supports (vsi_numba.model.influence).

    Each load adds its span's simply supported reactions and end slopes and, on a
    continuous deck, the support moments of its influence cubic; the sections of each
    span (``sec0[s] .. sec0[s + 1] - 1``, ascending) are then swept left to right with
    the loads (one pass: O(n_s + nl)),
    M(X) = R_A X - sum_{a_k <= X} P_k (X - a_k) + the support moments interpolated,
    V = dM/dx (the value just right of a load or support).  Arrays as in ``Reduce``
    (``le_`` dropped; no division in the step: ``Linv`` = 1/L, ``c6`` = 1/(6 EI L),
    ``xi_s`` = X/L); ``ls`` is scratch.
    """
    n_span = L.shape[0]
    n_sup = n_span + 1
    n_s = X.shape[0]
    if n_span == 1:  # one span from x = 0 (the moving-force hot path): no support moment
        L0 = L[0]
        li = Linv[0]
        c0 = c6[0]
        ra = 0.0
        rb = 0.0
        th0 = 0.0
        th1 = 0.0
        for k in range(nl):
            a = lx[k]
            p = lp[k]
            b = L0 - a
            ra += p * li * b
            rb += p * li * a
            c = p * a * b * c0
            th0 += c * (L0 + b)
            th1 -= c * (L0 + a)
        kk = 0
        s0 = 0.0
        s1 = 0.0
        for q in range(n_s):
            Xq = X[q]
            while kk < nl and lx[kk] <= Xq:
                s0 += lp[kk]
                s1 += lp[kk] * lx[kk]
                kk += 1
            v = ra - s0
            val[q] = Xq * v + s1
            val[n_s + q] = v
        val[2 * n_s] = ra
        val[2 * n_s + 1] = rb
        val[2 * n_s + 2] = th0
        val[2 * n_s + 3] = th1
        return
    for i in range(n_sup):
        Ms[i] = 0.0
    for k in range(n_span):
        acc[0, k] = 0.0
        acc[1, k] = 0.0
        acc[2, k] = 0.0
        acc[3, k] = 0.0
    s = 0
    for k in range(nl):
        x = lx[k]
        p = lp[k]
        while s < n_span - 1 and x >= sup[s + 1]:
            s += 1
        ls[k] = s
        Ls = L[s]
        a = x - sup[s]
        b = Ls - a
        pl = p * Linv[s]
        acc[0, s] += pl * b
        acc[1, s] += pl * a
        c = p * a * b * c6[s]
        acc[2, s] += c * (Ls + b)
        acc[3, s] -= c * (Ls + a)
        if n_span > 1:
            xi = a * Linv[s]
            g = p * xi * (1.0 - xi)
            for i in range(1, n_sup - 1):
                Ms[i] += g * (A[s, i] + B[s, i] * xi)
    kk = 0
    for sp in range(n_span):
        ra = acc[0, sp]
        x0 = sup[sp]
        s0 = 0.0
        s1 = 0.0
        while kk < nl and ls[kk] < sp:
            kk += 1
        for q in range(sec0[sp], sec0[sp + 1]):
            Xq = X[q]
            while kk < nl and ls[kk] == sp and lx[kk] - x0 <= Xq:
                s0 += lp[kk]
                s1 += lp[kk] * (lx[kk] - x0)
                kk += 1
            v = ra - s0
            val[q] = Xq * v + s1
            val[n_s + q] = v
    if n_span > 1:  # the support moments, interpolated in each span
        for sp in range(n_span):
            m0 = Ms[sp]
            m1 = Ms[sp + 1]
            dv = (m1 - m0) * Linv[sp]
            for q in range(sec0[sp], sec0[sp + 1]):
                val[q] += m0 + (m1 - m0) * xi_s[q]
                val[n_s + q] += dv
    o = 2 * n_s
    for k in range(n_sup):
        v = 0.0
        if k < n_span:
            v += acc[0, k] + (Ms[k + 1] - Ms[k]) * Linv[k]
        if k > 0:
            v += acc[1, k - 1] - (Ms[k] - Ms[k - 1]) * Linv[k - 1]
        val[o + k] = v
    o += n_sup
    for k in range(n_span):
        c = L[k] * L[k] * c6[k]  # L / (6 EI)
        val[o + k] = acc[2, k] + c * (2.0 * Ms[k] + Ms[k + 1])
    k = n_span - 1
    c = L[k] * L[k] * c6[k]
    val[o + n_span] = acc[3, k] - c * (Ms[k] + 2.0 * Ms[k + 1])


@njit(inline="always")
def le_finish(E, w2inv, val, q, f, mx, mxt, mn, mnt, r, n, t):
    """Add the modal correction sum_j E[j, c] (q_j - f_j / w_j^2) to the static effects
    in ``val`` and fold them into the envelopes ``mx``/``mn`` (times ``mxt``/``mnt``) of
    run ``r`` (step ``n``, time ``t``)."""
    n_c = E.shape[1]
    for j in range(q.shape[0]):
        cj = q[j] - f[j] * w2inv[j]
        for c in range(n_c):
            val[c] += E[j, c] * cj
    # most steps raise no envelope: a branch-free test first (the envelopes start at
    # -inf / +inf, so step 0 sets both)
    hit = False
    for c in range(n_c):
        hit |= (val[c] > mx[r, c]) | (val[c] < mn[r, c])
    if hit:
        for c in range(n_c):
            v = val[c]
            if v > mx[r, c]:
                mx[r, c] = v
                mxt[r, c] = t
            if v < mn[r, c]:
                mn[r, c] = v
                mnt[r, c] = t


@njit(inline="always")
def le_sort(lx, lp, nl):
    """Sort the first ``nl`` loads by abscissa ``lx`` (with their forces ``lp``): an
    insertion sort (the train's order: nearly sorted)."""
    for k in range(1, nl):
        x = lx[k]
        p = lp[k]
        m = k - 1
        while m >= 0 and lx[m] > x:
            lx[m + 1] = lx[m]
            lp[m + 1] = lp[m]
            m -= 1
        lx[m + 1] = x
        lp[m + 1] = p


@njit(kernel_only=True)
def le_record(red, wheel_x0, X, load_x0, load_p, q, f, r, n, t, speed):
    """Load effects of step ``n`` of the general time loop: the moving forces and the
    contact forces ``X`` of the wheels on the deck (at the deck line), with the step's
    total modal force ``f``."""
    lx = red.le_lx
    lp = red.le_lp
    sup = red.le_sup
    length = sup[sup.shape[0] - 1]
    nl = 0
    for i in range(wheel_x0.shape[0] - 1, -1, -1):
        x = wheel_x0[i] + speed * t
        if X[i] != 0.0 and x >= 0.0 and x <= length:
            lx[nl] = x
            lp[nl] = X[i]
            nl += 1
    for k in range(load_x0.shape[0] - 1, -1, -1):
        x = load_x0[k] + speed * t
        if x >= 0.0 and x <= length:
            lx[nl] = x
            lp[nl] = load_p[k]
            nl += 1
    le_sort(lx, lp, nl)
    le_static(sup, red.le_L, red.le_Linv, red.le_c6, red.le_A, red.le_B, red.le_X,
              red.le_xi, red.le_sec0, red.le_val, red.le_Ms, red.le_acc, lx, lp, red.le_ls,
              nl)
    le_finish(red.le_E, red.le_w2inv, red.le_val, q, f, red.le_max, red.le_max_t,
              red.le_min, red.le_min_t, r, n, t)


@njit(inline="always")
def close_separation(red, r, i):
    """A separation of wheel ``i`` ended (or the run did): count the event."""
    red.events[r, i] += 1
    if red.run_len[i] == 1:
        red.single[r, i] += 1
    red.run_len[i] = 0


@njit
def time_loop(br, veh, pr, prm, st, bk, wk, red, r, out, h):
    """Integrate ``prm.n_steps`` steps from the state ``st`` (recorded as step 0),
    reducing the envelopes of run ``r`` (and storing history slot ``h`` if >= 0).

    A step whose contact problem fails is retried as 2, 4, ... substeps (up to
    ``prm.max_sub`` halvings).  Returns (status, step index reached).
    """
    n_w = veh.wheel_dof.shape[0]
    for i in range(n_w):
        wk.xout[i] = st.X[i]
        red.run_len[i] = 0
    contact_search(br, veh, pr, 0.0, prm.speed, wk)  # on-bridge flags at t = 0
    track = track_element(veh)
    if track:
        for i in range(n_w):  # the static start, at rest
            wk.trk[i, 0] = veh.track_z0[i]
            wk.trk[i, 1] = 0.0
            wk.trk[i, 2] = 0.0
    dt = prm.dt
    # n = -1 records the initial state (step 0, t = 0) through the call that records
    # the steps: one inlined copy of record() in the kernel
    for n in range(-1, prm.n_steps):
        iters = 0
        if n >= 0:
            copy_state(st, bk)
            for i in range(n_w):
                wk.was_active[i] = wk.active[i]
                wk.act0[i] = wk.active[i]  # the set at t_n, for retries
                wk.onb0[i] = wk.onb[i]
            if track:
                for i in range(n_w):
                    for c in range(3):
                        wk.trk0[i, c] = wk.trk[i, c]
            # The step's pieces, all integrated by the one vsi_step call below (numba
            # and LLVM then compile the step once in this kernel, not once per kind of
            # piece): WHOLE the step (t0, t1]; CROSS the pieces of a step in which
            # wheels pass an end of the deck on the rigid track, each ending where a
            # wheel meets the kink of the running surface (event-driven: the impact
            # there, in impact_update, an LCP whose crossing wheel may only be pushed,
            # sees the true velocity jump of the rail - a plastic impact where the rail
            # turns towards the wheel, a free separation where it turns away; design
            # note 1.4); TAIL the rest of such a step after its last event, in
            # 2^CROSSING_LEVELS substeps (at most max_sub halvings: a wheel the kink
            # released lands again within microseconds, and landing at the end of a
            # whole step would leave its impact transient in the step's recorded
            # force); RETRY after a failed piece, the step again from its start in
            # 2^level substeps, level = 1 .. max_sub.  Pieces of a crossing step shorter
            # than CROSSING_MIN_FRACTION dt are not integrated: the event is taken at
            # the start of the piece (crossing_impact) or the state stands for t1.  The
            # vehicle blocks of the crossing pieces are inverted in the step (level -1).
            t0 = n * dt
            t1 = (n + 1) * dt
            eta = CROSSING_MIN_FRACTION * dt
            status = OK
            level = 0
            phase = WHOLE
            if prm.contact_model == 0 and br.track == 0 and crosses_deck_end(
                    br, veh, t0, t1, prm.speed):
                # a wheel meets the velocity jump of the rail at a deck end in this step
                if wk.khv.shape[0] == veh.start.shape[0] - 1 and prm.max_sub > 0:
                    phase = CROSS  # split at the crossing times
                    for i in range(n_w):
                        wk.imp[i] = 0.0
                else:
                    # no workspace for variable steps (or max_sub = 0: no step is ever
                    # split): 2^CROSSING_LEVELS substeps, at most max_sub halvings
                    status = NOT_CONVERGED
                    level = min(prm.max_sub, CROSSING_LEVELS) - 1
            t = t0  # CROSS, TAIL: where the current piece starts
            tc = t1  # CROSS: where it ends
            k = 0  # TAIL, RETRY: the substep
            m = 1  # TAIL, RETRY: substeps
            h_sub = dt  # TAIL, RETRY: their length
            while True:
                if status != OK:  # the step again, in twice as many substeps
                    if level >= prm.max_sub:
                        break
                    level += 1
                    copy_state(bk, st)
                    for i in range(n_w):
                        wk.active[i] = wk.act0[i]
                        wk.onb[i] = wk.onb0[i]
                    if track:
                        for i in range(n_w):
                            for c in range(3):
                                wk.trk[i, c] = wk.trk0[i, c]
                    phase = RETRY
                    m = 1 << level
                    h_sub = dt / m
                    k = 0
                    iters = 0
                # the next piece: (.., ta] of length hs at level lev, or an impact
                impact = False
                if phase == WHOLE:
                    ta = t1
                    hs = dt
                    lev = np.int64(0)
                elif phase == CROSS:
                    tc = next_deck_end(br, veh, t, t1, prm.speed)
                    if tc > t1:  # no more events: the rest of the step
                        if not t1 - t > eta:
                            for i in range(n_w):
                                wk.impulse[i] = wk.imp[i]  # the step's impulses
                            break
                        m = 1 << min(prm.max_sub, CROSSING_LEVELS) if t > t0 else 1
                        while m > 1 and (t1 - t) / m <= eta:
                            m //= 2
                        h_sub = (t1 - t) / m
                        k = 0
                        phase = TAIL
                        continue
                    for i in range(n_w):
                        wk.was_active[i] = wk.active[i]
                    impact = not tc - t > eta
                    ta = tc
                    hs = tc - t
                    lev = np.int64(-1)
                else:  # TAIL, RETRY
                    for i in range(n_w):
                        wk.was_active[i] = wk.active[i]
                    if phase == TAIL:
                        ta = t1 if k == m - 1 else t + (k + 1) * h_sub
                        lev = np.int64(-1)
                    else:
                        ta = t0 + (k + 1) * h_sub
                        lev = level
                    hs = h_sub
                if not impact:
                    status, it = vsi_step(br, veh, pr, prm, st, wk, ta, hs, lev)
                    iters += it
                    if status != OK:
                        continue
                    if phase == WHOLE:
                        break
                    if phase != RETRY:
                        for i in range(n_w):
                            wk.imp[i] += wk.impulse[i]
                    if phase == CROSS:
                        t = tc
                        continue
                    k += 1
                    if k == m:
                        if phase == TAIL:
                            for i in range(n_w):
                                wk.impulse[i] = wk.imp[i]  # the step's impulses, all pieces
                        break
                    continue
                # the wheels crossed within eta of t: the impact on the state there
                # (through hht_step, whose callees compile in the order of the leaves)
                status, _ = hht_step(br, veh, pr, prm, st, wk, tc, dt,
                                     np.int64(CROSSING_IMPACT))
                t = tc
            if status != OK:
                return status, n + 1
            if not state_is_finite(st):
                return NON_FINITE, n + 1
        record(veh, st, wk, red, r, n + 1, float(n + 1) * dt, prm.speed, out, h, iters)
    for i in range(n_w):
        if red.run_len[i] > 0:
            close_separation(red, r, i)
    return OK, prm.n_steps


@njit(kernel_only=True)
def load_windows(br, veh, speed, dt, n_steps, on, off):
    """Steps during which each moving force is on the bridge: load ``k`` is on it at the
    end of steps ``on[k] .. off[k] - 1`` (time ``(n + 1) dt`` at the end of step ``n``).

    Uses the comparison of :func:`assemble_loads` (on iff 0 <= x <= L with
    x = x0 + v t); x grows monotonically with t, so each window is one interval.
    """
    for k in range(veh.load_x0.shape[0]):
        x0 = veh.load_x0[k]
        # first step whose end time puts the load at x >= 0, then at x > L
        n = int(np.floor(-x0 / (speed * dt))) - 2
        if n < 0:
            n = 0
        while n < n_steps and x0 + speed * ((n + 1) * dt) < 0.0:
            n += 1
        on[k] = n
        m = int(np.floor((br.length - x0) / (speed * dt))) - 2
        if m < n:
            m = n
        while m < n_steps and not x0 + speed * ((m + 1) * dt) > br.length:
            m += 1
        off[k] = m


@njit(kernel_only=True)
def window_sums(veh, n, on, off, cs, sums):
    """Phasor sums of the loads on the bridge during step ``n`` (sine modes):
    ``sums[0, j] + i sums[1, j] = sum_k P_k exp(i (j+1) k1 x0_k)``.

    Returns the next step at which a load enters or leaves the bridge.
    """
    n_m = sums.shape[1]
    for j in range(n_m):
        sums[0, j] = 0.0
        sums[1, j] = 0.0
    nxt = 1 << 62
    for k in range(veh.load_x0.shape[0]):
        if on[k] > n:
            if on[k] < nxt:
                nxt = on[k]
            continue
        if off[k] <= n:
            continue
        if off[k] < nxt:
            nxt = off[k]
        p = veh.load_p[k]
        c1 = cs[0, k]
        s1 = cs[1, k]
        c = c1
        s = s1
        for j in range(n_m):
            sums[0, j] += p * c
            sums[1, j] += p * s
            c, s = c * c1 - s * s1, s * c1 + c * s1
    return nxt


@njit(kernel_only=True)  # its own kernel, not inlined: ~1.5 s less to compile
def mf_time_loop(br, veh, prm, st, wk, red, r, out, h, on, off, cs, sums):
    """:func:`time_loop` for a train of moving forces only (no vehicle DOFs, no contact).

    The same HHT-alpha arithmetic per mode as :func:`hht_step` with no wheels, without
    the work that has nothing to act on: the modes are uncoupled, and only the loads on
    the bridge are evaluated.  For sine modes (simply supported span) the modal load is
    sum_k P_k a_j sin((j+1) k1 (x0_k + v t)) = a_j Im(exp(i (j+1) k1 v t) Z_j), with the
    phasor sums Z_j = sum_k P_k exp(i (j+1) k1 x0_k) over the loads on the bridge
    rebuilt only when a load enters or leaves it: O(n_m) per step instead of
    O(n_loads n_m), equal to the direct sum to round-off (a few 1e-14 relative: the
    phases are products of up to ~1e3 rad).  Other bridges sum the loads directly, in
    the order of :func:`assemble_loads` (bit for bit the general step's numbers).
    """
    alpha = prm.alpha
    dt = prm.dt
    a0, a1, a2, a3, cv, ca, gamma, scale = hht_coefficients(alpha, dt)
    n_m = st.q.shape[0]
    n_l = veh.load_x0.shape[0]
    speed = prm.speed
    cq = wk.hq
    w2 = wk.rq
    for j in range(n_m):
        cq[j] = 2.0 * br.zeta[j] * br.omega[j]
        w2[j] = br.omega[j] ** 2
        wk.khat[j] = a0 + scale * (a1 * cq[j] + w2[j])
    load_windows(br, veh, speed, dt, prm.n_steps, on, off)
    # locals, not tuple fields, inside the step loop: no reference-count traffic
    q = st.q
    qd = st.qd
    qdd = st.qdd
    fq_tot = st.fq_tot
    fq = wk.fq
    khat = wk.khat
    phi_d = red.phi_d
    phi_a = red.phi_a
    disp = red.disp
    disp_t = red.disp_t
    acc_env = red.acc
    acc_t = red.acc_t
    amp = br.sine_amp
    load_x0 = veh.load_x0
    load_p = veh.load_p
    n_p = phi_d.shape[0]
    phi_g = red.phi_g
    phi_gmax = red.phi_gmax
    n_ka = phi_g.shape[0]
    gw = red.gwork
    n_g = gw.shape[0]
    gacc = red.gacc
    gacc_t = red.gacc_t
    gacc_i = red.gacc_i
    hq = out.q
    hqdd = out.qdd
    hit = out.iters
    hfq = out.fq
    le_on = red.le_E.shape[1] > 0
    order = red.le_order
    le_sup = red.le_sup
    le_length = le_sup[le_sup.shape[0] - 1]
    le_L = red.le_L
    le_Linv = red.le_Linv
    le_c6 = red.le_c6
    le_xi = red.le_xi
    le_A = red.le_A
    le_B = red.le_B
    le_X = red.le_X
    le_sec0 = red.le_sec0
    le_val = red.le_val
    le_Ms = red.le_Ms
    le_acc = red.le_acc
    le_lx = red.le_lx
    le_lp = red.le_lp
    le_ls = red.le_ls
    le_E = red.le_E
    le_w2inv = red.le_w2inv
    le_max = red.le_max
    le_max_t = red.le_max_t
    le_min = red.le_min
    le_min_t = red.le_min_t
    lo = n_l  # moving loads on the bridge: order[lo:hi] (ascending x: a window)
    hi = n_l
    first = 0  # loads before ``first`` have left the bridge for good
    nxt = 0  # next step at which the loads on the bridge change (sine modes)
    k1 = br.sine_k[0] if br.kind == 1 and n_m > 0 else 0.0
    if br.kind == 1:
        for k in range(n_l):
            cs[0, k] = np.cos(k1 * load_x0[k])
            cs[1, k] = np.sin(k1 * load_x0[k])
    # n = -1 records the initial state (step 0, t = 0) with the code that records the
    # steps, as :func:`record` would (the envelopes start at 0, the load effects at
    # -inf/+inf): one copy of that code in the kernel
    for n in range(-1, prm.n_steps):
        t1 = (n + 1) * dt
        if n >= 0:
            for j in range(n_m):
                fq[j] = 0.0
            if br.kind == 1 and n_m > 0:
                if n == nxt:
                    nxt = window_sums(veh, n, on, off, cs, sums)
                ang = k1 * (speed * t1)
                c1 = np.cos(ang)
                s1 = np.sin(ang)
                c = c1
                s = s1
                for j in range(n_m):
                    fq[j] = amp[j] * (s * sums[0, j] + c * sums[1, j])
                    c, s = c * c1 - s * s1, s * c1 + c * s1
            elif br.kind != 0:
                while first < n_l and off[first] <= n and on[first] <= n:
                    first += 1
                for k in range(first, n_l):
                    if n < on[k] or n >= off[k]:
                        continue
                    x = load_x0[k] + speed * t1
                    eval_modes(br, x, wk.phil, wk.yq, wk.vq)
                    p = load_p[k]
                    for j in range(n_m):
                        fq[j] += p * wk.phil[j]
            finite = 0.0
            for j in range(n_m):
                rj = (scale * fq[j] - alpha * fq_tot[j] + a2 * qd[j] + a3 * qdd[j]
                      - cq[j] * (cv * qd[j] + ca * qdd[j]) - w2[j] * q[j])
                dq = rj / khat[j]
                qd[j], qdd[j] = newmark(dq, qd[j], qdd[j], a0, a2, a3, gamma, dt)
                q[j] += dq
                fq_tot[j] = fq[j]
                finite += q[j] + qd[j] + qdd[j]
            if not np.isfinite(finite):
                return NON_FINITE, n + 1
        # record (see :func:`record`; no wheels, no car bodies)
        t = float(n + 1) * dt
        for p in range(n_p):
            w = 0.0
            a = 0.0
            for j in range(n_m):
                w += phi_d[p, j] * q[j]
                a += phi_a[p, j] * qdd[j]
            w = abs(w)
            a = abs(a)
            if w > disp[r, p]:
                disp[r, p] = w
                disp_t[r, p] = t
            if a > acc_env[r, p]:
                acc_env[r, p] = a
                acc_t[r, p] = t
        # whole-deck grid, only when the bound sum_j max|phi_j| |qdd_j| could raise the
        # envelope (exact: the skipped steps cannot); mode-outer sums, then the maximum
        bound = 0.0
        for j in range(n_ka):
            bound += phi_gmax[j] * abs(qdd[j])
        if n_g > 0 and bound > gacc[r]:
            aj = qdd[0]
            for p in range(n_g):
                gw[p] = phi_g[0, p] * aj
            for j in range(1, n_ka):
                aj = qdd[j]
                for p in range(n_g):
                    gw[p] += phi_g[j, p] * aj
            m = 0.0
            for p in range(n_g):
                a = abs(gw[p])
                if a > m:
                    m = a
            if m > gacc[r]:
                for p in range(n_g):
                    if abs(gw[p]) == m:
                        gacc[r] = m
                        gacc_t[r] = t
                        gacc_i[r] = p
                        break
        if le_on:
            nl = 0
            if n < 0:  # the loads on the deck at t = 0, as :func:`le_record` lists them
                for k in range(n_l - 1, -1, -1):
                    x = load_x0[k]
                    if x >= 0.0 and x <= le_length:
                        le_lx[nl] = x
                        le_lp[nl] = load_p[k]
                        nl += 1
                le_sort(le_lx, le_lp, nl)
            else:
                while lo > 0 and on[order[lo - 1]] <= n:
                    lo -= 1
                while hi > lo and off[order[hi - 1]] <= n:
                    hi -= 1
                for i in range(lo, hi):
                    k = order[i]
                    le_lx[nl] = load_x0[k] + speed * t1
                    le_lp[nl] = load_p[k]
                    nl += 1
            le_static(le_sup, le_L, le_Linv, le_c6, le_A, le_B, le_X, le_xi, le_sec0, le_val,
                      le_Ms, le_acc, le_lx, le_lp, le_ls, nl)
            le_finish(le_E, le_w2inv, le_val, q, fq_tot, le_max, le_max_t, le_min, le_min_t,
                      r, n + 1, t)
        if h >= 0:
            for j in range(n_m):
                hq[h, n + 1, j] = q[j]
                hqdd[h, n + 1, j] = qdd[j]
            hit[h, n + 1] = 1 if n >= 0 else 0
            if hfq.shape[0] > 0:
                for j in range(n_m):
                    hfq[h, n + 1, j] = fq_tot[j]
    if prm.n_steps > 0 and red.iters[r] < 1:
        red.iters[r] = 1  # the contact "solve" with no wheels: one pass per step
    return OK, prm.n_steps


@njit
def run_batch_mf(br, veh, prm, speeds, n_steps, init, st, wk, red, out, slots, status,
                 reached, on, off, cs, sums):
    """:func:`run_batch` of a moving-force model: every run in one call (thousands of
    short runs in a design catalogue).  ``on``, ``off`` (n_loads,) int64, ``cs``
    (2, n_loads) and ``sums`` (2, n_modes) are its scratch arrays."""
    for r in range(speeds.shape[0]):
        # the state from row r; the workspace needs no reset: the moving-force loop writes
        # every scratch value it reads (and has no wheels)
        copy_into(init.q[r], st.q)
        copy_into(init.qd[r], st.qd)
        copy_into(init.qdd[r], st.qdd)
        copy_into(init.fq_tot[r], st.fq_tot)
        p = Params(prm.dt, prm.alpha, speeds[r], n_steps[r], prm.max_iter, prm.tol_gap,
                   prm.tol_force, prm.max_sub, prm.contact_model, prm.hertz_g)
        s, k = mf_time_loop(br, veh, p, st, wk, red, r, out, slots[r], on, off, cs, sums)
        status[r] = s
        reached[r] = k


#: The workspace arrays that start at 1 (:func:`reset_work`); the others start at 0.
WORK_ONES = frozenset({"active", "was_active", "ones"})


def reset_work(wk):
    """Put a workspace back in its initial state (all wheels active, zeros elsewhere),
    with numpy: between two runs, not inside a kernel."""
    for name, a in zip(Work._fields, wk, strict=True):
        a[...] = 1 if name in WORK_ONES else 0


def start_vsi_run(init, r, st, wk):
    """Row ``r`` of ``init`` into the state ``st`` and the workspace back to its initial
    state (:func:`reset_work`), with numpy, before each :func:`time_loop` of the
    interaction runs: tens of microseconds against a run's thousands of steps, and no
    kernel for a first run to compile (~3 s)."""
    for src, dst in zip(init, st, strict=True):
        dst[...] = src[r]
    reset_work(wk)


def run_batch(br, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, slots, status,
              reached):
    """Run one packed model at every speed of ``speeds`` (m/s), one run after the other.

    Run ``r`` starts from row ``r`` of ``init``, integrates ``n_steps[r]`` steps at
    ``speeds[r]`` and folds its envelopes into row ``r`` of ``red``; when
    ``slots[r] >= 0`` its raw histories go to that slot of ``out``.  ``status[r]`` and
    ``reached[r]`` receive the run's status code and the step it reached.  The model,
    workspaces and outputs are allocated once per batch by the caller.

    A moving-force model runs all its runs in one kernel call (:func:`run_batch_mf`);
    an interaction model calls :func:`time_loop` once per run from here (a run is
    thousands of coupled steps, so the call costs nothing), which keeps the interaction
    kernels out of a moving-force study's first compilation and one level shallower
    (numba re-optimises every callee inside each caller it is linked into).
    """
    if veh.wheel_dof.shape[0] == 0 and veh.start.shape[0] == 1:
        n_l = veh.load_x0.shape[0]
        run_batch_mf(br, veh, prm, speeds, n_steps, init, st, wk, red, out, slots, status,
                     reached, np.zeros(n_l, np.int64), np.zeros(n_l, np.int64),
                     np.zeros((2, n_l)), np.zeros((2, br.omega.shape[0])))
        return
    for r in range(speeds.shape[0]):
        start_vsi_run(init, r, st, wk)
        p = prm._replace(speed=float(speeds[r]), n_steps=int(n_steps[r]))
        status[r], reached[r] = time_loop(br, veh, pr, p, st, bk, wk, red, r, out,
                                          int(slots[r]))


def compile_leaves(br, veh, pr, prm, speeds, n_steps, init, st, bk, wk, red, out, slots,
                   status, reached):
    """Compile the largest leaves of the interaction kernels - :func:`impact_update`
    (about a sixth of the family's compile time), :func:`nl_update_branches` and
    :func:`record` (with :func:`le_record`) - for the types :func:`run_batch` passes
    down with these arguments, without running anything.  A second process does this
    while the first compiles :func:`time_loop`, which then loads them from numba's cache
    when it reaches them (they are its last callees: numba types :func:`hht_step`'s
    other callees before :func:`impact_update`; :func:`hht_step` and :func:`vsi_step`
    pass ``br, veh, prm, st, wk`` on unchanged, ``dt`` and ``tol_force`` are floats;
    :func:`time_loop` records step ``n + 1`` (int64) at time ``(n + 1) dt`` with its
    int64 run, history slot and iteration count)."""
    p = prm._replace(speed=float(speeds[0]), n_steps=int(n_steps[0]))
    compile_for(impact_update, br, veh, p, st, wk, 0.0)
    compile_for(nl_update_branches, veh, wk, st, 0.0)
    compile_for(record, veh, st, wk, red, np.int64(0), np.int64(0), 0.0, p.speed, out,
                np.int64(0), np.int64(0))


#: The kernels :func:`compile_leaves` compiles.
LEAVES = (impact_update, nl_update_branches, record)
