"""A study whose results file is written and whose inputs are unchanged, found without
building its model.

:func:`vsi_numba.study.runner.execute_study` tells a results file of this very study by
the fingerprints the file holds (configuration, model, plan, code), which needs the model
built.  Once it has found one (or written one), it records the file's
:func:`vsi_numba.io.kept.study_signature` - the configuration, the contents of the files
it reads, the package's sources, the libraries' versions and the file's own bytes - with
the counts of the study; the next command whose signature is the same says the same
thing without building the model (nor importing the engine).  ``--fresh``, a case store
beside the output (a run to resume) or records off (``VSI_OUTPUT_CACHE=off``) take the
long way.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from vsi_numba.io import kept

KIND = "study"


@dataclass
class Finished:
    """The counts of a written study (as :class:`vsi_numba.study.runner.StudyOutcome`)."""

    path: Path
    n_runs: int
    n_failed: int
    n_batches: int


def message(n_runs: int, output) -> str:
    """What a command says of a study it does not compute again."""
    return (f"{n_runs} runs: {output} holds them, written for this configuration, model and "
            "code; nothing recomputed (--fresh recomputes them)")


def finished(cfg, output: Path) -> Finished | None:
    """The recorded counts when ``output`` is this study's results file by its signature
    and no case store is beside it; else None."""
    from vsi_numba.study.store import store_path

    output = Path(output)
    if not output.is_file() or store_path(output, "sweep").exists():
        return None
    record = kept.kept_value(KIND, output, kept.study_signature(cfg, output))
    if record is None:
        return None
    try:
        counts = [int(record[k]) for k in ("n_runs", "n_failed", "n_batches")]
    except (KeyError, TypeError, ValueError):
        return None
    return Finished(output, *counts)


def remember(cfg, output: Path, n_runs: int, n_failed: int, n_batches: int) -> None:
    """Record the results file ``output`` of the study ``cfg`` just found or written."""
    kept.remember_value(KIND, Path(output), kept.study_signature(cfg, output),
                        n_runs=n_runs, n_failed=n_failed, n_batches=n_batches)
