"""The validated configuration: :class:`Config` and :func:`load_config` (TOML reading, the
section readers in file order, the whole-model checks, the variants)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vsi_numba.config import existing as _existing
from vsi_numba.config._check import (
    _BAD,
    ConfigError,
    _Checker,
    _drop_none,
    _ok,
    _refuse,
    _show,
)
from vsi_numba.config._errors import typed_file, typed_section
from vsi_numba.config.across import (
    _distribution_checks,
    _other_train_checks,
)
from vsi_numba.config.bridge import EN_DAMPING, MIN_SPAN, _bridge_section, _BridgeSpec
from vsi_numba.config.code_profile import (
    _code_profile_section,
    _damping_rules,
    _hslm_applicability,
    profile_of_section,
)
from vsi_numba.config.compatibility import _compatibility_section
from vsi_numba.config.fatigue import _fatigue_section, fatigue_budget
from vsi_numba.config.imported_bridge import _files_of_a_refused_deck
from vsi_numba.config.irregularity import (
    _check_file_coverage,
    _defect_profile,
    _irregularity_section,
    _IrregularitySpec,
)
from vsi_numba.config.limits import MAX_RUNS
from vsi_numba.config.physics import (
    _default_time_step,
    _physics_warnings,
    _plausibility,
)
from vsi_numba.config.report import _report_section
from vsi_numba.config.schema import VsiConfig
from vsi_numba.config.solver import (
    SOLVER_OVERRIDES,
    _contact_section,
    _rail_track_section,
    _solver_section,
)
from vsi_numba.config.study import (
    _refine_resonance,
    _study_section,
    _StudySpec,
    refined_speeds,
    speeds_m_s,
)
from vsi_numba.config.toml_file import _read_toml
from vsi_numba.config.track_physics import _track_plausibility
from vsi_numba.config.train import _train_section, _TrainSpec
from vsi_numba.config.variants import _build_variants, merge_variant_warnings
from vsi_numba.model import bridge as _bridge
from vsi_numba.model import distribution as _dist
from vsi_numba.model import irregularity as _irr
from vsi_numba.model import track as _track
from vsi_numba.model import vehicle as _veh
from vsi_numba.solver.settings import SolverSettings


class Config:
    """A validated configuration (build it with :func:`load_config`).

    Attributes
    ----------
    title : str
        The run title (default: the file name stem).
    path : pathlib.Path or None
        The config file, or None for a mapping.
    base_dir : pathlib.Path
        Directory relative paths resolve against.
    warnings : list of str
        Physically suspicious but legal input; with ``study.vary``, the warnings of the
        variants, each marked with the variants it concerns unless all have it.
    """

    def __init__(self, *, title: str, path: Path | None, base_dir: Path, resolved: dict,
                 bridge: _BridgeSpec, train: _TrainSpec, irregularity: _IrregularitySpec,
                 solver: dict, study: _StudySpec, warnings, derived: dict | None = None):
        self.title: str = title
        self.path: Path | None = path
        self.base_dir: Path = base_dir
        self.warnings: list[str] = list(warnings)
        #: the warnings as records {"message", "kind", "keys"}; kind "resolution" marks a
        #: time-step resolution warning (the results' checks are then not reliable)
        self.warning_records: list[dict] = [
            {"message": w, "kind": "input", "keys": []} for w in self.warnings]
        #: the warnings of the configuration itself (without ``study.vary`` applied): a
        #: run of the base values (``vsi run``) carries these
        self.base_warning_records: list[dict] = self.warning_records
        self._resolved = resolved
        self._bridge = bridge
        self._train = train
        self._irregularity = irregularity
        self._solver = solver
        self._study = study
        #: what the rules of the input derive (Table 6.6 damping, refined speeds, ...):
        #: not part of the stored configuration, which keeps the rules themselves
        self._derived: dict = dict(derived or {})
        self._built: dict = {}  # track -> the bridge along it (build_bridge)
        #: ``[(labels, Config)]``: the variants of ``study.vary`` (empty: none)
        self.variants: list = []

    @property
    def base_warnings(self) -> list[str]:
        """The warnings of the configuration's own values (without ``study.vary``)."""
        return [str(r["message"]) for r in self.base_warning_records]

    def __repr__(self) -> str:
        """Title and hash."""
        return f"Config(title={self.title!r}, sha256={self.sha256[:12]}...)"

    # -- model
    def build_bridge(self, track: int | None = None) -> _bridge.ModalBridge:
        """Return the bridge model (:class:`~vsi_numba.model.bridge.ModalBridge`) along
        ``track`` (1-based; default ``train.track``).

        Imported bridges (``modes_file``, ``matrices``) are read and checked by
        :func:`load_config` already; this returns that model, with the track of
        ``[track]`` (:attr:`track_model`, :attr:`rail_track`).  A deck in space gives the
        track's line (the axis without torsion).
        """
        track = self.train_track if track is None else int(track)
        if track not in self._built:
            model = self._bridge.model
            space = self._bridge.space
            if space is not None:
                model = space.track_bridge(track - 1)
            if self.rail_track is not None:
                model = dataclasses.replace(model, track=self.rail_track)
            if self.load_distribution is not None:
                model = dataclasses.replace(model, load_distribution=self.load_distribution)
            self._built[track] = model
        return self._built[track]

    @property
    def deck_in_space(self):
        """The deck with its tracks and torsion (:class:`~vsi_numba.model.deck3d.BeamDeck3D`)
        when ``bridge.tracks`` or ``bridge.torsion`` is given, else None."""
        return self._bridge.space

    @property
    def train_track(self) -> int:
        """The track the train runs on (``train.track``, 1-based; default 1)."""
        return int(self._resolved["train"].get("track", 1))

    @property
    def other_trains(self) -> list[dict]:
        """The trains on other tracks in the same run (``train.other_trains``): resolved
        ``{track (1-based), direction ('same' | 'opposite'), offset (m)}``; empty: one
        train per run."""
        return [dict(o) for o in self._resolved["train"].get("other_trains", [])]

    def other_train_models(self) -> list:
        """Per entry of :attr:`other_trains` its own train (``train.other_trains[i].train``,
        moving forces), None where it is the run's train."""
        own = list(self._train.others)
        return own + [None] * (len(self.other_trains) - len(own))

    def other_train_speeds_m_s(self) -> list[float | None]:
        """Per entry of :attr:`other_trains` its own speed in m/s
        (``train.other_trains[i].speed_kmh``, converted by the configuration), None where
        it runs at the run's speed (times its ``speed_factor``)."""
        own = list(self._train.other_speeds_m_s)
        return own + [None] * (len(self.other_trains) - len(own))

    def bridge_on_track(self, train, track: int, direction: str = "same"):
        """:meth:`bridge_for` ``train`` on ``track`` (1-based) of the deck in space; for
        ``direction = 'opposite'`` the deck seen from its far end
        (:func:`vsi_numba.model.bridge.reversed_bridge`): a train running in -x is a
        train running in +x on the reversed deck, and its modal coordinates are the
        deck's own."""
        bridge = self.bridge_for(train, track)
        if direction == "opposite":
            bridge = _bridge.reversed_bridge(bridge)
        return bridge

    @property
    def load_distribution(self) -> _dist.LoadDistribution | None:
        """The distribution of the moving forces by the track (``track.load_distribution``,
        :mod:`vsi_numba.model.distribution`), or None: point forces on the deck line."""
        return _dist.from_track_config(self._resolved.get("track"))

    @property
    def rail_track(self) -> _track.ElasticTrack | None:
        """The rail on its foundation of ``[track]`` (model = 'elastic'), or None: the
        rigid-track idealisation, or the FE track layer of ``[bridge.track]``."""
        if self.track_model != "elastic":
            return None
        track = self._resolved["track"]
        return _track.ElasticTrack(track["foundation_stiffness"], track["rail_EI"],
                                   track["foundation_damping"], track["rail_mass"])

    @property
    def track_model(self) -> str:
        """'elastic' (rail on a foundation), 'rigid' (idealisation) or 'bridge_layer'
        (the FE track layer of ``[bridge.track]``)."""
        if "track" in self._resolved["bridge"]:
            return "bridge_layer"
        return self._resolved["track"]["model"]

    @property
    def output_points(self) -> np.ndarray:
        """Positions of the deck outputs (m from the left end), shape (n_points,)."""
        return self._bridge.output_points.copy()

    def trains(self) -> list[_veh.Train]:
        """Return the trains: one per preset, or one built from explicit vehicles."""
        return list(self._train.trains)

    @property
    def additional_damping(self) -> float:
        """EN 1991-2 6.4.6.3.1 additional damping (fraction) for moving-force trains
        (0 unless ``bridge.additional_damping = true`` and L < 30 m)."""
        return float(self._derived.get("additional_damping", 0.0))

    @property
    def damping_rule(self) -> str | None:
        """The EN 1991-2 Table 6.6 rule ``damping_ratio = 'EN1991-2'`` applied (text), or
        None."""
        return self._derived.get("damping_rule")

    @property
    def additional_damping_rule(self) -> str | None:
        """The EN 1991-2 6.4.6.3.1 rule ``additional_damping = true`` applied (text), or
        None."""
        return self._derived.get("additional_damping_rule")

    @property
    def code_profile(self):
        """The code profile of ``[code_profile]`` (:mod:`vsi_numba.code_profile`; the
        recommended values without the section)."""
        return profile_of_section(self._resolved.get("code_profile"))

    @property
    def damping_ratio(self):
        """The bridge's damping ratio as used: a number or one per mode (the Table 6.6
        value for ``damping_ratio = 'EN1991-2'``); None for a rigid bridge."""
        if "damping_ratio" in self._derived:
            return self._derived["damping_ratio"]
        return self._resolved["bridge"].get("damping_ratio")

    def frequencies_left_out(self, cutoff: float) -> np.ndarray | None:
        """The natural frequencies (Hz) up to ``cutoff`` of the bridge's modes that the
        model does not keep (empty: none is left out); None when the spectrum up to
        the cut-off is not known."""
        return self._bridge.frequencies_left_out(cutoff)

    def bridge_for(self, train, track: int | None = None) -> _bridge.ModalBridge:
        """The bridge a train runs on (along ``track``, default ``train.track``):
        :meth:`build_bridge`, with the additional damping of ``bridge.additional_damping``
        added to every mode when ``train`` is moving forces only (never for interaction
        models, which carry that interaction)."""
        bridge = self.build_bridge(track)
        extra = self.additional_damping
        if extra and all(v.n_dof == 0 for v in train.vehicles):
            return dataclasses.replace(bridge, damping=np.asarray(bridge.damping) + extra)
        return bridge

    def irregularities(self, x_start: float, x_stop: float) -> list[tuple[int, Any]]:
        """Track profiles over ``[x_start, x_stop]`` (m) as ``(realisation id, Profile)``.

        The id is the seed for ``kind = 'psd'`` (one profile per seed) and -1 for the
        deterministic kinds (none, cosine, step, file).  Isolated defects listed in
        ``[[irregularity.defects]]`` are added to every profile.
        """
        r = self._resolved["irregularity"]
        kind = r["kind"]

        def defect(spec):
            return _defect_profile(spec, x_stop)

        extra = [defect(s) for s in r.get("defects", [])]
        if kind == "psd":
            base = [
                (int(seed), _irr.psd_profile(r["spectrum"], r["wavelength_min"],
                                             r["wavelength_max"], int(seed), x_start, x_stop,
                                             r.get("dx")))
                for seed in r["seeds"]
            ]
        elif kind == "file":
            base = [(-1, self._irregularity.file_profile)]
        elif kind == "none":
            base = [(-1, _irr.no_irregularity())]
        else:
            base = [(-1, defect(r))]
        if not extra:
            return base
        return [(i, _irr.combine(p, *extra)) for i, p in base]

    def solver_settings(self) -> SolverSettings:
        """Return the :class:`~vsi_numba.solver.settings.SolverSettings` (SI units).

        The ``[contact]`` keys are part of the settings (``contact_model``,
        ``hertz_coefficient``).
        """
        contact = self._resolved["contact"]
        extra = {}
        if contact["model"] != "rigid":
            extra = {"contact_model": contact["model"],
                     "hertz_coefficient": contact["hertz_coefficient"]}
        fields = {k: v for k, v in self._solver.items() if k not in SOLVER_OVERRIDES}
        return SolverSettings(**fields, **extra)

    # -- study
    @property
    def speeds_kmh(self) -> np.ndarray:
        """Speeds of the study (km/h), shape (n_speeds,)."""
        return np.asarray(self._derived.get("speeds_kmh", self._study.resolved["speeds_kmh"]),
                          float)

    @property
    def speeds_m_s(self) -> np.ndarray:
        """Speeds of the study (m/s), shape (n_speeds,): :attr:`speeds_kmh` / 3.6, the one
        conversion of the speeds (the study and the kernels use these)."""
        return speeds_m_s(self.speeds_kmh)

    @property
    def irregularity_seeds(self) -> tuple[int, ...] | None:
        """The seeds of the random track realisations (``irregularity.seeds``,
        ``kind = 'psd'``), or None for a deterministic profile."""
        irr = self._resolved["irregularity"]
        if irr.get("kind") != "psd":
            return None
        return tuple(int(s) for s in irr["seeds"])

    def first_realisation(self) -> Config:
        """This configuration with only its first random track realisation (a shallow
        copy; ``self`` unchanged), or ``self`` when it has at most one: ``vsi run``
        computes the first realisation only, and a profile depends on its seed and the
        track range alone, so the others need not be generated."""
        import copy

        irr = self._resolved["irregularity"]
        if irr.get("kind") != "psd" or len(irr.get("seeds", ())) <= 1:
            return self
        out = copy.copy(self)
        out._resolved = {**self._resolved,
                         "irregularity": {**irr, "seeds": list(irr["seeds"][:1])}}
        return out

    def without_variants(self) -> Config:
        """This configuration without the variants of ``study.vary`` (a shallow copy, or
        ``self`` when it has none): what one run of the study computes from, small to
        send to a worker process."""
        if not self.variants:
            return self
        import copy

        out = copy.copy(self)
        out.variants = []
        return out

    @property
    def output_path(self) -> Path:
        """The netCDF output file (absolute; relative paths resolve against base_dir)."""
        return self._study.output_path

    @property
    def save_time_histories(self) -> bool:
        """Whether time histories are written (envelopes always are)."""
        return bool(self._study.resolved["save_time_histories"])

    @property
    def load_effects(self) -> bool:
        """Whether the dynamic load effects are computed (when the bridge gives them)."""
        return bool(self._study.resolved.get("load_effects", True))

    @property
    def history_speeds_kmh(self) -> np.ndarray | None:
        """Speeds (km/h) whose time histories are kept; None = every speed."""
        h = self._study.resolved.get("history_speeds_kmh")
        return None if h is None else np.asarray(h, float)

    @property
    def track_type(self) -> str:
        """Track form on the deck: 'ballasted' (3.5 m/s2) or 'direct_fastening' (5 m/s2)."""
        return self._resolved["bridge"].get("track_type", "ballasted")

    @property
    def contact_model(self) -> str:
        """Wheel-rail contact model ('rigid', 'hertz', ...)."""
        return self._resolved["contact"]["model"]

    # -- provenance
    def resolved(self) -> dict:
        """Return the configuration with every default filled in (JSON-serialisable).

        This is the stored configuration (``config_json`` of every results file): the
        input in the input's own keys, so that
        ``load_config(cfg.resolved(), base_dir=cfg.base_dir)`` gives the same
        configuration (same :attr:`sha256`, same study).  Paths stay as written (relative
        to :attr:`base_dir`).  Rules stay rules: ``damping_ratio = "EN1991-2"`` with its
        ``deck_type``, ``additional_damping = true``, ``refine_resonance = true`` next to
        the speeds it refines; what they derive is in :attr:`damping_ratio`,
        :attr:`damping_rule`, :attr:`additional_damping`, :attr:`speeds_kmh` (and in the
        results file's variables).  Reloading it is a fixed point:
        ``load_config(cfg.resolved()).resolved() == cfg.resolved()``.
        """
        return json.loads(json.dumps(self._resolved))

    def to_json(self) -> str:
        """Return the resolved configuration as JSON with sorted keys (stable)."""
        return json.dumps(self._resolved, sort_keys=True, separators=(",", ":"))

    @property
    def sha256(self) -> str:
        """SHA-256 hex digest of :meth:`to_json`."""
        return hashlib.sha256(self.to_json().encode("utf-8")).hexdigest()


