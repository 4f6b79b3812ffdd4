"""The kernels' arguments of a batch besides the model: the workspace, the history
buffers and the envelopes reduced in the time loop (:class:`~vsi_numba.kernels.types.Reduce`)."""

from __future__ import annotations

import numpy as np

from vsi_numba import kernels as ek
from vsi_numba.solver.pack import LoadEffectTables, Packed


def _workspace(n_m, n_v, n_w, veh: ek.VehicleArrays | None = None) -> ek.Work:
    z = np.zeros
    # variable steps (deck-end events) and nonlinear suspensions need per-vehicle blocks
    n_veh, nb = (veh.M.shape[0], veh.M.shape[1]) if veh is not None else (0, 0)
    n_e = veh.nl_veh.shape[0] if veh is not None else 0
    return ek.Work(
        khv=z((n_veh, nb, nb)), kh_dt=z(n_veh), kh_sig=z(n_veh, np.int64), kscr=z((nb, nb)),
        nlb=z(n_e, np.int64), nbk=z(4 * n_m + 4 * n_v + 4 * n_w), imp=z(n_w),
        phi=z((n_w, n_m)), dphi=z((n_w, n_m)), d2phi=z((n_w, n_m)),
        onb=z(n_w, np.int64), rr=z((n_w, 3)), S=z((n_w, n_w)), L=z((n_w, n_w)),
        idx=z(n_w, np.int64), rhs=z(n_w), sol=z(n_w), gstar=z(n_w), X=z(n_w),
        active=np.ones(n_w, np.int64), was_active=np.ones(n_w, np.int64),
        yq=z(n_m), yv=z(n_v), rq=z(n_m), rv=z(n_v), fq=z(n_m), phil=z(n_m), hq=z(n_m),
        hv=z(n_v), ones=np.ones(n_m), khat=z(n_m), xout=z(n_w), vq=z(n_m), vv=z(n_v),
        av=z(n_v), act0=z(n_w, np.int64), J=z((n_w, n_w)),
        first=z(n_w, np.int64), onb_prev=z(n_w, np.int64), onb0=z(n_w, np.int64),
        cand=z(n_w, np.int64), lq=z(n_w), lz=z(n_w), lw=z(n_w), lin=z(n_w, np.int64),
        impulse=z(n_w), trk=z((n_w, 4)), trk0=z((n_w, 3)), phz=z(n_w, np.int64),
        pf=z(1 + 2 * n_w, np.int64),
    )


def _history_buffers(n_slots, n_t, n_m, n_w, n_b, effects: bool = False) -> ek.Output:
    return ek.Output(
        q=np.full((n_slots, n_t, n_m), np.nan), qdd=np.full((n_slots, n_t, n_m), np.nan),
        X=np.full((n_slots, n_t, n_w), np.nan), contact=np.zeros((n_slots, n_t, n_w), np.int8),
        body_acc=np.full((n_slots, n_t, n_b), np.nan),
        iters=np.zeros((n_slots, n_t), np.int16),
        body_pitch=np.full((n_slots, n_t, n_b), np.nan),
        fq=(np.full((n_slots, n_t, n_m), np.nan) if effects and n_slots
            else np.zeros((0, 0, 0))),
    )


def _space_fields(deck, eff, speeds, n_r: int) -> dict:
    """The deck-in-space fields of :class:`~vsi_numba.kernels.types.Reduce` (the
    ``SpaceLayout``'s channels, with the load effects on; none: off)."""
    from vsi_numba.solver.space_effects import kernel_fields

    layout = deck.layout
    if eff is None or layout is None:
        return {}
    return kernel_fields(layout.channels, speeds, n_r)


def _effect_fields(eff: LoadEffectTables | None, packed: Packed, n_r: int) -> dict:
    """The load-effect fields of :class:`~vsi_numba.kernels.types.Reduce` (none: off)."""
    if eff is None:
        return {}
    f64 = np.float64
    n_c = eff.E.shape[1]
    veh = packed.kernel_vehicles
    n_load = veh.load_x0.size + veh.wheel_dof.size
    c = np.ascontiguousarray
    return dict(
        le_sup=c(eff.supports, f64), le_L=c(eff.spans, f64), le_Linv=1.0 / eff.spans,
        le_c6=1.0 / (6.0 * eff.EI * eff.spans), le_xi=c(eff.X / eff.spans[eff.span], f64),
        le_A=c(eff.A, f64), le_B=c(eff.B, f64), le_X=c(eff.X, f64),
        le_sec0=c(np.searchsorted(eff.span, np.arange(eff.spans.size + 1)), np.int64),
        le_E=c(eff.E, f64), le_w2inv=c(eff.w2inv, f64),
        le_order=c(np.argsort(veh.load_x0, kind="stable"), np.int64),
        le_val=np.zeros(n_c), le_Ms=np.zeros(eff.n_supports),
        le_acc=np.zeros((4, eff.spans.size)), le_lx=np.zeros(n_load),
        le_lp=np.zeros(n_load), le_ls=np.zeros(n_load, np.int64),
        le_max=np.full((n_r, n_c), -np.inf), le_max_t=np.zeros((n_r, n_c)),
        le_min=np.full((n_r, n_c), np.inf), le_min_t=np.zeros((n_r, n_c)),
    )
