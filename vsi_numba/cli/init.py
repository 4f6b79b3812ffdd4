"""``vsi init``: write a commented starter configuration (it validates and runs as is)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer

#: The starter configuration: a small EN 1991-2 dynamic check that runs in seconds.
#: Every key is explained; the full key reference is docs/reference/configuration.md.
TEMPLATE = '''\
# vsi_numba configuration (TOML). Units: SI (m, s, kg, N) except keys ending in _kmh.
# Check it without running:  vsi check {name}
# Run the study:              vsi sweep {name} --report {stem}_report
title = "EN 1991-2 dynamic check of a 20 m simply supported span"

[bridge]
kind = "simply_supported"      # simply_supported | continuous | rigid | modes_file | matrices
spans = [20.0]                 # m (one value for simply_supported; one per span if continuous)
EI = 3.5e10                    # N m^2 (a number, or one per span)
mass_per_length = 15000.0      # kg/m: deck + ballast + track (f1 = 6.0 Hz here)
damping_ratio = "EN1991-2"     # a number (0.01 = 1 %), one per mode, or the Table 6.6 rule ...
deck_type = "prestressed_concrete"   # ... for this deck type (steel_composite, ...)
additional_damping = true      # EN 1991-2 6.4.6.3.1 (L < 30 m): added for moving forces only
n_modes = 3                    # modes kept (or max_frequency = 30.0, Hz)
track_type = "ballasted"       # ballasted (3.5 m/s2 limit) | direct_fastening (5 m/s2)
# output_points = [5.0, 10.0, 15.0]   # m from the left support; default: mid-span

[train]
# library trains (`vsi trains` lists them): HSLM-A1..A10 are moving forces, ICE3 a
# multibody model (interaction); or [[train.vehicles]] / file = "my_trains.toml"
preset = ["HSLM-A1", "HSLM-A4", "ICE3"]

[irregularity]
kind = "none"                  # none | cosine | step | psd (random track, one per seed) | file
# kind = "psd"
# spectrum = "german_low"
# wavelength_min = 3.0          # m
# wavelength_max = 80.0         # m
# seeds = [1, 2, 3]

[solver]
dt = 1e-3                      # s: at least 10 steps per period of the highest mode
approach = 5.0                 # m of track ahead of the bridge where the train starts
free_vibration = 0.5           # s simulated after the last axle leaves the bridge

[study]
speeds_kmh = {{ start = 200.0, stop = 300.0, step = 50.0 }}   # km/h, or a list
# line_speed_kmh = 250.0        # instead: 140 km/h .. 1.2 x line speed in 5 km/h steps
output = "results/{stem}.nc"   # relative to this file's directory
history_speeds_kmh = [300.0]   # keep time histories for these speeds only
'''

#: ``vsi init --template compatibility``: is this train compatible with this existing
#: bridge?  The bridge of studies/hslm_psc_25m (25 m PSC span, f1 = 5.0 Hz), the ICE3,
#: a line speed of 300 km/h checked up to 1.1 x (330 km/h).
COMPATIBILITY = '''\
# vsi_numba configuration (TOML): compatibility of a train with an existing bridge.
# Units: SI (m, s, kg, N) except keys ending in _kmh.
# Check it without running:  vsi check {name}
# Run it and write the answer: vsi sweep {name} --report {stem}_report
# The report opens with the verdict (compatible or not), the governing check and its
# margin, and the train's dynamic signature against the HSLM-A envelope.
title = "Compatibility of the ICE3 with the 25 m PSC span at 300 km/h + 10 %"

[bridge]                       # the existing bridge, as built
kind = "simply_supported"
spans = [25.0]                 # m
EI = 7.16e10                   # N m^2 -> f1 = 5.0 Hz with 18 t/m
mass_per_length = 18000.0      # kg/m (deck, ballast, track)
damping_ratio = 0.01           # EN 1991-2 Table 6.6, prestressed concrete, L >= 20 m
n_modes = 3                    # all modes up to the EN 1990 A2 cut-off (45 Hz)
output_points = [3.125, 6.25, 9.375, 12.5, 15.625, 18.75, 21.875]   # every L/8
track_type = "ballasted"       # ballasted (3.5 m/s2) | direct_fastening (5 m/s2)

[train]                        # the train under check (`vsi trains` lists the library;
preset = "ICE3"                # `vsi trains ICE3 --signature` shows its signature)

[solver]
dt = 1e-3                      # s
approach = 5.0                 # m

[study]
# from well below the line speed up to speed_factor x line speed (330 km/h here)
speeds_kmh = {{ start = 140.0, stop = 330.0, step = 5.0 }}
output = "results/{stem}.nc"   # relative to this file's directory
history_speeds_kmh = [330.0]

[compatibility]
train = "ICE3"                 # one of the study's trains
line_speed_kmh = 300.0         # maximum line speed at the bridge
# speed_factor = 1.1           # default: the code profile's compatibility_speed_factor
'''

#: Templates of ``vsi init --template``.
TEMPLATES = {"default": TEMPLATE, "compatibility": COMPATIBILITY}


def init_command(path: Path, template: str = "default") -> int:
    """``vsi init [PATH]``: write :data:`TEMPLATE` to ``PATH`` (default ``study.toml``).

    Returns
    -------
    int
        0 written; 2 when ``PATH`` exists (never overwritten), is not a ``.toml`` file
        name or cannot be written.
    """
    pr = Printer()
    path = Path(path)
    if template not in TEMPLATES:
        pr.error(f"--template {template!r}: expected one of {', '.join(TEMPLATES)}")
        return EXIT_USAGE
    if path.suffix.lower() != ".toml":
        pr.error(f"{path}: expected a file name ending in .toml")
        return EXIT_USAGE
    from vsi_numba.io.paths import path_length_problem

    problem = path_length_problem(path, "configuration", "choose a shorter name")
    if problem is not None:
        pr.error(problem)
        return EXIT_USAGE
    if path.exists() or path.is_symlink():
        pr.error(f"{path} exists: refusing to overwrite it; give another file name "
                 "(vsi init NEW.toml) or remove it first")
        return EXIT_USAGE
    text = TEMPLATES[template].format(name=str(path), stem=path.stem)
    try:
        with path.open("x", encoding="utf-8") as f:  # "x": never replaces a file
            f.write(text)
    except OSError as exc:
        pr.error(f"cannot write {path}: {exc.strerror or exc}")
        return EXIT_USAGE
    pr.line(f"wrote {path}: check it with `vsi check {path}`, run it with "
            f"`vsi sweep {path}`")
    return 0
