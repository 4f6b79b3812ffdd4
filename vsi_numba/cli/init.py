"""``vsi init``: write a commented starter configuration (it validates and runs as is)."""

from __future__ import annotations

from pathlib import Path

from vsi_numba.cli.common import EXIT_USAGE, Printer
from vsi_numba.config.schema.generate import Raw, template

#: The values of the starter configuration: a small EN 1991-2 dynamic check that runs in
#: seconds.  Every other key of each table is listed commented out, with its default, unit
#: and description, from the declared keys (:mod:`vsi_numba.config.schema.models`).
STARTER = {
    "": {"title": "EN 1991-2 dynamic check of a 20 m simply supported span"},
    "bridge": {"kind": "simply_supported", "spans": [20.0], "EI": Raw("3.5e10"),
               "mass_per_length": 15000.0, "damping_ratio": "EN1991-2",
               "deck_type": "prestressed_concrete", "additional_damping": True, "n_modes": 3,
               "track_type": "ballasted"},
    "train": {"preset": ["HSLM-A1", "HSLM-A4", "ICE3"]},
    "irregularity": {"kind": "none"},
    "solver": {"dt": Raw("1e-3"), "approach": 5.0, "free_vibration": 0.5},
    "study": {"speeds_kmh": Raw("{ start = 200.0, stop = 300.0, step = 50.0 }"),
              "output": Raw('"results/@STEM@.nc"'), "history_speeds_kmh": [300.0]},
}
_HEADER = """\
# vsi_numba configuration (TOML). Units: SI (m, s, kg, N) except keys ending in _kmh.
# Check it without running:  vsi check @NAME@
# Run the study:              vsi sweep @NAME@ --report @STEM@_report
# Every key: docs/reference/config_keys.md; editor completion: `vsi schema` (JSON Schema).
# The commented keys show their defaults ("...": a rule or none, see the key reference).
"""


def _template(values=None, header=None) -> str:
    text = template(STARTER if values is None else values,
                    _HEADER if header is None else header)
    text = text.replace("{", "{{").replace("}", "}}")
    return text.replace("@NAME@", "{name}").replace("@STEM@", "{stem}")


#: The starter configuration (``str.format`` with ``name`` and ``stem``), generated from
#: :data:`STARTER` and the declared keys.
TEMPLATE = _template()

#: ``vsi init --template compatibility``: is this train compatible with this existing
#: bridge?  The bridge of studies/hslm_psc_25m (25 m PSC span, f1 = 5.0 Hz), the ICE3,
#: a line speed of 300 km/h checked up to 1.1 x (330 km/h).
COMPATIBILITY_VALUES = {
    "": {"title": Raw('"Compatibility of the ICE3 with the 25 m PSC span at 300 km/h + 10 %"')},
    "bridge": {"kind": "simply_supported", "spans": [25.0], "EI": Raw("7.16e10"),
               "mass_per_length": 18000.0, "damping_ratio": 0.01, "n_modes": 3,
               "output_points": [3.125, 6.25, 9.375, 12.5, 15.625, 18.75, 21.875],
               "track_type": "ballasted"},
    "train": {"preset": "ICE3"},
    "solver": {"dt": Raw("1e-3"), "approach": 5.0},
    "study": {"speeds_kmh": Raw("{ start = 140.0, stop = 330.0, step = 5.0 }"),
              "output": Raw('"results/@STEM@.nc"'), "history_speeds_kmh": [330.0]},
    "compatibility": {"train": "ICE3", "line_speed_kmh": 300.0},
}
_COMPATIBILITY_HEADER = """\
# vsi_numba configuration (TOML): compatibility of a train with an existing bridge.
# Units: SI (m, s, kg, N) except keys ending in _kmh.
# Check it without running:  vsi check @NAME@
# Run it and write the answer: vsi sweep @NAME@ --report @STEM@_report
# The report opens with the verdict (compatible or not), the governing check and its
# margin, and the train's dynamic signature against the HSLM-A envelope.
# The bridge, as built: a 25 m prestressed concrete span, EI and 18 t/m give f1 = 5.0 Hz,
# damping 1 % (EN 1991-2 Table 6.6, L >= 20 m), outputs every L/8. The train under check:
# `vsi trains` lists the library, `vsi trains ICE3 --signature` shows its signature.
# The speeds go from well below the line speed up to speed_factor x line speed (330 km/h).
# Every key: docs/reference/config_keys.md; editor completion: `vsi schema` (JSON Schema).
"""

#: ``vsi init --template compatibility`` (``str.format`` with ``name`` and ``stem``),
#: generated from :data:`COMPATIBILITY_VALUES` and the declared keys.
COMPATIBILITY = _template(COMPATIBILITY_VALUES, _COMPATIBILITY_HEADER)

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
    from vsi_numba.io.atomic import describe, write_text_atomic

    try:  # whole or not at all, and never over a file (one made meanwhile included)
        write_text_atomic(path, text, exclusive=True)
    except FileExistsError:
        pr.error(f"{path} exists: refusing to overwrite it; give another file name "
                 "(vsi init NEW.toml) or remove it first")
        return EXIT_USAGE
    except OSError as exc:
        pr.error(f"cannot write {path}: {describe(exc)}; nothing was written")
        return EXIT_USAGE
    pr.line(f"wrote {path}: check it with `vsi check {path}`, run it with "
            f"`vsi sweep {path}`")
    return 0
