"""The study runner: speeds x trains x irregularity realisations, resumable, parallel.

Flow of :func:`run_study`
1. load and resolve the configuration; build the case grid (:mod:`.grid`);
2. check the output directory is writable and open the case store ``<output>.cases/``
   (refused if it belongs to another configuration, see :mod:`.store`);
3. compile or load the numba kernels in this process (``warm_up``), then run the cases
   that are not in the store yet on the chosen backend (:mod:`.backends`); each finished
   case is written to the store at once, atomically;
4. read every case back from the store, assemble the study dataset (:mod:`.assemble`),
   write it atomically to the output, and remove the store.

Because step 4 always reads the stored files, a resumed study and an uninterrupted one
give the same file; because every backend runs the same serial kernel on the same inputs,
serial, process and Dask runs give bit-identical results.

Exit codes of :func:`sweep_command` (``vsi sweep``)
  0   every case ran and succeeded;
  1   the results file was written but some cases failed numerically (``status != 0``,
      their outputs are NaN; the count is in the ``n_failed_cases`` attribute), or the run
      stopped on an error of its own (a case raised, a worker died, the disk is full):
      then no results file is written, finished cases are kept and a re-run resumes;
  2   the study cannot run as asked: invalid configuration, a case store of another
      configuration or in use by another run, an output location that cannot be
      written, bad options;
  130 interrupted (Ctrl-C); finished cases are kept and a re-run resumes.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import sys
import time as _time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import xarray as xr

from vsi_numba.io.netcdf import (
    CONVENTIONS,
    history_line,
    open_results,
    source_string,
    to_netcdf_bytes,
    write_netcdf,
)
from vsi_numba.study.assemble import assemble, case_dataset
from vsi_numba.study.backends import DaskBackend, ProcessBackend, SerialBackend, available_cores
from vsi_numba.study.grid import Case, StudyGrid, history_mask, make_grid, profile_range
from vsi_numba.study.store import (
    CaseStore,
    OutputNotWritableError,
    StoreWriteError,
    StudyError,
    check_writable,
    store_path,
)

BACKENDS = ("serial", "processes", "dask")


class CaseErrors(StudyError):
    """Some cases raised an exception (not a numerical failure): no results file."""

    exit_code = 1


# ---------------------------------------------------------------------------- the model


@dataclass(frozen=True)
class StudyModel:
    """Everything a case needs, rebuilt from the resolved configuration."""

    config: object
    bridge: object
    trains: tuple
    settings: object
    output_points: np.ndarray
    profiles: dict
    x_range: tuple[float, float]


class StudySpec(NamedTuple):
    """What a worker needs to rebuild a study's model.

    The resolved configuration (JSON) and the directory its relative paths (profile file,
    train file) resolve against.
    """

    config_json: str
    base_dir: str


def study_spec(config) -> StudySpec:
    """:class:`StudySpec` of a ``Config``, a resolved-config dict or JSON string, or a spec.

    Dicts and JSON strings resolve relative paths against the working directory.
    """
    if isinstance(config, StudySpec):
        return config
    if isinstance(config, str):
        return StudySpec(config, str(Path.cwd()))
    if isinstance(config, dict):
        return StudySpec(json.dumps(config, sort_keys=True, separators=(",", ":")),
                         str(Path.cwd()))
    return StudySpec(config.to_json(), str(config.base_dir))


def _load(config):
    """Return a ``Config`` from a path, mapping, :class:`StudySpec` or ``Config``."""
    from vsi_numba.config import load_config

    if isinstance(config, StudySpec):
        return load_config(json.loads(config.config_json), base_dir=config.base_dir)
    if isinstance(config, str | os.PathLike | dict):
        return load_config(config)
    return config


@functools.lru_cache(maxsize=4)
def study_model(spec: StudySpec) -> StudyModel:
    """Build (once per process) the bridge, trains and profiles of a configuration."""
    return _build_model(_load(spec))


def _build_model(cfg) -> StudyModel:
    bridge = cfg.build_bridge()
    trains = tuple(cfg.trains())
    settings = cfg.solver_settings()
    x_range = profile_range(bridge.length, [t.length for t in trains], settings.approach,
                            settings.free_vibration)
    profiles = dict(cfg.irregularities(*x_range))
    points = cfg.output_points
    if points is None:
        s = np.asarray(bridge.supports, float)
        points = 0.5 * (s[:-1] + s[1:])
    return StudyModel(cfg, bridge, trains, settings, np.atleast_1d(np.asarray(points, float)),
                      profiles, x_range)


def model_fingerprint(model: StudyModel) -> str:
    """SHA-256 of the numbers the cases are computed from.

    The configuration's hash does not see data it only names: a train preset (library
    data), a profile file, the bridge built by this version.  This hash covers the built
    bridge, trains, profiles, solver settings and output points, so a store is refused
    when any of them changed even if the configuration text did not.
    """
    import hashlib

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
    """Return the case grid of a configuration (deterministic order)."""
    cfg = model.config
    hist = history_mask(cfg.speeds_kmh, bool(cfg.save_time_histories),
                        getattr(cfg, "history_speeds_kmh", None))
    return make_grid(cfg.speeds_kmh, [t.name for t in model.trains], list(model.profiles),
                     hist)


# ---------------------------------------------------------------------------- one case


def run_case(config, case: Case) -> xr.Dataset:
    """Run one case of a study and return its dataset.

    Parameters
    ----------
    config : StudySpec, Config, dict or str
        The resolved configuration: a :class:`StudySpec` (what workers receive: the
        ``Config.to_json()`` string and the base directory of relative paths), a
        ``Config``, or the resolved dict / JSON string (relative paths then resolve
        against the working directory).  The model is rebuilt from it (and cached per
        process), so the case runs identically in this process, in a worker process or on
        Dask.
    case : Case
        From the study grid (:func:`vsi_numba.study.grid.make_grid`).

    Returns
    -------
    xarray.Dataset
        Envelopes, ``status``, ``max_iterations``, ``message`` and, for cases that keep
        them, time histories; leading dims ``speed``, ``train``, ``irregularity`` of
        length 1.
    """
    from vsi_numba.solver.simulate import simulate

    model = study_model(study_spec(config))
    train = model.trains[case.i_train]
    if train.name != case.train:
        raise ValueError(f"case {case.key}: train {case.train!r} is not train "
                         f"{case.i_train} ({train.name!r}) of this configuration")
    profile = model.profiles[case.irregularity]
    sim = simulate(model.bridge, train, case.speed_m_s, profile, model.settings,
                   output_points=model.output_points, save_histories=case.histories)
    return case_dataset(sim, case)


def run_case_bytes(spec: StudySpec, case: Case) -> bytes:
    """:func:`run_case` encoded as netCDF bytes (what workers send back to the parent)."""
    return to_netcdf_bytes(run_case(spec, case))


# ---------------------------------------------------------------------------- progress


class _Progress:
    """A rich progress bar on a terminal; silent otherwise."""

    def __init__(self, enabled: bool, total: int, done: int, label: str):
        self.bar = None
        if not enabled:
            return
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        console = Console(stderr=True)
        if not console.is_terminal:
            return
        self.bar = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"), TimeElapsedColumn(), TextColumn("ETA"),
            TimeRemainingColumn(), console=console, transient=False,
        )
        self.task = self.bar.add_task(label, total=total, completed=done, rate="")
        self._t0 = _time.perf_counter()
        self._n = 0

    def __enter__(self):
        if self.bar is not None:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.stop()

    def advance(self):
        if self.bar is None:
            return
        self._n += 1
        rate = self._n / max(_time.perf_counter() - self._t0, 1e-9)
        self.bar.update(self.task, advance=1, rate=f"{rate:.2f} cases/s")


def _say(quiet: bool, message: str) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------- the study


def _choose_backend(backend, workers, scheduler, n_pending):
    if backend is not None and backend not in BACKENDS:
        raise StudyError(f"backend = {backend!r}: expected one of {', '.join(BACKENDS)}")
    if workers is not None and workers < 1:
        raise StudyError(f"workers = {workers}: expected a number of workers >= 1")
    if backend is None:
        backend = "dask" if (workers is not None or scheduler is not None) else "processes"
    if backend == "serial":
        return SerialBackend()
    if backend == "processes":
        n = workers if workers is not None else available_cores()
        n = min(n, n_pending)
        return SerialBackend() if n <= 1 else ProcessBackend(n)
    if scheduler is None and workers is None:
        workers = available_cores()
    return DaskBackend(n_workers=workers, scheduler=scheduler)


def _train_info(model: StudyModel) -> dict:
    from vsi_numba.solver.simulate import static_deck_envelope

    return {
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
                  n_failed: int, failed: list[str], command: str) -> dict:
    cfg = model.config
    warnings = list(getattr(cfg, "warnings", []) or [])
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
        "track_type": track_type_of(cfg),
        "bridge_length": float(model.bridge.length),
        "bridge_description": str(model.bridge.description or ""),
        "n_cases": len(grid.cases),
        "n_failed_cases": int(n_failed),
        "failed_cases": " ".join(failed[:200]) + (" ..." if len(failed) > 200 else ""),
        "history_speeds_kmh": " ".join(f"{v:g}" for v in grid.speeds_kmh[grid.history_speeds]),
        "dt": float(model.settings.dt),
        "hht_alpha": float(model.settings.hht_alpha),
    }
    if warnings:
        attrs["config_warnings"] = "\n".join(str(w) for w in warnings)
    return attrs


def _submission_order(grid: StudyGrid, pending: list[Case], model: StudyModel) -> list[Case]:
    """Longest cases first (cost ~ run length / speed) for a good load balance."""
    def cost(case):
        train = model.trains[case.i_train]
        run = model.settings.approach + model.bridge.length + train.length
        return -(run / max(case.speed_m_s, 1e-9) + model.settings.free_vibration)

    return sorted(pending, key=lambda c: (cost(c), c.index))


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
) -> xr.Dataset:
    """Run a study (speeds x trains x irregularity realisations) to one netCDF file.

    Parameters
    ----------
    config : path, dict or Config
        TOML file, config dict or loaded ``Config``.
    output : path, optional
        netCDF file to write (default: ``study.output`` of the configuration).  Finished
        cases are kept in ``<output>.cases/`` until the file is written; running the same
        study again resumes from there.
    workers : int, optional
        With no ``backend``: start a Dask ``LocalCluster`` (127.0.0.1) of this many
        workers.  With ``backend="processes"``: the number of local processes.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``).
    progress : bool
        Show a progress bar (on a terminal only).
    backend : {"serial", "processes", "dask"}, optional
        Default: ``"dask"`` when ``workers`` or ``scheduler`` is given, else
        ``"processes"`` (one spawned process per core; serial when a single case is left
        or a single core is available).
    fresh : bool
        Discard the case store of a previous run of this output, even if it belongs to
        another configuration.
    keep_cases : bool
        Keep the case store after the file is written.
    quiet : bool
        No summary lines on stderr.
    command : str, optional
        Command line recorded in the ``history`` attribute.

    Returns
    -------
    xarray.Dataset
        The study as written (read back from ``output``, loaded in memory).

    Raises
    ------
    vsi_numba.config.ConfigError
        Invalid configuration.
    StudyError
        :class:`~vsi_numba.study.store.StoreMismatchError` (the store belongs to another
        configuration), ``OutputNotWritableError``, ``StoreWriteError`` (disk full),
        :class:`CaseErrors` (some cases raised); ``exc.exit_code`` is the CLI status.
    KeyboardInterrupt
        Finished cases stay in the store.
    """
    cfg = _load(Path(config) if isinstance(config, str) else config)
    spec = study_spec(cfg)
    config_json = spec.config_json
    sha = cfg.sha256
    if output is None:
        output = getattr(cfg, "output_path", None)
        if output is None:
            raise StudyError("no output file: give one (-o PATH) or set study.output")
    output = Path(output)
    if output.exists() and output.is_dir():
        raise OutputNotWritableError(f"the output {output} is a directory")
    model = _build_model(cfg)
    grid = study_grid(model)
    if command is None:
        source = str(cfg.path) if getattr(cfg, "path", None) else "<mapping>"
        command = (f"vsi_numba.run_study({source!r}, output={str(output)!r}, "
                   f"workers={workers!r}, scheduler={scheduler!r}, backend={backend!r})")

    check_writable(output.parent if str(output.parent) else Path("."), "results file")
    store = CaseStore(store_path(output), sha, config_json, fresh=fresh,
                      model_sha256=model_fingerprint(model))
    with store:
        done = store.done()
        pending = [c for c in grid.cases if c.key not in done]
        n_s, n_t, n_i = grid.shape
        if pending:
            be = _choose_backend(backend, workers, scheduler, len(pending))
            _say(quiet, f"{len(grid.cases)} cases ({n_s} speeds x {n_t} trains x {n_i} "
                        f"irregularities): {len(grid.cases) - len(pending)} done earlier, "
                        f"{len(pending)} to run ({be.name}"
                        f"{'' if be.name == 'serial' else f', {workers or be.n_workers} workers'}"
                        ")")
            from vsi_numba.solver.simulate import warm_up

            warm_up()  # compile or load the kernels here, before any worker starts
            _run_pending(be, spec, grid, pending, model, store, progress)
        else:
            _say(quiet, f"{len(grid.cases)} cases: all done earlier, assembling {output}")

        cases = [store.load(c.key) for c in grid.cases]
        status = np.array([int(ds["status"].values.ravel()[0]) for ds in cases])
        failed = [c.key for c, s in zip(grid.cases, status, strict=True) if s != 0]
        attrs = _global_attrs(model, config_json, sha, grid, len(failed), failed, command)
        ds = assemble(grid, cases, _train_info(model), model.bridge.frequencies, attrs)
        try:
            write_netcdf(ds, output)
        except OSError as exc:
            msg = (f"cannot write {output}: {exc.strerror or exc}. The {len(cases)} finished "
                   f"cases are kept in {store.path}; re-run the same command once fixed.")
            if isinstance(exc, PermissionError):
                raise OutputNotWritableError(msg) from exc
            raise StoreWriteError(msg) from exc
    if not keep_cases:
        store.remove()
    _say(quiet, f"wrote {output}: {len(grid.cases)} cases, {len(failed)} failed")
    with open_results(output) as result:
        return result.load()


def _run_pending(be, spec, grid, pending, model, store, progress) -> None:
    errors: list[tuple[Case, BaseException]] = []
    order = _submission_order(grid, pending, model)
    with _Progress(progress, len(grid.cases), len(grid.cases) - len(pending), "cases") as bar:
        with be:
            try:
                for case, result in be.run(run_case_bytes, spec, order):
                    if isinstance(result, BaseException):
                        errors.append((case, result))
                    else:
                        store.write(case.key, result)
                    bar.advance()
            except BaseException as exc:
                if isinstance(exc, KeyboardInterrupt | StudyError):
                    raise
                try:
                    kept = f"{len(store.done())} finished cases are kept in {store.path}"
                except OSError:
                    kept = f"finished cases are kept in {store.path}"
                raise StudyError(
                    f"the study stopped: {type(exc).__name__}: {exc}. {kept}; re-run the "
                    "same command to resume."
                ) from exc
    if errors:
        case, exc = errors[0]
        tb = "".join(traceback.format_exception(exc)).rstrip()
        raise CaseErrors(
            f"{len(errors)} case(s) raised an error, e.g. case {case.key} "
            f"({case.speed_kmh:g} km/h, {case.train}, irregularity {case.irregularity}):\n"
            f"{tb}\nNo results file was written; the {len(store.done())} finished cases "
            f"are kept in {store.path} and a re-run computes only the missing ones."
        )


# ---------------------------------------------------------------------------- the CLI


def sweep_command(config: Path, output: Path | None, workers: int | None,
                  scheduler: str | None, quiet: bool, fresh: bool = False) -> int:
    """``vsi sweep``: run a study; returns the exit code (see the module docstring)."""
    from vsi_numba.config import ConfigError, load_config

    def fail(message: str, code: int) -> int:
        print(f"error: {message}", file=sys.stderr, flush=True)
        return code

    if workers is not None and scheduler is not None:
        return fail("give --workers (local Dask cluster) or --scheduler (existing cluster), "
                    "not both", 2)
    try:
        cfg = load_config(Path(config))
    except ConfigError as exc:
        return fail(f"invalid configuration {config}:\n{exc}", 2)
    except OSError as exc:
        return fail(f"cannot read {config}: {exc.strerror or exc}", 2)
    if not quiet:
        for w in getattr(cfg, "warnings", []) or []:
            print(f"warning: {w}", file=sys.stderr)
    parts = ["vsi", "sweep", str(config)]
    if output is not None:
        parts += ["-o", str(output)]
    if workers is not None:
        parts += ["--workers", str(workers)]
    if scheduler is not None:
        parts += ["--scheduler", scheduler]
    if fresh:
        parts += ["--fresh"]
    try:
        ds = run_study(cfg, output, workers=workers, scheduler=scheduler, progress=not quiet,
                       fresh=fresh, quiet=quiet, command=" ".join(parts))
    except ConfigError as exc:
        return fail(f"invalid configuration {config}:\n{exc}", 2)
    except StudyError as exc:
        return fail(str(exc), exc.exit_code)
    except KeyboardInterrupt:
        return fail("interrupted: the finished cases are kept; re-run the same command to "
                    "resume", 130)
    except OSError as exc:  # I/O outside the store/output writes (numba cache, temp files)
        return fail(f"{exc}. Finished cases are kept; re-run the same command to resume.", 1)
    n_failed = int(ds.attrs.get("n_failed_cases", 0))
    if n_failed:
        return fail(f"{n_failed} of {ds.attrs.get('n_cases')} cases failed numerically "
                    "(status != 0, outputs NaN); see the 'status' and 'message' variables",
                    1)
    return 0
