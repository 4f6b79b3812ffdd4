"""The study runner: speeds x trains x irregularity realisations, resumable, parallel.

Flow of :func:`run_study`
1. load and resolve the configuration; build the model once (bridge, trains, profiles,
   deck operators), the run grid (:mod:`.grid`) and its batch plan (:mod:`.batches`);
2. check the output directory is writable and open the batch store ``<output>.cases/``
   (refused if it belongs to another configuration, see :mod:`.store`);
3. run the batches that are not in the store yet on the chosen backend
   (:mod:`.backends`); each finished batch is written to the store at once, atomically;
4. write the results file by slices from the stored batches, one batch in memory at a
   time (:class:`vsi_numba.io.study_file.StudyFile`), to a temporary file in the store;
   rename it over the output and remove the store (its lock last).

Because step 4 always reads the stored batches, a resumed study and an uninterrupted one
give the same file; because every backend runs the same serial kernel on the same inputs,
serial, threaded, process and Dask runs give bit-identical results.

Exit codes of ``vsi sweep`` (:func:`vsi_numba.cli.sweep.sweep_command`)
  0   every run succeeded;
  1   the results file was written but some runs failed numerically (``status != 0``,
      their outputs are NaN; the count is in the ``n_failed_cases`` attribute), or the run
      stopped on an error of its own (a batch raised, a worker died, the disk is full):
      then no results file is written, finished batches are kept and a re-run resumes;
  2   the study cannot run as asked: invalid configuration, a store of another
      configuration or in use by another run, an output location that cannot be
      written, bad options;
  130 interrupted (Ctrl-C or SIGTERM); finished batches are kept and a re-run resumes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import subprocess
import time as _time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from vsi_numba.io.netcdf import (
    CONVENTIONS,
    _fsync_dir,
    history_line,
    source_string,
)
from vsi_numba.io.paths import output_conflict
from vsi_numba.study.backends import (
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    ThreadBackend,
    available_cores,
)
from vsi_numba.study.batches import (
    Batch,
    _packed_trains,
    plan_fingerprint,
    run_batch_task,
    study_plan,
    superpose_refusal,
)
from vsi_numba.study.grid import Case, StudyGrid
from vsi_numba.study.offers import no_values, not_computed_attr, not_offered
from vsi_numba.study.outlock import OutputLock
from vsi_numba.study.progress import _Progress, _say
from vsi_numba.study.spec import (
    StudyModel,
    StudySpec,
    _build_model,
    _load,
    _remember,
    model_fingerprint,
    study_grid,
    study_model,
    study_spec,
    variant_coords,
)
from vsi_numba.study.store import (
    CaseStore,
    OutputNotWritableError,
    StudyError,
    check_writable,
    final_write_error,
    store_path,
    study_need,
)

BACKENDS = ("serial", "threads", "processes", "dask")

#: Global attribute value (``track_type``, ``dt``) of a study whose variants differ in it:
#: each variant's value is in its ``variant_config_json``.
VARIES = "varies by variant"

#: Environment variable of the tests: hold the study (sleep until interrupted) once this
#: many batches were stored in this run, so an interruption never races the machine.
HOLD_ENV = "VSI_STUDY_HOLD_AFTER"
#: estimated kernel seconds of a study's batches above which the readers of its results
#: are imported while they run (:func:`_import_results_readers`)
PREFETCH_COST = 2.0


class CaseErrors(StudyError):
    """Some batches raised an exception (not a numerical failure): no results file."""

    exit_code = 1


# ---------------------------------------------------------------------------- one case


def run_case(config, case: Case):
    """Run one case of a study and return its dataset (dims ``speed``, ``train``,
    ``irregularity`` of length 1): the study engine restricted to that run.

    Parameters
    ----------
    config : StudySpec, Config, dict or str
        The resolved configuration (see :func:`study_spec`).
    case : Case
        From the study grid (:func:`vsi_numba.study.grid.make_grid`).
    """
    from vsi_numba.io.schema import DIAGNOSTICS, ENVELOPES, HISTORIES
    from vsi_numba.solver.simulate import simulate

    model = study_model(study_spec(config))
    train = model.trains[case.i_train]
    if train.name != case.train:
        raise ValueError(f"case {case.key}: train {case.train!r} is not train "
                         f"{case.i_train} ({train.name!r}) of this configuration")
    profile = model.profiles[case.irregularity]
    sim = simulate(model.bridge, train, case.speed_m_s, profile, model.settings,
                   output_points=model.output_points, save_histories=case.histories)
    names = [n for n in (*ENVELOPES, *DIAGNOSTICS, *HISTORIES) if n in sim]
    ds = sim[names].expand_dims(speed=[case.speed_m_s], train=[case.train],
                                irregularity=[case.irregularity])
    ds = ds.assign_coords(speed_kmh=("speed", [case.speed_kmh]))
    ds.attrs = {"case_key": case.key, "status": int(sim.attrs["status"]),
                "message": str(sim.attrs["message"])}
    return ds


# ---------------------------------------------------------------------------- the study


def _choose_backend(backend, workers, scheduler, n_pending, scratch):
    if backend is not None and backend not in BACKENDS:
        raise StudyError(f"backend = {backend!r}: expected one of {', '.join(BACKENDS)}")
    if workers is not None and workers < 1:
        raise StudyError(f"workers = {workers}: expected a number of workers >= 1")
    if backend is None:
        backend = "dask" if (workers is not None or scheduler is not None) else "threads"
    if backend == "serial":
        return SerialBackend()
    if backend in ("threads", "processes"):
        n = workers if workers is not None else available_cores()
        n = min(n, n_pending)
        if n <= 1:
            return SerialBackend()
        return ThreadBackend(n) if backend == "threads" else ProcessBackend(n)
    if scheduler is None and workers is None:
        workers = available_cores()
    return DaskBackend(n_workers=workers, scheduler=scheduler, local_directory=scratch)


def trains_info(spec: StudySpec, model: StudyModel) -> dict:
    """Per-train coordinates and references of the results file."""
    from vsi_numba.solver.simulate import static_deck_envelope

    packed = _packed_trains(spec, model)
    return {
        "wheel_position": [np.concatenate([p.wheel_positions, p.load_positions])
                           for p in packed],
        "static_wheel_load": [np.concatenate([p.static_loads, p.vehicles.load_p])
                              for p in packed],
        "vehicle_name": [list(p.vehicle_names) for p in packed],
        "n_wheel": [p.wheel_positions.size + p.load_positions.size for p in packed],
        "n_vehicle": [p.vehicles.body_dof.size for p in packed],
        "regular_length": [float(t.regular_length) for t in model.trains],
        "status": [str(t.status) for t in model.trains],
        "max_static_deck_displacement": np.array(
            [static_deck_envelope(model.bridge, t, model.output_points) for t in model.trains]
        ).reshape(len(model.trains), model.output_points.size),
    }


def track_type_of(cfg) -> str:
    """Track type stated by a configuration (``"unspecified"`` when it states none).

    Looked up as ``cfg.track_type``, then ``track_type`` in the resolved ``[bridge]``,
    ``[track]`` or ``[study]`` tables (or a string ``track``).  The EN 1990 A2 deck
    acceleration check reads it from the results' ``track_type`` attribute.
    """
    value = getattr(cfg, "track_type", None)
    if value is None:
        resolved = cfg.resolved() if hasattr(cfg, "resolved") else {}
        for section in ("bridge", "track", "study"):
            sec = resolved.get(section, {}) if isinstance(resolved, dict) else {}
            if isinstance(sec, dict) and sec.get("track_type") is not None:
                value = sec["track_type"]
                break
            if section == "track" and isinstance(resolved.get("track"), str):
                value = resolved["track"]
    return "unspecified" if value is None else str(value)


def _global_attrs(model: StudyModel, config_json: str, sha: str, grid: StudyGrid,
                  n_failed: int, failed: list[str], command: str, records=None,
                  track_type: str | None = None) -> dict:
    """Global attributes of a results file; ``records`` (the warnings) and ``track_type``
    default to those of ``model.config``."""
    cfg = model.config
    if records is None:
        records = _records(cfg)
    warnings = [str(r["message"]) for r in records]
    attrs = {
        "Conventions": CONVENTIONS,
        "title": str(cfg.title or "vsi_numba study"),
        "history": history_line(command),
        "source": source_string(),
        "references": (
            "Neves, Montenegro, Azevedo, Calcada (2014), A direct method for analyzing the "
            "nonlinear vehicle-structure interaction, Engineering Structures 69, 83-89"
        ),
        "comment": (
            "Study of speeds x trains x irregularity realisations; envelopes for every case, "
            "time histories (dim time) only for the speeds listed in history_speeds. "
            "Wheels, vehicles and time steps a train or run does not have are NaN."
        ),
        "config_json": config_json,
        "config_sha256": sha,
        "track_type": track_type if track_type is not None else track_type_of(cfg),
        "bridge_length": float(model.bridge.length),
        "bridge_description": str(model.bridge.description or ""),
        "n_cases": len(grid.cases),
        "n_failed_cases": int(n_failed),
        "failed_cases": " ".join(failed[:200]) + (" ..." if len(failed) > 200 else ""),
        "history_speeds_kmh": " ".join(f"{v:g}" for v in grid.speeds_kmh[grid.history_speeds]),
        "dt": float(model.settings.dt),
        "hht_alpha": float(model.settings.hht_alpha),
        "acceleration_cutoff_hz": float(model.deck.cutoff),
    }
    base = getattr(cfg, "base_dir", None)
    if base is not None:  # where the configuration's relative paths resolve (vsi report)
        attrs["config_directory"] = str(Path(base).resolve())
    if warnings:
        attrs["config_warnings"] = "\n".join(str(w) for w in warnings)
    attrs["warnings_json"] = json.dumps(records, ensure_ascii=False)
    track = getattr(model.bridge, "track", None)
    if track is not None and float(getattr(track, "rail_mass", 0.0)) > 0.0:
        from vsi_numba.solver.pack import RAIL_INERTIA_IN_DECK_LOAD

        # the deck load holds the rail's inertia (VehicleArrays.track_kappa)
        attrs["rail_inertia_in_deck_load"] = int(RAIL_INERTIA_IN_DECK_LOAD)
    if getattr(cfg, "deck_in_space", None) is not None:
        attrs["loaded_track"] = int(cfg.train_track)  # 1-based, as train.track
        layout = model.deck.layout
        if layout is not None and layout.channels is not None:
            from vsi_numba.solver.space_effects import METHOD

            attrs["deck_twist_method"] = METHOD  # the twist and track displacements
    others = getattr(cfg, "other_trains", [])
    if others:  # the ..._all_tracks variables: every train of a run loaded
        attrs["other_trains"] = json.dumps(others)
        attrs["loaded_tracks_all"] = " ".join(
            str(k) for k in sorted([int(cfg.train_track), *(int(o["track"]) for o in others)]))
    return attrs


def _records(cfg, base: bool = True) -> list[dict]:
    """The warnings of a configuration as records {"message", "kind", "keys"}: of its own
    values (``base``), or of the study it describes (with ``study.vary``: every variant's,
    marked per variant, see :func:`vsi_numba.config.variants.merge_variant_warnings`)."""
    records = getattr(cfg, "base_warning_records" if base else "warning_records", None)
    if records is None:
        records = getattr(cfg, "warning_records", None)
    if records is None:
        records = [{"message": str(w), "kind": "input", "keys": []}
                   for w in getattr(cfg, "warnings", []) or []]
    return [dict(r) for r in records]


@dataclass(frozen=True)
class _Study:
    """What :func:`execute_study` derives from a configuration before it runs: one spec
    and model per variant (a single one without ``study.vary``), the grid and the plan."""

    config: object  # the configuration as loaded (with its variants)
    specs: list
    models: list
    grid: StudyGrid
    plan: list
    labels: list | None  # the variants' {key path: value}, None without variants
    config_json: str
    sha: str
    command: str

    @property
    def task_spec(self):
        """What a batch task receives: the spec, or one spec per variant."""
        return tuple(self.specs) if self.labels is not None else self.specs[0]

    @property
    def n_runs(self) -> int:
        return len(self.grid.cases) * len(self.models)


@dataclass
class StudyOutcome:
    """What a finished study wrote."""

    path: Path
    n_runs: int
    n_failed: int
    n_batches: int


def run_study(
    config,
    output=None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    *,
    backend: str | None = None,
    fresh: bool = False,
    keep_cases: bool = False,
    quiet: bool = True,
    command: str | None = None,
):
    """Run a study (speeds x trains x irregularity realisations) to one netCDF file.

    Parameters
    ----------
    config : path, dict or Config
        TOML file, config dict or loaded ``Config``.
    output : path, optional
        netCDF file to write (default: ``study.output`` of the configuration).  Finished
        batches are kept in ``<output>.cases/`` until the file is written; running the
        same study again resumes from there.  A file this very study wrote (the same
        configuration, model, plan and code: its ``config_sha256``, ``model_sha256``,
        ``plan_sha256`` and ``engine_sha256`` attributes) is left as it is: nothing is
        recomputed unless ``fresh``.
    workers : int, optional
        With no ``backend``: a Dask ``LocalCluster`` of this many workers (threads of
        this process: the kernels release the GIL).  With ``backend="threads"`` or
        ``"processes"``: the number of local threads or spawned processes.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``).
    progress : bool
        Show a progress bar (on a terminal only).
    backend : {"serial", "threads", "processes", "dask"}, optional
        Default: ``"dask"`` when ``workers`` or ``scheduler`` is given, else
        ``"threads"`` (one thread per core running whole batches; serial when a single
        batch is left or a single core is available).
    fresh : bool
        Discard the store of a previous run of this output, even if it belongs to another
        configuration, and recompute a results file this study wrote.
    keep_cases : bool
        Keep the store after the file is written.
    quiet : bool
        No summary lines on stderr.
    command : str, optional
        Command line recorded in the ``history`` attribute.

    Returns
    -------
    xarray.Dataset
        The results file, opened lazily (:func:`vsi_numba.io.netcdf.open_results`):
        nothing is read until used; close it (or use it as a context manager) when done.
        :func:`execute_study` returns the path and counts without opening the file.

    Raises
    ------
    vsi_numba.config.ConfigError
        Invalid configuration.
    StudyError
        :class:`~vsi_numba.study.store.StoreMismatchError` (the store belongs to another
        configuration), ``OutputNotWritableError``, ``StoreWriteError`` (disk full),
        :class:`CaseErrors` (some batches raised); ``exc.exit_code`` is the CLI status.
    KeyboardInterrupt
        Finished batches stay in the store.
    """
    from vsi_numba.io.netcdf import open_results

    outcome = execute_study(config, output, workers, scheduler, progress, backend=backend,
                            fresh=fresh, keep_cases=keep_cases, quiet=quiet, command=command)
    return open_results(outcome.path)


def execute_study(config, output=None, workers=None, scheduler=None, progress=False, *,
                  backend=None, fresh=False, keep_cases=False, quiet=True,
                  command=None, first_case=False) -> StudyOutcome:
    """:func:`run_study` without opening the result: returns a :class:`StudyOutcome`.

    ``first_case``: only the first train on the first irregularity realisation, at every
    speed, without variants (``vsi run``: the same engine and the same file layout, with
    one train and one realisation; the track range of the profiles is the whole study's,
    so a seed is the same realisation as in the sweep).
    """
    cfg = _load(Path(config) if isinstance(config, str) else config)
    spec = study_spec(cfg)
    if output is None:
        output = getattr(cfg, "output_path", None)
        if output is None:
            raise StudyError("no output file: give one (-o PATH) or set study.output")
    output = Path(output)
    problem = output_conflict(output, cfg)  # an input, a device, a name too long, ...
    if problem is not None:
        raise OutputNotWritableError(problem)
    if command is None:
        source = str(cfg.path) if getattr(cfg, "path", None) else "<mapping>"
        command = (f"vsi_numba.run_study({source!r}, output={str(output)!r}, "
                   f"workers={workers!r}, scheduler={scheduler!r}, backend={backend!r})")
    # one writer per results file (vsi run and vsi sweep have different stores)
    with OutputLock(output, command):
        return _execute_locked(cfg, spec, output, workers, scheduler, progress, backend,
                               fresh, keep_cases, quiet, command, first_case)


def _execute_locked(cfg, spec, output, workers, scheduler, progress, backend, fresh,
                    keep_cases, quiet, command, first_case) -> StudyOutcome:
    """:func:`execute_study` once the output's lock is held."""
    config_json = spec.config_json
    sha = cfg.sha256
    variants = list(getattr(cfg, "variants", []) or []) if not first_case else []
    vcfgs = [v for _, v in variants] or [cfg]
    specs = [study_spec(c) for c in vcfgs] if variants else [spec]
    models = []
    for sp, c in zip(specs, vcfgs, strict=True):
        m = _build_model(c, first_realisation=first_case)
        if first_case:
            first = next(iter(m.profiles))
            m = dataclasses.replace(m, trains=m.trains[:1],
                                    profiles={first: m.profiles[first]})
        _remember(sp, m)
        models.append(m)
    model = models[0]
    grid = study_grid(model)
    for k, m in enumerate(models[1:], start=1):
        if [t.name for t in m.trains] != list(grid.trains) or list(m.profiles) != list(
                grid.irregularities):
            from vsi_numba.config.variants import variant_where

            raise StudyError(f"variant {k} ({variant_where(variants[k][0])}) changes the "
                             "trains or the "
                             "irregularity realisations: vary the bridge, track, contact "
                             "or vehicle data, not the study's axes")
    plan: list[Batch] = []
    for k, (sp, m) in enumerate(zip(specs, models, strict=True)):
        refusal = superpose_refusal(sp, m)  # the run budget the model alone tells
        if refusal is not None:
            from vsi_numba.config import ConfigError

            raise ConfigError([refusal], source=str(getattr(cfg, "path", None)
                                                    or "<mapping>"))
        plan += study_plan(sp, m, grid, variant=k if variants else None, start=len(plan))

    check_writable(output.parent if str(output.parent) else Path("."), "results file")
    spath = store_path(output, "run" if first_case else "sweep")  # never the other's
    store_existed = spath.exists()
    model_sha = (model_fingerprint(model) if not variants else hashlib.sha256(
        "".join(model_fingerprint(m) for m in models).encode()).hexdigest())
    plan_sha = plan_fingerprint(plan)
    if not fresh and not store_existed:
        n_failed = _finished_earlier(output, sha, model_sha, plan_sha)
        if n_failed is not None:  # the same study, written: nothing to recompute
            n_runs = len(grid.cases) * len(models)
            _say(quiet, f"{n_runs} runs: {output} holds them, written for this configuration, "
                        "model and code; nothing recomputed (--fresh recomputes them)")
            return StudyOutcome(output, n_runs, n_failed, len(plan))
    store = CaseStore(spath, sha, config_json, fresh=fresh,
                      model_sha256=model_sha, plan_sha256=plan_sha)
    study = _Study(cfg, specs, models, grid, plan, [lab for lab, _ in variants] or None,
                   config_json, sha, command)
    try:
        with store:
            return _execute(store, study, output, backend, workers, scheduler, progress,
                            keep_cases, quiet)
    except BaseException:
        # a run that stored nothing leaves nothing behind (e.g. an unreachable scheduler)
        if not store_existed and store.path.is_dir() and not store.done():
            store.remove()
        raise


