"""The sanitisers of text from inputs, by output format: :mod:`vsi_numba.analysis.sanitize`
(this module re-exports it for the report's modules)."""

from vsi_numba.analysis.sanitize import (
    MATH_GID,
    cell,
    clean,
    code,
    local_link,
    markdown_document,
    mathtext,
    md,
    natural_key,
    natural_order,
    plot_labels,
    sheet_frame,
    sheet_text,
    write_csv,
)

__all__ = ["MATH_GID", "cell", "clean", "code", "local_link", "markdown_document",
           "mathtext", "md", "natural_key", "natural_order", "plot_labels", "sheet_frame",
           "sheet_text", "write_csv"]