def load_config(path_or_mapping, base_dir=None) -> Config:
    """Read and validate a configuration.

    Parameters
    ----------
    path_or_mapping : str, path-like or mapping
        A TOML file, or the already-parsed mapping (same structure).
    base_dir : str or path-like, optional
        Directory that relative paths (profile file, train file, output) resolve
        against; default: the config file's directory, or the working directory for a
        mapping.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        Listing every problem found (key path, bad value, expectation), before any
        computation.
    """
    path = None
    if isinstance(path_or_mapping, Mapping):
        data = path_or_mapping
        source = "<mapping>"
    elif isinstance(path_or_mapping, str | Path):
        path = Path(path_or_mapping).expanduser()
        source = str(path)
        data, errors = _read_toml(path)
        if errors:
            raise ConfigError(errors, source=source)
        path = path.resolve()
    else:
        raise ConfigError([f"config = {_show(path_or_mapping)}: expected a path to a TOML "
                           "file or a mapping"])
    if base_dir is None:
        base = path.parent if path is not None else Path.cwd()
    else:
        base = Path(base_dir).expanduser().resolve()
    cfg = _validate(data, path, base, source)
    _check_run_count(cfg, source)
    if cfg._study.axes:
        speeds = list(cfg._study.resolved["speeds_kmh"])
        cfg.variants = _build_variants(data, cfg._study.axes, _validate, path, base, source,
                                       speeds)
        if cfg._study.resolved.get("refine_resonance"):
            # every variant's resonances (its own f1), on one speed axis for all
            union = cfg._unrefined_speeds
            for _, v in cfg.variants:
                union = refined_speeds(cfg._unrefined_speeds, v._bridge, v._train, union)
            if union != speeds:
                cfg._study.resolved["speeds_kmh"] = union
                cfg._derived["speeds_kmh"] = list(union)  # (stored: the speeds as listed)
                cfg.variants = _build_variants(data, cfg._study.axes, _validate, path, base,
                                               source, union)
        # the study runs the variants, not the base values: their warnings, each marked
        # with the variants it concerns (the base's stay in base_warning_records)
        cfg.warning_records = merge_variant_warnings(cfg.variants)
        cfg.warnings = [r["message"] for r in cfg.warning_records]
    return cfg