def _identity(model_sha: str, plan_sha: str) -> dict[str, str]:
    """The attributes that tie a results file to the study that wrote it: the model's
    and the plan's fingerprints (:func:`model_fingerprint`, :func:`plan_fingerprint`)
    and the hash of the package's sources (``engine_sha256``: an edit of the code or
    another version makes the file a different study's)."""
    from vsi_numba._jit import package_hash

    return {"model_sha256": model_sha, "plan_sha256": plan_sha,
            "engine_sha256": package_hash(Path(__file__).resolve().parents[1])}


def _finished_earlier(output: Path, sha: str, model_sha: str, plan_sha: str) -> int | None:
    """The failed-run count of ``output`` when it is the results file of this very study
    (the configuration's hash, the model's and the plan's fingerprints and the code's hash
    all equal the file's, see :func:`_identity`), else None (no file, another study's,
    one written before these attributes, or a file that cannot be read)."""
    if not output.is_file():
        return None
    try:
        import netCDF4

        with netCDF4.Dataset(output) as nc:
            attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
    except (OSError, RuntimeError, ValueError):
        return None
    want = {"config_sha256": sha, **_identity(model_sha, plan_sha)}
    if any(str(attrs.get(k, "")) != v for k, v in want.items()):
        return None
    try:
        return int(attrs.get("n_failed_cases", 0))
    except (TypeError, ValueError):
        return None


