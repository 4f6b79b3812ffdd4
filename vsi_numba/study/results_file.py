"""The results file of a study: written by slices from the stored batches, one batch in
memory at a time (:class:`vsi_numba.io.study_file.StudyFile`), to a temporary file in the
store, then renamed over the output; its global attributes (the configuration, the
warnings, the rules applied, the fingerprints that tie it to the study that wrote it);
and the test whether a file on disk is this very study's, written (a re-run then leaves
it as it is).  :mod:`.runner` runs the batches and calls :func:`write_results`."""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

import numpy as np

from vsi_numba.io.netcdf import (
    CONVENTIONS,
    _fsync_dir,
    history_line,
    source_string,
)
from vsi_numba.study.batches import _packed_trains
from vsi_numba.study.grid import Case, StudyGrid
from vsi_numba.study.hold import hold, hold_after
from vsi_numba.study.offers import no_values, not_computed_attr, not_offered
from vsi_numba.study.spec import StudyModel, StudySpec, variant_coords
from vsi_numba.study.store import CaseStore, StudyError, final_write_error

#: Global attribute value (``track_type``, ``dt``) of a study whose variants differ in it:
#: each variant's value is in its ``variant_config_json``.
VARIES = "varies by variant"


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


def global_attrs(model: StudyModel, config_json: str, sha: str, grid: StudyGrid,
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
        # "together": every train in one run (interaction); "superposed": moving forces
        attrs["other_trains_loading"] = _loading(model)
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


def identity_attrs(model_sha: str, plan_sha: str) -> dict[str, str]:
    """The attributes that tie a results file to the study that wrote it: the model's
    and the plan's fingerprints (:func:`model_fingerprint`, :func:`plan_fingerprint`)
    and the hash of the package's sources (``engine_sha256``: an edit of the code or
    another version makes the file a different study's)."""
    from vsi_numba._jit import package_hash

    return {"model_sha256": model_sha, "plan_sha256": plan_sha,
            "engine_sha256": package_hash(Path(__file__).resolve().parents[1])}


def finished_earlier(output: Path, sha: str, model_sha: str, plan_sha: str) -> int | None:
    """The failed-run count of ``output`` when it is the results file of this very study
    (the configuration's hash, the model's and the plan's fingerprints and the code's hash
    all equal the file's, see :func:`identity_attrs`), else None (no file, another study's,
    one written before these attributes, or a file that cannot be read)."""
    if not output.is_file():
        return None
    try:
        import netCDF4

        with netCDF4.Dataset(output) as nc:
            attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
    except (OSError, RuntimeError, ValueError):
        return None
    want = {"config_sha256": sha, **identity_attrs(model_sha, plan_sha)}
    if any(str(attrs.get(k, "")) != v for k, v in want.items()):
        return None
    try:
        return int(attrs.get("n_failed_cases", 0))
    except (TypeError, ValueError):
        return None


def write_results(output: Path, store: CaseStore, study,
                   need_bytes: int | None = None) -> int:
    """Stream the stored batches of ``study`` (``runner._Study``) into the results file
    ``output``, written to a temporary file in the store and renamed over ``output``;
    returns the failed-run count."""
    writer = ResultsWriter(output, store, study, need_bytes)
    holding = hold_after() == "write"
    with writer.guard():
        for b in study.plan:
            writer.add(b, store.load(b.key))
            if holding:
                writer.hold()
    return writer.finish()


class ResultsWriter:
    """The results file of a study being written, batch by batch, in any order: the
    temporary file in the store is created with every variable (:class:`StudyFile`),
    :meth:`add` writes a finished batch into its slices, :meth:`finish` writes the
    global attributes and renames the file over the output (:meth:`abort` removes it).

    The runner feeds it the batches as they finish (the file is written while the other
    batches run, :func:`~vsi_numba.study.runner._run_pending`; ``sync_histories``: each
    batch's time histories compressed and written to disk at once), then the batches
    stored earlier; :func:`write_results` the stored batches in plan order.  The values are
    the same whatever the order (each run has its own slice; the failed runs are sorted).
    Errors of the file (a full disk) are raised as
    :func:`~vsi_numba.study.store.final_write_error` says, the temp file removed."""

    def __init__(self, output: Path, store: CaseStore, study, need_bytes: int | None = None,
                 sync_histories: bool = False):
        from vsi_numba.io.study_file import StudyFile
        from vsi_numba.solver.batch import deck_grid

        self.output, self.store, self.study, self.need_bytes = output, store, study, need_bytes
        #: a batch's time histories to disk when it is added (compressed then, while the
        #: other batches run, instead of all at the close)
        self.sync_histories = sync_histories
        specs, models, grid, plan, labels = (study.specs, study.models, study.grid,
                                             study.plan, study.labels)
        self.infos = infos = [trains_info(sp, m) for sp, m in zip(specs, models, strict=True)]
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
        self.omit = not_offered(models, packed)
        self.tmp = tmp = store.temp_path(output.name)
        self.failed: list[str] = []
        self.file = None
        with self.guard():
            self.file = StudyFile(
                tmp, grid.speeds_kmh, grid.trains, grid.irregularities,
                [m.output_points for m in models], [m.bridge.frequencies for m in models],
                n_wheel, n_vehicle, n_time,
                [m.settings.dt for m in models] if labels is not None else model.settings.dt,
                infos, variants, deck_x=[deck_grid(m.bridge, m.output_points) for m in models],
                supports=[m.bridge.supports for m in models], omit=self.omit,
                space=[m.deck.layout for m in models],
                damping=([m.bridge.damping for m in models],
                         [m.config.additional_damping for m in models]),
                loading=_loading(model))

    @contextlib.contextmanager
    def guard(self):
        """Any error inside: the file closed and removed; a file error (OSError, HDF5's
        RuntimeError) raised as :func:`final_write_error`."""
        try:
            yield self
        except (OSError, RuntimeError) as exc:
            error = final_write_error(exc, self.output, self.store, self.need_bytes, self.tmp)
            self.abort()
            raise error from exc
        except BaseException:
            self.abort()
            raise

    def add(self, batch, data: dict) -> None:
        """Write one finished batch (:func:`~vsi_numba.study.batches.run_batch_task`
        output) into its slices."""
        with self.guard():
            info = self.infos[batch.variant or 0]
            self.file.write_batch(batch, data, info["n_wheel"][batch.i_train],
                                  info["n_vehicle"][batch.i_train])
            if self.sync_histories and "hist_runs" in data:
                self.file.flush()
                self.file.nc.sync()
            for r, st in enumerate(data["status"]):
                if st != 0:
                    key = Case(0, batch.speeds[r], batch.i_train, batch.i_irregularity, 0.0,
                               "", 0, False).key
                    self.failed.append(key if batch.variant is None
                                       else f"v{batch.variant:04d}_{key}")

    def hold(self) -> None:
        """Test hook (``hold_after() == "write"``): the file as written so far on disk,
        then hold (sleep until interrupted or killed)."""
        with self.guard():
            self.file.flush()
            self.file.nc.sync()
            hold(self.store)

    def finish(self) -> int:
        """Write the global attributes, close the file and rename it over the output;
        returns the failed-run count."""
        study, model, grid, f = self.study, self.study.models[0], self.study.grid, self.file
        models, labels, failed, tmp = study.models, study.labels, self.failed, self.tmp
        with self.guard():
            failed.sort()
            if labels is None:
                attrs = global_attrs(model, study.config_json, study.sha, grid, len(failed),
                                      failed, study.command)
            else:  # every variant's warnings, marked; one track type or "varies"
                types = {track_type_of(m.config) for m in models}
                attrs = global_attrs(model, study.config_json, study.sha, grid, len(failed),
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
                    f"not written: {self.output} would hold no value of {', '.join(empty)}, "
                    "which this model computes; this is a defect of vsi_numba (the finished "
                    "runs are kept), please report it with the configuration")
            attrs["not_computed"] = not_computed_attr(self.omit)
            # what a re-run compares to leave a file of the same study as it is
            attrs.update(identity_attrs(self.store.model_sha256, self.store.plan_sha256))
            f.close(attrs)
            self.file = None
            if "fatigue" in study.config.resolved():  # the traffic's runs, counted
                from vsi_numba.study import fatigue

                fatigue.write(tmp, fatigue.fatigue_runs(study.config))
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, self.output)
            _fsync_dir(self.output.parent)
        return len(failed)

    def abort(self) -> None:
        """Close the file without finishing it and remove it."""
        if self.file is not None:
            self.file.abort()
            self.file = None
        self.tmp.unlink(missing_ok=True)


def _loading(model) -> str | None:
    """How the trains of ``train.other_trains`` are in the runs: None (none), in the
    same run (interaction trains) or superposed (moving forces)."""
    from vsi_numba.io.schema import SUPERPOSED, TOGETHER
    from vsi_numba.study.batches import interacting

    if not getattr(model.config, "other_trains", []):
        return None
    return TOGETHER if all(interacting(t) for t in model.trains) else SUPERPOSED


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
