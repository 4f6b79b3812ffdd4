"""``vsi check``: validate a configuration and estimate its study (size, time, memory,
disk) without running anything.

The cost model
--------------
The study is planned exactly as ``vsi sweep`` plans it (variants, speed x train x
realisation grid, batches: :mod:`vsi_numba.study.batches`), and every run's number of
time steps is known from its speed, the train length, the approach and the free
vibration.  From there:

* **time** = :data:`STARTUP_SECONDS` (interpreter, imports, loading the compiled kernels
  from the numba cache, the checks printed at the end) + :data:`KERNEL_FACTOR` x the
  batches' per-step cost (:func:`vsi_numba.study.batches.step_cost`: ~0.01 us per mode
  and output point for moving forces, ~0.5 + 0.4 per wheel + 0.05 per vehicle DOF + 0.02
  per mode and point us for interaction models) x their time steps, shared by the
  workers (one per core, at most one per batch) + :data:`WRITE_SECONDS_PER_MB` per MB
  written.  A deck in space adds :data:`SPACE_ROW_SECONDS` per mode, step and deck row
  beyond the output points (its per-track and twist rows); trains on other tracks
  (``train.other_trains``) run once each and their histories are summed and reduced in
  numpy (:data:`SUPERPOSE_ROW_SECONDS`, :data:`SUPERPOSE_EFFECT_SECONDS`).  A first run
  compiles the kernels (one to three minutes) on top of that.
* **memory** (peak RSS) = :data:`BASE_MEMORY_MB` (the imported libraries and the
  kernels) + the raw time histories of the batches in flight (two per worker; with
  trains on other tracks those of every train of the runs superposed at once, at most
  :data:`~vsi_numba.study.batches.SUPERPOSE_CHUNK_BYTES`) + the superposition's
  temporaries of one run; the
  results file is written one stored batch at a time, so the study's size does not
  count.
* **results file** = the sweep's own disk model (:func:`vsi_numba.study.store.study_need`:
  the netCDF overhead, every envelope in float64 including the load-effect grid and
  supports, the per-variable overhead) + the values of the time histories each history
  run writes (float32, its own train's wheels and vehicles; the NaN padding to the
  longest run compresses to nothing), compressed to about :data:`HISTORY_COMPRESSION`.
* **peak disk** = the case store (every batch, uncompressed ``.npz``) + the results
  file: the file is written, as a temporary file inside the store, before the store is
  removed.

The constants were measured on this project's 2-core machine with a warm numba cache
(``benchmarks/check_estimates.py`` prints estimate against measurement for the bundled
studies and a long axle list; the table and the load it was measured under are in
``docs/check_estimates.md``); ``tests/test_cli_conveniences.py`` checks the estimate
against a real small run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsi_numba.cli.common import EXIT_USAGE, Printer, load_config

#: Seconds of a warm start: interpreter, imports, the numba cache, writing the file.
STARTUP_SECONDS = 3.0
#: Measured kernel time / :func:`~vsi_numba.study.batches.step_cost` estimate.
KERNEL_FACTOR = 1.3
#: Kernel seconds per moving load (axle) and time step (a 2,000-axle list: 150,876 steps
#: in ~0.9 s of CPU, measured under load).
MOVING_LOAD_SECONDS = 3e-9
#: Kernel seconds per mode, time step and deck row beyond the output points (the
#: per-track and twist rows of a deck in space, reduced every step for displacement and
#: acceleration): 0.24 ns, measured on configs/double_track_viaduct.toml with one track
#: loaded (3.8 us per step against 1.4 us without the rows).
SPACE_ROW_SECONDS = 0.24e-9
#: Runs with trains on other tracks (``train.other_trains``) sum the trains' histories
#: and reduce them again in numpy (:mod:`vsi_numba.solver.superpose`): seconds per time
#: step, mode and deck row (displacement, acceleration and whole-deck grid rows) ...
SUPERPOSE_ROW_SECONDS = 0.8e-9
#: ... and per time step, train, axle and load-effect section (the static part of each
#: train's load-effect histories).  Both set on configs/double_track_viaduct.toml (two
#: trains meeting, 12 modes, 822 deck rows, 97 grid points and sections, 50 axles):
#: ``vsi sweep`` measured 19.4 s of CPU (13.8 s with study.load_effects = false) under
#: load, estimated 23.8 s (17.8 s); the constants of the plan alone gave 5.1 s.  With
#: the other trains' kernels reducing no rows (the row term counts the run's own train
#: only), 406 deck rows and the load effects' support moments solved once for every
#: effect (0.7 -> 0.45 ns): HSLM-A1..A10 x 60 speeds (600 runs) measured 36.7 s of CPU,
#: estimated 39.1 s; a 15 + 20 + 15 m deck, 12 modes, 64 runs: 5.8 s, estimated 6.8 s.
#: With the torque and whole-deck M/V of every train loaded and their static part a
#: jitted sweep (kept as they were): 46.8 s measured under load (estimate 0.79x), and a
#: 15 + 20 + 15 m deck, 13 modes, 64 runs, 6.5 s (1.10x).
SUPERPOSE_EFFECT_SECONDS = 0.45e-9
#: Seconds per MB of results written (netCDF, compression of the histories).
WRITE_SECONDS_PER_MB = 0.05
#: Resident memory of a sweep without its batches (MB): Python, numpy, numba, xarray,
#: dask and the checks printed at its end.
BASE_MEMORY_MB = 285.0
#: Compressed / raw size of the float32 time histories written (zlib level 4 with
#: shuffle) of interaction runs: 0.40-0.43 measured on the bundled studies.
HISTORY_COMPRESSION = 0.42
#: The same for moving-force runs (smooth deck and load-effect histories compress less:
#: 0.69 measured).
MOVING_FORCE_HISTORY_COMPRESSION = 0.75

_MB = 2.0**20


@dataclass(frozen=True)
class StudyEstimate:
    """Size and cost of a study (see the module's cost model).

    Attributes
    ----------
    n_variants, n_speeds, n_trains, n_realisations : int
        The study's axes (``n_variants`` = 1 without ``study.vary``).
    n_runs, n_batches, n_history_runs : int
        Runs (speed x train x realisation x variant), kernel batches, runs whose time
        histories are kept.
    n_steps : int
        Time steps of all runs.
    workers : int
        Workers of a local sweep (cores, at most one per batch).
    seconds : float
        Estimated wall time of ``vsi sweep`` with a warm numba cache on idle cores (s).
    cpu_seconds : float
        Estimated CPU time of it (s): the same model with the kernel time summed over
        the workers instead of shared by them.
    memory_bytes, disk_bytes : float
        Estimated peak resident memory and results file size (bytes).
    """

    n_variants: int
    n_speeds: int
    n_trains: int
    n_realisations: int
    n_runs: int
    n_batches: int
    n_history_runs: int
    n_steps: int
    workers: int
    seconds: float
    cpu_seconds: float
    memory_bytes: float
    disk_bytes: float
    peak_disk_bytes: float = 0.0
    frequencies_hz: tuple = ()
    damping_ratios: tuple = ()
    additional_damping: float = 0.0
    speeds_kmh: tuple = ()


def estimate_study(cfg, workers: int | None = None) -> StudyEstimate:
    """Plan the study of ``cfg`` as ``vsi sweep`` would and estimate its cost.

    Parameters
    ----------
    cfg : vsi_numba.config.Config
        A loaded configuration.
    workers : int, optional
        Workers of the sweep; default: the cores available to this process.

    Returns
    -------
    StudyEstimate
    """
    import numpy as np

    from vsi_numba.io.schema import HISTORIES
    from vsi_numba.io.space import NC_VARIABLE_OVERHEAD, history_row_bytes
    from vsi_numba.study.backends import available_cores
    from vsi_numba.study.batches import (
        _packed_trains,
        deck_rows,
        history_bytes,
        study_plan,
        superpose_bytes,
        superpose_chunks,
        superpose_refusal,
    )
    from vsi_numba.study.spec import (
        _build_model,
        _remember,
        study_grid,
        study_spec,
    )

    vcfgs = [v for _, v in cfg.variants] or [cfg]
    first_model = None
    specs, models = [], []
    plan, steps, hist_runs, raw_hist, hist_written, load_seconds = [], 0, 0, 0.0, 0.0, 0.0
    transient = 0.0
    grid = None
    placeholders = []
    for k, c in enumerate(vcfgs):
        spec = study_spec(c)
        model = _planning_model(c, _build_model)
        if model is None:
            model = _build_model(c)
        else:  # not the study's model: forgotten once planned (a sweep rebuilds it)
            placeholders.append(spec)
        _remember(spec, model)
        specs.append(spec)
        models.append(model)
        first_model = first_model or model
        grid = grid or study_grid(model)
        refusal = superpose_refusal(spec, model)
        if refusal is not None:
            from vsi_numba.config import ConfigError

            raise ConfigError([refusal], source=str(cfg.path or "<mapping>"))
        batches = study_plan(spec, model, grid, variant=k if cfg.variants else None,
                             start=len(plan))
        plan += batches
        packed = _packed_trains(spec, model)
        speeds = np.asarray(grid.speeds_kmh, float) / 3.6
        n_i = len(grid.irregularities)
        n_trains = 1 + len(getattr(c, "other_trains", []) or [])
        rows = deck_rows(model)
        for p in packed:
            per_step = _extra_step_seconds(p, rows, n_trains)
            transient = max(transient, superpose_bytes(rows, n_trains,
                                                       p.n_steps(speeds.min())))
            for i_s, v in enumerate(speeds):
                n = p.n_steps(v)
                steps += n * n_i
                # the moving-force kernel visits every load each step; the batch plan's
                # step cost, calibrated on trains of up to ~50 axles, leaves out the rest
                load_seconds += (MOVING_LOAD_SECONDS * max(p.load_positions.size - 50, 0)
                                 * n * n_i)
                # the deck-in-space rows and the superposition of other trains, which
                # the batch plan's step cost leaves out
                load_seconds += per_step * n * n_i
                if grid.history_speeds[i_s]:
                    hist_runs += n_i
                    # the values a history run writes (its own train's wheels and
                    # vehicles); the NaN padding to the longest run compresses to nothing
                    hist_written += n_i * (n + 1) * (
                        HISTORY_COMPRESSION if p.vehicles.wheel_dof.size else
                        MOVING_FORCE_HISTORY_COMPRESSION) * history_row_bytes(
                        model.output_points.size, p.vehicles.wheel_dof.size,
                        p.vehicles.body_dof.size,
                        np.asarray(model.bridge.supports).size)
        # the raw histories a batch keeps: those asked for, and with trains on other
        # tracks every train's of the runs superposed at once (superpose_chunks)
        for b in batches:
            p = packed[b.i_train]
            if n_trains > 1:
                v = speeds[list(b.speeds)]
                held = max(sum(n_trains * history_bytes(p, int(p.n_steps(v[i])))
                               for i in c) for c in superpose_chunks(p, v, n_trains))
            else:
                held = sum(history_bytes(p, int(p.n_steps(speeds[s])))
                           for s, h in zip(b.speeds, b.histories, strict=True) if h)
            raw_hist = max(raw_hist, held)
    n_s, n_t, n_i = grid.shape
    n_runs = n_s * n_t * n_i * len(vcfgs)
    n_workers = max(1, min(workers or available_cores(), len(plan)))
    # the disk model of the sweep itself (vsi_numba.io.space): every stored batch, the
    # results file's envelopes and raw histories; the histories compress to about
    # HISTORY_COMPRESSION of their raw size
    from vsi_numba.study.runner import _Study
    from vsi_numba.study.store import study_need

    need = study_need(_Study(cfg, specs, models, grid, plan,
                             [lab for lab, _ in cfg.variants] or None, "", "", ""), plan)
    # (the disk model's per-variable overhead is an upper bound for the space check;
    # measured, the envelopes' is small and the chunked histories' about twice it)
    disk = (need.final_min + hist_written
            + (2 * NC_VARIABLE_OVERHEAD * len(HISTORIES) if hist_runs else 0))
    # the results file is written (as a temporary file in the store) while every batch
    # is still stored: the peak is the store plus the file
    peak_disk = need.store + disk
    kernel = KERNEL_FACTOR * (sum(b.cost for b in plan) + load_seconds)
    fixed = STARTUP_SECONDS + WRITE_SECONDS_PER_MB * disk / _MB
    seconds, cpu_seconds = fixed + kernel / n_workers, fixed + kernel
    # (the superposition's temporaries are short-lived: one worker's at a time)
    memory = BASE_MEMORY_MB * _MB + 2 * n_workers * raw_hist + transient
    from vsi_numba.study.spec import _MODELS

    for spec in placeholders:
        _MODELS.pop(spec, None)
    return StudyEstimate(
        n_variants=len(vcfgs), n_speeds=n_s, n_trains=n_t, n_realisations=n_i,
        n_runs=n_runs, n_batches=len(plan), n_history_runs=hist_runs, n_steps=int(steps),
        workers=n_workers, seconds=seconds, cpu_seconds=cpu_seconds, memory_bytes=memory,
        disk_bytes=disk, peak_disk_bytes=peak_disk,
        frequencies_hz=tuple(float(f) for f in first_model.bridge.frequencies),
        damping_ratios=tuple(float(z) for z in np.broadcast_to(
            first_model.bridge.damping, first_model.bridge.frequencies.shape)),
        additional_damping=float(getattr(first_model.config, "additional_damping", 0.0)
                                 or 0.0),
        speeds_kmh=tuple(float(v) for v in grid.speeds_kmh))


def _planning_model(cfg, build):
    """The study model of ``cfg`` for planning only, or None: with several random track
    realisations, the profile of the first stands for every one (the plan and the
    costs depend on their number, not on their values), so ``vsi check`` of 10,000
    seeds generates one profile instead of 10,000."""
    import dataclasses

    from vsi_numba.study.spec import _first_realisation

    first = _first_realisation(cfg)
    if first is cfg:
        return None
    model = build(first)
    (profile,) = model.profiles.values()
    seeds = cfg.irregularity_seeds
    return dataclasses.replace(model, config=cfg,
                               profiles={int(s): profile for s in seeds})


def _extra_step_seconds(packed, rows, n_trains: int) -> float:
    """Kernel and numpy seconds per time step of a run that the batch plan's step cost
    leaves out: the deck-in-space rows (:data:`SPACE_ROW_SECONDS`, the run's train's
    kernel)
    and, with trains on other tracks, the superposition (:data:`SUPERPOSE_ROW_SECONDS`,
    :data:`SUPERPOSE_EFFECT_SECONDS`)."""
    n_p, n_rows, n_grid, n_sec = rows
    n_m = int(packed.bridge.omega.size)
    # (the other trains' kernels reduce no rows: only the run's own train's)
    out = SPACE_ROW_SECONDS * n_m * max(n_rows - 2 * n_p, 0)
    if n_trains > 1:
        out += SUPERPOSE_ROW_SECONDS * n_m * (n_rows + n_grid)
        out += SUPERPOSE_EFFECT_SECONDS * n_trains * int(packed.load_positions.size) * n_sec
    return out


def _size(n_bytes: float) -> str:
    for unit, f in (("GB", 2.0**30), ("MB", _MB), ("kB", 2.0**10)):
        if n_bytes >= f:
            return f"{n_bytes / f:.3g} {unit}"
    return f"{n_bytes:.0f} B"


def _duration(s: float) -> str:
    if s < 90:
        return f"{s:.2g} s" if s < 10 else f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def _list(values, fmt, limit: int = 8) -> str:
    shown = [format(v, fmt) for v in values[:limit]]
    return ", ".join(shown) + (f", ... ({len(values) - limit} more)" if len(values) > limit
                               else "")


def model_lines(est: StudyEstimate, variants: bool = False) -> list[str]:
    """The retained modes (frequencies, damping ratios) and the speed grid, as printed."""
    f, z = est.frequencies_hz, est.damping_ratios
    lines = []
    base = " (base values; the variants change them)" if variants else ""
    if f:
        extra = (f"; + {100 * est.additional_damping:.2f} % for moving-force trains "
                 "(EN 1991-2 6.4.6.3.1)" if est.additional_damping > 0 else "")
        lines.append(f"modes: {len(f)} retained, f = {_list(f, '.4g')} Hz; damping "
                     f"ratios {_list([100 * v for v in z], '.2f')} %{extra}{base}")
    else:
        lines.append("modes: none (rigid track)")
    v = np.asarray(est.speeds_kmh, float)
    if v.size == 1:
        lines.append(f"speeds: 1, {v[0]:g} km/h")
    elif v.size:
        steps = np.diff(v)
        step = (f"step {steps[0]:g} km/h" if np.allclose(steps, steps[0], rtol=1e-6,
                                                           atol=1e-9)
                else f"steps {steps.min():g} to {steps.max():g} km/h")
        lines.append(f"speeds: {v.size} from {v[0]:g} to {v[-1]:g} km/h, {step} "
                     f"({v[0] / 3.6:.4g} to {v[-1] / 3.6:.4g} m/s)")
    return lines


def check_command(config: Path, workers: int | None = None) -> int:
    """``vsi check CONFIG``: validate, print the warnings, the study size and the estimate.

    Returns
    -------
    int
        0 valid (warnings or not); 2 invalid (every error printed, as for ``vsi sweep``).
    """
    pr = Printer()
    cfg = load_config(config, pr)
    if cfg is None:
        return EXIT_USAGE
    for w in cfg.warnings:
        pr.warning(w)
    from vsi_numba.config import ConfigError

    try:
        est = estimate_study(cfg, workers)
    except ConfigError as exc:  # over the budget of the runs (the study's own checks)
        pr.config_error(config, exc)
        return EXIT_USAGE
    except (ValueError, OSError) as exc:  # e.g. a model that cannot be built
        pr.error(f"{config}: the study cannot be planned: {exc}")
        return EXIT_USAGE
    def n(count: int, word: str, plural: str | None = None) -> str:
        return f"{count:,} {word if count == 1 else plural or word + 's'}"

    n_v = f"{n(est.n_variants, 'variant')} x " if cfg.variants else ""
    pr.line(f"{config}: valid configuration ({len(cfg.warnings)} warning"
            f"{'' if len(cfg.warnings) == 1 else 's'}), config SHA-256 {cfg.sha256[:12]}")
    if any(v.loads.size for t in cfg.trains() for v in t.vehicles):
        from vsi_numba.model.distribution import describe_config

        pr.line(f"input: {describe_config(cfg.resolved())}")
    pr.line(cfg.code_profile.summary())  # the clause values the checks will use
    if "fatigue" in cfg.resolved():  # one more run per train of the fatigue traffic
        from vsi_numba.config.fatigue import describe

        pr.line(describe(cfg.resolved()["fatigue"]) + " (one run per train after the sweep)")
    pr.line(f"study: {n(est.n_runs, 'run')} = {n_v}{n(est.n_speeds, 'speed')} x "
            f"{n(est.n_trains, 'train')} x {n(est.n_realisations, 'track realisation')}, in "
            f"{n(est.n_batches, 'batch', 'batches')}; {n(est.n_steps, 'time step')}; "
            f"time histories of {n(est.n_history_runs, 'run')}")
    for line in model_lines(est, bool(cfg.variants)):
        pr.line(line)
    pr.line(f"estimate (warm numba cache, {est.workers} worker"
            f"{'' if est.workers == 1 else 's'}): time ~{_duration(est.seconds)}, peak "
            f"memory ~{_size(est.memory_bytes)}, results file ~{_size(est.disk_bytes)} "
            f"({cfg.output_path}), peak disk ~{_size(est.peak_disk_bytes)} (the file and "
            "the case store beside it while it is written); a first run adds 1-3 min of "
            "compilation")
    if "calibration" in cfg.resolved() or "reliability" in cfg.resolved():
        from vsi_numba.existing.estimate import lines as existing_lines

        for line in existing_lines(cfg):  # vsi calibrate, vsi reliability
            pr.line(line)
    pr.line("nothing was run (vsi sweep runs it)")
    return 0