def _execute(store, study: _Study, output, backend, workers, scheduler, progress,
             keep_cases, quiet) -> StudyOutcome:
    """The part of :func:`execute_study` that runs with the store open."""
    done = store.done()
    for b in study.plan:  # a damaged or foreign batch file is found now, not at the end
        if b.key in done:
            store.check(b.key)
    pending = [b for b in study.plan if b.key not in done]
    n_runs = study.n_runs
    n_todo = sum(b.n_runs for b in pending)
    n_s, n_t, n_i = study.grid.shape
    need = study_need(study, pending)  # refused now if the disk cannot hold the study
    space_warning = store.check_space(need, output)
    if space_warning:
        _say(quiet, f"warning: {space_warning}")
    if pending:
        be = _choose_backend(backend, workers, scheduler, len(pending),
                             store.path / "dask-scratch")
        nv = f"{len(study.models)} variants x " if study.labels is not None else ""
        _say(quiet, f"{n_runs} runs in {len(study.plan)} batches ({nv}{n_s} speeds x {n_t} "
                    f"trains x {n_i} irregularities): {n_runs - n_todo} done earlier, "
                    f"{n_todo} to run ({be.name}"
                    f"{_workers_note(be, workers, scheduler)})")
        _run_pending(be, study.task_spec, pending, store, progress, n_runs, n_runs - n_todo,
                     quiet)
    else:
        _say(quiet, f"{n_runs} runs: all done earlier, writing {output}")
    n_failed = _write_results(output, store, study, need.final_max)
    if not keep_cases:
        store.remove()
    _say(quiet, f"wrote {output}: {n_runs} runs, {n_failed} failed")
    return StudyOutcome(output, n_runs, n_failed, len(study.plan))


