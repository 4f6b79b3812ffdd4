"""Measured records of a deck response: a CSV file with columns ``t`` (s) and ``value``.

```text
# deck acceleration at x = 10 m, m s-2, positive down
t,value
0.000,0.0012
0.002,-0.0031
```

Lines starting with ``#`` are comments; a header line ``t,value`` is optional; the times
must increase strictly and be (close to) equally spaced (the sampling step is their mean
spacing; a spacing more than 1 % off it is refused).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

#: Fewest samples of a record.
MIN_SAMPLES = 16
#: Largest record file read (bytes).
MAX_BYTES = 200_000_000


class RecordError(ValueError):
    """A record that cannot be read (the message says why)."""


class Record(NamedTuple):
    """A measured history: times (s, equally spaced) and values."""

    t: np.ndarray
    value: np.ndarray

    @property
    def dt(self) -> float:
        """Sampling step (s)."""
        return float((self.t[-1] - self.t[0]) / (self.t.size - 1))


def read_record(path) -> Record:
    """Read a record file (module notes); :class:`RecordError` says what is wrong."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_BYTES:
            raise RecordError(f"{path}: larger than {MAX_BYTES // 10**6} MB")
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise RecordError(f"cannot read {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise RecordError(f"{path}: not a UTF-8 text file") from None
    rows = []
    for n, line in enumerate(text.splitlines(), start=1):
        s = line.split("#", 1)[0].strip()
        if not s:
            continue
        parts = [p.strip() for p in s.replace(";", ",").split(",")]
        if not rows and [p.lower() for p in parts] == ["t", "value"]:
            continue
        if len(parts) != 2:
            raise RecordError(f"{path}, line {n}: expected two columns t, value, got "
                              f"{line.strip()[:60]!r}")
        try:
            rows.append((float(parts[0]), float(parts[1])))
        except ValueError:
            raise RecordError(f"{path}, line {n}: expected two numbers t, value, got "
                              f"{line.strip()[:60]!r}") from None
    if len(rows) < MIN_SAMPLES:
        raise RecordError(f"{path}: {len(rows)} samples, expected at least {MIN_SAMPLES}")
    a = np.array(rows, float)
    t, v = a[:, 0], a[:, 1]
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise RecordError(f"{path}: non-finite values (nan or inf)")
    d = np.diff(t)
    if np.any(d <= 0):
        k = int(np.argmax(d <= 0))
        raise RecordError(f"{path}: times must increase strictly (t = {t[k + 1]:g} s after "
                          f"{t[k]:g} s)")
    step = (t[-1] - t[0]) / (t.size - 1)
    if np.max(np.abs(d - step)) > 0.01 * step:
        raise RecordError(f"{path}: times not equally spaced (steps {d.min():g} .. "
                          f"{d.max():g} s)")
    return Record(t, v)
