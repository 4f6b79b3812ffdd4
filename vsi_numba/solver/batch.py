"""One packed model at several speeds in one kernel call: the kernels' arguments built
(:mod:`~vsi_numba.solver.operators`, :mod:`~vsi_numba.solver.buffers`), the kernels run
once per machine compiled, the outcome checked and handed back as a
:class:`~vsi_numba.solver.results.BatchResult`."""

from __future__ import annotations

import time as _time

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile
from vsi_numba.solver import driver, kernel_cache
from vsi_numba.solver.buffers import (  # noqa: F401  (re-exported)
    _effect_fields,
    _history_buffers,
    _space_fields,
    _workspace,
)
from vsi_numba.solver.operators import (  # noqa: F401  (re-exported)
    DECK_GRID_INTERVALS,
    DeckOperators,
    SpaceLayout,
    acceleration_cutoff,
    deck_grid,
    deck_operators,
    space_operators,
    torsional_moment_tables,
)
from vsi_numba.solver.pack import ModelError, Packed, initial_states
from vsi_numba.solver.results import STATUS_MESSAGES, BatchResult, effect_series  # noqa: F401
from vsi_numba.solver.settings import SolverSettings


def run_batch(packed: Packed, profile: Profile, speeds, points, settings: SolverSettings,
              bridge: ModalBridge, keep_histories=None, deck=None,
              modal_forces: bool = False, _ensure: bool = True, _kernel=None,
              n_steps=None) -> BatchResult:
    """Run one packed model at several speeds (m/s) in one kernel call.

    Parameters
    ----------
    packed : Packed
        From :func:`pack` (any speed: only its speed-independent arrays are used).
    profile : Profile
        The irregularity the model was packed with (for the initial states).
    speeds : array_like
        Speeds (m/s), one run each.
    points : array_like
        Deck output points (m).
    keep_histories : array_like of bool, optional
        Per run: keep its raw histories (default: none).
    deck : DeckOperators, optional
        ``deck_operators(bridge, points, settings)`` when already computed; one with
        only ``(phi_d, phi_a, cutoff)`` has no whole-deck grid (its envelopes are NaN).
    modal_forces : bool
        Keep the modal force histories of the runs that keep histories also without
        load effects (they are kept with them).
    _ensure : bool
        First have the family's kernels compiled once per machine
        (:func:`~vsi_numba.solver.kernel_cache.ensure_compiled`); False inside that.
    n_steps : array_like of int, optional
        Time steps of each run (default ``packed.n_steps`` of its speed): the runs of the
        trains on other tracks follow the run's train's time grid.
    _kernel : callable, optional
        Called with the kernel's arguments instead of running the batch (returns None):
        the tests read the arguments a study gives the kernels.
    """
    speeds = np.ascontiguousarray(np.atleast_1d(np.asarray(speeds, float)))
    if np.any(~(speeds > 0)):
        raise ModelError(f"speed = {speeds[~(speeds > 0)][0]!r} m/s: expected > 0")
    n_r = speeds.size
    keep = np.zeros(n_r, bool) if keep_histories is None else np.asarray(keep_histories, bool)
    layout = getattr(deck, "layout", None) if deck is not None else None
    per_line = (layout is not None and layout.channels is not None
                and layout.channels.per_line and getattr(deck, "effects", None) is not None)
    if per_line:  # the channels are reduced from every run's histories (reduce_channels)
        keep = np.ones(n_r, bool)
    n_steps = (np.array([packed.n_steps(v) for v in speeds], np.int64) if n_steps is None
               else np.array(np.broadcast_to(np.asarray(n_steps, np.int64), (n_r,))))
    deck = deck if deck is not None else deck_operators(bridge, points, settings)
    deck = DeckOperators.of(deck)
    phi_d, phi_a, cutoff = deck.phi_d, deck.phi_a, deck.cutoff
    grid_x, phi_g, eff = deck.grid_x, deck.phi_g, deck.effects
    grid_x = np.ascontiguousarray(grid_x, dtype=np.float64)
    phi_g = (np.ascontiguousarray(phi_g, dtype=np.float64) if grid_x.size
             else np.zeros((0, 0)))
    veh = packed.kernel_vehicles
    n_m, n_v, n_w = packed.bridge.omega.size, packed.n_dof, veh.wheel_dof.size
    n_b = veh.body_dof.size
    kernel_d, kernel_a, tw = _track_whole(layout, phi_d, phi_a, n_r)
    n_p = kernel_d.shape[0]
    slots = np.full(n_r, -1, np.int64)
    slots[keep] = np.arange(int(keep.sum()))
    n_t = int(n_steps[keep].max()) + 1 if keep.any() else 0
    out = _history_buffers(int(keep.sum()), n_t, n_m, n_w, n_b,
                           eff is not None or modal_forces)
    z = np.zeros
    red = ek.Reduce(
        phi_d=kernel_d, phi_a=kernel_a,
        disp=z((n_r, n_p)), disp_t=z((n_r, n_p)), acc=z((n_r, n_p)), acc_t=z((n_r, n_p)),
        xmin=z((n_r, n_w)), xmin_x=z((n_r, n_w)), xmax=z((n_r, n_w)),
        body=z((n_r, n_b)), body_t=z((n_r, n_b)), body_x=z((n_r, n_b)),
        body_end=np.full((n_r, n_b), np.nan), body_end_t=np.full((n_r, n_b), np.nan),
        body_end_x=np.full((n_r, n_b), np.nan),
        lost=z((n_r, n_w), np.int64), longest=z((n_r, n_w), np.int64),
        events=z((n_r, n_w), np.int64), single=z((n_r, n_w), np.int64),
        run_len=z(n_w, np.int64), iters=z(n_r, np.int64),
        phi_g=phi_g, phi_gmax=np.abs(phi_g).max(axis=1, initial=0.0) * (1.0 + 1e-12),
        gacc=z(n_r), gacc_t=z(n_r), gacc_i=z(n_r, np.int64),
        gwork=z(grid_x.size),
        **_effect_fields(eff, packed, n_r),
        **_space_fields(deck, eff, speeds, n_r),
        **tw,
    )
    init = initial_states(packed, profile, speeds)
    st = ek.State(*(np.empty_like(a[0]) for a in init))
    bk = ek.State(*(np.empty_like(a[0]) for a in init))
    wk = _workspace(n_m, n_v, n_w, veh)
    status = np.zeros(n_r, np.int64)
    reached = np.zeros(n_r, np.int64)
    if _kernel is not None:
        _kernel(packed.bridge, veh, packed.profile, packed.params, speeds, n_steps, init,
                st, bk, wk, red, out, slots, status, reached)
        return None
    if _ensure:  # compiled once per machine (another process compiling: wait)
        compile_family(kernel_cache.family_of(packed))
    t0 = _time.perf_counter()
    driver.run_batch(packed.bridge, veh, packed.profile, packed.params, speeds, n_steps, init,
                 st, bk, wk, red, out, slots, status, reached)
    elapsed = _time.perf_counter() - t0
    _flag_non_finite(status, reached, n_steps, slots, red, out)
    res = BatchResult(packed, speeds, n_steps, status, reached, slots, red, out, phi_d,
                      phi_a, cutoff, elapsed, np.asarray(grid_x, float), eff,
                      bridge.static if eff is not None else None,
                      deck.layout)
    if per_line:  # trains on several tracks: each load's own eccentricity
        from vsi_numba.solver.space_effects import reduce_channels

        reduce_channels(res)
    return res