def _write_results(output: Path, store: CaseStore, study: _Study,
                   need_bytes: int | None = None) -> int:
    """Stream the stored batches into the results file; returns the failed-run count."""
    from vsi_numba.io.study_file import StudyFile
    from vsi_numba.solver.batch import deck_grid

    specs, models, grid, plan, labels = (study.specs, study.models, study.grid, study.plan,
                                         study.labels)
    infos = [trains_info(sp, m) for sp, m in zip(specs, models, strict=True)]
    packed = [_packed_trains(sp, m) for sp, m in zip(specs, models, strict=True)]
    hist_steps = [packed[b.variant or 0][b.i_train].n_steps(grid.speeds_kmh[s] / 3.6) + 1
                  for b in plan for s, h in zip(b.speeds, b.histories, strict=True) if h]
    n_time = max(hist_steps) if hist_steps else None
    model = models[0]
    variants = None
    if labels is not None:
        rules = [{k: getattr(m.config, k, None) for k in ("damping_rule",
                                                          "additional_damping_rule")}
                 for m in models]
        variants = {"coords": variant_coords(labels),
                    "bridge_length": [m.bridge.length for m in models],
                    "acceleration_cutoff": [m.deck.cutoff for m in models],
                    "config_json": [sp.config_json for sp in specs],
                    "damping": [m.bridge.damping for m in models],
                    "additional_damping": [m.config.additional_damping for m in models],
                    "damping_rule": [" ; ".join(r[k] for k in ("damping_rule",
                                                               "additional_damping_rule")
                                                if r.get(k)) for r in rules]}
    n_wheel = max(max(i["n_wheel"], default=0) for i in infos)
    n_vehicle = max(max(i["n_vehicle"], default=0) for i in infos)
    omit = not_offered(models, packed)
    tmp = store.temp_path(output.name)
    failed: list[str] = []
    try:
        f = StudyFile(tmp, grid.speeds_kmh, grid.trains, grid.irregularities,
                      [m.output_points for m in models], [m.bridge.frequencies for m in models],
                      n_wheel, n_vehicle, n_time,
                      [m.settings.dt for m in models] if labels is not None else
                      model.settings.dt, infos, variants,
                      deck_x=[deck_grid(m.bridge, m.output_points) for m in models],
                      supports=[m.bridge.supports for m in models], omit=omit,
                      space=[m.deck.layout for m in models])
        hold = _hold_after() == "write"
        try:
            for b in plan:
                data = store.load(b.key)
                info = infos[b.variant or 0]
                f.write_batch(b, data, info["n_wheel"][b.i_train], info["n_vehicle"][b.i_train])
                if hold:
                    f.flush()
                    f.nc.sync()
                    _hold(store)
                for r, st in enumerate(data["status"]):
                    if st != 0:
                        key = Case(0, b.speeds[r], b.i_train, b.i_irregularity, 0.0, "", 0,
                                   False).key
                        failed.append(key if b.variant is None else f"v{b.variant:04d}_{key}")
                del data
            failed.sort()
            if labels is None:
                attrs = _global_attrs(model, study.config_json, study.sha, grid, len(failed),
                                      failed, study.command)
            else:  # every variant's warnings, marked; one track type or "varies"
                types = {track_type_of(m.config) for m in models}
                attrs = _global_attrs(model, study.config_json, study.sha, grid, len(failed),
                                      failed, study.command,
                                      records=_records(study.config, base=False),
                                      track_type=types.pop() if len(types) == 1 else
                                      VARIES)
            if labels is not None:
                attrs["n_cases"] = study.n_runs
                attrs["n_variants"] = len(models)
                attrs["varied_keys"] = " ".join(labels[0])
                if len({m.settings.dt for m in models}) > 1:
                    attrs["dt"] = VARIES
            if labels is None:  # per variant otherwise (damping_rule(variant))
                _bridge_rules(attrs, model.config)
                _modes_left_out(attrs, model.config, float(model.deck.cutoff))
            f.flush()
            empty = no_values(f.found, not failed)
            if empty:
                raise StudyError(
                    f"not written: {output} would hold no value of {', '.join(empty)}, which "
                    "this model computes; this is a defect of vsi_numba (the finished runs "
                    "are kept), please report it with the configuration")
            attrs["not_computed"] = not_computed_attr(omit)
            # what a re-run compares to leave a file of the same study as it is
            attrs.update(_identity(store.model_sha256, store.plan_sha256))
            f.close(attrs)
            if "fatigue" in study.config.resolved():  # the traffic's runs, counted
                from vsi_numba.study import fatigue

                fatigue.write(tmp, fatigue.fatigue_runs(study.config))
        except BaseException:
            f.abort()
            raise
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, output)
        _fsync_dir(output.parent)
    except (OSError, RuntimeError) as exc:
        error = final_write_error(exc, output, store, need_bytes, tmp)
        tmp.unlink(missing_ok=True)
        raise error from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return len(failed)


