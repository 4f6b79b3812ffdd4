"""The report's "Code profile" section: the clause values the checks used, printed once
(key, value, unit, clause, [R], override), and how the HSLM-B of the study was given.

The profile is the one stored with the results (``code_profile`` in ``config_json``, see
:func:`vsi_numba.analysis.checks.profile_of`), so the section shows what the checks of
the same report used.
"""

from __future__ import annotations

import pandas as pd
import xarray as xr

from vsi_numba.analysis.checks import profile_of, results_config
from vsi_numba.analysis.report.document import Markdown, Section, Table
from vsi_numba.analysis.report.safe import md
from vsi_numba.code_profile import DEFAULT_NAME, RECALLED, RECALLED_MEANING, default_profile

#: Title (and anchor "code-profile") of the section.
TITLE = "Code profile"

#: What "applies" means, for the note under the table.
_APPLIES = {
    "checks": "the checks of this report",
    "input": "read with the configuration (damping rules, α range, HSLM applicability)",
    "fixed": "part of the model or of the run; not overridable",
}


def _number(value: float) -> str:
    return f"{value:.6g}"


def hslm_b_line(ds: xr.Dataset) -> str | None:
    """``HSLM-B, N = 12, d = 3 m, user-given parameters ...`` when the study ran HSLM-B
    (the N and d of the stored configuration), else None."""
    names = [str(t) for t in ds["train"].values] if "train" in ds.coords else []
    if not any(n.casefold() == "hslm-b" for n in names):
        return None
    train = results_config(ds).get("train", {})
    hb = train.get("hslm_b") if isinstance(train, dict) else None
    if not isinstance(hb, dict):
        return ("HSLM-B: N and d not in the stored configuration; user-given parameters, "
                "not read from EN 1991-2 Fig. 6.13 here.")
    return (f"HSLM-B, N = {hb.get('N')}, d = {hb.get('d')} m, **user-given parameters**: "
            "the load model is EN 1991-2's, its N and d come from the configuration, not "
            "from Fig. 6.13 (whose curves are not available to vsi_numba).")


def profile_section(ds: xr.Dataset) -> Section:
    """The "Code profile" section of a results file's report.

    Parameters
    ----------
    ds : xarray.Dataset
        Results (its ``config_json`` gives the profile; without one the recommended
        values).

    Returns
    -------
    Section
        Title :data:`TITLE`: the profile's name, the table of its entries with the
        overridden ones marked (and their recommended value and clause), what [R] means
        (once), and the HSLM-B line (:func:`hslm_b_line`).
    """
    profile = profile_of(ds)
    n_over = len(profile.overridden)
    head = (f"Profile: **{md(profile.name)}**"
            + (f", {n_over} entr{'y' if n_over == 1 else 'ies'} overridden by the "
               "configuration (`[code_profile] overrides`), marked **override** below."
               if n_over else (" (no override)." if profile.name == DEFAULT_NAME else
                               ", no entry overridden.")))
    blocks: list = [head + " Every limit and clause value of the checks in this report "
                    "is taken from this table; the check lines cite the clause only."]
    rows = []
    for r in profile.rows():
        over = ""
        if r["overridden"]:
            tag = f" {RECALLED}" if default_profile().entry(r["key"]).recalled else ""
            over = Markdown(f"**override** (recommended {_number(r['default'])}, "
                            f"{md(r['default_clause'])}{tag})")
        rows.append({"Key": Markdown(f"`{r['key']}`"), "Value": _number(r["value"]),
                     "Unit": "–" if r["unit"] == "1" else r["unit"], "Clause": r["clause"],
                     RECALLED: r["recalled"] or "", "Override": over,
                     "Description": r["description"] + (" (fixed)" if r["applies"] == "fixed"
                                                        else "")})
    blocks.append(Table(pd.DataFrame(rows), f"Code profile: {md(profile.name)}"))
    blocks.append(f"Values marked {RECALLED} are {RECALLED_MEANING}. An override is the "
                  "configuration's value and source. Entries read with the configuration "
                  f"({_APPLIES['input']}) took effect when the study was set up; "
                  "(fixed) entries are part of the model or of the run.")
    line = hslm_b_line(ds)
    if line:
        blocks.append(line)
    return Section(TITLE, blocks)
