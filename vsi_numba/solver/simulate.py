"""``simulate``: one train at one speed over one bridge and track profile.

The wrapper validates and packs the model into contiguous float64 arrays, finds the
static equilibrium of the train on the approach track, runs the numba time loop and
turns the kernel's status code and raw histories into an ``xarray.Dataset`` with the
names and attributes of ``vsi_numba.io.schema`` (docs/manual/theory.md, "Results files").
"""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

import numpy as np

from vsi_numba.io.schema import attrs_for
from vsi_numba.model.bridge import ModalBridge
from vsi_numba.model.irregularity import Profile, no_irregularity
from vsi_numba.model.vehicle import Train
from vsi_numba.solver.batch import (  # noqa: F401  (re-exported: the solver's API)
    STATUS_MESSAGES,
    BatchResult,
    acceleration_cutoff,
    deck_grid,
    deck_operators,
    run_batch,
    run_kernel,
)
from vsi_numba.solver.pack import (  # noqa: F401  (re-exported: the solver's API)
    ModelError,
    Packed,
    initial_state,
    initial_states,
    pack,
    static_wheel_loads,
)
from vsi_numba.solver.settings import SolverSettings

if TYPE_CHECKING:  # imported where a Dataset is made: it takes ~1 s to import
    import xarray as xr
def simulate(
    bridge: ModalBridge,
    train: Train,
    speed: float,
    profile: Profile | None = None,
    settings: SolverSettings | None = None,
    output_points=None,
    save_histories: bool = True,
) -> xr.Dataset:
    """Run one train at one speed (m/s) over the bridge.

    Parameters
    ----------
    bridge : ModalBridge
    train : Train
    speed : float
        Train speed (m/s).
    profile : Profile, optional
        Vertical track irregularity (default: smooth track).
    settings : SolverSettings, optional
    output_points : array_like, optional
        Abscissae (m) of the deck output points; default: mid-span of every span.
    save_histories : bool
        Keep the time histories (else envelopes only).

    Returns
    -------
    xarray.Dataset
        Histories and envelopes named as in ``vsi_numba.io.schema``; ``attrs["status"]``
        is 0 when the analysis succeeded, otherwise the outputs are NaN and
        ``attrs["message"]`` says why.

    Notes
    -----
    Direct method of Neves et al., Eng. Struct. 69 (2014) 83-89, Eq. (3): HHT-alpha on
    the coupled system with the contact forces as unknowns of a Schur system.  This is
    the batch kernel (:func:`run_batch`) restricted to one run.
    """
    settings = settings or SolverSettings()
    profile = profile if profile is not None else no_irregularity()
    points = default_points(bridge, output_points)
    packed = pack(bridge, train, speed, profile, settings)
    res = run_batch(packed, profile, [speed], points, settings, bridge,
                    keep_histories=[save_histories])
    return to_dataset(bridge, train, res, profile, settings, points, save_histories)


def default_points(bridge: ModalBridge, output_points=None) -> np.ndarray:
    """Deck output points (m): the given ones, else the mid-span of every span."""
    if output_points is None:
        s = np.asarray(bridge.supports, float)
        output_points = 0.5 * (s[:-1] + s[1:])
    return np.atleast_1d(np.asarray(output_points, float))


def to_dataset(bridge, train, res: BatchResult, profile, settings, points,
               save_histories, r: int = 0) -> xr.Dataset:
    """Histories and envelopes of run ``r`` of a batch as a Dataset (schema names and
    attrs)."""
    import xarray as xr

    from vsi_numba.io.schema import ENVELOPES, HISTORIES, LOAD_EFFECTS

    effect_names = {f"{p}{e}_{n}" for n in LOAD_EFFECTS for e in ("max", "min")
                    for p in ("", "time_of_")}

    packed = res.packed
    dt = settings.dt
    status = int(res.status[r])
    wheel_pos = res.wheel_positions
    Q0 = res.static_loads
    n_body = packed.vehicles.body_dof.size
    coords = {
        "point": ("point", points, attrs_for("point")),
        "wheel": ("wheel", np.arange(wheel_pos.size), attrs_for("wheel")),
        "vehicle": ("vehicle", np.arange(n_body), attrs_for("vehicle")),
        "wheel_position": ("wheel", wheel_pos, attrs_for("wheel_position")),
        "static_wheel_load": ("wheel", Q0, attrs_for("static_wheel_load")),
    }
    variables = {
        "vehicle_name": ("vehicle", np.array(packed.vehicle_names, dtype=str),
                         attrs_for("vehicle_name")),
    }
    eff = res.effects
    if eff is not None:  # load effects: the whole-deck grid and the supports
        coords["deck_x"] = ("deck_x", eff.grid, attrs_for("deck_x"))
        coords["support"] = ("support", eff.supports, attrs_for("support"))
    for name, val in res.envelopes().items():
        if eff is None and name in effect_names:
            continue  # no load effects for this bridge
        variables[name] = (ENVELOPES[name][0], np.asarray(val[r], float), attrs_for(name))
    if save_histories:
        n = int(res.n_steps[r]) + 1
        coords["time"] = ("time", np.arange(n) * dt, attrs_for("time"))
        for name, val in res.histories(r).items():
            variables[name] = (HISTORIES[name][0], val, attrs_for(name))
    variables["status"] = ((), np.int32(status), attrs_for("status"))
    variables["max_iterations"] = ((), np.int32(res.red.iters[r]),
                                   attrs_for("max_iterations"))
    # one constructor call: assigning variables one by one re-aligns the whole
    # dataset each time and cost more than the time loop of a short run
    ds = xr.Dataset(variables, coords=coords)
    ds.attrs.update(
        status=status,
        message=res.message(r),
        speed=float(res.speeds[r]),
        speed_kmh=float(res.speeds[r] * 3.6),
        train=train.name,
        train_status=train.status,
        dt=float(dt),
        hht_alpha=float(settings.hht_alpha),
        acceleration_cutoff_hz=float(res.cutoff),
        n_steps=int(res.n_steps[r]),
        kernel_seconds=float(res.elapsed),
        profile=profile.label,
        bridge_description=bridge.description,
    )
    return ds