def _check_run_count(cfg: Config, source: str) -> None:
    """Refuse a study of more than :data:`MAX_RUNS` runs (variants x speeds x trains x
    realisations, counted in Python integers) before its variants are built."""
    irr = cfg._resolved["irregularity"]
    n_real = len(irr.get("seeds") or [0]) if irr.get("kind") == "psd" else 1
    n_var = math.prod(len(axis[0][1]) for axis in cfg._study.axes) if cfg._study.axes else 1
    n_speed, n_train = len(cfg._study.resolved["speeds_kmh"]), len(cfg.trains())
    n = n_var * n_speed * n_train * n_real
    if n > MAX_RUNS:
        raise ConfigError([f"study: {n} runs ({n_var} variants x {n_speed} speeds x {n_train} "
                           f"trains x {n_real} irregularity realisations): expected at most "
                           f"{MAX_RUNS} runs in one study (split it, or vary fewer values in "
                           "study.vary, study.speeds_kmh, train.preset, irregularity.seeds)"],
                          source=source)


def _validate(data, path: Path | None, base: Path, source: str) -> Config:
    chk = _Checker()
    top = typed_file(chk, data)  # the tables there are, the title
    default_title = path.stem if path is not None else "untitled"
    title = top.title if top is not _BAD else _BAD

    solver = _solver_section(chk, typed_section(chk, data, "solver", VsiConfig))
    contact = _contact_section(chk, typed_section(chk, data, "contact", VsiConfig))
    cutoff = solver["acceleration_cutoff"] if _ok(solver) else None
    bridge = typed_section(chk, data, "bridge", VsiConfig)
    if bridge is _BAD:  # its files are checked with its other errors
        _files_of_a_refused_deck(chk, data["bridge"], base)
    bridge = _bridge_section(chk, bridge, base, cutoff)
    fe_layer = isinstance(data.get("bridge"), dict) and "track" in data["bridge"]
    if fe_layer and "track" in data:
        track = chk.error("track", data["track"], "no [track] with [bridge.track]: the FE "
                          "track layer of the deck is the track")
    else:
        track = _rail_track_section(
            chk, None if fe_layer else typed_section(chk, data, "track", VsiConfig), fe_layer)
    train = _train_section(chk, typed_section(chk, data, "train", VsiConfig), base,
                           title if _ok(title) else None)
    _distribution_checks(chk, track, solver, train)
    if _ok(bridge, train) and "track" in train.resolved and _ok(train.resolved["track"]):
        n_tracks = len(bridge.resolved.get("tracks", [{}]))
        if train.resolved["track"] > n_tracks:
            chk.error("train.track", train.resolved["track"],
                      f"a track of bridge.tracks, 1 .. {n_tracks} (the bridge has "
                      f"{n_tracks} track{'s' if n_tracks != 1 else ''})")
    if _ok(bridge, train) and "other_trains" in train.resolved:
        _other_train_checks(chk, bridge, train)
    irr = _irregularity_section(chk, typed_section(chk, data, "irregularity", VsiConfig),
                                base)
    stem = path.stem if path is not None else "run"
    code_profile = _code_profile_section(
        chk, typed_section(chk, data, "code_profile", VsiConfig, None))
    profile = profile_of_section(code_profile)
    study = _study_section(chk, typed_section(chk, data, "study", VsiConfig),
                           f"results/{stem}.nc", base, profile)
    report = _report_section(chk, typed_section(chk, data, "report", VsiConfig, None))
    fatigue = _fatigue_section(chk, typed_section(chk, data, "fatigue", VsiConfig, None),
                               profile, bridge,
                               study.axes if _ok(study) else (), base)
    compat = _compatibility_section(
        chk, typed_section(chk, data, "compatibility", VsiConfig, None), profile, study, train)
    rest_ok = not chk.errors
    calib = _existing._calibration_section(
        chk, typed_section(chk, data, "calibration", VsiConfig, None), data,
        data.get("calibration"), base, rest_ok, _validate)
    relia = _existing._reliability_section(
        chk, typed_section(chk, data, "reliability", VsiConfig, None), data, base, rest_ok,
        _validate)

    if _ok(bridge, solver, irr) and irr.file_profile is not None:
        _check_file_coverage(chk, irr, -solver["approach"], bridge.length)
    for message in chk.implausible:  # outside a key's plausible range: a unit slip
        _refuse(chk, solver if _ok(solver) else {}, "allow_implausible", message)
    if chk.errors:
        # report in the order of the file's sections (validation order differs)
        order = {k: i for i, k in enumerate(data) if isinstance(k, str)}
        head = re.compile(r"^([^.\[ :=]+)")

        def rank(msg):
            m = head.match(msg)
            return order.get(m.group(1) if m else "", len(order))

        raise ConfigError(sorted(chk.errors, key=rank), source=source)

    bridge = _damping_rules(chk, bridge, profile)
    stored_speeds = list(study.resolved["speeds_kmh"])  # before the refinement
    if study.resolved.get("refine_resonance"):
        _refine_resonance(study.resolved, bridge, train)
    spans = bridge.resolved.get("spans") or []
    if spans and min(spans) < MIN_SPAN:
        # the span is the cause: no time-step or frequency message about its consequences
        _refuse(chk, solver, "allow_implausible", f"bridge.spans = {_show(spans)}: expected "
                f"spans of a railway bridge >= {MIN_SPAN:g} m (units: m)")
        if chk.errors:
            raise ConfigError(chk.errors, source=source)
    _default_time_step(solver, data.get("solver"), bridge)
    _physics_warnings(chk, bridge, train, irr, solver, study, contact, track)
    _plausibility(chk, bridge, train, irr, solver, study, contact)
    _track_plausibility(chk, train, solver, track, bridge)
    _hslm_applicability(chk, bridge, train, solver, profile, _refuse)
    if fatigue:
        fatigue_budget(chk, fatigue, bridge, solver, profile, base, _refuse)
    if chk.errors:  # checks of the whole model (time step, budget, plausibility)
        raise ConfigError(chk.errors, source=source)
    stored_bridge, derived = _stored_bridge(bridge.resolved)
    if study.axes and "output_points" not in data["bridge"]:
        # the default points are the variants' mid-spans: they follow the varied spans
        stored_bridge.pop("output_points", None)
    if stored_bridge.get("kind") == "modes_file" and "damping_ratio" not in data["bridge"]:
        # not given: the file's damping ratios (else 0), which an explicit 0 would replace
        stored_bridge.pop("damping_ratio", None)
    stored_study = dict(study.resolved)
    if stored_study.get("refine_resonance"):
        derived["speeds_kmh"] = stored_study["speeds_kmh"]
        stored_study["speeds_kmh"] = stored_speeds
    resolved = {
        "title": title if title is not None else default_title,
        "bridge": stored_bridge,
        "train": train.resolved,
        "irregularity": irr.resolved,
        "solver": _drop_none(dict(solver)),
        "contact": contact,
        # (none with the FE track layer of [bridge.track]: that layer is the track)
        **({"track": track} if track["model"] != "bridge_layer" else {}),
        "study": stored_study,
        **({"report": report} if report else {}),
        **({"code_profile": code_profile} if code_profile else {}),
        **({"fatigue": fatigue} if fatigue else {}),
        **({"compatibility": compat} if compat else {}),
        **({"calibration": calib} if calib else {}),
        **({"reliability": relia} if relia else {}),
    }
    cfg = Config(
        title=resolved["title"], path=path, base_dir=base, resolved=resolved, bridge=bridge,
        train=train, irregularity=irr, solver=solver, study=study, warnings=chk.warnings,
        derived=derived,
    )
    cfg.warning_records = [dict(r) for r in chk.records]
    cfg.base_warning_records = cfg.warning_records
    cfg._unrefined_speeds = stored_speeds  # the speeds as listed (before refine_resonance)
    return cfg


def _stored_bridge(resolved: dict) -> tuple[dict, dict]:
    """The ``[bridge]`` of the stored configuration (the rules as the input states them)
    and what the rules derived (``damping_ratio``, ``damping_rule``,
    ``additional_damping``, ``additional_damping_rule``)."""
    stored, derived = dict(resolved), {}
    if "damping_rule" in stored:  # damping_ratio = "EN1991-2" with deck_type
        derived["damping_rule"] = stored.pop("damping_rule")
        derived["damping_ratio"] = stored["damping_ratio"]
        stored["damping_ratio"] = EN_DAMPING
    if "additional_damping_rule" in stored:  # additional_damping = true
        derived["additional_damping_rule"] = stored.pop("additional_damping_rule")
        derived["additional_damping"] = stored["additional_damping"]
        stored["additional_damping"] = True
    return stored, derived