def _track_whole(layout, phi_d, phi_a, n_r: int):
    """The kernels' deck rows and ``Reduce.tw_*`` fields of a batch: the whole-deck
    rows along the track lines of a deck in space (:attr:`SpaceLayout.n_whole`), whose
    displacement rows are zero, go to one envelope per track (``tw_*``, their shapes
    mode-major); the other rows stay per row.  Without those rows: the operators as
    they are, no ``tw_*`` fields."""
    n_g = 0 if layout is None else layout.n_whole
    n_k = 0 if layout is None else layout.n_tracks
    n_rows = 0 if layout is None else layout.n_rows
    if n_g == 0 or phi_d.shape[0] != n_rows + n_k * n_g:
        return phi_d, phi_a, {}
    n_m = phi_a.shape[1]
    tw_phi = np.ascontiguousarray(
        phi_a[n_rows:].reshape(n_k, n_g, n_m).transpose(0, 2, 1), dtype=np.float64)
    return (np.ascontiguousarray(phi_d[:n_rows]), np.ascontiguousarray(phi_a[:n_rows]),
            dict(tw_phi=tw_phi, tw_phimax=np.abs(tw_phi).max(axis=2) * (1.0 + 1e-12),
                 tw_acc=np.zeros((n_r, n_k)), tw_acc_t=np.zeros((n_r, n_k)),
                 tw_acc_i=np.zeros((n_r, n_k), np.int64), tw_work=np.zeros(n_g)))


