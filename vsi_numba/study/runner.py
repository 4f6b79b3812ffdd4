"""The study runner: speeds x trains x irregularity realisations, resumable, parallel.

Flow of :func:`run_study`
1. load and resolve the configuration; build the model once (bridge, trains, profiles,
   deck operators), the run grid (:mod:`.grid`) and its batch plan (:mod:`.batches`);
2. check the output directory is writable and open the batch store ``<output>.cases/``
   (refused if it belongs to another configuration, see :mod:`.store`);
3. run the batches that are not in the store yet on the chosen backend
   (:mod:`.backends`); each finished batch is written to the store at once, atomically;
4. write the results file by slices from the stored batches, one batch in memory at a
   time, to a temporary file in the store; rename it over the output
   (:mod:`.results_file`) and remove the store (its lock last).

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

import dataclasses
import hashlib
import traceback
from dataclasses import dataclass
from pathlib import Path

from threadpoolctl import threadpool_limits

from vsi_numba.io.paths import output_conflict
from vsi_numba.study import unchanged
from vsi_numba.study.backends import (
    ProcessBackend,
    SerialBackend,
    ThreadBackend,
    available_cores,
)
from vsi_numba.study.batches import (
    Batch,
    plan_fingerprint,
    run_batch_task,
    study_plan,
    superpose_refusal,
)
from vsi_numba.study.grid import Case, StudyGrid
from vsi_numba.study.hold import HOLD_ENV, hold_after  # noqa: F401 - HOLD_ENV: tests
from vsi_numba.study.hold import hold as hold_store
from vsi_numba.study.outlock import OutputLock
from vsi_numba.study.progress import _Progress, _say
from vsi_numba.study.results_file import ResultsWriter, finished_earlier, write_results
from vsi_numba.study.spec import (  # noqa: F401 - StudySpec, study_model: the API
    StudySpec,
    _build_model,
    _load,
    _remember,
    model_fingerprint,
    study_grid,
    study_model,
    study_spec,
)
from vsi_numba.study.store import (
    CaseStore,
    OutputNotWritableError,
    StudyError,
    check_writable,
    store_path,
    study_need,
)

BACKENDS = ("serial", "threads", "processes", "dask")

#: estimated kernel seconds of a study's batches above which the readers of its results
#: are imported while they run (:func:`_import_results_readers`)
PREFETCH_COST = 2.0
#: raw history bytes of a batch above which they are not imported then (a study that
#: keeps time histories at a few speeds is below; one that keeps every run's is above)
PREFETCH_HISTORY_BYTES = 16 * 2**20


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
    from vsi_numba.study.cluster import DaskBackend

    return DaskBackend(n_workers=workers, scheduler=scheduler, local_directory=scratch)


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
    if not fresh and not first_case:
        written = unchanged.finished(cfg, output)  # by its signature: no model built
        if written is not None:
            _say(quiet, unchanged.message(written.n_runs, output))
            return StudyOutcome(output, written.n_runs, written.n_failed, written.n_batches)
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
        n_failed = finished_earlier(output, sha, model_sha, plan_sha)
        if n_failed is not None:  # the same study, written: nothing to recompute
            n_runs = len(grid.cases) * len(models)
            _say(quiet, unchanged.message(n_runs, output))
            if not first_case:
                unchanged.remember(cfg, output, n_runs, n_failed, len(plan))
            return StudyOutcome(output, n_runs, n_failed, len(plan))
    store = CaseStore(spath, sha, config_json, fresh=fresh,
                      model_sha256=model_sha, plan_sha256=plan_sha)
    study = _Study(cfg, specs, models, grid, plan, [lab for lab, _ in variants] or None,
                   config_json, sha, command)
    try:
        with store:
            outcome = _execute(store, study, output, backend, workers, scheduler, progress,
                               keep_cases, quiet)
    except BaseException:
        # a run that stored nothing leaves nothing behind (e.g. an unreachable scheduler)
        if not store_existed and store.path.is_dir() and not store.done():
            store.remove()
        raise
    if not first_case and not keep_cases:
        unchanged.remember(cfg, output, outcome.n_runs, outcome.n_failed, outcome.n_batches)
    return outcome


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
        # the results file is written while the batches run: each as it is stored, then
        # those stored earlier (a resumed study); the test hook that holds inside the
        # final write reads them all back from the store, as a resume does
        writer = (_LazyWriter(lambda: ResultsWriter(output, store, study, need.final_max,
                                                    sync_histories=True))
                  if hold_after() != "write" else None)
        try:
            _run_pending(be, study.task_spec, pending, store, progress, n_runs,
                         n_runs - n_todo, quiet, writer)
            if writer is not None:
                for b in study.plan:
                    if b.key in done:
                        writer.add(b, store.load(b.key))
        except BaseException:
            if writer is not None:
                writer.abort()
            raise
        n_failed = (writer.finish() if writer is not None else
                    write_results(output, store, study, need.final_max))
    else:
        _say(quiet, f"{n_runs} runs: all done earlier, writing {output}")
        n_failed = write_results(output, store, study, need.final_max)
    if not keep_cases:
        store.remove()
    _say(quiet, f"wrote {output}: {n_runs} runs, {n_failed} failed")
    return StudyOutcome(output, n_runs, n_failed, len(study.plan))


class _LazyWriter:
    """A :class:`~vsi_numba.study.results_file.ResultsWriter` made at the first batch
    added (``make()``): the file is created once a batch is stored (a disk without room
    for a batch says so about the batch), by the thread that stores the batches while the
    workers run the others, not before the batches start."""

    def __init__(self, make):
        self._make = make
        self.writer = None

    def add(self, batch, data: dict) -> None:
        if self.writer is None:
            self.writer = self._make()
        self.writer.add(batch, data)

    def finish(self) -> int:
        if self.writer is None:  # nothing added: every batch was stored earlier
            self.writer = self._make()
        return self.writer.finish()

    def abort(self) -> None:
        if self.writer is not None:
            self.writer.abort()


def _workers_note(be, workers, scheduler) -> str:
    """``, 2 workers`` (local backends) or ``, scheduler ADDRESS`` (its workers are counted
    once connected)."""
    if be.name == "serial":
        return ""
    if be.name == "dask" and scheduler is not None:
        return f", scheduler {scheduler}"
    return f", {workers or be.n_workers} workers"


def _start_compile_helper(be, spec, order):
    """The compile helper of a first run (:func:`~vsi_numba.solver.kernel_cache.
    start_helper`) for the families the batches ``order`` need, in that order; only for
    the backends that run the batches in this process (serial, threads, ``--workers``'
    LocalCluster).  Returns the helper's process, or None."""
    from vsi_numba.solver import kernel_cache as kc
    from vsi_numba.study.batches import _packed_train, _spec_of

    in_process = be.name in ("serial", "threads") or (
        be.name == "dask" and getattr(be, "scheduler", None) is None)
    if not in_process or any(kc.is_cached(f) for f in kc.FAMILIES):
        return None
    seen: dict = {}  # train -> family (variants do not change the trains)
    for b in order:
        if b.i_train not in seen:
            seen[b.i_train] = kc.family_of(_packed_train(_spec_of(spec, b), b.i_train))
    return kc.start_helper(seen.values())