def _bridge_rules(attrs: dict, cfg) -> None:
    """The EN 1991-2 damping rules a config applied, as attributes of the results."""
    for key in ("damping_rule", "additional_damping_rule"):
        rule = getattr(cfg, key, None)
        if rule:
            attrs[key] = str(rule)


def _modes_left_out(attrs: dict, cfg, cutoff: float) -> None:
    """``modes_left_out_below_cutoff`` (how many modes up to the deck-acceleration
    cut-off the model leaves out) and ``frequencies_left_out_below_cutoff`` (their
    frequencies, Hz), when the configuration knows its spectrum up to the cut-off."""
    left = getattr(cfg, "frequencies_left_out", None)
    freqs = left(cutoff) if left is not None else None
    if freqs is None:
        return
    attrs["modes_left_out_below_cutoff"] = int(len(freqs))
    attrs["frequencies_left_out_below_cutoff"] = " ".join(f"{f:.6g}" for f in freqs)


def _hold_after() -> int | str | None:
    """The test hook's setting: a number of stored batches, ``"write"`` (inside the final
    write) or None."""
    value = os.environ.get(HOLD_ENV, "").strip()
    if value == "write":
        return value
    try:
        return int(value) if value else None
    except ValueError:
        return None


def _hold(store: CaseStore) -> None:
    """Test hook: announce the hold and sleep until interrupted or killed."""
    (store.path / ".held").write_text(str(os.getpid()))
    while True:
        _time.sleep(0.05)


