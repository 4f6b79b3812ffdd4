"""``tables.xlsx`` written in openpyxl's write-only mode
(:func:`vsi_numba.analysis.report.tables.write_xlsx`) holds the cells
``DataFrame.to_excel`` writes: the same values and types, the widths and the panes."""

from __future__ import annotations

import numpy as np
import openpyxl
import pandas as pd

from vsi_numba.analysis.report.tables import write_xlsx


def test_write_xlsx__the_cells_of_to_excel(tmp_path):
    frame = pd.DataFrame({
        "name": ["HSLM-A1", None, "a long name " * 6],
        "x [m]": [1.25, np.nan, np.inf],
        "y": [-np.inf, 0.0, 3.0e-9],
        "n": np.array([1, 2, 3], dtype=np.int64),
        "ok": [True, False, True],
        "mixed": [1, "two", 3.5],
    })
    empty = pd.DataFrame({"only a header": []})
    sheets = [("first", frame), ("empty", empty)]
    write_xlsx(tmp_path / "new.xlsx", sheets)
    with pd.ExcelWriter(tmp_path / "pandas.xlsx", engine="openpyxl") as writer:
        for name, f in sheets:
            f.to_excel(writer, sheet_name=name, index=False)
        for sheet in writer.sheets.values():
            for col in sheet.columns:
                width = max(len(str(c.value)) if c.value is not None else 0 for c in col)
                sheet.column_dimensions[col[0].column_letter].width = min(max(width, 8), 48)
            sheet.freeze_panes = "B2"
    new = openpyxl.load_workbook(tmp_path / "new.xlsx")
    ref = openpyxl.load_workbook(tmp_path / "pandas.xlsx")
    assert new.sheetnames == ref.sheetnames == ["first", "empty"]
    for name in ref.sheetnames:
        a, b = new[name], ref[name]
        cells = [[(c.value, c.data_type) for c in r] for r in a.iter_rows()]
        assert cells == [[(c.value, c.data_type) for c in r] for r in b.iter_rows()]
        assert ({k: d.width for k, d in a.column_dimensions.items()}
                == {k: d.width for k, d in b.column_dimensions.items()})
        assert a.freeze_panes == b.freeze_panes == "B2"
    first = [[c.value for c in r] for r in new["first"].iter_rows()]
    assert first[1][:5] == ["HSLM-A1", 1.25, "-inf", 1, True]
    assert first[2][:3] == [None, None, 0]  # NaN and None: empty cells
