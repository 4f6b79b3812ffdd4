"""What a study computes from: the validated configuration (:class:`StudySpec`, what a
worker receives) and the model built from it once per process (:class:`StudyModel`:
bridge, trains, profiles, deck operators), its run grid, batch plan and fingerprints,
and the coordinates of a parametric study's variants."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsi_numba.study.grid import StudyGrid, history_mask, make_grid, profile_range


@dataclass(frozen=True)
class StudyModel:
    """Everything a batch needs, rebuilt from the resolved configuration."""

    config: object
    bridge: object
    trains: tuple
    settings: object
    output_points: np.ndarray
    profiles: dict
    x_range: tuple[float, float]
    speeds_kmh: np.ndarray
    deck: tuple  # (phi_d, phi_a, cut-off Hz) at the output points
    #: the speeds (m/s) of the configuration (:attr:`vsi_numba.config.Config.speeds_m_s`)
    speeds_m_s: np.ndarray


@dataclass(frozen=True)
class StudySpec:
    """What a worker needs to build a study's model: the validated configuration.

    ``config`` is the :class:`~vsi_numba.config.Config` itself (without its variants,
    each of which has a spec of its own): a worker builds the model from it and never
    validates the file again.  ``config_json`` (the resolved configuration) and
    ``base_dir`` (the directory its relative paths resolve against) are what a spec is
    compared and hashed by, so that the per-process model cache keeps one model per
    configuration whatever copy of the spec a task carries.
    """

    config_json: str
    base_dir: str
    config: Any = field(default=None, compare=False, repr=False)


def study_spec(config) -> StudySpec:
    """:class:`StudySpec` of a ``Config``, a resolved-config dict or JSON string, or a spec.

    Dicts and JSON strings resolve relative paths against the working directory; they
    are validated when the model is first built (:func:`study_model`, once per process):
    a study (:func:`~vsi_numba.study.runner.run_study`) validates its file first and
    hands its workers the ``Config``.
    """
    if isinstance(config, StudySpec):
        return config
    if isinstance(config, str):
        return StudySpec(config, str(Path.cwd()))
    if isinstance(config, dict):
        return StudySpec(json.dumps(config, sort_keys=True, separators=(",", ":")),
                         str(Path.cwd()))
    return StudySpec(config.to_json(), str(config.base_dir), config.without_variants())


def _load(config):
    """Return a ``Config`` from a path, mapping, :class:`StudySpec` or ``Config``."""
    from vsi_numba.config import load_config

    if isinstance(config, StudySpec):
        if config.config is not None:
            return config.config
        return load_config(json.loads(config.config_json), base_dir=config.base_dir)
    if isinstance(config, str | os.PathLike | dict):
        return load_config(config)
    return config


_MODELS: dict = {}
#: Models a process keeps built (the oldest goes first).
MODEL_CACHE_SIZE = 4


def study_model(spec: StudySpec) -> StudyModel:
    """Build (once per process) the bridge, trains and profiles of a configuration."""
    model = _MODELS.get(spec)
    if model is None:
        model = _build_model(_load(spec))
        if len(_MODELS) >= MODEL_CACHE_SIZE:
            _MODELS.pop(next(iter(_MODELS)))
        _MODELS[spec] = model
    return model


def _remember(spec: StudySpec, model: StudyModel) -> None:
    """Seed the per-process model cache (the parent built the model already)."""
    _MODELS[spec] = model


def _first_realisation(cfg):
    """``cfg`` with only its first PSD seed
    (:meth:`vsi_numba.config.Config.first_realisation`)."""
    return cfg.first_realisation()


def _build_model(cfg, first_realisation: bool = False) -> StudyModel:
    """The model of ``cfg``; ``first_realisation``: the profile of its first track
    realisation only (the rest of the model is the same)."""
    from vsi_numba.config.physics import train_extent
    from vsi_numba.solver.simulate import deck_operators, default_points

    bridge = cfg.build_bridge()
    trains = tuple(cfg.trains())
    settings = cfg.solver_settings()
    x_range = profile_range(bridge.length, [train_extent(t) for t in trains],
                            settings.approach,
                            settings.free_vibration)
    others = getattr(cfg, "other_trains", []) or []
    together = bool(others) and any(v.n_dof > 0 for t in trains for v in t.vehicles)
    if together:  # interaction trains on other tracks run in the same run: the profile
        # covers where each starts and ends (an offset further back, from either end)
        x_range = several_trains_range(x_range, bridge.length, trains, settings, others)
    profiles = dict((_first_realisation(cfg) if first_realisation else cfg).irregularities(
        *x_range))
    points = default_points(bridge, cfg.output_points)
    deck = deck_operators(bridge, points, settings, load_effects=cfg.load_effects)
    space = getattr(cfg, "deck_in_space", None)
    if space is not None:  # per-track rows under the deck's (solver.batch.SpaceLayout)
        from vsi_numba.solver.batch import space_operators

        deck = space_operators(space, points, deck, int(cfg.train_track) - 1,
                               one_track_loaded=not together,
                               lines=together_lines(cfg, others) if together else None)
    return StudyModel(cfg, bridge, trains, settings, points, profiles, x_range,
                      np.asarray(cfg.speeds_kmh, float), deck,
                      np.asarray(cfg.speeds_m_s, float))


def together_lines(cfg, others) -> list[int] | None:
    """The tracks (0-based) of the track lines of a run with interaction trains on
    several tracks (:func:`~vsi_numba.study.batches._packed_together`: line k is track
    k + 1), for the mode-acceleration channels with each load on its own track; None
    when a train runs at a speed of its own (the moving torque's speed factor of the
    static part is the run's speed's for every load)."""
    if any(float(o.get("speed_factor", 1.0)) != 1.0 for o in others):
        return None
    n_tracks = max([int(cfg.train_track), *(int(o["track"]) for o in others)])
    return list(range(n_tracks))


def several_trains_range(x_range, length, trains, settings, others) -> tuple[float, float]:
    """The profile range of a run with interaction trains on several tracks: ``x_range``
    widened to where the trains start (``offset`` further back, a train in -x beyond the
    far end) and end (the free vibration at the speed bound, in either direction; with
    ``speed_factor`` s the fastest train travels max s / min s times the slowest one's
    way on the deck, and its free vibration at max s times the bound)."""
    from vsi_numba.config.physics import train_extent
    from vsi_numba.model.irregularity import SPEED_BOUND_KMH

    ext = max(train_extent(t) for t in trains)
    back = settings.approach + max(float(o["offset"]) for o in others) + ext + 1.0
    factors = [1.0, *(float(o.get("speed_factor", 1.0)) for o in others)]
    fast, ratio = max(factors), max(factors) / min(factors)
    run = ((ratio - 1.0) * (length + back)
           + fast * SPEED_BOUND_KMH / 3.6 * settings.free_vibration + ext + 1.0)
    return (min(x_range[0], -back, -run), max(x_range[1], length + back, length + run))


def model_fingerprint(model: StudyModel) -> str:
    """SHA-256 of the numbers the cases are computed from.

    The configuration's hash does not see data it only names: a train preset (library
    data), a profile file, the bridge built by this version.  This hash covers the built
    bridge, trains, profiles, solver settings and output points, so a store is refused
    when any of them changed even if the configuration text did not.
    """

    h = hashlib.sha256()

    def add(value):
        if isinstance(value, np.ndarray) and value.dtype.kind in "biufc":
            a = np.ascontiguousarray(value)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
            if " at 0x" in text:  # an object without a stable repr: its type only
                text = type(value).__qualname__
            h.update(text.encode())

    def add_fields(obj):
        if dataclasses.is_dataclass(obj):
            for f in dataclasses.fields(obj):
                add(f.name)
                add_fields(getattr(obj, f.name))
        elif isinstance(obj, tuple | list):
            for item in obj:
                add_fields(item)
        else:
            add(obj)

    add_fields(model.bridge)
    add_fields(model.trains)
    for rid, p in model.profiles.items():
        add(rid)
        add(float(p.x0))
        add(float(p.dx))
        add(p.coef)
    add(repr(model.settings))
    add(model.output_points)
    return h.hexdigest()


def study_grid(model: StudyModel) -> StudyGrid:
    """Return the run grid of a configuration (deterministic order)."""
    cfg = model.config
    hist = history_mask(cfg.speeds_kmh, bool(cfg.save_time_histories),
                        getattr(cfg, "history_speeds_kmh", None))
    return make_grid(cfg.speeds_kmh, [t.name for t in model.trains], list(model.profiles),
                     hist, cfg.speeds_m_s)


def coordinate_name(key_path: str) -> str:
    """netCDF name of the variant coordinate of a varied key path
    (``bridge.track.pad_stiffness`` -> ``bridge_track_pad_stiffness``)."""

    return re.sub(r"[^A-Za-z0-9_]+", "_", key_path).strip("_")


#: Units of the usual varied keys (the variant coordinates' ``units``).
VARY_UNITS = {"EI": "N m2", "mass_per_length": "kg m-1", "damping_ratio": "1", "spans": "m",
              "hertz_coefficient": "m N-2/3", "pad_stiffness": "N m-1",
              "ballast_stiffness": "N m-1", "rail_EI": "N m2", "mass_factor": "1",
              "dt": "s", "hht_alpha": "1", "n_modes": "1"}


def variant_coords(labels: list[dict]) -> dict:
    """The ``variant`` coordinates of a study: one per varied key path."""
    from vsi_numba.config import MASS_FACTOR

    coords = {}
    for key in labels[0]:
        values = [lab[key] for lab in labels]
        if all(isinstance(v, list) and len(v) == 1 for v in values):
            values = [v[0] for v in values]  # e.g. the one span of a simply supported deck
        numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
        if key == "label":
            coords["label"] = (np.array([str(v) for v in values], dtype=object),
                               {"units": "1", "long_name": "label of the variant "
                                "(study.vary_together label)"})
            continue
        leaf = key.split(".")[-1].split("[")[0]
        attrs = {"units": VARY_UNITS.get(leaf, "1"), "key_path": key,
                 "long_name": (f"varied configuration key {key}" if key != MASS_FACTOR else
                               "factor on bridge.mass_per_length (study.mass_bounds)")}
        if numeric:
            coords[coordinate_name(key)] = (np.asarray(values, float), attrs)
        else:
            coords[coordinate_name(key)] = (np.array([json.dumps(v) for v in values],
                                                     dtype=object), attrs)
    return coords
