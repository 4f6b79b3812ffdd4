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

Keys (units; default)
---------------------
``title`` (file stem).
``[bridge]`` ``kind`` = simply_supported | continuous | rigid | modes_file (required);
``spans`` (m, one per span; one value for simply_supported and rigid); ``EI`` (N m^2) and
``mass_per_length`` (kg/m), a number or one per span; ``damping_ratio`` (-, a number or
one per mode; 0); ``n_modes`` (simply_supported and continuous: every mode up to the
deck-acceleration cut-off, ``solver.acceleration_cutoff`` or EN 1990 A2 max(30 Hz,
1.5 f1, f3); [bridge.track] and matrices: 10) or ``max_frequency`` (Hz; both: the
smaller set); ``elements_per_span`` (continuous; 40); ``output_points`` (m; every
mid-span).  Imported bridges (formats: :mod:`vsi_numba.model.imported`), read and
checked at load time: modes_file (``file``, netCDF or CSV; ``track_line`` when it has
several; ``mass_normalised`` true when there is no modal_mass; n_modes default: every mode
of the file) | matrices (``stiffness_matrix``, ``mass_matrix`` Matrix Market;
``station_map`` CSV; ``fixed_dofs`` [] = supports already applied; ``dof_base`` 0;
``rotation_sign`` 1; ``vertical_dofs`` station DOFs, or {start, step}; ``track_line``);
both: ``spans`` optional (m along the track line; the table must cover their sum).
``[bridge.track]`` (continuous only; values per track, both rails): ``rail_EI`` (N m^2),
``rail_mass_per_length`` (kg/m), ``pad_stiffness`` (N/m per sleeper), ``pad_damping``
(N s/m; 0), ``sleeper_mass`` (kg), ``sleeper_spacing`` (m), ``ballast_stiffness`` (N/m
per sleeper), ``ballast_damping`` (N s/m; 0), ``rail_elements_per_bay`` (2): a track
layer assembled with the deck before the modal reduction; the train runs on the rail
(see :class:`vsi_numba.model.bridge.TrackLayer` for when it is needed and what it costs:
a warning says how many modes keep 95 % of the rail's static flexibility).
``[train]`` exactly one of ``preset`` (library name or list; one train each), ``file``
(user train TOML, see :func:`vsi_numba.model.library.load_user_trains`) or
``[[train.vehicles]]`` (one train, ``name``: default ``title``, else "custom"); ``model`` =
interaction | moving_force for presets (default: interaction where the library has
vehicle dynamics, moving forces for the HSLM load models); ``hslm_b`` = {``N``, ``d``}
(required with the preset "HSLM-B": N forces of 170 kN at spacing d m, EN 1991-2 Fig.
6.13 [R], within the code profile's range: N 10..20, d 2.5..3.5 m, else refused unless
solver.allow_implausible); ``axles`` = {``file``, ``load_unit`` ("kN" | "N"), ``name``}
adds a moving-force train from an axle-load CSV (columns ``position`` m behind the first
axle, ``load``), alone or next to presets / a file.  A vehicle has ``kind`` =
force (``load``, N) | sprung_mass (``mass``, ``stiffness``, ``damping`` 0,
``wheel_mass`` 0) | car (the [whole] values of ``data/trains.toml`` plus
``body_cg_to_front_bogie``, default mid-way) | user (``M``, ``C``, ``K``, ``wheel_dofs``,
``wheel_positions``, ``gravity`` g diag(M), ``body_dof`` -1); ``offset`` (m behind the
train's first axle; 0) and ``name``.  Vehicles are listed front to back, not overlapping.
``[irregularity]`` ``kind`` = none (default) | cosine (``depth``, ``wavelength``,
``position``, m) | step (``height``, ``length``, ``position``, ``shape`` cosine) | psd
(``spectrum``, ``wavelength_min``, ``wavelength_max``, ``seeds``, ``dx``) | file
(``path``, ``x_column`` x, ``r_column`` r, ``r_unit`` m, ``dx``); ``[[irregularity.defects]]``
(cosine / step) are added to every realisation.
``[solver]`` ``dt`` (s; 1e-3, halved until the highest bridge mode within that cut-off
has 10 steps per period), ``hht_alpha`` (-0.3), ``approach`` (m; 5),
``free_vibration`` (s; 1), ``max_iterations`` (50), ``max_subdivisions`` (4),
``acceleration_cutoff`` (Hz; EN 1990 A2 rule).
``[contact]`` ``model`` = rigid (default) | hertz | hertz_linear (as offered by
:mod:`vsi_numba.solver.settings`), ``hertz_coefficient`` G (m N^-2/3; required for Hertz).
``[track]`` ``model`` = elastic (default: the rail on a Winkler foundation over the deck
and the approaches, :mod:`vsi_numba.model.track`) | rigid (the rigid-track idealisation:
a kink at the deck ends); ``foundation_stiffness`` (N/m per metre of track, both rails;
8.51e7: 150 kN/mm per axle with UIC60 rails), ``rail_EI`` (N m^2, both rails; 1.283e7,
UIC60), ``foundation_damping`` (N s/m per metre of track, 0 .. 2e6; 1.96e5, ballast)
and ``rail_mass`` (kg per metre of track moving with the rail, 0 .. 2000; 0).  Not with
``[bridge.track]``, whose FE track layer is then the track.  ``load_distribution`` =
none (default: moving forces act on the deck directly; the track model applies to
interaction trains only) | rail (EN 1991-2 6.3.6.1 [R]: P/4, P/2, P/4 on three sleepers)
| rail_ballast (and 4:1 through the ballast, 6.3.6.2 [R]) | elastic_track (the
foundation reaction of the elastic track at the sleepers) spreads moving forces
(:mod:`vsi_numba.model.distribution`); ``sleeper_spacing`` (m; 0.6), ``sleeper_width``
(m, at the base; 0.3) and ``ballast_depth`` (m under the sleepers; 0.35) for the kinds
that use them.
``[study]`` ``speeds_kmh`` (list, or {start, stop, step} with stop included when on the
grid) or ``line_speed_kmh`` (then 140 .. 1.2 x line speed, step 5, 1.2 x line speed
included; both: speeds stopping below 1.2 x line speed are warned); ``output``
(results/<stem>.nc); ``save_time_histories`` (true);
``history_speeds_kmh`` (all); ``classification_factor`` (alpha of LM71, 1.0, in the code
profile's range, [0.75, 1.46] by default, EN 1991-2 6.3.2(3) [R]) and
``track_maintenance`` ("standard": Phi_3, "careful": Phi_2, EN 1991-2 6.4.5.2 [R]) for the
load-effect checks of `vsi report`; ``load_effects`` (true: bending moment, shear,
reactions and rotations reduced in the runs).
Also: ``[bridge]`` ``track_type`` = ballasted (default) | direct_fastening (the EN 1990 A2
deck-acceleration limit); ``damping_ratio`` = "EN1991-2" with ``deck_type`` (Table 6.6
lower bound for the span); ``additional_damping`` (false; EN 1991-2 6.4.6.3.1, moving
forces only).  ``[solver]`` ``allow_coarse_dt``, ``allow_implausible``,
``allow_large_problem`` (false; accept what the checks refuse).  ``[study]``
``refine_resonance`` (false; adds the resonance speeds of the trains), ``vary`` (a table
of key paths, each with a list of values), ``vary_together`` (tables of key paths varied
together, optional ``label``), ``mass_bounds`` (factors on ``mass_per_length``): the
variants of a parametric study.
``[code_profile]`` (:mod:`vsi_numba.code_profile`): ``name`` (the profile's name; "EN 1990
A2 / EN 1991-2:2003 recommended values") and ``overrides`` (a table: entry key = a number
in the entry's SI unit, or a table of value and clause naming the rule it comes from): the
clause values of the checks (deck acceleration, comfort, wheel unloading and end rotation
limits, Table 6.6 damping, L_Phi, Phi_2 / Phi_3, phi'', LM71, the alpha range, the HSLM
applicability and HSLM-B's N and d), stored with the results so that `vsi report` uses the
study's profile.
``[fatigue]`` (:mod:`~vsi_numba.config.fatigue`): ``design_life_years`` (100), ``mix``
(none; "standard", "heavy" or "light": an EN 1991-2 Annex D traffic mix [R] at the Table
D.1 speeds), ``[[fatigue.sections]]`` with ``x`` (m), ``section_modulus`` (m^3, stress =
M / W), ``detail_category`` (MPa, EN 1993-1-9), ``gamma_Ff`` and ``gamma_Mf`` (the code
profile's, 1.0 and 1.35) and ``name``; ``[[fatigue.traffic]]`` with ``train`` (a library
train, AnnexD-1 .. AnnexD-12 or an axle-load CSV file), ``speed_kmh``, ``per_day`` and
``model`` ("moving_force"): one run per train after the sweep, rainflow, Miner's damage
over the design life (results variable fatigue_damage).
``[compatibility]`` (:mod:`~vsi_numba.config.compatibility`): ``train`` (one of the
study's trains), ``line_speed_kmh`` and ``speed_factor`` (the code profile's 1.1): the
report answers whether the train is compatible with the bridge at speeds up to
``speed_factor`` x ``line_speed_kmh``, which the study's speeds must reach.
The stored configuration of a results file (attribute config_json, :meth:`Config.resolved`) is
written in these keys, defaults filled in and rules kept as rules, so that it reloads to
the same configuration.

Modules
-------
:mod:`~vsi_numba.config._check` (the validation toolkit and :class:`ConfigError`),
:mod:`~vsi_numba.config.bridge`, :mod:`~vsi_numba.config.train`,
:mod:`~vsi_numba.config.irregularity`, :mod:`~vsi_numba.config.solver` (``[solver]``,
``[contact]``, ``[track]``), :mod:`~vsi_numba.config.study` and
:mod:`~vsi_numba.config.variants`, :mod:`~vsi_numba.config.fatigue`,
:mod:`~vsi_numba.config.compatibility` (one reader per section),
:mod:`~vsi_numba.config.physics` (warnings and plausibility checks of the whole model),
:mod:`~vsi_numba.config.limits` (their caps and thresholds) and
:mod:`~vsi_numba.config.core` (:class:`Config`, :func:`load_config`).

Example
-------
>>> cfg = load_config("configs/quickstart.toml")            # doctest: +SKIP
>>> bridge, trains = cfg.build_bridge(), cfg.trains()        # doctest: +SKIP
"""

# the names other modules and tests import from vsi_numba.config
# ruff: noqa: F401
from vsi_numba.config._check import _BAD, _MISSING, ConfigError, _Checker, _Num, _show
from vsi_numba.config.bridge import (
    BRIDGE_KINDS,
    EN_DAMPING,
    FLEXIBILITY_WARNING,
    MAX_FIXED_DOFS,
    MAX_TRACK_DOFS,
    MIN_SPAN,
    TRACK_TYPES,
)
from vsi_numba.config.core import Config, _validate, load_config
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
from vsi_numba.config.physics import (
    HERTZ_LOAD_FACTOR,
    RIGID_MASSIVE_ALPHA,
    _defects_amplitude,
    _train_loads,
)
from vsi_numba.config.solver import CONTACT_MODELS, SOLVER_OVERRIDES, TRACK_MODELS
from vsi_numba.config.study import RESONANCE_ORDERS, _line_speed_grid, _speed_grid
from vsi_numba.config.train import TRAIN_MODELS, VEHICLE_KINDS
from vsi_numba.config.variants import MASS_FACTOR, _set_path, variant_labels

__all__ = ["Config", "ConfigError", "load_config"]