def static_deck_envelope(bridge: ModalBridge, train: Train, output_points, step: float = 0.05
                         ) -> np.ndarray:
    """Maximum static deck displacement (m) at each output point as the train's static
    axle loads pass at crawling speed: sum_j phi_j(x_p) phi_j(x_k) Q_k / w_j^2.

    Uses the same modes as the dynamic analysis, so phi'_dyn compares like with like.
    """
    points = np.atleast_1d(np.asarray(output_points, float))
    if bridge.n_modes == 0:
        return np.zeros(points.size)
    settings = SolverSettings(dt=1e-3, approach=0.0)
    packed = pack(bridge, train, 1.0, None, settings)
    if packed.distributed is None:
        Q = np.concatenate([static_wheel_loads(packed), packed.vehicles.load_p])
        pos = np.concatenate([packed.wheel_positions, packed.load_positions])
    else:  # the moving forces as the track distributes them (bridge.load_distribution)
        Q = np.concatenate([static_wheel_loads(packed), packed.distributed.load_p])
        pos = np.concatenate([packed.wheel_positions,
                              -settings.approach - packed.distributed.load_x0])
    fronts = np.arange(min(0.0, pos.min()), bridge.length + pos.max() + step, step)
    modal = np.empty((fronts.size, bridge.n_modes))
    # only the (front, axle) pairs with the axle on the deck (the shapes are zero off
    # it), found by a search in the sorted positions (a margin of 1 um, then the exact
    # test), summed per front in ascending axle order as before, in blocks of ~1 million
    # pairs: a 20,000-axle list is linear in its length, not quadratic
    order = np.argsort(pos, kind="stable")
    ps = pos[order]
    lo = np.searchsorted(ps, fronts - bridge.length - 1e-6, "left")
    hi = np.searchsorted(ps, fronts + 1e-6, "right")
    cnt = hi - lo
    cum = np.cumsum(cnt)
    start = 0
    while start < fronts.size:
        base = cum[start - 1] if start else 0
        end = max(start + 1, int(np.searchsorted(cum, base + 1_000_000, "right")))
        c = cnt[start:end]
        f_i = np.repeat(np.arange(end - start), c)
        offs = np.arange(f_i.size) - np.repeat(np.cumsum(c) - c, c)
        k_i = order[np.repeat(lo[start:end], c) + offs]
        srt = np.lexsort((k_i, f_i))
        f_i, k_i = f_i[srt], k_i[srt]
        x = fronts[start:end][f_i] - pos[k_i]
        keep = (x >= 0.0) & (x <= bridge.length)
        f_i, k_i, x = f_i[keep], k_i[keep], x[keep]
        phi_q = bridge.shapes(x) * Q[k_i, None]
        modal[start:end] = np.stack(
            [np.bincount(f_i, weights=phi_q[:, j], minlength=end - start)
             for j in range(bridge.n_modes)], axis=1) / bridge.omega**2
        start = end
    w = modal @ bridge.output_shapes(points).T
    return np.max(np.abs(w), axis=0)


def warm_up() -> float:
    """Compile (or load from cache) the kernels; returns the seconds it took."""
    from vsi_numba.model import bridge as br
    from vsi_numba.model import vehicle as vh

    t0 = _time.perf_counter()
    beam = br.simply_supported(10.0, 1e9, 1e4, n_modes=2)
    train = Train("warm-up", (vh.sprung_mass(1e3, 1e6, 1e3, 100.0),), (0.0,))
    simulate(beam, train, 50.0, settings=SolverSettings(dt=5e-3, approach=0.0,
                                                        free_vibration=0.0),
             save_histories=False)
    return _time.perf_counter() - t0
