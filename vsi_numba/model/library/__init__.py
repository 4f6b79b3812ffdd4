"""The train library: EN 1991-2 HSLM-A load models and published multibody trains.

Data come from the package file ``vsi_numba/data/trains.toml`` (provenance, checks and
doubts of every entry: ``docs/manual/trains.md``).  All values are SI (m, kg, N); axle loads
are whole-axle loads (both rails), the convention of the file's ``[whole]`` blocks.

Two models of each real train
-----------------------------
``model="interaction"``
    Multibody vehicles (:func:`~vsi_numba.model.vehicle.railway_car`, 10 DOFs) from the
    ``[whole]`` values, placed at the train's ``vehicle_offsets``.  Coupled junctions are
    separate vehicles.  A run of cars joined by articulated junctions (coincident bogie
    centres, the Eurostar trailers) is ONE vehicle with shared (Jacobs) bogies, see
    :func:`articulated_vehicle`.
``model="moving_force"``
    The static axle loads of that multibody model on rigid level track, as moving point
    forces at the same positions (equal to the file's check values).

HSLM-A1 .. A10 exist as moving forces only (they are load models, not vehicles).

Articulation (open question in docs/manual/trains.md, "Documented doubts")
------------------------------------------------------------------
The data describe a Jacobs bogie TTB-2D style: each of the two cars brings its own
half-bogie with two wheelsets, placed at the same point.  Here each coincident pair
becomes ONE bogie whose mass and pitch inertia are the sums of the two half-bogies', on
two wheelsets whose masses are the sums of the two coincident wheelsets', joined by the
two primary suspensions in parallel (stiffness and damping summed).  Both car bodies'
secondary springs attach to it at its centre.  This is exactly the TTB-2D model with the
coincident half-bogies and wheelsets tied together, so total mass and static axle loads
equal the file's merged check values.  It keeps the possibly doubled unsprung mass
(2 x 1900 kg per axle position) of the data; whether Domenech's masses are per car or
per physical component is not known.

Modules: :mod:`.data` (specs read from the TOML data, name resolution), :mod:`.builders`
(vehicles and trains), :mod:`.tables` (status, doubts, tables), :mod:`.user` (user
train files).
"""

from __future__ import annotations

from vsi_numba.model.library.builders import (
    articulated_vehicle,
    get_train,
    get_vehicle,
    hslm_axle_positions,
    moving_force_train,
    static_axle_loads,
    vehicle_ids,
    vehicle_spec,
)
from vsi_numba.model.library.data import (
    ALIASES,
    MODELS,
    STATUS_MEANING,
    WHOLE_KEYS,
    HslmSpec,
    TrainSpec,
    UnknownTrainError,
    VehicleSpec,
    list_presets,
)
from vsi_numba.model.library.tables import (
    axle_table,
    documented_doubts,
    library_table,
    status_warning,
)
from vsi_numba.model.library.user import (
    clear_user_trains,
    load_user_trains,
)

__all__ = [
    "ALIASES",
    "HslmSpec",
    "MODELS",
    "STATUS_MEANING",
    "TrainSpec",
    "UnknownTrainError",
    "VehicleSpec",
    "WHOLE_KEYS",
    "articulated_vehicle",
    "axle_table",
    "clear_user_trains",
    "documented_doubts",
    "get_train",
    "get_vehicle",
    "hslm_axle_positions",
    "library_table",
    "list_presets",
    "load_user_trains",
    "moving_force_train",
    "static_axle_loads",
    "status_warning",
    "vehicle_ids",
    "vehicle_spec",
]
