"""The fatigue train types of EN 1991-2 Annex D as moving-force trains.

Names ``AnnexD-1`` .. ``AnnexD-12``.  Each train is rebuilt from the totals recalled in
:data:`vsi_numba.code_profile.ANNEX_D_TYPES` (total load, length first to last axle)
and the layout of :data:`~vsi_numba.code_profile.ANNEX_D_LAYOUT`: the locomotives as
listed, then equal cars whose axle load makes the total and whose length makes the
train's length.  Every vehicle has two bogies whose centres are 0.7 of its length apart
(a six-axle locomotive: two three-axle bogies).  The axle layout is therefore a
*reconstruction* (data status ``reconstruction``): the total, the mean load per metre
and the speed are those of Table D.1 [R]; the individual spacings of Fig. D.1 are not.
"""

from __future__ import annotations

import re

import numpy as np

from vsi_numba.code_profile import ANNEX_D_CLAUSE, ANNEX_D_LAYOUT, ANNEX_D_MIXES, ANNEX_D_TYPES
from vsi_numba.model.vehicle import Train, point_loads

#: Name prefix of the Annex D trains.
PREFIX = "AnnexD-"
#: Data status of the Annex D trains (the axle layouts are reconstructed).
STATUS = "reconstruction"
_NAME = re.compile(r"^\s*annex\s*d[-_ ]?(?:type[-_ ]?)?(\d+)\s*$", re.IGNORECASE)


def names() -> list[str]:
    """``AnnexD-1`` .. ``AnnexD-12``."""
    return [f"{PREFIX}{k}" for k in ANNEX_D_TYPES]


def type_of(name: str) -> int | None:
    """The Annex D type number of a name (``AnnexD-5``, ``annex d type 5``), else None."""
    m = _NAME.match(str(name))
    if m is None or int(m.group(1)) not in ANNEX_D_TYPES:
        return None
    return int(m.group(1))


def _vehicle_axles(length: float, n_axles: int, wheelbase: float) -> np.ndarray:
    """Axles of one vehicle, m from its front buffer: two bogies of n_axles / 2 axles."""
    per = n_axles // 2
    centres = 0.5 * length + np.array([-0.35, 0.35]) * length
    bogie = (np.arange(per) - 0.5 * (per - 1)) * wheelbase
    return np.concatenate([c + bogie for c in centres])


def annex_d_train(kind: int | str) -> Train:
    """The Annex D train of type ``kind`` (number or name) as moving forces."""
    k = kind if isinstance(kind, int) else type_of(kind)
    if k not in ANNEX_D_TYPES:
        raise KeyError(f"{kind!r}: expected an EN 1991-2 Annex D train type "
                       f"({', '.join(names())})")
    desc, total_kn, _speed, length = ANNEX_D_TYPES[k]
    (n_loco, loco_axles, loco_kn, loco_len), (n_car, car_axles), wb = ANNEX_D_LAYOUT[k]
    car_kn = (total_kn - n_loco * loco_axles * loco_kn) / (n_car * car_axles)

    def layout(car_len):
        pos, load, x = [], [], 0.0
        half = n_loco // 2 if n_loco > 1 else n_loco  # a second locomotive at the rear
        seq = ([("loco", loco_len)] * half + [("car", car_len)] * n_car
               + [("loco", loco_len)] * (n_loco - half))
        for kind_, ln in seq:
            if kind_ == "loco":
                a = _vehicle_axles(ln, loco_axles, wb)
                q = loco_kn
            else:
                a = _vehicle_axles(ln, car_axles, wb)
                q = car_kn
            pos.append(x + a)
            load.append(np.full(a.size, q))
            x += ln
        p = np.concatenate(pos)
        return p - p[0], np.concatenate(load)

    # the first-to-last-axle length is linear in the car length: two evaluations
    l1 = layout(20.0)[0][-1]
    l2 = layout(30.0)[0][-1]
    car_len = 20.0 + (length - l1) * 10.0 / (l2 - l1)
    pos, load = layout(car_len)
    name = f"{PREFIX}{k}"
    veh = point_loads(pos, load * 1e3, name=name, status=STATUS)
    return Train(name, (veh,), (0.0,), status=STATUS, regular_length=float(car_len))


def max_speed_kmh(kind: int | str) -> float:
    """The train type's speed of Table D.1 [R] (km/h)."""
    k = kind if isinstance(kind, int) else type_of(kind)
    return float(ANNEX_D_TYPES[k][2])


def mix(name: str) -> list[tuple[str, float, float]]:
    """An Annex D traffic mix as (train name, speed km/h, trains per day)."""
    if name not in ANNEX_D_MIXES:
        raise KeyError(f"{name!r}: expected one of {', '.join(ANNEX_D_MIXES)}")
    return [(f"{PREFIX}{k}", max_speed_kmh(k), float(n)) for k, n in
            ANNEX_D_MIXES[name].items()]


#: Clause of the data (for reports).
CLAUSE = ANNEX_D_CLAUSE
