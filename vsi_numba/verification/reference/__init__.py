"""Reference solutions of the verification cases, independent of the rest of vsi_numba.

This package imports numpy and scipy only, never another module of vsi_numba (a test
parses its files, and an import-linter contract of pyproject.toml checks it): the
figures it computes judge the engine, they do not come from it.  Closed forms,
``solve_ivp`` integrations of the coupled equations and published figures, each with
its source.

Conventions: SI units; vertical displacements, velocities and accelerations positive
**down**; contact forces positive in compression; ``x`` from the left support; a force
or vehicle that starts at ``x0`` is at ``x0 + v t``.  Simply supported beam:
mass-normalised modes ``phi_j = sqrt(2/(m L)) sin(j pi x / L)``,
``omega_j = (j pi / L)^2 sqrt(EI/m)``.

The modules: :mod:`~.published` (the published and peer figures), :mod:`~.beam` (the
simply supported beam and moving forces), :mod:`~.vehicles` (vehicles crossing it),
:mod:`~.statics` (influence lines, crawl-speed effects, LM71) and :mod:`~.space` (the
deck in space: torsion and twist).  Every name is read from here
(``vsi_numba.verification.reference.<name>``, as the manual's sources name them).
"""

from __future__ import annotations

from vsi_numba.verification.reference.beam import (
    GRAVITY,
    moving_force_daf,
    moving_force_modal,
    moving_forces_ivp,
    ss_omega,
    ss_shapes,
    train_of_forces,
)
from vsi_numba.verification.reference.published import (
    FRYBA_DAF,
    FRYBA_SOURCE,
    S1_OPENSEES_MIDSPAN,
    S1_OPENSEES_SOURCE,
    S2_FIRST_LIFT_OFF,
    S2_MIDSPAN,
    S2_SOURCE,
    YANG_WU,
    YANG_WU_BODY_ACC,
    YANG_WU_MIDSPAN,
    YANG_WU_SOURCE,
)
from vsi_numba.verification.reference.space import (
    deck_in_space_forces,
    deck_in_space_line,
    deck_in_space_moment,
    deck_in_space_twist,
    fork_spans_crawl_twist,
    fork_spans_twist,
    fork_torsion_channels,
    fork_torsion_frequencies,
    fork_torsion_moving_forces,
    point_torque_twist,
)
from vsi_numba.verification.reference.statics import (
    LM71_AXLE,
    LM71_SPACING,
    LM71_UDL,
    lm71_extreme,
    ss_crawl_effects,
    ss_influence,
    ss_mode_table,
    two_span_crawl_effects,
)
from vsi_numba.verification.reference.vehicles import (
    quarter_car_on_beam,
    sprung_mass_bump_stop_on_rigid_rail,
    sprung_mass_on_beam,
)

__all__ = [
    "FRYBA_DAF",
    "FRYBA_SOURCE",
    "GRAVITY",
    "LM71_AXLE",
    "LM71_SPACING",
    "LM71_UDL",
    "S1_OPENSEES_MIDSPAN",
    "S1_OPENSEES_SOURCE",
    "S2_FIRST_LIFT_OFF",
    "S2_MIDSPAN",
    "S2_SOURCE",
    "YANG_WU",
    "YANG_WU_BODY_ACC",
    "YANG_WU_MIDSPAN",
    "YANG_WU_SOURCE",
    "deck_in_space_forces",
    "deck_in_space_line",
    "deck_in_space_moment",
    "deck_in_space_twist",
    "fork_spans_crawl_twist",
    "fork_spans_twist",
    "fork_torsion_channels",
    "fork_torsion_frequencies",
    "fork_torsion_moving_forces",
    "lm71_extreme",
    "moving_force_daf",
    "moving_force_modal",
    "moving_forces_ivp",
    "point_torque_twist",
    "quarter_car_on_beam",
    "sprung_mass_bump_stop_on_rigid_rail",
    "sprung_mass_on_beam",
    "ss_crawl_effects",
    "ss_influence",
    "ss_mode_table",
    "ss_omega",
    "ss_shapes",
    "train_of_forces",
    "two_span_crawl_effects",
]
