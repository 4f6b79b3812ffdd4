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

from vsi_numba.config._check import _BAD
from vsi_numba.config.schema.codes import MAX_TEXT

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
MAX_LENGTH = MAX_TEXT


def _report_section(chk, r) -> dict | None:
    """The strings of a validated ``[report]`` (:class:`~.schema.models.Report`: one
    line of text each, stripped); None when the file has no section."""
    if r is None or r is _BAD:
        return r
    return {k: getattr(r, k) for k in REPORT_KEYS if k in r.model_fields_set}