#: Largest magnitude a result may have: histories are stored as float32.
_STORABLE = float(np.finfo(np.float32).max)


def _flag_non_finite(status, reached, n_steps, slots, red, out) -> None:
    """Flag ``non_finite_state`` for the runs the kernel passed as ok whose envelopes or
    histories are not finite or beyond the float32 range of the results file (the
    kernel's check covers the state, not the outputs derived from it, e.g. the deck
    response to a 1e300 N force)."""
    envelopes = (red.disp, red.acc, red.xmin, red.xmax, red.body,
                 *((red.tw_acc,) if red.tw_acc.shape[0] else ()))
    for r in np.flatnonzero(status == ek.OK):
        bad = any(not np.all(np.abs(a[r]) <= _STORABLE) for a in envelopes)
        step = int(n_steps[r])
        h = int(slots[r])
        if h >= 0:
            n = step + 1
            rows = np.zeros(n, bool)
            for a in (out.q, out.qdd, out.X, out.body_acc):
                v = a[h, :n].reshape(n, -1)
                rows |= ~np.all(np.abs(v) <= _STORABLE, axis=1)
            if rows.any():
                bad, step = True, int(np.argmax(rows))
        if bad:
            status[r] = ek.NON_FINITE
            reached[r] = step


def run_kernel(packed: Packed, profile: Profile):
    """Run the time loop at the packed speed, keeping the raw histories.

    Returns (status, step reached, Output of that one run, elapsed seconds).
    """
    bridge_points = np.zeros((0, packed.bridge.omega.size))
    res = _run_packed(packed, profile, bridge_points)
    out = ek.Output(*(a[0] if a.shape[0] else a.reshape(a.shape[1:]) for a in res.out))
    return int(res.status[0]), int(res.reached[0]), out, res.elapsed


def _run_packed(packed, profile, phi):
    """One run with histories and given deck operators (no bridge object needed)."""
    return run_batch(packed, profile, [packed.params.speed], np.zeros(0),
                     SolverSettings(dt=packed.params.dt), None, keep_histories=[True],
                     deck=DeckOperators(phi, phi, float("nan")))


def compile_family(family: str) -> tuple[str, float]:
    """Have ``family``'s kernels compiled (or loaded from the cache) in this process, once
    per machine (:func:`~vsi_numba.solver.kernel_cache.ensure_compiled`): a tiny batch of
    the family, whose kernel arguments have the types of every study's.  Returns
    (``"ready"``, ``"loaded"`` or ``"compiled"``, seconds)."""
    t0 = _time.perf_counter()
    how = kernel_cache.ensure_compiled(family, lambda: _tiny_batch(family))
    return how, _time.perf_counter() - t0


def _tiny_batch(family: str) -> None:
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh
    from vsi_numba.model.irregularity import no_irregularity
    from vsi_numba.model.vehicle import Train
    from vsi_numba.solver.pack import pack

    beam = br.simply_supported(10.0, 1e9, 1e4, n_modes=2)
    if family == "moving_force":
        unit = vh.point_loads([0.0, 3.0], [1e5, 1e5], name="tiny")
    else:
        unit = vh.sprung_mass(1e3, 1e6, 1e3, 100.0)
    settings = SolverSettings(dt=5e-3, approach=0.0, free_vibration=0.0)
    profile = no_irregularity()
    packed = pack(beam, Train("tiny", (unit,), (0.0,)), 50.0, profile, settings)
    run_batch(packed, profile, [50.0], [5.0], settings, beam, _ensure=False)
