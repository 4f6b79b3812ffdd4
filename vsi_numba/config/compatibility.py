"""``[compatibility]``: is this train compatible with this existing bridge?

```toml
[compatibility]
train = "ICE3"                 # the train under check (one of train.preset)
line_speed_kmh = 300.0         # maximum line speed at the bridge
# speed_factor = 1.1           # checked up to this x line speed (code profile
                               # compatibility_speed_factor, [R])
```

The study's speeds must reach ``speed_factor * line_speed_kmh``; the report then answers
the question (:mod:`vsi_numba.analysis.report.compatibility`): compatible or not, the
governing check and its margin, and the train's dynamic signature against the HSLM-A
envelope on the bridge's wavelengths.  ``vsi init --template compatibility`` writes a
configuration with this section.  Everything about the section lives here;
:mod:`vsi_numba.config.core` calls :func:`_compatibility_section`.
"""

from __future__ import annotations

from vsi_numba.config._check import _BAD, _MISSING, _ok
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import expected_of, keys_of

#: The keys of ``[compatibility]``, as declared (:class:`~.schema.models.Compatibility`).
KEYS = keys_of(_m.Compatibility)


def _compatibility_section(chk, d, profile, study=_BAD, train=_BAD) -> dict | None:
    """Validate ``[compatibility]``; None without it."""
    if d is _MISSING:
        return None
    if chk.table(d, "compatibility", KEYS,
                 what=" [compatibility] with train and line_speed_kmh") is _BAD:
        return _BAD
    r = chk.fields(d, "compatibility", _m.Compatibility)
    name, line, factor = r["train"], r["line_speed_kmh"], r["speed_factor"]
    if isinstance(name, str) and not name.strip():
        name = chk.error("compatibility.train", name, expected_of(_m.Compatibility, "train"))
    if factor is None:  # the default is the code profile's
        factor = profile["compatibility_speed_factor"]
    line, factor = (float(v) if _ok(v) else v for v in (line, factor))
    if not _ok(name, line, factor):
        return _BAD
    if _ok(train):
        names = [t.name for t in train.trains]
        if name not in names:
            low = {n.casefold(): n for n in names}
            if name.casefold() in low:
                name = low[name.casefold()]
            else:
                return chk.error("compatibility.train", name, "one of the study's trains "
                                 f"({', '.join(names)})")
    if _ok(study):
        top = max(study.resolved["speeds_kmh"])
        need = factor * line
        if top < need - 1e-6:
            return chk.error("study.speeds_kmh", study.resolved["speeds_kmh"],
                             f"speeds up to {need:g} km/h = {factor:g} x "
                             f"compatibility.line_speed_kmh = {line:g} (the highest is "
                             f"{top:g} km/h)")
    return {"train": name, "line_speed_kmh": line, "speed_factor": factor}