def _workers_note(be, workers, scheduler) -> str:
    """``, 2 workers`` (local backends) or ``, scheduler ADDRESS`` (its workers are counted
    once connected)."""
    if be.name == "serial":
        return ""
    if be.name == "dask" and scheduler is not None:
        return f", scheduler {scheduler}"
    return f", {workers or be.n_workers} workers"


def _start_compile_helper(be, spec, order):
    """On a first run of a study needing both kernel families with neither in the numba
    cache, a process of its own compiles the family the batch ``order`` needs last
    (:func:`~vsi_numba.solver.kernel_cache.helper_command`) while this one compiles the
    other: on 2 cores the two compilations run at once.  The first batch of the helper's
    family then waits for the family's compile lock, which the helper holds, and loads the
    kernels from the cache.  Returns the helper's process, or None.  Only for the backends
    that run the batches in this process (serial, threads, ``--workers``' LocalCluster)."""
    from vsi_numba._process import available_cores, term_with_parent
    from vsi_numba.solver import kernel_cache as kc
    from vsi_numba.study.batches import _packed_train, _spec_of

    in_process = be.name in ("serial", "threads") or (
        be.name == "dask" and getattr(be, "scheduler", None) is None)
    if (not in_process or available_cores() < 2
            or any(kc.is_cached(f) for f in kc.FAMILIES)):
        return None
    seen: dict = {}  # train -> family (variants do not change the trains)
    for b in order:
        if b.i_train not in seen:
            seen[b.i_train] = kc.family_of(_packed_train(_spec_of(spec, b), b.i_train))
    families = list(dict.fromkeys(seen.values()))
    if len(families) < 2:
        return None
    try:
        return subprocess.Popen(kc.helper_command(families[-1]), env=dict(os.environ),
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, preexec_fn=term_with_parent())
    except OSError:  # no process to spare: this process compiles both
        return None


