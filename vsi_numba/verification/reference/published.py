"""Published and peer figures of the verification cases, each with its source."""

from __future__ import annotations

#: Frýba, *Vibration of solids and structures under moving loads* (1972/1999), the
#: undamped simply supported beam under a constant force: the largest midspan deflection
#: while the force is on the span over the static ``P L^3 / (48 EI)``, at the speed
#: parameter ``alpha = v / (2 f1 L)`` (``= v / v_cr`` with ``v_cr = 2 f1 L``).  Values as
#: tabulated to 4 decimals from the modal series (60 modes).
FRYBA_DAF = {0.1: 1.0965, 0.3: 1.4105, 0.5: 1.7054, 0.62: 1.7317, 1.0: 1.5487}
FRYBA_SOURCE = ("Frýba (1999), Vibration of solids and structures under moving loads, "
                "ch. 1: undamped simply supported beam, modal series")

#: Yang & Wu (2001): sprung mass 5750 kg, k = 1595 kN/m, on a 25 m simply supported beam
#: (EI = 2.87e9 x 2.9 N m2, 2303 kg/m, undamped) at 100 km/h, smooth rail.
YANG_WU = dict(L=25.0, EI=2.87e9 * 2.9, m=2303.0, mass=5750.0, k=1595e3, v=100.0 / 3.6)
YANG_WU_MIDSPAN = 2.4073e-3  # m, largest midspan deflection (published)
YANG_WU_BODY_ACC = 0.1480  # m/s2, largest body acceleration (published)
YANG_WU_SOURCE = ("Yang & Wu (2001), Int. J. Struct. Stab. Dyn. 1(1); with the peers' "
                  "figures in docs/data/peer_cases.md, case S1")

#: OpenSees WheelRail on case S1 (Hertz contact of a 0.4575 m wheel, 10 kg wheel mass):
#: the largest midspan deflection, +0.16 % on the rigid contact's 2.40732 mm.
S1_OPENSEES_MIDSPAN = 2.41122e-3  # m
S1_OPENSEES_SOURCE = ("OpenSees WheelRail (xara Tcl), 20 Euler FE, Hertz contact, 10 kg "
                      "wheel; docs/data/peer_cases.md, case S1")

#: OpenSees WheelRail (Hertz contact, 500 kg wheel, 3 mm x 0.5 m half-cosine dip at
#: 12.5 m) on the Yang & Wu beam and sprung mass at 100 km/h, dt = 0.1 ms: case S2 of
#: docs/data/peer_cases.md.
S2_MIDSPAN = 2.674e-3  # m
S2_FIRST_LIFT_OFF = 12.28  # m
S2_SOURCE = ("OpenSees WheelRail (Gu, Liu et al. 2018), Newmark, Hertz contact; "
             "docs/data/peer_cases.md, case S2")
