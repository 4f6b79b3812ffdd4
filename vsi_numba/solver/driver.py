"""The Python side of the kernels: the calls that set up and run them
(:func:`run_batch`), workspace resets between runs, the nonzero patterns of the packed
vehicles, and the compilation of the interaction kernels' leaves in a second process.
"""

from __future__ import annotations

import numpy as np

from vsi_numba.kernels import Work
from vsi_numba.kernels.loop import time_loop
from vsi_numba.kernels.moving_force import run_batch_mf
from vsi_numba.kernels.types import ContactArrays, StepArrays, VehicleArrays


def _view(cls, *bundles):
    """``cls`` (a namedtuple of arrays) from the fields of the same names in ``bundles``."""
    return cls(*(next(getattr(b, f) for b in bundles if f in b._fields) for f in cls._fields))


def contact_view(veh, wk) -> ContactArrays:
    """The contact solvers' arrays of a model and workspace (as the kernels'
    ``contact_arrays``), for a call from Python."""
    return _view(ContactArrays, veh, wk)


def step_view(veh, st, wk) -> StepArrays:
    """The arrays ``record`` reads of a model, state and workspace (as the kernels'
    ``step_arrays``), for a call from Python."""
    return _view(StepArrays, veh, st, wk)


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
    interaction runs."""
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
    thousands of coupled steps, so the call costs nothing).
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
