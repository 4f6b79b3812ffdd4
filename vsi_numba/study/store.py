"""The batch store: one file per finished batch, next to the study output.

A study writing ``out.nc`` keeps its finished batches in ``out.nc.cases/`` (``vsi sweep``,
resumable) or ``out.nc.run-cases/`` (``vsi run``, never resumed: a run started on the
output of an interrupted sweep never touches the sweep's batches).  When ``out.nc`` is
so long a name that the suffix would not fit the file system, the store's name is
shortened with a hash of the output name (:func:`vsi_numba.io.paths.fitting_name`).

``store.json``
    manifest: store format, ``config_sha256`` and the resolved configuration of the study
    that owns the store, the model and batch-plan hashes, package version, creation time.
``batch_t001_i002_s0010-0019.npz``
    one finished batch (train 1, realisation 2, speeds 10..19): its envelopes, status and
    histories as numpy arrays, written by :func:`vsi_numba.io.netcdf.write_atomic`: a
    batch file exists completely or not at all, whatever happens to the process (Ctrl-C,
    SIGKILL, power loss after the fsync).
``.lock``
    ``flock``-ed while a run uses the store, so two runs cannot write one store; it is
    the last thing removed.
``.*.tmp``
    files being written (batches, the final results file); left by a killed run, they
    are removed by the next one.

Resume is "skip every batch whose file exists".  A store is only ever reused by a run
whose configuration, model data and batch plan are the same: anything else is refused
with :class:`StoreMismatchError` (never silently mixed).  After the final file is written
the store is removed (its content is all in the final file).

Removal is safe against a kill at any point: the store directory is first renamed,
atomically, to a hidden tombstone ``.out.nc.cases.removing`` (so it is either the
complete store, which a re-run resumes, or no store at all), then deleted; the next run
on that output deletes a tombstone left behind.  Clearing a store for ``--fresh``
deletes the batches first and the manifest last, so an interrupted clear leaves a valid
store with fewer batches, never batches without a manifest.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import zipfile
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from vsi_numba.io.atomic import (
    DirectoryBusyError,
    DirectoryLocks,
    describe,
    make_parents,
    write_atomic,
    write_bytes_atomic,
)
from vsi_numba.io.atomic import fsync_dir as _fsync_dir
from vsi_numba.io.netcdf import package_version
from vsi_numba.io.paths import fitting_name, name_max

STORE_FORMAT = 2
MANIFEST = "store.json"
LOCK = ".lock"
#: bytes of finished batches a store keeps in memory for the final write (envelopes: a few
#: kB per batch)
MEMORY_BUDGET = 64 * 2**20
#: of which batches with time histories (a study that keeps histories at a few speeds:
#: its history batches are not read back; larger ones come from their files, so that the
#: held histories do not add to the peak memory of the batches' own buffers)
HISTORY_MEMORY_BUDGET = 16 * 2**20
_BATCH_FILE = re.compile(r"^batch_((?:v\d{4,}_)?t\d{3,}_i\d{3,}_s\d{4,}-\d{4,})\.npz$")


class StudyError(Exception):
    """A study could not run or finish; ``exit_code`` is the CLI's exit status."""

    exit_code = 1


class StoreMismatchError(StudyError):
    """The case store belongs to another configuration (or is not a case store)."""

    exit_code = 2


class OutputNotWritableError(StudyError):
    """The output file or its case store cannot be written (permissions, read-only fs)."""

    exit_code = 2


class StoreBusyError(StudyError):
    """Another run holds the case store's lock."""

    exit_code = 2


class StoreWriteError(StudyError):
    """Writing a finished batch or the final file failed (e.g. disk full)."""

    exit_code = 1


class InsufficientSpaceError(StudyError):
    """The disk of the output has too little free space for the study (checked before
    it starts)."""

    exit_code = 2


class CorruptBatchError(StudyError):
    """A stored batch cannot be read or is not the batch its name says."""

    exit_code = 1


