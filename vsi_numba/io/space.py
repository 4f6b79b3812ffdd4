"""Disk space a study needs, estimated before it starts.

A study writes every finished batch to its case store (uncompressed ``.npz``: envelopes
float64, histories float32) and then the results file (envelopes float64, histories
float32 compressed with zlib) as a temporary file inside the store, which is renamed
over the output.  At the end both are on disk at once, so the need is

* ``store``: the batches still to compute (:func:`batch_bytes`, from the array shapes
  the batch will hold; the ``.npz`` container adds a few hundred bytes per array);
* ``final_min``: the results file without its histories (their compression is unknown
  before they exist; envelopes and diagnostics are stored uncompressed);
* ``final_max``: the results file with uncompressed histories (an upper bound).

A study is refused when the free space is below ``store + final_min`` (it could not
finish) and warned about when below ``store + final_max`` (it may not).
"""

from __future__ import annotations

from dataclasses import dataclass

from vsi_numba.io.schema import DIAGNOSTICS, ENVELOPES, HISTORIES, SPACE_HISTORIES

#: ``.npz`` bytes per stored array beside its data (zip entries + ``.npy`` header),
#: measured: 128 (header) + about 150 (local and central zip records with the name).
NPZ_OVERHEAD = 280
#: Characters assumed per stored status message (numpy stores 4 bytes per character;
#: "ok" for a run that succeeded, a sentence for one that failed).
MESSAGE_CHARS = 32
#: netCDF-4 bytes of the file beside the variables' data (metadata, coordinates).
NC_OVERHEAD = 64 * 2**10
#: Upper bound of the HDF5 bytes of one variable beside its data (object header,
#: attributes, chunk index; measured 2-2.5 kB with the load-effect variables' long
#: sign-convention attributes), added to the upper bound of the results file.
NC_VARIABLE_OVERHEAD = 3 * 2**10


def n_file_variables() -> int:
    """Variables and coordinates a results file may declare (:mod:`.schema`)."""
    from vsi_numba.io.schema import COORDS, STUDY_VARIABLES

    return (len(ENVELOPES) + len(HISTORIES) + len(DIAGNOSTICS) + len(STUDY_VARIABLES)
            + len(COORDS))


@dataclass(frozen=True)
class DiskNeed:
    """Bytes a study still needs on the disk of its output (see the module notes)."""

    store: int
    final_min: int
    final_max: int

    @property
    def minimum(self) -> int:
        """Without which the study cannot finish."""
        return self.store + self.final_min

    @property
    def maximum(self) -> int:
        """With which it surely finishes."""
        return self.store + self.final_max


def _width(dims: tuple, sizes: dict) -> int:
    n = 1
    for d in dims:
        if d != "time":
            n *= sizes[d]
    return n


def envelope_row_bytes(n_point: int, n_wheel: int, n_vehicle: int, n_deck_x: int = 0,
                       n_support: int = 0, n_track: int = 0, n_twist: int = 0,
                       all_tracks: bool = False) -> int:
    """float64 bytes of every envelope of one run (``n_deck_x``, ``n_support``: the
    load-effect grid and supports, 0 without load effects; ``n_track``, ``n_twist``: the
    tracks and twist windows of a deck in space, 0 for a planar deck; ``all_tracks``:
    the every-train-loaded twins of ``train.other_trains``)."""
    from vsi_numba.io.schema import ALL_TRACKS, SPACE_ENVELOPES

    sizes = {"point": n_point, "wheel": n_wheel, "vehicle": n_vehicle, "deck_x": n_deck_x,
             "support": n_support, "track": n_track, "twist_x": n_twist}
    tables = [ENVELOPES] + ([SPACE_ENVELOPES] if n_track else []) + (
        [ALL_TRACKS] if all_tracks else [])
    return 8 * sum(_width(dims, sizes) for t in tables for dims, *_ in t.values())


def history_row_bytes(n_point: int, n_wheel_dynamic: int, n_vehicle: int,
                      n_support: int = 0, n_track: int = 0) -> int:
    """float32 bytes of every history of one run at one time step (``n_track``: the
    tracks of a deck in space, 0 for a planar deck)."""
    sizes = {"point": n_point, "wheel": n_wheel_dynamic, "vehicle": n_vehicle,
             "support": n_support, "track": n_track}
    return 4 * sum(_width(dims, sizes) for dims, *_ in (*HISTORIES.values(),
                                                        *SPACE_HISTORIES.values()))


def batch_bytes(n_runs: int, hist_steps: list[int], n_point: int, n_wheel: int,
                n_wheel_dynamic: int, n_vehicle: int, n_deck_x: int = 0,
                n_support: int = 0, n_track: int = 0, n_twist: int = 0,
                all_tracks: bool = False) -> int:
    """Size of one stored batch (bytes): ``n_runs`` runs, of which those in
    ``hist_steps`` (time steps + 1 each) keep their histories, NaN-padded to the
    longest (:func:`vsi_numba.study.batches.run_batch_task`)."""
    size = n_runs * (envelope_row_bytes(n_point, n_wheel, n_vehicle, n_deck_x, n_support,
                                        n_track, n_twist, all_tracks)
                     + 4 * len(DIAGNOSTICS) + 4 * MESSAGE_CHARS)
    n_arrays = len(ENVELOPES) + len(DIAGNOSTICS) + 3
    if hist_steps:
        size += (len(hist_steps) * max(hist_steps)
                 * history_row_bytes(n_point, n_wheel_dynamic, n_vehicle, n_support,
                                     n_track))
        size += 16 * len(hist_steps)
        n_arrays += len(HISTORIES) + 2
    return size + NPZ_OVERHEAD * n_arrays


def megabytes(n: int) -> str:
    """``n`` bytes as a short text (``12.3 MB``)."""
    if n < 10**6:
        return f"{n / 1e3:.1f} kB"
    if n < 10**9:
        return f"{n / 1e6:.1f} MB"
    return f"{n / 1e9:.2f} GB"
