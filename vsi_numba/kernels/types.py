"""The arrays the kernels work on (namedtuples of numpy arrays, built by
:mod:`vsi_numba.solver.pack` and :mod:`vsi_numba.solver.batch`) and the codes they return.

Status codes returned by the kernels (translated to messages by the solver):
0 ok, 1 contact iterations not converged, 2 singular contact (Schur) system,
3 non-finite state, 4 singular impact system.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

OK, NOT_CONVERGED, SINGULAR_SCHUR, NON_FINITE, SINGULAR_IMPACT = 0, 1, 2, 3, 4

#: Kinds of nonlinear suspension element (``VehicleArrays.nl_kind``).
NL_BUMP_STOP, NL_BLOWOFF = 0, 1


class BridgeArrays(NamedTuple):
    """Bridge data for the kernels (see ``vsi_numba.model.bridge.ModalBridge``).

    Several track lines (a deck in space with trains on several tracks): the Hermite
    tables ``values``/``slopes`` (and ``t_values``/``t_slopes``) hold one block of
    ``nodes.shape[0]`` (``t_nodes.shape[0]``) rows per line, line ``k`` in rows
    ``k n_nodes .. (k + 1) n_nodes - 1``; a wheel reads the block of its line
    (``VehicleArrays.wheel_line``).  Sine modes are the same on every line (a deck
    without torsion).
    """

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
    # nonlinear suspension elements (vsi_numba.kernels.suspension), grouped by vehicle:
    # vehicle b has the elements nl_start[b] .. nl_start[b + 1] - 1; none: every vehicle
    # is linear and the step is the linear one, bit for bit
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
    # the rail's inertia in the deck load: wheel i loads the deck with
    # X_i - track_kappa z''_i (z'' of its element at the start of the step; kg,
    # = (m' / k) track_kt: the transmissibility 1 / (1 - w^2 m' / k) of the rail on its
    # foundation to first order); 0: the deck load is X_i
    track_kappa: float = 0.0
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
    # several trains in one run: wheel i is at x_i = wheel_x0[i] + v_i t with
    # v_i = wheel_sf[i] * speed (the signed speed factor of its train: 1 for the run's
    # train, < 0 for a train running in -x) on the track line wheel_line[i] (the row
    # block of the bridge's tables and of the profile it reads); the point loads the
    # same way (load_sf, load_line); set by the packing for every wheel and load
    wheel_sf: np.ndarray = np.zeros(0)  # (n_w,)
    wheel_line: np.ndarray = np.zeros(0, np.int64)  # (n_w,)
    load_sf: np.ndarray = np.zeros(0)  # (n_l,)
    load_line: np.ndarray = np.zeros(0, np.int64)  # (n_l,)


class ProfileArrays(NamedTuple):
    """Irregularity as a uniform-grid cubic spline.

    ``n_int`` > 0: one profile per track line on the same grid, line ``k`` in rows
    ``k n_int .. (k + 1) n_int - 1`` of ``coef``; 0: one profile, every line's."""

    x0: float
    dx: float
    coef: np.ndarray  # (n_int, 4) ascending powers (n_lines n_int with n_int > 0)
    n_int: int = 0


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


class ContactArrays(NamedTuple):
    """What the contact solvers (:mod:`~vsi_numba.kernels.schur`, the LCP of
    :mod:`~vsi_numba.kernels.impact`) read and write: the fields of ``VehicleArrays`` and
    ``Work`` of the same names, and nothing else of them (a call passes these arrays,
    not the whole workspace)."""

    wheel_veh: np.ndarray
    compliance: np.ndarray
    onb: np.ndarray
    S: np.ndarray
    L: np.ndarray
    J: np.ndarray
    idx: np.ndarray
    rhs: np.ndarray
    sol: np.ndarray
    gstar: np.ndarray
    X: np.ndarray
    active: np.ndarray
    first: np.ndarray
    pf: np.ndarray
    cand: np.ndarray
    lq: np.ndarray
    lz: np.ndarray
    lw: np.ndarray
    lin: np.ndarray