#: Suffix of the store of each command (``vsi sweep`` / ``run_study``, ``vsi run``).
STORE_SUFFIX = {"sweep": ".cases", "run": ".run-cases"}
TOMBSTONE_SUFFIX = ".removing"


def store_path(output: str | os.PathLike, command: str = "sweep") -> Path:
    """Case store directory of a study output: ``<output>.cases`` beside it
    (``<output>.run-cases`` for ``command="run"``), shortened with a hash of the output
    name when that would be too long a file name."""
    output = Path(output)
    limit = name_max(output.parent if str(output.parent) else ".")
    return output.with_name(fitting_name(output.name, suffix=STORE_SUFFIX[command],
                                         limit=limit))


def tombstone_path(store: str | os.PathLike) -> Path:
    """Where a store being removed is renamed first: ``.<store name>.removing``."""
    store = Path(store)
    limit = name_max(store.parent if str(store.parent) else ".")
    return store.with_name(fitting_name(store.name, prefix=".", suffix=TOMBSTONE_SUFFIX,
                                        limit=limit))


def remove_tombstone(store: str | os.PathLike) -> None:
    """Finish the removal of a store that a killed run had begun (if any)."""
    tomb = tombstone_path(store)
    if tomb.is_dir() and not tomb.is_symlink():
        shutil.rmtree(tomb, ignore_errors=True)


def _is_permission(exc: OSError) -> bool:
    return isinstance(exc, PermissionError) or exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM)


def check_writable(directory: Path, what: str) -> None:
    """Create ``directory`` if needed and prove a file can be created in it.

    Raises :class:`OutputNotWritableError` with the reason (read-only, permissions).
    """
    probe = directory / f".vsi-write-test.{os.getpid()}"
    try:  # nothing is made inside a directory another process is replacing
        with DirectoryLocks(shared=directory), DirectoryLocks(shared=make_parents(directory)):
            try:
                with open(probe, "wb") as f:
                    f.write(b"x")
                    f.flush()
                    os.fsync(f.fileno())
            finally:  # a full disk fails the write or the flush: the probe goes either way
                with contextlib.suppress(OSError):
                    probe.unlink()
    except DirectoryBusyError as exc:
        raise OutputNotWritableError(f"cannot write the {what} in {directory}: {exc}") from exc
    except OSError as exc:
        full = exc.errno in (errno.ENOSPC, errno.EDQUOT)
        raise OutputNotWritableError(
            f"cannot write the {what} in {directory}: {describe(exc)}. "
            + ("Free some space or choose another output (-o PATH)." if full else
               "Choose another output (-o PATH) or make the directory writable.")
        ) from exc