def _stop_helper(proc):
    """End the compile helper (if any) when the study stops before it is done."""
    from vsi_numba.solver.kernel_cache import stop_helper

    return stop_helper(proc)


def _import_results_readers(spec, order) -> None:
    """Import what reads the results file afterwards (xarray; ``dask.array`` is not
    imported, :mod:`vsi_numba.io.lazy_dask`) while the batches run, when they are long
    enough: the batches run in worker threads (kernels that release the GIL) or
    processes, so the import takes a share of the cores instead of a serial wait after
    the last batch (the sweep's governing results, a report); also the libraries'
    versions the records of kept outputs are signed with (:mod:`vsi_numba.io.kept`).  In
    this thread, once, after the first batch is stored: no second thread that imports
    while an interrupted sweep shuts down.  xarray not for a study whose batches keep
    large time histories (more than :data:`PREFETCH_HISTORY_BYTES` in a batch): the
    imports' ~65 MB would then add to the peak of the batches' history buffers."""
    if sum(b.cost for b in order) < PREFETCH_COST:
        return
    from vsi_numba.io import kept

    kept.library_versions()  # the records' signatures after the study (~50 ms)
    if _largest_history_bytes(spec, order) > PREFETCH_HISTORY_BYTES:
        return
    import xarray  # noqa: F401

    from vsi_numba.io.lazy_dask import defer_dask_array_import

    defer_dask_array_import()


def _largest_history_bytes(spec, order) -> int:
    """The raw history buffers of the batch of ``order`` that keeps the most
    (:func:`~vsi_numba.study.batches.history_bytes`; 0 without histories)."""
    from vsi_numba.study.batches import _packed_train, _spec_of, history_bytes

    largest = 0
    for b in order:
        if not any(b.histories):
            continue
        sp = _spec_of(spec, b)
        packed = _packed_train(sp, b.i_train)
        speeds = study_model(sp).speeds_m_s
        largest = max(largest, sum(history_bytes(packed, packed.n_steps(float(speeds[s])))
                                   for s, h in zip(b.speeds, b.histories, strict=True) if h))
    return largest


def _run_pending(be, spec, pending, store, progress, n_runs, n_done, quiet=True,
                 writer=None) -> None:
    """Run the batches ``pending`` on the backend ``be``, each stored as it finishes and,
    with a ``writer`` (:class:`~vsi_numba.study.results_file.ResultsWriter`), written
    into the results file at once (by this thread, while the workers run the others)."""
    errors: list[tuple[Batch, BaseException]] = []
    order = sorted(pending, key=lambda b: (-b.cost, b.index))
    hold = hold_after()
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
                        store.write(batch.key, result, remember=writer is None)
                        if writer is not None:
                            writer.add(batch, result)
                        stored += 1
                        if stored == 1:  # the other batches are under way
                            _import_results_readers(spec, order)
                    bar.advance(batch.n_runs)
                    if isinstance(hold, int) and stored >= hold:
                        hold_store(store)
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
