"""The tests' hook that holds a study at a chosen point (sleeping until it is interrupted
or killed), so that an interruption never races the machine: set :data:`HOLD_ENV` to a
number of stored batches, or to ``write`` (inside the final write of the results file)."""

from __future__ import annotations

import os
import time as _time

#: Environment variable of the tests: hold the study (sleep until interrupted) once this
#: many batches were stored in this run, so an interruption never races the machine.
HOLD_ENV = "VSI_STUDY_HOLD_AFTER"


def hold_after() -> int | str | None:
    """The test hook's setting: a number of stored batches, ``"write"`` (inside the final
    write) or None."""
    value = os.environ.get(HOLD_ENV, "").strip()
    if value == "write":
        return value
    try:
        return int(value) if value else None
    except ValueError:
        return None


def hold(store) -> None:
    """Test hook: announce the hold and sleep until interrupted or killed."""
    (store.path / ".held").write_text(str(os.getpid()))
    while True:
        _time.sleep(0.05)
