"""Caps and thresholds of the checks: sizes refused at load time, time-step resolution,
run budget and physical plausibility (one place for every number the checks compare)."""

from __future__ import annotations

from vsi_numba.model.irregularity import MAX_SAMPLES

DT_RESOLUTION = 0.1  # dt * f above this: fewer than 10 steps per period (warning)
STEPS_PER_WAVELENGTH = 10  # fewer time steps per shortest irregularity wavelength: warning
MAX_SPEEDS = 10_000  # cap on the number of speeds of one study
MAX_MODES = 1000  # cap on bridge.n_modes
MAX_ELEMENTS = 1000  # cap on spans * elements_per_span (the eigenproblem runs at load time)
MAX_USER_DOFS = 200  # cap on the size of a user vehicle
MAX_VEHICLES = 500  # cap on explicit vehicles
#: The default time step is not halved below this (s): a deck needing less (f3 above
#: 10 kHz) is refused by the budget or the plausibility checks, not run for ever
DT_DEFAULT_MIN = 1e-6
DT_ERROR = 0.25  # dt * f above this (fewer than 4 steps per period): error
MAX_STEPS = 50_000_000  # time steps of the slowest run: above this the run is refused
#: time steps of the slowest run beyond which no override runs it (no machine could)
HARD_MAX_STEPS = 100_000_000_000
#: Longest free vibration of a fatigue run (s): an undamped deck never decays
MAX_FATIGUE_FREE_VIBRATION = 120.0
MAX_OUTPUT_POINTS = 5000  # cap on bridge.output_points
MAX_SPANS = 200  # cap on the number of bridge.spans
MAX_TRACKS = 20  # cap on bridge.tracks
MAX_FIXED_DOFS = 100_000  # cap on bridge.fixed_dofs and vertical_dofs (imported matrices)
MAX_TRACK_DOFS = 4000  # [bridge.track]: deck + rail + sleepers (dense eigensolution at load time)
MAX_HISTORY_BYTES = 2 * 1024**3  # time histories of one run kept in memory: at most 2 GiB
MAX_PROFILE_SAMPLES = MAX_SAMPLES  # samples of one irregularity profile (its FFT included)
MAX_STATIC_DEFLECTION = 1.0 / 50.0  # static deck deflection / span: above this, error
MAX_HERTZ_PENETRATION = 0.010  # m, static Hertz penetration of a wheel: above this, error
MAX_TRACK_DEFLECTION = 0.010  # m, static rail deflection under an axle: above this, error
MAX_TRACK_STIFFNESS = 5e9  # N/m under one axle (30 x the default): above this, error
#: Physical ranges of the [track] values (both rails, per track): outside, error (unless
#: solver.allow_implausible).  Foundation: soft ballast ~3e7 .. stiff slab ~6e8 N/m per m;
#: rails: 2 x S49 7.6e6 .. 2 x UIC60 1.28e7 N m^2; a factor of about 5 of margin each way.
TRACK_RANGES = {"foundation_stiffness": (5e6, 3e9, "N/m per metre of track"),
                "rail_EI": (2e6, 1e8, "N m^2")}
#: Size of the FE rail filter of the mode shapes (nodes x modes): above this, error.
MAX_TRACK_FILTER = 20_000_000
MAX_PROFILE_AMPLITUDE = 0.050  # m, |r| of a profile: above this, error
LONG_TRAIN = 1000.0  # m, a longer train gets a warning
MAX_CONFIG_BYTES = 8 * 1024**2  # a configuration file larger than this is refused unread
MAX_RUNS = 2_000_000  # runs of one study (variants x speeds x trains x realisations)
MAX_VARIANTS = 5000  # cap on the bridge/track/contact variants of one study
#: Unit slips (each refused unless solver.allow_implausible, or warned where legal).
#: A deck mass per length below this (kg/m) is lighter than any railway deck (a single
#: track steel deck without ballast carries about 2-4 t/m): t/m typed as kg/m
MIN_DECK_MASS = 500.0
#: ... refused when, with EI, it also puts f1 above this multiple of the upper limit
#: 94.76 L^-0.748 of EN 1991-2 Fig. 6.10 [R] (22 kg/m instead of 22 t/m: x 31.6)
DECK_FREQUENCY_FACTOR = 2.0
#: Mean static axle load (N) of a train below this: lighter than ~100 kg per axle, kN
#: or tonnes typed as N or kg (railway axles carry 50-250 kN)
MIN_AXLE_LOAD = 1.0e3
#: Mean axle load (N) of an axle-load list in kN below this (3 t per axle; an empty
#: freight wagon's axle carries about 5 t): tonnes typed as kN
MIN_RAILWAY_AXLE_LOAD = 30.0e3
#: Mean static axle load (N) above this (100 t per axle; the heaviest freight axles
#: carry 35-40 t): N typed as kN
MAX_AXLE_LOAD = 1.0e6
#: A line speed, or the fastest speed of a study, below this (km/h) looks like m/s
MIN_STUDY_SPEED_KMH = 100.0
#: A modal damping ratio at or above this (10 % of critical) looks like a percentage
#: (railway decks: 0.5-4 %, EN 1991-2 Table 6.6 [R])
MAX_DAMPING_RATIO = 0.10
#: |eccentricity| (m) above which a track is warned as implausible: the outer tracks of
#: a four-track deck stand about 7 m off its axis.
MAX_ECCENTRICITY = 8.0
