"""``[report]``: the title block of the report (project, revision, who prepared and checked
it, client).

Every key is optional and free text; the section changes no result. The resolved config
carries it (so a results file alone reproduces its report's title block) only when the
file has a ``[report]`` table, which leaves the hash of every config without one as it was.

```toml
[report]
project = "Viaduct V-12, km 104+300"
client = "Rail Infrastructure Ltd"
revision = "B"
prepared_by = "A. Engineer"
checked_by = "B. Checker"
document = "VSI-V12-001"
```
"""

from __future__ import annotations

from vsi_numba.config._check import _BAD, _MISSING, _ok
from vsi_numba.config.schema._fields import keys_of
from vsi_numba.config.schema.models import Report

#: The keys of ``[report]``, each a string, with what the report shows for it.
REPORT_KEYS = {
    "project": "project",
    "client": "client",
    "document": "document number",
    "revision": "revision",
    "prepared_by": "prepared by",
    "checked_by": "checked by",
    "approved_by": "approved by",
    "date": "date",
}

#: Longest value accepted (one line of a title block).
MAX_LENGTH = 200


def _report_section(chk, d) -> dict | None:
    """Validate ``[report]``; return its strings (None when the file has no section)."""
    if d is _MISSING:
        return None
    if chk.table(d, "report", keys_of(Report),
                 what=" [report] of text fields (project, revision, checked_by, ...)") is _BAD:
        return _BAD
    out = {}
    for key in REPORT_KEYS:
        if key not in d:
            continue
        v = d[key]
        if isinstance(v, int | float) and not isinstance(v, bool) and key in ("revision",
                                                                              "document"):
            v = str(v)  # revision = 2 means "2"
        if not isinstance(v, str) or not v.strip() or len(v) > MAX_LENGTH or "\n" in v:
            chk.error(f"report.{key}", v, f"one line of text (1 to {MAX_LENGTH} characters)")
            out[key] = _BAD
            continue
        out[key] = v.strip()
    if not _ok(*out.values()):
        return _BAD
    return out