@contextlib.contextmanager
def _stop_helper(proc):
    """End the compile helper (if any) when the study stops before it is done."""
    try:
        yield
    finally:
        if proc is not None:
            if proc.poll() is None:
                proc.terminate()
            proc.wait()


def _import_results_readers(order) -> None:
    """Import what reads the results file afterwards (xarray, which imports dask.array
    when it sees an array; ~0.6 s) while the batches run, when they are long enough: the
    batches run in worker threads (kernels that release the GIL) or processes, so the
    import takes a share of the cores instead of a serial wait after the last batch
    (the sweep's governing results, a report).  In this thread, once, after the first
    batch is stored: no second thread that imports while an interrupted sweep shuts
    down.  Not for a study that keeps time histories: the imports' ~65 MB would then add
    to the peak of the batches' history buffers."""
    if sum(b.cost for b in order) < PREFETCH_COST or any(any(b.histories) for b in order):
        return
    with contextlib.suppress(ImportError):  # dask is installed with the package
        import dask.array  # noqa: F401
    import xarray  # noqa: F401


def _run_pending(be, spec, pending, store, progress, n_runs, n_done, quiet=True) -> None:
    errors: list[tuple[Batch, BaseException]] = []
    order = sorted(pending, key=lambda b: (-b.cost, b.index))
    hold = _hold_after()
    stored = 0
    helper = _start_compile_helper(be, spec, order)
    # The batches are the parallelism: BLAS on one thread in this process while they run.
    # With its default (a thread per core), OpenBLAS's threads busy-wait after every small
    # call (the static starts' solves) on the cores the batch threads need.  Worker
    # processes get the same from their environment (WORKER_ENV).
    with (_stop_helper(helper), threadpool_limits(limits=1, user_api="blas"),
          _Progress(progress, n_runs, n_done, "runs") as bar):
        with be:
            if be.name == "dask" and getattr(be, "scheduler", None) is not None:
                n_w, n_t = be.n_workers, be.n_threads
                _say(quiet, f"connected to the Dask scheduler {be.scheduler}: {n_w} "
                            f"worker{'' if n_w == 1 else 's'}, {n_t} thread"
                            f"{'' if n_t == 1 else 's'}"
                     + ("" if n_w else "; no worker yet: the batches wait until one "
                                       "connects (dask worker " + be.scheduler + ")"))
            try:
                for batch, result in be.run(run_batch_task, spec, order):
                    if isinstance(result, BaseException):
                        errors.append((batch, result))
                    else:
                        store.write(batch.key, result)
                        stored += 1
                        if stored == 1:  # the other batches are under way
                            _import_results_readers(order)
                    bar.advance(batch.n_runs)
                    if isinstance(hold, int) and stored >= hold:
                        _hold(store)
            except BaseException as exc:
                if isinstance(exc, KeyboardInterrupt | StudyError):
                    raise
                try:
                    kept = f"{len(store.done())} finished batches are kept in {store.path}"
                except OSError:
                    kept = f"finished batches are kept in {store.path}"
                raise StudyError(
                    f"the study stopped: {type(exc).__name__}: {exc}. {kept}; re-run the "
                    "same command to resume."
                ) from exc
    if errors:
        batch, exc = errors[0]
        tb = "".join(traceback.format_exception(exc)).rstrip()
        raise CaseErrors(
            f"{len(errors)} batch(es) raised an error, e.g. batch {batch.key} "
            f"(train {batch.i_train}, irregularity {batch.i_irregularity}, speeds "
            f"{batch.speeds[0]}..{batch.speeds[-1]}):\n{tb}\nNo results file was written; "
            f"the {len(store.done())} finished batches are kept in {store.path} and a "
            "re-run computes only the missing ones."
        )
