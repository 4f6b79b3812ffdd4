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

from vsi_numba.config._check import _BAD, _MISSING, _Num, _ok

KEYS = {"train", "line_speed_kmh", "speed_factor"}


def _compatibility_section(chk, d, profile, study=_BAD, train=_BAD) -> dict | None:
    """Validate ``[compatibility]``; None without it."""
    if d is _MISSING:
        return None
    if chk.table(d, "compatibility", KEYS,
                 what=" [compatibility] with train and line_speed_kmh") is _BAD:
        return _BAD
    name = chk.string(d, "compatibility", "train", "the name of the train under check "
                                                   "(one of train.preset)")
    line = chk.get_number(d, "compatibility", "line_speed_kmh",
                          _Num("a line speed > 0 km/h (at most 600)", gt=0, le=600))
    factor = chk.get_number(d, "compatibility", "speed_factor", _Num(
        "a factor >= 1 on the line speed (at most 2)", ge=1.0, le=2.0,
        default=profile["compatibility_speed_factor"]))
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
