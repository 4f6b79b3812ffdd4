"""The verification cases: each writes a TOML config, runs it through the study runner
that ``vsi sweep`` calls, reads the netCDF file it wrote and compares figures with
:mod:`vsi_numba.verification.reference`.

A case is a function ``(workdir) -> list[Row]``; :data:`CASES` lists them in the order of
the manual with the ``quick`` flag of ``vsi verify --quick``.  The cases live by what
they load the bridge with: :mod:`~.moving_forces`, :mod:`~.vehicles`, :mod:`~.effects`
(static load effects at crawl speed) and :mod:`~.space` (decks in space: torsion and
twist); what they share is in :mod:`~.common`; the existing-bridge cases (V21, V22) are
:mod:`vsi_numba.verification.existing`.
"""

from __future__ import annotations

from vsi_numba.verification import existing as _existing
from vsi_numba.verification.cases.common import Case, Row, sweep
from vsi_numba.verification.cases.effects import (
    v03_ss_effects,
    v04_continuous,
    v11_lm71,
)
from vsi_numba.verification.cases.moving_forces import (
    v01_fryba,
    v05_resonance,
    v06_cancellation,
    v07_hslm,
    v13_imported_modes,
    v14_second_resonance,
)
from vsi_numba.verification.cases.space import (
    v16_torsion,
    v17_crawl_twist,
    v18_trains_meeting,
    v19_continuous_twist,
    v20_torque,
)
from vsi_numba.verification.cases.vehicles import (
    v02_yang_wu,
    v08_opensees_dip,
    v09_quarter_car,
    v10_bump_stop,
    v12_order,
    v15_opensees_s1,
)

__all__ = ["CASES", "Case", "Row", "sweep"]

CASES: tuple[Case, ...] = (
    Case("V01", "Moving force on a simply supported beam (Frýba)", True, v01_fryba),
    Case("V02", "Sprung mass on a simply supported beam (Yang & Wu)", True, v02_yang_wu),
    Case("V03", "Load effects of a simply supported span at crawl speed", True,
         v03_ss_effects),
    Case("V04", "Load effects of a two-span continuous deck at crawl speed", False,
         v04_continuous),
    Case("V05", "Resonance of a train of equal forces", True, v05_resonance),
    Case("V06", "Cancellation of the resonance of a train of equal forces", False,
         v06_cancellation),
    Case("V07", "HSLM-A1 at resonance on a simply supported span", False, v07_hslm),
    Case("V08", "Lift-off on a rail dip against OpenSees (peer case S2)", False,
         v08_opensees_dip),
    Case("V09", "Quarter car with wheel mass and damping on a damped beam", False,
         v09_quarter_car),
    Case("V10", "Nonlinear suspension: a bump stop that closes over a bump", False,
         v10_bump_stop),
    Case("V11", "LM71 static load effects on a simply supported span", False, v11_lm71),
    Case("V12", "Second-order convergence in the time step (HHT alpha = 0)", False,
         v12_order),
    Case("V13", "A deck imported as a modes table (CSV) under a moving force", False,
         v13_imported_modes),
    Case("V14", "Second resonance of a train of equal forces (v = n0 d / 2)", False,
         v14_second_resonance),
    Case("V15", "Hertz contact and a light wheel against OpenSees (peer case S1)", False,
         v15_opensees_s1),
    Case("V16", "Torsion of a simply supported deck with an eccentric track", False,
         v16_torsion),
    Case("V17", "Crawl twist of a point torque", True, v17_crawl_twist),
    Case("V18", "Trains meeting on a twisting deck", True, v18_trains_meeting),
    Case("V19", "Twist of a continuous deck at crawl speed and at a torsional resonance",
         False, v19_continuous_twist),
    Case("V20", "Torsional moment at crawl speed and at speed", False, v20_torque),
    Case("V21", "Calibration on three synthetic passages: the truth recovered", False,
         lambda w: _existing.v21_calibration(w, Row)),
    Case("V21Q", "Calibration on one synthetic passage (short chain)", True,
         lambda w: _existing.v21_calibration(w, Row, quick=True)),
    Case("V22", "Probability of exceedance at 1e-3: subset simulation and Monte Carlo "
         "against the closed form", False, lambda w: _existing.v22_reliability(w, Row)),
    Case("V22Q", "Probability of exceedance at 0.03 by Monte Carlo against the closed "
         "form", True, lambda w: _existing.v22_reliability(w, Row, quick=True)),
)