class StepArrays(NamedTuple):
    """What :func:`~vsi_numba.kernels.record.record` reads of the vehicles, the state and
    the workspace (the fields of ``VehicleArrays``, ``State`` and ``Work`` of the same
    names)."""

    wheel_x0: np.ndarray
    wheel_sf: np.ndarray
    body_dof: np.ndarray
    body_pt_start: np.ndarray
    body_pt_pitch: np.ndarray
    body_pt_d: np.ndarray
    body_end_start: np.ndarray
    body_end_pitch: np.ndarray
    body_end_d: np.ndarray
    q: np.ndarray
    qdd: np.ndarray
    udd: np.ndarray
    fq_tot: np.ndarray
    xout: np.ndarray
    active: np.ndarray


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
    # Deck-in-space channels by the mode-acceleration method (cb_static, cb_finish), with
    # the load effects on: the twist, the displacement along a track and the torque of a
    # deck whose torsion is restrained at every support (each span a fork-supported span).
    # The static part is a combination of the span-wise simply supported moment and shear
    # of the loads at the n_cs sections ``cb_X`` (cb_ss: M at 0..n_cs-1, V at n_cs..):
    # value = D (sum_k coef_k ss[idx_k] - sum_j Ef[j, c] F_j) + sum_j Eq[j, c] q_j,
    # D = cb_D[r, c] the speed factor of the static part.  n_cb = 0: off.
    cb_X: np.ndarray = np.zeros(0)  # (n_cs,) section abscissa in its span, m
    cb_sec0: np.ndarray = np.zeros(1, np.int64)  # (n_span + 1,) first section of a span
    cb_ss: np.ndarray = np.zeros(0)  # (2 n_cs,) scratch: span-wise M (N m) and V (N)
    cb_ptr: np.ndarray = np.zeros(1, np.int64)  # (n_cb + 1,) terms of channel c
    cb_idx: np.ndarray = np.zeros(0, np.int64)  # (n_nz,) index into cb_ss of each term
    cb_coef: np.ndarray = np.zeros(0)  # (n_nz,) coefficient of each term
    cb_Eq: np.ndarray = np.zeros((0, 0))  # (n_m, n_cb) channel of q_j = 1
    cb_Ef: np.ndarray = np.zeros((0, 0))  # (n_m, n_cb) its static part of F_j = 1
    cb_D: np.ndarray = np.zeros((0, 0))  # (n_runs, n_cb) speed factor of the static part
    cb_val: np.ndarray = np.zeros(0)  # (n_cb,) scratch: channels of the step
    cb_max: np.ndarray = np.zeros((0, 0))  # (n_runs, n_cb) maximum over time (from -inf)
    cb_max_t: np.ndarray = np.zeros((0, 0))  # (n_runs, n_cb) s
    cb_min: np.ndarray = np.zeros((0, 0))  # (n_runs, n_cb) minimum over time (from +inf)
    cb_min_t: np.ndarray = np.zeros((0, 0))  # (n_runs, n_cb) s
    # Band-limited acceleration along each of n_k track lines on the whole-deck grid of
    # n_tg points (a deck in space whose track lines are not its axis), reduced as
    # ``gacc`` to one maximum per track and run: the first point (then the first step)
    # of the largest |a|, the steps whose bound sum_j tw_phimax[k, j] |qdd_j| <= the
    # envelope skipped.  n_k = 0: off.
    tw_phi: np.ndarray = np.zeros((0, 0, 0))  # (n_k, n_m, n_tg) shapes, mode-major
    tw_phimax: np.ndarray = np.zeros((0, 0))  # (n_k, n_m) max_p |tw_phi| (1 + 1e-12)
    tw_acc: np.ndarray = np.zeros((0, 0))  # (n_runs, n_k) max |a|, m/s2
    tw_acc_t: np.ndarray = np.zeros((0, 0))  # (n_runs, n_k) s
    tw_acc_i: np.ndarray = np.zeros((0, 0), np.int64)  # (n_runs, n_k) grid point
    tw_work: np.ndarray = np.zeros(0)  # (n_tg,) scratch: accelerations on the grid


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
