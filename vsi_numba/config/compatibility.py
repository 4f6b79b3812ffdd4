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

from vsi_numba.config._check import _BAD, _ok
from vsi_numba.config.schema import models as _m
from vsi_numba.config.schema._fields import keys_of

#: The keys of ``[compatibility]``, as declared (:class:`~.schema.models.Compatibility`).
KEYS = keys_of(_m.Compatibility)


def _compatibility_section(chk, c, profile, study=_BAD, train=_BAD) -> dict | None:
    """The resolved ``[compatibility]`` of a validated one (None without it) and the
    checks against the rest: the train is one of the study's, the speeds reach
    speed_factor x line speed (the factor's default is the code profile's)."""
    if c is None or c is _BAD:
        return c
    name, line, factor = c.train, float(c.line_speed_kmh), c.speed_factor
    if factor is None:  # the default is the code profile's
        factor = profile["compatibility_speed_factor"]
    factor = float(factor)
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