class CaseStore:
    """Finished batches of one study, one atomic file each (see the module notes).

    Parameters
    ----------
    path : path-like
        Store directory (:func:`store_path` of the output).
    config_sha256, config_json : str
        Identity and content of the resolved configuration.
    model_sha256 : str
        Hash of the model data built from it (see ``runner.model_fingerprint``).
    fresh : bool
        Delete an existing store of this output first (whatever its configuration).
    """

    def __init__(self, path, config_sha256: str, config_json: str, fresh: bool = False,
                 model_sha256: str = "", plan_sha256: str = ""):
        self.path = Path(path)
        self.sha256 = config_sha256
        self.model_sha256 = model_sha256
        self.plan_sha256 = plan_sha256
        self.config_json = config_json
        self.fresh = fresh
        self._lock_fd: int | None = None
        # copies of the batches written by this process, read back by ``load`` instead of
        # their files at the final write (up to MEMORY_BUDGET bytes; the files stay the
        # record a resume reads)
        self._memory: dict[str, tuple[dict, int, int]] = {}  # key -> (arrays, bytes, of histories)
        self._memory_bytes = 0
        self._memory_history_bytes = 0

    # -------------------------------------------------------------- life cycle
    def open(self) -> CaseStore:
        """Create or adopt the store, refusing one made by another configuration."""
        if self.path.exists() and not self.path.is_dir():
            raise StoreMismatchError(f"{self.path} exists and is not a case store directory")
        remove_tombstone(self.path)
        check_writable(self.path, "case store")
        self._lock()
        try:
            if self.fresh:
                self._check_ours(allow_other_config=True)
                self._clear(keep_lock=True)
            manifest = self.path / MANIFEST
            self._check_ours(allow_other_config=False)
            if not manifest.exists():
                info = {
                    "format": STORE_FORMAT,
                    "config_sha256": self.sha256,
                    "model_sha256": self.model_sha256,
                    "plan_sha256": self.plan_sha256,
                    "package_version": package_version(),
                    "created": datetime.now(UTC).isoformat(timespec="seconds"),
                    "config_json": self.config_json,
                }
                try:
                    write_bytes_atomic(manifest, json.dumps(info, indent=1).encode())
                except OSError as exc:
                    raise _write_error(exc, manifest, self) from exc
            self._clean_temp()
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        """Release the lock (the files stay)."""
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None

    def __enter__(self) -> CaseStore:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    def remove(self) -> None:
        """Delete the store (after its batches went into the final file).

        The directory is renamed to its tombstone (:func:`tombstone_path`) in one atomic
        step, then deleted: a kill before the rename leaves the whole store (a re-run
        resumes it), a kill after it leaves only the tombstone, which the next run on
        this output deletes.  The lock is held until the end.
        """
        remove_tombstone(self.path)  # left by an earlier, killed removal
        tomb = tombstone_path(self.path)
        try:
            os.rename(self.path, tomb)
        except FileNotFoundError:
            self.close()
            return
        except OSError:  # the parent cannot take a new name: delete in place, manifest last
            with contextlib.suppress(OSError):
                self._clear(keep_lock=False)
                self.path.rmdir()
            self.close()
            return
        _fsync_dir(self.path.parent)
        shutil.rmtree(tomb, ignore_errors=True)
        self.close()

    def check_space(self, need, output: Path) -> str | None:
        """Refuse a study that cannot fit on the disk of its store, before it starts.

        ``need`` is a :class:`vsi_numba.io.space.DiskNeed`.  Raises
        :class:`InsufficientSpaceError` when the free space is below ``need.minimum``;
        returns a warning when it is below ``need.maximum`` (the compressed histories may
        not fit), else None.
        """
        from vsi_numba.io.space import megabytes

        try:
            free = shutil.disk_usage(self.path).free
        except OSError:  # pragma: no cover - cannot tell: let the writes decide
            return None
        n = len(self.done())
        kept = (f" The {n} finished batch(es) stay in {self.path}; re-run the same command "
                "to resume." if n else "")
        if free < need.minimum:
            raise InsufficientSpaceError(
                f"not enough disk space for {output}: the study needs about "
                f"{megabytes(need.minimum)} ({megabytes(need.store)} of case store for the "
                f"batches still to run, then at least {megabytes(need.final_min)} for the "
                f"results file), but only {megabytes(free)} are free on the disk of "
                f"{self.path}. Free some space, write to another disk (-o PATH), or save "
                f"fewer time histories (study.history_speeds_kmh).{kept}")
        if free < need.maximum:
            return (f"the disk of {output} has {megabytes(free)} free; the study needs "
                    f"{megabytes(need.minimum)} to {megabytes(need.maximum)} (depending on "
                    "how well its time histories compress): it may run out of space at the "
                    "final write (the finished batches would be kept for a resume)")
        return None

    # -------------------------------------------------------------- content
    def done(self) -> set[str]:
        """Keys of the finished batches."""
        keys = set()
        for p in self.path.iterdir():
            m = _BATCH_FILE.match(p.name)
            if m:
                keys.add(m.group(1))
        return keys

    def batch_path(self, key: str) -> Path:
        """File of batch ``key``."""
        return self.path / f"batch_{key}.npz"

    def temp_path(self, name: str) -> Path:
        """A path for a file being written inside the store (removed if left behind)."""
        return self.path / fitting_name(name, prefix=".", suffix=f".{os.getpid()}.tmp",
                                        limit=name_max(self.path))

    def write(self, key: str, arrays: dict, remember: bool = True) -> Path:
        """Store one finished batch atomically (``arrays``: name -> numpy array); with
        ``remember``, a copy stays in memory for the final write (within the budgets)."""
        target = self.batch_path(key)
        data = {"batch_key": np.array(key)}
        data.update({k: v for k, v in arrays.items() if v is not None})

        def write(tmp):
            with open(tmp, "wb") as f:
                np.savez(f, **data)

        try:
            path = write_atomic(target, write)
        except OSError as exc:
            raise _write_error(exc, target, self) from exc
        self._forget(key)
        size = sum(v.nbytes for v in data.values())
        hist = size if "hist_runs" in data else 0
        if (remember and self._memory_bytes + size <= MEMORY_BUDGET
                and self._memory_history_bytes + hist <= HISTORY_MEMORY_BUDGET):
            self._memory[key] = ({k: np.array(v, copy=True) for k, v in data.items()}, size,
                                 hist)
            self._memory_bytes += size
            self._memory_history_bytes += hist
        return path

    def check(self, key: str) -> None:
        """Check that the stored batch ``key`` is readable and is that batch."""
        path = self.batch_path(key)
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as z:
                found = str(z["batch_key"])
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise CorruptBatchError(
                f"the stored batch {path} cannot be read ({type(exc).__name__}: {exc}). "
                "Delete this file and re-run the same command to compute it again."
            ) from exc
        if found != key:
            raise CorruptBatchError(
                f"the stored batch {path} holds batch {found!r}, not {key!r} (a file was "
                "renamed or copied in). Delete it and re-run the same command."
            )

    def load(self, key: str) -> dict:
        """Read one finished batch into memory (the file is closed on return).  A batch
        this process wrote comes from its copy in memory, once (the file is not read:
        ~6 ms per batch of envelopes)."""
        data = self._forget(key)
        if data is not None:
            return data
        path = self.batch_path(key)
        try:
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise CorruptBatchError(
                f"cannot read the stored batch {path}: {exc}. Delete this file and re-run "
                "the same command to compute that batch again."
            ) from exc

    # -------------------------------------------------------------- helpers
    def _forget(self, key: str) -> dict | None:
        """Drop the copy in memory of batch ``key``; returns it (None if there is none)."""
        data, size, hist = self._memory.pop(key, (None, 0, 0))
        self._memory_bytes -= size
        self._memory_history_bytes -= hist
        return data

    def _check_ours(self, allow_other_config: bool) -> None:
        manifest = self.path / MANIFEST
        if not manifest.exists():
            foreign = sorted(p.name for p in self.path.iterdir() if not p.name.startswith("."))
            if foreign:
                raise StoreMismatchError(
                    f"{self.path} is not a vsi case store (no {MANIFEST}, but it holds "
                    f"{', '.join(foreign[:3])}{' ...' if len(foreign) > 3 else ''}); not "
                    "touching it. Delete it yourself or write to another output (-o PATH)."
                )
            return
        try:
            info = json.loads(manifest.read_text())
        except (OSError, ValueError) as exc:
            raise StoreMismatchError(f"unreadable case store manifest {manifest}: {exc}") from exc
        if allow_other_config:
            return
        if info.get("format") != STORE_FORMAT:
            raise StoreMismatchError(
                f"the case store {self.path} has format {info.get('format')!r}, this version "
                f"uses {STORE_FORMAT}: delete it, re-run with --fresh, or use another output."
            )
        if info.get("config_sha256") != self.sha256:
            raise StoreMismatchError(
                f"the case store {self.path} holds {len(self.done())} finished batch(es) of a "
                f"DIFFERENT configuration (sha256 {str(info.get('config_sha256'))[:12]}..., "
                f"this one is {self.sha256[:12]}...). Results of two configurations are never "
                "mixed: delete that directory (or re-run with --fresh) to start again, or "
                "write to another output (-o PATH)."
            )
        if info.get("plan_sha256", "") != self.plan_sha256:
            raise StoreMismatchError(
                f"the case store {self.path} was cut into batches differently (another "
                "version of vsi_numba). Results are never mixed: delete that directory (or "
                "re-run with --fresh) to start again, or write to another output (-o PATH)."
            )
        if info.get("model_sha256", "") != self.model_sha256:
            raise StoreMismatchError(
                f"the case store {self.path} was computed from different model data than "
                "this configuration now builds (same configuration text, but a train preset, "
                "a profile file or the package changed). Results are never mixed: delete that "
                "directory (or re-run with --fresh) to start again, or write to another "
                "output (-o PATH)."
            )

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows: no advisory lock
            return
        fd = os.open(self.path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            raise StoreBusyError(
                f"another run is using the case store {self.path} (it is locked); wait for it "
                "to finish or write to another output (-o PATH)."
            ) from exc
        self._lock_fd = fd

    def _clean_temp(self) -> None:
        """Remove temp files left by a killed run (never a finished case)."""
        for p in self.path.iterdir():
            if p.name.startswith(".") and p.name.endswith(".tmp"):
                with contextlib.suppress(OSError):
                    p.unlink()

    def _clear(self, keep_lock: bool) -> None:
        """Delete the content: the manifest last (an interrupted clear leaves a valid
        store with fewer batches), the lock only if not ``keep_lock``."""
        last = [self.path / MANIFEST] + ([] if keep_lock else [self.path / LOCK])
        for p in [p for p in self.path.iterdir() if p.name not in (MANIFEST, LOCK)] + last:
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink(missing_ok=True)


def study_need(study, pending):
    """Disk need (:class:`vsi_numba.io.space.DiskNeed`) of a study (``runner._Study``)
    with the batches ``pending`` still to run."""
    from vsi_numba.io.schema import DIAGNOSTICS
    from vsi_numba.io.space import (
        NC_OVERHEAD,
        NC_VARIABLE_OVERHEAD,
        DiskNeed,
        batch_bytes,
        envelope_row_bytes,
        history_row_bytes,
        n_file_variables,
    )
    from vsi_numba.solver.batch import deck_grid
    from vsi_numba.study.batches import _packed_trains

    grid = study.grid
    # load effects: the whole-deck grid and the supports (upper bound: always counted)
    n_x = max(deck_grid(m.bridge, m.output_points).size for m in study.models)
    n_s = max(np.asarray(m.bridge.supports).size for m in study.models)
    # a deck in space: the histories along its tracks
    n_k = max(m.deck.layout.n_tracks if m.deck.layout is not None else 0
              for m in study.models)
    n_tw = max(np.size(m.deck.layout.twist_x) if m.deck.layout is not None else 0
               for m in study.models)
    # trains on other tracks: the every-train-loaded envelopes (..._all_tracks) too
    all_tracks = any(getattr(m.config, "other_trains", []) for m in study.models)
    packed = [_packed_trains(sp, m) for sp, m in zip(study.specs, study.models, strict=True)]
    speeds = [float(v) / 3.6 for v in grid.speeds_kmh]

    def dims(b):
        p = packed[b.variant or 0][b.i_train]
        return (study.models[b.variant or 0].output_points.size,
                p.wheel_positions.size + p.load_positions.size,
                p.vehicles.wheel_dof.size, p.vehicles.body_dof.size, p)

    store = 0
    for b in pending:
        n_p, n_w, n_wd, n_v, p = dims(b)
        steps = [p.n_steps(speeds[s]) + 1
                 for s, h in zip(b.speeds, b.histories, strict=True) if h]
        store += batch_bytes(b.n_runs, steps, n_p, n_w, n_wd, n_v, n_x, n_s, n_k, n_tw,
                             all_tracks)
    n_p = max(m.output_points.size for m in study.models)
    shapes = [dims(b)[1:4] for b in study.plan]
    n_w = max((d[0] for d in shapes), default=0)  # the file's wheel dim: all the wheels
    n_v = max((d[2] for d in shapes), default=0)
    n_runs = study.n_runs
    final_min = NC_OVERHEAD + n_runs * (envelope_row_bytes(n_p, n_w, n_v, n_x, n_s, n_k,
                                                           n_tw, all_tracks)
                                        + 4 * len(DIAGNOSTICS))
    hist = [dims(b)[4].n_steps(speeds[s]) + 1 for b in study.plan
            for s, h in zip(b.speeds, b.histories, strict=True) if h]
    final_max = final_min + (len(hist) * max(hist, default=0)
                             * history_row_bytes(n_p, n_w, n_v, n_s, n_k)) + (
        NC_VARIABLE_OVERHEAD * n_file_variables())
    return DiskNeed(store=int(store), final_min=int(final_min), final_max=int(final_max))


def final_write_error(exc: BaseException, output: Path, store: CaseStore,
                      need_bytes: int | None = None, partial: Path | None = None
                      ) -> StudyError:
    """The error of a failed write of the results file ``output`` (written as the temp
    file ``partial`` in ``store``, then renamed; call this before deleting it): what
    happened, which file, the space needed and the space that was free for it, and that
    the finished batches are kept."""
    from vsi_numba.io.space import megabytes

    try:
        n = len(store.done())
    except OSError:
        n = 0
    keep = (f"The {n} finished batch(es) are kept in the case store {store.path}; re-run "
            "the same command to resume once this is fixed (only the results file is "
            "written again).")
    try:
        free = shutil.disk_usage(store.path if store.path.is_dir() else output.parent).free
        if partial is not None and partial.exists():  # what the failed write had taken
            free += partial.stat().st_blocks * 512
    except OSError:
        free = None
    errno_ = getattr(exc, "errno", None)
    reason = getattr(exc, "strerror", None) or str(exc)
    cause = exc.__cause__ if exc.__cause__ is not None else exc
    hdf = isinstance(cause, RuntimeError) or "HDF error" in str(exc)
    if hdf and isinstance(cause, RuntimeError):
        reason = str(cause)
    space = ""
    if need_bytes is not None or free is not None:
        space = (f" The results file needs up to about {megabytes(need_bytes)}"
                 if need_bytes is not None else " The results file")
        space += (f"; {megabytes(free)} were free for it on the disk of {store.path}."
                  if free is not None else ".")
    if isinstance(exc, OSError) and _is_permission(exc):
        return OutputNotWritableError(f"cannot write {output} (the results file): {reason}. "
                                      f"{keep}")
    if errno_ in (errno.ENOSPC, errno.EDQUOT):
        what = "the disk is full (no space left on the device)"
    elif errno_ == errno.EFBIG:
        what = "a file size limit was reached (file too large)"
    elif hdf:
        what = (f"the netCDF library failed ({reason}), most likely because the disk is "
                "full or a file size limit was reached")
    else:
        what = reason
    return StoreWriteError(f"cannot write {output} (the results file): {what}.{space} {keep}")


def _write_error(exc: OSError, target: Path, store: CaseStore) -> StudyError:
    n = len(store.done()) if store.path.is_dir() else 0
    keep = (
        f"The {n} finished batch(es) are kept in {store.path}; re-run the same command to "
        "resume once this is fixed."
    )
    if _is_permission(exc):
        return OutputNotWritableError(f"cannot write {target}: {exc.strerror or exc}. {keep}")
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return StoreWriteError(f"cannot write {target}: {exc.strerror} (disk full?). {keep}")
    return StoreWriteError(f"cannot write {target}: {exc}. {keep}")
