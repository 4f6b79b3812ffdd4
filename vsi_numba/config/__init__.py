"""TOML configuration: parse, validate (every error at once), build the model objects.

The keys are the contract of docs/manual/config.md: same names, same meaning, SI
units unless the key says otherwise (``speeds_kmh``).  A config is data only: nothing in
it is evaluated or imported.

Validation runs before any computation and collects *all* problems of a file in one
:class:`ConfigError`.  Each message is one line naming the key path, the bad value and
what was expected, e.g.::

    bridge.spans[1] = -3.0: expected a span length > 0 m
    bridge.spna = [25.0]: unknown key; did you mean 'spans'?

Physically suspicious but legal input (time step too coarse for the retained modes,
modes missing below the EN 1990 A2 cut-off, ...) is reported in :attr:`Config.warnings`.

Keys
----
Every key is declared once, as a field of the models of
:mod:`vsi_numba.config.schema.models` (type, bounds, default, unit, description and the
expectation its error message states); the key reference (docs/reference/config_keys.md),
the JSON Schema (``vsi_numba/config/vsi_config.schema.json``, ``vsi schema``) and the
``vsi init`` template are generated from them, and the section readers take their key
sets and numeric checks from them.

The stored configuration of a results file (attribute config_json, :meth:`Config.resolved`) is
written in these keys, defaults filled in and rules kept as rules, so that it reloads to
the same configuration.

Modules
-------
:mod:`~vsi_numba.config._check` (the validation toolkit and :class:`ConfigError`),
:mod:`~vsi_numba.config.bridge` (with
:mod:`~vsi_numba.config.imported_bridge`), :mod:`~vsi_numba.config.train`,
:mod:`~vsi_numba.config.irregularity`, :mod:`~vsi_numba.config.solver` (``[solver]``,
``[contact]``, ``[track]``), :mod:`~vsi_numba.config.study` and
:mod:`~vsi_numba.config.variants`, :mod:`~vsi_numba.config.fatigue`,
:mod:`~vsi_numba.config.compatibility` (one reader per section),
:mod:`~vsi_numba.config.physics` (warnings and plausibility checks of the whole model,
with :mod:`~vsi_numba.config.track_physics` for the wheel, contact and track springs and
:mod:`~vsi_numba.config.slips` for the unit slips),
:mod:`~vsi_numba.config.limits` (their caps and thresholds) and
:mod:`~vsi_numba.config.core` (:class:`Config`, :func:`load_config`);
:mod:`~vsi_numba.config.schema` (the declared keys and what is generated from them).

Example
-------
>>> cfg = load_config("configs/quickstart.toml")            # doctest: +SKIP
>>> bridge, trains = cfg.build_bridge(), cfg.trains()        # doctest: +SKIP
"""

# the names other modules and tests import from vsi_numba.config
# ruff: noqa: F401
from vsi_numba.config._check import _BAD, _MISSING, ConfigError, _Checker, _show
from vsi_numba.config.bridge import (
    BRIDGE_KINDS,
    EN_DAMPING,
    FLEXIBILITY_WARNING,
    MAX_TRACK_DOFS,
    MIN_SPAN,
    TRACK_TYPES,
)
from vsi_numba.config.core import Config, _validate, load_config
from vsi_numba.config.imported_bridge import MAX_FIXED_DOFS
from vsi_numba.config.irregularity import DEFECT_KINDS, IRREGULARITY_KINDS, _defect_profile
from vsi_numba.config.limits import (
    DT_ERROR,
    DT_RESOLUTION,
    LONG_TRAIN,
    MAX_ELEMENTS,
    MAX_HERTZ_PENETRATION,
    MAX_HISTORY_BYTES,
    MAX_MODES,
    MAX_PROFILE_AMPLITUDE,
    MAX_PROFILE_SAMPLES,
    MAX_SPEEDS,
    MAX_STATIC_DEFLECTION,
    MAX_STEPS,
    MAX_USER_DOFS,
    MAX_VARIANTS,
    MAX_VEHICLES,
    STEPS_PER_WAVELENGTH,
)
from vsi_numba.config.physics import _defects_amplitude
from vsi_numba.config.solver import CONTACT_MODELS, SOLVER_OVERRIDES, TRACK_MODELS
from vsi_numba.config.study import RESONANCE_ORDERS, _line_speed_grid, _speed_grid
from vsi_numba.config.track_physics import HERTZ_LOAD_FACTOR, RIGID_MASSIVE_ALPHA, _train_loads
from vsi_numba.config.train import TRAIN_MODELS, VEHICLE_KINDS
from vsi_numba.config.variants import MASS_FACTOR, _set_path, variant_labels

__all__ = ["Config", "ConfigError", "load_config"]
